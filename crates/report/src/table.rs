//! The merged table of a sweep, read back: [`Table`] of [`Row`]s, each a map from column name
//! (`arch.trax.tms`, `trax.ms_per_frame` …) to a [`Cell`].
//!
//! A sweep's table holds only the parameters that vary (`[grid]`, `[[point]]`), so the
//! architecture, scene and sizes a point shares with every other point are not columns. When
//! the point directories are there (`RESULTS/points/p00007/config.resolved.toml`, written by
//! every run), each row is completed from its point's resolved configuration: every scalar key,
//! by its dotted name, where the table has no column of that name.

use crate::ReportError;
use rtsim_sweep::results::{CSV_FILE as CSV, JSONL_FILE as JSONL};
use rtsim_sweep::store::Store;
use serde_json::Value;
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
/// Each point's resolved configuration, inside `points/pNNNNN/`.
pub const RESOLVED: &str = "config.resolved.toml";

/// One value of the table.
#[derive(Clone, Debug, PartialEq)]
pub enum Cell {
    Num(f64),
    Bool(bool),
    Text(String),
}

impl Cell {
    /// A CSV cell: a number if it parses as one, a boolean for `true`/`false`, else text.
    fn parse(s: &str) -> Cell {
        match s {
            "true" => Cell::Bool(true),
            "false" => Cell::Bool(false),
            _ => s
                .parse::<f64>()
                .map(Cell::Num)
                .unwrap_or_else(|_| Cell::Text(s.to_string())),
        }
    }

    fn from_json(v: &Value) -> Option<Cell> {
        match v {
            Value::Number(n) => n.as_f64().map(Cell::Num),
            Value::Bool(b) => Some(Cell::Bool(*b)),
            Value::String(s) => Some(Cell::Text(s.clone())),
            Value::Null | Value::Array(_) | Value::Object(_) => None,
        }
    }

    fn from_toml(v: &toml::Value) -> Option<Cell> {
        match v {
            toml::Value::Integer(i) => Some(Cell::Num(*i as f64)),
            toml::Value::Float(f) => Some(Cell::Num(*f)),
            toml::Value::Boolean(b) => Some(Cell::Bool(*b)),
            toml::Value::String(s) => Some(Cell::Text(s.clone())),
            _ => None,
        }
    }
}

/// One finished point.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Row {
    pub point: usize,
    /// Which results it came from (1-based) when a report reads several; None for one.
    pub source: Option<usize>,
    pub values: BTreeMap<String, Cell>,
    /// Which of `values` are settings of the run (a JSON table's `params`, and every key of
    /// the point's resolved configuration) rather than its measurements. A CSV table's
    /// columns are not told apart, so without point directories this holds none of them.
    pub params: BTreeSet<String>,
    /// Whether the row was completed from its point's resolved configuration (every setting
    /// the run's build knew is then among `params`).
    pub resolved: bool,
}

impl Row {
    /// The row's name on the page: its point index, prefixed `K:` with its results' number
    /// when the report reads several.
    pub fn id(&self) -> String {
        match self.source {
            Some(k) => format!("{k}:{}", self.point),
            None => self.point.to_string(),
        }
    }

    pub fn num(&self, column: &str) -> Option<f64> {
        match self.values.get(column)? {
            Cell::Num(x) => Some(*x),
            Cell::Bool(b) => Some(f64::from(u8::from(*b))),
            Cell::Text(_) => None,
        }
    }

    pub fn text(&self, column: &str) -> Option<&str> {
        match self.values.get(column)? {
            Cell::Text(s) => Some(s),
            _ => None,
        }
    }

    pub fn flag(&self, column: &str) -> Option<bool> {
        match self.values.get(column)? {
            Cell::Bool(b) => Some(*b),
            _ => None,
        }
    }
}

/// A merged table and the file it came from (named in every error about it).
#[derive(Clone, Debug, PartialEq)]
pub struct Table {
    pub source: PathBuf,
    pub rows: Vec<Row>,
}

