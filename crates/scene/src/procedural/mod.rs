//! Built-in procedural scenes that need no files.
//!
//! | name | what | triangles at size 1 | scales with `size` |
//! |---|---|---|---|
//! | `cornell` | the real Cornell box data (two blocks, red/green walls, ceiling light) | 38 | no |
//! | `hairball` | a ball of thin curved tubes, a stand-in for Laine's Hairball | 2,880,000 | tube count |
//! | `vegetation` | a field of grass tufts and leafy plants on a ground plane | 1,000,502 | instance count |
//!
//! Determinism: every tube, tuft and plant draws from its own [`Pcg32`] stream seeded by
//! [`stream_seed`]`(seed, kind, index)`, and writes a fixed slice of the output, so the
//! triangles are bit-identical for a given seed whatever the thread count (generation runs in
//! parallel with rayon).
//!
//! [`Pcg32`]: rtsim_core::Pcg32
//! [`stream_seed`]: rtsim_core::rng::stream_seed

mod cornell;
mod hairball;
mod vegetation;

pub use cornell::cornell;
pub use hairball::{HAIRBALL_TRIANGLES_PER_TUBE, HAIRBALL_TUBES, hairball};
pub use vegetation::{
    PLANT_TRIANGLES, TUFT_TRIANGLES, VEGETATION_PLANTS, VEGETATION_TUFTS, vegetation,
};

use crate::mesh::Mesh;
use crate::{Camera, PointLight, Scene, SceneError, Triangle, auto, triangle_defect};
use rtsim_core::{Pcg32, Vec3};

/// Largest `size`, the bound of the run config's `scene.size` (0, 4], so the library refuses
/// what the CLI would (4 × the hairball is 11.5 M triangles, 415 MB).
pub const MAX_SIZE: f64 = 4.0;

/// The built-in scenes, in `rtsim scenes` order.
pub const BUILTIN_NAMES: [&str; 3] = ["cornell", "hairball", "vegetation"];

/// One line per built-in scene for `rtsim scenes`.
pub fn describe(name: &str) -> Option<&'static str> {
    Some(match name {
        "cornell" => {
            "the real Cornell box data (mm, Z up), ceiling light, camera of simtrax cornell.view"
        }
        "hairball" => {
            "procedural stand-in for Laine's Hairball: 7,500 thin curved tubes in a ball of radius 4.5"
        }
        "vegetation" => "procedural meadow: grass tufts and leafy plants on a 26 x 26 ground plane",
        _ => return None,
    })
}

/// Triangle count of a built-in scene at `size` (known without generating it).
pub fn triangle_count(name: &str, size: f64) -> Option<u64> {
    Some(match name {
        "cornell" => cornell::CORNELL_TRIANGLES,
        "hairball" => hairball::tubes(size) * HAIRBALL_TRIANGLES_PER_TUBE as u64,
        "vegetation" => {
            let (t, p) = vegetation::instances(size);
            vegetation::GROUND_TRIANGLES as u64
                + t * TUFT_TRIANGLES as u64
                + p * PLANT_TRIANGLES as u64
        }
        _ => return None,
    })
}

/// Generate built-in scene `name`; `None` if there is no such scene.
pub fn generate(name: &str, size: f64, seed: u64) -> Option<Result<Scene, SceneError>> {
    if !BUILTIN_NAMES.contains(&name) {
        return None;
    }
    if !(size > 0.0 && size <= MAX_SIZE) {
        return Some(Err(SceneError::Config(rtsim_config::ConfigError::range(
            "scene.size",
            size,
            format!("(0, {MAX_SIZE}]"),
        ))));
    }
    Some(Ok(match name {
        "cornell" => cornell(),
        "hairball" => hairball(size, seed),
        _ => vegetation(size, seed),
    }))
}

/// Count `base × size` instances, at least one (sizes scale instance counts, not detail, so
/// per-instance geometry stays the same at every size).
pub(crate) fn scaled(base: u64, size: f64) -> u64 {
    ((base as f64 * size).round() as u64).max(1)
}

/// A generator for item `index` of kind `kind` (a small constant per scene and item type).
pub(crate) fn item_rng(seed: u64, kind: u64, index: u64) -> Pcg32 {
    Pcg32::new(rtsim_core::rng::stream_seed(seed, kind, index), kind)
}

/// Uniform in [lo, hi).
#[inline]
pub(crate) fn uniform(rng: &mut Pcg32, lo: f32, hi: f32) -> f32 {
    lo + (hi - lo) * rng.next_f32()
}

