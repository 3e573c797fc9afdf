//! Integration tests of `stokes::fluoro`: re-radiation data (parametric dye, measured CSV
//! matrix, diagonal only) and shift sampling on camera paths.
//!
//! Statistical tests use fixed seeds and a stated significance (chi-square at
//! α = 1e-3), each with a negative control showing that the same test rejects a wrong
//! sampler.

mod common;
use common::stats::{chi_square, Rng};
use std::path::{Path, PathBuf};

use glam::Vec4;
use stokes::fluoro::{ImportReport, Reradiation};
use stokes::spectrum::{Spectrum, Tabulated, LAMBDA_MAX, LAMBDA_MIN};

/// Significance of every chi-square test here.
const ALPHA: f64 = 1e-3;
/// Output wavelengths at which sampling is checked.
const OUTPUTS: [f32; 4] = [480.0, 550.0, 600.0, 650.0];

// ---------------------------------------------------------------------------------------
// Chi-square against bin probabilities.

/// The chi-square p-value of `observed` counts against bin probabilities `expected`
/// (summing to 1); 0 when a bin of probability 0 was hit.
fn chi_square_p(observed: &[u64], expected: &[f64]) -> f64 {
    let n = observed.iter().sum::<u64>() as f64;
    let psum: f64 = expected.iter().sum();
    assert!((psum - 1.0).abs() < 1e-4, "bin probabilities sum to {psum}");
    let counts: Vec<f64> = expected.iter().map(|p| p * n).collect();
    chi_square(observed, &counts).p_value
}

// ---------------------------------------------------------------------------------------
// Test data.

fn gauss(l: f32, mu: f32, sigma: f32) -> f32 {
    (-0.5 * ((l - mu) / sigma).powi(2)).exp()
}

/// A tabulated spectrum sampled every 1 nm over the range from `f`.
fn tabulate(f: impl Fn(f32) -> f32) -> Spectrum {
    let w: Vec<f32> = (0..=470).map(|k| LAMBDA_MIN + k as f32).collect();
    let v = w.iter().map(|&l| f(l)).collect();
    Spectrum::Tabulated(Tabulated::new(w, v).unwrap())
}

fn dye_absorption() -> Spectrum {
    tabulate(|l| 0.9 * gauss(l, 440.0, 25.0))
}

fn dye_emission() -> Spectrum {
    tabulate(|l| gauss(l, 520.0, 25.0) + 0.3 * gauss(l, 590.0, 40.0))
}

const PHI: f32 = 0.8;

/// Diagonal 0.85·(1 − A): D + Φ·A ≤ 0.85 everywhere.
fn dye_diagonal() -> Spectrum {
    tabulate(|l| 0.85 * (1.0 - 0.9 * gauss(l, 440.0, 25.0)))
}

fn dye(cell_nm: f32) -> Reradiation {
    Reradiation::from_dye(
        dye_diagonal(),
        &dye_absorption(),
        &dye_emission(),
        PHI,
        cell_nm,
    )
    .unwrap()
}

fn example_path() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/data/fluoro/synthetic_dye_10nm.csv")
}

fn measured() -> (Reradiation, ImportReport) {
    Reradiation::from_csv(&example_path()).unwrap()
}

/// The sources every generic check runs on.
fn sources() -> Vec<(&'static str, Reradiation)> {
    vec![
        ("dye 10 nm", dye(10.0)),
        ("dye 3 nm", dye(3.0)),
        ("measured example", measured().0),
    ]
}

