//! Where a TP's work comes from: the [`Source`] a [`crate::Chip`] runs. The TRaX baseline's
//! source ([`TraxSource`]) is every TP running whole pixels from the atomic counter
//! ([`crate::work`]); STRaTA's (`rtsim-strata`) moves rays between treelet buffers in a
//! stream memory. The chip owns the timing (issue, scoreboard, caches, DRAM); the source owns
//! the functional state and any shared state beyond the caches that its instructions touch
//! (the atomic counter's meaning, triangle pipeline instances, the stream memory), reached
//! at the synchronisation points in global (cycle, TM, key, TP) order in both engines.

use crate::chip::ChipError;
use crate::isa::{Class, Mem, UNIT_CLASSES};
use crate::program::Run;
use crate::stats::Stall;
use crate::timeline::Column;
use crate::work::{Ctx, PixelDone, Work};
use rtsim_trace::FrameStats;

/// The answer to an access of a source's shared state.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SourceAccess {
    /// Accepted: the registers the instruction writes are readable from `ready`.
    Done { ready: u64 },
    /// Refused: offer again at `retry_at`; the cycles until then are a stall of `stall`.
    Busy { retry_at: u64, stall: Stall },
}

/// What the TPs of a chip run.
pub trait Source {
    /// The block every TP starts with.
    fn first_run(&self) -> Run;
    /// Pixels of the frame (for the report).
    fn pixel_count(&self) -> usize;
    /// The next block of TP `tp`, advancing its functional state as it reaches the end of
    /// one; `None` once it has halted. A finished ray is added to `stats` and counted in
    /// `rays`; a finished pixel is reported through `done`.
    fn next(
        &mut self,
        tp: usize,
        stats: &mut FrameStats,
        rays: &mut u64,
        done: &mut Option<PixelDone>,
    ) -> Option<Run>;
    /// TP `tp`'s `atominc` was accepted: take the counter's next value; returns the pixel it
    /// starts, if any (for the per-pixel cycle map).
    fn atomic(&mut self, tp: usize) -> Option<u32>;
    /// TP `tp` of TM `tm` offers a [`Class::TriTest`], [`Class::StreamLoad`] or
    /// [`Class::StreamStore`] instruction with memory operand `mem` at cycle `t`
    /// (nondecreasing across calls). `caps` are the TM's unit capacities, which the source may
    /// change (a pipeline reconfiguration) when no TP of the TM has booked past `t`.
    fn access(
        &mut self,
        tp: usize,
        tm: usize,
        class: Class,
        mem: Mem,
        t: u64,
        caps: &mut [u8; UNIT_CLASSES],
    ) -> Result<SourceAccess, ChipError>;
    /// TP `tp` of TM `tm` had its access (`class`, `mem`) refused at cycle `t` with a retry
    /// at `t + 1`. `Some(stall)` if offering it again now would be refused once more,
    /// changing nothing but counters (its stall of `stall`, and whatever
    /// [`Source::refused_again`] charges), and would stay so, within cycle `t`, until an
    /// access of TM `tm` is accepted. The fast engine then stops offering it each cycle: it
    /// asks again at the TP's place in each later cycle's order and charges the refusals it
    /// skipped. The answer may depend on `tm`, `class`, `mem`, `t` and the shared state, not
    /// on which of the TM's TPs asks. `None` (the default): it retries every cycle.
    fn still_refused(&self, tp: usize, tm: usize, class: Class, mem: Mem, t: u64) -> Option<Stall> {
        let _ = (tp, tm, class, mem, t);
        None
    }
    /// Accesses of `class` that the source refuses only while every one of a few units of
    /// TM `tm` is busy (STRaTA's triangle pipelines): `Some((units, free_at, stall))` if the
    /// TM has `units` of them, the first frees at `free_at`, and a refused TP's cycles until
    /// then are a stall of `stall`; `free_at` is the retry cycle of a refusal at `t`. The
    /// fast engine then queues refused TPs per TM and, when a unit frees, offers only the
    /// first `units` of them (by key): the reference offers all of them, and the ones beyond
    /// the free units are refused, changing nothing but counters, which are charged when
    /// they are offered again ([`Source::refused_again`]). The answer may depend on `tm`,
    /// `class`, `t` and the shared state, not on which TP asks; a unit frees only with time,
    /// never through another access. `None` (the default): refused TPs retry on their own.
    fn unit_wait(&self, tm: usize, class: Class, t: u64) -> Option<(u32, u64, Stall)> {
        let _ = (tm, class, t);
        None
    }
    /// Charge `n` refusals of TP `tp`'s access that the fast engine skipped (see
    /// [`Source::still_refused`] and [`Source::unit_wait`]).
    fn refused_again(&mut self, tp: usize, class: Class, mem: Mem, n: u64) {
        let _ = (tp, class, mem, n);
    }
    /// Energy beyond the chip's own events, in joules: the stream memory's, and the
    /// operations performed inside fused pipelines.
    fn extra_energy(
        &self,
        cfg: &crate::TraxConfig,
        issue: &crate::stats::IssueStats,
    ) -> (f64, f64) {
        let _ = (cfg, issue);
        (0.0, 0.0)
    }
    /// Columns the source adds to the frame's time series ([`crate::timeline`]): counters
    /// and levels of its shared state that change only at accesses, so that both engines
    /// agree on them at every cycle boundary.
    fn timeline_columns(&self) -> &'static [Column] {
        &[]
    }
    /// The running values of [`Source::timeline_columns`], appended to `out` (a
    /// most-in-the-interval level starts again after each call).
    fn timeline_values(&mut self, out: &mut Vec<u64>) {
        let _ = out;
    }
    /// Hint: TP `tp`'s state is about to be used (the fast engine prefetches it).
    #[inline(always)]
    fn prefetch(&self, tp: usize) {
        let _ = tp;
    }
}

