//! Reports: the papers' tables and figures drawn from a sweep's merged results, with the
//! published values beside ours.
//!
//! Principal types:
//!
//! - [`table::Table`]: a merged sweep table (`results.jsonl` or `results.csv`) read back, each
//!   row completed from its point's `config.resolved.toml` (the architecture, scene and sizes
//!   that did not vary are not columns of the table).
//! - [`Results`]: the table checked — every row's architecture known ([`Arch`]), every column
//!   the presentations read present — so the builders below never meet a missing value.
//! - [`paper`]: the published values, cited row by row.
//! - [`chart::Chart`]: a line or bar chart, laid out once into primitives that [`svg`] and
//!   [`raster`] both draw (the PNG's text uses an embedded bitmap font: no system fonts).
//! - [`strata`] and [`sgrt`]: one builder per table and figure of each paper.
//! - [`Report`]: the HTML page and every figure's SVG and PNG, built by [`build`]; the CLI
//!   writes them as one output set. The same input gives byte-identical files.

pub mod chart;
pub mod html;
pub mod paper;
pub mod raster;
pub mod sgrt;
pub mod strata;
pub mod svg;
pub mod table;
pub mod timeline;

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use table::{Cell, Row, Table};

/// Why a report cannot be made.
#[derive(Debug, thiserror::Error)]
pub enum ReportError {
    #[error("{path}: {message}")]
    Input { path: PathBuf, message: String },
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("encoding figure {name}: {source}")]
    Png {
        name: String,
        source: png::EncodingError,
    },
}

impl ReportError {
    pub fn input(path: impl Into<PathBuf>, message: impl Into<String>) -> Self {
        ReportError::Input {
            path: path.into(),
            message: message.into(),
        }
    }

    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        ReportError::Io {
            path: path.into(),
            source,
        }
    }
}

/// The architectures a report knows (`arch.preset`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Arch {
    TraxBaseline,
    /// STRaTA on TRaX: the TRaX report's columns plus the stream memory's.
    Strata,
    Sgrt,
    SgrtSptrv,
    Sgrt1,
}

impl Arch {
    pub const ALL: [Arch; 5] = [
        Arch::TraxBaseline,
        Arch::Strata,
        Arch::Sgrt,
        Arch::SgrtSptrv,
        Arch::Sgrt1,
    ];

    pub fn preset(self) -> &'static str {
        match self {
            Arch::TraxBaseline => "trax-baseline",
            Arch::Strata => "strata",
            Arch::Sgrt => "sgrt",
            Arch::SgrtSptrv => "sgrt-sptrv",
            Arch::Sgrt1 => "sgrt-1",
        }
    }

    /// Runs on the TRaX chip (the baseline or STRaTA), reported under `trax.*`.
    pub fn is_trax(self) -> bool {
        matches!(self, Arch::TraxBaseline | Arch::Strata)
    }
}

/// The column naming a row's architecture.
pub const ARCH_COLUMN: &str = "arch.preset";
/// The column naming a row's scene.
pub const SCENE_COLUMN: &str = "scene.name";

/// Checked tables: rows with their architecture, from one results directory or table or
/// several (each row's [`Row::source`] says which, 1-based, when there are several).
#[derive(Clone, Debug, Default)]
pub struct Results {
    pub sources: Vec<PathBuf>,
    pub rows: Vec<(Arch, Row)>,
    /// Settings that some rows' builds predate, drawn at their built-in defaults
    /// ([`Results::fill_predated`]).
    pub predated: Vec<Predated>,
    /// Settings in which rows differ from their presets ([`Results::find_departures`]).
    pub departures: Vec<Departure>,
}

/// A setting that the builds of some rows predate (their resolved configurations lack it,
/// others' have it), drawn for them at its built-in default.
#[derive(Clone, Debug, PartialEq)]
pub struct Predated {
    pub key: String,
    pub default: Cell,
    /// The rows given the default, as (results number when several, point index), in order.
    pub points: Vec<(Option<usize>, usize)>,
}

