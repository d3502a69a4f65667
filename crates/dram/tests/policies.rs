//! The controller policies of issue 12, each checked against its expected timing: write drain
//! that does not close rows queued reads need, the admission delay, batched refresh, per-bank
//! command queues, USIMM's FCFS, DRAMsim3's write buffer and its round-robin bank arbitration.

mod common;

use common::*;
use rtsim_core::{MemCompletion, MemOp, MemoryPort};
use rtsim_dram::DramConfig;
use rtsim_dram::config::{BankArbitration, SchedulerKind, WriteDrainKind};
use rtsim_dram::trace::Pattern;

fn finish_of(out: &[MemCompletion], id: u64) -> u64 {
    out.iter().find(|c| c.id == id).unwrap().finish
}

/// The three-request case of issue 12 on gddr5-trax (memory cycles at 2 GHz, requester at
/// 1 GHz): a read to row 0 of bank 0 at requester cycle 0, then two writes to row 1 of the same
/// bank at requester cycle 1 (memory cycle 2), write queue 2, so the writes start a drain while
/// the read's row is open but not yet read.
fn three_requests(policy: WriteDrainKind) -> (Vec<MemCompletion>, u64) {
    let mut c = config("gddr5-trax");
    c.refresh.enabled = false;
    c.controller.write_queue = 2;
    c.controller.write_high_watermark = 2;
    c.controller.write_low_watermark = 1;
    c.controller.write_drain = policy;
    let mut d = dram(&c);
    let r0 = addr(&d, 0, 0, 0, 0, 0);
    d.try_enqueue(req(1, r0, MemOp::Read, 0)).unwrap();
    d.advance_to(0);
    for (id, col) in [(2, 0), (3, 1)] {
        let w = addr(&d, 0, 0, 0, 1, col);
        d.try_enqueue(req(id, w, MemOp::Write, 1)).unwrap();
    }
    let out = run_to_idle(&mut d);
    assert_legal(&d);
    let s = d.stats();
    (out, s.activates)
}

#[test]
fn write_drain_does_not_close_a_row_a_queued_read_needs() {
    // gddr5-trax: tRCD 28, CL 28, burst 4, tRAS 70, tRP 28, CWL 13, tCCD 4 (memory cycles).
    // protect-rows: ACT row 0 at 0; the drain starts at 2, but the open row is the read's, so
    // the read goes first: RD at tRCD = 28, data done at 28 + 28 + 4 = 60 (the unloaded
    // closed-bank latency). Then PRE at tRAS = 70, ACT row 1 at 98, WR at 126 and 130, done at
    // 126 + 13 + 4 = 143 and 147. In requester cycles (1 GHz): 30, 72 and 74.
    let (out, acts) = three_requests(WriteDrainKind::ProtectRows);
    assert_eq!(finish_of(&out, 1), 30);
    assert_eq!(finish_of(&out, 2), 72);
    assert_eq!(finish_of(&out, 3), 74);
    assert_eq!(acts, 2);

    // writes-only (the old model): the write's PRE at 70 closes row 0 unused; ACT row 1 at 98,
    // WR at 126; one write left <= low watermark 1 with a read waiting ends the drain, so the
    // read's PRE waits only for write recovery, 126 + 13 + 4 + 30 (tWR) = 173, ACT at 201, RD
    // at 229, done at 261 = requester 131; the second write needs row 1 again afterwards.
    let (out, acts) = three_requests(WriteDrainKind::WritesOnly);
    assert_eq!(finish_of(&out, 1), 131);
    assert_eq!(finish_of(&out, 2), 72);
    assert_eq!(acts, 4);

    // mixed (DRAMsim3): the read's row hit is served with the writes, as with protect-rows.
    let (out, acts) = three_requests(WriteDrainKind::Mixed);
    assert_eq!(finish_of(&out, 1), 30);
    assert_eq!(finish_of(&out, 3), 74);
    assert_eq!(acts, 2);
}

/// On random mixed traffic the read-protecting drain opens fewer rows that are closed before
/// use, and fewer rows in all, than the old writes-only drain.
#[test]
fn protected_drain_opens_fewer_unused_rows() {
    let run = |policy| {
        let mut c = config("ddr4-3200");
        c.check = false;
        c.controller.write_drain = policy;
        let mut d = dram(&c);
        let cap = d.spec().org.capacity_bytes;
        let st = run_synthetic(&mut d, Pattern::Random, 40_000, 0.7, 0, cap, 3).stats;
        (st.activates, st.unused_activates())
    };
    let (old_acts, old_unused) = run(WriteDrainKind::WritesOnly);
    let (new_acts, new_unused) = run(WriteDrainKind::ProtectRows);
    // What remains are rows opened for writes when the drain ends, and refresh.
    assert!(
        new_unused * 4 < old_unused,
        "unused rows: {new_unused} (protect-rows) vs {old_unused} (writes-only)"
    );
    assert!(new_acts < old_acts, "{new_acts} vs {old_acts}");
}

