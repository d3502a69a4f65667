//! Figures of a frame's time series: `timeline.csv`, written by `rtsim simulate --timeline N`
//! (`sim.timeline_cycles`, `docs/TRAX.md` §6), drawn against the cycle.
//!
//! One or more runs go on the same axes, one line per run (named by its directory), so two
//! configurations can be read side by side: where one's issue rate falls behind, when its DRAM
//! traffic peaks, how long a STRaTA fill lasts. A rate (issue rate, miss rate, accesses per
//! 1,000 cycles) is over an interval and a level (rays buffered, TMs on the root buffer) at its
//! end; both are drawn at the interval's last cycle. STRaTA's figures appear when a run has
//! STRaTA's columns.

use crate::chart::{Body, Chart, Scale, Series, palette, short_number};
use crate::html::Section;
use crate::svg::escape;
use crate::{Figure, Report, ReportError};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// The file `simulate --timeline` writes in its output directory.
pub const FILE: &str = "timeline.csv";

/// The columns every time series starts with (`rtsim_trax::timeline`).
const LEADING: [&str; 4] = ["cycle", "cycles", "issue_rate", "instructions"];

/// A time series read back.
#[derive(Clone, Debug, PartialEq)]
pub struct Run {
    /// The run's name in legends: its directory's name.
    pub name: String,
    pub source: PathBuf,
    pub columns: Vec<String>,
    /// One row per interval, one value per column.
    pub rows: Vec<Vec<f64>>,
}

/// Whether `path` is a time series: a `timeline.csv`, or a directory holding one and no
/// sweep table (a `simulate` output directory).
pub fn is_timeline(path: &Path) -> bool {
    if path.is_file() {
        return path.file_name().is_some_and(|n| n == FILE);
    }
    path.join(FILE).is_file()
        && !path.join(rtsim_sweep::results::CSV_FILE).exists()
        && !path.join(rtsim_sweep::results::JSONL_FILE).exists()
}

impl Run {
    /// Read `path` (a `timeline.csv` or the directory holding it). Errors name the file, the
    /// line and the column.
    pub fn load(path: &Path) -> Result<Run, ReportError> {
        let file = if path.is_dir() {
            path.join(FILE)
        } else {
            path.to_path_buf()
        };
        let text = std::fs::read_to_string(&file).map_err(|e| ReportError::io(&file, e))?;
        let mut lines = text.lines();
        let header = lines
            .next()
            .ok_or_else(|| ReportError::input(&file, "empty: no header line"))?;
        let columns: Vec<String> = header.split(',').map(str::to_string).collect();
        if columns.len() < LEADING.len() || columns[..LEADING.len()] != LEADING {
            return Err(ReportError::input(
                &file,
                format!(
                    "line 1: not a time series: the header must start with `{}` (`rtsim simulate --timeline N` writes it)",
                    LEADING.join(",")
                ),
            ));
        }
        let mut rows = Vec::new();
        for (i, line) in lines.enumerate() {
            let n = i + 2;
            let cells: Vec<&str> = line.split(',').collect();
            if cells.len() != columns.len() {
                return Err(ReportError::input(
                    &file,
                    format!(
                        "line {n}: {} values for {} columns",
                        cells.len(),
                        columns.len()
                    ),
                ));
            }
            let row = cells
                .iter()
                .zip(&columns)
                .map(|(c, col)| match c.parse::<f64>() {
                    Ok(v) if v.is_finite() => Ok(v),
                    _ => Err(ReportError::input(
                        &file,
                        format!("line {n}: column `{col}`: `{c}` is not a finite number"),
                    )),
                })
                .collect::<Result<Vec<f64>, _>>()?;
            rows.push(row);
        }
        if rows.is_empty() {
            return Err(ReportError::input(&file, "no rows after the header"));
        }
        let dir = file.parent().unwrap_or(Path::new(""));
        let name = std::fs::canonicalize(dir)
            .ok()
            .and_then(|d| d.file_name().map(|n| n.to_string_lossy().into_owned()))
            .unwrap_or_else(|| dir.display().to_string());
        Ok(Run {
            name,
            source: file,
            columns,
            rows,
        })
    }

    fn col(&self, name: &str) -> Option<usize> {
        self.columns.iter().position(|c| c == name)
    }

    /// `f` of every row where it gives a value, at the row's interval end (`cycle +
    /// cycles`, the first two columns).
    fn points(&self, f: Value) -> Vec<(f64, f64)> {
        self.rows
            .iter()
            .filter_map(|row| {
                let get = |name: &str| self.col(name).map_or(f64::NAN, |k| row[k]);
                f(&get).map(|y| (row[0] + row[1], y))
            })
            .collect()
    }
}

