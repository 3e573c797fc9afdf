//! The four wavelengths a path carries, and how they are drawn.
//!
//! Hero wavelength spectral sampling (Wilkie et al. 2014): the hero λ₀ is drawn from a pdf
//! p over [[`LAMBDA_MIN`], [`LAMBDA_MAX`]) by inverting its CDF at a uniform u, and the
//! other lanes sit at the CDF positions u + k/4 (k = 1, 2, 3), wrapped back into [0, 1).
//! The offsets are a rotation of the circle [0, 1) forms, so every lane is *marginally*
//! distributed as p too, and the four "lane j as hero" techniques have the same density
//! in u: the lanes' MIS weights hold only their path pdfs, and the film divides each
//! lane by its own p(λ_k) ([`Wavelengths::film_weight`]).
//!
//! Two pdfs ([`Wavelengths`], the `wavelengths` axis of the method):
//! - `uniform`: p = 1/Δ, Δ = MAX − MIN, so the lanes are Δ/4 apart;
//! - `visible`: p ∝ |(r̄, ḡ, b̄)(λ)|, the length of the linear-sRGB colour-matching
//!   functions, plus a floor of [`VISIBLE_FLOOR`] of its peak, piecewise constant on 1 nm
//!   cells. A third of the uniform range (below 400 and above 700 nm) carries almost
//!   nothing the observer sees; this pdf puts the lanes where it looks, while the floor
//!   keeps every wavelength possible (spectral output, UV-lit scenes) and bounds r̄ḡb̄/p,
//!   so no lane's weight can blow up.

use crate::simd::{map4, Float, Lanes, Spec};
use glam::Vec4;
use std::sync::OnceLock;

use super::{cie_xyz, LAMBDA_MAX, LAMBDA_MIN, LAMBDA_RANGE};
use crate::color::xyz_to_linear_srgb;

/// Largest `f32` strictly below [`LAMBDA_MAX`]: keeps sampled wavelengths in the half-open
/// range even when `MIN + u·Δ` rounds up to `MAX`.
const LAMBDA_BELOW_MAX: f32 = 829.999_94;

/// The visible pdf's floor, as a fraction of the peak of |r̄ḡb̄|: high enough that the ends
/// of the range are still sampled (the largest film weight stays small), low enough that
/// the lanes stay where the observer looks.
pub const VISIBLE_FLOOR: f64 = 0.05;

/// How the hero wavelength is drawn: the `wavelengths` axis of a method.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Wavelengths {
    /// By visible importance (|r̄ḡb̄| with a floor). The default: it measures faster to
    /// the same error on every scene (README, "Visible wavelengths").
    #[default]
    Visible,
    /// Uniform over the whole range.
    Uniform,
}

/// The visible pdf's cells: 1 nm over [MIN, MAX).
const CELLS: usize = super::NM_CELLS;

/// Buckets of the guide table: fine enough that no bucket holds more than one interior
/// cell edge (a test checks it; the smallest cell holds 1/3,498 of the CDF), so the cell of
/// any u is its bucket's first cell or the one after it.
const GUIDE: usize = 4096;

/// The visible pdf: a density per 1 nm cell, its CDF at the cell edges, and a guide that
/// turns the CDF search into a look-up and one branch-free step (a binary search's
/// unpredictable branches cost a fifth of a Cornell box sample; a stepping loop's random
/// trip count cost packets 17 % at depth 1).
struct VisibleTable {
    /// (CDF at its start, p) of cell i = [MIN + i, MIN + i + 1), p in nm⁻¹; the entry
    /// `CELLS` is (1, 0): the end of the last cell. One load gives both.
    cells: [[f32; 2]; CELLS + 1],
    /// 1/(p·Δ) on cell i: the film's lane weight.
    weight: [f32; CELLS],
    /// The cell that holds u = j/GUIDE.
    guide: [u16; GUIDE],
}

fn visible_table() -> &'static VisibleTable {
    static TABLE: OnceLock<VisibleTable> = OnceLock::new();
    TABLE.get_or_init(|| {
        let shape: Vec<f64> = (0..CELLS)
            .map(|i| {
                // The cell's mean of |r̄ḡb̄| (trapezoid on the 1 nm table).
                let at = |l: f32| xyz_to_linear_srgb(cie_xyz(l)).length() as f64;
                let lo = LAMBDA_MIN + i as f32;
                0.5 * (at(lo) + at(lo + 1.0))
            })
            .collect();
        let peak = shape.iter().cloned().fold(0.0, f64::max);
        let weight: Vec<f64> = shape.iter().map(|s| s + VISIBLE_FLOOR * peak).collect();
        let total: f64 = weight.iter().sum();
        let mut cells = [[1.0, 0.0]; CELLS + 1];
        let mut acc = 0.0;
        for (cell, w) in cells.iter_mut().zip(&weight) {
            *cell = [acc as f32, (w / total) as f32];
            acc += w / total;
        }
        let cell_of = |u: f32| (cells.partition_point(|c| c[0] <= u).max(1) - 1).min(CELLS - 1);
        let guide = std::array::from_fn(|j| cell_of(j as f32 / GUIDE as f32) as u16);
        let weight = std::array::from_fn(|i| 1.0 / (cells[i][1] * LAMBDA_RANGE));
        VisibleTable {
            cells,
            weight,
            guide,
        }
    })
}

