//! `vegetation`: a field of thin grass blades and leafy plants on a ground plane, a stand-in
//! for the STRaTA paper's Vegetation scene (1.1 M triangles; no copy or camera is known,
//! `shared/scenes/README.md`).
//!
//! Z up. A 26 × 26 ground quad carries `tufts` grass tufts (12 curved, tapering blades each)
//! and `plants` (a thin curved stem with 24 folded leaves in a phyllotactic spiral), placed
//! uniformly at random over 25 × 25. Instance counts scale with `size`; their detail does not.

use super::{assemble, item_rng, scaled, tube, uniform};
use crate::{Camera, Material, Scene, Triangle};
use rayon::prelude::*;
use rtsim_core::{Pcg32, Vec3};

/// Tufts and plants at size 1: 7,000 × 84 + 3,125 × 132 + 2 = 1,000,502 triangles, about the
/// STRaTA paper's Vegetation (1.1 M; assumed split: ~60 % grass, ~40 % leafy plants).
pub const VEGETATION_TUFTS: u64 = 7_000;
pub const VEGETATION_PLANTS: u64 = 3_125;

/// Half the side of the planted square (assumed: 25 × 25 units, ~16 instances per unit², a
/// dense meadow in which the ground shows only between the nearest plants).
const FIELD_HALF: f32 = 12.5;
/// Half the side of the ground quad (assumed: a 0.5 margin so no plant stands at the edge).
const GROUND_HALF: f32 = 13.0;
pub(crate) const GROUND_TRIANGLES: usize = 2;

/// Blades per tuft (assumed: a small clump).
const BLADES_PER_TUFT: usize = 12;
/// Points along a blade (assumed: enough for a visible bend); the last is the tip (3 quads +
/// a tip triangle).
const BLADE_POINTS: usize = 4;
const BLADE_TRIANGLES: usize = (BLADE_POINTS - 1) * 2 + 1;
pub const TUFT_TRIANGLES: usize = BLADES_PER_TUFT * BLADE_TRIANGLES;
/// Radius of the disc a tuft's blades grow from, blade height, base width, lean (tip offset
/// over height) — all assumed, the look of a lawn at unit ≈ 1 m.
const TUFT_RADIUS: f32 = 0.08;
const BLADE_HEIGHT: (f32, f32) = (0.25, 0.7);
const BLADE_WIDTH: (f32, f32) = (0.008, 0.02);
const BLADE_LEAN: (f32, f32) = (0.1, 0.6);

/// Stem cross-section sides and segments, leaves per plant, triangles per leaf (assumed: a
/// thin 3-sided stem like the hairball's tubes; a leaf folded along its midrib needs 4).
const STEM_SIDES: usize = 3;
const STEM_SEGMENTS: usize = 6;
const LEAVES: usize = 24;
const LEAF_TRIANGLES: usize = 4;
pub const PLANT_TRIANGLES: usize = STEM_SIDES * STEM_SEGMENTS * 2 + LEAVES * LEAF_TRIANGLES;
/// Plant height, stem radius, leaf length (at the base; shorter up the stem), leaf elevation
/// above horizontal — assumed, a knee-high herb.
const PLANT_HEIGHT: (f32, f32) = (0.5, 1.5);
const STEM_RADIUS: f32 = 0.008;
const LEAF_LENGTH: (f32, f32) = (0.15, 0.3);
const LEAF_ELEVATION_DEG: (f32, f32) = (10.0, 45.0);
/// The golden angle, 137.5°, the usual leaf divergence (phyllotaxis).
const GOLDEN_ANGLE: f32 = 2.399_963;

const KIND_TUFT: u64 = 0x5455_4654; // "TUFT"
const KIND_PLANT: u64 = 0x504c_4e54; // "PLNT"

const GROUND: u32 = 0;
const GRASS: u32 = 1;
const STEM: u32 = 2;
const LEAF: u32 = 3;

pub(crate) fn instances(size: f64) -> (u64, u64) {
    (
        scaled(VEGETATION_TUFTS, size),
        scaled(VEGETATION_PLANTS, size),
    )
}

const Z: Vec3 = Vec3::new(0.0, 0.0, 1.0);

fn field_point(rng: &mut Pcg32) -> Vec3 {
    Vec3::new(
        uniform(rng, -FIELD_HALF, FIELD_HALF),
        uniform(rng, -FIELD_HALF, FIELD_HALF),
        0.0,
    )
}

