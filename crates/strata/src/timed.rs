//! The timed STRaTA chip: the ray flow of [`crate::flow`] run by the TRaX chip's TPs, cycle
//! by cycle, on the TRaX engines (`rtsim_trax::fast`, `rtsim_trax::reference`) through a
//! [`Source`] — so every issue rule, cache, link and DRAM timing is the baseline's, and what
//! differs is what STRaTA changes (`docs/STRATA.md` "The timed chip"):
//!
//! - **Work.** A TP first helps fill the stream memory: it takes a path slot from the atomic
//!   counter, runs the camera ray's shading blocks, writes the path's state record and pushes
//!   the ray onto the root buffer, until every slot (at most one per pixel) holds a path
//!   (under `arch.strata.fill = static` TP `i` of `T` takes slots `i`, `i + T`, … itself).
//!   Then it loops: pop a ray from its TM's treelet buffer (`stream_pop`), run the ray's
//!   `bit-stack` steps while they stay in the treelet (each step's block, unfused or fused),
//!   and push it onto the buffer of the treelet it enters (`stream_push`). A finished ray is
//!   shaded on the spot: read the path's state record, run the transition's shading blocks,
//!   write the record, push the successor onto the root buffer; a finished pixel takes the
//!   next pixel from the atomic counter, or retires its path slot.
//! - **Buffers.** A TM keeps its treelet while its buffer holds rays. A pop that finds the
//!   buffer empty releases it and picks another by the policy (`arch.strata.policy`); with
//!   none to take, the TP retries after `arch.strata.poll_cycles`. Pops, pushes and path
//!   records share the stream memory's banks (`arch.strata.stream.banks`, one port each by
//!   default): an access to a bank already used this cycle waits a cycle.
//! - **Fused pipelines** (`arch.strata.fused`). A TM is in node mode (a box pipeline of 6 mul
//!   and 6 add: one box test per cycle, latency 8; 2 mul and 2 add left for general use) or
//!   triangle mode (`triangle_pipelines` Plücker pipelines of 4 mul and 2 add, initiation
//!   interval 18, latency 31). It changes mode only when it picks a treelet of the other kind
//!   and none of its TPs holds a ray (§3.3: "all of the TPs within operate in the same mode
//!   until reconfigured"); the reconfiguration takes `reconfigure_cycles`.
//!
//! The image and every ray's counters are the functional tracer's (`bit-stack`) by
//! construction: the values come from the functional kernels; timing decides only when.

use crate::config::{Fill, StrataConfig};
use crate::flow::{FlowError, Ready};
use crate::pipeline;
use crate::program::StrataProgram;
use crate::stream::{StreamLayout, StreamMemory, StreamStats};
use rtsim_bvh::{TreeletKind, Treelets};
use rtsim_trace::step::Step;
use rtsim_trace::step::bitstack::State;
use rtsim_trace::{
    FrameStats, Kernel, Next, PathState, RayCounters, RayJob, Resumed, TraceResult, Traversal,
    TraversalState,
};
use rtsim_trax::isa::{Class, Mem, StreamOp, UNIT_CLASSES};
use rtsim_trax::program::SHADING_ORDER;
use rtsim_trax::stats::{IssueStats, Stall};
use rtsim_trax::timeline::Column;
use rtsim_trax::work::PixelDone;
use rtsim_trax::{
    Chip, ChipError, Frame, Options, Output, Progress, Run, Source, SourceAccess, TraxConfig,
};
use serde::Serialize;

