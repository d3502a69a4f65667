//! [`Link`]: a bounded queue with a latency, the only way units talk to each other.
//!
//! An item pushed at cycle `t` becomes visible to the receiver at `t + latency`. The capacity
//! counts everything in the link — items still in flight and items that have arrived but were
//! not yet taken — so a link of capacity `n` never holds more than `n` items, and a receiver
//! that stops taking items fills it: a full link refuses the push and hands the item back. That
//! is back-pressure, not a special case (`../shared/STYLE.md` §3). Items leave in push order.
//!
//! Time never goes backwards on a link: a push or a pop at a cycle earlier than the last one
//! seen is an error ([`LinkError::Past`]), not a panic. [`Link::next_ready`] tells the caller
//! when the head item becomes visible, so idle cycles can be skipped. Occupancy is integrated
//! over time for [`LinkStats`].

use crate::Stats;
use serde::{Deserialize, Serialize};
use std::collections::VecDeque;

/// Counters of one link (`+=` merges links).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize, Stats)]
pub struct LinkStats {
    /// Items accepted.
    pub pushes: u64,
    /// Pushes refused because the link was full.
    pub refused: u64,
    /// Items taken by the receiver.
    pub pops: u64,
    /// Σ occupancy × cycles, for the time-averaged occupancy.
    pub occupancy_sum: u128,
    /// Cycles over which the occupancy was integrated.
    pub cycles: u64,
    /// Largest occupancy seen.
    #[stats(max)]
    pub max_occupancy: u64,
}

impl LinkStats {
    /// Time-averaged number of items in the link.
    pub fn mean_occupancy(&self) -> f64 {
        rtsim_core::stats::ratio(self.occupancy_sum as f64, self.cycles as f64)
    }
}

/// Misuse of a link by its caller.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
pub enum LinkError {
    #[error("link used at cycle {cycle}, before cycle {now} already seen")]
    Past { cycle: u64, now: u64 },
    #[error("link capacity must be at least 1")]
    ZeroCapacity,
}

/// Why a push failed; a full link returns the item.
#[derive(Debug, PartialEq, Eq, thiserror::Error)]
pub enum PushError<T> {
    #[error("link full")]
    Full(T),
    #[error(transparent)]
    Link(#[from] LinkError),
}

/// A bounded FIFO whose items become visible `latency` cycles after they are pushed.
#[derive(Clone, Debug)]
pub struct Link<T> {
    latency: u64,
    capacity: usize,
    items: VecDeque<(u64, T)>,
    now: u64,
    stats: LinkStats,
}

impl<T> Link<T> {
    /// A link holding at most `capacity` items (≥ 1) with the given latency in cycles (0 = the
    /// item is visible in the cycle it is pushed).
    pub fn new(capacity: usize, latency: u64) -> Result<Self, LinkError> {
        if capacity == 0 {
            return Err(LinkError::ZeroCapacity);
        }
        Ok(Link {
            latency,
            capacity,
            items: VecDeque::with_capacity(capacity),
            now: 0,
            stats: LinkStats::default(),
        })
    }

    pub fn capacity(&self) -> usize {
        self.capacity
    }
    pub fn latency(&self) -> u64 {
        self.latency
    }
    /// Items in the link (in flight and arrived).
    pub fn len(&self) -> usize {
        self.items.len()
    }
    pub fn is_empty(&self) -> bool {
        self.items.is_empty()
    }
    pub fn is_full(&self) -> bool {
        self.items.len() >= self.capacity
    }

    /// Account occupancy up to `cycle` and make it the present.
    fn seen(&mut self, cycle: u64) -> Result<(), LinkError> {
        if cycle < self.now {
            return Err(LinkError::Past {
                cycle,
                now: self.now,
            });
        }
        let dt = cycle - self.now;
        self.stats.occupancy_sum += self.items.len() as u128 * u128::from(dt);
        self.stats.cycles += dt;
        self.now = cycle;
        Ok(())
    }

    /// Push `item` at `cycle`; it is visible from `cycle + latency`. A full link refuses it and
    /// returns it in [`PushError::Full`].
    pub fn push(&mut self, cycle: u64, item: T) -> Result<(), PushError<T>> {
        self.seen(cycle)?;
        if self.is_full() {
            self.stats.refused += 1;
            return Err(PushError::Full(item));
        }
        self.items
            .push_back((cycle.saturating_add(self.latency), item));
        self.stats.pushes += 1;
        self.stats.max_occupancy = self.stats.max_occupancy.max(self.items.len() as u64);
        Ok(())
    }

    /// Items visible at `cycle` (arrived and not yet taken): a receiver that takes items in
    /// batches (a shader taking a packet of hits) decides by it.
    pub fn visible_len(&self, cycle: u64) -> usize {
        self.items.partition_point(|&(t, _)| t <= cycle)
    }