/// A scratch file with `text`, named after the test.
fn scratch(name: &str, text: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("stokes-fluoro-tests-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path
}

/// Bin probabilities at output λo: bin 0 = keep, bin 1 + k = a shift into cell k.
fn expected_bins(r: &Reradiation, lambda_o: f32) -> Vec<f64> {
    let mut p = vec![f64::from(r.pdf_input(lambda_o, lambda_o, true))];
    for k in 0..r.cells() {
        let (a, b) = r.cell_bounds(k);
        let mid = 0.5 * (a + b);
        p.push(f64::from(r.pdf_input(mid, lambda_o, false)) * f64::from(b - a));
    }
    p
}

fn bin_of(r: &Reradiation, kept: bool, lambda_i: f32) -> usize {
    if kept {
        0
    } else {
        1 + r.cell(lambda_i).expect("shifted outside the grid")
    }
}

fn histogram(
    r: &Reradiation,
    lambda_o: f32,
    n: usize,
    seed: u64,
    mut sample: impl FnMut(&mut Rng) -> Option<(bool, f32)>,
) -> Vec<u64> {
    let mut counts = vec![0u64; r.cells() + 1];
    let mut rng = Rng::new(seed, lambda_o.to_bits() as u64);
    for _ in 0..n {
        let (kept, li) = sample(&mut rng).expect("sampling failed");
        counts[bin_of(r, kept, li)] += 1;
    }
    counts
}

// ---------------------------------------------------------------------------------------
// Shift sampling.

fn check_sampling_chi_square(name: &str, r: &Reradiation) {
    for (j, &lo) in OUTPUTS.iter().enumerate() {
        assert!(
            r.sigma_se(lo) > 0.0,
            "{name}: no in-shifting at {lo} nm, the test would be vacuous"
        );
        let counts = histogram(r, lo, 200_000, 17 + j as u64, |rng| {
            let s = r.sample_input(lo, rng.next_f32(), rng.next_f32())?;
            Some((s.kept, s.lambda_i))
        });
        assert!(counts[0] > 0 && counts[1..].iter().any(|&c| c > 0));
        let p = chi_square_p(&counts, &expected_bins(r, lo));
        assert!(p > ALPHA, "{name} at {lo} nm: chi-square p = {p}");
    }
}

#[test]
fn dye_shift_sampling_matches_density_chi_square() {
    check_sampling_chi_square("dye 10 nm", &dye(10.0));
    check_sampling_chi_square("dye 3 nm", &dye(3.0));
}

#[test]
fn measured_shift_sampling_matches_density_chi_square() {
    check_sampling_chi_square("measured example", &measured().0);
}

/// A wrong sampler: the right keep probability, but cells drawn ∝ F·width with the
/// heaviest cell's weight doubled.
fn doubled_cell_sampler(
    r: &Reradiation,
    lambda_o: f32,
) -> impl FnMut(&mut Rng) -> Option<(bool, f32)> + '_ {
    let o = r.cell(lambda_o).unwrap();
    let mut w: Vec<f64> = (0..o)
        .map(|k| {
            let (a, b) = r.cell_bounds(k);
            f64::from(r.f(0.5 * (a + b), lambda_o)) * f64::from(b - a)
        })
        .collect();
    let heaviest = (0..o)
        .max_by(|&x, &y| w[x].partial_cmp(&w[y]).unwrap())
        .unwrap();
    w[heaviest] *= 2.0;
    let total: f64 = w.iter().sum();
    let p_keep = r.pdf_input(lambda_o, lambda_o, true);
    move |rng: &mut Rng| {
        if rng.next_f32() < p_keep {
            return Some((true, lambda_o));
        }
        let mut u = f64::from(rng.next_f32()) * total;
        let mut k = 0;
        while k + 1 < o && u >= w[k] {
            u -= w[k];
            k += 1;
        }
        let (a, b) = r.cell_bounds(k);
        Some((false, a + rng.next_f32() * (b - a)))
    }
}

#[test]
fn chi_square_rejects_a_sampler_with_one_cell_doubled() {
    for (name, r) in [("dye", dye(10.0)), ("measured", measured().0)] {
        for (j, &lo) in OUTPUTS.iter().enumerate() {
            let counts = histogram(&r, lo, 200_000, 99 + j as u64, doubled_cell_sampler(&r, lo));
            let p = chi_square_p(&counts, &expected_bins(&r, lo));
            assert!(
                p < ALPHA,
                "{name} at {lo} nm: wrong sampler accepted, p = {p}"
            );
        }
    }
}

#[test]
fn pdf_input_sums_to_one_with_the_keep_probability() {
    for (name, r) in sources() {
        let mut lo = LAMBDA_MIN + 0.37;
        while lo < LAMBDA_MAX {
            let d = r.d(lo);
            let total = d + r.sigma_se(lo);
            if total > 0.0 {
                let p_keep = r.pdf_input(lo, lo, true);
                assert!((p_keep - d / total).abs() < 1e-6, "{name} {lo}");
                let sum: f64 = expected_bins(&r, lo).iter().sum();
                assert!((sum - 1.0).abs() < 1e-5, "{name} at {lo} nm: Σ = {sum}");
                // The density agrees with f / (D + σ_se) and is 0 at and above λo.
                for li in [380.0f32, 433.3, 470.1, 505.0, 560.0, 610.9, 700.0] {
                    let expect = r.f(li, lo) / total;
                    assert!((r.pdf_input(li, lo, false) - expect).abs() <= 1e-6 * expect.max(1.0));
                    if li >= lo {
                        assert_eq!(r.pdf_input(li, lo, false), 0.0);
                    }
                }
            } else {
                assert_eq!(r.pdf_input(lo, lo, true), 0.0);
                assert!(r.sample_input(lo, 0.5, 0.5).is_none());
            }
            lo += 2.9;
        }
    }
}

