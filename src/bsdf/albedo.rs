//! How much light a rough dielectric interface reflects: the directional albedo
//! E(μ, η, α) = ∫ F·D·G₂/(4μ) dωi of GGX reflection (isotropic width α) at incidence
//! cosine μ and relative index η. A rough coat passes 1 − E of the light arriving at μ
//! on to its base (Kelemen & Szirmay-Kalos 2001; Mitsuba 3's `roughplastic`), the
//! rough counterpart of 1 − F at a smooth coat.
//!
//! E has no closed form. [`reflection_albedo`] integrates it over the visible normals of
//! ωo with a stratified product rule (the integrand F·G₂/G₁ is smooth and bounded by 1);
//! [`external`] interpolates a table of it over μ, η ∈ [1, 3] and √α, built once on first
//! use (about 23 000 entries; 0.6 s of one core, spread over the
//! thread pool). At α = 0 the table holds Fresnel exactly.

use super::microfacet::Ggx;
use super::{fresnel_dielectric, reflect};
use crate::simd::{Float, V3};
use rayon::prelude::*;
use std::sync::OnceLock;

/// The table's nodes: μ in [0, 1], η in [`ETA_MIN`, `ETA_MAX`], √α in [0, 1].
const N_MU: usize = 64;
const N_ETA: usize = 21;
const N_ALPHA: usize = 17;
/// The range of coat indices the table covers (the coat parser enforces it).
pub const ETA_MIN: f32 = 1.0;
/// See [`ETA_MIN`].
pub const ETA_MAX: f32 = 3.0;
/// Quadrature points per axis of the visible-normal square.
const N_QUAD: usize = 24;

/// E(μ, η, α) by quadrature over the normals visible from μ (α ≥ 0; α = 0 is Fresnel).
/// η < 1 (light inside the coat) includes total internal reflection.
pub fn reflection_albedo(mu: f32, eta: f32, alpha: f32) -> f32 {
    let mu = mu.clamp(1e-4, 1.0);
    if alpha <= 0.0 {
        return fresnel_dielectric(mu, eta);
    }
    let ggx = Ggx::<f32>::new(alpha, alpha);
    let wo = V3::<f32>::new((1.0 - mu * mu).max(0.0).sqrt(), 0.0, mu);
    let g1 = ggx.g1(wo);
    let mut sum = 0.0f64;
    for i in 0..N_QUAD {
        for j in 0..N_QUAD {
            let u = [
                (i as f32 + 0.5) / N_QUAD as f32,
                (j as f32 + 0.5) / N_QUAD as f32,
            ];
            let m = ggx.sample_visible(wo, u);
            let wi = reflect(wo, m);
            if wi.z <= 0.0 {
                continue;
            }
            let f = fresnel_dielectric(wo.dot(m), eta);
            sum += f64::from(f * ggx.g2(wo, wi) / g1);
        }
    }
    (sum / (N_QUAD * N_QUAD) as f64) as f32
}

/// The tabulated E over (√α, η, μ), μ fastest.
fn table() -> &'static [f32] {
    static TABLE: OnceLock<Vec<f32>> = OnceLock::new();
    TABLE.get_or_init(|| {
        let rows: Vec<Vec<f32>> = (0..N_ALPHA)
            .into_par_iter()
            .map(|a| {
                let s = a as f32 / (N_ALPHA - 1) as f32;
                let mut t = Vec::with_capacity(N_ETA * N_MU);
                for e in 0..N_ETA {
                    let eta = ETA_MIN + (ETA_MAX - ETA_MIN) * e as f32 / (N_ETA - 1) as f32;
                    for m in 0..N_MU {
                        let mu = m as f32 / (N_MU - 1) as f32;
                        t.push(reflection_albedo(mu, eta, s * s));
                    }
                }
                t
            })
            .collect();
        rows.concat()
    })
}

/// Position `x` ∈ [0, 1] on `n` nodes: the lower node and the weight of the upper one.
#[inline(always)]
fn node(x: f32, n: usize) -> (usize, f32) {
    let x = x.clamp(0.0, 1.0) * (n - 1) as f32;
    let i = (x as usize).min(n - 2);
    (i, x - i as f32)
}

