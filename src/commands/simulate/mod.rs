//! `rtsim simulate --arch P`: run a frame on an architecture model and write what it did.
//!
//! Every architecture writes the same set of files into `output.dir`: `render.png` (identical
//! to `rtsim render`'s for the pixels simulated), `heatmap.png` (cycles per pixel for a chip;
//! nodes visited for `functional`), `stats.json` (typed, deterministic), `timing.json`
//! (host-dependent) and `config.resolved.toml`. One module per architecture family turns a
//! [`Session`] into a [`SimOutput`]; this module dispatches on `arch.preset` and writes the
//! files.

mod functional;
pub mod sgrt;
pub(crate) mod strata;
pub(crate) mod trax;

use crate::cli::SceneArgs;
use crate::commands::FrameOutputs;
use crate::run_config::Flag;
use crate::session::{self, Session};
use anyhow::Result;
use clap::Args;
use rtsim_run::facts::{BvhFacts, RayFacts, SceneFacts, WorkloadFacts};
use rtsim_trace::film::heatmap_rgb8;
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
    #[command(flatten)]
    pub frame: FrameArgs,
}

/// The frame and timing flags `simulate` and `compare` share.
#[derive(Debug, Args, Clone)]
pub struct FrameArgs {
    /// Workload: primary, ao, diffuse, path, specular.
    #[arg(long)]
    pub workload: Option<String>,
    /// Image width in pixels, 1..=16384 (`workload.width`).
    #[arg(long, value_parser = crate::cli::image_size_arg, allow_negative_numbers = true)]
    pub width: Option<u32>,
    /// Image height in pixels, 1..=16384 (`workload.height`).
    #[arg(long, value_parser = crate::cli::image_size_arg, allow_negative_numbers = true)]
    pub height: Option<u32>,
    /// Samples per pixel.
    #[arg(long, value_parser = crate::cli::u32_arg, allow_negative_numbers = true)]
    pub spp: Option<u32>,
    /// Simulate only pixels x0..x1 × y0..y1 of the image (`sim.window`).
    #[arg(
        long,
        value_name = "X0,Y0,X1,Y1",
        value_delimiter = ',',
        value_parser = crate::cli::u32_arg,
        allow_negative_numbers = true
    )]
    pub window: Option<Vec<u32>>,
    /// Stop after this many core cycles (`sim.cycle_limit`).
    #[arg(long, value_name = "CYCLES", value_parser = crate::cli::u64_arg, allow_negative_numbers = true)]
    pub cycle_limit: Option<u64>,
    /// Write the frame's time series to `timeline.csv`, one row per this many core cycles
    /// (`sim.timeline_cycles`; TRaX-family chips).
    #[arg(long, value_name = "CYCLES", value_parser = crate::cli::u64_arg, allow_negative_numbers = true)]
    pub timeline: Option<u64>,
    /// Timing engine: fast (default) or reference (cycle by cycle) (`sim.mode`).
    #[arg(long)]
    pub mode: Option<String>,
    /// Output directory.
    #[arg(long, value_name = "DIR")]
    pub out: Option<PathBuf>,
}

impl FrameArgs {
    /// The flags as dotted keys.
    pub fn flags(&self) -> Result<Vec<Flag>> {
        if let Some(w) = &self.window
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
        s("workload.kind", self.workload.clone().map(Value::String));
        s(
            "workload.width",
            self.width.map(|v| Value::Integer(v.into())),
        );
        s(
            "workload.height",
            self.height.map(|v| Value::Integer(v.into())),
        );
        s("workload.spp", self.spp.map(|v| Value::Integer(v.into())));
        s(
            "sim.window",
            self.window
                .as_ref()
                .map(|w| Value::Array(w.iter().map(|&v| Value::Integer(v.into())).collect())),
        );
        s(
            "sim.cycle_limit",
            cycles("--cycle-limit", self.cycle_limit)?,
        );
        s("sim.timeline_cycles", cycles("--timeline", self.timeline)?);
        s("sim.mode", self.mode.clone().map(Value::String));
        s(
            "output.dir",
            self.out
                .as_ref()
                .map(|o| Value::String(o.display().to_string())),
        );
        Ok(flags)
    }
}

