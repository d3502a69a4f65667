//! One SGRT core's T&I unit (SGRT §3.3, Figures 3–4): ray dispatch (RD), the traversal units
//! (TRV, organised as PPTRV or SPTRV), the intersection unit (IST), the memory stage and RAU
//! in front of every pipeline, and the ray and hit buffers that join it to the shader.
//!
//! # What a ray does
//!
//! A ray owns one short stack (a *slot*) of a TRV from dispatch until it leaves the T&I unit.
//! Its traversal is the functional `short-stack` stepper (`rtsim_trace::step`): each [`Step`]
//! is one operation of one unit ([`unit_of`]):
//!
//! | step | unit | reads |
//! |---|---|---|
//! | `Node` | TRV_PRE: fetch the node, leaf or inner | the node record |
//! | `RootBox`, `ChildPair` | TRV_AABB: test the root box / the child pair | the root record / the pair's line |
//! | `Push`, `Pop`, `Restart` | TRV_POST: the short-stack operation | registers |
//! | `Triangle` | IST: Wald's test on one triangle | the Wald record |
//! | `Done` | leaves for the hit buffer | — |
//!
//! The next step is always computed when the ray enters the pipeline of the current one
//! (functional work is timing-free and private to the ray); where it goes when it leaves is
//! then known. Memory operations look up their lines in the unit's L1 at entry: a hit enters
//! the pipeline (`hit_latency` cycles before the pipeline proper); a miss parks the ray in the
//! RAU until every line has arrived, and the ray then re-enters ahead of the queue.
//!
//! # PPTRV and SPTRV; steps
//!
//! A *step* is one pass of a ray through one of the three sub-pipelines. PPTRV's
//! sub-pipelines are independent, each behind its own queue (TRV_PRE behind the TRV's input
//! buffer, TRV_AABB and TRV_POST behind the two extra FIFOs), and a crossbar puts a ray that
//! leaves one straight into the queue of the one it needs next: one step per operation.
//! SPTRV chains them into one deep pipeline (memory stage, PRE, AABB, POST) behind the input
//! buffer; every pass goes through all three stages, so it is three steps, bypassed stages
//! included. A pass does the operations that can follow each other in stage order without a
//! second memory read: PRE alone (the child pair is only known after the node is read), or AABB
//! with the POST operation that follows it, or POST alone (a pop after the IST, a second pop).
//! Every pass does at least one operation, so SPTRV never takes fewer steps than PPTRV for a
//! ray (`docs/SGRT.md`).

use crate::config::{Organisation, SgrtConfig};
use crate::error::SgrtError;
use crate::pipe::{Pipe, Rau, Slot};
use crate::stats::{CoreStats, IstStats, KindStats, MemStats, TrvStats};
use rtsim_bvh::{LineSpan, MemoryImage};
use rtsim_cache::{Hierarchy, Outcome, Request};
use rtsim_core::{MemOp, MemoryPort};
use rtsim_sim::{Link, PushError};
use rtsim_trace::step::{Access, Step};
use rtsim_trace::traverse::SlotHit;
use rtsim_trace::{RayCounters, RayJob, Tracer, TraversalState};
use std::collections::VecDeque;

/// Which unit performs a step.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Unit {
    Pre,
    Aabb,
    Post,
    Ist,
    Done,
}

/// The unit of a step (see the module table). `Parent` (bit stack) reads a node record like
/// TRV_PRE; `SiblingRetest` tests a box like TRV_AABB; `Treelet` is never seen (skipped).
#[inline]
pub fn unit_of(s: &Step) -> Unit {
    match s {
        Step::Node { .. } | Step::Parent { .. } | Step::Treelet { .. } => Unit::Pre,
        Step::RootBox { .. } | Step::ChildPair { .. } | Step::SiblingRetest { .. } => Unit::Aabb,
        Step::Push { .. } | Step::Pop { .. } | Step::Restart => Unit::Post,
        Step::Triangle { .. } => Unit::Ist,
        Step::Done(_) => Unit::Done,
    }
}

/// What the units read: the tracer, the memory image, the line size and the triangle record
/// the IST reads (Wald's, or the vertex record for another triangle test).
#[derive(Clone, Copy, Debug)]
pub struct Env<'a> {
    pub tracer: &'a Tracer,
    pub image: &'a MemoryImage,
    pub line_bytes: u32,
    pub wald: bool,
}

impl Env<'_> {
    /// Lines a step reads (none for register operations).
    #[inline]
    pub fn lines(&self, s: &Step) -> Option<LineSpan> {
        match s.access() {
            Access::Triangle(slot) if self.wald => {
                Some(self.image.wald_lines(slot, self.line_bytes))
            }
            Access::Stack { .. } => None,
            a => a.lines(self.image, self.line_bytes),
        }
    }

    /// The ray's next step (treelet crossings, which no SGRT layout has, cost nothing).
    #[inline]
    fn step(&self, r: &mut RaySlot) -> Step {
        loop {
            let s = self.tracer.step(&mut r.st, &mut r.counters);
            if !matches!(s, Step::Treelet { .. }) {
                return s;
            }
        }
    }
}

/// A request tag: the core, whether it is the shader's, and the slot.
pub(crate) fn tag(core: u32, srp: bool, slot: u16) -> u64 {
    (u64::from(core) << 32) | (u64::from(srp) << 16) | u64::from(slot)
}

/// The inverse of [`tag`].
pub(crate) fn untag(tag: u64) -> (u32, bool, u16) {
    ((tag >> 32) as u32, (tag >> 16) & 1 == 1, tag as u16)
}

