//! [`EventQueue`]: events ordered by (cycle, sequence number).
//!
//! Events at the same cycle come out in the order they were pushed — the sequence number breaks
//! ties — so a simulation that pushes the same events in the same order replays identically. It
//! never depends on hash order or on the events' own contents. Pushing an event before the
//! cycle of the last event popped is an error ([`EventError::Past`]): it would be handled late.

use std::cmp::Ordering;
use std::collections::BinaryHeap;

/// An event scheduled for an earlier cycle than the queue has already reached.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
pub enum EventError {
    #[error("event scheduled for cycle {cycle}, before the present cycle {now}")]
    Past { cycle: u64, now: u64 },
}

#[derive(Debug)]
struct Entry<E> {
    cycle: u64,
    seq: u64,
    event: E,
}

impl<E> PartialEq for Entry<E> {
    fn eq(&self, o: &Self) -> bool {
        (self.cycle, self.seq) == (o.cycle, o.seq)
    }
}
impl<E> Eq for Entry<E> {}
impl<E> PartialOrd for Entry<E> {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}
impl<E> Ord for Entry<E> {
    /// Reversed, so that the max-heap's top is the earliest (cycle, seq).
    fn cmp(&self, o: &Self) -> Ordering {
        (o.cycle, o.seq).cmp(&(self.cycle, self.seq))
    }
}

/// A priority queue of events by (cycle, insertion order).
#[derive(Debug)]
pub struct EventQueue<E> {
    heap: BinaryHeap<Entry<E>>,
    seq: u64,
    now: u64,
}

impl<E> Default for EventQueue<E> {
    fn default() -> Self {
        EventQueue {
            heap: BinaryHeap::new(),
            seq: 0,
            now: 0,
        }
    }
}

impl<E> EventQueue<E> {
    pub fn new() -> Self {
        Self::default()
    }

    pub fn with_capacity(n: usize) -> Self {
        EventQueue {
            heap: BinaryHeap::with_capacity(n),
            ..Self::default()
        }
    }

    /// Schedule `event` at `cycle` (not before the cycle of the last event popped).
    pub fn push(&mut self, cycle: u64, event: E) -> Result<(), EventError> {
        if cycle < self.now {
            return Err(EventError::Past {
                cycle,
                now: self.now,
            });
        }
        self.seq += 1;
        self.heap.push(Entry {
            cycle,
            seq: self.seq,
            event,
        });
        Ok(())
    }

    /// The cycle of the earliest event.
    pub fn next_cycle(&self) -> Option<u64> {
        self.heap.peek().map(|e| e.cycle)
    }

    /// Remove and return the earliest event.
    pub fn pop(&mut self) -> Option<(u64, E)> {
        let e = self.heap.pop()?;
        self.now = e.cycle;
        Some((e.cycle, e.event))
    }

    /// Remove and return the earliest event if it is due at or before `cycle`.
    pub fn pop_due(&mut self, cycle: u64) -> Option<(u64, E)> {
        if self.next_cycle()? <= cycle {
            self.pop()
        } else {
            None
        }
    }

    /// The cycle of the last event popped (0 before any).
    pub fn now(&self) -> u64 {
        self.now
    }

    pub fn len(&self) -> usize {
        self.heap.len()
    }

    pub fn is_empty(&self) -> bool {
        self.heap.is_empty()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ordered_by_cycle_then_insertion() {
        let mut q = EventQueue::new();
        // Contents chosen so that ordering by content would give a different answer.
        for (c, e) in [(5, 'z'), (3, 'y'), (5, 'a'), (3, 'b'), (5, 'm'), (0, 'q')] {
            q.push(c, e).unwrap();
        }
        let out: Vec<_> = std::iter::from_fn(|| q.pop()).collect();
        assert_eq!(
            out,
            vec![(0, 'q'), (3, 'y'), (3, 'b'), (5, 'z'), (5, 'a'), (5, 'm')]
        );
    }

    #[test]
    fn many_ties_keep_insertion_order() {
        let mut q = EventQueue::new();
        for i in 0..1000u32 {
            q.push(u64::from(i % 3), i).unwrap();
        }
        let mut last = (0u64, None::<u32>);
        while let Some((c, i)) = q.pop() {
            assert!(c >= last.0);
            if c == last.0 {
                assert!(last.1.is_none_or(|p| p < i), "tie out of order");
            }
            last = (c, Some(i));
        }
    }

    #[test]
    fn pop_due_and_past_events() {
        let mut q = EventQueue::new();
        q.push(4, "a").unwrap();
        q.push(9, "b").unwrap();
        assert_eq!(q.pop_due(3), None);
        assert_eq!(q.pop_due(4), Some((4, "a")));
        assert_eq!(q.now(), 4);
        assert_eq!(
            q.push(3, "late"),
            Err(EventError::Past { cycle: 3, now: 4 })
        );
        q.push(4, "same cycle is fine").unwrap();
        assert_eq!(q.next_cycle(), Some(4));
        assert_eq!(q.len(), 2);
    }
}