/// A count of cycles given as `flag`, as a TOML integer (which holds up to `i64::MAX`).
fn cycles(flag: &str, v: Option<u64>) -> Result<Option<Value>> {
    Ok(v.map(|c| {
        i64::try_from(c)
            .map(Value::Integer)
            .map_err(|_| rtsim_config::ConfigError::range(flag, c, format!("1..={}", i64::MAX)))
    })
    .transpose()?)
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
    /// Further files for the output directory, by name; each must be one of
    /// [`extra_outputs`]' names for the run.
    pub files: Vec<(&'static str, Vec<u8>)>,
}

/// The files a run writes besides the frame's: SGRT's `hits.bin` when it traces a rays file,
/// a TRaX-family chip's `timeline.csv` when `sim.timeline_cycles` asks for it.
fn extra_outputs(r: &rtsim_run::Resolved) -> &'static [&'static str] {
    let a = &r.config.arch;
    if a.preset.starts_with("sgrt") && a.sgrt.rays_file.is_some() {
        &["hits.bin"]
    } else if r.config.sim.timeline_cycles.is_some() && (a.is_trax() || a.is_strata()) {
        &["timeline.csv"]
    } else {
        &[]
    }
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
    /// Host threads the simulation ran on (at most: the TRaX baseline's engine runs on one
    /// of them when the others lose, `docs/TRAX.md` §4).
    pub threads: usize,
    pub bvh_build_seconds: f64,
    /// Wall-clock seconds of the simulation alone (not the BVH build).
    pub simulate_seconds: f64,
    /// Process CPU seconds of the simulation, where the host reports them: on one thread
    /// close to `simulate_seconds` on an idle host; below it when other programs share the
    /// cores, above it when the engine ran on several threads.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub cpu_seconds: Option<f64>,
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
    let mut flags = args.frame.flags()?;
    if let Some(a) = &args.arch {
        flags.push(("arch.preset", Value::String(a.clone())));
    }
    Ok(flags)
}

pub fn run(args: SimulateArgs) -> Result<()> {
    let flags = flags(&args)?;
    let resolved = crate::run_config::resolve(&args.scene, &flags)?;
    // Pre-flight: every output is checked and staged before the (possibly hours-long) run.
    let outputs = crate::commands::FrameOutputs::prepare_with(
        &args.scene,
        &resolved,
        extra_outputs(&resolved),
    )?;
    let session = session::build(resolved, false)?;
    let preset = session.resolved.config.arch.preset.clone();
    let out = match preset.as_str() {
        "functional" => functional::run(&session)?,
        "trax-baseline" => trax::run(&session)?,
        "strata" => strata::run(&session)?,
        "sgrt" | "sgrt-sptrv" | "sgrt-1" => sgrt::run(&session)?,
        other => anyhow::bail!(
            "arch.preset = {other} has no simulator in this build (known: functional, \
             trax-baseline, strata, sgrt, sgrt-sptrv, sgrt-1)"
        ),
    };
    let png = outputs.png().to_path_buf();
    let top = write_outputs(&session, &out, outputs)?;
    for line in &out.summary {
        println!("{line}");
    }
    println!(
        "heat map         {} per pixel, ramp top (99th percentile) {top}",
        out.heat_label
    );
    println!("wrote            {}", png.display());
    Ok(())
}

/// The log-average luminance of the whole frame (the automatic exposure's key), from the
/// functional tracer on the session's BVH and traversal.
fn full_frame_log_average(s: &Session, params: &WorkloadParams) -> f32 {
    let integ = rtsim_trace::Integrator::new(&s.resolved.scene, &s.tracer, params.clone());
    let start = std::time::Instant::now();
    let frame = s.pool.install(|| rtsim_trace::render_frame(&integ, &|| {}));
    eprintln!(
        "exposure         the whole frame's (a functional render of {}x{}, {:.1} s), so the \
         window's pixels equal `rtsim render`'s",
        params.width,
        params.height,
        start.elapsed().as_secs_f64()
    );
    frame.log_average_luminance()
}

/// Write the image, heat map, stats, timing and resolved config as one set (all or none);
/// returns the heat map's top value.
fn write_outputs(s: &Session, out: &SimOutput, mut files: FrameOutputs) -> Result<u64> {
    for (name, bytes) in &out.files {
        files.write_extra(name, bytes)?;
    }
    let cfg = &s.resolved.config;
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
        // A window is exposed as the whole frame would be, so its pixels equal `rtsim
        // render`'s: the unsimulated black around it must not set the key (it blew windows
        // out), and the window's own key would differ from the frame's. The whole frame's
        // key comes from the functional tracer, whose radiance the chips reproduce exactly;
        // it costs a functional frame, small beside any chip simulation.
        (None, _) if cfg.sim.window.is_some() => ToneMap::AutoFrom {
            log_average: full_frame_log_average(s, &params),
        },
        (None, _) => ToneMap::Auto,
    };
    let image = frame.to_srgb8(tone);
    crate::commands::warn_if_black(&image, params.kind, &s.resolved);
    let (rgb, top) = heatmap_rgb8(&out.heat);
    let json = |v: serde_json::Value| serde_json::to_string_pretty(&v);
    files.write(
        (w, h),
        &image,
        &rgb,
        &json(out.stats.to_json()?)?,
        &serde_json::to_string_pretty(&out.timing)?,
        &rtsim_run::resolved_toml(&s.resolved, "simulate")?,
    )?;
    Ok(top)
}
