//! The ray flow of STRaTA (paper §3.1), functional: which ray goes to which treelet buffer,
//! which TM drains which buffer, and what that costs in stream accesses, treelet switches and
//! L1 footprint — without timing.
//!
//! The model drives the substrate's functional code: the workload's pixel state machine
//! (`Integrator::begin` / `resume`) and the `bit-stack` stepped traversal (`Tracer::step`).
//! Every ray parked in the stream memory is stored as its 48-byte record
//! (`bitstack::State::to_record`) and read back from it, so nothing a ray carries between
//! treelets hides outside the record; the image and the per-ray counters are therefore the
//! functional tracer's (tests check every pixel).
//!
//! # Rules
//!
//! - **Initial fill.** Before rendering, one path per free slot (at most one per pixel) is
//!   started and its first ray pushed onto the root treelet's buffer (treelet 0).
//! - **Rounds.** The chip works in rounds. In each round every TM, in index order, keeps its
//!   treelet while its buffer holds rays; otherwise it releases it and picks a buffer by the
//!   policy (`most-rays`: the most unclaimed rays, i.e. the count minus `tps_per_tm` for
//!   every TM already on it, ties to the lowest id; `round-robin`: the next non-empty id after
//!   the last pick), among buffers held by fewer than `tms_per_buffer` TMs (0: any number).
//!   Then each of its TPs pops one ray (fewer if the buffer runs dry: those TPs idle) and
//!   runs it until it leaves the treelet. A TM switches treelets only when its buffer is
//!   empty at the start of a round.
//! - **Leaving a treelet.** A ray leaves when its traversal crosses into another node treelet
//!   (`Step::Treelet`, down or up), when it reaches a leaf (it goes to the buffer of the
//!   triangle treelet holding the leaf's triangles: node and triangle treelets are separate,
//!   §3.1), and after the leaf's last triangle (back to the leaf's node treelet, whose
//!   parent pointer it reads next). It is pushed onto that buffer and the TP is done for the
//!   round.
//! - **Finishing.** A ray whose traversal ends is shaded on the spot; its successor (shadow
//!   ray, bounce ray, or the first ray of the next pixel) is pushed onto the root buffer one
//!   for one (§3.1: "secondary rays replace the ray that spawned them to avoid overflowing
//!   on-chip ray buffers"). A path with no next pixel retires, freeing its slot for good.
//! - **Path state.** What a path carries between its rays besides the ray record (pixel,
//!   sample, depth, throughput, radiance, pending light, random state) lives in the memory
//!   image's `path_state` region, one 64-byte record per path slot: read once when a ray
//!   finishes (to shade it) and written once when the successor is issued. The model counts
//!   these accesses; the host keeps the values.
//! - **Caches and fetches.** With `FlowChip::caches`, every data access (node and triangle
//!   records, the shading's triangle and material reads, path state, framebuffer) goes
//!   through the L1 of the TM making it and the L2, untimed. Instruction fetches are counted
//!   one per operation (`rtsim_trace::ops`), with and without the fused pipelines
//!   ([`crate::pipeline`]).
//!
//! Every step a TM runs is checked against its buffer: node steps only on node treelets,
//! triangle tests only on triangle treelets; and every record it reads is classified as inside
//! or outside the treelet (the pair test of a frontier pair reads the next treelet's pair from
//! the parent's treelet: see `docs/STRATA.md`).

use crate::config::{Policy, StrataConfig};
use crate::pipeline;
use crate::stream::{StreamError, StreamLayout, StreamMemory, StreamStats};
use rtsim_bvh::{TreeletKind, Treelets};
use rtsim_cache::{CacheConfig, FunctionalHierarchy};
use rtsim_core::MemOp;
use rtsim_core::Vec3;
use rtsim_trace::Traversal;
use rtsim_trace::ops;
use rtsim_trace::step::bitstack::{RecordError, State};
use rtsim_trace::step::{Access, Step};
use rtsim_trace::{
    FrameStats, Next, PathState, PixelResult, RayCounters, RayJob, Resumed, TraceResult,
    TraversalState,
};
use serde::Serialize;
use std::cmp::Reverse;
use std::collections::BTreeSet;

/// What to render: the TRaX chip's frame description (the pixels are started in their
/// order).
pub use rtsim_trax::Frame;

/// The chip the rays flow through.
#[derive(Clone, Debug, PartialEq)]
pub struct FlowChip {
    pub tms: u32,
    pub tps_per_tm: u32,
    /// L1 line size, for footprints.
    pub line_bytes: u32,
    /// The cache tree the traversal's record reads go through, untimed (`None`: not
    /// modelled): one L1 per TM, in TM order, and the L2s behind them.
    pub caches: Option<CacheConfig>,
}

impl FlowChip {
    /// `tms` × `tps_per_tm` with 64-byte lines and no caches.
    pub fn new(tms: u32, tps_per_tm: u32) -> FlowChip {
        FlowChip {
            tms,
            tps_per_tm,
            line_bytes: 64,
            caches: None,
        }
    }

