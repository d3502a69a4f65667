//! Timing against analytic expectations: unloaded latencies, streaming bandwidth, the tRC and
//! tRRD/tFAW bounds, refresh counts and the clock-domain crossing. Checking mode is on.

mod common;

use common::*;
use rtsim_core::{MemOp, MemoryPort};
use rtsim_dram::config::{PRESETS, PowerDownKind, RowPolicyKind};
use rtsim_dram::trace::{Pattern, Synthetic};
use rtsim_dram::{Dram, DriveOptions, drive};
use std::convert::Infallible;

/// Requester-clock finish of a request arriving at requester cycle `arrival` that takes
/// `lat` memory cycles once it reaches the controller.
fn expected_finish(d: &Dram, arrival: u64, lat: u64) -> u64 {
    let s = d.spec();
    let a = s.req_clock.to_ceil(arrival, s.mem_clock);
    s.mem_clock.to_ceil(a + lat, s.req_clock)
}

#[test]
fn unloaded_read_latency_is_the_analytic_sum() {
    for p in PRESETS {
        for req_mhz in [1000.0, 500.0, 733.0] {
            let mut c = config(p.name);
            c.refresh.enabled = false;
            let mut d = dram_at(&c, req_mhz);
            let [hit, closed, conflict] = d.spec().unloaded_read_latency();
            let t = d.spec().t.clone();
            assert_eq!(hit, t.cl + t.burst);
            assert_eq!(closed, t.rcd + t.cl + t.burst);
            assert_eq!(conflict, t.rp + t.rcd + t.cl + t.burst);
            let cases = [
                (addr(&d, 0, 0, 0, 5, 0), 1_001, closed, "closed bank"),
                (addr(&d, 0, 0, 0, 5, 1), 20_003, hit, "row hit"),
                (addr(&d, 0, 0, 0, 6, 0), 40_007, conflict, "row conflict"),
            ];
            for (i, (a, at, lat, what)) in cases.into_iter().enumerate() {
                let got = single(&mut d, req(i as u64, a, MemOp::Read, at));
                assert_eq!(
                    got.finish,
                    expected_finish(&d, at, lat),
                    "{} at {req_mhz} MHz: {what}",
                    p.name
                );
            }
            let s = d.stats();
            assert_eq!(
                (s.read_row_hits, s.read_row_misses, s.read_row_conflicts),
                (1, 1, 1),
                "{}",
                p.name
            );
            assert_eq!(s.read_latency_mem.min, hit);
            assert_eq!(s.read_latency_mem.max, conflict);
            assert_legal(&d);
        }
    }
}

#[test]
fn gddr5_trax_unloaded_latency_in_core_cycles() {
    // 2 GHz DRAM behind a 1 GHz core: 32, 60, 88 memory cycles = 16, 30, 44 core cycles (the
    // STRaTA paper's Sibenik average read latency of 39 core cycles is near these).
    let mut c = config("gddr5-trax");
    c.refresh.enabled = false;
    let mut d = dram(&c);
    let a = |row, col| addr(&d, 3, 0, 2, row, col);
    let (x, y, z) = (a(9, 0), a(9, 7), a(10, 0));
    let lat = |c: rtsim_core::MemCompletion| c.finish - c.arrival;
    assert_eq!(lat(single(&mut d, req(0, x, MemOp::Read, 100))), 30);
    assert_eq!(lat(single(&mut d, req(1, y, MemOp::Read, 1000))), 16);
    assert_eq!(lat(single(&mut d, req(2, z, MemOp::Read, 2000))), 44);
}

#[test]
fn unloaded_write_latency_and_closed_page() {
    for p in PRESETS {
        let mut c = config(p.name);
        c.refresh.enabled = false;
        c.controller.row_policy = RowPolicyKind::Closed;
        let mut d = dram(&c);
        let t = d.spec().t.clone();
        // Closed page: every access finds its bank closed.
        for (i, col) in [0u32, 1, 2].into_iter().enumerate() {
            let at = 1000 + 10_000 * i as u64;
            let a = addr(&d, 0, 0, 1, 3, col);
            let r = single(&mut d, req(i as u64, a, MemOp::Read, at));
            assert_eq!(
                r.finish,
                expected_finish(&d, at, t.rcd + t.cl + t.burst),
                "{}",
                p.name
            );
        }
        let at = 50_000;
        let a = addr(&d, 0, 0, 2, 3, 0);
        let w = single(&mut d, req(9, a, MemOp::Write, at));
        assert_eq!(
            w.finish,
            expected_finish(&d, at, t.rcdwr + t.cwl + t.burst),
            "{}",
            p.name
        );
        let s = d.stats();
        assert_eq!(s.auto_precharges, 4);
        assert_eq!(s.read_row_misses, 3);
        assert_legal(&d);
    }
}

