//! The SGRT paper's Tables 3–6 from rows of `sgrt`, `sgrt-sptrv` and `sgrt-1`. Like the
//! paper ("averages from five representative viewpoints per scene", §4.2), each value of ours
//! is the mean over the runs of its scene and ray type (the viewpoints of
//! `experiments/sgrt-tables.toml`).
//!
//! - Table 3 (RGS kernels on the SRPs): four-core PPTRV runs with the shader on.
//! - Table 4 (SPTRV against PPTRV): one-core runs, shader off.
//! - Table 5 (four T&I units): four-core PPTRV runs, shader off.
//! - Table 6 (frames per second against other platforms): four-core PPTRV runs with the
//!   shader on at 1920×1080.

use crate::html::{Section, Val, fixed, table, td, td_val, th};
use crate::paper;
use crate::table::Row;
use crate::{Arch, Results, SCENE_COLUMN};
use std::collections::BTreeMap;

pub const CORES: &str = "sgrt.cores";
pub const SHADER: &str = "sgrt.shader";
pub const MRAYS: &str = "sgrt.mrays_per_second";
pub const TRV_STEPS: &str = "sgrt.trv_steps_per_ray";
pub const IST_STEPS: &str = "sgrt.ist_steps_per_ray";
pub const TRV_UTIL: &str = "sgrt.trv_utilisation";
pub const IST_UTIL: &str = "sgrt.ist_utilisation";
pub const TRV_L1: &str = "sgrt.hit_rates.trv_l1";
pub const TRV_L2: &str = "sgrt.hit_rates.trv_l2";
pub const IST_L1: &str = "sgrt.hit_rates.ist_l1";
pub const SRP_DCACHE: &str = "sgrt.hit_rates.srp_dcache";
pub const BANDWIDTH: &str = "sgrt.dram.bandwidth_gbps";
pub const FPS: &str = "sgrt.frames_per_second";
pub const AREA: &str = "sgrt.area.total_mm2";
/// The ray type (a configuration key: the statistics hold it as text, which the merged table
/// drops, so it comes from the table's parameters or the point's resolved configuration).
pub const KIND: &str = "workload.kind";
/// Organisation of the traversal unit (`pptrv`, `sptrv`), from the resolved configuration.
pub const ORGANISATION: &str = "arch.sgrt.organisation";
/// The scene's camera (`[[viewpoint]]` of its descriptor): the runs a mean is taken over.
pub const VIEWPOINT: &str = "scene.viewpoint";
pub const WIDTH: &str = "workload.width";
pub const HEIGHT: &str = "workload.height";

/// Columns every SGRT row must have (hit rates may be absent: a cache nobody used has none).
pub const REQUIRED: &[&str] = &[CORES, SHADER, MRAYS, TRV_STEPS, IST_STEPS];

/// Our ray type for the paper's (`FSR`: forced specular rays, 2 bounces).
fn our_kind(paper: &str) -> &'static str {
    match paper {
        "Primary" => "primary",
        "AO" => "ao",
        "Diffuse" => "diffuse",
        _ => "specular",
    }
}

/// True for PPTRV runs (the configured organisation, else the preset's).
fn pptrv(arch: Arch, row: &Row) -> bool {
    match row.text(ORGANISATION) {
        Some(o) => o == "pptrv",
        None => arch != Arch::SgrtSptrv,
    }
}

/// SGRT rows matching `keep`, by (scene, ray type); of a group's rows only those with the most
/// samples (width × height × spp), so a `--quick` sweep read beside a paper-scale one does
/// not dilute its means, and one run per viewpoint (the first read), so a viewpoint run by
/// two of the results read (a sweep and a rerun of some of its points) counts once.
fn groups(r: &Results, keep: impl Fn(Arch, &Row) -> bool) -> BTreeMap<(String, String), Vec<&Row>> {
    let mut g: BTreeMap<(String, String), Vec<&Row>> = BTreeMap::new();
    for (a, row) in r.rows.iter().filter(|(a, _)| !a.is_trax()) {
        if keep(*a, row) {
            let scene = row.text(SCENE_COLUMN).unwrap_or("?").to_string();
            let kind = row.text(KIND).unwrap_or("?").to_string();
            g.entry((scene, kind)).or_default().push(row);
        }
    }
    for rows in g.values_mut() {
        let most = rows.iter().map(|r| samples(r)).max().unwrap_or(0);
        rows.retain(|r| samples(r) == most);
        let mut seen = Vec::new();
        rows.retain(|r| match r.num(VIEWPOINT) {
            Some(v) if seen.contains(&v.to_bits()) => false,
            Some(v) => {
                seen.push(v.to_bits());
                true
            }
            None => true,
        });
    }
    g
}

