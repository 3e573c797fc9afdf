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

use glam::Vec3;
use std::f32::consts::{FRAC_1_PI, TAU};

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
        if self.g.is_nan() {
            0.0
        } else {
            self.g.clamp(-G_MAX, G_MAX)
        }
    }

    /// The phase function (sr⁻¹) at the cosine of the scattering angle between the
    /// propagation directions (see the module docs); it integrates to 1 over the sphere.
    #[inline]
    pub fn eval(&self, cos_theta: f32) -> f32 {
        let cos = cos_theta.clamp(-1.0, 1.0);
        self.density(1.0 - cos, 1.0 + cos)
    }

    /// The phase function from 1 − cos θ and 1 + cos θ (each in [0, 2]), so that callers
    /// that know them more accurately than cos θ itself keep that accuracy near the peak.
    #[inline]
    fn density(&self, one_minus_cos: f32, one_plus_cos: f32) -> f32 {
        let g = self.g_clamped();
        // 1 + g² − 2g cos θ written as a sum of two non-negative terms, so it does not
        // cancel near the peak when |g| → 1: (1−g)² + 2g(1−cos) for g ≥ 0,
        // (1+g)² + 2|g|(1+cos) for g < 0.
        let denom = if g >= 0.0 {
            (1.0 - g) * (1.0 - g) + 2.0 * g * one_minus_cos
        } else {
            (1.0 + g) * (1.0 + g) - 2.0 * g * one_plus_cos
        };
        INV_4PI * (1.0 - g) * (1.0 + g) / (denom * denom.sqrt())
    }

    /// The phase function for the directions `wo`, `wi` (unit, pointing away from the
    /// scattering point), cos θ = −`wo`·`wi`. Equal to [`Self::pdf`].
    ///
    /// 1 − cos θ = |wo + wi|²/2 and 1 + cos θ = |wo − wi|²/2 for unit vectors; dividing
    /// both by (|wo + wi|² + |wo − wi|²)/4 = (|wo|² + |wi|²)/2 makes them insensitive to
    /// the vectors' normalisation error. Near the peak of a strong lobe, where wi ≈ ∓wo,
    /// 1 ∓ cos θ ~ 10⁻⁴ comes out to f32 precision, where 1 + wo·wi would lose three digits.
    #[inline]
    pub fn eval_dirs(&self, wo: Vec3, wi: Vec3) -> f32 {
        let sum = (wo + wi).length_squared();
        let diff = (wo - wi).length_squared();
        let total = sum + diff;
        if total > 0.0 {
            let scale = 2.0 / total;
            self.density(sum * scale, diff * scale)
        } else {
            self.eval(-wo.dot(wi))
        }
    }

    /// The solid-angle density with which [`Self::sample`] returns `wi` given `wo`.
    #[inline]
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        self.eval_dirs(wo, wi)
    }

    /// Samples the new direction `wi` given `wo` (unit, pointing back along the incoming
    /// ray) by inverting the CDF of cos θ with `u[0]` and drawing the azimuth with `u[1]`.
    /// Returns `(wi, pdf)` with `pdf` = [`Self::pdf`]`(wo, wi)` (up to rounding).
    ///
    /// The textbook inversion cos θ = (1 + g² − ((1 − g²)/(1 − g + 2gξ))²)/(2g) divides by
    /// g and cancels badly near the peak; here 1 − cos θ and 1 + cos θ are computed as
    /// products of positive factors (with t = 1 − g + 2gξ):
    ///   1 − cos θ = (1 − g)² (1 − ξ)(1 + g + t) / t²,
    ///   1 + cos θ = (1 + g)² ξ (1 − g + t) / t²,
    /// which hold for every g including 0, and sin²θ is their product. The pdf follows from t
    /// alone: 1 + g² − 2g cos θ = ((1 − g²)/t)², so p = t³ / (4π (1 − g²)²).
    #[inline]
    pub fn sample(&self, wo: Vec3, u: [f32; 2]) -> (Vec3, f32) {
        let g = self.g_clamped();
        let xi = u[0].clamp(0.0, 1.0);
        let (one_m_g, one_p_g) = (1.0 - g, 1.0 + g);
        let t = one_m_g + 2.0 * g * xi;
        let inv_t2 = 1.0 / (t * t);
        let one_minus_cos = (one_m_g * one_m_g * (1.0 - xi) * (one_p_g + t) * inv_t2).min(2.0);
        let one_plus_cos = (one_p_g * one_p_g * xi * (one_m_g + t) * inv_t2).min(2.0);
        // Take cos θ from whichever side is the more accurate.
        let cos = if one_minus_cos < one_plus_cos {
            1.0 - one_minus_cos
        } else {
            one_plus_cos - 1.0
        };
        let sin = (one_minus_cos * one_plus_cos).max(0.0).sqrt();
        let phi = TAU * u[1];
        let axis = -wo;
        let (b1, b2) = axis.any_orthonormal_pair();
        let wi = cos * axis + sin * (phi.cos() * b1 + phi.sin() * b2);
        let one_m_g2 = one_m_g * one_p_g;
        let pdf = INV_4PI * t * t * t / (one_m_g2 * one_m_g2);
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
