//! Integration tests of `stokes::spectrum` and `stokes::color`: sampling (chi-square),
//! tabulated curves, CIE colorimetry against published values, the film's Monte Carlo
//! estimator against quadrature (Z-test), Planck's law, CSV errors and CIEDE2000.
//!
//! Statistical tests use fixed seeds and a stated significance, so a run is reproducible
//! and a failure means something.

mod common;
use common::stats::{chi_square, Rng};
use std::path::PathBuf;

use glam::{Vec3, Vec4};
use stokes::color::{delta_e_2000, xyz_to_linear_srgb, xyz_to_xy};
use stokes::spectrum::{
    cie_xyz, csv_column, illuminant, peak_wavelength, read_csv, reflectance_to_xyz,
    spectrum_to_xyz, xyz_estimate, SampledWavelengths, Spectrum, Tabulated, CIE_Y_INTEGRAL,
    LAMBDA_MAX, LAMBDA_MIN,
};

const RANGE: f32 = LAMBDA_MAX - LAMBDA_MIN;
/// Significance of every chi-square test here.
const ALPHA: f64 = 1e-3;

// ---------------------------------------------------------------------------------------
// Chi-square against the uniform distribution.

/// Chi-square p-value of `samples` against the uniform distribution on [MIN, MAX),
/// with `bins` equal bins.
fn uniformity_p_value(samples: &[f32], bins: usize) -> f64 {
    let mut counts = vec![0u64; bins];
    for &l in samples {
        assert!(
            (LAMBDA_MIN..LAMBDA_MAX).contains(&l),
            "sample {l} outside [{LAMBDA_MIN}, {LAMBDA_MAX})"
        );
        let b = (((l - LAMBDA_MIN) / RANGE) * bins as f32) as usize;
        counts[b.min(bins - 1)] += 1;
    }
    let expected = vec![samples.len() as f64 / bins as f64; bins];
    chi_square(&counts, &expected).p_value
}

// ---------------------------------------------------------------------------------------
// Wavelength sampling.

const BINS: usize = 47; // 10 nm each
const SAMPLES: usize = 100_000;

fn hwss_lanes(seed: u64) -> [Vec<f32>; 4] {
    let mut rng = Rng::new(seed, 0);
    let mut lanes: [Vec<f32>; 4] = Default::default();
    for _ in 0..SAMPLES {
        let w = SampledWavelengths::sample_hwss(rng.next_f32());
        for (k, lane) in lanes.iter_mut().enumerate() {
            lane.push(w.lambda[k]);
        }
    }
    lanes
}

#[test]
fn hwss_hero_is_uniform() {
    let lanes = hwss_lanes(0x5EED_0001);
    let p = uniformity_p_value(&lanes[0], BINS);
    eprintln!("hero: chi-square p = {p:.4}");
    assert!(p > ALPHA, "hero wavelength is not uniform: p = {p:.3e}");
}

#[test]
fn hwss_every_lane_is_marginally_uniform() {
    let lanes = hwss_lanes(0x5EED_0002);
    for (k, lane) in lanes.iter().enumerate() {
        let p = uniformity_p_value(lane, BINS);
        eprintln!("lane {k}: chi-square p = {p:.4}");
        assert!(p > ALPHA, "lane {k} is not uniform: p = {p:.3e}");
    }
}

#[test]
fn hwss_lanes_are_spaced_by_a_quarter_range() {
    let mut rng = Rng::new(0x5EED_0003, 0);
    for _ in 0..10_000 {
        let l = SampledWavelengths::sample_hwss(rng.next_f32()).lambda;
        for k in 1..4 {
            let offset = (l[k] - l[0]).rem_euclid(RANGE);
            let expect = k as f32 * RANGE / 4.0;
            // Either the offset or its wrap-around can land at RANGE − tiny for k = 0.
            assert!(
                (offset - expect).abs() < 1e-3,
                "lane {k}: offset {offset} nm from hero {}, expected {expect}",
                l[0]
            );
        }
    }
}

