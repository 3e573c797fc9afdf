//! `stokes submit slurm` without a cluster: the dry-run scripts against a golden file,
//! shell quoting of paths, what `--resume` would submit, the sbatch calls (through a fake
//! `sbatch` that records them) and the bad inputs (one line, nothing written).
//!
//! The golden file holds `$STOKES` for the binary and `$WORK` for the test's working
//! directory (both differ between machines); everything else is the output as printed.
//! `STOKES_BLESS=1` rewrites it.

mod common;
use common::*;
use std::path::{Path, PathBuf};

/// A scratch directory holding `scene_dir/box.toml`, the Cornell box at 32×32 (its data
/// files linked).
fn work(name: &str, scene_dir: &str) -> (PathBuf, PathBuf) {
    let dir = scratch(name);
    let sd = dir.join(scene_dir);
    std::fs::create_dir_all(&sd).unwrap();
    let text = std::fs::read_to_string(root().join("scenes/cornell-box.toml")).unwrap();
    let text = text.replace("resolution = [512, 512]", "resolution = [32, 32]");
    assert!(text.contains("[32, 32]"));
    std::fs::write(sd.join("box.toml"), text).unwrap();
    std::os::unix::fs::symlink(root().join("scenes/data"), sd.join("data")).unwrap();
    (dir.clone(), sd.join("box.toml"))
}

/// Runs stokes in `dir` with `args`: (success, stdout, stderr).
fn stokes_in(dir: &Path, args: &[&str]) -> (bool, String, String) {
    run(stokes().current_dir(dir).args(args))
}

fn bin() -> String {
    stokes().get_program().to_string_lossy().into_owned()
}

/// Every file under `dir`, relative, sorted.
fn tree(dir: &Path) -> Vec<String> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            out.push(p.strip_prefix(dir).unwrap().display().to_string());
            if p.is_dir() && !p.is_symlink() {
                stack.push(p);
            }
        }
    }
    out.sort();
    out
}

#[test]
fn dry_run_matches_the_golden_file() {
    let (dir, _) = work("submit-golden", "scenes");
    let (ok, out, err) = stokes_in(
        &dir,
        &[
            "submit",
            "slurm",
            "scenes/box.toml",
            "--parts",
            "4",
            "--spp-per-part",
            "8",
            "--time-limit",
            "01:00:00",
            "--partition",
            "debug",
            "--cpus-per-task",
            "2",
            "--dry-run",
            "--",
            "--mem=1G",
        ],
    );
    assert!(ok, "{err}");
    let before = tree(&dir);
    assert!(
        !before.iter().any(|f| f.starts_with("out")),
        "dry run wrote {before:?}"
    );
    let text = out
        .replace(&bin(), "$STOKES")
        .replace(&dir.display().to_string(), "$WORK");
    let golden = root().join("tests/golden/submit-dry-run.txt");
    if std::env::var_os("STOKES_BLESS").is_some() {
        std::fs::write(&golden, &text).unwrap();
    }
    let want = std::fs::read_to_string(&golden).unwrap();
    assert_eq!(
        text,
        want,
        "dry-run output differs from {}",
        golden.display()
    );
}

#[test]
fn paths_with_spaces_and_quotes_are_shell_quoted() {
    let (dir, _) = work("submit-quoting", "it's my scenes");
    let (ok, out, err) = stokes_in(
        &dir,
        &[
            "submit",
            "slurm",
            "it's my scenes/box.toml",
            "--parts",
            "2",
            "--spp-per-part",
            "1",
            "--out",
            "out dir",
            "--dry-run",
        ],
    );
    assert!(ok, "{err}");
    let d = dir.display().to_string();
    let scene = format!(r"'{d}/it'\''s my scenes/box.toml'");
    assert!(
        out.contains(&format!(" render {scene} --seed-offset")),
        "{out}"
    );
    assert!(
        out.contains(&format!("-o '{d}/out dir/parts'/part-$i.exr")),
        "{out}"
    );
    assert!(out.contains(&format!("dir='{d}/out dir'\n")), "{out}");
    // The scripts run: bash parses them, and the render line names the scene as one word.
    for script in out.split("==> ").skip(1) {
        let body = script.split_once(" <==\n").unwrap().1;
        let (ok, _, err) = run(std::process::Command::new("bash").args(["-n", "-c", body]));
        assert!(ok, "bash -n: {err}\n{body}");
    }
    let render = out
        .split("==> ")
        .nth(1)
        .unwrap()
        .split_once(" <==\n")
        .unwrap()
        .1;
    let exec = &render[render.find("\nexec ").unwrap() + 6..];
    let cmd = format!("set -- {}\nprintf '%s\\n' \"$3\"", exec.trim_end());
    let (ok, word, _) = run(std::process::Command::new("bash").args(["-c", &cmd]));
    assert!(ok);
    assert_eq!(word.trim_end(), format!("{d}/it's my scenes/box.toml"));
}

