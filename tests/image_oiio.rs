//! The OpenImageIO image check (`tests/common/oiio.rs`): its thresholds, its behaviour on
//! synthetic images with known noise (unbiased pairs pass, biased ones fail, pixels without
//! variance must agree exactly), the EXR output as OpenImageIO sees it, and a small Cornell
//! box render against a stored reference (tests/reference/, see its README).

mod common;
use common::oiio::{normal_tail, shifted_copy, stats, Exr, ImageCheck, TestVariance, INSTALL_HINT};
use common::*;
use std::path::{Path, PathBuf};
use stokes::sampler::Pcg32;

fn render_cbox(dir: &Path, seed: u64, spp: u32) -> Exr {
    let out = dir.join("cbox.exr");
    let (ok, _, err) = run(stokes().args([
        "render",
        &s(&root().join("scenes/cornell-box.toml")),
        "--res",
        "64x64",
        "--spp",
        &spp.to_string(),
        "--seed",
        &seed.to_string(),
        "--variance",
        "-o",
        &s(&out),
    ]));
    assert!(ok, "{err}");
    Exr::stokes(out)
}

fn reference() -> Exr {
    Exr::stokes(root().join("tests/reference/cornell-box-64.exr"))
}

/// The check against the stored reference: its variance (16384 spp) scaled to the test's
/// sample count stands for the test's.
fn against_reference() -> ImageCheck {
    ImageCheck {
        test_variance: TestVariance::FromReference,
        ..Default::default()
    }
}

/// A synthetic image pair with known noise: W×H pixels of mean `mu(x, y)` and variance
/// of the mean `var(x, y)` (the variance images hold the true variances), drawn as
/// μ + σ·N(0, 1) per channel.
struct Synthetic {
    w: u32,
    h: u32,
    mu: Vec<[f32; 3]>,
    var: Vec<[f32; 3]>,
}

impl Synthetic {
    fn new(w: u32, h: u32, f: impl Fn(u32, u32) -> ([f32; 3], [f32; 3])) -> Synthetic {
        let (mu, var) = (0..w * h).map(|i| f(i % w, i / w)).unzip();
        Synthetic { w, h, mu, var }
    }

