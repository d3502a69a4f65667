//! Functional cache speed: accesses per second on one core. The target (issue: 50 M/s) is for
//! a 16 KB direct-mapped cache with 64 B lines — TRaX's L1 — on a reuse-heavy stream like a
//! BVH traversal's; also a 4-way LRU L1 and the two-level TRaX L1 + L2.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use rtsim_cache::{Cache, CacheConfig, CacheLevel, FunctionalHierarchy, Replacement};
use rtsim_core::{MemOp, Pcg32};
use std::hint::black_box;

const N: usize = 1 << 20;

/// Addresses with locality: mostly within a 32 KB working set, with random jumps; 1 in 8 writes.
pub fn trace() -> Vec<(u64, MemOp)> {
    let mut rng = Pcg32::new(7, 1);
    let mut base = 0u64;
    (0..N)
        .map(|_| {
            if rng.below(64) == 0 {
                base = u64::from(rng.below(1 << 20)) * 64;
            }
            let addr = base + u64::from(rng.below(32 * 1024));
            let op = if rng.below(8) == 0 {
                MemOp::Write
            } else {
                MemOp::Read
            };
            (addr, op)
        })
        .collect()
}

fn bench(c: &mut Criterion) {
    let t = trace();
    let mut g = c.benchmark_group("cache-functional");
    g.throughput(Throughput::Elements(N as u64));
    g.bench_function("l1-16KB-direct-mapped", |b| {
        let mut cache = Cache::new("l1", &CacheLevel::trax_l1(), 1, 0).unwrap();
        b.iter(|| {
            for &(a, op) in &t {
                black_box(cache.access(a, op));
            }
        })
    });
    g.bench_function("l1-16KB-4way-lru", |b| {
        let l = CacheLevel {
            ways: 4,
            replacement: Replacement::Lru,
            ..CacheLevel::trax_l1()
        };
        let mut cache = Cache::new("l1", &l, 1, 0).unwrap();
        b.iter(|| {
            for &(a, op) in &t {
                black_box(cache.access(a, op));
            }
        })
    });
    g.bench_function("trax-l1-l2", |b| {
        let mut h = FunctionalHierarchy::new(&CacheConfig::default()).unwrap();
        b.iter(|| {
            for &(a, op) in &t {
                black_box(h.access(0, a, op));
            }
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
