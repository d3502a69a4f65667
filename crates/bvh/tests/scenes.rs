//! Real scenes (long; `cargo test --release -p rtsim-bvh -- --ignored`): invariants, quality
//! and build time on the shared Sibenik and Conference meshes, read with the scene loader.
//! Skipped (with a message) only when no scene directory is configured; a configured
//! directory without the files fails.

mod support;

use rtsim_bvh::{Builder, BvhConfig, BvhStats, MemoryImage, MemoryLayoutConfig, NodeOrder, build};
use std::time::Instant;
use support::*;

fn one_thread<T: Send>(f: impl FnOnce() -> T + Send) -> T {
    rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap()
        .install(f)
}

fn check_scene(rel: &str, expect_triangles: usize) {
    let Some(scene) = shared_scene(rel) else {
        return;
    };
    let tris = scene.triangles;
    let dropped = (scene.report.dropped_degenerate + scene.report.dropped_non_finite) as usize;
    let in_file = tris.len() + dropped;
    assert_eq!(in_file, expect_triangles, "{rel}");
    println!("{rel}: {} triangles ({dropped} dropped)", tris.len());
    let mut costs = Vec::new();
    for builder in [Builder::Binned, Builder::Sweep] {
        for max_depth in [64, 32] {
            let c = BvhConfig {
                builder,
                max_depth,
                ..Default::default()
            };
            // Best of three single-threaded builds (the machine is shared).
            let mut best = f64::INFINITY;
            let mut bvh = None;
            for _ in 0..3 {
                let t = Instant::now();
                let b = one_thread(|| build(&tris, &c, NodeOrder::DepthFirst).unwrap());
                best = best.min(t.elapsed().as_secs_f64());
                bvh = Some(b);
            }
            let bvh = bvh.unwrap();
            bvh.check_invariants(&tris, &c).unwrap();
            let s = BvhStats::compute(&bvh, &c);
            let image = MemoryImage::new(&bvh, &MemoryLayoutConfig::default()).unwrap();
            image.check().unwrap();
            println!(
                "{rel} {builder:?} max_depth {max_depth}: {best:.3} s (1 thread), SAH {:.4}, \
                 {} nodes, depth max {} avg {:.1}, {:.2} tris/leaf",
                s.sah_cost,
                s.nodes,
                s.max_leaf_depth,
                s.avg_leaf_depth(),
                s.avg_leaf_size()
            );
            costs.push((builder, max_depth, s.sah_cost));
            if builder == Builder::Binned && expect_triangles < 100_000 && max_depth == 64 {
                // Issue 2 §7: binned build of Sibenik under 0.5 s on one core.
                assert!(best < 0.5, "{rel}: binned build {best:.3} s");
            }
        }
    }
    let cost = |b, d| costs.iter().find(|c| c.0 == b && c.1 == d).unwrap().2;
    assert!(cost(Builder::Sweep, 64) <= cost(Builder::Binned, 64) * 1.01);
}

#[test]
#[ignore = "reads shared scenes; long"]
fn sibenik() {
    check_scene("sibenik", 75_284);
}

#[test]
#[ignore = "reads shared scenes; long"]
fn conference() {
    check_scene("conference", 331_179);
}

/// Issue 2 asks the sweep builder to be practical at Hairball scale (about 2.9 M triangles);
/// a generated soup of small triangles of that size stands in until the procedural scene lands.
#[test]
#[ignore = "2.9 M triangles; long"]
fn hairball_sized_input() {
    let tris = random_soup(2_900_000, 77, 0.004);
    for builder in [Builder::Binned, Builder::Sweep] {
        let c = BvhConfig {
            builder,
            ..Default::default()
        };
        for threads in [1, 0] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let t = Instant::now();
            let bvh = pool.install(|| build(&tris, &c, NodeOrder::DepthFirst).unwrap());
            let secs = t.elapsed().as_secs_f64();
            let s = BvhStats::compute(&bvh, &c);
            println!(
                "2.9M soup {builder:?} {} threads: {secs:.2} s, SAH {:.2}, depth {}",
                pool.current_num_threads(),
                s.sah_cost,
                s.max_leaf_depth
            );
            if threads == 1 {
                bvh.check_invariants(&tris, &c).unwrap();
            }
        }
    }
}