/// Run a synthetic stream to completion; returns the DRAM for inspection.
fn run(c: &rtsim_dram::DramConfig, traffic: Synthetic) -> Dram {
    let mut d = dram(c);
    drive(
        &mut d,
        traffic.map(Ok::<_, Infallible>),
        DriveOptions::default(),
        |_| {},
    )
    .unwrap();
    d
}

#[test]
fn streaming_reads_reach_90_percent_of_peak() {
    for p in PRESETS {
        let mut c = config(p.name);
        // Lines interleave over channels, then bank groups, then columns of one row.
        c.mapping = "row:rank:bank:column:bankgroup:channel:offset".into();
        let o = &c.organisation;
        let n = 4000 * u64::from(o.channels);
        let d0 = dram(&c);
        let cap = d0.spec().org.capacity_bytes;
        let traffic = Synthetic::new(Pattern::Stream, n, 1.0, 0, o.line_bytes.into(), cap, 1);
        let mut d = run(&c, traffic);
        let end = d.now().unwrap();
        let r = d.report(end);
        assert!(
            r.bandwidth.utilisation >= 0.90,
            "{}: {:.1} % of peak",
            p.name,
            100.0 * r.bandwidth.utilisation
        );
        assert!(r.row_hit_rate.reads > 0.9, "{}", p.name);
        assert_eq!(r.stats.reads_done, n);
        assert_legal(&d);
    }
}

/// Random rows in one bank: one access per row cycle.
#[test]
fn single_bank_random_traffic_is_bounded_by_trc() {
    for p in PRESETS {
        let mut c = config(p.name);
        c.refresh.enabled = false;
        let mut d = dram(&c);
        let rows = d.spec().org.rows;
        let n = 1000u64;
        for i in 0..n {
            let row = ((i * 7919 + 13) % u64::from(rows)) as u32;
            let a = addr(&d, 0, 0, 0, row, (i % 8) as u32);
            d.try_enqueue(req(i, a, MemOp::Read, 0)).ok();
            if d.outstanding() as u64 == u64::from(c.controller.read_queue) {
                break;
            }
        }
        let queued = d.outstanding() as u64;
        let out = run_to_idle(&mut d);
        let s = d.stats();
        let t = &d.spec().t;
        assert_eq!(s.activates, queued, "{}", p.name);
        // First ACT at 0, last at ≥ (n−1)·tRC; the last read ends tRCD + CL + burst later.
        let last = out.iter().map(|c| c.finish).max().unwrap();
        let last_mem = d.spec().req_clock.to_ceil(last, d.spec().mem_clock);
        let span = last_mem - (t.rcd + t.cl + t.burst);
        assert!(span >= (queued - 1) * t.rc, "{}: {span}", p.name);
        assert!(span <= (queued - 1) * t.rc + 2 * t.rc, "{}: {span}", p.name);
        assert_legal(&d);
    }
}

/// Every access to another bank of one rank, each opening a new row: ACTs are paced by
/// max(tRRD, tFAW/4, t32AW/32).
#[test]
fn all_bank_random_traffic_is_bounded_by_trrd_and_tfaw() {
    for p in PRESETS {
        let mut c = config(p.name);
        c.refresh.enabled = false;
        c.controller.row_policy = RowPolicyKind::Closed;
        let n = 3000u64;
        let mut d = dram(&c);
        let o = d.spec().org.clone();
        let t = d.spec().t.clone();
        let mut out = Vec::new();
        let mut i = 0u64;
        let mut now = 0u64;
        // Alternate bank groups so tRRD_S applies.
        let bank_of = |i: u64| {
            let g = (i % u64::from(o.bank_groups)) as u32;
            let k = ((i / u64::from(o.bank_groups)) % u64::from(o.banks_per_group)) as u32;
            g * o.banks_per_group + k
        };
        while i < n {
            let a = addr(&d, 0, 0, bank_of(i), ((i * 31) % 1000) as u32, 0);
            if d.try_enqueue(req(i, a, MemOp::Read, now)).is_ok() {
                i += 1;
                continue;
            }
            now = d.next_event().unwrap();
            d.advance_to(now);
            d.drain_completions(&mut out);
            now += 1;
        }
        out.extend(run_to_idle(&mut d));
        let s = d.stats();
        assert_eq!(s.activates, n);
        let bound = (t.rrd as f64).max(t.faw as f64 / 4.0).max(if t.a32w > 0 {
            t.a32w as f64 / 32.0
        } else {
            0.0
        });
        let last = out.iter().map(|c| c.finish).max().unwrap();
        let last_mem = d.spec().req_clock.to_ceil(last, d.spec().mem_clock);
        let per_act = (last_mem - (t.rcd + t.cl + t.burst)) as f64 / (n - 1) as f64;
        assert!(
            per_act >= bound * 0.99 && per_act <= bound * 1.03,
            "{}: {per_act:.2} cycles per ACT, bound {bound}",
            p.name
        );
        assert_legal(&d);
    }
}

