//! The timed hierarchy: latencies, banks, MSHR merging and back-pressure, agreement with the
//! functional model, DRAM behind it, and event skipping equal to ticking every cycle.

use rtsim_cache::{
    BusyCause, CacheConfig, CacheLevel, CacheStats, Completion, FixedLatency, FunctionalHierarchy,
    Hierarchy, HierarchyError, Node, Outcome, Parent, Replacement, Request, Topology, WritePolicy,
};
use rtsim_core::{MemOp, MemoryPort, Pcg32};
use rtsim_dram::config::preset_config;
use rtsim_dram::{Dram, Requester};

fn two_level(l1s: u32) -> CacheConfig {
    CacheConfig {
        l1_count: l1s,
        ..CacheConfig::default()
    }
}

fn fixed(h: &CacheConfig, latency: u64) -> Hierarchy<FixedLatency> {
    let t = Topology::from_config(h).unwrap();
    Hierarchy::new(t, FixedLatency::new(latency, 64, 64, 8)).unwrap()
}

fn req(cycle: u64, l1: usize, addr: u64, op: MemOp, tag: u64) -> Request {
    Request {
        cycle,
        l1,
        addr,
        op,
        tag,
    }
}

fn run_dry<M: MemoryPort>(h: &mut Hierarchy<M>) -> Vec<Completion> {
    h.drain().unwrap();
    let mut out = Vec::new();
    h.drain_completions(&mut out);
    out
}

#[test]
fn latencies_of_hits_and_misses() {
    let mut h = fixed(&two_level(1), 100);
    // Cold: L1 lookup 1, L2 lookup 3, memory 100.
    assert_eq!(
        h.submit(req(10, 0, 0x1000, MemOp::Read, 7)).unwrap(),
        Outcome::Pending
    );
    let c = run_dry(&mut h);
    assert_eq!(c.len(), 1);
    assert_eq!((c[0].tag, c[0].ready), (7, 10 + 1 + 3 + 100));
    // L1 hit: ready one cycle later.
    assert_eq!(
        h.submit(req(500, 0, 0x1008, MemOp::Read, 8)).unwrap(),
        Outcome::Done {
            ready: 501,
            hit: true
        }
    );
    // L1 miss, L2 hit: 1 + 3. (16 KB apart: same L1 set, different L2 set.)
    h.submit(req(600, 0, 0x1000 + 16384, MemOp::Read, 9))
        .unwrap();
    run_dry(&mut h);
    assert_eq!(
        h.submit(req(1000, 0, 0x1000, MemOp::Read, 10)).unwrap(),
        Outcome::Pending
    );
    let c = run_dry(&mut h);
    assert_eq!(c[0].ready, 1000 + 1 + 3);
    let l2 = h.stats(1);
    assert_eq!((l2.reads, l2.read_hits), (3, 1));
}

#[test]
fn misses_to_a_line_in_flight_merge() {
    let mut h = fixed(&two_level(2), 50);
    // Same line from one L1 in two cycles, and from the other L1: one memory read.
    for (t, l1) in [(0u64, 0usize), (1, 0), (2, 1)] {
        assert_eq!(
            h.submit(req(t, l1, 0x40, MemOp::Read, t)).unwrap(),
            Outcome::Pending
        );
    }
    let c = run_dry(&mut h);
    assert_eq!(c.len(), 3);
    assert_eq!(c[0].ready, c[1].ready, "merged misses complete together");
    assert_eq!(h.stats(0).mshr_merges, 1);
    assert_eq!(
        h.stats(2).mshr_merges,
        1,
        "the L2 merges the second L1's miss"
    );
    assert_eq!(h.memory().accepted[0], 1);
    assert_eq!(h.stats(2).miss_latency.count, 1);
}

