//! Surface scattering: diffuse, perfect mirror and smooth (optionally dispersive) dielectric.
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
//! [materials.highlighter]
//! type = "fluorescent_diffuse" # a dye over a reflectance, or matrix = "measured.csv"
//! reflectance = 0.8
//! dye = { absorption = { narrow_band = 440, fwhm = 60 }, emission = { narrow_band = 520, fwhm = 40 }, quantum_yield = 0.9 }
//! ```

pub mod desc;

pub use desc::{DyeDesc, IorDesc, IorTable, MaterialDesc, SellmeierDesc};

use crate::fluoro::Reradiation;
use crate::simd::{math, Float, Lanes, Mask, Spec, V3};
use crate::spectrum::Spectrum;
use glam::{Vec3, Vec4};
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
    /// Perfect specular reflection.
    Mirror {
        /// Spectral reflectance in [0, 1].
        reflectance: Spectrum,
    },
    /// Lambertian with re-radiation: M(λi→λo)/π · cos θ. The integrator samples the
    /// wavelength shift first ([`crate::fluoro`]); what is left is Lambertian with albedo 1.
    FluorescentDiffuse {
        /// The re-radiation function (its diagonal is the ordinary reflectance).
        reradiation: Arc<Reradiation>,
    },
    /// Smooth dielectric interface (Fresnel reflection and refraction).
    Dielectric {
        /// Interior index.
        ior: Ior,
        /// Exterior index.
        ext_ior: f32,
    },
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
}

impl Material {
    /// The material at the wavelengths `lambda`; for a fluorescent material, the part left
    /// after the wavelength shift has been sampled (a white Lambertian).
    #[inline]
    pub fn at(&self, lambda: Vec4) -> Lobe {
        match self {
            Material::Diffuse { reflectance } => Lobe::Diffuse(reflectance.eval4(lambda)),
            Material::Mirror { reflectance } => Lobe::Mirror(reflectance.eval4(lambda)),
            Material::FluorescentDiffuse { .. } => Lobe::Diffuse(Vec4::ONE),
            Material::Dielectric { ior, ext_ior } => Lobe::Dielectric(ior.eval4(lambda), *ext_ior),
        }
    }
}

impl Lobe {
    /// Whether every scattering event is a Dirac delta (no light sampling helps).
    #[inline]
    pub fn is_specular(&self) -> bool {
        !matches!(self, Lobe::Diffuse(_))
    }

    /// f·|cos θᵢ| and the per-lane pdf of sampling `wi` ([`Lobes::eval`] for one path).
    #[inline]
    pub fn eval(&self, n: Vec3, wo: Vec3, wi: Vec3) -> (Vec4, Vec4) {
        let (f, pdf) = Lobes::<f32>::one(*self).eval(n.into(), wo.into(), wi.into());
        (f.into(), pdf.into())
    }

    /// Samples a direction with the hero's wavelength ([`Lobes::sample`] for one path).
    #[inline]
    pub fn sample(&self, n: Vec3, wo: Vec3, uc: f32, u: [f32; 2]) -> Option<BsdfSample> {
        let s = Lobes::<f32>::one(*self).sample(n.into(), wo.into(), uc, u);
        s.valid.then(|| BsdfSample {
            wi: s.wi.into(),
            f_cos: s.f_cos.into(),
            pdf: s.pdf.into(),
            specular: s.specular,
        })
    }

