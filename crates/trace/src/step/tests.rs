//! The variants against the closed loop and against each other, on random soups and any
//! valid BVH (median splits), for every kernel, order and query.

use super::*;
use crate::config::{TraceConfig, Traversal, TraversalOrder, TriangleTest};
use crate::counters::RayCounters;
use crate::testutil::{median_bvh, random_rays, random_soup};
use crate::tracer::{Tracer, TraversalState};
use rtsim_core::{Ray, Vec3};

fn cfg(
    traversal: Traversal,
    test: TriangleTest,
    order: TraversalOrder,
    early: bool,
) -> TraceConfig {
    TraceConfig {
        traversal,
        triangle_test: test,
        order,
        early_exit: early,
        fast_path: false,
        ..TraceConfig::default()
    }
}

/// Treelet ids that keep sibling pairs together: pair `(2k-1, 2k)` gets id `k / group`.
fn fake_treelets(nodes: usize, group: u32) -> Vec<u32> {
    (0..nodes as u32).map(|i| i.div_ceil(2) / group).collect()
}

/// Hits agree: the same slot (then bit-identical t, u, v), or a tie at the same t.
fn same_hit(a: &SlotHit, b: &SlotHit) -> bool {
    if a.slot == b.slot {
        return a.t.to_bits() == b.t.to_bits()
            && (!a.is_hit() || (a.u.to_bits() == b.u.to_bits() && a.v.to_bits() == b.v.to_bits()));
    }
    a.is_hit() && b.is_hit() && a.t == b.t
}

fn all_configs(traversal: Traversal) -> Vec<TraceConfig> {
    let mut v = Vec::new();
    for test in [
        TriangleTest::MollerTrumbore,
        TriangleTest::Plucker,
        TriangleTest::Wald,
    ] {
        for order in [TraversalOrder::NearestFirst, TraversalOrder::LeftFirst] {
            for early in [true, false] {
                v.push(cfg(traversal, test, order, early));
            }
        }
    }
    v
}

fn stepped(t: &Tracer, ray: &Ray, q: Query) -> (SlotHit, RayCounters, Vec<Step>) {
    let mut c = RayCounters::default();
    let mut st = t.start(ray, q);
    let mut steps = Vec::new();
    loop {
        let s = t.step(&mut st, &mut c);
        steps.push(s);
        if let Step::Done(h) = s {
            // Done is idempotent.
            assert_eq!(t.step(&mut st, &mut c), s);
            return (h, c, steps);
        }
        assert!(steps.len() < 1_000_000, "traversal does not end");
    }
}

fn closed(t: &Tracer, ray: &Ray, q: Query) -> (SlotHit, RayCounters) {
    let mut c = RayCounters::default();
    let h = match q {
        Query::Closest => t.closest_hit(ray, &mut c),
        Query::Any => t.any_hit_detail(ray, &mut c),
    };
    let slot = if h.is_hit() {
        (0..t.bvh().prim_ids.len() as u32)
            .find(|&s| t.prim_of_slot(s) == h.prim)
            .unwrap()
    } else {
        NONE
    };
    (
        SlotHit {
            t: h.t,
            slot,
            u: h.u,
            v: h.v,
        },
        c,
    )
}

#[test]
fn stack_steps_equal_the_closed_loop() {
    let tris = random_soup(1500, 31, 1.5);
    let rays = random_rays(1500, 32);
    for cfg in all_configs(Traversal::Stack) {
        for leaf in [1, 4] {
            let mut t = Tracer::new(&tris, median_bvh(&tris, leaf), &cfg).unwrap();
            for treelets in [None, Some(3), Some(40)] {
                let ids = treelets.map_or(Vec::new(), |g| fake_treelets(t.bvh().nodes.len(), g));
                t.set_treelets(ids).unwrap();
                for ray in &rays {
                    for q in [Query::Closest, Query::Any] {
                        let (h1, c1) = closed(&t, ray, q);
                        let (h2, c2, steps) = stepped(&t, ray, q);
                        assert_eq!(h1.slot, h2.slot, "{cfg:?}");
                        assert_eq!(h1.t.to_bits(), h2.t.to_bits());
                        assert_eq!(c1, c2, "{cfg:?} {treelets:?} {q:?}");
                        // The steps account for the counters.
                        let n = |f: fn(&Step) -> bool| steps.iter().filter(|s| f(s)).count() as u32;
                        assert_eq!(n(|s| matches!(s, Step::Node { .. })), c2.nodes_visited);
                        assert_eq!(n(|s| matches!(s, Step::Triangle { .. })), c2.tri_tests);
                        assert_eq!(n(|s| matches!(s, Step::Push { .. })), c2.stack_pushes);
                        assert_eq!(n(|s| matches!(s, Step::Pop { .. })), c2.stack_pops);
                        assert_eq!(
                            n(|s| matches!(s, Step::Treelet { .. })),
                            c2.treelet_crossings
                        );
                        if treelets.is_none() {
                            assert_eq!(c2.treelet_crossings, 0);
                        }
                    }
                }
            }
        }
    }
}