#[test]
fn banks_mshrs_and_write_buffers_push_back() {
    let mut cfg = two_level(1);
    cfg.l1.mshrs = 2;
    cfg.l1.write_buffer = 1;
    cfg.l1.banks = 4;
    let mut h = fixed(&cfg, 50);
    // Lines 0 and 4 share bank 0 (line mod 4); line 1 is bank 1.
    assert_eq!(
        h.submit(req(5, 0, 0, MemOp::Read, 0)).unwrap(),
        Outcome::Pending
    );
    assert_eq!(
        h.submit(req(5, 0, 4 * 64, MemOp::Read, 1)).unwrap(),
        Outcome::Busy {
            retry_at: 6,
            cause: BusyCause::Bank
        }
    );
    assert_eq!(
        h.submit(req(5, 0, 64, MemOp::Read, 2)).unwrap(),
        Outcome::Pending
    );
    // Both MSHRs busy: a third line is refused until a fill frees one.
    let Outcome::Busy {
        retry_at,
        cause: BusyCause::Mshr,
    } = h.submit(req(6, 0, 2 * 64, MemOp::Read, 3)).unwrap()
    else {
        panic!("third miss accepted with two MSHRs");
    };
    assert!(retry_at > 6);
    // A hit-free merge still works with MSHRs full.
    assert_eq!(
        h.submit(req(7, 0, 8, MemOp::Read, 4)).unwrap(),
        Outcome::Pending
    );
    // Write buffer of one: the second posted write is refused.
    assert!(matches!(
        h.submit(req(8, 0, 3 * 64, MemOp::Write, 5)).unwrap(),
        Outcome::Done {
            ready: 9,
            hit: false
        }
    ));
    assert!(matches!(
        h.submit(req(8, 0, 5 * 64, MemOp::Write, 6)).unwrap(),
        Outcome::Busy {
            cause: BusyCause::WriteBuffer,
            ..
        }
    ));
    let s = h.stats(0);
    assert_eq!(
        (
            s.bank_conflicts,
            s.mshr_full_stalls,
            s.write_buffer_full_stalls
        ),
        (1, 1, 1)
    );
    assert_eq!(s.accesses(), 4, "refused attempts are not accesses");
    assert_eq!(s.mshr_peak, 2);
    // Later, everything is accepted again.
    let mut t = retry_at;
    while let Outcome::Busy { retry_at, .. } = h.submit(req(t, 0, 2 * 64, MemOp::Read, 3)).unwrap()
    {
        t = retry_at;
    }
    assert_eq!(run_dry(&mut h).len(), 4);
}

#[test]
fn misuse_is_an_error() {
    let mut h = fixed(&two_level(1), 10);
    h.submit(req(100, 0, 0, MemOp::Read, 0)).unwrap();
    assert!(matches!(
        h.submit(req(99, 0, 0, MemOp::Read, 0)),
        Err(HierarchyError::Past {
            cycle: 99,
            now: 100
        })
    ));
    assert!(matches!(
        h.submit(req(100, 3, 0, MemOp::Read, 0)),
        Err(HierarchyError::NoSuchL1 { l1: 3, count: 1 })
    ));
}

#[test]
fn line_size_must_match_the_dram() {
    let mut cfg = two_level(1);
    cfg.l1.line_bytes = 128;
    cfg.l2.line_bytes = 128;
    let dram = Dram::new(
        &preset_config("gddr5-trax").unwrap(),
        Requester::mhz(1000.0),
    )
    .unwrap();
    let e = Hierarchy::new(Topology::from_config(&cfg).unwrap(), dram)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("l2.line_bytes") && e.contains("organisation.line_bytes") && e.contains("64"),
        "{e}"
    );
}

fn random_trace(n: usize, seed: u64, l1s: usize, span: u64, spacing: u64) -> Vec<Request> {
    let mut rng = Pcg32::new(seed, 3);
    let mut t = 0;
    (0..n)
        .map(|i| {
            t += rng.below(spacing as u32 + 1) as u64;
            let op = if rng.below(4) == 0 {
                MemOp::Write
            } else {
                MemOp::Read
            };
            req(
                t,
                rng.below(l1s as u32) as usize,
                rng.below(span as u32) as u64 * 8,
                op,
                i as u64,
            )
        })
        .collect()
}