    /// The refraction of every lane at a dielectric, for splitting a path whose lanes
    /// leave a dispersive interface in different directions. Per lane: its own refracted
    /// direction (`None` under total internal reflection), f·|cos θᵢ| = (1 − F)/η², and
    /// the probability 1 − F with which that lane, as hero, chooses refraction (no lane is
    /// masked, unlike [`Lobe::sample`]). `None` for a lobe that does not refract.
    #[inline]
    pub fn refract_lanes(&self, n: Vec3, wo: Vec3) -> Option<([Option<Vec3>; 4], Vec4, Vec4)> {
        let Lobe::Dielectric(n_in, ext_ior) = *self else {
            return None;
        };
        let (n, wo) = (V3::<f32>::from(n), V3::<f32>::from(wo));
        let (ns, eta, fr) = dielectric_at(Spec::from(n_in), ext_ior, n, wo);
        let t = Spec::splat(1.0) - fr;
        let wi = std::array::from_fn(|k| match refract(wo, ns, eta[k]) {
            (wi, true) => Some(wi.into()),
            _ => None,
        });
        Some((wi, (t / (eta * eta)).into(), t.into()))
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
    /// The dielectric paths.
    pub dielectric: F::Mask,
    /// Diffuse albedo or mirror reflectance.
    pub albedo: Spec<F>,
    /// Dielectric interior index per wavelength.
    pub n_in: Spec<F>,
    /// Dielectric exterior index.
    pub ext_ior: F,
}

impl<F: Float> Lobes<F> {
    /// The lobes of the paths in `active`: path i's is `lobe(i)`.
    #[inline(always)]
    pub fn from_fn(active: F::Mask, mut lobe: impl FnMut(usize) -> Lobe) -> Lobes<F> {
        let l: F::Arr<Option<Lobe>> = Lanes::from_fn(|i| active.get(i).then(|| lobe(i)));
        let albedo = Spec::from_fn(|i| match l[i] {
            Some(Lobe::Diffuse(a) | Lobe::Mirror(a)) => a,
            _ => Vec4::ONE,
        });
        let n_in = Spec::from_fn(|i| match l[i] {
            Some(Lobe::Dielectric(n, _)) => n,
            _ => Vec4::ONE,
        });
        Lobes {
            diffuse: F::Mask::from_fn(|i| matches!(l[i], Some(Lobe::Diffuse(_)))),
            mirror: F::Mask::from_fn(|i| matches!(l[i], Some(Lobe::Mirror(_)))),
            dielectric: F::Mask::from_fn(|i| matches!(l[i], Some(Lobe::Dielectric(..)))),
            albedo,
            n_in,
            ext_ior: F::from_fn(|i| match l[i] {
                Some(Lobe::Dielectric(_, ext)) => ext,
                _ => 1.0,
            }),
        }
    }

    /// The lobes of the paths in `active`, path i on material `materials[mat[i]]` at its
    /// wavelengths: each material present is evaluated once, for all its paths at once.
    #[inline(always)]
    pub fn at(
        materials: &[Material],
        mat: &F::Arr<u32>,
        active: F::Mask,
        lambda: &Spec<F>,
    ) -> Lobes<F> {
        let no = F::Mask::splat(false);
        let mut l = Lobes {
            diffuse: no,
            mirror: no,
            dielectric: no,
            albedo: Spec::splat(1.0),
            n_in: Spec::splat(1.0),
            ext_ior: F::splat(1.0),
        };
        let mut left = active;
        while let Some(first) = left.iter().next() {
            let id = mat[first];
            let m = left & F::Mask::from_fn(|i| mat[i] == id);
            left &= !m;
            match &materials[id as usize] {
                Material::Diffuse { reflectance } => {
                    l.diffuse |= m;
                    l.albedo.set_where(m, reflectance.eval_w(lambda, m));
                }
                Material::Mirror { reflectance } => {
                    l.mirror |= m;
                    l.albedo.set_where(m, reflectance.eval_w(lambda, m));
                }
                Material::FluorescentDiffuse { .. } => {
                    l.diffuse |= m;
                    l.albedo.set_where(m, Spec::splat(1.0));
                }
                Material::Dielectric { ior, ext_ior } => {
                    l.dielectric |= m;
                    l.n_in.set_where(m, ior.eval_w(lambda, m));
                    l.ext_ior = F::select(m, F::splat(*ext_ior), l.ext_ior);
                }
            }
        }
        l
    }