#[test]
fn value_over_pdf_is_d_plus_sigma_se_for_every_sample() {
    for (name, r) in sources() {
        let mut rng = Rng::new(3, 4);
        let mut shifted = 0;
        for _ in 0..200_000 {
            let lo = LAMBDA_MIN + rng.next_f32() * (LAMBDA_MAX - LAMBDA_MIN);
            let total = r.d(lo) + r.sigma_se(lo);
            let Some(s) = r.sample_input(lo, rng.next_f32(), rng.next_f32()) else {
                assert_eq!(total, 0.0, "{name}: no sample at {lo} nm");
                continue;
            };
            assert!(s.pdf > 0.0, "{name}: {s:?}");
            assert!(
                (s.value / s.pdf - total).abs() <= 1e-5 * total,
                "{name} at {lo} nm: {s:?}, D + σ_se = {total}"
            );
            // The sample agrees with value() and pdf_input() at its own wavelengths.
            assert_eq!(s.value, r.value(s.lambda_i, lo, s.kept));
            assert!((s.pdf - r.pdf_input(s.lambda_i, lo, s.kept)).abs() <= 1e-6 * s.pdf);
            if s.kept {
                assert_eq!(s.lambda_i, lo);
            } else {
                shifted += 1;
                assert!(s.lambda_i < lo && s.lambda_i >= LAMBDA_MIN, "{name}: {s:?}");
                assert!(r.cell(s.lambda_i).unwrap() < r.cell(lo).unwrap());
            }
        }
        assert!(shifted > 1000, "{name}: only {shifted} shifts");
    }
}

/// Chi-square of the position of shifted samples inside their cell against uniform (10
/// sub-bins), pooled over every cell; `warp` distorts the position (identity = the real
/// sampler).
fn within_cell_p(r: &Reradiation, lambda_o: f32, warp: impl Fn(f32) -> f32) -> f64 {
    let mut counts = vec![0u64; 10];
    let mut rng = Rng::new(41, 7);
    let mut n = 0;
    while n < 100_000 {
        let s = r
            .sample_input(lambda_o, rng.next_f32(), rng.next_f32())
            .unwrap();
        if s.kept {
            continue;
        }
        let (a, b) = r.cell_bounds(r.cell(s.lambda_i).unwrap());
        let t = warp(((s.lambda_i - a) / (b - a)).clamp(0.0, 0.999_999));
        counts[(t * 10.0) as usize] += 1;
        n += 1;
    }
    chi_square_p(&counts, &[0.1; 10])
}

#[test]
fn shifted_wavelengths_are_uniform_within_their_cell() {
    for (name, r) in sources() {
        for lo in OUTPUTS {
            let p = within_cell_p(&r, lo, |t| t);
            assert!(p > ALPHA, "{name} at {lo} nm: p = {p}");
        }
        // Negative control: a quadratic warp of the position is rejected.
        let p = within_cell_p(&r, 550.0, |t| t * t);
        assert!(p < ALPHA, "{name}: warped positions accepted, p = {p}");
    }
}

// ---------------------------------------------------------------------------------------
// The tables.

/// ∫ g over [LAMBDA_MIN, LAMBDA_MAX) by the midpoint rule in 0.01 nm steps.
fn integrate(g: impl Fn(f32) -> f32) -> f64 {
    let steps = 47_000;
    let h = f64::from(LAMBDA_MAX - LAMBDA_MIN) / steps as f64;
    (0..steps)
        .map(|k| f64::from(g((f64::from(LAMBDA_MIN) + (k as f64 + 0.5) * h) as f32)) * h)
        .sum()
}

