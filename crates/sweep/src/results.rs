//! The merged table of a sweep: one row per point, with every parameter and every numeric value
//! of the point's statistics file (`stats.json`, `dram_stats.json` or `cache_stats.json`,
//! which are deterministic; host timings are never merged, so a resumed sweep's table is
//! byte-identical to an uninterrupted one's).
//!
//! Metrics are the numeric and boolean leaves of the statistics, named by their dotted path
//! (`rays.total.nodes_visited`, `dram.row_hits` …); arrays (histograms, per-requester lists)
//! stay in the point's own file.

use crate::SweepError;
use crate::experiment::{Experiment, Point};
use crate::store::{PointRecord, Status, Store};
use serde_json::{Map, Value};
use std::collections::BTreeSet;

/// The merged table's file names in the results directory.
pub const CSV_FILE: &str = "results.csv";
pub const JSONL_FILE: &str = "results.jsonl";

/// Numeric and boolean leaves of `v`, by dotted path, in key order.
pub fn flatten_metrics(v: &Value) -> Map<String, Value> {
    fn walk(prefix: &str, v: &Value, out: &mut Map<String, Value>) {
        match v {
            Value::Object(m) => {
                for (k, v) in m {
                    let key = if prefix.is_empty() {
                        k.clone()
                    } else {
                        format!("{prefix}.{k}")
                    };
                    walk(&key, v, out);
                }
            }
            Value::Number(_) | Value::Bool(_) => {
                out.insert(prefix.to_string(), v.clone());
            }
            Value::Null | Value::String(_) | Value::Array(_) => {}
        }
    }
    let mut out = Map::new();
    walk("", v, &mut out);
    out
}

/// One point's row.
#[derive(Clone, Debug, PartialEq)]
pub struct Row {
    pub point: usize,
    pub params: Map<String, Value>,
    pub metrics: Map<String, Value>,
}

/// What merging found.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Merged {
    pub rows: Vec<Row>,
    /// Points not finished (never run, killed, or failed).
    pub missing: Vec<usize>,
}

/// Read every finished point of `points` from `store`.
pub fn collect(
    e: &Experiment,
    points: &[Point],
    quick: bool,
    store: &Store,
) -> Result<Merged, SweepError> {
    let mut m = Merged::default();
    for p in points {
        let rec = PointRecord::of(e, p, quick);
        if store.status(&rec)? != Status::Done {
            m.missing.push(p.index);
            continue;
        }
        let metrics = match e.command.stats_file() {
            Some(name) => {
                let path = store.point_dir(p.index).join(name);
                let text = std::fs::read_to_string(&path)
                    .map_err(|err| rtsim_core::FileError::io(&path, err))?;
                let v: Value = serde_json::from_str(&text)
                    .map_err(|source| SweepError::Json { path, source })?;
                flatten_metrics(&v)
            }
            None => Map::new(),
        };
        m.rows.push(Row {
            point: p.index,
            params: rec.params,
            metrics,
        });
    }
    Ok(m)
}

/// JSON lines: `{"point": i, "params": {…}, "metrics": {…}}` per finished point.
pub fn to_jsonl(m: &Merged) -> String {
    let mut s = String::new();
    for r in &m.rows {
        let mut o = Map::new();
        o.insert("point".into(), Value::from(r.point));
        o.insert("params".into(), Value::Object(r.params.clone()));
        o.insert("metrics".into(), Value::Object(r.metrics.clone()));
        s.push_str(&Value::Object(o).to_string());
        s.push('\n');
    }
    s
}

/// CSV: `point`, every parameter, every metric (unions over the rows, sorted); empty cells
/// where a row lacks a column.
pub fn to_csv(m: &Merged) -> String {
    let params: BTreeSet<&String> = m.rows.iter().flat_map(|r| r.params.keys()).collect();
    let metrics: BTreeSet<&String> = m.rows.iter().flat_map(|r| r.metrics.keys()).collect();
    let mut s = String::from("point");
    for k in params.iter().chain(&metrics) {
        s.push(',');
        s.push_str(&csv_cell(k));
    }
    s.push('\n');
    for r in &m.rows {
        s.push_str(&r.point.to_string());
        for (map, keys) in [(&r.params, &params), (&r.metrics, &metrics)] {
            for k in keys.iter() {
                s.push(',');
                if let Some(v) = map.get(*k) {
                    let text = match v {
                        Value::String(t) => t.clone(),
                        other => other.to_string(),
                    };
                    s.push_str(&csv_cell(&text));
                }
            }
        }
        s.push('\n');
    }
    s
}

/// RFC 4180 quoting where needed.
fn csv_cell(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn metrics_are_numeric_leaves_by_dotted_path() {
        let m = flatten_metrics(&json!({
            "scene": {"name": "x", "triangles": 3},
            "ok": true,
            "hist": [1, 2],
            "rays": {"total": {"rays": 10, "ratio": 0.5}},
            "none": null
        }));
        let keys: Vec<&str> = m.keys().map(String::as_str).collect();
        assert_eq!(
            keys,
            [
                "ok",
                "rays.total.ratio",
                "rays.total.rays",
                "scene.triangles"
            ]
        );
    }

    #[test]
    fn csv_unions_columns_and_quotes_cells() {
        let row = |point, p: Value, m: Value| Row {
            point,
            params: p.as_object().unwrap().clone(),
            metrics: m.as_object().unwrap().clone(),
        };
        let merged = Merged {
            rows: vec![
                row(0, json!({"scene.name": "a,b"}), json!({"x": 1})),
                row(1, json!({"scene.name": "c"}), json!({"x": 2, "y": 3})),
            ],
            missing: vec![],
        };
        assert_eq!(
            to_csv(&merged),
            "point,scene.name,x,y\n0,\"a,b\",1,\n1,c,2,3\n"
        );
        assert_eq!(to_jsonl(&merged).lines().count(), 2);
    }
}
