//! Small-vector math: [`Vec3`], [`Aabb`] and [`Affine`].
//!
//! Everything is `f32`, the precision of the hardware being modelled (TRaX and SGRT both use
//! single-precision units). Operations are plain scalar code that the compiler vectorises.
//! [`Vec3`] is generic over its scalar ([`Real`], default `f32`) so the kernels can also run
//! on a counting scalar.

use crate::real::Real;
use serde::{Deserialize, Serialize};
use std::ops::{Add, AddAssign, Div, Index, IndexMut, Mul, MulAssign, Neg, Sub, SubAssign};

/// A 3-component vector (points, directions, colours), single precision by default. Generic
/// over the scalar so the kernels can run on a counting scalar ([`Real`]); `Vec3` alone means
/// `Vec3<f32>`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[repr(C)]
pub struct Vec3<T = f32> {
    pub x: T,
    pub y: T,
    pub z: T,
}

impl Vec3 {
    pub const ZERO: Vec3 = Vec3::splat(0.0);
    pub const ONE: Vec3 = Vec3::splat(1.0);

    #[inline(always)]
    pub const fn new(x: f32, y: f32, z: f32) -> Self {
        Vec3 { x, y, z }
    }
    #[inline(always)]
    pub const fn splat(v: f32) -> Self {
        Vec3 { x: v, y: v, z: v }
    }
    #[inline(always)]
    pub fn from_array(a: [f32; 3]) -> Self {
        Vec3::new(a[0], a[1], a[2])
    }
    #[inline(always)]
    pub fn to_array(self) -> [f32; 3] {
        [self.x, self.y, self.z]
    }
}

impl<T: Real> Vec3<T> {
    #[inline(always)]
    pub fn xyz(x: T, y: T, z: T) -> Self {
        Vec3 { x, y, z }
    }
    /// Convert an `f32` vector (inputs: records, rays).
    #[inline(always)]
    pub fn from_f32(v: Vec3) -> Self {
        Vec3::xyz(T::from_f32(v.x), T::from_f32(v.y), T::from_f32(v.z))
    }
    /// The `f32` values.
    #[inline(always)]
    pub fn value(self) -> Vec3 {
        Vec3::new(self.x.value(), self.y.value(), self.z.value())
    }
    #[inline(always)]
    pub fn dot(self, o: Vec3<T>) -> T {
        self.x * o.x + self.y * o.y + self.z * o.z
    }
    #[inline(always)]
    pub fn cross(self, o: Vec3<T>) -> Vec3<T> {
        Vec3::xyz(
            self.y * o.z - self.z * o.y,
            self.z * o.x - self.x * o.z,
            self.x * o.y - self.y * o.x,
        )
    }
    #[inline(always)]
    pub fn length_squared(self) -> T {
        self.dot(self)
    }
    #[inline(always)]
    pub fn length(self) -> T {
        self.length_squared().sqrt()
    }
    /// Unit vector in the same direction; the zero vector stays zero.
    #[inline(always)]
    pub fn normalized(self) -> Vec3<T> {
        let l = self.length();
        if l > T::from_f32(0.0) {
            self * (T::from_f32(1.0) / l)
        } else {
            self
        }
    }
    #[inline(always)]
    pub fn min(self, o: Vec3<T>) -> Vec3<T> {
        Vec3::xyz(self.x.min(o.x), self.y.min(o.y), self.z.min(o.z))
    }
    #[inline(always)]
    pub fn max(self, o: Vec3<T>) -> Vec3<T> {
        Vec3::xyz(self.x.max(o.x), self.y.max(o.y), self.z.max(o.z))
    }
    #[inline(always)]
    pub fn mul_elem(self, o: Vec3<T>) -> Vec3<T> {
        Vec3::xyz(self.x * o.x, self.y * o.y, self.z * o.z)
    }
    #[inline(always)]
    pub fn abs(self) -> Vec3<T> {
        Vec3::xyz(self.x.abs(), self.y.abs(), self.z.abs())
    }
    #[inline(always)]
    pub fn max_component(self) -> T {
        self.x.max(self.y).max(self.z)
    }
    #[inline(always)]
    pub fn min_component(self) -> T {
        self.x.min(self.y).min(self.z)
    }
    /// Index (0, 1, 2) of the largest component; ties go to the lower axis.
    #[inline(always)]
    pub fn max_axis(self) -> usize {
        if self.x >= self.y && self.x >= self.z {
            0
        } else if self.y >= self.z {
            1
        } else {
            2
        }
    }
    #[inline(always)]
    pub fn is_finite(self) -> bool {
        self.x.is_finite() && self.y.is_finite() && self.z.is_finite()
    }
    /// Component-wise reciprocal. Division by ±0 gives ±infinity, which the slab test relies on.
    #[inline(always)]
    pub fn recip(self) -> Vec3<T> {
        let one = T::from_f32(1.0);
        Vec3::xyz(one / self.x, one / self.y, one / self.z)
    }
    /// An orthonormal basis (t, b) with `self` (a unit vector) as the third axis
    /// (Duff et al., "Building an Orthonormal Basis, Revisited", JCGT 2017).
    #[inline]
    pub fn orthonormal_basis(self) -> (Vec3<T>, Vec3<T>) {
        let one = T::from_f32(1.0);
        let sign = one.copysign(self.z);
        let a = -one / (sign + self.z);
        let b = self.x * self.y * a;
        (
            Vec3::xyz(one + sign * self.x * self.x * a, sign * b, -sign * self.x),
            Vec3::xyz(b, sign + self.y * self.y * a, -self.y),
        )
    }
}