/// Samples a run traced: width × height × spp (the columns each missing counts as 1).
fn samples(row: &Row) -> u64 {
    ["workload.width", "workload.height", "workload.spp"]
        .iter()
        .map(|c| row.num(c).map_or(1, |v| v as u64))
        .fold(1u64, u64::saturating_mul)
}

fn cores(row: &Row) -> f64 {
    row.num(CORES).unwrap_or(f64::NAN)
}

fn shader(row: &Row) -> bool {
    row.num(SHADER) == Some(1.0)
}

/// Our rows for a paper (scene, ray type), and the text for a missing value.
fn ours<'a>(
    g: &'a BTreeMap<(String, String), Vec<&'a Row>>,
    scene: &str,
    kind: &str,
) -> (Vec<&'a Row>, &'static str) {
    match paper::our_scene(scene) {
        None => (Vec::new(), "no scene"),
        Some(s) => match g.get(&(s.to_string(), our_kind(kind).to_string())) {
            Some(rows) => (rows.clone(), "n/a"),
            None => (Vec::new(), "not run"),
        },
    }
}

/// A cell of ours: the mean of `col`, "not run" / "no scene" without rows, "n/a" where the
/// rows lack the column.
fn cell(rows: &[&Row], col: &str, missing: &str, show: impl Fn(f64) -> String) -> String {
    td_val(&Val::mean(rows, col), show, missing)
}

fn pct(x: f64) -> String {
    fixed(100.0 * x, 0)
}

fn f2(x: f64) -> String {
    fixed(x, 2)
}

fn f1(x: f64) -> String {
    fixed(x, 1)
}

fn n_runs(rows: &[&Row]) -> String {
    td(&if rows.is_empty() {
        "–".to_string()
    } else {
        rows.len().to_string()
    })
}

/// Table 3: RGS on four SRPs, primary and forced-specular rays.
/// A 16:9 frame: Table 6's 1920×1080, or its `--quick` stand-in (96×54 in
/// `experiments/sgrt-tables.toml`); Table 3's frames are 4:3 at either scale.
fn full_hd(row: &Row) -> bool {
    match (row.num(WIDTH), row.num(HEIGHT)) {
        (Some(w), Some(h)) => w * 9.0 == h * 16.0,
        _ => false,
    }
}

pub fn table3(r: &Results) -> String {
    // Not the full-HD frames of Table 6: the paper's Table 3 is at 1024×768, and a mean over
    // two frame sizes would be neither's.
    let g = groups(r, |a, row| {
        pptrv(a, row) && cores(row) == 4.0 && shader(row) && !full_hd(row)
    });
    let head = vec![
        [
            "Scene",
            "Ray type",
            "",
            "runs",
            "Texture hit (%)",
            "Data hit (%)",
            "Bandwidth (GB/s)",
            "Mrays/s",
        ]
        .iter()
        .map(|h| th(h, 1))
        .collect(),
    ];
    let mut body = Vec::new();
    for (scene, kind, tex, data, bw, m) in paper::SGRT_TABLE3 {
        let paper_cells = [
            tex.map_or("–".to_string(), |t| t.to_string()),
            data.to_string(),
            bw.to_string(),
            m.to_string(),
        ];
        body.push((
            "paper".to_string(),
            td(scene)
                + &td(kind)
                + &td("paper")
                + &td("")
                + &paper_cells.iter().map(|c| td(c)).collect::<String>(),
        ));
        let (rows, missing) = ours(&g, scene, kind);
        body.push((
            "ours".to_string(),
            td(scene)
                + &td(kind)
                + &td("rtsim")
                + &n_runs(&rows)
                + &td("not modelled")
                + &cell(&rows, SRP_DCACHE, missing, pct)
                + &cell(&rows, BANDWIDTH, missing, f2)
                + &cell(&rows, MRAYS, missing, f1),
        ));
    }
    table(
        "sgrt-table3",
        "SGRT Table 3: ray generation and shading (RGS) kernels on four SRPs at 1 GHz (32 KB texture, 4 KB data cache; FSR: forced specular rays, 2 bounces). \
         Ours: four-core PPTRV runs with the shader on (<code>arch.sgrt.shader = true</code>), ray type <code>specular</code> for FSR; \
         our Mrays/s is the whole core's (T&amp;I and SRP together), the paper's the SRP kernels' alone; the texture cache is not modelled (no shipped scene has textures).",
        &head,
        &body,
    )
}