#[test]
fn sigma_se_and_sigma_sa_match_brute_force_integration() {
    for (name, r) in sources() {
        assert!(r.is_fluorescent(), "{name}");
        let mut l = LAMBDA_MIN + 0.13;
        let mut nonzero = (0, 0);
        while l < LAMBDA_MAX {
            let se = integrate(|li| r.f(li, l));
            let sa = integrate(|lo| r.f(l, lo));
            let (t_se, t_sa) = (f64::from(r.sigma_se(l)), f64::from(r.sigma_sa(l)));
            assert!(
                (se - t_se).abs() <= 2e-3 * t_se + 1e-7,
                "{name}: σ_se({l}) = {t_se}, integral {se}"
            );
            assert!(
                (sa - t_sa).abs() <= 2e-3 * t_sa + 1e-7,
                "{name}: σ_sa({l}) = {t_sa}, integral {sa}"
            );
            nonzero.0 += (t_se > 1e-4) as usize;
            nonzero.1 += (t_sa > 1e-4) as usize;
            l += 7.3;
        }
        assert!(nonzero.0 > 5 && nonzero.1 > 5, "{name}: {nonzero:?}");
    }
}

#[test]
fn f_is_zero_unless_the_input_cell_is_below_the_output_cell() {
    for (name, r) in sources() {
        let n = r.cells();
        let mut positive = 0;
        for i in 0..n {
            for o in 0..n {
                let (ia, ib) = r.cell_bounds(i);
                let (oa, ob) = r.cell_bounds(o);
                for t in [0.01f32, 0.5, 0.99] {
                    let (li, lo) = (ia + t * (ib - ia), oa + (1.0 - t) * (ob - oa));
                    let v = r.f(li, lo);
                    assert!(v >= 0.0 && v.is_finite());
                    if i >= o {
                        assert_eq!(v, 0.0, "{name}: F({li}, {lo}) = {v}, cells {i} ≥ {o}");
                    } else if v > 0.0 {
                        positive += 1;
                    }
                }
            }
        }
        assert!(positive > 100, "{name}");
        // Outside the renderer's range F is 0 too.
        assert_eq!(r.f(350.0, 500.0), 0.0);
        assert_eq!(r.f(450.0, 835.0), 0.0);
        assert_eq!(r.f(f32::NAN, 500.0), 0.0);
    }
}

#[test]
fn diagonal_only_never_shifts() {
    let d = tabulate(|l| 0.2 + 0.6 * gauss(l, 600.0, 80.0));
    let r = Reradiation::diagonal_only(d.clone());
    assert!(!r.is_fluorescent());
    assert!(r.energy_gain_rows().is_empty());
    let mut rng = Rng::new(1, 2);
    for _ in 0..100_000 {
        let lo = LAMBDA_MIN + rng.next_f32() * (LAMBDA_MAX - LAMBDA_MIN);
        let s = r.sample_input(lo, rng.next_f32(), rng.next_f32()).unwrap();
        assert!(s.kept && s.lambda_i == lo && s.pdf == 1.0, "{s:?}");
        assert_eq!(s.value, d.eval(lo));
        assert_eq!(s.value / s.pdf, d.eval(lo));
        assert_eq!(r.sigma_se(lo), 0.0);
        assert_eq!(r.sigma_sa(lo), 0.0);
        assert_eq!(r.f(lo - 50.0, lo), 0.0);
        assert_eq!(r.pdf_input(lo - 50.0, lo, false), 0.0);
        assert_eq!(r.pdf_input(lo, lo, true), 1.0);
    }
    // Even u_choice just below 1 keeps the wavelength.
    assert!(r.sample_input(500.0, 1.0 - f32::EPSILON, 0.5).unwrap().kept);
    // Black: the lane cannot continue.
    let black = Reradiation::diagonal_only(Spectrum::Constant(0.0));
    assert!(black.sample_input(500.0, 0.1, 0.1).is_none());
    assert_eq!(black.pdf_input(500.0, 500.0, true), 0.0);
}

#[test]
fn d4_matches_d() {
    for (name, r) in sources() {
        let l = Vec4::new(361.0, 455.5, 612.25, 829.9);
        let four = r.d4(l).to_array();
        for k in 0..4 {
            assert_eq!(four[k], r.d(l[k]), "{name} lane {k}");
        }
    }
    let r = Reradiation::diagonal_only(dye_diagonal());
    let l = Vec4::new(400.0, 440.0, 500.0, 700.0);
    assert_eq!(r.d4(l), dye_diagonal().eval4(l));
}

// ---------------------------------------------------------------------------------------
// The parametric dye.

