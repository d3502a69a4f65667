//! `rtsim simulate --arch trax-baseline` and `rtsim bench-sim` end to end: every output, the
//! image byte-identical to `rtsim render`'s, determinism, and configuration errors.

mod common;
use common::{fails, ok, rtsim};
use std::fs;
use std::path::Path;

/// A small chip on a small Cornell frame: 2 TMs × 8 TPs, 24×16 pixels.
fn simulate(out: &Path, extra: &[&str]) -> String {
    ok(rtsim()
        .args([
            "simulate",
            "--arch",
            "trax-baseline",
            "--width",
            "24",
            "--height",
            "16",
            "--set",
            "arch.trax.tms=2",
            "--set",
            "arch.trax.tps_per_tm=8",
            "--out",
        ])
        .arg(out)
        .args(extra))
}

#[test]
fn simulate_writes_every_output_and_the_render_image() {
    let dir = tempfile::tempdir().unwrap();
    let (sim, render) = (dir.path().join("sim"), dir.path().join("render"));
    let stdout = simulate(&sim, &[]);
    for want in [
        "ms/frame",
        "instructions",
        "stalls",
        "L1 ",
        "L2 ",
        "DRAM",
        "row-buffer hit rate",
        "energy",
        "calibration",
    ] {
        assert!(stdout.contains(want), "summary lacks {want}: {stdout}");
    }
    for f in [
        "render.png",
        "heatmap.png",
        "stats.json",
        "timing.json",
        "config.resolved.toml",
    ] {
        assert!(sim.join(f).is_file(), "missing {f}");
    }
    ok(rtsim()
        .args(["render", "--width", "24", "--height", "16", "--out"])
        .arg(&render));
    assert_eq!(
        fs::read(sim.join("render.png")).unwrap(),
        fs::read(render.join("render.png")).unwrap(),
        "the chip's image differs from rtsim render's"
    );
    let stats: serde_json::Value =
        serde_json::from_slice(&fs::read(sim.join("stats.json")).unwrap()).unwrap();
    let t = &stats["trax"];
    assert_eq!(t["complete"], true);
    assert_eq!(t["chip"]["tps"], 16);
    assert!(t["cycles"].as_u64().unwrap() > 0);
    assert!(t["energy"]["dram_j"].as_f64().unwrap() > 0.0);
    assert_eq!(t["pixels_done"], 24 * 16);
}

#[test]
fn simulate_is_deterministic_and_its_resolved_config_repeats_it() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = (dir.path().join("a"), dir.path().join("b"));
    simulate(&a, &[]);
    ok(rtsim()
        .args(["simulate", "--config"])
        .arg(a.join("config.resolved.toml"))
        .arg("--out")
        .arg(&b));
    for f in ["stats.json", "render.png", "heatmap.png"] {
        assert_eq!(
            fs::read(a.join(f)).unwrap(),
            fs::read(b.join(f)).unwrap(),
            "{f} differs between identical runs"
        );
    }
}

/// `timing.json` says how many host threads the engine ran on: the baseline's fast engine
/// takes `--threads`, its time series and STRaTA's engine one (it once said 1 for all).
#[test]
fn timing_names_the_threads_the_engine_ran_on() {
    let dir = tempfile::tempdir().unwrap();
    let timing = |d: &Path| -> serde_json::Value {
        serde_json::from_slice(&fs::read(d.join("timing.json")).unwrap()).unwrap()
    };
    let strata = |out: &Path| {
        ok(rtsim()
            .args([
                "simulate", "--arch", "strata", "--width", "8", "--height", "8",
            ])
            .args([
                "--set",
                "arch.trax.tms=2",
                "--set",
                "arch.trax.tps_per_tm=8",
            ])
            .args(["--threads", "2", "--out"])
            .arg(out))
    };
    for (name, threads, stdout) in [
        (
            "two",
            2,
            simulate(&dir.path().join("two"), &["--threads", "2"]),
        ),
        (
            "one",
            1,
            simulate(&dir.path().join("one"), &["--threads", "1"]),
        ),
        (
            "timeline",
            1,
            simulate(
                &dir.path().join("timeline"),
                &["--threads", "2", "--timeline", "500"],
            ),
        ),
        ("strata", 1, strata(&dir.path().join("strata"))),
    ] {
        let t = timing(&dir.path().join(name));
        assert_eq!(t["threads"], threads, "{name}: {t}");
        let wall = t["simulate_seconds"].as_f64().unwrap();
        assert!(wall > 0.0, "{name}: {t}");
        if cfg!(target_os = "linux") {
            assert!(t["cpu_seconds"].as_f64().unwrap() > 0.0, "{name}: {t}");
        }
        let plural = if threads == 1 { "thread" } else { "threads" };
        assert!(
            stdout.contains(&format!("({threads} {plural}")),
            "{name}: the host line lacks the thread count: {stdout}"
        );
    }
}

