//! The GGX (Trowbridge–Reitz) microfacet distribution with Smith's height-correlated
//! masking–shadowing, and sampling of the normals visible from a direction.
//!
//! Everything works in a local frame whose z axis is the (shading) normal: the routines
//! take and return local directions, [`Frame`] converts. Roughness is the distribution's
//! width α per tangent axis (α = 0 is a perfect mirror; α = 1 is very rough); the
//! material parsers take α directly, as Mitsuba 3's `alpha` and pbrt-v4's unremapped
//! roughness do, so scenes carry over.
//!
//! Visible normals are drawn with the spherical-cap method of Dupuy & Benyoub (2023,
//! *Sampling Visible GGX Normals with Spherical Caps*): in the configuration stretched to
//! α = 1, the visible normals of direction ω are the half vectors between ω and a
//! uniform direction on the spherical cap z > −ω_z. Its density is Heitz's
//! D_ω(m) = G₁(ω)·max(0, ω·m)·D(m)/ω_z (Heitz 2018), which [`Ggx::pdf_visible`] returns.

use crate::simd::{math, Float, Mask, V3};
use std::f32::consts::PI;

/// An orthonormal frame around a unit normal: world ↔ local (z along the normal).
#[derive(Debug, Clone, Copy)]
pub struct Frame<F: Float> {
    /// First tangent.
    pub t: V3<F>,
    /// Second tangent.
    pub b: V3<F>,
    /// The normal.
    pub n: V3<F>,
}

impl<F: Float> Frame<F> {
    /// The frame of [`V3::basis`] around `n`: its tangents orient anisotropic roughness.
    #[inline(always)]
    pub fn new(n: V3<F>) -> Frame<F> {
        let (t, b) = n.basis();
        Frame { t, b, n }
    }

    /// The frame around `n` whose first tangent is `t` made orthogonal to `n`, for the
    /// paths of `has` where that is not degenerate; [`Frame::new`]'s elsewhere.
    #[inline(always)]
    pub fn oriented(n: V3<F>, t: V3<F>, has: F::Mask) -> Frame<F> {
        let basis = Frame::new(n);
        if has.none() {
            return basis;
        }
        let tp = t - n * n.dot(t);
        let len2 = tp.length_squared();
        let ok = has & len2.gt(F::splat(1e-12));
        let tp = tp * (F::splat(1.0) / len2.max(F::splat(1e-12)).sqrt());
        Frame {
            t: V3::select(ok, tp, basis.t),
            b: V3::select(ok, n.cross(tp), basis.b),
            n,
        }
    }

    /// World → local.
    #[inline(always)]
    pub fn to_local(&self, v: V3<F>) -> V3<F> {
        V3::new(v.dot(self.t), v.dot(self.b), v.dot(self.n))
    }

    /// Local → world.
    #[inline(always)]
    pub fn to_world(&self, v: V3<F>) -> V3<F> {
        self.t * v.x + self.b * v.y + self.n * v.z
    }
}

/// GGX with widths `ax`, `ay` along the frame's two tangents (per path).
#[derive(Debug, Clone, Copy)]
pub struct Ggx<F: Float> {
    /// α along the first tangent.
    pub ax: F,
    /// α along the second tangent.
    pub ay: F,
}

impl<F: Float> Ggx<F> {
    /// The distribution with widths `ax`, `ay`.
    #[inline(always)]
    pub fn new(ax: F, ay: F) -> Ggx<F> {
        Ggx { ax, ay }
    }

    /// D(m): microfacet normals per unit solid angle per unit projected area (local `m`,
    /// unit length); 0 below the surface.
    #[inline(always)]
    pub fn d(&self, m: V3<F>) -> F {
        let zero = F::splat(0.0);
        let s = (m.x / self.ax).sq() + (m.y / self.ay).sq() + m.z.sq();
        let d = F::splat(1.0) / (F::splat(PI) * self.ax * self.ay * s * s);
        d.masked(m.z.gt(zero))
    }