#[test]
fn refresh_count_is_time_over_trefi() {
    for p in PRESETS {
        for stagger in [true, false] {
            let mut c = config(p.name);
            c.refresh.stagger_ranks = stagger;
            let mut d = dram(&c);
            let refi = d.spec().t.refi;
            let ranks = u64::from(d.spec().org.ranks * d.spec().org.channels);
            // Idle, then loaded: refreshes keep their rate either way.
            d.advance_to(50 * refi / 2);
            let traffic = Synthetic::new(
                Pattern::Random,
                20_000,
                0.7,
                3,
                64,
                d.spec().org.capacity_bytes,
                7,
            );
            drive(
                &mut d,
                traffic.map(Ok::<_, Infallible>),
                DriveOptions::default(),
                |_| {},
            )
            .unwrap();
            let end_req = d.now().unwrap() + 100;
            let r = d.report(end_req);
            let expect = r.mem_cycles / refi * ranks;
            assert!(
                r.refreshes.abs_diff(expect) <= ranks,
                "{}: {} refreshes, expected {expect} ± {ranks}",
                p.name,
                r.refreshes
            );
            assert_legal(&d);
        }
    }
}

/// Long idle stretches skip their refreshes arithmetically; the result is the one of simulating
/// them one by one.
#[test]
fn idle_refreshes_are_skipped_exactly() {
    for p in PRESETS {
        let c = config(p.name);
        let refi = dram(&c).spec().t.refi;
        let mut jump = dram(&c);
        let mut walk = dram(&c);
        let x = addr(&jump, 0, 0, 1, 4, 0);
        // A request, a long idle gap, another request.
        for d in [&mut jump, &mut walk] {
            d.try_enqueue(req(0, x, MemOp::Read, 10)).unwrap();
        }
        let far = 37 * refi + 5;
        walk.advance_to(11);
        let mut t = 11;
        while t < far - 1 {
            t = (t + refi / 7).min(far - 1);
            walk.advance_to(t);
        }
        jump.advance_to(far - 1);
        for d in [&mut jump, &mut walk] {
            d.try_enqueue(req(1, x + 64, MemOp::Read, far)).unwrap();
        }
        let (a, b) = (run_to_idle(&mut jump), run_to_idle(&mut walk));
        assert_eq!(a, b, "{}", p.name);
        let end = a[1].finish + 10;
        let (mut ra, mut rb) = (jump.report(end), walk.report(end));
        // Skipped refreshes are counted, not re-validated by the checker.
        assert!(ra.stats.commands_checked < rb.stats.commands_checked);
        ra.stats.commands_checked = 0;
        rb.stats.commands_checked = 0;
        assert_eq!(ra, rb, "{}", p.name);
        let ranks = u64::from(c.organisation.channels * c.organisation.ranks);
        assert!(ra.refreshes.abs_diff(ra.mem_cycles / refi * ranks) <= ranks);
        assert_legal(&jump);
    }
}

#[test]
fn power_down_adds_txp_and_saves_background_energy() {
    let mut c = config("ddr3-1600");
    c.refresh.enabled = false;
    let on = {
        let mut c = c.clone();
        c.controller.power_down = PowerDownKind::Fast;
        c
    };
    let mut a = dram(&c);
    let mut b = dram(&on);
    let t = a.spec().t.clone();
    let x = addr(&a, 0, 0, 0, 3, 0);
    let at = 10_000;
    let ra = single(&mut a, req(0, x, MemOp::Read, at));
    let rb = single(&mut b, req(0, x, MemOp::Read, at));
    assert_eq!(ra.finish, expected_finish(&a, at, t.rcd + t.cl + t.burst));
    assert_eq!(
        rb.finish,
        expected_finish(&b, at, t.xp + t.rcd + t.cl + t.burst)
    );
    let ea = a.report(20_000).energy;
    let eb = b.report(20_000).energy;
    assert!(eb.background_j < 0.8 * ea.background_j, "{eb:?} vs {ea:?}");
    assert!(eb.background_precharge_power_down_j > 0.0);
    assert_legal(&b);
}

