//! Distance sampling on a camera-path segment through a homogeneous medium.
//!
//! A segment runs from the current vertex to the next surface at a finite distance d
//! (d = 0 is allowed and always reaches the surface). A sampler returns either a
//! collision at t ∈ [0, d) (a density p(t), per unit length) or "reached the surface"
//! (a probability P(surface)); the estimator then weighs a collision with
//! T(t)·σ̂_s / p(t) (the σ̂_s factor enters through the shift sample, whose value over pdf is
//! σ̂_s) and the surface with T(d) / P(surface), T(t) = e^{−σ̂_t t}.
//!
//! `sigma_t` and `sigma_s` are the camera-path coefficients σ̂_t, σ̂_s of docs/design.md §3, in
//! 1/scene-unit, one per lane; negative or NaN values count as 0. The hero (lane 0) drives
//! sampling; [`pdf_collision`] and [`prob_surface`] give, per lane k, the density or
//! probability with which lane k *as hero* would have produced the same event, for the
//! balance heuristic over the lanes.
//!
//! # The three methods and where they fail
//! | method | p(t), t < d | P(surface) | hero weight (collision / surface) |
//! | --- | --- | --- | --- |
//! | [`Tracking::Classic`] | σ̂_t e^{−σ̂_t t} | e^{−σ̂_t d} | σ̂_s/σ̂_t / 1 |
//! | [`Tracking::Max`] | μ e^{−μ t}, μ = max(σ̂_s, σ̂_t) | e^{−μ d} | (σ̂_s/μ) e^{(μ−σ̂_t)t} / e^{(μ−σ̂_t)d} |
//! | [`Tracking::FluoAware`] | σ̂_s e^{−σ̂_t t} / N | e^{−σ̂_t d} / N | N / N |
//!
//! with N = [`fluo_aware_norm`] = e^{−σ̂_t d} + σ̂_s (1 − e^{−σ̂_t d})/σ̂_t (→ 1 + σ̂_s d as
//! σ̂_t → 0).
//!
//! - **Classic** cannot sample a collision where σ̂_t = 0 although σ̂_s > 0 (an exclusively
//!   fluorescent medium at a wavelength it emits but does not absorb): the in-shifted light
//!   is never collected, a bias, not noise. Where σ̂_t > 0 it is unbiased but its weight
//!   σ̂_s/σ̂_t is unbounded as σ̂_t → 0. Under the balance heuristic a lane with σ̂_t = 0 < σ̂_s
//!   has pdf 0 and its light only arrives through the other lanes' techniques.
//! - **Max** samples a collision wherever σ̂_s > 0 or σ̂_t > 0 (μ > 0), so it is unbiased;
//!   its weights are bounded by e^{(σ̂_s−σ̂_t)⁺ d}, which grows exponentially with the
//!   segment length where σ̂_s > σ̂_t.
//! - **Fluorescence-aware** (Mojzík et al. 2018) samples a collision wherever σ̂_s > 0 and
//!   never where σ̂_s = 0 (nothing to collect there: the collision would have weight 0). Its
//!   hero weight is the constant N ≤ min(max(1, σ̂_s/σ̂_t), 1 + σ̂_s d) for both outcomes
//!   (N is a convex combination of 1 and σ̂_s/σ̂_t).
//!
//! In every method lane k's balance-heuristic weight value_k / Σ_j p_j is at most its own
//! hero weight value_k / p_k whenever p_k > 0, so the bounds above hold for every lane
//! (Max and fluorescence-aware have p_k > 0 wherever value_k > 0).
//!
//! # Numerics
//! 1 − e^{−x} is computed with `exp_m1` and its inverse with `ln_1p` (the polynomials of
//! [`crate::simd::math`], the same bits at every lane width); the integral
//! (1 − e^{−σ d})/σ switches to its series below σd = 10⁻⁵ (so σ̂_t = 0 is exact). Dense
//! (σ̂_t d = 100) and thin (σ̂_t d = 10⁻⁴) segments give finite results; a sampled
//! collision always lies in [0, d).

use crate::simd::{math, Float, Spec};
use glam::Vec4;

/// A distance-sampling strategy. Its names (`classic`, `max`, `fluo-aware`) and the
/// scene-dependent default are in [`crate::method`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Tracking {
    /// Exponential in σ̂_t: biased where σ̂_t = 0 < σ̂_s.
    Classic,
    /// Exponential in max(σ̂_s, σ̂_t): unbiased, weights up to e^{(σ̂_s−σ̂_t)d}.
    Max,
    /// The paper's σ̂_s e^{−σ̂_t t}/N: unbiased, hero weight exactly N.
    FluoAware,
}