impl Table {
    /// Read `path`: a sweep's results directory, or its `results.jsonl` / `results.csv`. Rows
    /// are completed from `points/*/config.resolved.toml` beside the table when present.
    pub fn load(path: &Path) -> Result<Table, ReportError> {
        let meta = std::fs::metadata(path).map_err(|e| ReportError::io(path, e))?;
        let file = if meta.is_dir() {
            [JSONL, CSV]
                .iter()
                .map(|n| path.join(n))
                .find(|p| p.is_file())
                .ok_or_else(|| {
                    ReportError::input(
                        path,
                        format!(
                            "no {JSONL} or {CSV} here: not a sweep's results directory (run `rtsim sweep EXP` or `rtsim sweep EXP --merge` first)"
                        ),
                    )
                })?
        } else {
            path.to_path_buf()
        };
        let text = std::fs::read_to_string(&file).map_err(|e| ReportError::io(&file, e))?;
        // A table with no row (or cut off before its header ended) means no point has
        // finished: there is nothing to report, and an empty report would look like success.
        let none_finished = |what: &str| {
            ReportError::input(
                path,
                format!(
                    "no point has finished: {} {what} (wait for the sweep, or resume it with `rtsim sweep EXP`)",
                    file.display()
                ),
            )
        };
        let is_jsonl = file.extension().is_some_and(|e| e == "jsonl");
        if !is_jsonl && !text.contains('\n') {
            return Err(none_finished(if text.trim().is_empty() {
                "is empty"
            } else {
                "ends inside its header line"
            }));
        }
        let mut table = if is_jsonl {
            parse_jsonl(&file, &text)?
        } else {
            parse_csv(&file, &text)?
        };
        if table.rows.is_empty() {
            return Err(none_finished("has no rows"));
        }
        let dir = file.parent().unwrap_or(Path::new("."));
        for row in &mut table.rows {
            let resolved = Store::new(dir).point_dir(row.point).join(RESOLVED);
            if resolved.is_file() {
                complete_from_config(row, &resolved)?;
            }
        }
        Ok(table)
    }
}

/// `{"point": i, "params": {…}, "metrics": {…}}` per line (`rtsim sweep`'s `results.jsonl`).
pub fn parse_jsonl(path: &Path, text: &str) -> Result<Table, ReportError> {
    let mut rows = Vec::new();
    for (i, line) in text.lines().enumerate() {
        if line.trim().is_empty() {
            continue;
        }
        let at = |m: String| ReportError::input(path, format!("line {}: {m}", i + 1));
        let v: Value = serde_json::from_str(line).map_err(|e| at(e.to_string()))?;
        let point = v
            .get("point")
            .and_then(Value::as_u64)
            .ok_or_else(|| at("no `point` number".into()))?;
        let mut row = Row {
            point: point as usize,
            ..Row::default()
        };
        for part in ["params", "metrics"] {
            let Some(obj) = v.get(part).and_then(Value::as_object) else {
                return Err(at(format!("no `{part}` object")));
            };
            for (k, v) in obj {
                if let Some(c) = Cell::from_json(v) {
                    row.values.insert(k.clone(), c);
                    if part == "params" {
                        row.params.insert(k.clone());
                    }
                }
            }
        }
        rows.push(row);
    }
    Ok(Table {
        source: path.to_path_buf(),
        rows,
    })
}

