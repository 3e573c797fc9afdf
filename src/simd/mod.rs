//! Lane width: the estimator is written once over [`Float`], a vector of the values of W
//! camera paths, and runs with W = 1 (`f32`: single rays), W = 4 ([`F4`]: Embree's 4-wide
//! packets, SSE2 arithmetic over the four paths) or W = 8 ([`F8`], 8-wide packets).
//!
//! Three kinds of value follow from it:
//! - [`Float`] itself: one scalar per path (a distance, a pdf, a coordinate);
//! - [`V3`]: a point or direction per path, one `Float` per coordinate (structure of
//!   arrays);
//! - [`Spec`]: a spectral quantity, the four HWSS wavelengths × W paths, one `Float` per
//!   wavelength, so that "over the paths" is the vector dimension and "over the
//!   wavelengths" is the array index (the hero is index 0).
//!
//! Words: a SIMD *lane* here is one path (`get(i)`, `set(i, ..)`); the rest of the
//! renderer calls the four HWSS wavelengths of a path its lanes, and they are the array
//! index of a [`Spec`] (`s[k]`).
//!
//! Data that cannot be vectorised (indices, random streams, material ids) lives in
//! [`Float::Arr`], an array with one element per path.
//!
//! Every operation here is the same IEEE arithmetic in every lane at every width, and the
//! transcendental functions ([`math`]) are this module's own polynomials, not libm's, so
//! that a path computes the same bits whichever width carries it (the tests compare
//! widths bit for bit). `min`/`max` follow the SSE rule `a < b ? a : b` at every width
//! (a NaN in `a` gives `b`).

pub mod math;
mod paths;
mod spec;
mod vec3;

pub use paths::{F4, F8, M4, M8};
pub use spec::Spec;
pub use vec3::V3;

/// `f` applied to each of the four HWSS wavelengths' values: `Vec4::to_array().map(f)`
/// written out, since the compiler leaves that closure as a call per element in hot code.
#[inline(always)]
pub fn map4(v: glam::Vec4, f: impl Fn(f32) -> f32) -> glam::Vec4 {
    glam::Vec4::new(f(v.x), f(v.y), f(v.z), f(v.w))
}

use std::fmt::Debug;
use std::ops::{
    Add, AddAssign, BitAnd, BitAndAssign, BitOr, BitOrAssign, BitXor, Div, DivAssign, Index,
    IndexMut, Mul, MulAssign, Neg, Not, Sub, SubAssign,
};

/// One `bool` per path: which lanes an operation applies to.
pub trait Mask:
    Copy
    + Debug
    + PartialEq
    + Send
    + Sync
    + 'static
    + BitAnd<Output = Self>
    + BitOr<Output = Self>
    + Not<Output = Self>
    + BitAndAssign
    + BitOrAssign
{
    /// Every lane `b`.
    fn splat(b: bool) -> Self;
    /// Lane `i` is `f(i)`.
    fn from_fn(f: impl FnMut(usize) -> bool) -> Self;
    /// Lane `i` set where bit `i` of `b` is (bits from W up are ignored).
    fn from_bits(b: u32) -> Self;
    /// Bit `i` set where lane `i` is.
    fn bits(self) -> u32;
    /// Whether lane `i` is set.
    #[inline(always)]
    fn get(self, i: usize) -> bool {
        self.bits() >> i & 1 != 0
    }
    /// This mask with lane `i` set to `b`.
    #[inline(always)]
    fn with(self, i: usize, b: bool) -> Self {
        Self::from_bits(self.bits() & !(1 << i) | (b as u32) << i)
    }
    /// Whether any lane is set.
    #[inline(always)]
    fn any(self) -> bool {
        self.bits() != 0
    }
    /// Whether no lane is set.
    #[inline(always)]
    fn none(self) -> bool {
        self.bits() == 0
    }
    /// The set lanes, in order.
    #[inline(always)]
    fn iter(self) -> SetLanes {
        SetLanes(self.bits())
    }
}

/// The indices of a mask's set lanes ([`Mask::iter`]).
#[derive(Debug, Clone, Copy)]
pub struct SetLanes(u32);

impl Iterator for SetLanes {
    type Item = usize;
    #[inline(always)]
    fn next(&mut self) -> Option<usize> {
        if self.0 == 0 {
            return None;
        }
        let i = self.0.trailing_zeros();
        self.0 &= self.0 - 1;
        Some(i as usize)
    }
}

