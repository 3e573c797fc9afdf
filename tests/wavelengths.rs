//! The visible-importance wavelength sampler (`--wavelengths visible`): its pdf is what
//! the documentation says, the hero and every lane follow it (chi-square), the lanes sit a
//! quarter of the CDF apart, a slightly wrong pdf is rejected by the same test, and the
//! film's estimate with its lane weights converges to the exact XYZ (Z-test), where
//! forgetting the weights is caught.
//!
//! Fixed seeds and a stated significance, as in `tests/spectrum.rs`.

mod common;
use common::stats::{chi_square, Rng};
use common::{region_mean, scene_from, TestRender};
use stokes::method::Spectral;

use glam::{Vec3, Vec4};
use stokes::color::xyz_to_linear_srgb;
use stokes::spectrum::{
    cie_xyz, illuminant, spectrum_to_xyz, xyz_estimate, SampledWavelengths, Spectrum, Wavelengths,
    LAMBDA_MAX, LAMBDA_MIN, VISIBLE_FLOOR,
};

/// Significance of every chi-square test here.
const ALPHA: f64 = 1e-3;
/// 5 nm bins over 360–830.
const BINS: usize = 94;
const SAMPLES: usize = 200_000;
const VISIBLE: Wavelengths = Wavelengths::Visible;

/// ∫ pdf over `[lo, hi)` by the midpoint rule on 0.01 nm steps.
fn mass(pdf: impl Fn(f32) -> f64, lo: f32, hi: f32) -> f64 {
    let n = ((hi - lo) * 100.0).round() as usize;
    let h = (hi - lo) as f64 / n as f64;
    (0..n)
        .map(|i| pdf(lo + ((i as f64 + 0.5) * h) as f32) * h)
        .sum()
}

/// Chi-square p-value of `samples` against `pdf` with [`BINS`] equal bins.
fn p_value(samples: &[f32], pdf: impl Fn(f32) -> f64) -> f64 {
    let width = (LAMBDA_MAX - LAMBDA_MIN) / BINS as f32;
    let mut counts = vec![0u64; BINS];
    for &l in samples {
        assert!(
            (LAMBDA_MIN..LAMBDA_MAX).contains(&l),
            "sample {l} outside [{LAMBDA_MIN}, {LAMBDA_MAX})"
        );
        counts[(((l - LAMBDA_MIN) / width) as usize).min(BINS - 1)] += 1;
    }
    let expected: Vec<f64> = (0..BINS)
        .map(|b| {
            let lo = LAMBDA_MIN + b as f32 * width;
            samples.len() as f64 * mass(&pdf, lo, lo + width)
        })
        .collect();
    chi_square(&counts, &expected).p_value
}

/// The pdf as documented, computed here from the public CIE and colour functions: the
/// length of the linear-sRGB colour-matching functions (cell means on 1 nm cells) plus
/// `floor` times its peak, normalised.
fn documented_pdf(floor: f64) -> impl Fn(f32) -> f64 {
    let at = |l: f32| xyz_to_linear_srgb(cie_xyz(l)).length() as f64;
    let cells: Vec<f64> = (0..470)
        .map(|i| {
            let lo = LAMBDA_MIN + i as f32;
            0.5 * (at(lo) + at(lo + 1.0))
        })
        .collect();
    let peak = cells.iter().cloned().fold(0.0, f64::max);
    let total: f64 = cells.iter().map(|c| c + floor * peak).sum();
    move |l: f32| {
        let i = ((l - LAMBDA_MIN) as usize).min(469);
        (cells[i] + floor * peak) / total
    }
}

fn lanes(seed: u64) -> [Vec<f32>; 4] {
    let mut rng = Rng::new(seed, 0);
    let mut lanes: [Vec<f32>; 4] = Default::default();
    for _ in 0..SAMPLES {
        let w = SampledWavelengths::hwss_with(VISIBLE, rng.next_f32());
        for (k, lane) in lanes.iter_mut().enumerate() {
            lane.push(w.lambda[k]);
        }
    }
    lanes
}

