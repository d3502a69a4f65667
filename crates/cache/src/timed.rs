//! [`Hierarchy`]: the timed cache tree — banks, hit latencies, MSHRs, write buffers — over a
//! memory model behind [`MemoryPort`], simulated event by event in the chip's clock.
//!
//! # Interface
//!
//! Requests `(cycle, l1, addr, op, tag)` are [`submit`](Hierarchy::submit)ted in nondecreasing
//! cycle order (an earlier cycle is [`HierarchyError::Past`], never a panic). The L1 answers at
//! once:
//!
//! - [`Outcome::Done`]: a read hit, or a write the L1 accepted (write-around writes are posted;
//!   write-back write hits), with the cycle its data is ready (`cycle + hit_latency`);
//! - [`Outcome::Pending`]: a miss; its [`Completion`] comes later from
//!   [`drain_completions`](Hierarchy::drain_completions), ready when the line arrives;
//! - [`Outcome::Busy`]: refused — the access's bank already served an access this cycle, every
//!   MSHR is busy, or the write buffer is full. Back-pressure: nothing happened, and the
//!   requester offers it again at `retry_at` (no earlier cycle can succeed).
//!
//! [`next_event`](Hierarchy::next_event) is the next cycle at which anything happens inside
//! (the caches' events or the memory's), so a chip jumps over idle time with
//! [`advance_to`](Hierarchy::advance_to); advancing cycle by cycle gives identical results (a
//! test checks it). Events at a cycle are handled before requests submitted at that cycle.
//!
//! # Timing rules
//!
//! - **Banks.** A cache of `banks` banks (a power of two) sends an access to bank
//!   `(address / bank_bytes) mod banks` — by default `bank_bytes` is the line, so the bank is
//!   the address bits just above the line offset — and each bank does one lookup per cycle. At an L1 a second access to a busy bank is refused
//!   (`Busy`, retry next cycle); at an inner cache (an L2) it waits for the bank's next free
//!   cycle (the wait is recorded in `bank_wait`). Each such conflict is counted once per
//!   attempt. With `combine_reads`, a read arriving at an inner cache while an earlier read of
//!   the same line waits for its bank joins it: that one lookup answers both (`combined`).
//! - **Hits** are ready `hit_latency` cycles after the lookup.
//! - **Misses** allocate an MSHR at lookup; the request reaches the next level `hit_latency`
//!   cycles later (the tag check). A miss to a line already in flight merges into its MSHR
//!   (counted) and completes with it. With every MSHR busy an L1 refuses the access and an inner
//!   cache queues it until an MSHR frees (each try counted as an MSHR-full stall); queued
//!   accesses are re-examined first-in first-out, stopping at the first refused again, without
//!   a second bank lookup. When the line
//!   arrives it is installed (evicting by the replacement policy) and every merged access
//!   completes in that cycle; an inner cache forwards the line to the waiting children in the
//!   same cycle.
//! - **Writes** follow the write policy. Write-around: the write updates a hit line and goes to
//!   the next level through the write buffer, `hit_latency` later; the buffer entry frees when
//!   the next level accepts the write (an inner cache: when it performs it; memory: when the
//!   controller queues it). Write-back: a hit marks the line dirty; a miss allocates like a read
//!   and the line arrives dirty; a dirty victim goes through the write buffer. Each MSHR of a
//!   write-back cache reserves a write-buffer entry for its victim, so a fill never finds the
//!   buffer full.
//! - **Memory.** Caches whose parent is memory send line requests through the port, tagged by
//!   their index among such caches (per-L2 DRAM stats). A full DRAM queue is retried at the
//!   port's retry hint. The cache line must equal the memory's line size (checked at build).
//!
//! Fixed order everywhere: events by (cycle, insertion), MSHR targets in arrival order,
//! blocked accesses first-come first-served, memory completions in the port's order.

use crate::cache::Cache;
use crate::config::WritePolicy;
use crate::stats::CacheStats;
use crate::topology::{Parent, Topology};
use rtsim_config::ConfigError;
use rtsim_core::mem::FIBONACCI_HASH;
use rtsim_core::{MemCompletion, MemError, MemOp, MemRequest, MemoryPort, QueueFull};
use rtsim_sim::{Component, EventError, EventQueue};
use std::cell::Cell;
use std::collections::{HashMap, VecDeque};
use std::hash::{BuildHasherDefault, Hasher};

/// One access by a requester.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Request {
    /// Chip cycle of the access; nondecreasing from one submit to the next.
    pub cycle: u64,
    /// Which leaf cache (index into [`Topology::leaves`]).
    pub l1: usize,
    pub addr: u64,
    pub op: MemOp,
    /// Requester's tag, returned in the completion (a TP id, a ray slot …).
    pub tag: u64,
}

/// Why an access was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BusyCause {
    Bank,
    Mshr,
    WriteBuffer,
}

/// The L1's immediate answer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Outcome {
    /// Done: data (or the write's acceptance) ready at `ready`.
    Done { ready: u64, hit: bool },
    /// A miss: a [`Completion`] follows.
    Pending,
    /// Refused (back-pressure); offer it again at `retry_at`.
    Busy { retry_at: u64, cause: BusyCause },
}

/// A finished miss.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Completion {
    pub tag: u64,
    pub l1: usize,
    pub addr: u64,
    pub op: MemOp,
    /// Cycle it was submitted.
    pub cycle: u64,
    /// Cycle its data is ready.
    pub ready: u64,
}

