//! Participating media: the Henyey–Greenstein phase function, the three distance-tracking
//! methods (classic, maximum, fluorescence-aware), shift sampling in a fluorescent medium,
//! and a 1-D single-scattering estimate that shows classic tracking's bias.
//!
//! Every statistical test uses a fixed seed and rejects at significance 1e-3 (chi-square
//! p-value from the regularised incomplete gamma function) or at |z| ≥ 4 (Z-test); the
//! negative controls check that the same machinery rejects a wrong sampler.

mod common;
use common::stats::{chi_square, ChiSquare, Rng};
use glam::{Vec3, Vec4};
use stokes::medium::tracking::{
    fluo_aware_norm, pdf_collision_lane, prob_surface_lane, DistanceSample, Tracking,
};

/// The trackers at width 1 (one path), with the four lanes as a `Vec4`.
mod one_path {
    use glam::Vec4;
    use stokes::medium::tracking::{self, DistanceSample, Tracking};

    pub fn sample_distance(m: Tracking, st: Vec4, ss: Vec4, d: f32, u: f32) -> DistanceSample {
        tracking::sample_distance1(m, st, ss, d, u)
    }
    pub fn pdf_collision(m: Tracking, st: Vec4, ss: Vec4, d: f32, t: f32) -> Vec4 {
        tracking::pdf_collision(m, st.into(), ss.into(), d, t).into()
    }
    pub fn prob_surface(m: Tracking, st: Vec4, ss: Vec4, d: f32) -> Vec4 {
        tracking::prob_surface(m, st.into(), ss.into(), d).into()
    }
    pub fn transmittance(st: Vec4, t: f32) -> Vec4 {
        tracking::transmittance(st.into(), t).into()
    }
}
use one_path::{pdf_collision, prob_surface, sample_distance, transmittance};
use stokes::fluoro::Reradiation;
use stokes::medium::{HenyeyGreenstein, Homogeneous};
use stokes::method::Axis;
use stokes::spectrum::{Spectrum, Tabulated, LAMBDA_MAX, LAMBDA_MIN};

const ALPHA: f64 = 1e-3;
const METHODS: [Tracking; 3] = [Tracking::Classic, Tracking::Max, Tracking::FluoAware];

// ---------------------------------------------------------------------------------------
// Quadrature
// ---------------------------------------------------------------------------------------

/// Simpson's rule with `n` (even) intervals.
fn simpson(f: impl Fn(f64) -> f64, a: f64, b: f64, n: usize) -> f64 {
    let h = (b - a) / n as f64;
    let mut s = f(a) + f(b);
    for i in 1..n {
        s += f(a + i as f64 * h) * if i % 2 == 1 { 4.0 } else { 2.0 };
    }
    s * h / 3.0
}

// ---------------------------------------------------------------------------------------
// Henyey–Greenstein
// ---------------------------------------------------------------------------------------

const HG_G: [f32; 4] = [-0.7, 0.0, 0.3, 0.9];

/// A fixed, non-axis-aligned unit vector.
fn some_wo(rng: &mut Rng) -> Vec3 {
    loop {
        let v = Vec3::new(
            2.0 * rng.next_f32() - 1.0,
            2.0 * rng.next_f32() - 1.0,
            2.0 * rng.next_f32() - 1.0,
        );
        let l = v.length();
        if l > 0.1 && l <= 1.0 {
            return v / l;
        }
    }
}

#[test]
fn hg_eval_integrates_to_one() {
    for g in [-0.99f32, -0.7, 0.0, 0.3, 0.9, 0.99] {
        let p = HenyeyGreenstein::new(g);
        // 2π ∫ p(cos θ) d cos θ, with most intervals near the peak (cos = ±1).
        let f = |c: f64| p.eval(c as f32) as f64;
        let mut total = 0.0;
        let edges = [-1.0, -0.999, -0.99, -0.9, 0.0, 0.9, 0.99, 0.999, 1.0];
        for w in edges.windows(2) {
            total += simpson(f, w[0], w[1], 20_000);
        }
        total *= 2.0 * std::f64::consts::PI;
        assert!((total - 1.0).abs() < 1e-4, "g = {g}: ∫ = {total}");
    }
    let iso = HenyeyGreenstein::new(0.0).eval(0.3) as f64;
    assert!((iso * 4.0 * std::f64::consts::PI - 1.0).abs() < 1e-6);
}

/// (cos θ, φ) of `wi` around the propagation axis −`wo`, in a frame of the test's own.
fn local_angles(wo: Vec3, wi: Vec3) -> (f32, f32) {
    let axis = -wo;
    let helper = if axis.x.abs() < 0.9 { Vec3::X } else { Vec3::Y };
    let b1 = axis.cross(helper).normalize();
    let b2 = axis.cross(b1);
    let phi = wi.dot(b2).atan2(wi.dot(b1));
    let phi = if phi < 0.0 {
        phi + std::f32::consts::TAU
    } else {
        phi
    };
    (wi.dot(axis), phi)
}

