//! `rtsim trace`: answer ray queries from `rays.bin`, writing `hits.bin` (formats in
//! `rtsim_trace::query` and the README). Rays are processed in chunks, traced in parallel on
//! the configured threads; the reported throughput counts tracing time only (not file I/O).

use crate::cli::TraceArgs;
use crate::cputime;
use crate::progress;
use crate::session;
use anyhow::{Context, Result};
use rayon::prelude::*;
use rtsim_core::output::OutputPlan;
use rtsim_trace::query::{RayReader, encode_hits, is_traceable};
use rtsim_trace::{Hit, NO_HIT, RayCounters};
use std::io::Write;
use std::time::{Duration, Instant};

/// Rays per chunk: 1 M rays is 32 MB in and 16 MB out.
const CHUNK: usize = 1 << 20;

pub fn run(args: TraceArgs) -> Result<()> {
    let resolved = crate::run_config::resolve(&args.scene, &[])?;
    let mut reader = RayReader::open(&args.rays)?;
    let total = reader.count();
    let mut plan = OutputPlan::new();
    plan.file(&args.out).input("--rays", &args.rays);
    super::scene_inputs(&mut plan, &args.scene, &resolved);
    let mut outputs = plan.prepare()?;
    let s = session::build(resolved, true)?;
    let mut out = outputs.create(&args.out)?;
    let bar = progress::bar(total, "trace");
    let tracer = &s.tracer;
    let fast = s.fast.as_ref();
    let any = args.any_hit;
    let (mut rays, mut hits, mut bytes) = (Vec::new(), Vec::new(), Vec::new());
    let (mut traced, mut hit_count, mut busy, mut cpu) = (0u64, 0u64, Duration::ZERO, 0.0f64);
    while reader.read_chunk(CHUNK, &mut rays)? > 0 {
        let start = Instant::now();
        let cpu_start = cputime::process_seconds();
        s.pool.install(|| {
            rays.par_iter()
                .with_min_len(4096)
                .map(|ray| {
                    if !is_traceable(ray) {
                        return Hit {
                            t: f32::INFINITY,
                            prim: NO_HIT,
                            u: 0.0,
                            v: 0.0,
                        };
                    }
                    match (fast, any) {
                        (Some(f), true) => f.any_hit_detail(ray),
                        (Some(f), false) => f.closest_hit(ray),
                        (None, true) => tracer.any_hit_detail(ray, &mut RayCounters::default()),
                        (None, false) => tracer.closest_hit(ray, &mut RayCounters::default()),
                    }
                })
                .collect_into_vec(&mut hits)
        });
        busy += start.elapsed();
        if let (Some(a), Some(b)) = (cpu_start, cputime::process_seconds()) {
            cpu += b - a;
        }
        traced += rays.len() as u64;
        hit_count += hits.iter().filter(|h| h.is_hit()).count() as u64;
        bytes.clear();
        encode_hits(&hits, &mut bytes);
        out.write_all(&bytes)
            .with_context(|| format!("writing {}", args.out.display()))?;
        bar.inc(rays.len() as u64);
    }
    outputs.finish(out)?;
    outputs.commit()?;
    bar.finish_and_clear();
    let secs = busy.as_secs_f64().max(1e-9);
    let mode = if any { "any-hit" } else { "closest-hit" };
    let path = if fast.is_some() { "fast" } else { "reference" };
    eprintln!(
        "rtsim trace: {traced} {mode} rays on `{}` ({} triangles), {hit_count} hits ({:.2} %), {} threads, {path} path",
        s.resolved.scene.name,
        s.resolved.scene.triangles.len(),
        100.0 * hit_count as f64 / traced.max(1) as f64,
        s.pool.current_num_threads(),
    );
    eprintln!(
        "rtsim trace: tracing {secs:.3} s wall ({:.2} Mrays/s), {cpu:.3} s CPU ({:.2} Mrays/s per CPU second); BVH build {:.3} s",
        traced as f64 / secs / 1e6,
        traced as f64 / cpu.max(1e-9) / 1e6,
        s.build_seconds,
    );
    Ok(())
}