/// E(μ, η, α) from the table, trilinear (η clamped to [`ETA_MIN`], [`ETA_MAX`]).
pub fn external_one(mu: f32, eta: f32, alpha: f32) -> f32 {
    let t = table();
    let (a, wa) = node(alpha.max(0.0).sqrt(), N_ALPHA);
    let (e, we) = node((eta - ETA_MIN) / (ETA_MAX - ETA_MIN), N_ETA);
    let (m, wm) = node(mu, N_MU);
    let at = |a: usize, e: usize| {
        let row = &t[(a * N_ETA + e) * N_MU..][..N_MU];
        row[m] + wm * (row[m + 1] - row[m])
    };
    let along_eta = |a: usize| at(a, e) + we * (at(a, e + 1) - at(a, e));
    along_eta(a) + wa * (along_eta(a + 1) - along_eta(a))
}

/// [`external_one`] per path.
#[inline(always)]
pub fn external<F: Float>(mu: F, eta: F, alpha: F) -> F {
    F::from_fn(|i| external_one(mu.get(i), eta.get(i), alpha.get(i)))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// At α → 0 the rough albedo is Fresnel; it never exceeds 1 and grows towards grazing.
    #[test]
    fn albedo_limits() {
        for mu in [0.1f32, 0.5, 0.9] {
            let e = reflection_albedo(mu, 1.5, 1e-3);
            let f = fresnel_dielectric(mu, 1.5);
            assert!((e - f).abs() < 2e-3, "μ {mu}: {e} vs Fresnel {f}");
        }
        for alpha in [0.05f32, 0.3, 1.0] {
            let (a, b) = (
                reflection_albedo(0.9, 1.5, alpha),
                reflection_albedo(0.1, 1.5, alpha),
            );
            assert!(a > 0.0 && a < b && b <= 1.0, "α {alpha}: {a}, {b}");
        }
        // Inside a coat, diffuse-ish light beyond the critical angle comes back.
        assert!(reflection_albedo(0.3, 1.0 / 1.5, 0.1) > 0.9);
    }

    /// The quadrature against a brute-force integral of F·D·G₂/(4μ) over the hemisphere.
    #[test]
    fn quadrature_matches_the_hemisphere_integral() {
        let (mu, eta, alpha) = (0.6f32, 1.5f32, 0.3f32);
        let ggx = Ggx::<f32>::new(alpha, alpha);
        let wo = V3::<f32>::new((1.0 - mu * mu).sqrt(), 0.0, mu);
        let n = 1500;
        let mut sum = 0.0f64;
        for i in 0..n {
            for j in 0..n {
                let s = (i as f64 + 0.5) / n as f64;
                let ct = 1.0 - s * s;
                let phi = 2.0 * std::f64::consts::PI * (j as f64 + 0.5) / n as f64;
                let st = (1.0 - ct * ct).max(0.0).sqrt();
                let wi =
                    V3::<f32>::new((st * phi.cos()) as f32, (st * phi.sin()) as f32, ct as f32);
                let h = (wo + wi).normalize();
                let f = fresnel_dielectric(wo.dot(h), eta) * ggx.d(h) * ggx.g2(wo, wi) / (4.0 * mu);
                let w = 2.0 * s / n as f64 * 2.0 * std::f64::consts::PI / n as f64;
                sum += f64::from(f) * w;
            }
        }
        let e = reflection_albedo(mu, eta, alpha);
        assert!((f64::from(e) - sum).abs() < 5e-3 * sum, "{e} vs {sum}");
    }

    /// The table reproduces the quadrature between its nodes (to 1 % of E, 0.35 % of 1 − E).
    #[test]
    fn table_interpolates_the_quadrature() {
        for (mu, eta, alpha) in [
            (0.37f32, 1.52f32, 0.2f32),
            (0.83, 1.33, 0.07),
            (0.12, 2.2, 0.6),
        ] {
            let (t, q) = (
                external_one(mu, eta, alpha),
                reflection_albedo(mu, eta, alpha),
            );
            assert!(
                (t - q).abs() < 1e-2 * q,
                "μ {mu} η {eta} α {alpha}: {t} vs {q}"
            );
        }
        let (t, f) = (external_one(0.5, 1.5, 0.0), fresnel_dielectric(0.5, 1.5));
        assert!((t - f).abs() < 1e-3, "smooth: {t} vs Fresnel {f}");
    }
}