/// A ray the T&I unit was asked to trace, and what it found.
#[derive(Clone, Copy, Debug)]
pub struct Job {
    pub job: RayJob,
    /// The work item that owns it (a pixel's state, or a ray of a file).
    pub owner: u32,
    pub hit: SlotHit,
    pub counters: RayCounters,
    /// Cycles from dispatch to leaving the T&I unit.
    pub latency: u64,
}

/// Where a ray goes back to when its lines have arrived.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Back {
    Trv(u8),
    Ist,
}

/// One short stack with its ray.
#[derive(Clone, Debug)]
pub(crate) struct RaySlot {
    st: TraversalState,
    next: Step,
    counters: RayCounters,
    job: u32,
    lines_left: u8,
    looked_up: bool,
    back: Back,
    dispatched: u64,
    trv_steps: u32,
    trv_active: u32,
    trv_passes: u32,
    ist_steps: u32,
}

/// A lookup whose lines did not all go out in one cycle.
#[derive(Clone, Copy, Debug)]
struct Partial {
    slot: Slot,
    next_line: u32,
    misses: u32,
}

/// A pipeline with its queue and memory stage.
#[derive(Debug)]
struct Stage {
    input: Link<Slot>,
    /// Rays back from the RAU with their data.
    ready: VecDeque<Slot>,
    partial: Option<Partial>,
    retry_at: u64,
    pipe: Pipe,
    mem: MemStats,
}

impl Stage {
    fn new(queue: u32, queue_latency: u64, latency: u32, interval: u32) -> Result<Self, SgrtError> {
        Ok(Stage {
            input: Link::new(queue as usize, queue_latency)?,
            ready: VecDeque::new(),
            partial: None,
            retry_at: 0,
            pipe: Pipe::new(latency, interval),
            mem: MemStats::default(),
        })
    }
}

#[derive(Debug)]
struct Trv {
    free: Vec<Slot>,
    /// PPTRV: TRV_PRE, TRV_AABB, TRV_POST. SPTRV: the deep pipeline.
    stages: Vec<Stage>,
    rau: Rau,
    /// SPTRV: next cycle the box datapath is free.
    aabb_free: u64,
    held: u32,
    held_last: u64,
    in_pipes: u32,
    busy_since: u64,
    stats: TrvStats,
}

impl Trv {
    fn account_held(&mut self, t: u64) {
        self.stats.stack_occupancy_sum += u128::from(self.held) * u128::from(t - self.held_last);
        self.held_last = t;
    }
    fn enter_pipes(&mut self, t: u64) {
        if self.in_pipes == 0 {
            self.busy_since = t;
        }
        self.in_pipes += 1;
    }
    fn leave_pipes(&mut self, t: u64) {
        self.in_pipes -= 1;
        if self.in_pipes == 0 {
            self.stats.busy_cycles += t - self.busy_since;
        }
    }
}

#[derive(Debug)]
struct Ist {
    stage: Stage,
    looped: Link<Slot>,
    rau: Rau,
    stats: IstStats,
}

/// Which lookup path a stage entry takes.
enum Candidate {
    Ready(Slot),
    Partial(Partial),
    Queue(Slot, bool),
}

/// One core's T&I unit with its ray and hit buffers.
#[derive(Debug)]
pub(crate) struct Core {
    pub id: u32,
    org: Organisation,
    stacks: u32,
    rays: Vec<RaySlot>,
    trvs: Vec<Trv>,
    ist: Ist,
    pub jobs: Vec<Job>,
    free_jobs: Vec<u32>,
    /// Rays from the shader (or the feeder), by job.
    pub ray_fifo: Link<u32>,
    /// Finished rays for the shader, by job.
    pub hit_fifo: Link<u32>,
    rd_next: u32,
    trv_leaf0: usize,
    ist_leaf: usize,
    trv_hit: u64,
    ist_hit: u64,
    aabb_interval: u64,
    q_lat: u64,
    /// Rays holding a slot.
    pub in_flight: u32,
    /// Per unit (TRV stages, then the IST, then ray dispatch): the earliest cycle it may act.
    /// Kept conservative (never later than the unit could act): a unit that acts changes
    /// other units' wakes where it gives them something to do.
    wake: Vec<u64>,
    /// At most the least of `wake` (equal to it but where a unit's wake rose within the tick
    /// it became due in: an early guess only costs a tick in which nothing is due).
    min_wake: u64,
    /// During a tick at `now`: bit `u` set iff `wake[u] <= now` (kept exact as wakes change
    /// within the tick), so the tick visits the due units without scanning the others.
    due: u64,
    /// Bit `u` set iff `wake[u]` may have changed since the tick began (the units due then,
    /// and every unit woken or given a wake since), so the tick's end takes the least wake
    /// over these and the minimum of the others taken at its start, without a second scan.
    touched: u64,
    /// Bit `u` set iff `wake[u]` is not `u64::MAX` (a unit waiting for another has no wake),
    /// so the tick's scan reads only the units that have one.
    finite: u64,
    /// The TRV stages' bits (every unit below the IST's).
    stage_mask: u64,
    now: u64,
    /// Per unit: its TRV and stage (the IST and dispatch: unused).
    unit_trv: Vec<(u8, u8)>,
    /// The same for the shader of this core (the chip owns the shader).
    pub shader_wake: u64,
    /// Stages per TRV.
    per_trv: usize,
    pub stats: CoreStats,
}

