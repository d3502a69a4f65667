//! `rtsim report` on the real binary: a tiny sweep (the TRaX baseline over two TM counts,
//! one-core SGRT SPTRV and PPTRV points), then the report — every file there, the PNGs decode
//! at the canvas size, every number of ours in the HTML equals the merged table's, a second
//! run is byte-identical — and bad input fails with a message, never a panic.

mod common;
use common::{fails, ok, rtsim};
use std::collections::BTreeMap;
use std::path::Path;

const FIGURES: [&str; 4] = ["strata-fig1", "strata-fig5", "strata-fig6", "strata-fig7"];

fn experiment(dir: &Path) -> std::path::PathBuf {
    let p = dir.join("exp.toml");
    std::fs::write(
        &p,
        r#"
name = "report-test"
command = "simulate"
[base]
"arch.preset" = "trax-baseline"
"scene.name" = "cornell"
"workload.width" = 8
"workload.height" = 8
[grid]
"arch.trax.tms" = [1, 2]
[[point]]
"arch.preset" = "sgrt-sptrv"
"arch.sgrt.cores" = 1
"arch.sgrt.shader" = false
"scene.name" = "sibenik"
"workload.kind" = "primary"
[[point]]
"arch.preset" = "sgrt-1"
"arch.sgrt.shader" = false
"scene.name" = "sibenik"
"workload.kind" = "primary"
"#,
    )
    .unwrap();
    p
}

/// The merged CSV as (point, column) → number.
fn csv_numbers(path: &Path) -> BTreeMap<(usize, String), f64> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    // The test's columns hold no quoted cells.
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let mut out = BTreeMap::new();
    for line in lines {
        let cells: Vec<&str> = line.split(',').collect();
        let point: usize = cells[0].parse().unwrap();
        for (h, c) in header.iter().zip(&cells) {
            if let Ok(v) = c.parse::<f64>() {
                out.insert((point, h.to_string()), v);
            }
        }
    }
    out
}

/// Every cell of ours: (column, points, value).
fn our_cells(html: &str) -> Vec<(String, Vec<usize>, f64)> {
    let attr = |s: &str, name: &str| -> String {
        let start = s.find(&format!("{name}=\"")).unwrap() + name.len() + 2;
        s[start..start + s[start..].find('"').unwrap()].to_string()
    };
    html.split("<td class=\"ours\" ")
        .skip(1)
        .map(|s| {
            let points = attr(s, "data-points")
                .split(' ')
                .map(|p| p.parse().unwrap())
                .collect();
            (
                attr(s, "data-col"),
                points,
                attr(s, "data-value").parse().unwrap(),
            )
        })
        .collect()
}