/// The atomic counter, at `next`, hands its value to `work`: returns the pixel it starts.
#[inline]
pub(crate) fn counter_next(next: &mut u32, work: &mut Work, ctx: &Ctx<'_>) -> Option<u32> {
    let value = *next;
    *next = next.saturating_add(1);
    work.set_counter(value);
    ctx.pixels.get(value as usize).copied()
}

/// The TRaX baseline's work: every TP runs whole pixels handed out by the atomic counter.
#[derive(Debug)]
pub struct TraxSource<'a> {
    pub ctx: Ctx<'a>,
    pub works: Vec<Work>,
    /// The atomic counter's next value.
    pub(crate) next: u32,
}

impl<'a> TraxSource<'a> {
    /// `tps` TPs rendering `ctx`'s pixels.
    pub fn new(ctx: Ctx<'a>, tps: usize) -> TraxSource<'a> {
        TraxSource {
            ctx,
            works: (0..tps).map(|_| Work::new()).collect(),
            next: 0,
        }
    }
}

impl Source for TraxSource<'_> {
    fn first_run(&self) -> Run {
        Run::new(self.ctx.program.next_pixel)
    }

    fn pixel_count(&self) -> usize {
        self.ctx.pixels.len()
    }

    #[inline]
    fn next(
        &mut self,
        tp: usize,
        stats: &mut FrameStats,
        rays: &mut u64,
        done: &mut Option<PixelDone>,
    ) -> Option<Run> {
        self.works[tp].next(&self.ctx, stats, rays, done)
    }

    fn atomic(&mut self, tp: usize) -> Option<u32> {
        counter_next(&mut self.next, &mut self.works[tp], &self.ctx)
    }

    fn access(
        &mut self,
        _tp: usize,
        _tm: usize,
        class: Class,
        _mem: Mem,
        _t: u64,
        _caps: &mut [u8; UNIT_CLASSES],
    ) -> Result<SourceAccess, ChipError> {
        unreachable!("the TRaX program has no {} instruction", class.mnemonic())
    }

    #[inline(always)]
    fn prefetch(&self, tp: usize) {
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
            let work = self.works.as_ptr().wrapping_add(tp) as *const i8;
            for l in 0..2 {
                // SAFETY: prefetching is a hint and never faults, even for a bad address.
                unsafe { _mm_prefetch::<_MM_HINT_T0>(work.wrapping_add(64 * l)) };
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        let _ = tp;
    }
}
