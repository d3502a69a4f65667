//! Command-line definitions (clap).

use clap::{Args, Parser, Subcommand};
use std::path::PathBuf;

#[derive(Debug, Parser)]
#[command(name = "rtsim", version, about = "Cycle-level simulator of ray-tracing hardware", long_about = None)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Debug, Subcommand)]
pub enum Command {
    /// Render a frame with the functional tracer: PNG, heat map, stats.json, config.resolved.toml.
    Render(RenderArgs),
    /// Run a frame on an architecture model (--arch): image, cycle heat map, stats.json.
    Simulate(crate::commands::simulate::SimulateArgs),
    /// Run every point of an experiment, resumably, locally or as a Slurm array; merge results.
    Sweep(crate::commands::sweep::SweepArgs),
    /// Answer ray queries from a binary file (see README: rays.bin / hits.bin).
    Trace(TraceArgs),
    /// Write the scene's triangles in hit-index order (see README: tris.bin).
    ExportTriangles(ExportArgs),
    /// Build the BVH and print its statistics.
    BvhStats(BvhStatsArgs),
    /// List built-in and descriptor scenes.
    Scenes(ScenesArgs),
    /// Measure tracing throughput (Mrays/s) and BVH build time.
    Bench(BenchArgs),
    /// Measure the TRaX chip model's speed: simulated cycles, TP-cycles and instructions per
    /// host second, and peak memory (full chip on Sibenik, 200,000 cycles, by default).
    BenchSim(crate::commands::bench_sim::BenchSimArgs),
    /// Run the DRAM model alone on a request trace or synthetic traffic (see docs/DRAM.md).
    Dram(crate::commands::dram::DramArgs),
    /// Replay an address trace through a cache hierarchy, functionally or timed (docs/CACHES.md).
    Cache(crate::commands::cache::CacheArgs),
    /// Run the same frame on several presets of one chip, ours beside the papers': SGRT
    /// presets (speed and step ratios, SGRT Table 4) or trax-baseline and strata (STRaTA
    /// Tables 1 and 3, with whether each change goes the paper's way).
    Compare(crate::commands::compare::CompareArgs),
    /// Draw the papers' tables and figures from a sweep's results, beside the published
    /// values: report.html and every figure as SVG and PNG (docs/EXPERIMENTS.md); or the time
    /// series of `simulate --timeline` runs, side by side.
    Report(crate::commands::report::ReportArgs),
}

/// Flags shared by everything that loads a scene and a config.
#[derive(Debug, Args, Clone, Default)]
pub struct SceneArgs {
    /// Scene: built-in (cornell, hairball, vegetation), descriptor name (see `rtsim scenes`),
    /// or a path to a .toml descriptor or a mesh file (.obj/.ply, optionally .zst/.gz).
    #[arg(long)]
    pub scene: Option<String>,
    /// Directory holding the scene files (default: $RTSIM_SCENE_DIR, else ../shared/scenes).
    #[arg(long, value_name = "DIR")]
    pub scene_dir: Option<PathBuf>,
    /// TOML config file merged over the defaults.
    #[arg(long, value_name = "FILE")]
    pub config: Option<PathBuf>,
    /// Override any config key, e.g. --set bvh.max_leaf_size=8 (repeatable).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
    /// Run seed (procedural scenes, sampling).
    #[arg(long, value_parser = crate::cli::u64_arg, allow_negative_numbers = true)]
    pub seed: Option<u64>,
    /// Worker threads (0 = all cores).
    #[arg(long, value_parser = crate::cli::usize_arg, allow_negative_numbers = true)]
    pub threads: Option<usize>,
}

#[derive(Debug, Args, Clone)]
pub struct RenderArgs {
    #[command(flatten)]
    pub scene: SceneArgs,
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
    /// Output directory.
    #[arg(long, value_name = "DIR")]
    pub out: Option<PathBuf>,
}

#[derive(Debug, Args, Clone)]
pub struct TraceArgs {
    #[command(flatten)]
    pub scene: SceneArgs,
    /// Input rays (u64 count, then 8 f32 per ray).
    #[arg(long, value_name = "FILE")]
    pub rays: PathBuf,
    /// Output hits (f32 t, i32 triangle, f32 u, f32 v per ray).
    #[arg(long, value_name = "FILE")]
    pub out: PathBuf,
    /// Occlusion queries: any hit ends the ray.
    #[arg(long)]
    pub any_hit: bool,
}