    /// Smith's Λ(ω) for the local unit direction ω (both hemispheres).
    #[inline(always)]
    pub fn lambda(&self, w: V3<F>) -> F {
        let t2 = ((self.ax * w.x).sq() + (self.ay * w.y).sq()) / w.z.sq();
        F::splat(0.5) * ((F::splat(1.0) + t2).sqrt() - F::splat(1.0))
    }

    /// G₁(ω) = 1 / (1 + Λ(ω)): the fraction of the normals visible from ω.
    #[inline(always)]
    pub fn g1(&self, w: V3<F>) -> F {
        F::splat(1.0) / (F::splat(1.0) + self.lambda(w))
    }

    /// Height-correlated G₂(ωo, ωi) = 1 / (1 + Λ(ωo) + Λ(ωi)).
    #[inline(always)]
    pub fn g2(&self, wo: V3<F>, wi: V3<F>) -> F {
        F::splat(1.0) / (F::splat(1.0) + self.lambda(wo) + self.lambda(wi))
    }

    /// A normal visible from the local direction `wo` (wo.z > 0), drawn from D_wo with the
    /// 2-D sample `u`.
    #[inline(always)]
    pub fn sample_visible(&self, wo: V3<F>, u: [F; 2]) -> V3<F> {
        let one = F::splat(1.0);
        // Stretch to α = 1, where the visible normals are those of a hemisphere.
        let ws = V3::new(wo.x * self.ax, wo.y * self.ay, wo.z).normalize();
        // A uniform direction on the spherical cap z ∈ (−ws.z, 1].
        let (sin_phi, cos_phi) = math::sin_cos_turns(u[0]);
        let z = (one - u[1]) * (one + ws.z) - ws.z;
        let sin_theta = (one - z * z).max(F::splat(0.0)).sqrt();
        let c = V3::new(sin_theta * cos_phi, sin_theta * sin_phi, z);
        // The half vector, unstretched.
        let h = c + ws;
        V3::new(h.x * self.ax, h.y * self.ay, h.z.max(F::splat(0.0))).normalize()
    }

    /// D_wo(m) = G₁(wo)·max(0, wo·m)·D(m)/wo.z: the density of [`Ggx::sample_visible`]
    /// (per solid angle of m; wo.z > 0).
    #[inline(always)]
    pub fn pdf_visible(&self, wo: V3<F>, m: V3<F>) -> F {
        let c = wo.dot(m).max(F::splat(0.0));
        self.g1(wo) * c * self.d(m) / wo.z
    }
}

