//! Unidirectional spectral path tracing with next-event estimation, MIS between light and
//! BSDF sampling, Russian roulette, and hero wavelength spectral sampling (HWSS), written
//! once over the lane width ([`crate::simd`]): W camera paths advance together, W = 1 for
//! single rays and W = 4 for Embree's 4-wide packets.
//!
//! Bookkeeping of one path over its four lanes (lane 0 is the hero, which drives every
//! sampling decision):
//! - `beta[k]` = f_k / p_0 over the prefix: lane k's value over the hero's pdf;
//! - `ratio[j]` = p_j / p_0 over the prefix: how likely lane j, had it been the hero,
//!   was to generate the same prefix.
//!
//! A contribution of lane k is then `beta[k] · L / Σ_j ratio[j]` — the balance heuristic
//! over the four "hero = j" techniques — and, at a vertex where light sampling and BSDF
//! sampling compete, the denominator becomes Σ_j ratio[j]·(p_light,j + p_bsdf,j) in the
//! hero's units. Monochromatic mode is the same code with lanes 1–3 dead from the start
//! (`ratio = (1, 0, 0, 0)`). docs/design.md §3 derives the rules.
//!
//! - [`path`]: [`path::Paths`], the state of W paths, and `step`, the estimator;
//! - [`shadow`]: next-event shadow rays, traced after the step (through media one
//!   segment at a time);
//! - [`trace`]: the driver that feeds pixel samples to the W lanes and Embree;
//! - [`render`]: passes, the film and progressive renders.

pub mod census;
pub mod path;
pub mod render;
pub mod shadow;
pub mod trace;

use crate::accel::Ray;
use crate::fluoro::map::Printed;
use crate::fluoro::Reradiation;
use crate::medium::Homogeneous;
use crate::method::{Resolved, Shifting};
use crate::sampler::{LazyStream, Pcg32, Streams};
use crate::scene::Scene;
use crate::simd::{Float, Spec, V3};
use crate::spectrum::{LAMBDA_MAX, LAMBDA_MIN};
use glam::{Vec3, Vec4};

/// Counters of one render (summed over threads).
#[derive(Debug, Default, Clone, Copy)]
pub struct PathStats {
    /// Rays traced: camera, bounce and shadow rays.
    pub rays: u64,
    /// Samples that came out NaN or infinite and were dropped.
    pub nonfinite: u64,
    /// Packet mode: lanes of the 4-wide queries that carried a ray.
    pub lanes_used: u64,
    /// Packet mode: lanes of all 4-wide queries (4 per query).
    pub lanes_total: u64,
    /// Packet modes, scenes with media: paths that started a step inside a medium, and
    /// the lanes of the packets that had any (how busy the medium's parts run).
    pub medium_lanes_used: u64,
    pub medium_lanes_total: u64,
    /// Packet modes: paths whose camera ray a step traced, and the lanes of the packets
    /// that traced any (how full the camera packets ran).
    pub camera_lanes_used: u64,
    pub camera_lanes_total: u64,
}

impl PathStats {
    /// Adds another thread's or pass's counters.
    pub fn add(&mut self, o: &PathStats) {
        self.rays += o.rays;
        self.nonfinite += o.nonfinite;
        self.lanes_used += o.lanes_used;
        self.lanes_total += o.lanes_total;
        self.medium_lanes_used += o.medium_lanes_used;
        self.medium_lanes_total += o.medium_lanes_total;
        self.camera_lanes_used += o.camera_lanes_used;
        self.camera_lanes_total += o.camera_lanes_total;
    }

    /// The share of packet lanes that carried a ray (`None` without packets).
    pub fn occupancy(&self) -> Option<f64> {
        (self.lanes_total > 0).then(|| self.lanes_used as f64 / self.lanes_total as f64)
    }

    /// The share of busy lanes in the packet steps that started with a path inside a
    /// medium (`None` without packets or without such steps).
    pub fn medium_occupancy(&self) -> Option<f64> {
        (self.medium_lanes_total > 0)
            .then(|| self.medium_lanes_used as f64 / self.medium_lanes_total as f64)
    }

    /// The share of busy lanes in the packet steps that traced camera rays (`None`
    /// without packets).
    pub fn camera_occupancy(&self) -> Option<f64> {
        (self.camera_lanes_total > 0)
            .then(|| self.camera_lanes_used as f64 / self.camera_lanes_total as f64)
    }
}

