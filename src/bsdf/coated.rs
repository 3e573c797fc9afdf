//! A smooth clear coat over a Lambertian base that may fluoresce: gloss paint, plastics,
//! highlighter ink under varnish, a sticky note's coated paper.
//!
//! The model is the classic energy-aware layer over a diffuse base (Weidlich & Wilkie
//! 2007 reduce to it for a smooth coat; Mitsuba 3's `plastic` with `nonlinear = true` is
//! the same without absorption). Light from ωi enters through the coat with 1 − F(θi),
//! crosses the layer along the refracted direction with transmittance e^(−τ/cos θi'),
//! is re-radiated by the base with M(λi→λo)/π, and leaves towards ωo with
//! (1 − F(θo))·e^(−τ/cos θo')/η². Light the coat reflects back down reaches the base
//! again: for a Lambertian base that series sums in closed form to 1/(1 − ρ(λo)·r(λo)),
//! where r is the coat's internal reflectance of diffuse light including the round
//! trip's absorption. With ρ = 1 and τ = 0 the layer conserves energy exactly (the
//! tests' white furnace); otherwise it never creates any.
//!
//! Why this model: it is exact for what it covers (a smooth coat over a Lambertian base,
//! whose output depends only on the irradiance it receives, so internally reflected light
//! needs no direction), its two wavelengths sit where the physics puts them (the exit's
//! Fresnel, absorption and 1/η² at λo, the entrance's at λi), and it costs no random
//! numbers in evaluation, unlike a stochastic layered BSDF (Guo et al. 2018), so light
//! sampling's MIS stays deterministic. What it leaves out: rough coats and non-Lambertian
//! bases (their internal reflections need directions), and fluorescence *between* the
//! internal reflections (the series treats the base's later bounces at λo as elastic,
//! with its diagonal ρ(λo) — light lost, never gained).
//!
//! Sampling picks the coat's mirror reflection with probability P = F(θo) at the coat's
//! index at 550 nm (kept in [0.05, 0.95]), the same for every lane, so the choice moves
//! no lane's MIS ratio; its weight is F(θo, λ)/P per lane. Otherwise the base: the
//! integrator applies the exit factor at λo divided by 1 − P, shifts the wavelengths if
//! the base fluoresces, and the base lobe ([`super::Lobe::CoatedBase`]) samples the
//! cosine and carries the entrance factor at λi.
//!
//! ```toml
//! [materials.sticky_note]
//! type = "coated"
//! ior = 1.5                      # the coat's index (any index form; default 1.5)
//! absorption = 0.2               # optional: σ_a of the coat per scene unit (a spectrum)
//! thickness = 0.05               # with absorption: the coat's thickness in scene units
//! base = { type = "fluorescent_diffuse", reflectance = 0.8, dye = { ... } }   # or a diffuse
//! ```

use super::{fresnel_dielectric, Ior};
use crate::fluoro::Reradiation;
use crate::simd::{math, Float, Spec};
use crate::spectrum::{Spectrum, Tabulated, LAMBDA_MAX, LAMBDA_MIN};
use std::sync::Arc;

/// A smooth clear coat over a Lambertian base.
#[derive(Debug, Clone)]
pub struct Coated {
    /// The coat's index (the outside is 1).
    pub ior: Ior,
    /// The coat's optical depth τ(λ) = σ_a(λ)·thickness (0: clear).
    pub tau: Spectrum,
    /// The base's re-radiation (its diagonal is the Lambertian albedo ρ).
    pub base: Arc<Reradiation>,
    /// η at 550 nm: the coat-or-base choice, the same for every lane.
    eta_ref: f32,
    /// 1/(η²·(1 − ρ·r)) per wavelength: the exit's constant part.
    exit_scale: Spectrum,
}

/// The branch probability's bounds: neither branch is ever starved.
const P_MIN: f32 = 0.05;

impl Coated {
    /// The coat of index `ior` and optical depth `tau` over `base`; tabulates the
    /// internal-reflection series per nm.
    pub fn new(ior: Ior, tau: Spectrum, base: Arc<Reradiation>) -> Coated {
        let grid: Vec<f32> = (LAMBDA_MIN as u32..=LAMBDA_MAX as u32)
            .map(|l| l as f32)
            .collect();
        let scale: Vec<f32> = grid
            .iter()
            .map(|&l| {
                let eta = ior.eval(l);
                let r = internal_reflectance(eta, tau.eval(l));
                let rho = base.diagonal().eval(l);
                1.0 / (eta * eta * (1.0 - rho * r))
            })
            .collect();
        let exit_scale =
            Spectrum::Tabulated(Tabulated::new(grid, scale).expect("a 1 nm grid of finite values"));
        Coated {
            eta_ref: ior.eval(550.0),
            ior,
            tau,
            base,
            exit_scale,
        }
    }

