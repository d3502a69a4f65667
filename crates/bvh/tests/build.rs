//! BVH invariants on random and degenerate inputs, for both builders and both node orders.

mod support;

use proptest::prelude::*;
use rtsim_bvh::{BuildError, Builder, Bvh, BvhConfig, BvhStats, NodeOrder, build};
use rtsim_core::Vec3;
use support::*;

fn cfg(builder: Builder) -> BvhConfig {
    BvhConfig {
        builder,
        ..Default::default()
    }
}

fn build_ok(tris: &[Tri], c: &BvhConfig, order: NodeOrder) -> Bvh {
    let bvh = build(tris, c, order).expect("build");
    if let Err(e) = bvh.check_invariants(tris, c) {
        panic!("{:?}/{order:?}: {e}", c.builder);
    }
    bvh
}

const BUILDERS: [Builder; 2] = [Builder::Binned, Builder::Sweep];
const ORDERS: [NodeOrder; 2] = [NodeOrder::DepthFirst, NodeOrder::BreadthFirst];

fn arb_builder() -> impl Strategy<Value = Builder> {
    prop_oneof![Just(Builder::Binned), Just(Builder::Sweep)]
}

fn arb_order() -> impl Strategy<Value = NodeOrder> {
    prop_oneof![Just(NodeOrder::DepthFirst), Just(NodeOrder::BreadthFirst)]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(96))]

    /// Every structural invariant (see `Bvh::check_invariants`) on random soups and settings.
    #[test]
    fn random_soups_satisfy_invariants(
        n in 0usize..700,
        seed in any::<u64>(),
        size in prop_oneof![Just(0.001f32), Just(0.05), Just(0.5), Just(3.0)],
        builder in arb_builder(),
        order in arb_order(),
        bins in 2u32..64,
        max_leaf_size in 1u32..9,
        max_depth in 10u32..40,
        traversal_cost in 0.1f32..4.0,
        intersection_cost in 0.1f32..4.0,
    ) {
        let tris = random_soup(n, seed, size);
        let c = BvhConfig {
            builder, bins, max_leaf_size, max_depth, traversal_cost, intersection_cost,
            parallel_threshold: 64,
        };
        let bvh = build(&tris, &c, order).unwrap();
        prop_assert_eq!(bvh.check_invariants(&tris, &c), Ok(()));
    }

    /// Random depth limits on inputs whose unconstrained trees are deep.
    #[test]
    fn depth_limit_always_met(
        n in 1usize..1500,
        builder in arb_builder(),
        max_leaf_size in 1u32..5,
        slack in 0u32..3,
    ) {
        let tris = geometric(n);
        // The smallest feasible depth, plus a little slack.
        let mut d = 1;
        while (max_leaf_size as usize) << d < n { d += 1; }
        let c = BvhConfig { builder, max_leaf_size, max_depth: d + slack, parallel_threshold: 64,
            ..Default::default() };
        let bvh = build(&tris, &c, NodeOrder::DepthFirst).unwrap();
        prop_assert_eq!(bvh.check_invariants(&tris, &c), Ok(()));
    }
}

#[test]
fn empty_input_gives_empty_bvh() {
    for b in BUILDERS {
        let bvh = build_ok(&[], &cfg(b), NodeOrder::DepthFirst);
        assert!(bvh.nodes.is_empty() && bvh.prim_ids.is_empty());
    }
}

#[test]
fn one_triangle_is_one_leaf() {
    let t = random_soup(1, 3, 0.5);
    for b in BUILDERS {
        let bvh = build_ok(&t, &cfg(b), NodeOrder::BreadthFirst);
        assert_eq!(bvh.nodes.len(), 1);
        assert_eq!((bvh.nodes[0].index, bvh.nodes[0].count), (0, 1));
    }
}

#[test]
fn identical_triangles_split_by_index_within_leaf_limit() {
    let t = vec![random_soup(1, 9, 0.5)[0]; 1000];
    for b in BUILDERS {
        for l in [1, 4] {
            let c = BvhConfig {
                builder: b,
                max_leaf_size: l,
                ..Default::default()
            };
            let bvh = build_ok(&t, &c, NodeOrder::DepthFirst);
            // Balanced: depth ceil(log2(1000 / l)), or one more where the sweep's equal SAH
            // sums differ by a rounding error (no one-triangle-per-level chain).
            let s = BvhStats::compute(&bvh, &c);
            let want = (1000f64 / l as f64).log2().ceil() as u32;
            assert!(
                (want..=want + 1).contains(&s.max_leaf_depth),
                "{b:?} leaf {l}: {}",
                s.max_leaf_depth
            );
        }
    }
}

