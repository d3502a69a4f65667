//! The fast engine equals the cycle-by-cycle reference: cycles, every stat, the image and the
//! per-pixel cycles, on small chips and several scenes and workloads.

mod support;

use rtsim_cache::{Replacement, WritePolicy};
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

/// The fast engine on each of `threads` host threads equals it on one — cycles, every stat,
/// the whole report, the image and the per-pixel cycles — for whole frames and for runs
/// stopped at each of `limits`.
fn check_threads(
    scene: &str,
    size: (u32, u32),
    kind: WorkloadKind,
    cfg: &TraxConfig,
    threads: &[usize],
    limits: &[Option<u64>],
) {
    let Some(w) = world(scene, size.0, size.1) else {
        return;
    };
    let p = params(&w, kind, 1);
    let pixels = all_pixels(&w);
    // The whole report (DRAM, energy, every counter).
    let json = |o: &Output| serde_json::to_string(&o.report).unwrap();
    for &limit in limits {
        let one = simulate_until(&w, &p, cfg, Engine::Fast, &pixels, limit);
        for &n in threads {
            let many = simulate_threads(&w, &p, cfg, Engine::Fast, &pixels, limit, n);
            let what = format!("{scene}, {n} threads, limit {limit:?}");
            assert_eq!(many.report.cycles, one.report.cycles, "{what}");
            assert_eq!(many.heat, one.heat, "{what}");
            assert_eq!(many.rays, one.rays, "{what}");
            assert_same_image(&many.pixels, &one.pixels);
            assert_eq!(json(&many), json(&one), "{what}");
        }
    }
}

#[test]
fn host_threads_change_nothing() {
    // Enough TPs per cycle that the cycles really run on several threads; shards of unequal
    // sizes (7 TMs on 3 and 4 threads) and more threads than TMs (5 TMs on 8).
    check_threads(
        "cornell",
        (24, 16),
        WorkloadKind::Path,
        &chip(4, 16),
        &[2, 3, 4],
        &[None],
    );
    check_threads(
        "cornell",
        (16, 12),
        WorkloadKind::Ao,
        &chip(3, 12),
        &[2],
        &[None],
    );
    check_threads(
        "sibenik",
        (20, 16),
        WorkloadKind::Path,
        &chip(5, 16),
        &[2, 3],
        &[None],
    );
    check_threads(
        "cornell",
        (20, 16),
        WorkloadKind::Path,
        &chip(7, 8),
        &[3, 4],
        &[None],
    );
    check_threads(
        "cornell",
        (16, 12),
        WorkloadKind::Ao,
        &chip(5, 12),
        &[8],
        &[None],
    );
}

#[test]
fn host_threads_change_nothing_under_contention() {
    // Tiny L1s with two MSHRs and a small write buffer (refusals whose retry is the next
    // event), a one-bank L2 (the order of the cycle's sends decides who waits), a
    // one-access-per-cycle counter (TMs stop at it often), few fetch ports; also stopped runs.
    let mut cfg = chip(4, 16);
    cfg.l2.banks = 1;
    cfg.l1.size_bytes = 1024;
    cfg.l1.banks = 1;
    cfg.l1.mshrs = 2;
    cfg.l1.write_buffer = 1;
    cfg.l2.size_bytes = 64 << 10;
    cfg.atomic.count = 1;
    cfg.fetches_per_bank = 1;
    let limits = [None, Some(57), Some(4321)];
    check_threads(
        "cornell",
        (20, 16),
        WorkloadKind::Path,
        &cfg,
        &[2, 3],
        &limits,
    );
    check_threads(
        "sibenik",
        (16, 12),
        WorkloadKind::Primary,
        &cfg,
        &[2],
        &[None],
    );
    // Two counter slots with a 3-cycle latency, a 2-cycle L1 with one MSHR.
    let mut cfg = chip(6, 16);
    cfg.l2.banks = 1;
    cfg.l1.size_bytes = 1024;
    cfg.l1.banks = 1;
    cfg.l1.mshrs = 1;
    cfg.l1.write_buffer = 1;
    cfg.l1.hit_latency = 2;
    cfg.l2.size_bytes = 64 << 10;
    cfg.atomic.count = 2;
    cfg.atomic.latency = 3;
    cfg.fetches_per_bank = 1;
    check_threads(
        "sibenik",
        (12, 10),
        WorkloadKind::Path,
        &cfg,
        &[3],
        &[None, Some(2500)],
    );
}

/// One MSHR per L1: a refusal's retry is brought forward by an earlier send of its own TM in
/// the same round (thousands of times a run; `par::settle`'s `first`), which the tests above
/// reach too rarely to tell (found by review: ignoring it passed them, and fails this).
#[test]
fn host_threads_change_nothing_with_one_mshr() {
    for (tms, tps, lat, wb) in [(2, 32, 1, 1), (3, 24, 4, 2), (4, 16, 1, 1)] {
        let mut cfg = chip(tms, tps);
        cfg.l1.size_bytes = 1024;
        cfg.l1.mshrs = 1;
        cfg.l1.hit_latency = lat;
        cfg.l1.write_buffer = wb;
        let limits = [None, Some(1500)];
        check_threads(
            "cornell",
            (16, 12),
            WorkloadKind::Path,
            &cfg,
            &[2, 3],
            &limits,
        );
        check_threads(
            "sibenik",
            (16, 12),
            WorkloadKind::Primary,
            &cfg,
            &[2],
            &[None],
        );
    }
}

#[test]
fn write_back_l1s_several_l2s_random_replacement() {
    // A store that misses a write-back L1 allocates its line without a register waiting for it
    // (it used to index a register array with "no register"); engines and threads agree.
    let mut cfg = chip(6, 16);
    cfg.l1s_per_l2 = 2;
    cfg.l1.write_policy = WritePolicy::WriteBack;
    cfg.l1.replacement = Replacement::Random;
    cfg.l1.size_bytes = 2048;
    cfg.l1.mshrs = 3;
    cfg.l1.write_buffer = 4;
    cfg.l2.size_bytes = 64 << 10;
    cfg.l2.banks = 1;
    check("cornell", (20, 16), WorkloadKind::Path, 1, &cfg);
    check_threads(
        "cornell",
        (20, 16),
        WorkloadKind::Path,
        &cfg,
        &[2, 3],
        &[None, Some(3000)],
    );
}
