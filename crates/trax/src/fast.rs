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

use crate::chip::{Chip, ChipError, Dec, Offered, Wait};
use crate::isa::{Class, UNIT_CLASSES};
use crate::source::Source;
use crate::stats::{IssueStats, Stall};
use std::cmp::Reverse;
use std::collections::BinaryHeap;

const EMPTY: u64 = u64::MAX;

/// Rings of per-cycle slot counts, one ring per *lane* (a TM's execution units, or one
/// instruction cache's banks): a row of `width` bytes per cycle, reused once its cycle is
/// past. No tags: each lane remembers the first cycle it has not yet cleared (`fresh`), and a
/// booking beyond it clears the rows in between (their slots held cycles already past).
#[derive(Debug)]
struct Ring {
    lanes: usize,
    /// Bytes per row (a power of two).
    width: usize,
    /// Rows per lane (a power of two).
    slots: usize,
    /// Bytes from one lane to the next: its rows and a cache line of padding, so that the
    /// same cycle's rows of different lanes do not all fall into the same few sets of the
    /// host's caches (a power-of-two stride would).
    lane_bytes: usize,
    /// Per lane: rows of cycles below this hold their counts; from it on, stale.
    fresh: Vec<u64>,
    data: Vec<u8>,
}

impl Ring {
    fn new(lanes: usize, counts: usize, slots: usize) -> Self {
        let width = counts.next_power_of_two();
        let lane_bytes = slots * width + 64;
        Ring {
            lanes,
            width,
            slots,
            lane_bytes,
            fresh: vec![0; lanes],
            data: vec![0; lanes * lane_bytes],
        }
    }

    /// Double the ring (a booking reached further ahead than it holds); live rows (cycles
    /// `now..fresh`) move to their new places.
    #[cold]
    fn grow(&mut self, now: u64) {
        let mut bigger = Ring::new(self.lanes, self.width, self.slots * 2);
        for lane in 0..self.lanes {
            let fresh = self.fresh[lane];
            for c in now..fresh {
                let o = self.at(lane, c);
                let n = bigger.at(lane, c);
                bigger.data[n..n + self.width].copy_from_slice(&self.data[o..o + self.width]);
            }
            bigger.fresh[lane] = fresh;
        }
        *self = bigger;
    }

    #[inline(always)]
    fn at(&self, lane: usize, c: u64) -> usize {
        lane * self.lane_bytes + (c as usize & (self.slots - 1)) * self.width
    }

    /// The byte offset of cycle `c`'s row in lane `lane` (`c ≥ now`, the engine's current
    /// cycle: rows before it are dead), cleared if it held an older cycle.
    #[inline(always)]
    fn row(&mut self, lane: usize, c: u64, now: u64) -> usize {
        debug_assert!(c >= now);
        let fresh = self.fresh[lane];
        if c >= fresh {
            // Not when `c` is a whole ring ahead: its slot then holds a live cycle, and
            // `clear_to` grows the ring instead.
            if c == fresh && c - now < self.slots as u64 && (self.width == 16 || self.width == 4) {
                // The usual stale case, one new row of a usual width (16 unit classes, or 16
                // banks' packed counts): cleared inline, without `clear_to`'s call and `memset`.
                let o = self.at(lane, c);
                if self.width == 16 {
                    self.data[o..o + 16].fill(0);
                } else {
                    self.data[o..o + 4].fill(0);
                }
                self.fresh[lane] = c + 1;
                return o;
            }
            self.clear_to(lane, c, now);
        }
        self.at(lane, c)
    }

    /// Make the rows of lane `lane` up to cycle `c` valid (cleared).
    #[inline(never)]
    fn clear_to(&mut self, lane: usize, c: u64, now: u64) {
        if c - now >= self.slots as u64 {
            self.grow(now);
            return self.clear_to(lane, c, now);
        }
        let from = self.fresh[lane].max((c + 1).saturating_sub(self.slots as u64));
        // At most two runs of slots (the ring may wrap).
        let (a, b) = (self.at(lane, from), self.at(lane, c) + self.width);
        if a < b {
            self.data[a..b].fill(0);
        } else {
            let lane_start = lane * self.lane_bytes;
            self.data[a..lane_start + self.slots * self.width].fill(0);
            self.data[lane_start..b].fill(0);
        }
        self.fresh[lane] = c + 1;
    }
}

