//! Robustness under bad input and long renders (issue 8):
//!
//! - `bad_scene_corpus`: every file of `tests/bad_scenes/` (its first line says
//!   `# expect: FRAGMENT`) fails with exit status 1 and one line naming the file and
//!   holding the fragment — no panic, no output file. `# pending: FRAGMENT` marks input
//!   the loader does not reject yet (it must not panic either way).
//! - `bounded_fuzz_of_the_scene_parser`: mutated copies of the repository's scenes through
//!   `Scene::from_str`, failing on any panic.
//! - non-finite samples injected through the hidden `--inject-nonfinite-every` flag are
//!   dropped, counted and reported, and never reach the image.
//! - atomic output: a failed write leaves the previous file; a failed render leaves the
//!   previous output.
//! - `--time`, Ctrl-C (SIGINT) after the first pass, EXR headers.
//! - `--seed-offset` and `stokes merge`: two 32-spp parts equal one 64-spp render.

mod common;
use common::*;
use std::collections::BTreeMap;
use std::io::BufRead;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};
use stokes::output::read_exr;

/// The small scene most tests render.
fn cornell() -> PathBuf {
    root().join("scenes/cornell-box.toml")
}

fn header(path: &Path) -> BTreeMap<String, String> {
    let (_, _, _, meta) = read_exr(path).unwrap_or_else(|e| panic!("{e}"));
    meta.into_iter().collect()
}

fn pixels(path: &Path) -> Vec<[f32; 3]> {
    read_exr(path).unwrap_or_else(|e| panic!("{e}")).2
}

/// Renders the Cornell box at `res` with extra arguments; panics unless it succeeds.
fn render_ok(out: &Path, res: &str, extra: &[&str]) -> String {
    let (ok, _, err) = run(stokes()
        .args(["render", &s(&cornell()), "-o", &s(out), "--res", res])
        .args(extra));
    assert!(ok, "render failed: {err}");
    err
}

// ---------------------------------------------------------------------------------------
// Bad input

/// What a corpus file expects: `(pending, fragment)` from its first line.
fn expectation(path: &Path) -> (bool, String) {
    let text = std::fs::read_to_string(path).unwrap();
    let first = text.lines().next().unwrap_or("");
    if let Some(f) = first.strip_prefix("# expect: ") {
        (false, f.trim().to_string())
    } else if let Some(f) = first.strip_prefix("# pending: ") {
        (true, f.trim().to_string())
    } else {
        panic!(
            "{}: the first line must be `# expect: FRAGMENT` or `# pending: FRAGMENT`",
            path.display()
        )
    }
}

#[test]
fn bad_scene_corpus() {
    let dir = root().join("tests/bad_scenes");
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    files.sort();
    let scratch = scratch("corpus");
    let mut failures = Vec::new();
    let mut checked = 0;
    for f in &files {
        let (pending, fragment) = expectation(f);
        let name = f.file_name().unwrap().to_string_lossy().into_owned();
        let out = scratch.join(format!("{name}.exr"));
        let (ok, _, err) = run(stokes().args(["render", &s(f), "-o", &s(&out), "--spp", "1"]));
        let mut problems = Vec::new();
        if err.contains("panicked") || err.contains("RUST_BACKTRACE") {
            problems.push("panicked".to_string());
        }
        if ok {
            if !pending {
                problems.push("rendered".into());
            } else {
                eprintln!("pending (still accepted): {name}");
            }
        } else {
            if out.exists() {
                problems.push("wrote an output file".into());
            }
            let lines = err.trim().lines().count();
            if lines != 1 {
                problems.push(format!("{lines} lines instead of one"));
            }
            if !err.contains(&name) {
                problems.push("does not name the file".into());
            }
            if !err.contains(&fragment) {
                problems.push(format!("lacks {fragment:?}"));
            }
            if !pending {
                checked += 1;
            }
        }
        if !problems.is_empty() {
            failures.push(format!("{name}: {}: {}", problems.join(", "), err.trim()));
        }
    }
    assert!(
        failures.is_empty(),
        "bad scenes handled badly:\n{}",
        failures.join("\n")
    );
    assert!(checked >= 15, "only {checked} bad scenes checked");
}

#[test]
fn a_failed_render_leaves_the_previous_output() {
    let dir = scratch("keep");
    let out = dir.join("out.exr");
    render_ok(&out, "8x8", &["--spp", "2"]);
    let before = std::fs::read(&out).unwrap();
    let bad = root().join("tests/bad_scenes/negative_radius.toml");
    let (ok, _, _) = run(stokes().args(["render", &s(&bad), "-o", &s(&out)]));
    assert!(!ok);
    assert_eq!(
        std::fs::read(&out).unwrap(),
        before,
        "the previous image changed"
    );
}

#[test]
fn a_failed_write_leaves_the_previous_file_whole() {
    let dir = scratch("atomic");
    let target = dir.join("img.exr");
    let px = vec![[0.25f32, 0.5, 0.75]; 4];
    stokes::output::write_exr(&target, 2, 2, &px, &[("spp".into(), "3".into())]).unwrap();
    let before = std::fs::read(&target).unwrap();
    // A writer that gets half-way and fails (a full disk, a killed process).
    let r = stokes::output::write_atomically(&target, |tmp| {
        std::fs::write(tmp, &before[..before.len() / 2]).unwrap();
        Err("No space left on device".into())
    });
    let e = r.unwrap_err().to_string();
    assert!(e.contains("img.exr") && e.contains("No space"), "{e}");
    assert_eq!(std::fs::read(&target).unwrap(), before);
    assert_eq!(pixels(&target), px);
    let left: Vec<_> = std::fs::read_dir(&dir).unwrap().collect();
    assert_eq!(left.len(), 1, "a temporary file was left behind");
    // The same write succeeding replaces the file.
    let px2 = vec![[1.0f32, 2.0, 3.0]; 4];
    stokes::output::write_exr(&target, 2, 2, &px2, &[]).unwrap();
    assert_eq!(pixels(&target), px2);
}

