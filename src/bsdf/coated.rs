//! A clear coat, smooth or rough, over a Lambertian base that may fluoresce or over a
//! conductor: gloss paint, plastics, highlighter ink under varnish, a sticky note's coated
//! paper, lacquered brass.
//!
//! **Lambertian base.** The model is the classic energy-aware layer over a diffuse base
//! (Weidlich & Wilkie 2007 reduce to it for a smooth coat; Mitsuba 3's `plastic` and
//! `roughplastic` with `nonlinear = true` are the same without absorption). Light from ωi
//! enters through the coat with 1 − R(θi), crosses the layer along the refracted
//! direction with transmittance e^(−τ/cos θi'), is re-radiated by the base with
//! M(λi→λo)/π, and leaves towards ωo with (1 − R(θo))·e^(−τ/cos θo')/η². R is Fresnel's
//! F for a smooth coat and, for a rough one, the directional albedo E of its GGX
//! reflection ([`super::albedo`]; Kelemen & Szirmay-Kalos 2001), so that what the coat
//! reflects and what it passes on add up to one. Light the coat reflects back down
//! reaches the base again: for a Lambertian base that series sums in closed form to
//! 1/(1 − ρ(λo)·r(λo)), where r is the coat's internal reflectance of diffuse light
//! including the round trip's absorption. With ρ = 1 and τ = 0 the layer conserves energy
//! exactly (the tests' white furnace); otherwise it never creates any.
//!
//! **Conductor base** (Weidlich & Wilkie 2007, one internal bounce): the base's BRDF is
//! evaluated between the directions refracted into the coat through its mean surface,
//! with the conductor's index relative to the coat's, between the same crossing factors;
//! f = (1 − R(θi))(1 − R(θo))·e^(−τ/cos θi' − τ/cos θo')·f_base(ωi', ωo')/η². A smooth
//! base makes the whole a mirror, for which the internal reflections sum in closed form
//! (1/(1 − F_base·R·e^(−2τ/cos θ'))); a rough base's light that the coat reflects back
//! down, or that meets the coat beyond its critical angle, is lost (the model's known
//! darkening at high base roughness).
//!
//! Why these models: each is exact or energy-consistent for what it covers, costs no
//! random numbers in evaluation (unlike a stochastic layered BSDF, Guo et al. 2018), so
//! light sampling's MIS stays deterministic, and its two wavelengths sit where the
//! physics puts them (the exit's crossing and 1/η² at λo, the entrance's at λi). What it
//! leaves out: fluorescence *between* the internal reflections (the series treats the
//! base's later bounces at λo as elastic, with its diagonal ρ(λo) — light lost, never
//! gained), a rough coat's spread of the refracted light (the base sees the mean
//! refracted directions), and a coat's anisotropy.
//!
//! Sampling picks the coat's reflection with probability P = R(θo) at the coat's index
//! at 550 nm (kept in [0.05, 0.95]), the same for every lane, so the choice moves no
//! lane's MIS ratio: a smooth coat's mirror with weight F(θo, λ)/P per lane, a rough
//! coat's GGX reflection (a rough conductor lobe with k = 0, the path's throughput
//! divided by P). Otherwise the base: the integrator applies the exit factor at λo
//! divided by 1 − P, shifts the wavelengths if the base fluoresces, and the base lobe
//! ([`super::Lobe::CoatedBase`], [`super::Lobe::CoatedConductor`]) samples the base and
//! carries the entrance factor at λi.
//!
//! **Textured base.** A Lambertian base's albedo and dye strength may vary over the
//! surface ([`FluorescenceMap`]: a diffuse base's `reflectance` texture, a fluorescent
//! base's textured `reflectance` and `fluorescence` map). The closed form then takes the
//! albedo at the hit, 1/(1 − ρ_uv(λo)·r(λo)), with r tabulated per nm once; the coat
//! itself stays uniform.
//!
//! ```toml
//! [materials.sticky_note]
//! type = "coated"
//! ior = 1.5                      # the coat's index in [1, 3] (any index form; default 1.5)
//! roughness = 0.1                # optional: the coat's GGX width α (0, the default: smooth)
//! absorption = 0.2               # optional: σ_a of the coat per scene unit (a spectrum)
//! thickness = 0.05               # with absorption: the coat's thickness in scene units
//! base = { type = "fluorescent_diffuse", reflectance = 0.8, dye = { ... } }   # or a diffuse
//! [materials.lacquered_copper]
//! type = "coated"
//! base = { type = "conductor", metal = "Cu", roughness = 0.2 }   # any conductor
//! ```