#[test]
fn variants_find_the_same_closest_hit_and_agree_on_occlusion() {
    let tris = random_soup(2500, 41, 1.5);
    let rays = random_rays(2000, 42);
    for (traversal, entries) in [
        (Traversal::BitStack, 0),
        (Traversal::ShortStack, 1),
        (Traversal::ShortStack, 2),
        (Traversal::ShortStack, 8),
    ] {
        for base in all_configs(traversal) {
            let cfg = TraceConfig {
                short_stack_entries: entries.max(1),
                ..base
            };
            let reference_cfg = TraceConfig {
                traversal: Traversal::Stack,
                ..cfg.clone()
            };
            for leaf in [1, 3] {
                let bvh = median_bvh(&tris, leaf);
                let v = Tracer::new(&tris, bvh.clone(), &cfg).unwrap();
                let r = Tracer::new(&tris, bvh, &reference_cfg).unwrap();
                let mut restarts = 0;
                for ray in &rays {
                    let (hr, _) = closed(&r, ray, Query::Closest);
                    let (hv, cv, _) = stepped(&v, ray, Query::Closest);
                    assert!(same_hit(&hr, &hv), "{cfg:?}: {hr:?} vs {hv:?}");
                    restarts += cv.restarts;
                    let (ar, _) = closed(&r, ray, Query::Any);
                    let (av, _, _) = stepped(&v, ray, Query::Any);
                    assert_eq!(ar.is_hit(), av.is_hit(), "{cfg:?}");
                    // The public API answers with the configured variant.
                    let mut c = RayCounters::default();
                    assert_eq!(v.any_hit(ray, &mut c), av.is_hit());
                }
                if traversal == Traversal::ShortStack && entries <= 2 {
                    assert!(
                        restarts > 0,
                        "{cfg:?}: tiny stacks must overflow and restart"
                    );
                }
            }
        }
    }
}

#[test]
fn a_deep_enough_short_stack_equals_the_stack_variant() {
    let tris = random_soup(2000, 51, 1.2);
    let rays = random_rays(1500, 52);
    for base in all_configs(Traversal::ShortStack) {
        let cfg = TraceConfig {
            short_stack_entries: 64,
            ..base
        };
        let reference = TraceConfig {
            traversal: Traversal::Stack,
            ..cfg.clone()
        };
        let bvh = median_bvh(&tris, 2);
        let v = Tracer::new(&tris, bvh.clone(), &cfg).unwrap();
        let r = Tracer::new(&tris, bvh, &reference).unwrap();
        for ray in &rays {
            for q in [Query::Closest, Query::Any] {
                let (hr, cr) = closed(&r, ray, q);
                let (hv, cv, _) = stepped(&v, ray, q);
                assert_eq!(hr.slot, hv.slot);
                assert_eq!(hr.t.to_bits(), hv.t.to_bits());
                assert_eq!(cr, cv, "{cfg:?} {q:?}");
            }
        }
    }
}

#[test]
fn bit_stack_counters_are_consistent() {
    let tris = random_soup(2000, 61, 1.5);
    let rays = random_rays(1000, 62);
    let cfg = cfg(
        Traversal::BitStack,
        TriangleTest::MollerTrumbore,
        TraversalOrder::NearestFirst,
        true,
    );
    let t = Tracer::new(&tris, median_bvh(&tris, 2), &cfg).unwrap();
    let mut retests = 0;
    for ray in &rays {
        let (_, c, steps) = stepped(&t, ray, Query::Closest);
        let n = |f: fn(&Step) -> bool| steps.iter().filter(|s| f(s)).count() as u32;
        assert_eq!(n(|s| matches!(s, Step::Parent { .. })), c.parent_fetches);
        assert_eq!(
            n(|s| matches!(s, Step::SiblingRetest { .. })),
            c.sibling_retests
        );
        assert_eq!(
            c.box_tests,
            1 + 2 * (c.nodes_visited - c.leaves_visited) + c.sibling_retests
        );
        // A finished closest-hit traversal climbs back to the root: every bit is popped.
        if c.nodes_visited > 0 {
            assert_eq!(c.stack_pushes, c.stack_pops);
        }
        assert!(c.max_stack <= bitstack::MAX_LEVELS);
        retests += c.sibling_retests;
    }
    assert!(retests > 0);
}

