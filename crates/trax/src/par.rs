//! The fast engine on several host threads ([`crate::Options::threads`]): the events,
//! bookings and accesses of [`crate::fast`], cycle for cycle, with each cycle's work split
//! between threads by TM. Results are bit-identical whatever the number of threads, and equal
//! to the one-thread engine's (tests check both).
//!
//! Why the split is exact. Within a cycle of the fast engine — after the memory system's
//! events of the cycle, which come first — a TM's offers and resumes touch only its own state
//! (its TPs, their work, its calendar rows, its L1), except in three ways:
//!
//! 1. the atomic pixel counter, whose answer depends on every earlier access to it;
//! 2. what its L1 sends towards the L2: events in the hierarchy's queue, whose order among
//!    events of one cycle is the order of the accesses that made them;
//! 3. an L1 refusal for lack of an MSHR or a write-buffer entry, whose retry cycle is the
//!    hierarchy's next event — which the sends of the cycle's earlier accesses can bring
//!    forward.
//!
//! The fast engine's order of accesses within a cycle is every TM's offers (TM by TM), then
//! every TM's resumes (TM by TM). Here each thread takes a run of TMs and does, TM by TM, the
//! TM's offers and then its resumes, with three changes: (1) an access to the atomic counter
//! *stops* its TM, and the rest of that TM's cycle is done afterwards on one thread — first the
//! offers of every stopped TM, then their resumes, TMs in order: the fast engine's order;
//! (2) sends go to a log per round (offers, resumes) and TM, replayed into the hierarchy in
//! that order; (3) such a refusal's retry is settled once every send of the cycle is known,
//! from the hierarchy's next event at the start of the cycle and the sends before the refusal
//! in that order. Nothing else a TM does in a cycle depends on another TM, so every TP books
//! the same slots, offers the same accesses and gets the same answers as in the fast engine.
//! Counters are summed per thread and added up at the end (integer sums; `max_stack` a
//! maximum).
//!
//! Threads meet twice per cycle, so cycles with few TPs to handle run on one thread
//! ([`PARALLEL_MIN`]); that choice changes nothing but speed.

use crate::chip::{Atomic, Chip, ChipError, Core, Dec, Offered, Wait, completion_tp};
use crate::fast::{AHEAD, Calendar, Progress, Wheel, insertion_sort};
use crate::isa::{CLASSES, Class, UNIT_CLASSES};
use crate::source::{TraxSource, counter_next};
use crate::stats::{IssueStats, Stall};
use crate::work::{Ctx, PixelDone, Work};
use rtsim_cache::{Completion, LeafOutcome, LeafSend, Leaves, busy_retry};
use rtsim_sim::Crew;
use rtsim_trace::FrameStats;
use std::cmp::Reverse;
use std::collections::BinaryHeap;

/// The two rounds of a cycle's accesses, in the fast engine's order.
const OFFERS: usize = 0;
const RESUMES: usize = 1;

/// Cycles with fewer TPs due than this run on one thread: waking the others and waiting for
/// them costs about as much as handling a few dozen TPs (assumed from the engine's cost per TP,
/// 0.5–1 µs, against a few µs per hand-over; only speed depends on it).
const PARALLEL_MIN: u32 = 24;

/// Whether cycles run on the crew or on this thread alone, chosen by measuring both: the
/// choice changes nothing but speed, and on a machine with fewer free cores than threads
/// (other programs, or other runs) the crew's hand-overs wait for descheduled threads and
/// cost more than they save. Cycles are counted in windows of [`Pace::WINDOW`]; each window
/// measures the work it did (TPs and returned misses handled) per second in its mode; the
/// mode with the better rate runs, and now and then the other one is tried again: after
/// [`Pace::PROBE`] windows, and after twice as many each time the other one loses again (up
/// to [`Pace::PROBE_MAX`]), since on a machine that stays busy every probe of the crew costs a
/// slow window (about 15 % of the time with probes every 16 windows, measured); a probe that
/// wins, or a change of the better mode between probes, starts again from `PROBE`. Probes (and
/// the first two windows, which measure each mode once) last [`Pace::PROBE_WINDOW`] cycles
/// only: with a core taken by another program, a crew window can take many times as long as
/// the same cycles alone, since each hand-over waits for a descheduled thread.
#[derive(Debug)]
struct Pace {
    crew: bool,
    start: std::time::Instant,
    cycles: u32,
    work: u64,
    windows: u32,
    /// Work per second last measured: alone, and with the crew.
    rate: [f64; 2],
    /// The window that runs in the other mode next, and the gap after it if it loses.
    next_probe: u32,
    gap: u32,
    /// The window running now is a probe.
    probing: bool,
    /// Cycles of the window running now.
    len: u32,
}

