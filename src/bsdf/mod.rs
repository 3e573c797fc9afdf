//! Surface scattering: diffuse, perfect mirror, smooth and rough (optionally dispersive)
//! dielectrics, smooth and rough conductors.
//!
//! Every routine works on the four HWSS lanes at once. Sampling is driven by the hero
//! (lane 0); the result carries each lane's value `f·|cos|` and each lane's pdf of the
//! sampled direction, so that the integrator can form the balance heuristic over lanes.
//! A lane that cannot follow the hero (a refraction through a dispersive interface) gets
//! value 0 and pdf 0: it leaves the MIS sum instead of receiving an infinite weight.
//!
//! # Scene syntax
//! (parsed by [`Material::from_desc`] in [`desc`]; spectra as in [`crate::spectrum::desc`])
//! ```toml
//! [materials.white]
//! type = "diffuse"
//! reflectance = 0.8
//! [materials.mirror]
//! type = "mirror"              # reflectance optional, default 1
//! [materials.glass]
//! type = "dielectric"          # ior: a number, { cauchy = [A, B] } (B in nm²) or Sellmeier
//! ior = { sellmeier = { b = [1.03961212, 0.231792344, 1.01046945], c = [0.00600069867, 0.0200179144, 103.560653] } }
//! ext_ior = 1.0                # optional, the index outside
//! roughness = 0.1              # optional: GGX width α (0, the default: smooth), or [αu, αv]
//! [materials.gold]
//! type = "conductor"           # metal = "Au", "Ag", "Cu" or "Al" (measured, data/metals/),
//! metal = "Au"                 # or eta = SPECTRUM and k = SPECTRUM (η > 0, k ≥ 0)
//! roughness = [0.05, 0.2]      # optional, as for dielectrics; anisotropic widths follow
//!                              # the mesh's texture u and v (∂p/∂u), else an arbitrary frame
//! [materials.glossy_note]
//! type = "coated"              # a smooth or rough clear coat over a diffuse,
//! ior = 1.5                    # fluorescent_diffuse or conductor base; syntax and model
//! roughness = 0.05             # in [`coated`]
//! base = { type = "diffuse", reflectance = 0.8 }
//! [materials.highlighter]
//! type = "fluorescent_diffuse" # a dye over a reflectance, or matrix = "measured.csv"
//! reflectance = 0.8
//! dye = { absorption = { narrow_band = 440, fwhm = 60 }, emission = { narrow_band = 520, fwhm = 40 }, quantum_yield = 0.9 }
//! ```

pub mod albedo;
pub mod coated;
pub mod desc;
pub mod metals;
pub mod microfacet;
pub mod rough;

pub use coated::{CoatBase, Coated, CoatedConductor};
pub use desc::{DyeDesc, IorDesc, IorTable, MaterialDesc, SellmeierDesc};
pub use microfacet::{fresnel_conductor, Frame, Ggx};

use crate::fluoro::map::FluorescenceMap;
use crate::fluoro::Reradiation;
use crate::simd::{math, Float, Mask, Spec, V3};
use crate::spectrum::Spectrum;
use crate::texture::scalar::ScalarTexture;
use crate::texture::Texture;
use glam::{Vec2, Vec3, Vec4};
use std::f32::consts::FRAC_1_PI;
use std::sync::Arc;

/// An index of refraction as a function of wavelength.
#[derive(Debug, Clone)]
pub enum Ior {
    /// The same at every wavelength.
    Constant(f32),
    /// n = a + b/λ² (λ in nm).
    Cauchy {
        /// A
        a: f32,
        /// B in nm²
        b: f32,
    },
    /// n² = 1 + Σ bᵢλ²/(λ² − cᵢ) (λ in µm).
    Sellmeier {
        /// B₁..B₃
        b: [f32; 3],
        /// C₁..C₃ in µm²
        c: [f32; 3],
    },
}

impl Ior {
    /// n at one wavelength (nm).
    pub fn eval(&self, lambda: f32) -> f32 {
        match *self {
            Ior::Constant(n) => n,
            Ior::Cauchy { a, b } => a + b / (lambda * lambda),
            Ior::Sellmeier { b, c } => {
                let l2 = (lambda * 1e-3).powi(2);
                let s: f32 = (0..3).map(|i| b[i] * l2 / (l2 - c[i])).sum();
                (1.0 + s).max(0.0).sqrt()
            }
        }
    }

    /// n at the four lanes.
    pub fn eval4(&self, lambda: Vec4) -> Vec4 {
        match *self {
            Ior::Constant(n) => Vec4::splat(n),
            _ => Vec4::new(
                self.eval(lambda.x),
                self.eval(lambda.y),
                self.eval(lambda.z),
                self.eval(lambda.w),
            ),
        }
    }

    /// n at the four wavelengths of the W paths of `m` (1 elsewhere).
    #[inline(always)]
    pub fn eval_w<F: Float>(&self, lambda: &Spec<F>, m: F::Mask) -> Spec<F> {
        match *self {
            Ior::Constant(n) => Spec::splat(n),
            _ => Spec::from_fn(|i| match m.get(i) {
                true => self.eval4(lambda.path(i)),
                false => Vec4::ONE,
            }),
        }
    }

    /// Whether n varies with wavelength (then refraction splits the lanes).
    pub fn is_dispersive(&self) -> bool {
        !matches!(self, Ior::Constant(_))
    }
}

/// A surface material.
#[derive(Debug, Clone)]
pub enum Material {
    /// Lambertian reflection.
    Diffuse {
        /// Spectral albedo in [0, 1].
        reflectance: Spectrum,
    },
    /// Lambertian reflection with an albedo that varies over the surface.
    TexturedDiffuse {
        /// The albedo at the hit's texture coordinates.
        texture: Arc<Texture>,
    },
    /// Perfect specular reflection.
    Mirror {
        /// Spectral reflectance in [0, 1].
        reflectance: Spectrum,
    },
    /// Perfect specular reflection with a reflectance that varies over the surface.
    TexturedMirror {
        /// The reflectance at the hit's texture coordinates.
        texture: Arc<Texture>,
    },
    /// Lambertian with re-radiation: M(λi→λo)/π · cos θ. The integrator samples the
    /// wavelength shift first ([`crate::fluoro`]); what is left is Lambertian with albedo 1.
    FluorescentDiffuse {
        /// The re-radiation function (its diagonal is the ordinary reflectance).
        reradiation: Arc<Reradiation>,
        /// A diagonal and a dye strength that vary over the surface ([`crate::fluoro::map`]).
        map: Option<Arc<FluorescenceMap>>,
    },
    /// Smooth dielectric interface (Fresnel reflection and refraction).
    Dielectric {
        /// Interior index.
        ior: Ior,
        /// Exterior index.
        ext_ior: f32,
    },
    /// Rough dielectric interface: GGX reflection and refraction ([`rough`]).
    RoughDielectric {
        /// Interior index.
        ior: Ior,
        /// Exterior index.
        ext_ior: f32,
        /// GGX widths along the two tangents.
        alpha: [f32; 2],
        /// An isotropic width that varies over the surface, instead of `alpha`.
        alpha_map: Option<Arc<ScalarTexture>>,
    },
    /// A metal: Fresnel reflection with a complex index η + ik, smooth (`alpha` zero, a
    /// Dirac reflection) or rough (GGX, [`rough`]).
    Conductor {
        /// Real part of the index, relative to the outside.
        eta: Spectrum,
        /// Imaginary part (extinction coefficient).
        k: Spectrum,
        /// GGX widths along the two tangents; [0, 0] for a smooth conductor.
        alpha: [f32; 2],
        /// An isotropic width that varies over the surface, instead of `alpha` (which is
        /// then rough).
        alpha_map: Option<Arc<ScalarTexture>>,
    },
    /// A smooth or rough clear coat over a Lambertian (possibly fluorescent) or a
    /// conductor base ([`coated`]).
    Coated(Arc<Coated>),
}

