//! BVH build time: `cargo bench -p rtsim-bvh --bench build`.
//!
//! Single-threaded (the target: binned Sibenik under 0.5 s on one core) and on all
//! cores, for both builders, on a generated sphere and on Sibenik when the shared scenes are
//! present (read with the scene loader).

#[path = "../tests/support/mod.rs"]
mod support;

use criterion::{Criterion, criterion_group, criterion_main};
use rtsim_bvh::{Builder, BvhConfig, NodeOrder, build};
use std::hint::black_box;
use std::time::Duration;

fn bench(c: &mut Criterion) {
    let mut inputs = vec![("sphere-120k".to_string(), support::sphere(250, 240))];
    if let Some(scene) = support::shared_scene("sibenik") {
        inputs.push(("sibenik".into(), scene.triangles));
    }
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let mut g = c.benchmark_group("bvh-build");
    g.sample_size(10).measurement_time(Duration::from_secs(5));
    for (name, tris) in &inputs {
        for builder in [Builder::Binned, Builder::Sweep] {
            let cfg = BvhConfig {
                builder,
                ..Default::default()
            };
            let id = format!("{name}/{builder:?}");
            g.bench_function(format!("{id}/1-thread"), |b| {
                b.iter(|| one.install(|| build(black_box(tris), &cfg, NodeOrder::DepthFirst)))
            });
            g.bench_function(format!("{id}/all-threads"), |b| {
                b.iter(|| build(black_box(tris), &cfg, NodeOrder::DepthFirst))
            });
        }
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
