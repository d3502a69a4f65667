//! The STRaTA paper's presentations: Figures 1, 5, 6 and 7, Tables 1 and 3, from rows of
//! `trax-baseline` and `strata` (both report the TRaX chip's columns, `trax.*`).
//!
//! Which runs each shows:
//! - Tables 1 and 3 and Figure 1 (one value per scene): per architecture and scene, the run at
//!   the paper's 4 MB L2 (baseline) or stream memory (STRaTA) with the most TMs.
//! - Figures 5 and 6 (against L2/stream size): one curve per architecture, scene and TM count
//!   with at least two sizes.
//! - Figure 7 (against TMs): one curve per architecture, scene and size with at least two TM
//!   counts.

use crate::chart::{self, BarSeries, Body, Chart, Scale, Series, bytes_label, palette};
use crate::html::{Section, Val, fixed, significant, table, td, td_missing_row, td_val, th};
use crate::paper::{self, DramCols};
use crate::table::{Cell, Row};
use crate::{Arch, Figure, Results, SCENE_COLUMN};
use rtsim_sweep::reuse::result_neutral;
use std::collections::{BTreeMap, BTreeSet};

/// TMs on the chip.
pub const TMS: &str = "trax.chip.tms";
/// The setting that gives it.
const TMS_SETTING: &str = "arch.trax.tms";
/// Table 1's columns, in its order.
pub const DRAM_ACCESSES: &str = "trax.dram.accesses";
pub const ROW_HIT_RATE: &str = "trax.dram.row_hit_rate";
pub const READ_LATENCY: &str = "trax.dram.average_read_latency_core_cycles";
pub const MS_PER_FRAME: &str = "trax.ms_per_frame";
pub const DRAM_ENERGY: &str = "trax.energy.dram_j";
/// Table 3's columns.
pub const RF_ENERGY: &str = "trax.energy.register_file_j";
pub const ICACHE_ENERGY: &str = "trax.energy.icache_j";
/// Figure 1's components (column, label in the paper's abbreviations: I$ instruction cache,
/// RF register file, XUs execution units), and the total they add up to.
pub const COMPONENTS: [(&str, &str); 7] = [
    (DRAM_ENERGY, "DRAM"),
    ("trax.energy.l2_j", "L2"),
    ("trax.energy.l1_j", "L1"),
    (ICACHE_ENERGY, "I$"),
    (RF_ENERGY, "RF"),
    ("trax.energy.execution_units_j", "XUs"),
    ("trax.energy.local_memory_j", "Local"),
];
pub const TOTAL_ENERGY: &str = "trax.energy.total_j";
pub const L2_ENERGY: &str = "trax.energy.l2_j";
/// Figure 5 and the L1 hit rates its caption states.
pub const L1_MISSES: &str = "trax.l1.misses";
pub const L1_HIT_RATE: &str = "trax.l1.hit_rate";
/// L1 accesses and hits, and the accesses that merged into a miss already in flight (rtsim
/// counts those as misses; the paper counts them as hits, `docs/VALIDATION.md`).
pub const L1_ACCESSES: &str = "trax.l1.accesses";
pub const L1_HITS: &str = "trax.l1.hits";
pub const L1_MSHR_MERGES: &str = "trax.l1.mshr_merges";
/// Figure 7: frames per second.
pub const FPS: &str = "trax.fps";

/// The stream memory's accesses on STRaTA rows: the first alternative whose columns are all
/// present, summed. The STRaTA chip's report is not written yet; these are the names it is
/// expected to use (the TRaX report's `trax.` prefix, the stream memory's `StreamStats`
/// field names), and the one place to change if it uses others.
pub const STREAM_ACCESSES: [&[&str]; 3] = [
    &["trax.stream.accesses"],
    &["trax.stream.pushes", "trax.stream.pops"],
    &["strata.stream.pushes", "strata.stream.pops"],
];
/// The stream memory's energy on STRaTA rows (first present), as above.
pub const STREAM_ENERGY: [&str; 2] = ["trax.energy.stream_j", "strata.energy.stream_j"];

/// Columns every TRaX-chip row must have.
pub const REQUIRED: &[&str] = &[
    TMS,
    DRAM_ACCESSES,
    ROW_HIT_RATE,
    READ_LATENCY,
    MS_PER_FRAME,
    DRAM_ENERGY,
    RF_ENERGY,
    ICACHE_ENERGY,
    "trax.energy.l2_j",
    "trax.energy.l1_j",
    "trax.energy.execution_units_j",
    "trax.energy.local_memory_j",
    TOTAL_ENERGY,
    L1_MISSES,
    L1_HIT_RATE,
    FPS,
];

/// The size Figures 5–6 vary: the L2's (baseline) or the stream memory's (STRaTA), from the
/// point's resolved configuration.
pub fn size_column(arch: Arch) -> Option<&'static str> {
    match arch {
        Arch::TraxBaseline => Some("arch.trax.l2.size_bytes"),
        Arch::Strata => Some("arch.strata.stream.bytes"),
        _ => None,
    }
}

fn label(arch: Arch) -> &'static str {
    if arch == Arch::Strata {
        "STRaTA"
    } else {
        "baseline"
    }
}

fn scene(r: &Row) -> &str {
    r.text(SCENE_COLUMN).unwrap_or("?")
}

fn size(arch: Arch, r: &Row) -> f64 {
    size_column(arch).and_then(|c| r.num(c)).unwrap_or(f64::NAN)
}

fn num(r: &Row, col: &str) -> f64 {
    r.num(col).unwrap_or(f64::NAN)
}

/// The frame's width and height (0 where the row does not say).
fn frame(r: &Row) -> (u64, u64) {
    let dim = |c| r.num(c).map_or(0, |v| v as u64);
    (dim("workload.width"), dim("workload.height"))
}

/// `1024×1024` (not `1024²`: the PNG's font draws `²` as `2`).
fn frame_label((w, h): (u64, u64)) -> String {
    format!("{w}×{h}")
}

/// The L1 hit rate counted as the paper counts it: an access to a line already in flight
/// (an MSHR merge) is a hit, since the line is not fetched again. None without the columns
/// or without accesses.
pub fn l1_hit_rate_with_merges(r: &Row) -> Option<f64> {
    let accesses = r.num(L1_ACCESSES)?;
    (accesses > 0.0).then_some((r.num(L1_HITS)? + r.num(L1_MSHR_MERGES)?) / accesses)
}

/// "lo–hi %" of fractions, or None without any.
fn pct_range(values: &[f64]) -> Option<String> {
    if values.is_empty() {
        return None;
    }
    let lo = values.iter().cloned().fold(f64::INFINITY, f64::min);
    let hi = values.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
    Some(format!(
        "{}–{} %",
        fixed(100.0 * lo, 1),
        fixed(100.0 * hi, 1)
    ))
}

/// Stream accesses of a STRaTA row, with the columns they came from.
pub fn stream_accesses(r: &Row) -> Option<f64> {
    STREAM_ACCESSES
        .iter()
        .find(|cols| cols.iter().all(|c| r.num(c).is_some()))
        .map(|cols| cols.iter().map(|c| num(r, c)).sum())
}

/// Stream memory energy of a STRaTA row.
pub fn stream_energy(r: &Row) -> Option<f64> {
    STREAM_ENERGY.iter().find_map(|c| r.num(c))
}

