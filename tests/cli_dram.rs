//! `rtsim dram` driven as a user would: traces in the three formats, synthetic traffic, every
//! preset, the output file, and bad input (a clear one-line error and exit code 2).

use std::path::Path;
use std::process::{Command, Output};

fn rtsim(args: &[&str], dir: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_rtsim"))
        .args(args)
        .current_dir(dir)
        .output()
        .expect("rtsim runs")
}

fn ok(args: &[&str], dir: &Path) -> String {
    let o = rtsim(args, dir);
    let out = String::from_utf8_lossy(&o.stdout).to_string();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{args:?} failed:\n{out}\n{err}");
    out
}

/// Runs must fail with exit code 2 and a one-line message containing every needle.
fn fails(args: &[&str], dir: &Path, needles: &[&str]) {
    let o = rtsim(args, dir);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
    assert_eq!(
        err.trim().lines().count(),
        1,
        "{args:?}: not one line: {err}"
    );
    assert!(!err.contains("internal error"), "{args:?} panicked: {err}");
    for n in needles {
        assert!(err.contains(n), "{args:?}: `{n}` not in: {err}");
    }
}

fn stats(dir: &Path) -> serde_json::Value {
    let text = std::fs::read_to_string(dir.join("dram_stats.json")).expect("dram_stats.json");
    serde_json::from_str(&text).expect("valid JSON")
}

#[test]
fn synthetic_run_writes_stats_and_summary() {
    let dir = tempfile::tempdir().unwrap();
    let out = ok(
        &[
            "dram",
            "--synthetic",
            "random",
            "--requests",
            "3000",
            "--read-ratio",
            "0.75",
            "--out",
            "o",
        ],
        dir.path(),
    );
    for key in [
        "row-buffer hit rate",
        "read latency (mem cycles)",
        "read latency (req cycles)",
        "bandwidth",
        "average power",
        "refreshes",
    ] {
        assert!(out.contains(key), "summary lacks `{key}`:\n{out}");
    }
    let s = stats(&dir.path().join("o"));
    let r = &s["report"];
    assert_eq!(
        r["reads"].as_u64().unwrap() + r["writes"].as_u64().unwrap(),
        3000
    );
    for key in [
        "activates",
        "refreshes",
        "row_hit_rate",
        "read_latency",
        "queue_occupancy",
        "bandwidth",
        "energy",
        "stats",
    ] {
        assert!(!r[key].is_null(), "dram_stats.json lacks report.{key}");
    }
    assert!(
        r["read_latency"]["requester_cycles"]["p99"]
            .as_u64()
            .unwrap()
            > 0
    );
    assert!(r["energy"]["average_power_w"].as_f64().unwrap() > 1.0);
    assert_eq!(s["config"]["preset"], "gddr5-trax");
    assert!(dir.path().join("o/dram_config.resolved.toml").exists());
}

#[test]
fn every_preset_runs() {
    let dir = tempfile::tempdir().unwrap();
    let list = ok(&["dram", "--list-presets"], dir.path());
    for p in [
        "gddr5-trax",
        "gddr5-strata",
        "gddr5-8gb-x32",
        "lpddr3-1600",
        "ddr3-1600",
        "ddr4-3200",
    ] {
        assert!(list.contains(p), "{list}");
        ok(
            &[
                "dram",
                "--preset",
                p,
                "--synthetic",
                "stream",
                "--requests",
                "2000",
                "--read-ratio",
                "0.5",
                "--set",
                "check=true",
                "--out",
                p,
            ],
            dir.path(),
        );
        let s = stats(&dir.path().join(p));
        assert_eq!(s["config"]["preset"], p);
        assert_eq!(s["report"]["stats"]["violations"], 0);
        assert!(s["report"]["stats"]["commands_checked"].as_u64().unwrap() > 2000);
    }
}

