//! `cargo bench -p rtsim-sgrt`: simulation speed, in simulated rays per host second, of the
//! four-core `sgrt` chip (PPTRV, T&I-only as Tables 4–5 measure it) tracing Sibenik's diffuse
//! inter-reflection rays over LPDDR3-1600 (issue 9 §7: target ≥ 200 K rays/s, i.e. a Table 5
//! frame of 1024×768 × 32 samples ≈ 25 M rays in about two minutes).
//!
//! One timed run (the simulation alone: scene loading, the BVH build and the memory image are
//! outside the clock), repeated `SGRT_BENCH_RUNS` times (default 3) to show the spread on a
//! shared machine; the cycle count and the counters' checksum must be equal in every run
//! (bit-identical results). The frame size is `SGRT_BENCH_FRAME=W,H,SPP` (default 96,72,4);
//! the scene directory is `$RTSIM_SCENE_DIR`, else `../shared/scenes` beside the repository,
//! as for the `rtsim` command. Record `uptime` beside the figures: on a shared machine the
//! wall-clock rate falls with the load, so the rate per CPU second of the (single-threaded)
//! simulation is printed too, from `/proc/self/schedstat` where it exists.

#[path = "../tests/common/mod.rs"]
mod common;

use rtsim_scene::{SceneRequest, load_scene};
use rtsim_sgrt::{Engine, SgrtConfig};
use rtsim_trace::WorkloadKind;
use std::path::PathBuf;
use std::time::Instant;

fn frame() -> (u32, u32, u32) {
    let v = std::env::var("SGRT_BENCH_FRAME").unwrap_or_else(|_| "96,72,4".into());
    let n: Vec<u32> = v
        .split(',')
        .map(|s| s.trim().parse().expect("SGRT_BENCH_FRAME=W,H,SPP"))
        .collect();
    assert_eq!(n.len(), 3, "SGRT_BENCH_FRAME=W,H,SPP");
    (n[0], n[1], n[2])
}

/// CPU seconds the main thread has run (Linux: `/proc/self/schedstat`, nanoseconds first).
fn cpu_seconds() -> Option<f64> {
    let s = std::fs::read_to_string("/proc/self/schedstat").ok()?;
    let ns: f64 = s.split_whitespace().next()?.parse().ok()?;
    Some(ns * 1e-9)
}

fn main() {
    // `cargo bench` passes `--bench`; any other argument is a filter this bench ignores.
    let scene_dir = std::env::var_os("RTSIM_SCENE_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| {
            PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/scenes")
        });
    let runs: u32 = std::env::var("SGRT_BENCH_RUNS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(3);
    let (w, h, spp) = frame();
    let scene = load_scene(&SceneRequest {
        name: "sibenik",
        size: 1.0,
        seed: 1,
        scene_dir: Some(&scene_dir),
    })
    .expect("loading Sibenik (set RTSIM_SCENE_DIR)");
    let tris = scene.triangles.len();
    // The `sgrt` preset's traversal: short stack of trace.short_stack_entries (8), Wald's
    // test, sweep SAH, leaves of bvh.max_leaf_size (4) — the defaults `setup` uses.
    let s = common::setup(scene, WorkloadKind::Diffuse, w, h, spp, 8);
    let c = SgrtConfig {
        shader: false,
        ..SgrtConfig::default()
    };
    println!(
        "sgrt bench: Sibenik ({tris} triangles), diffuse, {w}×{h} × {spp} spp, 4 cores PPTRV, \
         T&I only, LPDDR3-1600, fast engine"
    );
    let mut first: Option<(u64, u64)> = None;
    for run in 1..=runs {
        let start = Instant::now();
        let cpu0 = cpu_seconds();
        let r = common::run_frame(&s, &c, Engine::Fast);
        let secs = start.elapsed().as_secs_f64();
        let cpu = cpu_seconds().zip(cpu0).map(|(b, a)| b - a);
        let t = &r.stats.total;
        let rays: u64 = t.kinds.iter().map(|k| k.rays).sum();
        let sig = (r.stats.cycles, t.trv.steps ^ (t.ist.steps << 32));
        if let Some(f) = first {
            assert_eq!(f, sig, "run {run} differs from run 1: not deterministic");
        }
        first = Some(sig);
        println!(
            "run {run}: {rays} timed rays, {} T&I cycles, {secs:.2} s host: {:.0} simulated rays/s, \
             {:.0} T&I cycles/s; {}",
            r.stats.cycles,
            rays as f64 / secs,
            r.stats.cycles as f64 / secs,
            cpu.map_or("CPU time unavailable".into(), |c| format!(
                "{c:.2} s CPU: {:.0} simulated rays per CPU second",
                rays as f64 / c
            ))
        );
    }
}