/// Per scene, the run the one-value-per-scene presentations show (module docs).
pub fn table_rows(r: &Results, arch: Arch) -> BTreeMap<String, &Row> {
    let mut best: BTreeMap<String, &Row> = BTreeMap::new();
    // Then the most pixels (the paper's frame is 1024²), then the first results and point.
    let key = |row: &Row| {
        let (w, h) = frame(row);
        (
            size(arch, row) == paper::STRATA_TABLE_SIZE_BYTES,
            num(row, TMS) as i64,
            w.saturating_mul(h),
            std::cmp::Reverse(row.source),
            std::cmp::Reverse(row.point),
        )
    };
    for row in r.of(arch) {
        let e = best.entry(scene(row).to_string()).or_insert(row);
        if key(row) > key(e) {
            *e = row;
        }
    }
    best
}

/// One curve: the architecture, the legend's scene name (with the frame's size when the
/// results hold several), the fixed value, what sets it apart from the group's other curves
/// (`variant`, empty if nothing), and its rows in `x` order.
struct Curve<'a> {
    arch: Arch,
    scene: String,
    fixed: f64,
    variant: String,
    rows: Vec<&'a Row>,
}

/// A setting's value in a legend (`–`: the row does not record the setting).
fn setting_label(row: &Row, key: &str) -> String {
    match row.values.get(key) {
        Some(Cell::Text(t)) => t.clone(),
        Some(Cell::Num(x)) => chart::short_number(*x),
        Some(Cell::Bool(b)) => b.to_string(),
        None => "–".into(),
    }
}

/// Curves: rows grouped by (arch, scene, frame, `fixed`), x = `vary`, kept where ≥ 2 x
/// values. Rows of a group that share an x but differ in a setting (a sweep over a knob as
/// well as the axis, or two sweeps read together that set it differently) are split into
/// one curve per combination of the settings that differ there, named in the legend (on
/// every curve of the architecture that holds one value of them, as are the settings in
/// which rows differ from their presets, the axes aside); a setting that changes
/// only with x (a function of it) does not split. Of two rows at one x
/// with the same settings (a point shared by two sweeps), the first results' first point is
/// drawn.
fn curves(
    r: &Results,
    x_of: impl Fn(Arch, &Row) -> f64,
    fixed_of: impl Fn(Arch, &Row) -> f64,
) -> Vec<Curve<'_>> {
    let trax = || r.rows.iter().filter(|(a, _)| a.is_trax());
    let frames: std::collections::BTreeSet<_> = trax().map(|(_, row)| frame(row)).collect();
    // (arch, scene, frame, the fixed value's bits) → rows
    type Group = (Arch, String, (u64, u64), u64);
    let mut groups: BTreeMap<Group, Vec<&Row>> = BTreeMap::new();
    for (a, row) in trax() {
        groups
            .entry((
                *a,
                scene(row).to_string(),
                frame(row),
                fixed_of(*a, row).to_bits(),
            ))
            .or_default()
            .push(row);
    }
    // Curves to draw: (arch, scene, fixed, the settings that split its group, rows by x).
    type Drawn<'r> = (Arch, String, f64, BTreeSet<&'r str>, Vec<&'r Row>);
    let mut drawn: Vec<Drawn<'_>> = Vec::new();
    for ((a, s, fr, f), rows) in groups {
        let scene = if frames.len() > 1 {
            format!("{s} {}", frame_label(fr))
        } else {
            s
        };
        let x_bits = |row: &Row| x_of(a, row).to_bits();
        // The settings that differ between two rows at one x.
        let mut by_x: BTreeMap<u64, Vec<&Row>> = BTreeMap::new();
        for &row in &rows {
            by_x.entry(x_bits(row)).or_default().push(row);
        }
        let keys: BTreeSet<&str> = rows
            .iter()
            .flat_map(|row| row.params.iter().map(String::as_str))
            .filter(|k| !result_neutral(k))
            .filter(|k| {
                by_x.values().any(|same_x| {
                    same_x
                        .iter()
                        .any(|row| row.values.get(*k) != same_x[0].values.get(*k))
                })
            })
            .collect();
        // In the order of their first rows (the first results' first point first).
        let mut variants: Vec<(Vec<String>, Vec<&Row>)> = Vec::new();
        for &row in &rows {
            let v: Vec<String> = keys.iter().map(|k| setting_label(row, k)).collect();
            match variants.iter_mut().find(|(w, _)| *w == v) {
                Some((_, rows)) => rows.push(row),
                None => variants.push((v, vec![row])),
            }
        }
        for (_, mut rows) in variants {
            rows.sort_by(|p, q| {
                x_of(a, p)
                    .total_cmp(&x_of(a, q))
                    .then(p.source.cmp(&q.source))
                    .then(p.point.cmp(&q.point))
            });
            rows.dedup_by(|p, q| x_of(a, p) == x_of(a, q));
            if rows.len() >= 2 {
                drawn.push((a, scene.clone(), f64::from_bits(f), keys.clone(), rows));
            }
        }
    }
    // A setting that splits a curve of an architecture is named on all its curves that hold
    // one value of it, so a curve drawn alone (one scene run under a knob only) does not
    // read as the default.
    // So is a setting in which some of its rows differ from their preset (the remedies'
    // sweep alone, `Results::departures`), unless it is one of the figures' axes.
    let mut named: BTreeMap<Arch, BTreeSet<&str>> = BTreeMap::new();
    for (a, _, _, keys, _) in &drawn {
        named.entry(*a).or_default().extend(keys.iter().copied());
    }
    for d in &r.departures {
        if let Some(keys) = named.get_mut(&d.arch)
            && d.key != TMS_SETTING
            && Some(d.key.as_str()) != size_column(d.arch)
        {
            keys.insert(&d.key);
        }
    }
    let mut out = Vec::new();
    for (a, scene, fixed, _, rows) in drawn {
        let keys = &named[&a];
        // Legend names: a key's last part, or the whole key where two share it.
        let short = |k: &str| {
            let last = k.rsplit('.').next().unwrap_or(k);
            let shared = keys
                .iter()
                .filter(|o| o.rsplit('.').next() == Some(last))
                .count();
            if shared > 1 {
                k.to_string()
            } else {
                last.to_string()
            }
        };
        let variant = keys
            .iter()
            .filter_map(|k| {
                let v = setting_label(rows[0], k);
                rows.iter()
                    .all(|row| setting_label(row, k) == v)
                    .then(|| format!("{} {v}", short(k)))
            })
            .collect::<Vec<_>>()
            .join(", ");
        out.push(Curve {
            arch: a,
            scene,
            fixed,
            variant,
            rows,
        });
    }
    out
}

/// `base`, with the curve's variant appended after `; ` inside its parentheses.
fn with_variant(base: String, c: &Curve<'_>) -> String {
    if c.variant.is_empty() {
        return base;
    }
    match base.strip_suffix(')') {
        Some(open) => format!("{open}; {})", c.variant),
        None => format!("{base} ({})", c.variant),
    }
}

fn size_ticks() -> Vec<(f64, String)> {
    paper::STRATA_SIZES_BYTES
        .iter()
        .map(|b| (*b, bytes_label(*b)))
        .collect()
}