/// A direction sampled from a material (one path; [`BsdfSamples`] for W paths).
#[derive(Debug, Clone, Copy)]
pub struct BsdfSample {
    /// The new direction (world space, unit length).
    pub wi: Vec3,
    /// Per lane: f·|cos θᵢ| (for a specular event: the discrete weight).
    pub f_cos: Vec4,
    /// Per lane: the pdf (solid angle, or the discrete probability of a specular event)
    /// with which that lane, as hero, would have sampled `wi`.
    pub pdf: Vec4,
    /// A Dirac event: no light sampling at this vertex, no MIS on the next emitter hit.
    pub specular: bool,
}

/// Directions sampled at W paths' vertices ([`Lobes::sample`]).
#[derive(Debug, Clone, Copy)]
pub struct BsdfSamples<F: Float> {
    /// The paths that got a direction.
    pub valid: F::Mask,
    /// The new directions (unit length).
    pub wi: V3<F>,
    /// Per wavelength: f·|cos θᵢ| (for a specular event: the discrete weight).
    pub f_cos: Spec<F>,
    /// Per wavelength: the pdf with which that wavelength, as hero, would have sampled
    /// `wi` (solid angle, or the probability of a specular event).
    pub pdf: Spec<F>,
    /// Dirac events: no light sampling at the vertex, no MIS on the next emitter hit.
    pub specular: F::Mask,
}

/// An orthonormal basis around a unit normal (Duff et al. 2017).
#[inline]
pub fn basis(n: Vec3) -> (Vec3, Vec3) {
    let (t, b) = V3::<f32>::from(n).basis();
    (t.into(), b.into())
}

/// Cosine-weighted directions around the unit normals `n`.
#[inline(always)]
pub fn sample_cosine_w<F: Float>(n: V3<F>, u: [F; 2]) -> V3<F> {
    let r = u[0].sqrt();
    let (sin_phi, cos_phi) = math::sin_cos_turns(u[1]);
    let (t, b) = n.basis();
    let z = (F::splat(1.0) - u[0]).max(F::splat(0.0)).sqrt();
    (t * (r * cos_phi) + b * (r * sin_phi) + n * z).normalize()
}

/// A cosine-weighted direction around `n` (unit).
#[inline]
pub fn sample_cosine(n: Vec3, u: [f32; 2]) -> Vec3 {
    sample_cosine_w(V3::from(n), u).into()
}

/// The solid-angle density with which [`sample_cosine`] produces a direction at cosine
/// `cos_theta` to its axis: cos θ / π in the hemisphere, 0 below it.
#[inline(always)]
pub fn cosine_hemisphere_pdf<F: Float>(cos_theta: F) -> F {
    cos_theta.max(F::splat(0.0)) * F::splat(FRAC_1_PI)
}

/// Unpolarised Fresnel reflectance of a smooth dielectric; `cos_i` > 0 on the incident
/// side, `eta` = n_transmitted / n_incident.
#[inline(always)]
pub fn fresnel_dielectric<F: Float>(cos_i: F, eta: F) -> F {
    let one = F::splat(1.0);
    let cos_i = cos_i.clamp(0.0, 1.0);
    let sin2_t = (one - cos_i * cos_i) / (eta * eta);
    let cos_t = (one - sin2_t).max(F::splat(0.0)).sqrt();
    let r_parl = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    let r_perp = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    let r = F::splat(0.5) * (r_parl * r_parl + r_perp * r_perp);
    F::select(sin2_t.ge(one), one, r)
}

/// Mirror `wo` about `n`.
#[inline(always)]
pub fn reflect<F: Float>(wo: V3<F>, n: V3<F>) -> V3<F> {
    n * (F::splat(2.0) * wo.dot(n)) - wo
}

/// Refracts `wo` (pointing away from the surface, on the side of `n`) with relative index
/// `eta` = n_t/n_i: the direction, and the paths that refract (the others are totally
/// internally reflected; their direction is meaningless).
#[inline(always)]
pub fn refract<F: Float>(wo: V3<F>, n: V3<F>, eta: F) -> (V3<F>, F::Mask) {
    let one = F::splat(1.0);
    let cos_i = wo.dot(n);
    let sin2_t = (one - cos_i * cos_i).max(F::splat(0.0)) / (eta * eta);
    let cos_t = (one - sin2_t).max(F::splat(0.0)).sqrt();
    let wi = (-wo / eta + n * (cos_i / eta - cos_t)).normalize();
    (wi, sin2_t.lt(one))
}

/// A material with its spectral parameters evaluated at one path's four wavelengths, so
/// that light sampling and BSDF sampling at one vertex evaluate the spectra once
/// ([`Lobes`] holds W of them).
#[derive(Debug, Clone, Copy)]
pub enum Lobe {
    /// Lambertian with per-lane albedo.
    Diffuse(Vec4),
    /// Mirror with per-lane reflectance.
    Mirror(Vec4),
    /// Dielectric with per-lane interior index and the exterior index.
    Dielectric(Vec4, f32),
    /// Rough dielectric: per-lane interior index, exterior index, GGX widths.
    RoughDielectric(Vec4, f32, [f32; 2]),
    /// Conductor: per-lane η and k, GGX widths ([0, 0]: smooth).
    Conductor(Vec4, Vec4, [f32; 2]),
    /// The Lambertian base of a coated surface seen through its coat: per-lane coat index
    /// and optical depth, the coat's GGX width (the coat's own reflection is a
    /// [`Lobe::Mirror`] or a rough [`Lobe::Conductor`] with k = 0).
    CoatedBase(Vec4, Vec4, f32),
    /// A conductor under a coat ([`CoatedConductor`]): per-lane coat index and optical
    /// depth, the coat's GGX width, per-lane conductor η and k, its GGX widths ([0, 0]:
    /// smooth, and the whole a mirror).
    CoatedConductor {
        /// The coat's index.
        coat_eta: Vec4,
        /// The coat's optical depth.
        tau: Vec4,
        /// The coat's GGX width.
        coat_alpha: f32,
        /// The conductor's η.
        eta: Vec4,
        /// The conductor's k.
        k: Vec4,
        /// The conductor's GGX widths.
        alpha: [f32; 2],
    },
}

