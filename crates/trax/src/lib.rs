//! The TRaX baseline chip (STRaTA paper §3 and §5; issue 8): thread multiprocessors (TMs) of
//! in-order, single-issue thread processors (TPs) that share their TM's execution units,
//! instruction caches and L1 data cache; one or more L2s shared by all TMs; the cycle-level
//! DRAM model behind them at its own clock. Every TP runs the whole ray program — pixel loop,
//! camera ray, `stack` traversal with Möller–Trumbore, Lambertian shading with shadow rays,
//! bounces, framebuffer write — as instruction blocks recorded from the functional kernels, so
//! the image and the per-ray counters are the functional tracer's by construction and timing
//! decides only when.
//!
//! Principal types and how they interact:
//!
//! - [`TraxConfig`] (`arch.trax.*`): every chip parameter with its default and source,
//!   validated with errors naming the key.
//! - [`isa`]: an instruction's [`isa::Class`] (its unit, the data cache, local memory or the
//!   atomic counter), registers, record word and address.
//! - [`program`]: the [`Program`] — blocks recorded from the real kernels
//!   ([`program::asm`]), checked class by class against `rtsim_trace::ops`, published as
//!   `docs/TRAX_PROGRAM.md` — and the dynamic block ([`Run`]) a unit of work executes.
//! - [`work`]: a TP's functional state: the pixel's state machine and the ray's stepped
//!   traversal, turned into the sequence of [`Run`]s.
//! - [`chip`]: [`Chip`], the state both timing engines share (TPs with their scoreboards and
//!   priority keys, the cache [`rtsim_cache::Hierarchy`] over [`rtsim_dram::Dram`], the atomic
//!   pixel counter) and the engine-independent operations (access, completion, issue).
//! - [`fast`] and [`reference`]: the two timing engines — run-ahead booking in per-TM
//!   calendars with synchronisation at memory events, and plain cycle by cycle — which tests
//!   prove equal, cycles and stats.
//! - [`stats`], [`energy`], [`report`]: typed counters ([`stats::IssueStats`]), energy per
//!   component from a cited table ([`energy::Energy`]), and the [`TraxReport`].
//!
//! [`simulate`] runs a frame: build the chip, run an engine, drain the memory system, report.
//! The model — every rule and parameter with its source — is `docs/TRAX.md`.

pub mod chip;
pub mod config;
pub mod energy;
pub mod fast;
pub mod isa;
pub mod par;
pub mod program;
pub mod reference;
pub mod report;
pub mod source;
pub mod stats;
pub mod timeline;
pub mod work;

#[cfg(test)]
mod timing_tests;

pub use chip::{Chip, ChipError};
pub use config::{TraxConfig, UnitConfig};
pub use program::{Program, Run, Seg};
pub use report::TraxReport;
pub use source::{Source, SourceAccess, TraxSource};

use rtsim_bvh::MemoryImage;
use rtsim_dram::DramConfig;
use rtsim_trace::{FrameStats, Integrator, PixelResult, Tracer};

/// What to render.
#[derive(Clone, Copy, Debug)]
pub struct Frame<'a> {
    pub integ: &'a Integrator<'a>,
    pub tracer: &'a Tracer,
    pub image: &'a MemoryImage,
    /// The pixels to simulate (row-major indices), in the order the counter hands them out.
    pub pixels: &'a [u32],
    /// Pixels of the whole image (width × height).
    pub image_pixels: usize,
}

/// Which timing engine.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Engine {
    /// Run-ahead booking with synchronisation at memory events (default).
    Fast,
    /// Every TP, every cycle.
    Reference,
}

impl Engine {
    pub fn name(self) -> &'static str {
        match self {
            Engine::Fast => "fast",
            Engine::Reference => "reference",
        }
    }
}

/// How to run.
#[derive(Clone, Copy, Debug)]
pub struct Options {
    pub engine: Engine,
    /// Stop after this many core cycles (the frame is then incomplete).
    pub cycle_limit: Option<u64>,
    /// Seed of the caches' random replacement streams.
    pub seed: u64,
    /// Host threads of the fast engine on the TRaX program ([`par`]): results are
    /// bit-identical whatever the number. 1 (or 0): [`fast`] alone.
    pub threads: usize,
    /// Record the frame's time series ([`timeline`]) in intervals of this many core cycles.
    /// It runs on one host thread ([`fast`] or [`reference`]): the parallel engine does not
    /// sample.
    pub timeline: Option<u64>,
}

