//! `arch.preset = "strata"`: STRaTA on the TRaX chip (`rtsim-strata`), cycle by cycle.

use super::trax::{self, Ran};
use super::{RunFacts, SimOutput};
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
        false,
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
    let r = frame(s)?;
    let StrataOutput { out, strata } = r.out;
    let extra = vec![
        format!(
            "stream memory    {} paths, {} pushes, {} pops, {} path records, {:.3} mJ; {} treelet \
             switches, {} reconfigurations",
            strata.paths,
            strata.stream.pushes,
            strata.stream.pops,
            strata.stream.path_reads + strata.stream.path_writes,
            strata.stream_energy_j * 1e3,
            strata.treelet_switches,
            strata.reconfigurations
        ),
        format!(
            "buffer sharing   {:.2} TMs on a buffer when one joins it (at most {}); {} pops \
             refused for their bank",
            strata.holders_at_pick as f64 / strata.treelet_switches.max(1) as f64,
            strata.max_holders,
            strata.bank_conflicts_by_op[0],
        ),
    ];
    let ran = Ran {
        out,
        params: r.params,
        pixels: r.pixels,
        seconds: r.seconds,
        cpu_seconds: r.cpu_seconds,
        threads: r.threads,
    };
    let mut out = trax::output(s, ran, extra, |run, report| {
        Box::new(StrataStats {
            run,
            trax: report,
            strata,
        })
    })?;
    // A path's rays run on many TPs, one stream-memory pop at a time, so no TP's cycles
    // belong to one pixel: the heat map shows the pixel's traversal work instead (nodes
    // visited by all its rays, as `rtsim render`'s), not an empty cycle map.
    out.heat = out.pixels.iter().map(|p| p.nodes_visited as u64).collect();
    out.heat_label = "nodes visited (no per-pixel cycles: a path's rays run on many TPs)";
    Ok(out)
}
