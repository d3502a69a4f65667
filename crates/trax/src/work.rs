//! What a TP works on, functionally: the pixel's state machine, the ray's stepped traversal,
//! and the sequence of dynamic blocks ([`Run`]s) that they make the TP execute.
//!
//! The values come from the substrate's functional code — `Integrator::begin`/`resume` for
//! the pixel, `Tracer::start`/`step` for the ray — called in program order as the TP reaches
//! the end of each block. Timing never feeds back into them, so the image and every ray's
//! counters equal the functional tracer's whatever the chip does; timing decides only when.

use crate::program::{Program, Run, SHADING_ORDER, Seg};
use rtsim_bvh::MemoryImage;
use rtsim_core::Vec3;
use rtsim_trace::step::Step;
use rtsim_trace::{
    FrameStats, Integrator, Kernel, Next, PathState, RayCounters, RayJob, Resumed, Shading,
    TraceResult, Tracer, TraversalState,
};

/// Everything the TPs share to find their work.
#[derive(Debug)]
pub struct Ctx<'a> {
    pub integ: &'a Integrator<'a>,
    pub tracer: &'a Tracer,
    pub image: &'a MemoryImage,
    pub program: &'a Program,
    /// The pixels of the frame (row-major indices), handed out in this order by the counter.
    pub pixels: &'a [u32],
}

/// Where the TP is in its work.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Phase {
    /// Running the pixel loop's block; the counter's value decides what follows.
    NextPixel,
    /// Running a transition's shading blocks, then the ray setup; then tracing or the next
    /// pixel.
    Shading,
    /// Running traversal steps.
    Tracing,
    /// No pixels left.
    Halted,
}

/// Most blocks one transition queues: every kernel at most twice, three record accesses, the
/// ray setup and three fixups.
const QUEUE: usize = 2 * rtsim_trace::workload::KERNELS + 3 + 4;

/// A finished pixel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PixelDone {
    pub pixel: u32,
    pub color: Vec3,
    pub nodes_visited: u32,
}

impl PixelDone {
    /// The pixel's entry in the frame's result.
    pub fn result(&self) -> rtsim_trace::PixelResult {
        rtsim_trace::PixelResult {
            color: self.color,
            nodes_visited: self.nodes_visited,
        }
    }
}

/// One TP's functional state.
#[derive(Clone, Debug)]
pub struct Work {
    phase: Phase,
    queue: [Run; QUEUE],
    qlen: u8,
    qpos: u8,
    /// The counter's value from the last `atominc`.
    counter: Option<u32>,
    path: Option<PathState>,
    job: Option<RayJob>,
    after: Option<Next>,
    trav: Option<TraversalState>,
    counters: RayCounters,
    pixel_nodes: u32,
}

impl Default for Work {
    fn default() -> Self {
        Work::new()
    }
}

impl Work {
    /// A TP about to run the pixel loop.
    pub fn new() -> Work {
        Work {
            phase: Phase::NextPixel,
            queue: [Run::default(); QUEUE],
            qlen: 0,
            qpos: 0,
            counter: None,
            path: None,
            job: None,
            after: None,
            trav: None,
            counters: RayCounters::default(),
            pixel_nodes: 0,
        }
    }

    /// A TP that runs exactly `runs` and halts (hand-computed timing tests).
    #[cfg(test)]
    pub(crate) fn scripted(runs: &[Run]) -> Work {
        let mut w = Work::new();
        for &r in runs {
            w.push(r);
        }
        w.phase = Phase::Halted;
        w
    }

    pub fn is_halted(&self) -> bool {
        self.phase == Phase::Halted
    }

    /// The `atominc` of the pixel loop returned `value`.
    pub fn set_counter(&mut self, value: u32) {
        self.counter = Some(value);
    }

    fn push(&mut self, r: Run) {
        self.queue[self.qlen as usize] = r;
        self.qlen += 1;
    }

    /// Queue the blocks of one transition's shading, in the program's fixed order.
    fn queue_shading(&mut self, c: &Ctx<'_>, sh: &Shading) {
        let p = c.program;
        for &k in &SHADING_ORDER {
            let n = sh.count(k);
            let seg = p.kernels[k as usize];
            for _ in 0..n {
                let run = if k == Kernel::Surface {
                    let slot = sh
                        .triangle
                        .expect("the surface kernel reads the hit triangle's record");
                    Run::at(seg, c.image.triangle_addr(slot))
                } else {
                    Run::new(seg)
                };
                self.push(run);
            }
            if k == Kernel::Surface
                && let Some(m) = sh.material
            {
                self.push(Run::at(p.material_read, c.image.material_addr(m)));
            }
            if k == Kernel::Finish
                && let Some(px) = sh.framebuffer
            {
                self.push(Run::at(p.framebuffer_write, c.image.framebuffer_addr(px)));
            }
        }
    }