fn tuft(seed: u64, i: u64, out: &mut [Triangle]) {
    let mut rng = item_rng(seed, KIND_TUFT, i);
    let centre = field_point(&mut rng);
    for blade in out.chunks_exact_mut(BLADE_TRIANGLES) {
        let a = uniform(&mut rng, 0.0, std::f32::consts::TAU);
        let r = TUFT_RADIUS * rng.next_f32().sqrt();
        let base = centre + Vec3::new(r * a.cos(), r * a.sin(), 0.0);
        let h = uniform(&mut rng, BLADE_HEIGHT.0, BLADE_HEIGHT.1);
        let w = uniform(&mut rng, BLADE_WIDTH.0, BLADE_WIDTH.1);
        let lean = uniform(&mut rng, BLADE_LEAN.0, BLADE_LEAN.1);
        let phi = uniform(&mut rng, 0.0, std::f32::consts::TAU);
        let dir = Vec3::new(phi.cos(), phi.sin(), 0.0);
        let side = Vec3::new(-phi.sin(), phi.cos(), 0.0);
        // Quadratic bend: up by h·t, out by lean·h·t²; the width tapers to 0 at the tip.
        let at = |t: f32| base + Z * (h * t) + dir * (lean * h * t * t);
        let edge = |j: usize| {
            let t = j as f32 / BLADE_POINTS as f32;
            let half = 0.5 * w * (1.0 - t);
            (at(t) - side * half, at(t) + side * half)
        };
        let mut o = 0;
        for j in 0..BLADE_POINTS - 1 {
            let ((l0, r0), (l1, r1)) = (edge(j), edge(j + 1));
            blade[o] = [l0, r0, r1];
            blade[o + 1] = [l0, r1, l1];
            o += 2;
        }
        let (l, r) = edge(BLADE_POINTS - 1);
        blade[o] = [l, r, at(1.0)];
    }
}

fn plant(seed: u64, i: u64, out: &mut [Triangle]) {
    let mut rng = item_rng(seed, KIND_PLANT, i);
    let base = field_point(&mut rng);
    let h = uniform(&mut rng, PLANT_HEIGHT.0, PLANT_HEIGHT.1);
    let phi = uniform(&mut rng, 0.0, std::f32::consts::TAU);
    let bend = Vec3::new(phi.cos(), phi.sin(), 0.0) * (0.15 * h);
    let at = |t: f32| base + Z * (h * t) + bend * (t * t);
    let stem: Vec<Vec3> = (0..=STEM_SEGMENTS)
        .map(|j| at(j as f32 / STEM_SEGMENTS as f32))
        .collect();
    let (stem_out, leaves_out) = out.split_at_mut(STEM_SIDES * STEM_SEGMENTS * 2);
    tube(&stem, STEM_RADIUS, STEM_SIDES, stem_out);
    let len0 = uniform(&mut rng, LEAF_LENGTH.0, LEAF_LENGTH.1);
    let a0 = uniform(&mut rng, 0.0, std::f32::consts::TAU);
    for (k, leaf) in leaves_out.chunks_exact_mut(LEAF_TRIANGLES).enumerate() {
        let t = 0.25 + 0.75 * (k as f32 + 0.5) / LEAVES as f32;
        let b = at(t);
        let len = len0 * (1.1 - 0.6 * t);
        let a = a0 + GOLDEN_ANGLE * k as f32;
        let elev = uniform(&mut rng, LEAF_ELEVATION_DEG.0, LEAF_ELEVATION_DEG.1).to_radians();
        let out_dir = Vec3::new(a.cos() * elev.cos(), a.sin() * elev.cos(), elev.sin());
        let side = Vec3::new(-a.sin(), a.cos(), 0.0);
        let normal = out_dir.cross(side);
        let half_w = 0.22 * len;
        // Folded along the midrib: the edges sit a little above the rib; the tip droops.
        let mid = b + out_dir * (0.4 * len);
        let left = mid + side * half_w + normal * (0.15 * half_w);
        let right = mid - side * half_w + normal * (0.15 * half_w);
        let tip = b + out_dir * len - Z * (0.15 * len);
        leaf[0] = [b, mid, left];
        leaf[1] = [b, right, mid];
        leaf[2] = [mid, tip, left];
        leaf[3] = [mid, right, tip];
    }
}

