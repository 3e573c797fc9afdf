//! Image tests of every scene family through the OpenImageIO check
//! (`tests/common/oiio.rs`): renders that must agree — two seeds, and two estimators that
//! must have the same expectation (HWSS and mono, uniform and visible-importance
//! wavelengths, independent and constant shifting, fluorescence-aware and maximum
//! tracking, packets and single rays, split and dropped dispersion) — pass, and negative controls must fail: a render shifted by 3 standard
//! errors per pixel (per-pixel criterion), and a physically wrong render (an edited
//! scene, or classic tracking where it is biased).
//!
//! Renders are tiny (48×48, tens to hundreds of samples per pixel, one thread each) and
//! run in-process; every family is one entry of `families!` at the bottom, so a new scene
//! family is one more line there, e.g.
//! `glass => Family { scene: "glass", spp: 64, agree: &[Mono], wrong: &[] };`.
//!
//! Calibration (seeds other than the ones below): 150 pairs that must agree (6 seed
//! pairs × every family and method) all passed, the worst at 0.65 of the allowed share of
//! failing pixels (HWSS against mono in the slab), a largest pixel |z| of 5.4 (bound 8)
//! and a largest block |z| at 0.82 of its bound; each physically wrong render failed for
//! every seed tried (5 each, 6 for the prism). Whole file: about 15 s on 2 cores
//! (`cargo test --release`), most of it in `oiiotool` start-ups and the prism.

mod common;
use common::oiio::{shifted_copy, Exr, ImageCheck, Report};
use common::*;
use std::path::Path;
use stokes::medium::Tracking;
use stokes::method::{Dispersion, Rays, Shifting, Spectral, Wavelengths};
use stokes::scene::Scene;

/// Image side in pixels.
const RES: u32 = 48;
/// Worker threads per render (the test harness runs tests in parallel too).
const THREADS: usize = 1;

/// An estimator, as a change from the default (HWSS, independent shifting, the scene's
/// default tracking). Every render also has its own seed, so renders are independent.
#[derive(Clone, Copy, Debug)]
enum Variant {
    /// The default estimator.
    Base,
    /// One wavelength per path, with 4× the samples: a pixel's samples must cover the
    /// spectrum for its z to be near normal (see `tests/common/oiio.rs`).
    Mono,
    /// Constant shifting at fluorescent events.
    Constant,
    /// A distance-sampling strategy.
    Tracking(Tracking),
    /// Single rays or packets.
    Rays(Rays),
    /// Dispersive refraction: keep the hero only, or split the path.
    Dispersion(Dispersion),
    /// The other hero pdf than the default (uniform or visible importance).
    OtherWavelengths,
    /// The other hero pdf, and the secondary lanes dropped at a dispersive refraction.
    OtherWavelengthsDrop,
}

/// The hero pdf that the default method does not use.
fn other_wavelengths() -> Wavelengths {
    match Wavelengths::default() {
        Wavelengths::Uniform => Wavelengths::Visible,
        Wavelengths::Visible => Wavelengths::Uniform,
    }
}