fn unloaded_read(c: &DramConfig) -> u64 {
    let mut d = dram(c);
    let a = addr(&d, 0, 0, 3, 5, 0);
    single(&mut d, req(1, a, MemOp::Read, 10)).finish
}

/// The admission delay postpones a request's first command by exactly that many memory
/// cycles: with delay 2 the ACT is illegal one cycle early (the read would finish one cycle
/// sooner) and legal on time.
#[test]
fn admission_delay_postpones_the_first_command() {
    let mut c = config("ddr4-3200");
    c.refresh.enabled = false;
    // Requester clock = memory clock, so finish cycles are memory cycles.
    let mhz = c.timing.clock_mhz;
    let base = {
        let mut d = dram_at(&c, mhz);
        let a = addr(&d, 0, 0, 3, 5, 0);
        single(&mut d, req(1, a, MemOp::Read, 10)).finish
    };
    let [_, closed, _] = dram_at(&c, mhz).spec().unloaded_read_latency();
    assert_eq!(base, 10 + closed);
    for delay in [1u32, 2, 7] {
        c.controller.admission_delay = delay;
        let mut d = dram_at(&c, mhz);
        let a = addr(&d, 0, 0, 3, 5, 0);
        let f = single(&mut d, req(1, a, MemOp::Read, 10)).finish;
        assert_eq!(f, base + u64::from(delay), "delay {delay}");
        assert_legal(&d);
    }
    let _ = unloaded_read;
}

/// Batched refresh: with batch 8 the rank is refreshed eight times back to back every
/// 8 × tREFI (the k-th REF of a batch tRFC after the previous one), and the count over a run
/// is still time / tREFI.
#[test]
fn batched_refresh_issues_eight_refs_every_eight_trefi() {
    for batch in [1u32, 8] {
        let mut c = config("ddr3-1600");
        c.organisation.ranks = 1;
        c.refresh.batch = batch;
        let mut d = dram_at(&c, c.timing.clock_mhz);
        let refi = u64::from(c.timing.t_refi);
        let rfc = u64::from(c.timing.t_rfc);
        // Just before the first batch is due: nothing refreshed yet.
        let due = refi * u64::from(batch);
        d.advance_to(due - 1);
        assert_eq!(d.stats().refreshes, 0, "batch {batch}");
        // The k-th REF of the batch issues at due + k·tRFC: not one cycle earlier.
        for k in 1..=u64::from(batch) {
            let at = due + (k - 1) * rfc;
            d.advance_to(at - 1);
            assert_eq!(d.stats().refreshes, k - 1, "batch {batch}, REF {k} early");
            d.advance_to(at);
            assert_eq!(d.stats().refreshes, k, "batch {batch}, REF {k} on time");
        }
        // Long run: time / tREFI.
        d.advance_to(100 * refi - 1);
        assert_eq!(
            d.stats().refreshes,
            96 + u64::from(batch == 1) * 3,
            "batch {batch}"
        );
        assert_legal(&d);
    }
}

/// Command queues: each bank holds at most `depth` requests besides the read queue, so a
/// channel accepts `read_queue + banks × depth` reads to distinct banks before refusing.
#[test]
fn command_queues_hold_depth_requests_per_bank() {
    let mut c = config("ddr3-1600");
    c.refresh.enabled = false;
    c.controller.read_queue = 4;
    c.controller.command_queue_depth = 2;
    let mut d = dram_at(&c, c.timing.clock_mhz);
    let banks = d.spec().org.banks_per_rank * d.spec().org.ranks;
    // One per cycle moves from the read queue into a command queue; offer a read per cycle
    // to rows of bank 0 only: bank 0's queue fills at 2, then the read queue at 4.
    let mut accepted = 0u64;
    for t in 0..40u64 {
        let a = addr(&d, 0, 0, 0, 100 + t as u32, 0);
        if t > 0 {
            d.advance_to(t - 1);
        }
        if d.try_enqueue(req(t, a, MemOp::Read, t)).is_ok() {
            accepted += 1;
        }
        if accepted == 6 {
            break;
        }
    }
    // Six accepted (4 + 2) while bank 0's first read is still far from done (tRCD + CL).
    assert_eq!(accepted, 6);
    let a = addr(&d, 0, 0, 0, 999, 0);
    let now = d.now().unwrap();
    assert!(d.try_enqueue(req(99, a, MemOp::Read, now + 1)).is_err());
    run_to_idle(&mut d);
    assert_legal(&d);
    let _ = banks;
}