#[test]
fn mono_hero_is_uniform() {
    let mut rng = Rng::new(0x5EED_0004, 0);
    let samples: Vec<f32> = (0..SAMPLES)
        .map(|_| SampledWavelengths::sample_mono(rng.next_f32()).lambda.x)
        .collect();
    let p = uniformity_p_value(&samples, BINS);
    assert!(p > ALPHA, "mono wavelength is not uniform: p = {p:.3e}");
    assert!((SampledWavelengths::pdf() - 1.0 / 470.0).abs() < 1e-9);
}

#[test]
fn chi_square_rejects_a_skewed_sampler() {
    // The same test must fail for a sampler that is only slightly off (density ∝ 1 + 0.1u).
    let mut rng = Rng::new(0x5EED_0005, 0);
    let samples: Vec<f32> = (0..SAMPLES)
        .map(|_| {
            let u = rng.next_f32();
            // Inverse CDF of (1 + 0.1x)/1.05 on [0, 1].
            let x = ((1.0 + 0.21 * u).sqrt() - 1.0) / 0.1;
            SampledWavelengths::sample_hwss(x.min(0.999_999)).lambda.x
        })
        .collect();
    let p = uniformity_p_value(&samples, BINS);
    eprintln!("skewed sampler: chi-square p = {p:.3e}");
    assert!(p < ALPHA, "skewed sampler passed: p = {p:.3e}");
}

// ---------------------------------------------------------------------------------------
// Tabulated curves.

#[test]
fn tabulated_interpolates_and_is_zero_outside() {
    let t = Tabulated::new(vec![400.0, 450.0, 700.0], vec![0.2, 0.8, 0.3]).unwrap();
    let s = Spectrum::Tabulated(t);
    assert_eq!(s.eval(400.0), 0.2);
    assert_eq!(s.eval(450.0), 0.8);
    assert_eq!(s.eval(700.0), 0.3);
    assert!((s.eval(425.0) - 0.5).abs() < 1e-6);
    assert!((s.eval(600.0) - 0.5).abs() < 1e-6);
    assert_eq!(s.eval(399.9), 0.0);
    assert_eq!(s.eval(700.1), 0.0);
    assert_eq!(s.eval(360.0), 0.0);
    let four = s.eval4(Vec4::new(380.0, 425.0, 600.0, 800.0));
    assert!((four - Vec4::new(0.0, 0.5, 0.5, 0.0)).abs().max_element() < 1e-6);
    assert_eq!(s.max_value(), 0.8);
}

/// Every segment of a longer table interpolates its own two knots, on uneven and even
/// grids, with integer knots (the integer-nm table) and without (searched per call):
/// an index clamped one segment too early, or found one off, extrapolates a neighbour.
#[test]
fn tabulated_interpolates_in_every_segment_of_every_kind_of_grid() {
    let values = vec![0.1, 0.5, 0.2, 0.9, 0.3, 0.6];
    for knots in [
        vec![400.0, 450.0, 500.0, 600.0, 700.0, 800.0],
        vec![400.0, 480.0, 560.0, 640.0, 720.0, 800.0],
        vec![400.5, 450.5, 500.5, 600.5, 700.5, 800.5],
        vec![400.5, 480.5, 560.5, 640.5, 720.5, 800.5],
    ] {
        let s = Spectrum::Tabulated(Tabulated::new(knots.clone(), values.clone()).unwrap());
        for i in 0..knots.len() - 1 {
            for t in [0.0f32, 0.25, 0.5, 0.75] {
                let l = knots[i] + t * (knots[i + 1] - knots[i]);
                let want = values[i] + t * (values[i + 1] - values[i]);
                let got = s.eval(l);
                assert!(
                    (got - want).abs() < 1e-5,
                    "{knots:?} at {l} nm: {got}, expected {want}"
                );
            }
        }
        assert!(
            (s.eval(knots[5]) - 0.6).abs() < 1e-6,
            "{knots:?} at the last knot"
        );
    }
}

