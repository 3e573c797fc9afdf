//! Chi-square p-values for the statistical tests (no dependencies): the regularised upper
//! incomplete gamma function at the half-integer arguments a chi-square test needs.

/// ln Γ(a) for a a positive multiple of 1/2 (all a chi-square test needs), exactly.
pub fn ln_gamma_half(a: f64) -> f64 {
    let twice = (2.0 * a).round() as i64;
    assert!(twice >= 1 && (2.0 * a - twice as f64).abs() < 1e-9);
    if twice % 2 == 0 {
        (1..twice / 2).map(|k| (k as f64).ln()).sum()
    } else {
        // Γ(m + 1/2) = √π · Π_{k<m} (k + 1/2)
        let m = (twice - 1) / 2;
        0.5 * std::f64::consts::PI.ln() + (0..m).map(|k| (k as f64 + 0.5).ln()).sum::<f64>()
    }
}

/// Regularised upper incomplete gamma Q(a, x): series below a + 1, continued fraction
/// (modified Lentz) above.
pub fn gamma_q(a: f64, x: f64) -> f64 {
    if x <= 0.0 {
        return 1.0;
    }
    let prefactor = (-x + a * x.ln() - ln_gamma_half(a)).exp();
    if x < a + 1.0 {
        let (mut term, mut sum, mut ap) = (1.0 / a, 1.0 / a, a);
        for _ in 0..10_000 {
            ap += 1.0;
            term *= x / ap;
            sum += term;
            if term.abs() < sum.abs() * 1e-15 {
                break;
            }
        }
        (1.0 - sum * prefactor).max(0.0)
    } else {
        let tiny = 1e-300;
        let mut b = x + 1.0 - a;
        let mut c = 1.0 / tiny;
        let mut d = 1.0 / b;
        let mut h = d;
        for i in 1..10_000 {
            let an = -(i as f64) * (i as f64 - a);
            b += 2.0;
            d = an * d + b;
            if d.abs() < tiny {
                d = tiny;
            }
            c = b + an / c;
            if c.abs() < tiny {
                c = tiny;
            }
            d = 1.0 / d;
            let delta = d * c;
            h *= delta;
            if (delta - 1.0).abs() < 1e-15 {
                break;
            }
        }
        prefactor * h
    }
}

/// P(χ²_dof ≥ x).
pub fn chi2_p_value(x: f64, dof: usize) -> f64 {
    gamma_q(dof as f64 / 2.0, x / 2.0)
}