/// USIMM's FCFS issues the first issuable command in arrival order: a younger request's row
/// hit goes before an older request's ACT that tRRD still blocks, which plain FCFS (oldest
/// ready offer per bank) also allows, but within one bank a younger hit may also overtake an
/// older conflict whose PRE cannot issue yet (tRAS), which plain FCFS does not.
#[test]
fn usimm_fcfs_takes_the_first_issuable_command_in_arrival_order() {
    let run = |sched| {
        let mut c = config("ddr3-1600");
        c.refresh.enabled = false;
        c.controller.scheduler = sched;
        let mhz = c.timing.clock_mhz;
        let mut d = dram_at(&c, mhz);
        // Open row 1 of bank 0, then queue an older conflict (row 2) and a younger hit (row 1).
        let hit0 = addr(&d, 0, 0, 0, 1, 0);
        d.try_enqueue(req(1, hit0, MemOp::Read, 0)).unwrap();
        d.advance_to(0);
        d.try_enqueue(req(2, addr(&d, 0, 0, 0, 2, 0), MemOp::Read, 1))
            .unwrap();
        d.try_enqueue(req(3, addr(&d, 0, 0, 0, 1, 1), MemOp::Read, 1))
            .unwrap();
        let out = run_to_idle(&mut d);
        assert_legal(&d);
        (finish_of(&out, 2), finish_of(&out, 3))
    };
    let (conflict_fcfs, hit_fcfs) = run(SchedulerKind::Fcfs);
    let (conflict_usimm, hit_usimm) = run(SchedulerKind::UsimmFcfs);
    // FCFS: the conflict goes first (PRE at tRAS), the hit needs its row again afterwards.
    assert!(hit_fcfs > conflict_fcfs);
    // USIMM's FCFS: the younger hit's RD is issuable while the older one's PRE waits for tRAS.
    assert!(hit_usimm < conflict_usimm);
    assert!(hit_usimm < hit_fcfs);
}

/// Round robin across banks (DRAMsim3): three reads queued together at cycle 0 for closed
/// banks 3, 1 and 2 (oldest first). ddr3-1600, requester at the memory clock: ACTs tRRD = 6
/// apart at 0, 6 and 12, RDs tRCD = 11 later, data CL + burst = 15 after the RD, so the reads
/// finish at 26, 32 and 38 in the order their ACTs went. By priority (FR-FCFS: the oldest
/// ready) that is arrival order; round robin starts at bank 0 and takes the first bank with a
/// ready offer after the last one served: banks 1, 2, 3.
#[test]
fn round_robin_serves_the_banks_in_turn() {
    let run = |arb| {
        let mut c = config("ddr3-1600");
        c.refresh.enabled = false;
        c.controller.bank_arbitration = arb;
        let mhz = c.timing.clock_mhz;
        let mut d = dram_at(&c, mhz);
        for (id, bank) in [(1, 3), (2, 1), (3, 2)] {
            let a = addr(&d, 0, 0, bank, 5, 0);
            d.try_enqueue(req(id, a, MemOp::Read, 0)).unwrap();
        }
        let out = run_to_idle(&mut d);
        assert_legal(&d);
        [1, 2, 3].map(|id| finish_of(&out, id))
    };
    assert_eq!(run(BankArbitration::Priority), [26, 32, 38]);
    assert_eq!(run(BankArbitration::RoundRobin), [38, 26, 32]);
}