/// The vegetation field at `size` (instance counts × size) from `seed`.
pub fn vegetation(size: f64, seed: u64) -> Scene {
    let (tufts, plants) = instances(size);
    let (tufts, plants) = (tufts as usize, plants as usize);
    let n = GROUND_TRIANGLES + tufts * TUFT_TRIANGLES + plants * PLANT_TRIANGLES;
    let mut triangles: Vec<Triangle> = vec![[Vec3::ZERO; 3]; n];
    let g = GROUND_HALF;
    let c = |x: f32, y: f32| Vec3::new(x, y, 0.0);
    triangles[0] = [c(-g, -g), c(g, -g), c(g, g)];
    triangles[1] = [c(-g, -g), c(g, g), c(-g, g)];
    let (grass, herbs) = triangles[GROUND_TRIANGLES..].split_at_mut(tufts * TUFT_TRIANGLES);
    rayon::join(
        || {
            grass
                .par_chunks_mut(TUFT_TRIANGLES)
                .enumerate()
                .for_each(|(i, out)| tuft(seed, i as u64, out))
        },
        || {
            herbs
                .par_chunks_mut(PLANT_TRIANGLES)
                .enumerate()
                .for_each(|(i, out)| plant(seed, i as u64, out))
        },
    );
    let mut ids = Vec::with_capacity(n);
    ids.extend([GROUND; GROUND_TRIANGLES]);
    ids.resize(GROUND_TRIANGLES + tufts * TUFT_TRIANGLES, GRASS);
    for _ in 0..plants {
        ids.extend([STEM; STEM_SIDES * STEM_SEGMENTS * 2]);
        ids.extend([LEAF; LEAVES * LEAF_TRIANGLES]);
    }
    // Albedos assumed: typical measured reflectances of soil and green foliage.
    let mat = |name: &str, a: Vec3| Material {
        name: name.into(),
        albedo: a,
        emission: Vec3::ZERO,
    };
    let materials = vec![
        mat("ground", Vec3::new(0.3, 0.22, 0.12)),
        mat("grass", Vec3::new(0.25, 0.5, 0.15)),
        mat("stem", Vec3::new(0.35, 0.45, 0.2)),
        mat("leaf", Vec3::new(0.15, 0.4, 0.1)),
    ];
    // Assumed view: 1.8 units high, 2.5 outside the near edge, looking across the field
    // slightly downwards (the image's lower edge meets the ground just inside the field).
    let camera = Camera {
        eye: Vec3::new(0.0, -15.0, 1.8),
        direction: Vec3::new(0.0, 1.0, -0.15),
        up: Z,
        fov_y_deg: 50.0,
    };
    // Assumed: a high light behind the camera's left shoulder, like an afternoon sun.
    let light = Vec3::new(-15.0, -30.0, 40.0);
    assemble("vegetation", triangles, ids, materials, camera, light)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn layout_and_materials() {
        let s = vegetation(0.01, 2);
        let (t, p) = instances(0.01);
        assert_eq!((t, p), (70, 31));
        assert_eq!(
            s.triangles.len(),
            GROUND_TRIANGLES + 70 * TUFT_TRIANGLES + 31 * PLANT_TRIANGLES
        );
        assert_eq!(s.material_of(0).name, "ground");
        assert_eq!(s.material_of(2).name, "grass");
        let first_plant = (GROUND_TRIANGLES + 70 * TUFT_TRIANGLES) as u32;
        assert_eq!(s.material_of(first_plant).name, "stem");
        assert_eq!(s.material_of(first_plant + 36).name, "leaf");
        let b = s.bounds();
        // The ground is at z = 0; stems may root a fraction of their radius into it.
        assert!(b.min.z <= 0.0 && b.min.z > -STEM_RADIUS, "{b:?}");
        assert!(b.max.z > 0.5 && b.max.z < 2.0, "{b:?}");
        assert!(b.min.x >= -GROUND_HALF && b.max.x <= GROUND_HALF);
        // Blades are thin: every grass triangle is narrower than the widest blade.
        for tri in &s.triangles[2..2 + 70 * TUFT_TRIANGLES] {
            let min_edge = (0..3)
                .map(|i| (tri[i] - tri[(i + 1) % 3]).length())
                .fold(f32::INFINITY, f32::min);
            assert!(min_edge <= BLADE_WIDTH.1 + 1e-6);
        }
        // The camera stands outside the field, above the ground, looking over it.
        assert!(s.camera.eye.z > b.max.z && s.camera.eye.y < b.min.y);
    }

    #[test]
    fn deterministic_from_seed() {
        let a = vegetation(0.005, 1);
        assert_eq!(a.triangles, vegetation(0.005, 1).triangles);
        assert_ne!(a.triangles, vegetation(0.005, 2).triangles);
    }

    #[test]
    #[ignore = "full size: 1 M triangles"]
    fn full_size_count() {
        let s = vegetation(1.0, 1);
        assert_eq!(s.triangles.len(), 1_000_502);
        assert_eq!(s.report, Default::default());
    }
}
