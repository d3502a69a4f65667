//! Building blocks of the T&I unit's datapaths: [`Pipe`], a fixed-latency pipeline with an
//! initiation interval, and [`Rau`], the ray accumulation unit's occupancy.
//!
//! Rays are named by their slot (a short stack) in the core's ray table; pipelines and queues
//! carry slot numbers only.

use crate::stats::{PipeStats, RauStats};
use std::collections::VecDeque;

/// A ray slot of a core: `trv × stacks + stack`.
pub type Slot = u16;

/// A pipeline: a ray entering at `t` leaves at `t + latency` (in entry order); the next ray may
/// enter `interval` cycles after the last. A finished ray whose next queue is full waits at the
/// exit and blocks the pipeline's entry until it leaves (back-pressure).
#[derive(Clone, Debug)]
pub struct Pipe {
    latency: u64,
    interval: u64,
    /// Earliest cycle the next ray may enter.
    next_entry: u64,
    /// (exit cycle, slot), exit cycles nondecreasing.
    items: VecDeque<(u64, Slot)>,
    /// Cycle since which the head has been waiting at the exit, if it is.
    blocked_since: Option<u64>,
    /// Cycle the pipeline last became non-empty.
    busy_since: u64,
    pub stats: PipeStats,
}

impl Pipe {
    pub fn new(latency: u32, interval: u32) -> Pipe {
        Pipe {
            latency: latency.into(),
            interval: interval.max(1).into(),
            next_entry: 0,
            items: VecDeque::new(),
            blocked_since: None,
            busy_since: 0,
            stats: PipeStats::default(),
        }
    }

    pub fn latency(&self) -> u64 {
        self.latency
    }

    /// Whether a ray may enter at `t`.
    #[inline]
    pub fn can_enter(&self, t: u64) -> bool {
        self.blocked_since.is_none() && t >= self.next_entry
    }

    /// The earliest cycle a ray could enter (`None` while blocked).
    #[inline]
    pub fn entry_at(&self) -> Option<u64> {
        self.blocked_since.is_none().then_some(self.next_entry)
    }

    /// A ray enters at `t` and leaves `extra + latency` cycles later (`extra`: the memory stage
    /// in front, if the pass has one). `interval` overrides the pipeline's own for this entry.
    #[inline]
    pub fn enter(&mut self, t: u64, slot: Slot, extra: u64, interval: u64) {
        debug_assert!(self.can_enter(t));
        if self.items.is_empty() {
            self.busy_since = t;
        }
        let exit = t + extra + self.latency;
        debug_assert!(self.items.back().is_none_or(|&(e, _)| e <= exit));
        self.items.push_back((exit, slot));
        self.next_entry = t + interval;
        self.stats.entries += 1;
        self.stats.issue_cycles += interval;
    }

    /// The standard interval.
    pub fn interval(&self) -> u64 {
        self.interval
    }

    /// The head ray if it has finished by `t`.
    #[inline]
    pub fn head(&self, t: u64) -> Option<Slot> {
        match self.items.front() {
            Some(&(e, s)) if e <= t => Some(s),
            _ => None,
        }
    }

    /// The head left at `t`.
    #[inline]
    pub fn leave(&mut self, t: u64) {
        self.items.pop_front();
        if let Some(since) = self.blocked_since.take() {
            self.stats.blocked_cycles += t - since;
        }
        if self.items.is_empty() {
            self.stats.busy_cycles += t - self.busy_since;
        }
    }

    /// The head could not leave at `t` (its queue is full).
    #[inline]
    pub fn block(&mut self, t: u64) {
        if self.blocked_since.is_none() {
            self.blocked_since = Some(t);
        }
    }

    pub fn is_blocked(&self) -> bool {
        self.blocked_since.is_some()
    }

    /// The cycle the head finishes, if there is one.
    #[inline]
    pub fn next_exit(&self) -> Option<u64> {
        self.items.front().map(|&(e, _)| e)
    }

