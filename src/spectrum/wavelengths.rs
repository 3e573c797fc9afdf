//! The four wavelengths a path carries, and how they are drawn.
//!
//! Hero wavelength spectral sampling (Wilkie et al. 2014): the hero λ₀ is uniform over
//! [`LAMBDA_MIN`], [`LAMBDA_MAX`]) and the other lanes sit at λ₀ + kΔ/4 (k = 1, 2, 3), wrapped
//! back into the range. Because the offsets are a rotation of the circle the range forms,
//! every lane is *marginally* uniform too, so all four share the pdf 1/Δ.

use crate::simd::{Float, Spec};
use glam::Vec4;

use super::{LAMBDA_MIN, LAMBDA_RANGE};

/// Largest `f32` strictly below [`LAMBDA_MAX`]: keeps sampled wavelengths in the half-open
/// range even when `MIN + u·Δ` rounds up to `MAX`.
const LAMBDA_BELOW_MAX: f32 = 829.999_94;

/// Four wavelengths in nm, lane 0 is the hero.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SampledWavelengths {
    pub lambda: Vec4,
}

impl SampledWavelengths {
    /// Hero wavelength sampling: λ₀ = MIN + u·Δ, λ_k = λ₀ + kΔ/4 wrapped into [MIN, MAX).
    ///
    /// `u` is expected in [0, 1).
    pub fn sample_hwss(u: f32) -> Self {
        let lane = |k: f32| {
            // Rotate in the unit interval first: adding a quarter and subtracting 1 is exact
            // there, so the lanes stay exactly Δ/4 apart (modulo Δ) up to one rounding of λ.
            let mut v = u + 0.25 * k;
            if v >= 1.0 {
                v -= 1.0;
            }
            to_lambda(v)
        };
        Self {
            lambda: Vec4::new(lane(0.0), lane(1.0), lane(2.0), lane(3.0)),
        }
    }

    /// One wavelength per path (the paper's monochromatic baseline): every lane holds the
    /// hero so that per-lane code needs no special case; the integrator masks lanes 1–3.
    pub fn sample_mono(u: f32) -> Self {
        Self {
            lambda: mono(u).into(),
        }
    }

    /// The pdf of each lane's wavelength, 1/(MAX − MIN): every lane is marginally uniform.
    pub fn pdf() -> f32 {
        1.0 / LAMBDA_RANGE
    }

    /// The random number that [`Self::sample_hwss`] / [`Self::sample_mono`] map to the hero
    /// wavelength `lambda` (the inverse of the sampling map).
    pub fn invert(lambda: f32) -> f32 {
        (lambda - LAMBDA_MIN) / LAMBDA_RANGE
    }

    /// The hero wavelength (lane 0).
    pub fn hero(&self) -> f32 {
        self.lambda.x
    }
}

fn to_lambda<F: Float>(u: F) -> F {
    (F::splat(LAMBDA_MIN) + u * F::splat(LAMBDA_RANGE)).clamp(LAMBDA_MIN, LAMBDA_BELOW_MAX)
}

/// The HWSS wavelengths of W paths from their uniforms `u`: the hero at `u`, the others a
/// quarter of the range apart, wrapped.
#[inline(always)]
pub fn hwss<F: Float>(u: F) -> Spec<F> {
    let one = F::splat(1.0);
    let lane = |k: f32| {
        let v = u + F::splat(0.25 * k);
        to_lambda(F::select(v.ge(one), v - one, v))
    };
    Spec([lane(0.0), lane(1.0), lane(2.0), lane(3.0)])
}

/// One wavelength per path, in every lane (monochromatic sampling).
#[inline(always)]
pub fn mono<F: Float>(u: F) -> Spec<F> {
    Spec::broadcast(to_lambda(u))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spectrum::LAMBDA_MAX;

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
    fn invert_undoes_sampling() {
        for &u in &[0.0, 0.123, 0.5, 0.987] {
            let w = SampledWavelengths::sample_hwss(u);
            assert!((SampledWavelengths::invert(w.hero()) - u).abs() < 1e-6);
        }
    }

    #[test]
    fn pdf_integrates_to_one() {
        assert!((SampledWavelengths::pdf() * (LAMBDA_MAX - LAMBDA_MIN) - 1.0).abs() < 1e-6);
    }
}