#[test]
fn a_cycle_limit_stops_the_frame_and_says_so() {
    let dir = tempfile::tempdir().unwrap();
    let stdout = simulate(dir.path(), &["--cycle-limit", "2000"]);
    assert!(stdout.contains("INCOMPLETE"), "{stdout}");
    let stats: serde_json::Value =
        serde_json::from_slice(&fs::read(dir.path().join("stats.json")).unwrap()).unwrap();
    assert_eq!(stats["trax"]["complete"], false);
}

#[test]
fn bad_chip_values_name_their_keys() {
    for (set, key) in [
        ("arch.trax.tms=0", "arch.trax.tms"),
        (
            "arch.trax.units.fp_add.count=0",
            "arch.trax.units.fp_add.count",
        ),
        (
            "arch.trax.l1.size_bytes=2199023255552",
            "arch.trax.l1.size_bytes",
        ),
        ("arch.trax.bogus=1", "bogus"),
    ] {
        let e = fails(rtsim().args([
            "simulate",
            "--arch",
            "trax-baseline",
            "--width",
            "8",
            "--height",
            "8",
            "--set",
            set,
        ]));
        assert!(e.contains(key), "{set}: {e}");
    }
}

#[test]
fn bench_sim_reports_rates_and_peak_memory() {
    let stdout = ok(rtsim().args([
        "bench-sim",
        "--scene",
        "cornell",
        "--width",
        "16",
        "--height",
        "16",
        "--set",
        "arch.trax.tms=2",
        "--cycle-limit",
        "3000",
    ]));
    for want in [
        "cycles/s",
        "M TP-cycles/s",
        "M instructions/s",
        "peak memory",
        "host load",
    ] {
        assert!(stdout.contains(want), "lacks {want}: {stdout}");
    }
    let e = fails(rtsim().args(["bench-sim", "--arch", "functional"]));
    assert!(e.contains("trax-baseline"), "{e}");
}

/// RGB pixels of a PNG the commands wrote.
fn rgb(path: &Path) -> (u32, Vec<u8>) {
    let mut r = png::Decoder::new(std::io::BufReader::new(fs::File::open(path).unwrap()))
        .read_info()
        .unwrap();
    let mut buf = vec![0; r.output_buffer_size().unwrap()];
    let info = r.next_frame(&mut buf).unwrap();
    assert_eq!(info.color_type, png::ColorType::Rgb);
    buf.truncate(info.buffer_size());
    (info.width, buf)
}

#[test]
fn a_window_is_exposed_as_the_whole_frame() {
    // A window's pixels equal `render`'s, with a fixed exposure and with the automatic one
    // (the whole frame's key: the black surround blew windows out, 254 against 86).
    let dir = tempfile::tempdir().unwrap();
    let run = |name: &str, cmd: &str, extra: &[&str]| {
        let out = dir.path().join(name);
        ok(rtsim()
            .args([cmd, "--scene", "cornell", "--width", "24", "--height", "16"])
            .args(extra)
            .arg("--out")
            .arg(&out));
        rgb(&out.join("render.png"))
    };
    let inside = |(w, px): (u32, Vec<u8>)| -> Vec<u8> {
        let mut v = Vec::new();
        for y in 4..12 {
            let row = (y * w * 3) as usize;
            v.extend_from_slice(&px[row + 8 * 3..row + 20 * 3]);
        }
        v
    };
    let window = [
        "--arch",
        "trax-baseline",
        "--set",
        "arch.trax.tms=2",
        "--window",
        "8,4,20,12",
    ];
    for (name, exposure) in [
        ("fixed", &["--set", "output.exposure=0.5"][..]),
        ("auto", &[]),
    ] {
        let sim = run(
            &format!("sim-{name}"),
            "simulate",
            &[&window[..], exposure].concat(),
        );
        let full = run(&format!("render-{name}"), "render", exposure);
        assert_eq!(inside(sim), inside(full), "{name}");
    }
}

#[test]
fn a_black_frame_under_a_cycle_limit_blames_the_limit() {
    let dir = tempfile::tempdir().unwrap();
    let o = rtsim()
        .args(["simulate", "--arch", "trax-baseline", "--scene", "cornell"])
        .args(["--width", "16", "--height", "16", "--cycle-limit", "500"])
        .args(["--set", "arch.trax.tms=2", "--out"])
        .arg(dir.path().join("o"))
        .output()
        .unwrap();
    assert!(o.status.success());
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(
        e.contains("`sim.cycle_limit` = 500") && !e.contains("closed geometry"),
        "{e}"
    );
}

#[test]
fn bench_sim_refuses_an_out_it_would_ignore() {
    let e = fails(rtsim().args(["bench-sim", "--out", "somewhere"]));
    assert!(
        e.contains("writes no files") && e.contains("somewhere"),
        "{e}"
    );
}
