//! One camera path as a state machine, so that single-ray and packet tracing run the
//! same estimator: a driver traces the path's current ray, hands the hit to
//! [`Path::step`], traces the shadow ray the step asked for, and repeats until the path
//! ends. The single-ray driver ([`super::radiance`]) does this for one path, depth
//! first; the packet driver ([`super::packet`]) for many paths at once, four rays per
//! Embree query.
//!
//! A shadow ray is deferred, not traced inside the step: its contribution depends on
//! nothing the step computes afterwards and the step draws no random numbers for it, so
//! a path's random numbers and its sum of contributions come out in the same order under
//! both drivers. With media, a shadow ray crosses index-matched boundaries one segment
//! at a time ([`MediaShadow`]); the drivers trace each segment as a query of its own.

use super::{
    medium_after_crossing, russian_roulette, shadow_ray, shift_wavelengths, spawn_eps,
    EmissionCache, MediaShadow, PathOptions, PathStats, PrevVertex, ShiftModel,
};
use crate::accel::{Hit, Ray};
use crate::bsdf::{Lobe, Material};
use crate::medium::tracking::{self, DistanceSample};
use crate::method::{Dispersion, Shifting, Spectral};
use crate::sampler::{mix64, LazyStream, Pcg32};
use crate::scene::Scene;
use glam::{Vec3, Vec4};

/// A next-event shadow ray the path asks its driver to trace.
#[derive(Debug, Clone, Copy)]
pub struct ShadowQuery {
    /// From the shading point to the light sample (in media: the current segment).
    pub ray: Ray,
    /// Without media: what the path adds if nothing blocks the ray. With media: β·f·L_e,
    /// to be multiplied by the transmittance and divided by the MIS sum.
    pub contribution: Vec4,
    /// In scenes with media: the ray's state from segment to segment (index-matched
    /// boundaries are crossed, see [`MediaShadow::segment`]).
    pub media: Option<MediaShadow>,
}

/// The lane layout of a path's result: all four camera wavelengths, or, for a path split
/// off at a dispersive refraction, the one camera lane its lane 0 continues.
pub const ALL_LANES: u8 = 4;

/// The state of one camera path between two ray queries.
#[derive(Clone)]
pub struct Path {
    /// The ray to trace next.
    pub ray: Ray,
    /// The radiance gathered so far (lanes as given by `out_lane`).
    pub l: Vec4,
    /// [`ALL_LANES`], or the camera lane this split-off path's lane 0 stands for.
    pub out_lane: u8,
    /// The driver's index of the pixel sample this path belongs to.
    pub slot: u32,
    /// Whether the next query is the camera ray (coherent within a pixel quad).
    pub at_camera: bool,
    lambda: Vec4,
    beta: Vec4,
    ratio: Vec4,
    prev: Option<PrevVertex>,
    depth: i32,
    medium: Option<u32>,
    crossings: u32,
    le_cache: EmissionCache,
    rng: Pcg32,
    shift_rng: LazyStream,
    lanes: Shifting,
}

impl Path {
    /// A path about to trace `camera_ray` at the wavelengths `lambda`, drawing its
    /// decisions from `rng` and its wavelength shifts from `shift_rng`.
    pub fn new(
        scene: &Scene,
        camera_ray: Ray,
        lambda: Vec4,
        opts: &PathOptions,
        rng: Pcg32,
        shift_rng: LazyStream,
        slot: u32,
    ) -> Path {
        let beta = match opts.method.spectral {
            Spectral::Hwss => Vec4::ONE,
            Spectral::Mono => Vec4::X,
        };
        Path {
            ray: camera_ray,
            l: Vec4::ZERO,
            out_lane: ALL_LANES,
            slot,
            at_camera: true,
            lambda,
            beta,
            ratio: beta,
            prev: None,
            depth: 0,
            medium: scene.camera_medium,
            crossings: 0,
            le_cache: EmissionCache::default(),
            rng,
            shift_rng,
            lanes: match opts.method.spectral {
                Spectral::Hwss => opts.method.shifting,
                Spectral::Mono => Shifting::Independent,
            },
        }
    }

    /// Adds this path's radiance to `acc`, the pixel sample's value at the camera
    /// wavelengths.
    #[inline]
    pub fn add_to(&self, acc: &mut Vec4) {
        if self.out_lane == ALL_LANES {
            *acc += self.l;
        } else {
            acc[self.out_lane as usize] += self.l.x;
        }
    }

