//! [`Sgrt`]: the whole chip — the cores' T&I units and shaders over one memory path (the
//! caches of every core and one memory behind them) — and its two timing engines.
//!
//! # One cycle
//!
//! [`Sgrt::tick`] simulates T&I cycle `t` completely, in a fixed order: the memory path
//! advances to `t` and its finished line requests release their rays (or the shader's reads);
//! then core by core, the pipelines' finished rays leave for their next queue, every pipeline
//! takes its next ray (a lookup in its L1, or a ray back from the RAU), ray dispatch hands one
//! ray to a TRV, and the shader (or the feeder) acts. A tick at a cycle where nothing is due
//! changes nothing.
//!
//! # Two engines
//!
//! [`Engine::Reference`] ticks every cycle. [`Engine::Fast`] ticks only the cycles where
//! something can happen: the earliest of every unit's next event (a pipeline's head finishing,
//! a queue's head becoming visible, a pipeline's initiation interval ending, a refused lookup's
//! retry, the shader's kernel ending, the memory path's next event). Units that wait on another
//! unit (a free buffer entry, a line) have no event of their own: what frees them is an event of
//! the other unit, whose tick handles them in the same cycle. Tests run both and compare every
//! counter, cycle and pixel.

use crate::config::SgrtConfig;
use crate::core::{Core, Env, untag};
use crate::error::SgrtError;
use crate::srp::Shader;
use crate::stats::CoreStats;
use crate::work::{FrameWork, RayWork, Work};
use rtsim_bvh::MemoryImage;
use rtsim_cache::{CacheStats, Completion, Hierarchy, HierarchyStats, Node, Parent, Topology};
use rtsim_core::MemoryPort;
use rtsim_trace::query::RayReader;
use rtsim_trace::{FrameStats, Hit, Integrator, PixelResult, Query, RayKind, Tracer, TriangleTest};
use serde::Serialize;
use std::path::Path;

/// How time advances.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Engine {
    /// Jump from event to event (default).
    Fast,
    /// Every cycle, every unit: the check on `Fast`.
    Reference,
}

/// What the chip computes.
#[derive(Debug)]
pub enum Input<'a> {
    /// A frame: the pixels (row-major indices, in the order they are handed out) of the
    /// integrator's workload. `timed` says which ray kinds go through the T&I unit (indexed by
    /// `RayKind as usize`); the others are answered functionally at no cost.
    Frame {
        integ: &'a Integrator<'a>,
        pixels: Vec<u32>,
        timed: [bool; 6],
    },
    /// The rays of a `rays.bin`, asking `query`.
    Rays { path: &'a Path, query: Query },
}

impl Input<'_> {
    /// The ray kinds the T&I unit traces in the T&I-only mode of a workload: its own rays
    /// (Tables 4–5 measure primary, AO and diffuse rays separately; the camera rays that AO
    /// and diffuse rays start from are answered functionally), all of them for `specular` and
    /// `path`. With the shader on, every ray is timed.
    pub fn timed_kinds(kind: rtsim_trace::WorkloadKind, shader: bool) -> [bool; 6] {
        use rtsim_trace::WorkloadKind as W;
        let mut t = [shader; 6];
        let own = match kind {
            W::Primary => Some(RayKind::Primary),
            W::Ao => Some(RayKind::Ao),
            W::Diffuse => Some(RayKind::Diffuse),
            W::Specular | W::Path => None,
        };
        match own {
            Some(k) => t[k as usize] = true,
            None => t = [true; 6],
        }
        t
    }
}

/// Counters of a run.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SgrtStats {
    /// T&I cycles until the last item finished (or the cycle limit).
    pub cycles: u64,
    /// Whether every item finished (false: stopped at `sim.cycle_limit`).
    pub complete: bool,
    /// Items (pixels or rays of a file) finished, of `items`.
    pub items_done: u64,
    pub items: u64,
    /// Every core, summed.
    pub total: CoreStats,
    pub cores: Vec<CoreStats>,
    /// Every cache, summed over the cores: `trv-l1`, `l2`, `ist-l1`, `srp-dcache`.
    pub caches: Vec<(String, CacheStats)>,
}

/// What a finished run hands back.
#[derive(Debug)]
pub struct SgrtResult<M> {
    pub stats: SgrtStats,
    /// Counters of every ray, in the functional tracer's terms (timed or not).
    pub frame: FrameStats,
    /// Per image pixel (frames only; empty for rays).
    pub pixels: Vec<PixelResult>,
    /// Cycles per pixel: Σ of its rays' time in the T&I unit (frames only).
    pub heat: Vec<u64>,
    /// Per ray of the file, in order (rays only).
    pub hits: Vec<Hit>,
    /// The memory behind the caches (for its own report).
    pub memory: M,
}

/// The SGRT chip over memory `M`.
#[derive(Debug)]
pub struct Sgrt<'a, M: MemoryPort> {
    env: Env<'a>,
    hier: Hierarchy<M>,
    cores: Vec<Core>,
    shaders: Vec<Shader>,
    work: Work<'a>,
    /// The last cycle ticked, if any.
    now: Option<u64>,
    completions: Vec<Completion>,
    end: u64,
    complete: bool,
}

