//! `rtsim simulate --arch strata`, `rtsim compare --arch trax-baseline --arch strata` and
//! `rtsim bench-sim --arch strata` end to end: outputs, the image equal to the functional
//! render with the same settings, the tables, determinism, and configuration errors.

mod common;
use common::{fails, ok, rtsim};
use std::fs;
use std::path::Path;

const SMALL: [&str; 8] = [
    "--width",
    "16",
    "--height",
    "16",
    "--set",
    "arch.trax.tms=2",
    "--set",
    "arch.trax.tps_per_tm=8",
];

fn simulate(out: &Path, extra: &[&str]) -> String {
    ok(rtsim()
        .args(["simulate", "--arch", "strata"])
        .args(SMALL)
        .arg("--out")
        .arg(out)
        .args(extra))
}

#[test]
fn simulate_renders_the_functional_image_and_repeats_exactly() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b, render) = (
        dir.path().join("a"),
        dir.path().join("b"),
        dir.path().join("render"),
    );
    let stdout = simulate(&a, &[]);
    for want in ["stream memory", "treelet", "row-buffer hit rate", "energy"] {
        assert!(stdout.contains(want), "summary lacks {want}: {stdout}");
    }
    let stats: serde_json::Value =
        serde_json::from_str(&fs::read_to_string(a.join("stats.json")).unwrap()).unwrap();
    assert!(stats["strata"]["stream"]["pushes"].as_u64().unwrap() > 0);
    assert!(stats["trax"]["energy"]["stream_j"].as_f64().unwrap() > 0.0);
    // The functional tracer with the preset's settings renders the same image.
    ok(rtsim()
        .args(["render", "--width", "16", "--height", "16"])
        .args(["--set", "arch.preset=strata", "--out"])
        .arg(&render));
    assert_eq!(
        fs::read(a.join("render.png")).unwrap(),
        fs::read(render.join("render.png")).unwrap()
    );
    // No cycles belong to one pixel on STRaTA: its heat map is the pixels' nodes visited, the
    // functional render's (it was one flat colour).
    assert!(
        stdout.contains("heat map         nodes visited"),
        "{stdout}"
    );
    assert_eq!(
        fs::read(a.join("heatmap.png")).unwrap(),
        fs::read(render.join("heatmap.png")).unwrap()
    );
    simulate(&b, &[]);
    assert_eq!(
        fs::read(a.join("stats.json")).unwrap(),
        fs::read(b.join("stats.json")).unwrap(),
        "same config and seed: the same stats"
    );
}

#[test]
fn compare_writes_tables_1_and_3() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("cmp");
    let stdout = ok(rtsim()
        .args(["compare", "--arch", "trax-baseline", "--arch", "strata"])
        .args(SMALL)
        .arg("--out")
        .arg(&out));
    assert!(
        stdout.contains("Table 1") && stdout.contains("Table 3"),
        "{stdout}"
    );
    let t3 = fs::read_to_string(out.join("table3.csv")).unwrap();
    let strata: Vec<&str> = t3
        .lines()
        .find(|l| l.starts_with("strata"))
        .unwrap()
        .split(',')
        .collect();
    let pct: f64 = strata[3].parse().unwrap();
    assert!(
        pct < 100.0,
        "fused pipelines cut RF + icache energy: {pct}%"
    );
    assert!(out.join("table1.csv").is_file() && out.join("compare.json").is_file());
}

#[test]
fn compare_says_each_scene_note_once() {
    // A quad and a zero-area face: loading drops one triangle and says so, once, though
    // `compare` loads the scene for each architecture. A STRaTA setting is not read by the
    // baseline's run: said once, for it, and not an error.
    let dir = tempfile::tempdir().unwrap();
    let obj = dir.path().join("m.obj");
    fs::write(
        &obj,
        "v 0 0 -1\nv 1 0 -1\nv 1 1 -1\nv 0 1 -1\nf 1 2 3 4\nf 1 1 2\n",
    )
    .unwrap();
    let out = rtsim()
        .args([
            "compare",
            "--arch",
            "trax-baseline",
            "--arch",
            "strata",
            "--scene",
        ])
        .arg(&obj)
        .args(SMALL)
        .args(["--set", "arch.strata.poll_cycles=8"])
        .arg("--out")
        .arg(dir.path().join("cmp"))
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert_eq!(stderr.matches("dropped 1 zero-area").count(), 1, "{stderr}");
    let unread = "--set arch.strata.poll_cycles=8: `arch.strata.poll_cycles` has no effect: \
                  arch.preset = trax-baseline does not read [arch.strata] (read by strata)";
    assert_eq!(stderr.matches(unread).count(), 1, "{stderr}");
}