/// Why the timed chip could not run.
#[derive(Debug, thiserror::Error)]
pub enum TimedError {
    /// What the functional flow refuses too (no treelets, not bit-stack, a stream or record
    /// error).
    #[error(transparent)]
    Flow(#[from] FlowError),
    #[error(transparent)]
    Chip(#[from] ChipError),
    #[error(transparent)]
    Config(#[from] rtsim_config::ConfigError),
}

/// What the stream memory and the scheduling did.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct StrataFacts {
    pub layout: Option<StreamLayout>,
    pub stream: StreamStats,
    /// nJ per stream access and the stream memory's energy (J).
    pub stream_access_nj: f64,
    pub stream_energy_j: f64,
    /// Path slots (paths in flight at most).
    pub paths: u32,
    /// Buffer picks (a TM starting on a treelet) and mode changes (reconfigurations).
    pub treelet_switches: u64,
    pub reconfigurations: u64,
    /// TMs on the picked buffer at each pick, the picking TM included, summed over picks
    /// (divided by `treelet_switches`: how many TMs share a buffer when one joins it), and
    /// the most at once.
    pub holders_at_pick: u64,
    pub max_holders: u32,
    /// Pops refused: no buffer the TM may take held a ray (the TP waits `poll_cycles`), or
    /// the TM must reconfigure and still has TPs holding rays.
    pub empty_polls: u64,
    pub drain_waits: u64,
    /// Pops refused under `switch = drained`: the buffer is empty but TPs of the TM still hold
    /// rays.
    pub hold_waits: u64,
    /// Stream accesses that waited a cycle for their bank: pops, pushes, path records.
    pub bank_conflicts: u64,
    pub bank_conflicts_by_op: [u64; 3],
    /// Triangle tests that waited for a pipeline instance.
    pub pipeline_waits: u64,
    /// Pushes by cause: a path's ray entering the root buffer, a node-treelet crossing, a
    /// leaf sending its ray to its triangle treelet, the ray coming back.
    pub pushes_root: u64,
    pub pushes_crossing: u64,
    pub pushes_to_triangles: u64,
    pub pushes_from_triangles: u64,
    /// Fused tests performed (box, triangle) and their operations' energy (J), charged to the
    /// execution units.
    pub box_tests: u64,
    pub triangle_tests: u64,
    pub pipeline_energy_j: f64,
}

/// Where a TP is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Phase {
    /// Taking a path slot from the counter (its value decides what follows).
    Fill,
    /// Waiting for a pop's ray.
    Pop,
    /// Running a ray's steps inside its treelet.
    Ray,
    /// Its path's pixel is done: taking the next pixel from the counter.
    Restart,
    Halted,
}

/// Most blocks queued at once: a transition's shading (every kernel at most twice, three
/// record accesses), the path record, push, pop and a step's two blocks.
/// The root treelet's buffer: every path's first ray and every successor enter it.
const ROOT: u32 = 0;

/// STRaTA's columns of the time series (`sim.timeline_cycles`), after the chip's: stream
/// accesses, buffer picks (with the TMs on the picked buffer summed, as
/// `strata.holders_at_pick`) and reconfigurations in the interval, then levels at its end:
/// rays in the stream memory, in the root buffer, TMs on the root buffer, buffers holding rays,
/// paths in flight, and the most TMs on a picked buffer in the interval.
const TIMELINE: [Column; 12] = [
    Column::count("stream_pops"),
    Column::count("stream_pushes"),
    Column::count("path_records"),
    Column::count("treelet_switches"),
    Column::count("holders_at_pick"),
    Column::count("reconfigurations"),
    Column::level("rays_buffered"),
    Column::level("root_rays"),
    Column::level("root_holders"),
    Column::level("buffers_with_rays"),
    Column::level("live_paths"),
    Column::level("max_holders"),
];

const QUEUE: usize = 2 * rtsim_trace::workload::KERNELS + 3 + 8;

/// A TP's STRaTA work. `repr(C)` keeps what every `next` reads (the queue's position, the
/// phase, the ray and its counters) together at the front, in the first three host cache
/// lines: the fast engine visits up to 4,096 TPs between two visits to one, so each visit
/// starts with host cache misses, one per line touched.
/// Host cache lines at the front of a [`Tp`] that the fast engine prefetches: the fields up
/// to the queue, and the queue's first two blocks.
const TP_HOT_LINES: usize = (std::mem::offset_of!(Tp, queue) + 2 * size_of::<Run>()).div_ceil(64);

#[derive(Clone, Debug)]
#[repr(C, align(64))]
struct Tp {
    qlen: u8,
    qpos: u8,
    phase: Phase,
    /// The TP holds a ray of its TM's mode (or is still filling).
    held: bool,
    halt: bool,
    /// The held ray's kind, as its record carries it.
    kind: u8,
    /// The treelet (buffer) the ray was popped from.
    treelet: u32,
    /// The path whose ray (or shading) the TP runs.
    path: Option<u32>,
    counter: Option<u32>,
    /// The ray being traversed.
    trav: Option<State>,
    /// The held ray's counters: its path's, moved here at the pop and back at the push (so a
    /// step need not reach the path table, a host cache miss per step).
    counters: RayCounters,
    queue: [Run; QUEUE],
    /// The ray popped, delivered by the pop access.
    popped: Option<[u8; 48]>,
    /// The ray to push and its buffer, consumed by the push access.
    outgoing: Option<(u32, [u8; 48])>,
    /// Under `fill = static`, the next path slot this TP fills (its index, then every
    /// TP-count-th slot after it). Last: read only while filling, it stays out of the lines
    /// the engine prefetches for every step.
    fill: u32,
}

/// A slot of the path table. `repr(C)`: a pop and a push read and write only the front
/// (whether the slot is live, and the ray's counters), one host cache line.
#[derive(Clone, Debug)]
#[repr(C, align(64))]
struct Path {
    live: bool,
    counters: RayCounters,
    nodes: u32,
    /// The path and its current ray (`None` while the slot is free).
    body: Option<PathBody>,
}

#[derive(Clone, Debug)]
struct PathBody {
    state: PathState,
    job: RayJob,
}

impl Path {
    fn free() -> Path {
        Path {
            live: false,
            counters: RayCounters::default(),
            nodes: 0,
            body: None,
        }
    }
}

// The host-cache layout the `Tp` and `Path` docs promise, checked when compiling: what a
// step reads of its TP lies in the lines the engine prefetches, and a pop or push reaches
// one line of the path table (moving a field would change no result, only the speed).
const _: () = {
    use std::mem::offset_of;
    assert!(align_of::<Tp>() == 64 && align_of::<Path>() == 64);
    assert!(TP_HOT_LINES <= 4);
    assert!(offset_of!(Tp, counters) + size_of::<RayCounters>() <= offset_of!(Tp, queue));
    assert!(offset_of!(Tp, trav) < offset_of!(Tp, queue));
    assert!(offset_of!(Path, live) == 0);
    assert!(offset_of!(Path, counters) + size_of::<RayCounters>() <= 64);
};

/// The live path in slot `id` (a model bug if it is free).
fn live(paths: &mut [Path], id: u32) -> &mut Path {
    let p = &mut paths[id as usize];
    assert!(p.live, "path slot {id} is free (a model bug)");
    p
}

#[derive(Clone, Debug)]
struct Tm {
    treelet: Option<u32>,
    /// The pipelines it is configured for (fused only).
    mode: TreeletKind,
    configured_at: u64,
    /// TPs holding a ray (or still filling).
    holding: u32,
    /// Per triangle pipeline instance: the first cycle it accepts a test.
    tri_free: [u64; 2],
}

/// The STRaTA work of every TP and the state they share (stream memory, buffers, pipelines).
pub struct StrataSource<'a> {
    frame: Frame<'a>,
    sp: &'a StrataProgram,
    cfg: StrataConfig,
    treelets: &'a Treelets,
    last_of_leaf: Vec<bool>,
    leaf_of_slot: Vec<u32>,
    stream: StreamMemory,
    ready: Ready,
    rr_cursor: Option<u32>,
    tms: Vec<Tm>,
    tps: Vec<Tp>,
    paths: Vec<Path>,
    n_paths: u32,
    fill_next: u32,
    /// TPs on the chip: a static fill's step between one TP's slots.
    fill_stride: u32,
    pixel_next: u32,
    live_paths: u32,
    /// Per stream bank: the cycle of its last accesses and how many.
    banks: Vec<(u64, u32)>,
    caps_node: [u8; UNIT_CLASSES],
    caps_tri: [u8; UNIT_CLASSES],
    facts: StrataFacts,
    /// The most TMs on a picked buffer since the time series' last sample.
    interval_max_holders: u32,
}

