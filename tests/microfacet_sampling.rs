//! Rough conductors and rough dielectrics (`stokes::bsdf::{microfacet, rough}`): is what
//! the sampler draws the density the MIS weights are told, is the BSDF reciprocal, does
//! it conserve energy, and does it become the smooth interface as α → 0?
//!
//! A path tracer with hero-wavelength MIS needs, at every rough vertex, (1) directions
//! distributed as the hero pdf `Lobe::eval` reports, (2) for every lane the pdf with
//! which that lane would have drawn the direction, and (3) a value f·|cos| that is right
//! on its own (reciprocal, energy-conserving), since light sampling uses `eval` alone.
//! Errors in any of them bias renders without showing up as noise, so they are checked
//! here directly:
//!
//! - chi-square of `Lobe::sample` directions over (cos θ, φ) cells around a tilted
//!   normal against eval's hero pdf (integrated per cell by Gauss–Legendre), for several
//!   conductors and dielectrics and incident directions on both sides; the missing mass
//!   (directions that leave the lobe's side) must be the frequency of "no sample". Every
//!   sample is also checked pointwise against `eval` (pdf and f/pdf per lane), against
//!   the visible normal it was built from (reflection or refraction, on the right side,
//!   chosen by the hero's Fresnel), and for dispersive glass every lane whose own
//!   generalised half vector exists must keep a non-zero pdf;
//! - chi-square of `Ggx::sample_visible` against `Ggx::pdf_visible` alone, to localise
//!   a failure to the distribution of visible normals;
//! - reciprocity of f over random direction pairs (the radiance BTDF with its 1/η²);
//! - directional albedo by deterministic quadrature of `eval` against the mean of
//!   f/pdf over samples (a Z-test) and against an independent f64 model of single
//!   scattering (GGX D, height-correlated Smith G₂, Fresnel by complex amplitudes),
//!   written here from the formulas as expectations over the visible normals, so that
//!   neither the BSDF's form nor its Jacobians are shared with the code under test;
//! - α → 0: the sampled directions and weights of the smooth interfaces.
//!
//! Fixed seeds throughout. A test function's chi-square checks share a false-alarm rate
//! of 1e-4 (Bonferroni); each has a must-fail control on the same samples, in which the
//! densest cells holding half the probability are 1.1× too likely (the pdf of a lobe
//! that is slightly too peaked), which must be rejected at p < 1e-6. The Z-tests accept
//! |z| < 5 (two-sided p ≈ 5.7e-7 each, below 1e-4 over a function's checks).

mod common;
use common::assert_sample_matches_eval;
use common::directions::{direction, gauss_legendre, Binned, Grid, Mass, Region};
use common::stats::{ChiSquare, Rng};
use glam::{DVec3, Vec3, Vec4};
use std::f64::consts::PI;
use std::sync::OnceLock;
use std::time::Instant;
use stokes::bsdf::{fresnel_conductor, metals, Frame, Ggx, Ior, Lobe, Material};
use stokes::simd::V3;
use stokes::spectrum::{Spectrum, Tabulated, LAMBDA_MAX, LAMBDA_MIN};

/// False-alarm rate of each test function (split over its checks).
const FALSE_ALARM: f64 = 1e-4;
/// What a must-fail control must reach.
const CONTROL_P: f64 = 1e-6;
/// The factor by which a control's expected distribution is wrong in one region.
const WRONG_BY: f64 = 1.1;
/// Largest |z| a Z-test accepts.
const Z_MAX: f64 = 5.0;
/// The path's four wavelengths (nm).
const LAMBDA: Vec4 = Vec4::new(400.0, 517.5, 635.0, 752.5);
/// Samples per chi-square test.
const SAMPLES: usize = 200_000;

/// A tilted geometric normal (not along an axis).
fn normal() -> Vec3 {
    Vec3::new(0.3, -0.5, 0.8).normalize()
}

/// The direction at cosine `c` to the normal (negative: below the surface), at an
/// azimuth that varies with `k`.
fn wo_at(c: f64, k: usize) -> Vec3 {
    direction(normal().as_dvec3(), c, 0.7 + 1.3 * k as f64).as_vec3()
}

fn rel(a: f32, b: f32) -> f32 {
    (a - b).abs() / b.abs().max(1e-30)
}

