//! `arch.preset = "trax-baseline"`: the TRaX chip (`rtsim-trax`), cycle by cycle.

use super::{RunFacts, SimOutput, Timing};
use crate::session::Session;
use anyhow::Result;
use rtsim_run::SimMode;
use rtsim_trace::Integrator;
use rtsim_trax::{Engine, Frame, Options, TraxReport};
use serde::Serialize;
use std::time::Instant;

#[derive(Debug, Serialize)]
struct TraxStats {
    #[serde(flatten)]
    run: RunFacts,
    trax: TraxReport,
}

/// Compact counts for the progress message.
pub(crate) fn si(n: u64) -> String {
    match n {
        0..1_000 => n.to_string(),
        1_000..1_000_000 => format!("{:.1}K", n as f64 / 1e3),
        1_000_000..1_000_000_000 => format!("{:.1}M", n as f64 / 1e6),
        _ => format!("{:.2}G", n as f64 / 1e9),
    }
}

/// A frame run on the chip (`O`: the chip's output), with its host cost.
pub(crate) struct Ran<O = rtsim_trax::Output> {
    pub out: O,
    pub params: rtsim_trace::WorkloadParams,
    /// The pixels simulated (the window's).
    pub pixels: Vec<u32>,
    /// Wall-clock and process CPU seconds of the simulation alone (not the BVH build).
    pub seconds: f64,
    pub cpu_seconds: Option<f64>,
    /// Host threads the engine ran on ([`Options::engine_threads`] for the TRaX program;
    /// one for the other sources).
    pub threads: usize,
}

/// What runs a frame on a TRaX-chip model: the frame, the engine options, a progress sink.
pub(crate) type ChipRun<'s, O> =
    dyn FnOnce(Frame<'_>, &Options, &mut dyn FnMut(rtsim_trax::Progress)) -> Result<O> + 's;

/// Run the session's frame on a TRaX-chip model (`chip`), with a progress bar on terminals.
/// `parallel`: the model runs the TRaX program, whose fast engine may take several host
/// threads (`rtsim_trax::simulate`); other sources run on one.
pub(crate) fn frame_on<O>(
    s: &Session,
    parallel: bool,
    chip: Box<ChipRun<'_, O>>,
) -> Result<Ran<O>> {
    let cfg = &s.resolved.config;
    let params = rtsim_run::workload_params(&s.resolved);
    let integ = Integrator::new(&s.resolved.scene, &s.tracer, params.clone());
    let (w, h) = (params.width, params.height);
    let pixels = cfg.sim.pixels(w, h);
    let engine = match cfg.sim.mode {
        SimMode::Fast => Engine::Fast,
        SimMode::Reference => Engine::Reference,
    };
    let bar = crate::progress::bar(pixels.len() as u64, "pixels");
    let cpu_start = crate::cputime::process_seconds();
    let start = Instant::now();
    let opts = Options {
        engine,
        cycle_limit: cfg.sim.cycle_limit,
        seed: cfg.seed,
        threads: s.pool.current_num_threads(),
        timeline: cfg.sim.timeline_cycles,
    };
    let threads = if parallel { opts.engine_threads() } else { 1 };
    let out = chip(
        Frame {
            integ: &integ,
            tracer: &s.tracer,
            image: &s.image,
            pixels: &pixels,
            image_pixels: (w * h) as usize,
        },
        &opts,
        &mut |p| {
            bar.set_position(p.pixels_done);
            bar.set_message(format!("{} cycles, {} rays", si(p.cycle), si(p.rays)));
        },
    )?;
    let seconds = start.elapsed().as_secs_f64();
    let cpu_seconds = crate::cputime::process_seconds()
        .zip(cpu_start)
        .map(|(b, a)| b - a);
    bar.finish_and_clear();
    Ok(Ran {
        out,
        params,
        pixels,
        seconds,
        cpu_seconds,
        threads,
    })
}

/// Run the session's frame on the TRaX chip.
pub(crate) fn frame(s: &Session) -> Result<Ran> {
    let cfg = &s.resolved.config;
    frame_on(
        s,
        true,
        Box::new(|f, o, p| Ok(rtsim_trax::simulate(&cfg.arch.trax, &cfg.dram, f, o, p)?)),
    )
}

pub fn run(s: &Session) -> Result<SimOutput> {
    let ran = frame(s)?;
    output(s, ran, Vec::new(), |run, report| {
        Box::new(TraxStats { run, trax: report })
    })
}

/// The `simulate` output of a frame on a TRaX-chip model: the summary (the chip's report,
/// then `extra` lines, then the host's rates), the timing, and the stats `stats` builds from
/// the run's facts and the chip's report.
pub(crate) fn output(
    s: &Session,
    ran: Ran,
    extra: Vec<String>,
    stats: impl FnOnce(RunFacts, TraxReport) -> Box<dyn super::erased::Stats>,
) -> Result<SimOutput> {
    let cfg = &s.resolved.config;
    let Ran {
        out,
        params,
        pixels,
        seconds,
        cpu_seconds,
        threads,
    } = ran;
    let (w, h) = (params.width, params.height);
    let r = &out.report;
    let mut summary = vec![format!(
        "arch             {} ({} pixels of {}x{}, {} rays, traversal {})",
        cfg.arch.preset,
        pixels.len(),
        w,
        h,
        out.rays.total().rays,
        s.tracer.traversal().name()
    )];
    summary.extend(r.summary());
    summary.extend(extra);
    let tp_cycles = r.cycles as f64 * r.chip.tps as f64;
    let cycles_per_second = r.cycles as f64 / seconds;
    let cpu = cpu_seconds.map_or(String::new(), |c| format!(", {c:.2} s CPU"));
    let plural = if threads == 1 { "" } else { "s" };
    summary.push(format!(
        "host             {seconds:.2} s ({threads} thread{plural}{cpu}): {:.0} cycles/s, {:.1} M \
         TP-cycles/s, {:.1} M instructions/s",
        cycles_per_second,
        tp_cycles / seconds / 1e6,
        r.instructions.total as f64 / seconds / 1e6
    ));
    let mut files = Vec::new();
    if let Some(tl) = &out.timeline {
        summary.push(format!(
            "timeline         {} intervals of {} cycles in timeline.csv",
            tl.rows.len(),
            tl.every
        ));
        files.push(("timeline.csv", tl.to_csv().into_bytes()));
    }
    let run = RunFacts::of(s, &params, pixels.len(), &out.rays);
    Ok(SimOutput {
        heat: out.heat.clone(),
        heat_label: "core cycles",
        stats: stats(run, out.report),
        pixels: out.pixels,
        timing: Timing {
            threads,
            bvh_build_seconds: s.build_seconds,
            simulate_seconds: seconds,
            cpu_seconds,
            cycles_per_second,
        },
        summary,
        files,
    })
}