/// A row's value by column name (NaN for a column the run lacks).
type Get<'a> = &'a dyn Fn(&str) -> f64;
/// What a figure plots of a row (None: nothing to draw for it).
type Value = fn(Get) -> Option<f64>;

/// A figure of the time series: its file stem, title, y label, what it plots and the
/// columns it needs.
struct Plot {
    name: &'static str,
    title: &'static str,
    y_label: &'static str,
    needs: &'static [&'static str],
    value: Value,
    caption: &'static str,
}

fn ratio(a: f64, b: f64, scale: f64) -> Option<f64> {
    (b > 0.0).then(|| scale * a / b)
}

const PLOTS: [Plot; 10] = [
    Plot {
        name: "timeline-issue-rate",
        title: "Issue rate",
        y_label: "instructions per TP-cycle",
        needs: &["issue_rate"],
        value: |g| Some(g("issue_rate")),
        caption: "Instructions issued in the interval per TP and cycle (1 = every TP issues every cycle).",
    },
    Plot {
        name: "timeline-l1-miss-rate",
        title: "L1 miss rate",
        y_label: "misses per 100 L1 accesses",
        needs: &["l1_accesses", "l1_misses"],
        value: |g| ratio(g("l1_misses"), g("l1_accesses"), 100.0),
        caption: "L1 data-cache misses per 100 accesses in the interval (intervals without an access are not drawn).",
    },
    Plot {
        name: "timeline-dram",
        title: "DRAM traffic",
        y_label: "DRAM accesses per 1,000 cycles",
        needs: &["dram_reads", "dram_writes"],
        value: |g| ratio(g("dram_reads") + g("dram_writes"), g("cycles"), 1000.0),
        caption: "DRAM reads and writes (one per burst) in the interval per 1,000 core cycles.",
    },
    Plot {
        name: "timeline-row-hits",
        title: "DRAM row-buffer hit rate",
        y_label: "row hits per 100 column accesses",
        needs: &["dram_row_hits", "dram_column_accesses"],
        value: |g| ratio(g("dram_row_hits"), g("dram_column_accesses"), 100.0),
        caption: "Column accesses that found their row open, per 100, in the interval (intervals without DRAM traffic are not drawn).",
    },
    Plot {
        name: "timeline-atomic",
        title: "Atomic counter",
        y_label: "grants per cycle",
        needs: &["atomic_grants"],
        value: |g| ratio(g("atomic_grants"), g("cycles"), 1.0),
        caption: "Grants of the global atomic counter per cycle in the interval (pixels on the baseline; path slots and pixels on STRaTA).",
    },
    Plot {
        name: "timeline-rays-buffered",
        title: "Rays in the stream memory",
        y_label: "rays",
        needs: &["rays_buffered"],
        value: |g| Some(g("rays_buffered")),
        caption: "STRaTA: rays waiting in the stream memory's buffers at the interval's end.",
    },
    Plot {
        name: "timeline-root-rays",
        title: "Rays in the root buffer",
        y_label: "rays",
        needs: &["root_rays"],
        value: |g| Some(g("root_rays")),
        caption: "STRaTA: rays waiting in the root treelet's buffer at the interval's end (every path's rays enter there).",
    },
    Plot {
        name: "timeline-root-holders",
        title: "TMs on the root buffer",
        y_label: "TMs",
        needs: &["root_holders"],
        value: |g| Some(g("root_holders")),
        caption: "STRaTA: TMs working on the root treelet at the interval's end.",
    },
    Plot {
        name: "timeline-buffers-with-rays",
        title: "Buffers holding rays",
        y_label: "buffers",
        needs: &["buffers_with_rays"],
        value: |g| Some(g("buffers_with_rays")),
        caption: "STRaTA: treelet buffers holding at least one ray at the interval's end (how far the rays have spread).",
    },
    Plot {
        name: "timeline-live-paths",
        title: "Paths in flight",
        y_label: "paths",
        needs: &["live_paths"],
        value: |g| Some(g("live_paths")),
        caption: "STRaTA: paths holding a stream-memory slot at the interval's end (under <code>arch.strata.fill = static</code> every slot counts from the first cycle).",
    },
];

/// Ticks for the cycle axis: 0 and about five round steps to the last cycle.
fn cycle_ticks(last: f64) -> Vec<(f64, String)> {
    let step = crate::chart::nice_step((last / 5.0).max(1.0));
    let mut ticks = Vec::new();
    let mut x = 0.0;
    while x <= last * (1.0 + 1e-9) {
        ticks.push((x, short_number(x)));
        x += step;
    }
    ticks
}

