//! `rtsim compare --arch trax-baseline --arch strata`: the STRaTA paper's Table 1 (DRAM
//! accesses, row-buffer hit rate, average read latency, ms/frame, DRAM energy and its
//! percentage of the first architecture's) and Table 3 (register-file and instruction-cache
//! energy, the sum as a percentage of the first's) for one scene, ours beside the paper's
//! (`rtsim_strata::paper`); written as `compare.json`, `table1.csv` and `table3.csv`, with
//! host time in `timing.json`. Where both architectures ran, each column says whether
//! STRaTA moves it the paper's way. Values are printed to three significant figures; a rate
//! with nothing to count (no DRAM reads in a frame cut short) is `n/a`.

use super::compare::{CompareArgs, RunTiming, TimingFile};
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
    /// False when the cycle limit stopped the frame: its figures are not a whole frame's.
    complete: bool,
    dram_accesses_m: f64,
    /// None without DRAM column accesses.
    row_hit_percent: Option<f64>,
    /// None without DRAM reads.
    read_latency_cycles: Option<f64>,
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

fn row(arch: &str, r: &TraxReport) -> Row {
    Row {
        arch: arch.to_string(),
        complete: r.complete,
        dram_accesses_m: r.dram.accesses as f64 / 1e6,
        row_hit_percent: (r.dram.accesses > 0).then_some(100.0 * r.dram.row_hit_rate),
        read_latency_cycles: (r.dram.reads > 0).then_some(r.dram.average_read_latency_core_cycles),
        ms_per_frame: r.ms_per_frame,
        dram_energy_j: r.dram.energy_j,
        dram_energy_percent: 100.0,
        register_file_j: r.energy.register_file_j,
        icache_j: r.energy.icache_j,
        rf_icache_percent: 100.0,
        l1_hit_percent: 100.0 * r.l1.hit_rate,
        total_energy_j: r.energy.total_j,
    }
}

/// `v` to three significant figures: plain decimals from 0.001 (`0.0431`, `39.0`, `1980`),
/// exponent form below (`6.16e-8`), where plain decimals would be a row of zeros.
fn significant(v: f64) -> String {
    if v != 0.0 && v.is_finite() && v.abs() < 1e-3 {
        format!("{v:.2e}")
    } else {
        rtsim_report::html::significant(v, 3)
    }
}

/// Three significant figures, or `n/a`.
fn sig(v: Option<f64>) -> String {
    v.map_or_else(|| "n/a".to_string(), significant)
}

/// A CSV cell: the exact value, or empty for none.
fn cell(v: Option<f64>) -> String {
    v.map_or_else(String::new, |v| v.to_string())
}

/// Whether ours moves from `ours.0` (baseline) to `ours.1` (STRaTA) the way the paper's
/// moves from `paper.0` to `paper.1`; None where the paper shows no change (no direction).
fn direction(ours: (f64, f64), paper: (f64, f64)) -> Option<&'static str> {
    let sign = |(a, b): (f64, f64)| {
        let tolerance = 1e-9 * a.abs().max(b.abs());
        if (b - a).abs() <= tolerance {
            0
        } else if b > a {
            1
        } else {
            -1
        }
    };
    match (sign(ours), sign(paper)) {
        (_, 0) => None,
        (0, _) => Some("no change while the paper's changes"),
        (o, p) if o == p => Some("same direction as paper"),
        _ => Some("opposite to paper"),
    }
}

/// "up"/"down"/"same" of a change, for the direction lines.
fn arrow(a: f64, b: f64) -> &'static str {
    if b > a {
        "up"
    } else if b < a {
        "down"
    } else {
        "same"
    }
}

