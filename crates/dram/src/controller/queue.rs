//! The read and write queues of one channel.
//!
//! Requests live in a fixed slab (capacity = read queue + write queue); each bank keeps its
//! schedulable requests in arrival order, one list for reads and one for writes, so the
//! scheduler looks only at the requests of a bank. A read to a line already queued for reading
//! is *merged*: it occupies a slot but rides on the first read and completes with it; likewise a
//! write to a queued line. A read to a line with a queued write is *forwarded* (answered from
//! the write queue). Requests enqueued for a future cycle wait in `pending` until they arrive
//! (plus the admission delay).
//!
//! With per-bank command queues (`command_queue_depth = n > 0`, DRAMsim3's structure) an
//! admitted request first waits in its kind's *transaction queue* (`staged_reads` /
//! `staged_writes`, arrival order); [`RequestQueues::transfer`] moves the oldest one whose bank
//! holds fewer than `n` requests into the bank's lists, freeing its read/write-queue slot. The
//! bank lists are then the command queues, and only they are scheduled. Nothing here allocates
//! after construction.

use rtsim_core::MemOp;
use rtsim_core::mem::FIBONACCI_HASH;
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
    /// Moved into its bank's command queue (no longer holds a read/write-queue slot).
    pub in_cq: bool,
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
    /// Waiting for room in its bank's command queue.
    Staged,
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
    /// Cycles from arrival until the request is admitted (seen by the scheduler).
    pub admission_delay: u64,
    /// Per-bank command-queue depth; 0 = no command-queue stage.
    pub command_queue_depth: u32,
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
    /// Admitted requests waiting for room in their bank's command queue, oldest first (only
    /// with command queues).
    staged_reads: VecDeque<u32>,
    staged_writes: VecDeque<u32>,
    /// Requests in command queues.
    in_cq: u32,
    /// The listed and staged reads and writes by line, for merging and forwarding: lookups
    /// without scanning a bank's list (a stream queues all its requests at one bank). `None`
    /// where that kind is never looked up.
    read_lines: Option<LineIndex>,
    write_lines: Option<LineIndex>,
}

impl RequestQueues {
    pub fn new(policy: QueuePolicy, banks: usize, ranks: usize) -> Self {
        // Command queues hold requests beyond the read and write queues' capacity.
        let cap = (policy.read_capacity + policy.write_capacity) as usize
            + banks * policy.command_queue_depth as usize;
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
            in_cq: false,
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
            staged_reads: VecDeque::with_capacity(policy.read_capacity as usize),
            staged_writes: VecDeque::with_capacity(policy.write_capacity as usize),
            in_cq: 0,
            read_lines: policy.merge_reads.then(|| LineIndex::new(cap)),
            write_lines: (policy.merge_writes || policy.forward_reads).then(|| LineIndex::new(cap)),
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
        let after = |s: u32| {
            let p = &self.slab[s as usize];
            (p.arrival_mem, p.seq) <= key
        };
        if self.pending.back().is_none_or(|&s| after(s)) {
            self.pending.push_back(slot);
            return;
        }
        let pos = self
            .pending
            .iter()
            .rposition(|&s| after(s))
            .map_or(0, |i| i + 1);
        self.pending.insert(pos, slot);
    }

    /// The cycle at which the first pending request is admitted (arrival + admission delay).
    #[inline]
    pub fn next_arrival(&self) -> Option<u64> {
        self.pending
            .front()
            .map(|&s| self.slab[s as usize].arrival_mem + self.policy.admission_delay)
    }

    /// Pop the first pending request if it is admitted by cycle `t`.
    #[inline]
    pub fn pop_arrived(&mut self, t: u64) -> Option<u32> {
        match self.pending.front() {
            Some(&s) if self.slab[s as usize].arrival_mem + self.policy.admission_delay <= t => {
                self.pending.pop_front()
            }
            _ => None,
        }
    }

    /// The line index of kind `op` (present where that kind is looked up).
    #[inline]
    fn lines(&mut self, op: MemOp) -> Option<&mut LineIndex> {
        match op {
            MemOp::Read => self.read_lines.as_mut(),
            MemOp::Write => self.write_lines.as_mut(),
        }
    }

