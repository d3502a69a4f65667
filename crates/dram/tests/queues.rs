//! Queues: capacity of every bounded queue, no request lost or duplicated, write-drain
//! watermarks, merging and forwarding, determinism. Checking mode is on.

mod common;

use common::*;
use proptest::prelude::*;
use rtsim_core::{MemOp, MemoryPort};
use rtsim_dram::config::{PRESETS, PowerDownKind, RowPolicyKind, SchedulerKind};
use rtsim_dram::trace::{Pattern, TraceRecord, When};
use rtsim_dram::{DriveOptions, drive};
use std::convert::Infallible;

/// Each queue takes exactly its capacity, refuses the next request, and takes one more once a
/// slot is freed by a column command.
#[test]
fn every_queue_holds_exactly_its_capacity() {
    for p in PRESETS {
        for op in [MemOp::Read, MemOp::Write] {
            let c = config(p.name);
            let cap = match op {
                MemOp::Read => c.controller.read_queue,
                MemOp::Write => c.controller.write_queue,
            };
            let mut d = dram(&c);
            let channels = d.spec().org.channels;
            let chans: Vec<u32> = if channels > 1 {
                vec![0, channels - 1]
            } else {
                vec![0]
            };
            for &ch in &chans {
                for i in 0..cap {
                    let a = addr(&d, ch, 0, i % 4, i, 0);
                    d.try_enqueue(req(u64::from(i), a, op, 0))
                        .unwrap_or_else(|_| panic!("{}: {op:?} {i} of {cap} refused", p.name));
                }
                let extra = addr(&d, ch, 0, 5, 999, 1);
                assert!(
                    d.try_enqueue(req(9999, extra, op, 0)).is_err(),
                    "{}: {op:?} queue took {} requests",
                    p.name,
                    cap + 1
                );
            }
            let s = d.stats();
            let refused = match op {
                MemOp::Read => s.reads_refused,
                MemOp::Write => s.writes_refused,
            };
            assert_eq!(refused, chans.len() as u64, "{}", p.name);
            // A slot frees when a column command issues; then exactly one more fits.
            let mut out = Vec::new();
            let mut t = 0;
            while !d.channels()[0].has_room(op) {
                t = d.next_event().unwrap();
                d.advance_to(t);
                d.drain_completions(&mut out);
            }
            let a = addr(&d, 0, 0, 6, 77, 2);
            assert!(
                d.try_enqueue(req(10_000, a, op, t + 1)).is_ok(),
                "{}",
                p.name
            );
            let b = addr(&d, 0, 0, 6, 78, 2);
            assert!(
                d.try_enqueue(req(10_001, b, op, t + 1)).is_err(),
                "{}",
                p.name
            );
            run_to_idle(&mut d);
            assert_legal(&d);
        }
    }
}

/// Merged reads still take a slot: capacity counts requests, not DRAM accesses.
#[test]
fn merged_reads_count_against_capacity_and_complete_together() {
    let c = config("ddr3-1600");
    let mut d = dram(&c);
    let a = addr(&d, 0, 0, 3, 10, 4);
    for i in 0..c.controller.read_queue {
        d.try_enqueue(req(u64::from(i), a + 8, MemOp::Read, 0))
            .unwrap();
    }
    assert!(d.try_enqueue(req(999, a, MemOp::Read, 0)).is_err());
    let out = run_to_idle(&mut d);
    assert_eq!(out.len() as u32, c.controller.read_queue);
    assert!(out.iter().all(|x| x.finish == out[0].finish));
    assert!(out.iter().all(|x| x.addr == a + 8));
    let s = d.stats();
    assert_eq!(s.column_reads, 1);
    assert_eq!(s.reads_merged, u64::from(c.controller.read_queue) - 1);
    assert_legal(&d);
}