/// Issue requests in order at their cycles (or later when refused), advancing time either by
/// jumping to the next event or cycle by cycle. Returns completions and the refusal count.
fn drive<M: MemoryPort>(
    h: &mut Hierarchy<M>,
    reqs: &[Request],
    tick: bool,
) -> (Vec<Completion>, Vec<Outcome>) {
    let mut out = Vec::new();
    let mut outcomes = Vec::new();
    let mut t = 0;
    for r in reqs {
        let mut r = *r;
        r.cycle = r.cycle.max(t);
        loop {
            if tick {
                while t < r.cycle {
                    h.advance_to(t).unwrap();
                    t += 1;
                }
            }
            let o = h.submit(r).unwrap();
            outcomes.push(o);
            match o {
                Outcome::Busy { retry_at, .. } => r.cycle = retry_at,
                _ => break,
            }
        }
        t = r.cycle;
        h.drain_completions(&mut out);
    }
    if tick {
        while h.next_event().is_some() {
            h.advance_to(t).unwrap();
            t += 1;
        }
    } else {
        h.drain().unwrap();
    }
    h.drain_completions(&mut out);
    (out, outcomes)
}

fn trax_on_dram(l1s: u32) -> Hierarchy<Dram> {
    let mut cfg = two_level(l1s);
    cfg.l1.mshrs = 4;
    cfg.l2.mshrs = 16;
    cfg.l2.size_bytes = 64 * 1024;
    let t = Topology::from_config(&cfg).unwrap();
    let mut d = preset_config("gddr5-trax").unwrap();
    d.controller.read_queue = 4;
    let dram = Dram::new(&d, Requester::mhz(1000.0).with_tags(1)).unwrap();
    Hierarchy::new(t, dram).unwrap()
}

/// SGRT per core: four TRV L1s (16 KB 2-way) over a 128 KB 2-way 8-bank L2 (hit 20), plus an
/// IST L1 (128 KB 4-way) straight to memory; four cores on LPDDR3 at 500 MHz : 800 MHz.
fn sgrt(cores: usize) -> Hierarchy<Dram> {
    let trv = CacheLevel {
        size_bytes: 16 * 1024,
        ways: 2,
        ..CacheLevel::trax_l1()
    };
    let l2 = CacheLevel {
        size_bytes: 128 * 1024,
        ways: 2,
        banks: 8,
        hit_latency: 20,
        ..CacheLevel::trax_l2()
    };
    let ist = CacheLevel {
        size_bytes: 128 * 1024,
        ways: 4,
        ..CacheLevel::trax_l1()
    };
    let mut nodes = Vec::new();
    for core in 0..cores {
        let l2_index = cores * 5 + core;
        for _ in 0..4 {
            nodes.push(Node {
                name: "trv-l1".into(),
                level: 1,
                cache: trv.clone(),
                parent: Parent::Cache(l2_index),
            });
        }
        nodes.push(Node {
            name: "ist-l1".into(),
            level: 1,
            cache: ist.clone(),
            parent: Parent::Memory,
        });
    }
    for _ in 0..cores {
        nodes.push(Node {
            name: "l2".into(),
            level: 2,
            cache: l2.clone(),
            parent: Parent::Memory,
        });
    }
    let t = Topology::new(nodes, 1).unwrap();
    let d = preset_config("lpddr3-1600").unwrap();
    let dram = Dram::new(&d, Requester::mhz(500.0).with_tags(2 * cores as u32)).unwrap();
    let h = Hierarchy::new(t, dram).unwrap();
    assert_eq!(h.memory_tags(), 2 * cores as u32);
    h
}

#[test]
fn event_skipping_equals_ticking_every_cycle() {
    for (name, make, l1s) in [
        (
            "trax",
            (|| trax_on_dram(4)) as fn() -> Hierarchy<Dram>,
            4usize,
        ),
        ("sgrt", || sgrt(2), 10),
    ] {
        let reqs = random_trace(3000, 11, l1s, 1 << 16, 3);
        let (mut a, mut b) = (make(), make());
        let (ca, oa) = drive(&mut a, &reqs, false);
        let (cb, ob) = drive(&mut b, &reqs, true);
        assert_eq!(oa, ob, "{name}: outcomes");
        assert_eq!(ca, cb, "{name}: completions");
        assert_eq!(a.all_stats(), b.all_stats(), "{name}: cache stats");
        assert_eq!(
            a.memory_mut().stats(),
            b.memory_mut().stats(),
            "{name}: DRAM stats"
        );
        let pending = oa.iter().filter(|o| matches!(o, Outcome::Pending)).count();
        assert_eq!(ca.len(), pending, "{name}: every miss completes");
        let s = a.all_stats();
        let merges: u64 = s.caches.iter().map(|c| c.2.mshr_merges).sum();
        let refusals = oa
            .iter()
            .filter(|o| matches!(o, Outcome::Busy { .. }))
            .count();
        assert!(
            merges > 0 && refusals > 0,
            "{name}: the trace exercises merges ({merges}) and back-pressure ({refusals})"
        );
        for c in &ca {
            assert!(c.ready > c.cycle);
        }
    }
}

