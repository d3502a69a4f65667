//! One module per subcommand; each owns its clap arguments where they are its alone.

pub mod bench;
pub mod bench_sim;
pub mod bvh_stats;
pub mod cache;
pub mod compare;
pub mod compare_strata;
pub mod dram;
pub mod export;
pub mod render;
pub mod report;
pub mod scenes;
pub mod simulate;
pub mod sweep;
pub mod trace;

use crate::cli::{Cli, Command, SceneArgs};
use crate::run_config::Resolved;
use anyhow::{Context, Result};
use rtsim_core::output::{OutputPlan, OutputSet};
use rtsim_trace::film::png_bytes;
use std::path::{Path, PathBuf};

pub fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Render(a) => render::run(a),
        Command::Simulate(a) => simulate::run(a),
        Command::Sweep(a) => sweep::run(a),
        Command::Trace(a) => trace::run(a),
        Command::ExportTriangles(a) => export::run(a),
        Command::BvhStats(a) => bvh_stats::run(a),
        Command::Scenes(a) => scenes::run(a),
        Command::Bench(a) => bench::run(a),
        Command::BenchSim(a) => bench_sim::run(a),
        Command::Dram(a) => dram::run(a),
        Command::Cache(a) => cache::run(a),
        Command::Compare(a) => compare::run(a),
        Command::Report(a) => report::run(a),
    }
}

/// `1234567` → `1,234,567`.
pub(crate) fn thousands(n: u64) -> String {
    let s = n.to_string();
    let mut out = String::with_capacity(s.len() + s.len() / 3);
    for (i, c) in s.chars().enumerate() {
        if i > 0 && (s.len() - i) % 3 == 0 {
            out.push(',');
        }
        out.push(c);
    }
    out
}

/// Inputs of a scene run that no output may overwrite: the config file, a scene given as a
/// path, and every file the scene was read from.
pub(crate) fn scene_inputs(plan: &mut OutputPlan, args: &SceneArgs, r: &Resolved) {
    if let Some(c) = &args.config {
        plan.input("--config", c);
    }
    let named = Path::new(&r.config.scene.name);
    if named.is_file() {
        plan.input("--scene", named);
    }
    for f in &r.scene.files {
        plan.input("scene file", f);
    }
}

/// The files every frame command (`render`, `simulate`) writes into `output.dir`, prepared
/// as one set before the work.
pub(crate) struct FrameOutputs {
    set: OutputSet,
    png: PathBuf,
    heatmap: Option<PathBuf>,
    stats: PathBuf,
    timing: PathBuf,
    config: PathBuf,
    /// Further files of this run, by name in the output directory (`hits.bin` …).
    extra: Vec<PathBuf>,
}

impl FrameOutputs {
    /// Plan and prepare the set (the pre-flight check: fails before any work).
    pub(crate) fn prepare(args: &SceneArgs, r: &Resolved) -> Result<FrameOutputs> {
        Self::prepare_with(args, r, &[])
    }

    /// As [`FrameOutputs::prepare`], with further files named in the output directory.
    pub(crate) fn prepare_with(
        args: &SceneArgs,
        r: &Resolved,
        extra: &[&str],
    ) -> Result<FrameOutputs> {
        let dir = r.config.output.dir.clone();
        let heatmap = dir.join("heatmap.png");
        let heatmap = r.config.output.heatmap.then_some(heatmap);
        let (png, stats, timing, config) = (
            dir.join("render.png"),
            dir.join("stats.json"),
            dir.join("timing.json"),
            dir.join("config.resolved.toml"),
        );
        let mut plan = OutputPlan::new();
        plan.dir(&dir, "the output directory (--out, output.dir)");
        let extra: Vec<PathBuf> = extra.iter().map(|n| dir.join(n)).collect();
        for f in [&png, &stats, &timing, &config].into_iter().chain(&extra) {
            plan.file(f);
        }
        match &heatmap {
            Some(h) => plan.file(h),
            // An older run's heat map must not sit beside this run's image.
            None => plan.stale(dir.join("heatmap.png")),
        };
        scene_inputs(&mut plan, args, r);
        Ok(FrameOutputs {
            set: plan.prepare()?,
            png,
            heatmap,
            stats,
            timing,
            config,
            extra,
        })
    }