impl std::fmt::Debug for StrataSource<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("StrataSource")
            .field("paths", &self.n_paths)
            .finish_non_exhaustive()
    }
}

/// The unit capacities of a TM in each mode, from the baseline's (`trax`): node mode gives the
/// box pipeline 6 multipliers and 6 adders (§3.3) and has one box test per cycle; triangle
/// mode gives each Plücker instance 4 and 2, leaving at least one of each for the
/// instructions outside the pipeline (assumed: with two instances all 8 multipliers are the
/// pipelines', but they use 41 of their 72 multiply slots per interval, so one general
/// multiply per cycle fits between them). Without fusing, the baseline's units and no box
/// pipeline.
fn mode_caps(
    base: &[u8; UNIT_CLASSES],
    cfg: &StrataConfig,
) -> ([u8; UNIT_CLASSES], [u8; UNIT_CLASSES]) {
    let (add, mul) = (Class::FpAdd as usize, Class::FpMul as usize);
    if !cfg.fused {
        return (*base, *base);
    }
    let mut node = *base;
    node[add] = base[add].saturating_sub(pipeline::BOX.fp_add as u8).max(1);
    node[mul] = base[mul].saturating_sub(pipeline::BOX.fp_mul as u8).max(1);
    node[Class::BoxTest as usize] = pipeline::BOX.instances as u8;
    let mut tri = *base;
    let n = cfg.triangle_pipelines as u8;
    tri[add] = base[add]
        .saturating_sub(n * pipeline::TRIANGLE.fp_add as u8)
        .max(1);
    tri[mul] = base[mul]
        .saturating_sub(n * pipeline::TRIANGLE.fp_mul as u8)
        .max(1);
    tri[Class::BoxTest as usize] = 0;
    (node, tri)
}

