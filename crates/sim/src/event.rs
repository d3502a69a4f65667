//! [`EventQueue`]: events ordered by (cycle, sequence number).
//!
//! Events at the same cycle come out in the order they were pushed — the sequence number breaks
//! ties — so a simulation that pushes the same events in the same order replays identically. It
//! never depends on hash order or on the events' own contents. Pushing an event before the
//! cycle of the last event popped is an error ([`EventError::Past`]): it would be handled late.
//!
//! # Layout
//!
//! Simulated events are mostly due within a few dozen cycles, so the queue is a timing wheel:
//! one FIFO per cycle of the window `[now, now + WHEEL)` (`now`: the cycle of the last event
//! popped), and a heap by (cycle, sequence number) for the events beyond it. An event pushed
//! for cycle `c` goes to `c`'s FIFO if `c` is in the window, else to the heap; whenever `now`
//! moves, the heap's events that entered the window move to their FIFOs, in (cycle, sequence)
//! order, before anything else can be pushed for those cycles. A FIFO therefore holds one cycle's
//! events in push order, and the order out is exactly that of one heap by (cycle, sequence
//! number) (a test compares the two on random pushes and pops).

use std::cmp::Ordering;
use std::collections::{BinaryHeap, VecDeque};

/// Cycles in the timing wheel's window (a power of two).
const WHEEL: u64 = 256;

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
    /// Per cycle of the window, at index `cycle % WHEEL`: its events in push order.
    wheel: Vec<VecDeque<E>>,
    /// Events in the wheel.
    in_wheel: usize,
    /// No event in the wheel is due before this cycle (`now <= first`).
    first: u64,
    /// Events at or beyond `now + WHEEL` when pushed, not yet moved into the wheel.
    far: BinaryHeap<Entry<E>>,
    seq: u64,
    now: u64,
}

impl<E> Default for EventQueue<E> {
    fn default() -> Self {
        EventQueue {
            wheel: (0..WHEEL).map(|_| VecDeque::new()).collect(),
            in_wheel: 0,
            first: 0,
            far: BinaryHeap::new(),
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
            far: BinaryHeap::with_capacity(n),
            ..Self::default()
        }
    }

    #[inline]
    fn slot(cycle: u64) -> usize {
        (cycle & (WHEEL - 1)) as usize
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
        if cycle - self.now < WHEEL {
            self.wheel[Self::slot(cycle)].push_back(event);
            if self.in_wheel == 0 || cycle < self.first {
                self.first = cycle;
            }
            self.in_wheel += 1;
        } else {
            self.far.push(Entry {
                cycle,
                seq: self.seq,
                event,
            });
        }
        Ok(())
    }

    /// The cycle of the earliest event.
    #[inline]
    pub fn next_cycle(&self) -> Option<u64> {
        if self.in_wheel == 0 {
            return self.far.peek().map(|e| e.cycle);
        }
        // `first` is kept on a non-empty FIFO by `pop`; every far event is beyond the window.
        Some(self.first)
    }

    /// Remove and return the earliest event.
    pub fn pop(&mut self) -> Option<(u64, E)> {
        if self.in_wheel == 0 {
            // Jump to the first far event: its cycle becomes `now`, and its window fills.
            let c = self.far.peek()?.cycle;
            self.advance(c);
        }
        let c = self.first;
        let event = self.wheel[Self::slot(c)]
            .pop_front()
            .expect("`first` is a non-empty cycle");
        self.in_wheel -= 1;
        self.advance(c);
        Some((c, event))
    }

    /// `now` becomes `c` (the cycle of an event being popped): far events that entered the
    /// window move to the wheel, and `first` moves to the next non-empty cycle.
    fn advance(&mut self, c: u64) {
        self.now = c;
        while let Some(e) = self.far.peek() {
            if e.cycle - c >= WHEEL {
                break;
            }
            let e = self.far.pop().expect("peeked");
            if self.in_wheel == 0 || e.cycle < self.first {
                self.first = e.cycle;
            }
            self.wheel[Self::slot(e.cycle)].push_back(e.event);
            self.in_wheel += 1;
        }
        if self.in_wheel > 0 {
            let mut f = self.first.max(c);
            while self.wheel[Self::slot(f)].is_empty() {
                f += 1;
            }
            self.first = f;
        }
    }

    /// Remove and return the earliest event if it is due at or before `cycle`.
    #[inline]
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
        self.in_wheel + self.far.len()
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
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

    /// The wheel and its far heap give exactly the order of one heap by (cycle, sequence):
    /// random pushes near and far (beyond the window, and jumps over idle time) between pops.
    #[test]
    fn same_order_as_one_heap_on_random_pushes_and_pops() {
        let mut x = 0x9e37_79b9_7f4a_7c15u64;
        let mut rnd = |n: u64| {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            x % n
        };
        let mut q = EventQueue::new();
        let mut reference: BinaryHeap<Entry<u32>> = BinaryHeap::new();
        let (mut seq, mut now, mut id) = (0u64, 0u64, 0u32);
        for _ in 0..200_000 {
            if rnd(5) < 3 {
                let ahead = match rnd(10) {
                    0 => rnd(4 * WHEEL),
                    1 => WHEEL - 1 + rnd(3),
                    _ => rnd(24),
                };
                q.push(now + ahead, id).unwrap();
                seq += 1;
                reference.push(Entry {
                    cycle: now + ahead,
                    seq,
                    event: id,
                });
                id += 1;
            } else {
                assert_eq!(q.next_cycle(), reference.peek().map(|e| e.cycle));
                let got = q.pop();
                let want = reference.pop().map(|e| (e.cycle, e.event));
                assert_eq!(got, want);
                if let Some((c, _)) = got {
                    now = c;
                }
            }
            assert_eq!(q.len(), reference.len());
        }
        while let Some(e) = reference.pop() {
            assert_eq!(q.pop(), Some((e.cycle, e.event)));
        }
        assert!(q.is_empty());
    }
}