use super::microfacet::{fresnel_conductor, Ggx};
use super::rough::frame_towards;
use super::{albedo, fresnel_dielectric, reflect, Ior, Normals, MIN_ALPHA};
use crate::fluoro::map::FluorescenceMap;
use crate::fluoro::Reradiation;
use crate::simd::{math, Float, Mask, Spec, V3};
use crate::spectrum::{Spectrum, Tabulated, LAMBDA_MAX, LAMBDA_MIN};
use std::sync::Arc;

/// What lies under a coat.
#[derive(Debug, Clone)]
pub enum CoatBase {
    /// A Lambertian re-radiator (its diagonal is the albedo ρ; it may fluoresce).
    Lambertian(Arc<Reradiation>),
    /// A conductor with absolute index η + ik and GGX widths ([0, 0]: smooth).
    Conductor {
        /// Real part of the index.
        eta: Spectrum,
        /// Extinction coefficient.
        k: Spectrum,
        /// GGX widths along the two tangents.
        alpha: [f32; 2],
    },
}

/// A clear coat over a base ([`CoatBase`]).
#[derive(Debug, Clone)]
pub struct Coated {
    /// The coat's index (the outside is 1).
    pub ior: Ior,
    /// The coat's optical depth τ(λ) = σ_a(λ)·thickness (0: clear).
    pub tau: Spectrum,
    /// The coat's GGX width (0: smooth).
    pub alpha: f32,
    /// What lies under the coat.
    pub base: CoatBase,
    /// η at 550 nm: the coat-or-base choice, the same for every lane.
    eta_ref: f32,
    /// The exit's constant part per wavelength: 1/(η²·(1 − ρ·r)) over a Lambertian base,
    /// 1/η² over a conductor.
    exit_scale: Spectrum,
    /// The coat's internal reflectance r(λ) per nm (over a Lambertian base), for a
    /// textured base's exit.
    internal: Option<Spectrum>,
    /// A Lambertian base's albedo and dye strength over the surface, if they vary.
    map: Option<Arc<FluorescenceMap>>,
}

/// The branch probability's bounds: neither branch is ever starved.
const P_MIN: f32 = 0.05;

impl Coated {
    /// The coat of index `ior`, optical depth `tau` and GGX width `alpha` over `base`;
    /// tabulates the exit's constant part per nm.
    pub fn new(ior: Ior, tau: Spectrum, alpha: f32, base: CoatBase) -> Coated {
        let grid: Vec<f32> = (LAMBDA_MIN as u32..=LAMBDA_MAX as u32)
            .map(|l| l as f32)
            .collect();
        let mut last: Option<(f32, f32, f32)> = None;
        let rough = RoughInterior::new(&ior, alpha);
        let internal: Option<Vec<f32>> = matches!(base, CoatBase::Lambertian(_)).then(|| {
            grid.iter()
                .map(|&l| {
                    let (eta, tau_l) = (ior.eval(l), tau.eval(l));
                    let r = match (last, &rough) {
                        (Some((e, t, r)), _) if e == eta && t == tau_l => r,
                        (_, Some(rough)) => rough.at(eta).reflectance(eta, tau_l),
                        (_, None) => internal_reflectance(eta, tau_l, alpha),
                    };
                    last = Some((eta, tau_l, r));
                    r
                })
                .collect()
        });
        let scale: Vec<f32> = grid
            .iter()
            .enumerate()
            .map(|(n, &l)| {
                let eta = ior.eval(l);
                let rho_r = match (&base, &internal) {
                    (CoatBase::Lambertian(b), Some(r)) => b.diagonal().eval(l) * r[n],
                    _ => 0.0,
                };
                1.0 / (eta * eta * (1.0 - rho_r))
            })
            .collect();
        let tabulate = |values| {
            Spectrum::Tabulated(
                Tabulated::new(grid.clone(), values).expect("a 1 nm grid of finite values"),
            )
        };
        Coated {
            eta_ref: ior.eval(550.0),
            exit_scale: tabulate(scale),
            internal: internal.map(tabulate),
            ior,
            tau,
            alpha,
            base,
            map: None,
        }
    }

