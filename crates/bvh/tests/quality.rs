//! Tree quality: the full sweep is at least as good as binning (approximately: both are
//! greedy), and more bins approach the sweep.

mod support;

use rtsim_bvh::{Builder, BvhConfig, NodeOrder, build, sah_cost};
use support::*;

fn cost(tris: &[Tri], builder: Builder, bins: u32) -> f64 {
    let c = BvhConfig {
        builder,
        bins,
        ..Default::default()
    };
    let bvh = build(tris, &c, NodeOrder::DepthFirst).unwrap();
    sah_cost(&bvh, c.traversal_cost, c.intersection_cost)
}

fn inputs() -> Vec<(&'static str, Vec<Tri>)> {
    let mut clusters = random_soup(3000, 3, 0.01);
    clusters.extend(
        random_soup(3000, 4, 0.2)
            .into_iter()
            .map(|t| t.map(|v| v * 10.0)),
    );
    vec![
        ("soup", random_soup(20_000, 1, 0.03)),
        ("sphere", sphere(100, 120)),
        ("grid", grid(120, 90)),
        ("clusters", clusters),
    ]
}

#[test]
fn sweep_is_no_worse_than_binned() {
    for (name, tris) in inputs() {
        let (sweep, binned) = (
            cost(&tris, Builder::Sweep, 32),
            cost(&tris, Builder::Binned, 32),
        );
        println!("{name}: sweep {sweep:.3} binned {binned:.3}");
        assert!(
            sweep <= binned * 1.01,
            "{name}: sweep {sweep} > binned {binned}"
        );
    }
}

#[test]
fn more_bins_approach_the_sweep() {
    for (name, tris) in inputs() {
        let sweep = cost(&tris, Builder::Sweep, 32);
        let b4 = cost(&tris, Builder::Binned, 4);
        let b256 = cost(&tris, Builder::Binned, 256);
        println!("{name}: 4 bins {b4:.3}, 256 bins {b256:.3}, sweep {sweep:.3}");
        assert!(b256 <= b4, "{name}");
        assert!(
            b256 <= sweep * 1.03,
            "{name}: 256 bins {b256} vs sweep {sweep}"
        );
    }
}

/// Weighted SAH of a split, `A_L·n_L + A_R·n_R`, computed from scratch.
fn weighted(tris: &[Tri], left: &[usize], right: &[usize]) -> f32 {
    let b = |s: &[usize]| {
        s.iter().fold(rtsim_core::Aabb::EMPTY, |acc, &i| {
            acc.union(rtsim_core::Aabb::from_points(&tris[i]))
        })
    };
    b(left).surface_area() * left.len() as f32 + b(right).surface_area() * right.len() as f32
}

/// Scene ids under the root's left and right child.
fn root_partition(bvh: &rtsim_bvh::Bvh) -> (Vec<usize>, Vec<usize>) {
    let under = |root: usize| {
        let mut out = Vec::new();
        let mut stack = vec![root];
        while let Some(i) = stack.pop() {
            let n = bvh.nodes[i];
            if n.is_leaf() {
                out.extend(
                    bvh.prim_ids[n.index as usize..][..n.count as usize]
                        .iter()
                        .map(|&p| p as usize),
                );
            } else {
                stack.extend([n.index as usize, n.index as usize + 1]);
            }
        }
        out
    };
    let c = bvh.nodes[0].index as usize;
    (under(c), under(c + 1))
}

fn centre2(t: &Tri) -> [f32; 3] {
    let b = rtsim_core::Aabb::from_points(t);
    [b.min.x + b.max.x, b.min.y + b.max.y, b.min.z + b.max.z]
}

/// Brute force: the root split the sweep picks is the cheapest of all object splits along the
/// three centroid orders.
#[test]
fn sweep_root_split_is_the_exhaustive_optimum() {
    for seed in 0..20 {
        let tris = random_soup(60, seed, 0.3);
        let c = BvhConfig {
            builder: Builder::Sweep,
            max_leaf_size: 1,
            ..Default::default()
        };
        let bvh = build(&tris, &c, NodeOrder::DepthFirst).unwrap();
        let (l, r) = root_partition(&bvh);
        let chosen = weighted(&tris, &l, &r);
        let mut best = f32::INFINITY;
        for axis in 0..3 {
            let mut ids: Vec<usize> = (0..tris.len()).collect();
            ids.sort_by(|&a, &b| {
                centre2(&tris[a])[axis]
                    .total_cmp(&centre2(&tris[b])[axis])
                    .then(a.cmp(&b))
            });
            for p in 1..ids.len() {
                best = best.min(weighted(&tris, &ids[..p], &ids[p..]));
            }
        }
        assert!(
            chosen <= best * (1.0 + 1e-6),
            "seed {seed}: chosen {chosen}, optimum {best}"
        );
    }
}

/// Brute force: the binned root split is the cheapest plane among the `bins − 1` planes of the
/// centroid bounds on each axis.
#[test]
fn binned_root_split_is_the_best_plane() {
    for (seed, bins) in (0..20).zip([4u32, 7, 16, 32].into_iter().cycle()) {
        let tris = random_soup(80, seed, 0.3);
        let c = BvhConfig {
            bins,
            max_leaf_size: 1,
            ..Default::default()
        };
        let bvh = build(&tris, &c, NodeOrder::DepthFirst).unwrap();
        let (l, r) = root_partition(&bvh);
        let chosen = weighted(&tris, &l, &r);
        let mut best = f32::INFINITY;
        for axis in 0..3 {
            let cs: Vec<f32> = tris.iter().map(|t| centre2(t)[axis]).collect();
            let (lo, hi) = cs
                .iter()
                .fold((f32::INFINITY, f32::NEG_INFINITY), |(a, b), &c| {
                    (a.min(c), b.max(c))
                });
            for k in 1..bins {
                // Plane k of `bins` equal intervals, up to rounding at the plane itself.
                let plane = lo + (hi - lo) * k as f32 / bins as f32;
                let (left, right): (Vec<usize>, Vec<usize>) =
                    (0..tris.len()).partition(|&i| cs[i] < plane);
                if !left.is_empty() && !right.is_empty() {
                    best = best.min(weighted(&tris, &left, &right));
                }
            }
        }
        assert!(
            chosen <= best * (1.0 + 1e-5),
            "seed {seed}, {bins} bins: chosen {chosen}, best plane {best}"
        );
    }
}