/// Misuse of the hierarchy, or a memory error that is not back-pressure.
#[derive(Debug, thiserror::Error)]
pub enum HierarchyError {
    #[error(transparent)]
    Config(#[from] ConfigError),
    #[error(
        "request at cycle {cycle} submitted after cycle {now}: requests must come in nondecreasing cycle order"
    )]
    Past { cycle: u64, now: u64 },
    #[error("no L1 {l1}: the hierarchy has {count}")]
    NoSuchL1 { l1: usize, count: usize },
    #[error("memory: {0}")]
    Memory(MemError),
    #[error(transparent)]
    Event(#[from] EventError),
}

#[derive(Clone, Copy, Debug)]
enum Target {
    Requester {
        tag: u64,
        l1: usize,
        addr: u64,
        op: MemOp,
        cycle: u64,
    },
    Child(usize),
}

#[derive(Clone, Debug, Default)]
struct Mshr {
    start: u64,
    dirty: bool,
    targets: Vec<Target>,
}

/// An access arriving at an inner cache from a child.
#[derive(Clone, Copy, Debug)]
struct Op {
    addr: u64,
    write: bool,
    child: usize,
}

/// Where an access to an inner cache is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Stage {
    /// Arriving from the child: it asks its bank for a cycle.
    Arrive,
    /// At the cycle its bank gave it, after waiting.
    Lookup,
    /// Offered again from the queue of accesses waiting for an MSHR or the write buffer
    /// (its bank was already used). Reads that joined another's lookup go straight to
    /// `perform` with it.
    Replay,
}

#[derive(Clone, Copy, Debug)]
enum Ev {
    Access {
        node: usize,
        op: Op,
        stage: Stage,
    },
    Fill {
        node: usize,
        addr: u64,
    },
    MemSend {
        node: usize,
        addr: u64,
        op: MemOp,
    },
    /// A run of line requests a full memory queue refused, offered again in order
    /// ([`MemWaits`]).
    MemWait {
        group: u32,
    },
    Retry {
        node: usize,
    },
}

/// A line request waiting for room in a memory queue.
#[derive(Clone, Copy, Debug)]
struct MemWaiter {
    addr: u64,
    node: u32,
    /// The memory queue that refused it ([`QueueFull::queue`]; a request's queue never
    /// changes).
    queue: u32,
    /// Its cache's requester tag at the memory.
    tag: u32,
    op: MemOp,
}

impl MemWaiter {
    /// The request, arriving at `t`.
    fn request(&self, t: u64) -> MemRequest {
        MemRequest {
            id: u64::from(self.node),
            addr: self.addr,
            op: self.op,
            arrival: t,
            tag: self.tag,
        }
    }
}

/// Line requests refused by a full memory queue, waiting to be offered again.
///
/// Each refused request used to be an [`Ev::MemSend`] of its own, offered again at the
/// queue's retry cycle and mostly refused again: on a DRAM-bound frame thousands wait and each
/// retry was an event (35 G refusals in one STRaTA frame of Hairball at 1024², most of its
/// host time). A *group* stands for the waiting requests of one memory domain
/// ([`QueueFull::domain`], a DRAM channel) due at one cycle that lie between the same two other
/// events of the event queue: requests refused with no event other than such groups pushed in
/// between. One [`Ev::MemWait`] holds them, in order, and offers them in turn when it comes up.
///
/// Why that is exact. Expanded into one event per request, the groups give the event queue of
/// the one-event-per-request scheme except that the requests of different domains between the
/// same two other events come domain by domain instead of interleaved. Those commute: a
/// domain's requests change only that domain of the memory (`QueueFull::domain`), and an
/// accepted write's only other effect, freeing its cache's write-buffer entry and scheduling
/// the cache's retry for the current cycle, is the same whichever of them comes first, since
/// no other event runs between them. Within a domain the order is kept. And once a request is
/// refused, the memory's contract (`QueueFull::queue`) says the requests after it for the same
/// queue are refused too, with the same retry cycle, until something is accepted into the
/// domain: they are counted refused ([`MemoryPort::refuse_again`]) without being offered. Tests
/// compare both schemes on saturated memories.
#[derive(Debug, Default)]
struct MemWaits {
    /// By group id: the domain and the waiting requests in order.
    groups: Vec<(u32, Vec<MemWaiter>)>,
    free: Vec<u32>,
    /// Per domain: the group that requests refused now for a given cycle join (the cycle, the
    /// group, and `others` when it was made: it is joinable while no other event has been
    /// pushed since).
    open: Vec<Option<(u64, u32, u64)>>,
    /// Events pushed other than [`Ev::MemWait`].
    others: u64,
    /// One event per refused request, as before (tests; the same results, slower).
    off: bool,
}

/// The MSHR fetching each line in flight. `filter` has bit `line mod 64` set iff a line in
/// flight has that residue (`count` of them), so most lines that are not in flight (an inner
/// cache asks for every access it looks up) are answered at once. Past that, a cache of a few
/// dozen MSHRs scans one line per MSHR (`NONE`: free), sooner than a map would answer; a cache
/// of more (an L2 with thousands) keeps a map.
#[derive(Clone, Debug)]
struct InFlight {
    /// By MSHR, when there are at most `SCAN_MAX`; else empty.
    lines: Vec<u64>,
    /// Line → MSHR, when there are more than `SCAN_MAX`.
    map: LineMap<usize>,
    scan: bool,
    filter: u64,
    count: [u16; 64],
}

