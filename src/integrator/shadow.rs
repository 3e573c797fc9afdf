//! Next-event shadow rays of W paths, asked for by the step and traced by the driver
//! after it. Without media a shadow ray is one occlusion query and carries its finished
//! contribution. Through media it is traced one segment at a time across index-matched
//! boundaries: each segment multiplies the transmittance e^{−σ̂_t d} (per lane) and, for
//! MIS, the probability that the tracking method would have passed the segment with lane
//! j as hero; only at the light is the balance heuristic's denominator known.

use super::trace::Hits;
use super::{medium_after_crossing, offset, NO_MEDIUM};
use crate::medium::tracking::{self, Tracking};
use crate::scene::Scene;
use crate::simd::{Float, Lanes, Mask, Spec, V3};
use glam::Vec3;

/// A ray per path: origin, unit direction and segment end.
pub type RaySegment<F> = (V3<F>, V3<F>, F);

/// The shadow rays of W paths.
#[derive(Clone, Copy, Debug)]
pub struct Shadows<F: Float> {
    /// The lanes with a shadow ray to trace.
    pub active: F::Mask,
    /// Origins of the current segments.
    pub org: V3<F>,
    /// Unit directions.
    pub dir: V3<F>,
    /// Segment ends (towards the light).
    pub tfar: F,
    /// Without media: what the path adds if nothing blocks the ray. With media: β·f·L_e,
    /// to be multiplied by the transmittance and divided by the MIS sum.
    pub contribution: Spec<F>,
    /// The medium the current segment runs in.
    medium: F::Arr<u32>,
    /// The paths' wavelengths.
    lambda: Spec<F>,
    /// The paths' MIS ratios at the vertex.
    ratio: Spec<F>,
    /// Solid-angle pdf of the light samples.
    p_light: F,
    /// Per-lane pdf of BSDF or phase sampling the same direction.
    pdf_dir: Spec<F>,
    /// Transmittance so far.
    tr: Spec<F>,
    /// Tracking pass probability so far.
    pass: Spec<F>,
    /// Boundaries crossed so far.
    crossings: F::Arr<u32>,
}

impl<F: Float> Default for Shadows<F> {
    fn default() -> Shadows<F> {
        let zero = Spec::zero();
        Shadows {
            active: F::Mask::splat(false),
            org: V3::splat(Vec3::ZERO),
            dir: V3::splat(Vec3::Z),
            tfar: F::splat(0.0),
            contribution: zero,
            medium: Lanes::splat(NO_MEDIUM),
            lambda: zero,
            ratio: zero,
            p_light: F::splat(0.0),
            pdf_dir: zero,
            tr: zero,
            pass: zero,
            crossings: Lanes::splat(0),
        }
    }
}

impl<F: Float> Shadows<F> {
    /// Shadow rays (no media) for the paths in `m`, adding `contribution` if unblocked.
    #[inline(always)]
    pub fn push(&mut self, m: F::Mask, ray: RaySegment<F>, contribution: Spec<F>) {
        self.active |= m;
        self.org.set_where(m, ray.0);
        self.dir.set_where(m, ray.1);
        self.tfar = F::select(m, ray.2, self.tfar);
        self.contribution.set_where(m, contribution);
    }

    /// Shadow rays through media for the paths in `m`, leaving in `medium`, for vertices
    /// with MIS ratios `ratio`, light pdf `p_light` and direction-sampling pdf `pdf_dir`;
    /// `base` is β·f·L_e.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    pub fn push_media(
        &mut self,
        m: F::Mask,
        ray: RaySegment<F>,
        base: Spec<F>,
        medium: &F::Arr<u32>,
        lambda: &Spec<F>,
        ratio: &Spec<F>,
        p_light: F,
        pdf_dir: Spec<F>,
    ) {
        self.push(m, ray, base);
        self.lambda.set_where(m, *lambda);
        self.ratio.set_where(m, *ratio);
        self.p_light = F::select(m, p_light, self.p_light);
        self.pdf_dir.set_where(m, pdf_dir);
        self.tr.set_where(m, Spec::splat(1.0));
        self.pass.set_where(m, Spec::splat(1.0));
        for i in m.iter() {
            self.medium[i] = medium[i];
            self.crossings[i] = 0;
        }
    }

    /// Accounts for the segments that ended at `hit` (a miss: at the light) and moves the
    /// rays that crossed an index-matched boundary on to their next segment. Returns the
    /// lanes that reached their light and what each adds; the lanes still to trace stay
    /// `active`.
    #[inline(always)]
    pub fn segment(
        &mut self,
        scene: &Scene,
        tracking: Tracking,
        hit: &Hits<F>,
    ) -> (F::Mask, Spec<F>) {
        let m = self.active;
        let seg = F::select(hit.valid, hit.t, self.tfar);
        let inside = m & F::Mask::from_fn(|i| self.medium[i] != NO_MEDIUM);
        if inside.any() {
            let (st, ss) = coefficients(scene, inside, &self.medium, &self.lambda);
            let len = seg * self.dir.length();
            self.tr
                .set_where(inside, self.tr * tracking::transmittance(st, len));
            let ps = tracking::prob_surface(tracking, st, ss, len);
            self.pass.set_where(inside, self.pass * ps);
        }
        let mut reached = m & !hit.valid;
        let hits = m & hit.valid;
        let mut go_on = F::Mask::splat(false);
        for i in hits.iter() {
            self.crossings[i] += 1;
            let g = &scene.geometries[hit.geom[i] as usize];
            if g.is_null_interface() && self.crossings[i] <= 64 {
                go_on = go_on.with(i, true);
            }
        }
        if go_on.any() {
            let ng = hit.ng.normalize();
            for i in go_on.iter() {
                self.medium[i] =
                    medium_after_crossing(scene, hit.geom[i], ng.path(i), self.dir.path(i));
            }
            let p = self.org + self.dir * hit.t;
            let org = offset(p, ng, self.dir);
            let rest = self.tfar - hit.t - super::spawn_eps(p);
            let done = go_on & rest.le(F::splat(0.0));
            reached |= done;
            go_on &= !done;
            self.org.set_where(go_on, org);
            self.tfar = F::select(go_on, rest, self.tfar);
        }
        self.active = go_on;
        let denom = (self.ratio * (Spec::broadcast(self.p_light) + self.pdf_dir * self.pass)).sum();
        (reached, self.contribution * self.tr / denom)
    }
}

/// The camera-path coefficients σ̂_t and σ̂_s at the wavelengths `lambda` of the media
/// `medium` the paths in `m` are in (0 elsewhere).
#[inline(always)]
pub(super) fn coefficients<F: Float>(
    scene: &Scene,
    m: F::Mask,
    medium: &F::Arr<u32>,
    lambda: &Spec<F>,
) -> (Spec<F>, Spec<F>) {
    let both: F::Arr<(glam::Vec4, glam::Vec4)> = Lanes::from_fn(|i| match m.get(i) {
        true => {
            let med = &scene.media[medium[i] as usize];
            let l = lambda.path(i);
            (med.sigma_t_hat(l), med.sigma_s_hat(l))
        }
        false => (glam::Vec4::ZERO, glam::Vec4::ZERO),
    });
    (Spec::from_fn(|i| both[i].0), Spec::from_fn(|i| both[i].1))
}