    /// The TRaX chip `chip` with STRaTA's changes (`StrataConfig::chip`: the smaller L2),
    /// its caches modelled; `seed` seeds random replacement, if any.
    pub fn of(chip: &rtsim_trax::TraxConfig, strata: &StrataConfig, seed: u64) -> FlowChip {
        let c = strata.chip(chip);
        FlowChip {
            tms: c.tms,
            tps_per_tm: c.tps_per_tm,
            line_bytes: c.l1.line_bytes,
            caches: Some(c.cache_config(seed)),
        }
    }
}

/// Why the flow could not run.
#[derive(Debug, thiserror::Error)]
pub enum FlowError {
    #[error(
        "the memory image has no treelets: STRaTA needs memory.layout = \"treelets\" \
         (STRaTA §3.1)"
    )]
    NoTreelets,
    #[error("the tracer must run trace.traversal = \"bit-stack\" (STRaTA §3.2)")]
    NotBitStack,
    #[error(transparent)]
    Stream(#[from] StreamError),
    #[error("a ray cannot be stored as a 48-byte record: {0}")]
    Record(#[from] RecordError),
    #[error("the chip has no TPs (arch.trax.tms or arch.trax.tps_per_tm is 0)")]
    NoTps,
    #[error(transparent)]
    Config(#[from] rtsim_config::ConfigError),
    #[error("no TM could take any of the {rays} rays in the stream memory (a scheduling bug)")]
    Stalled { rays: u32 },
}

/// Counts of the flow (numerators and denominators kept; ratios when reporting).
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct FlowStats {
    /// How the stream memory was divided.
    pub layout: Option<StreamLayout>,
    pub stream: StreamStats,
    /// nJ per stream access used for [`FlowStats::stream_energy_j`].
    pub stream_access_nj: f64,
    /// Paths started by the initial fill.
    pub initial_paths: u64,
    /// Rounds until the last ray finished.
    pub rounds: u64,
    /// TM-rounds spent working on a treelet, and without one (no buffer to take).
    pub tm_rounds_active: u64,
    pub tm_rounds_idle: u64,
    /// TP-rounds without a ray inside active TM-rounds (the buffer ran dry).
    pub tp_rounds_idle: u64,
    /// Buffer picks (a TM starting on a treelet), and those that changed the TM between node
    /// and triangle work (a pipeline reconfiguration once fused pipelines exist).
    pub treelet_switches: u64,
    pub kind_switches: u64,
    /// Tenures (a TM's stay on one treelet) ended, and the rays they ran.
    pub tenures: u64,
    pub tenure_rays: u64,
    /// Distinct L1 lines of its own treelet a tenure read (the compulsory misses of an L1 that
    /// holds the treelet): their sum over tenures, and the largest.
    pub tenure_lines: u64,
    pub tenure_lines_max: u64,
    /// Distinct lines outside its treelet a tenure read (the child pairs at the treelet's
    /// frontier, which belong to the next treelet): sum and largest.
    pub tenure_foreign_lines: u64,
    pub tenure_foreign_lines_max: u64,
    /// Record reads of a tenure outside its treelet (by kind of step).
    pub foreign_pair_reads: u64,
    pub foreign_other_reads: u64,
    /// Steps run on the wrong kind of treelet (node work on a triangle treelet or the
    /// reverse): the separation of §3.1 makes this 0.
    pub wrong_kind_steps: u64,
    /// Pushes by cause: a path's ray entering the root buffer (first ray or successor), a
    /// node-treelet crossing, a leaf sending its ray to its triangle treelet, the ray coming
    /// back from it.
    pub pushes_root: u64,
    pub pushes_crossing: u64,
    pub pushes_to_triangles: u64,
    pub pushes_from_triangles: u64,
    /// Traversal steps run.
    pub steps: u64,
    /// Rays finished.
    pub rays: u64,
    pub pixels_done: u64,
    /// Path-state record reads (shading a finished ray) and writes (issuing its successor).
    pub path_state_reads: u64,
    pub path_state_writes: u64,
    pub framebuffer_writes: u64,
    /// With caches: every data access, one per line a record touches, through the L1 of
    /// the TM making it: L1 reads and read misses (summed over TMs; writes go around the L1
    /// to the L2), L2 accesses (read misses and writes) and misses, DRAM line reads and
    /// write-backs. The traversal's node and triangle reads, and the shading's
    /// line accesses: hit triangle and material reads, path-state reads (a ray finished)
    /// and writes (its successor issued), framebuffer writes.
    pub l1_accesses: u64,
    pub l1_misses: u64,
    pub l2_accesses: u64,
    pub l2_misses: u64,
    pub dram_line_reads: u64,
    pub dram_line_writes: u64,
    pub shading_line_reads: u64,
    pub shading_line_writes: u64,
    /// Instruction fetches, one instruction per operation (`rtsim_trace::ops`): the traversal
    /// steps as ordinary instructions, and with the fused pipelines (`pipeline::fused_fetches`);
    /// one intrinsic per stream push or pop (assumed); the shading transitions (the same with
    /// or without pipelines, §3.3: "the final stage shades the ray without reconfiguring").
    pub fetches_traversal_scalar: u64,
    pub fetches_traversal_fused: u64,
    pub fetches_stream: u64,
    pub fetches_shading: u64,
}

impl FlowStats {
    /// Stream-memory energy in joules (accesses × energy per access).
    pub fn stream_energy_j(&self) -> f64 {
        self.stream.accesses() as f64 * self.stream_access_nj * 1e-9
    }
}

/// A rendered frame and its flow.
#[derive(Debug)]
pub struct FlowOutput {
    /// One per image pixel (black outside the rendered pixels).
    pub pixels: Vec<PixelResult>,
    /// The rays traced, by kind, with their counters (the `bit-stack` variant's).
    pub rays: FrameStats,
    pub stats: FlowStats,
}

/// A path in flight: its workload state and the job of its ray (both rebuilt in hardware
/// from the path-state record and the ray record; the host keeps them whole), the ray's
/// counters (simulator bookkeeping, not hardware state) and the pixel's node visits.
#[derive(Clone, Debug)]
struct Path {
    state: PathState,
    job: RayJob,
    counters: RayCounters,
    nodes: u32,
}

/// The buffers a TM may take, ordered for both policies. It keeps each buffer's ray count
/// and the TMs holding it (`holders`), so that a pick is one lookup rather than a scan.
#[derive(Debug, Default)]
pub(crate) struct Ready {
    /// TPs per TM: a TM on a buffer claims that many of its rays.
    tps: u32,
    /// TMs a buffer may have at once (0: any number).
    limit: u32,
    counts: Vec<u32>,
    holders: Vec<u32>,
    /// Keep `by_rank` (`most-rays` and `rays-per-tm`; `round-robin` needs only `by_id`).
    ranked: bool,
    /// Rank buffers by rays per TM (`rays-per-tm`) instead of unclaimed rays (`most-rays`).
    per_tm: bool,
    /// Buffers a TM may take under `most-rays` or `rays-per-tm`, by (rank, lowest id first).
    by_rank: BTreeSet<(u64, Reverse<u32>)>,
    /// Non-empty buffers, by id (`round-robin`).
    by_id: BTreeSet<u32>,
}

impl Ready {
    /// `buffers` empty buffers for TMs of `tps` TPs, at most `limit` TMs per buffer (0: any),
    /// ranked for `policy`.
    pub(crate) fn new(buffers: u32, tps: u32, limit: u32, policy: Policy) -> Self {
        Ready {
            tps,
            limit,
            counts: vec![0; buffers as usize],
            holders: vec![0; buffers as usize],
            ranked: policy != Policy::RoundRobin,
            per_tm: policy == Policy::RaysPerTm,
            by_rank: BTreeSet::new(),
            by_id: BTreeSet::new(),
        }
    }

    fn free(&self, b: u32) -> bool {
        self.limit == 0 || self.holders[b as usize] < self.limit
    }

    /// Buffer `b`'s place in `by_rank`, if it has unclaimed rays (its rays minus `tps` for
    /// every TM already on it) and may be taken: ranked by those unclaimed rays, or under
    /// `rays-per-tm` by its rays per TM once the picking TM joins, `count / (holders + 1)`,
    /// in units of 2^-20 ray (exact for any two buffers whose shares differ by more).
    fn entry(&self, b: u32) -> Option<(u64, Reverse<u32>)> {
        let (count, holders) = (
            self.counts[b as usize] as u64,
            self.holders[b as usize] as u64,
        );
        let unclaimed = count.saturating_sub(holders * self.tps as u64);
        if unclaimed == 0 || !self.free(b) {
            return None;
        }
        let rank = if self.per_tm {
            (count << 20) / (holders + 1)
        } else {
            unclaimed
        };
        Some((rank, Reverse(b)))
    }

    /// Change buffer `b`'s count or holders by `f`, keeping the orders. Called on every
    /// push and pop, so the sets are touched only where an entry changes: a buffer's rank
    /// entry (most pops of a held buffer leave it fully claimed, out of `by_rank` before and
    /// after), and its place in `by_id` only when it fills or empties.
    fn change(&mut self, b: u32, f: impl FnOnce(&mut Self)) {
        let was = self.counts[b as usize] > 0;
        let before = if self.ranked { self.entry(b) } else { None };
        f(self);
        if self.ranked {
            let after = self.entry(b);
            if after != before {
                if let Some(e) = before {
                    self.by_rank.remove(&e);
                }
                if let Some(e) = after {
                    self.by_rank.insert(e);
                }
            }
        }
        match (was, self.counts[b as usize] > 0) {
            (false, true) => {
                self.by_id.insert(b);
            }
            (true, false) => {
                self.by_id.remove(&b);
            }
            _ => {}
        }
    }

    /// Buffer `b` now holds `count` rays.
    pub(crate) fn update(&mut self, b: u32, count: u32) {
        self.change(b, |r| r.counts[b as usize] = count);
    }

    /// A TM takes buffer `b`.
    pub(crate) fn claim(&mut self, b: u32) {
        self.change(b, |r| r.holders[b as usize] += 1);
    }

    /// TMs on buffer `b` now.
    pub(crate) fn holders(&self, b: u32) -> u32 {
        self.holders[b as usize]
    }

    /// Buffers holding rays now.
    pub(crate) fn nonempty(&self) -> usize {
        self.by_id.len()
    }

    /// A TM leaves buffer `b`.
    pub(crate) fn release(&mut self, b: u32) {
        self.change(b, |r| r.holders[b as usize] -= 1);
    }

    /// The buffer a TM takes under `policy`, among buffers held by fewer than `limit` TMs.
    /// `most-rays` ranks buffers by their unclaimed rays, `rays-per-tm` by their rays per TM
    /// with the picking one, both ties to the lowest id, and neither takes a fully claimed
    /// one (the ranking is fixed at [`Ready::new`]); `round-robin` takes the first non-empty
    /// one after `cursor` in id order, wrapping, and moves it.
    pub(crate) fn pick(&self, policy: Policy, cursor: &mut Option<u32>) -> Option<u32> {
        match policy {
            Policy::MostRays | Policy::RaysPerTm => {
                debug_assert!(self.ranked, "a round-robin `Ready` keeps no ranks");
                self.by_rank.last().map(|&(_, Reverse(b))| b)
            }
            Policy::RoundRobin => {
                let start = cursor.map_or(0, |c| c + 1);
                let b = self
                    .by_id
                    .range(start..)
                    .chain(self.by_id.range(..start))
                    .copied()
                    .find(|&b| self.free(b))?;
                *cursor = Some(b);
                Some(b)
            }
        }
    }
}

struct Flow<'a> {
    input: Frame<'a>,
    cfg: &'a StrataConfig,
    tms: usize,
    tps: u32,
    line_bytes: u32,
    treelets: &'a Treelets,
    /// Leaf node of every triangle slot, and whether the slot is its leaf's last.
    leaf_of_slot: Vec<u32>,
    last_of_leaf: Vec<bool>,
    stream: StreamMemory,
    ready: Ready,
    tm_treelet: Vec<Option<u32>>,
    tm_kind: Vec<Option<TreeletKind>>,
    rr_cursor: Option<u32>,
    paths: Vec<Option<Path>>,
    next_pixel: usize,
    out: Vec<PixelResult>,
    rays: FrameStats,
    stats: FlowStats,
    /// Lines read in each TM's current tenure, inside and outside its treelet.
    tenure_lines: Vec<Vec<u64>>,
    tenure_foreign: Vec<Vec<u64>>,
    tenure_rays: Vec<u64>,
    caches: Option<FunctionalHierarchy>,
}

/// Per triangle slot: its leaf, and whether it is the leaf's last (after which a ray returns
/// from the triangle treelet to the leaf's node treelet).
/// The job a path holds from its start until its first `Next::Trace` replaces it (nothing
/// reads it in between).
pub(crate) fn placeholder_job(pixel: u32) -> RayJob {
    RayJob {
        id: rtsim_trace::RayId {
            pixel,
            sample: 0,
            segment: 0,
            kind: rtsim_trace::RayKind::Primary,
        },
        ray: rtsim_core::Ray::new(Vec3::ZERO, Vec3::ONE, 0.0, 0.0),
        query: rtsim_trace::Query::Closest,
    }
}

pub(crate) fn leaf_maps(bvh: &rtsim_bvh::Bvh) -> (Vec<u32>, Vec<bool>) {
    let slots = bvh.prim_ids.len();
    let mut leaf_of_slot = vec![u32::MAX; slots];
    let mut last_of_leaf = vec![false; slots];
    for (i, n) in bvh.nodes.iter().enumerate() {
        if n.is_leaf() && n.count > 0 {
            for s in n.index..n.index + n.count {
                leaf_of_slot[s as usize] = i as u32;
            }
            last_of_leaf[(n.index + n.count - 1) as usize] = true;
        }
    }
    (leaf_of_slot, last_of_leaf)
}

/// Render `input` with STRaTA's ray flow on `chip` (see the module docs).
pub fn run(cfg: &StrataConfig, chip: &FlowChip, input: Frame<'_>) -> Result<FlowOutput, FlowError> {
    let treelets = input.image.treelets().ok_or(FlowError::NoTreelets)?;
    if input.tracer.traversal() != Traversal::BitStack {
        return Err(FlowError::NotBitStack);
    }
    if chip.tms == 0 || chip.tps_per_tm == 0 {
        return Err(FlowError::NoTps);
    }
    let (leaf_of_slot, last_of_leaf) = leaf_maps(input.tracer.bvh());
    let buffers = treelets.len() as u32;
    let stream = StreamMemory::new(&cfg.stream, buffers)?;
    let caches = match &chip.caches {
        Some(c) => Some(FunctionalHierarchy::new(c)?),
        None => None,
    };
    let (tms, line_bytes) = (chip.tms as usize, chip.line_bytes);
    let tps = chip.tps_per_tm;
    let mut f = Flow {
        input,
        cfg,
        treelets,
        leaf_of_slot,
        last_of_leaf,
        stream,
        ready: Ready::new(buffers, tps, cfg.tms_per_buffer, cfg.policy),
        tm_treelet: vec![None; tms],
        tm_kind: vec![None; tms],
        rr_cursor: None,
        paths: Vec::new(),
        next_pixel: 0,
        out: vec![PixelResult::default(); input.image_pixels],
        rays: FrameStats::default(),
        stats: FlowStats {
            stream_access_nj: cfg.stream.access_nj(),
            ..FlowStats::default()
        },
        tenure_lines: vec![Vec::new(); tms],
        tenure_foreign: vec![Vec::new(); tms],
        tenure_rays: vec![0; tms],
        caches,
        tms,
        tps,
        line_bytes,
    };
    f.stats.layout = Some(*f.stream.layout());
    f.fill()?;
    f.rounds()?;
    f.stats.stream = f.stream.stats().clone();
    f.stats.fetches_stream = f.stats.stream.accesses();
    if let Some(h) = &f.caches {
        let top = h.topology();
        for &l1 in top.leaves() {
            let st = h.stats(l1);
            f.stats.l1_accesses += st.reads;
            f.stats.l1_misses += st.read_misses;
        }
        for n in 0..h.caches().len() {
            if !top.leaves().contains(&n) {
                let st = h.stats(n);
                f.stats.l2_accesses += st.accesses();
                f.stats.l2_misses += st.misses();
            }
        }
        f.stats.dram_line_reads = h.memory.reads;
        f.stats.dram_line_writes = h.memory.writes;
    }
    Ok(FlowOutput {
        pixels: f.out,
        rays: f.rays,
        stats: f.stats,
    })
}

impl Flow<'_> {
    fn push(&mut self, b: u32, rec: &[u8; 48]) -> Result<(), FlowError> {
        self.stream.push(b, rec)?;
        self.ready.update(b, self.stream.count(b));
        Ok(())
    }

    fn pop(&mut self, b: u32) -> Result<Option<[u8; 48]>, FlowError> {
        let r = self.stream.pop(b)?;
        if r.is_some() {
            self.ready.update(b, self.stream.count(b));
        }
        Ok(r)
    }

    /// The initial fill: one path per slot, at most one per pixel.
    fn fill(&mut self) -> Result<(), FlowError> {
        let n = (self.stream.capacity() as usize).min(self.input.pixels.len());
        self.paths = vec![None; n];
        for id in 0..n {
            let Some(r) = self.begin_pixel(id) else {
                break;
            };
            self.stats.initial_paths += 1;
            // The fill is spread over the TMs, slot k on TM k mod tms (assumed).
            self.advance(id % self.tms, id, r)?;
        }
        Ok(())
    }

    /// Start the next pixel on path slot `id`.
    fn begin_pixel(&mut self, id: usize) -> Option<Resumed> {
        let &pixel = self.input.pixels.get(self.next_pixel)?;
        self.next_pixel += 1;
        let (state, r) = self.input.integ.begin(pixel);
        self.paths[id] = Some(Path {
            state,
            // Replaced by the first `Next::Trace` before anything reads it.
            job: placeholder_job(pixel),
            counters: RayCounters::default(),
            nodes: 0,
        });
        Some(r)
    }

    /// After a transition of path `id`: push its next ray onto the root buffer, or finish
    /// its pixel and start the next one (retiring the slot when none is left).
    fn advance(&mut self, tm: usize, id: usize, mut r: Resumed) -> Result<(), FlowError> {
        loop {
            self.stats.fetches_shading += ops::shading(&r.shading).total() as u64;
            let img = self.input.image;
            let lb = self.line_bytes;
            if let Some(slot) = r.shading.triangle {
                self.data(tm, img.triangle_lines(slot, lb), MemOp::Read);
            }
            if let Some(m) = r.shading.material {
                self.data(tm, img.material_lines(m, lb), MemOp::Read);
            }
            if let Some(px) = r.shading.framebuffer {
                self.stats.framebuffer_writes += 1;
                self.data(tm, img.framebuffer_lines(px, lb), MemOp::Write);
            }
            match r.next {
                Next::Trace(job) => {
                    let p = self.paths[id].as_mut().expect("a live path");
                    p.job = job;
                    p.counters = RayCounters::default();
                    let TraversalState::BitStack(s) = self.input.tracer.start(&job.ray, job.query)
                    else {
                        return Err(FlowError::NotBitStack);
                    };
                    let rec = s.to_record(id as u32, job.id.kind as u8)?;
                    self.stats.path_state_writes += 1;
                    let lines = self
                        .input
                        .image
                        .path_state_lines(id as u32, self.line_bytes);
                    self.data(tm, lines, MemOp::Write);
                    self.stats.pushes_root += 1;
                    return self.push(0, &rec);
                }
                Next::Done(color) => {
                    let p = self.paths[id].take().expect("a live path");
                    self.out[p.state.pixel() as usize] = PixelResult {
                        color,
                        nodes_visited: p.nodes,
                    };
                    self.stats.pixels_done += 1;
                    match self.begin_pixel(id) {
                        Some(next) => r = next,
                        None => return Ok(()),
                    }
                }
            }
        }
    }

    /// A finished ray: count it, shade it, issue its successor.
    fn finish(
        &mut self,
        tm: usize,
        id: usize,
        h: rtsim_trace::traverse::SlotHit,
    ) -> Result<(), FlowError> {
        let tracer = self.input.tracer;
        let p = self.paths[id].as_mut().expect("a live path");
        let result = TraceResult::from_slot_hit(tracer, h);
        self.rays
            .kind_mut(p.job.id.kind)
            .record(&p.counters, result.hit.is_hit());
        p.nodes = p.nodes.saturating_add(p.counters.nodes_visited);
        self.stats.rays += 1;
        self.stats.path_state_reads += 1;
        let job = p.job;
        let r = self.input.integ.resume(&mut p.state, &job, &result);
        let lines = self
            .input
            .image
            .path_state_lines(id as u32, self.line_bytes);
        self.data(tm, lines, MemOp::Read);
        self.advance(tm, id, r)
    }

    /// A shading or path-state access of TM `tm` through the caches, if modelled.
    fn data(&mut self, tm: usize, span: rtsim_bvh::LineSpan, op: MemOp) {
        if let Some(h) = &mut self.caches {
            for line in span.iter() {
                h.access(tm, line, op);
                match op {
                    MemOp::Read => self.stats.shading_line_reads += 1,
                    MemOp::Write => self.stats.shading_line_writes += 1,
                }
            }
        }
    }

    fn kind_of(&self, b: u32) -> TreeletKind {
        self.treelets.treelets[b as usize].kind
    }

    /// A buffer for a TM by the policy, if any may be taken (see [`Ready::pick`]).
    fn pick(&mut self) -> Option<u32> {
        self.ready.pick(self.cfg.policy, &mut self.rr_cursor)
    }

    fn end_tenure(&mut self, tm: usize) {
        let Some(b) = self.tm_treelet[tm].take() else {
            return;
        };
        self.ready.release(b);
        let distinct = |lines: &mut Vec<u64>| {
            lines.sort_unstable();
            lines.dedup();
            let n = lines.len() as u64;
            lines.clear();
            n
        };
        let own = distinct(&mut self.tenure_lines[tm]);
        let foreign = distinct(&mut self.tenure_foreign[tm]);
        self.stats.tenures += 1;
        self.stats.tenure_lines += own;
        self.stats.tenure_lines_max = self.stats.tenure_lines_max.max(own);
        self.stats.tenure_foreign_lines += foreign;
        self.stats.tenure_foreign_lines_max = self.stats.tenure_foreign_lines_max.max(foreign);
        self.stats.tenure_rays += std::mem::take(&mut self.tenure_rays[tm]);
    }

    /// Run rounds until every ray has finished.
    fn rounds(&mut self) -> Result<(), FlowError> {
        let tps = self.tps as usize;
        let mut batch = Vec::with_capacity(tps);
        while !self.stream.is_empty() {
            self.stats.rounds += 1;
            let pops = self.stream.stats().pops;
            for tm in 0..self.tms {
                if let Some(b) = self.tm_treelet[tm]
                    && self.stream.count(b) == 0
                {
                    self.end_tenure(tm);
                }
                if self.tm_treelet[tm].is_none() {
                    let Some(b) = self.pick() else {
                        self.stats.tm_rounds_idle += 1;
                        continue;
                    };
                    self.ready.claim(b);
                    self.tm_treelet[tm] = Some(b);
                    self.stats.treelet_switches += 1;
                    let kind = self.kind_of(b);
                    if self.tm_kind[tm].is_some_and(|k| k != kind) {
                        self.stats.kind_switches += 1;
                    }
                    self.tm_kind[tm] = Some(kind);
                }
                let b = self.tm_treelet[tm].expect("just picked");
                self.stats.tm_rounds_active += 1;
                // Every TP takes one ray, then they run (a successor pushed onto this
                // buffer waits for the next round).
                batch.clear();
                while batch.len() < tps {
                    match self.pop(b)? {
                        Some(r) => batch.push(r),
                        None => break,
                    }
                }
                self.stats.tp_rounds_idle += (tps - batch.len()) as u64;
                self.tenure_rays[tm] += batch.len() as u64;
                for rec in &batch {
                    self.run_ray(tm, b, rec)?;
                }
            }
            // The policies always leave some TM a ray to take (see `Ready::pick`); a round
            // without one would repeat forever.
            if self.stream.stats().pops == pops {
                return Err(FlowError::Stalled {
                    rays: self.stream.len(),
                });
            }
        }
        for tm in 0..self.tms {
            self.end_tenure(tm);
        }
        Ok(())
    }

    /// Note a step's record read for TM `tm` on treelet `b`.
    fn touch(&mut self, tm: usize, b: u32, step: &Step) {
        let access = step.access();
        let t = self.treelets;
        let owner = match access {
            Access::Node(n) | Access::NodePair(n) => t.node_treelet[n as usize],
            Access::Triangle(s) => t.triangle_treelet[s as usize],
            Access::None | Access::Stack { .. } => return,
        };
        let lines = if owner == b {
            &mut self.tenure_lines[tm]
        } else {
            if matches!(access, Access::NodePair(_)) {
                self.stats.foreign_pair_reads += 1;
            } else {
                self.stats.foreign_other_reads += 1;
            }
            &mut self.tenure_foreign[tm]
        };
        if let Some(span) = access.lines(self.input.image, self.line_bytes) {
            lines.extend(span.iter());
            if let Some(h) = &mut self.caches {
                for line in span.iter() {
                    h.access(tm, line, MemOp::Read);
                }
            }
        }
    }

    /// Run the ray `rec` on TM `tm`, which works on treelet `b`, until it leaves the treelet
    /// or finishes.
    fn run_ray(&mut self, tm: usize, b: u32, rec: &[u8; 48]) -> Result<(), FlowError> {
        let (state, id, kind) = State::from_record(rec)?;
        let id = id as usize;
        let tracer = self.input.tracer;
        let on_triangles = self.kind_of(b) == TreeletKind::Triangle;
        let mut ts = TraversalState::BitStack(state);
        loop {
            let step = {
                let p = self.paths[id].as_mut().expect("a ray's path is live");
                tracer.step(&mut ts, &mut p.counters)
            };
            self.stats.steps += 1;
            let scalar =
                ops::step(Traversal::BitStack, tracer.triangle_test(), &step).total() as u64;
            self.stats.fetches_traversal_scalar += scalar;
            self.stats.fetches_traversal_fused +=
                pipeline::fused_fetches(&step).map_or(scalar, u64::from);
            let is_tri = matches!(step, Step::Triangle { .. });
            if !matches!(step, Step::Done(_)) && is_tri != on_triangles {
                self.stats.wrong_kind_steps += 1;
            }
            self.touch(tm, b, &step);
            let TraversalState::BitStack(s) = ts else {
                return Err(FlowError::NotBitStack);
            };
            let to = match step {
                Step::Done(h) => return self.finish(tm, id, h),
                Step::Treelet { to, .. } => Some((to, Cause::Crossing)),
                Step::Node { node, leaf: true } => {
                    let n = &tracer.bvh().nodes[node as usize];
                    (n.count > 0).then(|| {
                        (
                            self.treelets.triangle_treelet[n.index as usize],
                            Cause::ToTriangles,
                        )
                    })
                }
                Step::Triangle { slot, .. } if !s.is_done() && self.last_of_leaf[slot as usize] => {
                    let leaf = self.leaf_of_slot[slot as usize];
                    Some((
                        self.treelets.node_treelet[leaf as usize],
                        Cause::FromTriangles,
                    ))
                }
                _ => None,
            };
            if let Some((to, cause)) = to
                && to != b
            {
                match cause {
                    Cause::Crossing => self.stats.pushes_crossing += 1,
                    Cause::ToTriangles => self.stats.pushes_to_triangles += 1,
                    Cause::FromTriangles => self.stats.pushes_from_triangles += 1,
                }
                let rec = s.to_record(id as u32, kind)?;
                return self.push(to, &rec);
            }
        }
    }
}