/// Prints the time a test took.
struct Timer(&'static str, Instant);

impl Timer {
    fn start(what: &'static str) -> Timer {
        Timer(what, Instant::now())
    }
}

impl Drop for Timer {
    fn drop(&mut self) {
        println!("{}: {:.2} s", self.0, self.1.elapsed().as_secs_f64());
    }
}

// ---------------------------------------------------------------------------------------
// Materials.

/// A linear ramp over the visible range, so that the four lanes differ.
fn ramp(from: f32, to: f32) -> Spectrum {
    Spectrum::Tabulated(Tabulated::new(vec![LAMBDA_MIN, LAMBDA_MAX], vec![from, to]).unwrap())
}

fn gold(alpha: [f32; 2]) -> Lobe {
    let (eta, k) = metals::metal("Au").unwrap();
    Material::Conductor {
        eta,
        k,
        alpha,
        alpha_map: None,
    }
    .at(LAMBDA)
}

fn conductors() -> [(&'static str, Lobe); 3] {
    [
        ("gold, α 0.2", gold([0.2, 0.2])),
        ("gold, α 0.5", gold([0.5, 0.5])),
        (
            "ramp η/k, α [0.2, 0.6]",
            Material::Conductor {
                eta: ramp(0.3, 1.8),
                k: ramp(4.0, 2.0),
                alpha: [0.2, 0.6],
                alpha_map: None,
            }
            .at(LAMBDA),
        ),
    ]
}

fn rough_glass(ior: Ior, ext_ior: f32, alpha: [f32; 2]) -> Lobe {
    Material::RoughDielectric {
        ior,
        ext_ior,
        alpha,
        alpha_map: None,
    }
    .at(LAMBDA)
}

fn dispersive() -> Ior {
    Ior::Cauchy {
        a: 1.5,
        b: 10_000.0,
    }
}

fn dielectrics() -> [(&'static str, Lobe); 4] {
    [
        (
            "glass in air, α 0.3",
            rough_glass(Ior::Constant(1.5), 1.0, [0.3; 2]),
        ),
        (
            "glass in water, α 0.2",
            rough_glass(Ior::Constant(1.5), 1.33, [0.2; 2]),
        ),
        (
            "glass in air, α [0.1, 0.4]",
            rough_glass(Ior::Constant(1.5), 1.0, [0.1, 0.4]),
        ),
        (
            "dispersive glass, α 0.3",
            rough_glass(dispersive(), 1.0, [0.3; 2]),
        ),
    ]
}

/// The GGX widths of a rough lobe.
fn alpha_of(lobe: &Lobe) -> [f32; 2] {
    match *lobe {
        Lobe::Conductor(_, _, a) | Lobe::RoughDielectric(_, _, a) => a,
        _ => panic!("not a rough lobe: {lobe:?}"),
    }
}

/// Per lane, n_t/n_i for light leaving towards `wo` (i on wo's side), or None for a
/// conductor; and per lane the index on wo's side and on the other side.
fn dielectric_indices(lobe: &Lobe, front: bool) -> Option<([f64; 4], [f64; 4], [f64; 4])> {
    let Lobe::RoughDielectric(n_in, ext, _) = *lobe else {
        return None;
    };
    let n_in = n_in.to_array().map(f64::from);
    let ext = f64::from(ext);
    let (near, far) = match front {
        true => ([ext; 4], n_in),
        false => (n_in, [ext; 4]),
    };
    Some((std::array::from_fn(|k| far[k] / near[k]), near, far))
}

// ---------------------------------------------------------------------------------------
// Geometry in f64, written here.

fn mirrored(wo: DVec3, m: DVec3) -> DVec3 {
    2.0 * wo.dot(m) * m - wo
}

/// `wo` (on m's side) refracted through the facet `m` into the other side, with
/// `eta` = n_t/n_i (Snell in vector form); None under total internal reflection.
fn refracted(wo: DVec3, m: DVec3, eta: f64) -> Option<DVec3> {
    let c = wo.dot(m);
    let s2 = (1.0 - c * c) / (eta * eta);
    (s2 < 1.0).then(|| -wo / eta + m * (c / eta - (1.0 - s2).sqrt()))
}

/// A complex number, for Fresnel's amplitudes.
#[derive(Debug, Clone, Copy)]
struct C(f64, f64);

impl C {
    fn add(self, o: C) -> C {
        C(self.0 + o.0, self.1 + o.1)
    }
    fn sub(self, o: C) -> C {
        C(self.0 - o.0, self.1 - o.1)
    }
    fn mul(self, o: C) -> C {
        C(self.0 * o.0 - self.1 * o.1, self.0 * o.1 + self.1 * o.0)
    }
    fn norm2(self) -> f64 {
        self.0 * self.0 + self.1 * self.1
    }
    fn div(self, o: C) -> C {
        let d = o.norm2();
        C(
            (self.0 * o.0 + self.1 * o.1) / d,
            (self.1 * o.0 - self.0 * o.1) / d,
        )
    }
    /// The principal square root (non-negative real part).
    fn sqrt(self) -> C {
        let r = self.norm2().sqrt();
        let re = (0.5 * (r + self.0)).max(0.0).sqrt();
        let im = (0.5 * (r - self.0)).max(0.0).sqrt();
        C(re, if self.1 < 0.0 { -im } else { im })
    }
}

/// Unpolarised Fresnel reflectance at incidence cosine `cos_i` onto relative index
/// η + ik (n_t/n_i), from the s and p amplitude coefficients with the complex
/// transmitted cosine (k = 0 covers dielectrics, total internal reflection included).
fn fresnel(cos_i: f64, eta: f64, k: f64) -> f64 {
    let ci = C(cos_i, 0.0);
    let n2 = C(eta, k).mul(C(eta, k));
    let w = n2.sub(C(1.0 - cos_i * cos_i, 0.0)).sqrt(); // n̂ cos θt
    let rs = ci.sub(w).div(ci.add(w));
    let rp = n2.mul(ci).sub(w).div(n2.mul(ci).add(w));
    0.5 * (rs.norm2() + rp.norm2())
}

/// Isotropic GGX in f64, in the frame of its normal: D from θ, Smith's Λ from
/// a = 1/(α tan θ) (Heitz 2014).
struct Model {
    alpha: f64,
}

impl Model {
    fn d(&self, cos_m: f64) -> f64 {
        if cos_m <= 0.0 {
            return 0.0;
        }
        let c2 = cos_m * cos_m;
        let tan2 = (1.0 - c2) / c2;
        let a2 = self.alpha * self.alpha;
        1.0 / (PI * a2 * c2 * c2 * (1.0 + tan2 / a2).powi(2))
    }

    fn lambda(&self, cos_w: f64) -> f64 {
        let c = cos_w.abs();
        let tan = (1.0 - c * c).max(0.0).sqrt() / c;
        if tan == 0.0 {
            return 0.0;
        }
        let a = 1.0 / (self.alpha * tan);
        0.5 * (-1.0 + (1.0 + 1.0 / (a * a)).sqrt())
    }

    fn g2(&self, cos_o: f64, cos_i: f64) -> f64 {
        1.0 / (1.0 + self.lambda(cos_o) + self.lambda(cos_i))
    }
}

// ---------------------------------------------------------------------------------------
// Chi-square of sampled directions.

/// Samples `lobe` at `wo` with the random numbers of `rng` and checks the sample
/// pointwise (see the module doc); returns its direction, or None if there is none.
fn checked_sample(lobe: &Lobe, wo: Vec3, rng: &mut Rng) -> Option<Vec3> {
    let n = normal();
    let (uc, u) = (rng.next_f32(), rng.next_2d());
    let s = lobe.sample(n, wo, uc, u)?;
    let what = || format!("{lobe:?} at {wo}: {s:?}");
    let (f_cos, pdf) = lobe.eval(n, wo, s.wi);
    assert_sample_matches_eval(&s, f_cos, pdf, &what);
    // The visible normal the sampler drew from `u`, on wo's side of the surface.
    let front = wo.dot(n) > 0.0;
    let ns = if front { n } else { -n };
    let frame = Frame::new(V3::<f32>::from(ns));
    let [ax, ay] = alpha_of(lobe);
    let m_local = Ggx::new(ax, ay).sample_visible(frame.to_local(V3::from(wo)), u);
    let m = Vec3::from(frame.to_world(m_local)).as_dvec3().normalize();
    let (wo_d, wi_d, ns_d) = (wo.as_dvec3(), s.wi.as_dvec3(), ns.as_dvec3());
    assert!(wo_d.dot(m) > -1e-6, "normal {m} not visible: {}", what());
    let same_side = wi_d.dot(ns_d) > 0.0;
    match dielectric_indices(lobe, front) {
        None => {
            assert!(same_side, "{}", what());
            assert!((wi_d - mirrored(wo_d, m)).length() < 1e-4, "{}", what());
        }
        Some((eta, _, _)) => {
            let f = fresnel(wo_d.dot(m).clamp(0.0, 1.0), eta[0], 0.0);
            let wt = refracted(wo_d, m, eta[0]);
            if same_side {
                assert!((wi_d - mirrored(wo_d, m)).length() < 1e-4, "{}", what());
                assert!(f64::from(uc) < f + 1e-5, "reflected at F = {f}: {}", what());
            } else {
                let wt = wt.unwrap_or_else(|| panic!("refracted under TIR: {}", what()));
                assert!((wi_d - wt).length() < 1e-4, "{}", what());
                assert!(f64::from(uc) > f - 1e-5, "refracted at F = {f}: {}", what());
                all_lanes_refract(wi_d, wo_d, ns_d, &eta, &s.pdf, &what);
            }
        }
    }
    Some(s.wi)
}

/// Transmission into `wi`: every lane whose own generalised half vector wo + η·wi (ns
/// on wo's side) is a facet that faces wo and refracts into wi must have a pdf. Facets
/// within 0.01 of grazing on either side are left out: at the critical angle (wi·m → 0
/// from inside) the f32 directions' rounding alone decides whether a lane still
/// refracts (seen: wi·m = −6e-4, where sin²θt rounds to 1 + 7e-8 and the pdf is ~0).
fn all_lanes_refract(
    wi: DVec3,
    wo: DVec3,
    ns: DVec3,
    eta: &[f64; 4],
    pdf: &Vec4,
    what: &dyn Fn() -> String,
) {
    for k in 1..4 {
        let h = wo + wi * eta[k];
        let m = (h * h.dot(ns).signum()).normalize();
        let exists = m.dot(ns) > 1e-2 && wo.dot(m) > 1e-2 && wi.dot(m) < -1e-2;
        if exists {
            assert!(pdf[k] > 0.0, "lane {k} dropped (η {}): {}", eta[k], what());
        }
    }
}

/// (name, lobe, cos θo): conductors at incident angles on both sides (conductors are
/// two-sided), down to grazing.
fn conductor_cases() -> Vec<(String, Lobe, f64)> {
    let mut out = Vec::new();
    for (name, lobe) in conductors() {
        for c in [0.9, 0.5, 0.1, -0.3, -0.8] {
            out.push((format!("{name}, cos θo = {c}"), lobe, c));
        }
    }
    out
}

/// Dielectrics from outside and from inside, below and beyond the critical angle
/// (cos θc ≈ 0.745 for glass in air, 0.462 for glass in water).
fn dielectric_cases() -> Vec<(String, Lobe, f64)> {
    let d = dielectrics();
    let cosines: [&[f64]; 4] = [
        &[0.9, 0.5, 0.1, -0.95, -0.6, -0.2],
        &[0.7, -0.8, -0.3],
        &[0.6, -0.5],
        &[0.8, 0.3, -0.9, -0.6],
    ];
    let mut out = Vec::new();
    for ((name, lobe), cs) in d.iter().zip(cosines) {
        for &c in cs {
            out.push((format!("{name}, cos θo = {c}"), *lobe, c));
        }
    }
    out
}

/// Binned samples of every case against eval's hero pdf: 32 × 64 cells, Gauss–Legendre
/// order 8 per cell (12 for lobes narrower than α 0.25 somewhere).
fn binned(cases: &[(String, Lobe, f64)], seed: u64) -> Vec<(String, Grid, Binned)> {
    let n = normal();
    cases
        .iter()
        .enumerate()
        .map(|(k, (name, lobe, c))| {
            let wo = wo_at(*c, k);
            let [ax, ay] = alpha_of(lobe);
            let grid = Grid {
                n: n.as_dvec3(),
                n_cos: 32,
                n_phi: 64,
                order: if ax.min(ay) < 0.25 { 12 } else { 8 },
            };
            let b = Binned::new(
                &grid,
                seed + k as u64,
                SAMPLES,
                |rng| checked_sample(lobe, wo, rng),
                |w| f64::from(lobe.eval(n, wo, w.as_vec3()).1.x),
                Mass::AtMostOne,
            );
            (name.clone(), grid, b)
        })
        .collect()
}

fn conductor_bins() -> &'static [(String, Grid, Binned)] {
    static BINS: OnceLock<Vec<(String, Grid, Binned)>> = OnceLock::new();
    BINS.get_or_init(|| binned(&conductor_cases(), 1000))
}

fn dielectric_bins() -> &'static [(String, Grid, Binned)] {
    static BINS: OnceLock<Vec<(String, Grid, Binned)>> = OnceLock::new();
    BINS.get_or_init(|| binned(&dielectric_cases(), 2000))
}

/// Prints every result, then asserts that each accepts at the family's false-alarm rate
/// split over its tests (Bonferroni).
fn accept_all(results: &[(String, ChiSquare)]) {
    let alpha = FALSE_ALARM / results.len() as f64;
    for (what, r) in results {
        println!("{what}: {r}");
    }
    for (what, r) in results {
        r.assert_accepts(alpha, what);
    }
}

fn chi_squares(bins: &[(String, Grid, Binned)], control: bool) -> Vec<(String, ChiSquare)> {
    let control = control.then_some((Region::DensestHalf, WRONG_BY));
    bins.iter()
        .map(|(name, grid, b)| {
            let missing = b.probabilities[grid.cells()];
            let what = format!("{name} (no sample: {missing:.4})");
            (what, b.chi_square(grid, control))
        })
        .collect()
}

fn reject_all(results: &[(String, ChiSquare)]) {
    for (what, r) in results {
        println!("control, {what}: {r}");
    }
    for (what, r) in results {
        r.assert_rejects(CONTROL_P, &format!("{what}, densest half × 1.1"));
    }
}

#[test]
fn rough_conductors_sample_the_pdf_they_evaluate() {
    let _t = Timer::start("rough conductors, chi-square");
    accept_all(&chi_squares(conductor_bins(), false));
}

#[test]
fn rough_conductor_chi_square_rejects_a_pdf_off_by_ten_percent() {
    let _t = Timer::start("rough conductors, controls");
    reject_all(&chi_squares(conductor_bins(), true));
}

#[test]
fn rough_dielectrics_sample_the_pdf_they_evaluate() {
    let _t = Timer::start("rough dielectrics, chi-square");
    accept_all(&chi_squares(dielectric_bins(), false));
}

#[test]
fn rough_dielectric_chi_square_rejects_a_pdf_off_by_ten_percent() {
    let _t = Timer::start("rough dielectrics, controls");
    reject_all(&chi_squares(dielectric_bins(), true));
}

/// The dispersive glass: transmitted samples keep every lane (the lanes' pdfs differ
/// and are non-zero), and no sample is specular; counted over many directions.
#[test]
fn dispersive_rough_glass_keeps_every_lane() {
    let _t = Timer::start("dispersive lanes");
    let lobe = rough_glass(dispersive(), 1.0, [0.3; 2]);
    let n = normal();
    let mut rng = Rng::new(77, 1);
    let (mut transmitted, mut all_lanes, mut differ) = (0, 0, 0);
    for i in 0..40_000 {
        let wo = wo_at(if i % 2 == 0 { 0.6 } else { -0.9 }, i);
        let Some(s) = lobe.sample(n, wo, rng.next_f32(), rng.next_2d()) else {
            continue;
        };
        assert!(!s.specular);
        let front = wo.dot(n) > 0.0;
        if s.wi.dot(n) * wo.dot(n) < 0.0 {
            transmitted += 1;
            all_lanes += usize::from(s.pdf.min_element() > 0.0);
            differ += usize::from(s.pdf.y != s.pdf.x && s.pdf.w != s.pdf.x);
            // A lane may only be 0 at its critical angle.
            let (eta, _, _) = dielectric_indices(&lobe, front).unwrap();
            let ns = if front { n } else { -n }.as_dvec3();
            let what = || format!("wo {wo}: {s:?}");
            all_lanes_refract(s.wi.as_dvec3(), wo.as_dvec3(), ns, &eta, &s.pdf, &what);
        }
    }
    println!(
        "{transmitted} transmitted, {all_lanes} with all four lanes (the others at a lane's \
         critical angle), {differ} with lanes' own pdfs"
    );
    assert!(transmitted > 10_000);
    assert!(all_lanes as f64 > 0.99 * transmitted as f64);
    assert!(differ as f64 > 0.99 * transmitted as f64);
}

// ---------------------------------------------------------------------------------------
// Visible normals alone.

fn visible_bins() -> &'static [(String, Grid, Binned)] {
    static BINS: OnceLock<Vec<(String, Grid, Binned)>> = OnceLock::new();
    BINS.get_or_init(|| {
        let cases = [
            ([0.3f32, 0.3f32], 0.9, 8),
            ([0.3, 0.3], 0.3, 8),
            // Grazing: the visible normals reach just past the pole, a sliver of the
            // polar cells that order 8 would miss (expecting 0 where samples land).
            ([0.3, 0.3], 0.02, 24),
            ([0.2, 0.6], 0.5, 8),
            ([1.0, 1.0], 0.1, 8),
        ];
        cases
            .iter()
            .enumerate()
            .map(|(k, &([ax, ay], c, order))| {
                let ggx = Ggx::<f32>::new(ax, ay);
                let wo = V3::from(direction(DVec3::Z, c, 0.4 + k as f64).as_vec3());
                let grid = Grid {
                    n: DVec3::Z,
                    n_cos: 32,
                    n_phi: 64,
                    order,
                };
                let b = Binned::new(
                    &grid,
                    500 + k as u64,
                    SAMPLES,
                    |rng| Some(Vec3::from(ggx.sample_visible(wo, rng.next_2d()))),
                    |m| f64::from(ggx.pdf_visible(wo, V3::from(m.as_vec3()))),
                    Mass::AtMostOne,
                );
                let total = 1.0 - b.probabilities[grid.cells()];
                assert!(total > 1.0 - 1e-4, "∫ D_wo = {total}");
                (
                    format!("visible normals, α [{ax}, {ay}], cos θo = {c}"),
                    grid,
                    b,
                )
            })
            .collect()
    })
}

