//! Experiment files and their points.
//!
//! ```toml
//! name = "strata-fig7"          # names the results directory (results/strata-fig7)
//! command = "simulate"          # render | simulate | dram | cache | bench | bvh-stats
//! args = ["--arch", "strata"]   # optional: fixed command-line arguments of every point
//!
//! [base]                        # settings every point shares: dotted keys or nested tables
//! "scene.name" = "sibenik"
//! workload = { width = 256, height = 256 }
//!
//! [grid]                        # every combination is a point; the last key varies fastest
//! "arch.preset" = ["trax-baseline", "strata"]
//! "arch.trax.tms" = [1, 2, 4, 8]
//!
//! [[point]]                     # explicit points, after the grid's, each over [base]
//! "scene.name" = "dragon-box"
//! quick = { "workload.width" = 48 }  # optional: this point's own --quick overrides
//!
//! [quick]                       # with --quick: overrides for every point (minutes, not hours)
//! "workload.width" = 32
//! "arch.trax.tms" = [1, 4]      # a key the [grid] varies: a list that replaces its values
//!
//! [[exclude]]                   # grid points not to run: those with all of these values
//! "arch.preset" = "strata"
//! "arch.trax.tms" = 1
//! ```
//!
//! With `--quick`, a point's settings are `[base]`, its grid values (a `[quick]` list replacing
//! a grid key's), its `[[point]]` settings, the `[quick]` scalars, then its own `quick` table.
//! A point's recorded parameters are the values it runs with. Two points with the same
//! settings (at either scale) are an error, as is one key written twice in a section (a dotted
//! key and a nested table).
//!
//! Keys are the command's configuration keys (for `dram`, keys under `dram.`, as its
//! `--config` file takes a `[dram]` table). Grid keys vary in alphabetical order (TOML tables
//! are sorted), the last fastest; points are numbered grid first, then `[[point]]`s in file
//! order; with neither, the experiment is one point. An excluded grid point keeps its number
//! (the numbers after it do not move, so adding an exclusion never renames finished points),
//! and `--list` shows the gap. Each point's settings are written as a
//! config file the command reads with `--config`, so every point is also an ordinary run that
//! `config.resolved.toml` repeats.

use crate::SweepError;
use rtsim_config::Layers;
use serde_json::Value as Json;
use std::path::{Path, PathBuf};
use toml::{Table, Value};

/// Most points one experiment may have (a runaway grid is a typo, not an experiment).
pub const MAX_POINTS: usize = 1_000_000;

/// The rtsim command an experiment runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SweepCommand {
    Render,
    Simulate,
    Dram,
    Cache,
    Bench,
    BvhStats,
}

impl SweepCommand {
    pub const ALL: [SweepCommand; 6] = [
        SweepCommand::Render,
        SweepCommand::Simulate,
        SweepCommand::Dram,
        SweepCommand::Cache,
        SweepCommand::Bench,
        SweepCommand::BvhStats,
    ];

    pub fn name(self) -> &'static str {
        match self {
            SweepCommand::Render => "render",
            SweepCommand::Simulate => "simulate",
            SweepCommand::Dram => "dram",
            SweepCommand::Cache => "cache",
            SweepCommand::Bench => "bench",
            SweepCommand::BvhStats => "bvh-stats",
        }
    }

    fn parse(s: &str) -> Option<SweepCommand> {
        Self::ALL.into_iter().find(|c| c.name() == s)
    }

    /// Whether the command writes into an `--out DIR` (else its standard output is the result).
    pub fn has_out_dir(self) -> bool {
        !matches!(self, SweepCommand::Bench | SweepCommand::BvhStats)
    }

    /// Whether the command reads the run configuration (with its `threads` key).
    pub fn reads_run_config(self) -> bool {
        !matches!(self, SweepCommand::Dram | SweepCommand::Cache)
    }

    /// The deterministic statistics file whose values become the point's metrics.
    pub fn stats_file(self) -> Option<&'static str> {
        match self {
            SweepCommand::Render | SweepCommand::Simulate => Some("stats.json"),
            SweepCommand::Dram => Some("dram_stats.json"),
            SweepCommand::Cache => Some("cache_stats.json"),
            SweepCommand::Bench | SweepCommand::BvhStats => None,
        }
    }
}