/// Whether GGX widths describe a rough surface; below this a conductor is a Dirac mirror
/// (the parser enforces 0 or at least this, so no lobe is numerically a spike).
pub const MIN_ALPHA: f32 = 1e-3;

fn is_rough(alpha: [f32; 2]) -> bool {
    alpha[0] >= MIN_ALPHA && alpha[1] >= MIN_ALPHA
}

/// A roughness map's GGX width at `uv`: the texel value, no smaller than [`MIN_ALPHA`]
/// (a map describes rough surfaces only; below that a lobe is numerically a spike).
#[inline]
fn map_alpha(map: &ScalarTexture, uv: Vec2) -> f32 {
    map.eval(uv).max(MIN_ALPHA)
}

/// The widths at `uv`: the map's (isotropic) if there is one, else `alpha`.
#[inline]
fn alpha_at(alpha: &[f32; 2], map: &Option<Arc<ScalarTexture>>, uv: Vec2) -> [f32; 2] {
    match map {
        Some(map) => [map_alpha(map, uv); 2],
        None => *alpha,
    }
}

impl Material {
    /// Whether its lobes depend on the hit's texture coordinates.
    #[inline]
    pub fn is_textured(&self) -> bool {
        match self {
            Material::TexturedDiffuse { .. } | Material::TexturedMirror { .. } => true,
            Material::FluorescentDiffuse { map: Some(m), .. } => m.varies(),
            Material::RoughDielectric { alpha_map, .. } | Material::Conductor { alpha_map, .. } => {
                alpha_map.as_ref().is_some_and(|m| m.varies())
            }
            Material::Coated(c) => c.map().is_some_and(|m| m.varies()),
            _ => false,
        }
    }

    /// The material at the wavelengths `lambda` ([`Material::at_uv`] at texture
    /// coordinates (0, 0), which only a textured material reads).
    #[inline]
    pub fn at(&self, lambda: Vec4) -> Lobe {
        self.at_uv(Vec2::ZERO, lambda)
    }

    /// The material at texture coordinates `uv` and the wavelengths `lambda`; for a
    /// fluorescent material, the part left after the wavelength shift has been sampled (a
    /// white Lambertian).
    #[inline]
    pub fn at_uv(&self, uv: Vec2, lambda: Vec4) -> Lobe {
        match self {
            Material::Diffuse { reflectance } => Lobe::Diffuse(reflectance.eval4(lambda)),
            Material::TexturedDiffuse { texture } => Lobe::Diffuse(texture.eval4(uv, lambda)),
            Material::Mirror { reflectance } => Lobe::Mirror(reflectance.eval4(lambda)),
            Material::TexturedMirror { texture } => Lobe::Mirror(texture.eval4(uv, lambda)),
            Material::FluorescentDiffuse { .. } => Lobe::Diffuse(Vec4::ONE),
            Material::Dielectric { ior, ext_ior } => Lobe::Dielectric(ior.eval4(lambda), *ext_ior),
            Material::RoughDielectric {
                ior,
                ext_ior,
                alpha,
                alpha_map,
            } => Lobe::RoughDielectric(ior.eval4(lambda), *ext_ior, alpha_at(alpha, alpha_map, uv)),
            Material::Conductor {
                eta,
                k,
                alpha,
                alpha_map,
            } => Lobe::Conductor(
                eta.eval4(lambda),
                k.eval4(lambda),
                alpha_at(alpha, alpha_map, uv),
            ),
            Material::Coated(c) => {
                let (coat_eta, tau) = (c.ior.eval4(lambda), c.tau.eval4(lambda));
                match &c.base {
                    CoatBase::Lambertian(_) => Lobe::CoatedBase(coat_eta, tau, c.alpha),
                    CoatBase::Conductor { eta, k, alpha } => Lobe::CoatedConductor {
                        coat_eta,
                        tau,
                        coat_alpha: c.alpha,
                        eta: eta.eval4(lambda),
                        k: k.eval4(lambda),
                        alpha: *alpha,
                    },
                }
            }
        }
    }
}

impl Lobe {
    /// Whether every scattering event is a Dirac delta (no light sampling helps).
    #[inline]
    pub fn is_specular(&self) -> bool {
        match *self {
            Lobe::Diffuse(_) | Lobe::RoughDielectric(..) | Lobe::CoatedBase(..) => false,
            Lobe::Conductor(_, _, alpha) | Lobe::CoatedConductor { alpha, .. } => !is_rough(alpha),
            Lobe::Mirror(_) | Lobe::Dielectric(..) => true,
        }
    }

    /// f·|cos θᵢ| and the per-lane pdf of sampling `wi` ([`Lobes::eval`] for one flat
    /// path with normal `n`).
    #[inline]
    pub fn eval(&self, n: Vec3, wo: Vec3, wi: Vec3) -> (Vec4, Vec4) {
        let nrm = Normals::<f32>::flat(n.into());
        let (f, pdf) = Lobes::<f32>::one(*self).eval(&nrm, wo.into(), wi.into());
        (f.into(), pdf.into())
    }

    /// Samples a direction with the hero's wavelength ([`Lobes::sample`] for one flat path
    /// with normal `n`).
    #[inline]
    pub fn sample(&self, n: Vec3, wo: Vec3, uc: f32, u: [f32; 2]) -> Option<BsdfSample> {
        let nrm = Normals::<f32>::flat(n.into());
        let s = Lobes::<f32>::one(*self).sample(&nrm, wo.into(), uc, u);
        s.valid.then(|| BsdfSample {
            wi: s.wi.into(),
            f_cos: s.f_cos.into(),
            pdf: s.pdf.into(),
            specular: s.specular,
        })
    }

    /// The refraction of every lane at a smooth dielectric, for splitting a path whose
    /// lanes leave a dispersive interface in different directions. Per lane: its own
    /// refracted direction (`None` under total internal reflection, or where the shading
    /// normal would send it back to `wo`'s side), f·|cos θᵢ| = (1 − F)/η², and the
    /// probability 1 − F with which that lane, as hero, chooses refraction (no lane is
    /// masked, unlike [`Lobe::sample`]). `None` for a lobe that does not refract this way.
    #[inline]
    pub fn refract_lanes(
        &self,
        nrm: &Normals<f32>,
        wo: Vec3,
    ) -> Option<([Option<Vec3>; 4], Vec4, Vec4)> {
        let Lobe::Dielectric(n_in, ext_ior) = *self else {
            return None;
        };
        let wo = V3::<f32>::from(wo);
        let (ns, eta, fr) = dielectric_at(Spec::from(n_in), ext_ior, nrm, wo);
        let t = Spec::splat(1.0) - fr;
        let wi = std::array::from_fn(|k| match refract(wo, ns, eta[k]) {
            (wi, true) if nrm.crosses(wo, wi) => Some(wi.into()),
            _ => None,
        });
        Some((wi, (t / (eta * eta)).into(), t.into()))
    }
}