impl<'a> StrataSource<'a> {
    /// The work of a `tms × tps_per_tm` chip rendering `frame` with `cfg`.
    pub fn new(
        frame: Frame<'a>,
        sp: &'a StrataProgram,
        cfg: &StrataConfig,
        trax: &TraxConfig,
    ) -> Result<StrataSource<'a>, TimedError> {
        let treelets = frame.image.treelets().ok_or(FlowError::NoTreelets)?;
        if frame.tracer.traversal() != Traversal::BitStack {
            return Err(FlowError::NotBitStack.into());
        }
        let (leaf_of_slot, last_of_leaf) = crate::flow::leaf_maps(frame.tracer.bvh());
        let buffers = treelets.len() as u32;
        let stream = StreamMemory::with_path_table(&cfg.stream, buffers, cfg.path_bytes)
            .map_err(FlowError::from)?;
        let n_paths = stream.capacity().min(frame.pixels.len() as u32);
        let mut base = [0u8; UNIT_CLASSES];
        for (k, (_, u)) in trax.units.by_class().iter().enumerate() {
            base[k] = u.count as u8;
        }
        let (caps_node, caps_tri) = mode_caps(&base, cfg);
        let tps = trax.total_tps() as usize;
        let static_fill = cfg.fill == Fill::Static;
        let tp = Tp {
            phase: Phase::Fill,
            queue: [Run::default(); QUEUE],
            qlen: 0,
            qpos: 0,
            counter: None,
            fill: 0,
            path: None,
            trav: None,
            counters: RayCounters::default(),
            treelet: 0,
            popped: None,
            outgoing: None,
            held: true,
            halt: false,
            kind: 0,
        };
        let facts = StrataFacts {
            layout: Some(*stream.layout()),
            stream_access_nj: cfg.stream.access_nj(),
            paths: n_paths,
            ..StrataFacts::default()
        };
        Ok(StrataSource {
            frame,
            sp,
            cfg: cfg.clone(),
            treelets,
            last_of_leaf,
            leaf_of_slot,
            ready: Ready::new(buffers, trax.tps_per_tm, cfg.tms_per_buffer, cfg.policy),
            rr_cursor: None,
            tms: vec![
                Tm {
                    treelet: None,
                    mode: TreeletKind::Node,
                    configured_at: 0,
                    holding: trax.tps_per_tm,
                    tri_free: [0; 2],
                };
                trax.tms as usize
            ],
            tps: (0..tps as u32)
                .map(|i| Tp {
                    fill: i,
                    ..tp.clone()
                })
                .collect(),
            paths: vec![Path::free(); n_paths as usize],
            n_paths,
            // A static fill hands every slot out at the start: no TP asks the counter for one,
            // and the paths count as in flight (so none can look finished) until they retire.
            fill_next: if static_fill { n_paths } else { 0 },
            fill_stride: tps as u32,
            pixel_next: n_paths,
            live_paths: if static_fill { n_paths } else { 0 },
            banks: vec![(u64::MAX, 0); cfg.stream.banks as usize],
            caps_node,
            caps_tri,
            stream,
            facts,
            interval_max_holders: 0,
        })
    }

    /// The capacities every TM starts with (node mode).
    pub fn initial_caps(&self) -> [u8; UNIT_CLASSES] {
        self.caps_node
    }

    /// What the stream memory and the scheduling did.
    pub fn facts(&self) -> StrataFacts {
        let mut f = self.facts.clone();
        f.stream = self.stream.stats().clone();
        f.stream_energy_j = f.stream.accesses() as f64 * f.stream_access_nj * 1e-9;
        f
    }

    /// The block that gives a filling TP its next path slot.
    fn fill_run(&self) -> Run {
        match self.cfg.fill {
            Fill::Counter => Run::new(self.sp.program.next_pixel),
            Fill::Static => Run::new(self.sp.fill_slot),
        }
    }

    fn push_run(&mut self, tp: usize, r: Run) {
        let w = &mut self.tps[tp];
        w.queue[w.qlen as usize] = r;
        w.qlen += 1;
    }

    /// Queue a transition's shading blocks (as the TRaX program runs them).
    fn queue_shading(&mut self, tp: usize, r: &Resumed) {
        let p = &self.sp.program;
        let img = self.frame.image;
        let sh = &r.shading;
        for &k in &SHADING_ORDER {
            let seg = p.kernels[k as usize];
            for _ in 0..sh.count(k) {
                let run = if k == Kernel::Surface {
                    let slot = sh
                        .triangle
                        .expect("the surface kernel reads the hit triangle");
                    Run::at(seg, img.triangle_addr(slot))
                } else {
                    Run::new(seg)
                };
                self.push_run(tp, run);
            }
            if k == Kernel::Surface
                && let Some(m) = sh.material
            {
                self.push_run(tp, Run::at(p.material_read, img.material_addr(m)));
            }
            if k == Kernel::Finish
                && let Some(px) = sh.framebuffer
            {
                self.push_run(tp, Run::at(p.framebuffer_write, img.framebuffer_addr(px)));
            }
        }
    }

    /// After a transition of path `id` on TP `tp`: queue its shading, then the successor's
    /// record write and push onto the root buffer (and the next pop), or the counter for the
    /// next pixel.
    fn then(
        &mut self,
        tp: usize,
        id: u32,
        r: Resumed,
        done: &mut Option<PixelDone>,
    ) -> Result<(), TimedError> {
        self.queue_shading(tp, &r);
        match r.next {
            Next::Trace(job) => {
                let p = live(&mut self.paths, id);
                p.body.as_mut().expect("a live path has a body").job = job;
                p.counters = RayCounters::default();
                let TraversalState::BitStack(s) = self.frame.tracer.start(&job.ray, job.query)
                else {
                    return Err(FlowError::NotBitStack.into());
                };
                let rec = s
                    .to_record(id, job.id.kind as u8)
                    .map_err(FlowError::from)?;
                self.push_run(tp, Run::new(self.sp.path_write));
                self.push_run(tp, Run::new(self.sp.push));
                self.facts.pushes_root += 1;
                let w = &mut self.tps[tp];
                w.outgoing = Some((0, rec));
                w.path = Some(id);
                if w.phase != Phase::Fill {
                    w.phase = Phase::Pop;
                    self.push_run(tp, Run::new(self.sp.pop));
                } else {
                    self.push_run(tp, self.fill_run());
                }
            }
            Next::Done(color) => {
                let p = live(&mut self.paths, id);
                *done = Some(PixelDone {
                    pixel: p
                        .body
                        .as_ref()
                        .expect("a live path has a body")
                        .state
                        .pixel(),
                    color,
                    nodes_visited: p.nodes,
                });
                let w = &mut self.tps[tp];
                w.path = Some(id);
                let run = if w.phase != Phase::Fill {
                    w.phase = Phase::Restart;
                    Run::new(self.sp.program.next_pixel)
                } else {
                    self.fill_run()
                };
                self.push_run(tp, run);
            }
        }
        Ok(())
    }

    /// Start pixel `v` on path slot `id`.
    fn begin(
        &mut self,
        tp: usize,
        id: u32,
        v: u32,
        done: &mut Option<PixelDone>,
    ) -> Result<(), TimedError> {
        let pixel = self.frame.pixels[v as usize];
        let (state, r) = self.frame.integ.begin(pixel);
        self.paths[id as usize] = Path {
            live: true,
            counters: RayCounters::default(),
            nodes: 0,
            body: Some(PathBody {
                state,
                // Replaced by the first `Next::Trace` before anything reads it.
                job: crate::flow::placeholder_job(pixel),
            }),
        };
        self.then(tp, id, r, done)
    }

    /// The block of one `bit-stack` step (`None`: `Done` and `Treelet` run nothing).
    fn step_runs(&mut self, tp: usize, step: &Step) {
        let sp = self.sp;
        let p = &sp.program;
        let img = self.frame.image;
        let fused = self.cfg.fused;
        let run = match *step {
            Step::RootBox { .. } => {
                let seg = if fused { sp.fused_root } else { p.root_box };
                Run::at(seg, img.node_addr(0))
            }
            Step::Node { node, .. } => Run::at(p.node, img.node_addr(node)),
            Step::ChildPair { left, hit } => {
                let both = hit[0] && hit[1];
                let seg = match (fused, both) {
                    (true, true) => sp.fused_pair,
                    (true, false) => sp.fused_pair.prefix(sp.fused_pair_one),
                    (false, true) => p.pair,
                    (false, false) => p.pair.prefix(p.pair_one),
                };
                Run {
                    seg,
                    base: [img.node_addr(left), img.node_addr(left + 1)],
                    local: 0,
                }
            }
            Step::Push { .. } => Run::new(sp.bit_push),
            Step::Pop { .. } => Run::new(sp.bit_pop),
            Step::Parent { node, .. } => Run::at(sp.parent, img.node_addr(node)),
            Step::SiblingRetest { node, .. } => {
                let seg = if fused { sp.fused_sibling } else { sp.sibling };
                Run::at(seg, img.node_addr(node))
            }
            Step::Triangle { slot, exit, .. } => {
                let seg = if fused {
                    self.facts.triangle_tests += 1;
                    sp.fused_tri.prefix(sp.fused_tri_exit[exit as usize])
                } else {
                    sp.plucker.prefix(sp.plucker_exit[exit as usize])
                };
                self.push_run(tp, Run::at(seg, img.triangle_addr(slot)));
                self.push_run(tp, Run::new(p.tri_tail));
                return;
            }
            Step::Done(_) | Step::Treelet { .. } | Step::Restart => return,
        };
        self.push_run(tp, run);
    }

    /// Advance TP `tp`'s ray by one step: queue its block, and when the ray leaves the
    /// treelet, its push and the next pop; when it finishes, its shading.
    fn ray_step(
        &mut self,
        tp: usize,
        stats: &mut FrameStats,
        rays: &mut u64,
        done: &mut Option<PixelDone>,
    ) -> Result<(), TimedError> {
        let id = self.tps[tp].path.expect("a ray's path");
        let tracer = self.frame.tracer;
        // The state is stepped where it lies (moving it out and back copied the whole
        // traversal state, the largest variant's stack included, every step).
        let step = {
            let w = &mut self.tps[tp];
            let ts = w.trav.as_mut().expect("a ray in flight");
            tracer.step_bit_stack(ts, &mut w.counters)
        };
        self.step_runs(tp, &step);
        let s = self.tps[tp].trav.as_ref().expect("a ray in flight");
        let finished = s.is_done();
        let b = self.tps[tp].treelet;
        let to = match step {
            Step::Done(h) => {
                let w = &mut self.tps[tp];
                w.trav = None;
                let counters = w.counters;
                let p = live(&mut self.paths, id);
                let body = p.body.as_mut().expect("a live path has a body");
                let result = TraceResult::from_slot_hit(tracer, h);
                stats
                    .kind_mut(body.job.id.kind)
                    .record(&counters, result.hit.is_hit());
                *rays += 1;
                p.nodes = p.nodes.saturating_add(counters.nodes_visited);
                let job = body.job;
                let r = self.frame.integ.resume(&mut body.state, &job, &result);
                self.push_run(tp, Run::new(self.sp.path_read));
                return self.then(tp, id, r, done);
            }
            Step::Treelet { to, .. } => Some((to, 0)),
            Step::Node { node, leaf: true } => {
                let n = &tracer.bvh().nodes[node as usize];
                (n.count > 0).then(|| (self.treelets.triangle_treelet[n.index as usize], 1))
            }
            Step::Triangle { slot, .. } if !finished && self.last_of_leaf[slot as usize] => {
                let leaf = self.leaf_of_slot[slot as usize];
                Some((self.treelets.node_treelet[leaf as usize], 2))
            }
            _ => None,
        };
        if let Some((to, cause)) = to
            && to != b
        {
            match cause {
                0 => self.facts.pushes_crossing += 1,
                1 => self.facts.pushes_to_triangles += 1,
                _ => self.facts.pushes_from_triangles += 1,
            }
            live(&mut self.paths, id).counters = self.tps[tp].counters;
            let rec = s
                .to_record(id, self.tps[tp].kind)
                .map_err(FlowError::from)?;
            self.tps[tp].trav = None;
            self.push_run(tp, Run::new(self.sp.push));
            self.push_run(tp, Run::new(self.sp.pop));
            let w = &mut self.tps[tp];
            w.outgoing = Some((to, rec));
            w.phase = Phase::Pop;
            return Ok(());
        }
        Ok(())
    }

    fn advance(
        &mut self,
        tp: usize,
        stats: &mut FrameStats,
        rays: &mut u64,
        done: &mut Option<PixelDone>,
    ) -> Result<Option<Run>, TimedError> {
        loop {
            let w = &mut self.tps[tp];
            if w.qpos < w.qlen {
                let r = w.queue[w.qpos as usize];
                w.qpos += 1;
                return Ok(Some(r));
            }
            w.qpos = 0;
            w.qlen = 0;
            match w.phase {
                Phase::Halted => return Ok(None),
                Phase::Fill => {
                    let v = match self.cfg.fill {
                        Fill::Counter => w.counter.take().expect("the counter has answered"),
                        Fill::Static => {
                            let v = w.fill;
                            w.fill = v.saturating_add(self.fill_stride);
                            v
                        }
                    };
                    if v < self.n_paths {
                        self.begin(tp, v, v, done)?;
                    } else {
                        w.phase = Phase::Pop;
                        self.push_run(tp, Run::new(self.sp.pop));
                    }
                }
                Phase::Restart => {
                    let v = w.counter.take().expect("the counter has answered");
                    let id = w.path.take().expect("a path");
                    if (v as usize) < self.frame.pixels.len() {
                        w.phase = Phase::Pop;
                        self.begin(tp, id, v, done)?;
                    } else {
                        self.paths[id as usize] = Path::free();
                        w.phase = Phase::Pop;
                        self.push_run(tp, Run::new(self.sp.pop));
                    }
                }
                Phase::Pop => {
                    if w.halt {
                        w.phase = Phase::Halted;
                        return Ok(None);
                    }
                    let rec = w.popped.take().expect("the pop has answered");
                    let (state, id, kind) = State::from_record(&rec).map_err(FlowError::from)?;
                    w.path = Some(id);
                    w.trav = Some(state);
                    w.kind = kind;
                    w.counters = live(&mut self.paths, id).counters;
                    w.phase = Phase::Ray;
                    // A node treelet's box tests need the inverse direction, which the record
                    // does not hold (recomputed on load, `bitstack` docs).
                    if self.treelets.treelets[w.treelet as usize].kind == TreeletKind::Node {
                        let p = &self.sp.program;
                        self.push_run(tp, Run::new(p.ray_setup));
                        let d = state.direction();
                        for v in [d.x, d.y, d.z] {
                            if !(1.0 / v).is_finite() {
                                self.push_run(tp, Run::new(p.inv_fixup));
                            }
                        }
                    }
                }
                Phase::Ray => self.ray_step(tp, stats, rays, done)?,
            }
        }
    }

    /// Whether bank `bank` has a port left at cycle `t`.
    fn port_free(&self, bank: u32, t: u64) -> bool {
        let b = self.banks[bank as usize];
        b.0 != t || b.1 < self.cfg.stream.ports_per_bank
    }

    fn bank_free(&mut self, bank: u32, t: u64, op: usize) -> bool {
        let b = &mut self.banks[bank as usize];
        if b.0 != t {
            *b = (t, 0);
        }
        if b.1 >= self.cfg.stream.ports_per_bank {
            self.facts.bank_conflicts += 1;
            self.facts.bank_conflicts_by_op[op] += 1;
            return false;
        }
        b.1 += 1;
        true
    }

    fn pop(
        &mut self,
        tp: usize,
        tm: usize,
        t: u64,
        caps: &mut [u8; UNIT_CLASSES],
    ) -> Result<SourceAccess, TimedError> {
        let poll = SourceAccess::Busy {
            retry_at: t + self.cfg.poll_cycles as u64,
            stall: Stall::Stream,
        };
        if std::mem::take(&mut self.tps[tp].held) {
            self.tms[tm].holding -= 1;
        }
        if let Some(b) = self.tms[tm].treelet
            && self.stream.count(b) == 0
        {
            if self.cfg.switch == crate::config::Switch::Drained && self.tms[tm].holding > 0 {
                self.facts.hold_waits += 1;
                return Ok(poll);
            }
            self.ready.release(b);
            self.tms[tm].treelet = None;
        }
        if self.tms[tm].treelet.is_none() {
            let Some(b) = self.ready.pick(self.cfg.policy, &mut self.rr_cursor) else {
                if self.fill_next >= self.n_paths && self.live_paths == 0 {
                    // Every path has retired: the frame is done.
                    self.tps[tp].halt = true;
                    return Ok(SourceAccess::Done { ready: t + 1 });
                }
                self.facts.empty_polls += 1;
                return Ok(poll);
            };
            let kind = self.treelets.treelets[b as usize].kind;
            let m = &mut self.tms[tm];
            if self.cfg.fused && kind != m.mode {
                if m.holding > 0 {
                    self.facts.drain_waits += 1;
                    return Ok(poll);
                }
                m.mode = kind;
                m.configured_at = t + self.cfg.reconfigure_cycles as u64;
                m.tri_free = [m.configured_at; 2];
                *caps = if kind == TreeletKind::Node {
                    self.caps_node
                } else {
                    self.caps_tri
                };
                self.facts.reconfigurations += 1;
            }
            m.treelet = Some(b);
            self.ready.claim(b);
            self.facts.treelet_switches += 1;
            let holders = self.ready.holders(b);
            self.facts.holders_at_pick += holders as u64;
            self.facts.max_holders = self.facts.max_holders.max(holders);
            self.interval_max_holders = self.interval_max_holders.max(holders);
        }
        let b = self.tms[tm].treelet.expect("a treelet");
        let bank = self.stream.pop_bank(b).expect("the buffer holds a ray");
        if !self.bank_free(bank, t, 0) {
            return Ok(SourceAccess::Busy {
                retry_at: t + 1,
                stall: Stall::Stream,
            });
        }
        let rec = self
            .stream
            .pop(b)
            .map_err(FlowError::from)?
            .expect("the buffer holds a ray");
        self.ready.update(b, self.stream.count(b));
        self.tms[tm].holding += 1;
        let w = &mut self.tps[tp];
        w.held = true;
        w.popped = Some(rec);
        w.treelet = b;
        let at = t.max(self.tms[tm].configured_at);
        Ok(SourceAccess::Done {
            ready: at + self.cfg.stream.latency as u64,
        })
    }
}