/// Requester tags the memory behind the caches must accept: per core the IST's L1 (and the
/// SRP's data cache when the shader runs), then one per core's L2.
pub fn memory_tags(c: &SgrtConfig) -> u32 {
    c.cores * (1 + u32::from(c.shader)) + c.cores
}

/// The cache tree: per core the TRV L1s (over the core's L2), the IST L1 and, with the
/// shader, the SRP's data cache (straight to memory); then the L2s. Returns it with each
/// core's first TRV L1 leaf, IST leaf and data-cache leaf.
fn topology(c: &SgrtConfig, seed: u64) -> Result<(Topology, Vec<[usize; 3]>), SgrtError> {
    let per_core = c.trvs as usize + 1 + usize::from(c.shader);
    let cores = c.cores as usize;
    let mut nodes = Vec::with_capacity(cores * per_core + cores);
    let mut leaves = Vec::with_capacity(cores);
    for core in 0..cores {
        let l2 = cores * per_core + core;
        let base = nodes.len();
        for _ in 0..c.trvs {
            nodes.push(Node {
                name: "trv-l1".into(),
                level: 1,
                cache: c.trv.l1.clone(),
                parent: Parent::Cache(l2),
            });
        }
        nodes.push(Node {
            name: "ist-l1".into(),
            level: 1,
            cache: c.ist.l1.clone(),
            parent: Parent::Memory,
        });
        if c.shader {
            nodes.push(Node {
                name: "srp-dcache".into(),
                level: 1,
                cache: c.srp.dcache.clone(),
                parent: Parent::Memory,
            });
        }
        // Leaves are numbered in node order, and every node of a core but the L2 is a leaf.
        leaves.push([base, base + c.trvs as usize, base + c.trvs as usize + 1]);
    }
    for _ in 0..cores {
        nodes.push(Node {
            name: "l2".into(),
            level: 2,
            cache: c.l2.clone(),
            parent: Parent::Memory,
        });
    }
    Ok((Topology::new(nodes, seed)?, leaves))
}

impl<'a, M: MemoryPort> Sgrt<'a, M> {
    /// Build the chip (the configuration is validated here) over `memory`, whose requester
    /// clock must be the T&I clock and which must accept [`memory_tags`] tags.
    pub fn new(
        c: &SgrtConfig,
        tracer: &'a Tracer,
        image: &'a MemoryImage,
        input: Input<'a>,
        memory: M,
        seed: u64,
    ) -> Result<Self, SgrtError> {
        use rtsim_config::Validate;
        c.validate()?;
        if tracer.bvh().nodes.is_empty() {
            return Err(SgrtError::EmptyScene);
        }
        let env = Env {
            tracer,
            image,
            line_bytes: c.trv.l1.line_bytes,
            wald: tracer.triangle_test() == TriangleTest::Wald,
        };
        let (topo, leaves) = topology(c, seed)?;
        let hier = Hierarchy::new(topo, memory)?;
        let mut cores = Vec::with_capacity(c.cores as usize);
        let mut shaders = Vec::with_capacity(c.cores as usize);
        for (i, l) in leaves.iter().enumerate() {
            cores.push(Core::new(i as u32, c, l[0], l[1], &env)?);
            shaders.push(Shader::new(c, l[2]));
        }
        let work = match input {
            Input::Frame {
                integ,
                pixels,
                timed,
            } => Work::Frame(FrameWork::new(
                integ,
                image,
                c.srp.dcache.line_bytes,
                pixels,
                timed,
            )),
            Input::Rays { path, query } => Work::Rays(RayWork::new(RayReader::open(path)?, query)),
        };
        Ok(Sgrt {
            env,
            hier,
            cores,
            shaders,
            work,
            now: None,
            completions: Vec::new(),
            end: 0,
            complete: false,
        })
    }

    /// Whether every item has finished and nothing is in flight.
    pub fn finished(&self) -> bool {
        self.work.remaining() == 0
            && self.shaders.iter().all(Shader::is_idle)
            && self.cores.iter().all(Core::is_idle)
    }

    /// Items finished and in total.
    pub fn progress(&self) -> (u64, u64) {
        (self.work.done(), self.work.total())
    }

    /// Simulate T&I cycle `t` (after every cycle ticked so far). `all`: visit every unit
    /// (the reference engine) rather than only those whose wake has come.
    pub fn tick(&mut self, t: u64, all: bool) -> Result<(), SgrtError> {
        debug_assert!(self.now.is_none_or(|n| n < t));
        self.hier.advance_to(t)?;
        self.hier.drain_completions(&mut self.completions);
        for c in self.completions.drain(..) {
            let (core, srp, slot) = untag(c.tag);
            let core = core as usize;
            if srp {
                self.shaders[core].load_done(c.ready);
                self.cores[core].shader_wake = t;
            } else {
                self.cores[core].line_arrived(t, slot);
            }
        }
        let env = self.env;
        for i in 0..self.cores.len() {
            let (core, shader) = (&mut self.cores[i], &mut self.shaders[i]);
            core.tick(t, all, &env, &mut self.hier)?;
            if all || core.shader_wake <= t {
                let before = self.work.remaining();
                shader.tick(t, core, &mut self.work, env.tracer, &mut self.hier)?;
                core.shader_wake = shader.next_event(t, core, &self.work).unwrap_or(u64::MAX);
                if self.work.remaining() != before {
                    // Less work left may let another core's shader take the rest.
                    for c in &mut self.cores {
                        c.shader_wake = c.shader_wake.min(t);
                    }
                }
            }
        }
        self.now = Some(t);
        Ok(())
    }