/// Chi-square of HG sampling over (cos θ, φ) bins for `sampler_g` against the density of
/// `pdf_g` (equal except for the negative control).
fn hg_chi2(sampler_g: f32, pdf_g: f32, seed: u64) -> ChiSquare {
    let (n_cos, n_phi, n) = (16usize, 8usize, 200_000usize);
    let mut rng = Rng::new(seed, 1);
    let wo = some_wo(&mut rng);
    let sampler = HenyeyGreenstein::new(sampler_g);
    let reference = HenyeyGreenstein::new(pdf_g);
    let mut counts = vec![0u64; n_cos * n_phi];
    for _ in 0..n {
        let (wi, _) = sampler.sample(wo, rng.next_2d());
        let (c, phi) = local_angles(wo, wi);
        let i = (((c + 1.0) * 0.5 * n_cos as f32) as usize).min(n_cos - 1);
        let j = ((phi / std::f32::consts::TAU * n_phi as f32) as usize).min(n_phi - 1);
        counts[i * n_phi + j] += 1;
    }
    // ∫∫ pdf over a bin = (2π/n_phi) ∫ p(cos) d cos (p does not depend on φ).
    let mut expected = vec![0.0; n_cos * n_phi];
    for i in 0..n_cos {
        let a = -1.0 + 2.0 * i as f64 / n_cos as f64;
        let b = a + 2.0 / n_cos as f64;
        let mass = simpson(|c| reference.eval(c as f32) as f64, a, b, 4000)
            * (std::f64::consts::TAU / n_phi as f64);
        for j in 0..n_phi {
            expected[i * n_phi + j] = mass * n as f64;
        }
    }
    chi_square(&counts, &expected)
}

#[test]
fn hg_sampling_chi_square() {
    for (k, g) in HG_G.into_iter().enumerate() {
        let r = hg_chi2(g, g, 100 + k as u64);
        println!(
            "HG g = {g}: χ² = {:.1}, dof {}, p = {:.3}",
            r.statistic, r.dof, r.p_value
        );
        assert!(r.p_value > ALPHA, "g = {g}: {r:?}");
    }
}

#[test]
fn hg_chi_square_rejects_a_wrong_g() {
    let r = hg_chi2(0.35, 0.3, 7);
    assert!(
        r.p_value < ALPHA,
        "a sampler with g = 0.35 passed as 0.3: {r:?}"
    );
}

#[test]
fn hg_sample_pdf_matches_pdf_and_eval() {
    let mut rng = Rng::new(3, 3);
    for g in [-0.99f32, -0.7, 0.0, 0.3, 0.9, 0.99] {
        let p = HenyeyGreenstein::new(g);
        let mut worst = 0.0f32;
        for _ in 0..20_000 {
            let wo = some_wo(&mut rng);
            let (wi, pdf) = p.sample(wo, rng.next_2d());
            assert!(
                (wi.length() - 1.0).abs() < 1e-5,
                "g = {g}: |wi| = {}",
                wi.length()
            );
            let again = p.pdf(wo, wi);
            assert_eq!(again, p.eval_dirs(wo, wi));
            let from_cos = p.eval(-wo.dot(wi));
            assert!(
                (from_cos / again - 1.0).abs() < 0.05,
                "g = {g}: {from_cos} vs {again}"
            );
            worst = worst.max((pdf / again - 1.0).abs());
        }
        // The pdf from the sampled cos θ and the one from the built direction differ by the
        // rounding of wi: relative 1e-3 even on the 10⁵ sr⁻¹ peak of |g| = 0.99.
        assert!(worst < 1e-3, "g = {g}: worst relative pdf mismatch {worst}");
    }
}

#[test]
fn hg_g_is_the_mean_cosine_between_propagation_directions() {
    // E[cos θ] = g with cos θ = −wo·wi: g > 0 scatters forward.
    let mut rng = Rng::new(11, 5);
    for g in HG_G {
        let p = HenyeyGreenstein::new(g);
        let n = 100_000;
        let (mut s, mut s2) = (0.0f64, 0.0f64);
        for _ in 0..n {
            let wo = some_wo(&mut rng);
            let (wi, _) = p.sample(wo, rng.next_2d());
            let c = -wo.dot(wi) as f64;
            s += c;
            s2 += c * c;
        }
        let mean = s / n as f64;
        let se = ((s2 / n as f64 - mean * mean) / n as f64).sqrt();
        let z = (mean - g as f64) / se.max(1e-12);
        assert!(z.abs() < 4.0, "g = {g}: mean cos {mean} ± {se} (z = {z})");
    }
}

// ---------------------------------------------------------------------------------------
// Distance sampling
// ---------------------------------------------------------------------------------------

/// (σ̂_t, σ̂_s, d, label) for the hero lane.
const CASES: [(f32, f32, f32, &str); 8] = [
    (1.0, 0.5, 2.0, "ordinary"),
    (0.5, 2.0, 3.0, "σs > σt"),
    (0.0, 1.5, 1.0, "σt = 0, σs > 0"),
    (2.0, 0.0, 1.0, "σs = 0"),
    (0.0, 0.0, 1.0, "vacuum"),
    (50.0, 20.0, 2.0, "dense σt d = 100"),
    (1e-4, 5e-5, 1.0, "thin σt d = 1e-4"),
    (1e-4, 3.0, 1.0, "thin, σs ≫ σt"),
];

/// Lanes 1..3 hold unrelated values: sampling must depend on lane 0 only.
fn lanes(st: f32, ss: f32) -> (Vec4, Vec4) {
    (Vec4::new(st, 7.0, 0.0, 0.3), Vec4::new(ss, 0.0, 9.0, 0.3))
}

/// The rate of the exponential in a method's density (for placing bins).
fn decay_rate(method: Tracking, st: f32, ss: f32) -> f64 {
    match method {
        Tracking::Max => st.max(ss) as f64,
        _ => st as f64,
    }
}