impl Options {
    /// The host threads the fast engine runs the TRaX program on: [`Options::threads`] with
    /// the fast engine and no time series ([`par`]), else one. Other sources (STRaTA's) run on
    /// [`fast`] or [`reference`] alone, one thread, whatever these options say.
    pub fn engine_threads(&self) -> usize {
        match self.engine {
            Engine::Fast if self.timeline.is_none() => self.threads.max(1),
            _ => 1,
        }
    }
}

/// Where a run is, for progress bars.
#[derive(Clone, Copy, Debug, Default)]
pub struct Progress {
    pub cycle: u64,
    pub pixels_done: u64,
    pub pixels: u64,
    pub rays: u64,
}

/// A simulated frame.
#[derive(Debug)]
pub struct Output {
    /// One per image pixel (black outside the simulated pixels).
    pub pixels: Vec<PixelResult>,
    /// Core cycles each pixel took on its TP (from the `atominc` that handed it out to the
    /// one after it).
    pub heat: Vec<u64>,
    /// The rays traced, by kind, with their counters.
    pub rays: FrameStats,
    pub report: TraxReport,
    /// The time series, if [`Options::timeline`] asked for one.
    pub timeline: Option<timeline::Timeline>,
}

/// Simulate a frame on the chip `cfg` with `dram` behind it.
pub fn simulate(
    cfg: &TraxConfig,
    dram: &DramConfig,
    frame: Frame<'_>,
    opts: &Options,
    progress: &mut dyn FnMut(Progress),
) -> Result<Output, ChipError> {
    let program = Program::new();
    let ctx = work::Ctx {
        integ: frame.integ,
        tracer: frame.tracer,
        image: frame.image,
        program: &program,
        pixels: frame.pixels,
    };
    let src = TraxSource::new(ctx, cfg.total_tps() as usize);
    let chip = Chip::new(cfg, src, &program, frame.image_pixels, dram, opts.seed)?;
    let (out, _) = run_with(
        chip,
        &program,
        opts,
        progress,
        |chip, limit, tick| match opts.engine {
            Engine::Fast if opts.engine_threads() > 1 => {
                par::run(chip, opts.engine_threads(), limit, tick)
            }
            Engine::Fast => fast::run(chip, limit, tick),
            Engine::Reference => reference::run(chip, limit, tick),
        },
    )?;
    Ok(out)
}

/// Run a built chip to the end of its frame (or `opts.cycle_limit`) with the engine `opts`
/// names (one thread); returns the output and the source, for what it counted.
pub fn run_chip<S: Source>(
    chip: Chip<'_, S>,
    program: &Program,
    opts: &Options,
    progress: &mut dyn FnMut(Progress),
) -> Result<(Output, S), ChipError> {
    run_with(
        chip,
        program,
        opts,
        progress,
        |chip, limit, tick| match opts.engine {
            Engine::Fast => fast::run(chip, limit, tick),
            Engine::Reference => reference::run(chip, limit, tick),
        },
    )
}

/// Run a built chip with `engine` (which runs to the end of the frame or a cycle limit and
/// returns the last cycle), then close its accounts.
fn run_with<'c, S: Source>(
    mut chip: Chip<'c, S>,
    program: &Program,
    opts: &Options,
    progress: &mut dyn FnMut(Progress),
    engine: impl FnOnce(&mut Chip<'c, S>, Option<u64>, fast::Progress<'_>) -> Result<u64, ChipError>,
) -> Result<(Output, S), ChipError> {
    let total = chip.pixel_count;
    let mut tick = |cycle: u64, pixels_done: u64, rays: u64| {
        progress(Progress {
            cycle,
            pixels_done,
            pixels: total,
            rays,
        })
    };
    chip.start_timeline(opts.timeline.filter(|&n| n > 0), opts.cycle_limit);
    let last = engine(&mut chip, opts.cycle_limit, &mut tick)?;
    let (out, src) = chip.finish(last, opts, program)?;
    progress(Progress {
        cycle: out.report.cycles,
        pixels_done: out.report.pixels_done,
        pixels: total,
        rays: out.rays.total().rays,
    });
    Ok((out, src))
}
