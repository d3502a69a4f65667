//! Automatic camera, light placement and light intensity.
//!
//! Used when a mesh is loaded without a descriptor (`--scene model.ply`), when a descriptor
//! omits `[camera]` or `[light]`, and for the default light intensity of every scene.

use crate::{Camera, Triangle};
use rtsim_core::{Aabb, Vec3};

/// Vertical field of view of an automatic camera (assumed: 45°, a "normal" lens; the shared
/// scenes' suggested cameras use 45–60°).
pub const AUTO_FOV_Y_DEG: f32 = 45.0;

/// Direction from the model's centre towards an automatic camera: in front (+z), a little to
/// the right (+x) and above (+y), the OBJ/PLY convention of +y up and +z towards the viewer
/// (assumed: a three-quarter view shows depth better than a straight-on one).
const AUTO_VIEW_FROM: Vec3 = Vec3::new(0.4, 0.3, 1.0);

/// Direction from the model's centre towards an automatic light: upper left front (assumed:
/// the classic key-light position, so the lit side faces the camera).
const AUTO_LIGHT_FROM: Vec3 = Vec3::new(-0.5, 1.0, 0.8);

/// Extra distance beyond the one that makes the bounding sphere touch the top and bottom of
/// the image (assumed: 5 % margin).
const FRAMING_MARGIN: f32 = 1.05;

/// Most triangles sampled for the median light distance (assumed: 4096 gives the median to
/// about ±1.5 % and costs nothing next to loading).
const INTENSITY_SAMPLES: usize = 4096;

/// Bounding-sphere radius of `bounds` (1 for an empty or point-sized box, so a camera can
/// still be placed).
fn radius(bounds: &Aabb) -> f32 {
    let r = if bounds.is_empty() {
        0.0
    } else {
        0.5 * bounds.extent().length()
    };
    if r > 0.0 && r.is_finite() { r } else { 1.0 }
}

fn centre(bounds: &Aabb) -> Vec3 {
    if bounds.is_empty() {
        Vec3::ZERO
    } else {
        bounds.center()
    }
}

/// A camera outside `bounds` looking at its centre, +y up, with the bounding sphere filling
/// the image height (plus 5 %).
pub fn framing_camera(bounds: &Aabb) -> Camera {
    let (c, r) = (centre(bounds), radius(bounds));
    let half = (AUTO_FOV_Y_DEG.to_radians() * 0.5).sin();
    let eye = c + AUTO_VIEW_FROM.normalized() * (r / half * FRAMING_MARGIN);
    Camera {
        eye,
        direction: c - eye,
        up: Vec3::new(0.0, 1.0, 0.0),
        fov_y_deg: AUTO_FOV_Y_DEG,
    }
}

/// A light position for `bounds`: upper left front, two bounding radii from the centre.
pub fn framing_light(bounds: &Aabb) -> Vec3 {
    centre(bounds) + AUTO_LIGHT_FROM.normalized() * (2.0 * radius(bounds))
}

/// Default light intensity for a light at `position`: π·m² per channel, where m is the median
/// distance from the light to the triangles' centroids (every k-th triangle, at most 4096).
///
/// Why: a white Lambertian surface facing the light at distance d has radiance
/// (1/π)·I/d², so at the median distance this gives radiance 1 — the middle of the tone
/// curve — whatever the scene's units (millimetres for the Cornell box, metres for the
/// bunny). Deterministic: the sample is a fixed stride over scene order.
pub fn light_intensity(triangles: &[Triangle], position: Vec3) -> Vec3 {
    let n = triangles.len();
    if n == 0 {
        return Vec3::splat(std::f32::consts::PI);
    }
    let step = n.div_ceil(INTENSITY_SAMPLES).max(1);
    let mut d: Vec<f32> = triangles
        .iter()
        .step_by(step)
        .map(|t| ((t[0] + t[1] + t[2]) * (1.0 / 3.0) - position).length())
        .filter(|d| d.is_finite())
        .collect();
    if d.is_empty() {
        return Vec3::splat(std::f32::consts::PI);
    }
    let mid = d.len() / 2;
    let (_, &mut m, _) = d.select_nth_unstable_by(mid, f32::total_cmp);
    // A light sitting on most centroids (m = 0) would get no light at all: fall back to 1.
    let m = if m > 0.0 { m } else { 1.0 };
    Vec3::splat(std::f32::consts::PI * m * m)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn framing_camera_sees_the_whole_box() {
        let b = Aabb::new(Vec3::new(-1.0, 0.0, -3.0), Vec3::new(5.0, 2.0, 1.0));
        let cam = framing_camera(&b);
        assert!(!b.contains(cam.eye));
        let (r, u, f) = cam.basis();
        let tan_half = (cam.fov_y_deg.to_radians() * 0.5).tan();
        // Every corner projects inside a square image.
        for i in 0..8 {
            let p = Vec3::new(
                if i & 1 == 0 { b.min.x } else { b.max.x },
                if i & 2 == 0 { b.min.y } else { b.max.y },
                if i & 4 == 0 { b.min.z } else { b.max.z },
            );
            let q = p - cam.eye;
            let z = q.dot(f);
            assert!(z > 0.0);
            assert!((q.dot(r) / z).abs() < tan_half && (q.dot(u) / z).abs() < tan_half);
        }
    }

    #[test]
    fn framing_handles_degenerate_bounds() {
        let cam = framing_camera(&Aabb::EMPTY);
        assert!(cam.eye.is_finite() && cam.direction.length() > 0.0);
        let p = Vec3::new(1.0, 2.0, 3.0);
        let cam = framing_camera(&Aabb::new(p, p));
        assert!(cam.eye.is_finite() && cam.direction.length() > 0.0);
        assert!(framing_light(&Aabb::EMPTY).is_finite());
    }

    #[test]
    fn intensity_uses_median_distance() {
        let tri_at = |x: f32| {
            [
                Vec3::new(x - 0.1, -0.1, 0.0),
                Vec3::new(x + 0.2, -0.1, 0.0),
                Vec3::new(x - 0.1, 0.2, 0.0),
            ]
        };
        // Centroids at x = 1, 2, 100: the median distance from the origin is 2.
        let tris = [tri_at(1.0), tri_at(100.0), tri_at(2.0)];
        let i = light_intensity(&tris, Vec3::ZERO);
        assert!((i.x - std::f32::consts::PI * 4.0).abs() < 1e-4, "{i:?}");
        assert_eq!(i.x, i.z);
        // Scale invariance: the same scene in millimetres gives 1e6 times the intensity.
        let mm: Vec<Triangle> = tris.iter().map(|t| t.map(|v| v * 1000.0)).collect();
        let j = light_intensity(&mm, Vec3::ZERO);
        assert!((j.x / i.x - 1e6).abs() < 1.0);
        assert!(light_intensity(&[], Vec3::ZERO).x > 0.0);
    }
}