#[test]
fn the_three_trace_formats() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(
        d.join("a.trc"),
        "# rtsim trace\n0 R 0x0\n0 R 0x40\n5 W 0x1000\n\n20 R 0x2000000\n",
    )
    .unwrap();
    std::fs::write(
        d.join("b.trc"),
        "0x0 READ 0\n0x40 READ 2\n0x1000 WRITE 10\n0x2000000 READ 40\n",
    )
    .unwrap();
    std::fs::write(
        d.join("c.trc"),
        "0 R 0x0 0x400a5c\n0 R 0x40 0x400a60\n5 W 0x1000\n15 R 0x2000000 0x400b00\n",
    )
    .unwrap();
    for (file, fmt) in [
        ("a.trc", "rtsim"),
        ("b.trc", "dramsim3"),
        ("c.trc", "usimm"),
    ] {
        ok(
            &[
                "dram",
                "--trace",
                file,
                "--format",
                fmt,
                "--preset",
                "ddr3-1600",
                "--out",
                fmt,
            ],
            d,
        );
        let s = stats(&d.join(fmt));
        assert_eq!(s["report"]["reads"], 3, "{fmt}");
        assert_eq!(s["report"]["writes"], 1, "{fmt}");
        assert_eq!(s["run"]["format"], fmt);
    }
    // DRAMsim3 cycles are memory cycles: the requester clock follows the memory clock.
    let s = stats(&d.join("dramsim3"));
    assert_eq!(s["config"]["trace"]["requester_clock_mhz"], 800.0);
    assert_eq!(s["run"]["max_outstanding_reads"], serde_json::Value::Null);
    let s = stats(&d.join("usimm"));
    assert_eq!(s["run"]["max_outstanding_reads"], 64);
}

#[test]
fn malformed_trace_names_file_and_line() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("bad.trc"), "0 R 0x0\n1 R 0x40\n2 Q 0x80\n").unwrap();
    fails(
        &["dram", "--trace", "bad.trc"],
        d,
        &["bad.trc:3", "operation"],
    );
    std::fs::write(d.join("bad2.trc"), "0x0 READ\n").unwrap();
    fails(
        &["dram", "--trace", "bad2.trc", "--format", "dramsim3"],
        d,
        &["bad2.trc:1", "field"],
    );
    std::fs::write(d.join("bad3.trc"), "10 R 0x0\n5 R 0x40\n").unwrap();
    fails(
        &["dram", "--trace", "bad3.trc"],
        d,
        &["bad3.trc:2", "earlier"],
    );
    std::fs::write(d.join("bin.trc"), [0u8, 159, 146, 150, b'\n']).unwrap();
    fails(&["dram", "--trace", "bin.trc"], d, &["bin.trc:1"]);
    fails(&["dram", "--trace", "missing.trc"], d, &["missing.trc"]);
    fails(
        &["dram", "--trace", "bad.trc", "--format", "ramulator"],
        d,
        &["ramulator", "rtsim, dramsim3, usimm"],
    );
}

#[test]
fn bad_configuration_is_a_clear_error() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let run = |extra: &[&str], needles: &[&str]| {
        let mut args = vec!["dram", "--synthetic", "random", "--requests", "10"];
        args.extend_from_slice(extra);
        fails(&args, d, needles);
    };
    run(&["--preset", "ddr9"], &["ddr9", "gddr5-trax", "ddr4-3200"]);
    run(&["--set", "timing.tRCX=3"], &["tRCX"]);
    run(&["--set", "dram.timing.tRCD=lots"], &["timing.tRCD"]);
    run(&["--set", "timing.tRC=20"], &["timing.tRC", "tRAS + tRP"]);
    run(
        &["--set", "controller.scheduler=lifo"],
        &["controller.scheduler", "fr-fcfs"],
    );
    run(
        &["--set", "organisation.channels=6"],
        &["organisation.channels", "power of two"],
    );
    run(
        &["--set", "organisation.columns=1000"],
        &["organisation.columns"],
    );
    run(
        &["--set", "mapping=row:bank:channel:column:offset:rank"],
        &["mapping", "offset"],
    );
    run(
        &["--set", "mapping=row:rank:bank(2):channel:column:offset"],
        &["mapping", "bank", "do not add up"],
    );
    run(
        &["--set", "controller.write_low_watermark=60"],
        &["controller.write_low_watermark", "0..=39"],
    );
    run(&["--set", "novalue"], &["novalue", "key=value"]);
    run(&["--read-ratio", "1.5"], &["--read-ratio", "0..=1"]);
    fails(&["dram"], d, &["--trace", "--synthetic"]);
    fails(
        &["dram", "--synthetic", "zigzag", "--requests", "10"],
        d,
        &["zigzag", "stream, random, strided"],
    );
}