/// Bin edges over [0, d): equal mass under e^{−r t} (uniform when r d is small), so dense
/// media get bins where the collisions are.
fn bin_edges(rate: f64, d: f64, k: usize) -> Vec<f64> {
    (0..=k)
        .map(|i| {
            let q = i as f64 / k as f64;
            if rate * d < 1e-3 {
                q * d
            } else {
                (-(-q * (-(-rate * d).exp_m1())).ln_1p() / rate).min(d)
            }
        })
        .collect()
}

/// ∫ pdf_collision over each bin (Simpson, fine) plus the surface probability last.
fn expected_masses(method: Tracking, st: f32, ss: f32, d: f32, edges: &[f64]) -> Vec<f64> {
    let mut m: Vec<f64> = edges
        .windows(2)
        .map(|w| {
            simpson(
                |t| pdf_collision_lane(method, st, ss, d, (t as f32).min(d.next_down())) as f64,
                w[0],
                w[1],
                256,
            )
        })
        .collect();
    m.push(prob_surface_lane(method, st, ss, d) as f64);
    m
}

/// Chi-square of `sample_distance(method, …st_sampler…)` against the density of
/// `method` with the reference coefficients.
fn distance_chi2(
    method: Tracking,
    sampler: (f32, f32),
    reference: (f32, f32),
    d: f32,
    seed: u64,
) -> ChiSquare {
    let n = 200_000usize;
    let (st, ss) = reference;
    let edges = bin_edges(decay_rate(method, st, ss), d as f64, 24);
    let k = edges.len() - 1;
    let mut counts = vec![0u64; k + 1];
    let (vt, vs) = lanes(sampler.0, sampler.1);
    let mut rng = Rng::new(seed, 17);
    for _ in 0..n {
        match sample_distance(method, vt, vs, d, rng.next_f32()) {
            DistanceSample::Collision { t } => {
                assert!(
                    (0.0..d).contains(&t),
                    "{method:?}: t = {t} outside [0, {d})"
                );
                let i = edges.partition_point(|&e| e <= t as f64).clamp(1, k) - 1;
                counts[i] += 1;
            }
            DistanceSample::Surface => counts[k] += 1,
        }
    }
    let expected: Vec<f64> = expected_masses(method, st, ss, d, &edges)
        .into_iter()
        .map(|p| p * n as f64)
        .collect();
    chi_square(&counts, &expected)
}

#[test]
fn distance_sampling_chi_square_all_methods() {
    let mut seed = 1000;
    for method in METHODS {
        for (st, ss, d, label) in CASES {
            seed += 1;
            let r = distance_chi2(method, (st, ss), (st, ss), d, seed);
            println!(
                "{:>10} {label:>18}: χ² = {:.1}, dof {}, p = {:.3}",
                method.name(),
                r.statistic,
                r.dof,
                r.p_value
            );
            assert!(r.p_value > ALPHA, "{method:?}, {label}: {r:?}");
        }
    }
}

#[test]
fn classic_tracking_never_collides_where_sigma_t_is_zero() {
    // The bias the paper fixes: all mass at the surface although σ̂_s > 0.
    let (vt, vs) = lanes(0.0, 1.5);
    for i in 0..10_000 {
        let u = i as f32 / 10_000.0;
        assert_eq!(
            sample_distance(Tracking::Classic, vt, vs, 1.0, u),
            DistanceSample::Surface
        );
    }
    assert_eq!(prob_surface_lane(Tracking::Classic, 0.0, 1.5, 1.0), 1.0);
    assert_eq!(
        pdf_collision_lane(Tracking::Classic, 0.0, 1.5, 1.0, 0.5),
        0.0
    );
    // Max and fluorescence-aware do collide there.
    assert!(prob_surface_lane(Tracking::Max, 0.0, 1.5, 1.0) < 0.25);
    assert!((prob_surface_lane(Tracking::FluoAware, 0.0, 1.5, 1.0) - 0.4).abs() < 1e-6);
}

#[test]
fn distance_chi_square_rejects_wrong_coefficients() {
    // Negative controls: a sampler with a coefficient 10% off, tested against the right
    // density, must be rejected.
    let r = distance_chi2(Tracking::Classic, (1.1, 0.5), (1.0, 0.5), 2.0, 5);
    assert!(r.p_value < ALPHA, "classic with σt × 1.1 passed: {r:?}");
    let r = distance_chi2(Tracking::FluoAware, (0.5, 2.2), (0.5, 2.0), 3.0, 6);
    assert!(r.p_value < ALPHA, "fluo-aware with σs × 1.1 passed: {r:?}");
    // Max sampled with σt instead of max(σs, σt) where σs > σt.
    let r = distance_chi2(Tracking::Max, (0.5, 0.0), (0.5, 2.0), 3.0, 8);
    assert!(r.p_value < ALPHA, "max sampled with σt passed: {r:?}");
}

#[test]
fn distance_pdfs_integrate_to_one() {
    for method in METHODS {
        for (st, ss, d, label) in CASES {
            let edges = bin_edges(decay_rate(method, st, ss), d as f64, 64);
            let total: f64 = expected_masses(method, st, ss, d, &edges).iter().sum();
            assert!(
                (total - 1.0).abs() < 1e-5,
                "{method:?}, {label}: ∫p dt + P(surface) = {total}"
            );
        }
    }
}