#[test]
fn dye_sigma_sa_is_quantum_yield_times_absorption() {
    let a = dye_absorption();
    let e = dye_emission();
    for cell in [10.0, 3.0, 7.0] {
        let r = dye(cell);
        for k in 0..r.cells() {
            let (lo, hi) = r.cell_bounds(k);
            let c = 0.5 * (lo + hi);
            // Some emission above this cell?
            let emits_above = (k + 1..r.cells()).any(|o| {
                let (p, q) = r.cell_bounds(o);
                e.eval(0.5 * (p + q)) > 0.0
            });
            let expect = if emits_above { PHI * a.eval(c) } else { 0.0 };
            assert!(
                (r.sigma_sa(c) - expect).abs() <= 1e-5 * expect.max(1e-3),
                "cell {cell} nm at {c} nm: σ_sa = {}, Φ·A = {expect}",
                r.sigma_sa(c)
            );
            // The whole cell shares it.
            assert_eq!(r.sigma_sa(lo + 0.01 * (hi - lo)), r.sigma_sa(c));
        }
    }
}

#[test]
fn dye_matrix_matches_the_formula_at_cell_centres() {
    let (a, e) = (dye_absorption(), dye_emission());
    for scaling in [false, true] {
        let r =
            Reradiation::from_dye_with_scaling(dye_diagonal(), &a, &e, PHI, 10.0, scaling).unwrap();
        assert_eq!(r.cells(), 47);
        for i in 0..r.cells() {
            let ci = r.cell_centre(i);
            // ∫_{λ' > cell i} E = Σ_{o > i} E(c_o)·h
            let tail: f64 = (i + 1..r.cells())
                .map(|o| f64::from(e.eval(r.cell_centre(o))) * 10.0)
                .sum();
            let mut row = 0.0f64;
            for o in 0..r.cells() {
                let co = r.cell_centre(o);
                let mut expect = if o > i && tail > 0.0 {
                    f64::from(PHI * a.eval(ci) * e.eval(co)) / tail
                } else {
                    0.0
                };
                if scaling {
                    expect *= f64::from(ci / co);
                }
                let got = f64::from(r.f(ci, co));
                assert!(
                    (got - expect).abs() <= 1e-5 * expect + 1e-12,
                    "scaling {scaling}: F({ci}, {co}) = {got}, expected {expect}"
                );
                row += got * 10.0;
            }
            assert!((row - f64::from(r.sigma_sa(ci))).abs() < 1e-5);
            if scaling {
                // Photon yield: re-emission at longer wavelengths carries less energy.
                assert!(row <= f64::from(PHI * a.eval(ci)) + 1e-7);
                if a.eval(ci) > 0.1 && tail > 0.0 {
                    assert!(row < 0.95 * f64::from(PHI * a.eval(ci)), "{ci}: {row}");
                }
            }
        }
    }
}

#[test]
fn dye_rejects_bad_parameters() {
    let (a, e, d) = (dye_absorption(), dye_emission(), dye_diagonal());
    let err = Reradiation::from_dye(d.clone(), &a, &e, 1.5, 10.0)
        .unwrap_err()
        .to_string();
    assert!(err.contains("quantum yield"), "{err}");
    let err = Reradiation::from_dye(d.clone(), &a, &e, 0.5, 0.0)
        .unwrap_err()
        .to_string();
    assert!(err.contains("cell width"), "{err}");
    let err = Reradiation::from_dye(d.clone(), &Spectrum::Constant(1.2), &e, 0.5, 10.0)
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("absorption") && err.contains("365 nm"),
        "{err}"
    );
    let err = Reradiation::from_dye(d.clone(), &a, &Spectrum::Constant(-1.0), 0.5, 10.0)
        .unwrap_err()
        .to_string();
    assert!(err.contains("emission"), "{err}");
    let err = Reradiation::from_dye(d, &a, &Spectrum::Constant(0.0), 0.5, 10.0)
        .unwrap_err()
        .to_string();
    assert!(err.contains("emission is zero"), "{err}");
}

#[test]
fn dye_grid_covers_the_range_even_when_the_cell_does_not_divide_it() {
    let r = dye(7.0); // 470 / 7 = 67.1: 68 cells, the last clipped at 830
    assert_eq!(r.cells(), 68);
    assert_eq!(r.cell_bounds(0).0, LAMBDA_MIN);
    assert_eq!(r.cell_bounds(67).1, LAMBDA_MAX);
    assert_eq!(r.cell(829.99), Some(67));
    assert_eq!(r.cell(LAMBDA_MAX), None);
}

