//! The frame's time series (`sim.timeline_cycles`): both engines give the same rows, whole
//! frames and frames stopped by a cycle limit, and the rows add up to the frame's totals.

mod support;

use rtsim_trace::WorkloadKind;
use rtsim_trax::timeline::Timeline;
use rtsim_trax::{Engine, Output};
use support::*;

/// Every count column summed over the rows equals the report's total.
fn assert_adds_up(o: &Output) {
    let tl = o.timeline.as_ref().expect("a time series");
    let r = &o.report;
    let sum = |c: &str| tl.column(c).unwrap().iter().sum::<u64>();
    assert_eq!(sum("instructions"), r.instructions.total, "instructions");
    assert_eq!(sum("l1_accesses"), r.l1.accesses, "L1 accesses");
    assert_eq!(sum("l1_misses"), r.l1.misses, "L1 misses");
    assert_eq!(sum("l2_accesses"), r.l2.accesses, "L2 accesses");
    assert_eq!(sum("dram_reads"), r.dram.reads, "DRAM reads");
    assert_eq!(sum("dram_writes"), r.dram.writes, "DRAM writes");
    let cycles: u64 = tl.rows.iter().map(|row| row.cycles).sum();
    assert_eq!(cycles, r.cycles, "the rows cover the frame");
    assert_eq!(tl.rows[0].start, 0);
    for w in tl.rows.windows(2) {
        assert_eq!(w[0].start + w[0].cycles, w[1].start, "rows are contiguous");
        assert_eq!(w[0].cycles, tl.every, "only the last row is short");
    }
}

/// The rows of two runs are the same, with the first differing row named.
fn assert_same_rows(a: &Timeline, b: &Timeline) {
    assert_eq!(a.columns, b.columns);
    assert_eq!(a.rows.len(), b.rows.len(), "rows");
    for (x, y) in a.rows.iter().zip(&b.rows) {
        assert_eq!(x, y, "row at cycle {}", x.start);
    }
}

#[test]
fn engines_give_the_same_time_series() {
    let Some(w) = world("cornell", 16, 12) else {
        return;
    };
    let p = params(&w, WorkloadKind::Path, 1);
    let cfg = chip(2, 8);
    for (every, limit) in [(500, None), (137, None), (1000, Some(4321)), (1, Some(700))] {
        let f = simulate_timeline(&w, &p, &cfg, Engine::Fast, limit, every, 1);
        let r = simulate_timeline(&w, &p, &cfg, Engine::Reference, limit, every, 1);
        assert_eq!(f.report.cycles, r.report.cycles);
        assert_same_rows(f.timeline.as_ref().unwrap(), r.timeline.as_ref().unwrap());
        if limit.is_none() {
            assert_adds_up(&f);
            assert_adds_up(&r);
        } else {
            // Stopped: the rows hold the instructions issued before the limit, which is the
            // reference's total (the fast engine's report also counts those it booked past
            // the limit).
            let sum: u64 = f
                .timeline
                .as_ref()
                .unwrap()
                .column("instructions")
                .unwrap()
                .iter()
                .sum();
            assert_eq!(sum, r.report.instructions.total);
        }
        let tl = f.timeline.as_ref().unwrap();
        assert!(
            tl.column("instructions")
                .unwrap()
                .iter()
                .filter(|&&n| n > 0)
                .count()
                > 1,
            "work spread over several rows"
        );
        // The time series changes nothing else.
        let plain = simulate_until(&w, &p, &cfg, Engine::Fast, &all_pixels(&w), limit);
        assert_eq!(plain.report.issue, f.report.issue);
        assert_eq!(plain.report.cycles, f.report.cycles);
        assert!(plain.timeline.is_none());
    }
}

#[test]
fn host_threads_do_not_change_the_time_series() {
    let Some(w) = world("cornell", 16, 12) else {
        return;
    };
    let p = params(&w, WorkloadKind::Primary, 1);
    let cfg = chip(4, 4);
    let one = simulate_timeline(&w, &p, &cfg, Engine::Fast, None, 250, 1);
    let four = simulate_timeline(&w, &p, &cfg, Engine::Fast, None, 250, 4);
    assert_eq!(one.timeline, four.timeline);
    // The CSV: a header naming every column and one line per row.
    let csv = one.timeline.as_ref().unwrap().to_csv();
    let mut lines = csv.lines();
    assert_eq!(
        lines.next().unwrap(),
        "cycle,cycles,issue_rate,instructions,atomic_grants,l1_accesses,l1_misses,l2_accesses,\
         l2_misses,dram_reads,dram_writes,dram_row_hits,dram_column_accesses"
    );
    assert_eq!(lines.count(), one.timeline.as_ref().unwrap().rows.len());
}
