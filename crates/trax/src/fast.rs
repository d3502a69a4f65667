//! The fast engine: TPs run ahead through their instructions, booking issue slots in per-TM
//! calendars, and synchronise with the rest of the chip only at data-cache and atomic
//! accesses and at returning misses, which are processed in global time order.
//!
//! Why it equals the cycle-by-cycle reference (`docs/TRAX.md`, "Timing rules"): a TP's
//! instructions between two synchronisation events arbitrate with the key of the first event
//! (its cycle; ties by TP index). The engine handles events in (cycle, TP) order, and a TP
//! handling an event at cycle `k` books, right then, every instruction up to its next access
//! or to an operand whose miss has not returned — all at cycles ≥ `k`. So whenever a TP books
//! a slot, every booking with a smaller key is already in the calendar and none with a larger
//! key is: the slot it gets is the first whose unit and fetch bank have room after the
//! higher-priority TPs — what the reference grants cycle by cycle in key order. Accesses reach
//! the caches at their issue cycles in (cycle, TP) order, as in the reference. A TP waiting on
//! memory or a long-latency unit costs nothing until it can act.

use crate::chip::{Chip, ChipError, Offered, Wait};
use crate::stats::Stall;
use std::cmp::Reverse;
use std::collections::BinaryHeap;

const EMPTY: u64 = u64::MAX;

/// Per-TM rings of issue-slot counts: one row per cycle — its cycle (8 bytes), then a count
/// per unit class and per instruction-cache bank — reused once its cycle is past.
#[derive(Debug)]
struct Calendar {
    tms: usize,
    /// Counts per row.
    width: usize,
    /// Bytes per row (the cycle tag, the counts, padding to 8).
    stride: usize,
    slots: usize,
    data: Vec<u8>,
}

const TAG: usize = 8;

impl Calendar {
    fn new(tms: usize, width: usize, slots: usize) -> Self {
        let stride = (TAG + width).next_multiple_of(8);
        let mut c = Calendar {
            tms,
            width,
            stride,
            slots,
            data: vec![0; tms * slots * stride],
        };
        for i in 0..tms * slots {
            c.set_tag(i, EMPTY);
        }
        c
    }

    #[inline(always)]
    fn tag(&self, i: usize) -> u64 {
        let at = i * self.stride;
        u64::from_le_bytes(self.data[at..at + TAG].try_into().expect("8 bytes"))
    }

    #[inline(always)]
    fn set_tag(&mut self, i: usize, c: u64) {
        let at = i * self.stride;
        self.data[at..at + TAG].copy_from_slice(&c.to_le_bytes());
    }

    /// Double the ring (a booking reached further ahead than it holds); live rows move to
    /// their new places.
    fn grow(&mut self) {
        let mut bigger = Calendar::new(self.tms, self.width, self.slots * 2);
        for tm in 0..self.tms {
            for s in 0..self.slots {
                let old = tm * self.slots + s;
                let c = self.tag(old);
                if c == EMPTY {
                    continue;
                }
                let new = tm * bigger.slots + (c as usize & (bigger.slots - 1));
                let (o, n) = (old * self.stride, new * bigger.stride);
                bigger.data[n..n + self.stride].copy_from_slice(&self.data[o..o + self.stride]);
            }
        }
        *self = bigger;
    }

    /// The counts of cycle `c` in TM `tm` (cleared if the row held an older cycle; `now` is
    /// the engine's current cycle: rows before it are dead).
    #[inline(always)]
    fn row(&mut self, tm: usize, c: u64, now: u64) -> &mut [u8] {
        loop {
            let i = tm * self.slots + (c as usize & (self.slots - 1));
            let tag = self.tag(i);
            if tag != c {
                if tag != EMPTY && tag >= now {
                    self.grow();
                    continue;
                }
                self.set_tag(i, c);
                let at = i * self.stride;
                self.data[at + TAG..at + self.stride].fill(0);
            }
            let at = i * self.stride + TAG;
            return &mut self.data[at..at + self.width];
        }
    }
}