/// The 1 nm cell that holds λ, if λ is in [MIN, MAX) (not for NaN).
#[inline]
fn cell(lambda: f32) -> Option<usize> {
    let f = lambda - LAMBDA_MIN;
    (0.0..LAMBDA_RANGE)
        .contains(&f)
        .then(|| (f as usize).min(CELLS - 1))
}

impl VisibleTable {
    /// The wavelengths at CDF positions `u` ∈ [0, 1) of W paths. The cell is u's guide
    /// entry or the next one; within it the CDF is linear, so λ = MIN + i + (u − cdfᵢ)/pᵢ.
    /// Every width runs the same arithmetic (the scalar [`Wavelengths::sample`] is width 1).
    #[inline(always)]
    fn sample_w<F: Float>(&self, u: F) -> F {
        let bucket = (u * F::splat(GUIDE as f32)).to_index();
        let cell: F::Arr<usize> = Lanes::from_fn(|l| {
            let i = self.guide[(bucket[l] as usize).min(GUIDE - 1)] as usize;
            (i + (self.cells[i + 1][0] <= u.get(l)) as usize).min(CELLS - 1)
        });
        let rows: F::Arr<[f32; 2]> = Lanes::from_fn(|l| self.cells[cell[l]]);
        let (cdf, p) = (F::from_fn(|l| rows[l][0]), F::from_fn(|l| rows[l][1]));
        let t = ((u - cdf) / p).clamp(0.0, 1.0);
        let start = F::splat(LAMBDA_MIN) + F::from_fn(|l| cell[l] as f32);
        (start + t).clamp(LAMBDA_MIN, LAMBDA_BELOW_MAX)
    }

    /// p(λ), 0 outside [MIN, MAX).
    #[inline]
    fn pdf(&self, lambda: f32) -> f32 {
        cell(lambda).map_or(0.0, |i| self.cells[i][1])
    }

    /// The CDF at λ: the u that [`Self::sample_w`] maps to λ.
    #[inline]
    fn cdf(&self, lambda: f32) -> f32 {
        let f = (lambda - LAMBDA_MIN).clamp(0.0, LAMBDA_RANGE);
        let i = (f as usize).min(CELLS - 1);
        let [cdf, p] = self.cells[i];
        cdf + (f - i as f32) * p
    }
}

impl Wavelengths {
    /// The hero wavelength at CDF position `u` ∈ [0, 1).
    #[inline]
    pub fn sample(self, u: f32) -> f32 {
        match self {
            Wavelengths::Uniform => to_lambda(u),
            Wavelengths::Visible => visible_table().sample_w(u),
        }
    }

    /// The pdf of a lane's wavelength (every lane has the hero's), in nm⁻¹; 0 outside the
    /// range.
    #[inline]
    pub fn pdf(self, lambda: f32) -> f32 {
        match self {
            Wavelengths::Uniform if (LAMBDA_MIN..LAMBDA_MAX).contains(&lambda) => {
                1.0 / LAMBDA_RANGE
            }
            Wavelengths::Uniform => 0.0,
            Wavelengths::Visible => visible_table().pdf(lambda),
        }
    }

    /// The CDF position u that [`Self::sample`] maps to `lambda` (its inverse).
    #[inline]
    pub fn cdf(self, lambda: f32) -> f32 {
        match self {
            Wavelengths::Uniform => (lambda - LAMBDA_MIN) / LAMBDA_RANGE,
            Wavelengths::Visible => visible_table().cdf(lambda),
        }
    }

    /// What the film multiplies each lane's radiance by before its uniform estimate
    /// ([`super::xyz_estimate`] and the spectral bins divide by the uniform pdf 1/Δ):
    /// 1/(p(λ_k)·Δ), or `None` for uniform sampling, whose lanes need nothing (and keep
    /// their bits). Lanes outside the range (never sampled) get 0.
    #[inline]
    pub fn film_weight(self, lambda: Vec4) -> Option<Vec4> {
        match self {
            Wavelengths::Uniform => None,
            Wavelengths::Visible => {
                let t = visible_table();
                Some(map4(lambda, |l| cell(l).map_or(0.0, |i| t.weight[i])))
            }
        }
    }
}

