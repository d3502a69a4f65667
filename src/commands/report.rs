//! `rtsim report RESULTS... [--out DIR]`: the papers' tables and figures from one or more
//! sweeps' merged results (or the time series of `simulate --timeline` runs), with the
//! published values beside ours — `report.html` (inline CSS, figures inline
//! as SVG) and `figures/NAME.svg` and `.png` for every figure, written as one output set. The
//! drawing is in `rtsim-report` (`docs/EXPERIMENTS.md`, "Reports").

use anyhow::{Result, bail};
use clap::Args;
use rtsim_core::output::OutputPlan;
use rtsim_report::{FIGURE_DIR, PAGE};
use std::path::{Path, PathBuf};

#[derive(Debug, Args, Clone)]
pub struct ReportArgs {
    /// A sweep's results directory, or its merged table (results.jsonl or results.csv).
    /// Several are read as one set of rows (for instance a Figure 7 sweep and Table 1's runs,
    /// whose 128-TM points it shares); then --out is required. Or `simulate --timeline`
    /// outputs (directories holding timeline.csv, or the files): their time series drawn
    /// against the cycle, one line per run.
    #[arg(required = true, value_name = "RESULTS")]
    pub results: Vec<PathBuf>,
    /// Output directory. Default, with one RESULTS: `report/` in the results directory
    /// (beside the table when a table is given).
    #[arg(long, value_name = "DIR")]
    pub out: Option<PathBuf>,
}

pub fn run(args: ReportArgs) -> Result<()> {
    let out = match (&args.out, args.results.as_slice()) {
        (Some(out), _) => out.clone(),
        (None, [one]) if one.is_dir() => one.join("report"),
        (None, [one]) => one
            .parent()
            .map(|p| p.join("report"))
            .unwrap_or_else(|| PathBuf::from("report")),
        (None, several) => bail!(
            "--out is required with {} RESULTS (the report would otherwise be written into one of them)",
            several.len()
        ),
    };
    // The same results twice (a directory, or either of its tables) would count their runs
    // twice over.
    let mut seen = std::collections::BTreeMap::new();
    for r in &args.results {
        let dir = if r.is_file() {
            r.parent().map(Path::to_path_buf).unwrap_or_default()
        } else {
            r.clone()
        };
        let key = std::fs::canonicalize(&dir).unwrap_or(dir);
        if let Some(first) = seen.insert(key, r) {
            bail!(
                "RESULTS {} and {} are the same results; give each once",
                first.display(),
                r.display()
            );
        }
    }
    let timelines = args
        .results
        .iter()
        .filter(|r| rtsim_report::timeline::is_timeline(r))
        .count();
    let report = if timelines == 0 {
        // For points whose builds predate a setting (`Results::fill_predated`).
        let builtin = rtsim_report::table::scalars(&crate::run_config::builtin_defaults_toml()?)
            .map_err(|e| anyhow::anyhow!("the built-in defaults do not parse: {e}"))?;
        // What points' settings are compared with (`Results::find_departures`). A DRAM preset
        // this build does not know (a point of another build) gives `None`: such a point is
        // compared with its architecture preset's own configuration.
        let presets = |arch: &str, dram: Option<&str>| {
            let toml = crate::run_config::preset_toml(arch, dram).ok()?;
            rtsim_report::table::scalars(&toml).ok()
        };
        let defaults = rtsim_report::Defaults {
            builtin,
            presets: &presets,
            reads: &rtsim_run::arch::reads,
        };
        rtsim_report::build_many(&args.results, &defaults)?
    } else if timelines == args.results.len() {
        rtsim_report::timeline::build(&args.results)?
    } else {
        bail!(
            "RESULTS mixes {timelines} time series (`{}` of `rtsim simulate --timeline`) with {} sweep results; report them separately",
            rtsim_report::timeline::FILE,
            args.results.len() - timelines
        )
    };
    let page = out.join(PAGE);
    let figures = out.join(FIGURE_DIR);
    let mut plan = OutputPlan::new();
    plan.dir(&out, "--out").file(&page);
    for results in args.results.iter().filter(|r| r.is_file()) {
        plan.input("RESULTS", results);
    }
    for (name, _, _) in &report.figures {
        plan.file(figures.join(format!("{name}.svg")))
            .file(figures.join(format!("{name}.png")));
    }
    let mut set = plan.prepare()?;
    set.write(&page, report.html.as_bytes())?;
    for (name, svg, png) in &report.figures {
        set.write(&figures.join(format!("{name}.svg")), svg.as_bytes())?;
        set.write(&figures.join(format!("{name}.png")), png)?;
    }
    set.commit()?;
    println!(
        "report: {} and {} figures (SVG, PNG) in {}",
        page.display(),
        report.figures.len(),
        figures.display()
    );
    Ok(())
}
