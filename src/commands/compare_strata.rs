//! `rtsim compare --arch trax-baseline --arch strata`: the STRaTA paper's Table 1 (DRAM
//! accesses, row-buffer hit rate, average read latency, ms/frame, DRAM energy and its
//! percentage of the first architecture's) and Table 3 (register-file and instruction-cache
//! energy, the sum as a percentage of the first's) for one scene, ours beside the paper's
//! (`rtsim_strata::paper`); written as `compare.json`, `table1.csv` and `table3.csv`.

use super::compare::CompareArgs;
use crate::commands::simulate::{strata, trax};
use crate::session;
use anyhow::Result;
use rtsim_strata::paper;
use rtsim_strata::timed::StrataFacts;
use rtsim_trax::TraxReport;
use serde::Serialize;
use std::fmt::Write as _;
use toml::Value;

/// One architecture's Table 1 and Table 3 columns.
#[derive(Debug, Serialize)]
struct Row {
    arch: String,
    dram_accesses_m: f64,
    row_hit_percent: f64,
    read_latency_cycles: f64,
    ms_per_frame: f64,
    dram_energy_j: f64,
    /// DRAM energy as a percentage of the first architecture's.
    dram_energy_percent: f64,
    register_file_j: f64,
    icache_j: f64,
    /// Register file plus instruction cache as a percentage of the first's.
    rf_icache_percent: f64,
    l1_hit_percent: f64,
    total_energy_j: f64,
    simulate_seconds: f64,
}

#[derive(Debug, Serialize)]
struct Run {
    arch: String,
    report: TraxReport,
    strata: Option<StrataFacts>,
}

#[derive(Debug, Serialize)]
struct CompareFile {
    scene: String,
    rows: Vec<Row>,
    /// The paper's rows for this scene, where it has them.
    paper_table1: Option<PaperTable1>,
    paper_table3: Option<PaperTable3>,
    runs: Vec<Run>,
}

#[derive(Debug, Serialize)]
struct PaperTable1 {
    scene: &'static str,
    baseline: [f64; 5],
    strata: [f64; 5],
}

#[derive(Debug, Serialize)]
struct PaperTable3 {
    scene: &'static str,
    baseline_rf_j: f64,
    baseline_icache_j: f64,
    strata_rf_j: f64,
    strata_icache_j: f64,
    diff_percent: f64,
}

fn row(arch: &str, r: &TraxReport, seconds: f64) -> Row {
    Row {
        arch: arch.to_string(),
        dram_accesses_m: r.dram.accesses as f64 / 1e6,
        row_hit_percent: 100.0 * r.dram.row_hit_rate,
        read_latency_cycles: r.dram.average_read_latency_core_cycles,
        ms_per_frame: r.ms_per_frame,
        dram_energy_j: r.dram.energy_j,
        dram_energy_percent: 100.0,
        register_file_j: r.energy.register_file_j,
        icache_j: r.energy.icache_j,
        rf_icache_percent: 100.0,
        l1_hit_percent: 100.0 * r.l1.hit_rate,
        total_energy_j: r.energy.total_j,
        simulate_seconds: seconds,
    }
}