/// A setting in which rows of one architecture differ from the configuration of their
/// presets alone: an experiment's axis or base (`arch.strata.fill = "static"` in the
/// remedies' sweep), which a table or a curve drawn from those rows alone would not show.
#[derive(Clone, Debug, PartialEq)]
pub struct Departure {
    pub arch: Arch,
    pub key: String,
    pub value: Cell,
    /// The rows holding it, in order.
    pub points: Points,
}

/// The settings ([`table::scalars`]) of the configuration that an `arch.preset` alone gives
/// (no scene, workload or other setting), with the given `dram.preset` in place of the one
/// the architecture's preset names (`None`: that one); `None` for a preset the build does not
/// know. The binary resolves it (`rtsim_run::layers`).
pub type PresetSettings<'a> = &'a dyn Fn(&str, Option<&str>) -> Option<Settings>;

/// Whether the chip of an `arch.preset` reads a setting (`arch.strata.*` is not read by the
/// baseline, nor `arch.trax.*` by SGRT): a setting its chip does not read is neither a
/// departure nor a setting the row's build predates. The binary answers with
/// `rtsim_run::arch::reads`.
pub type ReadsSetting<'a> = &'a dyn Fn(&str, &str) -> bool;

/// A configuration's settings by dotted key.
pub type Settings = BTreeMap<String, Cell>;
/// Rows as (results number when several, point index).
pub type Points = Vec<(Option<usize>, usize)>;

/// Whether a setting is compared with the presets' ([`Results::find_departures`]): the
/// scene and the workload are the tables' rows and the figures' curves already, the presets
/// are what is compared with, and result-neutral settings (output, host threads) do not
/// decide what was simulated.
pub fn compared_with_presets(key: &str) -> bool {
    !(key.starts_with("scene.")
        || key.starts_with("workload.")
        || key == ARCH_COLUMN
        || key == DRAM_PRESET
        || rtsim_sweep::reuse::result_neutral(key))
}

/// The column naming a row's DRAM preset.
pub const DRAM_PRESET: &str = "dram.preset";

impl Results {
    /// Check that every row names a known architecture and has every column the report
    /// reads for it (errors name the file, the point and the column).
    pub fn check(table: Table) -> Result<Results, ReportError> {
        let mut rows = Vec::with_capacity(table.rows.len());
        for row in table.rows {
            let err =
                |m: String| ReportError::input(&table.source, format!("point {}: {m}", row.point));
            let Some(name) = row.text(ARCH_COLUMN) else {
                return Err(err(format!(
                    "no column `{ARCH_COLUMN}` (neither in the table nor in the point's {} beside it)",
                    table::RESOLVED
                )));
            };
            let Some(arch) = Arch::ALL.iter().copied().find(|a| a.preset() == name) else {
                let known: Vec<&str> = Arch::ALL.iter().map(|a| a.preset()).collect();
                return Err(err(format!(
                    "column `{ARCH_COLUMN}` is `{name}`, an architecture the report does not know (it knows {})",
                    known.join(", ")
                )));
            };
            let texts: &[&str] = if arch.is_trax() {
                &[SCENE_COLUMN]
            } else {
                &[SCENE_COLUMN, sgrt::KIND]
            };
            for col in texts {
                if row.text(col).is_none() {
                    return Err(err(format!("no column `{col}` (needed for arch {name})")));
                }
            }
            let required: &[&str] = if arch.is_trax() {
                strata::REQUIRED
            } else {
                sgrt::REQUIRED
            };
            let size = strata::size_column(arch);
            for col in required.iter().chain(size.as_ref()) {
                if row.num(col).is_none() {
                    return Err(err(format!(
                        "no numeric column `{col}` (needed for arch {name})"
                    )));
                }
            }
            rows.push((arch, row));
        }
        Ok(Results {
            sources: vec![table.source],
            rows,
            predated: Vec::new(),
            departures: Vec::new(),
        })
    }

