//! [`CompletionQueue`]: completions waiting for the requester, by finish cycle.
//!
//! The requester takes completions in order of finish and, among equal finishes, of collection
//! (the order in which the channels produced them: channel by channel within one
//! `advance_to`). Channels produce them nearly in finish order, but one `advance_to` runs the
//! channels one after another, so about 40 % of random-traffic completions arrive behind a
//! later finish; a sorted list would place each by a search. Here each finish cycle has a
//! bucket (a list in arrival order) in a ring covering `RING` cycles from the first cycle not
//! yet drained (`base`): appending is O(1) and keeps collection order within a cycle, and
//! draining walks the buckets up to the requester's cycle. Completions beyond the ring wait in
//! `beyond` (collection order) and move into their buckets as `base` advances, before any later
//! completion can reach the same bucket; completions finishing before `base` (which the clock
//! conversion does not produce, kept for exactness) wait in `early`, sorted, and are drained
//! first. Nodes live in a slab reused through a free list: nothing allocates once the slab has
//! grown to the largest number of completions waiting at once.

use rtsim_core::MemCompletion;

/// Cycles the ring covers: a power of two, well above a read's latency in requester cycles
/// (CL + burst, at most a few hundred cycles in every preset, `config::PRESETS`), so that
/// completions go to `beyond` only after `advance_to` jumps over many cycles at once.
const RING: usize = 512;

/// "No node".
const NIL: u32 = u32::MAX;

#[derive(Clone, Copy, Debug)]
struct Node {
    c: MemCompletion,
    next: u32,
}

/// One finish cycle's completions, oldest first.
#[derive(Clone, Copy, Debug)]
struct Bucket {
    head: u32,
    tail: u32,
}

const EMPTY: Bucket = Bucket {
    head: NIL,
    tail: NIL,
};

/// Completions ordered by (finish, collection), see the module documentation.
#[derive(Clone, Debug)]
pub struct CompletionQueue {
    nodes: Vec<Node>,
    /// Free nodes, linked through `next`.
    free: u32,
    buckets: Box<[Bucket; RING]>,
    /// No completion in the ring finishes before this cycle; the ring covers
    /// `base..base + RING`.
    base: u64,
    /// Completions in the ring.
    in_ring: usize,
    /// Completions finishing at or after `base + RING`, in collection order.
    beyond: Vec<MemCompletion>,
    /// Completions finishing before `base`, sorted by (finish, collection).
    early: Vec<MemCompletion>,
}

impl CompletionQueue {
    /// Room for `capacity` completions before the slab grows.
    pub fn with_capacity(capacity: usize) -> Self {
        CompletionQueue {
            nodes: Vec::with_capacity(capacity),
            free: NIL,
            buckets: Box::new([EMPTY; RING]),
            base: 0,
            in_ring: 0,
            beyond: Vec::new(),
            early: Vec::new(),
        }
    }

    /// Add `c` after every completion finishing no later.
    #[inline]
    pub fn push(&mut self, c: MemCompletion) {
        if c.finish.wrapping_sub(self.base) < RING as u64 {
            self.push_ring(c);
        } else {
            self.push_rare(c);
        }
    }

    /// `c` finishes in the ring's span.
    #[inline]
    fn push_ring(&mut self, c: MemCompletion) {
        let n = if self.free != NIL {
            let n = self.free;
            self.free = self.nodes[n as usize].next;
            self.nodes[n as usize] = Node { c, next: NIL };
            n
        } else {
            self.nodes.push(Node { c, next: NIL });
            (self.nodes.len() - 1) as u32
        };
        let b = &mut self.buckets[c.finish as usize % RING];
        if b.tail == NIL {
            b.head = n;
        } else {
            self.nodes[b.tail as usize].next = n;
        }
        b.tail = n;
        self.in_ring += 1;
    }

    /// `c` finishes before `base` or beyond the ring.
    #[inline(never)]
    fn push_rare(&mut self, c: MemCompletion) {
        if c.finish >= self.base {
            self.beyond.push(c);
        } else {
            let at = self.early.partition_point(|e| e.finish <= c.finish);
            self.early.insert(at, c);
        }
    }