// ---------------------------------------------------------------------------------------
// Bounded fuzzing of the scene parser

/// Values a fuzzed number is replaced with.
const NASTY: [&str; 24] = [
    "-1",
    "nan",
    "inf",
    "-inf",
    "1e30",
    "-1e30",
    "0",
    "\"\"",
    "1e-30",
    "4294967296",
    "-0.0",
    "[]",
    "{}",
    "0.5",
    "2",
    "[nan, 0, 0]",
    "1",
    "3",
    "0.001",
    "1e-7",
    "-0.5",
    "100000",
    "65535",
    "1e6",
];

/// Key names a fuzzed key is renamed to.
const KEYS: [&str; 30] = [
    "radius",
    "fov",
    "spp",
    "stacks",
    "slices",
    "scale",
    "origin",
    "edge_u",
    "min",
    "max",
    "interior",
    "exterior",
    "file",
    "csv",
    "column",
    "matrix",
    "wavelengths",
    "values",
    "dye",
    "g",
    "sigma_a",
    "sigma_t",
    "albedo",
    "resolution",
    "max_depth",
    "material",
    "emission",
    "type",
    "object",
    "zzz",
];

struct Mutator {
    rng: stokes::sampler::Pcg32,
}

impl Mutator {
    fn below(&mut self, n: usize) -> usize {
        (self.rng.next_u32() as usize) % n.max(1)
    }

    /// One mutation of `text`; `other` is another scene for crossover.
    fn mutate(&mut self, text: &str, other: &str) -> String {
        let mut lines: Vec<String> = text.lines().map(String::from).collect();
        if lines.is_empty() {
            lines.push(String::new());
        }
        let i = self.below(lines.len());
        // Mostly mutations that keep the TOML valid, so the loader gets past the parser.
        let kind = match self.below(20) {
            0..=7 => 3,
            8..=9 => 7,
            10..=11 => 1,
            12 => 2,
            13..=14 => 4,
            15 => 0,
            16 => 5,
            17 => 6,
            _ => 8,
        };
        match kind {
            0 => {
                // Byte flips (kept valid UTF-8: `from_str` takes text).
                let mut b = text.as_bytes().to_vec();
                for _ in 0..1 + self.below(4) {
                    if b.is_empty() {
                        break;
                    }
                    let k = self.below(b.len());
                    const BYTES: &[u8] = b" =[]{}\"',.#\n-+0123456789aeinfxz\\\t";
                    b[k] = BYTES[self.below(BYTES.len())];
                }
                return String::from_utf8_lossy(&b).into_owned();
            }
            1 => {
                lines.remove(i);
            }
            2 => {
                let l = lines[i].clone();
                lines.insert(i, l);
            }
            3 => {
                // Replace a number with a nasty value.
                let nums: Vec<(usize, usize)> = number_spans(&lines[i]);
                if let Some(&(a, b)) = nums.get(self.below(nums.len())) {
                    let v = NASTY[self.below(NASTY.len())];
                    lines[i].replace_range(a..b, v);
                }
            }
            4 => {
                // Rename a key.
                if let Some(eq) = lines[i].find('=') {
                    let key = lines[i][..eq].trim().to_string();
                    if !key.is_empty() && !key.starts_with('#') {
                        let new = KEYS[self.below(KEYS.len())];
                        lines[i] = format!("{new} ={}", &lines[i][eq + 1..]);
                    }
                }
            }
            5 => {
                let j = self.below(lines.len());
                lines.swap(i, j);
            }
            6 => {
                let o: Vec<&str> = other.lines().collect();
                if !o.is_empty() {
                    lines.insert(i, o[self.below(o.len())].to_string());
                }
            }
            7 => {
                // Replace a string value with another string from the file or nonsense.
                if let Some(a) = lines[i].find('"') {
                    if let Some(b) = lines[i][a + 1..].find('"') {
                        let choices = [
                            "",
                            "nope",
                            "../../etc/passwd",
                            "D65",
                            "fog",
                            "white",
                            "\u{1F600}",
                        ];
                        let v = choices[self.below(choices.len())];
                        lines[i].replace_range(a + 1..a + 1 + b, v);
                    }
                }
            }
            _ => {
                // Truncate.
                let cut = self.below(text.len() + 1);
                let mut cut = cut;
                while !text.is_char_boundary(cut) {
                    cut -= 1;
                }
                return text[..cut].to_string();
            }
        }
        lines.join("\n") + "\n"
    }
}

/// Byte spans of the numbers on a line.
fn number_spans(line: &str) -> Vec<(usize, usize)> {
    let b = line.as_bytes();
    let mut out = Vec::new();
    let mut i = 0;
    while i < b.len() {
        let starts =
            b[i].is_ascii_digit() || (b[i] == b'-' && i + 1 < b.len() && b[i + 1].is_ascii_digit());
        let boundary = i == 0 || !(b[i - 1].is_ascii_alphanumeric() || b[i - 1] == b'_');
        if starts && boundary {
            let a = i;
            i += 1;
            while i < b.len()
                && (b[i].is_ascii_digit() || matches!(b[i], b'.' | b'e' | b'-' | b'+'))
            {
                i += 1;
            }
            out.push((a, i));
        } else {
            i += 1;
        }
    }
    out
}

