//! `rtsim simulate --arch P`: run a frame on an architecture model and write what it did.
//!
//! Every architecture writes the same set of files into `output.dir`: `render.png` (identical
//! to `rtsim render`'s for the pixels simulated), `heatmap.png` (cycles per pixel for a chip;
//! nodes visited for `functional`), `stats.json` (typed, deterministic), `timing.json`
//! (host-dependent) and `config.resolved.toml`. One module per architecture family turns a
//! [`Session`] into a [`SimOutput`]; this module dispatches on `arch.preset` and writes the
//! files.

mod functional;
pub(crate) mod trax;

use crate::cli::SceneArgs;
use crate::run_config::Flag;
use crate::session::{self, Session};
use anyhow::{Context, Result};
use clap::Args;
use rtsim_core::output::write_atomic;
use rtsim_run::facts::{BvhFacts, RayFacts, SceneFacts, WorkloadFacts};
use rtsim_trace::film::{heatmap_rgb8, write_png};
use rtsim_trace::{FrameStats, PixelResult, ToneMap, WorkloadKind, WorkloadParams};
use serde::Serialize;
use std::path::PathBuf;
use toml::Value;

#[derive(Debug, Args, Clone)]
pub struct SimulateArgs {
    #[command(flatten)]
    pub scene: SceneArgs,
    /// Architecture preset (`arch.preset`): functional, and the chip presets (see README).
    #[arg(long)]
    pub arch: Option<String>,
    /// Workload: primary, ao, diffuse, path, specular.
    #[arg(long)]
    pub workload: Option<String>,
    #[arg(long)]
    pub width: Option<u32>,
    #[arg(long)]
    pub height: Option<u32>,
    /// Samples per pixel.
    #[arg(long)]
    pub spp: Option<u32>,
    /// Simulate only pixels x0..x1 × y0..y1 of the image (`sim.window`).
    #[arg(long, value_name = "X0,Y0,X1,Y1", value_delimiter = ',')]
    pub window: Option<Vec<u32>>,
    /// Stop after this many core cycles (`sim.cycle_limit`).
    #[arg(long, value_name = "CYCLES")]
    pub cycle_limit: Option<u64>,
    /// Timing engine: fast (default) or reference (cycle by cycle) (`sim.mode`).
    #[arg(long)]
    pub mode: Option<String>,
    /// Output directory.
    #[arg(long, value_name = "DIR")]
    pub out: Option<PathBuf>,
}

/// What an architecture model produced for a frame.
pub struct SimOutput {
    /// One per image pixel, row-major (black outside the simulated window).
    pub pixels: Vec<PixelResult>,
    /// The heat map's per-pixel values (cycles for a chip) and what they are.
    pub heat: Vec<u64>,
    pub heat_label: &'static str,
    /// Everything for `stats.json` (typed, deterministic).
    pub stats: Box<dyn erased::Stats>,
    /// Host-dependent figures for `timing.json`.
    pub timing: Timing,
    /// Lines of the terminal summary.
    pub summary: Vec<String>,
}

/// What every architecture's `stats.json` starts with: the run's scene, BVH, workload and
/// rays.
#[derive(Debug, Serialize)]
pub struct RunFacts {
    rtsim_version: &'static str,
    arch: String,
    scene: SceneFacts,
    bvh: BvhFacts,
    workload: WorkloadFacts,
    traversal: &'static str,
    /// Pixels simulated (the window's).
    pixels: u64,
    rays: RayFacts,
}

impl RunFacts {
    pub fn of(s: &Session, params: &WorkloadParams, pixels: usize, rays: &FrameStats) -> Self {
        RunFacts {
            rtsim_version: env!("CARGO_PKG_VERSION"),
            arch: s.resolved.config.arch.preset.clone(),
            scene: SceneFacts::of(&s.resolved.scene),
            bvh: BvhFacts::of(s.tracer.bvh(), Some(&s.image)),
            workload: WorkloadFacts::of(params),
            traversal: s.tracer.traversal().name(),
            pixels: pixels as u64,
            rays: RayFacts::of(rays, params.kind),
        }
    }
}

/// Host figures of a run.
#[derive(Debug, Default, Serialize)]
pub struct Timing {
    pub threads: usize,
    pub bvh_build_seconds: f64,
    pub simulate_seconds: f64,
    /// Simulated core cycles per host second (0 for `functional`).
    pub cycles_per_second: f64,
}