/// The rows of `a` and `b` on the viewpoints both have (a row without a viewpoint counts as
/// one viewpoint), so that a partly run grid compares the two units on the same cameras; and
/// whether they have any in common. With none in common, or one side empty, both are kept
/// as they are (their means are shown, their ratio is not).
fn same_viewpoints<'a>(a: Vec<&'a Row>, b: Vec<&'a Row>) -> (Vec<&'a Row>, Vec<&'a Row>, bool) {
    let key = |r: &Row| r.num(VIEWPOINT).map(f64::to_bits);
    let common: Vec<Option<u64>> = a
        .iter()
        .map(|r| key(r))
        .filter(|k| b.iter().any(|r| key(r) == *k))
        .collect();
    if common.is_empty() {
        return (a, b, false);
    }
    let keep = |rows: Vec<&'a Row>| -> Vec<&'a Row> {
        rows.into_iter()
            .filter(|r| common.contains(&key(r)))
            .collect()
    };
    (keep(a), keep(b), true)
}

/// Table 4: one T&I unit, SPTRV against PPTRV.
pub fn table4(r: &Results) -> String {
    let sp = groups(r, |a, row| {
        !pptrv(a, row) && cores(row) == 1.0 && !shader(row)
    });
    let pp = groups(r, |a, row| {
        pptrv(a, row) && cores(row) == 1.0 && !shader(row)
    });
    let head = vec![
        format!(
            "{}{}{}{}{}{}",
            th("Scene", 1),
            th("Ray type", 1),
            th("", 1),
            th("Average steps", 2),
            th("Mrays/s", 2),
            th("Ratio to SPTRV", 1)
        ),
        format!(
            "{}{}{}{}{}{}{}{}",
            th("", 1),
            th("", 1),
            th("", 1),
            th("SPTRV", 1),
            th("PPTRV", 1),
            th("SPTRV", 1),
            th("PPTRV", 1),
            th("", 1)
        ),
    ];
    let mut body = Vec::new();
    for (scene, kind, ss, ps, sm, pm, ratio) in paper::SGRT_TABLE4 {
        // As printed: steps and ratios with two decimals, rates as integers.
        let cells = td(&f2(ss))
            + &td(&f2(ps))
            + &td(&sm.to_string())
            + &td(&pm.to_string())
            + &td(&f2(ratio));
        body.push((
            "paper".to_string(),
            td(scene) + &td(kind) + &td("paper") + &cells,
        ));
        let (s_rows, s_missing) = ours(&sp, scene, kind);
        let (p_rows, p_missing) = ours(&pp, scene, kind);
        let (s_rows, p_rows, paired) = same_viewpoints(s_rows, p_rows);
        let ratio = match (Val::mean(&s_rows, MRAYS), Val::mean(&p_rows, MRAYS)) {
            (Some(s), Some(p)) if paired => f2(p.value / s.value),
            _ => "–".into(),
        };
        body.push((
            "ours".to_string(),
            td(scene)
                + &td(kind)
                + &td("rtsim")
                + &cell(&s_rows, TRV_STEPS, s_missing, f2)
                + &cell(&p_rows, TRV_STEPS, p_missing, f2)
                + &cell(&s_rows, MRAYS, s_missing, f1)
                + &cell(&p_rows, MRAYS, p_missing, f1)
                + &td(&ratio),
        ));
    }
    table(
        "sgrt-table4",
        "SGRT Table 4: one T&amp;I unit, the single pipelined traversal unit (SPTRV) against the parallel pipelined one (PPTRV), 1024×768, 32 samples per pixel. \
         Ours: one-core runs with the shader off, averaged over the viewpoints both units ran. Our step counts one step per sub-pipeline pass, about three times the paper's; \
         the SPTRV/PPTRV step ratio is comparable (<code>docs/SGRT.md</code>, \"Steps\").",
        &head,
        &body,
    )
}