    /// The probability of sampling the coat's reflection at incidence cosine `cos_o`.
    #[inline(always)]
    pub fn p_coat<F: Float>(&self, cos_o: F) -> F {
        fresnel_dielectric(cos_o, F::splat(self.eta_ref)).clamp(P_MIN, 1.0 - P_MIN)
    }

    /// The coat's Fresnel reflectance per lane at `cos_o` (the mirror branch's value).
    #[inline(always)]
    pub fn reflectance<F: Float>(&self, cos_o: F, lambda: &Spec<F>, m: F::Mask) -> Spec<F> {
        let eta = self.ior.eval_w(lambda, m);
        eta.map(|e| fresnel_dielectric(cos_o, e))
    }

    /// What light leaving the base towards `cos_o` keeps, per lane at its wavelength λo:
    /// (1 − F)·e^(−τ/cos θo')/(η²·(1 − ρ·r)).
    #[inline(always)]
    pub fn exit<F: Float>(&self, cos_o: F, lambda: &Spec<F>, m: F::Mask) -> Spec<F> {
        let through = self.through(cos_o, lambda, m);
        through * self.exit_scale.eval_w(lambda, m)
    }

    /// The coat's parameters at the wavelengths `lambda` for the base lobe: η and τ.
    #[inline(always)]
    pub fn at<F: Float>(&self, lambda: &Spec<F>, m: F::Mask) -> (Spec<F>, Spec<F>) {
        (self.ior.eval_w(lambda, m), self.tau.eval_w(lambda, m))
    }

    /// (1 − F(cos))·e^(−τ/cos') per lane: one crossing of the coat.
    #[inline(always)]
    fn through<F: Float>(&self, cos: F, lambda: &Spec<F>, m: F::Mask) -> Spec<F> {
        let (eta, tau) = self.at(lambda, m);
        crossing(cos, &eta, &tau)
    }
}

/// (1 − F(cos, η))·e^(−τ/cos θ') per lane, θ' the refracted angle inside the coat.
#[inline(always)]
pub fn crossing<F: Float>(cos: F, eta: &Spec<F>, tau: &Spec<F>) -> Spec<F> {
    let one = F::splat(1.0);
    let c = cos.clamp(0.0, 1.0);
    let mut out = Spec::zero();
    for k in 0..4 {
        let e = eta[k];
        let cos_t = (one - (one - c * c) / (e * e)).max(F::splat(1e-6)).sqrt();
        let t = one - fresnel_dielectric(c, e);
        out[k] = t * math::exp(-(tau[k] / cos_t));
    }
    out
}

/// r: the fraction of diffuse light going up inside a coat of index `eta` and optical
/// depth `tau` that comes back down to the base (internal Fresnel reflection, with the
/// layer's absorption on the way up and down): 2∫₀¹ F(μ, 1/η)·e^(−2τ/μ)·μ dμ.
pub fn internal_reflectance(eta: f32, tau: f32) -> f32 {
    let n = 2000;
    let mut sum = 0.0f64;
    for i in 0..n {
        let mu = (i as f64 + 0.5) / n as f64;
        let f = f64::from(fresnel_dielectric(mu as f32, 1.0 / eta));
        sum += f * (-2.0 * f64::from(tau) / mu).exp() * mu;
    }
    (2.0 * sum / n as f64) as f32
}

#[cfg(test)]
mod tests {
    use super::*;

    /// 1 − r_internal = (1 − r_external)/η² for a clear coat: what enters diffusely leaves.
    #[test]
    fn internal_and_external_diffuse_reflectance_balance() {
        for eta in [1.33f32, 1.5, 2.0] {
            let r_int = internal_reflectance(eta, 0.0);
            let n = 4000;
            let r_ext: f64 = (0..n)
                .map(|i| {
                    let mu = (i as f64 + 0.5) / n as f64;
                    2.0 * f64::from(fresnel_dielectric(mu as f32, eta)) * mu / n as f64
                })
                .sum();
            let lhs = 1.0 - f64::from(r_int);
            let rhs = (1.0 - r_ext) / f64::from(eta * eta);
            assert!((lhs - rhs).abs() < 2e-3, "η {eta}: {lhs} vs {rhs}");
        }
        // Absorption only lowers what comes back.
        assert!(internal_reflectance(1.5, 0.3) < internal_reflectance(1.5, 0.0));
    }
}