#[test]
fn bounded_fuzz_of_the_scene_parser() {
    // The seeds: every scene of the repository (parsed where they are, so their OBJ and
    // CSV files load) and the bad-scene corpus.
    let mut seeds: Vec<(PathBuf, String)> = Vec::new();
    for dir in ["scenes", "tests/bad_scenes"] {
        let mut files: Vec<PathBuf> = std::fs::read_dir(root().join(dir))
            .unwrap()
            .map(|e| e.unwrap().path())
            .filter(|p| p.extension().is_some_and(|e| e == "toml"))
            .collect();
        files.sort();
        for f in files {
            let text = std::fs::read_to_string(&f).unwrap();
            // The 100k-triangle sphere costs ~0.1 s a parse: fuzz it at a tenth the size.
            let text = text
                .replace("stacks = 160", "stacks = 16")
                .replace("slices = 318", "slices = 32");
            seeds.push((f, text));
        }
    }
    let good = seeds
        .iter()
        .position(|(p, _)| p.starts_with(root().join("tests")))
        .unwrap_or(seeds.len());
    assert!(good >= 5 && seeds.len() >= 20);
    let iterations: usize = std::env::var("STOKES_FUZZ_ITERATIONS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(12_000);
    let seed: u64 = std::env::var("STOKES_FUZZ_SEED")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(0x5eed_f022);
    let deadline = Duration::from_secs(60);
    let mut m = Mutator {
        rng: stokes::sampler::Pcg32::new(seed, 8),
    };
    let start = Instant::now();
    let mut slowest = (0.0, String::new());
    let mut panics = Vec::new();
    let (mut accepted, mut rejected, mut syntax) = (0, 0, 0);
    let mut done = 0;
    for _ in 0..iterations {
        // Three in four inputs start from a good scene.
        let pick = if m.below(4) > 0 {
            m.below(good)
        } else {
            m.below(seeds.len())
        };
        let (path, text) = &seeds[pick];
        let other = &seeds[m.below(seeds.len())].1;
        let mut input = text.clone();
        let rounds = [1, 1, 1, 1, 1, 1, 1, 2, 2, 3][m.below(10)];
        for _ in 0..rounds {
            input = m.mutate(&input, other);
        }
        let t0 = Instant::now();
        let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            stokes::scene::Scene::from_str(&input, path)
                .map(|_| ())
                .map_err(|e| e.to_string())
        }));
        let dt = t0.elapsed().as_secs_f64();
        if dt > slowest.0 {
            slowest = (dt, input.clone());
        }
        match r {
            Ok(Ok(())) => accepted += 1,
            Ok(Err(e)) => {
                rejected += 1;
                // TOML-level errors carry `file:line:column:`.
                if e.split(": ")
                    .next()
                    .is_some_and(|p| p.matches(':').count() >= 2)
                {
                    syntax += 1;
                }
                // (A message may span lines only through a file name given with a
                // newline escape; the command line prints it escaped.)
                assert!(
                    e.starts_with(&path.display().to_string())
                        && e.len() > path.as_os_str().len() + 2,
                    "an error message that does not name the file: {e:?}\ninput:\n{input}"
                );
            }
            Err(p) => {
                let msg = p
                    .downcast_ref::<String>()
                    .cloned()
                    .or_else(|| p.downcast_ref::<&str>().map(|s| s.to_string()))
                    .unwrap_or_default();
                panics.push(format!(
                    "--- panic {msg:?} on a mutation of {}:\n{input}",
                    path.display()
                ));
            }
        }
        done += 1;
        if start.elapsed() > deadline {
            break;
        }
    }
    eprintln!(
        "fuzzed {done} inputs in {:.1} s: {accepted} accepted, {rejected} rejected ({syntax} by the TOML reader), {} panics",
        start.elapsed().as_secs_f64(),
        panics.len()
    );
    eprintln!("slowest input: {:.3} s", slowest.0);
    if std::env::var("STOKES_FUZZ_SHOW_SLOWEST").is_ok() {
        eprintln!("{}", slowest.1);
    }
    assert!(
        panics.is_empty(),
        "the scene parser panicked on {} inputs:\n{}",
        panics.len(),
        panics.join("\n")
    );
    assert!(rejected > done / 4, "the mutations hardly break anything");
    assert!(
        accepted > done / 20 && rejected - syntax > done / 10,
        "the mutations hardly get past the TOML reader"
    );
}

// ---------------------------------------------------------------------------------------
// Non-finite samples

#[test]
fn injected_nonfinite_samples_are_dropped_counted_and_reported() {
    let dir = scratch("nan");
    for (every, spp) in [(7u64, 4u32), (1, 2)] {
        let out = dir.join(format!("nan{every}.exr"));
        let stats = dir.join(format!("nan{every}.json"));
        let err = render_ok(
            &out,
            "16x16",
            &[
                "--spp",
                &spp.to_string(),
                "--inject-nonfinite-every",
                &every.to_string(),
                "--stats-json",
                &s(&stats),
                "--variance",
            ],
        );
        let expected = stokes::integrator::render::poisoned_count(every, 256, 0, spp);
        assert!(expected > 0);
        let json: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&stats).unwrap()).unwrap();
        assert_eq!(
            json["nonfinite_samples"].as_u64(),
            Some(expected),
            "every {every}: {json}"
        );
        assert!(
            err.contains(&format!(
                "warning: {expected} samples were NaN or infinite and were dropped"
            )),
            "{err}"
        );
        for p in [&out, &dir.join(format!("nan{every}.variance.exr"))] {
            let px = pixels(p);
            assert!(
                px.iter().flatten().all(|v| v.is_finite()),
                "{}: NaN or Inf in the image",
                p.display()
            );
        }
        assert_eq!(
            header(&out).get("nonfinite_samples").map(String::as_str),
            Some(expected.to_string().as_str())
        );
        if every == 1 {
            // Every sample dropped: a black image, not a broken one.
            assert!(pixels(&out).iter().flatten().all(|&v| v == 0.0));
        } else {
            assert!(pixels(&out).iter().flatten().any(|&v| v > 0.0));
        }
    }
    // Without the hook, nothing is dropped and no warning is printed.
    let out = dir.join("clean.exr");
    let err = render_ok(&out, "16x16", &["--spp", "4"]);
    assert!(!err.contains("NaN"), "{err}");
}

