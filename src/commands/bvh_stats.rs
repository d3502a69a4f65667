//! `rtsim bvh-stats`: build the scene's BVH with the configured builder (`bvh.*`), lay out its
//! memory image (`memory.*`, with the regions a chip reads or writes sized by the scene's
//! materials and the workload's image), check the tree's invariants and print a table: SAH
//! cost, node and leaf counts, leaf depth, triangles per leaf, build time, treelets with their
//! fill and DRAM rows (`memory.layout = "treelets"`), and every region's base and size.
//!
//! The treelet row check uses the address mapping of the run's `[dram]` section (its preset
//! is `dram.preset`, which `--dram-preset` sets; default `gddr5-trax`); findings are
//! warnings, or an error with `memory.treelet_row_check = "strict"`.

use super::thousands;
use crate::cli::BvhStatsArgs;
use crate::run_config::RunConfig;
use anyhow::{Context, Result};
use rtsim_bvh::memory::{
    FRAMEBUFFER_REGION, MATERIALS_REGION, NODES_REGION, PATH_STATE_REGION, TRIANGLES_REGION,
    WALD_REGION,
};
use rtsim_bvh::treelet::KindSummary;
use rtsim_bvh::{
    Builder, BvhStats, ImageExtras, Layout, MemoryImage, RecordKind, RowFinding, check_rows,
    enforce_row_check,
};
use rtsim_core::Vec3;
use rtsim_trace::TriangleTest;
use std::fmt::Write as _;
use std::time::Instant;

pub fn run(args: BvhStatsArgs) -> Result<()> {
    let flags: Vec<crate::run_config::Flag> = args
        .dram_preset
        .iter()
        .map(|p| ("dram.preset", toml::Value::String(p.clone())))
        .collect();
    let r = crate::run_config::resolve(&args.scene, &flags)?;
    let dram = DramRows::for_config(&r.config.dram)?;
    let (width, height, _) = r.config.workload.resolved_size();
    let extras = ImageExtras::for_run(
        &r.config.memory,
        r.config.trace.triangle_test == TriangleTest::Wald,
        r.scene.materials.len() as u32,
        width,
        height,
    );
    let out = report(&r.scene.name, &r.scene.triangles, &extras, &dram, &r.config)?;
    const SHOWN: usize = 5;
    for f in out.findings.iter().take(SHOWN) {
        eprintln!("warning: {f} ({} B rows, {})", dram.row_bytes, dram.preset);
    }
    if out.findings.len() > SHOWN {
        eprintln!(
            "warning: … and {} more treelets that span extra DRAM rows",
            out.findings.len() - SHOWN
        );
    }
    print!("{}", out.text);
    Ok(())
}

/// How many aligned, contiguous bytes one DRAM row holds under a preset's address mapping.
#[derive(Clone, Debug)]
struct DramRows {
    preset: String,
    mapping: String,
    row_bytes: u64,
}

impl DramRows {
    fn for_config(c: &rtsim_dram::DramConfig) -> Result<Self> {
        let m = rtsim_dram::AddressMapper::new(&c.mapping, c.bank_xor, &c.organisation)
            .with_context(|| format!("dram.mapping = {}", c.mapping))?;
        Ok(DramRows {
            preset: c.preset.clone(),
            mapping: c.mapping.clone(),
            row_bytes: m.row_run_bytes(),
        })
    }
}

/// The table, and the row-check findings to warn about.
#[derive(Debug)]
struct Report {
    text: String,
    findings: Vec<RowFinding>,
}

