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
//! 1 − e^{−x} is computed with `exp_m1` and its inverse with `ln_1p`; the integral
//! (1 − e^{−σ d})/σ switches to its series below σd = 10⁻⁵ (so σ̂_t = 0 is exact). Dense
//! (σ̂_t d = 100) and thin (σ̂_t d = 10⁻⁴) segments give finite results; a sampled
//! collision always lies in [0, d).

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

/// The outcome of distance sampling on a segment.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum DistanceSample {
    /// A real collision at distance `t` ∈ [0, d).
    Collision { t: f32 },
    /// The segment's end (the next surface) is reached.
    Surface,
}

/// A coefficient as used here: negative and NaN count as 0.
#[inline]
fn coeff(x: f32) -> f32 {
    x.max(0.0)
}

/// ∫₀ᵗ e^{−σ s} ds = (1 − e^{−σ t})/σ, → t as σt → 0 (exact at σ = 0).
#[inline]
fn integral_exp(sigma: f32, t: f32) -> f32 {
    let tau = sigma * t;
    if tau < 1e-5 {
        t * (1.0 - 0.5 * tau)
    } else {
        -(-tau).exp_m1() / sigma
    }
}

/// The fluorescence-aware normalisation N = e^{−σ̂_t d} + σ̂_s (1 − e^{−σ̂_t d})/σ̂_t
/// (→ 1 + σ̂_s d as σ̂_t → 0): the hero's weight for either outcome. Always ≥ e^{−σ̂_t d}.
#[inline]
pub fn fluo_aware_norm(sigma_t: f32, sigma_s: f32, d: f32) -> f32 {
    let (st, ss, d) = (coeff(sigma_t), coeff(sigma_s), d.max(0.0));
    (-st * d).exp() + ss * integral_exp(st, d)
}

/// Exponential free-flight with rate `mu` truncated at `d`: t = −ln(1 − u)/μ.
#[inline]
fn sample_exponential(mu: f32, d: f32, u: f32) -> DistanceSample {
    if !(mu > 0.0 && d > 0.0) {
        return DistanceSample::Surface;
    }
    let t = -(-u).ln_1p() / mu;
    if t < d {
        DistanceSample::Collision { t }
    } else {
        DistanceSample::Surface
    }
}

/// Fluorescence-aware sampling: collide when u·N < σ̂_s (1 − e^{−σ̂_t d})/σ̂_t, then invert
/// ∫₀ᵗ e^{−σ̂_t s} ds = u·N/σ̂_s.
#[inline]
fn sample_fluo_aware(st: f32, ss: f32, d: f32, u: f32) -> DistanceSample {
    if !(ss > 0.0 && d > 0.0) {
        return DistanceSample::Surface;
    }
    let collide = ss * integral_exp(st, d);
    let x = u * ((-st * d).exp() + collide);
    // Written so that a NaN falls through to the surface.
    let g = if x < collide {
        x / ss
    } else {
        return DistanceSample::Surface;
    };
    // g = ∫₀ᵗ e^{−σ̂_t s} ds, y = σ̂_t g = 1 − e^{−σ̂_t t} ∈ [0, 1).
    let y = (st * g).min(1.0);
    let t = if y < 1e-5 {
        g * (1.0 + y * (0.5 + y * (1.0 / 3.0)))
    } else {
        -(-y).ln_1p() / st
    };
    // Rounding may push t to d or beyond (or to ∞ when y rounds to 1): the event was a
    // collision, so keep it inside the segment.
    DistanceSample::Collision {
        t: t.clamp(0.0, d.next_down()),
    }
}

/// Samples a collision distance on [0, d) or the surface, with the hero's (lane 0)
/// coefficients; `u` ∈ [0, 1).
#[inline]
pub fn sample_distance(
    method: Tracking,
    sigma_t: Vec4,
    sigma_s: Vec4,
    d: f32,
    u: f32,
) -> DistanceSample {
    let (st, ss) = (coeff(sigma_t.x), coeff(sigma_s.x));
    match method {
        Tracking::Classic => sample_exponential(st, d, u),
        Tracking::Max => sample_exponential(st.max(ss), d, u),
        Tracking::FluoAware => sample_fluo_aware(st, ss, d, u),
    }
}