#[test]
fn distance_pdfs_match_the_closed_forms() {
    // Independent f64 transcriptions of the formulas in docs/design.md §3 at random t.
    let mut rng = Rng::new(21, 2);
    for (st, ss, d, label) in CASES {
        let (st64, ss64, d64) = (st as f64, ss as f64, d as f64);
        let mu = st64.max(ss64);
        let n_fa = if st64 > 0.0 {
            (-st64 * d64).exp() + ss64 * (1.0 - (-st64 * d64).exp()) / st64
        } else {
            1.0 + ss64 * d64
        };
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-5 * b.abs().max(1e-30);
        assert!(close(fluo_aware_norm(st, ss, d) as f64, n_fa), "{label}");
        let surf = [
            (-st64 * d64).exp(),
            (-mu * d64).exp(),
            (-st64 * d64).exp() / n_fa,
        ];
        for (m, want) in METHODS.into_iter().zip(surf) {
            let got = prob_surface_lane(m, st, ss, d) as f64;
            assert!(
                close(got, want),
                "{m:?}, {label}: P(surface) {got} vs {want}"
            );
        }
        for _ in 0..100 {
            let t = rng.next_f32() * d;
            let t64 = t as f64;
            let want = [
                st64 * (-st64 * t64).exp(),
                mu * (-mu * t64).exp(),
                ss64 * (-st64 * t64).exp() / n_fa,
            ];
            for (m, w) in METHODS.into_iter().zip(want) {
                let got = pdf_collision_lane(m, st, ss, d, t) as f64;
                let tol = 1e-5 * w.abs() + 1e-37;
                assert!(
                    (got - w).abs() <= tol,
                    "{m:?}, {label}, t = {t}: {got} vs {w}"
                );
            }
        }
        // Outside [0, d) there is no collision density.
        for m in METHODS {
            assert_eq!(pdf_collision_lane(m, st, ss, d, d), 0.0);
            assert_eq!(pdf_collision_lane(m, st, ss, d, -0.1), 0.0);
        }
    }
}

#[test]
fn fluo_aware_hero_weight_is_exactly_n() {
    let mut rng = Rng::new(31, 4);
    let mut checked = 0;
    for (st, ss, d, label) in CASES {
        if ss == 0.0 {
            continue; // no collisions; the surface weight is checked below
        }
        let n = fluo_aware_norm(st, ss, d);
        let (vt, vs) = lanes(st, ss);
        for _ in 0..2000 {
            let t = rng.next_f32() * d;
            let tr = transmittance(vt, t).x;
            if tr < 1e-30 {
                continue; // T and p both underflow; such t is never sampled
            }
            let w = tr * ss / pdf_collision(Tracking::FluoAware, vt, vs, d, t).x;
            assert!(
                (w / n - 1.0).abs() < 1e-5,
                "{label}, t = {t}: {w} vs N = {n}"
            );
            checked += 1;
        }
        // Sampled collisions too.
        for _ in 0..2000 {
            if let DistanceSample::Collision { t } =
                sample_distance(Tracking::FluoAware, vt, vs, d, rng.next_f32())
            {
                let w = transmittance(vt, t).x * ss
                    / pdf_collision(Tracking::FluoAware, vt, vs, d, t).x;
                assert!(
                    (w / n - 1.0).abs() < 1e-5,
                    "{label}, sampled t = {t}: {w} vs {n}"
                );
            }
        }
    }
    assert!(checked > 5000);
    for (st, ss, d, label) in CASES {
        let (vt, vs) = lanes(st, ss);
        let tr = transmittance(vt, d).x;
        if tr < 1e-30 {
            continue;
        }
        let n = fluo_aware_norm(st, ss, d);
        let w = tr / prob_surface(Tracking::FluoAware, vt, vs, d).x;
        assert!(
            (w / n - 1.0).abs() < 1e-5,
            "{label}: surface weight {w} vs N = {n}"
        );
    }
    // The σ̂_t → 0 limit and its continuity.
    assert_eq!(fluo_aware_norm(0.0, 1.5, 2.0), 4.0);
    assert!((fluo_aware_norm(1e-7, 1.5, 2.0) / 4.0 - 1.0).abs() < 1e-6);
}

#[test]
fn slab_transmittance_and_classic_pass_rate() {
    let vt = Vec4::new(0.7, 0.0, 100.0, 1e-4);
    let d = 1.3f32;
    let tr = transmittance(vt, d);
    for k in 0..4 {
        let want = (-(vt[k] as f64) * d as f64).exp();
        assert!(
            (tr[k] as f64 - want).abs() <= 1e-6 * want + 1e-45,
            "lane {k}: {} vs {want}",
            tr[k]
        );
    }
    // Under classic tracking the probability of passing the slab is its transmittance.
    let mut rng = Rng::new(41, 6);
    for (st, ss) in [(0.7f32, 0.3f32), (0.7, 5.0), (2.0, 0.0)] {
        let (vt, vs) = lanes(st, ss);
        let n = 200_000;
        let passed = (0..n)
            .filter(|_| {
                sample_distance(Tracking::Classic, vt, vs, d, rng.next_f32())
                    == DistanceSample::Surface
            })
            .count();
        let p = (-(st as f64) * d as f64).exp();
        let z = (passed as f64 / n as f64 - p) / (p * (1.0 - p) / n as f64).sqrt();
        assert!(
            z.abs() < 4.0,
            "σt = {st}: passed {passed}/{n}, e^(−σt d) = {p}, z = {z}"
        );
        let ps = prob_surface(Tracking::Classic, vt, vs, d).x as f64;
        assert!((ps - p).abs() < 1e-6);
    }
}