/// The outcome of distance sampling on a segment (one path; see [`sample_distance`] for
/// W paths at once).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum DistanceSample {
    /// A real collision at distance `t` ∈ [0, d).
    Collision { t: f32 },
    /// The segment's end (the next surface) is reached.
    Surface,
}

/// A coefficient as used here: negative and NaN count as 0.
#[inline(always)]
fn coeff<F: Float>(x: F) -> F {
    x.nonneg()
}

/// ∫₀ᵗ e^{−σ s} ds = (1 − e^{−σ t})/σ, → t as σt → 0 (exact at σ = 0).
#[inline(always)]
fn integral_exp<F: Float>(sigma: F, t: F) -> F {
    let tau = sigma * t;
    let series = t * (F::splat(1.0) - F::splat(0.5) * tau);
    F::select(tau.lt(F::splat(1e-5)), series, -math::exp_m1(-tau) / sigma)
}

/// The fluorescence-aware normalisation N = e^{−σ̂_t d} + σ̂_s ∫₀ᵈ e^{−σ̂_t s} ds: the hero's
/// weight for both outcomes.
#[inline(always)]
pub fn fluo_aware_norm<F: Float>(sigma_t: F, sigma_s: F, d: F) -> F {
    let (st, ss, d) = (coeff(sigma_t), coeff(sigma_s), d.max(F::splat(0.0)));
    math::exp(-st * d) + ss * integral_exp(st, d)
}

/// Exponential sampling with rate `mu` on [0, d): which paths collide, and where.
#[inline(always)]
fn sample_exponential<F: Float>(mu: F, d: F, u: F) -> (F::Mask, F) {
    let zero = F::splat(0.0);
    let ok = mu.gt(zero) & d.gt(zero);
    let t = -math::ln_1p(-u) / mu;
    (ok & t.lt(d), t)
}

/// The paper's density σ̂_s e^{−σ̂_t t}/N on [0, d), surface with probability e^{−σ̂_t d}/N.
#[inline(always)]
fn sample_fluo_aware<F: Float>(st: F, ss: F, d: F, u: F) -> (F::Mask, F) {
    let (zero, one) = (F::splat(0.0), F::splat(1.0));
    let ok = ss.gt(zero) & d.gt(zero);
    let collide = ss * integral_exp(st, d);
    let x = u * (math::exp(-st * d) + collide);
    // Written so that a NaN falls through to the surface.
    let hit = ok & x.lt(collide);
    // g = ∫₀ᵗ e^{−σ̂_t s} ds, y = σ̂_t g = 1 − e^{−σ̂_t t} ∈ [0, 1).
    let g = x / ss;
    let y = (st * g).min(one);
    let series = g * (one + y * (F::splat(0.5) + y * F::splat(1.0 / 3.0)));
    let t = F::select(y.lt(F::splat(1e-5)), series, -math::ln_1p(-y) / st);
    // Rounding may push t to d or beyond (or to ∞ when y rounds to 1): the event was a
    // collision, so keep it inside the segment (d·(1 − 2⁻²⁴) is the float below d).
    let below_d = d * F::splat(1.0 - f32::EPSILON / 2.0);
    (hit, t.max(zero).min(below_d))
}

/// Samples the distance to the next collision on a segment of length `d` with the hero's
/// coefficients `sigma_t`, `sigma_s` (σ̂_t, σ̂_s of W paths): the paths that collide before
/// `d`, and their collision distances (meaningless elsewhere).
#[inline(always)]
pub fn sample_distance<F: Float>(
    method: Tracking,
    sigma_t: F,
    sigma_s: F,
    d: F,
    u: F,
) -> (F::Mask, F) {
    let (st, ss) = (coeff(sigma_t), coeff(sigma_s));
    match method {
        Tracking::Classic => sample_exponential(st, d, u),
        Tracking::Max => sample_exponential(st.max(ss), d, u),
        Tracking::FluoAware => sample_fluo_aware(st, ss, d, u),
    }
}