    /// The next cycle at which anything can happen (`None`: nothing will).
    pub fn next_event(&self) -> Option<u64> {
        let now = self.now.unwrap_or(0);
        let mut next = u64::MAX;
        for core in &self.cores {
            next = next
                .min(core.next_event(now).unwrap_or(u64::MAX))
                .min(core.shader_wake);
        }
        // The memory path is asked only if it could come first (asking it costs the DRAM's).
        if next > now + 1 {
            next = next.min(self.hier.next_event().unwrap_or(u64::MAX));
        }
        (next != u64::MAX).then_some(next.max(now + 1))
    }

    /// Run until every item has finished, or past `cycle_limit` (then incomplete), calling
    /// `progress(done, total)` now and then.
    pub fn run(
        &mut self,
        engine: Engine,
        cycle_limit: Option<u64>,
        progress: &mut dyn FnMut(u64, u64),
    ) -> Result<(), SgrtError> {
        let limit = cycle_limit.unwrap_or(u64::MAX);
        let mut ticks = 0u64;
        let mut t = self.now.map_or(0, |n| n + 1);
        loop {
            if self.finished() {
                self.complete = true;
                break;
            }
            if t > limit {
                break;
            }
            self.tick(t, engine == Engine::Reference)?;
            self.end = t;
            ticks += 1;
            if ticks & 0xffff == 0 {
                let (d, n) = self.progress();
                progress(d, n);
            }
            t = match engine {
                Engine::Fast => match self.next_event() {
                    Some(e) => e,
                    None if self.finished() => t + 1,
                    None => return Err(self.stalled(t)),
                },
                Engine::Reference => {
                    if ticks & 0xfffff == 0 && self.next_event().is_none() && !self.finished() {
                        return Err(self.stalled(t));
                    }
                    t + 1
                }
            };
        }
        let (d, n) = self.progress();
        progress(d, n);
        Ok(())
    }

    /// A text of the whole observable state (counters with time integrated up to `end`,
    /// queue and pipeline contents): equal texts mean the engines agree. For the engine tests.
    #[doc(hidden)]
    pub fn fingerprint(&self, end: u64) -> String {
        let mut s = String::new();
        for (c, sh) in self.cores.iter().zip(&self.shaders) {
            s += &format!("{:?}|{}|{:?}\n", c.stats_at(end), c.in_flight, sh.stats);
            s += &c.debug_state();
        }
        s += &format!("{:?}", self.hier.all_stats());
        s
    }

    fn stalled(&self, t: u64) -> SgrtError {
        let in_flight: u32 = self.cores.iter().map(|c| c.in_flight).sum();
        let active: u32 = self.shaders.iter().map(|s| s.active).sum();
        SgrtError::Stalled {
            cycle: t,
            detail: format!(
                "no unit has an event, {in_flight} rays in the T&I units, {active} items in \
                 flight, {} not started",
                self.work.remaining()
            ),
        }
    }

    /// End of the run: let the memory path finish what is in flight (writes) and hand over
    /// the counters and results.
    pub fn finish(mut self) -> Result<SgrtResult<M>, SgrtError> {
        let end = self.now.unwrap_or(0).max(self.end);
        let mut cores = Vec::with_capacity(self.cores.len());
        let mut total = CoreStats::default();
        for (core, shader) in self.cores.iter().zip(&self.shaders) {
            let mut s = core.stats_at(end);
            s.srp += &shader.stats;
            total += &s;
            cores.push(s);
        }
        self.hier.drain()?;
        let hs: HierarchyStats = self.hier.all_stats();
        let mut caches: Vec<(String, CacheStats)> = Vec::new();
        for (name, _, s) in hs.caches {
            match caches.iter_mut().find(|(n, _)| *n == name) {
                Some((_, acc)) => *acc += &s,
                None => caches.push((name, s)),
            }
        }
        let (items_done, items) = self.progress();
        let stats = SgrtStats {
            cycles: end,
            complete: self.complete,
            items_done,
            items,
            total,
            cores,
            caches,
        };
        let frame = *self.work.stats();
        let (pixels, heat, hits) = match self.work {
            Work::Frame(f) => (f.pixels, f.heat, Vec::new()),
            Work::Rays(r) => (Vec::new(), Vec::new(), r.hits),
        };
        Ok(SgrtResult {
            stats,
            frame,
            pixels,
            heat,
            hits,
            memory: self.hier.into_memory(),
        })
    }
}