/// Requests refused by a full DRAM queue wait in groups, one event per run of them
/// (`MemWaits` in `timed.rs`); offering each again as its own event, as the hierarchy once
/// did, must give the same outcomes, completions and counters, here with the queues so small
/// that thousands of requests wait: one L2 on two DRAM channels with 4-entry read and write
/// queues, and SGRT's several caches (several requester tags) on LPDDR3.
#[test]
fn grouped_memory_waits_equal_one_event_per_refused_request() {
    // A DRAM preset cut down to `channels` channels and tiny queues, so that requests wait.
    fn tiny_dram(preset: &str, channels: u32, read_queue: u32, requester: Requester) -> Dram {
        let mut d = preset_config(preset).unwrap();
        d.organisation.channels = channels;
        d.controller.read_queue = read_queue;
        d.controller.write_queue = 4;
        (
            d.controller.write_high_watermark,
            d.controller.write_low_watermark,
        ) = (3, 1);
        Dram::new(&d, requester).unwrap()
    }
    let tiny = || {
        let mut cfg = two_level(8);
        cfg.l1.mshrs = 32;
        cfg.l2.mshrs = 4096;
        cfg.l2.size_bytes = 16 * 1024;
        let dram = tiny_dram("gddr5-trax", 2, 4, Requester::mhz(1000.0).with_tags(1));
        Hierarchy::new(Topology::from_config(&cfg).unwrap(), dram).unwrap()
    };
    let sgrt_tiny = || {
        let h = sgrt(2);
        let dram = tiny_dram("lpddr3-1600", 1, 2, Requester::mhz(500.0).with_tags(4));
        Hierarchy::new(h.topology().clone(), dram).unwrap()
    };
    for (name, make, l1s, spacing) in [
        (
            "trax",
            Box::new(tiny) as Box<dyn Fn() -> Hierarchy<Dram>>,
            8usize,
            1,
        ),
        ("sgrt", Box::new(sgrt_tiny), 10, 1),
    ] {
        let reqs = random_trace(6000, 5, l1s, 1 << 18, spacing);
        let (mut grouped, mut single) = (make(), make());
        single.set_grouped_memory_waits(false);
        let (cg, og) = drive(&mut grouped, &reqs, false);
        let (cs, os) = drive(&mut single, &reqs, false);
        assert_eq!(og, os, "{name}: outcomes");
        assert_eq!(cg, cs, "{name}: completions");
        assert_eq!(
            grouped.all_stats(),
            single.all_stats(),
            "{name}: cache stats"
        );
        let (dg, ds) = (grouped.memory_mut().stats(), single.memory_mut().stats());
        assert_eq!(dg, ds, "{name}: DRAM stats");
        assert!(
            dg.reads_refused > 10 * reqs.len() as u64 && dg.writes_refused > 0,
            "{name}: the queues saturate ({} reads, {} writes refused)",
            dg.reads_refused,
            dg.writes_refused
        );
    }
}

