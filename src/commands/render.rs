//! `rtsim render`: render a frame with the functional tracer and write the image, the heat
//! map, `stats.json` (deterministic: every counter), `timing.json` (host-dependent) and
//! `config.resolved.toml`.

use crate::cli::RenderArgs;
use crate::progress;
use crate::run_config::{self, Flag};
use crate::session;
use anyhow::Result;
use rtsim_run::facts::{BvhFacts, RayFacts, SceneFacts, WorkloadFacts};
use rtsim_trace::{Integrator, ToneMap, WorkloadKind, WorkloadParams, render_frame};
use serde::Serialize;
use std::time::Instant;
use toml::Value;

pub fn run(args: RenderArgs) -> Result<()> {
    let mut flags: Vec<Flag> = Vec::new();
    if let Some(w) = &args.workload {
        flags.push(("workload.kind", Value::String(w.clone())));
    }
    if let Some(w) = args.width {
        flags.push(("workload.width", Value::Integer(w.into())));
    }
    if let Some(h) = args.height {
        flags.push(("workload.height", Value::Integer(h.into())));
    }
    if let Some(s) = args.spp {
        flags.push(("workload.spp", Value::Integer(s.into())));
    }
    if let Some(o) = &args.out {
        flags.push(("output.dir", Value::String(o.display().to_string())));
    }
    let resolved = run_config::resolve(&args.scene, &flags)?;
    // Every output is checked (and staged) before the BVH build and the render.
    let outputs = super::FrameOutputs::prepare(&args.scene, &resolved)?;
    let s = session::build(resolved, false)?;
    let cfg = &s.resolved.config;
    let scene = &s.resolved.scene;
    let params = workload_params(&s.resolved);
    eprintln!(
        "rtsim render: scene `{}` ({} triangles), workload {:?} {}x{} spp {}, {} threads",
        scene.name,
        scene.triangles.len(),
        params.kind,
        params.width,
        params.height,
        params.spp,
        s.pool.current_num_threads()
    );
    let integ = Integrator::new(scene, &s.tracer, params.clone());
    let bar = progress::bar(params.height as u64, "render");
    let start = Instant::now();
    let frame = s.pool.install(|| render_frame(&integ, &|| bar.inc(1)));
    let render_seconds = start.elapsed().as_secs_f64();
    bar.finish_and_clear();

    let tone = match (cfg.output.exposure, params.kind) {
        (Some(exposure), _) => ToneMap::Linear { exposure },
        (None, WorkloadKind::Ao) => ToneMap::Linear { exposure: 1.0 },
        (None, _) => ToneMap::Auto,
    };
    let image = frame.to_srgb8(tone);
    super::warn_if_black(&image, params.kind, &s.resolved);
    let (heat, heat_top) = frame.heatmap_rgb8();
    let total = frame.stats.total();
    let stats = RenderStats {
        rtsim_version: env!("CARGO_PKG_VERSION"),
        scene: SceneFacts::of(scene),
        bvh: BvhFacts::of(s.tracer.bvh(), Some(&s.image)),
        workload: WorkloadFacts::of(&params),
        traversal: s.tracer.traversal().name(),
        rays: RayFacts::of(&frame.stats, params.kind),
        heatmap: HeatmapFacts {
            nodes_visited_max: frame
                .pixels
                .iter()
                .map(|p| p.nodes_visited)
                .max()
                .unwrap_or(0),
            nodes_visited_scale_top: heat_top,
        },
    };
    let timing = RenderTiming {
        threads: s.pool.current_num_threads(),
        bvh_build_seconds: s.build_seconds,
        render_seconds,
        mrays_per_second: total.rays as f64 / render_seconds.max(1e-9) / 1e6,
    };
    let png = outputs.png().to_path_buf();
    outputs.write(
        (frame.width, frame.height),
        &image,
        &heat,
        &serde_json::to_string_pretty(&stats)?,
        &serde_json::to_string_pretty(&timing)?,
        &rtsim_run::resolved_toml(&s.resolved, "render")?,
    )?;

    println!(
        "scene            {} ({} triangles)",
        scene.name,
        scene.triangles.len()
    );
    println!(
        "image            {}x{}, {} spp, workload {:?}",
        params.width, params.height, params.spp, params.kind
    );
    for (name, c) in frame.stats.by_kind() {
        println!(
            "{name:<16} {:>12} rays  {:>6.2} % hit  {:>7.2} nodes/ray  {:>7.2} tris/ray",
            c.rays,
            100.0 * c.hits as f64 / c.rays.max(1) as f64,
            c.nodes_visited as f64 / c.rays.max(1) as f64,
            c.tri_tests as f64 / c.rays.max(1) as f64
        );
    }
    if params.kind == WorkloadKind::Path {
        println!("path segments    {}", frame.stats.path_segments());
    }
    if s.image.treelets().is_some() {
        println!(
            "treelets         {:.2} crossed per ray ({} crossings, {} rays)",
            total.treelet_crossings as f64 / total.rays.max(1) as f64,
            total.treelet_crossings,
            total.rays
        );
    }
    println!(
        "time             BVH {:.3} s, render {:.3} s, {:.2} Mrays/s",
        s.build_seconds,
        render_seconds,
        total.rays as f64 / render_seconds.max(1e-9) / 1e6
    );
    println!("wrote            {}", png.display());
    Ok(())
}

/// The frame parameters of a resolved run (defaults filled in).
pub fn workload_params(r: &run_config::Resolved) -> WorkloadParams {
    rtsim_run::workload_params(r)
}

/// `stats.json` of `rtsim render`: deterministic (same config and seed, same bytes).
#[derive(Debug, Serialize)]
struct RenderStats {
    rtsim_version: &'static str,
    scene: SceneFacts,
    bvh: BvhFacts,
    workload: WorkloadFacts,
    traversal: &'static str,
    rays: RayFacts,
    heatmap: HeatmapFacts,
}

#[derive(Debug, Serialize)]
struct HeatmapFacts {
    nodes_visited_max: u32,
    nodes_visited_scale_top: u32,
}

/// `timing.json`: host-dependent figures, kept apart from the deterministic stats.
#[derive(Debug, Serialize)]
struct RenderTiming {
    threads: usize,
    bvh_build_seconds: f64,
    render_seconds: f64,
    mrays_per_second: f64,
}