fn not_run(what: &str) -> String {
    format!("<p class=\"missing\">{what}</p>")
}

/// Figure 1: energy per frame by component, as a share of the frame's total, mean over scenes.
pub fn figure1(r: &Results) -> Figure {
    let mut series = Vec::new();
    let mut notes = String::new();
    for (i, arch) in [Arch::TraxBaseline, Arch::Strata].into_iter().enumerate() {
        let rows: Vec<&Row> = table_rows(r, arch).into_values().collect();
        if rows.is_empty() {
            notes.push_str(&not_run(&format!("{}: not run.", label(arch))));
            continue;
        }
        let mut values: Vec<Option<f64>> = COMPONENTS
            .iter()
            .map(|(c, _)| {
                Some(
                    100.0
                        * rows
                            .iter()
                            .map(|row| num(row, c) / num(row, TOTAL_ENERGY))
                            .sum::<f64>()
                        / rows.len() as f64,
                )
            })
            .collect();
        if arch == Arch::Strata {
            let shares: Option<Vec<f64>> = rows
                .iter()
                .map(|row| stream_energy(row).map(|e| e / num(row, TOTAL_ENERGY)))
                .collect();
            values.push(shares.map(|s| 100.0 * s.iter().sum::<f64>() / s.len() as f64));
        }
        let scenes: Vec<&str> = rows.iter().map(|row| scene(row)).collect();
        notes.push_str(&format!(
            "<p>rtsim {}: mean over {} scene(s) ({}).</p>",
            label(arch),
            rows.len(),
            scenes.join(", ")
        ));
        series.push(BarSeries {
            name: format!("rtsim {}", label(arch)),
            values,
            color: palette(i),
        });
    }
    let mut categories: Vec<String> = COMPONENTS.iter().map(|(_, l)| l.to_string()).collect();
    categories.push("Stream".into());
    Figure {
        name: "strata-fig1",
        caption: "STRaTA Figure 1: energy per frame by component, share of the frame's total (%), mean over the scenes run \
                  (I$: instruction caches, RF: register files, XUs: execution units). \
                  The paper's figure is graphical; its text states only that DRAM takes \"slightly over 60%\" (§1), drawn as the dashed mark."
            .into(),
        chart: Chart {
            title: "Energy per frame by component".into(),
            x_label: "component".into(),
            y_label: "share of frame energy (%)".into(),
            body: Body::Bars {
                categories,
                series,
                marks: vec![(0, 100.0 * paper::STRATA_FIG1_DRAM_SHARE, "paper: >60%".into())],
            },
        },
        notes,
    }
}

/// A curve of Figures 5–6: architecture, legend name, runs in size order.
type SizeCurve<'a> = (Arch, String, Vec<&'a Row>);

/// Curves against size (Figures 5–6) with their legend names, and the notes for the
/// architectures without one.
fn size_curves(r: &Results) -> (Vec<SizeCurve<'_>>, String) {
    let cs: Vec<_> = curves(r, size, |_, row| num(row, TMS))
        .into_iter()
        .map(|c| {
            let name = format!("{} {} ({} TMs)", c.scene, label(c.arch), c.fixed);
            (c.arch, with_variant(name, &c), c.rows)
        })
        .collect();
    let drawn: Vec<Arch> = cs.iter().map(|c| c.0).collect();
    let notes = missing_curves(&drawn, "sizes");
    (cs, notes)
}

/// `y` against size over `rows`, leaving out rows without a value.
fn size_series(
    arch: Arch,
    rows: &[&Row],
    name: String,
    color: usize,
    dashed: bool,
    y: impl Fn(&Row) -> Option<f64>,
) -> Series {
    Series {
        name,
        points: rows
            .iter()
            .filter_map(|row| y(row).map(|v| (size(arch, row), v)))
            .collect(),
        color: palette(color),
        dashed,
    }
}

/// Notes for the architectures without a curve (`drawn`: the curves' architectures, `over`:
/// what the curves vary).
fn missing_curves(drawn: &[Arch], over: &str) -> String {
    [Arch::TraxBaseline, Arch::Strata]
        .into_iter()
        .filter(|a| !drawn.contains(a))
        .map(|a| not_run(&format!("{}: not run over {over}.", label(a))))
        .collect()
}

/// Figure 5: L1 misses (solid) and stream accesses (dashed) against L2/stream size.
pub fn figure5(r: &Results) -> Figure {
    let mut series = Vec::new();
    let (cs, mut notes) = size_curves(r);
    for (i, (arch, name, rows)) in cs.iter().enumerate() {
        let l1 = |row: &Row| row.num(L1_MISSES);
        series.push(size_series(
            *arch,
            rows,
            format!("{name} L1 misses"),
            i,
            false,
            l1,
        ));
        if *arch == Arch::Strata {
            let stream = size_series(
                *arch,
                rows,
                format!("{name} stream"),
                i,
                true,
                stream_accesses,
            );
            if stream.points.is_empty() {
                notes.push_str(&not_run(&format!(
                    "{name}: no stream-access columns in the results."
                )));
            }
            series.push(stream);
        }
    }
    // The caption's L1 hit rates beside ours (every TRaX-chip row). The paper counts an
    // access to a line already in flight as a hit; rtsim's raw rate counts it as a miss, so
    // the comparable rate is the one counting MSHR merges as hits.
    let mut rates = String::from(
        "<p>L1 hit rates, the paper's caption against ours (all runs). The paper counts an access to a line \
         already in flight as a hit, so the comparable rate of ours counts MSHR merges as hits \
         (<code>(trax.l1.hits + trax.l1.mshr_merges) / trax.l1.accesses</code>); the raw rate \
         (<code>trax.l1.hit_rate</code>) counts them as misses.",
    );
    for (arch, lo, hi) in [Arch::TraxBaseline, Arch::Strata]
        .iter()
        .zip(paper::STRATA_FIG5_L1_HIT_PCT)
        .map(|(a, p)| (*a, p.1, p.2))
    {
        let rows: Vec<&Row> = r.of(arch).collect();
        let raw: Vec<f64> = rows.iter().map(|row| num(row, L1_HIT_RATE)).collect();
        let merged: Vec<f64> = rows
            .iter()
            .filter_map(|row| l1_hit_rate_with_merges(row))
            .collect();
        let ours = match (pct_range(&merged), pct_range(&raw)) {
            (_, None) => "not run".to_string(),
            (Some(m), Some(r)) if merged.len() == raw.len() => {
                format!("{m} counting merges (comparable), raw {r} without merges")
            }
            (_, Some(r)) => format!(
                "raw {r} without merges (not comparable: no <code>{L1_MSHR_MERGES}</code> column in every row)"
            ),
        };
        rates.push_str(&format!(
            "<br>{}: paper {lo}–{hi} %, rtsim {ours};",
            label(arch)
        ));
    }
    rates.push_str("</p>");
    notes.push_str(&rates);
    Figure {
        name: "strata-fig5",
        caption: "STRaTA Figure 5: L1 misses (solid) and stream memory accesses (dashed) against the L2 (baseline) or stream memory (STRaTA) size; \
                  STRaTA's L1 misses go to its fixed 512 KB L2. The grey line is 1.5 MB (GK110's L2). The paper's curves are graphical only."
            .into(),
        chart: Chart {
            title: "L1 misses and stream accesses vs L2/stream size".into(),
            x_label: "L2 / stream memory size".into(),
            y_label: "accesses per frame".into(),
            body: Body::Lines {
                x_scale: Scale::Log2,
                y_scale: Scale::Linear,
                x_ticks: size_ticks(),
                series,
                marker: Some((paper::STRATA_GK110_L2_BYTES, "GK110".into())),
            },
        },
        notes,
    }
}

