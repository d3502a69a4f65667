//! `arch.preset = "sgrt"` (and `sgrt-sptrv`, `sgrt-1`): the SGRT chip (`rtsim_sgrt`) on the
//! DRAM model, with the frame's image and the figures of the paper's tables.

use super::{SimOutput, Timing};
use crate::progress;
use crate::session::Session;
use anyhow::{Context, Result};
use rtsim_core::Clock;
use rtsim_dram::{Dram, Requester};
use rtsim_run::SimMode;
use rtsim_run::facts::{BvhFacts, RayFacts, SceneFacts, WorkloadFacts};
use rtsim_sgrt::{Engine, Input, RaysQuery, Report, Sgrt, SgrtStats, memory_tags};
use rtsim_trace::query::encode_hits;
use rtsim_trace::{Integrator, PixelResult, Query};
use serde::Serialize;
use std::time::Instant;

#[derive(Debug, Serialize)]
struct SgrtStatsFile {
    rtsim_version: &'static str,
    arch: String,
    scene: SceneFacts,
    bvh: BvhFacts,
    workload: WorkloadFacts,
    traversal: &'static str,
    /// Pixels simulated (the window's), or rays of `arch.sgrt.rays_file`.
    items: u64,
    /// Every ray, in the functional tracer's terms (equal to `rtsim simulate --arch
    /// functional`'s).
    rays: RayFacts,
    /// The figures of the paper's tables.
    sgrt: Report,
    /// The raw counters: per core and summed, every cache.
    counters: SgrtStats,
    /// The DRAM's own report (`rtsim dram`'s `dram_stats.json`).
    dram: rtsim_dram::Report,
}

/// What a run of the SGRT model produced, for `simulate` and `compare`.
pub struct SgrtRun {
    pub output: SimOutput,
    pub report: Report,
}

pub fn run(s: &Session) -> Result<SimOutput> {
    Ok(simulate(s)?.output)
}

/// Simulate the session's frame (or rays file) on the configured SGRT chip.
pub fn simulate(s: &Session) -> Result<SgrtRun> {
    let cfg = &s.resolved.config;
    let sg = &cfg.arch.sgrt;
    let params = rtsim_run::workload_params(&s.resolved);
    let (w, h) = (params.width, params.height);
    let integ = Integrator::new(&s.resolved.scene, &s.tracer, params.clone());
    let requester =
        Requester::new(Clock::from_mhz(sg.ti_clock_mhz.into())).with_tags(memory_tags(sg));
    let dram = Dram::new(&cfg.dram, requester).context("building the DRAM model")?;
    let pixels = cfg.sim.pixels(w, h);
    let whole = pixels.len() as u64 == u64::from(w) * u64::from(h);
    let input = match &sg.rays_file {
        Some(path) => Input::Rays {
            path,
            query: match sg.rays_query {
                RaysQuery::Closest => Query::Closest,
                RaysQuery::Any => Query::Any,
            },
        },
        None => Input::Frame {
            integ: &integ,
            timed: Input::timed_kinds(params.kind, sg.shader),
            pixels,
        },
    };
    let mut chip = Sgrt::new(sg, &s.tracer, &s.image, input, dram, cfg.seed)?;
    let engine = match cfg.sim.mode {
        SimMode::Fast => Engine::Fast,
        SimMode::Reference => Engine::Reference,
    };
    let bar = progress::bar(chip.progress().1, "sgrt");
    let start = Instant::now();
    chip.run(engine, cfg.sim.cycle_limit, &mut |done, _| {
        bar.set_position(done)
    })?;
    let result = chip.finish()?;
    let seconds = start.elapsed().as_secs_f64();
    bar.finish_and_clear();
    let mut memory = result.memory;
    let dram_report = memory.report(result.stats.cycles);
    let report = Report::new(
        sg,
        &result.stats,
        Some(&dram_report),
        whole && sg.rays_file.is_none(),
    );
    let rays_mode = sg.rays_file.is_some();
    let mut files = Vec::new();
    if rays_mode {
        let mut bytes = Vec::new();
        encode_hits(&result.hits, &mut bytes);
        files.push(("hits.bin", bytes));
    }
    let mut summary = report.summary();
    summary.push(format!(
        "host             {seconds:.2} s: {:.0} simulated rays/s, {:.0} T&I cycles/s",
        report.rays as f64 / seconds.max(1e-9),
        result.stats.cycles as f64 / seconds.max(1e-9)
    ));
    if rays_mode {
        summary.push(format!(
            "hits             {}",
            cfg.output.dir.join("hits.bin").display()
        ));
    }
    let n = (w * h) as usize;
    let (pixels, heat) = if rays_mode {
        (vec![PixelResult::default(); n], vec![0; n])
    } else {
        (result.pixels, result.heat)
    };
    let stats = SgrtStatsFile {
        rtsim_version: env!("CARGO_PKG_VERSION"),
        arch: cfg.arch.preset.clone(),
        scene: SceneFacts::of(&s.resolved.scene),
        bvh: BvhFacts::of(s.tracer.bvh(), Some(&s.image)),
        workload: WorkloadFacts::of(&params),
        traversal: s.tracer.traversal().name(),
        items: result.stats.items,
        rays: RayFacts::of(&result.frame, params.kind),
        sgrt: report.clone(),
        counters: result.stats.clone(),
        dram: dram_report,
    };
    Ok(SgrtRun {
        output: SimOutput {
            pixels,
            heat,
            heat_label: "T&I cycles",
            stats: Box::new(stats),
            timing: Timing {
                threads: 1,
                bvh_build_seconds: s.build_seconds,
                simulate_seconds: seconds,
                cpu_seconds: None,
                cycles_per_second: result.stats.cycles as f64 / seconds.max(1e-9),
            },
            summary,
            files,
        },
        report,
    })
}