/// Under a negative scale the largest value comes from the most negative one: the bound
/// is |scale| times the largest |value|, here exactly 3 · 2 = 6 (and never below any value).
#[test]
fn max_value_bounds_a_negatively_scaled_spectrum() {
    let t = Tabulated::new(vec![400.0, 600.0], vec![-2.0, 0.5]).unwrap();
    for s in [
        Spectrum::Scaled(Box::new(Spectrum::Tabulated(t)), -3.0),
        Spectrum::Scaled(Box::new(Spectrum::Constant(-2.0)), -3.0),
        Spectrum::Scaled(
            Box::new(Spectrum::Scaled(Box::new(Spectrum::Constant(-1.0)), 2.0)),
            -3.0,
        ),
    ] {
        assert_eq!(s.max_value(), 6.0, "{s:?}");
        for l in (360..=830).step_by(10) {
            assert!(s.eval(l as f32) <= s.max_value(), "{s:?} at {l} nm");
        }
    }
}

#[test]
fn tabulated_rejects_unsorted_wavelengths() {
    let e = Tabulated::new(vec![400.0, 500.0, 450.0], vec![1.0, 1.0, 1.0])
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("strictly increasing") && e.contains("index 2") && e.contains("450"),
        "{e}"
    );
    let e = Tabulated::new(vec![400.0, 400.0], vec![1.0, 1.0])
        .unwrap_err()
        .to_string();
    assert!(e.contains("index 1") && e.contains("400"), "{e}");
    assert!(Tabulated::new(vec![400.0, 500.0], vec![1.0]).is_err());
    assert!(Tabulated::new(vec![], vec![]).is_err());
    assert!(Tabulated::new(vec![400.0], vec![f32::INFINITY]).is_err());
}

// ---------------------------------------------------------------------------------------
// CIE colorimetry.

#[test]
fn y_bar_integrates_to_the_normalisation_constant() {
    // Trapezoid over the 1 nm samples = the exact integral of the interpolated ȳ.
    let mut sum = 0.0f64;
    for nm in 360..=830 {
        let w = if nm == 360 || nm == 830 { 0.5 } else { 1.0 };
        sum += w * f64::from(cie_xyz(nm as f32).y);
    }
    let rel = (sum / f64::from(CIE_Y_INTEGRAL) - 1.0).abs();
    assert!(
        rel < 1e-5,
        "∫ȳ = {sum}, expected {CIE_Y_INTEGRAL} (rel. error {rel:.2e})"
    );
}

#[test]
fn constant_one_has_unit_luminance() {
    let xyz = spectrum_to_xyz(&Spectrum::Constant(1.0));
    assert!((xyz.y - 1.0).abs() < 1e-5, "Y = {}", xyz.y);
    // Illuminant E: X, Y, Z equal to within the table's normalisation (≈ 1e-4).
    assert!((xyz - Vec3::ONE).abs().max_element() < 1e-3, "{xyz}");
    let doubled = spectrum_to_xyz(&Spectrum::Constant(1.0).scaled(2.0));
    assert!((doubled - 2.0 * xyz).abs().max_element() < 1e-5);
}

fn chromaticity_of(name: &str) -> glam::Vec2 {
    xyz_to_xy(spectrum_to_xyz(&illuminant(name).unwrap()))
}

#[test]
fn d65_chromaticity() {
    let xy = chromaticity_of("D65");
    eprintln!("D65 xy = {xy}");
    assert!(
        (xy.x - 0.3127).abs() < 5e-4 && (xy.y - 0.3290).abs() < 5e-4,
        "D65 xy = {xy}, expected (0.3127, 0.3290)"
    );
}

#[test]
fn illuminant_a_chromaticity() {
    let xy = chromaticity_of("A");
    eprintln!("A xy = {xy}");
    assert!(
        (xy.x - 0.4476).abs() < 5e-4 && (xy.y - 0.4074).abs() < 5e-4,
        "A xy = {xy}, expected (0.4476, 0.4074)"
    );
}

