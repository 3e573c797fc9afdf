//! Transcendental functions over [`Float`], the same polynomials at every width so that a
//! path's bits do not depend on the width that carries it (libm and SIMD libraries each
//! round their own way). Range reduction and polynomials after Cephes (Moshier, public
//! domain); accuracy within a few ulp, checked against f64 in the tests.

use super::{Float, Mask};
use std::f32::consts::FRAC_PI_2;

/// eˣ, for x ≤ 88 (0 below −87.3, NaN for NaN).
#[inline(always)]
pub fn exp<F: Float>(x: F) -> F {
    const LOG2E: f32 = std::f32::consts::LOG2_E;
    // ln 2 split so that n·C1 is exact.
    const C1: f32 = 0.693_359_4;
    const C2: f32 = -2.121_944_4e-4;
    let xc = x.clamp(-87.3, 88.0);
    let n = (xc * F::splat(LOG2E)).round();
    let r = xc - n * F::splat(C1) - n * F::splat(C2);
    let mut p = F::splat(1.987_569_1e-4);
    for c in [
        1.398_199_9e-3,
        8.333_452e-3,
        4.166_579_6e-2,
        1.666_666_5e-1,
        0.5,
    ] {
        p = p * r + F::splat(c);
    }
    let y = p * r * r + r + F::splat(1.0);
    let v = y * F::exp2i(n);
    let v = F::select(x.lt(F::splat(-87.3)), F::splat(0.0), v);
    F::select(x.ne(x), x, v)
}

/// eˣ − 1, accurate near 0 (for x ≤ 88).
#[inline(always)]
pub fn exp_m1<F: Float>(x: F) -> F {
    // Taylor to x⁹ on |x| < ½ (truncation below 10⁻⁹ relative), eˣ − 1 beyond.
    let mut p = F::splat(1.0 / 362_880.0);
    for c in [
        1.0 / 40_320.0,
        1.0 / 5_040.0,
        1.0 / 720.0,
        1.0 / 120.0,
        1.0 / 24.0,
        1.0 / 6.0,
        0.5,
        1.0,
    ] {
        p = p * x + F::splat(c);
    }
    let small = x.abs().lt(F::splat(0.5));
    if small.bits() == (1u32 << F::WIDTH) - 1 {
        return p * x;
    }
    F::select(small, p * x, exp(x) - F::splat(1.0))
}

/// ln x (−∞ at 0, NaN below 0, +∞ at +∞).
#[inline(always)]
pub fn ln<F: Float>(x: F) -> F {
    const SQRT_HALF: f32 = std::f32::consts::FRAC_1_SQRT_2;
    let (m, e) = x.frexp();
    let small = m.lt(F::splat(SQRT_HALF));
    let e = F::select(small, e - F::splat(1.0), e);
    let f = F::select(small, m + m, m) - F::splat(1.0);
    let z = f * f;
    let mut p = F::splat(7.037_683_6e-2);
    for c in [
        -1.151_461_1e-1,
        1.167_699_9e-1,
        -1.242_014_1e-1,
        1.424_932_3e-1,
        -1.666_805_8e-1,
        2.000_071_4e-1,
        -2.499_999_4e-1,
        0.333_333_3,
    ] {
        p = p * f + F::splat(c);
    }
    let y = p * f * z + e * F::splat(-2.121_944_4e-4) - F::splat(0.5) * z;
    let r = f + y + e * F::splat(0.693_359_4);
    let positive = x.ge(F::splat(f32::MIN_POSITIVE)) & x.lt(F::splat(f32::INFINITY));
    if positive.bits() == (1u32 << F::WIDTH) - 1 {
        return r;
    }
    let zero = x.ge(F::splat(0.0)) & x.lt(F::splat(f32::MIN_POSITIVE));
    let inf = F::splat(f32::INFINITY);
    let edge = F::select(x.eq(inf), inf, F::splat(f32::NAN));
    let edge = F::select(zero, -inf, edge);
    F::select(positive, r, edge)
}

/// ln(1 + x), accurate near 0.
#[inline(always)]
pub fn ln_1p<F: Float>(x: F) -> F {
    // Kahan: with u = 1 + x rounded, ln(u)·x/(u − 1) corrects the rounding of u.
    let one = F::splat(1.0);
    let u = x + one;
    let v = ln(u) * (x / (u - one));
    let v = F::select(u.eq(F::splat(f32::INFINITY)), u, v);
    F::select(u.eq(one), x, v)
}