    /// Advances the path by the result `hit` of tracing [`Path::ray`]: gathers emission
    /// and light, samples the next direction. Returns whether the path goes on (its next
    /// ray in [`Path::ray`]). A next-event shadow ray to trace is left in `shadow`; a
    /// split at a dispersive refraction ends this path and leaves its single-wavelength
    /// continuations in `children`.
    #[inline(always)]
    pub fn step<const MEDIA: bool>(
        &mut self,
        scene: &Scene,
        opts: &PathOptions,
        hit: Option<Hit>,
        stats: &mut PathStats,
        shadow: &mut Option<ShadowQuery>,
        children: &mut Vec<Path>,
    ) -> bool {
        stats.rays += 1;
        self.at_camera = false;
        let lights = &scene.lights;
        let max_depth = opts.max_depth;
        let ray = self.ray;

        // Distance sampling in the current medium, hero-driven with per-lane pdfs.
        if let (true, Some(m)) = (MEDIA, self.medium) {
            let Some(h) = hit else { return false }; // left a medium that is not closed
            let med = &scene.media[m as usize];
            let (st, ss) = (med.sigma_t_hat(self.lambda), med.sigma_s_hat(self.lambda));
            let d = h.t * ray.dir.length();
            match tracking::sample_distance(opts.method.tracking, st, ss, d, self.rng.next_f32()) {
                DistanceSample::Collision { t } => {
                    let pdf = tracking::pdf_collision(opts.method.tracking, st, ss, d, t);
                    if pdf.x <= 0.0 {
                        return false;
                    }
                    self.beta *= tracking::transmittance(st, t) / pdf.x;
                    self.ratio *= pdf / pdf.x;
                    self.depth += 1;
                    if max_depth >= 0 && self.depth >= max_depth {
                        return false;
                    }
                    let p = ray.org + ray.dir.normalize() * t;
                    let wo = -ray.dir.normalize();
                    // The scattering coefficient σ̂_s enters through the shift sample
                    // (its value over its pdf is σ̂_s: elastic or fluorescent).
                    if !self.shift(med) {
                        return false;
                    }
                    let phase = med.phase();
                    // Next-event estimation through the medium, MIS against phase sampling.
                    let u_light = [
                        self.rng.next_f32(),
                        self.rng.next_f32(),
                        self.rng.next_f32(),
                    ];
                    if let Some((ls, wi, p_light)) = lights.sample_towards(p, u_light) {
                        let le = self.le_cache.get(ls.emitter, self.lambda, lights);
                        let f = phase.eval_dirs(wo, wi);
                        let pdf_dir = phase.pdf(wo, wi);
                        let sray = shadow_ray(p, Vec3::ZERO, ls.p, ls.n, wi);
                        stats.rays += 1;
                        *shadow = Some(ShadowQuery {
                            ray: sray,
                            contribution: self.beta * le * f,
                            media: Some(MediaShadow::new(
                                Some(m),
                                self.lambda,
                                self.ratio,
                                p_light,
                                Vec4::splat(pdf_dir),
                            )),
                        });
                    }
                    let (wi, pdf_dir) = phase.sample(wo, self.rng.next_2d());
                    if pdf_dir <= 0.0 {
                        return false;
                    }
                    // Phase sampling is exact (f = pdf) and the same for every lane.
                    self.prev = Some(PrevVertex {
                        pdf_dir: Vec4::splat(pdf_dir),
                        ratio: self.ratio,
                        p,
                        pass: Vec4::ONE,
                    });
                    if !russian_roulette(&mut self.beta, self.depth, &mut self.rng) {
                        return false;
                    }
                    self.ray = Ray::new(p, wi);
                    return true;
                }
                DistanceSample::Surface => {
                    let ps = tracking::prob_surface(opts.method.tracking, st, ss, d);
                    if ps.x <= 0.0 {
                        return false;
                    }
                    self.beta *= tracking::transmittance(st, d) / ps.x;
                    self.ratio *= ps / ps.x;
                    if let Some(pv) = self.prev.as_mut() {
                        pv.pass *= ps;
                    }
                }
            }
        }

        let Some(hit) = hit else { return false };
        let p = ray.org + ray.dir * hit.t;
        let ng = hit.ng.normalize();
        let geom = &scene.geometries[hit.geom_id as usize];

        // An index-matched medium boundary: cross it without scattering.
        if MEDIA && geom.is_null_interface() {
            self.crossings += 1;
            if self.crossings > 256 {
                return false;
            }
            self.medium = medium_after_crossing(scene, hit.geom_id, ng, ray.dir);
            let eps = spawn_eps(p);
            self.ray = Ray::new(p + ng * (eps * ng.dot(ray.dir).signum()), ray.dir);
            return true;
        }
        self.depth += 1;
        let wo = -ray.dir;

        if let Some(e) = lights.emitter_index_of(hit.geom_id) {
            let le = if lights.emitters[e as usize].emits_towards(ng.dot(wo)) {
                self.le_cache.get(e, self.lambda, lights)
            } else {
                Vec4::ZERO
            };
            if le != Vec4::ZERO {
                match self.prev {
                    None => self.l += self.beta * le / self.ratio.element_sum(),
                    Some(pv) => {
                        let d2 = (p - pv.p).length_squared();
                        let cos_l = ng.dot(wo).abs();
                        let p_light =
                            lights.pdf_area(hit.geom_id, hit.prim_id) * d2 / cos_l.max(1e-12);
                        let p_dir = pv.pdf_dir * pv.pass;
                        let denom = (pv.ratio * (p_dir + Vec4::splat(p_light))).element_sum();
                        // beta already holds f/p_dir,0 (and the passes' T/P_0): put the
                        // hero's pdf back.
                        self.l += self.beta * le * (p_dir.x / denom);
                    }
                }
            }
        }
        if max_depth >= 0 && self.depth >= max_depth {
            return false;
        }
        let Some(mat_id) = geom.material else {
            return false;
        };
        let mat = &scene.materials[mat_id as usize];
        if let Material::FluorescentDiffuse { reradiation } = mat {
            if !self.shift(reradiation.as_ref()) {
                return false;
            }
        }
        let material = mat.at(self.lambda);

        // Next-event estimation: one point on a light, MIS against BSDF sampling.
        let u_light = [
            self.rng.next_f32(),
            self.rng.next_f32(),
            self.rng.next_f32(),
        ];
        if !material.is_specular() {
            if let Some((ls, wi, p_light)) = lights.sample_towards(p, u_light) {
                let (f_cos, pdf_bsdf) = material.eval(ng, wo, wi);
                if f_cos != Vec4::ZERO {
                    let le = self.le_cache.get(ls.emitter, self.lambda, lights);
                    let sray = shadow_ray(p, ng, ls.p, ls.n, wi);
                    stats.rays += 1;
                    *shadow = Some(if MEDIA {
                        // Leaving the surface towards wi: which medium is the shadow ray in?
                        let m_out = if ng.dot(wi) * ng.dot(wo) > 0.0 {
                            self.medium
                        } else {
                            medium_after_crossing(scene, hit.geom_id, ng, wi)
                        };
                        ShadowQuery {
                            ray: sray,
                            contribution: self.beta * f_cos * le,
                            media: Some(MediaShadow::new(
                                m_out,
                                self.lambda,
                                self.ratio,
                                p_light,
                                pdf_bsdf,
                            )),
                        }
                    } else {
                        let denom = (self.ratio * (Vec4::splat(p_light) + pdf_bsdf)).element_sum();
                        ShadowQuery {
                            ray: sray,
                            contribution: self.beta * f_cos * le / denom,
                            media: None,
                        }
                    });
                }
            }
        }

        // Continue the path with the hero's BSDF sample.
        let uc = self.rng.next_f32();
        let u2 = self.rng.next_2d();
        let Some(bs) = material.sample(ng, wo, uc, u2) else {
            return false;
        };
        let p0 = bs.pdf.x;
        if p0 <= 0.0 {
            return false;
        }
        let refracts = ng.dot(bs.wi) * ng.dot(wo) < 0.0;
        if opts.method.dispersion == Dispersion::Split
            && bs.specular
            && refracts
            && (1..4).any(|k| self.ratio[k] != 0.0 && bs.pdf[k] == 0.0)
        {
            self.split::<MEDIA>(scene, &material, p, ng, wo, hit.geom_id, children);
            return false;
        }
        let ratio_prev = self.ratio;
        self.beta *= bs.f_cos / p0;
        self.ratio *= bs.pdf / p0;
        self.prev = if bs.specular {
            None
        } else {
            Some(PrevVertex {
                pdf_dir: bs.pdf,
                ratio: ratio_prev,
                p,
                pass: Vec4::ONE,
            })
        };
        if self.beta == Vec4::ZERO {
            return false;
        }
        // Crossing the surface (refraction) changes the medium.
        if MEDIA && refracts {
            self.medium = medium_after_crossing(scene, hit.geom_id, ng, bs.wi);
        }
        if !russian_roulette(&mut self.beta, self.depth, &mut self.rng) {
            return false;
        }
        let eps = spawn_eps(p);
        self.ray = Ray::new(p + ng * eps * ng.dot(bs.wi).signum(), bs.wi);
        true
    }