/// Offset for spawning rays off a surface, relative to the scene's scale.
#[inline(always)]
pub(crate) fn spawn_eps<F: Float>(p: V3<F>) -> F {
    F::splat(1e-4) * (F::splat(1.0) + p.abs_max())
}

/// `p` pushed off its surface (normal `n`) by [`spawn_eps`] to the side `dir` leaves
/// towards.
#[inline(always)]
pub(crate) fn offset<F: Float>(p: V3<F>, n: V3<F>, dir: V3<F>) -> V3<F> {
    p + n * (spawn_eps(p) * F::splat(1.0).copysign(n.dot(dir)))
}

/// Everything that selects an estimator, besides the random numbers: the method (with
/// its tracking resolved once per render) and the path depth.
#[derive(Debug, Clone, Copy)]
pub struct PathOptions {
    /// The method.
    pub method: Resolved,
    /// Path segments from the camera, −1 for unbounded.
    pub max_depth: i32,
}

/// Shadow rays between points, each pushed off its surface (`n = 0` for a point in a
/// medium) towards the other: origins, unit directions and segment ends. The rays run
/// between the *offset* points: measuring the length from the unshifted point instead
/// makes the ray reach the light's own surface at grazing angles.
#[inline(always)]
pub fn shadow_ray<F: Float>(
    p: V3<F>,
    n: V3<F>,
    q: V3<F>,
    nq: V3<F>,
    wi: V3<F>,
) -> (V3<F>, V3<F>, F) {
    let org = offset(p, n, wi);
    let target = q - nq * (spawn_eps(q) * F::splat(1.0).copysign(nq.dot(wi)));
    let to = target - org;
    let len = to.length();
    (org, to / len, len * F::splat(1.0 - 1e-5))
}

/// The medium on the other side of geometry `geom` for a ray travelling along `dir`
/// (meshes bounding a medium face outwards); [`NO_MEDIUM`] for none.
#[inline]
fn medium_after_crossing(scene: &Scene, geom: u32, ng: Vec3, dir: Vec3) -> u32 {
    let g = &scene.geometries[geom as usize];
    let m = if dir.dot(ng) < 0.0 {
        g.interior
    } else {
        g.exterior
    };
    m.unwrap_or(NO_MEDIUM)
}

/// "In no medium", in the per-path medium indices.
pub const NO_MEDIUM: u32 = u32::MAX;

/// Radiance along a camera ray at the wavelengths `lambda`, already weighted by the
/// balance heuristic over lanes: summing `xyz(λ_k)·L_k / pdf(λ)` over the lanes gives an
/// unbiased XYZ estimate (at the camera's wavelengths, whatever shifts happen later).
/// One path traced with single rays ([`trace::trace_one`]); renders trace W at a time.
///
/// `shift_rng` draws the wavelength shifts at fluorescent events: a stream of its own,
/// so that a scene renders with the same main random numbers whether or not a material
/// fluoresces (a diagonal-only re-radiation matrix then gives the plain diffuse image).
pub fn radiance(
    scene: &Scene,
    camera_ray: Ray,
    lambda: Vec4,
    opts: &PathOptions,
    rng: Streams<f32>,
    shift_rng: LazyStream,
    stats: &mut PathStats,
) -> Vec4 {
    let path = path::Paths::camera(scene, camera_ray, lambda, opts, rng, shift_rng);
    trace::trace_one(scene, opts, path, stats)
}

/// A wavelength-shifting scattering event: re-radiation at a fluorescent surface (D =
/// reflectance) or scattering in a medium (D = σ_s, F from its dye).
pub trait ShiftModel {
    /// Samples an input wavelength for output `lambda_o`.
    fn sample_input(
        &self,
        lambda_o: f32,
        u_choice: f32,
        u_lambda: f32,
    ) -> Option<crate::fluoro::ShiftSample>;
    /// The pdf [`ShiftModel::sample_input`] gives that event.
    fn pdf_input(&self, lambda_i: f32, lambda_o: f32, kept: bool) -> f32;
    /// The value of that event.
    fn value(&self, lambda_i: f32, lambda_o: f32, kept: bool) -> f32;
}