#[test]
fn config_file_and_set_layers() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // A chip-style file with a [dram] table.
    std::fs::write(
        d.join("chip.toml"),
        "[dram]\npreset = \"lpddr3-1600\"\ntrace.requester_clock_mhz = 500.0\n\
         [dram.controller]\nscheduler = \"fcfs\"\nrow_policy = \"closed\"\n",
    )
    .unwrap();
    ok(
        &[
            "dram",
            "--config",
            "chip.toml",
            "--set",
            "dram.timing.tRCD=16",
            "--set",
            "mapping=row:column:rank:bank:channel:offset",
            "--synthetic",
            "strided",
            "--requests",
            "500",
            "--out",
            "o",
        ],
        d,
    );
    let s = stats(&d.join("o"));
    let c = &s["config"];
    assert_eq!(c["preset"], "lpddr3-1600");
    assert_eq!(c["trace"]["requester_clock_mhz"], 500.0);
    assert_eq!(s["report"]["setup"]["requester_clock_hz"], 500_000_000u64);
    assert_eq!(c["controller"]["scheduler"], "fcfs");
    assert_eq!(c["controller"]["row_policy"], "closed");
    assert_eq!(c["timing"]["tRCD"], 16);
    assert_eq!(c["organisation"]["channels"], 2);
    assert_eq!(c["mapping"], "row:column:rank:bank:channel:offset");
    // The resolved file repeats the run exactly.
    ok(
        &[
            "dram",
            "--config",
            "o/dram_config.resolved.toml",
            "--synthetic",
            "strided",
            "--requests",
            "500",
            "--out",
            "o2",
        ],
        d,
    );
    assert_eq!(stats(&d.join("o2"))["report"], s["report"]);
    // The requester clock is the standalone run's own key; the old root key says where it went.
    fails(
        &[
            "dram",
            "--set",
            "requester_clock_mhz=500",
            "--synthetic",
            "random",
        ],
        d,
        &["requester_clock_mhz", "trace.requester_clock_mhz"],
    );
    // --preset overrides the file's preset.
    ok(
        &[
            "dram",
            "--config",
            "chip.toml",
            "--preset",
            "ddr4-3200",
            "--synthetic",
            "random",
            "--requests",
            "100",
            "--out",
            "o3",
        ],
        d,
    );
    assert_eq!(
        stats(&d.join("o3"))["config"]["organisation"]["bank_groups"],
        4
    );
}

#[test]
fn bench_reports_requests_per_second_and_runs_repeat() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let args = |out: &'static str| {
        vec![
            "dram",
            "--synthetic",
            "random",
            "--requests",
            "20000",
            "--seed",
            "7",
            "--bench",
            "--out",
            out,
        ]
    };
    let out = ok(&args("a"), d);
    assert!(out.contains("M requests/s"), "{out}");
    ok(&args("b"), d);
    // dram_stats.json is deterministic: host timings live in timing.json.
    let bytes = |r: &str| std::fs::read(d.join(r).join("dram_stats.json")).unwrap();
    assert_eq!(bytes("a"), bytes("b"));
    let timing: serde_json::Value =
        serde_json::from_slice(&std::fs::read(d.join("a/timing.json")).unwrap()).unwrap();
    assert!(timing["requests_per_second"].as_f64().unwrap() > 0.0);
}
