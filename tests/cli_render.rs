//! `rtsim render` end to end: the README's main job, outputs, determinism across runs and
//! thread counts, and configuration errors.

mod common;
use common::{fails, ok, rtsim};
use std::fs;

#[test]
fn render_writes_all_outputs() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let stdout = ok(rtsim()
        .args(["render", "--width", "64", "--height", "48", "--out"])
        .arg(&out));
    assert!(stdout.contains("path segments"), "{stdout}");
    for f in [
        "render.png",
        "heatmap.png",
        "stats.json",
        "timing.json",
        "config.resolved.toml",
    ] {
        assert!(out.join(f).is_file(), "missing {f}");
    }
    let png = png::Decoder::new(std::io::BufReader::new(
        fs::File::open(out.join("render.png")).unwrap(),
    ));
    let info = png.read_info().unwrap().info().clone();
    assert_eq!((info.width, info.height), (64, 48));
    let stats: serde_json::Value =
        serde_json::from_slice(&fs::read(out.join("stats.json")).unwrap()).unwrap();
    assert_eq!(stats["scene"]["name"], "cornell");
    let primary = stats["rays"]["by_kind"]["primary"]["rays"]
        .as_u64()
        .unwrap();
    assert_eq!(primary, 64 * 48);
    let segments = stats["rays"]["path_segments"].as_u64().unwrap();
    // Depth 5: at most 5 hits and 10 segments per pixel; the closed Cornell box keeps most
    // paths alive.
    assert!(
        segments <= 10 * 64 * 48 && segments > 5 * 64 * 48,
        "{segments}"
    );
    // No stray temporary files.
    assert!(
        fs::read_dir(&out).unwrap().all(|e| !e
            .unwrap()
            .file_name()
            .to_string_lossy()
            .contains(".tmp"))
    );
}

#[test]
fn resolved_config_repeats_the_run() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = (dir.path().join("a"), dir.path().join("b"));
    ok(rtsim()
        .args([
            "render",
            "--workload",
            "ao",
            "--width",
            "40",
            "--height",
            "30",
            "--spp",
            "4",
            "--seed",
            "7",
        ])
        .args(["--set", "bvh.max_leaf_size=2", "--out"])
        .arg(&a));
    // Re-running from the resolved file alone (only the output directory changed) reproduces
    // the stats exactly.
    ok(rtsim()
        .args(["render", "--config"])
        .arg(a.join("config.resolved.toml"))
        .arg("--out")
        .arg(&b));
    assert_eq!(
        fs::read(a.join("stats.json")).unwrap(),
        fs::read(b.join("stats.json")).unwrap()
    );
    assert_eq!(
        fs::read(a.join("render.png")).unwrap(),
        fs::read(b.join("render.png")).unwrap()
    );
}

#[test]
fn a_dram_setting_is_named_as_having_no_effect_on_the_functional_tracer() {
    // The functional tracer has no main memory: `dram.*` is read by the timed chips only.
    let dir = tempfile::tempdir().unwrap();
    let out = rtsim()
        .args(["render", "--width", "8", "--height", "8"])
        .args(["--set", "dram.controller.read_queue=8", "--out"])
        .arg(dir.path().join("a"))
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    let unread = "note: --set dram.controller.read_queue=8: `dram.controller.read_queue` has \
                  no effect: arch.preset = functional does not read [dram] (read by sgrt, \
                  sgrt-sptrv, sgrt-1, trax-baseline, strata)";
    assert_eq!(stderr.matches(unread).count(), 1, "{stderr}");
    // The run's resolved file holds the whole `[dram]` table; repeating the run from it names
    // only what the user set.
    let again = rtsim()
        .args(["render", "--config"])
        .arg(dir.path().join("a/config.resolved.toml"))
        .arg("--out")
        .arg(dir.path().join("b"))
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&again.stderr);
    assert!(again.status.success(), "{stderr}");
    assert_eq!(stderr.matches("has no effect").count(), 1, "{stderr}");
    assert!(stderr.contains("`dram.controller.read_queue`"), "{stderr}");
}

#[test]
fn deterministic_across_runs_and_thread_counts() {
    let dir = tempfile::tempdir().unwrap();
    for workload in ["path", "diffuse"] {
        let mut outputs = Vec::new();
        for (run, threads) in [(0, "1"), (1, "2"), (2, "2")] {
            let out = dir.path().join(format!("{workload}-{run}"));
            ok(rtsim()
                .args([
                    "render",
                    "--workload",
                    workload,
                    "--width",
                    "48",
                    "--height",
                    "40",
                    "--spp",
                    "2",
                ])
                .args(["--threads", threads, "--out"])
                .arg(&out));
            outputs.push((
                fs::read(out.join("stats.json")).unwrap(),
                fs::read(out.join("render.png")).unwrap(),
            ));
        }
        assert!(
            outputs.windows(2).all(|w| w[0] == w[1]),
            "{workload}: outputs differ"
        );
    }
}

#[test]
fn every_workload_runs() {
    let dir = tempfile::tempdir().unwrap();
    for w in ["primary", "ao", "diffuse", "path", "specular"] {
        let out = dir.path().join(w);
        ok(rtsim()
            .args([
                "render",
                "--workload",
                w,
                "--width",
                "24",
                "--height",
                "16",
                "--spp",
                "2",
                "--out",
            ])
            .arg(&out));
        let stats: serde_json::Value =
            serde_json::from_slice(&fs::read(out.join("stats.json")).unwrap()).unwrap();
        assert!(
            stats["rays"]["total"]["rays"].as_u64().unwrap() >= 24 * 16,
            "{w}"
        );
    }
}

#[test]
fn config_errors_are_one_line_with_exit_2() {
    let e = fails(rtsim().args(["render", "--scene", "no-such-scene"]));
    assert!(e.contains("no-such-scene") && e.contains("cornell"), "{e}");
    let e = fails(rtsim().args(["render", "--set", "bvh.no_such_key=1"]));
    assert!(e.contains("bvh.no_such_key"), "{e}");
    let e = fails(rtsim().args(["render", "--set", "bvh.bins=many"]));
    assert!(e.contains("bvh.bins"), "{e}");
    let e = fails(rtsim().args(["render", "--set", "bvh.bins=1"]));
    assert!(e.contains("bvh.bins") && e.contains("2..=1024"), "{e}");
    let e = fails(rtsim().args(["render", "--width", "0"]));
    assert!(
        e.contains("workload.width") && e.contains("1..=16384"),
        "{e}"
    );
    let e = fails(rtsim().args(["render", "--workload", "raymarch"]));
    assert!(e.contains("workload.kind"), "{e}");
    let e = fails(rtsim().args(["render", "--set", "novalue"]));
    assert!(e.contains("novalue"), "{e}");
    let e = fails(rtsim().args(["render", "--config", "/nonexistent/x.toml"]));
    assert!(e.contains("/nonexistent/x.toml"), "{e}");
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad.toml");
    fs::write(&bad, "[bvh]\nbins = 8\nbins = = 9\n").unwrap();
    let e = fails(rtsim().arg("render").arg("--config").arg(&bad));
    assert!(e.contains("bad.toml:3"), "{e}");
}
