//! The Henyey–Greenstein phase function.
//!
//! # Direction convention
//! Both directions point **away from the scattering point**:
//! - `wo` points back along the incoming (camera) ray, i.e. towards where the light goes to
//!   (the camera, or the previous vertex);
//! - `wi` is the new direction, the direction the path continues in (towards where the
//!   light comes from).
//!
//! The scattering angle θ is measured between the two *propagation* directions, the path's
//! −`wo` and `wi` (equivalently the light's −`wi` and `wo`): cos θ = −`wo`·`wi`. With that
//! sign, g > 0 is forward scattering (the path keeps going roughly straight on) and the
//! mean cosine E[cos θ] equals g.
//!
//! The density is over solid angle (sr⁻¹) and normalised over the sphere:
//! p(cos θ) = (1 − g²) / (4π (1 + g² − 2g cos θ)^{3/2}), 1/(4π) for g = 0.

use crate::simd::{math, Float, V3};
use glam::Vec3;
use std::f32::consts::FRAC_1_PI;

/// The largest |g| used: the lobe of |g| = 1 is a Dirac delta, which has no density, so
/// g is clamped to ±`G_MAX` (a peak of about 1.6·10⁷ sr⁻¹, still finite in f32).
pub const G_MAX: f32 = 0.9999;

/// 1/(4π).
const INV_4PI: f32 = 0.25 * FRAC_1_PI;

/// Henyey–Greenstein with asymmetry `g` ∈ (−1, 1) (clamped to ±[`G_MAX`]; NaN counts
/// as 0, isotropic). Scattering with it is exact: the sampled value equals its pdf.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct HenyeyGreenstein {
    /// Asymmetry: the mean cosine of the scattering angle.
    pub g: f32,
}

impl HenyeyGreenstein {
    /// A lobe with asymmetry `g`.
    pub fn new(g: f32) -> HenyeyGreenstein {
        HenyeyGreenstein { g }
    }

    /// The isotropic phase function 1/(4π).
    pub fn isotropic() -> HenyeyGreenstein {
        HenyeyGreenstein { g: 0.0 }
    }

    /// g as used by every method: clamped to ±[`G_MAX`], NaN → 0.
    #[inline]
    pub fn g_clamped(&self) -> f32 {
        Hg::new(self.g).g
    }

    /// The phase function (sr⁻¹) at the cosine of the scattering angle between the
    /// propagation directions (see the module docs); it integrates to 1 over the sphere.
    #[inline]
    pub fn eval(&self, cos_theta: f32) -> f32 {
        Hg::new(self.g).eval(cos_theta)
    }

    /// The phase function for the directions `wo` and `wi` (unit, module convention).
    #[inline]
    pub fn eval_dirs(&self, wo: Vec3, wi: Vec3) -> f32 {
        Hg::new(self.g).eval_dirs(wo.into(), wi.into())
    }

    /// The solid-angle density with which [`Self::sample`] returns `wi` given `wo`.
    #[inline]
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        self.eval_dirs(wo, wi)
    }

    /// Samples the new direction `wi` given `wo`; see [`Hg::sample`].
    #[inline]
    pub fn sample(&self, wo: Vec3, u: [f32; 2]) -> (Vec3, f32) {
        let (wi, pdf) = Hg::new(self.g).sample(wo.into(), u);
        (wi.into(), pdf)
    }
}

/// Henyey–Greenstein for W paths, each with its own (clamped) g.
#[derive(Clone, Copy, Debug)]
pub struct Hg<F> {
    /// g, clamped to ±[`G_MAX`] (NaN → 0).
    pub g: F,
}

impl<F: Float> Hg<F> {
    /// The lobes of asymmetries `g`.
    #[inline(always)]
    pub fn new(g: F) -> Hg<F> {
        let g = F::select(g.ne(g), F::splat(0.0), g.clamp(-G_MAX, G_MAX));
        Hg { g }
    }

    /// The density from 1 − cos θ and 1 + cos θ.
    #[inline(always)]
    fn density(&self, one_minus_cos: F, one_plus_cos: F) -> F {
        let (g, one, two) = (self.g, F::splat(1.0), F::splat(2.0));
        // 1 + g² − 2g cos θ written as a sum of two non-negative terms, so it does not
        // cancel near the peak when |g| → 1: (1−g)² + 2g(1−cos) for g ≥ 0,
        // (1+g)² + 2|g|(1+cos) for g < 0.
        let forward = (one - g) * (one - g) + two * g * one_minus_cos;
        let backward = (one + g) * (one + g) - two * g * one_plus_cos;
        let denom = F::select(g.ge(F::splat(0.0)), forward, backward);
        F::splat(INV_4PI) * (one - g) * (one + g) / (denom * denom.sqrt())
    }