impl ShiftModel for Reradiation {
    #[inline]
    fn sample_input(
        &self,
        lambda_o: f32,
        u_choice: f32,
        u_lambda: f32,
    ) -> Option<crate::fluoro::ShiftSample> {
        Reradiation::sample_input(self, lambda_o, u_choice, u_lambda)
    }
    #[inline]
    fn pdf_input(&self, lambda_i: f32, lambda_o: f32, kept: bool) -> f32 {
        Reradiation::pdf_input(self, lambda_i, lambda_o, kept)
    }
    #[inline]
    fn value(&self, lambda_i: f32, lambda_o: f32, kept: bool) -> f32 {
        Reradiation::value(self, lambda_i, lambda_o, kept)
    }
}

impl ShiftModel for Printed<'_> {
    #[inline]
    fn sample_input(
        &self,
        lambda_o: f32,
        u_choice: f32,
        u_lambda: f32,
    ) -> Option<crate::fluoro::ShiftSample> {
        let (d, s) = (self.d(lambda_o), self.strength());
        self.reradiation()
            .sample_input_with(d, s, lambda_o, u_choice, u_lambda)
    }
    #[inline]
    fn pdf_input(&self, lambda_i: f32, lambda_o: f32, kept: bool) -> f32 {
        let (d, s) = (self.d(lambda_o), self.strength());
        self.reradiation()
            .pdf_input_with(d, s, lambda_i, lambda_o, kept)
    }
    #[inline]
    fn value(&self, lambda_i: f32, lambda_o: f32, kept: bool) -> f32 {
        let (d, s) = (self.d(lambda_o), self.strength());
        self.reradiation()
            .value_with(d, s, lambda_i, lambda_o, kept)
    }
}

impl ShiftModel for Homogeneous {
    #[inline]
    fn sample_input(
        &self,
        lambda_o: f32,
        u_choice: f32,
        u_lambda: f32,
    ) -> Option<crate::fluoro::ShiftSample> {
        self.sample_shift(lambda_o, u_choice, u_lambda)
    }
    #[inline]
    fn pdf_input(&self, lambda_i: f32, lambda_o: f32, kept: bool) -> f32 {
        self.shift_pdf(lambda_i, lambda_o, kept)
    }
    #[inline]
    fn value(&self, lambda_i: f32, lambda_o: f32, kept: bool) -> f32 {
        self.shift_value(lambda_i, lambda_o, kept)
    }
}

/// Samples the input wavelengths at a fluorescent vertex of one camera path and updates
/// its lanes: `lambda` becomes the wavelengths before re-radiation, `beta` takes the value
/// over the hero's pdf, `ratio` the pdf ratios of the "lane j as hero" techniques. Returns
/// `false` when the hero cannot continue (the path ends). A path's shift is sampled from
/// table searches lane by lane, so W paths call this one after the other.
///
/// - Independent: each live lane draws its own shift; its weight is M_k/q_k = D + σ_se at
///   its wavelength, and the shift pdfs, common to every technique, cancel from `ratio`.
///   A lane that cannot shift (D + σ_se = 0) is zeroed and leaves the MIS sum.
/// - Constant: the hero draws the shift and every lane follows it (kept wavelengths stay,
///   shifted ones move by the same Δλ); lane k's technique has pdf q_k(λ_k+Δλ | λ_k) —
///   the keep probability for a kept wavelength, a density for a shift, never mixed.
pub fn shift_wavelengths(
    rr: &(impl ShiftModel + ?Sized),
    mode: Shifting,
    lambda: &mut Vec4,
    beta: &mut Vec4,
    ratio: &mut Vec4,
    rng: &mut Pcg32,
) -> bool {
    match mode {
        Shifting::Independent => {
            for k in 0..4 {
                if ratio[k] == 0.0 && beta[k] == 0.0 {
                    continue; // a dead lane (mono, or dropped earlier)
                }
                let (uc, ul) = (rng.next_f32(), rng.next_f32());
                match rr.sample_input(lambda[k], uc, ul) {
                    Some(s) if s.pdf > 0.0 => {
                        beta[k] *= s.value / s.pdf;
                        lambda[k] = s.lambda_i;
                    }
                    _ => {
                        if k == 0 {
                            return false;
                        }
                        beta[k] = 0.0;
                        ratio[k] = 0.0;
                    }
                }
            }
            true
        }
        Shifting::Constant => {
            let (uc, ul) = (rng.next_f32(), rng.next_f32());
            let Some(h) = rr.sample_input(lambda.x, uc, ul) else {
                return false;
            };
            if h.pdf <= 0.0 {
                return false;
            }
            let delta = h.lambda_i - lambda.x;
            for k in 0..4 {
                let lo = lambda[k];
                let li = if h.kept { lo } else { lo + delta };
                let (value, pdf) = if k == 0 {
                    (h.value, h.pdf)
                } else if (LAMBDA_MIN..LAMBDA_MAX).contains(&li) {
                    (rr.value(li, lo, h.kept), rr.pdf_input(li, lo, h.kept))
                } else {
                    (0.0, 0.0)
                };
                if pdf > 0.0 {
                    beta[k] *= value / h.pdf;
                    ratio[k] *= pdf / h.pdf;
                } else {
                    beta[k] = 0.0;
                    ratio[k] = 0.0;
                }
                lambda[k] = li;
            }
            true
        }
    }
}