/// Accesses far apart in time neither merge nor wait: the timed hierarchy then sees exactly
/// the functional model's hits, misses, evictions and write-backs at every level.
#[test]
fn sparse_accesses_count_as_the_functional_model() {
    for policy in [WritePolicy::WriteAround, WritePolicy::WriteBack] {
        for repl in [Replacement::Lru, Replacement::Fifo, Replacement::Random] {
            let mut cfg = two_level(2);
            for l in [&mut cfg.l1, &mut cfg.l2] {
                l.write_policy = policy;
                l.replacement = repl;
                l.ways = 4;
            }
            cfg.l1.size_bytes = 4096;
            cfg.l2.size_bytes = 32768;
            let reqs: Vec<_> = random_trace(4000, 5, 2, 1 << 13, 0)
                .into_iter()
                .enumerate()
                .map(|(i, mut r)| {
                    r.cycle = 1000 * i as u64;
                    r
                })
                .collect();
            let mut timed = fixed(&cfg, 40);
            drive(&mut timed, &reqs, false);
            let mut func = FunctionalHierarchy::new(&cfg).unwrap();
            for r in &reqs {
                func.access(r.l1, r.addr, r.op);
            }
            for n in 0..3 {
                let (f, t) = (func.stats(n), timed.stats(n));
                let key = |s: &rtsim_cache::CacheStats| {
                    (
                        s.reads,
                        s.writes,
                        s.read_hits,
                        s.write_hits,
                        s.fills,
                        s.evictions,
                        s.writebacks,
                        s.write_throughs,
                    )
                };
                assert_eq!(key(f), key(t), "{policy:?} {repl:?} cache {n}");
            }
            let mem_reads = timed.memory().accepted[0];
            assert_eq!(
                mem_reads,
                func.memory.reads + func.memory.writes,
                "{policy:?} {repl:?}"
            );
        }
    }
}

/// With word-interleaved banks, consecutive words of one line are in different banks; with the
/// default, every word of a line is in one bank.
#[test]
fn bank_interleaving_follows_bank_bytes() {
    let run = |bank_bytes: Option<u32>| {
        let cfg = CacheConfig {
            levels: 1,
            l1: CacheLevel {
                bank_bytes,
                ..CacheLevel::trax_l1()
            },
            ..CacheConfig::default()
        };
        let topo = Topology::from_config(&cfg).unwrap();
        let mut h = Hierarchy::new(topo, FixedLatency::new(10, 64, 64, 1)).unwrap();
        // Two requesters read words 0 and 4 of one line in the same cycle.
        let mut outs = Vec::new();
        for (tag, addr) in [(0u64, 0x1000u64), (1, 0x1004)] {
            outs.push(
                h.submit(Request {
                    cycle: 5,
                    l1: 0,
                    addr,
                    op: MemOp::Read,
                    tag,
                })
                .unwrap(),
            );
        }
        (outs, h.stats(0).bank_conflicts)
    };
    let (outs, conflicts) = run(None);
    assert!(matches!(outs[1], Outcome::Busy { retry_at: 6, .. }));
    assert_eq!(conflicts, 1);
    let (outs, conflicts) = run(Some(4));
    assert!(!matches!(outs[1], Outcome::Busy { .. }));
    assert_eq!(conflicts, 0);
    // Out of range is refused by name.
    let bad = CacheLevel {
        bank_bytes: Some(128),
        ..CacheLevel::trax_l1()
    };
    let e = bad.validate_at("l1").unwrap_err().to_string();
    assert!(e.contains("l1.bank_bytes"), "{e}");
}

/// An inner cache out of MSHRs queues its children's misses and offers them again, in arrival
/// order, after every fill — over and over while the queue is longer than the MSHRs freed (the
/// queue's storage is traded between rounds; the order and the counts must not change).
#[test]
fn blocked_inner_accesses_are_served_in_arrival_order_over_many_retries() {
    let mut cfg = two_level(4);
    cfg.l2.mshrs = 1;
    let mut h = fixed(&cfg, 50);
    // Four L1s miss four distinct lines, two each, one cycle apart: the L2 has one MSHR.
    let mut tag = 0;
    for round in 0..2u64 {
        for l1 in 0..4usize {
            let addr = (round * 4 + l1 as u64) * 64 * 1024 + 64 * l1 as u64;
            assert_eq!(
                h.submit(req(tag, l1, addr, MemOp::Read, tag)).unwrap(),
                Outcome::Pending
            );
            tag += 1;
        }
    }
    let c = run_dry(&mut h);
    let order: Vec<u64> = c.iter().map(|c| c.tag).collect();
    assert_eq!(
        order,
        (0..8).collect::<Vec<_>>(),
        "first come, first served"
    );
    for w in c.windows(2) {
        assert!(w[1].ready >= w[0].ready + 50, "one line at a time: {c:?}");
    }
    let l2 = h.stats(4);
    assert_eq!((l2.reads, l2.read_misses), (8, 8));
    // Seven are refused on arrival; each fill frees the MSHR for the oldest, and the queue
    // stops at the next one, refused again (one more each time, six times): 7 + 6.
    assert_eq!(l2.mshr_full_stalls, 7 + 6, "{l2:?}");
}

