//! Chi-square tests of sampled directions: (cos θ, φ) cells of equal solid angle around
//! a normal, each cell's probability under a solid-angle pdf by Gauss–Legendre
//! quadrature of any order, a "no sample" cell, and must-fail controls.
//!
//! The frame and the directions are built here, independently of `stokes::bsdf`.

use super::stats::{chi_square, perturbed, ChiSquare, Rng};
use glam::{DVec3, Vec3};
use std::f64::consts::TAU;

// ---------------------------------------------------------------------------------------
// Gauss–Legendre quadrature.

/// The nodes (ascending, in (−1, 1)) and weights of the `order`-point Gauss–Legendre rule:
/// Newton's method on P_order from the Chebyshev-like first guess, the Legendre
/// polynomials by their three-term recurrence.
pub fn gauss_legendre(order: usize) -> (Vec<f64>, Vec<f64>) {
    assert!(order >= 1, "a Gauss–Legendre rule needs at least one node");
    let n = order as f64;
    // P_n(x) and P_n'(x).
    let legendre = |x: f64| {
        let (mut p0, mut p1) = (1.0, x);
        for k in 2..=order {
            let k = k as f64;
            let p2 = ((2.0 * k - 1.0) * x * p1 - (k - 1.0) * p0) / k;
            p0 = p1;
            p1 = p2;
        }
        // (1 − x²) P_n' = n (P_{n−1} − x P_n)
        (p1, n * (p0 - x * p1) / (1.0 - x * x))
    };
    let mut nodes = vec![0.0; order];
    let mut weights = vec![0.0; order];
    for i in 0..order {
        // The i-th root from the top, then Newton to machine precision.
        let mut x = (std::f64::consts::PI * (i as f64 + 0.75) / (n + 0.5)).cos();
        for _ in 0..100 {
            let (p, dp) = legendre(x);
            let dx = p / dp;
            x -= dx;
            if dx.abs() < 1e-16 {
                break;
            }
        }
        let (_, dp) = legendre(x);
        nodes[order - 1 - i] = x;
        weights[order - 1 - i] = 2.0 / ((1.0 - x * x) * dp * dp);
    }
    (nodes, weights)
}

// ---------------------------------------------------------------------------------------
// Directions.

/// An orthonormal frame (t, b, n) around `n`, built here independently of `bsdf::basis`.
pub fn frame(n: DVec3) -> (DVec3, DVec3, DVec3) {
    let helper = if n.x.abs() < 0.9 { DVec3::X } else { DVec3::Y };
    let t = helper.cross(n).normalize();
    (t, n.cross(t), n)
}

/// The unit direction at cosine `c` to `n` and azimuth `phi` in `frame(n)`.
pub fn direction(n: DVec3, c: f64, phi: f64) -> DVec3 {
    let (t, b, n) = frame(n);
    let s = (1.0 - c * c).max(0.0).sqrt();
    t * (s * phi.cos()) + b * (s * phi.sin()) + n * c
}

/// How much probability a pdf must hold.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mass {
    /// All of it (to 1e-6): the sampler always returns a direction.
    One,
    /// At most 1 (+ 1e-4 for the quadrature): the missing mass is the probability that
    /// the sampler returns no direction (the last cell).
    AtMostOne,
}

/// (cos θ, φ) cells of equal solid angle over the sphere around a unit normal `n`, with
/// the cell probabilities integrated by `order` × `order` Gauss–Legendre nodes per cell.
#[derive(Debug, Clone, Copy)]
pub struct Grid {
    /// The axis (unit).
    pub n: DVec3,
    /// Cells in cos θ over [−1, 1] (even, so that the horizon is a cell edge).
    pub n_cos: usize,
    /// Cells in φ.
    pub n_phi: usize,
    /// Gauss–Legendre order per cell and dimension.
    pub order: usize,
}

impl Grid {
    /// The direction cells; the cell with this index is "no sample".
    pub fn cells(&self) -> usize {
        self.n_cos * self.n_phi
    }

    /// The cell of unit direction `w`.
    pub fn cell_of(&self, w: DVec3) -> usize {
        let (t, b, n) = frame(self.n);
        let c = w.dot(n).clamp(-1.0, 1.0);
        let phi = w.dot(b).atan2(w.dot(t)).rem_euclid(TAU);
        let i = (((c + 1.0) * 0.5 * self.n_cos as f64) as usize).min(self.n_cos - 1);
        let j = ((phi / TAU * self.n_phi as f64) as usize).min(self.n_phi - 1);
        i * self.n_phi + j
    }

    /// Whether cell `k` (not "no sample") lies where |cos θ| > 1/2.
    pub fn near_pole(&self, k: usize) -> bool {
        k < self.cells() && !(self.n_cos / 4..3 * self.n_cos / 4).contains(&(k / self.n_phi))
    }