impl<T> Index<usize> for Vec3<T> {
    type Output = T;
    #[inline(always)]
    fn index(&self, i: usize) -> &T {
        match i {
            0 => &self.x,
            1 => &self.y,
            _ => &self.z,
        }
    }
}
impl<T> IndexMut<usize> for Vec3<T> {
    #[inline(always)]
    fn index_mut(&mut self, i: usize) -> &mut T {
        match i {
            0 => &mut self.x,
            1 => &mut self.y,
            _ => &mut self.z,
        }
    }
}

macro_rules! vec_binop {
    ($tr:ident, $f:ident, $tra:ident, $fa:ident, $op:tt) => {
        impl<T: Real> $tr for Vec3<T> {
            type Output = Vec3<T>;
            #[inline(always)]
            fn $f(self, o: Vec3<T>) -> Vec3<T> {
                Vec3::xyz(self.x $op o.x, self.y $op o.y, self.z $op o.z)
            }
        }
        impl<T: Real> $tra for Vec3<T> {
            #[inline(always)]
            fn $fa(&mut self, o: Vec3<T>) {
                *self = *self $op o;
            }
        }
    };
}
vec_binop!(Add, add, AddAssign, add_assign, +);
vec_binop!(Sub, sub, SubAssign, sub_assign, -);

impl<T: Real> Mul<T> for Vec3<T> {
    type Output = Vec3<T>;
    #[inline(always)]
    fn mul(self, s: T) -> Vec3<T> {
        Vec3::xyz(self.x * s, self.y * s, self.z * s)
    }
}
impl Mul<Vec3> for f32 {
    type Output = Vec3;
    #[inline(always)]
    fn mul(self, v: Vec3) -> Vec3 {
        v * self
    }
}
impl<T: Real> MulAssign<T> for Vec3<T> {
    #[inline(always)]
    fn mul_assign(&mut self, s: T) {
        *self = *self * s;
    }
}
impl<T: Real> Div<T> for Vec3<T> {
    type Output = Vec3<T>;
    #[inline(always)]
    fn div(self, s: T) -> Vec3<T> {
        self * (T::from_f32(1.0) / s)
    }
}
impl<T: Real> Neg for Vec3<T> {
    type Output = Vec3<T>;
    #[inline(always)]
    fn neg(self) -> Vec3<T> {
        Vec3::xyz(-self.x, -self.y, -self.z)
    }
}