/// A multiplicative hash for line numbers (Fibonacci hashing): the map's keys are trusted
/// simulator state, so a keyed hash buys nothing and costs a lot on the hot path.
#[derive(Clone, Copy, Debug, Default)]
struct LineHasher(u64);

impl Hasher for LineHasher {
    fn finish(&self) -> u64 {
        self.0
    }
    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 = (self.0.rotate_left(8) ^ u64::from(b)).wrapping_mul(FIBONACCI_HASH);
        }
    }
    fn write_u64(&mut self, v: u64) {
        self.0 = (self.0 ^ v).wrapping_mul(FIBONACCI_HASH);
    }
}

type LineMap<V> = HashMap<u64, V, BuildHasherDefault<LineHasher>>;

impl InFlight {
    const NONE: u64 = u64::MAX;
    const SCAN_MAX: usize = 64;
    fn new(mshrs: usize) -> Self {
        let scan = mshrs <= Self::SCAN_MAX;
        InFlight {
            lines: if scan {
                vec![Self::NONE; mshrs]
            } else {
                Vec::new()
            },
            map: if scan {
                LineMap::default()
            } else {
                LineMap::with_capacity_and_hasher(mshrs, Default::default())
            },
            scan,
            filter: 0,
            count: [0; 64],
        }
    }
    /// The MSHR fetching `line`.
    #[inline]
    fn get(&self, line: u64) -> Option<usize> {
        if self.filter & (1 << (line & 63)) == 0 {
            return None;
        }
        if self.scan {
            self.lines.iter().position(|&l| l == line)
        } else {
            self.map.get(&line).copied()
        }
    }
    fn insert(&mut self, line: u64, mshr: usize) {
        debug_assert!(line != Self::NONE && self.get(line).is_none());
        if self.scan {
            self.lines[mshr] = line;
        } else {
            self.map.insert(line, mshr);
        }
        self.count[(line & 63) as usize] += 1;
        self.filter |= 1 << (line & 63);
    }
    fn remove(&mut self, line: u64) -> Option<usize> {
        let i = if self.scan {
            let i = self.get(line)?;
            self.lines[i] = Self::NONE;
            i
        } else {
            self.map.remove(&line)?
        };
        let r = (line & 63) as usize;
        self.count[r] -= 1;
        if self.count[r] == 0 {
            self.filter &= !(1 << r);
        }
        Some(i)
    }
}

#[derive(Debug)]
struct Node {
    cache: Cache,
    parent: Parent,
    latency: u64,
    bank_mask: u64,
    bank_shift: u32,
    bank_free: Vec<u64>,
    mshrs: Vec<Mshr>,
    free_mshrs: Vec<usize>,
    in_flight: InFlight,
    wb_used: u32,
    wb_cap: u32,
    write_back: bool,
    blocked: VecDeque<Op>,
    /// Empty: the storage `blocked` takes while its accesses are offered again.
    retrying: VecDeque<Op>,
    retry_pending: bool,
    mem_tag: u32,
    /// `combine_reads`: reads from children combine while they wait for a bank.
    combine: bool,
    /// Reads waiting for their bank, by line: the cycle the bank gave them, and the children
    /// whose reads of the line joined (`combine_reads` only).
    waiting: LineMap<(u64, Vec<usize>)>,
}

impl Node {
    fn line(&self, addr: u64) -> u64 {
        self.cache.line_of(addr)
    }
    fn bank(&self, addr: u64) -> usize {
        ((addr >> self.bank_shift) & self.bank_mask) as usize
    }
    fn mshrs_used(&self) -> usize {
        self.mshrs.len() - self.free_mshrs.len()
    }
    /// An MSHR is free, and under write-back so is a write-buffer entry for its victim.
    fn can_allocate(&self) -> bool {
        !self.free_mshrs.is_empty()
            && (!self.write_back
                || self.wb_used as usize + self.mshrs_used() < self.wb_cap as usize)
    }
    fn allocate(&mut self, t: u64, addr: u64, dirty: bool, target: Option<Target>) {
        let i = self.free_mshrs.pop().expect("checked by can_allocate");
        let m = &mut self.mshrs[i];
        m.start = t;
        m.dirty = dirty;
        m.targets.clear();
        if let Some(x) = target {
            m.targets.push(x);
        }
        let line = self.line(addr);
        self.in_flight.insert(line, i);
        let used = self.mshrs_used() as u64;
        let s = &mut self.cache.stats;
        s.mshr_peak = s.mshr_peak.max(used);
    }
    fn merge(&mut self, addr: u64, dirty: bool, target: Option<Target>) -> bool {
        let line = self.line(addr);
        let Some(i) = self.in_flight.get(line) else {
            return false;
        };
        let m = &mut self.mshrs[i];
        m.dirty |= dirty;
        if let Some(x) = target {
            m.targets.push(x);
        }
        self.cache.stats.mshr_merges += 1;
        true
    }
}

