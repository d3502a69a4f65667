//! Ray–box slab test (Kay & Kajiya 1986; Williams et al. 2005), the TRaX/STRaTA box kernel:
//! 6 multiplies and 6 subtracts plus comparisons per box (STRaTA §3.3).

use rtsim_core::{Aabb, Ray, Real, Vec3};

/// Per-ray data of the slab test: the origin and the inverse direction.
///
/// A zero direction component gives an inverse of ±`f32::MAX` rather than ±infinity, so a ray
/// starting exactly on a slab plane and running parallel to it computes `0 · MAX = 0` instead
/// of `0 · inf = NaN`: it counts as inside that slab, which is conservative (never a false miss).
#[derive(Clone, Copy, Debug)]
pub struct RayBox {
    pub origin: Vec3,
    pub inv_dir: Vec3,
}

impl RayBox {
    #[inline(always)]
    pub fn new(ray: &Ray) -> Self {
        RayBox {
            origin: ray.origin,
            inv_dir: inverse_direction(ray.direction),
        }
    }
}

/// The slab test's inverse direction (the per-ray setup of box testing): `1/d` per
/// component, ±`f32::MAX` where that is not finite.
#[inline(always)]
pub fn inverse_direction<R: Real>(d: Vec3<R>) -> Vec3<R> {
    let inv = |d: R| {
        let r = R::from_f32(1.0) / d;
        if r.is_finite() {
            r
        } else {
            R::from_f32(f32::MAX).copysign(d)
        }
    };
    Vec3::xyz(inv(d.x), inv(d.y), inv(d.z))
}

/// Entry distance of the ray into `b` within `[tmin, tmax]`, or `None` on a miss.
#[inline(always)]
pub fn slab_test(r: &RayBox, b: &Aabb, tmin: f32, tmax: f32) -> Option<f32> {
    box_entry(r.origin, r.inv_dir, b.min, b.max, tmin, tmax)
}

/// The slab test, generic over the scalar: 6 subtractions, 6 multiplies, 12 min/max and one
/// comparison (STRaTA §3.3's count).
#[inline(always)]
pub fn box_entry<R: Real>(
    o: Vec3<R>,
    inv: Vec3<R>,
    min: Vec3<R>,
    max: Vec3<R>,
    tmin: R,
    tmax: R,
) -> Option<R> {
    let t0x = (min.x - o.x) * inv.x;
    let t1x = (max.x - o.x) * inv.x;
    let t0y = (min.y - o.y) * inv.y;
    let t1y = (max.y - o.y) * inv.y;
    let t0z = (min.z - o.z) * inv.z;
    let t1z = (max.z - o.z) * inv.z;
    let near = t0x.min(t1x).max(t0y.min(t1y)).max(t0z.min(t1z)).max(tmin);
    let far = t0x.max(t1x).min(t0y.max(t1y)).min(t0z.max(t1z)).min(tmax);
    if near <= far { Some(near) } else { None }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn unit_box() -> Aabb {
        Aabb::new(Vec3::ZERO, Vec3::ONE)
    }

    #[test]
    fn hits_from_outside() {
        let ray = Ray::new(
            Vec3::new(-1.0, 0.5, 0.5),
            Vec3::new(1.0, 0.0, 0.0),
            0.0,
            f32::INFINITY,
        );
        assert_eq!(
            slab_test(&RayBox::new(&ray), &unit_box(), 0.0, f32::INFINITY),
            Some(1.0)
        );
    }

    #[test]
    fn misses_beside() {
        let ray = Ray::new(
            Vec3::new(-1.0, 1.5, 0.5),
            Vec3::new(1.0, 0.0, 0.0),
            0.0,
            f32::INFINITY,
        );
        assert_eq!(
            slab_test(&RayBox::new(&ray), &unit_box(), 0.0, f32::INFINITY),
            None
        );
    }

    #[test]
    fn inside_enters_at_tmin() {
        let ray = Ray::new(
            Vec3::splat(0.5),
            Vec3::new(0.3, -1.0, 0.2),
            0.0,
            f32::INFINITY,
        );
        assert_eq!(
            slab_test(&RayBox::new(&ray), &unit_box(), 0.0, f32::INFINITY),
            Some(0.0)
        );
    }

    #[test]
    fn respects_tmax() {
        let ray = Ray::new(
            Vec3::new(-1.0, 0.5, 0.5),
            Vec3::new(1.0, 0.0, 0.0),
            0.0,
            0.5,
        );
        assert_eq!(slab_test(&RayBox::new(&ray), &unit_box(), 0.0, 0.5), None);
    }

    #[test]
    fn parallel_ray_on_face_plane_is_not_nan() {
        // Origin on the x = 0 face plane, direction parallel to it: conservative hit.
        let ray = Ray::new(
            Vec3::new(0.0, -1.0, 0.5),
            Vec3::new(0.0, 1.0, 0.0),
            0.0,
            f32::INFINITY,
        );
        assert_eq!(
            slab_test(&RayBox::new(&ray), &unit_box(), 0.0, f32::INFINITY),
            Some(1.0)
        );
        // Parallel and outside the slab: miss.
        let ray = Ray::new(
            Vec3::new(-0.1, -1.0, 0.5),
            Vec3::new(0.0, 1.0, 0.0),
            0.0,
            f32::INFINITY,
        );
        assert_eq!(
            slab_test(&RayBox::new(&ray), &unit_box(), 0.0, f32::INFINITY),
            None
        );
    }

    #[test]
    fn flat_box_is_hit() {
        let flat = Aabb::new(Vec3::new(0.0, 0.0, 0.5), Vec3::new(1.0, 1.0, 0.5));
        let ray = Ray::new(
            Vec3::new(0.5, 0.5, -1.0),
            Vec3::new(0.0, 0.0, 1.0),
            0.0,
            f32::INFINITY,
        );
        assert_eq!(
            slab_test(&RayBox::new(&ray), &flat, 0.0, f32::INFINITY),
            Some(1.5)
        );
    }
}