#[test]
fn equal_centroids_with_different_boxes() {
    let t = same_centroid(500);
    for b in BUILDERS {
        for o in ORDERS {
            build_ok(&t, &cfg(b), o);
        }
    }
}

#[test]
fn flat_and_zero_area_boxes() {
    // A planar grid (zero z extent everywhere).
    let g = grid(40, 30);
    // Degenerate "triangles" that are points and segments on the x axis: zero-area boxes.
    let mut lines: Vec<Tri> = (0..300)
        .map(|k| {
            let x = k as f32 * 0.1;
            [
                Vec3::new(x, 0.0, 0.0),
                Vec3::new(x + 0.05, 0.0, 0.0),
                Vec3::new(x, 0.0, 0.0),
            ]
        })
        .collect();
    lines.extend(vec![[Vec3::splat(2.0); 3]; 50]);
    for b in BUILDERS {
        for o in ORDERS {
            build_ok(&g, &cfg(b), o);
            build_ok(&lines, &cfg(b), o);
        }
    }
}

#[test]
fn leaves_never_exceed_max_even_when_sah_prefers_a_leaf() {
    // Huge traversal cost: the SAH would make one leaf of everything.
    let t = random_soup(2000, 5, 0.05);
    for b in BUILDERS {
        let c = BvhConfig {
            builder: b,
            traversal_cost: 1000.0,
            max_leaf_size: 6,
            ..Default::default()
        };
        let bvh = build_ok(&t, &c, NodeOrder::DepthFirst);
        let s = BvhStats::compute(&bvh, &c);
        assert!(s.max_leaf_size <= 6);
        // And the SAH does prefer big leaves here: most leaves are full.
        assert!(s.avg_leaf_size() > 4.0, "{b:?}: {}", s.avg_leaf_size());
    }
}

#[test]
fn sah_makes_small_leaves_when_triangles_are_expensive() {
    let t = random_soup(2000, 5, 0.05);
    let c = BvhConfig {
        traversal_cost: 0.01,
        max_leaf_size: 8,
        ..Default::default()
    };
    let s = BvhStats::compute(&build_ok(&t, &c, NodeOrder::DepthFirst), &c);
    assert!(s.avg_leaf_size() < 1.5, "{}", s.avg_leaf_size());
}

#[test]
fn depth_limit_bites_and_is_met() {
    let t = geometric(3000);
    assert!(t[2999][0].x > 1e-30, "no denormals");
    for b in BUILDERS {
        let free = BvhConfig {
            builder: b,
            max_depth: 128,
            ..Default::default()
        };
        let deep = BvhStats::compute(&build_ok(&t, &free, NodeOrder::DepthFirst), &free);
        let free_depth = deep.max_leaf_depth;
        assert!(free_depth > 14, "{b:?}: unconstrained depth {free_depth}");
        // 10 is the least feasible depth for 3000 triangles in leaves of 4.
        for max_depth in [
            32.min(free_depth - 1),
            free_depth - 1,
            (free_depth + 10) / 2,
            10,
        ] {
            let c = BvhConfig {
                max_depth,
                ..free.clone()
            };
            let s = BvhStats::compute(&build_ok(&t, &c, NodeOrder::DepthFirst), &c);
            assert!(s.max_leaf_depth <= max_depth);
            // Constrained, still SAH where it can be: not much worse than the free tree.
            assert!(
                s.sah_cost < deep.sah_cost * 2.0,
                "{b:?} {max_depth}: {} vs {}",
                s.sah_cost,
                deep.sah_cost
            );
        }
    }
}

#[test]
fn infeasible_depth_is_a_clear_error() {
    let t = random_soup(100, 1, 0.1);
    let c = BvhConfig {
        max_depth: 4,
        max_leaf_size: 4,
        ..Default::default()
    };
    let e = build(&t, &c, NodeOrder::DepthFirst).unwrap_err();
    assert!(
        matches!(e, BuildError::DepthTooSmall { needed: 5, .. }),
        "{e:?}"
    );
    let msg = e.to_string();
    assert!(
        msg.contains("bvh.max_depth") && msg.contains("bvh.max_leaf_size"),
        "{msg}"
    );
}