#[test]
fn the_pdf_is_the_documented_one_and_integrates_to_one() {
    let want = documented_pdf(VISIBLE_FLOOR);
    for i in 0..4700 {
        let l = LAMBDA_MIN + 0.1 * i as f32 + 0.05;
        let (got, want) = (VISIBLE.pdf(l) as f64, want(l));
        assert!(
            (got - want).abs() < 1e-5 * want,
            "pdf({l}) = {got}, documented {want}"
        );
    }
    let total = mass(|l| VISIBLE.pdf(l) as f64, LAMBDA_MIN, LAMBDA_MAX);
    assert!((total - 1.0).abs() < 1e-4, "∫ pdf = {total}");
    assert_eq!(VISIBLE.pdf(LAMBDA_MIN - 1.0), 0.0);
    assert_eq!(VISIBLE.pdf(LAMBDA_MAX), 0.0);
    // Where the eye looks the pdf is higher than uniform, at the ends far lower, and the
    // floor keeps every wavelength possible.
    let uniform = 1.0 / (LAMBDA_MAX - LAMBDA_MIN);
    assert!(VISIBLE.pdf(600.0) > 2.0 * uniform && VISIBLE.pdf(450.0) > 2.0 * uniform);
    assert!(VISIBLE.pdf(555.0) > 1.3 * uniform);
    assert!(VISIBLE.pdf(365.0) < 0.3 * uniform);
    let lowest = (0..470)
        .map(|i| VISIBLE.pdf(LAMBDA_MIN + i as f32 + 0.5))
        .fold(f32::INFINITY, f32::min);
    assert!(lowest > 0.02 * uniform, "lowest pdf {lowest}");
}

#[test]
fn the_hero_follows_the_pdf() {
    let hero = &lanes(0x71_0001)[0];
    let p = p_value(hero, |l| VISIBLE.pdf(l) as f64);
    eprintln!("visible hero: chi-square p = {p:.4}");
    assert!(p > ALPHA, "hero does not follow its pdf: p = {p:.3e}");
}

#[test]
fn every_lane_follows_the_pdf() {
    for (k, lane) in lanes(0x71_0002).iter().enumerate() {
        let p = p_value(lane, |l| VISIBLE.pdf(l) as f64);
        eprintln!("visible lane {k}: chi-square p = {p:.4}");
        assert!(p > ALPHA, "lane {k} does not follow the pdf: p = {p:.3e}");
    }
}

#[test]
fn mono_follows_the_pdf() {
    let mut rng = Rng::new(0x71_0003, 0);
    let mono: Vec<f32> = (0..SAMPLES)
        .map(|_| {
            let w = SampledWavelengths::mono_with(VISIBLE, rng.next_f32());
            assert_eq!(w.lambda, Vec4::splat(w.hero()));
            w.hero()
        })
        .collect();
    let p = p_value(&mono, |l| VISIBLE.pdf(l) as f64);
    assert!(
        p > ALPHA,
        "mono wavelength does not follow the pdf: p = {p:.3e}"
    );
}

#[test]
fn the_test_rejects_a_slightly_wrong_pdf() {
    // The same samples against the pdf with a floor of 3 % instead of 5 %, against
    // uniform, and against the documented shape without a floor: all must be rejected.
    let hero = &lanes(0x71_0001)[0];
    let uniform = 1.0 / (LAMBDA_MAX - LAMBDA_MIN) as f64;
    for (what, p) in [
        ("floor 3 %", p_value(hero, documented_pdf(0.03))),
        ("uniform", p_value(hero, |_| uniform)),
        ("no floor", p_value(hero, documented_pdf(0.0))),
    ] {
        eprintln!("{what}: chi-square p = {p:.3e}");
        assert!(p < ALPHA, "{what} passed: p = {p:.3e}");
    }
}

#[test]
fn lanes_sit_a_quarter_of_the_cdf_apart() {
    let mut rng = Rng::new(0x71_0004, 0);
    for _ in 0..20_000 {
        let u = rng.next_f32();
        let w = SampledWavelengths::hwss_with(VISIBLE, u);
        let c0 = VISIBLE.cdf(w.lambda[0]);
        assert!((c0 - u).abs() < 2e-6, "cdf(sample(u)) = {c0}, u = {u}");
        for k in 1..4 {
            let d = (VISIBLE.cdf(w.lambda[k]) - c0).rem_euclid(1.0);
            let d = if d > 0.999 { d - 1.0 } else { d };
            assert!(
                (d - 0.25 * k as f32).abs() < 2e-6,
                "lane {k}: CDF offset {d} from the hero at {}",
                w.lambda[0]
            );
        }
    }
    // Uniform sampling is the same construction with the uniform CDF.
    let w = SampledWavelengths::hwss_with(Wavelengths::Uniform, 0.3);
    assert_eq!(w, SampledWavelengths::sample_hwss(0.3));
}