/// Reads of line `addr` by L1s `1..=4` at cycle 1000, after L1 0 warmed the L2 with it, on an
/// L2 of one bank: the L1 completions' ready cycles and the L2's stats.
fn four_reads_of_one_line(combine: bool) -> (Vec<u64>, CacheStats) {
    let mut cfg = two_level(5);
    cfg.l2.banks = 1;
    cfg.l2.combine_reads = combine;
    let mut h = fixed(&cfg, 50);
    let addr = 0x4000;
    h.submit(req(0, 0, addr, MemOp::Read, 0)).unwrap();
    run_dry(&mut h);
    for l1 in 1..=4 {
        let r = req(1000, l1, addr, MemOp::Read, l1 as u64);
        assert_eq!(h.submit(r).unwrap(), Outcome::Pending);
    }
    let mut ready: Vec<u64> = run_dry(&mut h).iter().map(|c| c.ready).collect();
    ready.sort_unstable();
    (ready, h.stats(5).clone())
}

#[test]
fn combined_reads_share_one_bank_lookup() {
    // Without combining the four reads take the bank one after another.
    let (apart, s) = four_reads_of_one_line(false);
    let a = apart[0];
    assert_eq!(apart, [a, a + 1, a + 2, a + 3]);
    assert_eq!((s.reads, s.read_hits, s.combined), (5, 4, 0));
    assert_eq!(s.bank_wait.sum, 1 + 2 + 3);
    // With it, the first read has the bank at once; the second waits a cycle and the other
    // two join its lookup instead of queueing behind it.
    let (together, s) = four_reads_of_one_line(true);
    assert_eq!(together, [a, a + 1, a + 1, a + 1]);
    assert_eq!((s.reads, s.read_hits, s.combined), (5, 4, 2));
    assert_eq!(s.bank_wait.sum, 1 + 1 + 1);
}

#[test]
fn combined_misses_merge_into_one_mshr() {
    let mut cfg = two_level(4);
    cfg.l2.banks = 1;
    cfg.l2.combine_reads = true;
    let mut h = fixed(&cfg, 50);
    for l1 in 0..4 {
        h.submit(req(0, l1, 0x8000, MemOp::Read, l1 as u64))
            .unwrap();
    }
    let c = run_dry(&mut h);
    assert_eq!(c.len(), 4);
    assert!(c.iter().all(|x| x.ready == c[0].ready), "{c:?}");
    let s = h.stats(4);
    // One lookup misses and allocates; the second misses and merges; two join the second.
    assert_eq!(
        (s.read_misses, s.mshr_merges, s.combined),
        (4, 3, 2),
        "{s:?}"
    );
    assert_eq!(h.memory().accepted.iter().sum::<u64>(), 1);
}

#[test]
fn queued_misses_do_not_take_bank_cycles_again() {
    let mut cfg = two_level(4);
    cfg.l2.banks = 1;
    cfg.l2.mshrs = 1;
    let mut h = fixed(&cfg, 50);
    // Four misses to four lines: the L2's one MSHR takes the first, three queue.
    for l1 in 0..4 {
        let addr = 0x10_0000 * (l1 as u64 + 1);
        h.submit(req(0, l1, addr, MemOp::Read, l1 as u64)).unwrap();
    }
    let c = run_dry(&mut h);
    let order: Vec<u64> = c.iter().map(|c| c.tag).collect();
    assert_eq!(order, [0, 1, 2, 3]);
    let s = h.stats(4);
    // Each access asked its bank once, on arrival (waits 0, 1, 2, 3); being offered again
    // from the queue used no bank cycle.
    assert_eq!(
        (s.bank_wait.count, s.bank_wait.sum),
        (4, 1 + 2 + 3),
        "{s:?}"
    );
    // Refused on arrival (three), then once per fill while others wait (two).
    assert_eq!(s.mshr_full_stalls, 3 + 2);
}