    /// After a transition: queue the next ray's setup, or the pixel loop.
    fn then(&mut self, c: &Ctx<'_>, r: Resumed, done: &mut Option<PixelDone>) {
        self.queue_shading(c, &r.shading);
        match r.next {
            Next::Trace(job) => {
                let p = c.program;
                self.push(Run::new(p.ray_setup));
                let d = job.ray.direction;
                for v in [d.x, d.y, d.z] {
                    // `kernels::inverse_direction`: a reciprocal that is not finite is replaced.
                    if !(1.0 / v).is_finite() {
                        self.push(Run::new(p.inv_fixup));
                    }
                }
                self.job = Some(job);
                self.after = None;
                self.phase = Phase::Shading;
            }
            Next::Done(color) => {
                let pixel = self.path.as_ref().expect("a pixel in flight").pixel();
                *done = Some(PixelDone {
                    pixel,
                    color,
                    nodes_visited: self.pixel_nodes,
                });
                self.path = None;
                self.job = None;
                self.after = Some(r.next);
                self.phase = Phase::Shading;
            }
        }
    }

    /// The next block, advancing the functional state as the TP reaches the end of one.
    /// `None` once the TP has no pixels left. A finished ray is added to `stats` (by kind) and counted in `rays`; a
    /// finished pixel is reported through `done`.
    pub fn next(
        &mut self,
        c: &Ctx<'_>,
        stats: &mut FrameStats,
        rays: &mut u64,
        done: &mut Option<PixelDone>,
    ) -> Option<Run> {
        loop {
            if self.qpos < self.qlen {
                let r = self.queue[self.qpos as usize];
                self.qpos += 1;
                return Some(r);
            }
            self.qpos = 0;
            self.qlen = 0;
            match self.phase {
                Phase::Halted => return None,
                Phase::NextPixel => {
                    let v = self
                        .counter
                        .take()
                        .expect("the pixel loop's atominc has returned");
                    let Some(&pixel) = c.pixels.get(v as usize) else {
                        self.phase = Phase::Halted;
                        return None;
                    };
                    let (ps, r) = c.integ.begin(pixel);
                    self.path = Some(ps);
                    self.pixel_nodes = 0;
                    self.then(c, r, done);
                }
                Phase::Shading => {
                    if self.after.take().is_some() {
                        self.phase = Phase::NextPixel;
                        return Some(Run::new(c.program.next_pixel));
                    }
                    let job = self.job.expect("a ray to trace");
                    self.trav = Some(c.tracer.start(&job.ray, job.query));
                    self.counters = RayCounters::default();
                    self.phase = Phase::Tracing;
                }
                Phase::Tracing => {
                    let trav = self.trav.as_mut().expect("a traversal in flight");
                    let step = c.tracer.step(trav, &mut self.counters);
                    if let Some(run) = step_run(c, &step) {
                        if matches!(step, Step::Triangle { .. }) {
                            // The leaf loop's tail follows every triangle test.
                            self.push(Run::new(c.program.tri_tail));
                        }
                        return Some(run);
                    }
                    if let Step::Done(h) = step {
                        let job = self.job.expect("a ray in flight");
                        let result = TraceResult::from_slot_hit(c.tracer, h);
                        stats
                            .kind_mut(job.id.kind)
                            .record(&self.counters, result.hit.is_hit());
                        *rays += 1;
                        self.pixel_nodes =
                            self.pixel_nodes.saturating_add(self.counters.nodes_visited);
                        self.trav = None;
                        let ps = self.path.as_mut().expect("a pixel in flight");
                        let r = c.integ.resume(ps, &job, &result);
                        self.then(c, r, done);
                    }
                }
            }
        }
    }
}

/// The block of one traversal step (`None` for steps that run nothing: `Done`, `Treelet`).
#[inline]
pub fn step_run(c: &Ctx<'_>, step: &Step) -> Option<Run> {
    let p = c.program;
    let img = c.image;
    Some(match *step {
        Step::RootBox { .. } => Run::at(p.root_box, img.node_addr(0)),
        Step::Node { node, .. } => Run::at(p.node, img.node_addr(node)),
        Step::ChildPair { left, hit } => {
            let seg: Seg = if hit[0] && hit[1] {
                p.pair
            } else {
                p.pair.prefix(p.pair_one)
            };
            Run {
                seg,
                base: [img.node_addr(left), img.node_addr(left + 1)],
                local: 0,
            }
        }
        Step::Push { depth, .. } | Step::Pop { depth, .. } => {
            let seg = if matches!(step, Step::Push { .. }) {
                p.push
            } else {
                p.pop
            };
            Run {
                seg,
                base: [0; 2],
                local: depth * rtsim_trace::step::stack::ENTRY_BYTES,
            }
        }
        // The exit's prefix of the test; the loop's tail follows as its own block.
        Step::Triangle { slot, exit, .. } => Run::at(
            p.tri.prefix(p.tri_exit[exit as usize]),
            img.triangle_addr(slot),
        ),
        Step::Done(_) | Step::Treelet { .. } => return None,
        Step::Parent { .. } | Step::SiblingRetest { .. } | Step::Restart => {
            unreachable!("the TRaX program runs the `stack` traversal (validated)")
        }
    })
}