    /// The same coat over a Lambertian base whose albedo and dye strength vary as `map`
    /// says (the base's re-radiation supplies the dye, and the diagonal where the map has
    /// none).
    pub fn with_map(self, map: Arc<FluorescenceMap>) -> Coated {
        debug_assert!(matches!(self.base, CoatBase::Lambertian(_)));
        Coated {
            map: Some(map),
            ..self
        }
    }

    /// The textured base's map, if any.
    pub fn map(&self) -> Option<&Arc<FluorescenceMap>> {
        self.map.as_ref()
    }

    /// The Lambertian base's re-radiation (None over a conductor).
    pub fn reradiation(&self) -> Option<&Arc<Reradiation>> {
        match &self.base {
            CoatBase::Lambertian(b) => Some(b),
            CoatBase::Conductor { .. } => None,
        }
    }

    /// Whether the base fluoresces (then the base branch shifts wavelengths).
    pub fn fluoresces(&self) -> bool {
        self.reradiation().is_some_and(|b| b.is_fluorescent())
    }

    /// Whether the coat is rough (its reflection a GGX lobe, not a mirror).
    pub fn is_rough(&self) -> bool {
        self.alpha >= MIN_ALPHA
    }

    /// The probability of sampling the coat's reflection at incidence cosine `cos_o`.
    #[inline(always)]
    pub fn p_coat<F: Float>(&self, cos_o: F) -> F {
        let eta = F::splat(self.eta_ref);
        let r = match self.is_rough() {
            false => fresnel_dielectric(cos_o, eta),
            true => albedo::external(cos_o, eta, F::splat(self.alpha)),
        };
        r.clamp(P_MIN, 1.0 - P_MIN)
    }

    /// A smooth coat's Fresnel reflectance per lane at `cos_o` (the mirror branch's value).
    #[inline(always)]
    pub fn reflectance<F: Float>(&self, cos_o: F, lambda: &Spec<F>, m: F::Mask) -> Spec<F> {
        let eta = self.ior.eval_w(lambda, m);
        eta.map(|e| fresnel_dielectric(cos_o, e))
    }

    /// What light leaving the base towards `cos_o` keeps, per lane at its wavelength λo:
    /// (1 − R)·e^(−τ/cos θo') times [`Coated`]'s exit scale.
    #[inline(always)]
    pub fn exit<F: Float>(&self, cos_o: F, lambda: &Spec<F>, m: F::Mask) -> Spec<F> {
        let (eta, tau) = self.at(lambda, m);
        let through = crossing(cos_o, &eta, &tau, F::splat(self.alpha));
        through * self.exit_scale.eval_w(lambda, m)
    }

    /// [`Coated::exit`] over a textured Lambertian base of albedo `rho` per lane at λo:
    /// (1 − R)·e^(−τ/cos θo') / (η²·(1 − ρ·r)).
    #[inline(always)]
    pub fn exit_textured<F: Float>(
        &self,
        cos_o: F,
        lambda: &Spec<F>,
        m: F::Mask,
        rho: &Spec<F>,
    ) -> Spec<F> {
        let (eta, tau) = self.at(lambda, m);
        let through = crossing(cos_o, &eta, &tau, F::splat(self.alpha));
        let r = match &self.internal {
            Some(r) => r.eval_w(lambda, m),
            None => Spec::zero(),
        };
        let one = Spec::splat(1.0);
        through / (eta * eta * (one - *rho * r))
    }

    /// The coat's parameters at the wavelengths `lambda` for the base lobe: η and τ.
    #[inline(always)]
    pub fn at<F: Float>(&self, lambda: &Spec<F>, m: F::Mask) -> (Spec<F>, Spec<F>) {
        (self.ior.eval_w(lambda, m), self.tau.eval_w(lambda, m))
    }
}

/// (1 − R(cos, η))·e^(−τ/cos θ') per lane, θ' the refracted angle inside the coat and R
/// Fresnel where the coat's width `alpha` is below [`MIN_ALPHA`], GGX's albedo elsewhere.
#[inline(always)]
pub fn crossing<F: Float>(cos: F, eta: &Spec<F>, tau: &Spec<F>, alpha: F) -> Spec<F> {
    let one = F::splat(1.0);
    let c = cos.clamp(0.0, 1.0);
    let rough = alpha.ge(F::splat(MIN_ALPHA));
    let mut out = Spec::zero();
    for k in 0..4 {
        let e = eta[k];
        let cos_t = (one - (one - c * c) / (e * e)).max(F::splat(1e-6)).sqrt();
        let mut t = one - fresnel_dielectric(c, e);
        if rough.any() {
            t = F::select(rough, one - albedo::external(c, e, alpha), t);
        }
        out[k] = t * math::exp(-(tau[k] / cos_t));
    }
    out
}