#[test]
fn film_weights_are_one_over_pdf_times_range_and_bounded() {
    let range = LAMBDA_MAX - LAMBDA_MIN;
    assert_eq!(Wavelengths::Uniform.film_weight(Vec4::splat(500.0)), None);
    let mut largest = 0.0f32;
    for i in 0..470 {
        let l = LAMBDA_MIN + i as f32 + 0.5;
        let w = VISIBLE.film_weight(Vec4::splat(l)).unwrap();
        let want = 1.0 / (VISIBLE.pdf(l) * range);
        assert!((w.x - want).abs() < 1e-6 * want, "{l}: {} vs {want}", w.x);
        largest = largest.max(w.x);
    }
    // The floor bounds the weight: 1/(floor · peak share · Δ), well under 100.
    assert!(largest < 100.0, "largest lane weight {largest}");
    let outside = VISIBLE.film_weight(Vec4::new(300.0, 500.0, 900.0, f32::NAN));
    assert_eq!(outside.unwrap().x, 0.0);
    assert_eq!(outside.unwrap().z, 0.0);
}

/// Mean and standard error of the film's XYZ estimate over `n` samples of `sample`.
fn estimate(n: usize, seed: u64, sample: impl Fn(f32) -> (Vec4, Vec4)) -> (Vec3, Vec3) {
    let mut rng = Rng::new(seed, 0);
    let (mut sum, mut sq) = (Vec3::ZERO.as_dvec3(), Vec3::ZERO.as_dvec3());
    for _ in 0..n {
        let (lambda, value) = sample(rng.next_f32());
        let e = xyz_estimate(lambda, value).as_dvec3();
        sum += e;
        sq += e * e;
    }
    let nf = n as f64;
    let mean = sum / nf;
    let var = (sq / nf - mean * mean) * (nf / (nf - 1.0));
    (mean.as_vec3(), (var / nf).as_vec3().map(f32::sqrt))
}

fn z_scores(mean: Vec3, se: Vec3, exact: Vec3) -> Vec3 {
    (mean - exact) / se
}

#[test]
fn the_film_estimate_with_visible_wavelengths_is_unbiased() {
    let cases = [
        ("D65", illuminant("D65").unwrap()),
        (
            "blackbody 2000 K",
            Spectrum::blackbody(2000.0, true).unwrap(),
        ),
        // Light only below 420 nm, where the visible pdf is lowest.
        ("violet line", Spectrum::narrow_band(405.0, 10.0).unwrap()),
    ];
    for (name, s) in cases {
        let exact = spectrum_to_xyz(&s);
        let weigh = |l: Vec4| VISIBLE.film_weight(l).unwrap();
        // HWSS: balance heuristic over four lanes with equal path pdfs, 1/4 each.
        let (m, se) = estimate(200_000, 0x71_0005, |u| {
            let l = SampledWavelengths::hwss_with(VISIBLE, u).lambda;
            (l, 0.25 * s.eval4(l) * weigh(l))
        });
        let z = z_scores(m, se, exact);
        eprintln!("{name}: HWSS visible {m} ± {se} vs {exact}: z = {z}");
        assert!(z.abs().max_element() < 4.0, "{name}: HWSS z = {z}");
        assert!((se / exact.abs()).max_element() < 2e-2, "{name}: s.e. {se}");
        // Mono: one lane.
        let (m, se) = estimate(400_000, 0x71_0006, |u| {
            let l = SampledWavelengths::mono_with(VISIBLE, u).lambda;
            (l, s.eval4(l) * weigh(l) * Vec4::X)
        });
        let z = z_scores(m, se, exact);
        eprintln!("{name}: mono visible: z = {z}");
        assert!(z.abs().max_element() < 4.0, "{name}: mono z = {z}");
        // Forgetting the lane weights (treating the lanes as uniform) is caught.
        let (m, se) = estimate(50_000, 0x71_0007, |u| {
            let l = SampledWavelengths::hwss_with(VISIBLE, u).lambda;
            (l, 0.25 * s.eval4(l))
        });
        let z = z_scores(m, se, exact);
        assert!(
            z.abs().max_element() > 4.0,
            "{name}: unweighted passed: z = {z}"
        );
    }
}