/// TP events by cycle: a ring of per-cycle bitsets over TPs (so a cycle's TPs come out in
/// index order), and a heap for events beyond the ring.
#[derive(Debug)]
struct Wheel {
    words: usize,
    slots: usize,
    tags: Vec<u64>,
    bits: Vec<u64>,
    /// Per slot, one bit per word of `bits` that is not zero.
    summary: Vec<u64>,
    sum_words: usize,
    count: Vec<u32>,
    /// One bit per slot: it holds events.
    busy: Vec<u64>,
    far: BinaryHeap<Reverse<(u64, u32)>>,
    now: u64,
}

impl Wheel {
    fn new(tps: usize, slots: usize) -> Self {
        let words = tps.div_ceil(64);
        let sum_words = words.div_ceil(64);
        Wheel {
            words,
            slots,
            tags: vec![EMPTY; slots],
            bits: vec![0; slots * words],
            summary: vec![0; slots * sum_words],
            sum_words,
            count: vec![0; slots],
            busy: vec![0; slots.div_ceil(64)],
            far: BinaryHeap::new(),
            now: 0,
        }
    }

    #[inline]
    fn add(&mut self, c: u64, tp: usize) {
        debug_assert!(c >= self.now);
        if c - self.now >= self.slots as u64 {
            self.far.push(Reverse((c, tp as u32)));
            return;
        }
        let s = c as usize & (self.slots - 1);
        if self.tags[s] != c {
            debug_assert_eq!(self.count[s], 0);
            self.tags[s] = c;
        }
        let wi = tp / 64;
        let w = &mut self.bits[s * self.words + wi];
        let b = 1u64 << (tp % 64);
        if *w & b == 0 {
            *w |= b;
            self.summary[s * self.sum_words + wi / 64] |= 1 << (wi % 64);
            self.count[s] += 1;
            self.busy[s / 64] |= 1 << (s % 64);
        }
    }

    /// The earliest cycle with events.
    fn next(&self) -> Option<u64> {
        let far = self.far.peek().map(|Reverse((c, _))| *c);
        let start = self.now as usize & (self.slots - 1);
        let n = self.busy.len();
        for k in 0..=n {
            let wi = (start / 64 + k) % n;
            let mut w = self.busy[wi];
            if k == 0 {
                w &= !0u64 << (start % 64);
            } else if k == n {
                w &= !(!0u64 << (start % 64));
            }
            if w != 0 {
                let s = wi * 64 + w.trailing_zeros() as usize;
                let c = self.tags[s];
                return Some(far.map_or(c, |f| f.min(c)));
            }
        }
        far
    }

    /// Move to cycle `c` and take its TPs, in index order.
    fn take(&mut self, c: u64, out: &mut Vec<u32>) {
        self.now = c;
        out.clear();
        while let Some(&Reverse((fc, tp))) = self.far.peek() {
            if fc > c {
                break;
            }
            debug_assert_eq!(fc, c, "an event was left behind");
            self.far.pop();
            self.add(c, tp as usize);
        }
        let s = c as usize & (self.slots - 1);
        if self.tags[s] != c || self.count[s] == 0 {
            return;
        }
        for k in 0..self.sum_words {
            let mut words = std::mem::take(&mut self.summary[s * self.sum_words + k]);
            while words != 0 {
                let wi = k * 64 + words.trailing_zeros() as usize;
                words &= words - 1;
                let mut b = std::mem::take(&mut self.bits[s * self.words + wi]);
                while b != 0 {
                    out.push((wi * 64) as u32 + b.trailing_zeros());
                    b &= b - 1;
                }
            }
        }
        self.count[s] = 0;
        self.busy[s / 64] &= !(1 << (s % 64));
    }
}

