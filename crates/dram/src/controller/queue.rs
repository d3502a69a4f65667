//! The read and write queues of one channel.
//!
//! Requests live in a fixed slab (capacity = read queue + write queue); each bank keeps its
//! schedulable requests in arrival order, one list for reads and one for writes, so the
//! scheduler looks only at the requests of a bank. A read to a line already queued for reading
//! is *merged*: it occupies a slot but rides on the first read and completes with it; likewise a
//! write to a queued line. A read to a line with a queued write is *forwarded* (answered from
//! the write queue). Requests enqueued for a future cycle wait in `pending` until they arrive.
//! Nothing here allocates after construction.

use rtsim_core::MemOp;
use std::collections::VecDeque;

/// "No entry".
pub const NIL: u32 = u32::MAX;

/// One queued request.
#[derive(Clone, Copy, Debug)]
pub struct Entry {
    pub id: u64,
    /// Line-aligned address.
    pub addr: u64,
    /// The address as requested (returned in the completion).
    pub req_addr: u64,
    pub op: MemOp,
    /// Requester-clock arrival (as given).
    pub arrival_req: u64,
    /// Memory cycle at which the controller sees it.
    pub arrival_mem: u64,
    /// Requester tag (per-tag stats).
    pub tag: u32,
    /// Global arrival order (smaller = older).
    pub seq: u64,
    pub rank: u32,
    /// Flat bank index within the channel (rank × banks per rank + bank).
    pub bank: u32,
    pub row: u32,
    /// An ACT was issued for this request (it was not a row hit).
    pub act_for: bool,
    /// A PRE was issued for this request (a row conflict).
    pub pre_for: bool,
    /// Head of the list of requests merged into this one.
    pub merged: u32,
    /// Next in the merged list of the request this one is merged into.
    pub next_merged: u32,
}

/// Outcome of admitting a request that has arrived.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Admit {
    /// Queued for scheduling at its bank.
    Queued,
    /// Merged into the queued request in the given slot.
    Merged(u32),
    /// A read answered from a queued write.
    Forwarded,
}

/// Queue capacities and which merging is enabled.
#[derive(Clone, Copy, Debug)]
pub struct QueuePolicy {
    pub read_capacity: u32,
    pub write_capacity: u32,
    pub merge_reads: bool,
    pub merge_writes: bool,
    pub forward_reads: bool,
}

#[derive(Clone, Debug)]
pub struct RequestQueues {
    pub policy: QueuePolicy,
    slab: Vec<Entry>,
    /// The row of each slot's request, apart from the slab so that bank-list scans stay in
    /// cache.
    rows: Vec<u32>,
    free: Vec<u32>,
    /// Slots in use by reads / writes (pending, queued and merged).
    pub read_slots: u32,
    pub write_slots: u32,
    /// Arrived requests per kind (queued + merged), for the write-drain decision.
    pub reads_arrived: u32,
    pub writes_arrived: u32,
    /// Schedulable requests per flat bank, oldest first.
    pub reads: Vec<Vec<u32>>,
    pub writes: Vec<Vec<u32>>,
    /// Arrived requests per rank (queued + merged), for power-down decisions.
    pub per_rank: Vec<u32>,
    /// Requests enqueued for a future cycle, sorted by arrival cycle.
    pending: VecDeque<u32>,
}

impl RequestQueues {
    pub fn new(policy: QueuePolicy, banks: usize, ranks: usize) -> Self {
        let cap = (policy.read_capacity + policy.write_capacity) as usize;
        let blank = Entry {
            id: 0,
            addr: 0,
            req_addr: 0,
            op: MemOp::Read,
            arrival_req: 0,
            arrival_mem: 0,
            tag: 0,
            seq: 0,
            rank: 0,
            bank: 0,
            row: 0,
            act_for: false,
            pre_for: false,
            merged: NIL,
            next_merged: NIL,
        };
        RequestQueues {
            policy,
            slab: vec![blank; cap],
            rows: vec![0; cap],
            free: (0..cap as u32).rev().collect(),
            read_slots: 0,
            write_slots: 0,
            reads_arrived: 0,
            writes_arrived: 0,
            reads: (0..banks)
                .map(|_| Vec::with_capacity(policy.read_capacity as usize))
                .collect(),
            writes: (0..banks)
                .map(|_| Vec::with_capacity(policy.write_capacity as usize))
                .collect(),
            per_rank: vec![0; ranks],
            pending: VecDeque::with_capacity(cap),
        }
    }

    /// Is there room for a request of kind `op`?
    #[inline]
    pub fn has_room(&self, op: MemOp) -> bool {
        match op {
            MemOp::Read => self.read_slots < self.policy.read_capacity,
            MemOp::Write => self.write_slots < self.policy.write_capacity,
        }
    }

    #[inline]
    pub fn get(&self, slot: u32) -> &Entry {
        &self.slab[slot as usize]
    }

    /// The row of the request in `slot`.
    #[inline]
    pub fn row(&self, slot: u32) -> u32 {
        self.rows[slot as usize]
    }

    #[inline]
    pub fn get_mut(&mut self, slot: u32) -> &mut Entry {
        &mut self.slab[slot as usize]
    }