#[test]
fn visible_normals_follow_pdf_visible() {
    let _t = Timer::start("visible normals, chi-square");
    accept_all(&chi_squares(visible_bins(), false));
}

#[test]
fn visible_normal_chi_square_rejects_a_pdf_off_by_ten_percent() {
    let _t = Timer::start("visible normals, controls");
    reject_all(&chi_squares(visible_bins(), true));
}

// ---------------------------------------------------------------------------------------
// Reciprocity.

/// f = f·|cos θi| / |cos θi| per lane.
fn f_of(lobe: &Lobe, wo: Vec3, wi: Vec3) -> Vec4 {
    lobe.eval(normal(), wo, wi).0 / wi.dot(normal()).abs()
}

/// Whether lane `k`'s refraction between `wo` and `wi` passes a facet within 0.05 of
/// grazing on either side: there Fresnel's transmittance has an infinite slope in the
/// facet cosine (at the critical angle), so the rounding of f32 directions alone makes
/// f(wo, wi) and f(wi, wo) differ by more than 1e-3 (seen: 2.7e-3 at a facet cosine of
/// 0.007; the f64 formula from the same f32 directions differs by 1.2e-4).
fn near_critical(lobe: &Lobe, wo: Vec3, wi: Vec3, k: usize) -> bool {
    let n = normal().as_dvec3().normalize();
    let front = wo.as_dvec3().dot(n) > 0.0;
    let (eta, _, _) = dielectric_indices(lobe, front).unwrap();
    let (wo, wi) = (wo.as_dvec3(), wi.as_dvec3());
    let h = wo + wi * eta[k];
    let m = (h * h.dot(n).signum()).normalize();
    wo.dot(m).abs().min(wi.dot(m).abs()) < 0.05
}

