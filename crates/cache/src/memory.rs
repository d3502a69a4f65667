//! [`FixedLatency`]: a memory that answers every line request a fixed number of cycles after it
//! arrives, with a bounded queue of outstanding requests.
//!
//! Not DRAM: no rows, banks or refresh. It is the memory of unit tests and of studies that want
//! caches without DRAM effects (as pycachesim's main memory, but timed); it honours the whole
//! `MemoryPort` contract — back-pressure with retry hints, tags, arrivals in the past refused.

use rtsim_core::{MemCompletion, MemError, MemRequest, MemoryPort, QueueFull};
use std::collections::VecDeque;

/// A memory with constant latency and at most `capacity` requests outstanding.
#[derive(Clone, Debug)]
pub struct FixedLatency {
    latency: u64,
    capacity: usize,
    line_bytes: u32,
    tags: u32,
    /// Outstanding requests in arrival order (finish times are nondecreasing).
    queue: VecDeque<MemCompletion>,
    done: Vec<MemCompletion>,
    now: Option<u64>,
    /// Requests accepted per tag.
    pub accepted: Vec<u64>,
}

impl FixedLatency {
    /// `latency` ≥ 1 cycles, `capacity` ≥ 1 outstanding requests, lines of `line_bytes`,
    /// requester tags `0..tags`.
    pub fn new(latency: u64, capacity: usize, line_bytes: u32, tags: u32) -> Self {
        FixedLatency {
            latency: latency.max(1),
            capacity: capacity.max(1),
            line_bytes,
            tags,
            queue: VecDeque::with_capacity(capacity),
            done: Vec::new(),
            now: None,
            accepted: vec![0; tags as usize],
        }
    }
}

impl MemoryPort for FixedLatency {
    fn try_enqueue(&mut self, r: MemRequest) -> Result<(), MemError> {
        if let Some(now) = self.now.filter(|&n| r.arrival <= n) {
            return Err(MemError::Past {
                id: r.id,
                arrival: r.arrival,
                now,
            });
        }
        if r.tag >= self.tags {
            return Err(MemError::Tag {
                id: r.id,
                tag: r.tag,
                tags: self.tags,
            });
        }
        if self.queue.len() >= self.capacity {
            // Room appears when the oldest finishes.
            let first = self.queue.front().map_or(r.arrival, |c| c.finish);
            return Err(QueueFull {
                retry_at: first.max(r.arrival) + 1,
                queue: 0,
                domain: 0,
            }
            .into());
        }
        let arrival = r.arrival.max(self.queue.back().map_or(0, |c| c.arrival));
        self.accepted[r.tag as usize] += 1;
        self.queue.push_back(MemCompletion {
            id: r.id,
            addr: r.addr,
            op: r.op,
            arrival: r.arrival,
            finish: arrival + self.latency,
            tag: r.tag,
        });
        Ok(())
    }
    fn advance_to(&mut self, cycle: u64) {
        while let Some(c) = self.queue.front().filter(|c| c.finish <= cycle) {
            self.done.push(*c);
            self.queue.pop_front();
        }
        self.now = Some(self.now.map_or(cycle, |n| n.max(cycle)));
    }
    fn next_event(&self) -> Option<u64> {
        self.queue.front().map(|c| c.finish)
    }
    fn drain_completions(&mut self, out: &mut Vec<MemCompletion>) {
        out.append(&mut self.done);
    }
    fn outstanding(&self) -> usize {
        self.queue.len() + self.done.len()
    }
    fn now(&self) -> Option<u64> {
        self.now
    }
    fn line_bytes(&self) -> u32 {
        self.line_bytes
    }
    /// Refusals are not counted here.
    fn refuse_again(&mut self, _req: &MemRequest, _times: u64) {}
}