#[test]
fn a_set_contradicting_the_arch_flag_is_an_error() {
    let e = fails(
        rtsim()
            .args([
                "simulate",
                "--arch",
                "functional",
                "--set",
                "arch.preset=strata",
            ])
            .args(["--width", "4", "--height", "4"]),
    );
    assert!(e.contains("arch.preset") && e.contains("functional"), "{e}");
}

#[test]
fn bench_sim_runs_strata_and_bad_settings_name_their_key() {
    let stdout = ok(rtsim()
        .args([
            "bench-sim",
            "--arch",
            "strata",
            "--scene",
            "cornell",
            "--cycle-limit",
            "5000",
            "--against-baseline",
        ])
        .args(SMALL));
    assert!(
        stdout.contains("stream memory") && stdout.contains("instructions/s"),
        "{stdout}"
    );
    // Both chips' host time per simulated instruction, and their ratio.
    let line = stdout
        .lines()
        .find(|l| l.starts_with("per instruction"))
        .unwrap_or_else(|| panic!("no per-instruction line: {stdout}"));
    assert!(
        line.contains("STRaTA") && line.contains("baseline") && line.ends_with("the baseline's"),
        "{line}"
    );
    // And per simulated cycle, with a ratio that is a number.
    let line = stdout
        .lines()
        .find(|l| l.starts_with("per cycle"))
        .unwrap_or_else(|| panic!("no per-cycle line: {stdout}"));
    let ratio: f64 = line
        .rsplit("STRaTA ")
        .next()
        .and_then(|r| r.split('×').next())
        .and_then(|r| r.trim().parse().ok())
        .unwrap_or_else(|| panic!("no ratio in {line}"));
    assert!(ratio.is_finite() && ratio > 0.0, "{line}");
    // And per synchronising access, with each chip's accesses per instruction: STRaTA's fused
    // tests read their inputs one load each, so its share is the larger.
    let line = stdout
        .lines()
        .find(|l| l.starts_with("per access"))
        .unwrap_or_else(|| panic!("no per-access line: {stdout}"));
    let shares: Vec<f64> = line
        .split(" per instruction")
        .next()
        .and_then(|l| l.rsplit("accesses — ").next())
        .map(|l| {
            l.split(" and ")
                .filter_map(|x| x.trim().parse().ok())
                .collect()
        })
        .unwrap_or_default();
    assert!(
        shares.len() == 2 && shares.iter().all(|s| *s > 0.0 && *s < 1.0) && shares[0] > shares[1],
        "{line}"
    );
    let e = fails(rtsim().args(["bench-sim", "--against-baseline", "--cycle-limit", "10"]));
    assert!(e.contains("--arch strata"), "{e}");
    let dir = tempfile::tempdir().unwrap();
    // The error of `simulate --arch strata --set SET` names each of `keys`.
    let names = |set: &str, keys: &[&str]| {
        let e = fails(
            rtsim()
                .args(["simulate", "--arch", "strata", "--set", set])
                .arg("--out")
                .arg(dir.path()),
        );
        assert!(keys.iter().all(|k| e.contains(k)), "{set}: {e}");
    };
    names(
        "arch.strata.triangle_pipelines=3",
        &["arch.strata.triangle_pipelines", "1..=2"],
    );
    names("trace.traversal=stack", &["trace.traversal", "bit-stack"]);
    // The baseline's L2 size is not STRaTA's: changing it is an error, not silently ignored.
    names(
        "arch.trax.l2.size_bytes=1048576",
        &["arch.trax.l2.size_bytes", "arch.strata.l2_bytes"],
    );
}