impl Node {
    /// An access at this leaf (an L1) in cycle `r.cycle`, everything due before it handled:
    /// the answer, and the send towards the next level it makes, if any.
    #[inline(always)]
    fn leaf_access(&mut self, r: &Request) -> (LeafOutcome, Option<LeafSend>) {
        let t = r.cycle;
        let b = self.bank(r.addr);
        if self.bank_free[b] > t {
            self.cache.stats.bank_conflicts += 1;
            let busy = Outcome::Busy {
                retry_at: self.bank_free[b],
                cause: BusyCause::Bank,
            };
            return (LeafOutcome::Now(busy), None);
        }
        let lat = self.latency;
        let target = Target::Requester {
            tag: r.tag,
            l1: r.l1,
            addr: r.addr,
            op: r.op,
            cycle: t,
        };
        let write = r.op == MemOp::Write;
        let send = |op| LeafSend {
            l1: r.l1,
            at: t + lat,
            addr: r.addr,
            op,
        };
        let (outcome, sent) = if write && !self.write_back {
            // Write-around: posted through the write buffer.
            if self.wb_used >= self.wb_cap {
                self.cache.stats.write_buffer_full_stalls += 1;
                let busy = LeafOutcome::BusyUntilNextEvent(BusyCause::WriteBuffer);
                return (busy, None);
            }
            let hit = self.cache.lookup(r.addr, r.op);
            self.cache.stats.write_throughs += 1;
            self.wb_used += 1;
            let done = Outcome::Done {
                ready: t + lat,
                hit,
            };
            (done, Some(send(MemOp::Write)))
        } else if self.cache.lookup_if_present(r.addr, r.op) {
            let done = Outcome::Done {
                ready: t + lat,
                hit: true,
            };
            (done, None)
        } else if self.in_flight.get(self.line(r.addr)).is_some() {
            self.cache.lookup(r.addr, r.op);
            self.merge(r.addr, write, Some(target));
            (Outcome::Pending, None)
        } else if self.can_allocate() {
            self.cache.lookup(r.addr, r.op);
            self.allocate(t, r.addr, write, Some(target));
            (Outcome::Pending, Some(send(MemOp::Read)))
        } else {
            self.cache.stats.mshr_full_stalls += 1;
            return (LeafOutcome::BusyUntilNextEvent(BusyCause::Mshr), None);
        };
        self.bank_free[b] = t + 1;
        (LeafOutcome::Now(outcome), sent)
    }
}

/// The retry cycle of an access refused at cycle `t` for lack of an MSHR or a write-buffer
/// entry, given the hierarchy's next event at that moment: nothing can free one before it.
pub fn busy_retry(t: u64, next_event: Option<u64>) -> u64 {
    next_event.unwrap_or(t + 1).max(t + 1)
}

/// An L1's answer to an access through [`Leaves::access`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LeafOutcome {
    /// The answer, as [`Hierarchy::submit`] gives it.
    Now(Outcome),
    /// Refused for lack of an MSHR or a write-buffer entry: `Busy` with `retry_at` =
    /// [`busy_retry`] of the hierarchy's next event, counting the sends of the cycle's
    /// accesses before this one.
    BusyUntilNextEvent(BusyCause),
}

/// What an access at an L1 sends towards the next level: the line (or the written word's
/// line) of `addr`, arriving at `at`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LeafSend {
    /// The L1 (index into [`Topology::leaves`]).
    pub l1: usize,
    pub at: u64,
    pub addr: u64,
    pub op: MemOp,
}

/// A run of L1s lent out for one cycle's accesses ([`Hierarchy::leaves`]).
#[derive(Debug)]
pub struct Leaves<'h> {
    /// The first L1's index.
    first: usize,
    nodes: &'h mut [Node],
    cycle: u64,
}

impl Leaves<'_> {
    /// Offer `r` (in the cycle the run was lent out for, to one of its L1s): the L1's answer
    /// and what it sends, which the caller must [`Hierarchy::replay`].
    #[inline]
    pub fn access(&mut self, r: &Request) -> (LeafOutcome, Option<LeafSend>) {
        debug_assert_eq!(
            r.cycle, self.cycle,
            "a run of L1s is lent out for one cycle"
        );
        self.nodes[r.l1 - self.first].leaf_access(r)
    }
}

/// The timed cache tree over a memory model `M`.
#[derive(Debug)]
pub struct Hierarchy<M> {
    topology: Topology,
    nodes: Vec<Node>,
    memory: M,
    events: EventQueue<Ev>,
    completions: Vec<Completion>,
    mem_buf: Vec<MemCompletion>,
    /// The memory's next event, kept from one question to the next until the memory changes
    /// (`None`: ask it): a chip asks every cycle, the memory changes at a few of them.
    mem_next: Cell<Option<Option<u64>>>,
    now: u64,
    /// Every event at or before this cycle has been handled (events are only ever added
    /// after it), so advancing to it again is free.
    settled: Option<u64>,
    memory_tags: u32,
    waits: MemWaits,
}

/// What a [`Hierarchy`] is built from (its [`Component::Config`]).
#[derive(Debug)]
pub struct HierarchyParts<M> {
    pub topology: Topology,
    pub memory: M,
}

/// Stats of every cache at the end of a run.
#[derive(Clone, Debug, PartialEq)]
pub struct HierarchyStats {
    /// Per node: (name, level, stats).
    pub caches: Vec<(String, u32, CacheStats)>,
}

