//! The HTML page: one section per paper, each figure inline as SVG (with links to its SVG and
//! PNG files) and each table with the paper's row above ours. Every cell of ours carries the
//! column it came from, the points it averages and the exact value (`data-col`,
//! `data-points`, `data-value`), so the page can be checked against the merged table.

use crate::svg::escape;
use crate::table::{Cell, Row};
use crate::{FIGURE_DIR, Figure, Results};

/// What a section holds, in order.
#[derive(Clone, Debug)]
pub enum Item {
    Figure(Figure),
    /// A table's HTML (built with the helpers below).
    Table(String),
}

/// One paper's part of the report.
#[derive(Clone, Debug, Default)]
pub struct Section {
    pub title: String,
    /// HTML paragraph(s) under the title.
    pub intro: String,
    pub items: Vec<Item>,
    /// The section's figures (also in `items`), for the files.
    pub figures: Vec<Figure>,
}

impl Section {
    pub fn figure(&mut self, f: Figure) {
        self.figures.push(f.clone());
        self.items.push(Item::Figure(f));
    }

    pub fn table(&mut self, html: String) {
        self.items.push(Item::Table(html));
    }
}

/// A value of ours: the mean of `col` over `points` (their [`Row::id`]s).
#[derive(Clone, Debug, PartialEq)]
pub struct Val {
    pub col: String,
    pub points: Vec<String>,
    pub value: f64,
}

impl Val {
    /// The mean of `col` over `rows` (None without rows or where a row lacks it).
    pub fn mean(rows: &[&Row], col: &str) -> Option<Val> {
        if rows.is_empty() {
            return None;
        }
        let mut sum = 0.0;
        for r in rows {
            sum += r.num(col)?;
        }
        Some(Val {
            col: col.to_string(),
            points: rows.iter().map(|r| r.id()).collect(),
            value: sum / rows.len() as f64,
        })
    }
}

/// A cell of ours, shown as `show(value)`; `missing` where there is none.
pub fn td_val(v: &Option<Val>, show: impl Fn(f64) -> String, missing: &str) -> String {
    match v {
        Some(v) => {
            format!(
                "<td class=\"ours\" data-col=\"{}\" data-points=\"{}\" data-value=\"{}\">{}</td>",
                escape(&v.col),
                v.points.join(" "),
                v.value,
                escape(&show(v.value))
            )
        }
        None => format!("<td class=\"missing\">{}</td>", escape(missing)),
    }
}

/// A plain cell.
pub fn td(s: &str) -> String {
    format!("<td>{}</td>", escape(s))
}

/// A cell of ours spanning `span` columns that says why the whole row has no values (a
/// paper scene we do not have), instead of repeating it in every column.
pub fn td_missing_row(s: &str, span: usize) -> String {
    format!(
        "<td class=\"missing\" colspan=\"{span}\">{}</td>",
        escape(s)
    )
}

/// A header cell spanning `span` columns.
pub fn th(s: &str, span: usize) -> String {
    if span > 1 {
        format!("<th colspan=\"{span}\">{}</th>", escape(s))
    } else {
        format!("<th>{}</th>", escape(s))
    }
}

/// `v` with `digits` significant digits in plain decimal notation (`0.583`, `0.0111`, `12.3`,
/// `1980`), never in exponent form: energies per frame span 10⁻⁴ to 10¹ J and read better
/// as plain numbers in a table.
pub fn significant(v: f64, digits: u32) -> String {
    if v == 0.0 || !v.is_finite() {
        return format!("{v}");
    }
    let magnitude = v.abs().log10().floor() as i32;
    let decimals = (digits as i32 - 1 - magnitude).clamp(0, 17) as usize;
    format!("{v:.decimals$}")
}

/// `v` with `decimals` digits after the point.
pub fn fixed(v: f64, decimals: usize) -> String {
    format!("{v:.decimals$}")
}