/// The local direction inside a coat of index `eta` that refracts into the local
/// direction `w` outside (both pointing away from the base).
#[inline(always)]
fn inside<F: Float>(w: V3<F>, eta: F) -> V3<F> {
    let sin2 = (F::splat(1.0) - w.z * w.z).max(F::splat(0.0)) / (eta * eta);
    let z = (F::splat(1.0) - sin2).max(F::splat(0.0)).sqrt();
    V3::new(w.x / eta, w.y / eta, z)
}

/// The outside direction of the local direction `w` inside the coat, and the paths for
/// which it leaves (the others are totally internally reflected).
#[inline(always)]
fn outside<F: Float>(w: V3<F>, eta: F) -> (V3<F>, F::Mask) {
    let sin2 = (F::splat(1.0) - w.z * w.z).max(F::splat(0.0)) * eta * eta;
    let z = (F::splat(1.0) - sin2).max(F::splat(0.0)).sqrt();
    (
        V3::new(w.x * eta, w.y * eta, z),
        sin2.lt(F::splat(1.0)) & w.z.gt(F::splat(0.0)),
    )
}

/// A conductor under a coat as the base lobe sees it: the coat's index, optical depth and
/// width per lane, the conductor's absolute index, and its GGX distribution.
#[derive(Debug, Clone, Copy)]
pub struct CoatedConductor<F: Float> {
    /// The coat's index per wavelength.
    pub coat_eta: Spec<F>,
    /// The coat's optical depth per wavelength.
    pub tau: Spec<F>,
    /// The coat's GGX width.
    pub coat_alpha: F,
    /// The conductor's η per wavelength.
    pub eta: Spec<F>,
    /// The conductor's k per wavelength.
    pub k: Spec<F>,
    /// The conductor's roughness.
    pub ggx: Ggx<F>,
}

impl<F: Float> CoatedConductor<F> {
    /// f·|cos θᵢ| (without the exit factor, which the integrator applied) and the pdf of
    /// reflecting `wo` into `wi` off a rough conductor under the coat, per lane: the base
    /// lobe between the refracted directions, times the entrance's crossing and the
    /// Jacobians cos θi/cos θi' (value) and cos θi/(η² cos θi') (pdf).
    #[inline(always)]
    pub fn eval(&self, nrm: &Normals<F>, wo: V3<F>, wi: V3<F>) -> (Spec<F>, Spec<F>) {
        let zero = F::splat(0.0);
        let (frame, lo, _) = frame_towards(nrm, wo);
        let li = frame.to_local(wi);
        let ok = (nrm.ng.dot(wo) * nrm.ng.dot(wi)).gt(zero) & lo.z.gt(zero) & li.z.gt(zero);
        let entrance = crossing(li.z, &self.coat_eta, &self.tau, self.coat_alpha);
        let (mut f, mut pdf) = (Spec::zero(), Spec::zero());
        for k in 0..4 {
            let e = self.coat_eta[k];
            let (lo_in, li_in) = (inside(lo, e), inside(li, e));
            let wh = (lo_in + li_in).normalize();
            let c = lo_in.dot(wh);
            let ok = ok & c.gt(zero) & li_in.z.gt(zero);
            let fc = fresnel_conductor(c, self.eta[k] / e, self.k[k] / e);
            let d_g = self.ggx.d(wh) * self.ggx.g2(lo_in, li_in) / (F::splat(4.0) * lo_in.z);
            let jac = li.z / li_in.z;
            f[k] = (entrance[k] * fc * d_g * jac).masked(ok);
            let p_in = self.ggx.pdf_visible(lo_in, wh) / (F::splat(4.0) * c);
            pdf[k] = (p_in * jac / (e * e)).masked(ok);
        }
        (f, pdf)
    }