impl Source for StrataSource<'_> {
    /// The lines every `next` and stream access of TP `tp` reads: the front of its [`Tp`]
    /// (queue position, phase, ray, counters and the queue's first blocks).
    #[inline(always)]
    fn prefetch(&self, tp: usize) {
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
            let w = self.tps.as_ptr().wrapping_add(tp) as *const i8;
            for l in 0..TP_HOT_LINES {
                // SAFETY: prefetching is a hint and never faults, even for a bad address.
                unsafe { _mm_prefetch::<_MM_HINT_T0>(w.wrapping_add(64 * l)) };
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        let _ = tp;
    }

    fn first_run(&self) -> Run {
        self.fill_run()
    }

    fn pixel_count(&self) -> usize {
        self.frame.pixels.len()
    }

    fn next(
        &mut self,
        tp: usize,
        stats: &mut FrameStats,
        rays: &mut u64,
        done: &mut Option<PixelDone>,
    ) -> Option<Run> {
        self.advance(tp, stats, rays, done).unwrap_or_else(|e| {
            panic!("STRaTA work of TP {tp}: {e} (a model bug: the run was validated)")
        })
    }

    fn atomic(&mut self, tp: usize) -> Option<u32> {
        // Paths start and retire here, at the counter's access (in global order in both
        // engines), not when the TP's functional state advances (which the fast engine does
        // ahead of time).
        let w = &mut self.tps[tp];
        let v = if w.phase == Phase::Fill {
            let v = self.fill_next;
            self.fill_next = self.fill_next.saturating_add(1);
            if v < self.n_paths {
                self.live_paths += 1;
            }
            v
        } else {
            let v = self.pixel_next;
            self.pixel_next = self.pixel_next.saturating_add(1);
            if v as usize >= self.frame.pixels.len() {
                self.live_paths -= 1;
            }
            v
        };
        w.counter = Some(v);
        // A path's pixel runs on many TPs: no per-pixel cycle map.
        None
    }

    fn access(
        &mut self,
        tp: usize,
        tm: usize,
        class: Class,
        mem: Mem,
        t: u64,
        caps: &mut [u8; UNIT_CLASSES],
    ) -> Result<SourceAccess, ChipError> {
        let busy = SourceAccess::Busy {
            retry_at: t + 1,
            stall: Stall::Stream,
        };
        let lat = self.cfg.stream.latency as u64;
        let out = match (class, mem) {
            (Class::TriTest, _) => {
                let m = &mut self.tms[tm];
                let n = self.cfg.triangle_pipelines as usize;
                match (0..n).find(|&k| m.tri_free[k] <= t) {
                    Some(k) => {
                        m.tri_free[k] = t + pipeline::TRIANGLE.initiation_interval as u64;
                        SourceAccess::Done {
                            ready: t + pipeline::TRIANGLE.latency as u64,
                        }
                    }
                    None => {
                        self.facts.pipeline_waits += 1;
                        let at = m.tri_free[..n].iter().copied().min().expect("an instance");
                        SourceAccess::Busy {
                            retry_at: at,
                            stall: Stall::Stream,
                        }
                    }
                }
            }
            (_, Mem::Stream(StreamOp::Pop)) => self.pop(tp, tm, t, caps).map_err(|e| {
                ChipError::Config(rtsim_config::ConfigError::key("arch.strata", e.to_string()))
            })?,
            (_, Mem::Stream(StreamOp::Push)) => {
                // Any bank with a free port and a free slot, trying the TP's own first.
                let n = self.cfg.stream.banks;
                let first = tp as u32 % n;
                let bank = (0..n)
                    .map(|k| (first + k) % n)
                    .find(|&k| self.stream.has_free(k) && self.port_free(k, t));
                let Some(bank) = bank else {
                    self.facts.bank_conflicts += 1;
                    self.facts.bank_conflicts_by_op[1] += 1;
                    return Ok(busy);
                };
                assert!(self.bank_free(bank, t, 1), "the port was free");
                let (b, rec) = self.tps[tp].outgoing.take().expect("a ray to push");
                self.stream
                    .push_in(b, &rec, bank)
                    .expect("one ray per path slot: the stream memory never overflows");
                self.ready.update(b, self.stream.count(b));
                SourceAccess::Done { ready: t + 1 }
            }
            (_, Mem::Stream(op @ (StreamOp::PathRead | StreamOp::PathWrite))) => {
                let id = self.tps[tp].path.expect("a path");
                let bank = self.stream.path_bank(id);
                if !self.bank_free(bank, t, 2) {
                    return Ok(busy);
                }
                self.stream.path_access(id, op == StreamOp::PathWrite);
                SourceAccess::Done { ready: t + lat }
            }
            _ => unreachable!("{} is not a STRaTA access", class.mnemonic()),
        };
        Ok(out)
    }

    fn still_refused(
        &self,
        _tp: usize,
        tm: usize,
        _class: Class,
        mem: Mem,
        t: u64,
    ) -> Option<Stall> {
        // A pop is refused, changing nothing but counters, while its TM's buffer holds rays
        // and the bank of the buffer's head has no port left this cycle (`pop`). Only an
        // access of the same TM can change that within the cycle's TM-ordered offers: a push
        // moves the head, a pop empties the buffer or moves the head, a switch changes the
        // buffer. (The TP's `held` was released at its first refusal.)
        if mem != Mem::Stream(StreamOp::Pop) {
            return None;
        }
        let b = self.tms[tm].treelet?;
        let bank = self.stream.pop_bank(b)?;
        (!self.port_free(bank, t)).then_some(Stall::Stream)
    }

    fn unit_wait(&self, tm: usize, class: Class, _t: u64) -> Option<(u32, u64, Stall)> {
        // A triangle test is refused only while both pipelines are busy (`access`), and
        // a pipeline frees only with time.
        if class != Class::TriTest {
            return None;
        }
        let n = self.cfg.triangle_pipelines as usize;
        let free_at = self.tms[tm].tri_free[..n].iter().copied().min()?;
        Some((n as u32, free_at, Stall::Stream))
    }

    fn timeline_columns(&self) -> &'static [Column] {
        &TIMELINE
    }

    fn timeline_values(&mut self, out: &mut Vec<u64>) {
        let st = self.stream.stats();
        out.extend_from_slice(&[
            st.pops,
            st.pushes,
            st.path_reads + st.path_writes,
            self.facts.treelet_switches,
            self.facts.holders_at_pick,
            self.facts.reconfigurations,
            self.stream.len() as u64,
            self.stream.count(ROOT) as u64,
            self.ready.holders(ROOT) as u64,
            self.ready.nonempty() as u64,
            self.live_paths as u64,
            std::mem::take(&mut self.interval_max_holders) as u64,
        ]);
    }

    fn refused_again(&mut self, _tp: usize, class: Class, _mem: Mem, n: u64) {
        if class == Class::TriTest {
            // Triangle pipelines busy (`unit_wait`).
            self.facts.pipeline_waits += n;
        } else {
            // A pop whose bank has no port left (`still_refused`).
            self.facts.bank_conflicts += n;
            self.facts.bank_conflicts_by_op[0] += n;
        }
    }

    fn extra_energy(&self, cfg: &TraxConfig, issue: &IssueStats) -> (f64, f64) {
        let f = self.facts();
        let u = &cfg.units;
        let nj = |m: &rtsim_trace::ops::OpMix| {
            m.fadd as f64 * u.fp_add.energy_nj
                + m.fmul as f64 * u.fp_mul.energy_nj
                + m.fminmax as f64 * u.fp_minmax.energy_nj
                + m.fcmp as f64 * u.fp_cmp.energy_nj
        };
        let boxes = issue.count(Class::BoxTest) as f64 * nj(&pipeline::root_box().pipeline_ops);
        let tris = issue.count(Class::TriTest) as f64 * nj(&pipeline::triangle(0).pipeline_ops);
        (f.stream_energy_j, (boxes + tris) * 1e-9)
    }
}