#[test]
fn a_parked_bit_stack_ray_continues_exactly() {
    let tris = random_soup(1500, 71, 1.5);
    let rays = random_rays(600, 72);
    let cfg = cfg(
        Traversal::BitStack,
        TriangleTest::Plucker,
        TraversalOrder::NearestFirst,
        true,
    );
    let mut t = Tracer::new(&tris, median_bvh(&tris, 3), &cfg).unwrap();
    t.set_treelets(fake_treelets(t.bvh().nodes.len(), 5))
        .unwrap();
    for (i, ray) in rays.iter().enumerate() {
        for q in [Query::Closest, Query::Any] {
            let (h, c, steps) = stepped(&t, ray, q);
            // Park the ray as a 48-byte record after every step and resume from the record.
            let mut st = t.start(ray, q);
            let mut c2 = RayCounters::default();
            for (k, expected) in steps.iter().enumerate() {
                let TraversalState::BitStack(s) = st else {
                    unreachable!()
                };
                let rec = s.to_record(i as u32, (k % 8) as u8).unwrap();
                let (back, path, kind) = bitstack::State::from_record(&rec).unwrap();
                assert_eq!((path, kind), (i as u32, (k % 8) as u8));
                st = TraversalState::BitStack(back);
                let got = t.step(&mut st, &mut c2);
                assert_eq!(&got, expected, "ray {i} step {k}");
            }
            assert_eq!(c, c2);
            assert!(matches!(steps.last(), Some(Step::Done(d)) if d.t.to_bits() == h.t.to_bits()));
        }
    }
    // The record holds no tmin.
    let st = bitstack::start(
        &Data::<crate::kernels::triangle::MollerTrumbore> {
            nodes: &[],
            tris: &[],
            parents: &[],
            treelets: &[],
            opts: t.options(),
        },
        &Ray::new(Vec3::ZERO, Vec3::ONE, 0.5, 1.0),
        Query::Closest,
    );
    assert!(st.to_record(0, 0).is_err());
}

#[test]
fn depth_limits_are_refused_with_the_key() {
    // A chain of 40 levels: each inner node splits off one triangle.
    let n = 41;
    let tris: Vec<[Vec3; 3]> = (0..n)
        .map(|i| {
            let x = i as f32 * 2.0;
            [
                Vec3::new(x, 0.0, 0.0),
                Vec3::new(x + 1.0, 0.0, 0.0),
                Vec3::new(x, 1.0, 0.0),
            ]
        })
        .collect();
    let bvh = rtsim_bvh::build(
        &tris,
        &rtsim_bvh::BvhConfig {
            max_leaf_size: 1,
            ..Default::default()
        },
        rtsim_bvh::NodeOrder::DepthFirst,
    )
    .unwrap();
    let levels = crate::tracer::bvh_depth(&bvh) - 1;
    assert!(levels > 5);
    let err = Tracer::new(
        &tris,
        bvh.clone(),
        &TraceConfig {
            stack_entries: 4,
            ..TraceConfig::default()
        },
    )
    .unwrap_err()
    .to_string();
    assert!(err.contains("trace.stack_entries"), "{err}");
    let ok = Tracer::new(&tris, bvh, &TraceConfig::default());
    assert!(ok.is_ok());
}

#[test]
fn steps_name_their_records() {
    let tris = random_soup(300, 81, 1.0);
    let bvh = median_bvh(&tris, 2);
    let img = rtsim_bvh::MemoryImage::new(&bvh, &rtsim_bvh::MemoryLayoutConfig::default()).unwrap();
    let t = Tracer::new(&tris, bvh, &TraceConfig::default()).unwrap();
    for ray in random_rays(200, 82) {
        let (_, _, steps) = stepped(&t, &ray, Query::Closest);
        for s in &steps {
            match s.access() {
                Access::NodePair(l) => {
                    // Default layout: a pair is exactly one 64-byte line.
                    let span = s.access().lines(&img, 64).unwrap();
                    assert_eq!(span.count, 1);
                    assert_eq!(span.first, img.node_addr(l));
                }
                Access::Node(n) => {
                    assert_eq!(s.access().lines(&img, 64).unwrap(), img.node_lines(n, 64))
                }
                Access::Triangle(slot) => {
                    assert_eq!(
                        s.access().lines(&img, 64).unwrap(),
                        img.triangle_lines(slot, 64)
                    )
                }
                Access::Stack { depth, .. } => assert!(depth < stack::STACK_CAPACITY as u32),
                Access::None => assert!(s.access().lines(&img, 64).is_none()),
            }
        }
    }
}
