//! Helpers shared by the integration tests: render scenes through the library and run
//! the command-line binary.
#![allow(dead_code)]

pub mod directions;
pub mod oiio;
pub mod plate;
pub mod stats;

use std::path::{Path, PathBuf};
use stokes::integrator::render::{render, Film, RenderOptions};
use stokes::method::{Dispersion, Method, Rays, Spectral};
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

/// Renders `scene` at `w`×`h` with `opts` and checks that no sample came out NaN or
/// infinite.
pub fn render_at(scene: &mut Scene, w: u32, h: u32, opts: &RenderOptions) -> Film {
    scene.set_resolution(w, h);
    let r = render(scene, opts, &|| {}).unwrap();
    assert_eq!(r.stats.nonfinite, 0, "non-finite samples");
    r.film
}

/// A test render, built up from the defaults (16 spp, seed 0, unbounded depth, one thread
/// per core, the default method with the scene's default tracking):
/// `TestRender::at(16, 16).spp(64).seed(3).spectral(Spectral::Mono).film(&mut scene)`.
#[derive(Debug, Clone)]
pub struct TestRender {
    /// Image size.
    pub size: (u32, u32),
    /// Everything else.
    pub opts: RenderOptions,
}

impl TestRender {
    /// A `w`×`h` render with the defaults.
    pub fn at(w: u32, h: u32) -> TestRender {
        TestRender {
            size: (w, h),
            opts: RenderOptions::default(),
        }
    }

    /// Samples per pixel.
    pub fn spp(mut self, spp: u32) -> Self {
        self.opts.spp = spp;
        self
    }

    /// Seed of the random streams.
    pub fn seed(mut self, seed: u64) -> Self {
        self.opts.seed = seed;
        self
    }

    /// Path depth (−1 unbounded).
    pub fn max_depth(mut self, max_depth: i32) -> Self {
        self.opts.max_depth = max_depth;
        self
    }

    /// Worker threads (0 = one per core).
    pub fn threads(mut self, threads: usize) -> Self {
        self.opts.threads = threads;
        self
    }

    /// The whole method.
    pub fn method(mut self, method: Method) -> Self {
        self.opts.method = method;
        self
    }

    /// Wavelength sampling.
    pub fn spectral(mut self, spectral: Spectral) -> Self {
        self.opts.method.spectral = spectral;
        self
    }

    /// The hero wavelength's pdf.
    #[allow(dead_code)]
    pub fn wavelengths(mut self, wavelengths: stokes::method::Wavelengths) -> Self {
        self.opts.method.wavelengths = wavelengths;
        self
    }

    /// Ray mode.
    pub fn rays(mut self, rays: Rays) -> Self {
        self.opts.method.rays = rays;
        self
    }

    /// Dispersive refraction.
    pub fn dispersion(mut self, dispersion: Dispersion) -> Self {
        self.opts.method.dispersion = dispersion;
        self
    }

    /// Which pixel samples start together in a packet.
    pub fn layout(mut self, layout: stokes::method::Layout) -> Self {
        self.opts.layout = layout;
        self
    }