    /// Give every row completed from a resolved configuration that lacks a setting other
    /// rows' configurations have the setting's built-in default (`defaults`: the built-in
    /// configuration's [`table::scalars`]), and record it in [`Results::predated`]. The
    /// row's build predates the setting, and a new setting's default keeps the behaviour
    /// before it: the rule `rtsim sweep --reuse` applies (`rtsim_sweep::reuse`). Without it
    /// a point run before a knob existed would be drawn apart from a later point at the
    /// knob's default, breaking one curve into pieces. Settings without a built-in default,
    /// and rows of a table without point directories, are left alone. A row is recorded only
    /// for settings its chip reads (`reads`): the baseline's points are not said to predate
    /// a STRaTA knob, although they too are given its default.
    pub fn fill_predated(&mut self, defaults: &BTreeMap<String, Cell>, reads: ReadsSetting<'_>) {
        let known: BTreeSet<String> = self
            .rows
            .iter()
            .filter(|(_, row)| row.resolved)
            .flat_map(|(_, row)| row.params.iter().cloned())
            .filter(|k| !rtsim_sweep::reuse::result_neutral(k))
            .collect();
        for key in known {
            let Some(default) = defaults.get(&key) else {
                continue;
            };
            let mut points = Vec::new();
            for (arch, row) in self.rows.iter_mut().filter(|(_, row)| row.resolved) {
                if !row.values.contains_key(&key) {
                    row.values.insert(key.clone(), default.clone());
                    row.params.insert(key.clone());
                    if reads(arch.preset(), &key) {
                        points.push((row.source, row.point));
                    }
                }
            }
            if !points.is_empty() {
                self.predated.push(Predated {
                    key,
                    default: default.clone(),
                    points,
                });
            }
        }
    }

    /// Find the settings in which rows completed from a resolved configuration differ from
    /// the configuration of their presets alone (`presets`), and record them in
    /// [`Results::departures`], by architecture and key, each value with its rows in order.
    /// A row whose `dram.preset` is not its architecture's own is compared with the
    /// configuration of both presets, and the DRAM preset is itself a departure. Settings the
    /// row's chip does not read (`reads`) are not compared: they changed nothing. Run after
    /// [`Results::fill_predated`], so a setting a row's build predates reads as its default.
    pub fn find_departures(&mut self, presets: PresetSettings<'_>, reads: ReadsSetting<'_>) {
        let mut known: BTreeMap<(Arch, Option<String>), Option<Settings>> = BTreeMap::new();
        let mut found: BTreeMap<(Arch, String), Vec<(Cell, Points)>> = BTreeMap::new();
        for (arch, row) in self.rows.iter().filter(|(_, row)| row.resolved) {
            let mut settings = |dram: Option<&str>| {
                known
                    .entry((*arch, dram.map(str::to_string)))
                    .or_insert_with(|| presets(arch.preset(), dram))
                    .clone()
            };
            let Some(own) = settings(None) else {
                continue;
            };
            let mut differ: Vec<(&str, &Cell)> = Vec::new();
            let reference = match row.values.get(DRAM_PRESET) {
                Some(dram) if own.get(DRAM_PRESET) != Some(dram) => {
                    differ.push((DRAM_PRESET, dram));
                    let text = match dram {
                        Cell::Text(t) => Some(t.as_str()),
                        _ => None,
                    };
                    text.and_then(|t| settings(Some(t))).unwrap_or(own)
                }
                _ => own,
            };
            let compared = |k: &&String| compared_with_presets(k) && reads(arch.preset(), k);
            for key in row.params.iter().filter(compared) {
                if let Some(value) = row.values.get(key)
                    && reference.get(key) != Some(value)
                {
                    differ.push((key.as_str(), value));
                }
            }
            for (key, value) in differ {
                let values = found.entry((*arch, key.to_string())).or_default();
                let at = (row.source, row.point);
                match values.iter_mut().find(|(v, _)| v == value) {
                    Some((_, points)) => points.push(at),
                    None => values.push((value.clone(), vec![at])),
                }
            }
        }
        self.departures = found
            .into_iter()
            .flat_map(|((arch, key), values)| {
                values.into_iter().map(move |(value, points)| Departure {
                    arch,
                    key: key.clone(),
                    value,
                    points,
                })
            })
            .collect();
    }