/// One path's [`sample_distance`] from the hero lanes of `sigma_t`, `sigma_s`.
pub fn sample_distance1(
    method: Tracking,
    sigma_t: Vec4,
    sigma_s: Vec4,
    d: f32,
    u: f32,
) -> DistanceSample {
    match sample_distance(method, sigma_t.x, sigma_s.x, d, u) {
        (true, t) => DistanceSample::Collision { t },
        (false, _) => DistanceSample::Surface,
    }
}

/// The density (per unit length) with which `method`, with coefficients σ̂_t, σ̂_s at
/// one wavelength, samples a collision at `t` on a segment of length `d`; 0 outside
/// [0, d).
#[inline(always)]
pub fn pdf_collision_lane<F: Float>(method: Tracking, sigma_t: F, sigma_s: F, d: F, t: F) -> F {
    let zero = F::splat(0.0);
    let inside = t.ge(zero) & t.lt(d);
    let (st, ss) = (coeff(sigma_t), coeff(sigma_s));
    let p = match method {
        Tracking::Classic => st * math::exp(-st * t),
        Tracking::Max => {
            let mu = st.max(ss);
            mu * math::exp(-mu * t)
        }
        Tracking::FluoAware => {
            let n = fluo_aware_norm(st, ss, d);
            let p = ss * math::exp(-st * t) / n;
            p.masked(ss.gt(zero) & n.gt(zero))
        }
    };
    p.masked(inside)
}

/// The probability with which `method` reaches the end of a segment of length `d`, with
/// coefficients σ̂_t, σ̂_s at one wavelength.
#[inline(always)]
pub fn prob_surface_lane<F: Float>(method: Tracking, sigma_t: F, sigma_s: F, d: F) -> F {
    let (st, ss, d) = (coeff(sigma_t), coeff(sigma_s), d.max(F::splat(0.0)));
    match method {
        Tracking::Classic => math::exp(-st * d),
        Tracking::Max => math::exp(-st.max(ss) * d),
        Tracking::FluoAware => {
            let tr = math::exp(-st * d);
            let n = tr + ss * integral_exp(st, d);
            // n = 0 only when both terms underflow; the sampler then returns the surface.
            F::select(n.gt(F::splat(0.0)), tr / n, F::splat(1.0))
        }
    }
}

/// [`pdf_collision_lane`] for the four wavelengths: with which density lane k, as hero,
/// would have sampled the collision at `t`.
#[inline(always)]
pub fn pdf_collision<F: Float>(
    method: Tracking,
    sigma_t: Spec<F>,
    sigma_s: Spec<F>,
    d: F,
    t: F,
) -> Spec<F> {
    sigma_t.zip(sigma_s, |st, ss| pdf_collision_lane(method, st, ss, d, t))
}

/// [`prob_surface_lane`] for the four wavelengths.
#[inline(always)]
pub fn prob_surface<F: Float>(
    method: Tracking,
    sigma_t: Spec<F>,
    sigma_s: Spec<F>,
    d: F,
) -> Spec<F> {
    sigma_t.zip(sigma_s, |st, ss| prob_surface_lane(method, st, ss, d))
}

/// Transmittance e^{−σ̂_t t} per wavelength.
#[inline(always)]
pub fn transmittance<F: Float>(sigma_t: Spec<F>, t: F) -> Spec<F> {
    sigma_t.map(|s| math::exp(coeff(s) * -t))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn norm_limits() {
        assert_eq!(fluo_aware_norm(0.0f32, 2.0, 3.0), 7.0);
        assert!((fluo_aware_norm(1e-9f32, 2.0, 3.0) - 7.0).abs() < 1e-5);
        assert!((fluo_aware_norm(5.0f32, 0.0, 1.0) - (-5.0f32).exp()).abs() < 1e-8);
        // σ̂_s = σ̂_t: N = 1 (the weights of an ordinary scattering medium).
        assert!((fluo_aware_norm(1.3f32, 1.3, 2.0) - 1.0).abs() < 1e-6);
    }

    #[test]
    fn zero_length_segment_reaches_the_surface() {
        let s = Vec4::new(1.0, 0.0, 3.0, 0.5);
        for m in [Tracking::Classic, Tracking::Max, Tracking::FluoAware] {
            assert_eq!(sample_distance1(m, s, s, 0.0, 0.0), DistanceSample::Surface);
            let p = prob_surface(m, s.into(), Vec4::new(0.0, 1.0, 0.5, 3.0).into(), 0.0f32);
            assert_eq!(Vec4::from(p), Vec4::ONE);
        }
    }
}