#[derive(Clone, Copy, Debug)]
enum Cause {
    Crossing,
    ToTriangles,
    FromTriangles,
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Buffers with the given counts and holders, for TMs of 8 TPs, at most `limit` TMs each.
    fn ready(counts: &[u32], holders: &[u32], limit: u32) -> Ready {
        ready_for(Policy::MostRays, counts, holders, limit)
    }

    fn ready_for(policy: Policy, counts: &[u32], holders: &[u32], limit: u32) -> Ready {
        let mut r = Ready::new(counts.len() as u32, 8, limit, policy);
        for (b, (&c, &h)) in counts.iter().zip(holders).enumerate() {
            r.update(b as u32, c);
            for _ in 0..h {
                r.claim(b as u32);
            }
        }
        r
    }

    #[test]
    fn most_rays_takes_the_most_unclaimed_rays() {
        let counts = [5, 0, 40, 40, 12];
        let mut cur = None;
        let mut pick = |holders: &[u32], limit| {
            ready(&counts, holders, limit).pick(Policy::MostRays, &mut cur)
        };
        // Fullest first, ties to the lowest id.
        assert_eq!(pick(&[0; 5], 0), Some(2));
        // Buffer 2 has a TM (8 rays claimed: 32 left), 3 none: 3 wins.
        assert_eq!(pick(&[0, 0, 1, 0, 0], 0), Some(3));
        // 2 and 3 with four TMs each (32 claimed, 8 left): 4's 12 win.
        assert_eq!(pick(&[0, 0, 4, 4, 0], 0), Some(4));
        // One TM per buffer: held buffers are out whatever their counts.
        assert_eq!(pick(&[0, 0, 1, 1, 1], 1), Some(0));
        // Fully claimed everywhere: nothing to take; empty buffers are never taken.
        assert_eq!(pick(&[1, 0, 5, 5, 2], 0), None);
    }

