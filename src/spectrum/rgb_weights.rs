//! The film's colour per wavelength: what a lane's radiance adds to its pixel's linear
//! sRGB, with the wavelength pdf's weight, the colour-matching functions, their
//! normalisation and the XYZ → sRGB matrix folded into one table.
//!
//! A pixel sample's colour is Σₖ lₖ · w(λₖ) · M · x̄ȳz̄(λₖ) · Δ / ∫ȳ, where w is the film
//! weight of the wavelength pdf ([`Wavelengths::film_weight`], 1 for uniform sampling)
//! and M the XYZ → linear sRGB matrix. The colour-matching functions are linear on the
//! 1 nm cells the visible pdf is constant on, so the whole factor is linear on each cell:
//! one table of the factor at both ends of each cell gives it with one look-up and one
//! interpolation per lane, where the film otherwise looks up the pdf's weight and the
//! colour-matching functions apart and converts XYZ after summing ([`super::xyz_estimate`]
//! and [`crate::color::xyz_to_linear_srgb`], which the tests keep as the reference). The
//! table takes M·x̄ȳz̄ in f32, as the film did, and the weight and normalisation in f64:
//! a sample now rounds at fewer steps, so images differ from the old film's in the last
//! bits.

use std::sync::OnceLock;

use glam::{DVec3, Vec3, Vec4};

use super::{cie_xyz, Wavelengths, CIE_Y_INTEGRAL, LAMBDA_MIN, LAMBDA_RANGE};
use crate::color::xyz_to_linear_srgb;

/// The table's cells: 1 nm over [MIN, MAX).
const CELLS: usize = super::NM_CELLS;

/// The factor w(λ) · M · x̄ȳz̄(λ) · Δ / ∫ȳ at both ends of every 1 nm cell (the fourth
/// component is 0).
pub struct RgbWeights {
    cells: Vec<[Vec4; 2]>,
}