#[derive(Debug, Args, Clone)]
pub struct ExportArgs {
    #[command(flatten)]
    pub scene: SceneArgs,
    /// Output file (u64 count, then 9 f32 per triangle).
    #[arg(long, value_name = "FILE")]
    pub out: PathBuf,
}

#[derive(Debug, Args, Clone)]
pub struct BvhStatsArgs {
    #[command(flatten)]
    pub scene: SceneArgs,
    /// DRAM preset whose address mapping the treelet row check uses (see `rtsim dram
    /// --list-presets`); the same as `--set dram.preset=PRESET`. Default: the run's
    /// `dram.preset` (`gddr5-trax` unless a chip preset or the user names another).
    #[arg(long, value_name = "PRESET")]
    pub dram_preset: Option<String>,
}

#[derive(Debug, Args, Clone)]
pub struct ScenesArgs {
    #[arg(long, value_name = "DIR")]
    pub scene_dir: Option<PathBuf>,
}

#[derive(Debug, Args, Clone)]
pub struct BenchArgs {
    #[command(flatten)]
    pub scene: SceneArgs,
    /// Rays per measurement (taken from the workload at a resolution that yields them).
    #[arg(long, default_value_t = 1_000_000, value_parser = crate::cli::usize_arg, allow_negative_numbers = true)]
    pub rays: usize,
    /// Also write the measured rays as DIR/{primary,ao,diffuse}.bin (rays.bin format), e.g.
    /// to time another ray caster on the same rays.
    #[arg(long, value_name = "DIR")]
    pub save_rays: Option<PathBuf>,
    /// Repetitions of each measurement; the fastest is reported.
    #[arg(long, default_value_t = 3, value_parser = crate::cli::u32_arg, allow_negative_numbers = true)]
    pub repeat: u32,
}

/// A whole number in `0..=max` from the command line; a negative or oversized value is an
/// error stating the allowed range (clap would otherwise take `-1` for an unknown flag).
fn unsigned(s: &str, max: u64) -> Result<u64, String> {
    let range = format!("allowed 0..={max}");
    let t = s.trim();
    if t.starts_with('-') && t.len() > 1 {
        return Err(format!("must not be negative ({range})"));
    }
    match t.parse::<u128>() {
        Ok(v) if v <= u128::from(max) => Ok(v as u64),
        Ok(_) => Err(format!("too large ({range})")),
        Err(_) => Err(format!("not a whole number ({range})")),
    }
}

/// Value parser for `u32` flags.
pub fn u32_arg(s: &str) -> Result<u32, String> {
    unsigned(s, u32::MAX.into()).map(|v| v as u32)
}

/// Value parser for image widths and heights: what is not a `u32` is refused stating the
/// range `workload.width` and `.height` allow (`rtsim_trace::config`, 1..=16384); a `u32`
/// outside it is refused by that check, naming the key.
pub fn image_size_arg(s: &str) -> Result<u32, String> {
    unsigned(s, u32::MAX.into()).map(|v| v as u32).map_err(|e| {
        format!(
            "{} (allowed 1..=16384)",
            &e[..e.find(" (").unwrap_or(e.len())]
        )
    })
}

/// Value parser for `u64` flags.
pub fn u64_arg(s: &str) -> Result<u64, String> {
    unsigned(s, u64::MAX)
}

/// Value parser for `usize` flags.
pub fn usize_arg(s: &str) -> Result<usize, String> {
    unsigned(s, usize::MAX as u64).map(|v| v as usize)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unsigned_flags_state_the_range() {
        assert_eq!(u32_arg("12"), Ok(12));
        assert!(u32_arg("-1").unwrap_err().contains("must not be negative"));
        assert!(
            u32_arg("4294967296")
                .unwrap_err()
                .contains("0..=4294967295")
        );
        assert!(u64_arg("x").unwrap_err().contains("not a whole number"));
    }

    #[test]
    fn image_sizes_state_their_own_range() {
        assert_eq!(image_size_arg("33"), Ok(33));
        // 0 and 16385 parse: the config check refuses them, naming `workload.width`.
        assert_eq!(image_size_arg("0"), Ok(0));
        for bad in ["-5", "4294967296", "x"] {
            let e = image_size_arg(bad).unwrap_err();
            assert!(e.contains("allowed 1..=16384"), "{bad}: {e}");
        }
    }
}