#[test]
fn reads_are_forwarded_from_queued_writes() {
    let mut c = config("gddr5-trax");
    c.refresh.enabled = false;
    let mut d = dram(&c);
    let a = addr(&d, 2, 0, 1, 5, 3);
    // Keep a read busy so the write stays queued (below the watermark, reads waiting).
    let other = addr(&d, 2, 0, 7, 9, 0);
    d.try_enqueue(req(0, other, MemOp::Read, 10)).unwrap();
    d.try_enqueue(req(1, a, MemOp::Write, 10)).unwrap();
    d.advance_to(10);
    d.try_enqueue(req(2, a, MemOp::Read, 11)).unwrap();
    let out = run_to_idle(&mut d);
    let fwd = out.iter().find(|x| x.id == 2).unwrap();
    // Arrives at memory cycle 22, answered forward_latency (1) cycle later: requester 12.
    assert_eq!(fwd.finish, 12);
    let s = d.stats();
    assert_eq!(
        (s.reads_forwarded, s.column_reads, s.column_writes),
        (1, 1, 1)
    );
    // Turned off, the read goes to DRAM after the write.
    c.controller.forward_reads = false;
    let mut d = dram(&c);
    d.try_enqueue(req(1, a, MemOp::Write, 10)).unwrap();
    d.advance_to(10);
    d.try_enqueue(req(2, a, MemOp::Read, 11)).unwrap();
    run_to_idle(&mut d);
    assert_eq!(d.stats().column_reads, 1);
    assert_legal(&d);
}

/// Write drain: with reads waiting, writes are held until the high watermark, then drained down
/// to the low watermark before reads resume.
#[test]
fn write_drain_follows_the_watermarks() {
    for (writes, drained_early) in [(39u32, 0usize), (40, 20), (45, 25)] {
        let mut c = config("gddr5-trax");
        c.refresh.enabled = false;
        let mut d = dram(&c);
        // 60 reads to one bank, all row conflicts: they take ~60 tRC.
        for i in 0..60u32 {
            let a = addr(&d, 0, 0, 0, 100 + i, 0);
            d.try_enqueue(req(u64::from(i), a, MemOp::Read, 0)).unwrap();
        }
        for i in 0..writes {
            let a = addr(&d, 0, 0, 1 + i % 8, 200 + i, i % 16);
            d.try_enqueue(req(1000 + u64::from(i), a, MemOp::Write, 0))
                .unwrap();
        }
        let out = run_to_idle(&mut d);
        let last_read = out
            .iter()
            .filter(|x| x.op == MemOp::Read)
            .map(|x| x.finish)
            .max()
            .unwrap();
        let first_read = out
            .iter()
            .filter(|x| x.op == MemOp::Read)
            .map(|x| x.finish)
            .min()
            .unwrap();
        let before_last = out
            .iter()
            .filter(|x| x.op == MemOp::Write && x.finish < last_read)
            .count();
        let before_first = out
            .iter()
            .filter(|x| x.op == MemOp::Write && x.finish < first_read)
            .count();
        assert_eq!(before_last, drained_early, "{writes} writes");
        assert_eq!(before_first, drained_early, "{writes} writes");
        let s = d.stats();
        // One episode at the watermark (if reached) and one once the reads are done.
        let episodes = if drained_early > 0 { 2 } else { 1 };
        assert_eq!(s.write_drain_episodes, episodes, "{writes} writes");
        assert_legal(&d);
    }
}

/// The same input gives bit-identical results.
#[test]
fn runs_are_deterministic() {
    let run = || {
        let mut c = config("gddr5-strata");
        c.controller.row_hit_cap = 4;
        let mut d = dram(&c);
        run_synthetic(&mut d, Pattern::Random, 30_000, 0.7, 1, 1 << 30, 42)
    };
    assert_eq!(run(), run());
}

#[test]
fn row_hit_cap_bounds_consecutive_hits() {
    // One bank: an old request for row 2 waits behind a stream of hits to the open row 1.
    let run = |cap: u32| {
        let mut c = config("ddr3-1600");
        c.refresh.enabled = false;
        c.controller.row_hit_cap = cap;
        let mut d = dram(&c);
        let open = addr(&d, 0, 0, 0, 1, 0);
        single(&mut d, req(0, open, MemOp::Read, 0));
        let conflict = addr(&d, 0, 0, 0, 2, 0);
        d.advance_to(999);
        d.try_enqueue(req(1, conflict, MemOp::Read, 1000)).unwrap();
        for i in 0..40u32 {
            let a = addr(&d, 0, 0, 0, 1, 1 + i % 100);
            d.try_enqueue(req(2 + u64::from(i), a, MemOp::Read, 1000))
                .unwrap();
        }
        let out = run_to_idle(&mut d);
        let c_fin = out.iter().find(|x| x.id == 1).unwrap().finish;
        out.iter().filter(|x| x.id >= 2 && x.finish < c_fin).count()
    };
    assert_eq!(run(0), 40, "no cap: every hit goes first");
    assert_eq!(
        run(8),
        8,
        "cap 8: the conflicting request waits for 8 hits only"
    );
}