    /// A direction for the hero: `wo` refracted in, a visible normal of the base (`u`),
    /// the reflection refracted out. The mask: the paths whose reflection leaves the coat.
    #[inline(always)]
    pub fn sample(&self, nrm: &Normals<F>, wo: V3<F>, u: [F; 2]) -> (V3<F>, F::Mask) {
        let (frame, lo, _) = frame_towards(nrm, wo);
        let e = self.coat_eta.hero();
        let lo_in = inside(lo, e);
        let wh = self.ggx.sample_visible(lo_in, u);
        let (li, ok) = outside(reflect(lo_in, wh), e);
        (frame.to_world(li), ok & lo.z.gt(F::splat(0.0)))
    }

    /// A smooth conductor under the coat: the mirror's weight per lane at cos θo =
    /// `cos_o`, η²·(1 − R)·e^(−τ/cos θ')·F_base(θ')/(1 − F_base·R·e^(−2τ/cos θ')) (the
    /// exit factor, 1/η² included, applied by the integrator).
    #[inline(always)]
    pub fn mirror(&self, cos_o: F) -> Spec<F> {
        let one = F::splat(1.0);
        let c = cos_o.clamp(0.0, 1.0);
        let zero_tau = Spec::zero();
        let t = crossing(c, &self.coat_eta, &zero_tau, self.coat_alpha);
        let mut w = Spec::zero();
        for k in 0..4 {
            let e = self.coat_eta[k];
            let cos_in = (one - (one - c * c) / (e * e)).max(F::splat(1e-6)).sqrt();
            let a = math::exp(-(self.tau[k] / cos_in));
            let fb = fresnel_conductor(cos_in, self.eta[k] / e, self.k[k] / e);
            let r = one - t[k];
            w[k] = e * e * t[k] * a * fb / (one - fb * r * a * a);
        }
        w
    }
}

/// r: the fraction of diffuse light going up inside a coat of index `eta`, optical depth
/// `tau` and GGX width `alpha` that comes back down to the base (internal reflection,
/// with the layer's absorption on the way up and down): 2∫₀¹ R(μ, 1/η)·e^(−2τ/μ)·μ dμ,
/// R Fresnel for a smooth coat, GGX's albedo for a rough one.
///
/// A rough coat's single-scattering albedo from inside misses the light its microfacets
/// shadow beyond the critical angle (about 6 % of r at η = 1.5, α = 0.1), which would
/// leave the layer as if transmitted. Reciprocity fixes diffuse light's balance across a
/// clear interface, 1 − r = (1 − r_ext)/η² with r_ext = 2∫E(μ, η)·μ dμ from outside; the
/// rough r is scaled to meet it, so that a white base under a clear rough coat conserves
/// energy as under a smooth one (Mitsuba 3's `roughplastic` keeps the single-scattering
/// r, and is that much darker).
pub fn internal_reflectance(eta: f32, tau: f32, alpha: f32) -> f32 {
    if alpha < MIN_ALPHA {
        let n = 2000;
        let mut sum = 0.0f64;
        for i in 0..n {
            let mu = (i as f64 + 0.5) / n as f64;
            let f = f64::from(fresnel_dielectric(mu as f32, 1.0 / eta));
            sum += f * (-2.0 * f64::from(tau) / mu).exp() * mu;
        }
        return (2.0 * sum / n as f64) as f32;
    }
    Interior::new(eta, alpha).reflectance(eta, tau)
}

/// Midpoints in μ of the rough coat's internal-reflectance integral.
const N_INTERIOR: usize = 64;

/// What a rough coat's internal reflectance needs at one index, whatever the absorption:
/// the single-scattering albedo from inside, E(μ, 1/η, α), at the μ midpoints, and the
/// diffuse albedo from outside, r_ext.
#[derive(Clone)]
struct Interior {
    e: [f64; N_INTERIOR],
    r_ext: f64,
}

impl Interior {
    fn new(eta: f32, alpha: f32) -> Interior {
        let mut e = [0.0; N_INTERIOR];
        for (i, e) in e.iter_mut().enumerate() {
            let mu = (i as f64 + 0.5) / N_INTERIOR as f64;
            *e = f64::from(albedo::reflection_albedo(mu as f32, 1.0 / eta, alpha));
        }
        Interior {
            e,
            r_ext: diffuse_external_albedo(eta, alpha),
        }
    }

