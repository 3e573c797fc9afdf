//! Coats over conductors and rough coats (`stokes::bsdf::coated`): does the base lobe
//! sample the density it evaluates, is the layered BSDF reciprocal, and is its albedo
//! what sampling measures?
//!
//! A conductor under a coat is sampled by refracting ωo into the coat, drawing a visible
//! normal of the base there and refracting the reflection out; its pdf carries the
//! refraction's Jacobian cos θi/(η² cos θi') per lane, and a dispersive coat gives each
//! lane its own inner directions. Errors in either bias renders silently, so:
//!
//! - chi-square of the sampled directions over (cos θ, φ) cells around a tilted normal
//!   against eval's hero pdf (Gauss–Legendre per cell), from both sides, with the
//!   missing mass (reflections the coat totally reflects back) as "no sample"; every
//!   sample checked pointwise against eval (pdf and f/pdf per lane); a must-fail control
//!   (the densest half of the cells 1.1× too likely) rejected at p < 1e-6;
//! - reciprocity of the whole layered BSDF, exit factor included:
//!   (1 − R(θo))·A(θo)·f_lobe(ωo, ωi)/cos θi must be symmetric in ωo and ωi;
//! - the base lobe's albedo by quadrature of eval against the mean of f/pdf (Z-test).
//!
//! Fixed seeds; a test function's chi-square checks share a false-alarm rate of 1e-4.

mod common;
use common::assert_sample_matches_eval;
use common::directions::{direction, Binned, Grid, Mass, Region};
use common::stats::{ChiSquare, Rng};
use glam::{Vec3, Vec4};
use std::sync::{Arc, OnceLock};
use stokes::bsdf::{coated, metals, CoatBase, Coated, Ior, Lobe, Material};
use stokes::fluoro::Reradiation;
use stokes::simd::Spec;
use stokes::spectrum::{Spectrum, Tabulated, LAMBDA_MAX, LAMBDA_MIN};

const FALSE_ALARM: f64 = 1e-4;
const CONTROL_P: f64 = 1e-6;
const WRONG_BY: f64 = 1.1;
const LAMBDA: Vec4 = Vec4::new(400.0, 517.5, 635.0, 752.5);
const SAMPLES: usize = 400_000;

fn normal() -> Vec3 {
    Vec3::new(0.3, -0.5, 0.8).normalize()
}

fn wo_at(c: f64, k: usize) -> Vec3 {
    direction(normal().as_dvec3(), c, 0.7 + 1.3 * k as f64).as_vec3()
}

fn ramp(from: f32, to: f32) -> Spectrum {
    Spectrum::Tabulated(Tabulated::new(vec![LAMBDA_MIN, LAMBDA_MAX], vec![from, to]).unwrap())
}

/// A coat of index `ior`, optical depth `tau` and width `alpha` over `base`.
fn coat(ior: Ior, tau: Spectrum, alpha: f32, base: CoatBase) -> Coated {
    Coated::new(ior, tau, alpha, base)
}

fn gold(alpha: [f32; 2]) -> CoatBase {
    let (eta, k) = metals::metal("Au").unwrap();
    CoatBase::Conductor { eta, k, alpha }
}

/// The coats under test, with names.
fn coats() -> Vec<(&'static str, Coated)> {
    let dispersive = Ior::Cauchy {
        a: 1.5,
        b: 20_000.0,
    };
    vec![
        (
            "gold α 0.2 under a clear coat",
            coat(
                Ior::Constant(1.5),
                Spectrum::Constant(0.0),
                0.0,
                gold([0.2; 2]),
            ),
        ),
        (
            "gold α 0.5 under a rough absorbing coat",
            coat(Ior::Constant(1.4), ramp(0.5, 0.0), 0.3, gold([0.5; 2])),
        ),
        (
            "gold α [0.1, 0.4] under a dispersive coat",
            coat(
                dispersive.clone(),
                Spectrum::Constant(0.1),
                0.0,
                gold([0.1, 0.4]),
            ),
        ),
        (
            "ramp η/k α 0.3 under a dispersive rough coat",
            coat(
                dispersive,
                Spectrum::Constant(0.0),
                0.2,
                CoatBase::Conductor {
                    eta: ramp(0.3, 1.8),
                    k: ramp(4.0, 2.0),
                    alpha: [0.3; 2],
                },
            ),
        ),
    ]
}