/// The normals at W paths' surface vertices: the geometric normal decides sides (which
/// medium a direction is in, whether light passes), the shading normal shapes the lobes.
#[derive(Debug, Clone, Copy)]
pub struct Normals<F: Float> {
    /// Unit geometric normal.
    pub ng: V3<F>,
    /// Unit shading normal (the geometric one where a path has none).
    pub ns: V3<F>,
    /// The paths whose shading normal differs from the geometric one: only these pay
    /// for the extra side tests, so flat meshes take exactly the arithmetic they always did.
    pub shaded: F::Mask,
    /// Unit first tangent (the mesh's ∂p/∂u) where `has_t`: the axis of the first GGX
    /// width; elsewhere the frame of [`V3::basis`] decides.
    pub t: V3<F>,
    /// The paths with a tangent.
    pub has_t: F::Mask,
}

impl<F: Float> Normals<F> {
    /// Flat shading: the geometric normal everywhere.
    #[inline(always)]
    pub fn flat(ng: V3<F>) -> Normals<F> {
        Normals {
            ng,
            ns: ng,
            shaded: F::Mask::splat(false),
            t: V3::splat(Vec3::ZERO),
            has_t: F::Mask::splat(false),
        }
    }

    /// The same normals with first tangents `t` where `has` (anisotropic lobes turn
    /// with the texture's u direction).
    #[inline(always)]
    pub fn with_tangents(self, t: V3<F>, has: F::Mask) -> Normals<F> {
        Normals {
            t,
            has_t: has,
            ..self
        }
    }

    /// Shading normals `ns` where `has`; a shading normal that puts `wo` on the other
    /// side than the geometric one does is replaced by the geometric normal, so an
    /// interpolated normal never turns a visible surface black (no seams at silhouettes).
    #[inline(always)]
    pub fn new(ng: V3<F>, ns: V3<F>, has: F::Mask, wo: V3<F>) -> Normals<F> {
        let agree = (ns.dot(wo) * ng.dot(wo)).gt(F::splat(0.0));
        let shaded = has & agree;
        Normals {
            ng,
            ns: V3::select(shaded, ns, ng),
            shaded,
            ..Normals::flat(ng)
        }
    }

    /// Path `i`'s normals.
    #[inline]
    pub fn path(&self, i: usize) -> Normals<f32> {
        Normals {
            ng: self.ng.path(i).into(),
            ns: self.ns.path(i).into(),
            shaded: self.shaded.get(i),
            t: self.t.path(i).into(),
            has_t: self.has_t.get(i),
        }
    }

    /// The paths for which a reflection of `wo` into `wi` stays on `wo`'s geometric side
    /// (always true for unshaded paths of the classic lobes, which never checked it).
    #[inline(always)]
    fn reflects(&self, wo: V3<F>, wi: V3<F>) -> F::Mask {
        (self.ng.dot(wo) * self.ng.dot(wi)).gt(F::splat(0.0)) | !self.shaded
    }

    /// The paths for which `wi` crosses to the other geometric side (likewise).
    #[inline(always)]
    fn crosses(&self, wo: V3<F>, wi: V3<F>) -> F::Mask {
        (self.ng.dot(wo) * self.ng.dot(wi)).lt(F::splat(0.0)) | !self.shaded
    }
}

/// The surfaces at W paths' vertices, evaluated at their wavelengths: each path one lobe
/// kind with its spectral parameters. Every routine evaluates each kind present once, for
/// all the paths at once, and keeps the result where the kind applies.
#[derive(Debug, Clone, Copy)]
pub struct Lobes<F: Float> {
    /// The Lambertian paths.
    pub diffuse: F::Mask,
    /// The mirror paths.
    pub mirror: F::Mask,
    /// The smooth dielectric paths.
    pub dielectric: F::Mask,
    /// The rough dielectric paths.
    pub rough_dielectric: F::Mask,
    /// The smooth conductor paths.
    pub conductor: F::Mask,
    /// The rough conductor paths.
    pub rough_conductor: F::Mask,
    /// The paths on a coated surface's Lambertian base ([`coated`]).
    pub coated_base: F::Mask,
    /// The paths on a rough conductor under a coat ([`CoatedConductor`]).
    pub coated_conductor: F::Mask,
    /// The paths on a smooth conductor under a coat (a mirror, [`CoatedConductor::mirror`]).
    pub coated_mirror: F::Mask,
    /// Diffuse albedo or mirror reflectance.
    pub albedo: Spec<F>,
    /// Dielectric interior index, or conductor η, per wavelength.
    pub n_in: Spec<F>,
    /// Conductor k per wavelength (bare or under a coat).
    pub k: Spec<F>,
    /// η of a conductor under a coat, per wavelength (the coat's index in `n_in`).
    pub base_eta: Spec<F>,
    /// Dielectric exterior index.
    pub ext_ior: F,
    /// GGX widths of the rough paths (1 elsewhere).
    pub alpha: [F; 2],
    /// Coat optical depth per wavelength (coated bases; coat index in `n_in`).
    pub tau: Spec<F>,
    /// The coat's GGX width (coated bases; 0: smooth).
    pub coat_alpha: F,
}

/// Which paths on coated surfaces took the coat's mirror reflection, and the cosine of
/// `wo` to their shading normal ([`coated`]: the integrator chooses before any shift).
#[derive(Debug, Clone, Copy)]
pub struct CoatChoice<F: Float> {
    /// The paths that reflect off the coat.
    pub mirror: F::Mask,
    /// Their cos θo.
    pub cos_o: F,
    /// The probability with which they chose the mirror ([`Coated::p_coat`]).
    pub p: F,
}

impl<F: Float> CoatChoice<F> {
    /// No path on a coat.
    pub fn none() -> CoatChoice<F> {
        CoatChoice {
            mirror: F::Mask::splat(false),
            cos_o: F::splat(1.0),
            p: F::splat(1.0),
        }
    }
}

impl<F: Float> Lobes<F> {
    /// The masks of the lobe kinds present (each routine runs once per kind present).
    pub fn kinds(&self) -> impl Iterator<Item = F::Mask> {
        [
            self.diffuse,
            self.mirror,
            self.dielectric,
            self.rough_dielectric,
            self.conductor,
            self.rough_conductor,
            self.coated_base,
            self.coated_conductor,
            self.coated_mirror,
        ]
        .into_iter()
        .filter(|k| k.any())
    }