/// The direction line of one column: ours and the paper's baseline → STRaTA, and whether
/// they agree. None where a value is missing or the paper shows no change.
fn direction_line(
    what: &str,
    unit: &str,
    ours: (Option<f64>, Option<f64>),
    paper: (f64, f64),
) -> Option<String> {
    let ours = (ours.0?, ours.1?);
    let verdict = direction(ours, paper)?;
    let show = significant;
    Some(format!(
        "  {what:<22} ours {} → {}{unit} ({}), paper {} → {}{unit} ({}): {verdict}",
        show(ours.0),
        show(ours.1),
        arrow(ours.0, ours.1),
        show(paper.0),
        show(paper.1),
        arrow(paper.0, paper.1)
    ))
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
    let files = ["compare.json", "table1.csv", "table3.csv", "timing.json"].map(|f| dir.join(f));
    let mut plan = rtsim_core::output::OutputPlan::new();
    plan.dir(&dir, "the output directory (--out, output.dir)");
    for f in &files {
        plan.file(f);
    }
    let mut outputs = plan.prepare()?;
    let (mut rows, mut runs) = (Vec::new(), Vec::new());
    let mut scene = String::new();
    let mut timing = TimingFile { runs: Vec::new() };
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
        if !report.complete {
            eprintln!(
                "warning: {arch}: the frame is incomplete (stopped by the cycle limit after {} \
                 cycles, {} of {} pixels done); its figures are not a whole frame's",
                report.cycles, report.pixels_done, report.pixels
            );
        }
        timing.runs.push(RunTiming {
            arch: arch.clone(),
            viewpoint: None,
            simulate_seconds: seconds,
        });
        rows.push(row(arch, &report));
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
    let flag = |r: &Row| if r.complete { "" } else { "  INCOMPLETE frame" };
    for r in &rows {
        println!(
            "  {:<14} {:>9} {:>6} {:>7} {:>9} {:>9} ({:.0}%){}",
            r.arch,
            sig(Some(r.dram_accesses_m)),
            sig(r.row_hit_percent),
            sig(r.read_latency_cycles),
            sig(Some(r.ms_per_frame)),
            sig(Some(r.dram_energy_j)),
            r.dram_energy_percent,
            flag(r)
        );
        let _ = writeln!(
            t1,
            "{},{},{},{},{},{},{}",
            r.arch,
            r.dram_accesses_m,
            cell(r.row_hit_percent),
            cell(r.read_latency_cycles),
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
    let base = rows.iter().find(|r| r.arch == "trax-baseline");
    let ours = rows.iter().find(|r| r.arch == "strata");
    if let Some(p) = p1 {
        for (name, d) in [("paper baseline", p.baseline), ("paper STRaTA", p.strata)] {
            println!(
                "  {name:<14} {:>9} {:>6} {:>7} {:>9} {:>9}",
                significant(d.accesses_m),
                significant(d.row_hit_percent),
                significant(d.read_latency_cycles),
                significant(d.ms_per_frame),
                significant(d.dram_energy_j)
            );
        }
        let whole = rows.iter().all(|r| r.complete);
        if let (Some(b), Some(s), true) = (base, ours, whole) {
            println!("  STRaTA against the baseline, ours and the paper's:");
            let lines = [
                (
                    "DRAM accesses",
                    " M",
                    (Some(b.dram_accesses_m), Some(s.dram_accesses_m)),
                    (p.baseline.accesses_m, p.strata.accesses_m),
                ),
                (
                    "row-buffer hits",
                    " %",
                    (b.row_hit_percent, s.row_hit_percent),
                    (p.baseline.row_hit_percent, p.strata.row_hit_percent),
                ),
                (
                    "read latency",
                    " cycles",
                    (b.read_latency_cycles, s.read_latency_cycles),
                    (p.baseline.read_latency_cycles, p.strata.read_latency_cycles),
                ),
                (
                    "ms/frame",
                    " ms",
                    (Some(b.ms_per_frame), Some(s.ms_per_frame)),
                    (p.baseline.ms_per_frame, p.strata.ms_per_frame),
                ),
                (
                    "DRAM energy",
                    " J",
                    (Some(b.dram_energy_j), Some(s.dram_energy_j)),
                    (p.baseline.dram_energy_j, p.strata.dram_energy_j),
                ),
            ];
            for (what, unit, o, pp) in lines {
                if let Some(l) = direction_line(what, unit, o, pp) {
                    println!("{l}");
                }
            }
        }
        println!(
            "  (the paper renders 1024×1024 with its own scene files; see docs/VALIDATION.md)"
        );
    }
    if rows.iter().any(|r| !r.complete) {
        println!("  (no directions against the paper: a frame is incomplete)");
    }
    println!("Table 3 ({scene}): register file (J), instruction cache (J), sum as % of first");
    for r in &rows {
        println!(
            "  {:<14} {:>9} {:>9} {:>6.0}%{}",
            r.arch,
            significant(r.register_file_j),
            significant(r.icache_j),
            r.rf_icache_percent,
            flag(r)
        );
    }
    if let Some(p) = p3 {
        println!(
            "  paper          {}/{} J baseline, {}/{} J STRaTA: {:.0}%",
            significant(p.baseline_rf_j),
            significant(p.baseline_icache_j),
            significant(p.strata_rf_j),
            significant(p.strata_icache_j),
            p.diff_percent
        );
        if let (Some(b), Some(s), true) = (base, ours, rows.iter().all(|r| r.complete)) {
            let sum = |r: &Row| Some(r.register_file_j + r.icache_j);
            let paper_sum = (
                p.baseline_rf_j + p.baseline_icache_j,
                p.strata_rf_j + p.strata_icache_j,
            );
            if let Some(l) = direction_line("RF + I$ energy", " J", (sum(b), sum(s)), paper_sum) {
                println!("  STRaTA against the baseline, ours and the paper's:\n{l}");
            }
        }
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
    outputs.write(&files[3], serde_json::to_string_pretty(&timing)?.as_bytes())?;
    outputs.commit()?;
    for f in &files {
        println!("wrote            {}", f.display());
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn directions_compare_ours_with_the_papers() {
        // Sibenik 96×96: our DRAM accesses rise while the paper's fall.
        assert_eq!(
            direction((0.104, 0.837), (39.0, 15.0)),
            Some("opposite to paper")
        );
        assert_eq!(
            direction((0.8, 0.1), (39.0, 15.0)),
            Some("same direction as paper")
        );
        assert_eq!(
            direction((1.0, 2.0), (5.0, 5.0)),
            None,
            "no paper direction"
        );
        assert_eq!(
            direction((1.0, 1.0), (5.0, 6.0)),
            Some("no change while the paper's changes")
        );
        let l = direction_line(
            "DRAM accesses",
            " M",
            (Some(0.104), Some(0.837)),
            (39.0, 15.0),
        )
        .unwrap();
        assert!(
            l.contains("ours 0.104 → 0.837 M (up), paper 39.0 → 15.0 M (down): opposite"),
            "{l}"
        );
        assert_eq!(direction_line("x", "", (None, Some(1.0)), (1.0, 2.0)), None);
    }

    #[test]
    fn small_values_keep_three_significant_figures_and_missing_ones_say_so() {
        assert_eq!(sig(Some(0.00123456)), "0.00123");
        assert_eq!(sig(Some(6.1649e-8)), "6.16e-8");
        assert_eq!(sig(Some(0.0)), "0");
        assert_eq!(sig(Some(39.0)), "39.0");
        assert_eq!(sig(None), "n/a");
        assert_eq!(cell(None), "");
    }
}
