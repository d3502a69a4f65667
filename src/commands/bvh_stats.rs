//! `rtsim bvh-stats`: build the scene's BVH with the configured builder (`bvh.*`), lay out its
//! memory image (`memory.*`), check the tree's invariants and print a table: SAH cost, node
//! and leaf counts, leaf depth, triangles per leaf, build time and image sizes.

use super::thousands;
use crate::cli::SceneArgs;
use crate::run_config::RunConfig;
use anyhow::{Context, Result};
use rtsim_bvh::{Builder, BvhStats, MemoryImage};
use rtsim_core::Vec3;
use std::fmt::Write as _;
use std::time::Instant;

pub fn run(args: SceneArgs) -> Result<()> {
    let r = crate::run_config::resolve(&args, &[])?;
    let text = report(&r.scene.name, &r.scene.triangles, &r.config)?;
    print!("{text}");
    Ok(())
}

/// Build, measure and format; separate from `run` so it can be tested without scene files.
fn report(name: &str, triangles: &[[Vec3; 3]], config: &RunConfig) -> Result<String> {
    let mut pool = rayon::ThreadPoolBuilder::new();
    if config.threads > 0 {
        pool = pool.num_threads(config.threads);
    }
    let pool = pool.build().context("starting worker threads")?;
    let threads = pool.current_num_threads();
    let start = Instant::now();
    let bvh = pool.install(|| rtsim_bvh::build(triangles, &config.bvh, config.memory.order))?;
    let build_time = start.elapsed();
    let image = MemoryImage::new(&bvh, &config.memory)?;
    // The check is O(n) and cheap next to the build: a broken tree is a bug worth a loud stop.
    bvh.check_invariants(triangles, &config.bvh)
        .map_err(|e| anyhow::anyhow!("internal error: BVH invariant violated: {e}"))?;
    let s = BvhStats::compute(&bvh, &config.bvh)
        .with_build_time(build_time)
        .with_image(&image);
    Ok(format_table(name, config, threads, &s, &image))
}

fn format_table(
    name: &str,
    config: &RunConfig,
    threads: usize,
    s: &BvhStats,
    image: &MemoryImage,
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
    for r in image.regions() {
        let record = if r.name == rtsim_bvh::memory::NODES_REGION {
            image.node_bytes()
        } else {
            image.triangle_bytes()
        };
        rows.push((
            if r.name == rtsim_bvh::memory::NODES_REGION {
                "node region"
            } else {
                "triangle region"
            },
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

    #[test]
    fn table_reports_counts_and_regions() {
        let mut c = RunConfig {
            threads: 1,
            ..Default::default()
        };
        let text = report("grid", &grid(20), &c).unwrap();
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
        c.bvh.builder = Builder::Sweep;
        c.memory.parent_pointers = true;
        let text = report("grid", &grid(20), &c).unwrap();
        assert!(
            text.contains("full-sweep SAH") && text.contains("40 B records"),
            "{text}"
        );
    }

    #[test]
    fn build_errors_name_the_key() {
        let mut c = RunConfig::default();
        c.bvh.max_depth = 2;
        let e = report("grid", &grid(20), &c).unwrap_err().to_string();
        assert!(e.contains("bvh.max_depth"), "{e}");
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