#[test]
fn rough_bsdfs_are_reciprocal() {
    let _t = Timer::start("reciprocity");
    let n = normal();
    let mut rng = Rng::new(9, 2);
    let lobes = conductors().into_iter().chain(dielectrics());
    for (name, lobe) in lobes {
        let (mut reflected, mut transmitted, mut skipped, mut lanes_through) = (0, 0, 0, 0);
        for _ in 0..20_000 {
            let (wo, wi) = (rng.unit_vector(), rng.unit_vector());
            let (a, b) = (f_of(&lobe, wo, wi), f_of(&lobe, wi, wo));
            let front = wo.dot(n) > 0.0;
            // Radiance BTDF: f(wo, wi)/n_wo² = f(wi, wo)/n_wi² (1 on one side for reflection).
            let scale = match dielectric_indices(&lobe, front) {
                Some((_, near, far)) if wi.dot(n) * wo.dot(n) < 0.0 => {
                    std::array::from_fn(|k| (near[k] / far[k]).powi(2) as f32)
                }
                _ => [1.0; 4],
            };
            for k in 0..4 {
                if scale[k] != 1.0 {
                    if near_critical(&lobe, wo, wi, k) {
                        skipped += 1;
                        continue;
                    }
                    lanes_through += 1;
                }
                let (x, y) = (a[k], b[k] * scale[k]);
                assert!(
                    (x - y).abs() <= 1e-3 * x.abs().max(y.abs()) + 1e-9,
                    "{name}, lane {k}: f(wo, wi) = {x}, f(wi, wo)·(n_wo/n_wi)² = {y}, wo {wo}, wi {wi}"
                );
            }
            if a.x > 1e-3 {
                match wi.dot(n) * wo.dot(n) > 0.0 {
                    true => reflected += 1,
                    false => transmitted += 1,
                }
            }
        }
        println!(
            "{name}: {reflected} reflecting and {transmitted} transmitting pairs with f > 1e-3, \
             {skipped} of {} transmitting lanes near the critical angle skipped",
            skipped + lanes_through
        );
        assert!(
            skipped * 5 <= lanes_through,
            "{name}: too many lanes skipped"
        );
        assert!(reflected > 1000, "{name}: too few reflecting pairs");
        if matches!(lobe, Lobe::RoughDielectric(..)) {
            assert!(transmitted > 500, "{name}: too few transmitting pairs");
        } else {
            assert_eq!(transmitted, 0, "{name}: a conductor transmits");
        }
    }
}