#[test]
fn fluorescent_illuminant_chromaticities() {
    // CIE 15:2004 table T.8: FL2 (0.3721, 0.3751), FL11 (0.3805, 0.3769).
    for (name, x, y) in [("F2", 0.3721, 0.3751), ("F11", 0.3805, 0.3769)] {
        let xy = chromaticity_of(name);
        eprintln!("{name} xy = {xy}");
        assert!(
            (xy.x - x).abs() < 1e-3 && (xy.y - y).abs() < 1e-3,
            "{name} xy = {xy}, expected ({x}, {y})"
        );
    }
}

#[test]
fn d65_is_white_in_linear_srgb() {
    let xyz = spectrum_to_xyz(&illuminant("D65").unwrap());
    let rgb = xyz_to_linear_srgb(xyz / xyz.y);
    eprintln!("D65 linear sRGB at Y = 1: {rgb}");
    assert!(
        (rgb - Vec3::ONE).abs().max_element() < 1e-2,
        "D65 at Y = 1 gives linear sRGB {rgb}"
    );
    // And illuminant A is clearly not white: red well above blue.
    let a = spectrum_to_xyz(&illuminant("A").unwrap());
    let rgb_a = xyz_to_linear_srgb(a / a.y);
    assert!(rgb_a.x > 1.3 && rgb_a.z < 0.5, "{rgb_a}");
}

#[test]
fn reflectance_xyz_is_reflected_radiance() {
    let d65 = illuminant("D65").unwrap();
    let white = reflectance_to_xyz(&Spectrum::Constant(1.0), &d65);
    let direct = spectrum_to_xyz(&d65);
    assert!((white - direct).abs().max_element() < 1e-3 * direct.y);
    // Not normalised to white: a 50 % grey reflects half of D65's Y (≈ 105 for D65 at 100).
    let grey = reflectance_to_xyz(&Spectrum::Constant(0.5), &d65);
    assert!((grey / white - Vec3::splat(0.5)).abs().max_element() < 1e-5);
    assert!(direct.y > 50.0, "D65 Y = {}", direct.y);
}

// ---------------------------------------------------------------------------------------
// The film's Monte Carlo estimator against quadrature (Z-test).

/// Mean and standard error of the estimator over `n` paths, per XYZ component.
fn estimate_xyz(n: usize, seed: u64, sample: impl Fn(&mut Rng) -> (Vec4, Vec4)) -> (Vec3, Vec3) {
    let mut rng = Rng::new(seed, 0);
    let (mut sum, mut sum_sq) = ([0.0f64; 3], [0.0f64; 3]);
    for _ in 0..n {
        let (lambda, value) = sample(&mut rng);
        let e = xyz_estimate(lambda, value);
        for c in 0..3 {
            sum[c] += f64::from(e[c]);
            sum_sq[c] += f64::from(e[c]).powi(2);
        }
    }
    let nf = n as f64;
    let mut mean = Vec3::ZERO;
    let mut se = Vec3::ZERO;
    for c in 0..3 {
        let m = sum[c] / nf;
        let var = (sum_sq[c] / nf - m * m) * nf / (nf - 1.0);
        mean[c] = m as f32;
        se[c] = (var / nf).sqrt() as f32;
    }
    (mean, se)
}

fn assert_within_4_se(name: &str, mean: Vec3, se: Vec3, exact: Vec3) {
    for c in 0..3 {
        let z = (mean[c] - exact[c]) / se[c];
        eprintln!(
            "{name}: component {c}: {} ± {} vs {} (z = {z:.2})",
            mean[c], se[c], exact[c]
        );
        assert!(
            z.abs() < 4.0,
            "{name}: component {c}: estimate {} ± {} vs exact {} (z = {z:.2})",
            mean[c],
            se[c],
            exact[c]
        );
        // The standard error must be small enough for the test to mean something.
        assert!(
            se[c] < 1e-2 * exact[c].abs(),
            "{name}: s.e. {} too large",
            se[c]
        );
    }
}

