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

pub mod render;

use crate::accel::Ray;
use crate::bsdf::Material;
use crate::fluoro::Reradiation;
use crate::sampler::{LazyStream, Pcg32};
use crate::scene::Scene;
use crate::spectrum::{LAMBDA_MAX, LAMBDA_MIN};
use glam::{Vec3, Vec4};

/// How wavelengths are sampled per path.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Spectral {
    /// Hero wavelength spectral sampling: four wavelengths per path.
    Hwss,
    /// One wavelength per path.
    Mono,
}

impl Spectral {
    /// The name used on the command line and in reports.
    pub fn name(self) -> &'static str {
        match self {
            Spectral::Hwss => "hwss",
            Spectral::Mono => "mono",
        }
    }
}

/// How the four lanes of a path move at a fluorescent vertex (HWSS only).
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Shifting {
    /// Every lane samples its own shift with its own random numbers, weighted f_k/p_k.
    Independent,
    /// Every lane moves by the hero's shift Δλ; the shift pdfs enter the MIS weights.
    Constant,
}

impl Shifting {
    /// The name used on the command line and in reports.
    pub fn name(self) -> &'static str {
        match self {
            Shifting::Independent => "independent",
            Shifting::Constant => "constant",
        }
    }
}

/// Counters of one render (summed over threads).
#[derive(Debug, Default, Clone, Copy)]
pub struct PathStats {
    /// Rays traced: camera, bounce and shadow rays.
    pub rays: u64,
    /// Samples that came out NaN or infinite and were dropped.
    pub nonfinite: u64,
}

/// Offset for spawning rays off a surface, relative to the scene's scale.
#[inline]
fn spawn_eps(p: Vec3) -> f32 {
    1e-4 * (1.0 + p.abs().max_element())
}

/// The last emitter's spectral radiance at the path's wavelengths: a path meets the same
/// light again and again (every light sample, every emitter hit), and its wavelengths do
/// not change.
#[derive(Default)]
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

/// A shadow ray between two surface points, both pushed off their surfaces towards each
/// other. The ray runs between the *offset* points: measuring the length from the
/// unshifted point instead makes the ray reach the light's own surface at grazing angles.
#[inline]
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

