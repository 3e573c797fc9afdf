//! `stokes submit slurm` against a real Slurm: the single-node cluster of
//! `scripts/slurm-local.sh`, which `make test-cluster` starts (and stops) around these
//! tests with `STOKES_CLUSTER=1` and `SLURM_CONF` set. Without `STOKES_CLUSTER=1` every
//! test says it is skipped and returns: the normal `cargo test` needs no Slurm.
//!
//! The renders are a 32×32 Cornell box, so that a test takes seconds (Slurm's scheduling
//! most of them), but the last one, which waits for Slurm's time limit (about 100 s).

mod common;
use common::*;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};
use stokes::output::{read_exr, variance_path};
use stokes::tools::merge::Part;

/// Whether the cluster is there; if not, says so on stderr (not captured by the harness).
fn cluster(test: &str) -> bool {
    if std::env::var_os("STOKES_CLUSTER").is_some() {
        return true;
    }
    let _ = writeln!(
        std::io::stderr(),
        "{test}: skipped: no cluster (run make test-cluster)"
    );
    false
}

/// A scratch directory holding `scenes/box.toml`, the Cornell box at 32×32.
fn work(name: &str) -> (PathBuf, PathBuf) {
    let dir = scratch(name);
    let sd = dir.join("my scenes");
    std::fs::create_dir_all(&sd).unwrap();
    let text = std::fs::read_to_string(root().join("scenes/cornell-box.toml")).unwrap();
    let text = text.replace("resolution = [512, 512]", "resolution = [32, 32]");
    std::fs::write(sd.join("box.toml"), text).unwrap();
    std::os::unix::fs::symlink(root().join("scenes/data"), sd.join("data")).unwrap();
    (dir.clone(), sd.join("box.toml"))
}

/// Submits; returns (render job, merge job) from what stokes prints.
fn submit(dir: &Path, args: &[&str]) -> (Option<String>, String) {
    let (ok, out, err) = run(stokes()
        .current_dir(dir)
        .args(["submit", "slurm", "my scenes/box.toml"])
        .args(args));
    assert!(ok, "submit failed: {err}");
    let id = |key: &str| {
        out.lines()
            .find_map(|l| l.strip_prefix(key))
            .and_then(|rest| rest.split_whitespace().next())
            .map(str::to_string)
    };
    let render = id("render job: ").filter(|s| s != "none");
    (render, id("merge job: ").expect(&out))
}

/// The states of a job (every task of an array).
fn states(job: &str) -> Vec<String> {
    let (ok, out, err) = run(std::process::Command::new("scontrol").args(["show", "job", job]));
    assert!(ok, "scontrol show job {job}: {err}");
    out.split_whitespace()
        .filter_map(|w| w.strip_prefix("JobState="))
        .map(str::to_string)
        .collect()
}

/// Waits until every task of `job` has ended; returns their states.
fn wait(job: &str, limit: Duration) -> Vec<String> {
    let t = Instant::now();
    loop {
        let s = states(job);
        let running = [
            "PENDING",
            "RUNNING",
            "CONFIGURING",
            "COMPLETING",
            "SUSPENDED",
        ];
        if !s.is_empty() && s.iter().all(|x| !running.contains(&x.as_str())) {
            return s;
        }
        assert!(t.elapsed() < limit, "job {job} still {s:?} after {limit:?}");
        std::thread::sleep(Duration::from_millis(500));
    }
}

fn merge_log(out: &Path, merge: &str) -> String {
    std::fs::read_to_string(out.join(format!("logs/merge-{merge}.out"))).unwrap()
}

/// Renders samples [0, spp) of the scene in one process, with variance.
fn full_render(dir: &Path, scene: &Path, spp: u32) -> PathBuf {
    let full = dir.join("full.exr");
    let (ok, _, err) = run(stokes().args([
        "render",
        &scene.display().to_string(),
        "--spp",
        &spp.to_string(),
        "--variance",
        "-o",
        &full.display().to_string(),
    ]));
    assert!(ok, "{err}");
    full
}

/// The largest relative difference between two images' R, G, B.
fn max_relative_difference(x: &Path, y: &Path) -> f64 {
    let (a, b) = (read_exr(x).unwrap().2, read_exr(y).unwrap().2);
    assert_eq!(a.len(), b.len());
    a.iter()
        .flatten()
        .zip(b.iter().flatten())
        .map(|(&u, &v)| ((u - v).abs() / v.abs().max(1e-6)) as f64)
        .fold(0.0, f64::max)
}

/// The merged result equals the one-process render of the same samples, and so does its
/// variance.
fn assert_equals_full(result: &Path, full: &Path) {
    let d = max_relative_difference(result, full);
    assert!(d < 1e-5, "merged and single render differ by {d:.2e}");
    let dv = max_relative_difference(&variance_path(result), &variance_path(full));
    assert!(dv < 1e-3, "pooled and single variance differ by {dv:.2e}");
}

const MINUTES: Duration = Duration::from_secs(180);