// ---------------------------------------------------------------------------------------
// Energy.

/// Reflected and transmitted directional albedo at `wo` (θo: cos `c` on the side of
/// `ns`), integrated over the microfacet normals m on wo's side: (cos θm, φm) with
/// cos θm from tan²θm = α²u/(1 − u), u = 1 − (1 − v)² (which makes the isotropic GGX
/// lobe and its grazing end smooth in v), composite Gauss–Legendre in v and φm.
/// `integrand(m, dω_m)` returns the (reflected, transmitted) contribution of one node.
fn over_normals(
    ns: DVec3,
    wo: DVec3,
    alpha: f64,
    panels: usize,
    mut integrand: impl FnMut(DVec3, f64) -> (f64, f64),
) -> (f64, f64) {
    let (x, w) = gauss_legendre(8);
    let (t, b, _) = common::directions::frame(ns);
    // Start φ at wo's azimuth so that the lobe's plane of symmetry is a panel edge.
    let phi_o = wo.dot(b).atan2(wo.dot(t));
    let a2 = alpha * alpha;
    let (mut r, mut tr) = (0.0, 0.0);
    let h = 1.0 / panels as f64;
    for pv in 0..panels {
        for (xv, wv) in x.iter().zip(&w) {
            let v = (pv as f64 + 0.5 * (1.0 + xv)) * h;
            let u = 1.0 - (1.0 - v) * (1.0 - v);
            let cos2 = (1.0 - u) / (1.0 - u + a2 * u);
            let cos_m = cos2.sqrt();
            // dω = sin θ dθ dφ = α² cos³θ / (2 (1 − u)²) du dφ and du = 2 (1 − v) dv
            // (finite as v → 1, where cos²θ ≈ (1 − v)²/α²).
            let dw_dv = a2 * cos2 * cos_m * (1.0 - v) / ((1.0 - u) * (1.0 - u)).max(1e-300);
            let sin_m = (1.0 - cos2).max(0.0).sqrt();
            for pp in 0..2 * panels {
                for (xp, wp) in x.iter().zip(&w) {
                    let phi = phi_o + (pp as f64 + 0.5 * (1.0 + xp)) * PI / panels as f64;
                    let m = t * (sin_m * phi.cos()) + b * (sin_m * phi.sin()) + ns * cos_m;
                    let weight = 0.25 * wv * wp * h * (PI / panels as f64) * dw_dv;
                    let (dr, dt) = integrand(m, weight);
                    r += dr;
                    tr += dt;
                }
            }
        }
    }
    (r, tr)
}

/// Directional albedo of `lobe`'s hero lane at `wo` by quadrature of `eval`:
/// (∫ f cos dωi over wo's side, ∫ f cos dωi over the other side), each direction wi
/// reached through its half vector with the Jacobian worked out here.
fn eval_albedo(lobe: &Lobe, wo: Vec3, alpha: f64, panels: usize) -> (f64, f64) {
    let n = normal();
    let front = wo.dot(n) > 0.0;
    // Normalised in f64: f32's unit vectors are 1 ± 1e-7 long, which would shift cos θm
    // by as much as 1 − cos θm is for α = 0.01.
    let ns = if front { n } else { -n }.as_dvec3().normalize();
    let wo_d = wo.as_dvec3().normalize();
    let eta = dielectric_indices(lobe, front).map(|(e, _, _)| e[0]);
    over_normals(ns, wo_d, alpha, panels, |m, dw| {
        let co = wo_d.dot(m);
        if co <= 0.0 {
            return (0.0, 0.0);
        }
        // Reflection into wo's side: dωi = 4 (wo·m) dωm.
        let wr = mirrored(wo_d, m);
        let r = match wr.dot(ns) > 0.0 {
            true => f64::from(lobe.eval(n, wo, wr.as_vec3()).0.x) * 4.0 * co * dw,
            false => 0.0,
        };
        // Refraction into the other side: dωi = (wo·m + η wi·m)² / (η² |wi·m|) dωm.
        let t = match eta.and_then(|e| refracted(wo_d, m, e).map(|wt| (e, wt))) {
            Some((e, wt)) if wt.dot(ns) < 0.0 => {
                let ci = wt.dot(m);
                let jac = (co + e * ci).powi(2) / (e * e * ci.abs());
                f64::from(lobe.eval(n, wo, wt.as_vec3()).0.x) * jac * dw
            }
            _ => 0.0,
        };
        (r, t)
    })
}