/// Path `i` of `lambda`, `beta` and `ratio` through [`shift_wavelengths`].
#[inline]
fn shift_path<F: Float>(
    rr: &(impl ShiftModel + ?Sized),
    mode: Shifting,
    i: usize,
    lambda: &mut Spec<F>,
    beta: &mut Spec<F>,
    ratio: &mut Spec<F>,
    rng: &mut Pcg32,
) -> bool {
    let (mut l, mut b, mut r) = (lambda.path(i), beta.path(i), ratio.path(i));
    let alive = shift_wavelengths(rr, mode, &mut l, &mut b, &mut r, rng);
    lambda.set_path(i, l);
    beta.set_path(i, b);
    ratio.set_path(i, r);
    alive
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fluoro::map::FluorescenceMap;
    use crate::spectrum::Spectrum;
    use crate::texture::scalar::ScalarTexture;
    use glam::Vec2;

    /// A print at full strength with the dye's own diagonal is the dye itself: every shift,
    /// constant or independent, leaves the same wavelengths, weights and MIS ratios, bit for
    /// bit (the map passes D(λo) and s = 1 to the same arithmetic). Catches a print that
    /// drops or misweighs the secondary lanes, which no image test can see: such a print
    /// is still unbiased, only noisier.
    #[test]
    fn a_full_strength_print_with_its_own_diagonal_shifts_as_the_dye() {
        let emission = Spectrum::NarrowBand {
            centre: 560.0,
            fwhm: 40.0,
        };
        let rr = Reradiation::from_dye(
            Spectrum::Constant(0.3),
            &Spectrum::Constant(0.5),
            &emission,
            0.9,
            5.0,
        )
        .unwrap();
        let map = FluorescenceMap {
            diagonal: None,
            strength: ScalarTexture::Constant(1.0),
        };
        let print = map.at(&rr, Vec2::new(0.25, 0.75));
        let range = LAMBDA_MAX - LAMBDA_MIN;
        let mut all_lanes_shifted = 0;
        for mode in [Shifting::Constant, Shifting::Independent] {
            for n in 0..400u64 {
                let hero = 380.0 + 0.9 * n as f32;
                let lambda = Vec4::from_array(
                    [0.0, 0.25, 0.5, 0.75]
                        .map(|k| LAMBDA_MIN + (hero - LAMBDA_MIN + k * range) % range),
                );
                let run = |model: &dyn ShiftModel| {
                    let (mut l, mut b, mut r) = (lambda, Vec4::ONE, Vec4::ONE);
                    let mut rng = Pcg32::for_sample(3, n, 1);
                    let alive = shift_wavelengths(model, mode, &mut l, &mut b, &mut r, &mut rng);
                    let bits = |v: Vec4| v.to_array().map(f32::to_bits);
                    (alive, bits(l), bits(b), bits(r))
                };
                let (want, got) = (run(&rr), run(&print));
                assert_eq!(
                    got, want,
                    "{mode:?}, hero {hero} nm: the print shifts otherwise"
                );
                let kept = |k: usize| want.1[k] == lambda[k].to_bits();
                let every_lane = (1..4).all(|k| f32::from_bits(want.3[k]) > 0.0 && !kept(k));
                all_lanes_shifted += usize::from(want.0 && every_lane);
            }
        }
        assert!(
            all_lanes_shifted > 50,
            "only {all_lanes_shifted} shifts moved every lane: the test would not see lanes dropped"
        );
    }
}
