//! Test inputs: generated triangle sets, and the shared scenes read with the real scene
//! loader (`rtsim_scene::load_scene`).
#![allow(dead_code)]

use rtsim_core::{Pcg32, Vec3};
use rtsim_scene::{Scene, SceneRequest, load_scene};
use std::path::PathBuf;

pub type Tri = [Vec3; 3];

/// `n` random triangles in the unit cube, edge lengths up to `size`.
pub fn random_soup(n: usize, seed: u64, size: f32) -> Vec<Tri> {
    let mut r = Pcg32::new(seed, 7);
    let v = |r: &mut Pcg32| Vec3::new(r.next_f32(), r.next_f32(), r.next_f32());
    (0..n)
        .map(|_| {
            let c = v(&mut r);
            let mut d = || (v(&mut r) - Vec3::splat(0.5)) * size;
            [c, c + d(), c + d()]
        })
        .collect()
}

/// A flat `nx × ny` grid of quads (two triangles each) in the plane z = 0.
pub fn grid(nx: usize, ny: usize) -> Vec<Tri> {
    let mut out = Vec::with_capacity(2 * nx * ny);
    for j in 0..ny {
        for i in 0..nx {
            let p = |a: usize, b: usize| Vec3::new(a as f32, b as f32, 0.0);
            out.push([p(i, j), p(i + 1, j), p(i + 1, j + 1)]);
            out.push([p(i, j), p(i + 1, j + 1), p(i, j + 1)]);
        }
    }
    out
}

/// A tessellated unit sphere: `rings × segments` quads split into triangles.
pub fn sphere(rings: usize, segments: usize) -> Vec<Tri> {
    let p = |i: usize, j: usize| {
        let th = std::f32::consts::PI * i as f32 / rings as f32;
        let ph = 2.0 * std::f32::consts::PI * j as f32 / segments as f32;
        Vec3::new(th.sin() * ph.cos(), th.cos(), th.sin() * ph.sin())
    };
    let mut out = Vec::new();
    for i in 0..rings {
        for j in 0..segments {
            let (a, b, c, d) = (p(i, j), p(i + 1, j), p(i + 1, j + 1), p(i, j + 1));
            if i != 0 {
                out.push([a, b, d]);
            }
            if i + 1 != rings {
                out.push([b, c, d]);
            }
        }
    }
    out
}

/// Triangles whose positions shrink geometrically toward the origin: SAH peels them off one
/// or two at a time, so the unconstrained tree is very deep.
pub fn geometric(n: usize) -> Vec<Tri> {
    (0..n)
        .map(|k| {
            let x = 0.99f32.powi(k as i32);
            let e = x * 0.01;
            [
                Vec3::new(x, 0.0, 0.0),
                Vec3::new(x + e, 0.0, 0.0),
                Vec3::new(x, e, e),
            ]
        })
        .collect()
}

/// `n` distinct triangles with the same bounding box, hence the same box centre (the
/// builders' centroid): every one spans the cube's diagonal.
pub fn same_centroid(n: usize) -> Vec<Tri> {
    (0..n)
        .map(|k| {
            let a = (k as f32 * 0.37).sin() * 0.9;
            [
                Vec3::splat(-1.0),
                Vec3::splat(1.0),
                Vec3::new(a, -a, 0.5 * a + 0.25),
            ]
        })
        .collect()
}

/// The shared scene directory, if one is configured: `$RTSIM_SCENE_DIR` when set (it must
/// then hold the scenes), else `../shared/scenes` beside the repository when it exists.
pub fn scene_dir() -> Option<PathBuf> {
    if let Some(d) = std::env::var_os("RTSIM_SCENE_DIR").filter(|d| !d.is_empty()) {
        return Some(PathBuf::from(d));
    }
    let d = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/scenes");
    d.is_dir().then_some(d)
}

/// Shipped scene `name` (a descriptor such as `sibenik`), read by the real scene loader from
/// the shared scene directory. `None` only when no scene directory is configured at all
/// (then the caller skips, and says so). With a directory configured, a missing or unreadable
/// file is a test failure: a scene test must not pass without its scene.
pub fn shared_scene(name: &str) -> Option<Scene> {
    let Some(dir) = scene_dir() else {
        eprintln!(
            "skipping: no scene directory (set RTSIM_SCENE_DIR or put the shared scenes at \
             ../shared/scenes)"
        );
        return None;
    };
    let scene = load_scene(&SceneRequest {
        name,
        size: 1.0,
        seed: 1,
        scene_dir: Some(&dir),
    })
    .unwrap_or_else(|e| panic!("scene `{name}` from {}: {e}", dir.display()));
    Some(scene)
}