/// Build, measure and format; separate from `run` so it can be tested without scene files.
fn report(
    name: &str,
    triangles: &[[Vec3; 3]],
    extras: &ImageExtras,
    dram: &DramRows,
    config: &RunConfig,
) -> Result<Report> {
    let mut pool = rayon::ThreadPoolBuilder::new();
    if config.threads > 0 {
        pool = pool.num_threads(config.threads);
    }
    let pool = pool.build().context("starting worker threads")?;
    let threads = pool.current_num_threads();
    let start = Instant::now();
    let bvh = pool.install(|| rtsim_bvh::build(triangles, &config.bvh, config.memory.order))?;
    let build_time = start.elapsed();
    let image = MemoryImage::build(&bvh, &config.memory, extras)?;
    // The checks are O(n) and cheap next to the build: a broken tree or image is a bug worth a
    // loud stop.
    bvh.check_invariants(triangles, &config.bvh)
        .map_err(|e| anyhow::anyhow!("internal error: BVH invariant violated: {e}"))?;
    image
        .check()
        .map_err(|e| anyhow::anyhow!("internal error: memory image: {e}"))?;
    let findings = match image.treelets() {
        Some(t) => enforce_row_check(
            check_rows(t, dram.row_bytes),
            config.memory.treelet_row_check,
            dram.row_bytes,
        )?,
        None => Vec::new(),
    };
    let s = BvhStats::compute(&bvh, &config.bvh)
        .with_build_time(build_time)
        .with_image(&image);
    Ok(Report {
        text: format_table(name, config, threads, &s, &image, dram, &findings),
        findings,
    })
}

/// "count, fill mean … (…%), min …, max …; total" for one kind of treelet.
fn treelet_line(k: &KindSummary, budget: u64) -> String {
    format!(
        "{}, fill mean {} B ({:.1} %), min {} B, max {} B; {} in all",
        thousands(k.count),
        thousands(k.mean_bytes().round() as u64),
        100.0 * k.mean_bytes() / budget as f64,
        thousands(k.min_bytes),
        thousands(k.max_bytes),
        bytes(k.bytes)
    )
}

