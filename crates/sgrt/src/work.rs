//! What the chip computes: a frame of a workload (each pixel a state machine,
//! `rtsim_trace::Integrator`) or the rays of a `rays.bin`. The cores take work in packets from
//! one shared, ordered list; this module starts and resumes the items and keeps their results,
//! so the image, the hits and the functional counters come out whatever the timing.

use crate::core::{Core, Job};
use crate::error::SgrtError;
use rtsim_bvh::MemoryImage;
use rtsim_core::{MemOp, Ray};
use rtsim_trace::query::{RayReader, is_traceable};
use rtsim_trace::{
    FrameStats, Hit, Integrator, NO_HIT, Next, PathState, PixelResult, Query, RayCounters, RayId,
    RayJob, RayKind, Resumed, TraceResult,
};
use std::collections::VecDeque;

/// Rays read from a `rays.bin` at a time.
const CHUNK: usize = 1 << 16;

/// What a start or resume of an item asks the shader to do: the operations its kernels ran
/// and the lines they read or wrote (`rtsim_trace::ops`, the memory image).
#[derive(Debug, Default)]
pub(crate) struct Charge {
    pub ops: u64,
    /// Line addresses with the operation, in program order.
    pub memory: Vec<(u64, MemOp)>,
    /// Rays produced (job indices in the core's table).
    pub rays: Vec<u32>,
}

impl Charge {
    pub fn clear(&mut self) {
        self.ops = 0;
        self.memory.clear();
        self.rays.clear();
    }
}

/// A frame: the pixels of the window, their state machines and results.
#[derive(Debug)]
pub(crate) struct FrameWork<'a> {
    integ: &'a Integrator<'a>,
    image: &'a MemoryImage,
    line_bytes: u32,
    /// Pixels to do, in order, and how many were handed out.
    todo: Vec<u32>,
    next: usize,
    states: Vec<PathState>,
    free_states: Vec<u32>,
    pub pixels: Vec<PixelResult>,
    /// Cycles per pixel: Σ over its rays of dispatch to leaving the T&I unit.
    pub heat: Vec<u64>,
    /// Counters of every ray, timed or answered functionally.
    pub stats: FrameStats,
    /// Which ray kinds go through the T&I unit (the others are answered functionally, at no
    /// cost: the T&I-only mode's rays that a table does not measure).
    timed: [bool; 6],
    pub done: u64,
}

/// The rays of a file.
#[derive(Debug)]
pub(crate) struct RayWork {
    reader: RayReader,
    buffer: VecDeque<Ray>,
    chunk: Vec<Ray>,
    query: Query,
    kind: RayKind,
    next: u64,
    pub hits: Vec<Hit>,
    pub stats: FrameStats,
    pub done: u64,
}

/// The work of a run.
#[derive(Debug)]
pub(crate) enum Work<'a> {
    Frame(FrameWork<'a>),
    Rays(RayWork),
}

impl<'a> FrameWork<'a> {
    pub fn new(
        integ: &'a Integrator<'a>,
        image: &'a MemoryImage,
        line_bytes: u32,
        todo: Vec<u32>,
        timed: [bool; 6],
    ) -> Self {
        let p = integ.params();
        let n = (p.width * p.height) as usize;
        FrameWork {
            integ,
            image,
            line_bytes,
            todo,
            next: 0,
            states: Vec::new(),
            free_states: Vec::new(),
            pixels: vec![PixelResult::default(); n],
            heat: vec![0; n],
            stats: FrameStats::default(),
            timed,
            done: 0,
        }
    }

    /// Charge a transition's kernels and records.
    fn charge(&self, sh: &rtsim_trace::Shading, c: &mut Charge) {
        c.ops += u64::from(rtsim_trace::ops::shading(sh).total());
        let lines = |span: rtsim_bvh::LineSpan, op: MemOp, c: &mut Charge| {
            c.memory.extend(span.iter().map(|a| (a, op)));
        };
        if let Some(slot) = sh.triangle {
            lines(
                self.image.triangle_lines(slot, self.line_bytes),
                MemOp::Read,
                c,
            );
        }
        if let Some(m) = sh.material {
            lines(
                self.image.material_lines(m, self.line_bytes),
                MemOp::Read,
                c,
            );
        }
        if let Some(p) = sh.framebuffer {
            lines(
                self.image.framebuffer_lines(p, self.line_bytes),
                MemOp::Write,
                c,
            );
        }
    }

    /// Follow a pixel's state machine from `r` until it asks for a timed ray (a job on `core`)
    /// or finishes; untimed rays are traced functionally on the way.
    fn drive(&mut self, owner: u32, mut r: Resumed, core: &mut Core, c: &mut Charge) {
        loop {
            self.charge(&r.shading, c);
            match r.next {
                Next::Trace(job) if self.timed[job.id.kind as usize] => {
                    c.rays.push(core.add_job(job, owner));
                    return;
                }
                Next::Trace(job) => {
                    let mut counters = RayCounters::default();
                    let res = self.integ.trace(&job, &mut counters);
                    self.stats
                        .kind_mut(job.id.kind)
                        .record(&counters, res.hit.is_hit());
                    let px = &mut self.pixels[job.id.pixel as usize];
                    px.nodes_visited = px.nodes_visited.saturating_add(counters.nodes_visited);
                    r = self
                        .integ
                        .resume(&mut self.states[owner as usize], &job, &res);
                }
                Next::Done(colour) => {
                    let p = self.states[owner as usize].pixel();
                    self.pixels[p as usize].color = colour;
                    self.free_states.push(owner);
                    self.done += 1;
                    return;
                }
            }
        }
    }