pub fn run(args: &CompareArgs) -> Result<()> {
    anyhow::ensure!(
        args.viewpoints.is_none(),
        "--viewpoints averages SGRT runs; the TRaX tables use the scene's camera"
    );
    let frame = args.frame.flags()?;
    let dir = crate::run_config::resolve(&args.scene, &frame)?
        .config
        .output
        .dir;
    let files = ["compare.json", "table1.csv", "table3.csv"].map(|f| dir.join(f));
    let mut plan = rtsim_core::output::OutputPlan::new();
    plan.dir(&dir, "the output directory (--out, output.dir)");
    for f in &files {
        plan.file(f);
    }
    let mut outputs = plan.prepare()?;
    let (mut rows, mut runs) = (Vec::new(), Vec::new());
    let mut scene = String::new();
    for arch in &args.archs {
        let mut flags = frame.clone();
        flags.push(("arch.preset", Value::String(arch.clone())));
        let s = session::open(&args.scene, &flags, false)?;
        scene = s.resolved.scene.name.clone();
        let (report, facts, seconds) = if arch == "strata" {
            let r = strata::frame(&s)?;
            (r.out.out.report, Some(r.out.strata), r.seconds)
        } else {
            let r = trax::frame(&s)?;
            (r.out.report, None, r.seconds)
        };
        eprintln!("{arch:<14} {:>9} cycles  {:.1} s", report.cycles, seconds);
        rows.push(row(arch, &report, seconds));
        runs.push(Run {
            arch: arch.clone(),
            report,
            strata: facts,
        });
    }
    let (e0, s0) = (
        rows[0].dram_energy_j,
        rows[0].register_file_j + rows[0].icache_j,
    );
    for r in &mut rows {
        r.dram_energy_percent = 100.0 * r.dram_energy_j / e0;
        r.rf_icache_percent = 100.0 * (r.register_file_j + r.icache_j) / s0;
    }
    let p1 = paper::table1(&scene);
    let p3 = paper::table3(&scene);
    let mut t1 = String::from(
        "arch,dram_accesses_m,row_hit_percent,read_latency_cycles,ms_per_frame,dram_energy_j,\
         dram_energy_percent\n",
    );
    let mut t3 = String::from("arch,register_file_j,icache_j,rf_icache_percent\n");
    println!(
        "Table 1 ({scene}): DRAM accesses (M), row-buffer hits (%), read latency (cycles), ms/frame, DRAM energy (J, % of first)"
    );
    for r in &rows {
        println!(
            "  {:<14} {:>9.3} {:>6.1} {:>7.1} {:>9.3} {:>9.4} ({:.0}%)",
            r.arch,
            r.dram_accesses_m,
            r.row_hit_percent,
            r.read_latency_cycles,
            r.ms_per_frame,
            r.dram_energy_j,
            r.dram_energy_percent
        );
        let _ = writeln!(
            t1,
            "{},{},{},{},{},{},{}",
            r.arch,
            r.dram_accesses_m,
            r.row_hit_percent,
            r.read_latency_cycles,
            r.ms_per_frame,
            r.dram_energy_j,
            r.dram_energy_percent
        );
        let _ = writeln!(
            t3,
            "{},{},{},{}",
            r.arch, r.register_file_j, r.icache_j, r.rf_icache_percent
        );
    }
    if let Some(p) = p1 {
        for (name, d) in [("paper baseline", p.baseline), ("paper STRaTA", p.strata)] {
            println!(
                "  {name:<14} {:>9.3} {:>6.1} {:>7.1} {:>9.3} {:>9.4}",
                d.accesses_m,
                d.row_hit_percent,
                d.read_latency_cycles,
                d.ms_per_frame,
                d.dram_energy_j
            );
        }
        println!(
            "  (the paper renders 1024×1024 with its own scene files; see docs/VALIDATION.md)"
        );
    }
    println!("Table 3 ({scene}): register file (J), instruction cache (J), sum as % of first");
    for r in &rows {
        println!(
            "  {:<14} {:>9.4} {:>9.4} {:>6.0}%",
            r.arch, r.register_file_j, r.icache_j, r.rf_icache_percent
        );
    }
    if let Some(p) = p3 {
        println!(
            "  paper          {:.2}/{:.2} J baseline, {:.2}/{:.2} J STRaTA: {:.0}%",
            p.baseline_rf_j, p.baseline_icache_j, p.strata_rf_j, p.strata_icache_j, p.diff_percent
        );
    }
    let arr = |d: paper::DramRow| {
        [
            d.accesses_m,
            d.row_hit_percent,
            d.read_latency_cycles,
            d.ms_per_frame,
            d.dram_energy_j,
        ]
    };
    let file = CompareFile {
        scene,
        rows,
        paper_table1: p1.map(|p| PaperTable1 {
            scene: p.paper_scene,
            baseline: arr(p.baseline),
            strata: arr(p.strata),
        }),
        paper_table3: p3.map(|p| PaperTable3 {
            scene: p.paper_scene,
            baseline_rf_j: p.baseline_rf_j,
            baseline_icache_j: p.baseline_icache_j,
            strata_rf_j: p.strata_rf_j,
            strata_icache_j: p.strata_icache_j,
            diff_percent: p.diff_percent,
        }),
        runs,
    };
    outputs.write(&files[0], serde_json::to_string_pretty(&file)?.as_bytes())?;
    outputs.write(&files[1], t1.as_bytes())?;
    outputs.write(&files[2], t3.as_bytes())?;
    outputs.commit()?;
    for f in &files {
        println!("wrote            {}", f.display());
    }
    Ok(())
}