/// The issue-slot calendar: per TM, the slots used per unit class; per instruction cache,
/// the fetches per bank.
///
/// With at most 3 fetches per bank and cycle (the default is 2), a bank's count takes two
/// bits and four banks share a byte, so the default 16 banks' row is 4 bytes instead of 16.
/// The bank rows are most of the calendar's memory (4 instruction caches per TM against one
/// row of units), and a new row is a host cache miss: a quarter of the bytes is a quarter of
/// the misses. Counts never exceed the cap, so a count never carries into its neighbour.
#[derive(Debug)]
pub(crate) struct Calendar {
    units: Ring,
    banks: Ring,
    /// Bank `b`'s count is bits `(b & sub) * bits ..` of byte `b >> log` of the row.
    bank_log: u32,
    bank_sub: usize,
    bank_bits: u32,
    bank_mask: u8,
}

impl Calendar {
    pub(crate) fn new(
        tms: usize,
        icaches: usize,
        banks: usize,
        fetch_cap: u8,
        slots: usize,
    ) -> Self {
        let packed = fetch_cap <= 3;
        let (log, bits) = if packed { (2, 2) } else { (0, 0) };
        Calendar {
            units: Ring::new(tms, UNIT_CLASSES, slots),
            banks: Ring::new(tms * icaches, banks.div_ceil(1 << log), slots),
            bank_log: log,
            bank_sub: (1 << log) - 1,
            bank_bits: bits,
            bank_mask: if packed { 3 } else { u8::MAX },
        }
    }

    /// Book instruction `d`, whose operands are ready at `e`, for a TP of the TM whose units
    /// are lane `tm` (`caps`: its issue slots per cycle by class) and whose instruction cache is
    /// lane `lane` (`fetch_cap` fetches per bank and cycle), while the engine is at `t`: the
    /// first cycle from `e` where its unit (if any) and its fetch bank have room. The cycles
    /// waited for them are counted as stalls.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    pub(crate) fn book(
        &mut self,
        tm: usize,
        lane: usize,
        d: &Dec,
        caps: &[u8; UNIT_CLASSES],
        fetch_cap: u8,
        e: u64,
        t: u64,
        st: &mut IssueStats,
    ) -> u64 {
        let unit = d.unit;
        let cls = d.class as usize;
        let cap = if unit { caps[cls] } else { 0 };
        let bank = d.bank as usize;
        let (bank_byte, shift) = (
            bank >> self.bank_log,
            (bank & self.bank_sub) as u32 * self.bank_bits,
        );
        let mut c = e;
        let (mut unit_busy, mut fetch_busy) = (0u64, 0u64);
        loop {
            let u = if unit {
                let u = self.units.row(tm, c, t) + cls;
                if self.units.data[u] >= cap {
                    unit_busy += 1;
                    c += 1;
                    continue;
                }
                Some(u)
            } else {
                None
            };
            let b = self.banks.row(lane, c, t) + bank_byte;
            if (self.banks.data[b] >> shift) & self.bank_mask >= fetch_cap {
                fetch_busy += 1;
                c += 1;
                continue;
            }
            if let Some(u) = u {
                self.units.data[u] += 1;
            }
            self.banks.data[b] += 1 << shift;
            break;
        }
        if unit_busy + fetch_busy > 0 {
            st.stall[Stall::Unit as usize] += unit_busy;
            st.stall[Stall::Fetch as usize] += fetch_busy;
            if unit {
                st.unit_busy[cls] += unit_busy;
            }
        }
        c
    }
}

/// TP events by cycle: a ring of per-cycle bitsets over TPs (so a cycle's TPs come out in
/// index order), and a heap for events beyond the ring.
#[derive(Debug)]
pub(crate) struct Wheel {
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
    pub(crate) now: u64,
}

