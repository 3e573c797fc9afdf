//! BSDF sampling (`stokes::bsdf`) against the densities the MIS weights use.
//!
//! Diffuse and fluorescent diffuse lobes: the directions `Lobe::sample` draws against the
//! pdf `Lobe::eval` reports (chi-square over (cos θ, φ) cells of equal solid angle, for
//! several incoming directions on both sides), the sampled pdf against the evaluated one
//! and f/pdf against eval's value over its pdf, pointwise. The cosine sampler against
//! `cosine_hemisphere_pdf`. Mirror and dielectric lobes are Dirac deltas: the direction
//! must be the reflection or refraction, the reflect/refract frequency must follow Fresnel
//! (chi-square, Fresnel worked out here in f64), and the weights f/pdf must be 1 and 1/η².
//!
//! Every chi-square test uses a fixed seed; a test function's checks share a false-alarm
//! rate of 1e-4 (Bonferroni). Each has a must-fail control: the same samples against an
//! expected distribution wrong by a factor 1.1 in one region (then renormalised) must be
//! rejected at p < 1e-6.

mod common;
use common::directions::{direction, direction_chi_square, Grid};
use common::stats::{chi_square, perturbed, ChiSquare, Rng};
use glam::{DVec3, Vec3, Vec4};
use std::sync::Arc;
use stokes::bsdf::{cosine_hemisphere_pdf, sample_cosine, CoatBase, Coated, Ior, Lobe, Material};
use stokes::fluoro::Reradiation;
use stokes::spectrum::{Spectrum, Tabulated, LAMBDA_MAX, LAMBDA_MIN};

/// False-alarm rate of each test function (split over its chi-square checks).
const FALSE_ALARM: f64 = 1e-4;
/// What a must-fail control must reach.
const CONTROL_P: f64 = 1e-6;
/// The factor by which a control's expected distribution is wrong in one region.
const WRONG_BY: f64 = 1.1;
/// The path's four wavelengths (nm).
const LAMBDA: Vec4 = Vec4::new(400.0, 517.5, 635.0, 752.5);

/// A tilted geometric normal (not along an axis).
fn normal() -> Vec3 {
    Vec3::new(0.3, -0.5, 0.8).normalize()
}

/// A reflectance that differs between the four lanes.
fn ramp() -> Spectrum {
    Spectrum::Tabulated(Tabulated::new(vec![LAMBDA_MIN, LAMBDA_MAX], vec![0.2, 0.9]).unwrap())
}

/// Incoming directions (towards the viewer) at these cosines to the normal; negative
/// ones arrive from below the surface.
const WO_COSINES: [f64; 5] = [0.95, 0.4, 0.05, -0.3, -0.9];

fn wo_at(c: f64, k: usize) -> Vec3 {
    direction(normal().as_dvec3(), c, 0.7 + 1.3 * k as f64).as_vec3()
}

// ---------------------------------------------------------------------------------------
// Directions: (cos θ, φ) cells of equal solid angle around the normal.

/// 16 × 32 cells, 4 × 4 Gauss–Legendre nodes per cell.
fn grid() -> Grid {
    Grid {
        n: normal().as_dvec3(),
        n_cos: 16,
        n_phi: 32,
        order: 4,
    }
}

/// Samples per chi-square test.
const SAMPLES: usize = 200_000;

/// Chi-square of directions from `sample` against `pdf` (which must integrate to 1),
/// with the expected distribution scaled by `wrong_by` where |cos θ| > 1/2 (1 for the
/// real test).
fn chi_square_of_directions(
    seed: u64,
    sample: impl FnMut(&mut Rng) -> Option<Vec3>,
    pdf: impl Fn(DVec3) -> f64,
    wrong_by: f64,
) -> ChiSquare {
    direction_chi_square(&grid(), seed, SAMPLES, sample, pdf, wrong_by)
}

