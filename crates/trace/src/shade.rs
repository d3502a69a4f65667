//! The shading kernels' arithmetic, generic over the scalar.
//!
//! [`crate::workload`] calls these with `f32`; [`crate::ops`] runs them on a counting scalar
//! to publish each kernel's operation mix. One function per [`crate::Kernel`] that does
//! floating-point work on the hit.

use crate::sampling;
use rtsim_core::{Real, Vec3};
use std::f32::consts::FRAC_1_PI;

/// The geometric normal of triangle `t`, facing against `dir`, and the hit point at
/// barycentrics (`u`, `v`) pushed off the surface by `eps` along it
/// ([`crate::Kernel::Surface`]). The point is interpolated from the vertices rather than
/// `o + t·d`: more precise far from the origin.
#[inline(always)]
pub fn surface<R: Real>(t: &[Vec3<R>; 3], u: R, v: R, dir: Vec3<R>, eps: R) -> (Vec3<R>, Vec3<R>) {
    let mut n = (t[1] - t[0]).cross(t[2] - t[0]).normalized();
    if n.dot(dir) > R::from_f32(0.0) {
        n = -n;
    }
    let p = t[0] * (R::from_f32(1.0) - u - v) + t[1] * u + t[2] * v;
    (n, p + n * eps)
}

/// Unshadowed Lambertian response at `p` (normal `n`, `albedo`) to a point light
/// ([`crate::Kernel::DirectLight`]).
#[inline(always)]
pub fn direct_unshadowed<R: Real>(
    light: Vec3<R>,
    intensity: Vec3<R>,
    p: Vec3<R>,
    n: Vec3<R>,
    albedo: Vec3<R>,
) -> Vec3<R> {
    let l = light - p;
    let d2 = l.length_squared().max(R::from_f32(f32::MIN_POSITIVE));
    let cos = (n.dot(l) / d2.sqrt()).max(R::from_f32(0.0));
    albedo.mul_elem(intensity) * (R::from_f32(FRAC_1_PI) * cos / d2)
}

/// Headlight shading of a primary hit: albedo scaled by the cosine to the viewer, plus
/// emission ([`crate::Kernel::Headlight`]).
#[inline(always)]
pub fn headlight<R: Real>(albedo: Vec3<R>, emission: Vec3<R>, n: Vec3<R>, dir: Vec3<R>) -> Vec3<R> {
    albedo * (R::from_f32(0.2) + R::from_f32(0.8) * n.dot(-dir).max(R::from_f32(0.0))) + emission
}

/// The mirror direction of `d` about `n` ([`crate::Kernel::Reflect`]).
#[inline(always)]
pub fn reflect<R: Real>(d: Vec3<R>, n: Vec3<R>) -> Vec3<R> {
    d - n * (R::from_f32(2.0) * d.dot(n))
}

/// The direction of a shadow ray from `p` to the light, reaching it at t = 1
/// ([`crate::Kernel::ShadowRay`]).
#[inline(always)]
pub fn shadow_direction<R: Real>(light: Vec3<R>, p: Vec3<R>) -> Vec3<R> {
    light - p
}

/// A normalised camera direction through image position (x, y) ([`crate::Kernel::CameraRay`]);
/// `tan_half` and `aspect` are per-frame constants.
#[inline(always)]
pub fn camera_ray_direction<R: Real>(
    basis: &(Vec3<R>, Vec3<R>, Vec3<R>),
    tan_half: R,
    aspect: R,
    x: R,
    y: R,
    width: R,
    height: R,
) -> Vec3<R> {
    rtsim_scene::camera_direction(basis, tan_half, aspect, x, y, width, height).normalized()
}

/// A cosine-weighted bounce direction around `n` from two uniform numbers
/// ([`crate::Kernel::CosineBounce`]; the random numbers are drawn separately).
#[inline(always)]
pub fn cosine_bounce<R: Real>(n: Vec3<R>, u: R, v: R) -> Vec3<R> {
    sampling::cosine_hemisphere(n, u, v)
}
