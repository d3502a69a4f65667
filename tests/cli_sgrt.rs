//! `rtsim simulate --arch sgrt` and `rtsim compare` end to end: the image equals the functional
//! tracer's, every figure the SGRT issue lists (§5) is in `stats.json` and the summary, the
//! PPTRV/SPTRV ratios are printed, and a bad SGRT key fails cleanly.

mod common;
use common::{fails, ok, rtsim};
use std::fs;
use std::path::Path;

fn simulate(arch: &str, out: &Path) -> String {
    ok(rtsim()
        .args([
            "simulate",
            "--arch",
            arch,
            "--workload",
            "diffuse",
            "--width",
            "24",
            "--height",
            "16",
            "--spp",
            "2",
            "--out",
        ])
        .arg(out))
}

#[test]
fn sgrt_image_equals_functional_and_reports_every_figure() {
    let dir = tempfile::tempdir().unwrap();
    let (f, s) = (dir.path().join("f"), dir.path().join("s"));
    simulate("functional", &f);
    let summary = simulate("sgrt", &s);
    assert_eq!(
        fs::read(f.join("render.png")).unwrap(),
        fs::read(s.join("render.png")).unwrap(),
        "the SGRT image differs from the functional one"
    );
    for line in [
        "frames/s",
        "Mrays/s",
        "utilisation",
        "TRV L1",
        "TRV L2",
        "IST L1",
        "RAU occupancy",
        "row-buffer hits",
        "area",
        "energy",
    ] {
        assert!(summary.contains(line), "summary lacks {line}: {summary}");
    }
    let stats: serde_json::Value =
        serde_json::from_slice(&fs::read(s.join("stats.json")).unwrap()).unwrap();
    let r = &stats["sgrt"];
    let num = |v: &serde_json::Value, what: &str| {
        v.as_f64()
            .unwrap_or_else(|| panic!("{what} missing or not a number: {r}"))
    };
    // Per ray type (shader on: the camera rays and the diffuse rays).
    for kind in ["primary", "diffuse"] {
        let k = &r["kinds"][kind];
        assert!(num(&k["mrays_per_second"], "Mrays/s") > 0.0);
        assert!(num(&k["trv_steps_per_ray"], "TRV steps") > 0.0);
        assert!(num(&k["ist_steps_per_ray"], "IST steps") >= 0.0);
    }
    for key in ["trv_utilisation", "ist_utilisation", "srp_utilisation"] {
        assert!((0.0..=1.0).contains(&num(&r[key], key)), "{key}");
    }
    for key in ["trv_l1", "trv_l2", "ist_l1"] {
        assert!(
            (0.0..=1.0).contains(&num(&r["hit_rates"][key], key)),
            "{key}"
        );
    }
    num(&r["trv_rau_occupancy"], "TRV RAU occupancy");
    num(&r["ist_rau_occupancy"], "IST RAU occupancy");
    assert!(num(&r["dram"]["bandwidth_gbps"], "GB/s") > 0.0);
    assert!((0.0..=1.0).contains(&num(&r["dram"]["row_hit_rate"], "row hits")));
    assert!(num(&r["frames_per_second"], "fps") > 0.0);
    assert!((num(&r["area"]["ti_unit_mm2"], "area") - 3.32).abs() < 0.02);
    assert!(num(&r["energy"]["total_nj"], "energy") > 0.0);
    assert_eq!(stats["arch"], "sgrt");
}

#[test]
fn compare_prints_the_pptrv_sptrv_ratios() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("c");
    let stdout = ok(rtsim()
        .args([
            "compare",
            "--arch",
            "sgrt-sptrv",
            "--arch",
            "sgrt",
            "--workload",
            "primary",
            "--width",
            "16",
            "--height",
            "12",
            "--set",
            "arch.sgrt.shader=false",
            "--out",
        ])
        .arg(&out));
    assert!(stdout.contains("sgrt / sgrt-sptrv: speed"), "{stdout}");
    let c: serde_json::Value =
        serde_json::from_slice(&fs::read(out.join("compare.json")).unwrap()).unwrap();
    let means = c["means"].as_array().unwrap();
    assert_eq!(means.len(), 2);
    assert_eq!(means[1]["arch"], "sgrt");
    // PPTRV takes fewer steps than SPTRV (SGRT Table 4).
    assert!(means[1]["trv_step_ratio"].as_f64().unwrap() < 1.0, "{c}");
}

#[test]
fn a_bad_sgrt_key_fails_naming_it() {
    let e = fails(rtsim().args([
        "simulate",
        "--arch",
        "sgrt",
        "--set",
        "arch.sgrt.trv.stacks=0",
    ]));
    assert!(e.contains("arch.sgrt.trv.stacks"), "{e}");
}