    /// One path's lobe (width 1).
    #[inline(always)]
    pub fn one(lobe: Lobe) -> Lobes<F> {
        Lobes::from_fn(F::Mask::splat(true), |_| lobe)
    }

    /// The paths whose every scattering event is a Dirac delta (no light sampling helps).
    #[inline(always)]
    pub fn is_specular(&self) -> F::Mask {
        !self.diffuse
    }

    /// f·|cos θᵢ| and the per-wavelength pdf of sampling `wi`, for light sampling and MIS;
    /// 0 for specular lobes. `n` is the geometric normal, `wo` points back along the
    /// incoming ray.
    #[inline(always)]
    pub fn eval(&self, n: V3<F>, wo: V3<F>, wi: V3<F>) -> (Spec<F>, Spec<F>) {
        let (co, ci) = (n.dot(wo), n.dot(wi));
        let ok = self.diffuse & (co * ci).gt(F::splat(0.0));
        // Lambertian: f·cos θ = albedo·cos θ/π, exactly the sampling density.
        let pdf = cosine_hemisphere_pdf(ci.abs()).masked(ok);
        (self.albedo * pdf, Spec::broadcast(pdf))
    }

    /// Samples a direction with each path's hero wavelength (lane 0). `uc` picks between
    /// reflection and refraction, `u` is the 2-D sample for a direction.
    #[inline(always)]
    pub fn sample(&self, n: V3<F>, wo: V3<F>, uc: F, u: [F; 2]) -> BsdfSamples<F> {
        let zero = F::splat(0.0);
        let mut s = BsdfSamples {
            valid: F::Mask::splat(false),
            wi: V3::splat(Vec3::ZERO),
            f_cos: Spec::zero(),
            pdf: Spec::zero(),
            specular: !self.diffuse,
        };
        let ns = V3::select(n.dot(wo).lt(zero), -n, n);
        if self.diffuse.any() {
            let wi = sample_cosine_w(ns, u);
            let c = ns.dot(wi);
            let ok = self.diffuse & c.gt(zero);
            let pdf = cosine_hemisphere_pdf(c);
            s.valid |= ok;
            s.wi.set_where(ok, wi);
            s.f_cos.set_where(ok, self.albedo * pdf);
            s.pdf.set_where(ok, Spec::broadcast(pdf));
        }
        if self.mirror.any() {
            let m = self.mirror;
            s.valid |= m;
            s.wi.set_where(m, reflect(wo, ns));
            s.f_cos.set_where(m, self.albedo);
            s.pdf.set_where(m, Spec::splat(1.0));
        }
        if self.dielectric.any() {
            let (ns, eta, fr) = dielectric_at(self.n_in, self.ext_ior, n, wo);
            // Reflection: the same direction for every lane.
            let refl = self.dielectric & uc.lt(fr.hero());
            s.valid |= refl;
            s.wi.set_where(refl, reflect(wo, ns));
            s.f_cos.set_where(refl, fr);
            s.pdf.set_where(refl, fr);
            let (wi, ok) = refract(wo, ns, eta.hero());
            let refr = self.dielectric & !refl & ok;
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
        s
    }
}

/// A dielectric seen along `wo` from the side of geometric normal `n`: the normal on
/// `wo`'s side, the relative index n_t/n_i per wavelength and the per-wavelength Fresnel
/// reflectance.
#[inline(always)]
fn dielectric_at<F: Float>(
    n_in: Spec<F>,
    ext_ior: F,
    n: V3<F>,
    wo: V3<F>,
) -> (V3<F>, Spec<F>, Spec<F>) {
    let cos_o = n.dot(wo);
    let entering = cos_o.gt(F::splat(0.0));
    let ns = V3::select(entering, n, -n);
    let eta = n_in.map(|ni| F::select(entering, ni / ext_ior, ext_ior / ni));
    let c = cos_o.abs();
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
