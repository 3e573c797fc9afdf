//! [`F4`]/[`M4`] (four paths in one SSE register, `wide::f32x4`) and [`F8`]/[`M8`] (eight
//! paths, `wide::f32x8`: one AVX register where the build enables AVX, two SSE registers
//! otherwise), both written by one macro.

use super::{Float, Lanes, Mask, Words};
use std::fmt;
use std::ops::{
    Add, AddAssign, BitAnd, BitAndAssign, BitOr, BitOrAssign, Div, DivAssign, Mul, MulAssign, Neg,
    Not, Sub, SubAssign,
};
use wide::{f32x4, f32x8, i32x4, i32x8, u32x4, u32x8, CmpEq, CmpGe, CmpGt, CmpLe, CmpLt, CmpNe};

/// A binary operator and its assigning form for a vector type.
macro_rules! binop {
    ($ty:ident, $tr:ident, $f:ident, $tra:ident, $fa:ident, $op:tt) => {
        impl $tr for $ty {
            type Output = $ty;
            #[inline(always)]
            fn $f(self, o: $ty) -> $ty {
                $ty(self.0 $op o.0)
            }
        }
        impl $tra for $ty {
            #[inline(always)]
            fn $fa(&mut self, o: $ty) {
                self.0 = self.0 $op o.0;
            }
        }
    };
}