/// The bound on lane k's own hero weight (value_k / p_k) that the module docs state:
/// classic max(1, σs/σt) (1 when σt = 0: only the surface is reached), max
/// e^{(σs−σt)⁺ d}, fluorescence-aware N ≤ min(max(1, σs/σt), 1 + σs d).
fn weight_bound(method: Tracking, st: f32, ss: f32, d: f32) -> f64 {
    let (st, ss, d) = (st as f64, ss as f64, d as f64);
    match method {
        Tracking::Classic if st > 0.0 => (ss / st).max(1.0),
        Tracking::Classic => 1.0,
        Tracking::Max => ((ss - st).max(0.0) * d).exp(),
        Tracking::FluoAware => {
            let cap = if st > 0.0 {
                (ss / st).max(1.0)
            } else {
                f64::INFINITY
            };
            cap.min(1.0 + ss * d)
        }
    }
}

#[test]
fn extreme_media_stay_finite_and_bounded_for_every_lane() {
    // Lanes: σ̂_t = 0 < σ̂_s, σ̂_s > σ̂_t, dense (σ̂_t d = 100), thin (σ̂_t d = 1e-4), σ̂_s = 0,
    // vacuum. Every lane is hero in turn; for every event and lane k the balance-heuristic
    // weight value_k / Σ_j p_j (value = T σ̂_s at a collision, T at the surface) must be
    // finite and at most lane k's own bound (`weight_bound`), except classic lanes with
    // σ̂_t = 0 < σ̂_s, which cannot sample the event (p_k = 0, the documented bias) and are
    // only required to be finite.
    let sets = [
        (
            Vec4::new(0.0, 0.5, 100.0, 1e-4),
            Vec4::new(1.5, 2.0, 30.0, 5e-5),
        ),
        (
            Vec4::new(2.0, 0.0, 1e-4, 100.0),
            Vec4::new(0.0, 0.0, 3.0, 150.0),
        ),
    ];
    let d = 1.0f32;
    let rot = |v: Vec4, r: usize| Vec4::from_array(std::array::from_fn(|k| v[(k + r) % 4]));
    let mut us: Vec<f32> = (0..4096).map(|i| (i as f32 + 0.5) / 4096.0).collect();
    us.extend([0.0, 1e-7, 1e-4, 1.0 - f32::EPSILON / 2.0]);
    let mut max_seen = [0.0f64; 3];
    for method in METHODS {
        for (st0, ss0) in sets {
            for r in 0..4 {
                let (st, ss) = (rot(st0, r), rot(ss0, r));
                for &u in &us {
                    let (value, pdf) = match sample_distance(method, st, ss, d, u) {
                        DistanceSample::Collision { t } => {
                            assert!(t.is_finite() && (0.0..d).contains(&t), "{method:?} t = {t}");
                            (
                                transmittance(st, t) * ss,
                                pdf_collision(method, st, ss, d, t),
                            )
                        }
                        DistanceSample::Surface => {
                            let p = prob_surface(method, st, ss, d);
                            assert!(p.cmple(Vec4::ONE).all(), "{method:?}: P = {p}");
                            (transmittance(st, d), p)
                        }
                    };
                    assert!(
                        value.is_finite() && pdf.is_finite(),
                        "{method:?}: {value} {pdf}"
                    );
                    assert!(value.cmpge(Vec4::ZERO).all() && pdf.cmpge(Vec4::ZERO).all());
                    assert!(
                        pdf.x > 0.0,
                        "{method:?}: the hero's event has pdf 0 ({st}, {ss}, u = {u})"
                    );
                    let sum = pdf.element_sum() as f64;
                    for k in 0..4 {
                        let w = value[k] as f64 / sum;
                        assert!(w.is_finite(), "{method:?} lane {k}: weight {w}");
                        let unsampleable =
                            method == Tracking::Classic && st[k] == 0.0 && ss[k] > 0.0;
                        if !unsampleable {
                            let b = weight_bound(method, st[k], ss[k], d);
                            assert!(
                                w <= b * (1.0 + 1e-4),
                                "{method:?} lane {k} (σt {}, σs {}): weight {w} > bound {b}",
                                st[k],
                                ss[k]
                            );
                            let mi = METHODS.iter().position(|&m| m == method).unwrap();
                            max_seen[mi] = max_seen[mi].max(w);
                        }
                    }
                }
            }
        }
    }
    // The largest weights seen stay far from f32 overflow (max: e^{50} for σs − σt = 50).
    println!("largest bounded weights (classic, max, fluo-aware): {max_seen:?}");
    assert!(max_seen.iter().all(|&w| w < 1e30), "{max_seen:?}");
}

// ---------------------------------------------------------------------------------------
// Fluorescent medium: shift sampling and the single-scattering estimate
// ---------------------------------------------------------------------------------------

/// A box [a, b] of height v with 1e-3 nm ramps outside it (the tabulated curve is linear
/// between samples and zero beyond them).
fn box_spectrum(a: f32, b: f32, v: f32) -> Spectrum {
    Spectrum::Tabulated(
        Tabulated::new(vec![a - 1e-3, a, b, b + 1e-3], vec![0.0, v, v, 0.0]).unwrap(),
    )
}

/// σ_a 0.05, σ_s 0.3, a dye absorbing 420–520 nm with coefficient 4 (above 1, so the
/// scaling around `Reradiation::from_dye` is exercised), emitting a triangle 480–640 nm.
fn dyed_medium() -> Homogeneous {
    let emission = Spectrum::Tabulated(
        Tabulated::new(vec![480.0, 550.0, 640.0], vec![0.0, 1.0, 0.0]).unwrap(),
    );
    Homogeneous::new(
        Spectrum::Constant(0.05),
        Spectrum::Constant(0.3),
        HenyeyGreenstein::new(0.2),
    )
    .with_dye(&box_spectrum(420.0, 520.0, 4.0), &emission, 0.7, 10.0)
    .unwrap()
}