    /// No path on any lobe.
    #[inline(always)]
    pub fn none() -> Lobes<F> {
        let no = F::Mask::splat(false);
        Lobes {
            diffuse: no,
            mirror: no,
            dielectric: no,
            rough_dielectric: no,
            conductor: no,
            rough_conductor: no,
            coated_base: no,
            coated_conductor: no,
            coated_mirror: no,
            albedo: Spec::splat(1.0),
            n_in: Spec::splat(1.0),
            k: Spec::splat(0.0),
            base_eta: Spec::splat(1.0),
            ext_ior: F::splat(1.0),
            alpha: [F::splat(1.0); 2],
            tau: Spec::splat(0.0),
            coat_alpha: F::splat(0.0),
        }
    }

    /// Puts the paths `m` on `lobe`, whose parameters are `lambda`'s (`at(m)` gives them).
    #[inline(always)]
    fn set(&mut self, m: F::Mask, lobe: LobeKind, p: LobeParams<F>) {
        match lobe {
            LobeKind::Diffuse => self.diffuse |= m,
            LobeKind::Mirror => self.mirror |= m,
            LobeKind::Dielectric => self.dielectric |= m,
            LobeKind::RoughDielectric => self.rough_dielectric |= m,
            LobeKind::Conductor => self.conductor |= m,
            LobeKind::RoughConductor => self.rough_conductor |= m,
            LobeKind::CoatedBase => self.coated_base |= m,
            LobeKind::CoatedConductor => self.coated_conductor |= m,
            LobeKind::CoatedMirror => self.coated_mirror |= m,
        }
        if let Some(a) = p.coat_alpha {
            self.coat_alpha = F::select(m, F::splat(a), self.coat_alpha);
        }
        if let Some(e) = p.base_eta {
            self.base_eta.set_where(m, e);
        }
        if let Some(t) = p.tau {
            self.tau.set_where(m, t);
        }
        if let Some(a) = p.albedo {
            self.albedo.set_where(m, a);
        }
        if let Some(n) = p.n_in {
            self.n_in.set_where(m, n);
        }
        if let Some(k) = p.k {
            self.k.set_where(m, k);
        }
        if let Some(e) = p.ext_ior {
            self.ext_ior = F::select(m, F::splat(e), self.ext_ior);
        }
        if let Some([ax, ay]) = p.alpha {
            self.alpha[0] = F::select(m, F::splat(ax), self.alpha[0]);
            self.alpha[1] = F::select(m, F::splat(ay), self.alpha[1]);
        }
    }

    /// The GGX widths of the paths in `m` from their material's roughness map, if it has
    /// one, at their texture coordinates `uv`.
    #[inline(always)]
    fn set_alpha_map(&mut self, m: F::Mask, map: &Option<Arc<ScalarTexture>>, uv: &F::Arr<Vec2>) {
        if let Some(map) = map {
            let a = F::from_fn(|i| match m.get(i) {
                true => map_alpha(map, uv[i]),
                false => 1.0,
            });
            self.alpha = [0, 1].map(|k| F::select(m, a, self.alpha[k]));
        }
    }

    /// The lobes of the paths in `active`: path i's is `lobe(i)`.
    #[inline(always)]
    pub fn from_fn(active: F::Mask, mut lobe: impl FnMut(usize) -> Lobe) -> Lobes<F> {
        let mut l = Lobes::none();
        for i in active.iter() {
            let m = F::Mask::from_fn(|j| j == i);
            let one = |v: Vec4| Spec::<F>::from_fn(|_| v);
            let (kind, p) = match lobe(i) {
                Lobe::Diffuse(a) => (LobeKind::Diffuse, LobeParams::albedo(one(a))),
                Lobe::Mirror(a) => (LobeKind::Mirror, LobeParams::albedo(one(a))),
                Lobe::Dielectric(n, e) => (LobeKind::Dielectric, LobeParams::ior(one(n), e, None)),
                Lobe::RoughDielectric(n, e, a) => (
                    LobeKind::RoughDielectric,
                    LobeParams::ior(one(n), e, Some(a)),
                ),
                Lobe::Conductor(eta, k, a) => (
                    conductor_kind(a),
                    LobeParams::conductor(one(eta), one(k), a),
                ),
                Lobe::CoatedBase(eta, tau, a) => (
                    LobeKind::CoatedBase,
                    LobeParams::coated(one(eta), one(tau), a),
                ),
                Lobe::CoatedConductor {
                    coat_eta,
                    tau,
                    coat_alpha,
                    eta,
                    k,
                    alpha,
                } => (
                    coated_conductor_kind(alpha),
                    LobeParams::coated_conductor(
                        LobeParams::coated(one(coat_eta), one(tau), coat_alpha),
                        one(eta),
                        one(k),
                        alpha,
                    ),
                ),
            };
            l.set(m, kind, p);
        }
        l
    }

    /// Sets the lobes of the paths in `active` into `self`, which holds no path's lobe yet
    /// ([`Lobes::none`]; filled in place: the struct is large at width 4, and a returned
    /// one is copied). Path i is on material `materials[mat[i]]` at its wavelengths: each
    /// material present is evaluated once, for all its paths at once. Paths on coated
    /// surfaces get the coat's reflection or the base, as `coat` says (a rough coat's
    /// reflection is a rough conductor with k = 0, its 1/P in the path's throughput).
    /// `uv` holds the paths' texture coordinates where a textured material needs them.
    #[inline(always)]
    pub fn fill(
        &mut self,
        materials: &[Material],
        mat: &F::Arr<u32>,
        active: F::Mask,
        lambda: &Spec<F>,
        coat: &CoatChoice<F>,
        uv: &F::Arr<Vec2>,
    ) {
        let l = self;
        let mut left = active;
        while let Some(first) = left.iter().next() {
            let id = mat[first];
            let m = left & F::Mask::from_fn(|i| mat[i] == id);
            left &= !m;
            let (kind, p) = match &materials[id as usize] {
                Material::Diffuse { reflectance } => (
                    LobeKind::Diffuse,
                    LobeParams::albedo(reflectance.eval_w(lambda, m)),
                ),
                Material::TexturedDiffuse { texture } => (
                    LobeKind::Diffuse,
                    LobeParams::albedo(texture.eval_w(lambda, m, uv)),
                ),
                Material::Mirror { reflectance } => (
                    LobeKind::Mirror,
                    LobeParams::albedo(reflectance.eval_w(lambda, m)),
                ),
                Material::TexturedMirror { texture } => (
                    LobeKind::Mirror,
                    LobeParams::albedo(texture.eval_w(lambda, m, uv)),
                ),
                Material::FluorescentDiffuse { .. } => {
                    (LobeKind::Diffuse, LobeParams::albedo(Spec::splat(1.0)))
                }
                Material::Dielectric { ior, ext_ior } => (
                    LobeKind::Dielectric,
                    LobeParams::ior(ior.eval_w(lambda, m), *ext_ior, None),
                ),
                Material::RoughDielectric {
                    ior,
                    ext_ior,
                    alpha,
                    alpha_map,
                } => {
                    let p = LobeParams::ior(ior.eval_w(lambda, m), *ext_ior, Some(*alpha));
                    l.set(m, LobeKind::RoughDielectric, p);
                    l.set_alpha_map(m, alpha_map, uv);
                    continue;
                }
                Material::Conductor {
                    eta,
                    k,
                    alpha,
                    alpha_map,
                } => {
                    let (eta, k) = (eta.eval_w(lambda, m), k.eval_w(lambda, m));
                    l.set(
                        m,
                        conductor_kind(*alpha),
                        LobeParams::conductor(eta, k, *alpha),
                    );
                    l.set_alpha_map(m, alpha_map, uv);
                    continue;
                }
                Material::Coated(c) => {
                    let mirror = m & coat.mirror;
                    if mirror.any() && c.is_rough() {
                        let eta = c.ior.eval_w(lambda, mirror);
                        let p = LobeParams::conductor(eta, Spec::zero(), [c.alpha; 2]);
                        l.set(mirror, LobeKind::RoughConductor, p);
                    } else if mirror.any() {
                        let w = c.reflectance(coat.cos_o, lambda, mirror) / coat.p;
                        l.set(mirror, LobeKind::Mirror, LobeParams::albedo(w));
                    }
                    let m = m & !mirror;
                    let (eta, tau) = c.at(lambda, m);
                    let coat_params = LobeParams::coated(eta, tau, c.alpha);
                    match &c.base {
                        CoatBase::Lambertian(_) => l.set(m, LobeKind::CoatedBase, coat_params),
                        CoatBase::Conductor { eta, k, alpha } => {
                            let (eta, k) = (eta.eval_w(lambda, m), k.eval_w(lambda, m));
                            let p = LobeParams::coated_conductor(coat_params, eta, k, *alpha);
                            l.set(m, coated_conductor_kind(*alpha), p);
                        }
                    }
                    continue;
                }
            };
            l.set(m, kind, p);
        }
    }

