//! Simulation speed: requests per second on one core for the GDDR5 presets (issue 12's targets:
//! 3 M/s for random traffic, 6 M/s for streaming; measured figures in docs/DRAM.md, "Speed")
//! and a DDR4 comparison point.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use rtsim_dram::config::preset_config;
use rtsim_dram::trace::{Pattern, Synthetic};
use rtsim_dram::{Dram, DriveOptions, Requester, drive};
use std::convert::Infallible;
use std::hint::black_box;

const N: u64 = 200_000;

fn run(preset: &str, pattern: Pattern) -> u64 {
    let c = preset_config(preset).unwrap();
    let mut d = Dram::new(&c, Requester::mhz(1000.0)).unwrap();
    let cap = d.spec().org.capacity_bytes;
    let traffic = Synthetic::new(pattern, N, 0.8, 0, 64, cap, 1);
    let s = drive(
        &mut d,
        traffic.map(Ok::<_, Infallible>),
        DriveOptions::default(),
        |_| {},
    )
    .unwrap();
    s.end_cycle
}

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("dram");
    g.throughput(Throughput::Elements(N));
    g.sample_size(10);
    for preset in ["gddr5-trax", "gddr5-strata", "ddr4-3200"] {
        for (name, p) in [("random", Pattern::Random), ("stream", Pattern::Stream)] {
            g.bench_function(format!("{preset}/{name}"), |b| {
                b.iter(|| black_box(run(preset, p)))
            });
        }
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