impl Wheel {
    pub(crate) fn new(tps: usize, slots: usize) -> Self {
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
    pub(crate) fn add(&mut self, c: u64, tp: usize) {
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
    pub(crate) fn next(&self) -> Option<u64> {
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

    /// TPs due at cycle `c` (those of the ring; a hint).
    pub(crate) fn due(&self, c: u64) -> u32 {
        let s = c as usize & (self.slots - 1);
        if self.tags[s] == c { self.count[s] } else { 0 }
    }

    /// Move to cycle `c` and take its TPs, in index order.
    pub(crate) fn take(&mut self, c: u64, out: &mut Vec<u32>) {
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

/// TPs refused by the atomic unit, waiting for it. The reference offers every one of them
/// again each cycle, and all but the first `count` (in (TM, key, TP) order, the order of the
/// cycle's offers) are refused again, which changes nothing but the stall count. So only the
/// first `count` are offered in the next cycle (woken through the wheel); the others wait
/// here, and their stall cycles are charged when they are woken. A waiter's key does not
/// change while it waits, and new offerers come either from the wheel (keys below the
/// cycle, in the same order) or from TPs resuming in the cycle (offered after them): the
/// first `count` of all offerers are among the first `count` waiters and the new ones.
#[derive(Debug, Default)]
struct AtomicQueue {
    /// (TM, key, TP), smallest first; the TP's `access_at` holds the cycle it was refused.
    waiting: BinaryHeap<Reverse<(u32, u64, u32)>>,
}

impl AtomicQueue {
    /// TP `tp`, refused at `t`, waits.
    fn park<S: Source>(&mut self, chip: &mut Chip<'_, S>, tp: usize, t: u64) {
        let c = &mut chip.cores[tp];
        c.access_at = t;
        self.waiting.push(Reverse((c.tm, c.key, tp as u32)));
    }

    /// End of cycle `t`: the first `count` waiters offer again at `t + 1`.
    fn wake<S: Source>(&mut self, chip: &mut Chip<'_, S>, wheel: &mut Wheel, t: u64) {
        for _ in 0..chip.cfg.atomic.count {
            let Some(Reverse((_, _, tp))) = self.waiting.pop() else {
                return;
            };
            let c = &mut chip.cores[tp as usize];
            chip.issue.stall[Stall::Atomic as usize] += t - c.access_at;
            c.access_at = t + 1;
            wheel.add(t + 1, tp as usize);
        }
    }

    /// The run stops after cycle `last`: charge the waiters' refusals up to it.
    fn flush<S: Source>(&mut self, chip: &mut Chip<'_, S>, last: u64) {
        for Reverse((_, _, tp)) in self.waiting.drain() {
            chip.issue.stall[Stall::Atomic as usize] += last - chip.cores[tp as usize].access_at;
        }
    }
}

/// A parked TP: its priority key and index, the cycle of its last charged refusal, and the
/// stall its refusals count as.
#[derive(Clone, Copy, Debug)]
struct ParkedTp {
    key: u64,
    tp: u32,
    /// The instruction it offers (unchanged while it is parked).
    inst: u32,
    since: u64,
    stall: Stall,
}

/// TPs whose access the source refused and would go on refusing, changing nothing but
/// counters, until an access of their TM is accepted (`Source::still_refused`: STRaTA's pops
/// of a buffer whose head bank has no port left). The reference offers each of them every
/// cycle. Here they leave the wheel: each cycle, at their places in the TM's run of offers
/// (first-round offers go TM by TM, by key), the first is asked whether it is still refused;
/// if so, so are the ones after it up to the TM's next accepted access, and they are skipped.
/// Skipped refusals are charged when the TP is offered again, or when the run stops.
#[derive(Debug, Default)]
struct Parked {
    /// Per TM: parked TPs, ascending by (key, TP).
    by_tm: Vec<Vec<ParkedTp>>,
    /// TPs parked in all.
    n: usize,
    /// Scratch: the ones that stay parked through a TM's run.
    keep: Vec<ParkedTp>,
    /// Scratch: the ones parked during a TM's run.
    spare: Vec<ParkedTp>,
    /// Per TM: its parked TPs may offer different instructions (false: all offer the same,
    /// so they ask the same question). Conservative: cleared only when the TM has none.
    mixed: Vec<bool>,
    /// Scratch: TPs offered again and accepted this cycle (they resume with the batch).
    woken: Vec<u32>,
}

impl Parked {
    fn new(tms: usize) -> Self {
        Parked {
            by_tm: vec![Vec::new(); tms],
            mixed: vec![false; tms],
            ..Parked::default()
        }
    }

    fn park(&mut self, tm: usize, key: u64, tp: usize, inst: usize, t: u64, stall: Stall) {
        if self.by_tm[tm]
            .first()
            .is_some_and(|f| f.inst != inst as u32)
        {
            self.mixed[tm] = true;
        }
        self.by_tm[tm].push(ParkedTp {
            key,
            tp: tp as u32,
            inst: inst as u32,
            since: t,
            stall,
        });
        self.n += 1;
    }

    /// Charge TP `p.tp`'s refusals skipped from its last charged one up to cycle `last`.
    fn charge<S: Source>(chip: &mut Chip<'_, S>, p: &ParkedTp, last: u64) {
        let n = last - p.since;
        if n > 0 {
            let tp = p.tp as usize;
            chip.issue.stall[p.stall as usize] += n;
            let d = chip.dec[p.inst as usize];
            chip.src.refused_again(tp, d.class, d.mem, n);
        }
    }

    /// The run stops after cycle `last`: charge the parked TPs' refusals up to it.
    fn flush<S: Source>(&mut self, chip: &mut Chip<'_, S>, last: u64) {
        for list in &mut self.by_tm {
            for p in list.drain(..) {
                Parked::charge(chip, &p, last);
            }
        }
        self.n = 0;
    }
}

/// TPs whose access waits for one of a few units of their TM ([`Source::unit_wait`]:
/// STRaTA's triangle pipelines). In the reference every refused TP of a TM offers again when
/// the first unit frees (they all got that cycle as their retry), in (key, TP) order with
/// whatever else offers then; at most `units` of all offerers can be accepted, and they are
/// among the first `units` waiters and the new offerers. So only the first `units` waiters
/// are offered (woken through the wheel at that cycle, a *round*); the others would be
/// refused, changing nothing but counters, and stay here. A waiter queued after round `c0`
/// and offered at round `c` skipped `c - 1 - c0` refusals, whose stall cycles telescope to
/// the offer cycle minus its first retry cycle; both are charged when it is offered.
#[derive(Debug, Default)]
struct UnitQueue {
    /// Per TM: waiting (key, TP), smallest first.
    by_tm: Vec<BinaryHeap<Reverse<(u64, u32)>>>,
    /// Per TM: its rounds so far.
    rounds: Vec<u64>,
    /// Per TM: the cycle of its next round (while it has waiters), and the class waited for.
    next: Vec<Option<(u64, Class)>>,
    /// Per TM: units offered per round.
    units: Vec<u32>,
    /// Scheduled rounds (cycle, TM), earliest first.
    due: BinaryHeap<Reverse<(u64, u32)>>,
    /// Per TP while it waits: the TM's round count when it was queued, its first retry cycle,
    /// and the stall its refusals count as.
    since: Vec<(u64, u64, Stall)>,
    /// Scratch: the TMs with a round in the current cycle.
    now: Vec<u32>,
    /// TPs waiting in all.
    n: usize,
}

impl UnitQueue {
    fn new(tms: usize, tps: usize) -> Self {
        UnitQueue {
            by_tm: vec![BinaryHeap::new(); tms],
            rounds: vec![0; tms],
            next: vec![None; tms],
            units: vec![0; tms],
            since: vec![(0, 0, Stall::Unit); tps],
            ..UnitQueue::default()
        }
    }

    /// TP `tp` of TM `tm`, with key `key`, was refused for `class` and waits for the TM's
    /// units, as [`Source::unit_wait`] describes them: `units` of them, the first free at
    /// `free_at` (its retry), its cycles until then a stall of `stall`.
    fn wait(&mut self, tm: usize, key: u64, tp: usize, class: Class, wait: (u32, u64, Stall)) {
        let (units, free_at, stall) = wait;
        self.by_tm[tm].push(Reverse((key, tp as u32)));
        self.since[tp] = (self.rounds[tm], free_at, stall);
        self.units[tm] = units;
        match self.next[tm] {
            None => {
                self.next[tm] = Some((free_at, class));
                self.due.push(Reverse((free_at, tm as u32)));
            }
            Some(r) => debug_assert_eq!(r, (free_at, class), "the TM's waiters share a retry"),
        }
        self.n += 1;
    }

    /// The earliest scheduled round.
    fn next_round(&self) -> Option<u64> {
        self.due.peek().map(|Reverse((c, _))| *c)
    }

    /// Start of cycle `t`: the TMs with a round now offer their first waiters.
    fn start<S: Source>(&mut self, chip: &mut Chip<'_, S>, wheel: &mut Wheel, t: u64) {
        while let Some(&Reverse((c, tm))) = self.due.peek() {
            if c != t {
                debug_assert!(c > t, "a round was left behind");
                break;
            }
            self.due.pop();
            let tm = tm as usize;
            self.next[tm] = None;
            self.rounds[tm] += 1;
            self.now.push(tm as u32);
            for _ in 0..self.units[tm] {
                let Some(Reverse((_, tp))) = self.by_tm[tm].pop() else {
                    break;
                };
                let tp = tp as usize;
                self.charge(chip, tp, self.rounds[tm] - 1, t);
                chip.cores[tp].access_at = t;
                wheel.add(t, tp);
                self.n -= 1;
            }
        }
    }

    /// Charge waiter `tp` the refusals of its TM's rounds after it was queued, up to round
    /// `upto`, the last of which retried at `until`.
    fn charge<S: Source>(&self, chip: &mut Chip<'_, S>, tp: usize, upto: u64, until: u64) {
        let (c0, first, stall) = self.since[tp];
        let skipped = upto - c0;
        if skipped > 0 {
            chip.issue.stall[stall as usize] += until - first;
            let d = chip.dec[(chip.cores[tp].run.seg.start + chip.cores[tp].ip) as usize];
            chip.src.refused_again(tp, d.class, d.mem, skipped);
        }
    }

    /// End of cycle `t`: the TMs that had a round and still have waiters schedule the next.
    fn end<S: Source>(&mut self, chip: &Chip<'_, S>, t: u64) {
        for tm in self.now.drain(..) {
            let tm = tm as usize;
            if self.by_tm[tm].is_empty() || self.next[tm].is_some() {
                continue;
            }
            // Every waiter was offered before (none joined this cycle), so they wait for the
            // same class.
            let Reverse((_, tp)) = *self.by_tm[tm].peek().expect("a waiter");
            let c = &chip.cores[tp as usize];
            let class = chip.dec[(c.run.seg.start + c.ip) as usize].class;
            let (_, free_at, _) = chip
                .src
                .unit_wait(tm, class, t)
                .expect("the source still has the unit busy");
            debug_assert!(free_at > t, "a unit was left free with waiters");
            self.next[tm] = Some((free_at, class));
            self.due.push(Reverse((free_at, tm as u32)));
        }
    }

    /// The run stops: charge the waiters' refusals of the rounds held since they queued.
    fn flush<S: Source>(&mut self, chip: &mut Chip<'_, S>) {
        for tm in 0..self.by_tm.len() {
            let heap = std::mem::take(&mut self.by_tm[tm]);
            for Reverse((_, tp)) in heap {
                // Each round's refusal counts the cycles to the next round, scheduled at the
                // end of the round.
                let (until, _) = self.next[tm].expect("waiters have a next round");
                self.charge(chip, tp as usize, self.rounds[tm], until);
            }
        }
        self.n = 0;
    }
}

/// Where TPs wait between their events: for a cycle ([`Wheel`]), for the atomic counter
/// ([`AtomicQueue`]), parked on a refusal that repeats ([`Parked`]), or for a busy unit
/// ([`UnitQueue`]).
#[derive(Debug)]
struct Waits {
    wheel: Wheel,
    atomics: AtomicQueue,
    parked: Parked,
    units: UnitQueue,
}

/// The offers of cycle `t` of TM `tm` (`offers`, by key) merged with its parked TPs. Kept
/// out of line: only sources that park (STRaTA) reach it.
#[inline(never)]
fn tm_run<S: Source>(
    chip: &mut Chip<'_, S>,
    w: &mut Waits,
    tm: usize,
    offers: &[(u32, u64, u32)],
    t: u64,
) -> Result<(), ChipError> {
    // TPs parked during this run go to a spare list, merged in at the end.
    let spare = std::mem::take(&mut w.parked.spare);
    let list = std::mem::replace(&mut w.parked.by_tm[tm], spare);
    // The parked TPs that stay: `list[..pi]` until one leaves (`left`), then `keep`. Most
    // cycles none leaves and nothing is copied.
    let mut keep = std::mem::take(&mut w.parked.keep);
    keep.clear();
    let mut left = false;
    let (mut pi, mut fi) = (0, 0);
    // Whether the parked TP at hand is known to be refused: it offers what the last one
    // asked offered, and no access of this TM has been offered since.
    let mut refused_now = false;
    let mut asked = None;
    loop {
        let take_offer = match (list.get(pi), offers.get(fi)) {
            (None, None) => break,
            (None, Some(_)) => true,
            (Some(_), None) => false,
            (Some(p), Some(&(_, key, tp))) => (key, tp) < (p.key, p.tp),
        };
        if take_offer {
            let tp = offers[fi].2 as usize;
            fi += 1;
            offer(chip, w, tp, t)?;
            refused_now = false;
            continue;
        }
        let p = list[pi];
        let tp = p.tp as usize;
        let i = p.inst as usize;
        let d = chip.dec[i];
        let q = (d.class, d.mem);
        if !refused_now || asked != Some(q) {
            refused_now = chip.src.still_refused(tp, tm, d.class, d.mem, t).is_some();
            asked = Some(q);
        }
        if refused_now {
            // So is every parked TP after it that offers the same, up to the TM's next offer.
            let next = offers.get(fi).map(|&(_, key, tp)| (key, tp));
            let end = if w.parked.mixed[tm] {
                let mut end = pi + 1;
                while let Some(r) = list.get(end) {
                    let dr = chip.dec[r.inst as usize];
                    if next.is_some_and(|o| o < (r.key, r.tp)) || (dr.class, dr.mem) != q {
                        break;
                    }
                    end += 1;
                }
                end
            } else {
                // All offer the same instruction: the run ends at the next offer's place.
                let rest = &list[pi + 1..];
                pi + 1 + next.map_or(rest.len(), |o| rest.partition_point(|r| (r.key, r.tp) < o))
            };
            if left {
                keep.extend_from_slice(&list[pi..end]);
            }
            pi = end;
            continue;
        }
        if !left {
            keep.extend_from_slice(&list[..pi]);
            left = true;
        }
        pi += 1;
        // Offered again: charge the refusals skipped before this cycle.
        w.parked.n -= 1;
        Parked::charge(chip, &p, t - 1);
        chip.cores[tp].access_at = t;
        match chip.access(tp, i, t)? {
            Offered::Accepted => w.parked.woken.push(p.tp),
            Offered::Busy { retry_at } => refused(chip, w, tp, i, t, retry_at),
        }
    }
    // Those parked this cycle join the ones still parked, in (key, TP) order. Both runs are
    // already in that order (this TM's offers and parked TPs were taken in merged order), so
    // the stable sort merges them in one pass; keys are unique, so any sort gives this order.
    let mut new = std::mem::take(&mut w.parked.by_tm[tm]);
    let (mut kept, mut unused) = if left { (keep, list) } else { (list, keep) };
    if let (Some(a), Some(b)) = (kept.first(), new.first())
        && a.inst != b.inst
    {
        w.parked.mixed[tm] = true;
    }
    if !new.is_empty() {
        kept.append(&mut new);
        kept.sort_by_key(|p| (p.key, p.tp));
    }
    unused.clear();
    if kept.is_empty() {
        w.parked.mixed[tm] = false;
    }
    w.parked.by_tm[tm] = kept;
    w.parked.keep = unused;
    w.parked.spare = new;
    Ok(())
}

/// TP `tp`'s access (instruction `i`) was refused at `t`: it waits for the atomic unit
/// ([`AtomicQueue`]), is parked if the source says the refusal repeats ([`Parked`]), or offers
/// again at `retry_at`.
#[inline]
fn refused<S: Source>(
    chip: &mut Chip<'_, S>,
    w: &mut Waits,
    tp: usize,
    i: usize,
    t: u64,
    retry_at: u64,
) {
    let d = chip.dec[i];
    if d.class == Class::Atomic {
        debug_assert_eq!(retry_at, t + 1);
        w.atomics.park(chip, tp, t);
        return;
    }
    let tm = chip.cores[tp].tm as usize;
    if let Some(wait) = chip.src.unit_wait(tm, d.class, t) {
        debug_assert_eq!(wait.1, retry_at, "a unit wait retries when the unit frees");
        w.units.wait(tm, chip.cores[tp].key, tp, d.class, wait);
        return;
    }
    if retry_at == t + 1
        && matches!(
            d.class,
            Class::TriTest | Class::StreamLoad | Class::StreamStore
        )
    {
        if let Some(stall) = chip.src.still_refused(tp, tm, d.class, d.mem, t) {
            w.parked.park(tm, chip.cores[tp].key, tp, i, t, stall);
            return;
        }
    }
    chip.cores[tp].access_at = retry_at;
    w.wheel.add(retry_at, tp);
}

/// Progress callback: called now and then with the chip and the current cycle.
/// Called with the cycle, the pixels finished and the rays traced.
pub(crate) type Progress<'p> = &'p mut dyn FnMut(u64, u64, u64);

/// Run the frame (to its end, or to `limit` cycles); returns the last cycle processed.
pub fn run<S: Source>(
    chip: &mut Chip<'_, S>,
    limit: Option<u64>,
    progress: Progress<'_>,
) -> Result<u64, ChipError> {
    let n = chip.tps();
    let mut cal = Calendar::new(
        chip.cfg.tms as usize,
        chip.cfg.icaches_per_tm as usize,
        chip.cfg.icache_banks as usize,
        chip.fetch_cap,
        256,
    );
    let mut w = Waits {
        wheel: Wheel::new(n, 1024),
        atomics: AtomicQueue::default(),
        parked: Parked::new(chip.cfg.tms as usize),
        units: UnitQueue::new(chip.cfg.tms as usize, n),
    };
    for tp in 0..n {
        w.wheel.add(0, tp);
    }
    let mut batch: Vec<u32> = Vec::with_capacity(n);
    let mut offers: Vec<(u32, u64, u32)> = Vec::with_capacity(n);
    let mut done = std::mem::take(&mut chip.completions);
    let mut last = 0;
    let mut ticks = 0u32;
    loop {
        let t_tp = w.wheel.next();
        let t_mem = chip.hier.next_event();
        // Parked TPs are asked again every cycle.
        let t_parked = (w.parked.n > 0).then_some(last + 1);
        let t_units = w.units.next_round();
        let t = match (t_tp, t_mem, t_parked, t_units) {
            (None, None, None, None) => break,
            (a, b, c, d) => a
                .unwrap_or(u64::MAX)
                .min(b.unwrap_or(u64::MAX))
                .min(c.unwrap_or(u64::MAX))
                .min(d.unwrap_or(u64::MAX)),
        };
        chip.sample_until(t);
        if limit.is_some_and(|l| t >= l) {
            break;
        }
        w.wheel.now = t;
        if t_units == Some(t) {
            w.units.start(chip, &mut w.wheel, t);
        }
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
                        w.wheel.add(t, tp);
                    }
                }
            }
        }
        w.wheel.take(t, &mut batch);
        // First the cycle's accesses, TM by TM, oldest first (by key, ties by TP index); then
        // every TP that resumes now — accepted or woken by a returned miss — books ahead with
        // key `t` in TP order (`docs/TRAX.md`). A resuming TP's access in this cycle is
        // offered in its turn: its key, `t`, is the largest of the cycle.
        offers.clear();
        for &tp in batch.iter() {
            let c = &chip.cores[tp as usize];
            if c.wait == Wait::Access {
                offers.push((c.tm, c.key, tp));
            }
        }
        // The batch is in TP order, so TM by TM: order each TM's run by key (a few TPs:
        // insertion sort).
        insertion_sort(&mut offers);
        if w.parked.n == 0 {
            for (k, &(_, _, tp)) in offers.iter().enumerate() {
                if let Some(&(_, _, ahead)) = offers.get(k + AHEAD) {
                    prefetch_tp(chip, ahead as usize);
                }
                offer(chip, &mut w, tp as usize, t)?;
            }
        } else {
            // TM by TM, each TM's offers merged with its parked TPs.
            w.parked.woken.clear();
            let mut k = 0;
            for tm in 0..w.parked.by_tm.len() {
                let start = k;
                while k < offers.len() && offers[k].0 as usize == tm {
                    k += 1;
                }
                if w.parked.by_tm[tm].is_empty() {
                    for &(_, _, tp) in &offers[start..k] {
                        offer(chip, &mut w, tp as usize, t)?;
                    }
                } else {
                    let run = &offers[start..k];
                    tm_run(chip, &mut w, tm, run, t)?;
                }
            }
            debug_assert_eq!(k, offers.len());
            if !w.parked.woken.is_empty() {
                // The batch is in TP order and the woken are few: sort them, then the stable
                // sort merges the two runs in one pass (TPs are distinct: a parked TP is not
                // on the wheel).
                w.parked.woken.sort_unstable();
                batch.extend_from_slice(&w.parked.woken);
                batch.sort();
            }
        }
        for (k, &tp) in batch.iter().enumerate() {
            if let Some(&ahead) = batch.get(k + AHEAD) {
                prefetch_tp(chip, ahead as usize);
            }
            resume(chip, &mut cal, &mut w, tp as usize, t)?;
        }
        w.atomics.wake(chip, &mut w.wheel, t);
        if !w.units.now.is_empty() {
            w.units.end(chip, t);
        }
        last = t;
        ticks += 1;
        if ticks & 0x3FFF == 0 {
            progress(t, chip.pixels_done, chip.rays_done);
        }
        if chip.live == 0
            && t_tp.is_none()
            && w.wheel.next().is_none()
            && w.parked.n == 0
            && w.units.n == 0
        {
            // Every TP has halted; what remains in the memory system is drained by the caller.
            break;
        }
    }
    w.atomics.flush(chip, last);
    w.parked.flush(chip, last);
    w.units.flush(chip);
    chip.completions = done;
    Ok(last)
}

/// How many TPs ahead of the one being handled the engine prefetches the state of.
pub(crate) const AHEAD: usize = 4;

/// Ask the host CPU to bring TP `tp`'s timing state and the head of its work into its cache:
/// a cycle's TPs are known in advance, and each one's state is usually out of the cache by the
/// time its turn comes (4,096 TPs' state is larger than the host's L2).
#[inline(always)]
fn prefetch_tp<S: Source>(chip: &Chip<'_, S>, tp: usize) {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
        let core = chip.cores.as_ptr().wrapping_add(tp) as *const i8;
        for l in 0..std::mem::size_of::<crate::chip::Core>().div_ceil(64) {
            // SAFETY: prefetching is a hint and never faults, even for a bad address.
            unsafe { _mm_prefetch::<_MM_HINT_T0>(core.wrapping_add(64 * l)) };
        }
    }
    chip.src.prefetch(tp);
}