/// Axis-aligned bounding box. The empty box has `min = +inf`, `max = -inf`, so growing it by
/// any point gives that point's box.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[repr(C)]
pub struct Aabb {
    pub min: Vec3,
    pub max: Vec3,
}

impl Default for Aabb {
    fn default() -> Self {
        Aabb::EMPTY
    }
}

impl Aabb {
    pub const EMPTY: Aabb = Aabb {
        min: Vec3::splat(f32::INFINITY),
        max: Vec3::splat(f32::NEG_INFINITY),
    };

    #[inline(always)]
    pub fn new(min: Vec3, max: Vec3) -> Self {
        Aabb { min, max }
    }
    #[inline(always)]
    pub fn from_points(points: &[Vec3]) -> Self {
        points.iter().fold(Aabb::EMPTY, |b, &p| b.grown(p))
    }
    #[inline(always)]
    pub fn grown(self, p: Vec3) -> Aabb {
        Aabb::new(self.min.min(p), self.max.max(p))
    }
    #[inline(always)]
    pub fn grow(&mut self, p: Vec3) {
        *self = self.grown(p);
    }
    #[inline(always)]
    pub fn union(self, o: Aabb) -> Aabb {
        Aabb::new(self.min.min(o.min), self.max.max(o.max))
    }
    #[inline(always)]
    pub fn is_empty(&self) -> bool {
        self.min.x > self.max.x || self.min.y > self.max.y || self.min.z > self.max.z
    }
    #[inline(always)]
    pub fn extent(&self) -> Vec3 {
        self.max - self.min
    }
    #[inline(always)]
    pub fn center(&self) -> Vec3 {
        (self.min + self.max) * 0.5
    }
    /// Surface area; 0 for the empty box (the SAH treats it as costless).
    #[inline(always)]
    pub fn surface_area(&self) -> f32 {
        if self.is_empty() {
            return 0.0;
        }
        let e = self.extent();
        2.0 * (e.x * e.y + e.y * e.z + e.z * e.x)
    }
    #[inline(always)]
    pub fn contains(&self, p: Vec3) -> bool {
        p.x >= self.min.x
            && p.x <= self.max.x
            && p.y >= self.min.y
            && p.y <= self.max.y
            && p.z >= self.min.z
            && p.z <= self.max.z
    }
    /// True if `o` lies entirely inside `self` (boundaries included).
    #[inline(always)]
    pub fn contains_box(&self, o: &Aabb) -> bool {
        o.is_empty() || (self.contains(o.min) && self.contains(o.max))
    }
}

/// An affine transform `p' = M p + t` (a 3×3 matrix and a translation), used by scene
/// descriptors to place meshes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Affine {
    /// Row-major 3×3 linear part.
    pub m: [[f32; 3]; 3],
    pub t: Vec3,
}

impl Default for Affine {
    fn default() -> Self {
        Affine::IDENTITY
    }
}

impl Affine {
    pub const IDENTITY: Affine = Affine {
        m: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
        t: Vec3::ZERO,
    };

