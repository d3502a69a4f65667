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
    #[arg(long)]
    pub seed: Option<u64>,
    /// Worker threads (0 = all cores).
    #[arg(long)]
    pub threads: Option<usize>,
}

#[derive(Debug, Args, Clone)]
pub struct RenderArgs {
    #[command(flatten)]
    pub scene: SceneArgs,
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
    #[arg(long, default_value_t = 1_000_000)]
    pub rays: usize,
    /// Also write the measured rays as DIR/{primary,ao,diffuse}.bin (rays.bin format), e.g.
    /// to time another ray caster on the same rays.
    #[arg(long, value_name = "DIR")]
    pub save_rays: Option<PathBuf>,
    /// Repetitions of each measurement; the fastest is reported.
    #[arg(long, default_value_t = 3)]
    pub repeat: u32,
}