fn lobe_of(c: &Coated) -> Lobe {
    Material::Coated(Arc::new(c.clone())).at(LAMBDA)
}

/// Samples `lobe` at `wo` and checks the sample against eval pointwise.
fn checked_sample(lobe: &Lobe, wo: Vec3, rng: &mut Rng) -> Option<Vec3> {
    let n = normal();
    let s = lobe.sample(n, wo, rng.next_f32(), rng.next_2d())?;
    let what = || format!("{lobe:?} at {wo}: {s:?}");
    let (f_cos, pdf) = lobe.eval(n, wo, s.wi);
    assert!(s.wi.dot(n) * wo.dot(n) > 0.0, "left wo's side: {}", what());
    assert_sample_matches_eval(&s, f_cos, pdf, &what);
    Some(s.wi)
}

fn bins() -> &'static [(String, Grid, Binned)] {
    static BINS: OnceLock<Vec<(String, Grid, Binned)>> = OnceLock::new();
    BINS.get_or_init(|| {
        let n = normal();
        let mut out = Vec::new();
        for (i, (name, c)) in coats().into_iter().enumerate() {
            let lobe = lobe_of(&c);
            for (j, cos) in [0.9, 0.4, 0.1, -0.6].into_iter().enumerate() {
                let k = 4 * i + j;
                let wo = wo_at(cos, k);
                let grid = Grid {
                    n: n.as_dvec3(),
                    n_cos: 32,
                    n_phi: 64,
                    order: 12,
                };
                let b = Binned::new(
                    &grid,
                    3000 + k as u64,
                    SAMPLES,
                    |rng| checked_sample(&lobe, wo, rng),
                    |w| f64::from(lobe.eval(n, wo, w.as_vec3()).1.x),
                    Mass::AtMostOne,
                );
                out.push((format!("{name}, cos θo = {cos}"), grid, b));
            }
        }
        out
    })
}

fn chi_squares(control: bool) -> Vec<(String, ChiSquare)> {
    let control = control.then_some((Region::DensestHalf, WRONG_BY));
    bins()
        .iter()
        .map(|(name, grid, b)| {
            let missing = b.probabilities[grid.cells()];
            (
                format!("{name} (no sample: {missing:.4})"),
                b.chi_square(grid, control),
            )
        })
        .collect()
}

#[test]
fn coated_conductors_sample_the_pdf_they_evaluate() {
    let results = chi_squares(false);
    let alpha = FALSE_ALARM / results.len() as f64;
    for (what, r) in &results {
        println!("{what}: {r}");
    }
    for (what, r) in &results {
        r.assert_accepts(alpha, what);
    }
}

#[test]
fn coated_conductor_chi_square_rejects_a_pdf_off_by_ten_percent() {
    for (what, r) in &chi_squares(true) {
        println!("control, {what}: {r}");
        r.assert_rejects(CONTROL_P, &format!("{what}, densest half × 1.1"));
    }
}

/// The whole layered BSDF's f(ωo, ωi) per lane: the exit factor the integrator applies
/// (without the branch probability) times the base lobe's f·cos θi over cos θi.
fn layered_f(c: &Coated, lobe: &Lobe, wo: Vec3, wi: Vec3) -> Vec4 {
    let n = normal();
    let (co, ci) = (wo.dot(n).abs(), wi.dot(n).abs());
    let lambda = Spec::<f32>::from(LAMBDA);
    let exit = Vec4::from(c.exit(co, &lambda, true));
    let (f_cos, _) = lobe.eval(n, wo, wi);
    exit * f_cos / ci
}

