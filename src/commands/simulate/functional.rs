//! `arch.preset = "functional"`: the functional tracer, no timing — the reference every chip
//! model's image and counters are compared with.

use super::{RunFacts, SimOutput, Timing};
use crate::session::Session;
use anyhow::Result;
use rayon::prelude::*;
use rtsim_trace::{FrameStats, Integrator, PixelResult};
use std::time::Instant;

pub fn run(s: &Session) -> Result<SimOutput> {
    let cfg = &s.resolved.config;
    let params = rtsim_run::workload_params(&s.resolved);
    let integ = Integrator::new(&s.resolved.scene, &s.tracer, params.clone());
    let (w, h) = (params.width, params.height);
    let todo = cfg.sim.pixels(w, h);
    let start = Instant::now();
    // Each pixel depends only on its index and the seed: any thread count, same result.
    let results: Vec<(u32, PixelResult, FrameStats)> = s.pool.install(|| {
        todo.par_iter()
            .map(|&p| {
                let mut st = FrameStats::default();
                let r = integ.pixel(p % w, p / w, &mut st);
                (p, r, st)
            })
            .collect()
    });
    let seconds = start.elapsed().as_secs_f64();
    let mut pixels = vec![PixelResult::default(); (w * h) as usize];
    let mut stats = FrameStats::default();
    for (p, r, st) in results {
        pixels[p as usize] = r;
        stats += st;
    }
    let total = stats.total();
    let summary = vec![
        format!(
            "arch             functional ({} pixels, {} rays, traversal {})",
            todo.len(),
            total.rays,
            s.tracer.traversal().name()
        ),
        format!("time             {seconds:.3} s"),
    ];
    Ok(SimOutput {
        heat: pixels.iter().map(|p| p.nodes_visited as u64).collect(),
        heat_label: "nodes visited",
        pixels,
        stats: Box::new(RunFacts::of(s, &params, todo.len(), &stats)),
        timing: Timing {
            threads: s.pool.current_num_threads(),
            bvh_build_seconds: s.build_seconds,
            simulate_seconds: seconds,
            cpu_seconds: None,
            cycles_per_second: 0.0,
        },
        summary,
        files: Vec::new(),
    })
}
