//! `rtsim bench`: BVH build time and tracing throughput (Mrays/s) for primary, AO and diffuse
//! rays, on one thread and on all cores, for the reference traversal (with counters), the
//! same traversal stepped one unit of work at a time (what the hardware models run) and the
//! 8-wide fast path. Rays are generated first, exactly as the workloads trace them, then timed
//! in isolation; each measurement is repeated and the fastest kept.

use crate::cli::BenchArgs;
use crate::run_config;
use crate::session::{fast_path, thread_pool};
use anyhow::{Context, Result};
use rayon::prelude::*;
use rtsim_config::ConfigError;
use rtsim_core::Ray;
use rtsim_core::output::OutputPlan;
use rtsim_trace::fast::FastBvh;
use rtsim_trace::query::encode_rays;
use rtsim_trace::{Integrator, Query, RayCounters, Tracer, WorkloadKind};
use std::time::Instant;

pub fn run(args: BenchArgs) -> Result<()> {
    if !(1..=MAX_RAYS).contains(&args.rays) {
        return Err(ConfigError::range("--rays", args.rays, format!("1..={MAX_RAYS}")).into());
    }
    if !(1..=MAX_REPEAT).contains(&args.repeat) {
        return Err(
            ConfigError::range("--repeat", args.repeat, format!("1..={MAX_REPEAT}")).into(),
        );
    }
    let resolved = run_config::resolve(&args.scene, &[])?;
    // `--save-rays`: planned and checked before any measurement.
    let mut saved = match &args.save_rays {
        Some(dir) => {
            let mut plan = OutputPlan::new();
            plan.dir(dir, "--save-rays");
            for kind in KINDS {
                plan.file(dir.join(format!("{}.bin", name(kind))));
            }
            super::scene_inputs(&mut plan, &args.scene, &resolved);
            Some(plan.prepare()?)
        }
        None => None,
    };
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
        "Mrays/s: reference binary-BVH traversal `{}` (with counters), the same stepped, \
         8-wide fast path (no counters)",
        tracer.traversal().name()
    );
    println!(
        "{:<8} {:>9} {:>7} {:>9} {:>9} {:>10} {:>9} {:>9}",
        "rays",
        "count",
        "hit %",
        "ref 1t",
        format!("ref {cores}t"),
        "stepped 1t",
        "fast 1t",
        format!("fast {cores}t")
    );
    for kind in KINDS {
        let rays = all.install(|| generate(&resolved, &tracer, kind, args.rays))?;
        if let (Some(set), Some(dir)) = (&mut saved, &args.save_rays) {
            let p = dir.join(format!("{}.bin", name(kind)));
            let mut f = set.create(&p)?;
            encode_rays(&mut f, &rays).with_context(|| format!("writing {}", p.display()))?;
            set.finish(f)?;
        }
        let any = kind == WorkloadKind::Ao;
        let measure = |pool: &rayon::ThreadPool, mode: Mode| {
            let mut best = (f64::INFINITY, 0);
            for _ in 0..args.repeat {
                let start = Instant::now();
                let hits = pool.install(|| trace_all(&tracer, mode, &rays, any));
                let secs = start.elapsed().as_secs_f64();
                if secs < best.0 {
                    best = (secs, hits);
                }
            }
            best
        };
        let n = rays.len() as f64;
        let rate = |t: f64| format!("{:.2}", n / t / 1e6);
        let (t1, hits) = measure(&one, Mode::Closed);
        let (tn, _) = measure(&all, Mode::Closed);
        let (s1, stepped_hits) = measure(&one, Mode::Stepped);
        if stepped_hits != hits {
            anyhow::bail!(
                "internal error: the stepped traversal found {stepped_hits} hits, the closed \
                 loop {hits}"
            );
        }
        let (f1, fnn) = match fast.as_ref() {
            Some(f) => (
                rate(measure(&one, Mode::Fast(f)).0),
                rate(measure(&all, Mode::Fast(f)).0),
            ),
            None => ("-".into(), "-".into()),
        };
        println!(
            "{:<8} {:>9} {:>7.2} {:>9} {:>9} {:>10} {:>9} {:>9}",
            name(kind),
            rays.len(),
            100.0 * hits as f64 / n.max(1.0),
            rate(t1),
            rate(tn),
            format!("{} ({:+.0}%)", rate(s1), 100.0 * (t1 / s1 - 1.0)),
            f1,
            fnn
        );
    }
    if let Some(set) = saved {
        set.commit()?;
    }
    Ok(())
}

/// Most rays per measurement (assumed: 2^24, 512 MB of rays — the same again while they are
/// generated; a larger count measures nothing new and can exhaust memory).
const MAX_RAYS: usize = 1 << 24;
/// Most repetitions of a measurement.
const MAX_REPEAT: u32 = 1000;
/// The ray kinds measured, in order.
const KINDS: [WorkloadKind; 3] = [
    WorkloadKind::Primary,
    WorkloadKind::Ao,
    WorkloadKind::Diffuse,
];

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
) -> Result<Vec<Ray>> {
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
        let total: usize = rows.iter().map(Vec::len).sum();
        let mut rays: Vec<Ray> = Vec::new();
        rays.try_reserve_exact(total).map_err(|_| {
            anyhow::anyhow!(
                "cannot allocate {total} rays ({} MB) for {kind:?} rays: lower --rays",
                (total * std::mem::size_of::<Ray>()) >> 20
            )
        })?;
        rays.extend(rows.into_iter().flatten());
        // Secondary rays exist only where camera rays hit: grow the image if too few.
        if rays.len() >= count || pixels > 64.0 * count as f64 {
            rays.truncate(count);
            return Ok(rays);
        }
        pixels *= 1.0 + count as f64 / rays.len().max(1) as f64;
    }
}

/// How rays are traced.
#[derive(Clone, Copy)]
enum Mode<'a> {
    /// The tracer's closest/any-hit queries (the closed loop for `stack`).
    Closed,
    /// The configured variant stepped one unit of work at a time.
    Stepped,
    Fast(&'a FastBvh),
}

/// Trace every ray on the current pool; returns the number of hits.
fn trace_all(tracer: &Tracer, mode: Mode<'_>, rays: &[Ray], any: bool) -> u64 {
    let query = if any { Query::Any } else { Query::Closest };
    rays.par_iter()
        .with_min_len(4096)
        .map(|r| {
            let hit = match (mode, any) {
                (Mode::Fast(f), true) => f.any_hit(r),
                (Mode::Fast(f), false) => f.closest_hit(r).is_hit(),
                (Mode::Closed, true) => tracer.any_hit(r, &mut RayCounters::default()),
                (Mode::Closed, false) => {
                    tracer.closest_hit(r, &mut RayCounters::default()).is_hit()
                }
                (Mode::Stepped, _) => tracer
                    .run_stepped(r, query, &mut RayCounters::default())
                    .is_hit(),
            };
            hit as u64
        })
        .sum()
}