    /// Renders `scene` (see [`render_at`]).
    pub fn film(&self, scene: &mut Scene) -> Film {
        render_at(scene, self.size.0, self.size.1, &self.opts)
    }
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

/// The largest relative difference between two images' extra channels (same names).
pub fn max_plane_difference(x: &[stokes::output::Plane], y: &[stokes::output::Plane]) -> f64 {
    let names = |p: &[stokes::output::Plane]| p.iter().map(|q| q.name.clone()).collect::<Vec<_>>();
    assert_eq!(names(x), names(y));
    x.iter()
        .zip(y)
        .flat_map(|(a, b)| a.data.iter().zip(&b.data))
        .map(|(&u, &v)| ((u - v).abs() / v.abs().max(1e-6)) as f64)
        .fold(0.0, f64::max)
}

/// Every pixel index of a film.
pub fn all_pixels(film: &Film) -> Vec<usize> {
    (0..(film.width * film.height) as usize).collect()
}

/// The `stokes` binary.
pub fn stokes() -> std::process::Command {
    // Not `env!`: tests that do not run the binary build without it (scripts/mutants.sh).
    match option_env!("CARGO_BIN_EXE_stokes") {
        Some(path) => std::process::Command::new(path),
        None => panic!("the stokes binary (feature `cli`, on by default) is not built"),
    }
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

/// A unit sphere of `material` (a TOML material body) with `stacks` rings and `extra`
/// sphere keys, inside a black box whose walls emit `radiance` from both sides: the
/// furnace and uniform-enclosure scenes.
pub fn enclosure(material: &str, radiance: &str, stacks: u32, extra: &str) -> String {
    format!(
        r#"
[camera]
position = [0, 0, -1.8]
look_at = [0, 0, 0]
fov = 60
resolution = [16, 16]

[materials.sphere]
{material}

[[shapes]]
type = "box"
min = [-2, -2, -2]
max = [2, 2, 2]
emission = {{ radiance = {radiance}, two_sided = true }}

[[shapes]]
type = "sphere"
center = [0, 0, 0]
radius = 1
stacks = {stacks}
material = "sphere"
{extra}
"#
    )
}

/// Linear sRGB of a constant spectrum of 1 (what a white furnace returns).
pub fn white_rgb() -> [f64; 3] {
    stokes::color::xyz_to_linear_srgb(stokes::spectrum::spectrum_to_xyz(
        &stokes::spectrum::Spectrum::Constant(1.0),
    ))
    .to_array()
    .map(f64::from)
}

/// The mean radiance at `lambda_o` along `ray` over `n` mono paths (seeded by `seed`, the
/// wavelength and the sample index) and its standard error.
pub fn mono_estimate(
    scene: &stokes::scene::Scene,
    ray: stokes::accel::Ray,
    lambda_o: f32,
    n: u64,
    seed: u64,
) -> (f64, f64) {
    use stokes::integrator::{radiance, PathOptions, PathStats};
    use stokes::medium::tracking::Tracking;
    use stokes::sampler::{LazyStream, Streams};
    let opts = PathOptions {
        method: Method {
            spectral: Spectral::Mono,
            ..Method::default()
        }
        .with_tracking(Tracking::Classic),
        max_depth: -1,
    };
    let (mut sum, mut sq) = (0.0f64, 0.0f64);
    let mut stats = PathStats::default();
    for i in 0..n {
        let l = radiance(
            scene,
            ray,
            glam::Vec4::splat(lambda_o),
            &opts,
            Streams::for_sample(seed, lambda_o as u64, i),
            LazyStream::new(seed, lambda_o as u64, i),
            &mut stats,
        );
        let v = l.x as f64;
        sum += v;
        sq += v * v;
    }
    let mean = sum / n as f64;
    (
        mean,
        ((sq / n as f64 - mean * mean) / (n as f64 - 1.0)).sqrt(),
    )
}

/// A non-specular BSDF sample checked against `eval` at its direction (`f_cos`, `pdf`):
/// unit length, a positive hero pdf, and per lane the same pdf and the same f/pdf (to
/// 1e-4), or zero value and pdf where eval has no density. `what` describes the case.
pub fn assert_sample_matches_eval(
    s: &stokes::bsdf::BsdfSample,
    f_cos: glam::Vec4,
    pdf: glam::Vec4,
    what: &dyn Fn() -> String,
) {
    let rel = |a: f32, b: f32| (a - b).abs() / b.abs().max(1e-30);
    assert!(!s.specular, "{}", what());
    assert!((s.wi.length() - 1.0).abs() < 1e-5, "{}", what());
    assert!(s.pdf.x > 0.0, "hero pdf 0: {}", what());
    for k in 0..4 {
        if pdf[k] == 0.0 {
            assert!(s.pdf[k] == 0.0 && s.f_cos[k] == 0.0, "lane {k}: {}", what());
            continue;
        }
        assert!(
            rel(s.pdf[k], pdf[k]) < 1e-4,
            "lane {k}: eval pdf {pdf}: {}",
            what()
        );
        let (sampled, evaluated) = (s.f_cos[k] / s.pdf[k], f_cos[k] / pdf[k]);
        assert!(
            rel(sampled, evaluated) < 1e-4,
            "lane {k}: f/pdf {sampled} vs eval {evaluated}: {}",
            what()
        );
    }
}