/// One lane's density of a collision at `t` (0 outside [0, d)).
#[inline]
pub fn pdf_collision_lane(method: Tracking, sigma_t: f32, sigma_s: f32, d: f32, t: f32) -> f32 {
    if !(t >= 0.0 && t < d) {
        return 0.0;
    }
    let (st, ss) = (coeff(sigma_t), coeff(sigma_s));
    match method {
        Tracking::Classic => st * (-st * t).exp(),
        Tracking::Max => {
            let mu = st.max(ss);
            mu * (-mu * t).exp()
        }
        Tracking::FluoAware => {
            if ss <= 0.0 {
                return 0.0;
            }
            let n = fluo_aware_norm(st, ss, d);
            if n > 0.0 {
                ss * (-st * t).exp() / n
            } else {
                0.0
            }
        }
    }
}

/// One lane's probability of reaching the surface at `d` (1 for d ≤ 0).
#[inline]
pub fn prob_surface_lane(method: Tracking, sigma_t: f32, sigma_s: f32, d: f32) -> f32 {
    let (st, ss, d) = (coeff(sigma_t), coeff(sigma_s), d.max(0.0));
    match method {
        Tracking::Classic => (-st * d).exp(),
        Tracking::Max => (-st.max(ss) * d).exp(),
        Tracking::FluoAware => {
            let tr = (-st * d).exp();
            let n = tr + ss * integral_exp(st, d);
            // n = 0 only when both terms underflow; the sampler then returns the surface.
            if n > 0.0 {
                tr / n
            } else {
                1.0
            }
        }
    }
}

/// Per-lane density of a collision at `t` (< d), as if lane k were the hero.
#[inline]
pub fn pdf_collision(method: Tracking, sigma_t: Vec4, sigma_s: Vec4, d: f32, t: f32) -> Vec4 {
    Vec4::from_array(std::array::from_fn(|k| {
        pdf_collision_lane(method, sigma_t[k], sigma_s[k], d, t)
    }))
}

/// Per-lane probability of reaching the surface at `d`, as if lane k were the hero.
#[inline]
pub fn prob_surface(method: Tracking, sigma_t: Vec4, sigma_s: Vec4, d: f32) -> Vec4 {
    Vec4::from_array(std::array::from_fn(|k| {
        prob_surface_lane(method, sigma_t[k], sigma_s[k], d)
    }))
}

/// Per-lane transmittance e^{−σ̂_t t} over a distance `t` ≥ 0.
#[inline]
pub fn transmittance(sigma_t: Vec4, t: f32) -> Vec4 {
    (sigma_t.max(Vec4::ZERO) * -t).exp()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn norm_limits() {
        assert_eq!(fluo_aware_norm(0.0, 2.0, 3.0), 7.0);
        assert!((fluo_aware_norm(1e-9, 2.0, 3.0) - 7.0).abs() < 1e-5);
        assert_eq!(fluo_aware_norm(5.0, 0.0, 1.0), (-5.0f32).exp());
        // σ̂_s = σ̂_t: N = 1 (the weights of an ordinary scattering medium).
        assert!((fluo_aware_norm(1.3, 1.3, 2.0) - 1.0).abs() < 1e-6);
    }

    #[test]
    fn zero_length_segment_reaches_the_surface() {
        let s = Vec4::new(1.0, 0.0, 3.0, 0.5);
        for m in [Tracking::Classic, Tracking::Max, Tracking::FluoAware] {
            assert_eq!(sample_distance(m, s, s, 0.0, 0.0), DistanceSample::Surface);
            assert_eq!(
                prob_surface(m, s, Vec4::new(0.0, 1.0, 0.5, 3.0), 0.0),
                Vec4::ONE
            );
        }
    }
}
