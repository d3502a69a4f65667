//! Test inputs: generated triangle sets and a throwaway reader for the shared OBJ scenes.
//!
//! THROWAWAY: `load_obj_zst` exists only until `rtsim_scene::load_scene` lands; it reads `v`
//! and `f` lines (fan-triangulating polygons) and ignores everything else.
#![allow(dead_code)]

use rtsim_core::{Pcg32, Vec3};
use std::io::{BufRead, BufReader};
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

/// The shared scene directory: `$RTSIM_SCENE_DIR`, else `../shared/scenes` beside the
/// repository.
pub fn scene_dir() -> PathBuf {
    if let Some(d) = std::env::var_os("RTSIM_SCENE_DIR").filter(|d| !d.is_empty()) {
        return PathBuf::from(d);
    }
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/scenes")
}

/// THROWAWAY OBJ reader (see the module docs): the triangles with non-zero area (the scene
/// loader drops the others) and the number of triangles in the file. `None` if the file is
/// missing.
pub fn load_obj_zst(rel: &str) -> Option<(Vec<Tri>, usize)> {
    let path = scene_dir().join(rel);
    let file = std::fs::File::open(&path).ok()?;
    let reader = BufReader::new(zstd::Decoder::new(file).expect("zstd stream"));
    let mut verts: Vec<Vec3> = Vec::new();
    let mut tris = Vec::new();
    let mut in_file = 0;
    for line in reader.lines() {
        let line = line.expect("readable OBJ");
        let mut it = line.split_whitespace();
        match it.next() {
            Some("v") => {
                let c: Vec<f32> = it.take(3).map(|s| s.parse().expect("number")).collect();
                verts.push(Vec3::new(c[0], c[1], c[2]));
            }
            Some("f") => {
                let idx: Vec<usize> = it
                    .map(|s| {
                        let i: i64 = s.split('/').next().unwrap().parse().expect("index");
                        if i < 0 {
                            (verts.len() as i64 + i) as usize
                        } else {
                            i as usize - 1
                        }
                    })
                    .collect();
                for k in 1..idx.len() - 1 {
                    in_file += 1;
                    let t = [verts[idx[0]], verts[idx[k]], verts[idx[k + 1]]];
                    // The scene loader drops zero-area triangles; do the same.
                    if (t[1] - t[0]).cross(t[2] - t[0]).length_squared() > 0.0 {
                        tris.push(t);
                    }
                }
            }
            _ => {}
        }
    }
    Some((tris, in_file))
}