impl Core {
    /// Core `id` whose TRV L1s are hierarchy leaves `trv_leaf0..trv_leaf0 + trvs` and whose IST
    /// L1 is leaf `ist_leaf`.
    pub fn new(
        id: u32,
        c: &SgrtConfig,
        trv_leaf0: usize,
        ist_leaf: usize,
        env: &Env<'_>,
    ) -> Result<Core, SgrtError> {
        let q = u64::from(c.queue_latency);
        let t = &c.trv;
        let dummy = rtsim_core::Ray::new(
            rtsim_core::Vec3::ZERO,
            rtsim_core::Vec3::new(0.0, 0.0, 1.0),
            0.0,
            0.0,
        );
        let st = env.tracer.start(&dummy, rtsim_trace::Query::Closest);
        let slots = c.trvs * t.stacks;
        if slots > u32::from(u16::MAX) {
            return Err(rtsim_config::ConfigError::range(
                "arch.sgrt.trvs × arch.sgrt.trv.stacks",
                slots,
                "at most 65535 rays per core",
            )
            .into());
        }
        let rays = (0..slots)
            .map(|_| RaySlot {
                st,
                next: Step::Restart,
                counters: RayCounters::default(),
                job: 0,
                lines_left: 0,
                looked_up: false,
                back: Back::Ist,
                dispatched: 0,
                trv_steps: 0,
                trv_active: 0,
                trv_passes: 0,
                ist_steps: 0,
            })
            .collect();
        let mut trvs = Vec::with_capacity(c.trvs as usize);
        for k in 0..c.trvs {
            let stages = match c.organisation {
                Organisation::Pptrv => vec![
                    Stage::new(t.input_buffer, q, t.pre_latency, t.pre_interval)?,
                    Stage::new(t.fifo_entries, q, t.aabb_latency, t.aabb_interval)?,
                    Stage::new(t.fifo_entries, q, t.post_latency, t.post_interval)?,
                ],
                // The deep pipeline takes a pass every cycle; the box datapath's interval is
                // enforced separately (only passes that test boxes use it).
                Organisation::Sptrv => vec![Stage::new(
                    t.input_buffer,
                    q,
                    t.pre_latency + t.aabb_latency + t.post_latency,
                    1,
                )?],
            };
            trvs.push(Trv {
                free: (0..t.stacks)
                    .rev()
                    .map(|s| (k * t.stacks + s) as Slot)
                    .collect(),
                stages,
                rau: Rau::new(t.rau_entries),
                aabb_free: 0,
                held: 0,
                held_last: 0,
                in_pipes: 0,
                busy_since: 0,
                stats: TrvStats::default(),
            });
        }
        let i = &c.ist;
        let per_trv = trvs[0].stages.len();
        let units = trvs.len() * per_trv + 2;
        // One bit per unit in `due` (at most 16 TRVs × 3 stages + 2).
        debug_assert!(units <= 64);
        Ok(Core {
            id,
            org: c.organisation,
            stacks: t.stacks,
            rays,
            trvs,
            ist: Ist {
                stage: Stage::new(i.input_buffer, q, i.latency, i.interval)?,
                // Every ray of the core fits: the loop can never block.
                looped: Link::new(slots as usize, q)?,
                rau: Rau::new(i.rau_entries),
                stats: IstStats::default(),
            },
            jobs: Vec::new(),
            free_jobs: Vec::new(),
            ray_fifo: Link::new(c.ray_buffer_rays() as usize, q)?,
            hit_fifo: Link::new(c.hit_buffer_rays() as usize, q)?,
            rd_next: 0,
            trv_leaf0,
            ist_leaf,
            trv_hit: u64::from(t.l1.hit_latency),
            ist_hit: u64::from(i.l1.hit_latency),
            aabb_interval: u64::from(t.aabb_interval),
            q_lat: q,
            in_flight: 0,
            wake: vec![0; units],
            min_wake: 0,
            due: 0,
            touched: 0,
            finite: u64::MAX >> (64 - units),
            stage_mask: (1 << (units - 2)) - 1,
            now: 0,
            unit_trv: (0..units)
                .map(|u| ((u / per_trv) as u8, (u % per_trv) as u8))
                .collect(),
            shader_wake: 0,
            per_trv,
            stats: CoreStats::default(),
        })
    }

    /// Unit index of TRV `k`'s stage `i`.
    #[inline]
    fn unit(&self, k: usize, i: usize) -> usize {
        k * self.per_trv + i
    }
    #[inline]
    fn ist_unit(&self) -> usize {
        self.wake.len() - 2
    }
    #[inline]
    fn rd_unit(&self) -> usize {
        self.wake.len() - 1
    }
    /// Unit `u` may have something to do from `t` on.
    #[inline]
    fn wake_at(&mut self, u: usize, t: u64) {
        if self.wake[u] > t {
            self.wake[u] = t;
            self.touched |= 1 << u;
            self.finite |= 1 << u;
            self.min_wake = self.min_wake.min(t);
            if t <= self.now {
                self.due |= 1 << u;
            }
        }
    }

    /// Unit `u`'s wake becomes `w` (within a tick).
    #[inline]
    fn set_wake(&mut self, u: usize, w: u64) {
        self.wake[u] = w;
        self.touched |= 1 << u;
        if w == u64::MAX {
            self.finite &= !(1 << u);
        } else {
            self.finite |= 1 << u;
        }
        if w <= self.now {
            self.due |= 1 << u;
        } else {
            self.due &= !(1 << u);
        }
    }

    /// Whether unit `u` is due (every unit is with `all`).
    #[inline]
    fn is_due(&self, u: usize, all: bool) -> bool {
        all || self.due & (1 << u) != 0
    }