impl Pace {
    const WINDOW: u32 = 2048;
    /// Assumed: 256 cycles of the full chip are ten milliseconds or more, enough to time.
    const PROBE_WINDOW: u32 = 256;
    const PROBE: u32 = 16;
    /// Assumed: 256 windows of 2,048 cycles are about half a minute of a full chip, how long
    /// a freed core may go unused.
    const PROBE_MAX: u32 = 256;

    fn new() -> Pace {
        Pace {
            crew: true,
            start: std::time::Instant::now(),
            cycles: 0,
            work: 0,
            windows: 0,
            rate: [0.0; 2],
            // The second window runs alone, so that both modes have a rate.
            next_probe: 1,
            gap: Self::PROBE,
            probing: false,
            len: Self::PROBE_WINDOW,
        }
    }

    /// A cycle of `work` was handled.
    #[inline]
    fn count(&mut self, work: u32) {
        self.work += work as u64;
        self.cycles += 1;
        if self.cycles == self.len {
            self.next_window();
        }
    }

    #[cold]
    fn next_window(&mut self) {
        self.close_window(self.start.elapsed().as_secs_f64());
    }

    /// The window ends after `secs` seconds: record its rate and choose the next one's mode.
    fn close_window(&mut self, secs: f64) {
        self.rate[self.crew as usize] = self.work as f64 / secs.max(1e-9);
        let closed = self.windows;
        self.windows += 1;
        let best = self.rate[1] >= self.rate[0];
        if self.probing {
            if closed > 1 {
                // The first probe only measures; later ones that lose space out.
                self.gap = if best == self.crew {
                    Self::PROBE
                } else {
                    (2 * self.gap).min(Self::PROBE_MAX)
                };
            }
            self.next_probe = closed + self.gap;
        } else if best != self.crew {
            // The mode that ran fell behind the other's last rate: the load changed.
            self.gap = Self::PROBE;
        }
        // The better mode; the other for one window at the probes.
        self.probing = self.windows == self.next_probe;
        self.crew = best != self.probing;
        self.len = if self.probing {
            Self::PROBE_WINDOW
        } else {
            Self::WINDOW
        };
        self.start = std::time::Instant::now();
        self.cycles = 0;
        self.work = 0;
    }
}

/// What every thread reads and no thread writes during a cycle.
struct Shared<'s, 'a> {
    dec: &'s [Dec],
    caps: &'s [[u8; UNIT_CLASSES]],
    lat: &'s [u64; CLASSES],
    fetch_cap: u8,
    per_tm: usize,
    icaches: usize,
    ctx: &'s Ctx<'a>,
}

/// A refusal whose retry is the hierarchy's next event, to be settled at the end of the
/// cycle: the TP, and where its access falls in the cycle's order (round, TM, and the sends
/// of that TM's round before it).
#[derive(Clone, Copy, Debug)]
struct Busy {
    tp: u32,
    round: u8,
    tm: u32,
    sends_before: u32,
}

/// A TM stopped at an access to the atomic counter: in round `round`, at position `at` of
/// its shard's offers (round [`OFFERS`]) or batch (round [`RESUMES`]: the TP whose booking
/// reached the access in the current cycle).
#[derive(Clone, Copy, Debug)]
struct Stop {
    tm: usize,
    round: usize,
    at: usize,
}

/// One thread's part of the chip: a run of TMs, their calendar rows and their TPs' wheel,
/// and what it counts.
#[derive(Debug)]
struct Shard {
    tm0: usize,
    tms: usize,
    tp0: usize,
    cal: Calendar,
    /// The shard's TPs by local index (`tp - tp0`).
    wheel: Wheel,
    issue: IssueStats,
    frame: FrameStats,
    rays: u64,
    pixels_done: u64,
    halted: usize,
    done: Vec<PixelDone>,
    /// The misses of its TPs that finished this cycle.
    completions: Vec<Completion>,
    /// The cycle's due TPs (global indices, ascending).
    batch: Vec<u32>,
    /// The cycle's offers: (TM, key, TP), ascending.
    offers: Vec<(u32, u64, u32)>,
    /// Per round and TM (`round * tms + tm - tm0`): what its accesses sent, in order.
    sends: Vec<Vec<LeafSend>>,
    busy: Vec<Busy>,
    stops: Vec<Stop>,
}

impl Shard {
    fn sends(&mut self, round: usize, tm: usize) -> &mut Vec<LeafSend> {
        &mut self.sends[round * self.tms + tm - self.tm0]
    }
}

/// The counter's side of an access on the thread that may take it: the slots, the counter,
/// the per-pixel cycles and the TPs waiting for it.
struct Counter<'c> {
    unit: &'c mut Atomic,
    count: u32,
    next: &'c mut u32,
    heat: &'c mut [u64],
    /// (TM, key, TP) of the TPs it refused; their `access_at` holds the refusal's cycle.
    waiting: &'c mut BinaryHeap<Reverse<(u32, u64, u32)>>,
}