// ---------------------------------------------------------------------------------------
// Headers, time budgets and interruption

#[test]
fn exr_header_records_the_render() {
    let dir = scratch("header");
    let out = dir.join("h.exr");
    render_ok(
        &out,
        "8x8",
        &[
            "--spp",
            "3",
            "--seed",
            "11",
            "--seed-offset",
            "5",
            "--spectral",
            "mono",
            "--shifting",
            "constant",
            "--max-depth",
            "4",
            "--tracking",
            "max",
        ],
    );
    let h = header(&out);
    let hash = stokes::header::scene_hash(&std::fs::read(cornell()).unwrap());
    for (k, v) in [
        ("spp", "3"),
        ("seed", "11"),
        ("seed_offset", "5"),
        ("sample_ranges", "11:5..8"),
        ("spectral", "mono"),
        ("shifting", "constant"),
        ("tracking", "max"),
        ("max_depth", "4"),
        ("scene", s(&cornell()).as_str()),
        ("scene_hash", hash.as_str()),
        ("stopped", "complete"),
        ("version", env!("CARGO_PKG_VERSION")),
    ] {
        assert_eq!(h.get(k).map(String::as_str), Some(v), "stokes:{k} in {h:?}");
    }
    let secs: f64 = h["render_seconds"].parse().unwrap();
    assert!((0.0..60.0).contains(&secs), "render_seconds {secs}");
    assert!(hash.starts_with("fnv1a64:") && hash.len() == 8 + 16);
}

#[test]
fn time_budget_renders_whole_passes_within_it() {
    let dir = scratch("time");
    let out = dir.join("t.exr");
    let stats = dir.join("t.json");
    let err = render_ok(
        &out,
        "16x16",
        &["--time", "0.5", "--stats-json", &s(&stats)],
    );
    let h = header(&out);
    let spp: u32 = h["spp"].parse().unwrap();
    let secs: f64 = h["render_seconds"].parse().unwrap();
    assert!(spp >= 2, "only {spp} spp in 0.5 s at 16x16");
    // How far past the budget the last pass ends depends on the machine's load; what
    // holds everywhere is tested in-process below (every pass starts within the budget).
    assert!(secs > 0.0, "render_seconds {secs}");
    assert_eq!(h["stopped"], "time budget");
    assert_eq!(h["time_budget"], "0.5");
    assert!(
        err.contains(&format!("{spp} spp (time budget 0.5 s)")),
        "{err}"
    );
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&stats).unwrap()).unwrap();
    assert_eq!(json["spp"].as_u64(), Some(spp as u64));
    // The budgeted image is the plain render of the same spp.
    let plain = dir.join("p.exr");
    render_ok(&plain, "16x16", &["--spp", &spp.to_string()]);
    assert_eq!(pixels(&out), pixels(&plain));

    // --spp is a maximum under --time.
    let out = dir.join("max.exr");
    render_ok(&out, "8x8", &["--time", "30", "--spp", "3"]);
    let h = header(&out);
    assert_eq!(h["spp"], "3");
    assert_eq!(h["stopped"], "complete");
    for bad in ["0", "-1", "nan", "inf", "soon"] {
        let (ok, _, err) = run(stokes().args(["render", &s(&cornell()), "--time", bad]));
        assert!(!ok && err.contains("--time"), "--time {bad}: {err}");
    }
}

#[test]
fn passes_of_several_samples_render_the_same_image() {
    let dir = scratch("pass_spp");
    // A packet tracer fills and drains its paths in flight once per pass and row pair, so
    // larger passes change which lanes and rounds carry a sample, never its bits.
    for rays in ["packet", "single"] {
        let one = dir.join(format!("one-{rays}.exr"));
        render_ok(&one, "16x16", &["--spp", "10", "--rays", rays]);
        let four = dir.join(format!("four-{rays}.exr"));
        let stats = dir.join(format!("four-{rays}.json"));
        render_ok(
            &four,
            "16x16",
            &[
                "--spp",
                "10",
                "--pass-spp",
                "4",
                "--rays",
                rays,
                "--stats-json",
                &s(&stats),
            ],
        );
        assert_eq!(pixels(&one), pixels(&four), "--rays {rays}");
        let json: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&stats).unwrap()).unwrap();
        // 4 + 4 + 2.
        assert_eq!(json["passes"].as_u64(), Some(3), "--rays {rays}");
        assert_eq!(header(&four)["spp"], "10");
    }
    // Under a time budget whole passes run: the spp reached is a multiple of the pass.
    let out = dir.join("time.exr");
    render_ok(&out, "8x8", &["--time", "0.3", "--pass-spp", "3"]);
    let spp: u32 = header(&out)["spp"].parse().unwrap();
    assert!(
        spp >= 3 && spp.is_multiple_of(3),
        "{spp} spp in passes of 3"
    );
    for bad in ["0", "-1", "two"] {
        let out = dir.join("bad.exr");
        let (ok, _, err) =
            run(stokes().args(["render", &s(&cornell()), "-o", &s(&out), "--pass-spp", bad]));
        assert!(!ok && err.contains("--pass-spp"), "--pass-spp {bad}: {err}");
        assert!(!out.exists(), "--pass-spp {bad} wrote {}", out.display());
    }
}

