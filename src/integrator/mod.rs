//! Unidirectional spectral path tracing with next-event estimation, MIS between light and
//! BSDF sampling, Russian roulette, and hero wavelength spectral sampling (HWSS).
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
//! (`ratio = (1, 0, 0, 0)`).

pub mod packet;
pub mod path;
pub mod render;

use crate::accel::Ray;
use crate::fluoro::Reradiation;
use crate::medium::tracking::{self, Tracking};
use crate::medium::Homogeneous;
use crate::method::{Resolved, Shifting};
use crate::sampler::{LazyStream, Pcg32};
use crate::scene::Scene;
use crate::spectrum::{LAMBDA_MAX, LAMBDA_MIN};
use glam::{Vec3, Vec4};
use path::Path;

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
}

impl PathStats {
    /// Adds another thread's or pass's counters.
    pub fn add(&mut self, o: &PathStats) {
        self.rays += o.rays;
        self.nonfinite += o.nonfinite;
        self.lanes_used += o.lanes_used;
        self.lanes_total += o.lanes_total;
    }

    /// The share of packet lanes that carried a ray (`None` without packets).
    pub fn occupancy(&self) -> Option<f64> {
        (self.lanes_total > 0).then(|| self.lanes_used as f64 / self.lanes_total as f64)
    }
}