fn format_table(
    name: &str,
    config: &RunConfig,
    threads: usize,
    s: &BvhStats,
    image: &MemoryImage,
    dram: &DramRows,
    findings: &[RowFinding],
) -> String {
    let b = &config.bvh;
    let builder = match b.builder {
        Builder::Binned => format!("binned SAH, {} bins", b.bins),
        Builder::Sweep => "full-sweep SAH".to_string(),
    };
    let mut rows: Vec<(&str, String)> = vec![
        ("scene", name.to_string()),
        ("triangles", thousands(s.triangles)),
        (
            "builder",
            format!(
                "{builder}; leaves <= {}, max depth {}, traversal cost {}, intersection cost {}",
                b.max_leaf_size, b.max_depth, b.traversal_cost, b.intersection_cost
            ),
        ),
        (
            "build time",
            format!(
                "{} on {threads} thread{}",
                seconds(s.build_seconds.unwrap_or(0.0)),
                if threads == 1 { "" } else { "s" }
            ),
        ),
        ("SAH cost", format!("{:.3}", s.sah_cost)),
        (
            "nodes",
            format!(
                "{} ({} inner, {} leaves)",
                thousands(s.nodes),
                thousands(s.inner_nodes),
                thousands(s.leaves)
            ),
        ),
        (
            "leaf depth",
            format!("max {}, avg {:.2}", s.max_leaf_depth, s.avg_leaf_depth()),
        ),
        (
            "triangles per leaf",
            format!(
                "min {}, avg {:.2}, max {}",
                s.min_leaf_size,
                s.avg_leaf_size(),
                s.max_leaf_size
            ),
        ),
    ];
    let hist: Vec<String> = s
        .leaf_size_histogram
        .iter()
        .enumerate()
        .filter(|&(_, &c)| c > 0)
        .map(|(k, &c)| format!("{k}: {}", thousands(c)))
        .collect();
    rows.push(("leaf sizes", hist.join(", ")));
    let order = match config.memory.order {
        rtsim_bvh::NodeOrder::DepthFirst => "depth-first",
        rtsim_bvh::NodeOrder::BreadthFirst => "breadth-first",
    };
    rows.push((
        "node order",
        format!(
            "{order}{}",
            if config.memory.parent_pointers {
                ", parent pointers"
            } else {
                ""
            }
        ),
    ));
    let m = &config.memory;
    rows.push((
        "layout",
        match m.layout {
            Layout::Linear => "linear".to_string(),
            Layout::Treelets if m.treelet_packing => format!(
                "treelets of <= {} B, packed on 64 B lines, a new {} B row where one would \
                 straddle",
                thousands(m.treelet_bytes),
                thousands(m.region_alignment)
            ),
            Layout::Treelets => format!(
                "treelets of <= {} B, each aligned to {} B",
                thousands(m.treelet_bytes),
                thousands(m.region_alignment)
            ),
        },
    ));
    rows.push((
        "DRAM rows",
        format!(
            "{} B of aligned addresses per row ({}: {})",
            thousands(dram.row_bytes),
            dram.preset,
            dram.mapping
        ),
    ));
    if let Some(t) = image.treelets() {
        let sum = t.summary(dram.row_bytes);
        rows.push(("node treelets", treelet_line(&sum.node, sum.budget_bytes)));
        rows.push((
            "triangle treelets",
            treelet_line(&sum.triangle, sum.budget_bytes),
        ));
        rows.push((
            "rows per treelet",
            format!(
                "node mean {:.2} ({}..{}), triangle mean {:.2} ({}..{})",
                sum.node.mean_rows(),
                sum.node.min_rows,
                sum.node.max_rows,
                sum.triangle.mean_rows(),
                sum.triangle.min_rows,
                sum.triangle.max_rows
            ),
        ));
        rows.push((
            "row check",
            match findings.first() {
                None => "ok".to_string(),
                Some(f) => format!(
                    "{} treelet(s) span more DRAM rows than their size needs; first: {f}",
                    thousands(findings.len() as u64)
                ),
            },
        ));
    }
    for r in image.regions() {
        let (label, record) = match r.name.as_str() {
            NODES_REGION => ("node region", image.node_bytes()),
            TRIANGLES_REGION => ("triangle region", image.triangle_bytes()),
            WALD_REGION => ("wald region", stride(image, RecordKind::Wald)),
            MATERIALS_REGION => ("material region", stride(image, RecordKind::Material)),
            FRAMEBUFFER_REGION => ("framebuffer region", stride(image, RecordKind::Pixel)),
            PATH_STATE_REGION => ("path state region", stride(image, RecordKind::PathState)),
            _ => ("region", 0),
        };
        rows.push((
            label,
            format!(
                "{} at {:#x}, {record} B records",
                bytes(r.size_bytes),
                r.base
            ),
        ));
    }
    rows.push((
        "image span",
        bytes(s.image_span_bytes.unwrap_or(0)).to_string(),
    ));
    rows.push(("invariants", "ok".into()));
    let w = rows.iter().map(|r| r.0.len()).max().unwrap_or(0);
    let mut out = String::new();
    for (k, v) in rows {
        let _ = writeln!(out, "{k:<w$}  {v}");
    }
    out
}

fn stride(image: &MemoryImage, kind: RecordKind) -> u32 {
    image.records(kind).map_or(0, |s| s.stride)
}

fn seconds(t: f64) -> String {
    if t < 1.0 {
        format!("{:.1} ms", t * 1e3)
    } else {
        format!("{t:.2} s")
    }
}