impl RgbWeights {
    /// The table for wavelengths sampled with pdf `w` (built once per pdf).
    pub fn of(w: Wavelengths) -> &'static RgbWeights {
        static VISIBLE: OnceLock<RgbWeights> = OnceLock::new();
        static UNIFORM: OnceLock<RgbWeights> = OnceLock::new();
        match w {
            Wavelengths::Visible => VISIBLE.get_or_init(|| RgbWeights::build(w)),
            Wavelengths::Uniform => UNIFORM.get_or_init(|| RgbWeights::build(w)),
        }
    }

    fn build(w: Wavelengths) -> RgbWeights {
        let norm = LAMBDA_RANGE as f64 / CIE_Y_INTEGRAL as f64;
        let rgb = |l: f32| xyz_to_linear_srgb(cie_xyz(l)).as_dvec3();
        let cells = (0..CELLS)
            .map(|i| {
                let lo = LAMBDA_MIN + i as f32;
                let weight = w
                    .film_weight(Vec4::splat(lo + 0.5))
                    .map_or(1.0, |v| v.x as f64);
                let end = |c: DVec3| (c * weight * norm).as_vec3().extend(0.0);
                [end(rgb(lo)), end(rgb(lo + 1.0))]
            })
            .collect();
        RgbWeights { cells }
    }

    /// The linear sRGB of a pixel sample whose lanes carry radiance `l` (MIS weights
    /// applied) at wavelengths `lambda`. A lane outside [MIN, MAX) (or NaN) has weight 0:
    /// it adds nothing unless its radiance is not finite, which makes the colour NaN, as
    /// the film must see.
    #[inline]
    pub fn rgb(&self, lambda: Vec4, l: Vec4) -> Vec3 {
        let f = lambda - Vec4::splat(LAMBDA_MIN);
        // False for NaN.
        let inside = f.cmpge(Vec4::ZERO) & f.cmplt(Vec4::splat(LAMBDA_RANGE));
        let cell = f.clamp(Vec4::ZERO, Vec4::splat(LAMBDA_RANGE - 1.0)).floor();
        // An outside lane (NaN too) reads a finite factor and adds l·0 times it.
        let t = Vec4::select(inside, f - cell, Vec4::ZERO);
        let l = Vec4::select(inside, l, l * 0.0);
        let (i, t, l) = (cell.as_ivec4().to_array(), t.to_array(), l.to_array());
        let mut sum = Vec4::ZERO;
        for k in 0..4 {
            let [a, b] = self.cells[i[k] as usize];
            sum += l[k] * (a + t[k] * (b - a));
        }
        sum.truncate()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spectrum::xyz_estimate;

    /// The separate steps the table folds: weight, colour-matching functions, XYZ → sRGB.
    fn by_steps(w: Wavelengths, lambda: Vec4, l: Vec4) -> Vec3 {
        let l = w.film_weight(lambda).map_or(l, |v| l * v);
        xyz_to_linear_srgb(xyz_estimate(lambda, l))
    }

    #[test]
    fn agrees_with_the_separate_steps() {
        let mut rng = crate::sampler::Pcg32::new(7, 1);
        for w in [Wavelengths::Visible, Wavelengths::Uniform] {
            let table = RgbWeights::of(w);
            let mut worst = 0.0f32;
            for _ in 0..20_000 {
                let lambda = Vec4::from_array(std::array::from_fn(|_| {
                    LAMBDA_MIN + rng.next_f32() * LAMBDA_RANGE
                }));
                let l = Vec4::from_array(std::array::from_fn(|_| rng.next_f32() * 2.0));
                let (got, want) = (table.rgb(lambda, l), by_steps(w, lambda, l));
                // Relative to the sample's size: components can cancel to near 0.
                let size = want.abs().max_element().max(l.max_element() * 1e-3);
                worst = worst.max((got - want).abs().max_element() / size);
            }
            assert!(worst < 2e-5, "{w:?}: worst relative difference {worst}");
        }
    }

    #[test]
    fn lanes_outside_the_range_add_nothing_but_non_finite_radiance_shows() {
        let table = RgbWeights::of(Wavelengths::Visible);
        let inside = table.rgb(
            Vec4::new(550.0, 0.0, 0.0, 0.0),
            Vec4::new(1.0, 0.0, 0.0, 0.0),
        );
        assert!(inside.y > 0.0);
        let lambda = Vec4::new(550.0, 300.0, 830.0, f32::NAN);
        let l = Vec4::new(1.0, 5.0, 5.0, 5.0);
        assert_eq!(table.rgb(lambda, l), inside);
        for k in 1..4 {
            let mut bad = l.to_array();
            bad[k] = f32::INFINITY;
            assert!(table.rgb(lambda, Vec4::from_array(bad)).is_nan());
        }
        let mut nan = Vec4::ZERO.to_array();
        nan[0] = f32::NAN;
        assert!(table
            .rgb(Vec4::splat(500.0), Vec4::from_array(nan))
            .is_nan());
        assert_eq!(table.rgb(Vec4::splat(f32::NAN), Vec4::ZERO), Vec3::ZERO);
    }

    #[test]
    fn a_white_lane_set_gives_about_white() {
        // Uniform sampling, lanes at the cell starts of a 4-way stratified sweep: the
        // average over many sweeps of a constant 1 is Y = 1 (to the sweep's resolution).
        let table = RgbWeights::of(Wavelengths::Uniform);
        let n = 4000;
        let mut sum = DVec3::ZERO;
        for j in 0..n {
            let u = (j as f32 + 0.5) / n as f32;
            let lambda = Vec4::from_array(std::array::from_fn(|k| {
                LAMBDA_MIN + ((u + 0.25 * k as f32) % 1.0) * LAMBDA_RANGE
            }));
            sum += table.rgb(lambda, Vec4::splat(0.25)).as_dvec3();
        }
        let xyz = crate::color::linear_srgb_to_xyz((sum / n as f64).as_vec3());
        assert!((xyz.y - 1.0).abs() < 1e-3, "Y = {}", xyz.y);
    }
}