/// A vector of paths (`$f`) and its mask (`$m`) over `wide`'s `$fx` (`$ix` for bits,
/// `$ux` for words), `$n` lanes, lane indices `$i`.
macro_rules! paths {
    ($f:ident, $m:ident, $fx:ident, $ix:ident, $ux:ident, $n:literal, [$($i:literal),+], $doc:literal) => {
        impl Words for $ux {
            #[inline(always)]
            fn splat(x: u32) -> $ux {
                $ux::splat(x)
            }
            #[inline(always)]
            fn get(self, i: usize) -> u32 {
                self.as_array_ref()[i]
            }
            #[inline(always)]
            fn set(&mut self, i: usize, x: u32) {
                self.as_array_mut()[i] = x;
            }
            #[inline(always)]
            fn add_wrapping(self, o: $ux) -> $ux {
                self + o
            }
            #[inline(always)]
            fn shl_by(self, n: u32) -> $ux {
                self << n
            }
            #[inline(always)]
            fn shr_by(self, n: u32) -> $ux {
                self >> n
            }
        }

        #[doc = $doc]
        #[derive(Clone, Copy, Default, PartialEq)]
        #[repr(transparent)]
        pub struct $f(pub $fx);

        /// One `bool` per path of the vector type of the same width, as all-ones or
        /// all-zeros lanes.
        #[derive(Clone, Copy)]
        #[repr(transparent)]
        pub struct $m($fx);

        /// Equal lanes (not the floats' equality: a set lane is a NaN).
        impl PartialEq for $m {
            #[inline(always)]
            fn eq(&self, o: &$m) -> bool {
                self.bits() == o.bits()
            }
        }

        impl fmt::Debug for $f {
            fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                write!(f, "{}{:?}", stringify!($f), self.0.to_array())
            }
        }

        impl fmt::Debug for $m {
            fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                write!(f, "{}({:0w$b})", stringify!($m), self.bits(), w = $n)
            }
        }

        impl Mask for $m {
            #[inline(always)]
            fn splat(b: bool) -> $m {
                $m($fx::splat(f32::from_bits(if b { u32::MAX } else { 0 })))
            }
            /// Lane by lane (gathering the bools as bits and spreading them with
            /// [`Mask::from_bits`] measured 0.8 % more instructions in a medium).
            #[inline(always)]
            fn from_fn(mut f: impl FnMut(usize) -> bool) -> $m {
                let l = |b: bool| f32::from_bits(if b { u32::MAX } else { 0 });
                $m($fx::new([$(l(f($i))),+]))
            }
            /// The bits spread to lanes in registers: `with` changes one lane with a
            /// few instructions instead of rebuilding the vector lane by lane.
            #[inline(always)]
            fn from_bits(b: u32) -> $m {
                let lane = $ix::new([$(1 << $i),+]);
                $m(bytemuck::cast(($ix::splat(b as i32) & lane).cmp_eq(lane)))
            }
            #[inline(always)]
            fn bits(self) -> u32 {
                self.0.move_mask() as u32
            }
        }

        impl BitAnd for $m {
            type Output = $m;
            #[inline(always)]
            fn bitand(self, o: $m) -> $m {
                $m(self.0 & o.0)
            }
        }

        impl BitOr for $m {
            type Output = $m;
            #[inline(always)]
            fn bitor(self, o: $m) -> $m {
                $m(self.0 | o.0)
            }
        }

        impl Not for $m {
            type Output = $m;
            #[inline(always)]
            fn not(self) -> $m {
                $m(self.0 ^ $fx::splat(f32::from_bits(u32::MAX)))
            }
        }

        impl BitAndAssign for $m {
            #[inline(always)]
            fn bitand_assign(&mut self, o: $m) {
                *self = *self & o;
            }
        }

        impl BitOrAssign for $m {
            #[inline(always)]
            fn bitor_assign(&mut self, o: $m) {
                *self = *self | o;
            }
        }

        binop!($f, Add, add, AddAssign, add_assign, +);
        binop!($f, Sub, sub, SubAssign, sub_assign, -);
        binop!($f, Mul, mul, MulAssign, mul_assign, *);
        binop!($f, Div, div, DivAssign, div_assign, /);

        impl Neg for $f {
            type Output = $f;
            #[inline(always)]
            fn neg(self) -> $f {
                // Flip the sign bit, as scalar negation does (0 − x would turn −0 into +0).
                $f(self.0 ^ $fx::splat(-0.0))
            }
        }

        impl $f {
            #[inline(always)]
            fn bits(self) -> $ix {
                bytemuck::cast(self.0)
            }
            #[inline(always)]
            fn from_bits(b: $ix) -> $f {
                $f(bytemuck::cast(b))
            }
        }

        impl Float for $f {
            type Mask = $m;
            type Arr<T: Copy + fmt::Debug + Send + Sync> = [T; $n];
            type Words = $ux;
            const WIDTH: usize = $n;

            #[inline(always)]
            fn splat(x: f32) -> $f {
                $f($fx::splat(x))
            }
            #[inline(always)]
            fn from_fn(mut f: impl FnMut(usize) -> f32) -> $f {
                $f($fx::new([$(f($i)),+]))
            }
            #[inline(always)]
            fn get(self, i: usize) -> f32 {
                self.0.as_array_ref()[i]
            }
            #[inline(always)]
            fn set(&mut self, i: usize, x: f32) {
                self.0.as_array_mut()[i] = x;
            }
            #[inline(always)]
            fn sqrt(self) -> $f {
                $f(self.0.sqrt())
            }
            #[inline(always)]
            fn abs(self) -> $f {
                $f(self.0 & $fx::splat(f32::from_bits(0x7fff_ffff)))
            }
            #[inline(always)]
            fn min(self, o: $f) -> $f {
                $f(self.0.fast_min(o.0))
            }
            #[inline(always)]
            fn max(self, o: $f) -> $f {
                $f(self.0.fast_max(o.0))
            }
            #[inline(always)]
            fn floor(self) -> $f {
                // SSE2 has no floor: truncate, then step down where that rounded up.
                let t = $f(self.0.fast_trunc_int().round_float());
                $f::select(t.gt(self), t - $f::splat(1.0), t)
            }
            #[inline(always)]
            fn round(self) -> $f {
                $f(self.0.fast_round_int().round_float())
            }
            #[inline(always)]
            fn copysign(self, s: $f) -> $f {
                let sign = $fx::splat(-0.0);
                let magnitude = $fx::splat(f32::from_bits(0x7fff_ffff));
                $f((self.0 & magnitude) | (s.0 & sign))
            }
            #[inline(always)]
            fn exp2i(n: $f) -> $f {
                $f::from_bits((n.0.fast_round_int() + $ix::splat(127)) << 23_i32)
            }
            #[inline(always)]
            fn frexp(self) -> ($f, $f) {
                let b = self.bits();
                let e: $ix = ((b >> 23_i32) & $ix::splat(0xff)) - $ix::splat(126);
                let m = (b & $ix::splat(0x807f_ffff_u32 as i32)) | $ix::splat(0x3f00_0000);
                ($f::from_bits(m), $f(e.round_float()))
            }
            #[inline(always)]
            fn columns(rows: &[glam::Vec4; $n]) -> [$f; 4] {
                $f::columns_of(rows)
            }
            #[inline(always)]
            fn rows(columns: [$f; 4]) -> [glam::Vec4; $n] {
                $f::rows_of(columns)
            }
            #[inline(always)]
            fn to_index(self) -> [u32; $n] {
                bytemuck::cast(self.0.fast_trunc_int())
            }
            #[inline(always)]
            fn lt(self, o: $f) -> $m {
                $m(self.0.cmp_lt(o.0))
            }
            #[inline(always)]
            fn le(self, o: $f) -> $m {
                $m(self.0.cmp_le(o.0))
            }
            #[inline(always)]
            fn gt(self, o: $f) -> $m {
                $m(self.0.cmp_gt(o.0))
            }
            #[inline(always)]
            fn ge(self, o: $f) -> $m {
                $m(self.0.cmp_ge(o.0))
            }
            #[inline(always)]
            fn eq(self, o: $f) -> $m {
                $m(self.0.cmp_eq(o.0))
            }
            #[inline(always)]
            fn ne(self, o: $f) -> $m {
                $m(self.0.cmp_ne(o.0))
            }
            #[inline(always)]
            fn select(m: $m, t: $f, f: $f) -> $f {
                $f(m.0.blend(t.0, f.0))
            }
            #[inline(always)]
            fn select_words(m: $m, t: $ux, f: $ux) -> $ux {
                bytemuck::cast::<$fx, $ux>(m.0).blend(t, f)
            }
            #[inline(always)]
            fn unit(w: $ux) -> $f {
                // Below 2²⁴, so the signed conversion is exact, as `as f32` is at width 1.
                let top: $ix = bytemuck::cast(w >> 8_u32);
                $f(top.round_float() * $fx::splat(1.0 / 16_777_216.0))
            }
        }

        // Written out, not `std::array::from_fn`, which the compiler does not always inline.
        impl<T: Copy + fmt::Debug + Send + Sync> Lanes<T> for [T; $n] {
            #[inline(always)]
            fn splat(t: T) -> Self {
                [t; $n]
            }
            #[inline(always)]
            fn from_fn(mut f: impl FnMut(usize) -> T) -> Self {
                [$(f($i)),+]
            }
        }
    };
}