#[test]
fn hwss_estimate_converges_to_quadrature() {
    let d65 = illuminant("D65").unwrap();
    let exact = spectrum_to_xyz(&d65);
    // Balance heuristic over four equally likely lanes: weight 1/4 each.
    let (mean, se) = estimate_xyz(200_000, 0xC0FFEE, |rng| {
        let w = SampledWavelengths::sample_hwss(rng.next_f32());
        (w.lambda, 0.25 * d65.eval4(w.lambda))
    });
    assert_within_4_se("HWSS D65", mean, se, exact);
    // Forgetting the MIS weights must be caught by the same test.
    let (wrong, wrong_se) = estimate_xyz(20_000, 0xC0FFEE, |rng| {
        let w = SampledWavelengths::sample_hwss(rng.next_f32());
        (w.lambda, d65.eval4(w.lambda))
    });
    assert!(((wrong.y - exact.y) / wrong_se.y).abs() > 4.0);
}

#[test]
fn mono_estimate_converges_to_quadrature() {
    let bb = Spectrum::blackbody(3200.0, true).unwrap();
    let exact = spectrum_to_xyz(&bb);
    let (mean, se) = estimate_xyz(400_000, 0xBEEF, |rng| {
        let w = SampledWavelengths::sample_mono(rng.next_f32());
        // Lanes 1–3 are masked: they carry zero.
        (w.lambda, Vec4::new(bb.eval(w.hero()), 0.0, 0.0, 0.0))
    });
    assert_within_4_se("mono blackbody", mean, se, exact);
}

// ---------------------------------------------------------------------------------------
// Analytic spectra.

#[test]
fn blackbody_peak_follows_wien() {
    let s = Spectrum::blackbody(5000.0, false).unwrap();
    let (mut best_l, mut best_v) = (0.0, f32::MIN);
    let mut l = 560.0f32;
    while l < 600.0 {
        let v = s.eval(l);
        if v > best_v {
            (best_l, best_v) = (l, v);
        }
        l += 0.01;
    }
    assert!(
        (best_l - 579.6).abs() < 1.0,
        "5000 K peaks at {best_l} nm, Wien says 579.6 nm"
    );
    assert!((peak_wavelength(5000.0) - 579.554).abs() < 0.01);
    let normalised = Spectrum::blackbody(5000.0, true).unwrap();
    assert!((normalised.max_value() - 1.0).abs() < 1e-6);
    assert!((normalised.eval(best_l) - 1.0).abs() < 1e-5);
}

#[test]
fn narrow_band_integrates_to_one() {
    for &(centre, fwhm) in &[(550.0f32, 10.0f32), (450.0, 1.0), (633.0, 30.0)] {
        let s = Spectrum::narrow_band(centre, fwhm).unwrap();
        let h = 0.005f64;
        let n = ((LAMBDA_MAX - LAMBDA_MIN) as f64 / h) as usize;
        let mut integral = 0.0f64;
        for i in 0..=n {
            let w = if i == 0 || i == n { 0.5 } else { 1.0 };
            integral += w * f64::from(s.eval(LAMBDA_MIN + (i as f64 * h) as f32));
        }
        integral *= h;
        assert!(
            (integral - 1.0).abs() < 1e-3,
            "narrow band at {centre} nm, fwhm {fwhm}: ∫ = {integral}"
        );
    }
}

// ---------------------------------------------------------------------------------------
// CSV files.