// ---------------------------------------------------------------------------------------
// The measured matrix.

#[test]
fn example_csv_imports_with_the_planted_defects_counted() {
    let (r, report) = measured();
    assert_eq!(
        report,
        ImportReport {
            clamped_negative: 2,
            clamped_anti_stokes: 2
        }
    );
    assert!(!report.is_clean());
    assert_eq!(r.cells(), 47);
    assert_eq!(r.cell_nm(), 10.0);
    assert_eq!(r.cell_bounds(0), (360.0, 370.0));
    assert_eq!(r.cell_bounds(46), (820.0, 830.0));
    // The planted entries are gone.
    assert_eq!(r.f(415.0, 705.0), 0.0);
    assert_eq!(r.f(435.0, 785.0), 0.0);
    assert_eq!(r.f(505.0, 485.0), 0.0);
    assert_eq!(r.f(525.0, 515.0), 0.0);
    // An ordinary entry: m = 0.02115 (365 → 515) so F = m / 10 nm, on the whole cell pair.
    assert!((r.f(365.0, 515.0) - 0.002115).abs() < 1e-9);
    assert!((r.f(361.0, 519.9) - 0.002115).abs() < 1e-9);
    // The diagonal is the matrix's, through the cell centres and flat to the outer edges.
    assert!((r.d(365.0) - 0.69867).abs() < 1e-6);
    assert!((r.d(370.0) - 0.5 * (0.69867 + 0.62331)).abs() < 1e-6);
    assert!((r.d(360.0) - 0.69867).abs() < 1e-6);
    assert!(r.d(829.9) > 0.89);
    // The synthetic dye conserves energy.
    assert!(
        r.energy_gain_rows().is_empty(),
        "{:?}",
        r.energy_gain_rows()
    );
}

/// A 4-cell matrix at 400, 410, 420, 430 nm.
fn small_matrix(rows: [&str; 4]) -> String {
    format!(
        "# test\nnm, 400, 410, 420, 430\n400, {}\n410, {}\n420, {}\n430, {}\n",
        rows[0], rows[1], rows[2], rows[3]
    )
}

#[test]
fn clamping_counts_every_changed_entry_once() {
    let text = small_matrix([
        "0.5, 0.1, -0.02, 0.0",   // one negative
        "0.3, -0.4, 0.05, 0.01",  // anti-Stokes (0.3), negative diagonal
        "-0.1, 0.0, 0.6, -0.001", // negative anti-Stokes (counted as anti-Stokes), negative
        "0.0, 0.0, 0.2, 0.7",     // anti-Stokes
    ]);
    let path = scratch("clamp.csv", &text);
    let (r, report) = Reradiation::from_csv(&path).unwrap();
    assert_eq!(report.clamped_negative, 3);
    assert_eq!(report.clamped_anti_stokes, 3);
    assert_eq!(r.d(410.0), 0.0); // the negative diagonal became 0
    assert!((r.d(400.0) - 0.5).abs() < 1e-7);
    assert!((r.f(400.0, 410.0) - 0.01).abs() < 1e-8); // m / h
    assert_eq!(r.f(400.0, 420.0), 0.0);
    assert!((r.sigma_sa(410.0) - 0.06).abs() < 1e-6);
    assert!((r.sigma_se(430.0) - 0.01).abs() < 1e-6);
    let clean = small_matrix([
        "0.5, 0.1, 0, 0",
        "0, 0.5, 0.1, 0",
        "0, 0, 0.5, 0",
        "0, 0, 0, 0.5",
    ]);
    let (_, report) = Reradiation::from_csv_str(&clean, "clean.csv").unwrap();
    assert!(report.is_clean());
    // Whitespace separation works too.
    let ws = clean.replace(',', " ");
    let (r, _) = Reradiation::from_csv_str(&ws, "ws.csv").unwrap();
    assert!((r.f(400.0, 410.0) - 0.01).abs() < 1e-8);
}

