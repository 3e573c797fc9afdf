//! [`V3`]: a point or direction per path, one [`Float`] per coordinate.

use super::{Float, Lanes, Mask};
use glam::Vec3;
use std::ops::{Add, AddAssign, Div, Mul, Neg, Sub};

/// W points or directions: x, y and z each a vector over the paths.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct V3<F> {
    /// x of every path.
    pub x: F,
    /// y of every path.
    pub y: F,
    /// z of every path.
    pub z: F,
}

impl<F: Float> V3<F> {
    /// From coordinates.
    #[inline(always)]
    pub fn new(x: F, y: F, z: F) -> V3<F> {
        V3 { x, y, z }
    }

    /// The same vector in every lane.
    #[inline(always)]
    pub fn splat(v: Vec3) -> V3<F> {
        V3::new(F::splat(v.x), F::splat(v.y), F::splat(v.z))
    }

    /// Lane `i` is `f(i)`.
    #[inline(always)]
    pub fn from_fn(f: impl FnMut(usize) -> Vec3) -> V3<F> {
        // Whole vectors from an array (see `Spec::from_fn`).
        let v: F::Arr<Vec3> = Lanes::from_fn(f);
        V3::new(
            F::from_fn(|i| v[i].x),
            F::from_fn(|i| v[i].y),
            F::from_fn(|i| v[i].z),
        )
    }

    /// Lane `i`.
    #[inline(always)]
    pub fn path(&self, i: usize) -> Vec3 {
        Vec3::new(self.x.get(i), self.y.get(i), self.z.get(i))
    }

    /// Sets lane `i`.
    #[inline(always)]
    pub fn set_path(&mut self, i: usize, v: Vec3) {
        self.x.set(i, v.x);
        self.y.set(i, v.y);
        self.z.set(i, v.z);
    }

    /// a·b, summed left to right.
    #[inline(always)]
    pub fn dot(self, o: V3<F>) -> F {
        self.x * o.x + self.y * o.y + self.z * o.z
    }

    /// a × b.
    #[inline(always)]
    pub fn cross(self, o: V3<F>) -> V3<F> {
        V3::new(
            self.y * o.z - self.z * o.y,
            self.z * o.x - self.x * o.z,
            self.x * o.y - self.y * o.x,
        )
    }

    /// |v|².
    #[inline(always)]
    pub fn length_squared(self) -> F {
        self.dot(self)
    }

    /// |v|.
    #[inline(always)]
    pub fn length(self) -> F {
        self.dot(self).sqrt()
    }

    /// v / |v| (as v · (1/|v|)).
    #[inline(always)]
    pub fn normalize(self) -> V3<F> {
        self * (F::splat(1.0) / self.length())
    }

    /// Two unit vectors that make an orthonormal basis with this unit vector (Duff et al.
    /// 2017, "Building an Orthonormal Basis, Revisited").
    #[inline(always)]
    pub fn basis(self) -> (V3<F>, V3<F>) {
        let n = self;
        let one = F::splat(1.0);
        let sign = one.copysign(n.z);
        let a = -one / (sign + n.z);
        let b = n.x * n.y * a;
        (
            V3::new(one + sign * n.x * n.x * a, sign * b, -sign * n.x),
            V3::new(b, sign + n.y * n.y * a, -n.y),
        )
    }

    /// max(|x|, |y|, |z|).
    #[inline(always)]
    pub fn abs_max(self) -> F {
        self.x.abs().max(self.y.abs()).max(self.z.abs())
    }

    /// `t` where `m` is set, `f` elsewhere.
    #[inline(always)]
    pub fn select(m: F::Mask, t: V3<F>, f: V3<F>) -> V3<F> {
        V3::new(
            F::select(m, t.x, f.x),
            F::select(m, t.y, f.y),
            F::select(m, t.z, f.z),
        )
    }

    /// Every coordinate finite.
    #[inline(always)]
    pub fn is_finite(self) -> F::Mask {
        self.x.is_finite() & self.y.is_finite() & self.z.is_finite()
    }

    /// The lanes where `m` is set are `t`.
    #[inline(always)]
    pub fn set_where(&mut self, m: F::Mask, t: V3<F>) {
        if m.any() {
            *self = V3::select(m, t, *self);
        }
    }
}

impl From<Vec3> for V3<f32> {
    #[inline(always)]
    fn from(v: Vec3) -> V3<f32> {
        V3::new(v.x, v.y, v.z)
    }
}

impl From<V3<f32>> for Vec3 {
    #[inline(always)]
    fn from(v: V3<f32>) -> Vec3 {
        Vec3::new(v.x, v.y, v.z)
    }
}

impl<F: Float> Add for V3<F> {
    type Output = V3<F>;
    #[inline(always)]
    fn add(self, o: V3<F>) -> V3<F> {
        V3::new(self.x + o.x, self.y + o.y, self.z + o.z)
    }
}

impl<F: Float> AddAssign for V3<F> {
    #[inline(always)]
    fn add_assign(&mut self, o: V3<F>) {
        *self = *self + o;
    }
}

impl<F: Float> Sub for V3<F> {
    type Output = V3<F>;
    #[inline(always)]
    fn sub(self, o: V3<F>) -> V3<F> {
        V3::new(self.x - o.x, self.y - o.y, self.z - o.z)
    }
}

impl<F: Float> Neg for V3<F> {
    type Output = V3<F>;
    #[inline(always)]
    fn neg(self) -> V3<F> {
        V3::new(-self.x, -self.y, -self.z)
    }
}

impl<F: Float> Mul<F> for V3<F> {
    type Output = V3<F>;
    #[inline(always)]
    fn mul(self, s: F) -> V3<F> {
        V3::new(self.x * s, self.y * s, self.z * s)
    }
}

impl<F: Float> Div<F> for V3<F> {
    type Output = V3<F>;
    #[inline(always)]
    fn div(self, s: F) -> V3<F> {
        V3::new(self.x / s, self.y / s, self.z / s)
    }
}