#[test]
fn medium_coefficients_follow_the_dye_convention() {
    let m = dyed_medium();
    assert!(m.is_fluorescent());
    assert_eq!(m.quantum_yield(), Some(0.7));
    let mut l = LAMBDA_MIN + 5.0;
    while l < LAMBDA_MAX {
        let v = Vec4::splat(l);
        let dye = if (420.0..=520.0).contains(&l) {
            4.0
        } else {
            0.0
        };
        // σ̂_t = σ_a + σ_s + σ_dye: all of the dye's absorption is extinction.
        assert!((m.sigma_t_hat(v).x - (0.35 + dye)).abs() < 1e-5, "{l}");
        // σ_sa = Φ σ_dye at the cell centre where emission lies above, else 0.
        let sa = m.sigma_sa(v).x;
        assert!((sa - 0.7 * dye).abs() < 1e-4, "σ_sa({l}) = {sa}");
        assert!((m.sigma_s_hat(v).x - (0.3 + m.sigma_se(v).x)).abs() < 1e-6);
        l += 10.0;
    }
    // Energy: everything shifted out of some λ arrives at another, ∫σ_sa = ∫σ_se.
    let (mut out, mut into) = (0.0f64, 0.0f64);
    let mut l = LAMBDA_MIN + 0.05;
    while l < LAMBDA_MAX {
        let v = Vec4::splat(l);
        out += m.sigma_sa(v).x as f64 * 0.1;
        into += m.sigma_se(v).x as f64 * 0.1;
        l += 0.1;
    }
    assert!((out - 0.7 * 4.0 * 100.0).abs() < 0.5, "∫σ_sa = {out}");
    assert!(
        (out / into - 1.0).abs() < 1e-3,
        "∫σ_sa = {out}, ∫σ_se = {into}"
    );
    // No dye below 420 nm or in the emission tail: an ordinary medium there.
    let s = m.sample_shift(700.0, 0.99, 0.5).unwrap();
    assert!(s.kept && s.pdf == 1.0 && (s.value - 0.3).abs() < 1e-6);
}

#[test]
fn medium_shift_sampling_chi_square_and_weight() {
    shift_sampling_chi_square(&dyed_medium(), 0.3, 10.0, &[495.0, 533.0, 600.0, 635.0], 51);
}

/// Chi-square of `m`'s shift sampling at each output wavelength in `lambdas` against its
/// `shift_pdf` on `cell`-nm bins (F is constant on them), plus the kept bin; every sample's
/// value/pdf must be σ̂_s and agree with `shift_pdf` and `shift_value`. `sigma_s` is the
/// medium's elastic scattering (the kept probability is σ_s/σ̂_s).
fn shift_sampling_chi_square(m: &Homogeneous, sigma_s: f32, cell: f32, lambdas: &[f32], seed: u64) {
    let cells = ((LAMBDA_MAX - LAMBDA_MIN) / cell).ceil() as usize;
    let mut rng = Rng::new(seed, 8);
    for (idx, &lambda_o) in lambdas.iter().enumerate() {
        let ss_hat = m.sigma_s_hat(Vec4::splat(lambda_o)).x;
        assert!(ss_hat > sigma_s, "σ̂_s({lambda_o}) = {ss_hat}");
        let n = 200_000usize;
        // Bin 0: kept; bin 1 + c: shifted into cell c.
        let mut counts = vec![0u64; cells + 1];
        for _ in 0..n {
            let s = m
                .sample_shift(lambda_o, rng.next_f32(), rng.next_f32())
                .unwrap();
            assert!((s.value / s.pdf / ss_hat - 1.0).abs() < 1e-5, "{s:?}");
            assert_eq!(s.pdf, m.shift_pdf(s.lambda_i, lambda_o, s.kept));
            assert_eq!(s.value, m.shift_value(s.lambda_i, lambda_o, s.kept));
            if s.kept {
                assert_eq!(s.lambda_i, lambda_o);
                counts[0] += 1;
            } else {
                assert!(s.lambda_i < lambda_o && s.lambda_i >= LAMBDA_MIN);
                let c = ((s.lambda_i - LAMBDA_MIN) / cell) as usize;
                counts[1 + c.min(cells - 1)] += 1;
            }
        }
        let mut expected = vec![0.0f64; cells + 1];
        expected[0] = m.shift_pdf(lambda_o, lambda_o, true) as f64;
        for c in 0..cells {
            let a = LAMBDA_MIN + c as f32 * cell;
            let b = (a + cell).min(LAMBDA_MAX);
            // Midpoints of 20 sub-intervals (the pdf is constant on a cell).
            let h = (b - a) / 20.0;
            expected[1 + c] = (0..20)
                .map(|j| m.shift_pdf(a + (j as f32 + 0.5) * h, lambda_o, false) as f64 * h as f64)
                .sum();
        }
        let total: f64 = expected.iter().sum();
        assert!(
            (total - 1.0).abs() < 1e-5,
            "λo {lambda_o}: total mass {total}"
        );
        // Kept with probability σ_s/σ̂_s.
        assert!((expected[0] - sigma_s as f64 / ss_hat as f64).abs() < 1e-6);
        let expected: Vec<f64> = expected.iter().map(|p| p * n as f64).collect();
        let r = chi_square(&counts, &expected);
        println!(
            "shift λo = {lambda_o}: χ² = {:.1}, dof {}, p = {:.3}",
            r.statistic, r.dof, r.p_value
        );
        assert!(r.p_value > ALPHA, "λo {lambda_o} (case {idx}): {r:?}");
    }
}