/// A parsed, validated experiment.
#[derive(Clone, Debug)]
pub struct Experiment {
    /// The file it was read from.
    pub path: PathBuf,
    pub name: String,
    pub command: SweepCommand,
    /// Fixed command-line arguments of every point.
    pub args: Vec<String>,
    base: Vec<(String, Value)>,
    grid: Vec<(String, Vec<Value>)>,
    /// `[[exclude]]`: grid points with all of one entry's values are not run.
    exclude: Vec<Vec<(String, Value)>>,
    points: Vec<ExplicitPoint>,
    /// `[quick]`, if the experiment has one: its lists for grid keys and its other settings.
    quick: Option<Quick>,
}

/// A `[[point]]`: its settings and its own `quick` overrides.
#[derive(Clone, Debug)]
struct ExplicitPoint {
    settings: Vec<(String, Value)>,
    quick: Vec<(String, Value)>,
}

/// The `[quick]` section.
#[derive(Clone, Debug, Default)]
struct Quick {
    /// Replacement values of grid keys.
    grid: Vec<(String, Vec<Value>)>,
    /// Overrides of every point.
    settings: Vec<(String, Value)>,
}

/// One run of an experiment.
#[derive(Clone, Debug, PartialEq)]
pub struct Point {
    /// The point's number, from 0, in the experiment's order (an excluded grid point's number
    /// is skipped, not reused).
    pub index: usize,
    /// What distinguishes this point: its grid values and explicit settings, sorted by key.
    pub params: Vec<(String, Value)>,
    /// The config file the command reads (`--config`): base, params, quick overrides.
    pub config_toml: String,
}

impl Point {
    /// The parameters as JSON (for records and result tables).
    pub fn params_json(&self) -> serde_json::Map<String, Json> {
        self.params
            .iter()
            .map(|(k, v)| (k.clone(), toml_to_json(v)))
            .collect()
    }
}

/// A TOML value as JSON (datetimes as strings).
pub fn toml_to_json(v: &Value) -> Json {
    match v {
        Value::String(s) => Json::String(s.clone()),
        Value::Integer(i) => Json::from(*i),
        Value::Float(f) => serde_json::Number::from_f64(*f).map_or(Json::Null, Json::Number),
        Value::Boolean(b) => Json::Bool(*b),
        Value::Datetime(d) => Json::String(d.to_string()),
        Value::Array(a) => Json::Array(a.iter().map(toml_to_json).collect()),
        Value::Table(t) => Json::Object(
            t.iter()
                .map(|(k, v)| (k.clone(), toml_to_json(v)))
                .collect(),
        ),
    }
}

/// Flatten a section, refusing a key given twice (`"a.b" = 1` and `a = { b = 2 }` are the same
/// key; TOML keeps both and one would be silently lost).
fn flatten_section(t: &Table, section: &str) -> Result<Vec<(String, Value)>, String> {
    let mut out = Vec::new();
    flatten("", t, &mut out);
    let mut keys: Vec<&str> = out.iter().map(|(k, _)| k.as_str()).collect();
    keys.sort_unstable();
    if let Some(w) = keys.windows(2).find(|w| w[0] == w[1]) {
        return Err(format!(
            "key `{}` is given twice in {section} (as a dotted key and in a nested table); \
             give it once",
            w[0]
        ));
    }
    Ok(out)
}

pub use rtsim_config::flatten;

impl Experiment {
    /// Read and validate an experiment file.
    pub fn load(path: &Path) -> Result<Experiment, SweepError> {
        let text = std::fs::read_to_string(path).map_err(|e| rtsim_core::FileError::io(path, e))?;
        Experiment::parse(&text, path)
    }

