//! The stepped traversals on every shared scene: `stack` stepped against the closed loop (hits
//! and counters identical), `bit-stack` and `short-stack` against `stack` (the same closest hit
//! up to exact-distance ties; the same any-hit answer), for random rays through the scene and
//! camera rays, with and without treelets.

mod common;
use rtsim_bvh::{BvhConfig, ImageExtras, Layout, MemoryImage, MemoryLayoutConfig, NodeOrder};
use rtsim_core::Ray;
use rtsim_scene::Scene;
use rtsim_trace::traverse::SlotHit;
use rtsim_trace::{Query, RayCounters, Step, TraceConfig, Tracer, Traversal};

fn rays_for(scene: &Scene, n: usize, seed: u64) -> Vec<Ray> {
    common::scene_rays(scene, n, seed, 17, true, true)
}

fn stepped(t: &Tracer, ray: &Ray, q: Query) -> (SlotHit, RayCounters) {
    let mut c = RayCounters::default();
    let mut st = t.start(ray, q);
    loop {
        if let Step::Done(h) = t.step(&mut st, &mut c) {
            return (h, c);
        }
    }
}

/// Same slot (then bit-identical t, u, v), or a tie at exactly the same distance.
fn same_hit(a: &SlotHit, b: &SlotHit) -> bool {
    if a.slot == b.slot {
        return a.t.to_bits() == b.t.to_bits()
            && (!a.is_hit() || (a.u.to_bits(), a.v.to_bits()) == (b.u.to_bits(), b.v.to_bits()));
    }
    a.is_hit() && b.is_hit() && a.t == b.t
}

fn check(name: &str, n: usize) {
    let scene = common::shared_scene(name);
    // 32 levels, so the bit stack can run the same BVH.
    let bvh_cfg = BvhConfig {
        max_depth: 32,
        ..BvhConfig::default()
    };
    let bvh = rtsim_bvh::build(&scene.triangles, &bvh_cfg, NodeOrder::DepthFirst).unwrap();
    let layout = MemoryLayoutConfig {
        layout: Layout::Treelets,
        ..MemoryLayoutConfig::default()
    };
    let image = MemoryImage::build(&bvh, &layout, &ImageExtras::default()).unwrap();
    let treelets = image.treelets().unwrap().node_treelet.clone();
    let rays = rays_for(&scene, n, 29);
    let tracer = |traversal, entries| {
        let cfg = TraceConfig {
            traversal,
            short_stack_entries: entries,
            ..TraceConfig::default()
        };
        let mut t = Tracer::new(&scene.triangles, bvh.clone(), &cfg).unwrap();
        t.set_treelets(treelets.clone()).unwrap();
        t
    };
    let stack = tracer(Traversal::Stack, 8);
    let others = [
        tracer(Traversal::BitStack, 8),
        tracer(Traversal::ShortStack, 8),
        tracer(Traversal::ShortStack, 2),
    ];
    let mut ties = 0;
    for ray in &rays {
        for q in [Query::Closest, Query::Any] {
            let mut c = RayCounters::default();
            let closed = stack.trace_slots(ray, q, &mut c);
            let (h, cs) = stepped(&stack, ray, q);
            assert_eq!(
                (h.slot, h.t.to_bits(), h.u.to_bits(), h.v.to_bits()),
                (
                    closed.slot,
                    closed.t.to_bits(),
                    closed.u.to_bits(),
                    closed.v.to_bits()
                ),
                "{name}: stepped stack differs from the closed loop on {ray:?}"
            );
            assert_eq!(c, cs, "{name}: counters differ on {ray:?} {q:?}");
            for t in &others {
                let (o, _) = stepped(t, ray, q);
                match q {
                    Query::Closest => {
                        assert!(
                            same_hit(&h, &o),
                            "{name} {:?}: {h:?} vs {o:?} on {ray:?}",
                            t.traversal()
                        );
                        ties += (h.slot != o.slot) as u32;
                    }
                    Query::Any => assert_eq!(h.is_hit(), o.is_hit(), "{name} any-hit"),
                }
            }
        }
    }
    // Ties need two triangles at exactly one distance: shared edges and vertices only.
    assert!(ties as usize <= n / 100, "{name}: {ties} ties");
}

#[test]
fn cornell_box() {
    check("cornell-box", 3000);
}
#[test]
fn sibenik() {
    check("sibenik", 1500);
}
#[test]
fn sponza_dabrovic() {
    check("sponza-dabrovic", 1000);
}
#[test]
fn stanford_bunny() {
    check("stanford-bunny", 1000);
}
#[test]
fn bunny_box() {
    check("bunny-box", 800);
}
#[test]
fn conference() {
    check("conference", 500);
}
#[test]
fn crytek_sponza() {
    check("crytek-sponza", 500);
}
#[test]
fn stanford_dragon() {
    check("stanford-dragon", 300);
}
#[test]
fn dragon_box() {
    check("dragon-box", 300);
}