#[test]
fn visible_sampling_has_less_colour_noise_for_a_flat_spectrum() {
    // The point of the pdf: the variance of the linear-sRGB estimate of a flat spectrum
    // falls (measured ≈ 15× for HWSS; asserted > 3×).
    let var = |w: Wavelengths| {
        let mut rng = Rng::new(0x71_0008, 0);
        let n = 100_000;
        let (mut sum, mut sq) = (Vec3::ZERO.as_dvec3(), Vec3::ZERO.as_dvec3());
        for _ in 0..n {
            let l = SampledWavelengths::hwss_with(w, rng.next_f32()).lambda;
            let v = Vec4::splat(0.25) * w.film_weight(l).unwrap_or(Vec4::ONE);
            let rgb = xyz_to_linear_srgb(xyz_estimate(l, v)).as_dvec3();
            sum += rgb;
            sq += rgb * rgb;
        }
        let mean = sum / n as f64;
        (sq / n as f64 - mean * mean).element_sum()
    };
    let (uniform, visible) = (var(Wavelengths::Uniform), var(VISIBLE));
    eprintln!("flat spectrum, sRGB variance: uniform {uniform:.4e}, visible {visible:.4e}");
    assert!(uniform > 3.0 * visible, "{uniform} vs {visible}");
}

/// A fluorescent sphere in an enclosure that emits only a 365 nm line (invisible): all
/// the sphere shows is its dye's green re-emission at ~520 nm, reached only through
/// input wavelengths in the UV that shift sampling draws, whatever the hero's pdf.
const UV_SCENE: &str = r#"
[camera]
position = [0, 0, -1.8]
look_at = [0, 0, 0]
fov = 60
resolution = [16, 16]

[materials.dyed]
type = "fluorescent_diffuse"
reflectance = 0.05
dye = { absorption = { wavelengths = [330, 350, 365, 380, 400], values = [0, 0.8, 0.95, 0.8, 0] }, emission = { wavelengths = [470, 500, 520, 540, 580], values = [0, 0.5, 1, 0.5, 0] }, quantum_yield = 0.9 }

[[shapes]]
type = "box"
min = [-2, -2, -2]
max = [2, 2, 2]
emission = { radiance = { narrow_band = 365, fwhm = 10 }, scale = 50, two_sided = true }

[[shapes]]
type = "sphere"
center = [0, 0, 0]
radius = 1
stacks = 24
material = "dyed"
"#;

#[test]
fn a_uv_lit_dye_renders_the_same_with_either_pdf() {
    let mut means = Vec::new();
    for (spectral, spp) in [(Spectral::Hwss, 512), (Spectral::Mono, 2048)] {
        for w in [Wavelengths::Uniform, VISIBLE] {
            let mut scene = scene_from(UV_SCENE);
            let film = TestRender::at(16, 16)
                .spp(spp)
                .seed(7)
                .spectral(spectral)
                .wavelengths(w)
                .film(&mut scene);
            // The central 6×6 pixels see only the sphere.
            let px: Vec<usize> = (5..11)
                .flat_map(|y| (5..11).map(move |x| y * 16 + x))
                .collect();
            let (m, se) = region_mean(&film, &px);
            eprintln!("{spectral:?} {w:?}: sphere {m:?} ± {se:?}");
            // Green glow, far above the noise: the UV input wavelengths were sampled.
            assert!(
                m[1] > 20.0 * se[1],
                "{spectral:?} {w:?}: no glow: {m:?} ± {se:?}"
            );
            assert!(
                m[1] > 2.0 * m[0] && m[1] > 2.0 * m[2],
                "{w:?}: not green: {m:?}"
            );
            means.push((format!("{spectral:?} {w:?}"), m, se));
        }
    }
    let (name0, m0, se0) = &means[0];
    for (name, m, se) in &means[1..] {
        for c in 0..3 {
            let z = (m[c] - m0[c]) / (se[c] * se[c] + se0[c] * se0[c]).sqrt();
            assert!(z.abs() < 4.0, "{name} vs {name0}, channel {c}: z = {z:.2}");
        }
    }
}