/// A shard's TMs in one cycle: their state, and the counter when this thread may take it.
struct Cx<'c, 's, 'a, 'h, 'k> {
    sh: &'c Shared<'s, 'a>,
    shard: &'c mut Shard,
    cores: &'c mut [Core],
    /// The shard's TPs' rows of [`Chip::miss_done`].
    miss_done: &'c mut [[u64; 32]],
    works: &'c mut [Work],
    leaves: &'c mut Leaves<'h>,
    counter: Option<Counter<'k>>,
    round: usize,
}

impl Cx<'_, '_, '_, '_, '_> {
    /// The shard's part of cycle `t`, TM by TM: its offers, then its resumes; TMs that reach
    /// the atomic counter stop (recorded in `stops`).
    fn cycle(&mut self, t: u64) {
        // The cycle's returned misses first: TPs whose wait they end resume now.
        let tp0 = self.shard.tp0;
        for c in self.shard.completions.drain(..) {
            let tp = completion_tp(&c);
            let l = tp - tp0;
            let core = &mut self.cores[l];
            core.complete(&c, &mut self.miss_done[l]);
            if core.wait == Wait::Blocked {
                let i = (core.run.seg.start + core.ip) as usize;
                if core.pending & self.sh.dec[i].regs == 0 {
                    self.shard.wheel.add(t, l);
                }
            }
        }
        let mut batch = std::mem::take(&mut self.shard.batch);
        let mut offers = std::mem::take(&mut self.shard.offers);
        self.shard.wheel.now = t;
        self.shard.wheel.take(t, &mut batch);
        for tp in batch.iter_mut() {
            *tp += tp0 as u32;
        }
        offers.clear();
        for &tp in batch.iter() {
            let c = self.core(tp as usize);
            if c.wait == Wait::Access {
                offers.push((c.tm, c.key, tp));
            }
        }
        insertion_sort(&mut offers);
        // TM by TM, visiting only the TMs that have an offer or a resume (the others' turns
        // do nothing): both lists are sorted by TM.
        let per_tm = self.sh.per_tm;
        let (mut o, mut b) = (0, 0);
        while o < offers.len() || b < batch.len() {
            let tm_o = offers.get(o).map_or(usize::MAX, |x| x.0 as usize);
            let tm_b = batch.get(b).map_or(usize::MAX, |&tp| self.tm_of(tp));
            let tm = tm_o.min(tm_b);
            let end_tp = (tm + 1) * per_tm;
            let o_end = o + offers[o..].partition_point(|x| x.0 as usize == tm);
            let b_end = b + batch[b..].partition_point(|&tp| (tp as usize) < end_tp);
            if let Some(stop) = self.tm_offers(tm, &offers[o..o_end], o, t) {
                self.shard.stops.push(stop);
            } else if let Some(stop) = self.tm_resumes(&batch[b..b_end], b, t) {
                self.shard.stops.push(stop);
            }
            (o, b) = (o_end, b_end);
        }
        self.shard.batch = batch;
        self.shard.offers = offers;
    }

    /// Finish a stopped TM's offers (this thread takes the counter): `offers` from the stop.
    fn finish_offers(&mut self, stop: Stop, t: u64) {
        let offers = std::mem::take(&mut self.shard.offers);
        let end = stop.at + offers[stop.at..].partition_point(|x| x.0 as usize == stop.tm);
        let left = self.tm_offers(stop.tm, &offers[stop.at..end], stop.at, t);
        debug_assert!(left.is_none(), "the counter's thread does not stop");
        self.shard.offers = offers;
    }

    /// Finish a stopped TM's resumes: all of them if it stopped in its offers, else from the
    /// TP whose booking reached the counter (its access is offered first).
    fn finish_resumes(&mut self, stop: Stop, t: u64) {
        let batch = std::mem::take(&mut self.shard.batch);
        let first = batch.partition_point(|&tp| self.tm_of(tp) < stop.tm);
        let end = first + batch[first..].partition_point(|&tp| self.tm_of(tp) == stop.tm);
        let from = if stop.round == OFFERS {
            first
        } else {
            let tp = batch[stop.at] as usize;
            let i = self.inst(tp);
            match self.access(tp, i, t) {
                Some(Offered::Accepted) => {
                    let left = self.run_ahead(tp, t);
                    debug_assert!(left.is_none(), "the counter's thread does not stop");
                }
                Some(Offered::Busy { retry_at }) => self.refused(tp, i, t, retry_at),
                None => unreachable!("the counter's thread does not stop"),
            }
            stop.at + 1
        };
        let left = self.tm_resumes(&batch[from..end], from, t);
        debug_assert!(left.is_none(), "the counter's thread does not stop");
        self.shard.batch = batch;
    }

    fn core(&self, tp: usize) -> &Core {
        &self.cores[tp - self.shard.tp0]
    }

    fn tm_of(&self, tp: u32) -> usize {
        tp as usize / self.sh.per_tm
    }

    /// TP `tp`'s current instruction (it has one: it offers an access).
    fn inst(&self, tp: usize) -> usize {
        let c = self.core(tp);
        (c.run.seg.start + c.ip) as usize
    }

    /// TM `tm`'s offers (`offers`, at position `at` of the shard's), in order.
    fn tm_offers(
        &mut self,
        tm: usize,
        offers: &[(u32, u64, u32)],
        at: usize,
        t: u64,
    ) -> Option<Stop> {
        self.round = OFFERS;
        for (k, &(_, _, tp)) in offers.iter().enumerate() {
            let tp = tp as usize;
            debug_assert_eq!(self.core(tp).access_at, t);
            let i = self.inst(tp);
            match self.access(tp, i, t) {
                None => {
                    return Some(Stop {
                        tm,
                        round: OFFERS,
                        at: at + k,
                    });
                }
                Some(Offered::Busy { retry_at }) => self.refused(tp, i, t, retry_at),
                Some(Offered::Accepted) => {}
            }
        }
        None
    }

    /// A TM's resuming TPs (`batch`, at position `at` of the shard's batch), in order.
    fn tm_resumes(&mut self, batch: &[u32], at: usize, t: u64) -> Option<Stop> {
        self.round = RESUMES;
        for (k, &tp) in batch.iter().enumerate() {
            if let Some(&ahead) = batch.get(k + AHEAD) {
                self.prefetch(ahead as usize);
            }
            let tp = tp as usize;
            let core = &mut self.cores[tp - self.shard.tp0];
            match core.wait {
                // Refused this cycle: it waits for its retry.
                Wait::Access | Wait::Halted => continue,
                Wait::Ready | Wait::Blocked => {
                    core.key = t;
                    core.wait = Wait::Ready;
                }
            }
            if self.run_ahead(tp, t).is_some() {
                return Some(Stop {
                    tm: tp / self.sh.per_tm,
                    round: RESUMES,
                    at: at + k,
                });
            }
        }
        None
    }

    fn prefetch(&self, tp: usize) {
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
            let l = tp - self.shard.tp0;
            let core = self.cores.as_ptr().wrapping_add(l) as *const i8;
            let work = self.works.as_ptr().wrapping_add(l) as *const i8;
            for k in 0..std::mem::size_of::<Core>().div_ceil(64) {
                // SAFETY: prefetching is a hint and never faults, even for a bad address.
                unsafe { _mm_prefetch::<_MM_HINT_T0>(core.wrapping_add(64 * k)) };
            }
            for k in 0..2 {
                // SAFETY: as above.
                unsafe { _mm_prefetch::<_MM_HINT_T0>(work.wrapping_add(64 * k)) };
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        let _ = tp;
    }

    /// TP `tp`'s current instruction, its next run from its work when the current one is
    /// finished; `None` once it has halted.
    #[inline(always)]
    fn current(&mut self, tp: usize) -> Option<usize> {
        let l = tp - self.shard.tp0;
        let c = &self.cores[l];
        if c.ip < c.run.seg.len {
            return Some((c.run.seg.start + c.ip) as usize);
        }
        self.next_run(l)
    }

    #[inline(never)]
    fn next_run(&mut self, l: usize) -> Option<usize> {
        let sh = &mut *self.shard;
        let mut done = None;
        let next = self.works[l].next(self.sh.ctx, &mut sh.frame, &mut sh.rays, &mut done);
        if let Some(d) = done {
            sh.done.push(d);
            sh.pixels_done += 1;
        }
        let first = self.cores[l].start_run(next);
        if first.is_none() {
            sh.halted += 1;
        }
        first
    }

    /// As [`crate::fast`]'s `run_ahead`: book TP `tp`'s instructions with key `t` up to its
    /// next access or an operand whose miss has not returned. `Some(())`: it stopped at an
    /// access to the counter in cycle `t` (left waiting to offer it).
    fn run_ahead(&mut self, tp: usize, t: u64) -> Option<()> {
        let l = tp - self.shard.tp0;
        let tm = self.cores[l].tm as usize;
        let (ltm, lane) = {
            let ltm = tm - self.shard.tm0;
            (ltm, ltm * self.sh.icaches + self.cores[l].icache as usize)
        };
        loop {
            let i = self.current(tp)?;
            let d = self.sh.dec[i];
            let sh = &mut *self.shard;
            let core = &mut self.cores[l];
            if core.pending & d.regs != 0 {
                core.wait = Wait::Blocked;
                return None;
            }
            let e = core.operands_ready(&d, core.next_issue, &mut sh.issue);
            debug_assert!(e >= t, "booking in the past: {e} < {t}");
            let caps = &self.sh.caps[tm];
            let c = sh
                .cal
                .book(ltm, lane, &d, caps, self.sh.fetch_cap, e, t, &mut sh.issue);
            if !d.sync {
                core.retire(&d, self.sh.lat[d.class as usize], c, &mut sh.issue);
                continue;
            }
            core.wait = Wait::Access;
            core.access_at = c;
            if c > t {
                sh.wheel.add(c, l);
                return None;
            }
            // The access falls in the current cycle: offer it now, in this TP's turn.
            match self.access(tp, i, t) {
                None => return Some(()),
                Some(Offered::Accepted) => self.cores[l].key = t,
                Some(Offered::Busy { retry_at }) => {
                    self.refused(tp, i, t, retry_at);
                    return None;
                }
            }
        }
    }

    /// Offer TP `tp`'s access `i` at `t`, as [`Chip::access`] does. `None`: it is an access to
    /// the counter on a thread that may not take it (the TM stops). A refusal to be settled
    /// at the end of the cycle is recorded and answers `Busy` at `u64::MAX` (not used).
    fn access(&mut self, tp: usize, i: usize, t: u64) -> Option<Offered> {
        let d = self.sh.dec[i];
        let l = tp - self.shard.tp0;
        let sh = &mut *self.shard;
        match d.class {
            Class::Atomic => {
                let a = self.counter.as_mut()?;
                if !a.unit.admit(t, a.count) {
                    sh.issue.stall[Stall::Atomic as usize] += 1;
                    return Some(Offered::Busy { retry_at: t + 1 });
                }
                let next_pixel = counter_next(a.next, &mut self.works[l], self.sh.ctx);
                let lat = self.sh.lat[Class::Atomic as usize];
                self.cores[l].atomic_granted(&d, lat, next_pixel, a.heat, t);
            }
            Class::Load | Class::Store => {
                let core = &mut self.cores[l];
                let tm = core.tm as usize;
                let (out, send) = self.leaves.access(&core.data_request(&d, tp, t));
                let log = sh.sends(self.round, tm);
                let sends_before = log.len() as u32;
                if let Some(s) = send {
                    log.push(s);
                }
                match out {
                    LeafOutcome::Now(o) => {
                        if let busy @ Offered::Busy { .. } =
                            core.data_outcome(&d, o, t, &mut sh.issue)
                        {
                            return Some(busy);
                        }
                    }
                    LeafOutcome::BusyUntilNextEvent(_) => {
                        sh.busy.push(Busy {
                            tp: tp as u32,
                            round: self.round as u8,
                            tm: tm as u32,
                            sends_before,
                        });
                        return Some(Offered::Busy { retry_at: u64::MAX });
                    }
                }
            }
            _ => unreachable!("the TRaX program's accesses are data-cache and atomic ones"),
        }
        self.cores[l].accepted(&d, t, &mut sh.issue);
        Some(Offered::Accepted)
    }

    /// TP `tp`'s access `i` was refused at `t`: it waits for the counter, or offers again at
    /// `retry_at` (`u64::MAX`: settled at the end of the cycle).
    fn refused(&mut self, tp: usize, i: usize, t: u64, retry_at: u64) {
        let l = tp - self.shard.tp0;
        let core = &mut self.cores[l];
        if self.sh.dec[i].class == Class::Atomic {
            let a = self
                .counter
                .as_mut()
                .expect("refused by the counter on its thread");
            core.access_at = t;
            a.waiting.push(Reverse((core.tm, core.key, tp as u32)));
            return;
        }
        if retry_at == u64::MAX {
            return;
        }
        core.access_at = retry_at;
        self.shard.wheel.add(retry_at, l);
    }
}