    /// The next due TRV stage from unit `*from` on (every stage with `all`), as (unit, TRV,
    /// stage); moves `*from` past it.
    #[inline]
    fn next_due_stage(&self, from: &mut usize, all: bool) -> Option<(usize, usize, usize)> {
        let live = if all {
            self.stage_mask
        } else {
            self.due & self.stage_mask
        };
        // `*from` is at most the IST's unit (< 64): the shift is defined.
        let m = live >> *from;
        if m == 0 {
            return None;
        }
        let u = *from + m.trailing_zeros() as usize;
        *from = u + 1;
        let (k, i) = self.unit_trv[u];
        Some((u, k as usize, i as usize))
    }

    /// One cycle of the T&I unit: finished rays leave, pipelines take rays, dispatch hands one
    /// on; only units whose wake has come (every unit with `all`, the reference engine).
    pub fn tick<M: MemoryPort>(
        &mut self,
        t: u64,
        all: bool,
        env: &Env<'_>,
        hier: &mut Hierarchy<M>,
    ) -> Result<(), SgrtError> {
        if !all && self.min_wake > t {
            return Ok(());
        }
        self.now = t;
        // One scan: the due units, and the least wake of the others (which only a wake-up in
        // this tick can change, and that marks the unit touched).
        let (mut due, mut rest) = (0u64, u64::MAX);
        let mut m = self.finite;
        while m != 0 {
            let u = m.trailing_zeros() as usize;
            m &= m - 1;
            let w = self.wake[u];
            if w <= t {
                due |= 1 << u;
            } else {
                rest = rest.min(w);
            }
        }
        self.due = due;
        self.touched = due;
        self.exits(t, all, env)?;
        self.entries(t, all, env, hier)?;
        self.dispatch(t, all, env)?;
        let mut m = self.touched;
        while m != 0 {
            rest = rest.min(self.wake[m.trailing_zeros() as usize]);
            m &= m - 1;
        }
        self.min_wake = rest;
        Ok(())
    }

    /// Store a job; its index goes through the buffers.
    pub fn add_job(&mut self, job: RayJob, owner: u32) -> u32 {
        let j = Job {
            job,
            owner,
            hit: SlotHit::miss(job.ray.tmax),
            counters: RayCounters::default(),
            latency: 0,
        };
        match self.free_jobs.pop() {
            Some(i) => {
                self.jobs[i as usize] = j;
                i
            }
            None => {
                self.jobs.push(j);
                (self.jobs.len() - 1) as u32
            }
        }
    }

    /// Give a job's storage back.
    pub fn free_job(&mut self, i: u32) {
        self.free_jobs.push(i);
    }

    fn trv_of(&self, slot: Slot) -> usize {
        (u32::from(slot) / self.stacks) as usize
    }

    /// The stage of TRV `k` that performs `unit`.
    fn stage_index(&self, unit: Unit) -> usize {
        match (self.org, unit) {
            (Organisation::Sptrv, _) => 0,
            (_, Unit::Pre) => 0,
            (_, Unit::Aabb) => 1,
            _ => 2,
        }
    }

    /// A line of `slot`'s current lookup arrived.
    pub fn line_arrived(&mut self, t: u64, slot: Slot) {
        let r = &mut self.rays[slot as usize];
        r.lines_left -= 1;
        if r.lines_left == 0 && r.looked_up {
            let back = r.back;
            self.ray_ready(t, slot, back);
        }
    }

    fn ray_ready(&mut self, t: u64, slot: Slot, back: Back) {
        match back {
            Back::Trv(i) => {
                let k = self.trv_of(slot);
                self.trvs[k].stages[i as usize].ready.push_back(slot);
                let u = self.unit(k, i as usize);
                self.wake_at(u, t);
            }
            Back::Ist => {
                self.ist.stage.ready.push_back(slot);
                let u = self.ist_unit();
                self.wake_at(u, t);
            }
        }
    }

    /// An entry of TRV `k`'s RAU was given back at `t`: its stages may look up again.
    fn rau_freed_trv(&mut self, k: usize, t: u64) {
        for i in 0..self.per_trv {
            let u = self.unit(k, i);
            self.wake_at(u, t);
        }
    }

    // -----------------------------------------------------------------------------------
    // Exits and routing

    /// Every due pipeline's finished rays leave (TRVs in order, then the IST); `all` visits
    /// every unit (the reference engine).
    fn exits(&mut self, t: u64, all: bool, env: &Env<'_>) -> Result<(), SgrtError> {
        let ist = self.ist_unit();
        let mut from = 0;
        while let Some((_, k, i)) = self.next_due_stage(&mut from, all) {
            while let Some(slot) = self.trvs[k].stages[i].pipe.head(t) {
                if !self.route(t, slot, false, env)? {
                    self.trvs[k].stages[i].pipe.block(t);
                    break;
                }
                self.trvs[k].stages[i].pipe.leave(t);
                self.trvs[k].leave_pipes(t);
            }
        }
        if self.is_due(ist, all) {
            while let Some(slot) = self.ist.stage.pipe.head(t) {
                if !self.route(t, slot, true, env)? {
                    self.ist.stage.pipe.block(t);
                    break;
                }
                self.ist.stage.pipe.leave(t);
            }
        }
        Ok(())
    }