/// A render that must NOT agree with the family's default render.
#[derive(Clone, Copy, Debug)]
enum Wrong {
    /// A biased estimator.
    Variant(Variant, &'static str),
    /// The scene text with each `(from, to)` replacement made (every `from` must occur).
    Edit(&'static [(&'static str, &'static str)], &'static str),
}

/// A scene family: the scene, its samples per pixel, the estimators that must agree with
/// the default one, and the physically wrong renders that must not.
struct Family {
    scene: &'static str,
    spp: u32,
    agree: &'static [Variant],
    wrong: &'static [Wrong],
}

fn options(variant: Variant, spp: u32, seed: u64) -> TestRender {
    let mut o = TestRender::at(RES, RES)
        .spp(spp)
        .seed(seed)
        .threads(THREADS);
    let m = &mut o.opts.method;
    match variant {
        Variant::Base => {}
        Variant::Mono => {
            m.spectral = Spectral::Mono;
            o.opts.spp *= 4;
        }
        Variant::Constant => m.shifting = Shifting::Constant,
        Variant::Tracking(t) => m.tracking = Some(t),
        Variant::Rays(r) => m.rays = r,
        Variant::Dispersion(d) => m.dispersion = d,
        Variant::OtherWavelengths => m.wavelengths = other_wavelengths(),
        Variant::OtherWavelengthsDrop => {
            m.wavelengths = other_wavelengths();
            m.dispersion = Dispersion::Drop;
        }
    }
    o
}

/// Renders `scene` with `method` and writes `<dir>/<name>.exr` and its variance image.
fn render_exr(
    scene: &mut Scene,
    method: Variant,
    spp: u32,
    seed: u64,
    dir: &Path,
    name: &str,
) -> Exr {
    let opts = options(method, spp, seed);
    let film = opts.film(scene);
    let out = Exr::stokes(dir.join(format!("{name}.exr")));
    let meta = [
        ("spp".to_string(), opts.opts.spp.to_string()),
        ("seed".to_string(), seed.to_string()),
        ("method".to_string(), format!("{method:?}")),
    ];
    stokes::output::write_exr(&out.image, RES, RES, &film.mean(), &meta).unwrap();
    stokes::output::write_exr(&out.variance, RES, RES, &film.variance_of_mean(), &meta).unwrap();
    out
}

fn assert_agree(what: &str, test: &Exr, reference: &Exr) -> Report {
    let r = ImageCheck::default()
        .run(test, reference)
        .unwrap_or_else(|e| panic!("{what}: renders that must agree differ:\n{e}"));
    assert!(
        r.nontrivial(0.01),
        "{what}: trivial images (means {:?} and {:?}, {} of {} pixels with variance)",
        r.test_mean,
        r.ref_mean,
        r.informative,
        RES * RES
    );
    eprintln!(
        "{what}: pass: {:.1} % of pixels beyond |z| > 2 (allowed {:.1} %), max |z| {:.2}, image-mean z {:.2?}",
        100.0 * r.fail_share,
        100.0 * r.allowed_share,
        r.max_z,
        r.mean_z
    );
    r
}

/// Asserts that the check fails, on the statistics (not on a tool or I/O error), that the
/// criterion `must` (a line tag of the message, if given) is among the failed ones, and
/// that the difference images were kept.
fn assert_differ(what: &str, test: &Exr, reference: &Exr, must: Option<&str>) {
    let e = match ImageCheck::default().run(test, reference) {
        Ok(r) => panic!("{what}: the check passed a render that must fail: {r:?}"),
        Err(e) => e,
    };
    for key in [
        "image check failed",
        "per-pixel share",
        "max |z|",
        "image-mean z",
        "FAIL",
    ] {
        assert!(e.contains(key), "{what}: failed for another reason:\n{e}");
    }
    if let Some(m) = must {
        assert!(
            e.contains(m),
            "{what}: expected `{m}` among the failures:\n{e}"
        );
    }
    for ext in ["diff.exr", "zdiff.exr"] {
        let p = test.image.with_extension(ext);
        assert!(p.exists(), "{what}: {} not kept", p.display());
        assert!(
            e.contains(&p.display().to_string()),
            "{what}: message does not name {}",
            p.display()
        );
    }
    let first = e
        .lines()
        .filter(|l| l.starts_with("FAIL"))
        .collect::<Vec<_>>()
        .join(" | ");
    eprintln!("{what}: fails as it must: {first}");
}

fn check_family(f: &Family) {
    let t0 = std::time::Instant::now();
    let dir = scratch(&format!("family-{}", f.scene));
    let path = root().join(format!("scenes/{}.toml", f.scene));
    let text = std::fs::read_to_string(&path).unwrap();
    // Parsed as if it were the file, so that its data files are found beside it.
    let scene_from = |text: &str| Scene::from_str(text, &path).unwrap_or_else(|e| panic!("{e}"));
    let mut scene = scene_from(&text);
    let name = |s: &str| format!("{}: {s}", f.scene);

    // Two independent renders of the default estimator agree.
    let base = render_exr(&mut scene, Variant::Base, f.spp, 1, &dir, "base");
    let seed2 = render_exr(&mut scene, Variant::Base, f.spp, 2, &dir, "seed2");
    assert_agree(&name("seed 2 vs seed 1"), &seed2, &base);

    // Estimators with the same expectation agree.
    for (i, &m) in f.agree.iter().enumerate() {
        let img = render_exr(
            &mut scene,
            m,
            f.spp,
            10 + i as u64,
            &dir,
            &format!("agree{i}"),
        );
        assert_agree(&name(&format!("{m:?} vs Base")), &img, &base);
    }

    // A copy of a render shifted by 3 standard errors per pixel fails, per pixel.
    let shifted = shifted_copy(&seed2, &base.variance, 3.0, &dir.join("shifted.exr")).unwrap();
    assert_differ(
        &name("+3 standard errors"),
        &shifted,
        &base,
        Some("FAIL per-pixel share"),
    );

    // Physically wrong renders fail.
    for (i, w) in f.wrong.iter().enumerate() {
        let (img, what) = match *w {
            Wrong::Variant(m, why) => (
                render_exr(
                    &mut scene,
                    m,
                    f.spp,
                    20 + i as u64,
                    &dir,
                    &format!("wrong{i}"),
                ),
                format!("{m:?} ({why})"),
            ),
            Wrong::Edit(edits, why) => {
                let mut edited = text.clone();
                for (from, to) in edits {
                    assert!(
                        edited.contains(from),
                        "{}: `{from}` not in the scene",
                        f.scene
                    );
                    edited = edited.replace(from, to);
                }
                let mut edited = scene_from(&edited);
                (
                    render_exr(
                        &mut edited,
                        Variant::Base,
                        f.spp,
                        20 + i as u64,
                        &dir,
                        &format!("wrong{i}"),
                    ),
                    why.to_string(),
                )
            }
        };
        assert_differ(&name(&what), &img, &base, None);
    }
    eprintln!("{}: {:.1} s", f.scene, t0.elapsed().as_secs_f64());
    let _ = std::fs::remove_dir_all(&dir);
}

/// One test per family: `test_name => Family { .. };`.
macro_rules! families {
    ($($test:ident => $family:expr;)*) => {
        $(
            #[test]
            fn $test() {
                check_family(&$family);
            }
        )*
    };
}

use Variant::*;

/// Every dye's quantum yield set to 0 in the fluorescent-surfaces scenes: the dyes
/// absorb but re-emit nothing.
const NO_REEMISSION: &[(&str, &str)] = &[
    ("quantum_yield = 0.9 }", "quantum_yield = 0.0 }"),
    ("quantum_yield = 0.85 }", "quantum_yield = 0.0 }"),
    ("quantum_yield = 0.7 }", "quantum_yield = 0.0 }"),
];
const CLASSIC: Wrong = Wrong::Variant(
    Tracking(Tracking::Classic),
    "classic tracking never collides where σ̂_t = 0 < σ̂_s",
);

families! {
    cornell_box => Family { scene: "cornell-box", spp: 128, agree: &[Mono, Rays(Rays::Single), OtherWavelengths],
        wrong: &[Wrong::Edit(&[("scale = 1.0 }", "scale = 1.1 }")], "light 10 % too bright")] };
    colorchecker => Family { scene: "colorchecker", spp: 32, agree: &[Mono, OtherWavelengths],
        wrong: &[Wrong::Edit(&[("column = \"red\" }", "column = \"orange\" }")], "the red patch with orange's reflectance")] };
    fluorescent_surfaces_d65 => Family { scene: "fluorescent-surfaces", spp: 64, agree: &[Mono, Constant, OtherWavelengths],
        wrong: &[Wrong::Edit(NO_REEMISSION, "the dyes re-emit nothing")] };
    fluorescent_surfaces_440nm => Family { scene: "fluorescent-surfaces-440nm", spp: 128, agree: &[Mono, Constant, OtherWavelengths],
        wrong: &[Wrong::Edit(NO_REEMISSION, "the dyes re-emit nothing")] };
    fluorescent_volume_440nm => Family { scene: "fluorescent-volume-440nm", spp: 64, agree: &[Tracking(Tracking::Max), Constant, Mono, Rays(Rays::Single), OtherWavelengths],
        wrong: &[Wrong::Edit(&[("quantum_yield = 0.9 }", "quantum_yield = 0.0 }")], "the dye re-emits nothing")] };
    fluorescent_slab => Family { scene: "fluorescent-slab", spp: 256, agree: &[Tracking(Tracking::Max), Mono], wrong: &[CLASSIC] };
    // The prism's spectrum is a caustic found only by BSDF sampling: at this budget the
    // image mean has a 15 % standard error, and neither a prism without dispersion nor a
    // screen 25 % darker is detected (measured; a lamp twice as bright gives z ≈ 7); the
    // family catches gross errors only.
    prism => Family { scene: "prism", spp: 1024, agree: &[Dispersion(Dispersion::Drop), Rays(Rays::Single), OtherWavelengths, OtherWavelengthsDrop],
        wrong: &[Wrong::Edit(&[("radiance = 200 }", "radiance = 600 }")], "the lamp 3× as bright")] };
    fluorescent_slab_backlit => Family { scene: "fluorescent-slab-backlit", spp: 256, agree: &[Tracking(Tracking::Max), Constant], wrong: &[CLASSIC] };
    // The EGSR 2018 paper's scenes (scenes/egsr2018/): a purely fluorescent medium filling
    // all space, transparent where it emits, so classic tracking misses its glow.
    egsr2018_main => Family { scene: "egsr2018/main", spp: 64, agree: &[Tracking(Tracking::Max), Mono, Constant], wrong: &[CLASSIC] };
    egsr2018_teaser => Family { scene: "egsr2018/teaser", spp: 64, agree: &[Tracking(Tracking::Max), Mono, Constant], wrong: &[CLASSIC] };
}