/// Run the frame (to its end, or to `limit` cycles) on `threads` host
/// threads (this one and `threads - 1` more); returns the last cycle processed. The same as [`crate::fast::run`], bit for bit.
pub fn run(
    chip: &mut Chip<'_, TraxSource<'_>>,
    threads: usize,
    limit: Option<u64>,
    progress: Progress<'_>,
) -> Result<u64, ChipError> {
    let tms = chip.cfg.tms as usize;
    let per_tm = chip.cfg.tps_per_tm as usize;
    let icaches = chip.cfg.icaches_per_tm as usize;
    // One shard (run of TMs) per thread: more, for the crew's threads to balance by claiming
    // them, measured slower on the full chip (`docs/TRAX.md` §7).
    let n = threads.clamp(1, tms);
    // Even shares of TMs. (This thread also does each cycle's sequential part, but giving it
    // fewer TMs measured slower, not faster, on the reference machine.)
    let bounds: Vec<usize> = (0..=n).map(|k| k * tms / n).collect();
    if chip.hier.leaves(0, &bounds)?.is_none() {
        // A topology whose L1s cannot be lent out in runs: one thread.
        return crate::fast::run(chip, limit, progress);
    }
    let mut shards: Vec<Shard> = bounds
        .windows(2)
        .map(|w| {
            let (tm0, tms) = (w[0], w[1] - w[0]);
            let tps = tms * per_tm;
            let mut wheel = Wheel::new(tps, 1024);
            for l in 0..tps {
                wheel.add(0, l);
            }
            Shard {
                tm0,
                tms,
                tp0: tm0 * per_tm,
                cal: Calendar::new(
                    tms,
                    icaches,
                    chip.cfg.icache_banks as usize,
                    chip.fetch_cap,
                    256,
                ),
                wheel,
                issue: IssueStats::default(),
                frame: FrameStats::default(),
                rays: 0,
                pixels_done: 0,
                halted: 0,
                done: Vec::new(),
                completions: Vec::new(),
                batch: Vec::with_capacity(tps),
                offers: Vec::with_capacity(tps),
                sends: vec![Vec::new(); 2 * tms],
                busy: Vec::new(),
                stops: Vec::new(),
            }
        })
        .collect();
    // The other shards' threads (this one does the first shard and everything in between).
    Crew::scope(n, |crew| {
        run_shards(chip, crew, &bounds, &mut shards, limit, progress)
    })
    .map_err(|e| ChipError::Threads(e.to_string()))?
}