    /// The phase function at the cosine of the scattering angle.
    #[inline(always)]
    pub fn eval(&self, cos_theta: F) -> F {
        let cos = cos_theta.clamp(-1.0, 1.0);
        self.density(F::splat(1.0) - cos, F::splat(1.0) + cos)
    }

    /// The phase function for the directions `wo` and `wi` (unit, module convention).
    #[inline(always)]
    pub fn eval_dirs(&self, wo: V3<F>, wi: V3<F>) -> F {
        // 1 ∓ cos θ from |wo ± wi|², which do not cancel near either pole.
        let sum = (wo + wi).length_squared();
        let diff = (wo - wi).length_squared();
        let total = sum + diff;
        let scale = F::splat(2.0) / total;
        let by_dirs = self.density(sum * scale, diff * scale);
        F::select(total.gt(F::splat(0.0)), by_dirs, self.eval(-wo.dot(wi)))
    }

    /// Samples the new direction `wi` given `wo` (unit, pointing back along the incoming
    /// ray) by inverting the CDF of cos θ with `u[0]` and drawing the azimuth with `u[1]`.
    /// Returns `(wi, pdf)` with `pdf` = [`Self::eval_dirs`]`(wo, wi)` (up to rounding).
    ///
    /// The textbook inversion cos θ = (1 + g² − ((1 − g²)/(1 − g + 2gξ))²)/(2g) divides by
    /// g and cancels badly near the peak; here 1 − cos θ and 1 + cos θ are computed as
    /// products of positive factors (with t = 1 − g + 2gξ):
    ///   1 − cos θ = (1 − g)² (1 − ξ)(1 + g + t) / t²,
    ///   1 + cos θ = (1 + g)² ξ (1 − g + t) / t²,
    /// which hold for every g including 0, and sin²θ is their product. The pdf follows from t
    /// alone: 1 + g² − 2g cos θ = ((1 − g²)/t)², so p = t³ / (4π (1 − g²)²).
    #[inline(always)]
    pub fn sample(&self, wo: V3<F>, u: [F; 2]) -> (V3<F>, F) {
        let (g, one, two) = (self.g, F::splat(1.0), F::splat(2.0));
        let xi = u[0].clamp(0.0, 1.0);
        let (one_m_g, one_p_g) = (one - g, one + g);
        let t = one_m_g + two * g * xi;
        let inv_t2 = one / (t * t);
        let one_minus_cos = (one_m_g * one_m_g * (one - xi) * (one_p_g + t) * inv_t2).min(two);
        let one_plus_cos = (one_p_g * one_p_g * xi * (one_m_g + t) * inv_t2).min(two);
        // Take cos θ from whichever side is the more accurate.
        let cos = F::select(
            one_minus_cos.lt(one_plus_cos),
            one - one_minus_cos,
            one_plus_cos - one,
        );
        let sin = (one_minus_cos * one_plus_cos).max(F::splat(0.0)).sqrt();
        let (sin_phi, cos_phi) = math::sin_cos_turns(u[1]);
        let axis = -wo;
        let (b1, b2) = axis.basis();
        let wi = axis * cos + (b1 * cos_phi + b2 * sin_phi) * sin;
        let one_m_g2 = one_m_g * one_p_g;
        let pdf = F::splat(INV_4PI) * t * t * t / (one_m_g2 * one_m_g2);
        (wi, pdf)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn isotropic_is_one_over_four_pi() {
        let p = HenyeyGreenstein::isotropic();
        for c in [-1.0, -0.3, 0.0, 0.7, 1.0] {
            assert!((p.eval(c) - INV_4PI).abs() < 1e-8);
        }
        let (wi, pdf) = p.sample(Vec3::Z, [0.3, 0.6]);
        assert!((pdf - INV_4PI).abs() < 1e-8 && (wi.length() - 1.0).abs() < 1e-6);
    }

    #[test]
    fn forward_means_along_the_incoming_ray() {
        let p = HenyeyGreenstein::new(0.9);
        let wo = Vec3::Z; // the ray travelled along −z
        assert!(p.pdf(wo, -Vec3::Z) > 100.0 * p.pdf(wo, Vec3::Z));
        let (wi, _) = p.sample(wo, [0.99, 0.2]);
        assert!(wi.z < -0.9, "{wi}");
    }

    #[test]
    fn extreme_g_stays_finite() {
        for g in [-1.0, -G_MAX, G_MAX, 1.0, f32::NAN] {
            let p = HenyeyGreenstein::new(g);
            for xi in [0.0, 1e-7, 0.5, 1.0 - f32::EPSILON, 1.0] {
                let (wi, pdf) = p.sample(Vec3::X, [xi, 0.25]);
                assert!(wi.is_finite() && pdf.is_finite() && pdf > 0.0, "{g} {xi}");
                assert!((wi.length() - 1.0).abs() < 1e-5);
                let e = p.pdf(Vec3::X, wi);
                assert!(e.is_finite() && e > 0.0);
            }
        }
    }
}
