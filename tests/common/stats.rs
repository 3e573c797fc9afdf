//! The statistical machinery of the tests (no dependencies): one random-number generator,
//! one chi-square goodness-of-fit test and its p-value (the regularised upper incomplete
//! gamma function at the half-integer arguments a chi-square test needs).

use std::fmt;
use stokes::sampler::Pcg32;

// ---------------------------------------------------------------------------------------
// Random numbers.

/// The random-number generator of the tests: the renderer's PCG32, so a (seed, stream)
/// pair names one reproducible sequence.
#[derive(Clone, Debug)]
pub struct Rng(Pcg32);

impl Rng {
    /// The sequence of `seed` on stream `stream` (the same as `Pcg32::new(seed, stream)`).
    pub fn new(seed: u64, stream: u64) -> Rng {
        Rng(Pcg32::new(seed, stream))
    }

    /// Uniform in [0, 1) with 24 random bits (every value exactly representable).
    pub fn next_f32(&mut self) -> f32 {
        self.0.next_f32()
    }

    /// Two uniforms in [0, 1).
    pub fn next_2d(&mut self) -> [f32; 2] {
        self.0.next_2d()
    }

    /// Three uniforms in [0, 1).
    pub fn next_3d(&mut self) -> [f32; 3] {
        [self.0.next_f32(), self.0.next_f32(), self.0.next_f32()]
    }

    /// A uniformly distributed unit vector.
    pub fn unit_vector(&mut self) -> glam::Vec3 {
        let z = 1.0 - 2.0 * self.next_f32();
        let r = (1.0 - z * z).max(0.0).sqrt();
        let phi = std::f32::consts::TAU * self.next_f32();
        glam::Vec3::new(r * phi.cos(), r * phi.sin(), z)
    }
}

// ---------------------------------------------------------------------------------------
// Pearson's chi-square test.

/// The outcome of a chi-square goodness-of-fit test.
#[derive(Debug, Clone)]
pub struct ChiSquare {
    /// Pearson's statistic Σ (o − e)²/e over the pooled cells.
    pub statistic: f64,
    /// Degrees of freedom: pooled cells − 1.
    pub dof: usize,
    /// P(χ²_dof ≥ statistic); 0 after an impossible observation.
    pub p_value: f64,
    /// The first cell holding observations although its expected count is 0, with its
    /// count: an event the model forbids, which no goodness of fit can excuse.
    pub impossible: Option<(usize, u64)>,
}

impl fmt::Display for ChiSquare {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if let Some((cell, count)) = self.impossible {
            return write!(
                f,
                "cell {cell} holds {count} observations where none are expected (p = 0)"
            );
        }
        write!(
            f,
            "χ² = {:.1}, dof {}, p = {:.3e}",
            self.statistic, self.dof, self.p_value
        )
    }
}

impl ChiSquare {
    /// Panics (naming `what`) unless the test accepts at significance `alpha`.
    #[track_caller]
    pub fn assert_accepts(&self, alpha: f64, what: &str) {
        assert!(
            self.p_value > alpha,
            "{what}: rejected at significance {alpha:e}: {self}"
        );
    }

    /// Panics (naming `what`) unless the test rejects at significance `alpha`.
    #[track_caller]
    pub fn assert_rejects(&self, alpha: f64, what: &str) {
        assert!(
            self.p_value < alpha,
            "{what}: a wrong distribution was accepted at significance {alpha:e}: {self}"
        );
    }
}

/// Pearson's chi-square test of `observed` counts against `expected` counts, which must
/// have the same total (to 1e-3 relative: a model whose probabilities do not sum to 1
/// needs a cell for the missing mass).
///
/// Cells expecting fewer than 5 observations are pooled into one cell (which joins the
/// smallest regular cell if it still expects fewer than 5). Observations in a cell that
/// expects none make the test fail whatever the rest: p = 0, `impossible` names the cell,
/// and a line goes to stderr.
pub fn chi_square(observed: &[u64], expected: &[f64]) -> ChiSquare {
    assert_eq!(
        observed.len(),
        expected.len(),
        "chi-square: {} observed cells but {} expected",
        observed.len(),
        expected.len()
    );
    if let Some(i) = expected.iter().position(|e| !(e.is_finite() && *e >= 0.0)) {
        panic!("chi-square: expected count {} in cell {i}", expected[i]);
    }
    let n_obs: u64 = observed.iter().sum();
    let n_exp: f64 = expected.iter().sum();
    assert!(
        (n_exp - n_obs as f64).abs() <= 1e-3 * (n_obs as f64).max(1.0),
        "chi-square: the expected counts sum to {n_exp}, but there are {n_obs} observations"
    );
    let impossible = observed
        .iter()
        .zip(expected)
        .position(|(&o, &e)| o > 0 && e == 0.0)
        .map(|i| (i, observed[i]));
    if let Some((cell, count)) = impossible {
        eprintln!("chi-square: cell {cell} holds {count} observations where none are expected");
        return ChiSquare {
            statistic: f64::INFINITY,
            dof: expected.len().saturating_sub(1),
            p_value: 0.0,
            impossible,
        };
    }
    let cells = pool_small_cells(observed, expected);
    let statistic: f64 = cells.iter().map(|&(o, e)| (o - e) * (o - e) / e).sum();
    let dof = cells.len().saturating_sub(1);
    let p_value = if dof == 0 {
        1.0
    } else {
        chi2_p_value(statistic, dof)
    };
    ChiSquare {
        statistic,
        dof,
        p_value,
        impossible: None,
    }
}

/// (observed, expected) per cell after pooling the cells that expect fewer than 5.
fn pool_small_cells(observed: &[u64], expected: &[f64]) -> Vec<(f64, f64)> {
    let mut cells: Vec<(f64, f64)> = Vec::new();
    let (mut pool_o, mut pool_e) = (0.0, 0.0);
    for (&o, &e) in observed.iter().zip(expected) {
        if e < 5.0 {
            pool_o += o as f64;
            pool_e += e;
        } else {
            cells.push((o as f64, e));
        }
    }
    if pool_e >= 5.0 {
        cells.push((pool_o, pool_e));
    } else if pool_e > 0.0 {
        match cells
            .iter_mut()
            .min_by(|a, b| a.1.partial_cmp(&b.1).unwrap())
        {
            Some(c) => {
                c.0 += pool_o;
                c.1 += pool_e;
            }
            None => cells.push((pool_o, pool_e)),
        }
    }
    cells
}

/// A copy of `probabilities` with the cells where `in_region` holds scaled by `factor`,
/// renormalised to the same total: the expected distribution of a model that is wrong
/// by `factor` in one region (for the must-fail controls).
pub fn perturbed(
    probabilities: &[f64],
    in_region: impl Fn(usize) -> bool,
    factor: f64,
) -> Vec<f64> {
    let total: f64 = probabilities.iter().sum();
    let scaled: Vec<f64> = probabilities
        .iter()
        .enumerate()
        .map(|(i, &p)| if in_region(i) { p * factor } else { p })
        .collect();
    let new_total: f64 = scaled.iter().sum();
    scaled.iter().map(|p| p * total / new_total).collect()
}

// ---------------------------------------------------------------------------------------
// The chi-square distribution.

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