/// The cycles of [`run`], `shards` split at `bounds` (TMs), the crew taking a shard each.
fn run_shards(
    chip: &mut Chip<'_, TraxSource<'_>>,
    crew: &Crew<'_>,
    bounds: &[usize],
    shards: &mut [Shard],
    limit: Option<u64>,
    progress: Progress<'_>,
) -> Result<u64, ChipError> {
    let per_tm = chip.cfg.tps_per_tm as usize;
    let icaches = chip.cfg.icaches_per_tm as usize;
    let owner = |tp: usize| bounds.partition_point(|&b| b * per_tm <= tp) - 1;
    let mut waiting = BinaryHeap::new();
    let mut pace = Pace::new();
    let mut done = std::mem::take(&mut chip.completions);
    let mut last = 0;
    let mut ticks = 0u32;
    let live0 = chip.live;
    loop {
        let t_tp = shards.iter().filter_map(|s| s.wheel.next()).min();
        let t_mem = chip.hier.next_event();
        let Some(t) = t_tp.into_iter().chain(t_mem).min() else {
            break;
        };
        if limit.is_some_and(|l| t >= l) {
            break;
        }
        for s in shards.iter_mut() {
            s.wheel.now = t;
        }
        if t_mem.is_some_and(|m| m <= t) {
            chip.hier.advance_to(t)?;
            chip.hier.drain_completions(&mut done);
            // Each shard applies its own (its thread has its TPs' state at hand).
            for c in done.drain(..) {
                debug_assert_eq!(c.ready, t);
                shards[owner(completion_tp(&c))].completions.push(c);
            }
        }
        // The hierarchy's next event before any access of the cycle (refusals settle on it).
        let next_event = chip.hier.next_event();
        let due: u32 = shards
            .iter()
            .map(|s| s.wheel.due(t) + s.completions.len() as u32)
            .sum();
        {
            let sh = Shared {
                dec: &chip.dec,
                caps: &chip.caps,
                lat: &chip.lat,
                fetch_cap: chip.fetch_cap,
                per_tm,
                icaches,
                ctx: &chip.src.ctx,
            };
            let mut runs = chip.hier.leaves(t, bounds)?.expect("checked at the start");
            // (One small allocation a cycle: the jobs borrow the cycle's slices.)
            let mut jobs = Vec::with_capacity(shards.len());
            let tps = split_tps(
                &mut chip.cores,
                &mut chip.miss_done,
                &mut chip.src.works,
                bounds,
                per_tm,
            );
            for ((s, leaves), (c, m, w)) in shards.iter_mut().zip(runs.iter_mut()).zip(tps) {
                jobs.push(Cx {
                    sh: &sh,
                    shard: s,
                    cores: c,
                    miss_done: m,
                    works: w,
                    leaves,
                    counter: None,
                    round: OFFERS,
                });
            }
            if due >= PARALLEL_MIN && pace.crew {
                crew.for_each(&mut jobs, |job| job.cycle(t));
            } else {
                for job in &mut jobs {
                    job.cycle(t);
                }
            }
            drop(jobs);
            // The stopped TMs, on this thread with the counter: every offer, then every resume.
            if shards.iter().any(|s| !s.stops.is_empty()) {
                let counter = Counter {
                    unit: &mut chip.atomic,
                    count: chip.cfg.atomic.count,
                    next: &mut chip.src.next,
                    heat: &mut chip.heat,
                    waiting: &mut waiting,
                };
                for round in [OFFERS, RESUMES] {
                    let tps = split_tps(
                        &mut chip.cores,
                        &mut chip.miss_done,
                        &mut chip.src.works,
                        bounds,
                        per_tm,
                    );
                    for ((s, leaves), (c, m, w)) in shards.iter_mut().zip(runs.iter_mut()).zip(tps)
                    {
                        if s.stops.is_empty() {
                            continue;
                        }
                        let stops = std::mem::take(&mut s.stops);
                        let mut cx = Cx {
                            sh: &sh,
                            shard: s,
                            cores: c,
                            miss_done: m,
                            works: w,
                            leaves,
                            counter: Some(Counter {
                                unit: &mut *counter.unit,
                                count: counter.count,
                                next: &mut *counter.next,
                                heat: &mut *counter.heat,
                                waiting: &mut *counter.waiting,
                            }),
                            round,
                        };
                        for &stop in &stops {
                            if round == RESUMES {
                                cx.finish_resumes(stop, t);
                            } else if stop.round == OFFERS {
                                cx.finish_offers(stop, t);
                            }
                        }
                        if round == OFFERS {
                            s.stops = stops;
                        }
                    }
                }
            }
        }
        // The sends, in the fast engine's order, and the refusals that depend on them.
        settle(chip, shards, next_event, t)?;
        for s in shards.iter_mut() {
            for d in s.done.drain(..) {
                chip.pixels[d.pixel as usize] = d.result();
            }
        }
        // End of the cycle: the first `count` TPs waiting for the counter offer again.
        for _ in 0..chip.cfg.atomic.count {
            let Some(Reverse((_, _, tp))) = waiting.pop() else {
                break;
            };
            let tp = tp as usize;
            let s = &mut shards[owner(tp)];
            let c = &mut chip.cores[tp];
            s.issue.stall[Stall::Atomic as usize] += t - c.access_at;
            c.access_at = t + 1;
            s.wheel.add(t + 1, tp - s.tp0);
        }
        pace.count(due);
        last = t;
        ticks += 1;
        if ticks & 0x3FFF == 0 {
            let (p, r) = shards
                .iter()
                .fold((chip.pixels_done, chip.rays_done), |(p, r), s| {
                    (p + s.pixels_done, r + s.rays)
                });
            progress(t, p, r);
        }
        let halted: usize = shards.iter().map(|s| s.halted).sum();
        if halted == live0 && t_tp.is_none() && shards.iter().all(|s| s.wheel.next().is_none()) {
            // Every TP has halted; what remains in the memory system is drained by the caller.
            break;
        }
    }
    for Reverse((_, _, tp)) in waiting.drain() {
        chip.issue.stall[Stall::Atomic as usize] += last - chip.cores[tp as usize].access_at;
    }
    for s in shards.iter_mut() {
        chip.issue += &s.issue;
        chip.frame += &s.frame;
        chip.rays_done += s.rays;
        chip.pixels_done += s.pixels_done;
        chip.live -= s.halted;
    }
    chip.completions = done;
    Ok(last)
}