/// A uniformly distributed unit vector.
pub(crate) fn unit_vector(rng: &mut Pcg32) -> Vec3 {
    let z = uniform(rng, -1.0, 1.0);
    let phi = uniform(rng, 0.0, std::f32::consts::TAU);
    let r = (1.0 - z * z).max(0.0).sqrt();
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// Triangles of a tube of `sides` sides around the polyline `points` (at least two points),
/// written to `out` (`(points.len() - 1) * sides * 2` entries). The cross-section follows the
/// curve with a parallel-transported frame, so the tube does not twist.
pub(crate) fn tube(points: &[Vec3], radius: f32, sides: usize, out: &mut [Triangle]) {
    debug_assert!(points.len() >= 2 && sides >= 3);
    debug_assert_eq!(out.len(), (points.len() - 1) * sides * 2);
    let last = points.len() - 1;
    let tangent = |i: usize| (points[(i + 1).min(last)] - points[i.saturating_sub(1)]).normalized();
    let mut normal = tangent(0).orthonormal_basis().0;
    let ring = |i: usize, normal: Vec3, k: usize| {
        let t = tangent(i);
        let b = t.cross(normal);
        let a = std::f32::consts::TAU * k as f32 / sides as f32;
        points[i] + (normal * a.cos() + b * a.sin()) * radius
    };
    let mut o = 0;
    for i in 0..last {
        // Transport the normal to ring i + 1: remove its component along the new tangent.
        let t1 = tangent(i + 1);
        let mut n1 = (normal - t1 * normal.dot(t1)).normalized();
        if n1.length_squared() < 0.5 {
            n1 = t1.orthonormal_basis().0; // tangent turned onto the normal: restart the frame
        }
        for k in 0..sides {
            let k1 = (k + 1) % sides;
            let (a0, a1) = (ring(i, normal, k), ring(i, normal, k1));
            let (b0, b1) = (ring(i + 1, n1, k), ring(i + 1, n1, k1));
            out[o] = [a0, a1, b1];
            out[o + 1] = [a0, b1, b0];
            o += 2;
        }
        normal = n1;
    }
}

/// Assemble a procedural scene: drop defective triangles (none are expected; counted like
/// file input if a parameter change ever creates one) and set the default light intensity.
pub(crate) fn assemble(
    name: &str,
    mesh_triangles: Vec<Triangle>,
    material_ids: Vec<u32>,
    materials: Vec<crate::Material>,
    camera: Camera,
    light_position: Vec3,
) -> Scene {
    let mut mesh = Mesh {
        triangles: Vec::new(),
        material_ids: Vec::new(),
        materials,
        report: Default::default(),
    };
    if mesh_triangles.iter().all(|t| triangle_defect(t).is_none()) {
        mesh.triangles = mesh_triangles;
        mesh.material_ids = material_ids;
    } else {
        for (t, m) in mesh_triangles.into_iter().zip(material_ids) {
            mesh.push(t, m);
        }
    }
    let intensity = auto::light_intensity(&mesh.triangles, light_position);
    Scene {
        name: name.to_string(),
        triangles: mesh.triangles,
        material_ids: mesh.material_ids,
        materials: mesh.materials,
        camera,
        viewpoints: Vec::new(),
        light: PointLight {
            position: light_position,
            intensity,
        },
        workload_defaults: toml::Table::new(),
        files: Vec::new(),
        report: mesh.report,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tube_is_closed_around_a_curve() {
        let pts: Vec<Vec3> = (0..10)
            .map(|i| {
                let a = i as f32 * 0.3;
                Vec3::new(a.cos(), a.sin(), 0.1 * i as f32)
            })
            .collect();
        let mut out = vec![[Vec3::ZERO; 3]; 9 * 3 * 2];
        tube(&pts, 0.05, 3, &mut out);
        for (j, t) in out.iter().enumerate() {
            assert!(triangle_defect(t).is_none());
            // Triangle 2(3i + k) is [a0, a1, b1] of segment i: a0 on ring i, b1 on ring i + 1,
            // each at the tube radius from its centre-line point and across the tangent.
            if j % 2 == 0 {
                let i = j / 6;
                for (v, c) in [(t[0], i), (t[1], i), (t[2], i + 1)] {
                    let off = v - pts[c];
                    assert!((off.length() - 0.05).abs() < 1e-5, "{}", off.length());
                    let tan = (pts[(c + 1).min(9)] - pts[c.saturating_sub(1)]).normalized();
                    assert!(off.dot(tan).abs() < 1e-5);
                }
            }
        }
    }

    #[test]
    fn counts_match_generation() {
        for name in BUILTIN_NAMES {
            let s = generate(name, 0.01, 3).unwrap().unwrap();
            assert_eq!(
                s.triangles.len() as u64,
                triangle_count(name, 0.01).unwrap(),
                "{name}"
            );
            assert_eq!(s.material_ids.len(), s.triangles.len());
            assert_eq!(s.report, Default::default(), "{name}");
            assert!(describe(name).is_some());
        }
        assert!(generate("nope", 1.0, 1).is_none());
        assert!(generate("hairball", 0.0, 1).unwrap().is_err());
        assert!(generate("hairball", f64::NAN, 1).unwrap().is_err());
        assert!(generate("hairball", 1e9, 1).unwrap().is_err());
    }

    #[test]
    fn default_sizes_are_as_documented() {
        assert_eq!(triangle_count("hairball", 1.0), Some(2_880_000));
        assert_eq!(triangle_count("vegetation", 1.0), Some(1_000_502));
        assert_eq!(triangle_count("cornell", 1.0), Some(38));
        // Approximately proportional to size.
        let h = triangle_count("hairball", 0.1).unwrap() as f64;
        assert!((h / 288_000.0 - 1.0).abs() < 0.01);
        let v = triangle_count("vegetation", 0.1).unwrap() as f64;
        assert!((v / 100_050.0 - 1.0).abs() < 0.01);
    }
}