/// A CSV table with a `point` column (`rtsim sweep`'s `results.csv`; RFC 4180 quoting).
pub fn parse_csv(path: &Path, text: &str) -> Result<Table, ReportError> {
    let records = csv_records(text).map_err(|m| ReportError::input(path, m))?;
    let Some((header, body)) = records.split_first() else {
        return Err(ReportError::input(path, "empty table (no header line)"));
    };
    let point_col = header
        .iter()
        .position(|h| h == "point")
        .ok_or_else(|| ReportError::input(path, "no column `point` (not a merged sweep table)"))?;
    let mut rows = Vec::new();
    for (i, rec) in body.iter().enumerate() {
        let line = i + 2;
        if rec.len() != header.len() {
            return Err(ReportError::input(
                path,
                format!(
                    "line {line}: {} cells, the header has {}",
                    rec.len(),
                    header.len()
                ),
            ));
        }
        let point = rec[point_col].parse::<usize>().map_err(|_| {
            ReportError::input(
                path,
                format!(
                    "line {line}: column `point` is `{}`, not a number",
                    rec[point_col]
                ),
            )
        })?;
        let mut row = Row {
            point,
            ..Row::default()
        };
        for (h, cell) in header.iter().zip(rec) {
            if h != "point" && !cell.is_empty() {
                row.values.insert(h.clone(), Cell::parse(cell));
            }
        }
        rows.push(row);
    }
    Ok(Table {
        source: path.to_path_buf(),
        rows,
    })
}

/// Split CSV text into records of unquoted cells.
fn csv_records(text: &str) -> Result<Vec<Vec<String>>, String> {
    let mut records = Vec::new();
    let mut rec = Vec::new();
    let mut cell = String::new();
    let mut quoted = false;
    let mut chars = text.chars().peekable();
    while let Some(c) = chars.next() {
        match (quoted, c) {
            (true, '"') if chars.peek() == Some(&'"') => {
                chars.next();
                cell.push('"');
            }
            (true, '"') => quoted = false,
            (true, c) => cell.push(c),
            (false, '"') if cell.is_empty() => quoted = true,
            (false, ',') => rec.push(std::mem::take(&mut cell)),
            (false, '\r') => {}
            (false, '\n') => {
                rec.push(std::mem::take(&mut cell));
                records.push(std::mem::take(&mut rec));
            }
            (false, c) => cell.push(c),
        }
    }
    if quoted {
        return Err(format!(
            "line {}: unterminated quoted cell",
            records.len() + 1
        ));
    }
    if !cell.is_empty() || !rec.is_empty() {
        rec.push(cell);
        records.push(rec);
    }
    Ok(records)
}

/// Add every scalar of the point's resolved configuration that the row lacks.
fn complete_from_config(row: &mut Row, path: &Path) -> Result<(), ReportError> {
    let text = std::fs::read_to_string(path).map_err(|e| ReportError::io(path, e))?;
    for (key, c) in scalars(&text).map_err(|e| ReportError::input(path, e))? {
        row.params.insert(key.clone());
        row.values.entry(key).or_insert(c);
    }
    row.resolved = true;
    Ok(())
}