/// One value of any type per path.
pub trait Lanes<T>:
    Copy + Debug + Send + Sync + Index<usize, Output = T> + IndexMut<usize, Output = T>
{
    /// Every lane `t`.
    fn splat(t: T) -> Self;
    /// Lane `i` is `f(i)`.
    fn from_fn(f: impl FnMut(usize) -> T) -> Self;
}

impl<T: Copy + Debug + Send + Sync> Lanes<T> for [T; 1] {
    #[inline(always)]
    fn splat(t: T) -> Self {
        [t]
    }
    #[inline(always)]
    fn from_fn(mut f: impl FnMut(usize) -> T) -> Self {
        [f(0)]
    }
}

/// One `u32` per path (`u32`, `wide::u32x4`, `wide::u32x8`): the words of the paths'
/// random streams, so that every path's generator advances in the same instructions.
pub trait Words:
    Copy + Debug + Send + Sync + 'static + BitXor<Output = Self> + BitOr<Output = Self>
{
    /// Every lane `x`.
    fn splat(x: u32) -> Self;
    /// Lane `i`.
    fn get(self, i: usize) -> u32;
    /// Sets lane `i`.
    fn set(&mut self, i: usize, x: u32);
    /// Lane-wise `self + o` modulo 2³².
    fn add_wrapping(self, o: Self) -> Self;
    /// Lane-wise `self << n`.
    fn shl_by(self, n: u32) -> Self;
    /// Lane-wise logical `self >> n`.
    fn shr_by(self, n: u32) -> Self;
}

impl Words for u32 {
    #[inline(always)]
    fn splat(x: u32) -> u32 {
        x
    }
    #[inline(always)]
    fn get(self, _: usize) -> u32 {
        self
    }
    #[inline(always)]
    fn set(&mut self, _: usize, x: u32) {
        *self = x;
    }
    #[inline(always)]
    fn add_wrapping(self, o: u32) -> u32 {
        self.wrapping_add(o)
    }
    #[inline(always)]
    fn shl_by(self, n: u32) -> u32 {
        self << n
    }
    #[inline(always)]
    fn shr_by(self, n: u32) -> u32 {
        self >> n
    }
}