/// Sort nearly sorted, mostly tiny runs.
pub(crate) fn insertion_sort<T: Ord + Copy>(v: &mut [T]) {
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
fn offer<S: Source>(
    chip: &mut Chip<'_, S>,
    w: &mut Waits,
    tp: usize,
    t: u64,
) -> Result<(), ChipError> {
    debug_assert_eq!(chip.cores[tp].access_at, t);
    let i = (chip.cores[tp].run.seg.start + chip.cores[tp].ip) as usize;
    if let Offered::Busy { retry_at } = chip.access(tp, i, t)? {
        refused(chip, w, tp, i, t, retry_at);
    }
    Ok(())
}

/// TP `tp` resumes at `t` (its access was accepted, or a miss it waited for returned, or the
/// frame starts): it books ahead with key `t`.
fn resume<S: Source>(
    chip: &mut Chip<'_, S>,
    cal: &mut Calendar,
    w: &mut Waits,
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
    // Two copies of the booking loop: counting issues for the time series is a test per
    // instruction, which the copy without it does not pay.
    if chip.sampler.every == 0 {
        run_ahead::<S, false>(chip, cal, w, tp, t)
    } else {
        run_ahead_sampled(chip, cal, w, tp, t)
    }
}

/// [`run_ahead`] counting issues for the time series, kept out of the engine's loop.
#[inline(never)]
fn run_ahead_sampled<S: Source>(
    chip: &mut Chip<'_, S>,
    cal: &mut Calendar,
    w: &mut Waits,
    tp: usize,
    t: u64,
) -> Result<(), ChipError> {
    run_ahead::<S, true>(chip, cal, w, tp, t)
}

/// Book TP `tp`'s instructions from its current one, with priority key `t`, up to its next
/// access (scheduled as an event, or offered at once if it falls in cycle `t`) or an operand
/// whose miss has not returned.
fn run_ahead<S: Source, const TIMELINE: bool>(
    chip: &mut Chip<'_, S>,
    cal: &mut Calendar,
    w: &mut Waits,
    tp: usize,
    t: u64,
) -> Result<(), ChipError> {
    let tm = chip.cores[tp].tm as usize;
    let icaches = chip.cfg.icaches_per_tm as usize;
    let lane = tm * icaches + chip.cores[tp].icache as usize;
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
        let e = core.operands_ready(&d, s, &mut chip.issue);
        debug_assert!(e >= t, "booking in the past: {e} < {t}");
        let c = cal.book(
            tm,
            lane,
            &d,
            &chip.caps[tm],
            chip.fetch_cap,
            e,
            t,
            &mut chip.issue,
        );
        if !d.sync {
            chip.retire_issue(tp, i, c);
            if TIMELINE {
                chip.sampler.issue(c);
            }
            continue;
        }
        let core = &mut chip.cores[tp];
        core.wait = Wait::Access;
        core.access_at = c;
        if c > t {
            w.wheel.add(c, tp);
            return Ok(());
        }
        // The access falls in the current cycle: offer it now, in this TP's turn.
        match chip.access(tp, i, t)? {
            Offered::Accepted => {
                chip.cores[tp].key = t;
            }
            Offered::Busy { retry_at } => {
                refused(chip, w, tp, i, t, retry_at);
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
    fn a_row_booked_next_a_whole_ring_ahead_grows_the_ring() {
        // Rows booked one after another up to a ring ahead of now: the next one's slot holds
        // the live cycle `now`, so the ring must grow rather than clear it (the inline path
        // for the next row of a lane once cleared it: every row width it takes is checked).
        for counts in [16, 4, 13] {
            let mut r = Ring::new(1, counts, 4);
            for c in 10..14 {
                let at = r.row(0, c, 10);
                r.data[at] = (c - 9) as u8;
            }
            let at = r.row(0, 14, 10);
            assert_eq!(r.data[at], 0, "width {}", r.width);
            r.data[at] = 5;
            assert_eq!(r.slots, 8, "width {}", r.width);
            for c in 10..15 {
                let at = r.row(0, c, 10);
                assert_eq!(r.data[at], (c - 9) as u8, "cycle {c}, width {}", r.width);
            }
        }
    }

    #[test]
    fn the_calendar_grows_instead_of_overwriting_a_live_row() {
        let mut r = Ring::new(2, 3, 4);
        assert_eq!(r.width, 4);
        let at = r.row(1, 10, 10);
        r.data[at] = 7;
        let at = r.row(1, 13, 10);
        r.data[at + 1] = 1;
        // Cycle 14 maps onto cycle 10's slot, still live at now = 10: the ring grows.
        let at = r.row(1, 14, 10);
        r.data[at + 2] = 2;
        assert_eq!(r.slots, 8);
        let at = r.row(1, 10, 10);
        assert_eq!(r.data[at], 7);
        let at = r.row(1, 13, 10);
        assert_eq!(r.data[at + 1], 1);
        let at = r.row(1, 14, 10);
        assert_eq!(r.data[at + 2], 2);
        // Rows between bookings were cleared; lane 0 is untouched.
        let at = r.row(1, 11, 10);
        assert_eq!(r.data[at], 0);
        let at = r.row(0, 10, 10);
        assert_eq!(r.data[at], 0);
        // A dead row is reused and cleared: cycle 18 takes cycle 10's slot.
        let at = r.row(1, 18, 11);
        assert_eq!(r.data[at], 0);
        let at = r.row(1, 14, 11);
        assert_eq!(r.data[at + 2], 2);
    }
}
