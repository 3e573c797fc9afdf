//! Rough conductors and rough dielectrics: GGX microfacets ([`super::microfacet`]) with
//! Fresnel per wavelength.
//!
//! The microfacet geometry (D, G, the half vector of a reflection) does not depend on the
//! wavelength, so a rough conductor's lanes share their pdf and differ only in Fresnel. A
//! rough dielectric's transmission does depend on it: each lane has its own generalised
//! half vector ωo + η(λ)·ωi (Walter et al. 2007), so each lane gets its own BTDF value
//! and its own pdf of the sampled direction, and the balance heuristic over lanes takes
//! care of dispersion — no lane is dropped and no path has to split, unlike at a smooth
//! interface.
//!
//! Directions are sampled with the hero's wavelength and then evaluated for every lane
//! by the same routine that light sampling uses ([`eval_conductor`], [`eval_dielectric`]),
//! so sampled and evaluated pdfs agree by construction.
//!
//! Side tests use the geometric normal `ng` (no light through back faces), the lobe
//! itself the shading frame: both must agree on which side ωi is, or the value is 0.

use super::microfacet::{fresnel_conductor, Frame, Ggx};
use super::{fresnel_dielectric, Normals};
use crate::simd::{Float, Mask, Spec, V3};

/// The shading frame oriented to `wo`'s side of the surface (its first tangent the mesh's
/// ∂p/∂u where it has one), and `wo` in it.
#[inline(always)]
pub(super) fn frame_towards<F: Float>(nrm: &Normals<F>, wo: V3<F>) -> (Frame<F>, V3<F>, F::Mask) {
    let front = nrm.ng.dot(wo).gt(F::splat(0.0));
    let n = V3::select(front, nrm.ns, -nrm.ns);
    let frame = Frame::oriented(n, nrm.t, nrm.has_t);
    (frame, frame.to_local(wo), front)
}

/// f·|cos θᵢ| and the pdf of reflecting `wo` into `wi` off a rough conductor with
/// per-wavelength index `eta` + i`k`, per lane.
#[inline(always)]
pub fn eval_conductor<F: Float>(
    ggx: &Ggx<F>,
    eta: &Spec<F>,
    k: &Spec<F>,
    nrm: &Normals<F>,
    wo: V3<F>,
    wi: V3<F>,
) -> (Spec<F>, Spec<F>) {
    let zero = F::splat(0.0);
    let (frame, lo, _) = frame_towards(nrm, wo);
    let li = frame.to_local(wi);
    let ok = (nrm.ng.dot(wo) * nrm.ng.dot(wi)).gt(zero) & lo.z.gt(zero) & li.z.gt(zero);
    let wh = (lo + li).normalize();
    let c = lo.dot(wh);
    let d_g = ggx.d(wh) * ggx.g2(lo, li) / (F::splat(4.0) * lo.z);
    let pdf = (ggx.pdf_visible(lo, wh) / (F::splat(4.0) * c)).masked(ok & c.gt(zero));
    let fr = eta.zip(*k, |e, k| fresnel_conductor(c, e, k));
    ((fr * d_g).masked(ok), Spec::broadcast(pdf))
}

/// A direction off a rough conductor from the visible normals of `wo` (`u`): the local
/// sample turned to world space. [`eval_conductor`] gives its value and pdf.
#[inline(always)]
pub fn sample_conductor<F: Float>(ggx: &Ggx<F>, nrm: &Normals<F>, wo: V3<F>, u: [F; 2]) -> V3<F> {
    let (frame, lo, _) = frame_towards(nrm, wo);
    let wh = ggx.sample_visible(lo, u);
    frame.to_world(super::reflect(lo, wh))
}

/// f·|cos θᵢ| and the pdf of scattering `wo` into `wi` at a rough dielectric whose
/// interior index is `n_in` (per wavelength) and exterior index `ext`, per lane. The pdf
/// includes the probability Fresnel gives the chosen event (reflection or refraction).
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub fn eval_dielectric<F: Float>(
    ggx: &Ggx<F>,
    n_in: &Spec<F>,
    ext: F,
    nrm: &Normals<F>,
    wo: V3<F>,
    wi: V3<F>,
) -> (Spec<F>, Spec<F>) {
    let zero = F::splat(0.0);
    let one = F::splat(1.0);
    let (frame, lo, front) = frame_towards(nrm, wo);
    let li = frame.to_local(wi);
    // n_t/n_i per lane, i on wo's side.
    let eta = n_in.map(|n| F::select(front, n / ext, ext / n));
    let side = nrm.ng.dot(wo) * nrm.ng.dot(wi);
    let g2 = ggx.g2(lo, li);
    let valid = lo.z.gt(zero);

    // Reflection: one half vector for every lane.
    let refl = valid & side.gt(zero) & li.z.gt(zero);
    let wh = (lo + li).normalize();
    let c = lo.dot(wh);
    let refl = refl & c.gt(zero);
    let d_g = ggx.d(wh) * g2 / (F::splat(4.0) * lo.z);
    let p_refl = ggx.pdf_visible(lo, wh) / (F::splat(4.0) * c);
    let fr = eta.map(|e| fresnel_dielectric(c, e));
    let mut f = (fr * d_g).masked(refl);
    let mut pdf = (fr * p_refl).masked(refl);

    // Refraction: each lane its own generalised half vector.
    let refr = valid & side.lt(zero) & li.z.lt(zero);
    if refr.any() {
        for k in 0..4 {
            let e = eta[k];
            let m = lo + li * e;
            let m = (m * F::splat(1.0).copysign(m.z)).normalize();
            let (co, ci) = (lo.dot(m), li.dot(m));
            let ok = refr & co.gt(zero) & ci.lt(zero);
            let denom = (ci + co / e).sq();
            let t = one - fresnel_dielectric(co, e);
            let jac = ci.abs() / denom;
            let fk = ggx.d(m) * g2 * t * co * jac / (lo.z * e * e);
            let pk = ggx.pdf_visible(lo, m) * jac * t;
            f[k] = F::select(ok, fk, f[k]);
            pdf[k] = F::select(ok, pk, pdf[k]);
        }
    }
    (f, pdf)
}

/// A direction at a rough dielectric for the hero wavelength: a visible normal of `wo`
/// (`u`), then reflection with the hero's Fresnel probability (`uc`), else refraction
/// through that normal. [`eval_dielectric`] gives its value and pdf per lane; the mask
/// says which samples stay on the side their event belongs to. A reflection that leaves
/// below the macro-surface must be discarded, not evaluated: [`eval_dielectric`] would
/// read it as a refraction, whose pdf does not count this way of reaching it, and the
/// estimate would come out too bright (likewise a refraction that leaves above).
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub fn sample_dielectric<F: Float>(
    ggx: &Ggx<F>,
    n_in_hero: F,
    ext: F,
    nrm: &Normals<F>,
    wo: V3<F>,
    uc: F,
    u: [F; 2],
) -> (V3<F>, F::Mask) {
    let zero = F::splat(0.0);
    let (frame, lo, front) = frame_towards(nrm, wo);
    let eta = F::select(front, n_in_hero / ext, ext / n_in_hero);
    let wh = ggx.sample_visible(lo, u);
    let fr = fresnel_dielectric(lo.dot(wh), eta);
    let (wt, ok) = super::refract(lo, wh, eta);
    let refl = uc.lt(fr) | !ok;
    let li = V3::select(refl, super::reflect(lo, wh), wt);
    let valid = F::select(refl, li.z, -li.z).gt(zero);
    (frame.to_world(li), valid)
}