/// `stats.json` content of any architecture: serialisable into a JSON value.
pub mod erased {
    pub trait Stats {
        fn to_json(&self) -> serde_json::Result<serde_json::Value>;
    }
    impl<T: serde::Serialize> Stats for T {
        fn to_json(&self) -> serde_json::Result<serde_json::Value> {
            serde_json::to_value(self)
        }
    }
}

/// The config flags `args` set (the scene flags aside).
pub(crate) fn flags(args: &SimulateArgs) -> Result<Vec<Flag>> {
    if let Some(w) = &args.window
        && w.len() != 4
    {
        anyhow::bail!("--window takes four numbers, X0,Y0,X1,Y1 (got {})", w.len());
    }
    let mut flags: Vec<Flag> = Vec::new();
    let mut s = |k: &'static str, v: Option<Value>| {
        if let Some(v) = v {
            flags.push((k, v));
        }
    };
    s("arch.preset", args.arch.clone().map(Value::String));
    s("workload.kind", args.workload.clone().map(Value::String));
    s(
        "workload.width",
        args.width.map(|v| Value::Integer(v.into())),
    );
    s(
        "workload.height",
        args.height.map(|v| Value::Integer(v.into())),
    );
    s("workload.spp", args.spp.map(|v| Value::Integer(v.into())));
    s(
        "sim.window",
        args.window
            .as_ref()
            .map(|w| Value::Array(w.iter().map(|&v| Value::Integer(v.into())).collect())),
    );
    s(
        "sim.cycle_limit",
        args.cycle_limit
            .map(|c| Value::Integer(c.min(i64::MAX as u64) as i64)),
    );
    s("sim.mode", args.mode.clone().map(Value::String));
    s(
        "output.dir",
        args.out
            .as_ref()
            .map(|o| Value::String(o.display().to_string())),
    );
    Ok(flags)
}

pub fn run(args: SimulateArgs) -> Result<()> {
    let flags = flags(&args)?;
    let session = session::open(&args.scene, &flags, false)?;
    let preset = session.resolved.config.arch.preset.clone();
    let out = match preset.as_str() {
        "functional" => functional::run(&session)?,
        "trax-baseline" => trax::run(&session)?,
        other => anyhow::bail!(
            "arch.preset = {other} has no simulator in this build (known: functional, \
             trax-baseline)"
        ),
    };
    let top = write_outputs(&session, &out)?;
    for line in &out.summary {
        println!("{line}");
    }
    println!(
        "heat map         {} per pixel, ramp top (99th percentile) {top}",
        out.heat_label
    );
    println!(
        "wrote            {}",
        session
            .resolved
            .config
            .output
            .dir
            .join("render.png")
            .display()
    );
    Ok(())
}

/// Write the image, heat map, stats, timing and resolved config, each atomically; returns the
/// heat map's top value.
fn write_outputs(s: &Session, out: &SimOutput) -> Result<u64> {
    let cfg = &s.resolved.config;
    let dir = &cfg.output.dir;
    let params = rtsim_run::workload_params(&s.resolved);
    let (w, h) = (params.width, params.height);
    let frame = rtsim_trace::Frame {
        width: w,
        height: h,
        pixels: out.pixels.clone(),
        stats: Default::default(),
    };
    let tone = match (cfg.output.exposure, params.kind) {
        (Some(exposure), _) => ToneMap::Linear { exposure },
        (None, WorkloadKind::Ao) => ToneMap::Linear { exposure: 1.0 },
        (None, _) => ToneMap::Auto,
    };
    let png = dir.join("render.png");
    write_png(&png, w, h, &frame.to_srgb8(tone))
        .with_context(|| format!("writing {}", png.display()))?;
    let (rgb, top) = heatmap_rgb8(&out.heat);
    if cfg.output.heatmap {
        let p = dir.join("heatmap.png");
        write_png(&p, w, h, &rgb).with_context(|| format!("writing {}", p.display()))?;
    }
    let json = |v: serde_json::Value| serde_json::to_string_pretty(&v);
    let stats_path = dir.join("stats.json");
    write_atomic(&stats_path, json(out.stats.to_json()?)?.as_bytes())
        .with_context(|| format!("writing {}", stats_path.display()))?;
    write_atomic(
        dir.join("timing.json"),
        serde_json::to_string_pretty(&out.timing)?.as_bytes(),
    )?;
    write_atomic(
        dir.join("config.resolved.toml"),
        rtsim_run::resolved_toml(&s.resolved, "simulate")?.as_bytes(),
    )?;
    Ok(top)
}