    /// The probability of each cell under the solid-angle density `pdf`, and last the
    /// probability of no sample, 1 − ∫ pdf (0 for [`Mass::One`], where it is asserted).
    pub fn probabilities(&self, pdf: impl Fn(DVec3) -> f64, mass: Mass) -> Vec<f64> {
        let (x, w) = gauss_legendre(self.order);
        let (dc, dphi) = (2.0 / self.n_cos as f64, TAU / self.n_phi as f64);
        let mut p = vec![0.0; self.cells() + 1];
        for i in 0..self.n_cos {
            for j in 0..self.n_phi {
                let (c0, phi0) = (-1.0 + i as f64 * dc, j as f64 * dphi);
                let mut s = 0.0;
                for (xa, wa) in x.iter().zip(&w) {
                    for (xb, wb) in x.iter().zip(&w) {
                        let c = c0 + 0.5 * dc * (1.0 + xa);
                        let phi = phi0 + 0.5 * dphi * (1.0 + xb);
                        s += wa * wb * pdf(direction(self.n, c, phi));
                    }
                }
                // dω = dcos θ dφ.
                p[i * self.n_phi + j] = s * 0.25 * dc * dphi;
            }
        }
        let total: f64 = p.iter().sum();
        match mass {
            Mass::One => assert!((total - 1.0).abs() < 1e-6, "the pdf integrates to {total}"),
            Mass::AtMostOne => {
                assert!(total <= 1.0 + 1e-4, "the pdf integrates to {total} > 1");
                p[self.cells()] = (1.0 - total).max(0.0);
            }
        }
        p
    }
}

/// Where a must-fail control's expected distribution is wrong.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Region {
    /// The cells where |cos θ| > 1/2.
    NearPole,
    /// The densest cells that together hold half the probability: a pdf too peaked.
    DensestHalf,
}

/// Sampled directions binned on a grid, with the cell probabilities of a pdf.
#[derive(Debug, Clone)]
pub struct Binned {
    /// Observations per cell (last: no sample).
    pub counts: Vec<u64>,
    /// Probabilities per cell (last: no sample).
    pub probabilities: Vec<f64>,
}

impl Binned {
    /// Bins `samples` directions of `sample` (`None`: no sample), drawn with the random
    /// numbers of (`seed`, stream 3), against the density `pdf`.
    pub fn new(
        grid: &Grid,
        seed: u64,
        samples: usize,
        mut sample: impl FnMut(&mut Rng) -> Option<Vec3>,
        pdf: impl Fn(DVec3) -> f64,
        mass: Mass,
    ) -> Binned {
        let mut rng = Rng::new(seed, 3);
        let mut counts = vec![0u64; grid.cells() + 1];
        for _ in 0..samples {
            match sample(&mut rng) {
                Some(w) => counts[grid.cell_of(w.as_dvec3())] += 1,
                None => counts[grid.cells()] += 1,
            }
        }
        Binned {
            counts,
            probabilities: grid.probabilities(pdf, mass),
        }
    }

    /// The chi-square test against the pdf, or (`control` = Some((region, factor))) a
    /// pdf wrong by `factor` in `region`, then renormalised.
    pub fn chi_square(&self, grid: &Grid, control: Option<(Region, f64)>) -> ChiSquare {
        let p = match control {
            None => self.probabilities.clone(),
            Some((Region::NearPole, f)) => perturbed(&self.probabilities, |k| grid.near_pole(k), f),
            Some((Region::DensestHalf, f)) => {
                let dense = densest_half(&self.probabilities[..grid.cells()]);
                perturbed(&self.probabilities, |k| k < grid.cells() && dense[k], f)
            }
        };
        let n: u64 = self.counts.iter().sum();
        let expected: Vec<f64> = p.iter().map(|q| q * n as f64).collect();
        chi_square(&self.counts, &expected)
    }
}

/// The cells, densest first, that together just reach half of the total probability.
fn densest_half(p: &[f64]) -> Vec<bool> {
    let mut order: Vec<usize> = (0..p.len()).collect();
    order.sort_by(|&a, &b| p[b].total_cmp(&p[a]));
    let total: f64 = p.iter().sum();
    let mut dense = vec![false; p.len()];
    let mut acc = 0.0;
    for k in order {
        if acc >= 0.5 * total {
            break;
        }
        dense[k] = true;
        acc += p[k];
    }
    dense
}

/// Chi-square of `samples` directions from `sample` against `pdf` on `grid`, with the
/// expected distribution wrong by `wrong_by` where |cos θ| > 1/2 (1 for the real test).
pub fn direction_chi_square(
    grid: &Grid,
    seed: u64,
    samples: usize,
    sample: impl FnMut(&mut Rng) -> Option<Vec3>,
    pdf: impl Fn(DVec3) -> f64,
    wrong_by: f64,
) -> ChiSquare {
    let b = Binned::new(grid, seed, samples, sample, pdf, Mass::One);
    let control = (wrong_by != 1.0).then_some((Region::NearPole, wrong_by));
    b.chi_square(grid, control)
}