    /// Command queues: move the oldest waiting request of kind `op` whose bank has room into
    /// its bank's command queue (one per cycle, as DRAMsim3 does). Returns its bank.
    pub fn transfer(&mut self, op: MemOp) -> Option<usize> {
        let depth = self.policy.command_queue_depth as usize;
        let staged = match op {
            MemOp::Read => &self.staged_reads,
            MemOp::Write => &self.staged_writes,
        };
        let i = staged.iter().position(|&s| {
            let b = self.slab[s as usize].bank as usize;
            self.reads[b].len() + self.writes[b].len() < depth
        })?;
        let staged = match op {
            MemOp::Read => &mut self.staged_reads,
            MemOp::Write => &mut self.staged_writes,
        };
        let slot = staged.remove(i).expect("position found");
        let e = &mut self.slab[slot as usize];
        e.in_cq = true;
        let b = e.bank as usize;
        match op {
            MemOp::Read => {
                self.read_slots -= 1;
                self.reads[b].push(slot);
            }
            MemOp::Write => {
                self.write_slots -= 1;
                self.writes[b].push(slot);
            }
        }
        self.in_cq += 1;
        Some(b)
    }

    /// Requests of kind `op` waiting for room in a command queue (the transaction queue).
    #[inline]
    pub fn staged_len(&self, op: MemOp) -> u32 {
        match op {
            MemOp::Read => self.staged_reads.len() as u32,
            MemOp::Write => self.staged_writes.len() as u32,
        }
    }

    /// Requests in command queues.
    #[inline]
    pub fn in_cq_len(&self) -> u32 {
        self.in_cq
    }

    /// Could [`RequestQueues::transfer`] move a request of kind `op` now?
    pub fn can_transfer(&self, op: MemOp) -> bool {
        let depth = self.policy.command_queue_depth as usize;
        let staged = match op {
            MemOp::Read => &self.staged_reads,
            MemOp::Write => &self.staged_writes,
        };
        staged.iter().any(|&s| {
            let b = self.slab[s as usize].bank as usize;
            self.reads[b].len() + self.writes[b].len() < depth
        })
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
                // A line's requests are all at one bank, so the line alone identifies them.
                if self.policy.forward_reads
                    && self
                        .write_lines
                        .as_ref()
                        .is_some_and(|w| w.contains(e.addr))
                {
                    return Admit::Forwarded;
                }
                self.reads_arrived += 1;
                self.per_rank[e.rank as usize] += 1;
                if let Some(host) = self.read_lines.as_ref().and_then(|r| r.get(e.addr)) {
                    self.attach(host, slot);
                    return Admit::Merged(host);
                }
                if let Some(ix) = self.lines(MemOp::Read) {
                    ix.insert(e.addr, slot);
                }
                if self.policy.command_queue_depth > 0 {
                    self.staged_reads.push_back(slot);
                    return Admit::Staged;
                }
                self.reads[b].push(slot);
            }
            MemOp::Write => {
                self.writes_arrived += 1;
                self.per_rank[e.rank as usize] += 1;
                if self.policy.merge_writes {
                    if let Some(host) = self.write_lines.as_ref().and_then(|w| w.get(e.addr)) {
                        self.attach(host, slot);
                        return Admit::Merged(host);
                    }
                }
                if let Some(ix) = self.lines(MemOp::Write) {
                    ix.insert(e.addr, slot);
                }
                if self.policy.command_queue_depth > 0 {
                    self.staged_writes.push_back(slot);
                    return Admit::Staged;
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
            let (op, addr) = (e.op, e.addr);
            if let Some(ix) = self.lines(op) {
                ix.remove(addr);
            }
        }
    }

    /// Free a slot whose request has been served (it must not be listed any more).
    pub fn release(&mut self, slot: u32, arrived: bool) {
        let e = self.slab[slot as usize];
        match e.op {
            MemOp::Read => {
                if !e.in_cq {
                    self.read_slots -= 1;
                }
                if arrived {
                    self.reads_arrived -= 1;
                }
            }
            MemOp::Write => {
                if !e.in_cq {
                    self.write_slots -= 1;
                }
                if arrived {
                    self.writes_arrived -= 1;
                }
            }
        }
        if e.in_cq {
            self.in_cq -= 1;
        }
        if arrived {
            self.per_rank[e.rank as usize] -= 1;
        }
        let x = &mut self.slab[slot as usize];
        x.merged = NIL;
        x.next_merged = NIL;
        x.in_cq = false;
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

    /// Requests held: pending, queued, merged, and in command queues.
    pub fn occupied(&self) -> u32 {
        self.read_slots + self.write_slots + self.in_cq
    }

    /// Anything pending or queued?
    pub fn is_empty(&self) -> bool {
        self.occupied() == 0
    }
}

/// Requests of one kind by line address: an open-addressing hash table (linear probing,
/// deletion by backward shift), allocated once, at most half full. Each line has a count of
/// its requests and the slot of one of them: where merging is on, a line has at most one
/// listed or staged request (a second one merges into it), so the slot is that request's;
/// otherwise only the count is used (forwarding asks whether a write to the line waits).
#[derive(Clone, Debug)]
struct LineIndex {
    cells: Vec<LineCell>,
    mask: usize,
    /// 64 − log2(cells): the hash keeps the top bits of the product.
    shift: u32,
}

#[derive(Clone, Copy, Debug)]
struct LineCell {
    addr: u64,
    slot: u32,
    /// Requests for `addr`; 0 = empty cell.
    count: u32,
}

impl LineIndex {
    /// Room for `max` lines.
    fn new(max: usize) -> Self {
        let size = (2 * max.max(1)).next_power_of_two();
        LineIndex {
            cells: vec![
                LineCell {
                    addr: 0,
                    slot: NIL,
                    count: 0,
                };
                size
            ],
            mask: size - 1,
            shift: 64 - size.trailing_zeros(),
        }
    }