fn temp_file(name: &str, contents: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("stokes-spectrum-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(name);
    std::fs::write(&path, contents).unwrap();
    path
}

#[test]
fn csv_malformed_line_names_file_and_line() {
    let path = temp_file(
        "cbox.csv",
        "# measured\nnm,white,red\n400,0.34,0.04\n404,0.45,abc\n",
    );
    let e = read_csv(&path).unwrap_err().to_string();
    assert!(
        e.contains("cbox.csv:4:") && e.contains("column 3") && e.contains("'abc'"),
        "{e}"
    );

    let path = temp_file("short.csv", "400,1,2\n410,1,2\n\n420,1\n");
    let e = read_csv(&path).unwrap_err().to_string();
    assert!(
        e.contains("short.csv:4:") && e.contains("expected 3 columns"),
        "{e}"
    );

    let e = read_csv(&temp_file("empty.csv", ""))
        .unwrap_err()
        .to_string();
    assert!(e.contains("empty.csv") && e.contains("no data"), "{e}");
}

#[test]
fn csv_columns_by_name_or_only_one() {
    let path = temp_file("two.csv", "nm, white, red\n400, 0.5, 0.1\n500, 0.7, 0.3\n");
    let cols = read_csv(&path).unwrap();
    assert_eq!(cols.len(), 2);
    let red = csv_column(&path, Some("red")).unwrap();
    assert!((Spectrum::Tabulated(red).eval(450.0) - 0.2).abs() < 1e-6);
    let e = csv_column(&path, None).unwrap_err().to_string();
    assert!(e.contains("'white', 'red'"), "{e}");
    let e = csv_column(&path, Some("green")).unwrap_err().to_string();
    assert!(e.contains("green") && e.contains("'white', 'red'"), "{e}");

    let one = temp_file("one.txt", "400 1\n500 3\n");
    let t = csv_column(&one, None).unwrap();
    assert_eq!(t.values(), &[1.0, 3.0]);
}

// ---------------------------------------------------------------------------------------
// CIEDE2000.

/// Sharma, Wu and Dalal (2005), "The CIEDE2000 color-difference formula: implementation
/// notes, supplementary test data, and mathematical observations", table 1: all 34 pairs
/// (L1, a1, b1, L2, a2, b2, ΔE00).
const SHARMA_PAIRS: [[f32; 7]; 34] = [
    [50.0000, 2.6772, -79.7751, 50.0000, 0.0000, -82.7485, 2.0425],
    [50.0000, 3.1571, -77.2803, 50.0000, 0.0000, -82.7485, 2.8615],
    [50.0000, 2.8361, -74.0200, 50.0000, 0.0000, -82.7485, 3.4412],
    [
        50.0000, -1.3802, -84.2814, 50.0000, 0.0000, -82.7485, 1.0000,
    ],
    [
        50.0000, -1.1848, -84.8006, 50.0000, 0.0000, -82.7485, 1.0000,
    ],
    [
        50.0000, -0.9009, -85.5211, 50.0000, 0.0000, -82.7485, 1.0000,
    ],
    [50.0000, 0.0000, 0.0000, 50.0000, -1.0000, 2.0000, 2.3669],
    [50.0000, -1.0000, 2.0000, 50.0000, 0.0000, 0.0000, 2.3669],
    [50.0000, 2.4900, -0.0010, 50.0000, -2.4900, 0.0009, 7.1792],
    [50.0000, 2.4900, -0.0010, 50.0000, -2.4900, 0.0010, 7.1792],
    [50.0000, 2.4900, -0.0010, 50.0000, -2.4900, 0.0011, 7.2195],
    [50.0000, 2.4900, -0.0010, 50.0000, -2.4900, 0.0012, 7.2195],
    [50.0000, -0.0010, 2.4900, 50.0000, 0.0009, -2.4900, 4.8045],
    [50.0000, -0.0010, 2.4900, 50.0000, 0.0010, -2.4900, 4.8045],
    [50.0000, -0.0010, 2.4900, 50.0000, 0.0011, -2.4900, 4.7461],
    [50.0000, 2.5000, 0.0000, 50.0000, 0.0000, -2.5000, 4.3065],
    [50.0000, 2.5000, 0.0000, 73.0000, 25.0000, -18.0000, 27.1492],
    [50.0000, 2.5000, 0.0000, 61.0000, -5.0000, 29.0000, 22.8977],
    [50.0000, 2.5000, 0.0000, 56.0000, -27.0000, -3.0000, 31.9030],
    [50.0000, 2.5000, 0.0000, 58.0000, 24.0000, 15.0000, 19.4535],
    [50.0000, 2.5000, 0.0000, 50.0000, 3.1736, 0.5854, 1.0000],
    [50.0000, 2.5000, 0.0000, 50.0000, 3.2972, 0.0000, 1.0000],
    [50.0000, 2.5000, 0.0000, 50.0000, 1.8634, 0.5757, 1.0000],
    [50.0000, 2.5000, 0.0000, 50.0000, 3.2592, 0.3350, 1.0000],
    [
        60.2574, -34.0099, 36.2677, 60.4626, -34.1751, 39.4387, 1.2644,
    ],
    [
        63.0109, -31.0961, -5.8663, 62.8187, -29.7946, -4.0864, 1.2630,
    ],
    [61.2901, 3.7196, -5.3901, 61.4292, 2.2480, -4.9620, 1.8731],
    [35.0831, -44.1164, 3.7933, 35.0232, -40.0716, 1.5901, 1.8645],
    [
        22.7233, 20.0904, -46.6940, 23.0331, 14.9730, -42.5619, 2.0373,
    ],
    [36.4612, 47.8580, 18.3852, 36.2715, 50.5065, 21.2231, 1.4146],
    [90.8027, -2.0831, 1.4410, 91.1528, -1.6435, 0.0447, 1.4441],
    [90.9257, -0.5406, -0.9208, 88.6381, -0.8985, -0.7239, 1.5381],
    [6.7747, -0.2908, -2.4247, 5.8714, -0.0985, -2.2286, 0.6377],
    [2.0776, 0.0795, -1.1350, 0.9033, -0.0636, -0.5514, 0.9082],
];

#[test]
fn delta_e_2000_matches_sharma_test_data() {
    for (i, p) in SHARMA_PAIRS.iter().enumerate() {
        let lab1 = Vec3::new(p[0], p[1], p[2]);
        let lab2 = Vec3::new(p[3], p[4], p[5]);
        for (d, order) in [
            (delta_e_2000(lab1, lab2), "1→2"),
            (delta_e_2000(lab2, lab1), "2→1"),
        ] {
            assert!(
                (d - p[6]).abs() < 1e-4,
                "pair {} ({order}): ΔE00 = {d:.5}, published {}",
                i + 1,
                p[6]
            );
        }
    }
}

/// A tabulated curve at four wavelengths at once (`eval4`, the width-4 look-up run across
/// the wavelengths) gives the bits of four single `eval`s: on the integer-nm table, off it
/// (knots beyond 360–830 nm), on a non-integer grid, and for NaN and out-of-range input.
#[test]
fn tabulated_eval4_gives_the_bits_of_four_evals() {
    let curves = [
        Tabulated::new(vec![400.0, 450.0, 700.0], vec![0.2, 0.8, 0.3]).unwrap(),
        Tabulated::new(vec![300.0, 500.0, 900.0], vec![0.9, 0.1, 0.7]).unwrap(),
        Tabulated::new(vec![401.5, 455.25, 690.75], vec![0.3, 0.6, 0.1]).unwrap(),
        Tabulated::new(vec![550.0], vec![0.4]).unwrap(),
    ];
    let special = [f32::NAN, -1.0, 0.0, 359.999, 360.0, 829.999, 830.0, 1e9];
    let lambdas: Vec<f32> = (0..2000)
        .map(|i| 290.0 + 0.3137 * i as f32)
        .chain(special)
        .collect();
    for t in &curves {
        for l in lambdas.chunks(4).filter(|c| c.len() == 4) {
            let four = t.eval4(Vec4::from_slice(l));
            for k in 0..4 {
                assert_eq!(
                    four[k].to_bits(),
                    t.eval(l[k]).to_bits(),
                    "{t:?} at {} nm",
                    l[k]
                );
            }
        }
    }
}