/// Figure 6: L2/stream energy (dashed) and DRAM energy (solid) per frame against size.
pub fn figure6(r: &Results) -> Figure {
    let mut series = Vec::new();
    let (cs, mut notes) = size_curves(r);
    for (i, (arch, name, rows)) in cs.iter().enumerate() {
        let dram = |row: &Row| row.num(DRAM_ENERGY);
        series.push(size_series(
            *arch,
            rows,
            format!("{name} DRAM"),
            i,
            false,
            dram,
        ));
        let strata = *arch == Arch::Strata;
        let on_chip = |row: &Row| {
            let stream = if strata { stream_energy(row)? } else { 0.0 };
            Some(num(row, L2_ENERGY) + stream)
        };
        let what = if strata { "L2+stream" } else { "L2" };
        let s = size_series(*arch, rows, format!("{name} {what}"), i, true, on_chip);
        if s.points.is_empty() {
            notes.push_str(&not_run(&format!(
                "{name}: no stream-energy column in the results."
            )));
        }
        series.push(s);
    }
    Figure {
        name: "strata-fig6",
        caption: "STRaTA Figure 6: energy per frame of the L2 cache / stream memory (dashed) and of DRAM (solid) against their size (log scale). \
                  The grey line is 1.5 MB. The paper's curves are graphical only; its Table 2 energies per access are what our L2 and stream memory charge."
            .into(),
        chart: Chart {
            title: "L2/stream and DRAM energy vs size".into(),
            x_label: "L2 / stream memory size".into(),
            y_label: "energy per frame (J)".into(),
            body: Body::Lines {
                x_scale: Scale::Log2,
                y_scale: Scale::Log10,
                x_ticks: size_ticks(),
                series,
                marker: Some((paper::STRATA_GK110_L2_BYTES, "GK110".into())),
            },
        },
        notes,
    }
}

/// Figure 7: frames per second against the number of TMs.
pub fn figure7(r: &Results) -> Figure {
    let cs = curves(r, |_, row| num(row, TMS), size);
    let series: Vec<Series> = cs
        .iter()
        .enumerate()
        .map(|(i, c)| Series {
            name: with_variant(
                format!("{} {} ({})", c.scene, label(c.arch), bytes_label(c.fixed)),
                c,
            ),
            points: c
                .rows
                .iter()
                .map(|row| (num(row, TMS), num(row, FPS)))
                .collect(),
            color: palette(i),
            dashed: c.arch == Arch::Strata,
        })
        .collect();
    let drawn: Vec<Arch> = cs.iter().map(|c| c.arch).collect();
    let notes = missing_curves(&drawn, "TM counts");
    Figure {
        name: "strata-fig7",
        caption: "STRaTA Figure 7: performance (frames per second) against the number of TMs (32 TPs each); baseline solid, STRaTA dashed. \
                  The paper's curves are graphical only (they plateau as DRAM saturates)."
            .into(),
        chart: Chart {
            title: "Performance vs TMs".into(),
            x_label: "TMs".into(),
            y_label: "frames per second".into(),
            body: Body::Lines {
                x_scale: Scale::Log2,
                y_scale: Scale::Linear,
                x_ticks: paper::STRATA_FIG7_TMS.iter().map(|t| (*t, chart::short_number(*t))).collect(),
                series,
                marker: None,
            },
        },
        notes,
    }
}