#[test]
fn csv_errors_name_the_file_and_line() {
    let ok = [
        "0.5, 0.1, 0, 0",
        "0, 0.5, 0.1, 0",
        "0, 0, 0.5, 0",
        "0, 0, 0, 0.5",
    ];
    let check = |name: &str, text: &str, line: usize, words: &[&str]| {
        let path = scratch(name, text);
        let e = Reradiation::from_csv(&path).unwrap_err().to_string();
        let prefix = format!("{}:{line}:", path.display());
        assert!(e.starts_with(&prefix), "expected '{prefix}…', got: {e}");
        for w in words {
            assert!(e.contains(w), "'{w}' missing from: {e}");
        }
    };
    // Ragged row (line 4 is the second data row).
    let mut rows = ok;
    rows[1] = "0, 0.5, 0.1";
    check(
        "ragged.csv",
        &small_matrix(rows),
        4,
        &["expected 5 fields", "found 4"],
    );
    // Not a number.
    let mut rows = ok;
    rows[2] = "0, 0, abc, 0";
    check("nan.csv", &small_matrix(rows), 5, &["column 4", "'abc'"]);
    let mut rows = ok;
    rows[0] = "0.5, inf, 0, 0";
    check("inf.csv", &small_matrix(rows), 3, &["finite", "column 3"]);
    // Non-uniform emission grid (header on line 2).
    let text = small_matrix(ok).replace("nm, 400, 410, 420, 430", "nm, 400, 410, 425, 430");
    check("uneven.csv", &text, 2, &["evenly spaced", "425"]);
    // Excitation grid differs from the emission grid.
    let text = small_matrix(ok).replace("\n420, ", "\n421, ");
    check("grids.csv", &text, 5, &["excitation wavelength 421", "420"]);
    // Missing and extra rows.
    let text = "nm, 400, 410, 420\n400, 0.5, 0, 0\n410, 0, 0.5, 0\n";
    check("short.csv", text, 3, &["2 excitation row", "420 nm"]);
    let text = "nm, 400, 410\n400, 0.5, 0\n410, 0, 0.5\n420, 0, 0.5\n";
    check("long.csv", text, 4, &["too many"]);
    // A header that is a number, or too short.
    check("nohdr.csv", "400, 0.5, 0\n410, 0, 0.5\n", 1, &["header"]);
    check(
        "hdr1.csv",
        "# c\n\nnm, 400\n400, 0.5\n",
        3,
        &["at least 2 wavelengths"],
    );
    // No data and no file.
    let path = scratch("empty.csv", "# nothing\n");
    let e = Reradiation::from_csv(&path).unwrap_err().to_string();
    assert!(
        e.starts_with(&format!("{}:", path.display())) && e.contains("no data"),
        "{e}"
    );
    let missing = Path::new("/nonexistent/stokes/matrix.csv");
    let e = Reradiation::from_csv(missing).unwrap_err().to_string();
    assert!(
        e.starts_with("/nonexistent/stokes/matrix.csv: cannot read"),
        "{e}"
    );
}

#[test]
fn energy_gain_rows_name_the_wavelength() {
    let text = small_matrix([
        "0.5, 0.1, 0, 0",
        "0, 0.7, 0.3, 0.2", // 1.2 at 410 nm
        "0, 0, 0.5, 0.1",
        "0, 0, 0, 1.0", // exactly 1: not a gain
    ]);
    let (r, _) = Reradiation::from_csv_str(&text, "gain.csv").unwrap();
    let rows = r.energy_gain_rows();
    assert_eq!(rows.len(), 1, "{rows:?}");
    assert_eq!(rows[0].0, 410.0);
    assert!((rows[0].1 - 1.2).abs() < 1e-6, "{rows:?}");

    // A dye whose diagonal ignores the absorption: D + Φ·A > 1 in the absorption band.
    let r = Reradiation::from_dye(
        Spectrum::Constant(0.5),
        &dye_absorption(),
        &dye_emission(),
        1.0,
        10.0,
    )
    .unwrap();
    let rows = r.energy_gain_rows();
    assert!(!rows.is_empty());
    let a = dye_absorption();
    for &(l, total) in &rows {
        assert!(
            a.eval(l) > 0.5 - 1e-3,
            "{l} nm reported with A = {}",
            a.eval(l)
        );
        assert!((total - (0.5 + a.eval(l))).abs() < 1e-4, "{l}: {total}");
    }
    assert!(rows.iter().any(|&(l, _)| l == 445.0), "{rows:?}");
    // with_diagonal fixes it without touching F.
    let fixed = r.clone().with_diagonal(Spectrum::Constant(0.05));
    assert!(fixed.energy_gain_rows().is_empty());
    assert_eq!(fixed.f(445.0, 525.0), r.f(445.0, 525.0));
}
