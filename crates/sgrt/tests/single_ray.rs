//! One ray through one TRV and the IST takes the hand-computed number of cycles and steps,
//! in both organisations (docs/SGRT.md works the same example).
//!
//! The scene: two triangles side by side (leaves of one triangle: a root over two leaves);
//! the camera ray hits the left one only. Its steps (the `short-stack` stepper): root box
//! (TRV_AABB, reads the root's line 0), the root's record (TRV_PRE, line 0 again), the child
//! pair (TRV_AABB, line 1: one child hit, nothing pushed), the hit leaf's record (TRV_PRE, line
//! 1), one triangle (IST, its Wald record), done. Caches start cold; memory answers every line
//! `M` cycles after it arrives.

mod common;

use common::*;
use rtsim_core::Vec3;
use rtsim_scene::{Camera, Material, PointLight, Scene};
use rtsim_sgrt::{Engine, Organisation, SgrtConfig};
use rtsim_trace::WorkloadKind;

const M: u64 = 100;

fn two_triangles() -> Scene {
    let tri = |x0: f32| {
        [
            Vec3::new(x0, -1.0, 0.0),
            Vec3::new(x0 + 2.0, -1.0, 0.0),
            Vec3::new(x0 + 1.0, 1.0, 0.0),
        ]
    };
    Scene {
        name: "two".into(),
        triangles: vec![tri(-3.0), tri(1.0)],
        material_ids: vec![0, 0],
        materials: vec![Material::default_grey()],
        camera: Camera {
            eye: Vec3::new(-2.0, 0.0, 5.0),
            direction: Vec3::new(0.0, 0.0, -1.0),
            up: Vec3::new(0.0, 1.0, 0.0),
            fov_y_deg: 40.0,
        },
        viewpoints: Vec::new(),
        light: PointLight {
            position: Vec3::new(0.0, 0.0, 5.0),
            intensity: Vec3::ONE,
        },
        workload_defaults: Default::default(),
        files: Vec::new(),
        report: Default::default(),
    }
}

/// (cycles from dispatch to leaving the T&I unit, TRV steps, active steps, passes, IST
/// steps) of the one camera ray.
fn one_ray(org: Organisation) -> (u64, u64, u64, u64, u64) {
    let s = setup_leaves(two_triangles(), WorkloadKind::Primary, 1, 1, 1, 8, 1);
    assert_eq!(s.tracer.bvh().nodes.len(), 3, "a root over two leaves");
    let c = SgrtConfig {
        cores: 1,
        trvs: 1,
        shader: false,
        organisation: org,
        ..SgrtConfig::default()
    };
    let r = run_pixels(&s, &c, Engine::Fast, vec![0], fixed(&c, M));
    let (px, _) = functional(&s);
    assert_eq!(r.pixels[0].color, px[0].color);
    let k = &r.stats.total.kinds[0];
    assert_eq!((k.rays, k.hits), (1, 1));
    (
        k.latency_cycles,
        k.trv_steps,
        k.trv_active_steps,
        k.trv_passes,
        k.ist_steps,
    )
}

#[test]
fn pptrv_single_ray_cycles_and_steps() {
    // Dispatched at cycle 1 (the feeder writes the ray buffer at 0, visible at 1). Queues
    // take 1 cycle, L1 hit 1, L2 20, memory M; TRV_PRE 1, TRV_AABB 9, IST 37.
    // Root box: lookup at 2 misses both levels: L2 at 3, memory at 23, line back at
    // tf = 23 + M; enters TRV_AABB at tf, leaves at tf + 1 + 9.
    let tf = 23 + M;
    // Root record: TRV_PRE queue visible at tf + 11, L1 hit, leaves at tf + 11 + 1 + 1.
    // Child pair: TRV_AABB at tf + 14 misses (line 1): L2 at + 15, memory at + 35, back at
    // tg = tf + 35 + M; leaves at tg + 10.
    let tg = tf + 35 + M;
    // Leaf record: TRV_PRE at tg + 11 (hit), leaves at tg + 13 for the IST, visible at tg +
    // 14: its L1 misses straight to memory (tg + 15), back at th = tg + 15 + M, leaves the
    // IST at th + 1 + 37, done.
    let th = tg + 15 + M;
    let done = th + 38;
    assert_eq!(done - 1, 110 + 3 * M);
    assert_eq!(
        one_ray(Organisation::Pptrv),
        (done - 1, 4, 4, 4, 1),
        "latency, steps, active, passes, IST steps"
    );
}

#[test]
fn sptrv_single_ray_cycles_and_steps() {
    // One deep pipeline: memory stage 1, PRE 1, AABB 9, POST 2 = 13 cycles a pass, every
    // pass three steps. Root box pass: lookup at 2 misses, back at tf = 23 + M, leaves at
    // tf + 13; root record pass: visible at tf + 14, hit, leaves at tf + 27; child pair pass:
    // visible at tf + 28, misses (L2 at + 29, memory at + 49), back at tg = tf + 49 + M,
    // leaves at tg + 13; leaf record pass: visible at tg + 14, hit, leaves at tg + 27 for
    // the IST, visible at tg + 28, memory at tg + 29, back at th = tg + 29 + M, leaves at
    // th + 38.
    let tf = 23 + M;
    let tg = tf + 49 + M;
    let th = tg + 29 + M;
    let done = th + 38;
    assert_eq!(done - 1, 138 + 3 * M);
    assert_eq!(
        one_ray(Organisation::Sptrv),
        (done - 1, 12, 4, 4, 1),
        "latency, steps, active, passes, IST steps"
    );
}