#[test]
fn timeline_writes_a_row_per_interval_and_bad_settings_name_their_key() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = (dir.path().join("a"), dir.path().join("b"));
    let stdout = simulate(&a, &["--timeline", "2000"]);
    assert!(stdout.contains("timeline.csv"), "{stdout}");
    let csv = fs::read_to_string(a.join("timeline.csv")).unwrap();
    let header = csv.lines().next().unwrap();
    for col in [
        "issue_rate",
        "dram_reads",
        "stream_pops",
        "root_holders",
        "live_paths",
    ] {
        assert!(header.split(',').any(|c| c == col), "{header}");
    }
    let stats: serde_json::Value =
        serde_json::from_str(&fs::read_to_string(a.join("stats.json")).unwrap()).unwrap();
    let cycles = stats["trax"]["cycles"].as_u64().unwrap();
    assert_eq!(csv.lines().count() as u64 - 1, cycles.div_ceil(2000));
    // The same key in a config file, and the same run again: byte-identical.
    let cfg = dir.path().join("c.toml");
    fs::write(&cfg, "[sim]\ntimeline_cycles = 2000\n").unwrap();
    simulate(&b, &["--config", cfg.to_str().unwrap()]);
    assert_eq!(csv, fs::read_to_string(b.join("timeline.csv")).unwrap());
    // Without it, no file.
    let c = dir.path().join("c");
    simulate(&c, &[]);
    assert!(!c.join("timeline.csv").exists());
    let e = fails(
        rtsim()
            .args(["simulate", "--arch", "strata", "--timeline", "0", "--out"])
            .arg(dir.path().join("d")),
    );
    assert!(
        e.contains("sim.timeline_cycles") && e.contains("at least 1"),
        "{e}"
    );
    let e = fails(
        rtsim()
            .args(["simulate", "--arch", "sgrt", "--timeline", "100", "--out"])
            .arg(dir.path().join("e")),
    );
    assert!(
        e.contains("sim.timeline_cycles") && e.contains("sgrt"),
        "{e}"
    );
}

#[test]
fn report_draws_time_series_side_by_side() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = (dir.path().join("counter"), dir.path().join("static"));
    simulate(&a, &["--timeline", "2000"]);
    simulate(
        &b,
        &["--timeline", "2000", "--set", "arch.strata.fill=static"],
    );
    // The static fill renders the same image with fewer counter grants.
    assert_eq!(
        fs::read(a.join("render.png")).unwrap(),
        fs::read(b.join("render.png")).unwrap()
    );
    let grants = |d: &Path| -> u64 {
        let csv = fs::read_to_string(d.join("timeline.csv")).unwrap();
        let mut lines = csv.lines();
        let k = lines
            .next()
            .unwrap()
            .split(',')
            .position(|c| c == "atomic_grants")
            .unwrap();
        lines
            .map(|l| l.split(',').nth(k).unwrap().parse::<u64>().unwrap())
            .sum()
    };
    assert!(grants(&b) < grants(&a), "{} {}", grants(&b), grants(&a));

    let (r1, r2) = (dir.path().join("r1"), dir.path().join("r2"));
    let stdout = ok(rtsim().arg("report").arg(&a).arg(&b).arg("--out").arg(&r1));
    assert!(stdout.contains("10 figures"), "{stdout}");
    let html = fs::read_to_string(r1.join("report.html")).unwrap();
    for want in [
        "timeline-issue-rate",
        "timeline-root-rays",
        "counter",
        "static",
    ] {
        assert!(html.contains(want), "report.html lacks {want}");
    }
    assert!(r1.join("figures/timeline-live-paths.png").is_file());
    // The same inputs (here the files themselves) draw byte-identical figures.
    ok(rtsim()
        .arg("report")
        .arg(a.join("timeline.csv"))
        .arg(b.join("timeline.csv"))
        .arg("--out")
        .arg(&r2));
    assert_eq!(
        fs::read(r1.join("figures/timeline-dram.svg")).unwrap(),
        fs::read(r2.join("figures/timeline-dram.svg")).unwrap()
    );
    // A broken file is refused, naming it and the line.
    let bad = dir.path().join("bad");
    fs::create_dir(&bad).unwrap();
    let csv = fs::read_to_string(a.join("timeline.csv")).unwrap();
    let mut lines: Vec<&str> = csv.lines().collect();
    lines[2] = "1,2,3";
    fs::write(bad.join("timeline.csv"), lines.join("\n")).unwrap();
    let e = fails(rtsim().arg("report").arg(&bad));
    assert!(
        e.contains("timeline.csv") && e.contains("line 3") && e.contains("3 values"),
        "{e}"
    );
}
