//! A four-lane box for the builders' hot loops.
//!
//! `Aabb`'s `f32::min`/`max` carry NaN handling that keeps them from compiling to single
//! `minps`/`maxps` instructions; profiling the binned build of Sibenik put about a fifth of the
//! time there. The builders only see finite coordinates (checked on entry), so plain
//! compare-and-select is exact here. Lane 3 is ignored by every query (the binned builder
//! keeps a triangle id in it).

use rtsim_core::{Aabb, Vec3};

#[derive(Clone, Copy, Debug)]
#[repr(C, align(16))]
pub(crate) struct Box4 {
    pub lo: [f32; 4],
    pub hi: [f32; 4],
}

impl Box4 {
    pub const EMPTY: Box4 = Box4 {
        lo: [f32::INFINITY; 4],
        hi: [f32::NEG_INFINITY; 4],
    };

    #[inline(always)]
    pub fn from_aabb(b: &Aabb) -> Self {
        Box4 {
            lo: [b.min.x, b.min.y, b.min.z, 0.0],
            hi: [b.max.x, b.max.y, b.max.z, 0.0],
        }
    }

    #[inline(always)]
    pub fn to_aabb(self) -> Aabb {
        if self.lo[0] > self.hi[0] {
            return Aabb::EMPTY;
        }
        Aabb::new(
            Vec3::new(self.lo[0], self.lo[1], self.lo[2]),
            Vec3::new(self.hi[0], self.hi[1], self.hi[2]),
        )
    }

    #[inline(always)]
    pub fn union(self, o: Box4) -> Box4 {
        let mut r = self;
        for i in 0..4 {
            r.lo[i] = if o.lo[i] < r.lo[i] { o.lo[i] } else { r.lo[i] };
            r.hi[i] = if o.hi[i] > r.hi[i] { o.hi[i] } else { r.hi[i] };
        }
        r
    }

    /// Grow by a point given as four lanes.
    #[inline(always)]
    pub fn grow(&mut self, p: [f32; 4]) {
        *self = self.union(Box4 { lo: p, hi: p });
    }

    /// Surface area (lanes 0..3), 0 for the empty box; the same formula as
    /// `Aabb::surface_area`.
    #[inline(always)]
    pub fn surface_area(&self) -> f32 {
        let e = |i: usize| {
            let d = self.hi[i] - self.lo[i];
            // The empty box has −inf extents; clamping makes its area 0 without a branch.
            if d > 0.0 { d } else { 0.0 }
        };
        let (x, y, z) = (e(0), e(1), e(2));
        2.0 * (x * y + y * z + z * x)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn matches_aabb() {
        let a = Aabb::new(Vec3::new(-1.0, 2.0, 0.5), Vec3::new(3.0, 2.5, 4.0));
        let b = Aabb::new(Vec3::new(0.0, -3.0, 1.0), Vec3::new(1.0, 0.0, 9.0));
        let u = Box4::from_aabb(&a).union(Box4::from_aabb(&b));
        assert_eq!(u.to_aabb(), a.union(b));
        assert_eq!(u.surface_area(), a.union(b).surface_area());
        assert_eq!(Box4::EMPTY.surface_area(), 0.0);
        assert_eq!(Box4::EMPTY.to_aabb(), Aabb::EMPTY);
        assert_eq!(Box4::EMPTY.union(Box4::from_aabb(&a)).to_aabb(), a);
        // A flat box has area from its two non-zero extents.
        let flat = Aabb::new(Vec3::ZERO, Vec3::new(2.0, 3.0, 0.0));
        assert_eq!(Box4::from_aabb(&flat).surface_area(), 12.0);
    }
}