#[test]
fn idle_gddr5_trax_draws_tens_of_watts() {
    // 16 ranks × 16 devices × IDD2N 70 mA × 1.5 V = 26.9 W of precharge standby, plus refresh
    // 16 × 16 × (IDD5 − IDD3N) 193 mA × 1.5 V × 110 ns / 7.8 µs = 1.04 W.
    let mut d = dram(&config("gddr5-trax"));
    let r = d.report(1_000_000);
    let e = &r.energy;
    let secs = r.seconds;
    assert!((e.background_j / secs - 26.88).abs() < 0.01, "{e:?}");
    assert!((e.refresh_j / secs - 1.045).abs() < 0.02, "{e:?}");
    assert!((e.average_power_w - 27.93).abs() < 0.03, "{e:?}");
}

#[test]
fn activate_energy_follows_tn_41_01() {
    let c = config("ddr3-1600");
    let d = dram(&c);
    let s = d.spec();
    let (cur, t) = (&c.current, &s.t);
    let tck = 1.25e-9;
    let per_device = c.current.vdd
        * 1e-3
        * (cur.idd0 * t.rc as f64 - (cur.idd3n * t.ras as f64 + cur.idd2n * (t.rc - t.ras) as f64))
        * tck;
    assert!((s.energy.act_pre_j - 4.0 * per_device).abs() < 1e-15);
    let read = 4.0 * c.current.vdd * 1e-3 * (cur.idd4r - cur.idd3n) * 4.0 * tck;
    assert!((s.energy.read_j - read).abs() < 1e-15);
}

/// Ticking every requester cycle and jumping from event to event give identical results.
#[test]
fn ticking_and_jumping_agree() {
    for (preset, mhz) in [
        ("gddr5-trax", 1000.0),
        ("lpddr3-1600", 500.0),
        ("ddr3-1600", 1333.0),
    ] {
        let c = config(preset);
        let reqs: Vec<_> = Synthetic::new(Pattern::Random, 400, 0.6, 2, 64, 1 << 24, 3)
            .enumerate()
            .map(|(i, r)| req(i as u64, r.addr, r.op, 2 * i as u64))
            .collect();
        let mut ticked = dram_at(&c, mhz);
        let mut out_t = Vec::new();
        let mut i = 0;
        let mut now = 0;
        while i < reqs.len() || ticked.outstanding() > 0 {
            while i < reqs.len() && reqs[i].arrival <= now {
                let mut r = reqs[i];
                r.arrival = now;
                if ticked.try_enqueue(r).is_err() {
                    break;
                }
                i += 1;
            }
            ticked.advance_to(now);
            ticked.drain_completions(&mut out_t);
            now += 1;
        }
        let mut jumped = dram_at(&c, mhz);
        let mut out_j = Vec::new();
        let mut i = 0;
        let mut next = 0;
        while i < reqs.len() || jumped.outstanding() > 0 {
            let mut refused = false;
            while i < reqs.len() && reqs[i].arrival <= next {
                let mut r = reqs[i];
                r.arrival = next;
                if jumped.try_enqueue(r).is_err() {
                    refused = true;
                    break;
                }
                i += 1;
            }
            jumped.advance_to(next);
            jumped.drain_completions(&mut out_j);
            // Nothing happens before the next event or arrival (a refused request retries
            // every cycle, as when ticking).
            let mut to = jumped.next_event().unwrap_or(u64::MAX);
            if i < reqs.len() {
                to = to.min(if refused { next + 1 } else { reqs[i].arrival });
            }
            next = to.max(next + 1);
        }
        assert_eq!(out_t, out_j, "{preset}");
        assert_eq!(
            ticked.stats().read_latency_mem,
            jumped.stats().read_latency_mem
        );
        assert_legal(&ticked);
    }
}

/// Long (run with `--ignored`): hundreds of thousands of requests per preset and policy mix,
/// every command re-validated by the checker.
#[test]
#[ignore]
fn long_checked_runs_are_legal() {
    for p in PRESETS {
        for (pattern, closed, pd) in [
            (Pattern::Random, false, false),
            (Pattern::Random, true, true),
            (Pattern::Strided { stride: 8192 * 3 }, false, true),
            (Pattern::Stream, true, false),
        ] {
            let mut c = config(p.name);
            if closed {
                c.controller.row_policy = RowPolicyKind::Closed;
            }
            if pd {
                c.controller.power_down = PowerDownKind::Fast;
                c.controller.power_down_idle = 20;
            }
            let n = 300_000u64;
            let cap = dram(&c).spec().org.capacity_bytes;
            let traffic = Synthetic::new(pattern, n, 0.7, 3, 64, cap, 11);
            let d = run(&c, traffic);
            let mut d = d;
            let s = d.stats();
            assert_eq!(s.reads_done + s.writes_done, n, "{}", p.name);
            assert!(s.commands_checked > n / 2);
            assert_legal(&d);
        }
    }
}