/// The cap only helps the bank's oldest request: a conflicting request younger than the
/// waiting hits does not cut in (DRAMsim3's rule).
#[test]
fn row_hit_cap_ignores_younger_conflicts() {
    let mut c = config("ddr3-1600");
    c.refresh.enabled = false;
    c.controller.row_hit_cap = 8;
    let mut d = dram(&c);
    let open = addr(&d, 0, 0, 0, 1, 0);
    single(&mut d, req(0, open, MemOp::Read, 0));
    d.advance_to(999);
    for i in 0..40u32 {
        let a = addr(&d, 0, 0, 0, 1, 1 + i % 100);
        d.try_enqueue(req(2 + u64::from(i), a, MemOp::Read, 1000))
            .unwrap();
    }
    let conflict = addr(&d, 0, 0, 0, 2, 0);
    d.try_enqueue(req(1, conflict, MemOp::Read, 1001)).unwrap();
    let out = run_to_idle(&mut d);
    let c_fin = out.iter().find(|x| x.id == 1).unwrap().finish;
    let before = out.iter().filter(|x| x.id >= 2 && x.finish < c_fin).count();
    assert_eq!(before, 40, "every older hit goes first");
}

/// Without row-hit protection (USIMM's FR-FCFS) a ready PRE for an older request may close a
/// row whose hits are momentarily blocked, so rows are opened more often for the same traffic.
#[test]
fn unprotected_row_hits_can_be_closed() {
    let run = |protect: bool| {
        let mut c = config("ddr3-1600");
        c.controller.protect_row_hits = protect;
        // Row-hit protection alone: the drain policy that also keeps rows open for the other
        // kind of request (the default, `protect-rows`) would blur the comparison.
        c.controller.write_drain = rtsim_dram::config::WriteDrainKind::WritesOnly;
        let mut d = dram(&c);
        // Runs of lines in random rows, reads and writes mixed: hits and conflicts interleave.
        let mut rng = rtsim_core::Pcg32::new(5, 1);
        let mut recs = Vec::new();
        while recs.len() < 20_000 {
            let base = u64::from(rng.next_u32() & !8191);
            for i in 0..(4 + rng.below(28)) {
                recs.push(TraceRecord {
                    when: When::Gap(u64::from(rng.below(4))),
                    op: if rng.below(5) == 0 {
                        MemOp::Write
                    } else {
                        MemOp::Read
                    },
                    addr: base + u64::from(i) * 64,
                });
            }
        }
        let s = drive(
            &mut d,
            recs.into_iter().map(Ok::<_, Infallible>),
            DriveOptions::default(),
            |_| {},
        )
        .unwrap();
        assert_legal(&d);
        let st = d.report(s.end_cycle).stats;
        (st.activates, st.read_row_hit_rate_by_activates())
    };
    let (acts_p, hit_p) = run(true);
    let (acts_u, hit_u) = run(false);
    assert!(acts_u > acts_p, "{acts_u} vs {acts_p}");
    assert!(hit_u < hit_p, "{hit_u} vs {hit_p}");
}

/// `trace.max_per_cycle` (DRAMsim3's front end offers one request per cycle): four reads all
/// timed at cycle 0 are issued at 0, 1, 2 and 3 with a limit of 1 (0 + 1 + 2 + 3 = 6 stall
/// cycles), at 0, 0, 1 and 1 with a limit of 2, and all at 0 without a limit.
#[test]
fn max_per_cycle_moves_the_excess_to_the_next_cycle() {
    let stalls = |limit| {
        let mut c = config("ddr3-1600");
        c.refresh.enabled = false;
        let mut d = dram_at(&c, c.timing.clock_mhz);
        let recs: Vec<_> = (0..4u32)
            .map(|b| TraceRecord {
                when: When::At(0),
                op: MemOp::Read,
                addr: addr(&d, 0, 0, b, 3, 0),
            })
            .collect();
        let opts = DriveOptions {
            max_per_cycle: limit,
            ..DriveOptions::default()
        };
        let s = drive(
            &mut d,
            recs.into_iter().map(Ok::<_, Infallible>),
            opts,
            |_| {},
        )
        .unwrap();
        assert_legal(&d);
        assert_eq!(s.requests, 4);
        s.stall_cycles
    };
    assert_eq!(stalls(0), 0);
    assert_eq!(stalls(1), 6);
    assert_eq!(stalls(2), 2);
}