    /// Parse and validate experiment text; `path` names it in errors.
    pub fn parse(text: &str, path: &Path) -> Result<Experiment, SweepError> {
        let origin = path.display().to_string();
        let mut root =
            rtsim_config::parse_toml(text, &origin).map_err(|e| SweepError::invalid(path, e))?;
        let bad = |m: String| SweepError::invalid(path, m);
        let name = match root.remove("name") {
            Some(Value::String(s)) => s,
            Some(v) => return Err(bad(format!("`name` must be a string, found {v}"))),
            None => {
                return Err(bad(
                    "`name` is missing (it names the results directory)".into()
                ));
            }
        };
        if name.is_empty()
            || !name
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || "-_.".contains(c))
            || name.starts_with('.')
        {
            return Err(bad(format!(
                "`name` = {name:?}: use letters, digits, `-`, `_` and `.` (it names a directory)"
            )));
        }
        let known: Vec<&str> = SweepCommand::ALL.iter().map(|c| c.name()).collect();
        let command = match root.remove("command") {
            Some(Value::String(s)) => SweepCommand::parse(&s).ok_or_else(|| {
                bad(format!(
                    "`command` = {s:?} is not a command a sweep runs; known: {}",
                    known.join(", ")
                ))
            })?,
            Some(v) => return Err(bad(format!("`command` must be a string, found {v}"))),
            None => {
                return Err(bad(format!(
                    "`command` is missing; one of {}",
                    known.join(", ")
                )));
            }
        };
        let args = match root.remove("args") {
            None => Vec::new(),
            Some(Value::Array(a)) => a
                .into_iter()
                .map(|v| match v {
                    Value::String(s) => Ok(s),
                    other => Err(bad(format!("`args` must hold strings, found {other}"))),
                })
                .collect::<Result<_, _>>()?,
            Some(v) => {
                return Err(bad(format!(
                    "`args` must be an array of strings, found {v}"
                )));
            }
        };
        for reserved in ["--config", "--set", "--out", "--threads"] {
            if args
                .iter()
                .any(|a| a == reserved || a.starts_with(&format!("{reserved}=")))
            {
                return Err(bad(format!(
                    "`args` may not contain {reserved}: the sweep sets it for each point \
                     (put settings in [base], [grid] or [[point]])"
                )));
            }
        }
        let section = |root: &mut Table, key: &str| -> Result<Vec<(String, Value)>, SweepError> {
            match root.remove(key) {
                None => Ok(Vec::new()),
                Some(Value::Table(t)) => flatten_section(&t, &format!("[{key}]")).map_err(bad),
                Some(v) => Err(SweepError::invalid(
                    path,
                    format!("[{key}] must be a table, found {v}"),
                )),
            }
        };
        let base = section(&mut root, "base")?;
        let has_quick = root.contains_key("quick");
        let quick_all = section(&mut root, "quick")?;
        let mut grid = Vec::new();
        for (key, values) in section(&mut root, "grid")? {
            match values {
                Value::Array(a) if !a.is_empty() => grid.push((key, a)),
                Value::Array(_) => {
                    return Err(bad(format!("grid key `{key}` has no values")));
                }
                other => {
                    return Err(bad(format!(
                        "grid key `{key}` must list its values in an array, found {other}"
                    )));
                }
            }
        }
        // A [quick] value of a grid key replaces that key's values: a list, never a scalar
        // (a scalar would run every point of that dimension at one value while the results
        // record the grid's).
        let quick = if has_quick {
            let mut q = Quick::default();
            for (key, v) in quick_all {
                if !grid.iter().any(|(k, _)| *k == key) {
                    q.settings.push((key, v));
                    continue;
                }
                match v {
                    Value::Array(a) if !a.is_empty() => q.grid.push((key, a)),
                    Value::Array(_) => {
                        return Err(bad(format!(
                            "[quick] `{key}` = []: the list that replaces the grid's values \
                             of `{key}` is empty (give at least one value)"
                        )));
                    }
                    other => {
                        return Err(bad(format!(
                            "[quick] `{key}` = {other}: the [grid] varies `{key}`, so [quick] \
                             must give a list of values that replaces the grid's (e.g. \
                             `\"{key}\" = [{other}]`)"
                        )));
                    }
                }
            }
            Some(q)
        } else {
            None
        };
        let exclude = match root.remove("exclude") {
            None => Vec::new(),
            Some(Value::Array(a)) => a
                .into_iter()
                .enumerate()
                .map(|(i, v)| {
                    let Value::Table(t) = v else {
                        return Err(bad(format!("[[exclude]] {i} must be a table, found {v}")));
                    };
                    let entry = flatten_section(&t, &format!("[[exclude]] {i}")).map_err(bad)?;
                    if entry.is_empty() {
                        return Err(bad(format!(
                            "[[exclude]] {i} is empty (it would exclude every grid point)"
                        )));
                    }
                    for (key, value) in &entry {
                        let Some((_, values)) = grid.iter().find(|(k, _)| k == key) else {
                            return Err(bad(format!(
                                "[[exclude]] {i}: `{key}` is not a [grid] key (an exclusion \
                                 names grid values)"
                            )));
                        };
                        if !values.contains(value) {
                            let listed: Vec<String> =
                                values.iter().map(|v| v.to_string()).collect();
                            return Err(bad(format!(
                                "[[exclude]] {i}: `{key}` = {value} is not among the grid's values \
                                 ({})",
                                listed.join(", ")
                            )));
                        }
                    }
                    Ok(entry)
                })
                .collect::<Result<_, _>>()?,
            Some(v) => {
                return Err(bad(format!(
                    "`exclude` must be [[exclude]] tables, found {v}"
                )));
            }
        };
        let points = match root.remove("point") {
            None => Vec::new(),
            Some(Value::Array(a)) => a
                .into_iter()
                .enumerate()
                .map(|(i, v)| match v {
                    Value::Table(mut t) => {
                        let quick = match t.remove("quick") {
                            None => Vec::new(),
                            Some(Value::Table(q)) => {
                                flatten_section(&q, &format!("[[point]] {i} `quick`"))
                                    .map_err(bad)?
                            }
                            Some(other) => {
                                return Err(bad(format!(
                                    "[[point]] {i}: `quick` must be a table of overrides, \
                                     found {other}"
                                )));
                            }
                        };
                        let settings =
                            flatten_section(&t, &format!("[[point]] {i}")).map_err(bad)?;
                        Ok(ExplicitPoint { settings, quick })
                    }
                    other => Err(bad(format!("[[point]] {i} must be a table, found {other}"))),
                })
                .collect::<Result<_, _>>()?,
            Some(v) => return Err(bad(format!("`point` must be [[point]] tables, found {v}"))),
        };
        if let Some(k) = root.keys().next() {
            return Err(bad(format!(
                "unknown key `{k}`; an experiment has name, command, args, [base], [grid], \
                 [[exclude]], [[point]] and [quick]"
            )));
        }
        let e = Experiment {
            path: path.to_path_buf(),
            name,
            command,
            args,
            base,
            grid,
            exclude,
            points,
            quick,
        };
        for quick in [false, true] {
            let count = e.count(quick);
            if count > MAX_POINTS {
                return Err(bad(format!(
                    "{count} points, more than the {MAX_POINTS} a sweep runs (check the grid)"
                )));
            }
        }
        // Every point must assemble into a config tree (a key that clashes with a section …),
        // and no two points may run the same settings (a [quick] override that collapses
        // them would fill the table with repeats under different labels).
        for quick in [false, true] {
            let points = e.points(quick)?;
            if points.is_empty() {
                let scale = if quick { " with --quick" } else { "" };
                return Err(bad(format!(
                    "[[exclude]] excludes every grid point{scale} and there is no [[point]]: \
                     nothing to run"
                )));
            }
            let mut seen = std::collections::BTreeMap::new();
            for p in &points {
                if let Some(first) = seen.insert(p.config_toml.as_str(), p.index) {
                    let scale = if quick { " with --quick" } else { "" };
                    return Err(bad(format!(
                        "points {first} and {} have the same settings{scale} ({}); give each \
                         point its own values (a [[point]] may set its own `quick = {{ … }}`)",
                        p.index,
                        serde_json::Value::Object(p.params_json())
                    )));
                }
            }
        }
        Ok(e)
    }

    /// Whether the experiment has a `[quick]` section.
    pub fn has_quick(&self) -> bool {
        self.quick.is_some()
    }

    /// The grid's keys and values, with `[quick]`'s lists if `quick`.
    fn grid(&self, quick: bool) -> Vec<(String, Vec<Value>)> {
        let replaced = self.quick.as_ref().filter(|_| quick).map(|q| &q.grid);
        self.grid
            .iter()
            .map(|(k, v)| {
                let v = replaced
                    .and_then(|r| r.iter().find(|(rk, _)| rk == k))
                    .map_or(v, |(_, rv)| rv);
                (k.clone(), v.clone())
            })
            .collect()
    }

    /// Number of point numbers at either scale (saturating): excluded grid points keep
    /// theirs, so this bounds the points run.
    fn count(&self, quick: bool) -> usize {
        let grid = self.grid(quick);
        let grid_count = if grid.is_empty() {
            0
        } else {
            grid.iter()
                .try_fold(1usize, |n, (_, v)| n.checked_mul(v.len()))
                .unwrap_or(usize::MAX)
        };
        grid_count.saturating_add(self.points.len()).max(1)
    }

    /// Number of point numbers at either scale, excluded grid points included.
    pub fn numbers(&self, quick: bool) -> usize {
        self.count(quick)
    }

    /// Number of point numbers (at full scale), excluded grid points included.
    pub fn len(&self) -> usize {
        self.count(false)
    }

    pub fn is_empty(&self) -> bool {
        false
    }

    /// The points, in order; `quick` applies the `[quick]` overrides and each `[[point]]`'s
    /// own `quick` table.
    pub fn points(&self, quick: bool) -> Result<Vec<Point>, SweepError> {
        let grid = self.grid(quick);
        // Each point's settings and its own quick overrides.
        type Setting = (String, Value);
        type Settings = Vec<Setting>;
        // (number, settings, own quick overrides)
        let mut params: Vec<(usize, Settings, &[Setting])> = Vec::new();
        let mut next = 0;
        if !grid.is_empty() {
            let mut idx = vec![0usize; grid.len()];
            loop {
                let settings: Settings = grid
                    .iter()
                    .zip(&idx)
                    .map(|((k, v), &i)| (k.clone(), v[i].clone()))
                    .collect();
                let excluded = self.exclude.iter().any(|entry| {
                    entry
                        .iter()
                        .all(|(k, v)| settings.iter().any(|(sk, sv)| sk == k && sv == v))
                });
                if !excluded {
                    params.push((next, settings, &[]));
                }
                next += 1;
                // Odometer: the last key fastest.
                let mut d = grid.len();
                loop {
                    if d == 0 {
                        break;
                    }
                    d -= 1;
                    idx[d] += 1;
                    if idx[d] < grid[d].1.len() {
                        break;
                    }
                    idx[d] = 0;
                    if d == 0 {
                        d = usize::MAX;
                        break;
                    }
                }
                if d == usize::MAX {
                    break;
                }
            }
        }
        params.extend(
            self.points
                .iter()
                .enumerate()
                .map(|(i, p)| (next + i, p.settings.clone(), p.quick.as_slice())),
        );
        if params.is_empty() && next == 0 {
            params.push((0, Vec::new(), &[]));
        }
        let quick_settings: &[(String, Value)] = match &self.quick {
            Some(q) if quick => &q.settings,
            _ => &[],
        };
        params
            .into_iter()
            .map(|(index, mut p, own_quick)| {
                let own_quick = if quick { own_quick } else { &[] };
                let err = |e: &dyn std::fmt::Display| {
                    SweepError::invalid(&self.path, format!("point {index}: {e}"))
                };
                let mut l = Layers::new();
                for (k, v) in self
                    .base
                    .iter()
                    .chain(&p)
                    .chain(quick_settings)
                    .chain(own_quick)
                {
                    l.set_value(k, v.clone()).map_err(|e| err(&e))?;
                }
                // The recorded parameters are the values the point runs with.
                for (k, v) in own_quick {
                    if !p.iter().any(|(pk, _)| pk == k) {
                        p.push((k.clone(), v.clone()));
                    }
                }
                for (k, v) in &mut p {
                    if let Some(run) = l.get(k) {
                        *v = run.clone();
                    }
                }
                p.sort_by(|a, b| a.0.cmp(&b.0));
                let config_toml = toml::to_string(l.table()).map_err(|e| err(&e))?;
                Ok(Point {
                    index,
                    params: p,
                    config_toml,
                })
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<Experiment, SweepError> {
        Experiment::parse(text, Path::new("exp.toml"))
    }

    #[test]
    fn grid_points_in_order_then_explicit_points() {
        let e = parse(
            r#"
            name = "t"
            command = "render"
            [base]
            "scene.name" = "cornell"
            workload = { width = 8 }
            [grid]
            "workload.spp" = [1, 2]
            "bvh.max_leaf_size" = [2, 4, 8]
            [[point]]
            "scene.name" = "sibenik"
            [quick]
            "workload.height" = 4
            "#,
        )
        .unwrap();
        assert_eq!(e.len(), 7);
        let p = e.points(false).unwrap();
        assert_eq!(p.len(), 7);
        // Keys in alphabetical order, the last one fastest.
        let keys: Vec<String> = p
            .iter()
            .take(6)
            .map(|p| format!("{}/{}", p.params[0].1, p.params[1].1))
            .collect();
        assert_eq!(keys, ["2/1", "2/2", "4/1", "4/2", "8/1", "8/2"]);
        assert_eq!(p[6].params, vec![("scene.name".into(), "sibenik".into())]);
        let cfg: Table = p[3].config_toml.parse().unwrap();
        assert_eq!(cfg["workload"]["width"].as_integer(), Some(8));
        assert_eq!(cfg["workload"]["spp"].as_integer(), Some(2));
        assert_eq!(cfg["bvh"]["max_leaf_size"].as_integer(), Some(4));
        assert!(cfg["workload"].get("height").is_none());
        let q: Table = e.points(true).unwrap()[0].config_toml.parse().unwrap();
        assert_eq!(q["workload"]["height"].as_integer(), Some(4));
    }

    #[test]
    fn excluded_grid_points_keep_their_numbers() {
        let text = |exclude: &str| {
            format!(
                r#"
                name = "t"
                command = "render"
                [grid]
                "arch.preset" = ["sgrt-sptrv", "sgrt"]
                "arch.sgrt.cores" = [1, 4]
                "workload.spp" = [1, 2]
                {exclude}
                [[point]]
                "workload.spp" = 8
                [quick]
                "workload.spp" = [1]
                "#
            )
        };
        let e = parse(&text(
            "[[exclude]]\n\"arch.preset\" = \"sgrt-sptrv\"\n\"arch.sgrt.cores\" = 4",
        ))
        .unwrap();
        let p = e.points(false).unwrap();
        let idx: Vec<usize> = p.iter().map(|p| p.index).collect();
        assert_eq!(
            idx,
            [0, 1, 4, 5, 6, 7, 8],
            "points 2 and 3 excluded, 8 explicit"
        );
        // Without the exclusion the same points have the same numbers and settings.
        let all = parse(&text("")).unwrap().points(false).unwrap();
        assert_eq!(all.len(), 9);
        for q in &p {
            assert_eq!(all[q.index], *q);
        }
        assert_eq!(
            (all[2].params[0].1.as_str(), all[2].params[1].1.as_integer()),
            (Some("sgrt-sptrv"), Some(4))
        );
        // With --quick: the quick grid's own numbering, the same rule.
        let idx: Vec<usize> = e.points(true).unwrap().iter().map(|p| p.index).collect();
        assert_eq!(idx, [0, 2, 3, 4]);
    }

    #[test]
    fn bad_exclusions_say_what_is_wrong() {
        let head = "name = \"x\"\ncommand = \"render\"\n";
        let grid = "[grid]\na = [1, 2]\n";
        for (text, needle) in [
            (
                format!("{head}{grid}[[exclude]]\nb = 1"),
                "`b` is not a [grid] key",
            ),
            (
                format!("{head}{grid}[[exclude]]\na = 3"),
                "`a` = 3 is not among the grid's values (1, 2)",
            ),
            (
                format!("{head}exclude = 1\n{grid}"),
                "must be [[exclude]] tables",
            ),
            (
                format!("{head}{grid}[[exclude]]\na = 1\n[[exclude]]\na = 2"),
                "excludes every grid point",
            ),
            (format!("{head}{grid}[[exclude]]\n"), "is empty"),
        ] {
            let e = parse(&text).unwrap_err().to_string();
            assert!(e.contains(needle), "{text}: {e}");
        }
    }

    #[test]
    fn no_grid_is_one_point() {
        let e = parse("name = \"one\"\ncommand = \"bench\"\n").unwrap();
        assert_eq!(e.len(), 1);
        assert_eq!(e.points(false).unwrap()[0].params, vec![]);
    }

    #[test]
    fn bad_experiments_say_what_is_wrong() {
        for (text, needle) in [
            ("command = \"render\"", "`name` is missing"),
            ("name = \"../x\"\ncommand = \"render\"", "names a directory"),
            ("name = \"x\"\ncommand = \"paint\"", "known: render"),
            ("name = \"x\"\ncommand = \"render\"\n[grid]\na = 1", "array"),
            (
                "name = \"x\"\ncommand = \"render\"\n[grid]\na = []",
                "no values",
            ),
            (
                "name = \"x\"\ncommand = \"render\"\ncolour = 1",
                "unknown key `colour`",
            ),
            (
                "name = \"x\"\ncommand = \"render\"\nargs = [\"--out\", \"y\"]",
                "--out",
            ),
            (
                "name = \"x\"\ncommand = \"render\"\n[base]\nworkload = 1\n[grid]\n\"workload.spp\" = [1]",
                "not a section",
            ),
            (
                "name = \"x\"\ncommand = \"render\"\n[grid]\na = [1,2,3,4,5,6,7,8,9,10]\nb = [1,2,3,4,5,6,7,8,9,10]\nc = [1,2,3,4,5,6,7,8,9,10]\nd = [1,2,3,4,5,6,7,8,9,10]\ne = [1,2,3,4,5,6,7,8,9,10]\nf = [1,2,3,4,5,6,7,8,9,10]\ng = [1,2]",
                "more than",
            ),
            ("name = \"x\"\ncommand = \"render\"\n[base\n", "exp.toml"),
        ] {
            let e = parse(text).unwrap_err().to_string();
            assert!(e.contains(needle), "{text}: {e}");
        }
    }

    #[test]
    fn quick_lists_replace_grid_values_and_params_are_what_runs() {
        let e = parse(
            r#"
            name = "t"
            command = "simulate"
            [base]
            "workload.width" = 128
            [grid]
            "arch.trax.tms" = [32, 128]
            "scene.name" = ["sibenik", "conference"]
            [[point]]
            "arch.trax.tms" = 8
            "workload.width" = 1920
            quick = { "workload.width" = 96, "workload.height" = 54 }
            [quick]
            "arch.trax.tms" = [2, 4, 8]
            "workload.width" = 24
            "#,
        )
        .unwrap();
        assert!(e.has_quick());
        let full = e.points(false).unwrap();
        assert_eq!(full.len(), 5);
        assert_eq!(full[0].params[0], ("arch.trax.tms".into(), 32.into()));
        assert_eq!(full[4].params[1], ("workload.width".into(), 1920.into()));
        let quick = e.points(true).unwrap();
        assert_eq!(quick.len(), 7);
        for p in &quick {
            // Every recorded parameter is the value in the config the point runs with.
            let cfg: Table = p.config_toml.parse().unwrap();
            let mut layers = Layers::new();
            layers.merge_table(cfg, "point");
            for (k, v) in &p.params {
                assert_eq!(layers.get(k), Some(v), "point {}: {k}", p.index);
            }
        }
        assert_eq!(quick[2].params[0], ("arch.trax.tms".into(), 4.into()));
        let cfg: Table = quick[2].config_toml.parse().unwrap();
        assert_eq!(cfg["arch"]["trax"]["tms"].as_integer(), Some(4));
        assert_eq!(cfg["workload"]["width"].as_integer(), Some(24));
        // The explicit point: [quick]'s scalars, then its own overrides, recorded.
        let last = &quick[6];
        assert_eq!(
            last.params,
            vec![
                ("arch.trax.tms".into(), 8.into()),
                ("workload.height".into(), 54.into()),
                ("workload.width".into(), 96.into()),
            ]
        );
    }

    #[test]
    fn quick_must_not_collapse_or_silently_override_the_grid() {
        // A scalar for a grid key would run every point at one value.
        let err = parse(
            "name = \"t\"\ncommand = \"simulate\"\n[grid]\n\"arch.trax.tms\" = [32, 128]\n\
             [quick]\n\"arch.trax.tms\" = 4\n",
        )
        .unwrap_err()
        .to_string();
        assert!(
            err.contains("`arch.trax.tms`") && err.contains("list") && err.contains("[quick]"),
            "{err}"
        );
        // An empty replacement list says so (it said "give a list").
        let err = parse(
            "name = \"t\"\ncommand = \"simulate\"\n[grid]\n\"arch.trax.tms\" = [32, 128]\n\
             [quick]\n\"arch.trax.tms\" = []\n",
        )
        .unwrap_err()
        .to_string();
        assert!(err.contains("is empty"), "{err}");
        // Points that run the same settings are refused, naming both.
        let err = parse(
            "name = \"t\"\ncommand = \"simulate\"\n[base]\n\"workload.width\" = 1024\n\
             [[point]]\n\"scene.name\" = \"a\"\n\
             [[point]]\n\"scene.name\" = \"a\"\n\"workload.width\" = 1920\n\
             [quick]\n\"workload.width\" = 64\n",
        )
        .unwrap_err()
        .to_string();
        assert!(
            err.contains("points 0 and 1") && err.contains("--quick"),
            "{err}"
        );
        let err =
            parse("name = \"t\"\ncommand = \"simulate\"\n[grid]\n\"workload.width\" = [8, 8]\n")
                .unwrap_err()
                .to_string();
        assert!(
            err.contains("points 0 and 1 have the same settings"),
            "{err}"
        );
        let err = parse("name = \"t\"\ncommand = \"simulate\"\n[[point]]\nquick = 3\n")
            .unwrap_err()
            .to_string();
        assert!(err.contains("`quick` must be a table"), "{err}");
        let e = parse("name = \"t\"\ncommand = \"simulate\"\n").unwrap();
        assert!(!e.has_quick());
    }

    #[test]
    fn a_key_given_twice_in_a_section_is_an_error() {
        for (text, section) in [
            (
                "[base]\n\"workload.width\" = 8\nworkload = { width = 16 }\n",
                "[base]",
            ),
            (
                "[grid]\n\"workload.width\" = [8, 16]\n[grid.workload]\nwidth = [4]\n",
                "[grid]",
            ),
            (
                "[grid.workload]\nwidth = [4]\n[grid]\n\"workload.width\" = [8, 16]\n",
                "[grid]",
            ),
            (
                "[quick]\n\"workload.width\" = 8\nworkload = { width = 16 }\n",
                "[quick]",
            ),
            (
                "[[point]]\n\"workload.width\" = 8\nworkload = { width = 16 }\n",
                "[[point]] 0",
            ),
            (
                "[[point]]\nquick = { \"workload.width\" = 8, workload = { width = 16 } }\n",
                "[[point]] 0 `quick`",
            ),
        ] {
            let text = format!("name = \"t\"\ncommand = \"simulate\"\n{text}");
            let err = parse(&text).unwrap_err().to_string();
            assert!(
                err.contains("`workload.width` is given twice in") && err.contains(section),
                "{text}: {err}"
            );
        }
    }
}