    /// One path's lobe (width 1).
    #[inline(always)]
    pub fn one(lobe: Lobe) -> Lobes<F> {
        Lobes::from_fn(F::Mask::splat(true), |_| lobe)
    }

    /// The paths whose every scattering event is a Dirac delta (no light sampling helps).
    #[inline(always)]
    pub fn is_specular(&self) -> F::Mask {
        !(self.diffuse
            | self.rough_conductor
            | self.rough_dielectric
            | self.coated_base
            | self.coated_conductor)
    }

    /// The conductors under a coat, as [`CoatedConductor`] sees them.
    #[inline(always)]
    fn coated_conductor(&self) -> CoatedConductor<F> {
        CoatedConductor {
            coat_eta: self.n_in,
            tau: self.tau,
            coat_alpha: self.coat_alpha,
            eta: self.base_eta,
            k: self.k,
            ggx: self.ggx(),
        }
    }

    /// The GGX distribution of the rough paths.
    #[inline(always)]
    fn ggx(&self) -> Ggx<F> {
        Ggx::new(self.alpha[0], self.alpha[1])
    }

    /// f·|cos θᵢ| and the per-wavelength pdf of sampling `wi`, for light sampling and MIS;
    /// 0 for specular lobes. `wo` points back along the incoming ray.
    #[inline(always)]
    pub fn eval(&self, nrm: &Normals<F>, wo: V3<F>, wi: V3<F>) -> (Spec<F>, Spec<F>) {
        let n = nrm.ng;
        let (co, ci) = (n.dot(wo), n.dot(wi));
        // Lambertian: f·cos θ = albedo·cos θ/π, exactly the sampling density. The cosine
        // is the shading normal's (turned to wo's side); flat paths get |n·wi| exactly.
        let cs = nrm.ns.dot(wi);
        let c = F::select(co.lt(F::splat(0.0)), -cs, cs);
        let ok = self.diffuse & (co * ci).gt(F::splat(0.0)) & c.gt(F::splat(0.0));
        let pdf = cosine_hemisphere_pdf(c).masked(ok);
        let mut f = self.albedo * pdf;
        let mut p = Spec::broadcast(pdf);
        if self.coated_base.any() {
            let ok = self.coated_base & (co * ci).gt(F::splat(0.0)) & c.gt(F::splat(0.0));
            let pdf = cosine_hemisphere_pdf(c).masked(ok);
            let through = coated::crossing(c, &self.n_in, &self.tau, self.coat_alpha);
            f.set_where(ok, through * pdf);
            p.set_where(ok, Spec::broadcast(pdf));
        }
        if self.coated_conductor.any() {
            let m = self.coated_conductor;
            let (fc, pc) = self.coated_conductor().eval(nrm, wo, wi);
            f.set_where(m, fc);
            p.set_where(m, pc);
        }
        if self.rough_conductor.any() {
            let m = self.rough_conductor;
            let (fc, pc) = rough::eval_conductor(&self.ggx(), &self.n_in, &self.k, nrm, wo, wi);
            f.set_where(m, fc);
            p.set_where(m, pc);
        }
        if self.rough_dielectric.any() {
            let m = self.rough_dielectric;
            let (fd, pd) =
                rough::eval_dielectric(&self.ggx(), &self.n_in, self.ext_ior, nrm, wo, wi);
            f.set_where(m, fd);
            p.set_where(m, pd);
        }
        (f, p)
    }