    /// r at index `eta` and optical depth `tau`, scaled to reciprocity.
    fn reflectance(&self, eta: f32, tau: f32) -> f32 {
        let (mut absorbed, mut clear) = (0.0f64, 0.0f64);
        for (i, &e) in self.e.iter().enumerate() {
            let mu = (i as f64 + 0.5) / N_INTERIOR as f64;
            absorbed += e * (-2.0 * f64::from(tau) / mu).exp() * mu;
            clear += e * mu;
        }
        let r_recip = 1.0 - (1.0 - self.r_ext) / f64::from(eta * eta);
        (absorbed / clear * r_recip) as f32
    }
}

/// [`Interior`] over a dispersive coat's range of indices: computed at nodes 0.002 apart
/// and interpolated, so that a coat whose index changes at every nm costs tens of
/// quadratures, not hundreds.
struct RoughInterior {
    eta0: f32,
    step: f32,
    nodes: Vec<Interior>,
}

impl RoughInterior {
    /// None for a smooth coat.
    fn new(ior: &Ior, alpha: f32) -> Option<RoughInterior> {
        if alpha < MIN_ALPHA {
            return None;
        }
        let etas: Vec<f32> = (LAMBDA_MIN as u32..=LAMBDA_MAX as u32)
            .map(|l| ior.eval(l as f32))
            .collect();
        let lo = etas.iter().copied().fold(f32::INFINITY, f32::min);
        let hi = etas.iter().copied().fold(f32::NEG_INFINITY, f32::max);
        let step = 0.002;
        let n = ((hi - lo) / step).ceil() as usize + 1;
        let nodes = (0..n)
            .map(|k| Interior::new(lo + k as f32 * step, alpha))
            .collect();
        Some(RoughInterior {
            eta0: lo,
            step,
            nodes,
        })
    }

    /// The ingredients at `eta`: a node's where it is one (a constant index), else
    /// linear between the two around it.
    fn at(&self, eta: f32) -> Interior {
        let x = ((eta - self.eta0) / self.step).max(0.0);
        let k = (x as usize).min(self.nodes.len() - 1);
        let w = f64::from(x - k as f32);
        if w == 0.0 || k + 1 == self.nodes.len() {
            return self.nodes[k].clone();
        }
        let (a, b) = (&self.nodes[k], &self.nodes[k + 1]);
        Interior {
            e: std::array::from_fn(|i| a.e[i] + w * (b.e[i] - a.e[i])),
            r_ext: a.r_ext + w * (b.r_ext - a.r_ext),
        }
    }
}