/// A simulated STRaTA frame.
#[derive(Debug)]
pub struct StrataOutput {
    pub out: Output,
    pub strata: StrataFacts,
}

/// Simulate a frame on the STRaTA chip: the TRaX chip `trax` with `cfg`'s changes, `dram`
/// behind it. With streaming off, the baseline chip runs (`rtsim_trax::simulate`).
pub fn simulate(
    trax: &TraxConfig,
    cfg: &StrataConfig,
    dram: &rtsim_dram::DramConfig,
    frame: Frame<'_>,
    opts: &Options,
    progress: &mut dyn FnMut(Progress),
) -> Result<StrataOutput, TimedError> {
    use rtsim_config::Validate;
    cfg.validate()?;
    let chip_cfg = cfg.chip(trax);
    if !cfg.streaming {
        let out = rtsim_trax::simulate(&chip_cfg, dram, frame, opts, progress)?;
        return Ok(StrataOutput {
            out,
            strata: StrataFacts::default(),
        });
    }
    let sp = crate::program::build();
    let src = StrataSource::new(frame, &sp, cfg, &chip_cfg)?;
    let caps = src.initial_caps();
    let mut chip = Chip::new(
        &chip_cfg,
        src,
        &sp.program,
        frame.image_pixels,
        dram,
        opts.seed,
    )?;
    chip.set_caps(caps);
    chip.set_latency(Class::BoxTest, pipeline::BOX.latency as u64);
    let (out, src) = rtsim_trax::run_chip(chip, &sp.program, opts, progress)?;
    let strata = src.facts();
    let mut facts = strata.clone();
    facts.box_tests = out.report.issue.count(Class::BoxTest);
    facts.triangle_tests = out.report.issue.count(Class::TriTest);
    facts.pipeline_energy_j = out
        .report
        .energy
        .units_by_class_j
        .get("fused_pipelines")
        .copied()
        .unwrap_or(0.0);
    Ok(StrataOutput { out, strata: facts })
}