/// One `f32` per path, W paths at once (see the module docs).
pub trait Float:
    Copy
    + Debug
    + Default
    + PartialEq
    + Send
    + Sync
    + 'static
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
    + AddAssign
    + SubAssign
    + MulAssign
    + DivAssign
{
    /// Which lanes.
    type Mask: Mask;
    /// Any other per-path data: `[T; W]`.
    type Arr<T: Copy + Debug + Send + Sync>: Lanes<T>;
    /// One `u32` per path, in a vector.
    type Words: Words;
    /// W: the number of paths.
    const WIDTH: usize;

    /// Every lane `x`.
    fn splat(x: f32) -> Self;
    /// Lane `i` is `f(i)`.
    fn from_fn(f: impl FnMut(usize) -> f32) -> Self;
    /// Lane `i`.
    fn get(self, i: usize) -> f32;
    /// Sets lane `i`.
    fn set(&mut self, i: usize, x: f32);

    /// √x (IEEE, correctly rounded).
    fn sqrt(self) -> Self;
    /// |x|.
    fn abs(self) -> Self;
    /// `self < o ? self : o`.
    fn min(self, o: Self) -> Self;
    /// `self > o ? self : o`.
    fn max(self, o: Self) -> Self;
    /// The largest integer ≤ x, for |x| < 2³¹.
    fn floor(self) -> Self;
    /// The nearest integer (ties to even), for |x| < 2³¹.
    fn round(self) -> Self;
    /// The magnitude of `self` with the sign of `s`.
    fn copysign(self, s: Self) -> Self;
    /// 2ⁿ for integral n in [−126, 127] (as floats).
    fn exp2i(n: Self) -> Self;
    /// (m, e) with x = m·2ᵉ, m in [½, 1), for positive normal x.
    fn frexp(self) -> (Self, Self);
    /// Each lane truncated to an index, for lanes in [0, 2³¹) (table lookups).
    fn to_index(self) -> Self::Arr<u32>;

    /// The four columns of W rows of four values: lane i of column k is `rows[i][k]`.
    /// Gathers per-path records (a light triangle, a spectral value) as whole vectors;
    /// four paths transpose in registers, the other widths go lane by lane.
    #[inline(always)]
    fn columns(rows: &Self::Arr<glam::Vec4>) -> [Self; 4] {
        [
            Self::from_fn(|i| rows[i].x),
            Self::from_fn(|i| rows[i].y),
            Self::from_fn(|i| rows[i].z),
            Self::from_fn(|i| rows[i].w),
        ]
    }

    /// The W rows of four columns, the inverse of [`Self::columns`]: `rows[i][k]` is lane
    /// i of column k. Writes per-path records (a ray for Embree) from whole vectors; four
    /// paths transpose in registers, the other widths go lane by lane.
    #[inline(always)]
    fn rows(columns: [Self; 4]) -> Self::Arr<glam::Vec4> {
        let [x, y, z, w] = columns;
        Lanes::from_fn(|i| glam::Vec4::new(x.get(i), y.get(i), z.get(i), w.get(i)))
    }

    /// self < o.
    fn lt(self, o: Self) -> Self::Mask;
    /// self ≤ o.
    fn le(self, o: Self) -> Self::Mask;
    /// self > o.
    fn gt(self, o: Self) -> Self::Mask;
    /// self ≥ o.
    fn ge(self, o: Self) -> Self::Mask;
    /// self == o.
    fn eq(self, o: Self) -> Self::Mask;
    /// self != o (true for NaN).
    fn ne(self, o: Self) -> Self::Mask;
    /// `t` where `m` is set, `f` elsewhere.
    fn select(m: Self::Mask, t: Self, f: Self) -> Self;
    /// `t` where `m` is set, `f` elsewhere, for words.
    fn select_words(m: Self::Mask, t: Self::Words, f: Self::Words) -> Self::Words;
    /// Each lane's top 24 bits as a float in [0, 1) (exact: every such value is a float).
    fn unit(w: Self::Words) -> Self;

    /// Neither NaN nor infinite.
    #[inline(always)]
    fn is_finite(self) -> Self::Mask {
        self.abs().lt(Self::splat(f32::INFINITY))
    }
    /// `self` where `m` is set, 0 elsewhere.
    #[inline(always)]
    fn masked(self, m: Self::Mask) -> Self {
        Self::select(m, self, Self::splat(0.0))
    }
    /// max(x, 0), NaN giving 0: how coefficients and reflectances are read.
    #[inline(always)]
    fn nonneg(self) -> Self {
        self.max(Self::splat(0.0))
    }
    /// x·x.
    #[inline(always)]
    fn sq(self) -> Self {
        self * self
    }
    /// min(max(x, lo), hi) (NaN gives `lo`).
    #[inline(always)]
    fn clamp(self, lo: f32, hi: f32) -> Self {
        self.max(Self::splat(lo)).min(Self::splat(hi))
    }
}

impl Mask for bool {
    #[inline(always)]
    fn splat(b: bool) -> bool {
        b
    }
    #[inline(always)]
    fn from_fn(mut f: impl FnMut(usize) -> bool) -> bool {
        f(0)
    }
    #[inline(always)]
    fn from_bits(b: u32) -> bool {
        b & 1 != 0
    }
    #[inline(always)]
    fn bits(self) -> u32 {
        self as u32
    }
    #[inline(always)]
    fn get(self, _: usize) -> bool {
        self
    }
    #[inline(always)]
    fn with(self, _: usize, b: bool) -> bool {
        b
    }
    #[inline(always)]
    fn any(self) -> bool {
        self
    }
    #[inline(always)]
    fn none(self) -> bool {
        !self
    }
}

impl Float for f32 {
    type Mask = bool;
    type Arr<T: Copy + Debug + Send + Sync> = [T; 1];
    type Words = u32;
    const WIDTH: usize = 1;