#[test]
fn bad_config_and_input_are_errors_not_panics() {
    let t = random_soup(10, 1, 0.1);
    let c = BvhConfig {
        bins: 0,
        ..Default::default()
    };
    assert!(
        build(&t, &c, NodeOrder::DepthFirst)
            .unwrap_err()
            .to_string()
            .contains("bvh.bins")
    );
    let mut bad = t.clone();
    bad[7][1].y = f32::NAN;
    let e = build(&bad, &BvhConfig::default(), NodeOrder::DepthFirst).unwrap_err();
    assert!(matches!(e, BuildError::NonFinite { index: 7 }), "{e:?}");
}

#[test]
fn reordering_preserves_the_tree() {
    let t = sphere(30, 40);
    for b in BUILDERS {
        let c = cfg(b);
        let dfs = build_ok(&t, &c, NodeOrder::DepthFirst);
        let bfs = build_ok(&t, &c, NodeOrder::BreadthFirst);
        assert_eq!(dfs.reordered(NodeOrder::BreadthFirst).nodes, bfs.nodes);
        assert_eq!(
            dfs.reordered(NodeOrder::BreadthFirst).prim_ids,
            bfs.prim_ids
        );
        assert_eq!(bfs.reordered(NodeOrder::DepthFirst).nodes, dfs.nodes);
        assert_eq!(bfs.reordered(NodeOrder::DepthFirst).prim_ids, dfs.prim_ids);
        let (sd, sb) = (BvhStats::compute(&dfs, &c), BvhStats::compute(&bfs, &c));
        assert_eq!(sd.leaf_size_histogram, sb.leaf_size_histogram);
        assert!((sd.sah_cost - sb.sah_cost).abs() < 1e-9 * sd.sah_cost);
    }
}

#[test]
fn breadth_first_is_level_order_and_depth_first_is_preorder() {
    let t = random_soup(3000, 11, 0.05);
    let c = BvhConfig::default();
    let bfs = build_ok(&t, &c, NodeOrder::BreadthFirst);
    let d = bfs.depths();
    assert!(
        d.windows(2).all(|w| w[0] <= w[1]),
        "BFS depths must not decrease"
    );
    // BFS: triangle slots increase with the leaf's node index.
    let leaves: Vec<_> = bfs.nodes.iter().filter(|n| n.is_leaf()).collect();
    assert!(
        leaves
            .windows(2)
            .all(|w| w[0].index + w[0].count == w[1].index)
    );

    let dfs = build_ok(&t, &c, NodeOrder::DepthFirst);
    // DFS: a left-first preorder walk meets leaves in slot order, and each pair is allocated
    // right after everything reachable before it in that walk.
    let mut stack = vec![0usize];
    let (mut next_slot, mut next_pair) = (0u32, 1u32);
    while let Some(i) = stack.pop() {
        let n = dfs.nodes[i];
        if n.is_leaf() {
            assert_eq!(n.index, next_slot);
            next_slot += n.count;
        } else {
            assert_eq!(n.index, next_pair);
            next_pair += 2;
            stack.push(n.index as usize + 1);
            stack.push(n.index as usize);
        }
    }
    assert_eq!(next_pair as usize, dfs.nodes.len());
}

#[test]
fn split_separates_two_clusters() {
    // Two far-apart clusters: the root split must separate them exactly.
    let mut t = random_soup(200, 1, 0.01);
    let far: Vec<Tri> = random_soup(300, 2, 0.01)
        .into_iter()
        .map(|tri| tri.map(|v| v + Vec3::new(100.0, 0.0, 0.0)))
        .collect();
    t.extend(far);
    for b in BUILDERS {
        let bvh = build_ok(&t, &cfg(b), NodeOrder::DepthFirst);
        let root = bvh.nodes[0];
        let (l, r) = (
            bvh.nodes[root.index as usize],
            bvh.nodes[root.index as usize + 1],
        );
        assert!(
            l.bounds.max.x < 2.0 && r.bounds.min.x > 99.0,
            "{b:?}: {l:?} {r:?}"
        );
    }
}
