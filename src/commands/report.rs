//! `rtsim report RESULTS [--out DIR]`: the papers' tables and figures from a sweep's merged
//! results, with the published values beside ours — `report.html` (inline CSS, figures inline
//! as SVG) and `figures/NAME.svg` and `.png` for every figure, written as one output set. The
//! drawing is in `rtsim-report` (`docs/EXPERIMENTS.md`, "Reports").

use anyhow::Result;
use clap::Args;
use rtsim_core::output::OutputPlan;
use rtsim_report::{FIGURE_DIR, PAGE};
use std::path::PathBuf;

#[derive(Debug, Args, Clone)]
pub struct ReportArgs {
    /// A sweep's results directory, or its merged table (results.jsonl or results.csv).
    pub results: PathBuf,
    /// Output directory. Default: `report/` in the results directory (beside the table when
    /// a table is given).
    #[arg(long, value_name = "DIR")]
    pub out: Option<PathBuf>,
}

pub fn run(args: ReportArgs) -> Result<()> {
    let report = rtsim_report::build(&args.results)?;
    let out = args.out.clone().unwrap_or_else(|| {
        if args.results.is_dir() {
            args.results.join("report")
        } else {
            args.results
                .parent()
                .map(|p| p.join("report"))
                .unwrap_or_else(|| PathBuf::from("report"))
        }
    });
    let page = out.join(PAGE);
    let figures = out.join(FIGURE_DIR);
    let mut plan = OutputPlan::new();
    plan.dir(&out, "--out").file(&page);
    if args.results.is_file() {
        plan.input("RESULTS", &args.results);
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
