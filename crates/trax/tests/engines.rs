//! The fast engine equals the cycle-by-cycle reference: cycles, every stat, the image and the
//! per-pixel cycles, on small chips and several scenes and workloads.

mod support;

use rtsim_trace::WorkloadKind;
use rtsim_trax::stats::Stall;
use rtsim_trax::{Engine, Output, TraxConfig};
use support::*;

fn assert_engines_agree(fast: &Output, reference: &Output) {
    let (f, r) = (&fast.report, &reference.report);
    assert_eq!(f.cycles, r.cycles, "cycles");
    assert_eq!(f.issue, r.issue, "issue stats");
    assert_eq!(f.l1.stats, r.l1.stats, "L1 stats");
    assert_eq!(f.l2.stats, r.l2.stats, "L2 stats");
    assert_eq!(f.dram.report.stats, r.dram.report.stats, "DRAM stats");
    assert_eq!(fast.heat, reference.heat, "cycles per pixel");
    assert_eq!(fast.rays, reference.rays, "ray counters");
    assert_same_image(&fast.pixels, &reference.pixels);
    // Every TP-cycle is an issue, a stall or idle.
    let t = &f.tp_cycles;
    assert_eq!(t.issued + t.stalls + t.idle, t.total, "TP-cycle accounting");
}

fn check(scene: &str, size: (u32, u32), kind: WorkloadKind, spp: u32, cfg: &TraxConfig) {
    let Some(w) = world(scene, size.0, size.1) else {
        return;
    };
    let p = params(&w, kind, spp);
    let pixels = all_pixels(&w);
    let fast = simulate(&w, &p, cfg, Engine::Fast, &pixels);
    let reference = simulate(&w, &p, cfg, Engine::Reference, &pixels);
    assert_engines_agree(&fast, &reference);
    let (image, rays) = functional(&w, &p, &pixels);
    assert_same_image(&fast.pixels, &image);
    assert_eq!(fast.rays, rays);
}

#[test]
fn cornell_path_tracing_on_small_chips() {
    check("cornell", (16, 12), WorkloadKind::Path, 1, &chip(1, 4));
    check("cornell", (16, 12), WorkloadKind::Path, 1, &chip(2, 8));
}

#[test]
fn contention_heavy_chip() {
    // One unit of each class, one icache bank with one fetch port, a tiny L1: every kind of
    // conflict happens.
    let mut cfg = chip(2, 8);
    for u in [
        &mut cfg.units.fp_add,
        &mut cfg.units.fp_mul,
        &mut cfg.units.fp_minmax,
        &mut cfg.units.fp_cmp,
        &mut cfg.units.int_add,
        &mut cfg.units.bitwise,
        &mut cfg.units.branch,
    ] {
        u.count = 1;
    }
    cfg.units.branch.latency = 3;
    cfg.icaches_per_tm = 1;
    cfg.icache_banks = 1;
    cfg.fetches_per_bank = 1;
    cfg.l1.size_bytes = 1024;
    cfg.l1.banks = 1;
    cfg.l1.mshrs = 2;
    cfg.l2.size_bytes = 64 << 10;
    check("cornell", (12, 10), WorkloadKind::Path, 1, &cfg);
}

#[test]
fn contended_atomic_counter() {
    // 64 TPs on short primary rays queue for the pixel counter; the fast engine offers only
    // the first `count` waiters each cycle and charges the rest their stall cycles later.
    for count in [1, 3] {
        let mut cfg = chip(4, 16);
        cfg.atomic.count = count;
        check("cornell", (16, 12), WorkloadKind::Primary, 1, &cfg);
        // Stopped while TPs still wait: the waiters' stall cycles up to the limit count too.
        // (Only the atomic stalls compare: the fast engine books instructions ahead of the
        // limit, so a stopped run's other counts differ, `docs/TRAX.md`.)
        let Some(w) = world("cornell", 16, 12) else {
            return;
        };
        let p = params(&w, WorkloadKind::Primary, 1);
        let pixels = all_pixels(&w);
        for limit in [40, 333] {
            let f = simulate_until(&w, &p, &cfg, Engine::Fast, &pixels, Some(limit));
            let r = simulate_until(&w, &p, &cfg, Engine::Reference, &pixels, Some(limit));
            let atomic = |o: &Output| o.report.issue.stall[Stall::Atomic as usize];
            assert_eq!(atomic(&f), atomic(&r), "limit {limit}, count {count}");
            assert!(atomic(&f) > 0);
        }
    }
}