    /// Stage one of the further files planned by [`FrameOutputs::prepare_with`].
    pub(crate) fn write_extra(&mut self, name: &str, bytes: &[u8]) -> Result<()> {
        let path = self
            .extra
            .iter()
            .find(|p| p.file_name().is_some_and(|n| n == name))
            .with_context(|| format!("{name} was not planned as an output"))?
            .clone();
        Ok(self.set.write(&path, bytes)?)
    }

    /// Write the image, heat map, stats, timing and resolved config, and commit them together.
    pub(crate) fn write(
        mut self,
        size: (u32, u32),
        image: &[u8],
        heat: &[u8],
        stats_json: &str,
        timing_json: &str,
        config_toml: &str,
    ) -> Result<()> {
        let (w, h) = size;
        let png = |rgb: &[u8], path: &Path| {
            png_bytes(w, h, rgb).with_context(|| format!("encoding {}", path.display()))
        };
        self.set.write(&self.png, &png(image, &self.png)?)?;
        if let Some(p) = &self.heatmap {
            self.set.write(p, &png(heat, p)?)?;
        }
        self.set.write(&self.stats, stats_json.as_bytes())?;
        self.set.write(&self.timing, timing_json.as_bytes())?;
        self.set.write(&self.config, config_toml.as_bytes())?;
        Ok(self.set.commit()?)
    }

    pub(crate) fn png(&self) -> &Path {
        &self.png
    }
}

/// Say so when a frame came out entirely black although its workload is lit: a light inside
/// closed geometry, or a camera that sees nothing, gives that without any error.
pub(crate) fn warn_if_black(srgb: &[u8], kind: rtsim_trace::WorkloadKind, r: &Resolved) {
    if kind == rtsim_trace::WorkloadKind::Ao || srgb.iter().any(|&b| b != 0) {
        return;
    }
    if let Some(limit) = r.config.sim.cycle_limit {
        eprintln!(
            "warning: the image is entirely black: with `sim.cycle_limit` = {limit}, the frame \
             probably stopped before any pixel finished (raise or unset the limit; stats.json \
             says whether the frame completed)"
        );
        return;
    }
    let l = r.scene.light.position;
    eprintln!(
        "warning: the image is entirely black: no light reaches a surface the camera sees \
         (is the light at ({}, {}, {}) inside closed geometry, or does the camera look at \
         nothing?)",
        l.x, l.y, l.z
    );
}

/// The three files of a component command (`rtsim dram`, `rtsim cache`) in its `--out`
/// directory: deterministic stats, the resolved config that repeats the run, and the
/// host-dependent `timing.json`.
pub(crate) struct StatsOutputs {
    pub(crate) stats: PathBuf,
    config: PathBuf,
    timing: PathBuf,
}

impl StatsOutputs {
    /// Plan the files `stats` and `config` (names) and `timing.json` in `out`, with the run's
    /// inputs, and prepare them: the pre-flight check, before any work.
    pub(crate) fn prepare(
        out: &Path,
        stats: &str,
        config: &str,
        inputs: &[(&str, Option<&Path>)],
    ) -> Result<(Self, OutputSet)> {
        let files = StatsOutputs {
            stats: out.join(stats),
            config: out.join(config),
            timing: out.join("timing.json"),
        };
        let mut plan = OutputPlan::new();
        plan.dir(out, "--out");
        for f in [&files.stats, &files.config, &files.timing] {
            plan.file(f);
        }
        for (what, path) in inputs {
            if let Some(p) = path {
                plan.input(what, p);
            }
        }
        let set = plan.prepare()?;
        Ok((files, set))
    }

    /// Write the three files and commit them as one set.
    pub(crate) fn write(
        &self,
        mut set: OutputSet,
        stats: &impl serde::Serialize,
        config_toml: &str,
        timing: &impl serde::Serialize,
    ) -> Result<()> {
        let name = self.stats.file_name().unwrap_or_default().to_string_lossy();
        let json =
            serde_json::to_string_pretty(stats).with_context(|| format!("serialising {name}"))?;
        set.write(&self.stats, json.as_bytes())?;
        set.write(&self.config, config_toml.as_bytes())?;
        set.write(
            &self.timing,
            serde_json::to_string_pretty(timing)?.as_bytes(),
        )?;
        set.commit()?;
        println!("  wrote {}", self.stats.display());
        Ok(())
    }
}