/// Table 5: four T&I units.
pub fn table5(r: &Results) -> String {
    let g = groups(r, |a, row| {
        pptrv(a, row) && cores(row) == 4.0 && !shader(row)
    });
    let head = vec![
        [
            "Scene",
            "Ray type",
            "",
            "TRV util. (%)",
            "IST util. (%)",
            "TRV steps",
            "IST steps",
            "TRV L1 hit (%)",
            "TRV L2 hit (%)",
            "IST L1 hit (%)",
            "Bandwidth (GB/s)",
            "Mrays/s",
            "Ratio to Tesla",
            "Ratio to Fermi",
        ]
        .iter()
        .map(|h| th(h, 1))
        .collect(),
    ];
    let mut body = Vec::new();
    for p in paper::SGRT_TABLE5 {
        // As printed: steps and ratios with two decimals, the rest as they are.
        let cells: String = [
            p.trv_util_pct.to_string(),
            p.ist_util_pct.to_string(),
            f2(p.trv_steps),
            f2(p.ist_steps),
            p.trv_l1_pct.to_string(),
            p.trv_l2_pct.to_string(),
            p.ist_l1_pct.to_string(),
            p.bandwidth_gbps.to_string(),
            p.mrays.to_string(),
            f2(p.to_tesla),
            f2(p.to_fermi),
        ]
        .iter()
        .map(|v| td(v))
        .collect();
        body.push((
            "paper".to_string(),
            td(p.scene) + &td(p.kind) + &td("paper") + &cells,
        ));
        let (rows, missing) = ours(&g, p.scene, p.kind);
        body.push((
            "ours".to_string(),
            td(p.scene)
                + &td(p.kind)
                + &td("rtsim")
                + &cell(&rows, TRV_UTIL, missing, pct)
                + &cell(&rows, IST_UTIL, missing, pct)
                + &cell(&rows, TRV_STEPS, missing, f2)
                + &cell(&rows, IST_STEPS, missing, f2)
                + &cell(&rows, TRV_L1, missing, pct)
                + &cell(&rows, TRV_L2, missing, pct)
                + &cell(&rows, IST_L1, missing, pct)
                + &cell(&rows, BANDWIDTH, missing, f2)
                + &cell(&rows, MRAYS, missing, f1)
                + &td("–")
                + &td("–"),
        ));
    }
    table(
        "sgrt-table5",
        "SGRT Table 5: four T&amp;I units at 500 MHz. Ours: four-core PPTRV runs (<code>sgrt</code>) with the shader off, averaged over viewpoints. \
         The ratios to Tesla and Fermi compare with Aila et al.'s GPU ray tracers and are the paper's only.",
        &head,
        &body,
    )
}

