//! `rtsim bench`: BVH build time and tracing throughput (Mrays/s) for primary, AO and diffuse
//! rays, on one thread and on all cores, for the reference traversal (with counters) and the
//! 8-wide fast path. Rays are generated first, exactly as the workloads trace them, then timed
//! in isolation; each measurement is repeated and the fastest kept.

use crate::cli::BenchArgs;
use crate::run_config;
use crate::session::{fast_path, thread_pool};
use anyhow::{Context, Result};
use rayon::prelude::*;
use rtsim_core::Ray;
use rtsim_trace::fast::FastBvh;
use rtsim_trace::query::write_rays;
use rtsim_trace::{Integrator, RayCounters, Tracer, WorkloadKind};
use std::time::Instant;

pub fn run(args: BenchArgs) -> Result<()> {
    if args.rays == 0 || args.repeat == 0 {
        anyhow::bail!("--rays and --repeat must be at least 1");
    }
    let resolved = run_config::resolve(&args.scene, &[])?;
    let scene = &resolved.scene;
    let cfg = &resolved.config;
    let one = thread_pool(1)?;
    let all = thread_pool(cfg.threads)?;
    let cores = all.current_num_threads();
    println!(
        "scene {} ({} triangles), builder {:?}",
        scene.name,
        scene.triangles.len(),
        cfg.bvh.builder
    );

    let build = |pool: &rayon::ThreadPool| -> Result<(f64, rtsim_bvh::Bvh)> {
        let mut best: Option<(f64, rtsim_bvh::Bvh)> = None;
        for _ in 0..args.repeat {
            let start = Instant::now();
            let bvh =
                pool.install(|| rtsim_bvh::build(&scene.triangles, &cfg.bvh, cfg.memory.order))?;
            let secs = start.elapsed().as_secs_f64();
            if best.as_ref().is_none_or(|b| secs < b.0) {
                best = Some((secs, bvh));
            }
        }
        Ok(best.expect("repeat >= 1"))
    };
    let (build_1, _) = build(&one)?;
    let (build_n, bvh) = build(&all)?;
    println!("BVH build        {build_1:>8.3} s on 1 thread   {build_n:>8.3} s on {cores} threads");
    let fast = fast_path(&cfg.trace, true, &scene.triangles, &bvh)?;
    let tracer = Tracer::new(&scene.triangles, bvh, &cfg.trace)?;

    println!(
        "Mrays/s: reference binary-BVH traversal (with counters), 8-wide fast path (no counters)"
    );
    println!(
        "{:<8} {:>9} {:>7} {:>9} {:>9} {:>9} {:>9}",
        "rays",
        "count",
        "hit %",
        "ref 1t",
        format!("ref {cores}t"),
        "fast 1t",
        format!("fast {cores}t")
    );
    for kind in [
        WorkloadKind::Primary,
        WorkloadKind::Ao,
        WorkloadKind::Diffuse,
    ] {
        let rays = all.install(|| generate(&resolved, &tracer, kind, args.rays));
        if let Some(dir) = &args.save_rays {
            let p = dir.join(format!("{}.bin", name(kind)));
            write_rays(&p, &rays).with_context(|| format!("writing {}", p.display()))?;
        }
        let any = kind == WorkloadKind::Ao;
        let measure = |pool: &rayon::ThreadPool, fast: Option<&FastBvh>| {
            let mut best = (f64::INFINITY, 0);
            for _ in 0..args.repeat {
                let start = Instant::now();
                let hits = pool.install(|| trace_all(&tracer, fast, &rays, any));
                let secs = start.elapsed().as_secs_f64();
                if secs < best.0 {
                    best = (secs, hits);
                }
            }
            best
        };
        let n = rays.len() as f64;
        let rate = |t: f64| format!("{:.2}", n / t / 1e6);
        let (t1, hits) = measure(&one, None);
        let (tn, _) = measure(&all, None);
        let (f1, fnn) = match fast.as_ref() {
            Some(f) => (
                rate(measure(&one, Some(f)).0),
                rate(measure(&all, Some(f)).0),
            ),
            None => ("-".into(), "-".into()),
        };
        println!(
            "{:<8} {:>9} {:>7.2} {:>9} {:>9} {:>9} {:>9}",
            name(kind),
            rays.len(),
            100.0 * hits as f64 / n.max(1.0),
            rate(t1),
            rate(tn),
            f1,
            fnn
        );
    }
    Ok(())
}

fn name(kind: WorkloadKind) -> &'static str {
    match kind {
        WorkloadKind::Primary => "primary",
        WorkloadKind::Ao => "ao",
        WorkloadKind::Diffuse => "diffuse",
        WorkloadKind::Path => "path",
        WorkloadKind::Specular => "specular",
    }
}

/// About `count` rays of `kind` from the scene's camera: the image is scaled (keeping the
/// workload's aspect ratio) until it yields enough rays, then truncated to `count`.
fn generate(
    r: &run_config::Resolved,
    tracer: &Tracer,
    kind: WorkloadKind,
    count: usize,
) -> Vec<Ray> {
    let mut params = crate::commands::render::workload_params(r);
    let mut w = r.config.workload.clone();
    w.kind = kind;
    w.width = None;
    w.height = None;
    w.spp = None;
    let (dw, dh, spp) = w.resolved_size();
    params.kind = kind;
    params.spp = spp;
    let aspect = dw as f64 / dh as f64;
    let mut pixels = (count as f64 / spp as f64).max(1.0);
    loop {
        params.height = ((pixels / aspect).sqrt().ceil() as u32).max(1);
        params.width = ((params.height as f64 * aspect).ceil() as u32).max(1);
        let integ = Integrator::new(&r.scene, tracer, params.clone());
        let rows: Vec<Vec<Ray>> = (0..params.height)
            .into_par_iter()
            .map(|y| {
                let mut v = Vec::new();
                for x in 0..params.width {
                    integ.benchmark_rays(x, y, &mut v);
                }
                v
            })
            .collect();
        let mut rays: Vec<Ray> = rows.into_iter().flatten().collect();
        // Secondary rays exist only where camera rays hit: grow the image if too few.
        if rays.len() >= count || pixels > 64.0 * count as f64 {
            rays.truncate(count);
            return rays;
        }
        pixels *= 1.0 + count as f64 / rays.len().max(1) as f64;
    }
}

/// Trace every ray on the current pool (fast path if given); returns the number of hits.
fn trace_all(tracer: &Tracer, fast: Option<&FastBvh>, rays: &[Ray], any: bool) -> u64 {
    rays.par_iter()
        .with_min_len(4096)
        .map(|r| {
            let hit = match (fast, any) {
                (Some(f), true) => f.any_hit(r),
                (Some(f), false) => f.closest_hit(r).is_hit(),
                (None, true) => tracer.any_hit(r, &mut RayCounters::default()),
                (None, false) => tracer.closest_hit(r, &mut RayCounters::default()).is_hit(),
            };
            hit as u64
        })
        .sum()
}