    /// Several checked results as one, in order; with more than one, every row is tagged with
    /// its results' number (1-based), which the page shows beside its point index.
    pub fn merge(parts: Vec<Results>) -> Results {
        let several = parts.len() > 1;
        let mut all = Results::default();
        for (i, part) in parts.into_iter().enumerate() {
            all.sources.extend(part.sources);
            all.predated.extend(part.predated);
            all.departures.extend(part.departures);
            all.rows.extend(part.rows.into_iter().map(|(a, mut row)| {
                row.source = several.then_some(i + 1);
                (a, row)
            }));
        }
        all
    }

    /// Rows of one architecture.
    pub fn of(&self, arch: Arch) -> impl Iterator<Item = &Row> {
        self.rows
            .iter()
            .filter(move |(a, _)| *a == arch)
            .map(|(_, r)| r)
    }
}

/// One figure: its file stem, caption (HTML) and chart.
#[derive(Clone, Debug)]
pub struct Figure {
    pub name: &'static str,
    pub caption: String,
    pub chart: chart::Chart,
    /// HTML shown under the figure (notes, the values the paper's text states).
    pub notes: String,
}

/// A finished report.
#[derive(Clone, Debug)]
pub struct Report {
    pub html: String,
    /// (file stem, SVG text, PNG bytes) of every figure.
    pub figures: Vec<(String, String, Vec<u8>)>,
}

/// Where the figures go, relative to the HTML page.
pub const FIGURE_DIR: &str = "figures";
/// The page's file name.
pub const PAGE: &str = "report.html";

/// Read `results` (a sweep directory or its merged table) and draw the report; `defaults`
/// as for [`build_many`].
pub fn build(results: &Path, defaults: &Defaults<'_>) -> Result<Report, ReportError> {
    build_many(&[results.to_path_buf()], defaults)
}

/// What rows are completed with and compared with.
pub struct Defaults<'a> {
    /// The built-in configuration's settings ([`table::scalars`] of it), given to rows whose
    /// builds predate a setting ([`Results::fill_predated`]).
    pub builtin: BTreeMap<String, Cell>,
    /// The presets' settings, which the page names rows' departures from
    /// ([`Results::find_departures`]).
    pub presets: PresetSettings<'a>,
    /// Which settings each preset's chip reads ([`ReadsSetting`]).
    pub reads: ReadsSetting<'a>,
}

impl std::fmt::Debug for Defaults<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Defaults")
            .field("builtin", &self.builtin)
            .finish_non_exhaustive()
    }
}

/// Read several results (sweep directories or merged tables) and draw one report over all
/// their rows: for instance a Figure 7 sweep together with Table 1's runs at 128 TMs.
pub fn build_many(results: &[PathBuf], defaults: &Defaults<'_>) -> Result<Report, ReportError> {
    let parts = results
        .iter()
        .map(|p| Table::load(p).and_then(Results::check))
        .collect::<Result<Vec<_>, _>>()?;
    let mut all = Results::merge(parts);
    all.fill_predated(&defaults.builtin, defaults.reads);
    all.find_departures(defaults.presets, defaults.reads);
    render(&all)
}

/// Draw the report of checked results.
pub fn render(r: &Results) -> Result<Report, ReportError> {
    let strata = strata::sections(r);
    let sgrt = sgrt::sections(r);
    let figures = draw(strata.figures.iter().chain(&sgrt.figures))?;
    let html = html::page(r, &[strata, sgrt], &figures);
    Ok(Report { html, figures })
}

/// Each figure laid out once and drawn as SVG and PNG: (file stem, SVG text, PNG bytes).
pub(crate) fn draw<'a>(
    figures: impl IntoIterator<Item = &'a Figure>,
) -> Result<Vec<(String, String, Vec<u8>)>, ReportError> {
    figures
        .into_iter()
        .map(|f| {
            let prims = f.chart.layout();
            let png = raster::png(&prims).map_err(|source| ReportError::Png {
                name: f.name.to_string(),
                source,
            })?;
            Ok((f.name.to_string(), svg::render(&prims), png))
        })
        .collect()
}