paths!(
    F4,
    M4,
    f32x4,
    i32x4,
    u32x4,
    4,
    [0, 1, 2, 3],
    "Four paths' `f32`s (SSE)."
);
paths!(
    F8,
    M8,
    f32x8,
    i32x8,
    u32x8,
    8,
    [0, 1, 2, 3, 4, 5, 6, 7],
    "Eight paths' `f32`s (AVX, or two SSE registers)."
);

impl F4 {
    /// [`Float::columns`] of four rows: one 4×4 transpose in SSE registers.
    #[inline(always)]
    fn columns_of(rows: &[glam::Vec4; 4]) -> [F4; 4] {
        let rows = rows.map(|r| f32x4::from(r.to_array()));
        f32x4::transpose(rows).map(F4)
    }

    /// [`Float::rows`] of four columns: the same transpose the other way.
    #[inline(always)]
    fn rows_of(columns: [F4; 4]) -> [glam::Vec4; 4] {
        let rows = f32x4::transpose(columns.map(|c| c.0));
        rows.map(|r| glam::Vec4::from_array(r.to_array()))
    }
}

impl F8 {
    /// [`Float::columns`] of eight rows, lane by lane.
    #[inline(always)]
    fn columns_of(rows: &[glam::Vec4; 8]) -> [F8; 4] {
        let column = |k: usize| F8(f32x8::new(rows.map(|r| r[k])));
        [column(0), column(1), column(2), column(3)]
    }

    /// [`Float::rows`] of four columns, lane by lane.
    #[inline(always)]
    fn rows_of(columns: [F8; 4]) -> [glam::Vec4; 8] {
        let c = columns.map(|c| c.0.to_array());
        std::array::from_fn(|i| glam::Vec4::new(c[0][i], c[1][i], c[2][i], c[3][i]))
    }
}