#[test]
fn coated_bsdfs_are_reciprocal() {
    let mut rng = Rng::new(11, 2);
    let lambertian = coat(
        Ior::Cauchy {
            a: 1.45,
            b: 20_000.0,
        },
        ramp(0.3, 0.0),
        0.25,
        CoatBase::Lambertian(Arc::new(Reradiation::diagonal_only(ramp(0.2, 0.9)))),
    );
    let mut all = coats();
    all.push((
        "grey base under a dispersive rough absorbing coat",
        lambertian,
    ));
    for (name, c) in all {
        let lobe = lobe_of(&c);
        let mut nonzero = 0;
        for _ in 0..20_000 {
            let (wo, wi) = (rng.unit_vector(), rng.unit_vector());
            let (a, b) = (layered_f(&c, &lobe, wo, wi), layered_f(&c, &lobe, wi, wo));
            for k in 0..4 {
                assert!(
                    (a[k] - b[k]).abs() <= 1e-3 * a[k].abs().max(b[k].abs()) + 1e-9,
                    "{name}, lane {k}: f(wo, wi) = {}, f(wi, wo) = {}, wo {wo}, wi {wi}",
                    a[k],
                    b[k]
                );
            }
            nonzero += usize::from(a.x > 1e-3);
        }
        println!("{name}: {nonzero} pairs with f > 1e-3");
        assert!(nonzero > 2000, "{name}: too few reflecting pairs");
    }
}

#[test]
fn coated_conductor_albedo_matches_its_samples() {
    let n = normal();
    for (i, (name, c)) in coats().into_iter().enumerate() {
        let lobe = lobe_of(&c);
        for (j, cos) in [0.9, 0.3].into_iter().enumerate() {
            let wo = wo_at(cos, 7 * i + j);
            // Quadrature of eval's f·cos over the hemisphere of wo (cos θi = 1 − s²).
            let (nc, nphi) = (600, 360);
            let mut quad = [0.0f64; 4];
            for a in 0..nc {
                let s = (a as f64 + 0.5) / nc as f64;
                let ci = 1.0 - s * s;
                for b in 0..nphi {
                    let phi = std::f64::consts::TAU * (b as f64 + 0.5) / nphi as f64;
                    let wi = direction(n.as_dvec3(), ci, phi).as_vec3();
                    let (f, _) = lobe.eval(n, wo, wi);
                    let w = 2.0 * s / nc as f64 * std::f64::consts::TAU / nphi as f64;
                    for k in 0..4 {
                        quad[k] += f64::from(f[k]) * w;
                    }
                }
            }
            let mut rng = Rng::new(70 + i as u64, j as u64);
            let samples = 100_000;
            let (mut sum, mut sum2) = (0.0f64, 0.0f64);
            for _ in 0..samples {
                if let Some(s) = lobe.sample(n, wo, rng.next_f32(), rng.next_2d()) {
                    let w = f64::from(s.f_cos.x / s.pdf.x);
                    sum += w;
                    sum2 += w * w;
                }
            }
            let mean = sum / samples as f64;
            let se = ((sum2 / samples as f64 - mean * mean) / samples as f64).sqrt();
            let z = (mean - quad[0]) / se.max(1e-12);
            println!(
                "{name}, cos {cos}: quadrature {:.5}, samples {mean:.5} ± {se:.1e} (z = {z:.2})",
                quad[0]
            );
            assert!(z.abs() < 5.0, "{name}, cos {cos}: z = {z}");
            // The whole layer (exit factor times the base lobe) never gains energy.
            let lambda = Spec::<f32>::from(LAMBDA);
            let exit = Vec4::from(c.exit(cos.abs() as f32, &lambda, true));
            for k in 0..4 {
                let total = f64::from(exit[k]) * quad[k];
                assert!((0.0..1.0).contains(&total), "{name}, lane {k}: {total}");
            }
        }
    }
}

/// The crossing is Fresnel at α = 0 and 1 − E (GGX's albedo) for a rough coat: it tends
/// to Fresnel as α → 0, and a rough coat passes more light at grazing incidence, where
/// its facets turn towards the light, than a smooth one.
#[test]
fn rough_crossing_tends_to_fresnel_and_passes_more_at_grazing() {
    let eta = Spec::<f32>::splat(1.5);
    let tau = Spec::<f32>::splat(0.0);
    let crossing = |c: f32, alpha: f32| coated::crossing(c, &eta, &tau, alpha)[0];
    assert!((crossing(1.0, 0.0) - 0.96).abs() < 1e-4);
    for c in [1.0f32, 0.7, 0.4, 0.15] {
        let (smooth, nearly) = (crossing(c, 0.0), crossing(c, 1e-3));
        assert!(
            (smooth - nearly).abs() < 3e-3,
            "cos {c}: {smooth} vs {nearly}"
        );
    }
    for alpha in [0.2f32, 0.5] {
        assert!(
            crossing(0.05, alpha) > crossing(0.05, 0.0) + 0.05,
            "α {alpha}"
        );
    }
}