/// Renders samples `[start, start + spp)` of `scene` at 4×4 into `out`, with variance.
fn render_part(dir: &Path, scene: &Path, start: u32, spp: u32, out: &Path) {
    let (ok, _, err) = stokes_in(
        dir,
        &[
            "render",
            &s(scene),
            "--res",
            "4x4",
            "--seed-offset",
            &start.to_string(),
            "--spp",
            &spp.to_string(),
            "--variance",
            "-o",
            &s(out),
        ],
    );
    assert!(ok, "{err}");
}

fn s(p: &Path) -> String {
    p.display().to_string()
}

#[test]
fn resume_submits_only_the_missing_ranges() {
    let (dir, scene) = work("submit-resume", "scenes");
    let parts = dir.join("r/parts");
    render_part(&dir, &scene, 0, 8, &parts.join("part-0.exr"));
    render_part(&dir, &scene, 8, 3, &parts.join("part-1.exr"));
    render_part(&dir, &scene, 24, 8, &parts.join("part-3.exr"));
    let (ok, out, err) = stokes_in(
        &dir,
        &[
            "submit",
            "slurm",
            "scenes/box.toml",
            "--parts",
            "4",
            "--spp-per-part",
            "8",
            "--resume",
            "r",
            "--dry-run",
        ],
    );
    assert!(ok, "{err}");
    assert!(out.contains("#SBATCH --array=0-1\n"), "{out}");
    assert!(
        out.contains("    0) start=11 spp=5 file=part-1-11.exr ;;\n"),
        "{out}"
    );
    assert!(
        out.contains("    1) start=16 spp=8 file=part-2.exr ;;\n"),
        "{out}"
    );
    assert!(!out.contains("    2)"), "{out}");
    assert!(out.contains("--expect 0..32 --part-spp 8"), "{out}");

    // Without --resume the same directory is refused.
    let (ok, _, err) = stokes_in(
        &dir,
        &[
            "submit",
            "slurm",
            "scenes/box.toml",
            "--parts",
            "4",
            "--spp-per-part",
            "8",
            "--out",
            "r",
            "--dry-run",
        ],
    );
    assert!(!ok);
    assert!(err.contains("add --resume"), "{err}");
    assert_eq!(err.trim().lines().count(), 1, "{err}");
}

/// A fake `sbatch` in `dir/bin` that appends its arguments to `dir/sbatch.log` and
/// prints job ids 101, 102, … (`--parsable`).
fn fake_sbatch(dir: &Path) -> PathBuf {
    let bin = dir.join("bin");
    std::fs::create_dir_all(&bin).unwrap();
    let script = format!(
        "#!/bin/bash\nlog={}\nprintf '%s|' \"$@\" >> \"$log\"; echo >> \"$log\"\necho $((100 + $(wc -l < \"$log\")))\n",
        dir.join("sbatch.log").display()
    );
    let p = bin.join("sbatch");
    std::fs::write(&p, script).unwrap();
    use std::os::unix::fs::PermissionsExt;
    std::fs::set_permissions(&p, std::fs::Permissions::from_mode(0o755)).unwrap();
    bin
}