#[test]
fn under_a_time_budget_every_pass_starts_within_it() {
    // A pass starts only if, at the mean pass time so far, it ends within the budget. So
    // with pass end times t_1 … t_n, the check before pass n saw an elapsed time e ≥ t_{n−1}
    // and passed: t_{n−1} + t_{n−1}/(n − 1) ≤ e + e/(n − 1) ≤ budget. That holds however
    // loaded the machine is (a wall-clock bound on the total would not).
    use stokes::integrator::render::{render_progressive, PassDone, Progressive, Stopped};
    let mut scene = scene_file("cornell-box.toml");
    scene.set_resolution(16, 16);
    let opts = stokes::integrator::render::RenderOptions {
        threads: 2,
        ..Default::default()
    };
    for budget in [0.05, 0.2] {
        let mut ends: Vec<f64> = Vec::new();
        let prog = Progressive {
            time_budget: Some(budget),
            batch: 1,
            ..Default::default()
        };
        let done = render_progressive(&scene, &opts, &prog, &|| {}, &mut |p: PassDone| {
            ends.push(p.seconds)
        })
        .unwrap();
        assert_eq!(done.stopped, Stopped::TimeBudget);
        assert_eq!(ends.len() as u32, done.passes);
        let n = ends.len();
        assert!(n >= 2, "budget {budget}: only {n} passes");
        let before_last = ends[n - 2];
        assert!(
            before_last + before_last / (n - 1) as f64 <= budget,
            "budget {budget}: pass {n} started although {before_last:.4} s + the mean pass time exceeded it"
        );
        assert_eq!(done.render.film.spp as usize, n);
    }
}

/// Spawns a render whose stderr is read line by line into a channel.
fn spawn_render(args: &[&str]) -> (std::process::Child, std::sync::mpsc::Receiver<String>) {
    let mut child = stokes()
        .args(args)
        .stderr(std::process::Stdio::piped())
        .stdout(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let stderr = child.stderr.take().unwrap();
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        for line in std::io::BufReader::new(stderr).lines() {
            let Ok(line) = line else { break };
            if tx.send(line).is_err() {
                break;
            }
        }
    });
    (child, rx)
}

/// Waits for a stderr line containing `what`, returning every line read so far.
fn wait_for_line(rx: &std::sync::mpsc::Receiver<String>, what: &str) -> Vec<String> {
    let mut seen = Vec::new();
    let deadline = Instant::now() + Duration::from_secs(120);
    while Instant::now() < deadline {
        match rx.recv_timeout(Duration::from_secs(1)) {
            Ok(l) => {
                let hit = l.contains(what);
                seen.push(l);
                if hit {
                    return seen;
                }
            }
            Err(std::sync::mpsc::RecvTimeoutError::Timeout) => {}
            Err(_) => break,
        }
    }
    panic!("no stderr line with {what:?}; got {seen:?}");
}

fn signal(child: &std::process::Child, sig: &str) {
    let ok = std::process::Command::new("kill")
        .args([&format!("-{sig}"), &child.id().to_string()])
        .status()
        .unwrap()
        .success();
    assert!(ok, "kill -{sig} failed");
}

fn sigint(child: &std::process::Child) {
    signal(child, "INT");
}