/// Every scalar leaf of a configuration's TOML text, as a dotted key and a cell.
pub fn scalars(toml_text: &str) -> Result<BTreeMap<String, Cell>, String> {
    let v: toml::Table = toml::from_str(toml_text).map_err(|e| e.to_string())?;
    let mut leaves = Vec::new();
    rtsim_sweep::experiment::flatten("", &v, &mut leaves);
    Ok(leaves
        .into_iter()
        .filter_map(|(k, v)| Cell::from_toml(&v).map(|c| (k, c)))
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn csv_cells_are_typed_and_quotes_undone() {
        let t = parse_csv(
            Path::new("r.csv"),
            "point,scene.name,x,ok\n0,\"a,\"\"b\"\"\",1.5,true\n1,c,,false\n",
        )
        .unwrap();
        assert_eq!(t.rows.len(), 2);
        assert_eq!(t.rows[0].text("scene.name"), Some("a,\"b\""));
        assert_eq!(t.rows[0].num("x"), Some(1.5));
        assert_eq!(t.rows[0].flag("ok"), Some(true));
        assert_eq!(t.rows[1].num("x"), None, "an empty cell is absent");
        assert_eq!(t.rows[1].point, 1);
    }

    #[test]
    fn csv_errors_name_the_file_line_and_column() {
        let e = parse_csv(Path::new("r.csv"), "x,y\n1,2\n").unwrap_err();
        assert!(
            e.to_string().contains("r.csv") && e.to_string().contains("`point`"),
            "{e}"
        );
        let e = parse_csv(Path::new("r.csv"), "point,y\n1,2,3\n").unwrap_err();
        assert!(e.to_string().contains("line 2"), "{e}");
        let e = parse_csv(Path::new("r.csv"), "point,y\nzz,2\n").unwrap_err();
        assert!(e.to_string().contains("`point` is `zz`"), "{e}");
    }

    #[test]
    fn jsonl_merges_params_and_metrics() {
        let t = parse_jsonl(
            Path::new("r.jsonl"),
            "{\"point\":3,\"params\":{\"arch.preset\":\"sgrt\"},\"metrics\":{\"a.b\":2,\"c\":true}}\n",
        )
        .unwrap();
        assert_eq!(t.rows[0].point, 3);
        assert_eq!(t.rows[0].text("arch.preset"), Some("sgrt"));
        assert_eq!(t.rows[0].num("a.b"), Some(2.0));
        let e = parse_jsonl(Path::new("r.jsonl"), "{\"params\":{}}\n").unwrap_err();
        assert!(e.to_string().contains("r.jsonl: line 1"), "{e}");
    }

    #[test]
    fn rows_are_completed_from_each_points_resolved_config() {
        let dir = std::env::temp_dir().join(format!("rtsim-report-table-{}", std::process::id()));
        let p = dir.join("points/p00000");
        std::fs::create_dir_all(&p).unwrap();
        std::fs::write(dir.join(CSV), "point,arch.trax.tms,m\n0,4,1\n1,8,2\n").unwrap();
        std::fs::write(
            p.join(RESOLVED),
            "[arch]\npreset = \"trax-baseline\"\n[arch.trax]\ntms = 99\n",
        )
        .unwrap();
        let t = Table::load(&dir).unwrap();
        std::fs::remove_dir_all(&dir).unwrap();
        assert_eq!(t.rows[0].text("arch.preset"), Some("trax-baseline"));
        assert_eq!(
            t.rows[0].num("arch.trax.tms"),
            Some(4.0),
            "the table's value wins"
        );
        assert_eq!(
            t.rows[1].text("arch.preset"),
            None,
            "no point directory: nothing added"
        );
        assert!(t.rows[0].resolved && !t.rows[1].resolved);
    }

    #[test]
    fn a_table_without_finished_points_is_an_error_naming_the_directory() {
        let dir = std::env::temp_dir().join(format!("rtsim-report-empty-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let cases = [
            ("", "is empty"),
            ("point,arch.preset,trax.cyc", "ends inside its header"),
            ("point,arch.preset\n", "has no rows"),
        ];
        for (text, why) in cases {
            std::fs::write(dir.join(CSV), text).unwrap();
            let e = Table::load(&dir).unwrap_err().to_string();
            assert!(e.starts_with(&dir.display().to_string()), "{e}");
            assert!(
                e.contains("no point has finished") && e.contains(why),
                "{e}"
            );
        }
        std::fs::remove_file(dir.join(CSV)).unwrap();
        std::fs::write(dir.join(JSONL), "\n").unwrap();
        let e = Table::load(&dir).unwrap_err().to_string();
        std::fs::remove_dir_all(&dir).unwrap();
        assert!(
            e.contains("no point has finished") && e.contains("has no rows"),
            "{e}"
        );
    }

    #[test]
    fn a_missing_results_directory_is_an_error_naming_it() {
        let e = Table::load(Path::new("/nonexistent/rtsim-results")).unwrap_err();
        assert!(e.to_string().contains("/nonexistent/rtsim-results"), "{e}");
    }
}