/// r_ext = 2∫₀¹ E(μ, η, α)·μ dμ: what a rough coat reflects of diffuse light from outside,
/// from the same table as the crossings.
pub fn diffuse_external_albedo(eta: f32, alpha: f32) -> f64 {
    let n = 256;
    let sum: f64 = (0..n)
        .map(|i| {
            let mu = (i as f64 + 0.5) / n as f64;
            f64::from(albedo::external_one(mu as f32, eta, alpha)) * mu
        })
        .sum();
    2.0 * sum / n as f64
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A smooth conductor under a smooth absorbing coat: the coat's own reflection R plus
    /// the mirror weight times the exit factor is the incoherent sum of the reflections
    /// between coat and base, R + (1 − R)²·F_b·a²/(1 − R·F_b·a²), with a = e^(−τ/cos θ')
    /// for θ' from Snell's law (one crossing of the coat is one path τ/cos θ' long).
    #[test]
    fn a_coated_mirror_sums_the_reflections_between_coat_and_base() {
        let (e, tau, eta_b, k_b) = (1.5f32, 0.4f32, 0.2f32, 3.0f32);
        let mirror = CoatedConductor::<f32> {
            coat_eta: Spec::splat(e),
            tau: Spec::splat(tau),
            coat_alpha: 0.0,
            eta: Spec::splat(eta_b),
            k: Spec::splat(k_b),
            ggx: Ggx::new(0.0, 0.0),
        };
        for cos_o in [1.0f32, 0.8, 0.5, 0.2] {
            let r = f64::from(fresnel_dielectric(cos_o, e));
            let cos_t = (1.0 - (1.0 - cos_o * cos_o) / (e * e)).sqrt();
            let fb = f64::from(fresnel_conductor(cos_t, eta_b / e, k_b / e));
            let a2 = (-2.0 * f64::from(tau / cos_t)).exp();
            let want = r + (1.0 - r).powi(2) * fb * a2 / (1.0 - r * fb * a2);
            let exit = crossing(cos_o, &Spec::splat(e), &Spec::splat(tau), 0.0)[0] / (e * e);
            let got = r + f64::from(mirror.mirror(cos_o)[0] * exit);
            assert!((got - want).abs() < 1e-5, "cos θo {cos_o}: {got} vs {want}");
        }
    }

    /// A rough absorbing coat's internal reflectance against a direct quadrature of its
    /// definition: the reciprocal clear r, times the share of the single-scattering
    /// albedo 2∫E(μ)·μ dμ that survives the round trip e^(−2τ/μ).
    #[test]
    fn rough_internal_reflectance_absorbs_along_each_direction() {
        for (eta, alpha, tau) in [(1.5f32, 0.3f32, 0.3f32), (1.33, 0.1, 0.6)] {
            let n = 1024;
            let (mut absorbed, mut clear) = (0.0f64, 0.0f64);
            for i in 0..n {
                let mu = (i as f64 + 0.5) / n as f64;
                let e = f64::from(albedo::reflection_albedo(mu as f32, 1.0 / eta, alpha));
                absorbed += e * (-2.0 * f64::from(tau) / mu).exp() * mu;
                clear += e * mu;
            }
            let r_clear = 1.0 - (1.0 - diffuse_external_albedo(eta, alpha)) / f64::from(eta * eta);
            let want = r_clear * absorbed / clear;
            let got = f64::from(internal_reflectance(eta, tau, alpha));
            assert!(
                (got - want).abs() < 2e-3,
                "η {eta} α {alpha} τ {tau}: {got} vs {want}"
            );
        }
    }

    /// 1 − r_internal = (1 − r_external)/η² for a clear coat: what enters diffusely leaves.
    #[test]
    fn internal_and_external_diffuse_reflectance_balance() {
        for eta in [1.33f32, 1.5, 2.0] {
            let r_int = internal_reflectance(eta, 0.0, 0.0);
            let n = 4000;
            let r_ext: f64 = (0..n)
                .map(|i| {
                    let mu = (i as f64 + 0.5) / n as f64;
                    2.0 * f64::from(fresnel_dielectric(mu as f32, eta)) * mu / n as f64
                })
                .sum();
            let lhs = 1.0 - f64::from(r_int);
            let rhs = (1.0 - r_ext) / f64::from(eta * eta);
            assert!((lhs - rhs).abs() < 2e-3, "η {eta}: {lhs} vs {rhs}");
        }
        // Through a rough coat the balance holds by construction; absorption still only
        // lowers r, and the single-scattering r it corrects is the smaller one.
        for (eta, alpha) in [(1.5f32, 0.1f32), (1.5, 0.5), (1.33, 0.3)] {
            let r = internal_reflectance(eta, 0.0, alpha);
            let lhs = 1.0 - f64::from(r);
            let rhs = (1.0 - diffuse_external_albedo(eta, alpha)) / f64::from(eta * eta);
            assert!(
                (lhs - rhs).abs() < 1e-5,
                "η {eta} α {alpha}: {lhs} vs {rhs}"
            );
            assert!(internal_reflectance(eta, 0.3, alpha) < r);
            let single: f64 = (0..64)
                .map(|i| {
                    let mu = (i as f64 + 0.5) / 64.0;
                    let e = albedo::reflection_albedo(mu as f32, 1.0 / eta, alpha);
                    2.0 * f64::from(e) * mu / 64.0
                })
                .sum();
            assert!(single < f64::from(r), "η {eta} α {alpha}: {single} vs {r}");
        }
        // A dispersive rough coat's interpolated r against the direct computation.
        let ior = Ior::Cauchy {
            a: 1.45,
            b: 20_000.0,
        };
        let rough = RoughInterior::new(&ior, 0.25).unwrap();
        for l in [400.0f32, 517.3, 700.0] {
            let eta = ior.eval(l);
            let (a, b) = (
                rough.at(eta).reflectance(eta, 0.2),
                internal_reflectance(eta, 0.2, 0.25),
            );
            assert!((a - b).abs() < 1e-4, "{l} nm: {a} vs {b}");
        }
        // Absorption only lowers what comes back.
        assert!(internal_reflectance(1.5, 0.3, 0.0) < internal_reflectance(1.5, 0.0, 0.0));
    }
}