fn arb_record() -> impl Strategy<Value = (u64, bool, u8)> {
    // Gaps, read/write, and a small address pool so that merging and forwarding happen.
    (0u64..6, any::<bool>(), 0u8..40)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 96, .. ProptestConfig::default() })]

    /// Whatever the trace and policies, every request completes exactly once, never before it
    /// arrived, and the checker finds no illegal command.
    #[test]
    fn no_request_is_lost_or_duplicated(
        recs in proptest::collection::vec(arb_record(), 1..400),
        preset in 0usize..PRESETS.len(),
        fcfs in any::<bool>(),
        closed in any::<bool>(),
        small_queues in any::<bool>(),
        cap in 0u32..4,
        refresh in any::<bool>(),
        power_down in any::<bool>(),
        protect in any::<bool>(),
    ) {
        let mut c = config(PRESETS[preset].name);
        if fcfs { c.controller.scheduler = SchedulerKind::Fcfs; }
        if closed { c.controller.row_policy = RowPolicyKind::Closed; }
        if small_queues {
            c.controller.read_queue = 3;
            c.controller.write_queue = 4;
            c.controller.write_high_watermark = 3;
            c.controller.write_low_watermark = 1;
        }
        c.controller.row_hit_cap = cap;
        c.controller.protect_row_hits = protect;
        // Without refresh no periodic event can hide a missing wake-up.
        c.refresh.enabled = refresh;
        if power_down {
            c.controller.power_down = PowerDownKind::Fast;
            c.controller.power_down_idle = 5;
        }
        let mut d = dram(&c);
        let row = d.spec().org.row_bytes;
        let trace: Vec<TraceRecord> = recs
            .iter()
            .map(|&(gap, read, k)| TraceRecord {
                when: When::Gap(gap),
                op: if read { MemOp::Read } else { MemOp::Write },
                // Pool: 8 lines in each of 5 rows spread over banks and channels.
                addr: u64::from(k / 8) * row * 3 + u64::from(k % 8) * 64 * 33,
            })
            .collect();
        let mut seen = vec![0u32; trace.len()];
        // Drive by hand to see every completion.
        let mut out = Vec::new();
        let mut t = 0u64;
        for (i, r) in trace.iter().enumerate() {
            if let When::Gap(g) = r.when { t += g; }
            loop {
                if t > 0 && d.now().is_none_or(|n| n < t - 1) { d.advance_to(t - 1); }
                d.drain_completions(&mut out);
                if d.try_enqueue(req(i as u64, r.addr, r.op, t)).is_ok() { break; }
                let e = d.next_event().unwrap();
                d.advance_to(e.max(t));
                d.drain_completions(&mut out);
                t = d.now().unwrap() + 1;
            }
        }
        out.extend(run_to_idle(&mut d));
        for x in &out {
            seen[x.id as usize] += 1;
            prop_assert!(x.finish > x.arrival || (x.finish == x.arrival && x.op == MemOp::Read));
            prop_assert_eq!(x.addr, trace[x.id as usize].addr);
            prop_assert_eq!(x.op, trace[x.id as usize].op);
        }
        prop_assert!(seen.iter().all(|&n| n == 1), "completions per id: {:?}", seen);
        prop_assert_eq!(d.outstanding(), 0);
        let s = d.stats();
        prop_assert_eq!(s.reads_done + s.writes_done, trace.len() as u64);
        prop_assert_eq!(s.reads_done, s.column_reads + s.reads_merged + s.reads_forwarded);
        prop_assert_eq!(s.writes_done, s.column_writes + s.writes_merged);
        prop_assert!(d.violations().is_empty(), "{:?}", d.violations());
    }
}

