//! `arch.preset = "strata"`: STRaTA on the TRaX chip (`rtsim-strata`), cycle by cycle.

use super::trax::{self, Ran};
use super::{RunFacts, SimOutput, Timing};
use crate::session::Session;
use anyhow::Result;
use rtsim_strata::timed::{StrataFacts, StrataOutput};
use rtsim_trax::TraxReport;
use serde::Serialize;

#[derive(Debug, Serialize)]
struct StrataStats {
    #[serde(flatten)]
    run: RunFacts,
    /// The chip's report (the same fields as the baseline's, so tables line up).
    trax: TraxReport,
    /// The stream memory and the scheduling.
    strata: StrataFacts,
}

/// Run the session's frame on the STRaTA chip.
pub(crate) fn frame(s: &Session) -> Result<Ran<StrataOutput>> {
    let cfg = &s.resolved.config;
    trax::frame_on(
        s,
        Box::new(|f, o, p| {
            Ok(rtsim_strata::timed::simulate(
                &cfg.arch.trax,
                &cfg.arch.strata,
                &cfg.dram,
                f,
                o,
                p,
            )?)
        }),
    )
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