#[test]
fn other_workloads() {
    check("cornell", (10, 8), WorkloadKind::Ao, 4, &chip(1, 8));
    check("cornell", (10, 8), WorkloadKind::Specular, 2, &chip(2, 4));
    check("cornell", (10, 8), WorkloadKind::Diffuse, 2, &chip(1, 6));
}

#[test]
fn shared_scenes() {
    check("sibenik", (16, 12), WorkloadKind::Path, 1, &chip(2, 8));
    check("conference", (12, 10), WorkloadKind::Path, 1, &chip(1, 8));
}

/// The fast engine on `threads` host threads equals it on one: cycles, every stat, the image,
/// the per-pixel cycles.
fn check_threads(scene: &str, size: (u32, u32), kind: WorkloadKind, cfg: &TraxConfig) {
    let Some(w) = world(scene, size.0, size.1) else {
        return;
    };
    let p = params(&w, kind, 1);
    let pixels = all_pixels(&w);
    let one = simulate(&w, &p, cfg, Engine::Fast, &pixels);
    for threads in [2, 3, 4] {
        let many = simulate_threads(&w, &p, cfg, Engine::Fast, &pixels, None, threads);
        assert_engines_agree(&many, &one);
        // The whole report (DRAM, energy, every counter) but the engine's name.
        let json = |o: &Output| serde_json::to_string(&o.report).unwrap();
        assert_eq!(json(&many), json(&one), "{threads} threads");
    }
}

#[test]
fn host_threads_change_nothing() {
    // Enough TPs per cycle that the cycles really run on several threads.
    check_threads("cornell", (24, 16), WorkloadKind::Path, &chip(4, 16));
    check_threads("cornell", (16, 12), WorkloadKind::Ao, &chip(3, 12));
    check_threads("sibenik", (20, 16), WorkloadKind::Path, &chip(5, 16));
}

#[test]
fn host_threads_change_nothing_under_contention() {
    // Tiny L1s with two MSHRs and a small write buffer (refusals whose retry is the next
    // event), a one-bank L2 (the order of the cycle's sends decides who waits), a
    // one-access-per-cycle counter (TMs stop at it often), few fetch ports.
    let mut cfg = chip(4, 16);
    cfg.l2.banks = 1;
    cfg.l1.size_bytes = 1024;
    cfg.l1.banks = 1;
    cfg.l1.mshrs = 2;
    cfg.l1.write_buffer = 1;
    cfg.l2.size_bytes = 64 << 10;
    cfg.atomic.count = 1;
    cfg.fetches_per_bank = 1;
    check_threads("cornell", (20, 16), WorkloadKind::Path, &cfg);
    check_threads("sibenik", (16, 12), WorkloadKind::Primary, &cfg);
}

#[test]
fn host_threads_change_nothing_in_a_stopped_run() {
    let Some(w) = world("cornell", 24, 16) else {
        return;
    };
    let cfg = chip(4, 16);
    let p = params(&w, WorkloadKind::Path, 1);
    let pixels = all_pixels(&w);
    for limit in [57, 1000, 4321] {
        let one = simulate_until(&w, &p, &cfg, Engine::Fast, &pixels, Some(limit));
        let two = simulate_threads(&w, &p, &cfg, Engine::Fast, &pixels, Some(limit), 2);
        assert_eq!(one.report.cycles, two.report.cycles, "limit {limit}");
        assert_eq!(one.report.issue, two.report.issue, "limit {limit}");
        assert_eq!(one.report.l1.stats, two.report.l1.stats, "limit {limit}");
        assert_eq!(one.report.l2.stats, two.report.l2.stats, "limit {limit}");
        assert_eq!(one.heat, two.heat, "limit {limit}");
        assert_eq!(one.rays, two.rays, "limit {limit}");
    }
}