#[test]
fn a_report_of_a_small_sweep_has_every_file_and_the_tables_numbers() {
    let tmp = tempfile::tempdir().unwrap();
    let results = tmp.path().join("r");
    ok(rtsim()
        .arg("sweep")
        .arg(experiment(tmp.path()))
        .arg("--out")
        .arg(&results)
        .args(["--jobs", "2"]));
    let out = tmp.path().join("rep");
    let said = ok(rtsim().arg("report").arg(&results).arg("--out").arg(&out));
    assert!(said.contains("4 figures"), "{said}");

    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    for name in FIGURES {
        let svg = std::fs::read_to_string(out.join(format!("figures/{name}.svg"))).unwrap();
        assert!(svg.starts_with("<svg") && html.contains(&format!("href=\"figures/{name}.png\"")));
        let png = std::fs::File::open(out.join(format!("figures/{name}.png"))).unwrap();
        let reader = png::Decoder::new(std::io::BufReader::new(png))
            .read_info()
            .unwrap();
        let info = reader.info();
        assert_eq!(
            (info.width, info.height),
            (rtsim_report::chart::WIDTH, rtsim_report::chart::HEIGHT)
        );
    }

    // Every number of ours is the mean of its column over its points in the merged table.
    let table = csv_numbers(&results.join("results.csv"));
    let cells = our_cells(&html);
    for (col, points, value) in &cells {
        let sum: f64 = points.iter().map(|p| table[&(*p, col.clone())]).sum();
        let mean = sum / points.len() as f64;
        assert!(
            (mean - value).abs() <= 1e-12 * mean.abs(),
            "{col} {points:?}: {value} vs {mean}"
        );
    }
    let cols: Vec<&str> = cells.iter().map(|c| c.0.as_str()).collect();
    // Table 1 and 3 (cornell at 2 TMs, point 1) and Table 4 (Sibenik primary, SPTRV and PPTRV).
    for c in [
        "trax.ms_per_frame",
        "trax.energy.register_file_j",
        "sgrt.mrays_per_second",
    ] {
        assert!(cols.contains(&c), "{c} not in the report");
    }
    assert!(
        cells
            .iter()
            .any(|(c, p, _)| c == "trax.dram.accesses" && p == &[1])
    );
    assert!(html.contains("not run"), "STRaTA has no rows");
    // Figure 7 has the TM curve.
    let fig7 = std::fs::read_to_string(out.join("figures/strata-fig7.svg")).unwrap();
    assert_eq!(fig7.matches("<circle").count(), 2, "{fig7}");

    // Deterministic: a second run writes the same bytes.
    let again = tmp.path().join("rep2");
    ok(rtsim().arg("report").arg(&results).arg("--out").arg(&again));
    let mut files = vec!["report.html".to_string()];
    for name in FIGURES {
        files.push(format!("figures/{name}.svg"));
        files.push(format!("figures/{name}.png"));
    }
    for f in files {
        let a = std::fs::read(out.join(&f)).unwrap();
        let b = std::fs::read(again.join(&f)).unwrap();
        // The page names its input, which is the same directory.
        assert!(a == b, "{f} differs between two runs");
    }

    // The merged table alone (the points beside it complete the rows) gives the same page.
    let from_table = tmp.path().join("rep3");
    ok(rtsim()
        .arg("report")
        .arg(results.join("results.jsonl"))
        .arg("--out")
        .arg(&from_table));
    let page = std::fs::read_to_string(from_table.join("report.html")).unwrap();
    assert_eq!(our_cells(&page), cells);
}

#[test]
fn bad_input_is_an_error_naming_the_file_and_column() {
    let tmp = tempfile::tempdir().unwrap();
    let missing = tmp.path().join("nowhere");
    let e = fails(rtsim().arg("report").arg(&missing));
    assert!(e.contains("nowhere"), "{e}");

    let empty = tmp.path().join("empty");
    std::fs::create_dir(&empty).unwrap();
    let e = fails(rtsim().arg("report").arg(&empty));
    assert!(e.contains("results.jsonl") && e.contains("empty"), "{e}");

    // A table with a header and no finished point, or cut off inside its header: an error
    // (it reported "0 finished points" and exited 0).
    for (name, text) in [
        ("header-only.csv", "point,arch.preset,scene.name\n"),
        ("cut.csv", "point,arch.pre"),
    ] {
        let path = tmp.path().join(name);
        std::fs::write(&path, text).unwrap();
        let e = fails(rtsim().arg("report").arg(&path));
        assert!(
            e.contains(name) && e.contains("no point has finished"),
            "{e}"
        );
    }

    let no_arch = tmp.path().join("no-arch.csv");
    std::fs::write(&no_arch, "point,scene.name\n0,sibenik\n").unwrap();
    let e = fails(rtsim().arg("report").arg(&no_arch));
    assert!(
        e.contains("no-arch.csv") && e.contains("`arch.preset`"),
        "{e}"
    );

    let unknown = tmp.path().join("unknown.csv");
    std::fs::write(
        &unknown,
        "point,arch.preset,scene.name\n0,functional,sibenik\n",
    )
    .unwrap();
    let e = fails(rtsim().arg("report").arg(&unknown));
    assert!(
        e.contains("unknown.csv") && e.contains("`functional`"),
        "{e}"
    );

    let no_column = tmp.path().join("no-column.csv");
    std::fs::write(
        &no_column,
        "point,arch.preset,scene.name\n0,trax-baseline,sibenik\n",
    )
    .unwrap();
    let e = fails(rtsim().arg("report").arg(&no_column));
    assert!(
        e.contains("no-column.csv") && e.contains("`trax.chip.tms`"),
        "{e}"
    );
}