    pub fn translate(t: Vec3) -> Self {
        Affine {
            t,
            ..Affine::IDENTITY
        }
    }
    pub fn scale(s: Vec3) -> Self {
        Affine {
            m: [[s.x, 0.0, 0.0], [0.0, s.y, 0.0], [0.0, 0.0, s.z]],
            t: Vec3::ZERO,
        }
    }
    /// Rotation by `degrees` about `axis` (right-handed, Rodrigues' formula).
    pub fn rotate(axis: Vec3, degrees: f32) -> Self {
        let a = axis.normalized();
        let (s, c) = degrees.to_radians().sin_cos();
        let t = 1.0 - c;
        Affine {
            m: [
                [
                    t * a.x * a.x + c,
                    t * a.x * a.y - s * a.z,
                    t * a.x * a.z + s * a.y,
                ],
                [
                    t * a.x * a.y + s * a.z,
                    t * a.y * a.y + c,
                    t * a.y * a.z - s * a.x,
                ],
                [
                    t * a.x * a.z - s * a.y,
                    t * a.y * a.z + s * a.x,
                    t * a.z * a.z + c,
                ],
            ],
            t: Vec3::ZERO,
        }
    }
    /// `self ∘ other`: apply `other` first, then `self`.
    pub fn then_after(&self, other: &Affine) -> Affine {
        let mut m = [[0.0f32; 3]; 3];
        for (i, row) in m.iter_mut().enumerate() {
            for (j, v) in row.iter_mut().enumerate() {
                *v = (0..3).map(|k| self.m[i][k] * other.m[k][j]).sum();
            }
        }
        Affine {
            m,
            t: self.apply_vector(other.t) + self.t,
        }
    }
    #[inline]
    pub fn apply_vector(&self, v: Vec3) -> Vec3 {
        let r = |i: usize| self.m[i][0] * v.x + self.m[i][1] * v.y + self.m[i][2] * v.z;
        Vec3::new(r(0), r(1), r(2))
    }
    #[inline]
    pub fn apply_point(&self, p: Vec3) -> Vec3 {
        self.apply_vector(p) + self.t
    }
    pub fn is_identity(&self) -> bool {
        *self == Affine::IDENTITY
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cross_is_right_handed() {
        let z = Vec3::new(1.0, 0.0, 0.0).cross(Vec3::new(0.0, 1.0, 0.0));
        assert_eq!(z, Vec3::new(0.0, 0.0, 1.0));
    }

    #[test]
    fn empty_box_grows_to_point() {
        let b = Aabb::EMPTY.grown(Vec3::new(1.0, 2.0, 3.0));
        assert_eq!(b.min, b.max);
        assert_eq!(b.surface_area(), 0.0);
        assert_eq!(Aabb::EMPTY.surface_area(), 0.0);
    }

    #[test]
    fn unit_cube_area() {
        let b = Aabb::new(Vec3::ZERO, Vec3::ONE);
        assert_eq!(b.surface_area(), 6.0);
        assert_eq!(b.center(), Vec3::splat(0.5));
    }

    #[test]
    fn rotation_quarter_turn_about_z() {
        let r = Affine::rotate(Vec3::new(0.0, 0.0, 1.0), 90.0);
        let p = r.apply_point(Vec3::new(1.0, 0.0, 0.0));
        assert!((p - Vec3::new(0.0, 1.0, 0.0)).length() < 1e-6);
    }

    #[test]
    fn composition_applies_right_operand_first() {
        let s = Affine::scale(Vec3::splat(2.0));
        let t = Affine::translate(Vec3::new(1.0, 0.0, 0.0));
        // Translate then scale: (0,0,0) -> (1,0,0) -> (2,0,0).
        assert_eq!(
            s.then_after(&t).apply_point(Vec3::ZERO),
            Vec3::new(2.0, 0.0, 0.0)
        );
    }

    #[test]
    fn orthonormal_basis_is_orthonormal() {
        for n in [
            Vec3::new(0.0, 0.0, 1.0),
            Vec3::new(0.0, 0.0, -1.0),
            Vec3::new(0.3, -0.5, 0.2),
        ] {
            let n = n.normalized();
            let (t, b) = n.orthonormal_basis();
            assert!(t.dot(n).abs() < 1e-6 && b.dot(n).abs() < 1e-6 && t.dot(b).abs() < 1e-6);
            assert!((t.length() - 1.0).abs() < 1e-5 && (b.length() - 1.0).abs() < 1e-5);
        }
    }
}