    /// Send a ray that finished a pass to the unit of its next step; false if that queue is
    /// full.
    fn route(
        &mut self,
        t: u64,
        slot: Slot,
        from_ist: bool,
        env: &Env<'_>,
    ) -> Result<bool, SgrtError> {
        let r = &self.rays[slot as usize];
        let unit = unit_of(&r.next);
        let k = self.trv_of(slot);
        // A queue that had a head keeps it: only a ray into an empty queue can wake its unit.
        let (res, u, was_empty) = match unit {
            Unit::Done => return self.finish(t, slot, env),
            Unit::Ist if from_ist => {
                self.ist.stats.loops += 1;
                let empty = self.ist.looped.is_empty();
                (self.ist.looped.push(t, slot), self.ist_unit(), empty)
            }
            Unit::Ist => {
                let empty = self.ist.stage.input.is_empty();
                let pushed = self.ist.stage.input.push(t, slot);
                if pushed.is_ok() {
                    self.ist.stats.arrivals += 1;
                }
                (pushed, self.ist_unit(), empty)
            }
            u => {
                let i = self.stage_index(u);
                let q = &mut self.trvs[k].stages[i].input;
                let empty = q.is_empty();
                (q.push(t, slot), self.unit(k, i), empty)
            }
        };
        match res {
            Ok(()) => {
                if was_empty {
                    self.wake_at(u, t + self.q_lat);
                }
                Ok(true)
            }
            Err(PushError::Full(_)) => Ok(false),
            Err(PushError::Link(e)) => Err(e.into()),
        }
    }

    /// The ray leaves the T&I unit for the hit buffer; false if it is full.
    fn finish(&mut self, t: u64, slot: Slot, env: &Env<'_>) -> Result<bool, SgrtError> {
        let r = &self.rays[slot as usize];
        let job = r.job;
        match self.hit_fifo.push(t, job) {
            // The shader counts the rays still in the T&I unit: it may act now.
            Ok(()) => self.shader_wake = self.shader_wake.min(t),
            Err(PushError::Full(_)) => return Ok(false),
            Err(PushError::Link(e)) => return Err(e.into()),
        }
        let Step::Done(hit) = r.next else {
            unreachable!("finish is only called for a finished ray")
        };
        let latency = t - r.dispatched;
        let j = &mut self.jobs[job as usize];
        j.hit = hit;
        j.counters = r.counters;
        j.latency = latency;
        let ks: &mut KindStats = &mut self.stats.kinds[j.job.id.kind as usize];
        ks.rays += 1;
        ks.hits += u64::from(hit.is_hit());
        ks.trv_steps += u64::from(r.trv_steps);
        ks.trv_active_steps += u64::from(r.trv_active);
        ks.trv_passes += u64::from(r.trv_passes);
        ks.ist_steps += u64::from(r.ist_steps);
        ks.latency_cycles += latency;
        let _ = env;
        let k = self.trv_of(slot);
        let trv = &mut self.trvs[k];
        trv.account_held(t);
        trv.held -= 1;
        trv.free.push(slot);
        self.in_flight -= 1;
        // A free short stack: dispatch may go on.
        let rd = self.rd_unit();
        self.wake_at(rd, t);
        Ok(true)
    }

    // -----------------------------------------------------------------------------------
    // Entries

    /// Every pipeline takes its next ray, if it can (TRVs in order, then the IST).
    fn entries<M: MemoryPort>(
        &mut self,
        t: u64,
        all: bool,
        env: &Env<'_>,
        hier: &mut Hierarchy<M>,
    ) -> Result<(), SgrtError> {
        let u = self.ist_unit();
        let mut from = 0;
        while let Some((v, k, i)) = self.next_due_stage(&mut from, all) {
            self.enter_trv(t, k, i, env, hier)?;
            let trv = &self.trvs[k];
            let boxes = (self.org == Organisation::Sptrv).then_some(trv.aabb_free);
            let w = self.stage_wake(&trv.stages[i], None, &trv.rau, boxes, t, env);
            self.set_wake(v, w);
        }
        if self.is_due(u, all) {
            self.enter_ist(t, env, hier)?;
            let ist = &self.ist;
            let w = self.stage_wake(&ist.stage, Some(&ist.looped), &ist.rau, None, t, env);
            self.set_wake(u, w);
        }
        Ok(())
    }

    /// The candidate of a stage at `t`: a ray back from the RAU, a lookup in progress, or the
    /// head of the IST's loop or of the queue.
    fn candidate(stage: &Stage, looped: Option<&Link<Slot>>, t: u64) -> Option<Candidate> {
        if let Some(&s) = stage.ready.front() {
            return Some(Candidate::Ready(s));
        }
        if t < stage.retry_at {
            return None;
        }
        if let Some(p) = stage.partial {
            return Some(Candidate::Partial(p));
        }
        if let Some(&s) = looped.and_then(|l| l.peek(t)) {
            return Some(Candidate::Queue(s, true));
        }
        stage.input.peek(t).map(|&s| Candidate::Queue(s, false))
    }

    fn candidate_slot(c: &Candidate) -> Slot {
        match *c {
            Candidate::Ready(s) | Candidate::Queue(s, _) => s,
            Candidate::Partial(p) => p.slot,
        }
    }