impl<M: MemoryPort> Hierarchy<M> {
    /// Build over `memory`, whose requester clock must be the chip clock the requests use. The
    /// caches that talk to memory must use its line size (an error names both keys otherwise).
    pub fn new(topology: Topology, memory: M) -> Result<Self, HierarchyError> {
        if let Some((bytes, name)) = topology.memory_line_bytes()? {
            let mem = memory.line_bytes();
            if bytes != mem {
                return Err(ConfigError::key(
                    &format!("{name}.line_bytes"),
                    format!(
                        "= {bytes} must equal the DRAM's `organisation.line_bytes` = {mem} (one \
                         cache line is one memory request)"
                    ),
                )
                .into());
            }
        }
        let caches = topology.build_caches()?;
        let mut memory_tags = 0;
        let nodes = caches
            .into_iter()
            .zip(topology.nodes())
            .map(|(cache, n)| {
                let c = &n.cache;
                let mem_tag = memory_tags;
                if n.parent == Parent::Memory {
                    memory_tags += 1;
                }
                Node {
                    cache,
                    parent: n.parent,
                    latency: c.hit_latency.into(),
                    bank_mask: u64::from(c.banks - 1),
                    bank_shift: c.bank_interleave().trailing_zeros(),
                    bank_free: vec![0; c.banks as usize],
                    mshrs: vec![Mshr::default(); c.mshrs as usize],
                    free_mshrs: (0..c.mshrs as usize).rev().collect(),
                    in_flight: InFlight::new(c.mshrs as usize),
                    wb_used: 0,
                    wb_cap: c.write_buffer,
                    write_back: c.write_policy == WritePolicy::WriteBack,
                    blocked: VecDeque::new(),
                    retrying: VecDeque::new(),
                    retry_pending: false,
                    mem_tag,
                    combine: c.combine_reads,
                    waiting: LineMap::default(),
                }
            })
            .collect();
        Ok(Hierarchy {
            topology,
            nodes,
            memory,
            events: EventQueue::with_capacity(1024),
            completions: Vec::new(),
            mem_buf: Vec::new(),
            mem_next: Cell::new(None),
            now: 0,
            settled: None,
            memory_tags,
            waits: MemWaits::default(),
        })
    }

    /// Offer every request refused by a full memory queue again as its own event, as the
    /// hierarchy once did, instead of in groups ([`MemWaits`]): the same results, slower. For
    /// tests that prove the two equal.
    pub fn set_grouped_memory_waits(&mut self, on: bool) {
        self.waits.off = !on;
    }

    pub fn topology(&self) -> &Topology {
        &self.topology
    }
    pub fn memory(&self) -> &M {
        &self.memory
    }
    pub fn memory_mut(&mut self) -> &mut M {
        self.mem_next.set(None);
        &mut self.memory
    }
    pub fn into_memory(self) -> M {
        self.memory
    }
    /// Requester tags the memory must accept (one per cache that talks to it).
    pub fn memory_tags(&self) -> u32 {
        self.memory_tags
    }
    /// Counters of cache node `n`.
    pub fn stats(&self, n: usize) -> &CacheStats {
        &self.nodes[n].cache.stats
    }
    /// The last cycle advanced to or submitted at.
    pub fn now(&self) -> u64 {
        self.now
    }

    /// The next cycle at which anything happens, `None` when all is idle.
    pub fn next_event(&self) -> Option<u64> {
        match (self.events.next_cycle(), self.mem_next()) {
            (Some(a), Some(b)) => Some(a.min(b)),
            (a, b) => a.or(b),
        }
    }

    /// The memory's next event (see `mem_next`).
    #[inline]
    fn mem_next(&self) -> Option<u64> {
        if let Some(n) = self.mem_next.get() {
            return n;
        }
        let n = self.memory.next_event();
        self.mem_next.set(Some(n));
        n
    }

    /// Handle everything due up to and including `cycle`.
    pub fn advance_to(&mut self, cycle: u64) -> Result<(), HierarchyError> {
        // Requests submitted at a settled cycle only add events after it (every latency is at
        // least one cycle), so a chip offering many accesses in one cycle pays once.
        if self.settled.is_some_and(|s| cycle <= s) {
            return Ok(());
        }
        while let Some(t) = self.next_event().filter(|&t| t <= cycle) {
            self.step(t)?;
        }
        self.now = self.now.max(cycle);
        self.settled = Some(cycle);
        Ok(())
    }

    /// Run until nothing is in flight; returns the last cycle with an event.
    pub fn drain(&mut self) -> Result<u64, HierarchyError> {
        while let Some(t) = self.next_event() {
            self.step(t)?;
            self.now = self.now.max(t);
        }
        Ok(self.now)
    }

    /// Move finished misses into `out`, in the order they finished.
    pub fn drain_completions(&mut self, out: &mut Vec<Completion>) {
        out.append(&mut self.completions);
    }

    /// Offer one access (see the module docs).
    pub fn submit(&mut self, r: Request) -> Result<Outcome, HierarchyError> {
        if r.cycle < self.now {
            return Err(HierarchyError::Past {
                cycle: r.cycle,
                now: self.now,
            });
        }
        let Some(&n) = self.topology.leaves().get(r.l1) else {
            return Err(HierarchyError::NoSuchL1 {
                l1: r.l1,
                count: self.topology.leaves().len(),
            });
        };
        self.advance_to(r.cycle)?;
        let (outcome, send) = self.nodes[n].leaf_access(&r);
        if let Some(s) = send {
            self.send_down(n, s.at, s.addr, s.op)?;
        }
        Ok(match outcome {
            LeafOutcome::Now(o) => o,
            LeafOutcome::BusyUntilNextEvent(cause) => Outcome::Busy {
                retry_at: busy_retry(r.cycle, self.next_event()),
                cause,
            },
        })
    }