/// A table: caption, header rows (already `<th>` cells) and body rows (already `<td>` cells,
/// with a row class: `paper` or `ours`).
pub fn table(id: &str, caption: &str, head: &[String], body: &[(String, String)]) -> String {
    let mut s = format!(
        "<table id=\"{}\">\n<caption>{caption}</caption>\n<thead>\n",
        escape(id)
    );
    for h in head {
        s.push_str(&format!("<tr>{h}</tr>\n"));
    }
    s.push_str("</thead>\n<tbody>\n");
    for (class, cells) in body {
        s.push_str(&format!("<tr class=\"{class}\">{cells}</tr>\n"));
    }
    s.push_str("</tbody>\n</table>\n");
    s
}

const CSS: &str =
    "body{font-family:sans-serif;max-width:70em;margin:2em auto;padding:0 1em;color:#222}
h1,h2,h3{font-weight:600}figure{margin:1.5em 0}figcaption{font-size:.95em;margin:.4em 0}
.notes{font-size:.9em;color:#444}table{border-collapse:collapse;margin:1.5em 0;font-size:.9em}
caption{text-align:left;padding:.3em 0;font-size:.95em}
th,td{border:1px solid #ccc;padding:.2em .5em;text-align:right}th{background:#f2f2f2;text-align:center}
td:first-child,td:nth-child(2){text-align:left}tr.paper td{color:#555}
tr.ours td{background:#eef5fb}td.missing{color:#b00;font-style:italic}
.files{font-size:.85em}";

/// The whole page.
pub fn page(r: &Results, sections: &[Section], svgs: &[(String, String, Vec<u8>)]) -> String {
    let mut counts: Vec<String> = Vec::new();
    for a in crate::Arch::ALL {
        let n = r.of(a).count();
        if n > 0 {
            counts.push(format!("{n} × <code>{}</code>", a.preset()));
        }
    }
    let sources = match r.sources.as_slice() {
        [one] => format!("<code>{}</code>", escape(&one.display().to_string())),
        several => {
            let named: Vec<String> = several
                .iter()
                .enumerate()
                .map(|(i, p)| {
                    let n = r
                        .rows
                        .iter()
                        .filter(|(_, row)| row.source == Some(i + 1))
                        .count();
                    format!(
                        "[{}] <code>{}</code> ({n})",
                        i + 1,
                        escape(&p.display().to_string())
                    )
                })
                .collect();
            format!(
                "{} (a value's points are named <i>K</i>:<i>point</i>, <i>K</i> the results' number)",
                named.join(", ")
            )
        }
    };
    let intro = format!(
        "<p>Results: {sources}, {} finished points ({}). Rows marked <i>paper</i> are the published values; \
         rows marked <i>rtsim</i> are ours (hover a value for the column it came from). \
         <span class=\"missing\">Red italics</span>: not in these results.</p>\n",
        r.rows.len(),
        if counts.is_empty() {
            "none".to_string()
        } else {
            counts.join(", ")
        }
    ) + &predated(r)
        + &departures(r);
    document("rtsim report", &intro, sections, svgs)
}

/// A paragraph naming the settings some points' builds predate and the defaults drawn for
/// them (empty when there are none).
fn predated(r: &Results) -> String {
    if r.predated.is_empty() {
        return String::new();
    }
    let items: Vec<String> = r
        .predated
        .iter()
        .map(|p| {
            let default = setting(&p.key, &p.default);
            format!(
                "<code>{}</code> = <code>{}</code> for point{} {}",
                escape(&p.key),
                escape(&default),
                if p.points.len() == 1 { "" } else { "s" },
                point_ranges(&p.points)
            )
        })
        .collect();
    format!(
        "<p>Settings these points' builds predate, taken at their built-in defaults (a new \
         setting's default keeps the behaviour before it): {}.</p>\n",
        items.join("; ")
    )
}

/// A list, by architecture, of the settings in which points differ from their presets
/// (empty when there are none): an experiment's axes and base, which the tables and a curve
/// drawn alone do not show.
fn departures(r: &Results) -> String {
    if r.departures.is_empty() {
        return String::new();
    }
    let mut items = String::new();
    for arch in crate::Arch::ALL {
        // One entry per key, its values in order: `key` = a (points …), b (points …).
        let mut of: Vec<(&str, Vec<String>)> = Vec::new();
        for d in r.departures.iter().filter(|d| d.arch == arch) {
            let value = format!(
                "<code>{}</code> (point{} {})",
                escape(&setting(&d.key, &d.value)),
                if d.points.len() == 1 { "" } else { "s" },
                point_ranges(&d.points)
            );
            match of.last_mut() {
                Some((key, values)) if *key == d.key => values.push(value),
                _ => of.push((&d.key, vec![value])),
            }
        }
        if !of.is_empty() {
            let keys: Vec<String> = of
                .iter()
                .map(|(key, values)| {
                    format!("<code>{}</code> = {}", escape(key), values.join(", "))
                })
                .collect();
            items.push_str(&format!(
                "<li><code>{}</code>: {}</li>\n",
                arch.preset(),
                keys.join("; ")
            ));
        }
    }
    format!(
        "<p>Settings in which points differ from their presets (the configuration that \
         <code>arch.preset</code> alone gives; scene and workload settings aside):</p>\n<ul>\n{items}</ul>\n"
    )
}

/// A setting's value as written in a configuration; a byte size (a key ending in `bytes`)
/// of whole KiB with the figures' label as well (`524288 (512 KB)`).
fn setting(key: &str, value: &Cell) -> String {
    match value {
        Cell::Text(t) => t.clone(),
        Cell::Bool(b) => b.to_string(),
        Cell::Num(x) if key.ends_with("bytes") && *x >= 1024.0 && x % 1024.0 == 0.0 => {
            format!("{x} ({})", crate::chart::bytes_label(*x))
        }
        Cell::Num(x) => x.to_string(),
    }
}

/// Points as `K:a–b` ranges of consecutive indices (`a–b` with one results), in order.
fn point_ranges(points: &[(Option<usize>, usize)]) -> String {
    let mut runs: Vec<(Option<usize>, usize, usize)> = Vec::new();
    for &(k, i) in points {
        match runs.last_mut() {
            Some((rk, _, last)) if *rk == k && *last + 1 == i => *last = i,
            _ => runs.push((k, i, i)),
        }
    }
    runs.iter()
        .map(|&(k, a, b)| {
            let k = k.map(|k| format!("{k}:")).unwrap_or_default();
            if a == b {
                format!("{k}{a}")
            } else {
                format!("{k}{a}–{b}")
            }
        })
        .collect::<Vec<_>>()
        .join(", ")
}

/// A page titled `title`: `intro` (HTML), then each section's title, intro, figures (inline
/// SVG with links to the files) and tables.
pub fn document(
    title: &str,
    intro: &str,
    sections: &[Section],
    svgs: &[(String, String, Vec<u8>)],
) -> String {
    let title = escape(title);
    let mut s = format!(
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<title>{title}</title>\n<style>\n"
    );
    s.push_str(CSS);
    s.push_str(&format!("\n</style>\n</head>\n<body>\n<h1>{title}</h1>\n"));
    s.push_str(intro);
    for sec in sections {
        s.push_str(&format!("<h2>{}</h2>\n{}\n", escape(&sec.title), sec.intro));
        for item in &sec.items {
            match item {
                Item::Table(t) => s.push_str(t),
                Item::Figure(f) => {
                    let svg = svgs
                        .iter()
                        .find(|(n, _, _)| n == f.name)
                        .map(|(_, svg, _)| svg.as_str())
                        .unwrap_or("");
                    s.push_str(&format!(
                        "<figure id=\"{0}\">\n{svg}<figcaption>{1} <span class=\"files\">(<a href=\"{2}/{0}.svg\">SVG</a>, <a href=\"{2}/{0}.png\">PNG</a>)</span></figcaption>\n<div class=\"notes\">{3}</div>\n</figure>\n",
                        f.name, f.caption, FIGURE_DIR, f.notes
                    ));
                }
            }
        }
    }
    s.push_str("</body>\n</html>\n");
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn points_are_named_in_ranges_per_results() {
        let p = [
            (Some(1), 0),
            (Some(1), 1),
            (Some(1), 2),
            (Some(1), 5),
            (Some(2), 6),
            (Some(2), 7),
        ];
        assert_eq!(point_ranges(&p), "1:0–2, 1:5, 2:6–7");
        assert_eq!(point_ranges(&[(None, 3)]), "3");
    }

    #[test]
    fn departures_are_listed_by_architecture_and_key() {
        let d = |arch, key: &str, value, points: &[usize]| crate::Departure {
            arch,
            key: key.into(),
            value,
            points: points.iter().map(|&p| (None, p)).collect(),
        };
        let r = Results {
            departures: vec![
                d(
                    crate::Arch::TraxBaseline,
                    "arch.trax.tms",
                    Cell::Num(1.0),
                    &[0],
                ),
                d(
                    crate::Arch::TraxBaseline,
                    "arch.trax.tms",
                    Cell::Num(2.0),
                    &[1],
                ),
                d(
                    crate::Arch::Strata,
                    "arch.strata.fill",
                    Cell::Text("static".into()),
                    &[2, 3],
                ),
                d(
                    crate::Arch::Strata,
                    "arch.strata.stream.bytes",
                    Cell::Num(524288.0),
                    &[2],
                ),
            ],
            ..Results::default()
        };
        let p = departures(&r);
        assert!(p.contains(
            "<li><code>trax-baseline</code>: <code>arch.trax.tms</code> = <code>1</code> (point 0), <code>2</code> (point 1)</li>"
        ), "{p}");
        assert!(p.contains(
            "<li><code>strata</code>: <code>arch.strata.fill</code> = <code>static</code> (points 2–3); <code>arch.strata.stream.bytes</code> = <code>524288 (512 KB)</code> (point 2)</li>"
        ), "{p}");
        assert_eq!(departures(&Results::default()), "");
        assert_eq!(
            setting("arch.trax.l2.size_bytes", &Cell::Num(1536.0)),
            "1536"
        );
        let mib16 = setting("arch.strata.stream.bytes", &Cell::Num(16777216.0));
        assert_eq!(mib16, "16777216 (16 MB)");
        assert_eq!(setting("arch.trax.tms", &Cell::Num(4096.0)), "4096");
    }

    #[test]
    fn significant_digits_stay_plain() {
        assert_eq!(significant(0.582616882344, 3), "0.583");
        assert_eq!(significant(0.011140251612, 3), "0.0111");
        assert_eq!(significant(1.977, 3), "1.98");
        assert_eq!(significant(12.34, 3), "12.3");
        assert_eq!(significant(1977.0, 3), "1977");
        assert_eq!(significant(0.000123456, 3), "0.000123");
        assert_eq!(significant(0.0, 3), "0");
    }

    #[test]
    fn our_cells_carry_their_source_and_exact_value() {
        let mut a = Row {
            point: 2,
            source: None,
            ..Row::default()
        };
        a.values.insert("x".into(), Cell::Num(1.0));
        let mut b = Row {
            point: 5,
            source: None,
            ..Row::default()
        };
        b.values.insert("x".into(), Cell::Num(2.5));
        let v = Val::mean(&[&a, &b], "x");
        let cell = td_val(&v, |x| fixed(x, 1), "not run");
        assert_eq!(
            cell,
            "<td class=\"ours\" data-col=\"x\" data-points=\"2 5\" data-value=\"1.75\">1.8</td>"
        );
        assert_eq!(Val::mean(&[&a], "y"), None);
        assert_eq!(
            td_val(&None, |x| x.to_string(), "not run"),
            "<td class=\"missing\">not run</td>"
        );
    }
}