#[test]
fn four_parts_and_their_merge_equal_one_render() {
    if !cluster("four_parts_and_their_merge_equal_one_render") {
        return;
    }
    let (dir, scene) = work("cluster-four");
    let (render, merge) = submit(
        &dir,
        &["--parts", "4", "--spp-per-part", "8", "--out", "o u t"],
    );
    let render = render.unwrap();
    assert_eq!(wait(&render, MINUTES), ["COMPLETED"; 4], "render {render}");
    assert_eq!(wait(&merge, MINUTES), ["COMPLETED"], "merge {merge}");
    let out = dir.join("o u t");
    let log = merge_log(&out, &merge);
    assert!(
        log.contains("complete: 32 of the 32 spp asked for"),
        "{log}"
    );
    let result = out.join("result.exr");
    let header = Part::read(&result).unwrap().header;
    assert_eq!(header.spp(), 32);
    let listed = header.parts.unwrap();
    for i in 0..4 {
        assert!(
            listed.contains(&format!("parts/part-{i}.exr (8 spp)")),
            "{listed}"
        );
    }
    assert_equals_full(&result, &full_render(&dir, &scene, 32));
}

#[test]
fn a_failed_task_leaves_the_others_merged_and_resume_completes_the_render() {
    if !cluster("a_failed_task_leaves_the_others_merged_and_resume_completes_the_render") {
        return;
    }
    let (dir, scene) = work("cluster-failed");
    let out = dir.join("o");
    // Part 2's output path is taken by a directory: its task fails at once.
    std::fs::create_dir_all(out.join("parts/part-2.exr")).unwrap();
    let (render, merge) = submit(&dir, &["--parts", "4", "--spp-per-part", "8", "--out", "o"]);
    let render = render.unwrap();
    let mut st = wait(&render, MINUTES);
    st.sort();
    assert_eq!(
        st,
        ["COMPLETED", "COMPLETED", "COMPLETED", "FAILED"],
        "render {render}"
    );
    assert_eq!(wait(&merge, MINUTES), ["COMPLETED"], "merge {merge}");
    let log = merge_log(&out, &merge);
    assert!(
        log.contains("incomplete: 24 of the 32 spp asked for (samples 0..32 of seed 0); missing part 2 (samples 16..24)"),
        "{log}"
    );
    assert_eq!(Part::read(&out.join("result.exr")).unwrap().spp(), 24);

    std::fs::remove_dir(out.join("parts/part-2.exr")).unwrap();
    let (render, merge) = submit(
        &dir,
        &["--parts", "4", "--spp-per-part", "8", "--resume", "o"],
    );
    let script = std::fs::read_to_string(out.join("render.sbatch")).unwrap();
    assert!(script.contains("#SBATCH --array=0-0\n"), "{script}");
    assert!(
        script.contains("    0) start=16 spp=8 file=part-2.exr ;;\n"),
        "{script}"
    );
    assert_eq!(wait(&render.unwrap(), MINUTES), ["COMPLETED"]);
    assert_eq!(wait(&merge, MINUTES), ["COMPLETED"]);
    let log = merge_log(&out, &merge);
    assert!(
        log.contains("complete: 32 of the 32 spp asked for"),
        "{log}"
    );
    assert_equals_full(&out.join("result.exr"), &full_render(&dir, &scene, 32));
}

#[test]
fn a_task_at_its_time_limit_leaves_a_valid_part_and_the_merge_reports_the_shortfall() {
    if !cluster("a_task_at_its_time_limit_leaves_a_valid_part_and_the_merge_reports_the_shortfall")
    {
        return;
    }
    let (dir, _) = work("cluster-timeout");
    let out = dir.join("o");
    // No --time-limit (so no --time budget for stokes): Slurm's own limit of one minute,
    // given as an sbatch option, ends the task with SIGTERM long before 10^6 spp.
    let (render, merge) = submit(
        &dir,
        &[
            "--parts",
            "1",
            "--spp-per-part",
            "1000000",
            "--out",
            "o",
            "--",
            "--time=00:01:00",
        ],
    );
    let render = render.unwrap();
    let st = wait(&render, Duration::from_secs(240));
    // stokes exits 130 after an interrupt; Slurm records the time limit.
    assert!(
        st == ["TIMEOUT"] || st == ["FAILED"],
        "render {render}: {st:?}"
    );
    assert_eq!(wait(&merge, MINUTES), ["COMPLETED"], "merge {merge}");
    let part = Part::read(&out.join("parts/part-0.exr")).unwrap();
    let spp = part.spp();
    assert!(spp > 0 && spp < 1_000_000, "{spp} spp");
    assert_eq!(
        part.header.stopped,
        Some(stokes::integrator::render::Stopped::Interrupted)
    );
    part.read_variance("the part's variance").unwrap();
    let log = merge_log(&out, &merge);
    let want = format!(
        "incomplete: {spp} of the 1000000 spp asked for (samples 0..1000000 of seed 0); missing part 0 (samples {spp}..1000000 of 0..1000000)"
    );
    assert!(log.contains(&want), "{log}");
}
