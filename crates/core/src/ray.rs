//! The ray every tracer and hardware model consumes.

use crate::math::Vec3;

/// A ray `origin + t · direction` for `t` in `[tmin, tmax]`.
///
/// The direction need not be normalised: `t` is measured in units of its length, as in the
/// `rays.bin` query format. `tmax` may be `+inf`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    pub origin: Vec3,
    pub direction: Vec3,
    pub tmin: f32,
    pub tmax: f32,
}

impl Ray {
    #[inline(always)]
    pub fn new(origin: Vec3, direction: Vec3, tmin: f32, tmax: f32) -> Self {
        Ray {
            origin,
            direction,
            tmin,
            tmax,
        }
    }
    #[inline(always)]
    pub fn at(&self, t: f32) -> Vec3 {
        self.origin + self.direction * t
    }
    /// A ray whose fields are all finite (tmax may be +inf) and whose direction is non-zero:
    /// the precondition of every traversal kernel. Query files are checked with this.
    pub fn is_valid(&self) -> bool {
        self.origin.is_finite()
            && self.direction.is_finite()
            && self.direction.length_squared() > 0.0
            && self.tmin.is_finite()
            && !self.tmax.is_nan()
            && self.tmin <= self.tmax
    }
}