/// The single-scattering albedo of the f64 model at `wo`: (R, T) with T the fraction
/// of energy arriving along wo that is transmitted, as expectations over the normals
/// visible from wo, D_wo(m) = G₁(wo) (wo·m) D(m)/cos θo, of F·G₂/G₁ (reflection into
/// the upper side) and (1 − F)·G₂/G₁ (refraction into the lower side).
fn model_albedo(wo: Vec3, alpha: f64, eta: f64, k: f64, dielectric: bool) -> (f64, f64) {
    let n = normal();
    let ns = if wo.dot(n) > 0.0 { n } else { -n }.as_dvec3().normalize();
    let wo = wo.as_dvec3().normalize();
    let model = Model { alpha };
    let cos_o = wo.dot(ns);
    over_normals(ns, wo, alpha, 64, |m, dw| {
        let co = wo.dot(m);
        if co <= 0.0 {
            return (0.0, 0.0);
        }
        // D_wo · G₂/G₁ = (wo·m) D G₂ / cos θo.
        let weight = co * model.d(m.dot(ns)) / cos_o * dw;
        let f = fresnel(co, eta, k);
        let wr = mirrored(wo, m);
        let r = match wr.dot(ns) > 0.0 {
            true => f * model.g2(cos_o, wr.dot(ns)) * weight,
            false => 0.0,
        };
        let t = match refracted(wo, m, eta) {
            Some(wt) if dielectric && wt.dot(ns) < 0.0 => {
                (1.0 - f) * model.g2(cos_o, wt.dot(ns)) * weight
            }
            _ => 0.0,
        };
        (r, t)
    })
}

/// Mean and standard error of the hero's f/pdf over `samples` samples at `wo` (no
/// sample: 0), split into samples on wo's side and on the other.
fn sampled_albedo(lobe: &Lobe, wo: Vec3, samples: usize, seed: u64) -> [(f64, f64); 2] {
    let n = normal();
    let mut rng = Rng::new(seed, 6);
    let mut sums = [[0f64; 2]; 2];
    for _ in 0..samples {
        if let Some(s) = lobe.sample(n, wo, rng.next_f32(), rng.next_2d()) {
            let w = f64::from(s.f_cos.x / s.pdf.x);
            let side = usize::from(s.wi.dot(n) * wo.dot(n) < 0.0);
            sums[side][0] += w;
            sums[side][1] += w * w;
        }
    }
    sums.map(|[s, s2]| {
        let mean = s / samples as f64;
        let var = (s2 / samples as f64 - mean * mean).max(0.0);
        (mean, (var / samples as f64).sqrt())
    })
}

/// The perfect conductor (η = 1, k = 10⁴: Fresnel 1 to 1e-4), isotropic α.
fn perfect_conductor(alpha: f32) -> Lobe {
    Material::Conductor {
        eta: Spectrum::Constant(1.0),
        k: Spectrum::Constant(1e4),
        alpha: [alpha; 2],
        alpha_map: None,
    }
    .at(LAMBDA)
}

/// The directional albedo of a perfect rough conductor, ∫ f cos dωi, as measured by
/// the quadrature of eval (64 × 8 nodes in v, 128 × 8 in φ; the f64 model and the
/// samples agree to the printed precision):
///
/// | α \ cos θo | 0.9    | 0.5    | 0.1    | 0.03   |
/// |------------|--------|--------|--------|--------|
/// | 0.01       | 0.9999 | 0.9997 | 0.9941 | 0.9446 |
/// | 0.2        | 0.9415 | 0.8952 | 0.8913 | 0.9546 |
/// | 0.5        | 0.6840 | 0.6983 | 0.8601 | 0.9398 |
/// | 1.0        | 0.3275 | 0.4507 | 0.7602 | 0.8939 |
///
/// GGX's heavy tail (P(θm > 45°) = α²/(1 + α²)) sends much of a rough lobe below the
/// horizon even at normal incidence, so at α = 1 the loss is largest near the normal
/// (67 % at cos θo 0.9) and smaller at grazing (11 % at 0.03), where the visible facets
/// turn towards wo and G₂/G₁ → 1 (height correlation, Λ(wo) → ∞); the smooth lobe loses
/// 5.5 % at cos θo 0.03 by reaching below the horizon. A brute-force check (uniform
/// directions, the textbook D and Λ) gave the same values for α 0.2 and 1.
#[test]
fn rough_conductor_albedo_matches_samples_and_the_model() {
    let _t = Timer::start("conductor energy");
    let mut previous = [1.0; 4];
    for (i, alpha) in [0.01f32, 0.2, 0.5, 1.0].into_iter().enumerate() {
        let lobe = perfect_conductor(alpha);
        for (j, c) in [0.9, 0.5, 0.1, 0.03].into_iter().enumerate() {
            let wo = wo_at(c, 4 * i + j);
            let a = f64::from(alpha);
            let (r, t) = eval_albedo(&lobe, wo, a, 64);
            let (r_coarse, _) = eval_albedo(&lobe, wo, a, 32);
            let (model, _) = model_albedo(wo, a, 1.0, 1e4, false);
            let [(mean, se), (mean_t, _)] = sampled_albedo(&lobe, wo, 100_000, 40 + i as u64);
            let quad_err = (r - r_coarse).abs();
            let z = (mean - r) / (se * se + quad_err * quad_err).sqrt();
            println!(
                "α {alpha}, cos θo {c}: quadrature {r:.6} (coarser: {r_coarse:.6}), model {model:.6}, \
                 samples {mean:.6} ± {se:.1e} (z = {z:.2})"
            );
            assert_eq!((t, mean_t), (0.0, 0.0), "a conductor transmits");
            assert!(r <= 1.0 + 1e-5, "α {alpha}, cos {c}: albedo {r} > 1");
            assert!(
                z.abs() < Z_MAX,
                "α {alpha}, cos {c}: samples disagree, z = {z}"
            );
            assert!(
                (r - model).abs() < 1e-3,
                "α {alpha}, cos {c}: eval {r} vs model {model}"
            );
            if alpha == 0.01 && c >= 0.5 {
                assert!(r > 0.995, "α 0.01, cos {c}: albedo {r}");
            }
            // Rougher loses more (away from grazing, where a rough surface's visible
            // facets turn towards wo and a smooth one loses its lobe below the horizon).
            if c >= 0.5 {
                assert!(
                    r < previous[j],
                    "α {alpha}, cos {c}: {r} ≥ smoother {}",
                    previous[j]
                );
            }
            previous[j] = r;
            if alpha == 1.0 {
                // A substantial loss at every angle, the largest towards the normal.
                assert!(r < 0.9 && (c < 0.5 || r < 0.5), "α 1, cos {c}: keeps {r}");
            }
        }
    }
}