    #[inline(always)]
    fn splat(x: f32) -> f32 {
        x
    }
    #[inline(always)]
    fn from_fn(mut f: impl FnMut(usize) -> f32) -> f32 {
        f(0)
    }
    #[inline(always)]
    fn get(self, _: usize) -> f32 {
        self
    }
    #[inline(always)]
    fn set(&mut self, _: usize, x: f32) {
        *self = x;
    }
    #[inline(always)]
    fn sqrt(self) -> f32 {
        f32::sqrt(self)
    }
    #[inline(always)]
    fn abs(self) -> f32 {
        f32::abs(self)
    }
    #[inline(always)]
    fn min(self, o: f32) -> f32 {
        if self < o {
            self
        } else {
            o
        }
    }
    #[inline(always)]
    fn max(self, o: f32) -> f32 {
        if self > o {
            self
        } else {
            o
        }
    }
    #[inline(always)]
    fn floor(self) -> f32 {
        // As F4 does it: truncate, then step down where that rounded up.
        let t = trunc_i32(self) as f32;
        if t > self {
            t - 1.0
        } else {
            t
        }
    }
    #[inline(always)]
    fn round(self) -> f32 {
        // As F4 does it (`cvtps2dq`): −0.5 rounds to +0, NaN to i32::MIN.
        if self.abs() < 2_147_483_648.0 {
            self.round_ties_even() as i32 as f32
        } else {
            i32::MIN as f32
        }
    }
    #[inline(always)]
    fn copysign(self, s: f32) -> f32 {
        f32::copysign(self, s)
    }
    #[inline(always)]
    fn exp2i(n: f32) -> f32 {
        f32::from_bits(((n as i32 + 127) as u32) << 23)
    }
    #[inline(always)]
    fn frexp(self) -> (f32, f32) {
        let b = self.to_bits();
        let e = ((b >> 23) & 0xff) as i32 - 126;
        (f32::from_bits((b & 0x807f_ffff) | 0x3f00_0000), e as f32)
    }
    #[inline(always)]
    fn to_index(self) -> [u32; 1] {
        [trunc_i32(self) as u32]
    }
    #[inline(always)]
    fn lt(self, o: f32) -> bool {
        self < o
    }
    #[inline(always)]
    fn le(self, o: f32) -> bool {
        self <= o
    }
    #[inline(always)]
    fn gt(self, o: f32) -> bool {
        self > o
    }
    #[inline(always)]
    fn ge(self, o: f32) -> bool {
        self >= o
    }
    #[inline(always)]
    fn eq(self, o: f32) -> bool {
        self == o
    }
    #[inline(always)]
    fn ne(self, o: f32) -> bool {
        self != o
    }
    #[inline(always)]
    fn select(m: bool, t: f32, f: f32) -> f32 {
        if m {
            t
        } else {
            f
        }
    }
    #[inline(always)]
    fn select_words(m: bool, t: u32, f: u32) -> u32 {
        if m {
            t
        } else {
            f
        }
    }
    #[inline(always)]
    fn unit(w: u32) -> f32 {
        (w >> 8) as f32 * (1.0 / 16_777_216.0)
    }
}