    /// The home cell of `addr`: Fibonacci hashing (the product with 2^64 / φ, whose top bits
    /// spread line addresses, multiples of the line size, evenly).
    #[inline]
    fn home(&self, addr: u64) -> usize {
        (addr.wrapping_mul(FIBONACCI_HASH) >> self.shift) as usize
    }

    /// The cell of `addr`, or the empty cell ending its probe sequence.
    #[inline]
    fn find(&self, addr: u64) -> usize {
        let mut i = self.home(addr);
        loop {
            let c = &self.cells[i];
            if c.count == 0 || c.addr == addr {
                return i;
            }
            i = (i + 1) & self.mask;
        }
    }

    /// Is a request for `addr` indexed?
    #[inline]
    fn contains(&self, addr: u64) -> bool {
        self.cells[self.find(addr)].count > 0
    }

    /// The request for `addr` (where merging keeps lines unique).
    #[inline]
    fn get(&self, addr: u64) -> Option<u32> {
        let c = &self.cells[self.find(addr)];
        debug_assert!(c.count <= 1, "merged lines are unique");
        (c.count > 0).then_some(c.slot)
    }

    #[inline]
    fn insert(&mut self, addr: u64, slot: u32) {
        let i = self.find(addr);
        let c = &mut self.cells[i];
        if c.count == 0 {
            *c = LineCell {
                addr,
                slot,
                count: 1,
            };
        } else {
            c.count += 1;
        }
    }

    /// Forget one request for `addr` (indexed).
    #[inline]
    fn remove(&mut self, addr: u64) {
        let mut hole = self.find(addr);
        debug_assert!(self.cells[hole].count > 0);
        self.cells[hole].count -= 1;
        if self.cells[hole].count > 0 {
            return;
        }
        // Close the gap: move back each later cell of the run that may live in the hole (its
        // home is not cyclically after the hole).
        let mut j = hole;
        loop {
            j = (j + 1) & self.mask;
            let c = self.cells[j];
            if c.count == 0 {
                break;
            }
            let home = self.home(c.addr);
            if j.wrapping_sub(home) & self.mask >= j.wrapping_sub(hole) & self.mask {
                self.cells[hole] = c;
                self.cells[j].count = 0;
                hole = j;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::LineIndex;
    use std::collections::HashMap;

    /// The index agrees with a counted map through inserts and removals that collide and wrap
    /// around (a small table, addresses drawn from a few lines).
    #[test]
    fn line_index_matches_a_map() {
        let mut ix = LineIndex::new(12);
        let mut model: HashMap<u64, u32> = HashMap::new();
        // A fixed-seed linear congruential sequence (Knuth's MMIX constants).
        let mut x = 1u64;
        let mut next = || {
            x = x
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            x >> 33
        };
        for _ in 0..20_000 {
            let addr = (next() % 40) * 64;
            let n = model.get(&addr).copied().unwrap_or(0);
            let held: u32 = model.values().sum();
            if n > 0 && (next() % 2 == 0 || held >= 12) {
                ix.remove(addr);
                *model.get_mut(&addr).unwrap() -= 1;
            } else if held < 12 {
                ix.insert(addr, addr as u32);
                *model.entry(addr).or_insert(0) += 1;
            }
            for line in 0..40 {
                let a = line * 64;
                let n = model.get(&a).copied().unwrap_or(0);
                assert_eq!(ix.contains(a), n > 0, "line {line}");
            }
        }
    }
}