    /// TRV `k`'s stage `i` takes its candidate at `t`, if the pipeline can.
    fn enter_trv<M: MemoryPort>(
        &mut self,
        t: u64,
        k: usize,
        i: usize,
        env: &Env<'_>,
        hier: &mut Hierarchy<M>,
    ) -> Result<(), SgrtError> {
        let stage = &self.trvs[k].stages[i];
        if !stage.pipe.can_enter(t) {
            return Ok(());
        }
        let Some(cand) = Self::candidate(stage, None, t) else {
            return Ok(());
        };
        let slot = Self::candidate_slot(&cand);
        // SPTRV: a pass that starts by testing boxes needs the box datapath.
        if self.org == Organisation::Sptrv
            && unit_of(&self.rays[slot as usize].next) == Unit::Aabb
            && t < self.trvs[k].aabb_free
        {
            return Ok(());
        }
        let p = match cand {
            Candidate::Ready(slot) => {
                let trv = &mut self.trvs[k];
                trv.stages[i].ready.pop_front();
                if trv.rau.release(t) {
                    self.rau_freed_trv(k, t);
                }
                self.start_trv_pass(t, k, i, slot, env);
                return Ok(());
            }
            Candidate::Partial(p) => p,
            Candidate::Queue(slot, _) => Partial {
                slot,
                next_line: 0,
                misses: 0,
            },
        };
        let Some(span) = env.lines(&self.rays[slot as usize].next) else {
            // A stack operation: no memory.
            self.trvs[k].stages[i].input.pop(t)?;
            self.start_trv_pass(t, k, i, slot, env);
            return Ok(());
        };
        if p.next_line == 0 && !self.trvs[k].rau.has_room() {
            return Ok(());
        }
        let leaf = self.trv_leaf0 + k;
        let tagv = tag(self.id, false, slot);
        let trv = &mut self.trvs[k];
        let stage = &mut trv.stages[i];
        let (looked, started) = lookup(
            t,
            p,
            span,
            leaf,
            tagv,
            stage,
            &mut trv.rau,
            &mut self.rays,
            hier,
        )?;
        if started {
            stage.input.pop(t)?;
        }
        self.after_lookup(t, slot, looked, Back::Trv(i as u8), |core, t, slot| {
            core.start_trv_pass(t, k, i, slot, env)
        });
        Ok(())
    }

    /// What follows a lookup: a hit enters the pipeline, a miss waits in the RAU (or is ready
    /// already if its lines arrived while the lookup was still going out).
    fn after_lookup(
        &mut self,
        t: u64,
        slot: Slot,
        looked: Looked,
        back: Back,
        enter: impl FnOnce(&mut Self, u64, Slot),
    ) {
        match looked {
            Looked::Refused => {}
            Looked::Hit => enter(self, t, slot),
            Looked::Parked => {
                let r = &mut self.rays[slot as usize];
                r.back = back;
                if r.lines_left == 0 {
                    self.ray_ready(t, slot, back);
                }
            }
        }
    }

    /// The ray enters TRV `k`'s stage `i` at `t` with its data: one pass (PPTRV: one step;
    /// SPTRV: three, with the operations that fit the pass).
    fn start_trv_pass(&mut self, t: u64, k: usize, i: usize, slot: Slot, env: &Env<'_>) {
        let r = &mut self.rays[slot as usize];
        let first = unit_of(&r.next);
        let memory = first != Unit::Post;
        let boxes = match r.next {
            Step::RootBox { .. } | Step::SiblingRetest { .. } => 1,
            Step::ChildPair { .. } => 2,
            _ => 0,
        };
        r.next = env.step(r);
        let mut post = u64::from(first == Unit::Post);
        let (steps, active) = match self.org {
            Organisation::Pptrv => (1, 1),
            Organisation::Sptrv => {
                let mut active = 1;
                if first == Unit::Aabb && unit_of(&r.next) == Unit::Post {
                    r.next = env.step(r);
                    active = 2;
                    post += 1;
                }
                (3, active)
            }
        };
        r.trv_steps += steps;
        r.trv_active += active;
        r.trv_passes += 1;
        let trv = &mut self.trvs[k];
        trv.stats.steps += u64::from(steps);
        trv.stats.active_steps += u64::from(active);
        trv.stats.passes += 1;
        trv.stats.pre_ops += u64::from(first == Unit::Pre);
        trv.stats.boxes += boxes;
        trv.stats.post_ops += post;
        let (extra, interval) = match self.org {
            Organisation::Pptrv => {
                let extra = if memory { self.trv_hit } else { 0 };
                (extra, trv.stages[i].pipe.interval())
            }
            Organisation::Sptrv => {
                // Every pass goes through the memory stage, used or bypassed.
                if first == Unit::Aabb {
                    trv.aabb_free = t + self.aabb_interval;
                }
                (self.trv_hit, 1)
            }
        };
        trv.stages[i].pipe.enter(t, slot, extra, interval);
        trv.enter_pipes(t);
    }

    /// The IST takes its candidate at `t`, if its pipeline can.
    fn enter_ist<M: MemoryPort>(
        &mut self,
        t: u64,
        env: &Env<'_>,
        hier: &mut Hierarchy<M>,
    ) -> Result<(), SgrtError> {
        if !self.ist.stage.pipe.can_enter(t) {
            return Ok(());
        }
        let Some(cand) = Self::candidate(&self.ist.stage, Some(&self.ist.looped), t) else {
            return Ok(());
        };
        let slot = Self::candidate_slot(&cand);
        let (p, from_loop) = match cand {
            Candidate::Ready(slot) => {
                self.ist.stage.ready.pop_front();
                // The IST's own wake is recomputed after this entry.
                let _ = self.ist.rau.release(t);
                self.start_ist_pass(t, slot, env);
                return Ok(());
            }
            Candidate::Partial(p) => (p, None),
            Candidate::Queue(slot, looped) => {
                if !self.ist.rau.has_room() {
                    return Ok(());
                }
                let p = Partial {
                    slot,
                    next_line: 0,
                    misses: 0,
                };
                (p, Some(looped))
            }
        };
        let span = env
            .lines(&self.rays[slot as usize].next)
            .expect("the IST reads a triangle record");
        let tagv = tag(self.id, false, slot);
        let ist = &mut self.ist;
        let (looked, started) = lookup(
            t,
            p,
            span,
            self.ist_leaf,
            tagv,
            &mut ist.stage,
            &mut ist.rau,
            &mut self.rays,
            hier,
        )?;
        match from_loop {
            Some(true) if started => {
                ist.looped.pop(t)?;
            }
            Some(false) if started => {
                ist.stage.input.pop(t)?;
            }
            _ => {}
        }
        self.after_lookup(t, slot, looked, Back::Ist, |core, t, slot| {
            core.start_ist_pass(t, slot, env)
        });
        Ok(())
    }