/// DRAMsim3's write buffer (`write_drain = dramsim3`): a drain moves into the command queues
/// as many writes as the write queue held when it started, one per cycle, and ends; it does not
/// wait for them to issue. Four writes and four reads to eight banks at cycle 0, write queue 4 =
/// high watermark: the drain starts at 0 and moves the writes at 0, 1, 2 and 3, so it lasts 3
/// cycles. With `mixed` the drain lasts until the write queue (counting the writes in command
/// queues) is down to the low watermark 2, i.e. until two writes have issued, after an ACT and
/// tRCD (11) at least.
#[test]
fn dramsim3_drain_moves_the_queued_writes_and_ends() {
    let run = |kind| {
        let mut c = config("ddr3-1600");
        c.refresh.enabled = false;
        c.controller.command_queue_depth = 8;
        c.controller.write_queue = 4;
        c.controller.write_high_watermark = 4;
        c.controller.write_low_watermark = 2;
        c.controller.write_drain = kind;
        let mhz = c.timing.clock_mhz;
        let mut d = dram_at(&c, mhz);
        for bank in 0..8u32 {
            let op = if bank < 4 { MemOp::Write } else { MemOp::Read };
            let a = addr(&d, 0, 0, bank, 7, 0);
            d.try_enqueue(req(u64::from(bank), a, op, 0)).unwrap();
        }
        let out = run_to_idle(&mut d);
        assert_legal(&d);
        assert_eq!(out.len(), 8);
        let s = d.stats();
        (s.write_drain_episodes, s.write_drain_cycles)
    };
    assert_eq!(run(WriteDrainKind::Dramsim3), (1, 3));
    let (episodes, cycles) = run(WriteDrainKind::Mixed);
    assert_eq!(episodes, 1);
    assert!(cycles > 11, "mixed drain lasted {cycles} cycles");
}

/// `write_drain = dramsim3` describes command queues: without them it is a configuration error.
#[test]
fn dramsim3_drain_needs_command_queues() {
    let mut c = config("ddr3-1600");
    c.controller.write_drain = WriteDrainKind::Dramsim3;
    let e = rtsim_dram::Dram::new(&c, rtsim_dram::Requester::mhz(800.0)).unwrap_err();
    assert!(
        e.to_string().contains("controller.command_queue_depth"),
        "{e}"
    );
}

/// Every issue-12 knob, alone and in the combinations that reproduce DRAMsim3 and USIMM, on
/// mixed random and row-local traffic across presets, in checking mode: every command is
/// re-validated by the independent checker (tPPD and the write rank switch included), no
/// request is lost, and refresh keeps its rate.
#[test]
fn issue_12_knobs_stay_legal_and_lose_nothing() {
    type Knob = fn(&mut DramConfig);
    let knobs: [(&str, Knob); 11] = [
        ("defaults", |_| {}),
        ("writes-only", |c| {
            c.controller.write_drain = WriteDrainKind::WritesOnly
        }),
        ("mixed", |c| {
            c.controller.write_drain = WriteDrainKind::Mixed
        }),
        ("admission 2", |c| c.controller.admission_delay = 2),
        ("refresh batch 8", |c| c.refresh.batch = 8),
        ("command queues 8", |c| c.controller.command_queue_depth = 8),
        ("usimm-fcfs", |c| {
            c.controller.scheduler = SchedulerKind::UsimmFcfs
        }),
        ("round-robin", |c| {
            c.controller.bank_arbitration = BankArbitration::RoundRobin
        }),
        ("command queues, mixed drain", |c| {
            c.controller.command_queue_depth = 8;
            c.controller.write_drain = WriteDrainKind::Mixed;
        }),
        ("DRAMsim3 settings", |c| {
            c.controller.read_queue = 32;
            c.controller.write_queue = 32;
            c.controller.write_high_watermark = 32;
            c.controller.write_low_watermark = 8;
            c.controller.command_queue_depth = 8;
            c.controller.write_drain = WriteDrainKind::Dramsim3;
            c.controller.bank_arbitration = BankArbitration::RoundRobin;
            c.controller.admission_delay = 2;
            c.controller.row_hit_cap = 3;
            c.timing.t_rtrs_w2w = Some(0);
        }),
        ("USIMM settings", |c| {
            c.controller.scheduler = SchedulerKind::UsimmFcfs;
            c.controller.protect_row_hits = false;
            c.controller.write_drain = WriteDrainKind::WritesOnly;
            c.controller.admission_delay = 1;
            c.refresh.batch = 8;
        }),
    ];
    for preset in ["ddr3-1600", "ddr4-3200", "gddr5-strata"] {
        for (name, knob) in knobs {
            for pattern in [Pattern::Random, Pattern::Stream] {
                let mut c = config(preset);
                // Two ranks everywhere, so that rank-switch rules bind.
                c.organisation.ranks = 2;
                knob(&mut c);
                let mut d = dram(&c);
                let cap = d.spec().org.capacity_bytes;
                let st = run_synthetic(&mut d, pattern, 2_000, 0.7, 0, cap, 11).stats;
                assert_legal(&d);
                let what = format!("{preset}, {name}, {pattern:?}");
                assert_eq!(st.reads_done + st.writes_done, 2_000, "{what}");
                assert_eq!(d.outstanding(), 0, "{what}");
                assert!(st.commands_checked > 0, "{what}");
            }
        }
    }
}