    /// The earliest finish waiting, if any.
    pub fn first_finish(&self) -> Option<u64> {
        if let Some(e) = self.early.first() {
            return Some(e.finish);
        }
        if self.in_ring > 0 {
            for c in self.base..self.base + RING as u64 {
                if self.buckets[c as usize % RING].head != NIL {
                    return Some(c);
                }
            }
        }
        self.beyond.iter().map(|c| c.finish).min()
    }

    /// Move every completion finishing at or before `now` to `out`, in order; returns how many.
    #[inline]
    pub fn drain_to(&mut self, now: u64, out: &mut Vec<MemCompletion>) -> usize {
        let mut moved = 0;
        if !self.early.is_empty() {
            moved += self.early.len();
            out.append(&mut self.early);
        }
        if now < self.base {
            return moved;
        }
        let mut c = self.base;
        while self.in_ring > 0 && c <= now && c < self.base + RING as u64 {
            let b = &mut self.buckets[c as usize % RING];
            let mut n = b.head;
            *b = EMPTY;
            while n != NIL {
                let node = &mut self.nodes[n as usize];
                out.push(node.c);
                let next = node.next;
                node.next = self.free;
                self.free = n;
                n = next;
                self.in_ring -= 1;
                moved += 1;
            }
            c += 1;
        }
        self.base = now + 1;
        if !self.beyond.is_empty() {
            moved += self.advance_beyond(now, out);
        }
        moved
    }

    /// After `base` advanced past `now`: move the completions of `beyond` that finish by `now`
    /// to `out` (collection order within a finish) and those now in the ring's span into their
    /// buckets, in collection order, before any later completion can reach the same bucket.
    #[inline(never)]
    fn advance_beyond(&mut self, now: u64, out: &mut Vec<MemCompletion>) -> usize {
        let mut due: Vec<MemCompletion> = Vec::new();
        let mut keep = Vec::with_capacity(self.beyond.len());
        let beyond = std::mem::take(&mut self.beyond);
        for c in beyond {
            if c.finish <= now {
                due.push(c);
            } else if c.finish - self.base < RING as u64 {
                self.push_ring(c);
            } else {
                keep.push(c);
            }
        }
        self.beyond = keep;
        // Stable: equal finishes keep collection order.
        due.sort_by_key(|c| c.finish);
        let n = due.len();
        out.append(&mut due);
        n
    }
}

#[cfg(test)]
mod tests {
    use super::CompletionQueue;
    use rtsim_core::{MemCompletion, MemOp};
    use std::collections::VecDeque;

    fn completion(id: u64, finish: u64) -> MemCompletion {
        MemCompletion {
            id,
            addr: 0,
            op: MemOp::Read,
            arrival: 0,
            finish,
            tag: 0,
        }
    }

    /// The queue gives the order of a list sorted by (finish, collection) — the order the
    /// sorted deque it replaced gave — through pushes near and far (beyond the ring, and
    /// before the drained cycle) and drains of short and long spans.
    #[test]
    fn matches_a_sorted_list() {
        let mut q = CompletionQueue::with_capacity(4);
        let mut model: VecDeque<MemCompletion> = VecDeque::new();
        // A fixed-seed linear congruential sequence (Knuth's MMIX constants).
        let mut x = 7u64;
        let mut next = || {
            x = x
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            x >> 33
        };
        let mut now = 0u64;
        let mut id = 0;
        let (mut got, mut want) = (Vec::new(), Vec::new());
        for _ in 0..20_000 {
            for _ in 0..next() % 4 {
                let finish = match next() % 16 {
                    0 => now + 1 + next() % 3000,
                    1 => now.saturating_sub(next() % 5),
                    _ => now + 1 + next() % 40,
                };
                id += 1;
                let c = completion(id, finish);
                q.push(c);
                let at = model
                    .iter()
                    .rposition(|m| m.finish <= finish)
                    .map_or(0, |i| i + 1);
                model.insert(at, c);
            }
            now += if next() % 50 == 0 {
                next() % 2000
            } else {
                next() % 4
            };
            got.clear();
            want.clear();
            let n = q.drain_to(now, &mut got);
            while model.front().is_some_and(|m| m.finish <= now) {
                want.push(model.pop_front().unwrap());
            }
            assert_eq!(n, got.len());
            assert_eq!(
                got.iter().map(|c| c.id).collect::<Vec<_>>(),
                want.iter().map(|c| c.id).collect::<Vec<_>>(),
                "at {now}"
            );
            assert_eq!(q.first_finish(), model.front().map(|m| m.finish));
        }
    }
}