    fn start_ist_pass(&mut self, t: u64, slot: Slot, env: &Env<'_>) {
        let r = &mut self.rays[slot as usize];
        r.next = env.step(r);
        r.ist_steps += 1;
        self.ist.stats.steps += 1;
        let interval = self.ist.stage.pipe.interval();
        self.ist.stage.pipe.enter(t, slot, self.ist_hit, interval);
    }

    // -----------------------------------------------------------------------------------
    // Dispatch

    /// Ray dispatch: the ray buffer's head goes to the next TRV (round robin) with a free
    /// short stack and room in the queue of its first step; at most one ray per cycle.
    fn dispatch(&mut self, t: u64, all: bool, env: &Env<'_>) -> Result<(), SgrtError> {
        let rd = self.rd_unit();
        if !self.is_due(rd, all) {
            return Ok(());
        }
        self.dispatch_one(t, env)?;
        let w = self.rd_wake();
        self.set_wake(rd, w);
        Ok(())
    }

    /// When dispatch can next act: the head of the ray buffer is visible and a TRV can take
    /// it (`u64::MAX`: it waits for a ray or a free short stack).
    fn rd_wake(&self) -> u64 {
        let Some(v) = self.ray_fifo.next_ready() else {
            return u64::MAX;
        };
        let first = self.stage_index(Unit::Aabb);
        if self
            .trvs
            .iter()
            .any(|trv| !trv.free.is_empty() && !trv.stages[first].input.is_full())
        {
            v
        } else {
            u64::MAX
        }
    }

    /// The shader (or feeder) put a ray into the ray buffer at `t`.
    pub fn ray_pushed(&mut self, t: u64) {
        let rd = self.rd_unit();
        self.wake_at(rd, t + self.q_lat);
    }

    fn dispatch_one(&mut self, t: u64, env: &Env<'_>) -> Result<(), SgrtError> {
        let Some(&job) = self.ray_fifo.peek(t) else {
            return Ok(());
        };
        let n = self.trvs.len() as u32;
        let first = self.stage_index(Unit::Aabb);
        for d in 0..n {
            let k = ((self.rd_next + d) % n) as usize;
            let trv = &self.trvs[k];
            if trv.free.is_empty() || trv.stages[first].input.is_full() {
                continue;
            }
            self.ray_fifo.pop(t)?;
            let trv = &mut self.trvs[k];
            let slot = trv.free.pop().expect("checked non-empty");
            trv.account_held(t);
            trv.held += 1;
            trv.stats.rays += 1;
            let j = &self.jobs[job as usize].job;
            let r = &mut self.rays[slot as usize];
            r.st = env.tracer.start(&j.ray, j.query);
            r.counters = RayCounters::default();
            r.job = job;
            r.dispatched = t;
            r.trv_steps = 0;
            r.trv_active = 0;
            r.trv_passes = 0;
            r.ist_steps = 0;
            r.next = env.step(r);
            debug_assert_eq!(
                unit_of(&r.next),
                Unit::Aabb,
                "a traversal starts at the root box"
            );
            self.trvs[k].stages[first]
                .input
                .push(t, slot)
                .map_err(|e| match e {
                    PushError::Full(_) => unreachable!("checked for room"),
                    PushError::Link(e) => SgrtError::from(e),
                })?;
            self.in_flight += 1;
            self.stats.rd.dispatched += 1;
            self.rd_next = (k as u32 + 1) % n;
            let u = self.unit(k, first);
            if self.trvs[k].stages[first].input.len() == 1 {
                self.wake_at(u, t + self.q_lat);
            }
            // Room in the ray buffer for the shader.
            self.shader_wake = self.shader_wake.min(t);
            return Ok(());
        }
        Ok(())
    }

    // -----------------------------------------------------------------------------------
    // Time

    /// The earliest cycle after `now` at which this T&I unit may do something, `None` if it
    /// waits for others (a line, a free buffer entry).
    pub fn next_event(&self, now: u64) -> Option<u64> {
        (self.min_wake != u64::MAX).then_some(self.min_wake.max(now + 1))
    }

