//! [`Spec`]: a spectral quantity at the four HWSS wavelengths of W paths.

use super::{Float, Lanes, Mask};
use glam::Vec4;
use std::ops::{Add, AddAssign, Div, DivAssign, Index, IndexMut, Mul, MulAssign, Sub};

/// The four wavelengths (index 0 is the hero) × W paths: `Spec.0[k]` holds wavelength k
/// of every path.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Spec<F>(pub [F; 4]);

impl<F: Float> Spec<F> {
    /// Every wavelength of every path `x`.
    #[inline(always)]
    pub fn splat(x: f32) -> Spec<F> {
        Spec([F::splat(x); 4])
    }

    /// Every wavelength of a path its value of `x`.
    #[inline(always)]
    pub fn broadcast(x: F) -> Spec<F> {
        Spec([x; 4])
    }

    /// The same four values in every path.
    #[inline(always)]
    pub fn splat4(v: Vec4) -> Spec<F> {
        Spec([F::splat(v.x), F::splat(v.y), F::splat(v.z), F::splat(v.w)])
    }

    /// Zero.
    #[inline(always)]
    pub fn zero() -> Spec<F> {
        Spec::splat(0.0)
    }

    /// Path `i`'s four values.
    #[inline(always)]
    pub fn path(&self, i: usize) -> Vec4 {
        Vec4::new(
            self.0[0].get(i),
            self.0[1].get(i),
            self.0[2].get(i),
            self.0[3].get(i),
        )
    }

    /// Sets path `i`'s four values.
    #[inline(always)]
    pub fn set_path(&mut self, i: usize, v: Vec4) {
        self.0[0].set(i, v.x);
        self.0[1].set(i, v.y);
        self.0[2].set(i, v.z);
        self.0[3].set(i, v.w);
    }

    /// Path `i`'s values are `f(i)`.
    #[inline(always)]
    pub fn from_fn(f: impl FnMut(usize) -> Vec4) -> Spec<F> {
        // Whole vectors from an array, not lane by lane: a lane written into a vector in
        // memory and the vector read back stalls store forwarding.
        Spec(F::columns(&Lanes::from_fn(f)))
    }

    /// The hero wavelength's values.
    #[inline(always)]
    pub fn hero(&self) -> F {
        self.0[0]
    }

    /// Σ over the wavelengths, as ((s₀ + s₁) + s₂) + s₃.
    #[inline(always)]
    pub fn sum(&self) -> F {
        self.0[0] + self.0[1] + self.0[2] + self.0[3]
    }

    /// The largest of the four wavelengths' values (NaN-free inputs).
    #[inline(always)]
    pub fn max_wavelength(&self) -> F {
        self.0[0].max(self.0[1]).max(self.0[2]).max(self.0[3])
    }

    /// `f` applied to each wavelength.
    #[inline(always)]
    pub fn map(self, mut f: impl FnMut(F) -> F) -> Spec<F> {
        Spec([f(self.0[0]), f(self.0[1]), f(self.0[2]), f(self.0[3])])
    }

    /// `f` applied to each wavelength of `self` and `o`.
    #[inline(always)]
    pub fn zip(self, o: Spec<F>, mut f: impl FnMut(F, F) -> F) -> Spec<F> {
        Spec([
            f(self.0[0], o.0[0]),
            f(self.0[1], o.0[1]),
            f(self.0[2], o.0[2]),
            f(self.0[3], o.0[3]),
        ])
    }

    /// Per path: `t` where `m` is set, `f` elsewhere.
    #[inline(always)]
    pub fn select(m: F::Mask, t: Spec<F>, f: Spec<F>) -> Spec<F> {
        t.zip(f, |a, b| F::select(m, a, b))
    }

    /// Per path: `self` where `m` is set, 0 elsewhere.
    #[inline(always)]
    pub fn masked(self, m: F::Mask) -> Spec<F> {
        self.map(|a| a.masked(m))
    }

    /// The paths where `m` is set are `t`.
    #[inline(always)]
    pub fn set_where(&mut self, m: F::Mask, t: Spec<F>) {
        if m.any() {
            *self = Spec::select(m, t, *self);
        }
    }

    /// The paths whose four values are all zero.
    #[inline(always)]
    pub fn is_zero(&self) -> F::Mask {
        let z = F::splat(0.0);
        self.0[0].eq(z) & self.0[1].eq(z) & self.0[2].eq(z) & self.0[3].eq(z)
    }
}

impl From<Vec4> for Spec<f32> {
    #[inline(always)]
    fn from(v: Vec4) -> Spec<f32> {
        Spec([v.x, v.y, v.z, v.w])
    }
}

impl From<Spec<f32>> for Vec4 {
    #[inline(always)]
    fn from(s: Spec<f32>) -> Vec4 {
        Vec4::from_array(s.0)
    }
}

impl<F> Index<usize> for Spec<F> {
    type Output = F;
    #[inline(always)]
    fn index(&self, k: usize) -> &F {
        &self.0[k]
    }
}

impl<F> IndexMut<usize> for Spec<F> {
    #[inline(always)]
    fn index_mut(&mut self, k: usize) -> &mut F {
        &mut self.0[k]
    }
}

macro_rules! elementwise {
    ($tr:ident, $f:ident, $tra:ident, $fa:ident, $op:tt) => {
        impl<F: Float> $tr for Spec<F> {
            type Output = Spec<F>;
            #[inline(always)]
            fn $f(self, o: Spec<F>) -> Spec<F> {
                self.zip(o, |a, b| a $op b)
            }
        }
        impl<F: Float> $tr<F> for Spec<F> {
            type Output = Spec<F>;
            #[inline(always)]
            fn $f(self, s: F) -> Spec<F> {
                self.map(|a| a $op s)
            }
        }
        impl<F: Float> $tra for Spec<F> {
            #[inline(always)]
            fn $fa(&mut self, o: Spec<F>) {
                *self = *self $op o;
            }
        }
        impl<F: Float> $tra<F> for Spec<F> {
            #[inline(always)]
            fn $fa(&mut self, s: F) {
                *self = *self $op s;
            }
        }
    };
}

elementwise!(Add, add, AddAssign, add_assign, +);
elementwise!(Mul, mul, MulAssign, mul_assign, *);
elementwise!(Div, div, DivAssign, div_assign, /);

impl<F: Float> Sub for Spec<F> {
    type Output = Spec<F>;
    #[inline(always)]
    fn sub(self, o: Spec<F>) -> Spec<F> {
        self.zip(o, |a, b| a - b)
    }
}