/// Radiance along a camera ray at the wavelengths `lambda`, already weighted by the
/// balance heuristic over lanes: summing `xyz(λ_k)·L_k / pdf(λ)` over the lanes gives an
/// unbiased XYZ estimate.
///
/// `shift_rng` draws the wavelength shifts at fluorescent vertices: a stream of its own,
/// so that a scene renders with the same main random numbers whether or not a material
/// fluoresces (a diagonal-only re-radiation matrix then gives the plain diffuse image).
#[allow(clippy::too_many_arguments)]
pub fn radiance(
    scene: &Scene,
    camera_ray: Ray,
    mut lambda: Vec4,
    spectral: Spectral,
    shifting: Shifting,
    max_depth: i32,
    rng: &mut Pcg32,
    shift_rng: &mut LazyStream,
    stats: &mut PathStats,
) -> Vec4 {
    let mut beta = match spectral {
        Spectral::Hwss => Vec4::ONE,
        Spectral::Mono => Vec4::X,
    };
    let mut ratio = beta;
    let mut l = Vec4::ZERO;
    let mut ray = camera_ray;
    // After a non-specular bounce: the per-lane BSDF pdfs of the sampled direction and the
    // prefix ratios before it, for MIS when the ray lands on a light.
    let mut prev_bsdf: Option<(Vec4, Vec4, Vec3)> = None;
    let mut depth: i32 = 0;
    let lights = &scene.lights;
    let mut le_cache = EmissionCache::default();

    loop {
        stats.rays += 1;
        let Some(hit) = scene.accel.intersect1(&ray) else {
            break;
        };
        depth += 1;
        let p = ray.org + ray.dir * hit.t;
        let ng = hit.ng.normalize();
        let wo = -ray.dir;

        if let Some(e) = lights.emitter_index_of(hit.geom_id) {
            let le = if lights.emitters[e as usize].emits_towards(ng.dot(wo)) {
                le_cache.get(e, lambda, lights)
            } else {
                Vec4::ZERO
            };
            if le != Vec4::ZERO {
                match prev_bsdf {
                    None => l += beta * le / ratio.element_sum(),
                    Some((pdf_bsdf, ratio_prev, p_prev)) => {
                        let d2 = (p - p_prev).length_squared();
                        let cos_l = ng.dot(wo).abs();
                        let p_light =
                            lights.pdf_area(hit.geom_id, hit.prim_id) * d2 / cos_l.max(1e-12);
                        let denom = (ratio_prev * (pdf_bsdf + Vec4::splat(p_light))).element_sum();
                        // beta already holds f/p_bsdf,0; put the hero's pdf back.
                        l += beta * le * (pdf_bsdf.x / denom);
                    }
                }
            }
        }
        if max_depth >= 0 && depth >= max_depth {
            break;
        }
        let Some(mat_id) = scene.geometries[hit.geom_id as usize].material else {
            break;
        };
        let mat = &scene.materials[mat_id as usize];
        if let Material::FluorescentDiffuse { reradiation } = mat {
            let lanes = match spectral {
                Spectral::Hwss => shifting,
                Spectral::Mono => Shifting::Independent,
            };
            if !shift_wavelengths(
                reradiation,
                lanes,
                &mut lambda,
                &mut beta,
                &mut ratio,
                shift_rng.get(),
            ) {
                break;
            }
            le_cache = EmissionCache::default();
        }
        let material = mat.at(lambda);

        // Next-event estimation: one point on a light, MIS against BSDF sampling.
        let u_light = [rng.next_f32(), rng.next_f32(), rng.next_f32()];
        if !material.is_specular() {
            if let Some(ls) = lights.sample(u_light) {
                let to = ls.p - p;
                let d2 = to.length_squared();
                let d = d2.sqrt();
                let wi = to / d;
                let cos_l = ls.n.dot(-wi);
                let le = if lights.emitters[ls.emitter as usize].emits_towards(cos_l) {
                    le_cache.get(ls.emitter, lambda, lights)
                } else {
                    Vec4::ZERO
                };
                if le != Vec4::ZERO && d > 0.0 {
                    let (f_cos, pdf_bsdf) = material.eval(ng, wo, wi);
                    if f_cos != Vec4::ZERO {
                        let p_light = ls.pdf_area * d2 / cos_l.abs();
                        let shadow = shadow_ray(p, ng, ls.p, ls.n, wi);
                        stats.rays += 1;
                        if !scene.accel.occluded1(&shadow) {
                            let denom = (ratio * (Vec4::splat(p_light) + pdf_bsdf)).element_sum();
                            l += beta * f_cos * le / denom;
                        }
                    }
                }
            }
        }

        // Continue the path with the hero's BSDF sample.
        let uc = rng.next_f32();
        let u2 = rng.next_2d();
        let Some(bs) = material.sample(ng, wo, uc, u2) else {
            break;
        };
        let p0 = bs.pdf.x;
        if p0 <= 0.0 {
            break;
        }
        let ratio_prev = ratio;
        beta *= bs.f_cos / p0;
        ratio *= bs.pdf / p0;
        prev_bsdf = if bs.specular {
            None
        } else {
            Some((bs.pdf, ratio_prev, p))
        };
        if beta == Vec4::ZERO {
            break;
        }

        // Russian roulette on the weighted throughput, after a few bounces.
        if depth >= 3 {
            let q = beta.max_element().min(0.95);
            if rng.next_f32() >= q {
                break;
            }
            beta /= q;
        }
        let eps = spawn_eps(p);
        ray = Ray::new(p + ng * eps * ng.dot(bs.wi).signum(), bs.wi);
    }
    l
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
    rr: &Reradiation,
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