/// (sin 2πu, cos 2πu), for u in [0, 1) (any u of moderate size works).
#[inline(always)]
pub fn sin_cos_turns<F: Float>(u: F) -> (F, F) {
    // Quarter turns: y = 4u = q + r' with q the nearest integer, angle r = r'·π/2 in
    // [−π/4, π/4] (y − q is exact), then the quadrant q mod 4 rotates (sin r, cos r).
    let y = u * F::splat(4.0);
    let q = y.round();
    let r = (y - q) * F::splat(FRAC_PI_2);
    let r2 = r * r;
    let s = r + r
        * r2
        * (F::splat(-1.0 / 6.0)
            + r2 * (F::splat(1.0 / 120.0)
                + r2 * (F::splat(-1.0 / 5_040.0) + r2 * F::splat(1.0 / 362_880.0))));
    let c = F::splat(1.0)
        + r2 * (F::splat(-0.5)
            + r2 * (F::splat(1.0 / 24.0)
                + r2 * (F::splat(-1.0 / 720.0)
                    + r2 * (F::splat(1.0 / 40_320.0) - r2 * F::splat(1.0 / 3_628_800.0)))));
    let q4 = q - (q * F::splat(0.25)).floor() * F::splat(4.0); // 0, 1, 2 or 3
    let odd = q4.eq(F::splat(1.0)) | q4.eq(F::splat(3.0));
    let (a, b) = (F::select(odd, c, s), F::select(odd, s, c));
    let sin = F::select(q4.ge(F::splat(2.0)), -a, a);
    let cos = F::select(q4.eq(F::splat(1.0)) | q4.eq(F::splat(2.0)), -b, b);
    (sin, cos)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::simd::F4;

    /// The relative error of `got` against `want`, in units of f32's epsilon, with an
    /// absolute floor `abs` (for values near zero).
    fn err(got: f32, want: f64, abs: f64) -> f64 {
        (got as f64 - want).abs() / (want.abs().max(abs) * f32::EPSILON as f64)
    }

    /// Checks `f` at width 1 and 4 (same bits) against `g` in f64 over `xs`; returns the
    /// largest error in epsilons.
    fn check(
        xs: impl Iterator<Item = f32>,
        f1: impl Fn(f32) -> f32,
        f4: impl Fn(F4) -> F4,
        g: impl Fn(f64) -> f64,
        abs: f64,
    ) -> f64 {
        let mut worst = 0f64;
        for x in xs {
            let a = f1(x);
            let b = f4(F4::from_fn(|i| if i == 2 { x } else { 0.5 })).get(2);
            assert!(
                a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan()),
                "x = {x}: width 1 gives {a}, width 4 {b}"
            );
            let want = g(x as f64);
            if want.is_finite() {
                worst = worst.max(err(a, want, abs));
            } else {
                assert!(
                    a.is_nan() == want.is_nan() && (a.is_nan() || a == want as f32),
                    "x = {x}: {a} against {want}"
                );
            }
        }
        worst
    }

    fn grid(lo: f32, hi: f32, n: usize) -> impl Iterator<Item = f32> {
        (0..=n).map(move |i| lo + (hi - lo) * i as f32 / n as f32)
    }

    fn log_grid(lo: f64, hi: f64, n: usize) -> impl Iterator<Item = f32> {
        (0..=n).map(move |i| (lo.ln() + (hi / lo).ln() * i as f64 / n as f64).exp() as f32)
    }

    #[test]
    fn exp_within_three_epsilon() {
        let w = check(grid(-87.0, 88.0, 200_001), exp, exp, f64::exp, 0.0);
        assert!(w < 3.0, "exp: {w} eps");
        assert_eq!(exp(-100.0f32), 0.0);
        assert_eq!(exp(f32::NEG_INFINITY), 0.0);
        assert!(exp(f32::NAN).is_nan());
        assert_eq!(exp(0.0f32), 1.0);
    }

    #[test]
    fn exp_m1_within_three_epsilon_near_zero() {
        let xs = grid(-10.0, 10.0, 100_001)
            .chain(log_grid(1e-12, 0.6, 20_000))
            .chain(log_grid(1e-12, 0.6, 20_000).map(|x| -x));
        let w = check(xs, exp_m1, exp_m1, f64::exp_m1, 0.0);
        assert!(w < 3.0, "exp_m1: {w} eps");
    }

    #[test]
    fn ln_within_three_epsilon() {
        let w = check(log_grid(1e-37, 1e38, 200_000), ln, ln, f64::ln, 1.0);
        assert!(w < 3.0, "ln: {w} eps");
        assert_eq!(ln(0.0f32), f32::NEG_INFINITY);
        assert_eq!(ln(f32::INFINITY), f32::INFINITY);
        assert!(ln(-1.0f32).is_nan() && ln(f32::NAN).is_nan());
        assert_eq!(ln(1.0f32), 0.0);
    }

    #[test]
    fn ln_1p_within_three_epsilon() {
        let xs = grid(-0.999, 10.0, 100_001)
            .chain(log_grid(1e-20, 0.5, 20_000))
            .chain(log_grid(1e-20, 0.5, 20_000).map(|x| -x));
        let w = check(xs, ln_1p, ln_1p, f64::ln_1p, 0.0);
        assert!(w < 3.0, "ln_1p: {w} eps");
        assert_eq!(ln_1p(-1.0f32), f32::NEG_INFINITY);
        assert_eq!(ln_1p(0.0f32), 0.0);
    }

    #[test]
    fn sin_cos_turns_within_two_epsilon_absolute() {
        let tau = std::f64::consts::TAU;
        let xs = || grid(0.0, 1.0, 400_000).filter(|&u| u < 1.0);
        let s = check(
            xs(),
            |u| sin_cos_turns(u).0,
            |u| sin_cos_turns(u).0,
            |u| (tau * u).sin(),
            1.0,
        );
        let c = check(
            xs(),
            |u| sin_cos_turns(u).1,
            |u| sin_cos_turns(u).1,
            |u| (tau * u).cos(),
            1.0,
        );
        assert!(s < 2.0 && c < 2.0, "sin {s} eps, cos {c} eps");
        let (s, c) = sin_cos_turns(0.25f32);
        assert_eq!((s, c.abs() < 1e-7), (1.0, true));
    }
}