/// Waits for the child (at most two minutes) and returns its exit code and the rest of
/// its stderr.
fn finish(
    mut child: std::process::Child,
    rx: std::sync::mpsc::Receiver<String>,
) -> (Option<i32>, String) {
    let deadline = Instant::now() + Duration::from_secs(120);
    let status = loop {
        if let Some(st) = child.try_wait().unwrap() {
            break st;
        }
        if Instant::now() > deadline {
            let _ = child.kill();
            panic!("the render did not stop after SIGINT");
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    let rest: Vec<String> = rx.iter().collect();
    (status.code(), rest.join("\n"))
}

#[test]
fn sigint_finishes_the_pass_and_writes_the_image_so_far() {
    interrupted_render_writes_the_image_so_far("INT");
}

/// SIGTERM (what a batch scheduler sends at the time limit) does the same as Ctrl-C.
#[test]
fn sigterm_finishes_the_pass_and_writes_the_image_so_far() {
    interrupted_render_writes_the_image_so_far("TERM");
}

fn interrupted_render_writes_the_image_so_far(sig: &str) {
    let dir = scratch(&format!("sig{sig}"));
    let out = dir.join("int.exr");
    let stats = dir.join("int.json");
    let (child, rx) = spawn_render(&[
        "render",
        &s(&cornell()),
        "--res",
        "48x48",
        "--spp",
        "1000000",
        "-o",
        &s(&out),
        "--stats-json",
        &s(&stats),
        "--variance",
    ]);
    wait_for_line(&rx, "pass 1 done");
    signal(&child, sig);
    let (code, err) = finish(child, rx);
    assert_eq!(code, Some(130), "exit status; stderr: {err}");
    assert!(err.contains("interrupted"), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    let h = header(&out);
    let spp: u32 = h["spp"].parse().unwrap();
    assert!((1..1_000_000).contains(&spp), "spp {spp}");
    assert_eq!(h["stopped"], "interrupted");
    assert_eq!(h["sample_ranges"], format!("0:0..{spp}"));
    assert!(err.contains(&format!("--seed-offset {spp}")), "{err}");
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&stats).unwrap()).unwrap();
    assert_eq!(json["spp"].as_u64(), Some(spp as u64));
    assert_eq!(json["stopped"], "interrupted");
    assert!(dir.join("int.variance.exr").exists());
    // The image so far is exactly the render of that many samples.
    let again = dir.join("again.exr");
    render_ok(&again, "48x48", &["--spp", &spp.to_string()]);
    assert_eq!(pixels(&out), pixels(&again));
}

#[test]
fn a_second_sigint_exits_at_once_without_writing() {
    let dir = scratch("sigint2");
    let out = dir.join("never.exr");
    // Passes of about a second: the second signal lands while one is in flight.
    let (child, rx) = spawn_render(&[
        "render",
        &s(&cornell()),
        "--res",
        "768x768",
        "--spp",
        "1000",
        "-o",
        &s(&out),
    ]);
    wait_for_line(&rx, "pass 1 done");
    sigint(&child);
    wait_for_line(&rx, "interrupted");
    sigint(&child);
    let (code, err) = finish(child, rx);
    assert_eq!(code, Some(130), "{err}");
    assert!(err.contains("interrupted again"), "{err}");
    assert!(
        !out.exists(),
        "an image was written after the second Ctrl-C"
    );
    let temps = std::fs::read_dir(&dir).unwrap().count();
    assert_eq!(temps, 0, "files left in {}", dir.display());
}

// ---------------------------------------------------------------------------------------
// Split renders and merging

/// max |a − b| / max(|a|, |b|) over every channel of every pixel (0 where both are 0).
fn max_relative_difference(a: &[[f32; 3]], b: &[[f32; 3]]) -> f64 {
    assert_eq!(a.len(), b.len());
    a.iter()
        .flatten()
        .zip(b.iter().flatten())
        .map(|(&x, &y)| {
            let (x, y) = (x as f64, y as f64);
            let m = x.abs().max(y.abs());
            if m == 0.0 {
                0.0
            } else {
                (x - y).abs() / m
            }
        })
        .fold(0.0, f64::max)
}

fn merge(inputs: &[&Path], out: &Path, extra: &[&str]) -> (bool, String) {
    let mut cmd = stokes();
    cmd.arg("merge");
    for i in inputs {
        cmd.arg(s(i));
    }
    cmd.args(["-o", &s(out)]).args(extra);
    let (ok, _, err) = run(&mut cmd);
    (ok, err)
}

#[test]
fn merging_two_32_spp_parts_equals_one_64_spp_render() {
    let dir = scratch("merge");
    let res = "24x24";
    let part = |name: &str, spp: u32, offset: u32| {
        let p = dir.join(name);
        render_ok(
            &p,
            res,
            &[
                "--spp",
                &spp.to_string(),
                "--seed-offset",
                &offset.to_string(),
                "--variance",
            ],
        );
        p
    };
    let a = part("a.exr", 32, 0);
    let b = part("b.exr", 32, 32);
    let full = part("full.exr", 64, 0);
    let merged = dir.join("merged.exr");
    let (ok, err) = merge(&[&a, &b], &merged, &["--variance"]);
    assert!(ok, "{err}");
    assert!(err.contains("64 spp"), "{err}");
    let d = max_relative_difference(&pixels(&merged), &pixels(&full));
    assert!(d < 1e-5, "merged and single render differ by {d:.2e}");
    // The pooled variance equals the single render's variance of the mean.
    let dv = max_relative_difference(
        &pixels(&dir.join("merged.variance.exr")),
        &pixels(&dir.join("full.variance.exr")),
    );
    assert!(dv < 1e-3, "variances differ by {dv:.2e}");
    let h = header(&merged);
    assert_eq!(h["spp"], "64");
    assert_eq!(h["sample_ranges"], "0:0..64");
    assert_eq!(h["seed"], "0");
    assert_eq!(h["seed_offset"], "0");
    assert!(
        h["parts"].contains("a.exr (32 spp)") && h["parts"].contains("b.exr (32 spp)"),
        "{h:?}"
    );
    assert_eq!(h["scene_hash"], header(&full)["scene_hash"]);

    // Unequal weights: 16 + 48 spp, given in either order.
    let c = part("c.exr", 16, 0);
    let d48 = part("d.exr", 48, 16);
    let merged2 = dir.join("merged2.exr");
    let (ok, err) = merge(&[&d48, &c], &merged2, &[]);
    assert!(ok, "{err}");
    let d = max_relative_difference(&pixels(&merged2), &pixels(&full));
    assert!(d < 1e-5, "16 + 48 spp differ from 64 spp by {d:.2e}");
    // A merge of merges.
    let merged3 = dir.join("merged3.exr");
    let e = part("e.exr", 64, 64);
    let (ok, err) = merge(&[&merged, &e], &merged3, &[]);
    assert!(ok, "{err}");
    assert_eq!(header(&merged3)["sample_ranges"], "0:0..128");

    // Negative control: other sample streams give another image (the test can fail).
    let f = part("f.exr", 32, 64);
    let other = dir.join("other.exr");
    let (ok, err) = merge(&[&a, &f], &other, &[]);
    assert!(ok, "{err}");
    let d = max_relative_difference(&pixels(&other), &pixels(&full));
    assert!(d > 1e-2, "different streams agree to {d:.2e}?");
    // Negative control: an unweighted average of 16 + 48 is not the 64-spp render.
    let unweighted: Vec<[f32; 3]> = pixels(&c)
        .iter()
        .zip(pixels(&d48))
        .map(|(x, y)| std::array::from_fn(|k| 0.5 * (x[k] + y[k])))
        .collect();
    assert!(max_relative_difference(&unweighted, &pixels(&full)) > 1e-3);
}

#[test]
fn merge_refuses_what_does_not_belong_together() {
    let dir = scratch("merge-refuse");
    let r = |name: &str, scene: &Path, args: &[&str]| {
        let p = dir.join(name);
        let (ok, _, err) = run(stokes()
            .args(["render", &s(scene), "-o", &s(&p), "--spp", "2"])
            .args(args));
        assert!(ok, "{err}");
        p
    };
    let colorchecker = root().join("scenes/colorchecker.toml");
    let a = r("a.exr", &cornell(), &["--res", "8x8"]);
    let b = r("b.exr", &cornell(), &["--res", "8x8", "--seed-offset", "2"]);
    let other_scene = r(
        "cc.exr",
        &colorchecker,
        &["--res", "8x8", "--seed-offset", "2"],
    );
    let other_size = r(
        "big.exr",
        &cornell(),
        &["--res", "8x6", "--seed-offset", "2"],
    );
    let overlap = r(
        "ov.exr",
        &cornell(),
        &["--res", "8x8", "--seed-offset", "1"],
    );
    let depth = r(
        "depth.exr",
        &cornell(),
        &["--res", "8x8", "--seed-offset", "2", "--max-depth", "2"],
    );
    let bare = dir.join("bare.exr");
    stokes::output::write_exr(&bare, 8, 8, &vec![[0.5; 3]; 64], &[]).unwrap();
    let no_hash = dir.join("nohash.exr");
    stokes::output::write_exr(
        &no_hash,
        8,
        8,
        &vec![[0.5; 3]; 64],
        &[("spp".into(), "2".into()), ("seed".into(), "0".into())],
    )
    .unwrap();
    let out = dir.join("out.exr");
    let cases: [(&Path, &[&str]); 6] = [
        (
            &other_scene,
            &["same scene", "colorchecker.toml", "cornell-box.toml"],
        ),
        (&other_size, &["8x6", "8x8", "same size"]),
        (
            &overlap,
            &["both hold samples 1..2 of seed 0", "--seed-offset"],
        ),
        (&depth, &["max_depth", "same settings"]),
        (&bare, &["bare.exr", "no stokes header"]),
        (&no_hash, &["nohash.exr", "stokes:scene_hash"]),
    ];
    for (bad, fragments) in cases {
        let (ok, err) = merge(&[&a, bad], &out, &[]);
        assert!(!ok, "merged {}", bad.display());
        assert!(!out.exists(), "wrote a merge of {}", bad.display());
        assert_eq!(err.trim().lines().count(), 1, "{err}");
        for f in fragments {
            assert!(err.contains(f), "{}: lacks {f:?}: {err}", bad.display());
        }
    }
    // The same file twice overlaps with itself.
    let (ok, err) = merge(&[&a, &a], &out, &[]);
    assert!(!ok && err.contains("not independent"), "{err}");
    // --variance without the parts' variance images.
    let (ok, err) = merge(&[&a, &b], &out, &["--variance"]);
    assert!(!ok && err.contains("a.variance.exr"), "{err}");
    assert!(!out.exists());
    // And the good pair merges.
    let (ok, err) = merge(&[&a, &b], &out, &[]);
    assert!(ok, "{err}");
    assert_eq!(header(&out)["spp"], "4");
}

#[test]
fn seed_offset_draws_other_samples() {
    let dir = scratch("offset");
    let a = dir.join("a.exr");
    let b = dir.join("b.exr");
    render_ok(&a, "8x8", &["--spp", "4"]);
    render_ok(&b, "8x8", &["--spp", "4", "--seed-offset", "4"]);
    assert_ne!(pixels(&a), pixels(&b));
    let (ok, _, err) = run(stokes().args([
        "render",
        &s(&cornell()),
        "--spp",
        "10",
        "--seed-offset",
        "4294967290",
    ]));
    assert!(!ok && err.contains("--seed-offset"), "{err}");
}

// ---------------------------------------------------------------------------------------
// Load-time limits and warnings (issue 12)

/// A light in front of a fluorescent slab, seen from both sides (the camera sees its
/// back), with every quantity at the loader's limits:
/// radiance × scale = 1e30 and σ_a, σ_s, σ_dye = 1e30 per scene unit each.
const AT_THE_LIMITS: &str = r#"
[camera]
position = [0, 0, -4]
look_at = [0, 0, 0]
fov = 35
resolution = [8, 8]

[media.m]
sigma_a = 1e30
sigma_s = 1e30
dye = { absorption = { wavelengths = [400, 440, 480], values = [0, 1, 0] }, concentration = 1e30, emission = { wavelengths = [490, 525, 600], values = [0, 1, 0] }, quantum_yield = 0.95 }

[materials.floor]
type = "diffuse"
reflectance = 0.5

[[shapes]]
type = "box"
min = [-1, -1, -0.4]
max = [1, 1, 0.4]
interior = "m"

[[shapes]]
type = "quad"
origin = [-3, -1.5, -3]
edge_u = [0, 0, 6]
edge_v = [6, 0, 0]
material = "floor"

[[shapes]]
type = "quad"
origin = [-1, 0.3, -1.5]
edge_u = [2, 0, 0]
edge_v = [0, 0.4, 0]
emission = { radiance = 1e20, scale = 1e10, two_sided = true }
"#;

/// What the loader accepts renders without a NaN or infinite sample in every method: the
/// limits (`MAX_RADIANCE`, `MAX_COEFFICIENT` in `scene`) leave the estimate headroom.
#[test]
fn renders_at_the_load_limits_stay_finite() {
    use stokes::medium::Tracking;
    use stokes::method::{Method, Rays, Spectral};
    let opts = |tracking, spectral, rays| {
        let method = Method {
            spectral,
            tracking: Some(tracking),
            rays,
            ..Method::default()
        };
        TestRender::at(8, 8)
            .spp(8)
            .seed(3)
            .threads(2)
            .method(method)
    };
    for tracking in [Tracking::Classic, Tracking::Max, Tracking::FluoAware] {
        for spectral in [Spectral::Hwss, Spectral::Mono] {
            for rays in [Rays::Single, Rays::Packet] {
                // TestRender::film asserts that no sample was dropped.
                let film = opts(tracking, spectral, rays).film(&mut scene_from(AT_THE_LIMITS));
                let mean = film.mean();
                assert!(mean.iter().flatten().any(|&v| v > 0.0), "a black image");
            }
        }
    }
    // Must-fail control: past the limit (forced after loading) samples overflow. The film
    // multiplies each lane's radiance once by its colour weight (at most about 4), so an
    // emitter of 1e38 may still give finite samples; one of 1e39 overflows f32 itself.
    let mut scene = scene_from(AT_THE_LIMITS);
    scene.lights.emitters[0].scale *= 1e9;
    let o = opts(Tracking::FluoAware, Spectral::Hwss, Rays::Single);
    scene.set_resolution(8, 8);
    let r = stokes::integrator::render::render(&scene, &o.opts, &|| {}).unwrap();
    assert!(
        r.stats.nonfinite > 0,
        "radiance 1e39 gave no non-finite sample"
    );
    // And the loader refuses the same scene written with that scale.
    let past = AT_THE_LIMITS.replace("scale = 1e10", "scale = 1e16");
    let e = stokes::scene::Scene::from_str(&past, Path::new("past.toml"))
        .err()
        .unwrap()
        .to_string();
    assert!(
        e.contains("shapes[2].emission.scale: expected radiance × scale ≤ 1e30"),
        "{e}"
    );
}

/// `[spectra]` entries may name each other in any order (resolved in dependency order);
/// a name that is no entry is a CIE illuminant.
#[test]
fn named_spectra_resolve_in_dependency_order() {
    let text = AT_THE_LIMITS
        .replace(
            "[materials.floor]\ntype = \"diffuse\"\nreflectance = 0.5",
            "[spectra]\nz = \"y\"\ny = \"x\"\nx = 0.25\nlamp = \"sun\"\nsun = \"d65\"\n\n[materials.floor]\ntype = \"diffuse\"\nreflectance = \"z\"",
        )
        .replace("radiance = 1e20, scale = 1e10", "radiance = \"lamp\"");
    let scene = scene_from(&text);
    match &scene.materials[0] {
        stokes::bsdf::Material::Diffuse { reflectance } => {
            assert_eq!(reflectance.eval(500.0), 0.25)
        }
        _ => panic!("not diffuse"),
    }
    assert_eq!(
        scene.lights.emitters[0].radiance,
        stokes::spectrum::illuminant("D65").unwrap()
    );
}

/// Lights that add nothing, or a line too narrow to be sampled, are warned about; a
/// plain scene has no warnings.
#[test]
fn warnings_for_lights_that_show_nothing() {
    let light = "emission = { radiance = 1e20, scale = 1e10, two_sided = true }";
    let warnings = |emission: &str| scene_from(&AT_THE_LIMITS.replace(light, emission)).warnings;
    assert_eq!(
        warnings("emission = { radiance = 1.0 }"),
        Vec::<String>::new()
    );
    let cases = [
        (
            "emission = { radiance = 0.0 }",
            "shapes[2].emission: radiance × scale is 0 over 360–830 nm",
        ),
        (
            "emission = { radiance = 1.0, scale = 0 }",
            "the light is black",
        ),
        (
            "emission = { radiance = { blackbody = 100 } }",
            "the light is black",
        ),
        (
            "emission = { radiance = { narrow_band = 550, fwhm = 0.01 } }",
            "shapes[2].emission.radiance: a band 1e-2 nm wide (fwhm)",
        ),
        ("material = \"floor\"", "shapes: no shape has an `emission`"),
    ];
    for (emission, fragment) in cases {
        let w = warnings(emission);
        assert!(w.len() == 1 && w[0].contains(fragment), "{emission}: {w:?}");
    }
}

/// The warnings of a quad of fluorescent paper (reflectance `reflectance`, a dye absorbing
/// `absorption` and emitting around 520 nm) under a grey sky.
fn paper_warnings(reflectance: f32, absorption: &str) -> Vec<String> {
    let text = format!(
        r#"
[camera]
position = [0, 0, 1]
look_at = [0, 0, 0]
fov = 60
resolution = [8, 8]

[materials.paper]
type = "fluorescent_diffuse"
reflectance = {reflectance}
dye = {{ absorption = {absorption}, emission = {{ narrow_band = 520, fwhm = 40 }}, quantum_yield = 0.9 }}

[[shapes]]
type = "quad"
origin = [-1, -1, 0]
edge_u = [2, 0, 0]
edge_v = [0, 2, 0]
material = "paper"

[[lights]]
type = "environment"
radiance = 0.1
"#
    );
    scene_from(&text).warnings
}

/// A surface dye's absorption given as a `narrow_band` line (unit integral, so a peak of a
/// few per cent) is warned about, with the `scale` that absorbs 90 % at the peak; a line
/// scaled to a real peak, and a tabulated absorption, are not.
#[test]
fn a_surface_dye_absorbing_a_few_per_cent_at_most_is_warned_about() {
    let w = paper_warnings(0.2, "{ narrow_band = 440, fwhm = 40 }");
    assert!(
        w.len() == 1
            && w[0].contains("materials.paper.dye.absorption")
            && w[0].contains("absorbs at most 2.3 %")
            && w[0].contains("`scale = 38.3")
            && w[0].contains("unit integral"),
        "{w:?}"
    );
    let scaled = paper_warnings(0.2, "{ narrow_band = 440, fwhm = 40, scale = 2 }");
    assert!(
        scaled.len() == 1 && scaled[0].contains("4.7 %"),
        "{scaled:?}"
    );
    for fine in [
        "{ narrow_band = 440, fwhm = 40, scale = 30 }",
        "{ wavelengths = [400, 440, 480], values = [0, 0.9, 0] }",
        "0.6",
    ] {
        assert_eq!(paper_warnings(0.2, fine), Vec::<String>::new(), "{fine}");
    }
}

/// Re-radiation that totals more than 1 is reported once per material, with the span of
/// wavelengths and the worst total, not once per row of the matrix.
#[test]
fn energy_gain_is_one_warning_per_material() {
    let w = paper_warnings(0.5, "{ narrow_band = 440, fwhm = 40, scale = 30 }");
    assert!(
        w.len() == 1
            && w[0].starts_with(
                "materials.paper: re-radiation totals more than 1 at 12 wavelengths over 429–451 nm"
            )
            && w[0].contains("at most 1.133 at 439 nm"),
        "{w:?}"
    );
}