/// Four wavelengths in nm, lane 0 is the hero.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SampledWavelengths {
    pub lambda: Vec4,
}

impl SampledWavelengths {
    /// Hero wavelength sampling with the pdf `w`: the lanes at CDF positions u + k/4,
    /// wrapped into [0, 1). `u` is expected in [0, 1).
    pub fn hwss_with(w: Wavelengths, u: f32) -> Self {
        let lane = |k: f32| {
            // Rotate in the unit interval first: adding a quarter and subtracting 1 is exact
            // there, so the lanes stay exactly a quarter of the CDF apart up to one rounding.
            let mut v = u + 0.25 * k;
            if v >= 1.0 {
                v -= 1.0;
            }
            w.sample(v)
        };
        Self {
            lambda: Vec4::new(lane(0.0), lane(1.0), lane(2.0), lane(3.0)),
        }
    }

    /// One wavelength with the pdf `w`, repeated in every lane.
    pub fn mono_with(w: Wavelengths, u: f32) -> Self {
        Self {
            lambda: Vec4::splat(w.sample(u)),
        }
    }

    /// Uniform hero wavelength sampling: λ₀ = MIN + u·Δ, λ_k = λ₀ + kΔ/4 wrapped into
    /// [MIN, MAX).
    ///
    /// `u` is expected in [0, 1).
    pub fn sample_hwss(u: f32) -> Self {
        Self::hwss_with(Wavelengths::Uniform, u)
    }

    /// One wavelength per path (the paper's monochromatic baseline): every lane holds the
    /// hero so that per-lane code needs no special case; the integrator masks lanes 1–3.
    pub fn sample_mono(u: f32) -> Self {
        Self::mono_with(Wavelengths::Uniform, u)
    }

    /// The pdf of each lane's wavelength, 1/(MAX − MIN): every lane is marginally uniform.
    pub fn pdf() -> f32 {
        1.0 / LAMBDA_RANGE
    }

    /// The hero wavelength (lane 0).
    pub fn hero(&self) -> f32 {
        self.lambda.x
    }
}

/// The uniform map MIN + u·Δ, kept inside [MIN, MAX).
fn to_lambda<F: Float>(u: F) -> F {
    (F::splat(LAMBDA_MIN) + u * F::splat(LAMBDA_RANGE)).clamp(LAMBDA_MIN, LAMBDA_BELOW_MAX)
}

/// The HWSS wavelengths of the W paths of `m` from their uniforms `u`, drawn with the pdf
/// `w`: the hero at CDF position `u`, the others a quarter of the CDF apart, wrapped (the
/// other paths' lanes are left meaningless; under the visible pdf they hold MIN).
#[inline(always)]
pub fn hwss<F: Float>(w: Wavelengths, u: F, m: F::Mask) -> Spec<F> {
    let table = visible_table();
    // A function, not a closure: four calls of a closure this size stayed out of line.
    #[inline(always)]
    fn lane<F: Float>(w: Wavelengths, table: &VisibleTable, u: F, m: F::Mask, k: f32) -> F {
        let one = F::splat(1.0);
        let v = u + F::splat(0.25 * k);
        let v = F::select(v.ge(one), v - one, v);
        match w {
            Wavelengths::Uniform => to_lambda(v),
            Wavelengths::Visible => F::select(
                m,
                table.sample_w(F::select(m, v, F::splat(0.0))),
                F::splat(LAMBDA_MIN),
            ),
        }
    }
    Spec([
        lane(w, table, u, m, 0.0),
        lane(w, table, u, m, 1.0),
        lane(w, table, u, m, 2.0),
        lane(w, table, u, m, 3.0),
    ])
}