    /// Samples a direction with each path's hero wavelength (lane 0). `uc` picks between
    /// reflection and refraction, `u` is the 2-D sample for a direction.
    #[inline(always)]
    pub fn sample(&self, nrm: &Normals<F>, wo: V3<F>, uc: F, u: [F; 2]) -> BsdfSamples<F> {
        let zero = F::splat(0.0);
        let mut s = BsdfSamples {
            valid: F::Mask::splat(false),
            wi: V3::splat(Vec3::ZERO),
            f_cos: Spec::zero(),
            pdf: Spec::zero(),
            specular: self.is_specular(),
        };
        let ns = V3::select(nrm.ng.dot(wo).lt(zero), -nrm.ns, nrm.ns);
        if self.diffuse.any() {
            let wi = sample_cosine_w(ns, u);
            let c = ns.dot(wi);
            let ok = self.diffuse & c.gt(zero) & nrm.reflects(wo, wi);
            let pdf = cosine_hemisphere_pdf(c);
            s.valid |= ok;
            s.wi.set_where(ok, wi);
            s.f_cos.set_where(ok, self.albedo * pdf);
            s.pdf.set_where(ok, Spec::broadcast(pdf));
        }
        if self.coated_base.any() {
            let wi = sample_cosine_w(ns, u);
            let c = ns.dot(wi);
            let same_side = (nrm.ng.dot(wo) * nrm.ng.dot(wi)).gt(zero);
            let ok = self.coated_base & c.gt(zero) & same_side;
            let pdf = cosine_hemisphere_pdf(c);
            s.valid |= ok;
            s.wi.set_where(ok, wi);
            let through = coated::crossing(c, &self.n_in, &self.tau, self.coat_alpha);
            s.f_cos.set_where(ok, through * pdf);
            s.pdf.set_where(ok, Spec::broadcast(pdf));
        }
        if self.coated_mirror.any() {
            let wi = reflect(wo, ns);
            let m = self.coated_mirror & (nrm.ng.dot(wo) * nrm.ng.dot(wi)).gt(zero);
            s.valid |= m;
            s.wi.set_where(m, wi);
            s.f_cos
                .set_where(m, self.coated_conductor().mirror(ns.dot(wo)));
            s.pdf.set_where(m, Spec::splat(1.0));
        }
        if self.coated_conductor.any() {
            let lobe = self.coated_conductor();
            let (wi, ok) = lobe.sample(nrm, wo, u);
            let (f, p) = lobe.eval(nrm, wo, wi);
            self.keep(&mut s, self.coated_conductor & ok, wi, f, p);
        }
        if self.mirror.any() {
            let wi = reflect(wo, ns);
            let m = self.mirror & nrm.reflects(wo, wi);
            s.valid |= m;
            s.wi.set_where(m, wi);
            s.f_cos.set_where(m, self.albedo);
            s.pdf.set_where(m, Spec::splat(1.0));
        }
        if self.conductor.any() {
            let wi = reflect(wo, ns);
            let m = self.conductor & (nrm.ng.dot(wo) * nrm.ng.dot(wi)).gt(zero);
            let c = ns.dot(wo);
            s.valid |= m;
            s.wi.set_where(m, wi);
            s.f_cos
                .set_where(m, self.n_in.zip(self.k, |e, k| fresnel_conductor(c, e, k)));
            s.pdf.set_where(m, Spec::splat(1.0));
        }
        if self.dielectric.any() {
            self.sample_smooth_dielectric(nrm, wo, uc, &mut s);
        }
        if self.rough_conductor.any() {
            let m = self.rough_conductor;
            let wi = rough::sample_conductor(&self.ggx(), nrm, wo, u);
            let (f, p) = rough::eval_conductor(&self.ggx(), &self.n_in, &self.k, nrm, wo, wi);
            self.keep(&mut s, m, wi, f, p);
        }
        if self.rough_dielectric.any() {
            let m = self.rough_dielectric;
            let (ggx, ext) = (self.ggx(), self.ext_ior);
            let (wi, ok) = rough::sample_dielectric(&ggx, self.n_in.hero(), ext, nrm, wo, uc, u);
            let (f, p) = rough::eval_dielectric(&ggx, &self.n_in, ext, nrm, wo, wi);
            self.keep(&mut s, m & ok, wi, f, p);
        }
        s
    }

    /// Records a sampled direction `wi` with values `f` and pdfs `p` for the paths of `m`
    /// whose hero pdf is positive.
    #[inline(always)]
    fn keep(&self, s: &mut BsdfSamples<F>, m: F::Mask, wi: V3<F>, f: Spec<F>, p: Spec<F>) {
        let ok = m & p.hero().gt(F::splat(0.0));
        s.valid |= ok;
        s.wi.set_where(ok, wi);
        s.f_cos.set_where(ok, f);
        s.pdf.set_where(ok, p);
    }

    /// Fresnel reflection or refraction at a smooth dielectric (the hero decides).
    #[inline(always)]
    fn sample_smooth_dielectric(&self, nrm: &Normals<F>, wo: V3<F>, uc: F, s: &mut BsdfSamples<F>) {
        let (ns, eta, fr) = dielectric_at(self.n_in, self.ext_ior, nrm, wo);
        // Reflection: the same direction for every lane.
        let wr = reflect(wo, ns);
        let refl = self.dielectric & uc.lt(fr.hero()) & nrm.reflects(wo, wr);
        s.valid |= refl;
        s.wi.set_where(refl, wr);
        s.f_cos.set_where(refl, fr);
        s.pdf.set_where(refl, fr);
        let (wi, ok) = refract(wo, ns, eta.hero());
        let refr = self.dielectric & !uc.lt(fr.hero()) & ok & nrm.crosses(wo, wi);
        if refr.any() {
            let t = Spec::splat(1.0) - fr;
            // Lanes whose index differs from the hero's refract elsewhere: drop them.
            let hero = eta.hero();
            let keep = eta.map(|e| F::splat(1.0).masked(e.eq(hero)));
            s.valid |= refr;
            s.wi.set_where(refr, wi);
            s.f_cos.set_where(refr, keep * t / (eta * eta));
            s.pdf.set_where(refr, keep * t);
        }
    }
}

/// Which of [`Lobes`]' masks a path goes to.
#[derive(Debug, Clone, Copy)]
enum LobeKind {
    Diffuse,
    Mirror,
    Dielectric,
    RoughDielectric,
    Conductor,
    RoughConductor,
    CoatedBase,
    CoatedConductor,
    CoatedMirror,
}

fn conductor_kind(alpha: [f32; 2]) -> LobeKind {
    match is_rough(alpha) {
        true => LobeKind::RoughConductor,
        false => LobeKind::Conductor,
    }
}

fn coated_conductor_kind(alpha: [f32; 2]) -> LobeKind {
    match is_rough(alpha) {
        true => LobeKind::CoatedConductor,
        false => LobeKind::CoatedMirror,
    }
}

/// The parameters one lobe kind sets ([`Lobes::set`]).
#[derive(Default)]
struct LobeParams<F: Float> {
    albedo: Option<Spec<F>>,
    n_in: Option<Spec<F>>,
    k: Option<Spec<F>>,
    ext_ior: Option<f32>,
    alpha: Option<[f32; 2]>,
    tau: Option<Spec<F>>,
    coat_alpha: Option<f32>,
    base_eta: Option<Spec<F>>,
}

impl<F: Float> LobeParams<F> {
    fn albedo(a: Spec<F>) -> Self {
        LobeParams {
            albedo: Some(a),
            ..Default::default()
        }
    }

    fn ior(n: Spec<F>, ext: f32, alpha: Option<[f32; 2]>) -> Self {
        LobeParams {
            n_in: Some(n),
            ext_ior: Some(ext),
            alpha,
            ..Default::default()
        }
    }

    fn conductor(eta: Spec<F>, k: Spec<F>, alpha: [f32; 2]) -> Self {
        LobeParams {
            n_in: Some(eta),
            k: Some(k),
            alpha: is_rough(alpha).then_some(alpha),
            ..Default::default()
        }
    }

    fn coated(eta: Spec<F>, tau: Spec<F>, coat_alpha: f32) -> Self {
        LobeParams {
            n_in: Some(eta),
            tau: Some(tau),
            coat_alpha: Some(coat_alpha),
            ..Default::default()
        }
    }