/// A refused request's retry hint never skips a cycle at which the request could have been
/// accepted: a requester that follows the hints is accepted in the same cycle as one that
/// polls every cycle, with far fewer attempts.
#[test]
fn retry_hints_skip_only_hopeless_cycles() {
    use rtsim_core::MemError;
    for p in ["gddr5-trax", "lpddr3-1600", "ddr4-3200"] {
        let mut c = config(p);
        c.controller.read_queue = 4;
        let fill = |d: &mut rtsim_dram::Dram| -> u64 {
            for i in 0..4 {
                let a = addr(d, 0, 0, 0, 10 + i, 0);
                d.try_enqueue(req(u64::from(i), a, MemOp::Read, 1)).unwrap();
            }
            addr(d, 0, 0, 1, 3, 0)
        };
        // Polling every cycle.
        let mut poll = dram(&c);
        let extra = fill(&mut poll);
        let mut t = 1;
        let mut polls = 0;
        while poll.try_enqueue(req(9, extra, MemOp::Read, t)).is_err() {
            polls += 1;
            poll.advance_to(t);
            t += 1;
        }
        // Following the hints.
        let mut hint = dram(&c);
        fill(&mut hint);
        let mut at = 1;
        let mut tries = 0;
        loop {
            match hint.try_enqueue(req(9, extra, MemOp::Read, at)) {
                Ok(()) => break,
                Err(MemError::Full(q)) => {
                    assert!(q.retry_at > at, "{p}: hint does not move forward");
                    tries += 1;
                    hint.advance_to(q.retry_at - 1);
                    at = q.retry_at;
                }
                Err(e) => panic!("{p}: {e}"),
            }
        }
        assert_eq!(at, t, "{p}: accepted at {at} following hints, {t} polling");
        assert!(tries < polls, "{p}: {tries} hinted tries vs {polls} polls");
        run_to_idle(&mut hint);
        assert_legal(&hint);
    }
}

/// Requests in the past and tags out of range are errors, not panics; stats split by tag.
#[test]
fn past_arrivals_and_tags() {
    use rtsim_core::{MemError, MemoryPort};
    use rtsim_dram::{Dram, Requester};
    let c = config("gddr5-trax");
    let mut d = Dram::new(&c, Requester::mhz(1000.0).with_tags(3)).unwrap();
    let a = addr(&d, 0, 0, 0, 1, 0);
    let b = addr(&d, 0, 0, 0, 1, 1);
    d.advance_to(100);
    assert_eq!(
        d.try_enqueue(req(1, a, MemOp::Read, 100)),
        Err(MemError::Past {
            id: 1,
            arrival: 100,
            now: 100
        })
    );
    let mut r = req(2, a, MemOp::Read, 101);
    r.tag = 3;
    assert_eq!(
        d.try_enqueue(r),
        Err(MemError::Tag {
            id: 2,
            tag: 3,
            tags: 3
        })
    );
    r.tag = 2;
    d.try_enqueue(r).unwrap();
    let mut w = req(3, b, MemOp::Write, 101);
    w.tag = 1;
    d.try_enqueue(w).unwrap();
    let out = run_to_idle(&mut d);
    assert_eq!(out.iter().map(|c| c.tag).collect::<Vec<_>>().len(), 2);
    assert!(out.iter().any(|c| c.id == 2 && c.tag == 2));
    let s = d.stats();
    assert_eq!(s.per_tag.len(), 3);
    assert_eq!((s.per_tag[2].reads, s.per_tag[1].writes), (1, 1));
    assert_eq!(s.per_tag[0].reads + s.per_tag[0].writes, 0);
    assert_eq!(s.per_tag[2].read_latency_req.count, 1);
    // The second access to the open row is a hit, whichever tag it came from.
    assert_eq!(s.per_tag[1].row_hits + s.per_tag[2].row_hits, 1);
    // Tags and the requester clock are validated at construction.
    let e = Dram::new(&c, Requester::mhz(1000.0).with_tags(0))
        .unwrap_err()
        .to_string();
    assert!(e.contains("requester tags"), "{e}");
    let e = Dram::new(&c, Requester::mhz(1.0)).unwrap_err().to_string();
    assert!(e.contains("requester clock") && e.contains("1024"), "{e}");
}