/// Progress callback: called now and then with the chip and the current cycle.
pub(crate) type Progress<'p> = &'p mut dyn FnMut(&Chip<'_>, u64);

/// Run the frame (to its end, or to `limit` cycles); returns the last cycle processed.
pub fn run(
    chip: &mut Chip<'_>,
    limit: Option<u64>,
    progress: Progress<'_>,
) -> Result<u64, ChipError> {
    let n = chip.tps();
    let mut cal = Calendar::new(chip.cfg.tms as usize, chip.row_width, 256);
    let mut wheel = Wheel::new(n, 1024);
    for tp in 0..n {
        wheel.add(0, tp);
    }
    let mut batch: Vec<u32> = Vec::with_capacity(n);
    let mut offers: Vec<(u32, u64, u32)> = Vec::with_capacity(n);
    let mut done = std::mem::take(&mut chip.completions);
    let mut last = 0;
    let mut ticks = 0u32;
    loop {
        let t_tp = wheel.next();
        let t_mem = chip.hier.next_event();
        let t = match (t_tp, t_mem) {
            (None, None) => break,
            (a, b) => a.unwrap_or(u64::MAX).min(b.unwrap_or(u64::MAX)),
        };
        if limit.is_some_and(|l| t >= l) {
            break;
        }
        wheel.now = t;
        if t_mem.is_some_and(|m| m <= t) {
            chip.hier.advance_to(t)?;
            chip.hier.drain_completions(&mut done);
            for c in done.drain(..) {
                debug_assert_eq!(c.ready, t);
                let tp = chip.complete(&c);
                let core = &chip.cores[tp];
                if core.wait == Wait::Blocked {
                    let i = (core.run.seg.start + core.ip) as usize;
                    if core.pending & chip.dec[i].regs == 0 {
                        wheel.add(t, tp);
                    }
                }
            }
        }
        wheel.take(t, &mut batch);
        // First the cycle's accesses, TM by TM, oldest first (by key, ties by TP index); then
        // every TP that resumes now — accepted or woken by a returned miss — books ahead with
        // key `t` in TP order (`docs/TRAX.md`). A resuming TP's access in this cycle is
        // offered in its turn: its key, `t`, is the largest of the cycle.
        offers.clear();
        offers.extend(
            batch
                .iter()
                .filter(|&&tp| chip.cores[tp as usize].wait == Wait::Access)
                .map(|&tp| {
                    let c = &chip.cores[tp as usize];
                    (c.tm, c.key, tp)
                }),
        );
        // The batch is in TP order, so TM by TM: order each TM's run by key (a few TPs:
        // insertion sort).
        insertion_sort(&mut offers);
        for &(_, _, tp) in &offers {
            offer(chip, &mut wheel, tp as usize, t)?;
        }
        for &tp in &batch {
            resume(chip, &mut cal, &mut wheel, tp as usize, t)?;
        }
        last = t;
        ticks += 1;
        if ticks & 0x3FFF == 0 {
            progress(chip, t);
        }
        if chip.live == 0 && t_tp.is_none() && wheel.next().is_none() {
            // Every TP has halted; what remains in the memory system is drained by the caller.
            break;
        }
    }
    chip.completions = done;
    Ok(last)
}

/// Sort nearly sorted, mostly tiny runs.
fn insertion_sort<T: Ord + Copy>(v: &mut [T]) {
    for i in 1..v.len() {
        let x = v[i];
        let mut j = i;
        while j > 0 && v[j - 1] > x {
            v[j] = v[j - 1];
            j -= 1;
        }
        v[j] = x;
    }
}

/// Offer TP `tp`'s pending access at cycle `t`; refused, it waits for the retry cycle.
fn offer(chip: &mut Chip<'_>, wheel: &mut Wheel, tp: usize, t: u64) -> Result<(), ChipError> {
    debug_assert_eq!(chip.cores[tp].access_at, t);
    let i = (chip.cores[tp].run.seg.start + chip.cores[tp].ip) as usize;
    if let Offered::Busy { retry_at } = chip.access(tp, i, t)? {
        chip.cores[tp].access_at = retry_at;
        wheel.add(retry_at, tp);
    }
    Ok(())
}

/// TP `tp` resumes at `t` (its access was accepted, or a miss it waited for returned, or the
/// frame starts): it books ahead with key `t`.
fn resume(
    chip: &mut Chip<'_>,
    cal: &mut Calendar,
    wheel: &mut Wheel,
    tp: usize,
    t: u64,
) -> Result<(), ChipError> {
    let core = &mut chip.cores[tp];
    match core.wait {
        // Refused this cycle: it waits for its retry.
        Wait::Access | Wait::Halted => return Ok(()),
        Wait::Ready | Wait::Blocked => {
            core.key = t;
            core.wait = Wait::Ready;
        }
    }
    run_ahead(chip, cal, wheel, tp, t)
}

/// Book TP `tp`'s instructions from its current one, with priority key `t`, up to its next
/// access (scheduled as an event, or offered at once if it falls in cycle `t`) or an operand
/// whose miss has not returned.
fn run_ahead(
    chip: &mut Chip<'_>,
    cal: &mut Calendar,
    wheel: &mut Wheel,
    tp: usize,
    t: u64,
) -> Result<(), ChipError> {
    let tm = chip.cores[tp].tm as usize;
    let col = chip.cores[tp].icache_col as usize;
    loop {
        let Some(i) = chip.current(tp) else {
            return Ok(());
        };
        let d = chip.dec[i];
        let core = &mut chip.cores[tp];
        if core.pending & d.regs != 0 {
            core.wait = Wait::Blocked;
            return Ok(());
        }
        let s = core.next_issue;
        let e = chip.operands_ready(tp, i, s);
        debug_assert!(e >= t, "booking in the past: {e} < {t}");
        // The first cycle from `e` whose unit (if any) and fetch bank have room.
        let unit = d.class.is_unit();
        let cls = d.class as usize;
        let cap = if unit { chip.cap[cls] } else { 0 };
        let fetch_cap = chip.fetch_cap;
        let bank = col + d.bank as usize;
        let mut c = e;
        let (mut unit_busy, mut fetch_busy) = (0u64, 0u64);
        loop {
            let row = cal.row(tm, c, t);
            if unit && row[cls] >= cap {
                unit_busy += 1;
            } else if row[bank] >= fetch_cap {
                fetch_busy += 1;
            } else {
                if unit {
                    row[cls] += 1;
                }
                row[bank] += 1;
                break;
            }
            c += 1;
        }
        if unit_busy + fetch_busy > 0 {
            let st = &mut chip.issue;
            st.stall[Stall::Unit as usize] += unit_busy;
            st.stall[Stall::Fetch as usize] += fetch_busy;
            if unit {
                st.unit_busy[cls] += unit_busy;
            }
        }
        if !d.class.is_sync() {
            chip.retire_issue(tp, i, c);
            continue;
        }
        let core = &mut chip.cores[tp];
        core.wait = Wait::Access;
        core.access_at = c;
        if c > t {
            wheel.add(c, tp);
            return Ok(());
        }
        // The access falls in the current cycle: offer it now, in this TP's turn.
        match chip.access(tp, i, t)? {
            Offered::Accepted => {
                chip.cores[tp].key = t;
            }
            Offered::Busy { retry_at } => {
                chip.cores[tp].access_at = retry_at;
                wheel.add(retry_at, tp);
                return Ok(());
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_wheel_returns_cycles_in_order_and_tps_in_index_order() {
        let mut w = Wheel::new(200, 8);
        w.add(5, 130);
        w.add(5, 3);
        w.add(2, 199);
        w.add(40, 7); // beyond the ring
        w.add(5, 3); // twice is once
        let mut out = Vec::new();
        assert_eq!(w.next(), Some(2));
        w.take(2, &mut out);
        assert_eq!(out, [199]);
        assert_eq!(w.next(), Some(5));
        w.take(5, &mut out);
        assert_eq!(out, [3, 130]);
        assert_eq!(w.next(), Some(40));
        w.add(9, 1);
        assert_eq!(w.next(), Some(9));
        w.take(9, &mut out);
        w.take(40, &mut out);
        assert_eq!(out, [7]);
        assert_eq!(w.next(), None);
        // Wrapping around the ring.
        w.add(46, 0);
        w.add(41, 2);
        assert_eq!(w.next(), Some(41));
    }

    #[test]
    fn the_calendar_grows_instead_of_overwriting_a_live_row() {
        let mut c = Calendar::new(2, 3, 4);
        c.row(1, 10, 10)[0] = 7;
        c.row(1, 13, 10)[1] = 1;
        // Cycle 14 maps onto cycle 10's slot, still live at now = 10: the ring grows.
        c.row(1, 14, 10)[2] = 2;
        assert_eq!(c.slots, 8);
        assert_eq!(c.row(1, 10, 10)[0], 7);
        assert_eq!(c.row(1, 13, 10)[1], 1);
        assert_eq!(c.row(1, 14, 10)[2], 2);
        // A dead row is reused and cleared.
        assert_eq!(c.row(1, 18, 11)[0], 0);
    }
}