/// One wavelength for each path of `m` drawn with the pdf `w`, in every lane
/// (monochromatic sampling; the other paths' lanes are left meaningless).
#[inline(always)]
pub fn mono<F: Float>(w: Wavelengths, u: F, m: F::Mask) -> Spec<F> {
    match w {
        Wavelengths::Uniform => Spec::broadcast(to_lambda(u)),
        Wavelengths::Visible => Spec::broadcast(F::select(
            m,
            visible_table().sample_w(F::select(m, u, F::splat(0.0))),
            F::splat(LAMBDA_MIN),
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn below_max_is_the_previous_float() {
        assert_eq!(
            f32::from_bits(LAMBDA_MAX.to_bits() - 1),
            LAMBDA_BELOW_MAX,
            "LAMBDA_BELOW_MAX must be the float just below LAMBDA_MAX"
        );
    }

    #[test]
    fn lanes_are_a_quarter_range_apart_and_wrap() {
        for &u in &[0.0, 0.1, 0.25, 0.5, 0.6, 0.75, 0.9, 0.999_999_9] {
            let w = SampledWavelengths::sample_hwss(u);
            let l = w.lambda.to_array();
            assert!((l[0] - (LAMBDA_MIN + u * LAMBDA_RANGE)).abs() < 1e-3);
            for k in 0..4 {
                assert!(
                    (LAMBDA_MIN..LAMBDA_MAX).contains(&l[k]),
                    "lane {k} = {} outside range",
                    l[k]
                );
                let d = (l[(k + 1) % 4] - l[k]).rem_euclid(LAMBDA_RANGE);
                assert!(
                    (d - LAMBDA_RANGE / 4.0).abs() < 1e-3,
                    "u = {u}: lanes {k} → {} differ by {d}",
                    (k + 1) % 4
                );
            }
        }
    }

    #[test]
    fn endpoints_stay_half_open() {
        let hi = SampledWavelengths::sample_hwss(f32::from_bits(1.0f32.to_bits() - 1));
        assert!(hi.lambda.max_element() < LAMBDA_MAX);
        let lo = SampledWavelengths::sample_hwss(0.0);
        assert_eq!(lo.hero(), LAMBDA_MIN);
        assert!(lo.lambda.min_element() >= LAMBDA_MIN);
    }

    #[test]
    fn mono_repeats_the_hero() {
        let w = SampledWavelengths::sample_mono(0.3);
        assert_eq!(w.lambda, Vec4::splat(LAMBDA_MIN + 0.3 * LAMBDA_RANGE));
    }

    #[test]
    fn the_cdf_undoes_sampling() {
        for &u in &[0.0, 0.123, 0.5, 0.987] {
            let w = SampledWavelengths::sample_hwss(u);
            assert!((Wavelengths::Uniform.cdf(w.hero()) - u).abs() < 1e-6);
        }
    }

    /// Each guide bucket [j/G, (j+1)/G) holds at most one interior cell edge: what lets
    /// [`VisibleTable::sample_w`] take one step instead of a search.
    #[test]
    fn no_guide_bucket_holds_two_cell_edges() {
        let t = visible_table();
        for j in 0..GUIDE {
            let (a, b) = (j as f32 / GUIDE as f32, (j + 1) as f32 / GUIDE as f32);
            let inside = t.cells.iter().filter(|c| a < c[0] && c[0] < b).count();
            assert!(inside <= 1, "bucket {j} holds {inside} cell edges");
        }
    }

    /// The visible sampler finds the cell a full search finds (at every cell edge, a float
    /// either side of it, and at random u), and every width gives the scalar's bits.
    #[test]
    fn visible_sampling_matches_a_full_search() {
        use crate::simd::{F4, F8};
        let t = visible_table();
        let searched = |u: f32| {
            let i = (t.cells.partition_point(|c| c[0] <= u).max(1) - 1).min(CELLS - 1);
            let [cdf, p] = t.cells[i];
            (LAMBDA_MIN + i as f32 + ((u - cdf) / p).clamp(0.0, 1.0))
                .clamp(LAMBDA_MIN, LAMBDA_BELOW_MAX)
        };
        let mut us: Vec<f32> = t.cells[..CELLS]
            .iter()
            .flat_map(|c| [c[0].next_down(), c[0], c[0].next_up()])
            .filter(|u| (0.0..1.0).contains(u))
            .collect();
        let mut x = 0x9e37_79b9_u32;
        us.extend((0..100_000).map(|_| {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            (x >> 8) as f32 / (1 << 24) as f32
        }));
        us.push(1.0f32.next_down());
        for chunk in us.chunks_exact(8) {
            let w4 = t.sample_w(F4::from_fn(|l| chunk[l]));
            let w8 = t.sample_w(F8::from_fn(|l| chunk[l]));
            for (l, &u) in chunk.iter().enumerate() {
                let want = searched(u);
                assert_eq!(t.sample_w(u).to_bits(), want.to_bits(), "u = {u}");
                assert_eq!(w8.get(l).to_bits(), want.to_bits(), "width 8, u = {u}");
                if l < 4 {
                    assert_eq!(w4.get(l).to_bits(), want.to_bits(), "width 4, u = {u}");
                }
            }
        }
    }

    #[test]
    fn pdf_integrates_to_one() {
        assert!((SampledWavelengths::pdf() * (LAMBDA_MAX - LAMBDA_MIN) - 1.0).abs() < 1e-6);
    }
}