/// Rough glass without absorption: R + T ≤ 1 (T the transmitted fraction of energy,
/// (n_t/n_i)² ∫ f cos dωi for the radiance BTDF), eval's quadrature against the model
/// and the samples. Measured (printed): see the output.
#[test]
fn rough_dielectric_albedo_matches_samples_and_the_model() {
    let _t = Timer::start("dielectric energy");
    for (i, alpha) in [0.1f32, 0.5].into_iter().enumerate() {
        let lobe = rough_glass(Ior::Constant(1.5), 1.0, [alpha; 2]);
        for (j, c) in [0.8, 0.2, -0.9, -0.5].into_iter().enumerate() {
            let wo = wo_at(c, 4 * i + j);
            let a = f64::from(alpha);
            let (eta, _, _) = dielectric_indices(&lobe, c > 0.0).unwrap();
            let e2 = eta[0] * eta[0];
            let (r, t) = eval_albedo(&lobe, wo, a, 64);
            let (r_coarse, t_coarse) = eval_albedo(&lobe, wo, a, 32);
            let (model_r, model_t) = model_albedo(wo, a, eta[0], 0.0, true);
            let [(mr, se_r), (mt, se_t)] = sampled_albedo(&lobe, wo, 100_000, 60 + i as u64);
            println!(
                "α {alpha}, cos θo {c}: R {r:.6} (coarser {r_coarse:.6}, model {model_r:.6}, \
                 samples {mr:.6} ± {se_r:.1e}); T = η²·∫f cos {:.6} (coarser {:.6}, model \
                 {model_t:.6}, samples {:.6} ± {:.1e}); R + T = {:.6}",
                e2 * t,
                e2 * t_coarse,
                e2 * mt,
                e2 * se_t,
                r + e2 * t
            );
            assert!(r + e2 * t <= 1.0 + 1e-4, "α {alpha}, cos {c}: R + T > 1");
            assert!(model_r + model_t <= 1.0 + 1e-9);
            for (what, q, coarse, model, (m, se)) in [
                ("R", r, r_coarse, model_r, (mr, se_r)),
                ("T", e2 * t, e2 * t_coarse, model_t, (e2 * mt, e2 * se_t)),
            ] {
                let z = (m - q) / (se * se + (q - coarse).powi(2)).sqrt();
                assert!(
                    z.abs() < Z_MAX,
                    "α {alpha}, cos {c}, {what}: samples {m} vs quadrature {q}, z = {z}"
                );
                assert!(
                    (q - model).abs() < 1e-3,
                    "α {alpha}, cos {c}, {what}: eval {q} vs model {model}"
                );
            }
        }
    }
}

// ---------------------------------------------------------------------------------------
// The smooth limit.

/// The median of `angles` (degrees) and the fraction beyond `limit`. GGX's tail is
/// heavy (P(tan θm > x) = α²/(α² + x²)), so even at α = 0.002 about 0.5 % of the facet
/// normals are more than 1.5° off: the bulk, not the maximum, must be near the smooth
/// direction.
fn angle_summary(angles: &mut [f64], limit: f64) -> (f64, f64) {
    angles.sort_by(f64::total_cmp);
    let beyond = angles.iter().filter(|&&a| a > limit).count();
    (
        angles[angles.len() / 2],
        beyond as f64 / angles.len() as f64,
    )
}

#[test]
fn nearly_smooth_conductor_is_the_smooth_conductor() {
    let _t = Timer::start("smooth limit, conductor");
    let lobe = gold([0.002; 2]);
    let Lobe::Conductor(eta, k, _) = lobe else {
        unreachable!()
    };
    let n = normal();
    let mut rng = Rng::new(31, 7);
    for (i, c) in [0.9, 0.3, -0.6].into_iter().enumerate() {
        let wo = wo_at(c, i);
        let ns = (n * c.signum() as f32).as_dvec3();
        let mirror = mirrored(wo.as_dvec3(), ns);
        let samples = 20_000;
        let mut sum = Vec4::ZERO;
        let mut angles = Vec::with_capacity(samples);
        let mut none = 0;
        for _ in 0..samples {
            // No sample (weight 0): a facet from GGX's tail sent wi below the surface.
            let Some(s) = lobe.sample(n, wo, rng.next_f32(), rng.next_2d()) else {
                none += 1;
                continue;
            };
            angles.push(
                s.wi.as_dvec3()
                    .dot(mirror)
                    .clamp(-1.0, 1.0)
                    .acos()
                    .to_degrees(),
            );
            sum += s.f_cos / s.pdf;
        }
        let mean = sum / samples as f32;
        let smooth = Vec4::from_array(std::array::from_fn(|l| {
            fresnel_conductor(c.abs() as f32, eta[l], k[l])
        }));
        let (median, beyond) = angle_summary(&mut angles, 3.0);
        println!(
            "cos θo {c}: median {median:.4}° from the mirror direction, {:.3} % beyond 3°, \
             {none} without a sample; mean weight {mean} vs Fresnel {smooth}",
            100.0 * beyond
        );
        assert!(median < 0.5 && beyond < 0.01, "not a mirror");
        assert!(none < samples / 1000);
        for l in 0..4 {
            assert!(
                rel(mean[l], smooth[l]) < 0.01,
                "lane {l}: {mean} vs {smooth}"
            );
        }
    }
}