/// Unpolarised Fresnel reflectance of a conductor with complex relative index η + ik at
/// the incidence cosine `cos_i` (in [0, 1]); the standard closed form (e.g. Born & Wolf,
/// *Principles of Optics*, §14.2), which reduces to the dielectric one at k = 0.
#[inline(always)]
pub fn fresnel_conductor<F: Float>(cos_i: F, eta: F, k: F) -> F {
    let zero = F::splat(0.0);
    let c2 = cos_i.clamp(0.0, 1.0).sq();
    let s2 = F::splat(1.0) - c2;
    let (e2, k2) = (eta * eta, k * k);
    let t0 = e2 - k2 - s2;
    // |n̂² − sin²θ| = a² + b², with a the real part of √(n̂² − sin²θ).
    let a2b2 = (t0 * t0 + F::splat(4.0) * e2 * k2).max(zero).sqrt();
    let a = (F::splat(0.5) * (a2b2 + t0)).max(zero).sqrt();
    let two_a_c = F::splat(2.0) * a * c2.sqrt();
    let rs = (a2b2 + c2 - two_a_c) / (a2b2 + c2 + two_a_c);
    let t3 = c2 * a2b2 + s2 * s2;
    let t4 = two_a_c * s2;
    let rp = rs * (t3 - t4) / (t3 + t4);
    let r = F::splat(0.5) * (rs + rp);
    // Grazing incidence on a lossless match (0/0): total reflection is the limit.
    F::select(r.is_finite(), r, F::splat(1.0)).clamp(0.0, 1.0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::fresnel_dielectric;
    use crate::sampler::Pcg32;
    use glam::Vec3;

    fn v(x: f32, y: f32, z: f32) -> V3<f32> {
        V3::from(Vec3::new(x, y, z).normalize())
    }

    #[test]
    fn conductor_fresnel_limits() {
        // k = 0: the dielectric formula.
        for c in [0.05f32, 0.3, 0.7, 1.0] {
            let (a, b) = (fresnel_conductor(c, 1.5, 0.0), fresnel_dielectric(c, 1.5));
            assert!((a - b).abs() < 1e-5, "cos {c}: {a} vs {b}");
        }
        // Normal incidence: ((η−1)² + k²)/((η+1)² + k²).
        let (eta, k) = (0.2f32, 3.0f32);
        let want = ((eta - 1.0).powi(2) + k * k) / ((eta + 1.0).powi(2) + k * k);
        assert!((fresnel_conductor(1.0, eta, k) - want).abs() < 1e-5);
        // A perfect conductor reflects everything; grazing incidence reflects everything.
        assert!(fresnel_conductor(0.4, 1.0, 1e4) > 0.9999);
        assert!(fresnel_conductor(0.0, 0.2, 3.0) > 0.9999);
    }

    /// ∫ D(m) m_z dm = 1 (the projected microfacet area is the macro-surface's).
    #[test]
    fn ggx_normalised_and_visible_area() {
        for (ax, ay) in [(0.1f32, 0.1f32), (0.5, 0.5), (0.3, 0.8), (1.0, 1.0)] {
            let g = Ggx::<f32>::new(ax, ay);
            let n = 600;
            let (mut proj, mut vis) = (0f64, 0f64);
            let wo = v(0.5, 0.2, 0.6);
            // Quadrature in (cos θ, φ) with cos θ squeezed towards 1 for narrow lobes.
            for i in 0..n {
                for j in 0..n {
                    let s = (i as f64 + 0.5) / n as f64;
                    let ct = 1.0 - s * s; // dcosθ = 2s ds
                    let phi = 2.0 * std::f64::consts::PI * (j as f64 + 0.5) / n as f64;
                    let st = (1.0 - ct * ct).max(0.0).sqrt();
                    let m = V3::from(Vec3::new(
                        (st * phi.cos()) as f32,
                        (st * phi.sin()) as f32,
                        ct as f32,
                    ));
                    let w = 2.0 * s / n as f64 * 2.0 * std::f64::consts::PI / n as f64;
                    proj += f64::from(g.d(m)) * ct * w;
                    vis += f64::from(g.pdf_visible(wo, m)) * w;
                }
            }
            assert!((proj - 1.0).abs() < 5e-3, "α {ax},{ay}: ∫D cos = {proj}");
            assert!((vis - 1.0).abs() < 5e-3, "α {ax},{ay}: ∫D_wo = {vis}");
        }
    }

    #[test]
    fn visible_normals_face_the_viewer() {
        let g = Ggx::<f32>::new(0.6, 0.2);
        let mut rng = Pcg32::new(3, 4);
        for _ in 0..10_000 {
            let wo = v(
                rng.next_f32() - 0.5,
                rng.next_f32() - 0.5,
                rng.next_f32() + 0.01,
            );
            let m = g.sample_visible(wo, rng.next_2d());
            assert!(m.z >= 0.0 && wo.dot(m) >= -1e-6, "{m:?} for {wo:?}");
            assert!((m.length() - 1.0).abs() < 1e-5);
        }
    }

    #[test]
    fn smith_g1_limits() {
        let g = Ggx::<f32>::new(0.3, 0.3);
        assert!((g.g1(v(0.0, 0.0, 1.0)) - 1.0).abs() < 1e-6);
        assert!(g.g1(v(1.0, 0.0, 0.01)) < 0.1);
        let wo = v(0.3, 0.1, 0.8);
        let wi = v(-0.2, 0.4, 0.7);
        assert!(g.g2(wo, wi) <= g.g1(wo).min(g.g1(wi)) + 1e-7);
    }
}