    /// Lend out the leaf caches for the accesses of cycle `cycle`, in runs that requesters on
    /// different threads may use at once: run `k` holds the L1s `bounds[k]..bounds[k + 1]`
    /// (`bounds` ascending from 0 to the number of L1s). Everything due up to `cycle` is
    /// handled first. `None` if the leaves are not consecutive nodes (a topology the split
    /// does not support; the caller then uses [`Hierarchy::submit`]).
    ///
    /// An access through a run ([`Leaves::access`]) decides at its L1 exactly what
    /// [`Hierarchy::submit`] decides, but what it sends towards the next level goes to a log
    /// ([`LeafSend`]), applied afterwards by [`Hierarchy::replay`] in the order the accesses would
    /// have been submitted; and a refusal for lack of an MSHR or write-buffer entry, whose
    /// retry is the hierarchy's next event — which the cycle's earlier sends may bring
    /// forward — comes back as [`LeafOutcome::BusyUntilNextEvent`], for the caller to resolve
    /// with [`busy_retry`] once it knows the earlier sends.
    pub fn leaves(
        &mut self,
        cycle: u64,
        bounds: &[usize],
    ) -> Result<Option<Vec<Leaves<'_>>>, HierarchyError> {
        if cycle < self.now {
            return Err(HierarchyError::Past {
                cycle,
                now: self.now,
            });
        }
        self.advance_to(cycle)?;
        let leaves = self.topology.leaves();
        let first = leaves.first().copied().unwrap_or(0);
        if leaves.iter().enumerate().any(|(i, &n)| n != first + i) {
            return Ok(None);
        }
        debug_assert!(bounds.first() == Some(&0) && bounds.last() == Some(&leaves.len()));
        let mut rest = &mut self.nodes[first..first + leaves.len()];
        let mut runs = Vec::with_capacity(bounds.len().saturating_sub(1));
        for w in bounds.windows(2) {
            let (run, tail) = rest.split_at_mut(w[1] - w[0]);
            rest = tail;
            runs.push(Leaves {
                first: w[0],
                nodes: run,
                cycle,
            });
        }
        Ok(Some(runs))
    }

    /// Apply a send that a [`Leaves::access`] logged (see [`Hierarchy::leaves`]), in the
    /// order the accesses would have been submitted.
    pub fn replay(&mut self, s: &LeafSend) -> Result<(), HierarchyError> {
        let n = self.topology.leaves()[s.l1];
        self.send_down(n, s.at, s.addr, s.op)
    }

    fn push(&mut self, t: u64, ev: Ev) -> Result<(), HierarchyError> {
        debug_assert!(
            self.settled.is_none_or(|s| t > s),
            "event at {t} behind the settled cycle"
        );
        if !matches!(ev, Ev::MemWait { .. }) {
            self.waits.others += 1;
        }
        Ok(self.events.push(t, ev)?)
    }

    /// Send a read or write from node `n` towards its parent, arriving at `at`.
    fn send_down(&mut self, n: usize, at: u64, addr: u64, op: MemOp) -> Result<(), HierarchyError> {
        match self.nodes[n].parent {
            Parent::Cache(p) => self.push(
                at,
                Ev::Access {
                    node: p,
                    op: Op {
                        addr,
                        write: op == MemOp::Write,
                        child: n,
                    },
                    stage: Stage::Arrive,
                },
            ),
            Parent::Memory => self.push(at, Ev::MemSend { node: n, addr, op }),
        }
    }

    fn schedule_retry(&mut self, t: u64, n: usize) -> Result<(), HierarchyError> {
        let node = &mut self.nodes[n];
        if node.blocked.is_empty() || node.retry_pending {
            return Ok(());
        }
        node.retry_pending = true;
        self.push(t, Ev::Retry { node: n })
    }

    /// A write-buffer entry of `n` is free again.
    fn free_write_slot(&mut self, t: u64, n: usize) -> Result<(), HierarchyError> {
        self.nodes[n].wb_used -= 1;
        self.schedule_retry(t, n)
    }

    /// One cycle with events: the caches' events, then the memory's completions.
    fn step(&mut self, t: u64) -> Result<(), HierarchyError> {
        while let Some((at, ev)) = self.events.pop_due(t) {
            self.handle(at, ev)?;
        }
        if self.mem_next().is_some_and(|m| m <= t) {
            self.mem_next.set(None);
            self.memory.advance_to(t);
            let mut buf = std::mem::take(&mut self.mem_buf);
            self.memory.drain_completions(&mut buf);
            for c in buf.drain(..) {
                if c.op == MemOp::Read {
                    self.fill(t, c.id as usize, c.addr)?;
                }
            }
            self.mem_buf = buf;
            while let Some((at, ev)) = self.events.pop_due(t) {
                self.handle(at, ev)?;
            }
        }
        Ok(())
    }

    fn handle(&mut self, t: u64, ev: Ev) -> Result<(), HierarchyError> {
        match ev {
            Ev::Access { node, op, stage } => self.inner_access(t, node, op, stage),
            Ev::Fill { node, addr } => self.fill(t, node, addr),
            Ev::MemSend { node, addr, op } => self.mem_send(t, node, addr, op),
            Ev::MemWait { group } => self.mem_wait(t, group),
            Ev::Retry { node } => {
                self.nodes[node].retry_pending = false;
                // The queued accesses are offered again in arrival order until one is refused
                // again: a first-in first-out miss queue beside the banks. A queued access had
                // its bank's lookup already and is re-examined without another bank cycle
                // (offering every queued access again through the banks at each freed MSHR
                // would delay the hits behind them for nothing). The two queues trade their
                // storage so that neither grows from empty.
                let n = &mut self.nodes[node];
                let mut ops = std::mem::replace(&mut n.blocked, std::mem::take(&mut n.retrying));
                while let Some(op) = ops.pop_front() {
                    self.inner_access(t, node, op, Stage::Replay)?;
                    if !self.nodes[node].blocked.is_empty() {
                        break;
                    }
                }
                let n = &mut self.nodes[node];
                n.blocked.extend(ops.drain(..));
                n.retrying = ops;
                Ok(())
            }
        }
    }

    /// An access from child `op.child` at inner cache `n`.
    fn inner_access(
        &mut self,
        t: u64,
        n: usize,
        op: Op,
        stage: Stage,
    ) -> Result<(), HierarchyError> {
        let node = &mut self.nodes[n];
        let combine = node.combine && !op.write;
        if stage == Stage::Arrive {
            if combine
                && let Some((start, joined)) = node.waiting.get_mut(&node.cache.line_of(op.addr))
            {
                // An earlier read of the line waits for its bank: this one joins its lookup.
                joined.push(op.child);
                let wait = *start - t;
                node.cache.stats.bank_wait.record(wait);
                node.cache.stats.combined += 1;
                return Ok(());
            }
            let b = node.bank(op.addr);
            let start = node.bank_free[b].max(t);
            node.bank_free[b] = start + 1;
            node.cache.stats.bank_wait.record(start - t);
            if start > t {
                node.cache.stats.bank_conflicts += 1;
                if combine {
                    let line = node.line(op.addr);
                    node.waiting.insert(line, (start, Vec::new()));
                }
                return self.push(
                    start,
                    Ev::Access {
                        node: n,
                        op,
                        stage: Stage::Lookup,
                    },
                );
            }
        }
        self.perform(t, n, op)?;
        if stage == Stage::Lookup && combine {
            let node = &mut self.nodes[n];
            let line = node.line(op.addr);
            if let Some((_, joined)) = node.waiting.remove(&line) {
                for child in joined {
                    self.perform(t, n, Op { child, ..op })?;
                }
            }
        }
        Ok(())
    }

    /// Access `op` at inner cache `n` once its bank has looked it up.
    fn perform(&mut self, t: u64, n: usize, op: Op) -> Result<(), HierarchyError> {
        let node = &mut self.nodes[n];
        let lat = node.latency;
        let mem_op = if op.write { MemOp::Write } else { MemOp::Read };
        if op.write && !node.write_back {
            if node.wb_used >= node.wb_cap {
                node.cache.stats.write_buffer_full_stalls += 1;
                node.blocked.push_back(op);
                return Ok(());
            }
            node.cache.lookup(op.addr, mem_op);
            node.cache.stats.write_throughs += 1;
            node.wb_used += 1;
            self.send_down(n, t + lat, op.addr, MemOp::Write)?;
        } else if node.cache.lookup_if_present(op.addr, mem_op) {
            if !op.write {
                self.push(
                    t + lat,
                    Ev::Fill {
                        node: op.child,
                        addr: op.addr,
                    },
                )?;
            }
        } else {
            let target = (!op.write).then_some(Target::Child(op.child));
            if node.in_flight.get(node.line(op.addr)).is_some() {
                node.cache.lookup(op.addr, mem_op);
                node.merge(op.addr, op.write, target);
            } else if node.can_allocate() {
                node.cache.lookup(op.addr, mem_op);
                node.allocate(t, op.addr, op.write, target);
                self.send_down(n, t + lat, op.addr, MemOp::Read)?;
            } else {
                node.cache.stats.mshr_full_stalls += 1;
                node.blocked.push_back(op);
                return Ok(());
            }
        }
        if op.write {
            // The child's write is accepted: its write-buffer entry frees.
            self.free_write_slot(t, op.child)?;
        }
        Ok(())
    }

    /// The line of `addr` arrives at node `n`.
    fn fill(&mut self, t: u64, n: usize, addr: u64) -> Result<(), HierarchyError> {
        let node = &mut self.nodes[n];
        let line = node.line(addr);
        let Some(i) = node.in_flight.remove(line) else {
            // Every fill answers an MSHR of this node; anything else is a bug.
            unreachable!("fill of line {line:#x} at cache {n} with no MSHR");
        };
        let m = std::mem::take(&mut node.mshrs[i]);
        let evicted = node.cache.fill(addr, m.dirty);
        node.cache.stats.miss_latency.record(t - m.start);
        let lat = node.latency;
        if let Some(e) = evicted.filter(|e| e.dirty) {
            // The reserved entry (write-back) takes the victim.
            node.wb_used += 1;
            self.send_down(n, t + lat, e.addr, MemOp::Write)?;
        }
        for target in &m.targets {
            match *target {
                Target::Requester {
                    tag,
                    l1,
                    addr,
                    op,
                    cycle,
                } => self.completions.push(Completion {
                    tag,
                    l1,
                    addr,
                    op,
                    cycle,
                    ready: t,
                }),
                Target::Child(c) => self.push(t, Ev::Fill { node: c, addr })?,
            }
        }
        // Give the targets' storage back to the free MSHR.
        let node = &mut self.nodes[n];
        node.mshrs[i] = Mshr {
            targets: m.targets,
            ..Mshr::default()
        };
        node.free_mshrs.push(i);
        self.schedule_retry(t, n)
    }

    /// Offer a line request of node `n` to memory, arriving at `t`.
    fn mem_send(&mut self, t: u64, n: usize, addr: u64, op: MemOp) -> Result<(), HierarchyError> {
        self.mem_next.set(None);
        if t > 0 && self.memory.now().is_none_or(|m| m < t - 1) {
            self.memory.advance_to(t - 1);
        }
        let req = MemRequest {
            id: n as u64,
            addr,
            op,
            arrival: t,
            tag: self.nodes[n].mem_tag,
        };
        match self.memory.try_enqueue(req) {
            Ok(()) => {
                if op == MemOp::Write {
                    self.free_write_slot(t, n)?;
                }
                Ok(())
            }
            Err(MemError::Full(q)) => {
                let w = MemWaiter {
                    addr,
                    node: n as u32,
                    queue: q.queue,
                    tag: req.tag,
                    op,
                };
                self.wait(q, w).map(|_| ())
            }
            Err(e) => Err(HierarchyError::Memory(e)),
        }
    }

    /// Request `w`, refused by the memory (`q`), waits for its retry cycle: in its domain's
    /// open group for that cycle if no other event has been pushed since the group was made,
    /// else in a new group ([`MemWaits`]). Returns the group.
    fn wait(&mut self, q: QueueFull, w: MemWaiter) -> Result<u32, HierarchyError> {
        if self.waits.off {
            let (node, addr, op) = (w.node as usize, w.addr, w.op);
            self.push(q.retry_at, Ev::MemSend { node, addr, op })?;
            return Ok(u32::MAX);
        }
        let d = q.domain as usize;
        if self.waits.open.len() <= d {
            self.waits.open.resize(d + 1, None);
        }
        if let Some((c, g, others)) = self.waits.open[d]
            && c == q.retry_at
            && others == self.waits.others
        {
            self.waits.groups[g as usize].1.push(w);
            return Ok(g);
        }
        let g = match self.waits.free.pop() {
            Some(g) => {
                let group = &mut self.waits.groups[g as usize];
                group.0 = q.domain;
                group.1.push(w);
                g
            }
            None => {
                self.waits.groups.push((q.domain, vec![w]));
                (self.waits.groups.len() - 1) as u32
            }
        };
        self.push(q.retry_at, Ev::MemWait { group: g })?;
        self.waits.open[d] = Some((q.retry_at, g, self.waits.others));
        Ok(g)
    }

    /// Group `g`'s requests are offered again at `t`, in order (see [`MemWaits`]).
    fn mem_wait(&mut self, t: u64, g: u32) -> Result<(), HierarchyError> {
        let (domain, mut members) = std::mem::take(&mut self.waits.groups[g as usize]);
        if self.waits.open[domain as usize].is_some_and(|(_, o, _)| o == g) {
            self.waits.open[domain as usize] = None;
        }
        self.mem_next.set(None);
        if t > 0 && self.memory.now().is_none_or(|m| m < t - 1) {
            self.memory.advance_to(t - 1);
        }
        // The last refusal, while nothing has been accepted into the domain since: the
        // requests after it for the same queue are refused too, with its retry cycle.
        let mut refused: Option<QueueFull> = None;
        let mut i = 0;
        while i < members.len() {
            let w = members[i];
            if let Some(q) = refused.filter(|q| q.queue == w.queue) {
                // The run of them with the same tag: counted refused, and waiting on in the
                // group the first joins (nothing is pushed in between, so they would all
                // have joined it).
                let end = i + members[i..]
                    .iter()
                    .position(|m| m.queue != w.queue || m.tag != w.tag)
                    .unwrap_or(members.len() - i);
                self.memory.refuse_again(&w.request(t), (end - i) as u64);
                // (Only grouping pushes `MemWait` events, so `to` is a group.)
                let to = self.wait(q, w)?;
                let rest = &members[i + 1..end];
                self.waits.groups[to as usize].1.extend_from_slice(rest);
                i = end;
                continue;
            }
            match self.memory.try_enqueue(w.request(t)) {
                Ok(()) => {
                    refused = None;
                    if w.op == MemOp::Write {
                        self.free_write_slot(t, w.node as usize)?;
                    }
                }
                Err(MemError::Full(q)) => {
                    refused = Some(q);
                    self.wait(q, w)?;
                }
                Err(e) => return Err(HierarchyError::Memory(e)),
            }
            i += 1;
        }
        members.clear();
        self.waits.groups[g as usize].1 = members;
        self.waits.free.push(g);
        Ok(())
    }

    /// Every cache's counters, with its name and level.
    pub fn all_stats(&self) -> HierarchyStats {
        HierarchyStats {
            caches: self
                .topology
                .nodes()
                .iter()
                .zip(&self.nodes)
                .map(|(t, n)| (t.name.clone(), t.level, n.cache.stats.clone()))
                .collect(),
        }
    }
}

impl<M: MemoryPort> Component for Hierarchy<M> {
    type Config = HierarchyParts<M>;
    type Stats = HierarchyStats;
    type Error = HierarchyError;

    fn build(parts: HierarchyParts<M>) -> Result<Self, HierarchyError> {
        Hierarchy::new(parts.topology, parts.memory)
    }
    fn next_event(&self) -> Option<u64> {
        Hierarchy::next_event(self)
    }
    fn advance_to(&mut self, cycle: u64) -> Result<(), HierarchyError> {
        Hierarchy::advance_to(self, cycle)
    }
    fn finish(mut self, end: u64) -> HierarchyStats {
        // Whatever is still in flight is finished first, so that every access is counted.
        let _ = self.drain();
        let _ = Hierarchy::advance_to(&mut self, end);
        self.all_stats()
    }
}