/// The per-TP state of each shard's TPs: cores, rows of `miss_done`, works.
type TpSlices<'c> = (&'c mut [Core], &'c mut [[u64; 32]], &'c mut [Work]);

/// The shards' slices (TMs `bounds[k]..bounds[k + 1]`) of the per-TP state.
fn split_tps<'c>(
    mut c: &'c mut [Core],
    mut m: &'c mut [[u64; 32]],
    mut w: &'c mut [Work],
    bounds: &[usize],
    per_tm: usize,
) -> Vec<TpSlices<'c>> {
    bounds
        .windows(2)
        .map(|b| {
            let n = (b[1] - b[0]) * per_tm;
            let (c0, c1) = std::mem::take(&mut c).split_at_mut(n);
            let (m0, m1) = std::mem::take(&mut m).split_at_mut(n);
            let (w0, w1) = std::mem::take(&mut w).split_at_mut(n);
            (c, m, w) = (c1, m1, w1);
            (c0, m0, w0)
        })
        .collect()
}

/// Replay the cycle's sends into the hierarchy in the fast engine's order (every TM's offers,
/// then every TM's resumes), and settle the refusals whose retry is the next event: the
/// hierarchy's next event before the cycle's accesses (`next_event`), or the earliest send
/// before the refusal in that order if sooner.
fn settle(
    chip: &mut Chip<'_, TraxSource<'_>>,
    shards: &mut [Shard],
    next_event: Option<u64>,
    t: u64,
) -> Result<(), ChipError> {
    // Earliest send of the rounds and TMs before the current one.
    let mut earliest = next_event;
    let min = |a: Option<u64>, b: Option<u64>| match (a, b) {
        (Some(a), Some(b)) => Some(a.min(b)),
        (a, b) => a.or(b),
    };
    for s in shards.iter_mut() {
        // Stopped TMs' refusals came after the others': in (round, TM) order again (a stable
        // sort keeps each TM's in order).
        s.busy.sort_by_key(|b| (b.round, b.tm));
    }
    for round in [OFFERS, RESUMES] {
        for s in shards.iter_mut() {
            let mut bi = s.busy.partition_point(|b| (b.round as usize) < round);
            for k in 0..s.tms {
                let tm = s.tm0 + k;
                let log = &s.sends[round * s.tms + k];
                while let Some(b) = s
                    .busy
                    .get(bi)
                    .filter(|b| b.round as usize == round && b.tm as usize == tm)
                {
                    let first = log[..b.sends_before as usize].iter().map(|x| x.at).min();
                    let retry_at = busy_retry(t, min(earliest, first));
                    let tp = b.tp as usize;
                    s.issue.stall[Stall::Memory as usize] += retry_at - t;
                    chip.cores[tp].access_at = retry_at;
                    s.wheel.add(retry_at, tp - s.tp0);
                    bi += 1;
                }
                for x in log {
                    chip.hier.replay(x)?;
                    earliest = min(earliest, Some(x.at));
                }
                s.sends[round * s.tms + k].clear();
            }
        }
    }
    for s in shards {
        s.busy.clear();
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::Pace;

    /// Windows of `work` each, taking `alone` or `crew` seconds by mode; the modes chosen.
    fn modes(alone: f64, crew: f64, windows: usize) -> Vec<bool> {
        let mut p = Pace::new();
        let mut out = Vec::new();
        for _ in 0..windows {
            out.push(p.crew);
            p.work = 1000;
            p.close_window(if p.crew { crew } else { alone });
        }
        out
    }

    /// The windows that probe the slower mode when it always loses: 1 (the first
    /// measurement), then PROBE after it, then gaps doubling up to PROBE_MAX.
    fn probes_when_losing(windows: usize) -> Vec<usize> {
        let (mut w, mut gap, mut out) = (1, Pace::PROBE as usize, vec![1]);
        loop {
            w += gap;
            if w >= windows {
                return out;
            }
            out.push(w);
            gap = (2 * gap).min(Pace::PROBE_MAX as usize);
        }
    }

    #[test]
    fn pace_keeps_the_faster_mode_and_probes_the_other_less_often() {
        for (alone, crew) in [(2.0, 1.0), (1.0, 2.0)] {
            let n = 2000;
            let m = modes(alone, crew, n);
            let faster = crew < alone;
            // The first window runs on the crew and the second alone, so both have a rate.
            assert_eq!(&m[..2], &[true, false]);
            let probes = probes_when_losing(n);
            assert_eq!(&probes[..5], &[1, 17, 49, 113, 241]);
            assert!(probes.windows(2).skip(5).all(|p| p[1] - p[0] == 256));
            for (w, &mode) in m.iter().enumerate().skip(2) {
                let probe = probes.contains(&w);
                assert_eq!(mode, faster != probe, "window {w}, crew faster: {faster}");
            }
            // Measuring windows are short, the others long.
            let mut p = Pace::new();
            for w in 0..300 {
                let short = w < 2 || probes.contains(&w);
                let want = if short {
                    Pace::PROBE_WINDOW
                } else {
                    Pace::WINDOW
                };
                assert_eq!(p.len, want, "window {w}");
                p.work = 1000;
                p.close_window(if p.crew { crew } else { alone });
            }
        }
    }

    #[test]
    fn pace_follows_a_change_of_load() {
        // The crew is faster, then (another program takes a core) slower: from the window
        // after its first slow one, the single thread runs, the crew only as a probe, less
        // and less often; when the core is free again the next probe wins and the crew runs.
        let mut p = Pace::new();
        let mut crew_secs = 1.0;
        let mut seen = Vec::new();
        let (busy, free) = (8, 600);
        for w in 0..800 {
            if w == busy {
                crew_secs = 4.0;
            }
            if w == free {
                crew_secs = 1.0;
            }
            seen.push(p.crew);
            p.work = 1000;
            p.close_window(if p.crew { crew_secs } else { 2.0 });
        }
        assert!(seen[2..=busy].iter().all(|&c| c));
        // Probes of the crew at 17, 49, 113, 241, 497 (each lost), then 753 (won).
        let probes = [17, 49, 113, 241, 497];
        for (w, &c) in seen.iter().enumerate().take(753).skip(busy + 1) {
            assert_eq!(c, probes.contains(&w), "window {w}");
        }
        // Alone is now the probed mode, from the shortest gap again: 769 (lost), then 801.
        for (w, &c) in seen.iter().enumerate().skip(753) {
            assert_eq!(c, w != 753 + Pace::PROBE as usize, "window {w}");
        }
        assert_eq!(p.next_probe, 753 + 3 * Pace::PROBE);
    }
}