/// The figures and page of one or more time series (`rtsim report` on `simulate` outputs).
pub fn build(inputs: &[PathBuf]) -> Result<Report, ReportError> {
    let mut runs = inputs
        .iter()
        .map(|p| Run::load(p))
        .collect::<Result<Vec<_>, _>>()?;
    // Two runs with the same directory name are told apart by their number.
    let mut seen: BTreeMap<String, usize> = BTreeMap::new();
    for r in &runs {
        *seen.entry(r.name.clone()).or_default() += 1;
    }
    for (i, r) in runs.iter_mut().enumerate() {
        if seen[&r.name] > 1 {
            r.name = format!("[{}] {}", i + 1, r.name);
        }
    }
    let last = runs
        .iter()
        .flat_map(|r| r.rows.iter().map(|row| row[0] + row[1]))
        .fold(0.0, f64::max);
    let mut section = Section {
        title: "Time series".into(),
        ..Section::default()
    };
    for p in &PLOTS {
        let series: Vec<Series> = runs
            .iter()
            .enumerate()
            .filter(|(_, r)| p.needs.iter().all(|c| r.col(c).is_some()))
            .map(|(i, r)| Series {
                name: r.name.clone(),
                points: r.points(p.value),
                color: palette(i),
                dashed: false,
            })
            .collect();
        if series.is_empty() {
            continue;
        }
        section.figure(Figure {
            name: p.name,
            caption: format!("{} {}", escape(p.title), p.caption),
            chart: Chart {
                title: p.title.into(),
                x_label: "core cycle (end of the interval)".into(),
                y_label: p.y_label.into(),
                body: Body::Lines {
                    x_scale: Scale::Linear,
                    y_scale: Scale::Linear,
                    x_ticks: cycle_ticks(last),
                    series,
                    marker: None,
                },
            },
            notes: String::new(),
        });
    }
    let figures = crate::draw(&section.figures)?;
    let html = crate::html::document("rtsim time series", &intro(&runs), &[section], &figures);
    Ok(Report { html, figures })
}

/// The page's opening: each run, its interval and length.
fn intro(runs: &[Run]) -> String {
    let mut s = String::from(
        "<p>Each line is one run's <code>timeline.csv</code> (<code>rtsim simulate --timeline N</code>): \
         rates over an interval and levels at its end, both drawn at the interval's last cycle.</p>\n<ul>\n",
    );
    for r in runs {
        let every = r.rows[0][1];
        let end = r.rows.last().map_or(0.0, |row| row[0] + row[1]);
        s.push_str(&format!(
            "<li>{}: <code>{}</code>, {} intervals of {} cycles, {} cycles</li>\n",
            escape(&r.name),
            escape(&r.source.display().to_string()),
            r.rows.len(),
            every,
            end
        ));
    }
    s.push_str("</ul>\n");
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    const HEAD: &str = "cycle,cycles,issue_rate,instructions,l1_accesses,l1_misses";

    fn write(dir: &Path, text: &str) -> PathBuf {
        std::fs::create_dir_all(dir).unwrap();
        let f = dir.join(FILE);
        std::fs::write(&f, text).unwrap();
        f
    }

    #[test]
    fn a_time_series_reads_back_and_rates_skip_empty_intervals() {
        let t = tempfile::tempdir().unwrap();
        let d = t.path().join("run");
        write(
            &d,
            &format!("{HEAD}\n0,100,0.5,200,10,1\n100,50,0.25,50,0,0\n"),
        );
        assert!(is_timeline(&d) && is_timeline(&d.join(FILE)));
        let r = Run::load(&d).unwrap();
        assert_eq!(r.name, "run");
        assert_eq!(r.rows.len(), 2);
        let miss = &PLOTS[1];
        assert_eq!(miss.name, "timeline-l1-miss-rate");
        assert_eq!(r.points(miss.value), [(100.0, 10.0)]);
        assert_eq!(r.points(PLOTS[0].value), [(100.0, 0.5), (150.0, 0.25)]);
        // A sweep's results directory is not a time series, even with one inside.
        std::fs::write(d.join(rtsim_sweep::results::CSV_FILE), "").unwrap();
        assert!(!is_timeline(&d));
    }

    #[test]
    fn broken_files_are_refused_by_line_and_column() {
        let t = tempfile::tempdir().unwrap();
        let err = |text: &str| {
            let f = write(t.path(), text);
            Run::load(&f).unwrap_err().to_string()
        };
        assert!(err("").contains("no header"));
        assert!(err("a,b\n1,2\n").contains("line 1: not a time series"));
        assert!(err(&format!("{HEAD}\n")).contains("no rows"));
        let e = err(&format!("{HEAD}\n0,100,0.5,200,x,1\n"));
        assert!(
            e.contains("line 2") && e.contains("`l1_accesses`") && e.contains("`x`"),
            "{e}"
        );
        let e = err(&format!("{HEAD}\n0,100,0.5,200,10,1\n0,1\n"));
        assert!(e.contains("line 3: 2 values for 6 columns"), "{e}");
    }
}
