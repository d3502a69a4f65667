//! `arch.preset = "strata"`: STRaTA on the TRaX chip (`rtsim-strata`), cycle by cycle.

use super::trax::si;
use super::{RunFacts, SimOutput, Timing};
use crate::session::Session;
use anyhow::Result;
use rtsim_run::SimMode;
use rtsim_strata::timed::{StrataFacts, StrataOutput};
use rtsim_trace::Integrator;
use rtsim_trax::{Engine, Frame, Options, TraxReport};
use serde::Serialize;
use std::time::Instant;

#[derive(Debug, Serialize)]
struct StrataStats {
    #[serde(flatten)]
    run: RunFacts,
    /// The chip's report (the same fields as the baseline's, so tables line up).
    trax: TraxReport,
    /// The stream memory and the scheduling.
    strata: StrataFacts,
}

/// A frame run on the STRaTA chip, with its host cost.
pub(crate) struct Ran {
    pub out: StrataOutput,
    pub params: rtsim_trace::WorkloadParams,
    pub pixels: Vec<u32>,
    pub seconds: f64,
    pub cpu_seconds: Option<f64>,
}

/// Run the session's frame on the STRaTA chip, with a progress bar on terminals.
pub(crate) fn frame(s: &Session) -> Result<Ran> {
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
    let out = rtsim_strata::timed::simulate(
        &cfg.arch.trax,
        &cfg.arch.strata,
        &cfg.dram,
        Frame {
            integ: &integ,
            tracer: &s.tracer,
            image: &s.image,
            pixels: &pixels,
            image_pixels: (w * h) as usize,
        },
        &Options {
            engine,
            cycle_limit: cfg.sim.cycle_limit,
            seed: cfg.seed,
        },
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
    })
}

pub fn run(s: &Session) -> Result<SimOutput> {
    let cfg = &s.resolved.config;
    let Ran {
        out,
        params,
        pixels,
        seconds,
        ..
    } = frame(s)?;
    let StrataOutput { out, strata } = out;
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
    summary.push(format!(
        "stream memory    {} paths, {} pushes, {} pops, {} path records, {:.3} mJ; {} treelet \
         switches, {} reconfigurations",
        strata.paths,
        strata.stream.pushes,
        strata.stream.pops,
        strata.stream.path_reads + strata.stream.path_writes,
        strata.stream_energy_j * 1e3,
        strata.treelet_switches,
        strata.reconfigurations
    ));
    let tp_cycles = r.cycles as f64 * r.chip.tps as f64;
    let cycles_per_second = r.cycles as f64 / seconds;
    summary.push(format!(
        "host             {seconds:.2} s: {:.0} cycles/s, {:.1} M TP-cycles/s, {:.1} M instructions/s",
        cycles_per_second,
        tp_cycles / seconds / 1e6,
        r.instructions.total as f64 / seconds / 1e6
    ));
    Ok(SimOutput {
        heat: out.heat.clone(),
        heat_label: "core cycles",
        stats: Box::new(StrataStats {
            run: RunFacts::of(s, &params, pixels.len(), &out.rays),
            trax: out.report,
            strata,
        }),
        pixels: out.pixels,
        timing: Timing {
            threads: 1,
            bvh_build_seconds: s.build_seconds,
            simulate_seconds: seconds,
            cycles_per_second,
        },
        summary,
        files: Vec::new(),
    })
}