    /// Take a slot for `e` and put it in the pending list (it arrives at `e.arrival_mem`).
    /// The caller has checked [`RequestQueues::has_room`].
    pub fn push_pending(&mut self, e: Entry) {
        let slot = self.free.pop().expect("capacity checked by has_room");
        self.slab[slot as usize] = e;
        self.rows[slot as usize] = e.row;
        match e.op {
            MemOp::Read => self.read_slots += 1,
            MemOp::Write => self.write_slots += 1,
        }
        // Usually appended at the back; keep the list sorted by (arrival, seq).
        let key = (e.arrival_mem, e.seq);
        let pos = self
            .pending
            .iter()
            .rposition(|&s| {
                let p = &self.slab[s as usize];
                (p.arrival_mem, p.seq) <= key
            })
            .map_or(0, |i| i + 1);
        self.pending.insert(pos, slot);
    }

    /// Arrival cycle of the first pending request.
    #[inline]
    pub fn next_arrival(&self) -> Option<u64> {
        self.pending
            .front()
            .map(|&s| self.slab[s as usize].arrival_mem)
    }

    /// Pop the first pending request if it has arrived by cycle `t`.
    #[inline]
    pub fn pop_arrived(&mut self, t: u64) -> Option<u32> {
        match self.pending.front() {
            Some(&s) if self.slab[s as usize].arrival_mem <= t => self.pending.pop_front(),
            _ => None,
        }
    }

    /// The queued requests of `op` at flat bank `b`, oldest first.
    #[inline]
    pub fn bank_list(&self, op: MemOp, b: usize) -> &[u32] {
        match op {
            MemOp::Read => &self.reads[b],
            MemOp::Write => &self.writes[b],
        }
    }

    /// Admit an arrived request: forward it, merge it, or queue it at its bank.
    pub fn admit(&mut self, slot: u32) -> Admit {
        let e = self.slab[slot as usize];
        let b = e.bank as usize;
        match e.op {
            MemOp::Read => {
                if self.policy.forward_reads
                    && self.writes[b]
                        .iter()
                        .any(|&w| self.slab[w as usize].addr == e.addr)
                {
                    return Admit::Forwarded;
                }
                self.reads_arrived += 1;
                self.per_rank[e.rank as usize] += 1;
                if self.policy.merge_reads {
                    if let Some(&host) = self.reads[b]
                        .iter()
                        .find(|&&r| self.slab[r as usize].addr == e.addr)
                    {
                        self.attach(host, slot);
                        return Admit::Merged(host);
                    }
                }
                self.reads[b].push(slot);
            }
            MemOp::Write => {
                self.writes_arrived += 1;
                self.per_rank[e.rank as usize] += 1;
                if self.policy.merge_writes {
                    if let Some(&host) = self.writes[b]
                        .iter()
                        .find(|&&w| self.slab[w as usize].addr == e.addr)
                    {
                        self.attach(host, slot);
                        return Admit::Merged(host);
                    }
                }
                self.writes[b].push(slot);
            }
        }
        Admit::Queued
    }

    fn attach(&mut self, host: u32, slot: u32) {
        let head = self.slab[host as usize].merged;
        self.slab[slot as usize].next_merged = head;
        self.slab[host as usize].merged = slot;
    }

    /// Remove the queued request in `slot` from its bank list (it has been issued).
    pub fn unlist(&mut self, slot: u32) {
        let e = &self.slab[slot as usize];
        let list = match e.op {
            MemOp::Read => &mut self.reads[e.bank as usize],
            MemOp::Write => &mut self.writes[e.bank as usize],
        };
        if let Some(i) = list.iter().position(|&s| s == slot) {
            list.remove(i);
        }
    }

    /// Free a slot whose request has been served (it must not be listed any more).
    pub fn release(&mut self, slot: u32, arrived: bool) {
        let e = self.slab[slot as usize];
        match e.op {
            MemOp::Read => {
                self.read_slots -= 1;
                if arrived {
                    self.reads_arrived -= 1;
                }
            }
            MemOp::Write => {
                self.write_slots -= 1;
                if arrived {
                    self.writes_arrived -= 1;
                }
            }
        }
        if arrived {
            self.per_rank[e.rank as usize] -= 1;
        }
        let x = &mut self.slab[slot as usize];
        x.merged = NIL;
        x.next_merged = NIL;
        self.free.push(slot);
    }

    /// Is some queued request (read or write) of flat bank `b` for `row`, other than `except`?
    pub fn row_wanted(&self, b: usize, row: u32, except: u32) -> bool {
        self.reads[b]
            .iter()
            .chain(&self.writes[b])
            .any(|&s| s != except && self.rows[s as usize] == row)
    }

    /// Requests accepted but not yet arrived.
    pub fn pending_len(&self) -> u32 {
        self.pending.len() as u32
    }

    /// Total slots in use.
    pub fn occupied(&self) -> u32 {
        self.read_slots + self.write_slots
    }

    /// Anything pending or queued?
    pub fn is_empty(&self) -> bool {
        self.occupied() == 0
    }
}
