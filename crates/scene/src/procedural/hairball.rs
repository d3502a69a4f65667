//! `hairball`: a dense ball of thin curved tubes, a stand-in for Samuli Laine's Hairball
//! (2.88 M triangles; no mesh of it is available, see `shared/scenes/README.md`).
//!
//! Each tube is a smooth random curve: it starts at a uniform point in a ball, walks in fixed
//! steps while its curvature vector drifts (curls of radius ~0.5–2), is steered back when it
//! nears the ball's surface, and is swept with a triangular cross-section. The tube count
//! scales with `size`; the per-tube detail does not.

use super::{assemble, item_rng, scaled, tube, uniform, unit_vector};
use crate::{Camera, Material, Scene, Triangle};
use rayon::prelude::*;
use rtsim_core::Vec3;

/// Tubes at size 1: 7,500 × 384 = 2,880,000 triangles, the Hairball's count in the STRaTA
/// paper's scene table ("Hairball (2.88M)", `shared/scenes/README.md`).
pub const HAIRBALL_TUBES: u64 = 7_500;
/// Segments along a tube (assumed: enough for visibly smooth curls at 1024² pixels).
const SEGMENTS: usize = 64;
/// Sides of the cross-section (assumed: 3, the fewest that close a tube; hair is thin).
const SIDES: usize = 3;
/// Triangles per tube.
pub const HAIRBALL_TRIANGLES_PER_TUBE: usize = SEGMENTS * SIDES * 2;

/// Radius of the ball the tubes fill (assumed: the simtrax camera at distance 10 with a
/// half-angle of atan(1/2) sees ±5 at the origin, so a 4.5 ball fills ~90 % of the frame).
const BALL_RADIUS: f32 = 4.5;
/// Tube radius (assumed: ~2 pixels wide at 1024² through the default camera, like hair).
const TUBE_RADIUS: f32 = 0.01;
/// Step between rings: tubes are 6.4 long, 1.4 ball radii (assumed).
const STEP: f32 = 0.1;
/// Curvature range (1 / curl radius) and how fast it drifts per step (assumed).
const CURVATURE: (f32, f32) = (0.5, 2.0);
const CURVATURE_DRIFT: f32 = 0.35;
/// Steering starts at this fraction of the ball radius (assumed).
const STEER_FROM: f32 = 0.8;

/// Stream kind for `item_rng`.
const KIND_TUBE: u64 = 0x4841_4952; // "HAIR"

pub(crate) fn tubes(size: f64) -> u64 {
    scaled(HAIRBALL_TUBES, size)
}

/// Centre line of tube `i`.
fn centre_line(seed: u64, i: u64) -> [Vec3; SEGMENTS + 1] {
    let mut rng = item_rng(seed, KIND_TUBE, i);
    let mut p = loop {
        let q = Vec3::new(
            uniform(&mut rng, -1.0, 1.0),
            uniform(&mut rng, -1.0, 1.0),
            uniform(&mut rng, -1.0, 1.0),
        );
        if q.length_squared() <= 1.0 {
            break q * BALL_RADIUS;
        }
    };
    let mut d = unit_vector(&mut rng);
    let kappa = uniform(&mut rng, CURVATURE.0, CURVATURE.1);
    let mut k = d.cross(unit_vector(&mut rng)).normalized() * kappa;
    let mut pts = [Vec3::ZERO; SEGMENTS + 1];
    for slot in pts.iter_mut() {
        *slot = p;
        // Drift the curvature, keep it across the direction and at its magnitude.
        k += unit_vector(&mut rng) * (kappa * CURVATURE_DRIFT);
        k = (k - d * k.dot(d)).normalized() * kappa;
        d = (d + k * STEP).normalized();
        // Steer back towards the centre near the surface, harder the further out.
        let r = p.length();
        if r > STEER_FROM * BALL_RADIUS {
            let out = p * (1.0 / r);
            let push = (r - STEER_FROM * BALL_RADIUS) / ((1.0 - STEER_FROM) * BALL_RADIUS);
            if d.dot(out) > 0.0 {
                d = (d - out * (d.dot(out) * push.min(1.0) * 1.5)).normalized();
            }
        }
        if d.length_squared() == 0.0 {
            d = unit_vector(&mut rng);
        }
        p += d * STEP;
    }
    pts
}

/// The hairball at `size` (tube count × size) from `seed`. Camera and light from simtrax's
/// `hairball.view` / `hairball.light` (eye (0, −10, 0), gaze +y, up +z, image plane [−1, 1]²
/// at distance 2, so fov 53.13°; light (−10, −10, 8)).
pub fn hairball(size: f64, seed: u64) -> Scene {
    let n = tubes(size) as usize;
    let mut triangles: Vec<Triangle> = vec![[Vec3::ZERO; 3]; n * HAIRBALL_TRIANGLES_PER_TUBE];
    triangles
        .par_chunks_mut(HAIRBALL_TRIANGLES_PER_TUBE)
        .enumerate()
        .for_each(|(i, out)| tube(&centre_line(seed, i as u64), TUBE_RADIUS, SIDES, out));
    let ids = vec![0; triangles.len()];
    let materials = vec![Material {
        name: "hair".into(),
        // Assumed: a light, slightly warm grey so bounces stay bright (many bounces in a tangle).
        albedo: Vec3::new(0.8, 0.75, 0.7),
        emission: Vec3::ZERO,
    }];
    let camera = Camera {
        eye: Vec3::new(0.0, -10.0, 0.0),
        direction: Vec3::new(0.0, 1.0, 0.0),
        up: Vec3::new(0.0, 0.0, 1.0),
        fov_y_deg: 2.0 * 0.5f32.atan().to_degrees(),
    };
    assemble(
        "hairball",
        triangles,
        ids,
        materials,
        camera,
        Vec3::new(-10.0, -10.0, 8.0),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tubes_stay_near_the_ball() {
        let s = hairball(0.02, 7);
        assert_eq!(s.triangles.len(), 150 * HAIRBALL_TRIANGLES_PER_TUBE);
        let b = s.bounds();
        assert!(b.max.max_component() < BALL_RADIUS * 1.15, "{b:?}");
        assert!(b.min.min_component() > -BALL_RADIUS * 1.15, "{b:?}");
        // It fills the ball rather than a shell or a clump: the bounds are nearly the ball's.
        assert!(b.extent().min_component() > 1.6 * BALL_RADIUS, "{b:?}");
        assert!(!b.contains(s.camera.eye) && !b.contains(s.light.position));
    }

    #[test]
    fn deterministic_from_seed() {
        let a = hairball(0.005, 11);
        let b = hairball(0.005, 11);
        let c = hairball(0.005, 12);
        assert_eq!(a.triangles, b.triangles);
        assert_ne!(a.triangles, c.triangles);
        // A tube depends only on (seed, index): a larger size adds tubes after the same ones.
        let big = hairball(0.01, 11);
        assert_eq!(big.triangles[..a.triangles.len()], a.triangles[..]);
    }

    #[test]
    fn independent_of_thread_count() {
        let one = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap()
            .install(|| hairball(0.01, 5));
        let many = rayon::ThreadPoolBuilder::new()
            .num_threads(4)
            .build()
            .unwrap()
            .install(|| hairball(0.01, 5));
        assert_eq!(one.triangles, many.triangles);
    }

    #[test]
    #[ignore = "full size: 2.88 M triangles, ~0.5 s in release"]
    fn full_size_count() {
        let s = hairball(1.0, 1);
        assert_eq!(s.triangles.len(), 2_880_000);
        assert_eq!(s.report, Default::default());
    }
}