/// Table 6: the Fairy scene on several platforms, and our full SGRT runs at 1920×1080.
pub fn table6(r: &Results) -> String {
    let rows: Vec<&Row> = r
        .rows
        .iter()
        .filter(|(a, row)| {
            !a.is_trax() && pptrv(*a, row) && cores(row) == 4.0 && shader(row) && full_hd(row)
        })
        .map(|(_, row)| row)
        .collect();
    let mut scenes: Vec<&str> = rows
        .iter()
        .filter_map(|row| row.text(SCENE_COLUMN))
        .collect();
    scenes.sort_unstable();
    scenes.dedup();
    let cols = &paper::SGRT_TABLE6;
    let head = vec![
        th("", 1) + &cols.iter().map(|c| th(c.name, 1)).collect::<String>() + &th("rtsim sgrt", 1),
    ];
    let missing = "not run";
    let line = |name: &str, paper: &dyn Fn(&paper::SgrtTable6Col) -> String, ours: String| {
        (
            "paper".to_string(),
            td(name) + &cols.iter().map(|c| td(&paper(c))).collect::<String>() + &ours,
        )
    };
    let mut body = vec![
        line(
            "Parallelism",
            &|c| c.parallelism.into(),
            td("MIMD + loop parallelism"),
        ),
        line(
            "Resolution",
            &|c| c.resolution.into(),
            td(if rows.is_empty() {
                "1920×1080 (not run)"
            } else {
                "1920×1080"
            }),
        ),
        line(
            "Platform",
            &|c| c.platform.into(),
            td("SGRT model (T&I + SRP)"),
        ),
        line(
            "Clock (MHz)",
            &|c| c.clock_mhz.into(),
            td("500 (T&I), 1000 (SRP)"),
        ),
        line(
            "Process (nm)",
            &|c| c.process_nm.to_string(),
            td("65 (area model)"),
        ),
        line(
            "Area (mm²)",
            &|c| c.area_mm2.map_or("–".into(), |a| a.to_string()),
            cell(&rows, AREA, missing, f1),
        ),
        line("BVH type", &|c| c.bvh.unwrap_or("–").into(), td("SAH")),
        line(
            "Scene",
            &|_| "Fairy".into(),
            td(&if scenes.is_empty() {
                "–".to_string()
            } else {
                scenes.join(", ")
            }),
        ),
        line("FPS", &|c| c.fps.to_string(), cell(&rows, FPS, missing, f1)),
    ];
    // The mean above is over different scenes; each scene's own figure too (the paper's
    // columns have only Fairy's).
    if scenes.len() > 1 {
        for scene in &scenes {
            let of: Vec<&Row> = rows
                .iter()
                .copied()
                .filter(|row| row.text(SCENE_COLUMN) == Some(*scene))
                .collect();
            body.push(line(
                &format!("FPS, {scene}"),
                &|_| "–".into(),
                cell(&of, FPS, missing, f1),
            ));
        }
    }
    table(
        "sgrt-table6",
        "SGRT Table 6: frames per second on the Fairy scene, against a desktop GPU, Intel MIC and two mobile ray tracers (the paper's values). \
         Ours: four-core PPTRV runs with the shader on at 1920×1080, any scene (we do not have Fairy), averaged, then per scene.",
        &head,
        &body,
    )
}