/// The 1-D slab of the single-scattering test: exclusively fluorescent (σ_a = σ_s = 0),
/// dye coefficient 2 on 440–540 nm, emission flat on 500–650 nm, Φ = 0.8.
fn fluorescent_slab() -> Homogeneous {
    Homogeneous::new(
        Spectrum::Constant(0.0),
        Spectrum::Constant(0.0),
        HenyeyGreenstein::isotropic(),
    )
    .with_dye(
        &box_spectrum(440.0, 540.0, 2.0),
        &box_spectrum(500.0, 650.0, 1.0),
        0.8,
        10.0,
    )
    .unwrap()
}

const SLAB_D: f32 = 1.0;
const DETECTOR: (f32, f32) = (500.0, 650.0);

/// One sample of the detector's single-scattering estimate (hero lane only, 1-D: the
/// phase function is taken as 1). A white beam (L = 1 at every λ) enters the slab at x = 0
/// going +x; the detector at x = 0 looks +x and measures the mean over λo ∈ [500, 650) nm
/// (λo drawn uniformly). At a collision at t: weight T(λo, t)/p(t), a shift sample
/// (value/pdf = σ̂_s(λo)), then the beam's radiance at λi after a depth t,
/// e^{−σ̂_t(λi) t}. The slab's back face is black: the surface contributes 0.
fn slab_sample(m: &Homogeneous, method: Tracking, rng: &mut Rng) -> f64 {
    let lambda_o = DETECTOR.0 + (DETECTOR.1 - DETECTOR.0) * rng.next_f32();
    let l = Vec4::new(lambda_o, 0.0, 0.0, 0.0);
    let (st, ss) = (m.sigma_t_hat(l), m.sigma_s_hat(l));
    let t = match sample_distance(method, st, ss, SLAB_D, rng.next_f32()) {
        DistanceSample::Surface => return 0.0,
        DistanceSample::Collision { t } => t,
    };
    let pdf = pdf_collision(method, st, ss, SLAB_D, t).x;
    let mut w = transmittance(st, t).x / pdf;
    let Some(s) = m.sample_shift(lambda_o, rng.next_f32(), rng.next_f32()) else {
        return 0.0;
    };
    w *= s.value / s.pdf;
    let beam = transmittance(m.sigma_t_hat(Vec4::splat(s.lambda_i)), t).x;
    (w * beam) as f64
}

/// 1-D quadrature of the same quantity:
/// (1/150) ∫dλo ∫₀ᵈ dt e^{−σ̂_t(λo) t} ∫dλi F(λi, λo) e^{−σ̂_t(λi) t},
/// on 1-nm midpoints in λ (F and σ̂_t are constant on the 10-nm cells) with the t-integral
/// in closed form.
fn slab_reference(m: &Homogeneous) -> f64 {
    let d = SLAB_D as f64;
    let mut sum = 0.0;
    let mut lo = DETECTOR.0 + 0.5;
    while lo < DETECTOR.1 {
        let st_o = m.sigma_t_hat(Vec4::splat(lo)).x as f64;
        let mut li = LAMBDA_MIN + 0.5;
        while li < lo {
            let f = m.shift_value(li, lo, false) as f64;
            if f > 0.0 {
                let a = st_o + m.sigma_t_hat(Vec4::splat(li)).x as f64;
                let t_int = if a > 0.0 { -(-a * d).exp_m1() / a } else { d };
                sum += f * t_int; // × 1 nm (λi) × 1 nm (λo)
            }
            li += 1.0;
        }
        lo += 1.0;
    }
    sum / (DETECTOR.1 - DETECTOR.0) as f64
}

#[test]
fn single_scattering_in_a_fluorescent_slab_exposes_classic_bias() {
    let m = fluorescent_slab();
    // Above 540 nm the slab emits but does not absorb: σ̂_t = 0 < σ̂_s.
    let v = Vec4::new(560.0, 600.0, 520.0, 450.0);
    let (st, ss) = (m.sigma_t_hat(v), m.sigma_s_hat(v));
    assert!(
        st.x == 0.0 && st.y == 0.0 && ss.x > 0.0 && ss.y > 0.0,
        "{st} {ss}"
    );
    trackers_against_slab_quadrature(&m, 61);
}

/// The slab's detector estimate with every tracker against [`slab_reference`]: classic
/// tracking biased low (z < −5), maximum and fluorescence-aware within |z| < 4.
fn trackers_against_slab_quadrature(m: &Homogeneous, seed: u64) {
    let m = m.clone();
    let reference = slab_reference(&m);
    assert!(reference > 0.0);
    let n = 400_000;
    let mut report = String::new();
    let mut z_of = [0.0f64; 3];
    for (i, method) in METHODS.into_iter().enumerate() {
        let mut rng = Rng::new(seed + i as u64, 10);
        let (mut s, mut s2) = (0.0f64, 0.0f64);
        for _ in 0..n {
            let x = slab_sample(&m, method, &mut rng);
            assert!(x.is_finite() && x >= 0.0);
            s += x;
            s2 += x * x;
        }
        let mean = s / n as f64;
        let se = ((s2 / n as f64 - mean * mean).max(0.0) / n as f64).sqrt();
        let z = (mean - reference) / se;
        z_of[i] = z;
        report += &format!(
            "{:>10}: mean {mean:.6} ± {se:.6} (reference {reference:.6}), z = {z:.1}\n",
            method.name()
        );
    }
    println!("{report}");
    assert!(
        z_of[0] < -5.0,
        "classic tracking should be biased low:\n{report}"
    );
    assert!(z_of[1].abs() < 4.0, "max tracking disagrees:\n{report}");
    assert!(
        z_of[2].abs() < 4.0,
        "fluorescence-aware tracking disagrees:\n{report}"
    );
}