#[test]
fn submit_runs_sbatch_for_the_array_then_the_merge_after_it() {
    let (dir, _) = work("submit-fake-sbatch", "scenes");
    let bin = fake_sbatch(&dir);
    let path = format!("{}:/usr/bin:/bin", bin.display());
    let (ok, out, err) = run(stokes().current_dir(&dir).env("PATH", path).args([
        "submit",
        "slurm",
        "scenes/box.toml",
        "--parts",
        "3",
        "--spp-per-part",
        "2",
        "--out",
        "o",
        "--",
        "--account=a b",
    ]));
    assert!(ok, "{err}");
    assert!(out.contains("render job: 101 (3 tasks"), "{out}");
    assert!(out.contains("merge job: 102"), "{out}");
    let log = std::fs::read_to_string(dir.join("sbatch.log")).unwrap();
    let o = dir.join("o");
    let d = o.display();
    assert_eq!(
        log,
        format!(
            "--parsable|--output={d}/logs/part-%a.out|--account=a b|{d}/render.sbatch|\n\
             --parsable|--dependency=afterany:101|--output={d}/logs/merge-%j.out|--account=a b|{d}/merge.sbatch|\n"
        )
    );
    assert!(o.join("render.sbatch").is_file() && o.join("merge.sbatch").is_file());
    assert!(o.join("logs").is_dir());
}

/// Runs a submit that must fail: one line holding every fragment, no panic, and nothing
/// new under `dir`.
fn expect_refused(dir: &Path, env_path: Option<&str>, args: &[&str], fragments: &[&str]) {
    let before = tree(dir);
    let mut cmd = stokes();
    cmd.current_dir(dir).args(["submit", "slurm"]).args(args);
    if let Some(p) = env_path {
        cmd.env("PATH", p);
    }
    let (ok, _, err) = run(&mut cmd);
    assert!(!ok, "{args:?} was accepted");
    assert!(!err.contains("panicked"), "{err}");
    assert_eq!(
        err.trim().lines().count(),
        1,
        "{args:?}: not one line: {err}"
    );
    for f in fragments {
        assert!(err.contains(f), "{args:?}: {err:?} lacks {f:?}");
    }
    assert_eq!(tree(dir), before, "{args:?} wrote files");
}

#[test]
fn bad_input_is_one_line_and_writes_nothing() {
    let (dir, _) = work("submit-bad", "scenes");
    let bin = fake_sbatch(&dir);
    let with_sbatch = format!("{}:/usr/bin:/bin", bin.display());
    let p = Some(with_sbatch.as_str());
    let base = ["scenes/box.toml", "--out", "o"];
    let args = |more: &[&'static str]| [&base[..], more].concat();
    expect_refused(
        &dir,
        p,
        &args(&["--parts", "0", "--spp-per-part", "8"]),
        &["--parts", "at least 1"],
    );
    expect_refused(
        &dir,
        p,
        &args(&["--parts", "4", "--spp-per-part", "0"]),
        &["--spp-per-part", "at least 1"],
    );
    expect_refused(
        &dir,
        Some("/nonexistent"),
        &args(&["--parts", "4", "--spp-per-part", "8"]),
        &["sbatch not found", "--dry-run"],
    );
    expect_refused(
        &dir,
        p,
        &args(&["--parts", "4", "--spp-per-part", "8", "--partition", "a;b"]),
        &["--partition"],
    );
    expect_refused(
        &dir,
        p,
        &["scenes/none.toml", "--parts", "4", "--spp-per-part", "8"],
        &["scenes/none.toml"],
    );
    assert!(!dir.join("sbatch.log").exists(), "sbatch was run");

    // An --out holding parts of another scene.
    let other = dir.join("scenes/other.toml");
    let text = std::fs::read_to_string(dir.join("scenes/box.toml")).unwrap();
    std::fs::write(&other, format!("{text}\n# another scene\n")).unwrap();
    render_part(&dir, &other, 0, 1, &dir.join("o/parts/part-0.exr"));
    for more in [&["--out", "o"][..], &["--resume", "o"][..]] {
        let a = [
            &["scenes/box.toml", "--parts", "4", "--spp-per-part", "8"][..],
            more,
        ]
        .concat();
        expect_refused(
            &dir,
            p,
            &a,
            &["o/parts/part-0.exr", "other.toml", "another --out"],
        );
    }
    assert!(!dir.join("sbatch.log").exists(), "sbatch was run");
}