    /// A stage's wake after acting at `now`: its head's exit (or the next cycle while it waits
    /// at a full queue), and the entry of its candidate when nothing but time stands in its
    /// way.
    fn stage_wake(
        &self,
        stage: &Stage,
        looped: Option<&Link<Slot>>,
        rau: &Rau,
        box_free: Option<u64>,
        now: u64,
        env: &Env<'_>,
    ) -> u64 {
        let mut next = u64::MAX;
        let mut at = |c: u64| next = next.min(c);
        let Some(entry) = stage.pipe.entry_at() else {
            return now + 1;
        };
        if let Some(e) = stage.pipe.next_exit() {
            at(e);
        }
        let boxes = |slot: Slot| match box_free {
            Some(f) if unit_of(&self.rays[slot as usize].next) == Unit::Aabb => f,
            _ => 0,
        };
        if let Some(&s) = stage.ready.front() {
            at(entry.max(boxes(s)));
        } else if let Some(p) = stage.partial {
            at(entry.max(stage.retry_at).max(boxes(p.slot)));
        } else {
            for q in [looped, Some(&stage.input)].into_iter().flatten() {
                let (Some(v), Some(&slot)) = (q.next_ready(), q.peek(u64::MAX)) else {
                    continue;
                };
                if rau.has_room() || env.lines(&self.rays[slot as usize].next).is_none() {
                    at(v.max(entry).max(stage.retry_at).max(boxes(slot)));
                }
            }
        }
        next
    }

    /// Counters of the units, with time accounted up to `end`.
    pub fn stats_at(&self, end: u64) -> CoreStats {
        let mut s = self.stats.clone();
        for trv in &self.trvs {
            let mut ts = trv.stats.clone();
            ts.stack_occupancy_sum +=
                u128::from(trv.held) * u128::from(end.saturating_sub(trv.held_last));
            if trv.in_pipes > 0 {
                ts.busy_cycles += end.saturating_sub(trv.busy_since);
            }
            ts.rau = trv.rau.stats_at(end);
            for (i, st) in trv.stages.iter().enumerate() {
                ts.mem += &st.mem;
                let p = st.pipe.stats_at(end);
                match (self.org, i) {
                    (Organisation::Sptrv, _) => ts.deep += p,
                    (_, 0) => ts.pre += p,
                    (_, 1) => ts.aabb += p,
                    _ => ts.post += p,
                }
            }
            s.trv += ts;
        }
        let mut is = self.ist.stats.clone();
        is.pipe = self.ist.stage.pipe.stats_at(end);
        is.mem = self.ist.stage.mem.clone();
        is.rau = self.ist.rau.stats_at(end);
        s.ist += is;
        s
    }

    /// Queue and pipeline contents, for [`crate::Sgrt::fingerprint`].
    pub fn debug_state(&self) -> String {
        let mut s = String::new();
        for (k, trv) in self.trvs.iter().enumerate() {
            for (i, st) in trv.stages.iter().enumerate() {
                s += &format!(
                    "trv{k}.{i}: in {} ready {:?} partial {:?} pipe {} blocked {}\n",
                    st.input.len(),
                    st.ready,
                    st.partial.map(|p| p.slot),
                    st.pipe.len(),
                    st.pipe.is_blocked()
                );
            }
        }
        s += &format!(
            "ist: in {} loop {} ready {:?} pipe {}; rays {} hits {}\n",
            self.ist.stage.input.len(),
            self.ist.looped.len(),
            self.ist.stage.ready,
            self.ist.stage.pipe.len(),
            self.ray_fifo.len(),
            self.hit_fifo.len()
        );
        s
    }

    /// Whether nothing is in the T&I unit or its buffers.
    pub fn is_idle(&self) -> bool {
        self.in_flight == 0 && self.ray_fifo.is_empty() && self.hit_fifo.is_empty()
    }
}

/// The outcome of a lookup step.
enum Looked {
    /// Refused (bank busy or MSHRs full): offered again at the stage's `retry_at`.
    Refused,
    /// Every line hit: the ray enters the pipeline now.
    Hit,
    /// Some line missed: the ray is in the RAU until its lines arrive.
    Parked,
}

/// Send the lines of a lookup to the L1 from `p.next_line` on; a refusal leaves the rest for
/// `stage.retry_at` (the ray becomes the stage's partial lookup). The RAU entry is taken with
/// the first line and given back if every line hits. Also returns whether this call started
/// the lookup (its first line went out), so the caller takes the ray off its queue.
#[allow(clippy::too_many_arguments)]
fn lookup<M: MemoryPort>(
    t: u64,
    mut p: Partial,
    span: LineSpan,
    leaf: usize,
    tag: u64,
    stage: &mut Stage,
    rau: &mut Rau,
    rays: &mut [RaySlot],
    hier: &mut Hierarchy<M>,
) -> Result<(Looked, bool), SgrtError> {
    let starting = p.next_line == 0;
    while p.next_line < span.count {
        let addr = span.first + u64::from(p.next_line) * u64::from(span.line_bytes);
        let out = hier.submit(Request {
            cycle: t,
            l1: leaf,
            addr,
            op: MemOp::Read,
            tag,
        })?;
        if let Outcome::Busy { retry_at, .. } = out {
            stage.mem.refusals += 1;
            stage.retry_at = retry_at;
            stage.partial = (p.next_line > 0).then_some(p);
            return Ok((Looked::Refused, starting && p.next_line > 0));
        }
        if p.next_line == 0 {
            rau.reserve(t);
            let r = &mut rays[p.slot as usize];
            r.lines_left = 0;
            r.looked_up = false;
        }
        stage.mem.lines += 1;
        if out == Outcome::Pending {
            stage.mem.line_misses += 1;
            p.misses += 1;
            rays[p.slot as usize].lines_left += 1;
        } else {
            stage.mem.line_hits += 1;
        }
        p.next_line += 1;
    }
    stage.partial = None;
    stage.mem.lookups += 1;
    if p.misses == 0 {
        // The entry was taken by this lookup: nobody waited for it.
        rau.release(t);
        return Ok((Looked::Hit, starting));
    }
    rau.park();
    rays[p.slot as usize].looked_up = true;
    Ok((Looked::Parked, starting))
}