    /// A wavelength-shifting event (fluorescent surface or medium scattering): samples
    /// the lanes' input wavelengths ([`shift_wavelengths`]) and forgets the cached
    /// emission, whose wavelengths are gone. `false` ends the path.
    #[inline]
    fn shift(&mut self, model: &(impl ShiftModel + ?Sized)) -> bool {
        let alive = shift_wavelengths(
            model,
            self.lanes,
            &mut self.lambda,
            &mut self.beta,
            &mut self.ratio,
            self.shift_rng.get(),
        );
        self.le_cache = EmissionCache::default();
        alive
    }

    /// Splits the path at a dispersive refraction (the hero refracted and some live lane
    /// refracts elsewhere) into one single-wavelength path per live lane, each leaving in
    /// its own direction.
    ///
    /// Lane k's path is the shared prefix, the choice to refract, then its own suffix.
    /// Every "lane j as hero" technique generates it with p_j(prefix)·(1 − F_j), times the
    /// suffix's pdf, which is the same for every technique and cancels. So the child
    /// carries beta_k·(1 − F_k)/η_k² / (1 − F_0) and, as its only ratio, the prefix's MIS
    /// denominator Σ_j ratio_j·(1 − F_j)/(1 − F_0); from there on it is a mono path.
    #[allow(clippy::too_many_arguments)]
    #[cold]
    fn split<const MEDIA: bool>(
        &mut self,
        scene: &Scene,
        material: &Lobe,
        p: Vec3,
        ng: Vec3,
        wo: Vec3,
        geom: u32,
        children: &mut Vec<Path>,
    ) {
        let Some((dirs, f_cos, pdf)) = material.refract_lanes(ng, wo) else {
            return;
        };
        let p0 = pdf.x;
        if p0 <= 0.0 {
            return;
        }
        let denom = (self.ratio * pdf / p0).element_sum();
        // The children's random streams: keyed by two draws of this path's stream, so
        // they are the same under every driver.
        let key = ((self.rng.next_u32() as u64) << 32) | self.rng.next_u32() as u64;
        let eps = spawn_eps(p);
        for (k, wi) in dirs.into_iter().enumerate() {
            let Some(wi) = wi else { continue };
            let b = self.beta[k] * f_cos[k] / p0;
            if b == 0.0 || !b.is_finite() {
                continue;
            }
            let mut child = Path {
                ray: Ray::new(p + ng * eps * ng.dot(wi).signum(), wi),
                l: Vec4::ZERO,
                out_lane: k as u8,
                slot: self.slot,
                at_camera: false,
                lambda: Vec4::splat(self.lambda[k]),
                beta: Vec4::new(b, 0.0, 0.0, 0.0),
                ratio: Vec4::new(denom, 0.0, 0.0, 0.0),
                prev: None,
                depth: self.depth,
                medium: if MEDIA {
                    medium_after_crossing(scene, geom, ng, wi)
                } else {
                    self.medium
                },
                crossings: self.crossings,
                le_cache: EmissionCache::default(),
                rng: Pcg32::new(mix64(key), k as u64),
                shift_rng: LazyStream::new(key, k as u64, u64::MAX),
                lanes: Shifting::Independent,
            };
            if russian_roulette(&mut child.beta, child.depth, &mut child.rng) {
                children.push(child);
            }
        }
    }
}
