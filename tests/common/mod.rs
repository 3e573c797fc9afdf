//! Helpers shared by the integration tests: render scenes through the library and run
//! the command-line binary.
#![allow(dead_code)]

pub mod oiio;
pub mod stats;

use std::path::{Path, PathBuf};
use stokes::integrator::render::{render, Film, RenderOptions};
use stokes::integrator::Spectral;
use stokes::scene::Scene;

/// The repository root.
pub fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// A fresh scratch directory for one test.
pub fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("stokes-test-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Loads a scene from text (relative paths resolve against `scenes/`).
pub fn scene_from(text: &str) -> Scene {
    Scene::from_str(text, &root().join("scenes/inline.toml")).unwrap_or_else(|e| panic!("{e}"))
}

/// Loads a scene file from `scenes/`.
pub fn scene_file(name: &str) -> Scene {
    Scene::load(&root().join("scenes").join(name)).unwrap_or_else(|e| panic!("{e}"))
}

/// Renders `scene` with `opts` (setting the camera to its resolution) and checks that no
/// sample came out NaN or infinite.
pub fn render_opts(scene: &mut Scene, opts: &RenderOptions) -> Film {
    scene.set_resolution(opts.width, opts.height);
    let r = render(scene, opts, &|| {}).unwrap();
    assert_eq!(r.stats.nonfinite, 0, "non-finite samples");
    r.film
}

/// Renders `scene` at `w`×`h` with independent shifting and the scene's default tracking.
#[allow(clippy::too_many_arguments)]
pub fn render_film(
    scene: &mut Scene,
    w: u32,
    h: u32,
    spp: u32,
    seed: u64,
    spectral: Spectral,
    max_depth: i32,
    threads: usize,
) -> Film {
    let opts = RenderOptions {
        width: w,
        height: h,
        spp,
        seed,
        max_depth,
        spectral,
        shifting: stokes::integrator::Shifting::Independent,
        tracking: None,
        threads,
        rays: Default::default(),
        dispersion: Default::default(),
    };
    render_opts(scene, &opts)
}

/// Asserts that every pair of `runs` agrees (Z-test at `z`) on every region.
pub fn assert_all_agree(what: &str, runs: &[(&str, Film)], regions: &[(&str, Vec<usize>)], z: f64) {
    for (name, px) in regions {
        let m: Vec<_> = runs.iter().map(|(n, f)| (*n, region_mean(f, px))).collect();
        for i in 0..m.len() {
            for j in i + 1..m.len() {
                assert_agree(
                    &format!("{what}: {name}: {} vs {}", m[i].0, m[j].0),
                    m[i].1,
                    m[j].1,
                    z,
                );
            }
        }
    }
}

/// Mean over a set of pixels and its standard error, per channel, from the pixels'
/// means and variances-of-the-mean (pixels are independent).
pub fn region_mean(film: &Film, pixels: &[usize]) -> ([f64; 3], [f64; 3]) {
    let mean = film.mean();
    let var = film.variance_of_mean();
    let n = pixels.len() as f64;
    let mut m = [0.0; 3];
    let mut v = [0.0; 3];
    for &i in pixels {
        for c in 0..3 {
            m[c] += mean[i][c] as f64 / n;
            v[c] += var[i][c] as f64 / (n * n);
        }
    }
    (m, v.map(f64::sqrt))
}

/// Every pixel index of a film.
pub fn all_pixels(film: &Film) -> Vec<usize> {
    (0..(film.width * film.height) as usize).collect()
}

/// The `stokes` binary.
pub fn stokes() -> std::process::Command {
    std::process::Command::new(env!("CARGO_BIN_EXE_stokes"))
}

/// Runs a command, returning (success, stdout, stderr).
pub fn run(cmd: &mut std::process::Command) -> (bool, String, String) {
    let out = cmd.output().expect("cannot run command");
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// Whether a tool is on the PATH.
pub fn have(tool: &str) -> bool {
    std::process::Command::new("sh")
        .arg("-c")
        .arg(format!("command -v {tool}"))
        .output()
        .map(|o| o.status.success())
        .unwrap_or(false)
}

/// Asserts that two estimates agree: |a − b| ≤ z·√(se_a² + se_b²) for each channel.
pub fn assert_agree(what: &str, a: ([f64; 3], [f64; 3]), b: ([f64; 3], [f64; 3]), z: f64) {
    for c in 0..3 {
        let se = (a.1[c].powi(2) + b.1[c].powi(2)).sqrt();
        let d = (a.0[c] - b.0[c]).abs();
        assert!(
            d <= z * se,
            "{what}: channel {c}: {} vs {} differ by {d:.3e} = {:.2} standard errors (se {se:.3e})",
            a.0[c],
            b.0[c],
            d / se
        );
    }
}

/// Path of a file in the scratch dir as a string.
pub fn s(p: &Path) -> String {
    p.display().to_string()
}