/// Truncation to i32 as SSE's `cvttps2dq` does it: NaN and out-of-range values give
/// `i32::MIN` (Rust's `as` would saturate).
#[inline(always)]
fn trunc_i32(x: f32) -> i32 {
    if x.abs() < 2_147_483_648.0 {
        x as i32
    } else {
        i32::MIN
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every width, the 4×4 transpose included, puts lane i of column k at `rows[i][k]`,
    /// and `rows` undoes `columns`.
    #[test]
    fn columns_transpose_rows_at_every_width() {
        fn check<F: Float>() {
            let rows: F::Arr<glam::Vec4> = Lanes::from_fn(|i| {
                glam::Vec4::from_array(std::array::from_fn(|k| (10 * i + k) as f32))
            });
            let columns = F::columns(&rows);
            for (k, column) in columns.iter().enumerate() {
                for i in 0..F::WIDTH {
                    let want = (10 * i + k) as f32;
                    assert_eq!(column.get(i), want, "lane {i}, column {k}");
                }
            }
            let back = F::rows(columns);
            for i in 0..F::WIDTH {
                assert_eq!(back[i], rows[i], "rows: lane {i}");
            }
        }
        check::<f32>();
        check::<F4>();
        check::<F8>();
    }

    /// Every operation of F4 agrees with f32's, lane by lane, bit for bit.
    #[test]
    fn f4_matches_f32_lane_by_lane() {
        let xs = [
            0.0f32,
            -0.0,
            1.0,
            -1.5,
            2.5,
            3.5,
            -2.5,
            1e-3,
            123.456,
            -7.0e6,
            0.5,
            1e30,
            -1e-30,
            f32::NAN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            2.0e9,
            0.999_999_9,
        ];
        for (i, &a) in xs.iter().enumerate() {
            for &b in &xs[i..] {
                let va = F4::from_fn(|k| if k % 2 == 0 { a } else { b });
                let vb = F4::from_fn(|k| if k % 2 == 0 { b } else { a });
                let same = |v: F4, f: &dyn Fn(f32, f32) -> f32| {
                    for k in 0..4 {
                        let (x, y) = if k % 2 == 0 { (a, b) } else { (b, a) };
                        let (got, want) = (v.get(k), f(x, y));
                        assert!(
                            got.to_bits() == want.to_bits() || (got.is_nan() && want.is_nan()),
                            "lane {k} of ({x}, {y}): {got} against {want}"
                        );
                    }
                };
                same(va + vb, &|x, y| x + y);
                same(va * vb, &|x, y| x * y);
                same(va / vb, &|x, y| x / y);
                same(va.min(vb), &|x, y| Float::min(x, y));
                same(va.max(vb), &|x, y| Float::max(x, y));
                same(va.copysign(vb), &|x, y| Float::copysign(x, y));
                same(va.sqrt(), &|x, _| Float::sqrt(x));
                same(va.abs(), &|x, _| Float::abs(x));
                if a.abs() < 2e9 {
                    same(va.floor(), &|x, _| Float::floor(x));
                    same(va.round(), &|x, _| Float::round(x));
                }
                assert_eq!(
                    va.lt(vb).bits(),
                    <M4 as Mask>::from_fn(|k| {
                        let (x, y) = if k % 2 == 0 { (a, b) } else { (b, a) };
                        x < y
                    })
                    .bits()
                );
                let m = va.ge(vb);
                same(F4::select(m, va, vb), &|x, y| if x >= y { x } else { y });
            }
        }
    }

    #[test]
    fn floor_round_frexp_and_exp2i() {
        for &x in &[-2.5f32, -2.0, -0.5, 0.0, 0.49, 0.5, 1.5, 2.5, 7.99] {
            assert_eq!(Float::floor(x), x.floor(), "{x}");
            assert_eq!(Float::round(x), x.round_ties_even(), "{x}");
        }
        for &x in &[1.0f32, 0.75, 3.0, 1e-20, 6.5e20] {
            let (m, e) = Float::frexp(x);
            assert!((0.5..1.0).contains(&m), "{x}: {m}");
            assert_eq!(m * 2f32.powi(e as i32), x);
            let (m4, e4) = F4::splat(x).frexp();
            assert_eq!((m4.get(2), e4.get(3)), (m, e));
        }
        for n in -126..=127 {
            assert_eq!(<f32 as Float>::exp2i(n as f32), 2f32.powi(n));
            assert_eq!(F4::exp2i(F4::splat(n as f32)).get(1), 2f32.powi(n));
        }
    }

    #[test]
    fn masks_iterate_their_set_lanes() {
        let m = M4::from_fn(|i| i == 1 || i == 3);
        assert_eq!(m.iter().collect::<Vec<_>>(), vec![1, 3]);
        assert_eq!(m.bits(), 0b1010);
        assert!(m.any() && !m.none() && m.get(3) && !m.get(0));
        assert_eq!((!m).bits(), 0b0101);
        assert_eq!((m & !m).bits(), 0);
        assert_eq!((m | !m).bits(), 0b1111);
        assert_eq!(true.iter().collect::<Vec<_>>(), vec![0]);
    }

    /// Every pattern of lanes survives bits → mask → bits, from bools and from bits, and
    /// `with` changes one lane only, at every width.
    #[test]
    fn masks_from_bits_from_fn_and_with_agree() {
        fn check<M: Mask>(width: usize) {
            let all = (1u32 << width) - 1;
            for b in 0..=all {
                let m = M::from_bits(b);
                assert_eq!(m.bits(), b, "from_bits({b:#b})");
                assert_eq!(M::from_fn(|i| b >> i & 1 != 0), m, "from_fn of {b:#b}");
                assert_eq!(M::from_bits(b | !all).bits(), b, "high bits of {b:#b}");
                for i in 0..width {
                    assert_eq!(m.with(i, true).bits(), b | 1 << i, "{b:#b} with {i} set");
                    assert_eq!(
                        m.with(i, false).bits(),
                        b & !(1 << i),
                        "{b:#b} with {i} clear"
                    );
                }
            }
        }
        check::<bool>(1);
        check::<M4>(4);
        check::<M8>(8);
    }
}