    /// A draw with seed `seed`, written to `<dir>/<name>.exr` and its variance image.
    fn draw(&self, seed: u64, dir: &Path, name: &str) -> Exr {
        let mut rng = Pcg32::new(seed, 7);
        let mut normal = || {
            let (u1, u2) = (1.0 - rng.next_f32() as f64, rng.next_f32() as f64);
            (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
        };
        let px: Vec<[f32; 3]> = self
            .mu
            .iter()
            .zip(&self.var)
            .map(|(m, v)| {
                std::array::from_fn(|c| m[c] + (v[c] as f64).sqrt() as f32 * normal() as f32)
            })
            .collect();
        self.write(&px, dir, name)
    }

    fn write(&self, px: &[[f32; 3]], dir: &Path, name: &str) -> Exr {
        let out = Exr::stokes(dir.join(format!("{name}.exr")));
        stokes::output::write_exr(&out.image, self.w, self.h, px, &[]).unwrap();
        stokes::output::write_exr(&out.variance, self.w, self.h, &self.var, &[]).unwrap();
        out
    }
}

/// A gradient with a bright square, variance growing with the mean, and a zero-variance
/// black border two pixels wide (like the void around a scene).
fn scene_like(w: u32, h: u32) -> Synthetic {
    Synthetic::new(w, h, |x, y| {
        if x < 2 || y < 2 {
            return ([0.0; 3], [0.0; 3]);
        }
        let base = 0.2 + 0.5 * x as f32 / w as f32;
        let bright = if (20..30).contains(&x) && (20..30).contains(&y) {
            2.0
        } else {
            0.0
        };
        let m = [base + bright, 0.7 * base, 0.3 * base + 0.1 * bright];
        (m, m.map(|v| 1e-3 * (0.05 + v)))
    })
}

#[test]
fn the_thresholds_follow_from_the_pixel_count() {
    let c = ImageCheck::default();
    // Normal tail: Q(2) and Q(3) to 1e-6 relative.
    assert!((normal_tail(2.0) / 0.022_750_131_948_179 - 1.0).abs() < 1e-6);
    assert!((normal_tail(3.0) / 0.001_349_898_031_630 - 1.0).abs() < 1e-6);
    // Unbiased pixel fails at most 1 − (1 − 2Q(2))³ = 13 %; a 3σ-biased one at least 84 %.
    assert!(
        (c.null_pixel_rate() - 0.1304).abs() < 1e-3,
        "{}",
        c.null_pixel_rate()
    );
    assert!((c.biased_pixel_rate() - 0.8413).abs() < 1e-3);
    // 48×48: the allowed share sits between 1.5 p₀ and p₁, closer to 1.5 p₀.
    let f = c.allowed_fail_share(48 * 48);
    assert!(f > 1.5 * c.null_pixel_rate() && f < 0.3, "{f}");
    assert!(c.miss_bound(48 * 48) < 1e-100);
    // More pixels, tighter share; few pixels: refused as vacuous.
    assert!(c.allowed_fail_share(512 * 512) < f);
    let need = c.min_informative();
    assert!((10..200).contains(&need), "{need}");
    assert!(c.miss_bound(need) <= c.alpha && c.miss_bound(need - 1) > c.alpha);
    // Block bounds: Bonferroni over blocks and channels.
    assert!(
        (c.block_z_bound(1) - 5.10).abs() < 0.01,
        "{}",
        c.block_z_bound(1)
    );
    assert!(
        (c.block_z_bound(144) - 5.97).abs() < 0.01,
        "{}",
        c.block_z_bound(144)
    );
}

#[test]
fn synthetic_unbiased_pairs_pass_and_biased_ones_fail() {
    let dir = scratch("oiio-synthetic");
    let syn = scene_like(64, 64);
    let check = ImageCheck::default();
    for seed in 1..4 {
        let a = syn.draw(2 * seed, &dir, "a");
        let b = syn.draw(2 * seed + 1, &dir, "b");
        let r = check
            .run(&a, &b)
            .unwrap_or_else(|e| panic!("seed {seed}: {e}"));
        assert!(r.nontrivial(0.1), "{r:?}");
        assert_eq!(r.informative, 62 * 62);
        // About 1 − (1 − 2Q(2))³ = 13 % of pixels beyond |z| = 2 (independent channels).
        assert!((0.10..0.16).contains(&r.fail_share), "{r:?}");
        assert!(!dir.join("a.diff.exr").exists() && !dir.join("a.zdiff.exr").exists());
    }
    let a = syn.draw(10, &dir, "a");
    let b = syn.draw(11, &dir, "b");

    // +3 standard errors everywhere: the per-pixel share fails.
    let shifted = shifted_copy(&a, &b.variance, 3.0, &dir.join("shifted.exr")).unwrap();
    let e = check.run(&shifted, &b).unwrap_err();
    assert!(e.contains("FAIL per-pixel share"), "{e}");
    assert!(e.contains("max |z|") && e.contains("image-mean z"), "{e}");
    for f in ["shifted.diff.exr", "shifted.zdiff.exr"] {
        assert!(dir.join(f).exists(), "{f} not kept");
        assert!(e.contains(&s(&dir.join(f))), "{e}");
    }

    // +0.6 standard errors on a 12×12 patch: no pixel notices, the blocks do.
    let (_, _, mut px, _) = stokes::output::read_exr(&a.image).unwrap();
    for y in 40..52 {
        for x in 40..52 {
            let i = (y * 64 + x) as usize;
            for (p, v) in px[i].iter_mut().zip(syn.var[i]) {
                *p += 0.6 * (2.0 * v).sqrt();
            }
        }
    }
    let patch = syn.write(&px, &dir, "patch");
    let e = check.run(&patch, &b).unwrap_err();
    assert!(
        e.contains("ok   per-pixel share") && e.contains("FAIL block |z|"),
        "{e}"
    );

    // 3 % too bright: the image means notice.
    let (_, _, mut px, _) = stokes::output::read_exr(&a.image).unwrap();
    px.iter_mut().flatten().for_each(|v| *v *= 1.03);
    let bright = syn.write(&px, &dir, "bright");
    let e = check.run(&bright, &b).unwrap_err();
    assert!(
        e.contains("ok   per-pixel share") && e.contains("FAIL image-mean z"),
        "{e}"
    );
}

#[test]
fn pixels_without_variance_must_agree_exactly() {
    let dir = scratch("oiio-zero-variance");
    // The border has no variance: zero in both images (and one constant column of 0.5).
    let syn = Synthetic::new(64, 64, |x, y| match (x, y) {
        (0, _) => ([0.5; 3], [0.0; 3]),
        (_, 0) => ([0.0; 3], [0.0; 3]),
        _ => ([0.3; 3], [1e-4; 3]),
    });
    let a = syn.draw(1, &dir, "a");
    let b = syn.draw(2, &dir, "b");
    let r = ImageCheck::default().run(&a, &b).unwrap();
    assert_eq!(r.informative, 63 * 63);

    // One pixel of the constant column off by 0.1 %: an enormous z, a hard failure.
    let (_, _, mut px, _) = stokes::output::read_exr(&a.image).unwrap();
    px[64 * 10][1] *= 1.001;
    let off = syn.write(&px, &dir, "off");
    let e = ImageCheck::default().run(&off, &b).unwrap_err();
    assert!(
        e.contains("FAIL max |z|") && e.contains("at (0, 10, G)"),
        "{e}"
    );

    // An image without variance anywhere is refused, not passed.
    let flat = Synthetic::new(64, 64, |_, _| ([0.3; 3], [0.0; 3]));
    let (c, d) = (flat.draw(1, &dir, "c"), flat.draw(2, &dir, "d"));
    let e = ImageCheck::default().run(&c, &d).unwrap_err();
    assert!(
        e.contains("vacuous") && e.contains("only 0 of 4096 pixels"),
        "{e}"
    );
}

#[test]
fn a_missing_oiiotool_names_the_package() {
    let dir = scratch("oiio-missing");
    let syn = scene_like(16, 16);
    let (a, b) = (syn.draw(1, &dir, "a"), syn.draw(2, &dir, "b"));
    let check = ImageCheck {
        oiiotool: "/nonexistent/oiiotool".into(),
        ..Default::default()
    };
    let e = check.run(&a, &b).unwrap_err();
    assert!(
        e.contains(INSTALL_HINT) && e.contains("/nonexistent/oiiotool"),
        "{e}"
    );
}

#[test]
fn exr_is_read_by_oiiotool_with_the_expected_size_and_no_nan() {
    let dir = scratch("oiiostats");
    let img = render_cbox(&dir, 5, 4);
    for f in [&img.image, &img.variance] {
        let st = stats(f)
            .unwrap()
            .split_whitespace()
            .collect::<Vec<_>>()
            .join(" ");
        assert!(st.contains("64 x 64, 3 channel, float openexr"), "{st}");
        assert!(st.contains("channel list: R, G, B"), "{st}");
        assert!(
            st.contains("NanCount: 0 0 0") && st.contains("InfCount: 0 0 0"),
            "{st}"
        );
    }
}

#[test]
fn cornell_box_matches_the_stored_reference() {
    let dir = scratch("oiioref");
    let img = render_cbox(&dir, 77, 256);
    let r = against_reference()
        .run(&img, &reference())
        .unwrap_or_else(|e| panic!("{e}"));
    assert!(r.nontrivial(0.05), "{r:?}");
    // With the render's own variance, pixels that missed the light's edge look many
    // standard errors dark: that is why the reference's variance stands in for it.
    let own = ImageCheck::default().run(&img, &reference());
    if let Err(e) = own {
        assert!(e.contains("FAIL max |z|"), "{e}");
    }
}

#[test]
fn the_check_fails_on_a_biased_image() {
    // A render shifted by 3 standard errors per pixel, and one 15 % too bright, must fail;
    // an independent render passes (`cornell_box_matches_the_stored_reference`).
    let dir = scratch("oiiobias");
    let img = render_cbox(&dir, 78, 256);
    let rf = reference();
    let shifted: PathBuf = dir.join("shifted.exr");
    let shifted = shifted_copy(&img, &rf.variance, 3.0, &shifted).unwrap();
    let e = against_reference().run(&shifted, &rf).unwrap_err();
    assert!(e.contains("FAIL per-pixel share"), "{e}");
    assert!(e.contains("max |z|") && e.contains("image-mean z"), "{e}");
    assert!(
        dir.join("shifted.diff.exr").exists(),
        "difference image not kept"
    );
    assert!(dir.join("shifted.zdiff.exr").exists(), "Z image not kept");

    let bright = Exr::new(dir.join("bright.exr"), &img.variance);
    let (w, h, px, meta) = stokes::output::read_exr(&img.image).unwrap();
    let px: Vec<[f32; 3]> = px.iter().map(|p| p.map(|v| 1.15 * v)).collect();
    stokes::output::write_exr(&bright.image, w, h, &px, &meta).unwrap();
    let e = against_reference().run(&bright, &rf).unwrap_err();
    assert!(e.contains("FAIL image-mean z"), "{e}");
}
