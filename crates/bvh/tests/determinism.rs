//! The tree is bit-identical whatever the thread count and `parallel_threshold`.

mod support;

use rtsim_bvh::{Builder, Bvh, BvhConfig, NodeOrder, build};
use support::*;

fn bits(b: &Bvh) -> (Vec<[u32; 8]>, Vec<u32>) {
    let nodes = b
        .nodes
        .iter()
        .map(|n| {
            let (lo, hi) = (n.bounds.min, n.bounds.max);
            [
                lo.x.to_bits(),
                lo.y.to_bits(),
                lo.z.to_bits(),
                hi.x.to_bits(),
                hi.y.to_bits(),
                hi.z.to_bits(),
                n.index,
                n.count,
            ]
        })
        .collect();
    (nodes, b.prim_ids.clone())
}

fn build_on(threads: usize, tris: &[Tri], c: &BvhConfig) -> Bvh {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap()
        .install(|| build(tris, c, NodeOrder::DepthFirst).unwrap())
}

#[test]
fn identical_across_thread_counts_and_thresholds() {
    // Big enough that with threshold 64 the top nodes bin in parallel chunks (>= 256
    // triangles) and hundreds of subtrees fork.
    let mut tris = random_soup(30_000, 42, 0.02);
    tris.extend(sphere(60, 80));
    for builder in [Builder::Binned, Builder::Sweep] {
        let c = BvhConfig {
            builder,
            parallel_threshold: 64,
            ..Default::default()
        };
        let reference = bits(&build_on(1, &tris, &c));
        assert!(reference.0.len() > 1000);
        for threads in [2, 3, 8] {
            assert!(
                bits(&build_on(threads, &tris, &c)) == reference,
                "{builder:?}: {threads} threads differ from 1"
            );
        }
        // The threshold decides only what runs in parallel, never the result.
        for threshold in [4096, 1 << 31] {
            let c2 = BvhConfig {
                parallel_threshold: threshold,
                ..c.clone()
            };
            assert!(
                bits(&build_on(4, &tris, &c2)) == reference,
                "{builder:?}: threshold {threshold} changes the tree"
            );
        }
    }
}