/// The paper scenes in the paper's order, then scenes of ours it does not have.
fn scene_order(r: &Results) -> Vec<(Option<&'static str>, Option<String>)> {
    let mut out: Vec<(Option<&'static str>, Option<String>)> = paper::STRATA_TABLE1
        .iter()
        .map(|t| {
            let p = t.paper_scene;
            (Some(p), paper::our_scene(p).map(str::to_string))
        })
        .collect();
    let mut extra: Vec<String> = r
        .rows
        .iter()
        .filter(|(a, _)| a.is_trax())
        .map(|(_, row)| scene(row).to_string())
        .filter(|s| !out.iter().any(|(_, o)| o.as_deref() == Some(s.as_str())))
        .collect();
    extra.sort();
    extra.dedup();
    out.extend(extra.into_iter().map(|s| (None, Some(s))));
    out
}

fn dram_paper(c: &DramCols, baseline_j: Option<f64>) -> String {
    let energy = match baseline_j {
        Some(b) => format!("{} ({:.0}%)", c.dram_energy_j, 100.0 * c.dram_energy_j / b),
        None => c.dram_energy_j.to_string(),
    };
    [
        c.accesses_m.to_string(),
        c.row_hit_percent.to_string(),
        c.read_latency_cycles.to_string(),
        c.ms_per_frame.to_string(),
        energy,
    ]
    .iter()
    .map(|s| td(s))
    .collect()
}

/// Our five Table 1 cells from `row`; with `baseline_j` (STRaTA's side, when the baseline ran)
/// the DRAM energy also gets its percentage of the baseline's, as the paper prints it.
fn dram_ours(row: Option<&&Row>, baseline_j: Option<f64>, missing: &str) -> String {
    let v = |col: &str| row.and_then(|r| Val::mean(&[r], col));
    let energy = |x: f64| match baseline_j {
        Some(b) if b > 0.0 => format!("{} ({:.0}%)", significant(x, 3), 100.0 * x / b),
        _ => significant(x, 3),
    };
    td_val(&v(DRAM_ACCESSES), |x| significant(x / 1e6, 3), missing)
        + &td_val(&v(ROW_HIT_RATE), |x| fixed(100.0 * x, 0), missing)
        + &td_val(&v(READ_LATENCY), |x| fixed(x, 0), missing)
        + &td_val(&v(MS_PER_FRAME), |x| fixed(x, 3), missing)
        + &td_val(&v(DRAM_ENERGY), energy, missing)
}

/// The text of a row of ours for a paper scene that `../shared/scenes` does not have.
const NO_SCENE: &str = "no scene: not among the benchmark scenes (../shared/scenes), so not run";

/// Table 1: DRAM characteristics and ms/frame per scene, baseline and STRaTA.
pub fn table1(r: &Results) -> String {
    let base = table_rows(r, Arch::TraxBaseline);
    let strata = table_rows(r, Arch::Strata);
    let cols = [
        "DRAM accesses (M)",
        "Row buffer hit rate (%)",
        "Avg. read latency (cycles)",
        "ms/frame",
        "DRAM energy (J)",
    ];
    let sub: String = cols.iter().chain(&cols).map(|c| th(c, 1)).collect();
    let head = vec![
        format!(
            "{}{}{}{}",
            th("Scene", 1),
            th("", 1),
            th("Baseline", 5),
            th("STRaTA", 5)
        ),
        format!("{}{}{sub}", th("", 1), th("", 1)),
    ];
    let mut body = Vec::new();
    for (paper_scene, ours) in scene_order(r) {
        let name = paper_scene
            .map(str::to_string)
            .or(ours.clone())
            .unwrap_or_default();
        if let Some((b, s)) = paper::STRATA_TABLE1
            .iter()
            .find(|t| Some(t.paper_scene) == paper_scene)
            .map(|t| (&t.baseline, &t.strata))
        {
            body.push((
                "paper".to_string(),
                td(&name)
                    + &td("paper")
                    + &dram_paper(b, None)
                    + &dram_paper(s, Some(b.dram_energy_j)),
            ));
        }
        let Some(key) = ours else {
            body.push((
                "ours".to_string(),
                td(&name) + &td("rtsim") + &td_missing_row(NO_SCENE, 2 * cols.len()),
            ));
            continue;
        };
        let b = base.get(&key);
        let baseline_j = b
            .and_then(|r| Val::mean(&[r], DRAM_ENERGY))
            .map(|v| v.value);
        body.push((
            "ours".to_string(),
            td(&format!("{name} ({key})"))
                + &td("rtsim")
                + &dram_ours(b, None, "not run")
                + &dram_ours(strata.get(&key), baseline_j, "not run"),
        ));
    }
    table(
        "strata-table1",
        "STRaTA Table 1: DRAM accesses, row buffer hit rate, average read latency (GPU cycles), ms/frame and DRAM energy per frame, \
         baseline (4 MB L2) against STRaTA (4 MB stream memory + 512 KB L2). Ours: per scene, the 4 MB run with the most TMs (quick runs use fewer TMs and smaller frames, so absolute values differ); \
         our DRAM energy is printed in J with three significant digits, STRaTA's with its percentage of our baseline's.",
        &head,
        &body,
    )
}

/// Table 3: register file and instruction cache energy, baseline and STRaTA, and STRaTA's sum
/// as a percentage of the baseline's.
pub fn table3(r: &Results) -> String {
    let base = table_rows(r, Arch::TraxBaseline);
    let strata = table_rows(r, Arch::Strata);
    let head = vec![
        format!(
            "{}{}{}{}{}",
            th("Scene", 1),
            th("", 1),
            th("Baseline", 2),
            th("STRaTA", 2),
            th("Diff (%)", 1)
        ),
        format!(
            "{}{}{}{}{}{}{}",
            th("", 1),
            th("", 1),
            th("RF (J)", 1),
            th("iCache (J)", 1),
            th("RF (J)", 1),
            th("iCache (J)", 1),
            th("", 1)
        ),
    ];
    let mut body = Vec::new();
    for (paper_scene, ours) in scene_order(r) {
        let name = paper_scene
            .map(str::to_string)
            .or(ours.clone())
            .unwrap_or_default();
        if let Some(t) = paper::STRATA_TABLE3
            .iter()
            .find(|t| Some(t.paper_scene) == paper_scene)
        {
            let cells = [
                t.baseline_rf_j,
                t.baseline_icache_j,
                t.strata_rf_j,
                t.strata_icache_j,
                t.diff_percent,
            ]
            .iter()
            .map(|v| td(&v.to_string()))
            .collect::<String>();
            body.push(("paper".to_string(), td(&name) + &td("paper") + &cells));
        }
        let Some(key) = ours else {
            body.push((
                "ours".to_string(),
                td(&name) + &td("rtsim") + &td_missing_row(NO_SCENE, 5),
            ));
            continue;
        };
        let missing = "not run";
        let (b, s) = (base.get(&key), strata.get(&key));
        let v = |row: Option<&&Row>, col: &str| row.and_then(|r| Val::mean(&[r], col));
        let e = |x: f64| significant(x, 3);
        let diff = match (b, s) {
            (Some(b), Some(s)) => fixed(
                100.0 * (num(s, RF_ENERGY) + num(s, ICACHE_ENERGY))
                    / (num(b, RF_ENERGY) + num(b, ICACHE_ENERGY)),
                0,
            ),
            _ => "–".into(),
        };
        body.push((
            "ours".to_string(),
            td(&format!("{name} ({key})"))
                + &td("rtsim")
                + &td_val(&v(b, RF_ENERGY), e, missing)
                + &td_val(&v(b, ICACHE_ENERGY), e, missing)
                + &td_val(&v(s, RF_ENERGY), e, missing)
                + &td_val(&v(s, ICACHE_ENERGY), e, missing)
                + &td(&diff),
        ));
    }
    table(
        "strata-table3",
        "STRaTA Table 3: register file (RF) and instruction cache energy per frame (J), baseline against STRaTA with phase-specific pipelines; \
         Diff is STRaTA's sum as a percentage of the baseline's. Ours: the same runs as Table 1.",
        &head,
        &body,
    )
}

/// The STRaTA section.
pub fn sections(r: &Results) -> Section {
    let mut s = Section {
        title:
            "STRaTA (Kopta et al., \"Memory Considerations for Low Energy Ray Tracing\", CGF 2015)"
                .into(),
        intro: format!(
            "<p>From rows of <code>trax-baseline</code> and <code>strata</code>. Paper values: Tables 1 and 3 as printed; \
             Figures 1, 5, 6 and 7 are graphical, so only the values the text states are shown. {}</p>",
            if r.of(Arch::Strata).next().is_none() {
                "<span class=\"missing\">No <code>strata</code> rows in these results: STRaTA's columns and curves are not run.</span>"
            } else {
                ""
            }
        ),
        ..Section::default()
    };
    s.figure(figure1(r));
    s.table(table1(r));
    s.figure(figure5(r));
    s.figure(figure6(r));
    s.figure(figure7(r));
    s.table(table3(r));
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::table::Cell;

    /// A TRaX-chip row with every required column (`x` scales the values).
    pub(crate) fn trax_row(
        point: usize,
        arch: Arch,
        scene: &str,
        tms: f64,
        size: f64,
        x: f64,
    ) -> (Arch, Row) {
        let mut row = Row {
            point,
            source: None,
            ..Row::default()
        };
        for c in REQUIRED {
            row.values.insert(c.to_string(), Cell::Num(x));
        }
        row.values.insert(TMS.into(), Cell::Num(tms));
        row.values.insert(TOTAL_ENERGY.into(), Cell::Num(7.0 * x));
        row.values.insert(L1_HIT_RATE.into(), Cell::Num(0.9));
        row.values
            .insert(SCENE_COLUMN.into(), Cell::Text(scene.into()));
        row.values
            .insert(crate::ARCH_COLUMN.into(), Cell::Text(arch.preset().into()));
        row.values
            .insert(size_column(arch).unwrap().into(), Cell::Num(size));
        (arch, row)
    }

    fn results(rows: Vec<(Arch, Row)>) -> Results {
        Results {
            sources: vec!["t.csv".into()],
            predated: Vec::new(),
            departures: Vec::new(),
            rows,
        }
    }

    const MB4: f64 = 4194304.0;

    #[test]
    fn tables_take_the_4mb_run_with_most_tms_per_scene() {
        let r = results(vec![
            trax_row(0, Arch::TraxBaseline, "sibenik", 128.0, 1048576.0, 1.0),
            trax_row(1, Arch::TraxBaseline, "sibenik", 4.0, MB4, 2.0),
            trax_row(2, Arch::TraxBaseline, "sibenik", 8.0, MB4, 3.0),
            trax_row(3, Arch::TraxBaseline, "hairball", 8.0, MB4, 4.0),
        ]);
        let t = table_rows(&r, Arch::TraxBaseline);
        assert_eq!(t["sibenik"].point, 2);
        assert_eq!(t["hairball"].point, 3);
        let html = table1(&r);
        // Sibenik's paper row, then ours from point 2; STRaTA not run.
        assert!(html.contains("<td>39</td>"));
        assert!(html.contains("data-col=\"trax.ms_per_frame\" data-points=\"2\" data-value=\"3\""));
        assert!(html.contains("not run"));
        // A paper scene we do not have: one cell across the row, not one per column.
        assert!(html.contains("<td class=\"missing\" colspan=\"10\">no scene"));
        assert_eq!(
            html.matches("no scene").count(),
            5,
            "Fairy, Buddha, Buddha Box, Sodahall, San Miguel"
        );
        assert!(table3(&r).contains("<td class=\"missing\" colspan=\"5\">no scene"));
    }

    #[test]
    fn table1_gives_strata_dram_energy_as_a_share_of_the_baseline() {
        let r = results(vec![
            trax_row(0, Arch::TraxBaseline, "sibenik", 128.0, MB4, 2.0),
            trax_row(1, Arch::Strata, "sibenik", 128.0, MB4, 1.5),
        ]);
        let html = table1(&r);
        // Every column of the fake rows is x, so the energies are 2 J and 1.5 J.
        assert!(html.contains(">1.50 (75%)</td>"), "{html}");
        assert!(
            html.contains(">2.00</td>"),
            "the baseline's own cell has no share"
        );
    }

    #[test]
    fn figures_draw_only_curves_the_results_have() {
        let r = results(vec![
            trax_row(0, Arch::TraxBaseline, "sibenik", 1.0, MB4, 1.0),
            trax_row(1, Arch::TraxBaseline, "sibenik", 2.0, MB4, 2.0),
            trax_row(2, Arch::TraxBaseline, "conference", 2.0, MB4, 2.0),
        ]);
        let f7 = figure7(&r);
        let Body::Lines { series, .. } = &f7.chart.body else {
            panic!()
        };
        assert_eq!(series.len(), 1, "conference has one TM count: no curve");
        assert_eq!(series[0].points, [(1.0, 1.0), (2.0, 2.0)]);
        assert!(f7.notes.contains("STRaTA: not run"));
        // One size only: Figures 5 and 6 are empty, and say so.
        assert!(figure5(&r).chart.is_empty() && figure6(&r).chart.is_empty());
        let f1 = figure1(&r);
        let Body::Bars { series, .. } = &f1.chart.body else {
            panic!()
        };
        assert_eq!(series.len(), 1);
        // Each component is 1/7 of the total in the synthetic rows.
        assert!((series[0].values[0].unwrap() - 100.0 / 7.0).abs() < 1e-9);
    }

    /// A STRaTA Conference row at 128 TMs, stream size `mb` MB, value `x`, with settings.
    /// `experiments/strata-remedies.toml`'s two settings.
    const REMEDIES: [(&str, &str); 2] = [
        ("arch.strata.policy", "rays-per-tm"),
        ("arch.strata.fill", "static"),
    ];

    fn knob_row(point: usize, mb: f64, x: f64, settings: &[(&str, &str)]) -> (Arch, Row) {
        let mut row = trax_row(point, Arch::Strata, "conference", 128.0, mb * 1048576.0, x);
        for (k, v) in settings {
            row.1
                .values
                .insert(k.to_string(), Cell::Text(v.to_string()));
            row.1.params.insert(k.to_string());
        }
        row.1.params.insert("scene.dir".into());
        let dir = format!("/host{point}/scenes");
        row.1.values.insert("scene.dir".into(), Cell::Text(dir));
        row.1.params.insert("threads".into());
        let threads = point as f64;
        row.1.values.insert("threads".into(), Cell::Num(threads));
        row.1.params.insert("sim.mode".into());
        let mode = if point % 2 == 0 { "fast" } else { "reference" };
        row.1
            .values
            .insert("sim.mode".into(), Cell::Text(mode.into()));
        row
    }

    /// Figure 5's L1-miss curves: their names and y values.
    fn l1_curves(r: &Results) -> Vec<(String, Vec<f64>)> {
        names_and_points(&figure5(r))
            .into_iter()
            .filter(|(n, _)| n.ends_with("L1 misses"))
            .map(|(n, p)| (n, p.iter().map(|q| q.1).collect()))
            .collect()
    }

    /// Figure 5's L1-miss curves' names.
    fn l1_names(r: &Results) -> Vec<String> {
        l1_curves(r).into_iter().map(|(n, _)| n).collect()
    }

    fn names_and_points(f: &Figure) -> Vec<(String, Vec<(f64, f64)>)> {
        let Body::Lines { series, .. } = &f.chart.body else {
            panic!()
        };
        series
            .iter()
            .map(|s| (s.name.clone(), s.points.clone()))
            .collect()
    }

    #[test]
    fn rows_that_share_a_size_but_not_a_setting_are_separate_curves() {
        let default = [("arch.strata.policy", "most-rays")];
        let remedy = REMEDIES;
        // A setting that changes only with the size (here `banks`) splits nothing; one that
        // differs at a size does, and where or how the runs ran (`scene.dir`, `threads`,
        // `sim.mode`) never does.
        let r = results(vec![
            knob_row(
                0,
                4.0,
                1.0,
                &[default[0], ("arch.strata.stream.banks", "16")],
            ),
            knob_row(
                1,
                16.0,
                2.0,
                &[default[0], ("arch.strata.stream.banks", "32")],
            ),
            knob_row(
                2,
                4.0,
                3.0,
                &[remedy[0], remedy[1], ("arch.strata.stream.banks", "16")],
            ),
            knob_row(
                3,
                16.0,
                4.0,
                &[remedy[0], remedy[1], ("arch.strata.stream.banks", "32")],
            ),
        ]);
        assert_eq!(
            l1_curves(&r),
            [
                (
                    "conference STRaTA (128 TMs; fill –, policy most-rays) L1 misses".to_string(),
                    vec![1.0, 2.0]
                ),
                (
                    "conference STRaTA (128 TMs; fill static, policy rays-per-tm) L1 misses"
                        .to_string(),
                    vec![3.0, 4.0]
                ),
            ]
        );
        // The same rows without their settings (a bare CSV table): one curve, the first
        // point at each size drawn, as before.
        let bare = results(
            r.rows
                .iter()
                .map(|(a, row)| {
                    let mut row = row.clone();
                    row.params.clear();
                    (*a, row)
                })
                .collect(),
        );
        assert_eq!(
            l1_curves(&bare),
            [(
                "conference STRaTA (128 TMs) L1 misses".to_string(),
                vec![1.0, 2.0]
            )]
        );
    }

    #[test]
    fn a_setting_that_splits_one_scene_is_named_on_the_others_curves() {
        let remedy = REMEDIES;
        let default = [
            ("arch.strata.policy", "most-rays"),
            ("arch.strata.fill", "counter"),
        ];
        let sibenik = |mut row: (Arch, Row)| {
            row.1
                .values
                .insert(SCENE_COLUMN.into(), Cell::Text("sibenik".into()));
            row
        };
        // Conference only under the remedies (its banks change with the size: not named);
        // Sibenik under both.
        let r = results(vec![
            knob_row(
                0,
                4.0,
                1.0,
                &[remedy[0], remedy[1], ("arch.strata.stream.banks", "16")],
            ),
            knob_row(
                1,
                16.0,
                2.0,
                &[remedy[0], remedy[1], ("arch.strata.stream.banks", "32")],
            ),
            sibenik(knob_row(2, 4.0, 3.0, &remedy)),
            sibenik(knob_row(3, 16.0, 4.0, &remedy)),
            sibenik(knob_row(4, 4.0, 5.0, &default)),
            sibenik(knob_row(5, 16.0, 6.0, &default)),
        ]);
        let names = l1_names(&r);
        assert_eq!(
            names,
            [
                "conference STRaTA (128 TMs; fill static, policy rays-per-tm) L1 misses",
                "sibenik STRaTA (128 TMs; fill static, policy rays-per-tm) L1 misses",
                "sibenik STRaTA (128 TMs; fill counter, policy most-rays) L1 misses",
            ]
        );
    }

    #[test]
    fn settings_away_from_the_preset_are_found_and_named_on_a_curve_drawn_alone() {
        // The remedies' sweep alone: nothing splits its curve, but both points differ from
        // the preset in the remedies' two settings. Point 1 also runs another DRAM preset,
        // compared with that preset's settings; point 2 has no resolved configuration.
        let setting = |row: &mut (Arch, Row), k: &str, v: Cell| {
            row.1.values.insert(k.to_string(), v);
            row.1.params.insert(k.to_string());
        };
        let mut rows = vec![
            knob_row(0, 4.0, 1.0, &REMEDIES),
            knob_row(1, 16.0, 2.0, &REMEDIES),
            knob_row(2, 8.0, 3.0, &REMEDIES),
        ];
        for (i, row) in rows.iter_mut().enumerate() {
            let size = size_column(Arch::Strata).unwrap();
            let bytes = row.1.values[size].clone();
            setting(row, size, bytes);
            setting(row, "workload.width", Cell::Num(1024.0));
            let (dram, tcl) = if i == 1 {
                ("hbm", 20.0)
            } else {
                ("gddr5", 10.0)
            };
            setting(row, "dram.preset", Cell::Text(dram.into()));
            setting(row, "dram.tcl", Cell::Num(tcl));
            row.1.resolved = i < 2;
        }
        let mut r = results(rows);
        let presets = |arch: &str, dram: Option<&str>| {
            assert_eq!(arch, "strata");
            let dram = dram.unwrap_or("gddr5");
            let tcl = if dram == "hbm" { 20.0 } else { 10.0 };
            Some(BTreeMap::from([
                ("arch.strata.fill".to_string(), Cell::Text("counter".into())),
                ("arch.strata.policy".into(), Cell::Text("most-rays".into())),
                ("arch.strata.stream.bytes".into(), Cell::Num(MB4)),
                ("dram.preset".into(), Cell::Text(dram.into())),
                ("dram.tcl".into(), Cell::Num(tcl)),
            ]))
        };
        r.find_departures(&presets, &|_, _| true);
        let found: Vec<(&str, Cell, Vec<usize>)> = r
            .departures
            .iter()
            .map(|d| {
                assert_eq!(d.arch, Arch::Strata);
                let points = d.points.iter().map(|&(_, p)| p).collect();
                (d.key.as_str(), d.value.clone(), points)
            })
            .collect();
        let text = |s: &str| Cell::Text(s.into());
        assert_eq!(
            found,
            [
                ("arch.strata.fill", text("static"), vec![0, 1]),
                ("arch.strata.policy", text("rays-per-tm"), vec![0, 1]),
                ("arch.strata.stream.bytes", Cell::Num(4.0 * MB4), vec![1]),
                ("dram.preset", text("hbm"), vec![1]),
            ],
            "the DRAM timing is its own preset's, the workload and the scene are not compared"
        );
        let names = l1_names(&r);
        assert_eq!(
            names,
            ["conference STRaTA (128 TMs; fill static, policy rays-per-tm) L1 misses"],
            "the size is the axis, and the DRAM preset changes along the curve: neither named"
        );
    }

    #[test]
    fn settings_a_chip_does_not_read_are_neither_predated_nor_departures() {
        // Point 0 (STRaTA) has `fill`; the baseline's point 1 predates it, and its point 2
        // was run with a STRaTA setting, which the baseline chip does not read.
        let mut rows = vec![
            knob_row(0, 4.0, 1.0, &[("arch.strata.fill", "counter")]),
            trax_row(1, Arch::TraxBaseline, "conference", 128.0, MB4, 2.0),
            trax_row(2, Arch::TraxBaseline, "conference", 128.0, MB4, 3.0),
        ];
        for (k, v) in [("arch.strata.fill", "static"), ("arch.trax.tms", "64")] {
            rows[2].1.values.insert(k.into(), Cell::Text(v.into()));
            rows[2].1.params.insert(k.into());
        }
        let mut r = results(rows);
        for (_, row) in &mut r.rows {
            row.resolved = true;
        }
        let text = |s: &str| Cell::Text(s.into());
        let defaults = BTreeMap::from([("arch.strata.fill".to_string(), text("counter"))]);
        let reads =
            |preset: &str, key: &str| preset == "strata" || !key.starts_with("arch.strata.");
        r.fill_predated(&defaults, &reads);
        assert_eq!(r.predated, [], "the baseline does not read `fill`");
        assert_eq!(r.rows[1].1.values["arch.strata.fill"], text("counter"));
        let presets = |_: &str, _: Option<&str>| {
            Some(BTreeMap::from([
                ("arch.strata.fill".to_string(), text("counter")),
                ("arch.trax.tms".to_string(), text("128")),
            ]))
        };
        r.find_departures(&presets, &reads);
        let found: Vec<(Arch, &str, Vec<usize>)> = r
            .departures
            .iter()
            .map(|d| {
                (
                    d.arch,
                    d.key.as_str(),
                    d.points.iter().map(|p| p.1).collect(),
                )
            })
            .collect();
        assert_eq!(found, [(Arch::TraxBaseline, "arch.trax.tms", vec![2])]);
        // Read by every chip, `fill` would be both.
        let mut r2 = r.clone();
        r2.find_departures(&presets, &|_, _| true);
        assert_eq!(r2.departures.len(), 2);
    }

    #[test]
    fn a_setting_a_build_predates_is_drawn_at_its_default() {
        // Points 0 and 2 ran before `fill` existed; 1 and 3 have it, at its default and not.
        // Point 4 comes from a table without point directories: nothing is known of it.
        let mut r = results(vec![
            knob_row(0, 4.0, 1.0, &[("arch.strata.policy", "most-rays")]),
            knob_row(
                1,
                16.0,
                2.0,
                &[
                    ("arch.strata.policy", "most-rays"),
                    ("arch.strata.fill", "counter"),
                ],
            ),
            knob_row(2, 4.0, 3.0, &[("arch.strata.policy", "rays-per-tm")]),
            knob_row(
                3,
                4.0,
                4.0,
                &[
                    ("arch.strata.policy", "most-rays"),
                    ("arch.strata.fill", "static"),
                ],
            ),
            knob_row(4, 8.0, 5.0, &[]),
        ]);
        for (_, row) in &mut r.rows[..4] {
            row.resolved = true;
        }
        let defaults: BTreeMap<String, Cell> = [
            ("arch.strata.fill", "counter"),
            ("arch.strata.policy", "most-rays"),
            ("threads", "0"),
        ]
        .into_iter()
        .map(|(k, v)| (k.to_string(), Cell::Text(v.to_string())))
        .collect();
        r.fill_predated(&defaults, &|_, _| true);
        assert_eq!(
            r.predated,
            [crate::Predated {
                key: "arch.strata.fill".into(),
                default: Cell::Text("counter".into()),
                points: vec![(None, 0), (None, 2)],
            }],
            "only the key some rows lack, only for rows with a resolved configuration"
        );
        assert!(!r.rows[4].1.values.contains_key("arch.strata.fill"));
        let names = l1_curves(&r);
        // Points 0 and 1 are one curve: before, point 0 was `fill –` and each curve had one
        // point (none drawn).
        assert_eq!(
            names,
            [(
                "conference STRaTA (128 TMs; fill counter, policy most-rays) L1 misses".to_string(),
                vec![1.0, 2.0]
            )]
        );
        let html = crate::html::page(&r, &[], &[]);
        assert!(
            html.contains("<code>arch.strata.fill</code> = <code>counter</code> for points 0, 2"),
            "{html}"
        );
    }

    #[test]
    fn a_cycle_limit_or_a_window_sets_a_curve_apart() {
        // They decide what is simulated: a run stopped early is not the same point.
        for key in ["sim.cycle_limit", "sim.window"] {
            let limited = [(key, "1000")];
            let r = results(vec![
                knob_row(0, 4.0, 1.0, &[]),
                knob_row(1, 16.0, 2.0, &[]),
                knob_row(2, 4.0, 3.0, &limited),
                knob_row(3, 16.0, 4.0, &limited),
            ]);
            let names = l1_names(&r);
            let short = key.rsplit('.').next().unwrap();
            assert_eq!(
                names,
                [
                    format!("conference STRaTA (128 TMs; {short} –) L1 misses"),
                    format!("conference STRaTA (128 TMs; {short} 1000) L1 misses"),
                ],
                "{key}"
            );
        }
    }

    /// Baseline Sibenik rows at (point, TMs, value) in a `w`² frame.
    fn framed(w: f64, rows: &[(usize, f64, f64)]) -> Results {
        results(
            rows.iter()
                .map(|&(point, tms, x)| {
                    let mut row = trax_row(point, Arch::TraxBaseline, "sibenik", tms, MB4, x);
                    row.1.values.insert("workload.width".into(), Cell::Num(w));
                    row.1.values.insert("workload.height".into(), Cell::Num(w));
                    row
                })
                .collect(),
        )
    }

    #[test]
    fn several_results_keep_frames_apart_and_tables_take_the_larger_frame() {
        // Figure 7 at 256² (results 1) beside Table 1's runs at 1024² and 128 TMs (results 2).
        let one = framed(256.0, &[(0, 64.0, 1.0), (1, 128.0, 2.0)]);
        let two = framed(1024.0, &[(0, 64.0, 3.0), (0, 128.0, 4.0)]);
        let r = Results::merge(vec![one, two]);
        assert_eq!(r.sources.len(), 2);
        let ids: Vec<String> = r.rows.iter().map(|(_, row)| row.id()).collect();
        assert_eq!(ids, ["1:0", "1:1", "2:0", "2:0"]);
        let f7 = figure7(&r);
        let Body::Lines { series, .. } = &f7.chart.body else {
            panic!()
        };
        let named: Vec<(&str, &[(f64, f64)])> = series
            .iter()
            .map(|s| (s.name.as_str(), s.points.as_slice()))
            .collect();
        assert_eq!(
            named,
            [
                (
                    "sibenik 256×256 baseline (4 MB)",
                    &[(64.0, 1.0), (128.0, 2.0)][..]
                ),
                (
                    "sibenik 1024×1024 baseline (4 MB)",
                    &[(64.0, 3.0), (128.0, 4.0)][..]
                ),
            ]
        );
        // Table 1 takes the 128-TM run at the paper's (larger) frame.
        let t = table_rows(&r, Arch::TraxBaseline);
        assert_eq!(t["sibenik"].num(MS_PER_FRAME), Some(4.0));
        // One results: names carry no frame and ids no results' number.
        let single = framed(256.0, &[(0, 64.0, 1.0), (1, 128.0, 2.0)]);
        let merged = Results::merge(vec![single]);
        assert_eq!(merged.rows[0].1.id(), "0");
        let Body::Lines { series, .. } = &figure7(&merged).chart.body else {
            panic!()
        };
        assert_eq!(series[0].name, "sibenik baseline (4 MB)");
    }

    #[test]
    fn strata_rows_fill_the_strata_columns_and_stream_curves() {
        let mut rows = vec![
            trax_row(0, Arch::TraxBaseline, "sibenik", 128.0, MB4, 1.0),
            trax_row(1, Arch::Strata, "sibenik", 128.0, MB4, 2.0),
            trax_row(2, Arch::Strata, "sibenik", 128.0, 2.0 * MB4, 3.0),
        ];
        rows[1]
            .1
            .values
            .insert("trax.stream.pushes".into(), Cell::Num(10.0));
        rows[1]
            .1
            .values
            .insert("trax.stream.pops".into(), Cell::Num(5.0));
        let r = results(rows);
        assert_eq!(stream_accesses(&r.rows[1].1), Some(15.0));
        let html = table3(&r);
        assert!(html.contains("data-points=\"1\""), "{html}");
        let f5 = figure5(&r);
        let Body::Lines { series, .. } = &f5.chart.body else {
            panic!()
        };
        let stream = series.iter().find(|s| s.dashed).unwrap();
        assert_eq!(
            stream.points,
            [(MB4, 15.0)],
            "point 2 has no stream columns: left out"
        );
    }

    #[test]
    fn figure5_shows_the_l1_hit_rate_counting_merges_beside_the_papers() {
        let mut rows = vec![
            trax_row(0, Arch::TraxBaseline, "sibenik", 8.0, MB4, 1.0),
            trax_row(1, Arch::Strata, "sibenik", 8.0, MB4, 1.0),
        ];
        for (c, v) in [
            (L1_ACCESSES, 100.0),
            (L1_HITS, 75.0),
            (L1_MSHR_MERGES, 20.0),
        ] {
            rows[0].1.values.insert(c.into(), Cell::Num(v));
        }
        rows[0].1.values.insert(L1_HIT_RATE.into(), Cell::Num(0.75));
        assert_eq!(l1_hit_rate_with_merges(&rows[0].1), Some(0.95));
        assert_eq!(l1_hit_rate_with_merges(&rows[1].1), None);
        let notes = figure5(&results(rows)).notes;
        assert!(
            notes.contains(
                "baseline: paper 91–94 %, rtsim 95.0–95.0 % counting merges (comparable), raw 75.0–75.0 %"
            ),
            "{notes}"
        );
        // No merge column: only the raw rate, marked as not comparable.
        assert!(
            notes.contains(
                "STRaTA: paper 97–99 %, rtsim raw 90.0–90.0 % without merges (not comparable"
            ),
            "{notes}"
        );
    }
}