    #[test]
    fn rays_per_tm_discounts_a_buffer_by_its_holders() {
        let counts = [100, 0, 40, 30];
        let pick = |holders: &[u32]| {
            ready_for(Policy::RaysPerTm, &counts, holders, 0).pick(Policy::RaysPerTm, &mut None)
        };
        assert_eq!(pick(&[0; 4]), Some(0));
        // Two TMs on buffer 0: 100 / 3 = 33.3 rays each with a third, against 40 alone on
        // buffer 2 (`most-rays` would still take 0: 84 unclaimed).
        assert_eq!(pick(&[2, 0, 0, 0]), Some(2));
        assert_eq!(
            ready(&counts, &[2, 0, 0, 0], 0).pick(Policy::MostRays, &mut None),
            Some(0)
        );
        // One TM on 2 as well: 100 / 3 = 33.3 against 40 / 2 = 20 and 30: buffer 0 again.
        assert_eq!(pick(&[2, 0, 1, 0]), Some(0));
        // Eligibility is `most-rays`': a fully claimed buffer is out however it ranks.
        assert_eq!(pick(&[13, 0, 5, 4]), None);
    }

    #[test]
    fn round_robin_cycles_through_non_empty_buffers() {
        let counts = [3, 0, 1, 0, 7];
        let r = ready(&counts, &[0; 5], 0);
        let mut cur = None;
        let order: Vec<_> = (0..5)
            .map(|_| r.pick(Policy::RoundRobin, &mut cur))
            .collect();
        assert_eq!(order, [Some(0), Some(2), Some(4), Some(0), Some(2)]);
        // Held buffers are skipped under a limit.
        let mut cur = Some(0);
        let r = ready(&counts, &[0, 0, 1, 0, 0], 1);
        assert_eq!(r.pick(Policy::RoundRobin, &mut cur), Some(4));
        assert_eq!(cur, Some(4));
        let empty = Ready::new(5, 8, 0, Policy::RoundRobin);
        assert_eq!(empty.pick(Policy::RoundRobin, &mut cur), None);
    }