/// The SGRT section.
pub fn sections(r: &Results) -> Section {
    let mut s = Section {
        title: "SGRT (Lee et al., \"SGRT: A Mobile GPU Architecture for Real-Time Ray Tracing\", HPG 2013)".into(),
        intro: "<p>From rows of <code>sgrt</code>, <code>sgrt-sptrv</code> and <code>sgrt-1</code>. Paper values: Tables 3–6 as printed. \
                Fairy and Ferrari are not among our scenes.</p>"
            .into(),
        ..Section::default()
    };
    s.table(table3(r));
    s.table(table4(r));
    s.table(table5(r));
    s.table(table6(r));
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::table::Cell;

    fn sgrt_row(point: usize, arch: Arch, cores: f64, kind: &str, mrays: f64) -> (Arch, Row) {
        let mut row = Row {
            point,
            source: None,
            ..Row::default()
        };
        for c in REQUIRED {
            row.values.insert(c.to_string(), Cell::Num(1.0));
        }
        row.values.insert(CORES.into(), Cell::Num(cores));
        row.values.insert(SHADER.into(), Cell::Bool(false));
        row.values.insert(MRAYS.into(), Cell::Num(mrays));
        row.values.insert(TRV_L1.into(), Cell::Num(0.5));
        row.values.insert(KIND.into(), Cell::Text(kind.into()));
        row.values
            .insert(SCENE_COLUMN.into(), Cell::Text("sibenik".into()));
        row.values
            .insert(crate::ARCH_COLUMN.into(), Cell::Text(arch.preset().into()));
        (arch, row)
    }

    #[test]
    fn table4_averages_viewpoints_and_computes_the_ratio() {
        let r = Results {
            sources: vec!["t.csv".into()],
            predated: Vec::new(),
            departures: Vec::new(),
            rows: vec![
                sgrt_row(0, Arch::SgrtSptrv, 1.0, "primary", 10.0),
                sgrt_row(1, Arch::SgrtSptrv, 1.0, "primary", 20.0),
                sgrt_row(2, Arch::Sgrt1, 1.0, "primary", 30.0),
                sgrt_row(3, Arch::Sgrt, 4.0, "ao", 99.0),
            ],
        };
        let html = table4(&r);
        assert!(
            html.contains(
                "data-col=\"sgrt.mrays_per_second\" data-points=\"0 1\" data-value=\"15\""
            ),
            "{html}"
        );
        assert!(html.contains("<td>2.00</td>"), "ratio 30/15");
        // Conference was not run; Fairy is not a scene of ours.
        assert!(html.contains("not run") && html.contains("no scene"));
        let t5 = table5(&r);
        assert!(t5.contains("data-points=\"3\" data-value=\"99\""));
        // A hit rate the run lacks is "n/a", not a number.
        assert!(t5.contains("<td class=\"missing\">n/a</td>"));
        assert!(table6(&r).contains("not run"));
    }

    #[test]
    fn table4_compares_the_units_on_the_viewpoints_both_ran() {
        // SPTRV ran viewpoints 1 and 2, PPTRV only 1 (a grid stopped part way): both columns
        // and the ratio use viewpoint 1 alone.
        let at = |point, arch, v: f64, mrays| {
            let (a, mut row) = sgrt_row(point, arch, 1.0, "primary", mrays);
            row.values.insert(VIEWPOINT.into(), Cell::Num(v));
            (a, row)
        };
        let r = Results {
            sources: vec!["t.csv".into()],
            predated: Vec::new(),
            departures: Vec::new(),
            rows: vec![
                at(0, Arch::SgrtSptrv, 1.0, 10.0),
                at(1, Arch::SgrtSptrv, 2.0, 40.0),
                at(2, Arch::Sgrt1, 1.0, 12.0),
            ],
        };
        let html = table4(&r);
        assert!(
            html.contains("data-col=\"sgrt.mrays_per_second\" data-points=\"0\" data-value=\"10\""),
            "{html}"
        );
        assert!(
            html.contains("<td>1.20</td>"),
            "ratio 12/10, not 12/25: {html}"
        );
        // No viewpoint in common: the means stand, the ratio is not given.
        let r = Results {
            sources: vec!["t.csv".into()],
            predated: Vec::new(),
            departures: Vec::new(),
            rows: vec![
                at(1, Arch::SgrtSptrv, 2.0, 40.0),
                at(2, Arch::Sgrt1, 1.0, 12.0),
            ],
        };
        let html = table4(&r);
        assert!(
            html.contains("data-points=\"1\" data-value=\"40\""),
            "{html}"
        );
        assert!(!html.contains("<td>0.30</td>"), "{html}");
    }

    #[test]
    fn means_take_the_runs_with_the_most_samples() {
        // A quick sweep's 64×48 × 1 run read beside a paper-scale 1024×768 × 32 one.
        let sized = |point, source, w: f64, h: f64, spp: f64, mrays| {
            let (a, mut row) = sgrt_row(point, Arch::Sgrt, 4.0, "ao", mrays);
            row.source = Some(source);
            for (c, v) in [
                ("workload.width", w),
                ("workload.height", h),
                ("workload.spp", spp),
            ] {
                row.values.insert(c.into(), Cell::Num(v));
            }
            (a, row)
        };
        let r = Results {
            sources: vec!["quick".into(), "full".into()],
            predated: Vec::new(),
            departures: Vec::new(),
            rows: vec![
                sized(0, 1, 64.0, 48.0, 1.0, 500.0),
                sized(0, 2, 1024.0, 768.0, 32.0, 90.0),
                sized(1, 2, 1024.0, 768.0, 32.0, 110.0),
            ],
        };
        let t5 = table5(&r);
        assert!(
            t5.contains(
                "data-col=\"sgrt.mrays_per_second\" data-points=\"2:0 2:1\" data-value=\"100\""
            ),
            "{t5}"
        );
    }

    #[test]
    fn a_viewpoint_read_twice_counts_once() {
        // Viewpoints 1 and 2 in one results directory, viewpoint 2 again in a second (a rerun
        // of a point): the mean is over viewpoints 1 and 2, each once, the first read kept.
        let at = |point, source, viewpoint: f64, mrays| {
            let (a, mut row) = sgrt_row(point, Arch::Sgrt, 4.0, "ao", mrays);
            row.source = Some(source);
            row.values.insert(VIEWPOINT.into(), Cell::Num(viewpoint));
            (a, row)
        };
        let r = Results {
            sources: vec!["sweep".into(), "rerun".into()],
            predated: Vec::new(),
            departures: Vec::new(),
            rows: vec![
                at(0, 1, 1.0, 90.0),
                at(1, 1, 2.0, 110.0),
                at(7, 2, 2.0, 110.0),
            ],
        };
        let t5 = table5(&r);
        assert!(
            t5.contains(
                "data-col=\"sgrt.mrays_per_second\" data-points=\"1:0 1:1\" data-value=\"100\""
            ),
            "{t5}"
        );
        // Without viewpoints (older tables) every row counts.
        let r = Results {
            sources: vec!["t.csv".into()],
            predated: Vec::new(),
            departures: Vec::new(),
            rows: vec![
                sgrt_row(0, Arch::Sgrt, 4.0, "ao", 90.0),
                sgrt_row(1, Arch::Sgrt, 4.0, "ao", 120.0),
            ],
        };
        assert!(table5(&r).contains("data-points=\"0 1\" data-value=\"105\""));
    }

    #[test]
    fn table3_leaves_the_full_hd_frames_to_table6() {
        let shaded = |point, w: f64, h: f64, mrays| {
            let (a, mut row) = sgrt_row(point, Arch::Sgrt, 4.0, "primary", mrays);
            row.values.insert(SHADER.into(), Cell::Bool(true));
            row.values.insert(WIDTH.into(), Cell::Num(w));
            row.values.insert(HEIGHT.into(), Cell::Num(h));
            row.values.insert(FPS.into(), Cell::Num(50.0));
            row.values.insert(AREA.into(), Cell::Num(25.0));
            (a, row)
        };
        let r = Results {
            sources: vec!["t.csv".into()],
            predated: Vec::new(),
            departures: Vec::new(),
            rows: vec![
                shaded(0, 1024.0, 768.0, 100.0),
                shaded(1, 1920.0, 1080.0, 80.0),
            ],
        };
        let t3 = table3(&r);
        assert!(
            t3.contains("data-col=\"sgrt.mrays_per_second\" data-points=\"0\" data-value=\"100\""),
            "{t3}"
        );
        assert!(!t3.contains("data-points=\"0 1\""), "{t3}");
        let t6 = table6(&r);
        assert!(t6.contains("data-points=\"1\""), "{t6}");
        assert!(!t6.contains("data-points=\"0"), "{t6}");
        // The same at `--quick` scale: 64×48 frames are Table 3's, 96×54 ones Table 6's.
        let r = Results {
            sources: vec!["t.csv".into()],
            predated: Vec::new(),
            departures: Vec::new(),
            rows: vec![shaded(0, 64.0, 48.0, 100.0), shaded(1, 96.0, 54.0, 80.0)],
        };
        assert!(!table3(&r).contains("data-points=\"0 1\""));
        let t6 = table6(&r);
        assert!(
            t6.contains("data-points=\"1\"") && !t6.contains("data-points=\"0"),
            "{t6}"
        );
        // Two scenes: their mean, then each scene's own.
        let (a, mut conf) = shaded(2, 1920.0, 1080.0, 90.0);
        conf.values
            .insert(SCENE_COLUMN.into(), Cell::Text("conference".into()));
        conf.values.insert(FPS.into(), Cell::Num(70.0));
        let r = Results {
            sources: vec!["t.csv".into()],
            predated: Vec::new(),
            departures: Vec::new(),
            rows: vec![shaded(1, 1920.0, 1080.0, 80.0), (a, conf)],
        };
        let t6 = table6(&r);
        for (points, fps) in [("1 2", "60"), ("1", "50"), ("2", "70")] {
            let want = format!(
                "data-col=\"sgrt.frames_per_second\" data-points=\"{points}\" data-value=\"{fps}\""
            );
            assert!(t6.contains(&want), "{want}: {t6}");
        }
        assert!(
            t6.contains("FPS, conference") && t6.contains("FPS, sibenik"),
            "{t6}"
        );
    }
}