    fn coated_conductor(coat: Self, eta: Spec<F>, k: Spec<F>, alpha: [f32; 2]) -> Self {
        LobeParams {
            base_eta: Some(eta),
            k: Some(k),
            alpha: is_rough(alpha).then_some(alpha),
            ..coat
        }
    }
}

/// A dielectric seen along `wo`: the shading normal on `wo`'s side (sides decided by the
/// geometric normal), the relative index n_t/n_i per wavelength and the per-wavelength
/// Fresnel reflectance.
#[inline(always)]
fn dielectric_at<F: Float>(
    n_in: Spec<F>,
    ext_ior: F,
    nrm: &Normals<F>,
    wo: V3<F>,
) -> (V3<F>, Spec<F>, Spec<F>) {
    let cos_o = nrm.ng.dot(wo);
    let entering = cos_o.gt(F::splat(0.0));
    let ns = V3::select(entering, nrm.ns, -nrm.ns);
    let eta = n_in.map(|ni| F::select(entering, ni / ext_ior, ext_ior / ni));
    // Flat paths: exactly |cos_o| (negation commutes with the dot product's rounding).
    let c = ns.dot(wo);
    let fr = eta.map(|e| fresnel_dielectric(c, e));
    (ns, eta, fr)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fresnel_limits() {
        assert!((fresnel_dielectric(1.0, 1.5) - 0.04).abs() < 1e-4);
        assert_eq!(fresnel_dielectric(0.1, 1.0 / 1.5), 1.0); // total internal reflection
        assert!(fresnel_dielectric(1e-4, 1.5) > 0.99);
    }

    #[test]
    fn a_refraction_about_a_shading_normal_must_cross_the_surface() {
        // ng = +z, the shading normal leaning 60° towards +x; wo all round, from outside
        // (index 1.5 inside) and from inside. Seen from some directions, refracting about
        // ns sends wi back to wo's side of the geometric surface: the sample is refused
        // there (the path ends), never continued on the wrong side.
        let ng = V3::<f32>::from(Vec3::Z);
        let lean = 60f32.to_radians();
        let ns = V3::<f32>::from(Vec3::new(lean.sin(), 0.0, lean.cos()));
        let glass = Lobes::<f32>::one(Lobe::Dielectric(Vec4::splat(1.5), 1.0));
        let (mut wrong_side, mut crossed) = (0, 0);
        for k in -179..180 {
            let a = (k as f32).to_radians();
            let wo = V3::<f32>::from(Vec3::new(a.sin(), 0.0, a.cos()));
            let nrm = Normals::new(ng, ns, true, wo);
            if !nrm.shaded {
                continue;
            }
            let (ns_wo, eta, fr) = dielectric_at(Spec::splat(1.5), 1.0, &nrm, wo);
            let (wi, ok) = refract(wo, ns_wo, eta.hero());
            if !ok || fr.hero() > 0.99 {
                continue;
            }
            let s = glass.sample(&nrm, wo, 0.995, [0.5, 0.5]);
            if wi.z * wo.z > 0.0 {
                wrong_side += 1;
                let wi = Vec3::from(wi);
                assert!(!s.valid, "wo at {k}°: wi {wi:?} kept on wo's side");
            } else {
                crossed += 1;
                let ok = s.valid && s.wi.z * wo.z < 0.0;
                assert!(ok, "wo at {k}°: the refraction was lost");
            }
        }
        assert!(wrong_side > 5 && crossed > 5, "{wrong_side} {crossed}");
    }

    #[test]
    fn refraction_obeys_snell() {
        let n = Vec3::Z;
        let wo = Vec3::new(0.6, 0.0, 0.8);
        let (wi, ok) = refract(V3::<f32>::from(wo), V3::from(n), 1.5);
        assert!(ok);
        let sin_o = 0.6f32;
        let sin_i = (1.0 - wi.z * wi.z).sqrt();
        assert!((sin_o - 1.5 * sin_i).abs() < 1e-5);
        assert!(wi.z < 0.0 && wi.x < 0.0);
    }

    #[test]
    fn sellmeier_bk7_at_587nm() {
        let bk7 = Ior::Sellmeier {
            b: [1.039_612, 0.231_792_3, 1.010_469_5],
            c: [0.006_000_699, 0.020_017_914, 103.560_65],
        };
        assert!((bk7.eval(587.6) - 1.5168).abs() < 1e-3);
        assert!(bk7.eval(450.0) > bk7.eval(650.0));
        assert!(bk7.is_dispersive());
        let cauchy = Ior::Cauchy { a: 1.5, b: 4200.0 };
        assert!((cauchy.eval(420.0) - 1.5238095).abs() < 1e-6);
        assert!(cauchy.is_dispersive() && !Ior::Constant(1.5).is_dispersive());
        let l = Vec4::new(400.0, 500.0, 600.0, 700.0);
        assert_eq!(Ior::Constant(1.33).eval4(l), Vec4::splat(1.33));
        let want = l.to_array().map(|x| bk7.eval(x));
        assert_eq!(bk7.eval4(l).to_array(), want);
    }

    #[test]
    fn dispersive_refraction_drops_secondary_lanes() {
        let m = Material::Dielectric {
            ior: Ior::Cauchy { a: 1.5, b: 10000.0 },
            ext_ior: 1.0,
        };
        let lambda = Vec4::new(400.0, 517.5, 635.0, 752.5);
        let s = m
            .at(lambda)
            .sample(
                Vec3::Z,
                Vec3::new(0.3, 0.0, 0.95).normalize(),
                0.99,
                [0.5, 0.5],
            )
            .unwrap();
        assert!(s.pdf.x > 0.0 && s.pdf.y == 0.0 && s.pdf.z == 0.0 && s.pdf.w == 0.0);
        assert_eq!(s.f_cos.y, 0.0);
    }

    #[test]
    fn cosine_sampling_chi_square_in_cos_theta() {
        // cos θ of a cosine-weighted direction has density 2·cosθ on [0,1].
        let mut rng = crate::sampler::Pcg32::new(5, 9);
        let n = Vec3::new(0.3, -0.5, 0.8).normalize();
        let bins = 20;
        let samples = 100_000;
        let mut counts = vec![0f64; bins];
        for _ in 0..samples {
            let w = sample_cosine(n, rng.next_2d());
            let c = w.dot(n).clamp(0.0, 0.999_999);
            counts[(c * bins as f32) as usize] += 1.0;
        }
        let mut chi2 = 0.0;
        for (i, &o) in counts.iter().enumerate() {
            let (a, b) = (i as f64 / bins as f64, (i + 1) as f64 / bins as f64);
            let e = (b * b - a * a) * samples as f64;
            chi2 += (o - e).powi(2) / e;
        }
        // 19 degrees of freedom, 0.999 quantile ≈ 43.8.
        assert!(chi2 < 43.8, "chi2 = {chi2}");
    }
}