    #[test]
    fn the_orders_equal_a_rebuild_after_any_changes() {
        // `change` skips the sets where an entry stays the same: after any run of pushes,
        // pops, claims and releases they must hold what a scan of every buffer gives.
        for policy in [Policy::MostRays, Policy::RaysPerTm, Policy::RoundRobin] {
            for limit in [0, 2] {
                let mut r = Ready::new(6, 4, limit, policy);
                let mut x = 0x2545_f491_u32;
                for step in 0..5_000 {
                    x ^= x << 13;
                    x ^= x >> 17;
                    x ^= x << 5;
                    let b = x % 6;
                    let (count, holders) = (r.counts[b as usize], r.holders(b));
                    match (x >> 8) % 4 {
                        0 => r.update(b, count + 1 + (x >> 16) % 9),
                        1 => r.update(b, count.saturating_sub(1 + (x >> 16) % 9)),
                        2 if limit == 0 || holders < limit => r.claim(b),
                        3 if holders > 0 => r.release(b),
                        _ => {}
                    }
                    let by_id: Vec<u32> = (0..6).filter(|&b| r.counts[b as usize] > 0).collect();
                    assert_eq!(r.by_id.iter().copied().collect::<Vec<_>>(), by_id, "{step}");
                    let by_rank: BTreeSet<_> = if policy == Policy::RoundRobin {
                        BTreeSet::new()
                    } else {
                        (0..6).filter_map(|b| r.entry(b)).collect()
                    };
                    assert_eq!(r.by_rank, by_rank, "{policy:?}, limit {limit}, step {step}");
                }
            }
        }
    }

    #[test]
    fn updates_keep_both_orders() {
        let mut r = ready(&[2, 2], &[0, 0], 0);
        r.update(0, 0);
        r.update(1, 3);
        assert_eq!(r.by_id.iter().copied().collect::<Vec<_>>(), [1]);
        assert_eq!(
            r.by_rank.iter().copied().collect::<Vec<_>>(),
            [(3, Reverse(1))]
        );
        // A claim of all its rays takes a buffer out of `most-rays`' reach; a release puts
        // it back.
        r.update(1, 8);
        r.claim(1);
        assert_eq!(r.pick(Policy::MostRays, &mut None), None);
        r.release(1);
        assert_eq!(r.pick(Policy::MostRays, &mut None), Some(1));
    }
}