// ---------------------------------------------------------------------------------------
// A medium with a general re-radiation matrix (the EGSR 2018 paper's tent-min form)
// ---------------------------------------------------------------------------------------

/// M(λi → λo) = d₀·min(tent(λi; 460, 40), tent(λo; 560, 40)) for λo > λi on 5-nm cells
/// with centres at 362.5, 367.5, … (edges on whole nm, where the quadrature's 1-nm
/// midpoints cannot straddle them), as a CSV the way a scene file names it; d₀ = 0.25 per
/// cell makes the peak row sum σ_sa(460) = 2 per unit at scale 1.
fn tent_min_csv() -> String {
    let tent = |l: f64, c: f64, w: f64| (1.0 - (l - c).abs() / w).max(0.0);
    let centres: Vec<f64> = (0..94).map(|k| 362.5 + 5.0 * k as f64).collect();
    let mut out = String::from("nm");
    for c in &centres {
        out += &format!(",{c}");
    }
    out.push('\n');
    for &li in &centres {
        out += &format!("{li}");
        for &lo in &centres {
            let m = if lo > li {
                0.25 * tent(li, 460.0, 40.0).min(tent(lo, 560.0, 40.0))
            } else {
                0.0
            };
            out += &format!(",{m}");
        }
        out.push('\n');
    }
    out
}

/// An exclusively fluorescent medium re-radiating with [`tent_min_csv`] at `scale`, over
/// elastic scattering `sigma_s`.
fn tent_min_medium(scale: f32, sigma_s: f32) -> Homogeneous {
    let (rr, report) = Reradiation::from_csv_str(&tent_min_csv(), "tent-min").unwrap();
    assert!(report.is_clean(), "{report}");
    Homogeneous::new(
        Spectrum::Constant(0.0),
        Spectrum::Constant(sigma_s),
        HenyeyGreenstein::isotropic(),
    )
    .with_matrix(rr, scale)
    .unwrap()
}

#[test]
fn matrix_medium_extinction_is_its_row_sum_and_scattering_its_column_sum() {
    let tent = |l: f64, c: f64, w: f64| (1.0 - (l - c).abs() / w).max(0.0);
    let scale = 1.5f32;
    let m = tent_min_medium(scale, 0.1);
    assert!(m.is_fluorescent());
    assert_eq!(m.quantum_yield(), None);
    let mut l = LAMBDA_MIN + 0.7;
    while l < LAMBDA_MAX {
        // The cell's centre and the brute-force sums over the other cells' centres.
        let c = 362.5 + 5.0 * ((l as f64 - 360.0) / 5.0).floor();
        let (mut row, mut column) = (0.0f64, 0.0f64);
        for k in 0..94 {
            let o = 362.5 + 5.0 * k as f64;
            if o > c {
                row += 0.25 * tent(c, 460.0, 40.0).min(tent(o, 560.0, 40.0));
            }
            if o < c {
                column += 0.25 * tent(o, 460.0, 40.0).min(tent(c, 560.0, 40.0));
            }
        }
        let v = Vec4::splat(l);
        let st = m.sigma_t_hat(v).x as f64;
        let ss = m.sigma_s_hat(v).x as f64;
        // σ̂_t = σ_s + scale·σ_sa; σ̂_s = σ_s + scale·σ_se.
        assert!(
            (st - 0.1 - 1.5 * row).abs() < 1e-5,
            "σ̂_t({l}) = {st}, row {row}"
        );
        assert!(
            (ss - 0.1 - 1.5 * column).abs() < 1e-5,
            "σ̂_s({l}) = {ss}, column {column}"
        );
        l += 1.3;
    }
    // The peak: σ_sa(460) = 0.25 × Σ tent_e = 0.25 × 8 = 2 per unit, × scale.
    let peak = m.sigma_sa(Vec4::splat(461.0)).x;
    assert!((peak - 2.0 * scale).abs() < 1e-5, "{peak}");
    // Transparent outside the absorption band (classic tracking's blind spot).
    assert_eq!(m.sigma_t_hat(Vec4::splat(560.0)).x, 0.1);
}

#[test]
fn matrix_medium_shift_sampling_chi_square() {
    shift_sampling_chi_square(
        &tent_min_medium(1.5, 0.1),
        0.1,
        5.0,
        &[521.0, 548.0, 560.0, 597.0],
        71,
    );
}

#[test]
fn matrix_medium_single_scattering_matches_quadrature_and_classic_is_biased() {
    let m = tent_min_medium(1.0, 0.0);
    trackers_against_slab_quadrature(&m, 81);
}

#[test]
fn matrix_medium_rejects_a_bad_scale_and_a_matrix_that_shifts_nothing() {
    let (rr, _) = Reradiation::from_csv_str(&tent_min_csv(), "tent-min").unwrap();
    let plain = || Homogeneous::from_albedo(0.5, 1.0, HenyeyGreenstein::isotropic());
    for bad in [0.0, -1.0, f32::NAN, f32::INFINITY] {
        assert!(plain().with_matrix(rr.clone(), bad).is_err(), "{bad}");
    }
    let diagonal = "nm,400,410\n400,0.5,0\n410,0,0.5\n";
    let (flat, _) = Reradiation::from_csv_str(diagonal, "diagonal").unwrap();
    let e = plain().with_matrix(flat, 1.0).unwrap_err().to_string();
    assert!(e.contains("shifts no light"), "{e}");
}