    /// The cycle at which the first item not yet visible at `cycle` becomes visible.
    pub fn next_ready_after(&self, cycle: u64) -> Option<u64> {
        self.items.get(self.visible_len(cycle)).map(|&(t, _)| t)
    }

    /// The cycle at which the head item is (or was) visible; `None` when empty.
    pub fn next_ready(&self) -> Option<u64> {
        self.items.front().map(|&(t, _)| t)
    }

    /// The head item if it is visible at `cycle`.
    pub fn peek(&self, cycle: u64) -> Option<&T> {
        match self.items.front() {
            Some((t, item)) if *t <= cycle => Some(item),
            _ => None,
        }
    }

    /// Take the head item if it is visible at `cycle`.
    pub fn pop(&mut self, cycle: u64) -> Result<Option<T>, LinkError> {
        self.seen(cycle)?;
        match self.items.front() {
            Some(&(t, _)) if t <= cycle => {
                self.stats.pops += 1;
                Ok(self.items.pop_front().map(|(_, item)| item))
            }
            _ => Ok(None),
        }
    }

    /// Counters, with the occupancy integrated up to `cycle` (not before the last cycle seen).
    pub fn stats(&mut self, cycle: u64) -> LinkStats {
        let _ = self.seen(cycle.max(self.now));
        self.stats.clone()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Ramulator's lesson: a queue of capacity n takes exactly n items, the (n+1)-th is refused
    /// and handed back, and taking one makes room for exactly one more.
    #[test]
    fn holds_exactly_its_capacity() {
        for cap in [1usize, 2, 7, 32] {
            let mut l = Link::new(cap, 5).unwrap();
            for i in 0..cap {
                l.push(0, i).unwrap();
            }
            assert!(l.is_full());
            assert_eq!(l.push(0, 99), Err(PushError::Full(99)));
            // In flight items count: nothing is visible before the latency has passed.
            assert_eq!(l.pop(4).unwrap(), None);
            assert_eq!(l.push(4, 99), Err(PushError::Full(99)));
            assert_eq!(l.pop(5).unwrap(), Some(0));
            l.push(5, 100).unwrap();
            assert_eq!(l.push(5, 101), Err(PushError::Full(101)));
            assert_eq!(l.len(), cap);
            let s = l.stats(5);
            assert_eq!((s.pushes, s.refused, s.pops), (cap as u64 + 1, 3, 1));
            assert_eq!(s.max_occupancy, cap as u64);
        }
    }

    #[test]
    fn latency_and_order() {
        let mut l = Link::new(4, 3).unwrap();
        l.push(10, 'a').unwrap();
        l.push(11, 'b').unwrap();
        assert_eq!(l.next_ready(), Some(13));
        assert_eq!(l.peek(12), None);
        assert_eq!(
            (l.visible_len(12), l.visible_len(13), l.visible_len(14)),
            (0, 1, 2)
        );
        assert_eq!(
            (l.next_ready_after(12), l.next_ready_after(13)),
            (Some(13), Some(14))
        );
        assert_eq!(l.next_ready_after(14), None);
        assert_eq!(l.pop(12).unwrap(), None);
        assert_eq!(l.peek(13), Some(&'a'));
        assert_eq!(l.pop(13).unwrap(), Some('a'));
        assert_eq!(l.next_ready(), Some(14));
        assert_eq!(l.pop(20).unwrap(), Some('b'));
        assert_eq!(l.next_ready(), None);
        // Zero latency: visible in the same cycle.
        let mut z = Link::new(1, 0).unwrap();
        z.push(7, 1u8).unwrap();
        assert_eq!(z.pop(7).unwrap(), Some(1));
    }

    #[test]
    fn time_going_backwards_is_an_error() {
        let mut l = Link::new(2, 1).unwrap();
        l.push(10, 1).unwrap();
        assert_eq!(
            l.push(9, 2),
            Err(PushError::Link(LinkError::Past { cycle: 9, now: 10 }))
        );
        assert_eq!(l.pop(3), Err(LinkError::Past { cycle: 3, now: 10 }));
        assert!(matches!(
            Link::<u8>::new(0, 1),
            Err(LinkError::ZeroCapacity)
        ));
    }

    #[test]
    fn occupancy_is_integrated_over_time() {
        let mut l = Link::new(4, 0).unwrap();
        l.push(0, ()).unwrap();
        l.push(2, ()).unwrap(); // 1 item for cycles 0..2
        l.pop(6).unwrap(); // 2 items for 2..6
        let s = l.stats(10); // 1 item for 6..10
        assert_eq!(s.occupancy_sum, 2 + 8 + 4);
        assert_eq!(s.cycles, 10);
        assert!((s.mean_occupancy() - 1.4).abs() < 1e-12);
    }
}