#[test]
fn a_report_over_two_sweeps_draws_their_rows_together() {
    let tmp = tempfile::tempdir().unwrap();
    let sweep = |name: &str, tms: &str| {
        let exp = tmp.path().join(format!("{name}.toml"));
        std::fs::write(
            &exp,
            format!(
                "name = \"{name}\"\ncommand = \"simulate\"\n[base]\n\"arch.preset\" = \"trax-baseline\"\n\
                 \"scene.name\" = \"cornell\"\n\"workload.width\" = 8\n\"workload.height\" = 8\n\
                 [grid]\n\"arch.trax.tms\" = {tms}\n"
            ),
        )
        .unwrap();
        let out = tmp.path().join(name);
        ok(rtsim().arg("sweep").arg(&exp).arg("--out").arg(&out));
        out
    };
    let (a, b) = (sweep("a", "[1, 2]"), sweep("b", "[4]"));
    let e = fails(rtsim().arg("report").arg(&a).arg(&b));
    assert!(e.contains("--out is required with 2 RESULTS"), "{e}");

    let out = tmp.path().join("rep");
    let e = fails(
        rtsim()
            .arg("report")
            .arg(&a)
            .arg(a.join("results.csv").parent().unwrap().join("."))
            .arg("--out")
            .arg(&out),
    );
    assert!(e.contains("are the same results"), "{e}");
    let e = fails(
        rtsim()
            .arg("report")
            .arg(&a)
            .arg(a.join("results.csv"))
            .arg("--out")
            .arg(&out),
    );
    assert!(e.contains("are the same results"), "{e}");
    ok(rtsim().arg("report").arg(&a).arg(&b).arg("--out").arg(&out));
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    assert!(html.contains("[1] <code>") && html.contains("[2] <code>"));
    // b's one TM count joins a's two on one curve.
    let fig7 = std::fs::read_to_string(out.join("figures/strata-fig7.svg")).unwrap();
    assert_eq!(fig7.matches("<circle").count(), 3, "{fig7}");
    // Table 1 takes b's 4-TM run, named by its results' number.
    assert!(
        html.contains("data-col=\"trax.ms_per_frame\" data-points=\"2:0\""),
        "{html}"
    );
}

#[test]
fn the_recorded_results_differ_from_their_presets_only_where_their_experiments_say() {
    // Table 1 runs the presets as they are; the remedies' sweep sets two STRaTA knobs in its
    // base. The presets' configurations come from the binary's own layering, so a preset
    // resolved wrongly would list settings for Table 1 too.
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/results");
    let page = |name: &str| {
        let tmp = tempfile::tempdir().unwrap();
        ok(rtsim()
            .arg("report")
            .arg(root.join(name))
            .arg("--out")
            .arg(tmp.path()));
        let html = std::fs::read_to_string(tmp.path().join("report.html")).unwrap();
        let fig5 = std::fs::read_to_string(tmp.path().join("figures/strata-fig5.svg")).unwrap();
        (html, fig5)
    };
    let (table1, _) = page("strata-table1");
    assert!(!table1.contains("differ from their presets"), "{table1}");
    let (remedies, fig5) = page("strata-remedies");
    assert!(
        remedies.contains(
            "<li><code>strata</code>: <code>arch.strata.fill</code> = <code>static</code> (points 0–11); \
             <code>arch.strata.policy</code> = <code>rays-per-tm</code> (points 0–11); \
             <code>arch.strata.stream.bytes</code> = <code>524288 (512 KB)</code> (points 0–1)"
        ),
        "{remedies}"
    );
    // The legend names the remedies (a long name wraps onto a second line at a space).
    assert!(
        fig5.contains(">sibenik STRaTA (128 TMs; fill static, policy</text>")
            && fig5.contains(">rays-per-tm) L1 misses</text>"),
        "{fig5}"
    );
}
