//! [`F4`] and [`M4`]: four paths' values in one SSE register (`wide::f32x4`).

use super::{Float, Mask};
use std::fmt;
use std::ops::{
    Add, AddAssign, BitAnd, BitAndAssign, BitOr, BitOrAssign, Div, DivAssign, Mul, MulAssign, Neg,
    Not, Sub, SubAssign,
};
use wide::{f32x4, i32x4, CmpEq, CmpGe, CmpGt, CmpLe, CmpLt, CmpNe};

/// Four paths' `f32`s.
#[derive(Clone, Copy, Default, PartialEq)]
#[repr(transparent)]
pub struct F4(pub f32x4);

/// Four paths' `bool`s, as all-ones or all-zeros lanes.
#[derive(Clone, Copy, PartialEq)]
#[repr(transparent)]
pub struct M4(f32x4);

impl fmt::Debug for F4 {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "F4{:?}", self.0.to_array())
    }
}

impl fmt::Debug for M4 {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "M4({:04b})", self.bits())
    }
}

impl Mask for M4 {
    #[inline(always)]
    fn splat(b: bool) -> M4 {
        M4(f32x4::splat(f32::from_bits(if b { u32::MAX } else { 0 })))
    }
    #[inline(always)]
    fn from_fn(mut f: impl FnMut(usize) -> bool) -> M4 {
        let l = |b: bool| f32::from_bits(if b { u32::MAX } else { 0 });
        M4(f32x4::new([l(f(0)), l(f(1)), l(f(2)), l(f(3))]))
    }
    #[inline(always)]
    fn bits(self) -> u32 {
        self.0.move_mask() as u32
    }
}

impl BitAnd for M4 {
    type Output = M4;
    #[inline(always)]
    fn bitand(self, o: M4) -> M4 {
        M4(self.0 & o.0)
    }
}

impl BitOr for M4 {
    type Output = M4;
    #[inline(always)]
    fn bitor(self, o: M4) -> M4 {
        M4(self.0 | o.0)
    }
}

impl Not for M4 {
    type Output = M4;
    #[inline(always)]
    fn not(self) -> M4 {
        M4(self.0 ^ f32x4::splat(f32::from_bits(u32::MAX)))
    }
}

impl BitAndAssign for M4 {
    #[inline(always)]
    fn bitand_assign(&mut self, o: M4) {
        *self = *self & o;
    }
}

impl BitOrAssign for M4 {
    #[inline(always)]
    fn bitor_assign(&mut self, o: M4) {
        *self = *self | o;
    }
}

macro_rules! binop {
    ($tr:ident, $f:ident, $tra:ident, $fa:ident, $op:tt) => {
        impl $tr for F4 {
            type Output = F4;
            #[inline(always)]
            fn $f(self, o: F4) -> F4 {
                F4(self.0 $op o.0)
            }
        }
        impl $tra for F4 {
            #[inline(always)]
            fn $fa(&mut self, o: F4) {
                self.0 = self.0 $op o.0;
            }
        }
    };
}

binop!(Add, add, AddAssign, add_assign, +);
binop!(Sub, sub, SubAssign, sub_assign, -);
binop!(Mul, mul, MulAssign, mul_assign, *);
binop!(Div, div, DivAssign, div_assign, /);

impl Neg for F4 {
    type Output = F4;
    #[inline(always)]
    fn neg(self) -> F4 {
        // Flip the sign bit, as scalar negation does (0 − x would turn −0 into +0).
        F4(self.0 ^ f32x4::splat(-0.0))
    }
}

impl F4 {
    #[inline(always)]
    fn bits(self) -> i32x4 {
        bytemuck::cast(self.0)
    }
    #[inline(always)]
    fn from_bits(b: i32x4) -> F4 {
        F4(bytemuck::cast(b))
    }
}

impl Float for F4 {
    type Mask = M4;
    type Arr<T: Copy + fmt::Debug + Send + Sync> = [T; 4];
    const WIDTH: usize = 4;

    #[inline(always)]
    fn splat(x: f32) -> F4 {
        F4(f32x4::splat(x))
    }
    #[inline(always)]
    fn from_fn(mut f: impl FnMut(usize) -> f32) -> F4 {
        F4(f32x4::new([f(0), f(1), f(2), f(3)]))
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
    fn sqrt(self) -> F4 {
        F4(self.0.sqrt())
    }
    #[inline(always)]
    fn abs(self) -> F4 {
        F4(self.0 & f32x4::splat(f32::from_bits(0x7fff_ffff)))
    }
    #[inline(always)]
    fn min(self, o: F4) -> F4 {
        F4(self.0.fast_min(o.0))
    }
    #[inline(always)]
    fn max(self, o: F4) -> F4 {
        F4(self.0.fast_max(o.0))
    }
    #[inline(always)]
    fn floor(self) -> F4 {
        // SSE2 has no floor: truncate, then step down where that rounded up.
        let t = F4(self.0.fast_trunc_int().round_float());
        F4::select(t.gt(self), t - F4::splat(1.0), t)
    }
    #[inline(always)]
    fn round(self) -> F4 {
        F4(self.0.fast_round_int().round_float())
    }
    #[inline(always)]
    fn copysign(self, s: F4) -> F4 {
        let sign = f32x4::splat(-0.0);
        let magnitude = f32x4::splat(f32::from_bits(0x7fff_ffff));
        F4((self.0 & magnitude) | (s.0 & sign))
    }
    #[inline(always)]
    fn exp2i(n: F4) -> F4 {
        F4::from_bits((n.0.fast_round_int() + i32x4::splat(127)) << 23_i32)
    }
    #[inline(always)]
    fn frexp(self) -> (F4, F4) {
        let b = self.bits();
        let e: i32x4 = ((b >> 23_i32) & i32x4::splat(0xff)) - i32x4::splat(126);
        let m = (b & i32x4::splat(0x807f_ffff_u32 as i32)) | i32x4::splat(0x3f00_0000);
        (F4::from_bits(m), F4(e.round_float()))
    }
    #[inline(always)]
    fn lt(self, o: F4) -> M4 {
        M4(self.0.cmp_lt(o.0))
    }
    #[inline(always)]
    fn le(self, o: F4) -> M4 {
        M4(self.0.cmp_le(o.0))
    }
    #[inline(always)]
    fn gt(self, o: F4) -> M4 {
        M4(self.0.cmp_gt(o.0))
    }
    #[inline(always)]
    fn ge(self, o: F4) -> M4 {
        M4(self.0.cmp_ge(o.0))
    }
    #[inline(always)]
    fn eq(self, o: F4) -> M4 {
        M4(self.0.cmp_eq(o.0))
    }
    #[inline(always)]
    fn ne(self, o: F4) -> M4 {
        M4(self.0.cmp_ne(o.0))
    }
    #[inline(always)]
    fn select(m: M4, t: F4, f: F4) -> F4 {
        F4(m.0.blend(t.0, f.0))
    }
}