    pub fn len(&self) -> usize {
        self.items.len()
    }

    pub fn is_empty(&self) -> bool {
        self.items.is_empty()
    }

    /// Counters with the time so far accounted up to `end`.
    pub fn stats_at(&self, end: u64) -> PipeStats {
        let mut s = self.stats.clone();
        if !self.items.is_empty() {
            s.busy_cycles += end.saturating_sub(self.busy_since);
        }
        if let Some(since) = self.blocked_since {
            s.blocked_cycles += end.saturating_sub(since);
        }
        s
    }
}

/// A ray accumulation unit: how many rays it holds (parked on a miss, or back with their data
/// and waiting to re-enter their pipeline), against its capacity. The rays themselves stay in
/// their slots; the pipelines' ready lists say which are back.
#[derive(Clone, Debug)]
pub struct Rau {
    held: u32,
    capacity: u32,
    last: u64,
    pub stats: RauStats,
}

impl Rau {
    pub fn new(capacity: u32) -> Rau {
        Rau {
            held: 0,
            capacity,
            last: 0,
            stats: RauStats::default(),
        }
    }

    #[inline]
    fn account(&mut self, t: u64) {
        self.stats.occupancy_sum += u128::from(self.held) * u128::from(t - self.last);
        self.last = t;
    }

    /// Whether a lookup may start (it needs an entry in case it misses).
    #[inline]
    pub fn has_room(&self) -> bool {
        self.held < self.capacity
    }

    /// A lookup takes an entry at `t` (in case it misses).
    #[inline]
    pub fn reserve(&mut self, t: u64) {
        self.account(t);
        self.held += 1;
        self.stats.max_occupancy = self.stats.max_occupancy.max(u64::from(self.held));
    }

    /// The lookup missed: its ray stays parked in the entry.
    #[inline]
    pub fn park(&mut self) {
        self.stats.parks += 1;
    }

    /// A ray leaves its entry (it re-entered its pipeline, or its lookup hit) at `t`;
    /// returns whether the RAU was full (lookups waiting for room may go on).
    #[inline]
    pub fn release(&mut self, t: u64) -> bool {
        self.account(t);
        let was_full = self.held == self.capacity;
        self.held -= 1;
        was_full
    }

    pub fn held(&self) -> u32 {
        self.held
    }

    /// Counters with the occupancy integrated up to `end`.
    pub fn stats_at(&self, end: u64) -> RauStats {
        let mut s = self.stats.clone();
        s.occupancy_sum += u128::from(self.held) * u128::from(end.saturating_sub(self.last));
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pipe_latency_interval_and_blocking() {
        let mut p = Pipe::new(5, 2);
        assert!(p.can_enter(0));
        p.enter(0, 7, 1, p.interval());
        assert!(!p.can_enter(1));
        assert!(p.can_enter(2));
        p.enter(2, 8, 1, p.interval());
        assert_eq!(p.head(5), None);
        assert_eq!(p.head(6), Some(7));
        p.leave(6);
        // The second finishes at 8 but its queue is full until 10.
        assert_eq!(p.head(8), Some(8));
        p.block(8);
        assert!(!p.can_enter(9));
        p.leave(10);
        assert!(p.is_empty());
        let s = p.stats_at(20);
        assert_eq!((s.entries, s.issue_cycles), (2, 4));
        assert_eq!(s.busy_cycles, 10);
        assert_eq!(s.blocked_cycles, 2);
    }

    #[test]
    fn rau_counts_occupancy_over_time() {
        let mut r = Rau::new(2);
        r.reserve(10);
        r.park();
        r.reserve(12);
        r.park();
        assert!(!r.has_room());
        r.release(20);
        let s = r.stats_at(30);
        // 1 ray for 2 cycles, 2 for 8, 1 for 10.
        assert_eq!(s.occupancy_sum, 2 + 16 + 10);
        assert_eq!((s.parks, s.max_occupancy), (2, 2));
    }
}
