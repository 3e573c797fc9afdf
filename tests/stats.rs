//! Self-tests of the statistical harness in `tests/common/stats.rs` that every sampling
//! test relies on: the chi-square p-value against tabulated quantiles, and the test's
//! pooling, impossible-event and normalisation rules. (They live here, once, rather than in
//! each test file that uses the harness.)

mod common;
use common::stats::{chi2_p_value, chi_square, gamma_q, perturbed, Rng};

#[test]
fn chi2_p_value_matches_known_quantiles() {
    // 0.999 quantiles of χ² (tables): dof 1, 2, 5, 10, 30, 63.
    for (dof, q) in [
        (1, 10.828),
        (2, 13.816),
        (5, 20.515),
        (10, 29.588),
        (30, 59.703),
        (63, 103.442),
    ] {
        let p = chi2_p_value(q, dof);
        assert!((p - 1e-3).abs() < 2e-6, "dof {dof}: {p}");
    }
    // Other tabulated points: P(χ²₁ > 3.841) = 0.05, P(χ²₁₀ > 23.21) = 0.01,
    // P(χ²₄₆ > 81.40) ≈ 1e-3, the median of χ²₄₆ ≈ 45.3.
    assert!((chi2_p_value(3.841_459, 1) - 0.05).abs() < 1e-5);
    assert!((chi2_p_value(23.209_25, 10) - 0.01).abs() < 1e-5);
    let p46 = chi2_p_value(81.400, 46);
    assert!((p46 - 1e-3).abs() < 5e-5, "{p46}");
    assert!((chi2_p_value(46.0, 46) - 0.472).abs() < 0.01);
    assert!((chi2_p_value(3.0, 5) - 0.699_985_836).abs() < 1e-8);
    // The far tail the must-fail controls use: 1e-6 quantiles of dof 1 (z = 4.8916) and
    // dof 2 (−2 ln 1e-6).
    assert!((chi2_p_value(23.928_127, 1) / 1e-6 - 1.0).abs() < 1e-5);
    assert!((chi2_p_value(27.631_021, 2) / 1e-6 - 1.0).abs() < 1e-5);
    // dof 2 is exponential: Q(1, x) = e^{−x}; both branches of gamma_q around a + 1.
    for x in [0.3, 1.9, 7.0, 40.0] {
        assert!((gamma_q(1.0, x) - (-x).exp()).abs() < 1e-12);
    }
    assert!((gamma_q(3.0, 1.0) - 0.919_698_602_928_605_6).abs() < 1e-12);
    assert!((gamma_q(3.0, 7.0) - 0.029_636_163_880_521_67).abs() < 1e-12);
}

#[test]
fn chi_square_rejects_and_accepts() {
    let e = vec![1000.0; 10];
    let fair = [990, 1012, 1003, 985, 1021, 998, 1007, 979, 1010, 995];
    assert!(chi_square(&fair, &e).p_value > 0.1);
    let skewed = [1100, 1100, 1100, 1100, 1100, 900, 900, 900, 900, 900];
    assert!(chi_square(&skewed, &e).p_value < 1e-6);
    // An observation where nothing is expected.
    let r = chi_square(&[10, 0, 1], &[11.0, 0.0, 0.0]);
    assert_eq!(r.p_value, 0.0);
    assert_eq!(r.impossible, Some((2, 1)));
}

#[test]
fn chi_square_pools_cells_expecting_fewer_than_five() {
    // Three cells of 1 pool into one of 3, which joins the smallest regular cell (10).
    let r = chi_square(&[50, 40, 10, 1, 1, 1], &[50.0, 40.0, 10.0, 1.0, 1.0, 1.0]);
    assert_eq!(r.dof, 2);
    assert_eq!(r.statistic, 0.0);
    // Six cells of 1 make a pool of their own.
    let r = chi_square(
        &[50, 40, 1, 1, 1, 1, 1, 1],
        &[50.0, 40.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0],
    );
    assert_eq!(r.dof, 2);
    // Cells expecting 0 and observing 0 carry no degree of freedom.
    let r = chi_square(&[60, 40, 0, 0], &[50.0, 50.0, 0.0, 0.0]);
    assert_eq!(r.dof, 1);
    assert!((r.statistic - 4.0).abs() < 1e-12);
}

#[test]
#[should_panic(expected = "expected counts sum to")]
fn chi_square_refuses_expected_counts_with_another_total() {
    // Probabilities instead of counts.
    chi_square(&[5, 5], &[0.5, 0.5]);
}

#[test]
fn perturbed_scales_one_region_and_keeps_the_total() {
    let p = perturbed(&[0.25, 0.25, 0.5], |i| i == 2, 1.1);
    let t = 0.25 + 0.25 + 0.55;
    for (a, b) in p.iter().zip([0.25 / t, 0.25 / t, 0.55 / t]) {
        assert!((a - b).abs() < 1e-15);
    }
}

#[test]
fn rng_is_the_renderers_pcg32() {
    let mut a = Rng::new(7, 3);
    let mut b = stokes::sampler::Pcg32::new(7, 3);
    for _ in 0..100 {
        assert_eq!(a.next_f32(), b.next_f32());
    }
    for _ in 0..1000 {
        let v = a.unit_vector();
        assert!((v.length() - 1.0).abs() < 1e-5);
    }
}