    fn begin(&mut self, pixel: u32, core: &mut Core, c: &mut Charge) {
        let (st, r) = self.integ.begin(pixel);
        let owner = match self.free_states.pop() {
            Some(i) => {
                self.states[i as usize] = st;
                i
            }
            None => {
                self.states.push(st);
                (self.states.len() - 1) as u32
            }
        };
        self.drive(owner, r, core, c);
    }

    fn resume(&mut self, job: &Job, core: &mut Core, c: &mut Charge) {
        let kind = job.job.id.kind;
        self.stats
            .kind_mut(kind)
            .record(&job.counters, job.hit.is_hit());
        let p = job.job.id.pixel as usize;
        self.heat[p] += job.latency;
        let px = &mut self.pixels[p];
        px.nodes_visited = px.nodes_visited.saturating_add(job.counters.nodes_visited);
        let res = TraceResult::from_slot_hit(self.integ.tracer(), job.hit);
        let r = self
            .integ
            .resume(&mut self.states[job.owner as usize], &job.job, &res);
        self.drive(job.owner, r, core, c);
    }
}

impl RayWork {
    pub fn new(reader: RayReader, query: Query) -> Self {
        let count = reader.count() as usize;
        RayWork {
            reader,
            buffer: VecDeque::new(),
            chunk: Vec::new(),
            query,
            // Rays of a file have no workload kind: closest-hit queries are counted as primary
            // rays, any-hit queries as AO rays (SGRT's any-hit rays).
            kind: match query {
                Query::Closest => RayKind::Primary,
                Query::Any => RayKind::Ao,
            },
            next: 0,
            hits: vec![
                Hit {
                    t: f32::INFINITY,
                    prim: NO_HIT,
                    u: 0.0,
                    v: 0.0
                };
                count
            ],
            stats: FrameStats::default(),
            done: 0,
        }
    }

    fn begin(&mut self, core: &mut Core, c: &mut Charge) -> Result<(), SgrtError> {
        if self.buffer.is_empty() {
            self.reader.read_chunk(CHUNK, &mut self.chunk)?;
            self.buffer.extend(self.chunk.drain(..));
        }
        let ray = self.buffer.pop_front().expect("items remain");
        let i = self.next - 1;
        if !is_traceable(&ray) {
            // As `rtsim trace`: a ray that cannot hit is a miss, not traced.
            self.done += 1;
            return Ok(());
        }
        let job = RayJob {
            id: RayId {
                pixel: i as u32,
                sample: (i >> 32) as u32,
                segment: 0,
                kind: self.kind,
            },
            ray,
            query: self.query,
        };
        c.rays.push(core.add_job(job, 0));
        Ok(())
    }

    fn resume(&mut self, job: &Job, tracer: &rtsim_trace::Tracer) {
        self.stats
            .kind_mut(job.job.id.kind)
            .record(&job.counters, job.hit.is_hit());
        let i = u64::from(job.job.id.pixel) | (u64::from(job.job.id.sample) << 32);
        self.hits[i as usize] = tracer.slot_to_scene(job.hit);
        self.done += 1;
    }
}

impl Work<'_> {
    /// Items not yet handed out.
    pub fn remaining(&self) -> u64 {
        match self {
            Work::Frame(f) => (f.todo.len() - f.next) as u64,
            Work::Rays(r) => r.reader.count() - r.next,
        }
    }

    /// Items in total.
    pub fn total(&self) -> u64 {
        match self {
            Work::Frame(f) => f.todo.len() as u64,
            Work::Rays(r) => r.reader.count(),
        }
    }

    /// Items finished.
    pub fn done(&self) -> u64 {
        match self {
            Work::Frame(f) => f.done,
            Work::Rays(r) => r.done,
        }
    }

    /// Start the next item on `core`, charging `c`.
    pub fn begin(&mut self, core: &mut Core, c: &mut Charge) -> Result<(), SgrtError> {
        match self {
            Work::Frame(f) => {
                let p = f.todo[f.next];
                f.next += 1;
                f.begin(p, core, c);
                Ok(())
            }
            Work::Rays(r) => {
                r.next += 1;
                r.begin(core, c)
            }
        }
    }

    /// A job of `core` came back from the T&I unit: record it and continue its item.
    pub fn resume(
        &mut self,
        job: u32,
        core: &mut Core,
        tracer: &rtsim_trace::Tracer,
        c: &mut Charge,
    ) {
        let j = core.jobs[job as usize];
        core.free_job(job);
        match self {
            Work::Frame(f) => f.resume(&j, core, c),
            Work::Rays(r) => r.resume(&j, tracer),
        }
    }

    /// The functional counters of every ray.
    pub fn stats(&self) -> &FrameStats {
        match self {
            Work::Frame(f) => &f.stats,
            Work::Rays(r) => &r.stats,
        }
    }
}