fn bytes(v: u64) -> String {
    const MIB: f64 = 1024.0 * 1024.0;
    if v as f64 >= MIB {
        format!("{:.2} MiB", v as f64 / MIB)
    } else {
        format!("{} B", thousands(v))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid(n: usize) -> Vec<[Vec3; 3]> {
        let mut t = Vec::new();
        for j in 0..n {
            for i in 0..n {
                let p = |a: usize, b: usize| Vec3::new(a as f32, b as f32, 0.0);
                t.push([p(i, j), p(i + 1, j), p(i + 1, j + 1)]);
                t.push([p(i, j), p(i + 1, j + 1), p(i, j + 1)]);
            }
        }
        t
    }

    fn trax() -> DramRows {
        DramRows::for_config(&rtsim_dram::DramConfig::default()).unwrap()
    }

    fn text(tris: &[[Vec3; 3]], c: &RunConfig) -> String {
        report("grid", tris, &ImageExtras::default(), &trax(), c)
            .unwrap()
            .text
    }

    #[test]
    fn table_reports_counts_and_regions() {
        let mut c = RunConfig {
            threads: 1,
            ..Default::default()
        };
        let text = text(&grid(20), &c);
        for want in [
            "triangles           800",
            "binned SAH, 32 bins",
            "on 1 thread\n",
            "node region",
            "at 0x0, 32 B records",
            "triangle region",
            "44 B records",
            "invariants          ok",
        ] {
            assert!(text.contains(want), "missing {want:?} in\n{text}");
        }
        assert!(text.contains("layout              linear\n"), "{text}");
        assert!(!text.contains("treelets"), "{text}");
        c.bvh.builder = Builder::Sweep;
        c.memory.parent_pointers = true;
        let text = super::tests::text(&grid(20), &c);
        assert!(
            text.contains("full-sweep SAH") && text.contains("40 B records"),
            "{text}"
        );
    }

    #[test]
    fn table_reports_treelets_rows_and_extra_regions() {
        let mut c = RunConfig {
            threads: 1,
            ..Default::default()
        };
        c.memory.layout = Layout::Treelets;
        c.memory.treelet_bytes = 1024;
        let extras = ImageExtras::for_run(&c.memory, true, 3, 16, 8);
        let out = report("grid", &grid(40), &extras, &trax(), &c).unwrap();
        let text = out.text;
        for want in [
            "layout              treelets of <= 1,024 B, packed on 64 B lines, a new 8,192 B \
             row where one would straddle\n",
            "DRAM rows           8,192 B of aligned addresses per row (gddr5-trax: \
             row:rank:bank:channel:column:offset)",
            "node treelets       ",
            "triangle treelets   ",
            "rows per treelet    node mean 1.00 (1..1), triangle mean 1.00 (1..1)",
            "row check           ok",
            "wald region",
            "48 B records",
            "material region     96 B at ",
            "framebuffer region  2,048 B at ",
            "path state region   8,192 B at ",
        ] {
            assert!(text.contains(want), "missing {want:?} in\n{text}");
        }
        assert!(out.findings.is_empty());
    }

    #[test]
    fn row_check_warns_or_refuses() {
        let mut c = RunConfig {
            threads: 1,
            ..Default::default()
        };
        // 16 KB treelets aligned to 4 KB under 8 KB rows: the full top treelet, from 4 KB,
        // covers 4 KB .. 20 KB, three rows where two would do.
        c.memory.layout = Layout::Treelets;
        c.memory.region_alignment = 4096;
        c.memory.base_address = 4096;
        let tris = grid(150);
        let out = report("grid", &tris, &ImageExtras::default(), &trax(), &c).unwrap();
        let f = &out.findings[0];
        assert_eq!((f.treelet, f.rows_touched, f.rows_needed), (0, 3, 2));
        assert!(out.text.contains("span more DRAM rows"), "{}", out.text);
        c.memory.treelet_row_check = rtsim_bvh::RowCheck::Strict;
        let e = report("grid", &tris, &ImageExtras::default(), &trax(), &c)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("memory.treelet_row_check") && e.contains("8192"),
            "{e}"
        );
    }

    #[test]
    fn build_errors_name_the_key() {
        let mut c = RunConfig::default();
        c.bvh.max_depth = 2;
        let e = report("grid", &grid(20), &ImageExtras::default(), &trax(), &c)
            .unwrap_err()
            .to_string();
        assert!(e.contains("bvh.max_depth"), "{e}");
        let bad = rtsim_dram::DramConfig {
            mapping: "row:nonsense".into(),
            ..Default::default()
        };
        let e = format!("{:#}", DramRows::for_config(&bad).unwrap_err());
        assert!(e.contains("dram.mapping"), "{e}");
    }

    #[test]
    fn number_formatting() {
        assert_eq!(thousands(0), "0");
        assert_eq!(thousands(999), "999");
        assert_eq!(thousands(1000), "1,000");
        assert_eq!(thousands(75_284), "75,284");
        assert_eq!(thousands(2_900_000), "2,900,000");
        assert_eq!(bytes(512), "512 B");
        assert_eq!(bytes(3 << 20), "3.00 MiB");
        assert_eq!(seconds(0.0452), "45.2 ms");
        assert_eq!(seconds(3.4), "3.40 s");
    }
}