/// Offset for spawning rays off a surface, relative to the scene's scale.
#[inline]
pub(crate) fn spawn_eps(p: Vec3) -> f32 {
    1e-4 * (1.0 + p.abs().max_element())
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

/// The last emitter's spectral radiance at the path's wavelengths: a path meets the same
/// light again and again (every light sample, every emitter hit), and its wavelengths do
/// not change between fluorescent events.
#[derive(Default, Clone)]
struct EmissionCache {
    emitter: Option<u32>,
    value: Vec4,
}

impl EmissionCache {
    #[inline]
    fn get(&mut self, e: u32, lambda: Vec4, lights: &crate::light::Lights) -> Vec4 {
        if self.emitter != Some(e) {
            self.emitter = Some(e);
            self.value = lights.emitters[e as usize].spectral_radiance(lambda);
        }
        self.value
    }
}

/// A shadow ray between two points, each pushed off its surface (`n = 0` for a point in
/// a medium) towards the other. The ray runs between the *offset* points: measuring the
/// length from the unshifted point instead makes the ray reach the light's own surface at
/// grazing angles.
#[inline(always)]
pub fn shadow_ray(p: Vec3, n: Vec3, q: Vec3, nq: Vec3, wi: Vec3) -> Ray {
    let org = p + n * (spawn_eps(p) * n.dot(wi).signum());
    let target = q - nq * (spawn_eps(q) * nq.dot(wi).signum());
    let to = target - org;
    let len = to.length();
    Ray {
        org,
        dir: to / len,
        tnear: 0.0,
        tfar: len * (1.0 - 1e-5),
    }
}

/// The medium on the other side of geometry `geom` for a ray travelling along `dir`
/// (meshes bounding a medium face outwards).
#[inline]
fn medium_after_crossing(scene: &Scene, geom: u32, ng: Vec3, dir: Vec3) -> Option<u32> {
    let g = &scene.geometries[geom as usize];
    if dir.dot(ng) < 0.0 {
        g.interior
    } else {
        g.exterior
    }
}

/// A next-event shadow ray through media, traced one segment at a time: each segment
/// ends at the next surface; an index-matched medium boundary is crossed, anything else
/// blocks the ray. Every medium segment multiplies the transmittance e^{−σ̂_t d} (per
/// lane) and, for MIS, the probability that `tracking` would have passed the segment
/// with lane j as hero.
#[derive(Debug, Clone, Copy)]
pub struct MediaShadow {
    /// The medium the current segment runs in.
    medium: Option<u32>,
    /// The path's wavelengths.
    lambda: Vec4,
    /// The path's MIS ratios at the vertex.
    ratio: Vec4,
    /// Solid-angle pdf of the light sample.
    p_light: f32,
    /// Per-lane pdf of BSDF or phase sampling the same direction.
    pdf_dir: Vec4,
    /// Transmittance so far.
    tr: Vec4,
    /// Tracking pass probability so far.
    pass: Vec4,
    /// Boundaries crossed so far.
    crossings: u32,
}

/// Where a shadow ray stands after one traced segment.
pub enum ShadowStep {
    /// Something opaque is in the way (or the ray crossed too many boundaries).
    Blocked,
    /// The light is reached: the path adds this.
    Reached(Vec4),
    /// A boundary was crossed: trace the query's ray again.
    Continue,
}

impl MediaShadow {
    /// A shadow ray leaving in `medium`, for a vertex with MIS ratios `ratio`, light pdf
    /// `p_light` and direction-sampling pdf `pdf_dir`.
    pub(crate) fn new(
        medium: Option<u32>,
        lambda: Vec4,
        ratio: Vec4,
        p_light: f32,
        pdf_dir: Vec4,
    ) -> MediaShadow {
        MediaShadow {
            medium,
            lambda,
            ratio,
            p_light,
            pdf_dir,
            tr: Vec4::ONE,
            pass: Vec4::ONE,
            crossings: 0,
        }
    }

    /// Accounts for the segment of `ray` that ended at `hit` (`None`: at the light) and,
    /// on a crossing, moves `ray` on to the next segment. `base` is the contribution
    /// before transmittance and MIS (β·f·L_e).
    pub fn segment(
        &mut self,
        scene: &Scene,
        ray: &mut Ray,
        hit: Option<crate::accel::Hit>,
        tracking: Tracking,
        base: Vec4,
    ) -> ShadowStep {
        let seg = hit.map_or(ray.tfar, |h| h.t);
        if let Some(m) = self.medium {
            let med = &scene.media[m as usize];
            let (st, ss) = (med.sigma_t_hat(self.lambda), med.sigma_s_hat(self.lambda));
            let len = seg * ray.dir.length();
            self.tr *= tracking::transmittance(st, len);
            self.pass *= tracking::prob_surface(tracking, st, ss, len);
        }
        let reached = |s: &MediaShadow| {
            let denom = (s.ratio * (Vec4::splat(s.p_light) + s.pdf_dir * s.pass)).element_sum();
            ShadowStep::Reached(base * s.tr / denom)
        };
        let Some(h) = hit else {
            return reached(self);
        };
        let g = &scene.geometries[h.geom_id as usize];
        self.crossings += 1;
        if !g.is_null_interface() || self.crossings > 64 {
            return ShadowStep::Blocked;
        }
        let ng = h.ng.normalize();
        self.medium = medium_after_crossing(scene, h.geom_id, ng, ray.dir);
        let p = ray.org + ray.dir * h.t;
        let eps = spawn_eps(p);
        let org = p + ng * (eps * ng.dot(ray.dir).signum());
        let rest = ray.tfar - h.t - eps;
        if rest <= 0.0 {
            return reached(self);
        }
        *ray = Ray {
            org,
            dir: ray.dir,
            tnear: 0.0,
            tfar: rest,
        };
        ShadowStep::Continue
    }
}

/// A vertex that BSDF or phase sampling left, remembered for MIS when the continuation
/// lands on a light.
#[derive(Clone, Copy)]
struct PrevVertex {
    /// Per-lane pdf (solid angle) of the sampled direction.
    pdf_dir: Vec4,
    /// The prefix ratios before that sample.
    ratio: Vec4,
    /// The vertex.
    p: Vec3,
    /// Per-lane probability that tracking passed every medium segment since.
    pass: Vec4,
}

/// Radiance along a camera ray at the wavelengths `lambda`, already weighted by the
/// balance heuristic over lanes: summing `xyz(λ_k)·L_k / pdf(λ)` over the lanes gives an
/// unbiased XYZ estimate (at the camera's wavelengths, whatever shifts happen later).
/// Single rays, depth first; see [`path`] for the steps and [`packet`] for the same
/// estimator over 4-wide packets.
///
/// `shift_rng` draws the wavelength shifts at fluorescent events: a stream of its own,
/// so that a scene renders with the same main random numbers whether or not a material
/// fluoresces (a diagonal-only re-radiation matrix then gives the plain diffuse image).
pub fn radiance(
    scene: &Scene,
    camera_ray: Ray,
    lambda: Vec4,
    opts: &PathOptions,
    rng: Pcg32,
    shift_rng: LazyStream,
    stats: &mut PathStats,
) -> Vec4 {
    let mut path = Path::new(scene, camera_ray, lambda, opts, rng, shift_rng, 0);
    // Scenes without media get a path loop with the medium code compiled out.
    if scene.has_media() {
        trace_single::<true>(scene, opts, &mut path, stats)
    } else {
        trace_single::<false>(scene, opts, &mut path, stats)
    }
}

/// Runs `path` and the paths it splits into to the end with single-ray queries.
fn trace_single<const MEDIA: bool>(
    scene: &Scene,
    opts: &PathOptions,
    path: &mut Path,
    stats: &mut PathStats,
) -> Vec4 {
    let mut acc = Vec4::ZERO;
    let mut split: Vec<Path> = Vec::new(); // allocates only when a path splits
    run_single::<MEDIA>(scene, opts, path, stats, &mut split);
    path.add_to(&mut acc);
    while let Some(mut child) = split.pop() {
        run_single::<MEDIA>(scene, opts, &mut child, stats, &mut split);
        child.add_to(&mut acc);
    }
    acc
}

/// Steps one path to its end, tracing each query as it comes (paths are advanced in
/// place: they are a few hundred bytes, and copying them showed in profiles).
#[inline(always)]
fn run_single<const MEDIA: bool>(
    scene: &Scene,
    opts: &PathOptions,
    p: &mut Path,
    stats: &mut PathStats,
    split: &mut Vec<Path>,
) {
    let mut shadow = None;
    loop {
        let hit = scene.accel.intersect1(&p.ray);
        let alive = p.step::<MEDIA>(scene, opts, hit, stats, &mut shadow, split);
        if let Some(s) = shadow.as_mut() {
            match s.media.as_mut() {
                None => {
                    if !scene.accel.occluded1(&s.ray) {
                        p.l += s.contribution;
                    }
                }
                Some(m) => loop {
                    let hit = scene.accel.intersect1(&s.ray);
                    match m.segment(scene, &mut s.ray, hit, opts.method.tracking, s.contribution) {
                        ShadowStep::Blocked => break,
                        ShadowStep::Reached(c) => {
                            p.l += c;
                            break;
                        }
                        ShadowStep::Continue => stats.rays += 1,
                    }
                },
            }
            shadow = None;
        }
        if !alive {
            break;
        }
    }
}

/// Russian roulette on the weighted throughput after the third bounce: `false` ends the
/// path, otherwise `beta` is divided by the survival probability.
#[inline]
fn russian_roulette(beta: &mut Vec4, depth: i32, rng: &mut Pcg32) -> bool {
    if depth >= 3 {
        let q = beta.max_element().min(0.95);
        if rng.next_f32() >= q {
            return false;
        }
        *beta /= q;
    }
    true
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

/// Samples the input wavelengths at a fluorescent vertex of a camera path and updates the
/// lanes: `lambda` becomes the wavelengths before re-radiation, `beta` takes the value over
/// the hero's pdf, `ratio` the pdf ratios of the "lane j as hero" techniques. Returns
/// `false` when the hero cannot continue (the path ends).
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