fn diffuse_lobes() -> [(&'static str, Lobe); 4] {
    let fluorescent = Material::FluorescentDiffuse {
        reradiation: Arc::new(Reradiation::diagonal_only(Spectrum::Constant(0.6))),
        map: None,
    };
    // The base of a coated surface as seen through a dispersive, absorbing coat (the
    // coat's mirror branch is a mirror lobe, tested below).
    let coated = Material::Coated(Arc::new(Coated::new(
        Ior::Cauchy {
            a: 1.5,
            b: 10_000.0,
        },
        ramp(),
        0.0,
        CoatBase::Lambertian(Arc::new(Reradiation::diagonal_only(Spectrum::Constant(
            0.6,
        )))),
    )));
    // The same under a rough coat (the crossings become 1 − E of GGX).
    let rough_coated = Material::Coated(Arc::new(Coated::new(
        Ior::Cauchy {
            a: 1.5,
            b: 10_000.0,
        },
        ramp(),
        0.3,
        CoatBase::Lambertian(Arc::new(Reradiation::diagonal_only(Spectrum::Constant(
            0.6,
        )))),
    )));
    [
        (
            "diffuse",
            Material::Diffuse {
                reflectance: ramp(),
            }
            .at(LAMBDA),
        ),
        ("fluorescent diffuse", fluorescent.at(LAMBDA)),
        ("coated base", coated.at(LAMBDA)),
        ("rough-coated base", rough_coated.at(LAMBDA)),
    ]
}

fn rel(a: f32, b: f32) -> f32 {
    (a - b).abs() / b.abs().max(1e-30)
}

/// Samples `lobe` at `wo`, checking each sample against `eval` pointwise: same pdf (every
/// lane), the same f/pdf, on the side of `wo`, not specular.
fn checked_diffuse_sample(lobe: &Lobe, wo: Vec3, rng: &mut Rng) -> Option<Vec3> {
    let n = normal();
    let s = lobe.sample(n, wo, rng.next_f32(), rng.next_2d())?;
    let (f_cos, pdf) = lobe.eval(n, wo, s.wi);
    assert!(!s.specular);
    assert!((s.wi.length() - 1.0).abs() < 1e-5);
    assert!(
        s.wi.dot(n) * wo.dot(n) > 0.0,
        "{:?} left the side of {wo}",
        s.wi
    );
    for k in 0..4 {
        assert!(
            rel(s.pdf[k], pdf[k]) < 1e-5,
            "lane {k}: sampled pdf {s:?}, eval {pdf}"
        );
        let (sampled, evaluated) = (s.f_cos[k] / s.pdf[k], f_cos[k] / pdf[k]);
        assert!(
            rel(sampled, evaluated) < 1e-5,
            "lane {k}: f/pdf {sampled} vs eval {evaluated}"
        );
    }
    Some(s.wi)
}

/// One chi-square per diffuse lobe and incoming direction.
fn diffuse_chi_squares(wrong_by: f64) -> Vec<(String, ChiSquare)> {
    let n = normal();
    let mut out = Vec::new();
    for (name, lobe) in diffuse_lobes() {
        for (k, &c) in WO_COSINES.iter().enumerate() {
            let wo = wo_at(c, k);
            let r = chi_square_of_directions(
                100 + 10 * out.len() as u64,
                |rng| checked_diffuse_sample(&lobe, wo, rng),
                |w| f64::from(lobe.eval(n, wo, w.as_vec3()).1.x),
                wrong_by,
            );
            out.push((format!("{name}, cos θo = {c}"), r));
        }
    }
    out
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

#[test]
fn diffuse_lobes_sample_the_pdf_they_evaluate() {
    accept_all(&diffuse_chi_squares(1.0));
}

#[test]
fn diffuse_chi_square_rejects_a_pdf_off_by_ten_percent() {
    for (what, r) in diffuse_chi_squares(WRONG_BY) {
        println!("control, {what}: {r}");
        r.assert_rejects(CONTROL_P, &format!("{what}, |cos θ| > 1/2 × 1.1"));
    }
}

fn cosine_chi_square(wrong_by: f64) -> ChiSquare {
    let n = normal();
    chi_square_of_directions(
        7,
        |rng| Some(sample_cosine(n, rng.next_2d())),
        |w| f64::from(cosine_hemisphere_pdf(w.as_vec3().dot(n))),
        wrong_by,
    )
}

#[test]
fn cosine_sampling_follows_cosine_hemisphere_pdf() {
    let r = cosine_chi_square(1.0);
    println!("cosine sampler: {r}");
    r.assert_accepts(FALSE_ALARM, "sample_cosine against cosine_hemisphere_pdf");
    assert_eq!(cosine_hemisphere_pdf(-0.3), 0.0);
    assert!((cosine_hemisphere_pdf(1.0) - std::f32::consts::FRAC_1_PI).abs() < 1e-7);
}

#[test]
fn cosine_chi_square_rejects_a_pdf_off_by_ten_percent() {
    let r = cosine_chi_square(WRONG_BY);
    println!("control, cosine sampler: {r}");
    r.assert_rejects(CONTROL_P, "cosine sampler, |cos θ| > 1/2 × 1.1");
}

// ---------------------------------------------------------------------------------------
// Specular lobes.

/// Unpolarised Fresnel reflectance of a smooth dielectric (worked out here in f64):
/// `cos_i` on the incident side, `eta` = n_t / n_i.
fn fresnel(cos_i: f64, eta: f64) -> f64 {
    let sin2_t = (1.0 - cos_i * cos_i) / (eta * eta);
    if sin2_t >= 1.0 {
        return 1.0;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    let r_s = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    let r_p = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    0.5 * (r_s * r_s + r_p * r_p)
}

/// `wo` mirrored about the normal `ns` on its side.
fn mirrored(wo: DVec3, ns: DVec3) -> DVec3 {
    2.0 * wo.dot(ns) * ns - wo
}

/// `wo` refracted into the other side (Snell: sin θt = sin θi / η, in the plane of `wo`
/// and `ns`, azimuth turned by π).
fn refracted(wo: DVec3, ns: DVec3, eta: f64) -> DVec3 {
    let cos_i = wo.dot(ns);
    let tangent = wo - cos_i * ns;
    let sin_t = tangent.length() / eta;
    let cos_t = (1.0 - sin_t * sin_t).sqrt();
    -tangent / eta - cos_t * ns
}

#[test]
fn mirror_reflects_with_its_reflectance_as_the_weight() {
    let lobe = Material::Mirror {
        reflectance: ramp(),
    }
    .at(LAMBDA);
    let Lobe::Mirror(reflectance) = lobe else {
        panic!("{lobe:?}")
    };
    assert!(
        reflectance.x < reflectance.w,
        "{reflectance}: the lanes should differ"
    );
    let n = normal();
    let mut rng = Rng::new(5, 5);
    for _ in 0..10_000 {
        let wo = rng.unit_vector();
        let s = lobe.sample(n, wo, rng.next_f32(), rng.next_2d()).unwrap();
        let ns = n.as_dvec3() * wo.dot(n).signum() as f64;
        assert!(
            (s.wi.as_dvec3() - mirrored(wo.as_dvec3(), ns)).length() < 1e-5,
            "{s:?}"
        );
        assert!(
            s.specular && s.pdf == Vec4::ONE && s.f_cos == reflectance,
            "{s:?}"
        );
        // A delta: no density for light sampling to meet.
        assert_eq!(lobe.eval(n, wo, s.wi), (Vec4::ZERO, Vec4::ZERO));
    }
}

/// A dielectric lobe with its interior index per lane (n_in) and exterior index.
struct Dielectric {
    name: &'static str,
    lobe: Lobe,
    n_in: [f64; 4],
    ext: f64,
}

fn dielectrics() -> [Dielectric; 3] {
    let cauchy = |l: f32| 1.5 + 10_000.0 / f64::from(l * l);
    let make = |name, ior, ext_ior: f32, n_in| Dielectric {
        name,
        lobe: Material::Dielectric { ior, ext_ior }.at(LAMBDA),
        n_in,
        ext: f64::from(ext_ior),
    };
    [
        make("glass in air", Ior::Constant(1.5), 1.0, [1.5; 4]),
        make("glass in water", Ior::Constant(1.5), 1.33, [1.5; 4]),
        make(
            "dispersive glass",
            Ior::Cauchy {
                a: 1.5,
                b: 10_000.0,
            },
            1.0,
            LAMBDA.to_array().map(cauchy),
        ),
    ]
}

/// (dielectric, cos θo): outside at several angles, inside below and above the critical
/// angle (cos θc ≈ 0.745 for glass in air: −0.5 is total internal reflection).
const FRESNEL_CASES: [(usize, f64); 10] = [
    (0, 0.95),
    (0, 0.6),
    (0, 0.2),
    (0, 0.05),
    (0, -0.95),
    (0, -0.8),
    (0, -0.5),
    (1, 0.3),
    (2, 0.7),
    (2, -0.9),
];
const FRESNEL_SAMPLES: usize = 400_000;

/// Samples a dielectric at cos θo = `c` (k: which azimuth), checking every sample's
/// direction, pdf and weight; returns [reflections, refractions] and the hero's Fresnel
/// reflectance.
fn fresnel_counts(d: &Dielectric, c: f64, k: usize, seed: u64) -> ([u64; 2], f64) {
    let n = normal();
    let wo = wo_at(c, k);
    let entering = c > 0.0;
    let ns = n.as_dvec3() * c.signum();
    let eta = d
        .n_in
        .map(|ni| if entering { ni / d.ext } else { d.ext / ni });
    let cos_i = c.abs();
    let fr = eta.map(|e| fresnel(cos_i, e));
    let mut counts = [0u64; 2];
    let mut rng = Rng::new(seed, 4);
    for _ in 0..FRESNEL_SAMPLES {
        let s = d
            .lobe
            .sample(n, wo, rng.next_f32(), rng.next_2d())
            .expect("no sample");
        assert!(s.specular);
        assert_eq!(d.lobe.eval(n, wo, s.wi), (Vec4::ZERO, Vec4::ZERO));
        let what = || format!("{}, cos θo = {c}: {s:?}", d.name);
        let wi = s.wi.as_dvec3();
        if wi.dot(ns) > 0.0 {
            counts[0] += 1;
            assert!(
                (wi - mirrored(wo.as_dvec3(), ns)).length() < 1e-5,
                "{}",
                what()
            );
            for (l, &f) in fr.iter().enumerate() {
                // Every lane reflects the same way, with its own Fresnel probability.
                assert!(
                    (f64::from(s.pdf[l]) - f).abs() < 1e-5,
                    "lane {l}: {}",
                    what()
                );
                assert_eq!(s.f_cos[l], s.pdf[l], "lane {l}: weight ≠ 1: {}", what());
            }
        } else {
            counts[1] += 1;
            assert!(
                (wi - refracted(wo.as_dvec3(), ns, eta[0])).length() < 1e-5,
                "{}",
                what()
            );
            for l in 0..4 {
                if eta[l] == eta[0] {
                    assert!(
                        (f64::from(s.pdf[l]) - (1.0 - fr[l])).abs() < 1e-5,
                        "lane {l}: {}",
                        what()
                    );
                    let weight = f64::from(s.f_cos[l] / s.pdf[l]);
                    let expect = 1.0 / (eta[l] * eta[l]);
                    assert!(
                        (weight / expect - 1.0).abs() < 1e-5,
                        "lane {l}: weight {weight}: {}",
                        what()
                    );
                } else {
                    // Refracts elsewhere: leaves the lane sum.
                    assert!(s.pdf[l] == 0.0 && s.f_cos[l] == 0.0, "lane {l}: {}", what());
                }
            }
        }
    }
    (counts, fr[0])
}

/// One chi-square per Fresnel case (reflect, refract); `wrong_by` scales the reflection
/// probability (1 for the real test). Cases of total internal reflection are left out of
/// a control, where scaling the one possible outcome changes nothing.
fn fresnel_chi_squares(wrong_by: f64) -> Vec<(String, ChiSquare)> {
    let ds = dielectrics();
    let mut out = Vec::new();
    for (k, &(i, c)) in FRESNEL_CASES.iter().enumerate() {
        let (counts, f) = fresnel_counts(&ds[i], c, k, 200 + k as u64);
        if wrong_by != 1.0 && f == 1.0 {
            continue;
        }
        let p = perturbed(&[f, 1.0 - f], |cell| cell == 0, wrong_by);
        let expected: Vec<f64> = p.iter().map(|q| q * FRESNEL_SAMPLES as f64).collect();
        let what = format!("{}, cos θo = {c} (F = {f:.4})", ds[i].name);
        out.push((what, chi_square(&counts, &expected)));
    }
    out
}

#[test]
fn dielectric_chooses_reflection_with_the_fresnel_probability() {
    accept_all(&fresnel_chi_squares(1.0));
}

#[test]
fn fresnel_chi_square_rejects_a_probability_off_by_ten_percent() {
    let results = fresnel_chi_squares(WRONG_BY);
    assert_eq!(results.len(), FRESNEL_CASES.len() - 1);
    for (what, r) in results {
        println!("control, {what}: {r}");
        r.assert_rejects(CONTROL_P, &format!("{what}, reflection × 1.1"));
    }
}