#[test]
fn nearly_smooth_dielectric_is_the_smooth_dielectric() {
    let _t = Timer::start("smooth limit, dielectric");
    let lobe = rough_glass(Ior::Constant(1.5), 1.0, [0.002; 2]);
    let n = normal();
    let mut rng = Rng::new(37, 7);
    let samples = 100_000;
    // Outside; inside below, near and beyond the critical angle (cos θc ≈ 0.745).
    for (i, c) in [0.8, 0.3, -0.9, -0.78, -0.6].into_iter().enumerate() {
        let wo = wo_at(c, i);
        let wo_d = wo.as_dvec3();
        let ns = (n * c.signum() as f32).as_dvec3();
        let (eta, _, _) = dielectric_indices(&lobe, c > 0.0).unwrap();
        let f = fresnel(c.abs(), eta[0], 0.0);
        let (mirror, through) = (mirrored(wo_d, ns), refracted(wo_d, ns, eta[0]));
        let (mut reflected, mut none) = (0usize, 0usize);
        let mut angles = Vec::with_capacity(samples);
        let mut weights = [0f64; 2];
        for _ in 0..samples {
            let Some(s) = lobe.sample(n, wo, rng.next_f32(), rng.next_2d()) else {
                none += 1;
                continue;
            };
            let wi = s.wi.as_dvec3();
            let side = usize::from(wi.dot(ns) < 0.0);
            // Beyond the critical angle only facets from GGX's tail refract: count them
            // as far off.
            let angle = match (side, through) {
                (0, _) => wi.dot(mirror).clamp(-1.0, 1.0).acos().to_degrees(),
                (_, Some(t)) => wi.dot(t).clamp(-1.0, 1.0).acos().to_degrees(),
                (_, None) => 180.0,
            };
            angles.push(angle);
            reflected += 1 - side;
            weights[side] += f64::from(s.f_cos.x / s.pdf.x);
        }
        let freq = reflected as f64 / samples as f64;
        // The binomial z (none beyond the critical angle, where F = 1).
        let z = match f < 1.0 - 1e-12 {
            true => (freq - f) / (f * (1.0 - f) / samples as f64).sqrt(),
            false => f64::NAN,
        };
        let w_r = weights[0] / reflected.max(1) as f64;
        let refracted_n = samples - reflected - none;
        let w_t = weights[1] / refracted_n.max(1) as f64;
        let (median, beyond) = angle_summary(&mut angles, 3.0);
        println!(
            "cos θo {c}: reflected {freq:.5} vs Fresnel {f:.5} (z = {z:.2}), weights {w_r:.5} and \
             {w_t:.5} (1/η² = {:.5}); median {median:.4}° from the smooth direction, {:.3} % \
             beyond 3°, {none} without a sample",
            1.0 / (eta[0] * eta[0]),
            100.0 * beyond
        );
        assert!(median < 0.5 && beyond < 0.01, "not the smooth directions");
        assert!(none < samples / 1000);
        assert!((freq - f).abs() < 0.01, "reflection frequency");
        // (Beyond the critical angle F = 1: only GGX's tail refracts, no binomial test.)
        assert!(
            z.is_nan() || z.abs() < Z_MAX,
            "reflection frequency, z = {z}"
        );
        if reflected > 0 {
            assert!((w_r - 1.0).abs() < 0.01);
        }
        if refracted_n > 0 {
            assert!((w_t * eta[0] * eta[0] - 1.0).abs() < 0.01);
        }
    }
}

// ---------------------------------------------------------------------------------------
// The test's own tools.

#[test]
fn gauss_legendre_rules_integrate_polynomials() {
    for order in 1..=24 {
        let (x, w) = gauss_legendre(order);
        assert!(x.windows(2).all(|p| p[0] < p[1]) && x[0] > -1.0 && x[order - 1] < 1.0);
        // Exact up to degree 2·order − 1: ∫₋₁¹ xᵏ dx = 2/(k + 1) for even k, else 0.
        for k in 0..2 * order + 1 {
            let q: f64 = x.iter().zip(&w).map(|(x, w)| w * x.powi(k as i32)).sum();
            let exact = if k % 2 == 0 {
                2.0 / (k as f64 + 1.0)
            } else {
                0.0
            };
            if k < 2 * order {
                assert!((q - exact).abs() < 1e-12, "order {order}, x^{k}: {q}");
            } else if order <= 8 {
                // ... and not beyond: x^(2·order) has a visible error (which falls like
                // 4^-order, so only the low orders show it above rounding).
                assert!((q - exact).abs() > 1e-8, "order {order}, x^{k}: exact?");
            }
        }
    }
    let (x, w) = gauss_legendre(2);
    assert!((x[1] - 1.0 / 3f64.sqrt()).abs() < 1e-15 && (w[0] - 1.0).abs() < 1e-15);
}

/// The renderer's closed-form conductor Fresnel against the amplitude form here (for
/// gold's lanes and a dielectric).
#[test]
fn conductor_fresnel_matches_the_amplitude_form() {
    let Lobe::Conductor(eta, k, _) = gold([0.2; 2]) else {
        unreachable!()
    };
    for l in 0..4 {
        for c in [1.0f32, 0.8, 0.5, 0.2, 0.05] {
            let (a, b) = (
                fresnel_conductor(c, eta[l], k[l]),
                fresnel(c.into(), eta[l].into(), k[l].into()),
            );
            assert!(
                (f64::from(a) - b).abs() < 1e-5,
                "lane {l}, cos {c}: {a} vs {b}"
            );
        }
    }
    assert!((fresnel(1.0, 1.5, 0.0) - 0.04).abs() < 1e-12);
    assert_eq!(fresnel(0.5, 1.0 / 1.5, 0.0), 1.0);
}
