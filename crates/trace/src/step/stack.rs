//! The `stack` variant: the TRaX baseline's traversal, stepped.
//!
//! Contract: identical to the closed loop [`crate::traverse::traverse`] — same hits, same
//! counters — one unit of work per [`step`]. Children are visited nearest first (or left
//! first, `trace.order`); the far child is deferred with its entry distance; any-hit queries
//! stop at the first hit when `trace.early_exit` is on. The stack lives in the thread
//! processor's 512-byte local memory: 8 bytes per entry (node index and entry distance), so
//! at most [`STACK_CAPACITY`] entries, and the tracer refuses a BVH deeper than the
//! configured `trace.stack_entries` (a stack never holds more entries than the tree has
//! levels below the root). Every push is a local-memory write, every pop a read.
//!
//! Steps of one ray: `RootBox`, then per node `Node` (and `Treelet` first when the node lies
//! in another treelet), then for an inner node `ChildPair` and possibly `Push`, for a leaf one
//! `Triangle` per triangle; `Pop` when a subtree is finished (culled entries are popped
//! without a node fetch); `Done`.

use super::{Data, Query, Step};
use crate::counters::RayCounters;
use crate::kernels::{HIT, RayBox, TriKernel, slab_test};
use crate::traverse::SlotHit;
use rtsim_core::Ray;

/// Most stack entries: the TRaX TP's 512-byte local memory (DESIGN §3, STRaTA paper §3)
/// divided by 8 bytes per entry (a 4-byte node index and a 4-byte entry distance).
pub const STACK_CAPACITY: usize = 64;

/// Bytes of one stack entry in local memory.
pub const ENTRY_BYTES: u32 = 8;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Phase {
    Root,
    Visit,
    Children,
    Push,
    Triangles,
    Pop,
    Done,
}

/// A ray in flight through the `stack` traversal (plain data; park it anywhere).
#[derive(Clone, Copy, Debug)]
pub struct State {
    ray: Ray,
    rb: RayBox,
    hit: SlotHit,
    /// Current node (Visit/Children), or the leaf whose triangles are tested.
    node: u32,
    /// Next triangle slot and one past the leaf's last.
    slot: u32,
    end: u32,
    /// The far child waiting to be pushed, with its entry distance.
    pending: (u32, f32),
    treelet: u32,
    sp: u32,
    phase: Phase,
    any: bool,
    stack: [(u32, f32); STACK_CAPACITY],
}

impl State {
    /// The best hit found so far (the final answer once done).
    pub fn hit(&self) -> SlotHit {
        self.hit
    }
    pub fn ray(&self) -> &Ray {
        &self.ray
    }
    pub fn is_done(&self) -> bool {
        self.phase == Phase::Done
    }
    /// Stack entries in use.
    pub fn depth(&self) -> u32 {
        self.sp
    }
}

/// Start a traversal.
#[inline]
pub fn start<K: TriKernel>(d: &Data<'_, K>, ray: &Ray, query: Query) -> State {
    State {
        ray: *ray,
        rb: RayBox::new(ray),
        hit: SlotHit::miss(ray.tmax),
        node: 0,
        slot: 0,
        end: 0,
        pending: (0, 0.0),
        treelet: d.treelet(0).unwrap_or(0),
        sp: 0,
        phase: if d.nodes.is_empty() {
            Phase::Done
        } else {
            Phase::Root
        },
        any: query == Query::Any,
        stack: [(0, 0.0); STACK_CAPACITY],
    }
}

/// Perform the next unit of work.
#[inline]
pub fn step<K: TriKernel>(d: &Data<'_, K>, s: &mut State, c: &mut RayCounters) -> Step {
    match s.phase {
        Phase::Root => {
            // The root's box.
            c.box_tests += 1;
            let hit = slab_test(&s.rb, &d.nodes[0].bounds, s.ray.tmin, s.hit.t).is_some();
            s.phase = if hit { Phase::Visit } else { Phase::Done };
            Step::RootBox { hit }
        }
        Phase::Visit => {
            if let Some(t) = d.treelet(s.node)
                && t != s.treelet
            {
                let from = std::mem::replace(&mut s.treelet, t);
                c.treelet_crossings += 1;
                return Step::Treelet { from, to: t };
            }
            let n = &d.nodes[s.node as usize];
            c.nodes_visited += 1;
            let leaf = n.is_leaf();
            if leaf {
                c.leaves_visited += 1;
                s.slot = n.index;
                s.end = n.index + n.count;
                s.phase = Phase::Triangles;
            } else {
                s.phase = Phase::Children;
            }
            Step::Node { node: s.node, leaf }
        }
        Phase::Children => {
            // Both children against the current interval.
            let left = d.nodes[s.node as usize].index;
            let right = left + 1;
            c.box_tests += 2;
            let tl = slab_test(&s.rb, &d.nodes[left as usize].bounds, s.ray.tmin, s.hit.t);
            let tr = slab_test(&s.rb, &d.nodes[right as usize].bounds, s.ray.tmin, s.hit.t);
            match (tl, tr) {
                (Some(a), Some(b)) => {
                    // Descend into the first, defer the other with its entry distance.
                    let (first, second, t_second) = if !d.opts.nearest_first || a <= b {
                        (left, right, b)
                    } else {
                        (right, left, a)
                    };
                    s.pending = (second, t_second);
                    s.node = first;
                    s.phase = Phase::Push;
                }
                (Some(_), None) => {
                    s.node = left;
                    s.phase = Phase::Visit;
                }
                (None, Some(_)) => {
                    s.node = right;
                    s.phase = Phase::Visit;
                }
                (None, None) => s.phase = Phase::Pop,
            }
            Step::ChildPair {
                left,
                hit: [tl.is_some(), tr.is_some()],
            }
        }
        Phase::Push => {
            let depth = s.sp;
            s.stack[depth as usize] = s.pending;
            s.sp += 1;
            c.stack_pushes += 1;
            c.max_stack = c.max_stack.max(s.sp);
            s.phase = Phase::Visit;
            Step::Push {
                node: s.pending.0,
                depth,
                dropped: false,
            }
        }
        Phase::Triangles => {
            let slot = s.slot;
            c.tri_tests += 1;
            let res = K::test(&d.tris[slot as usize], &s.ray, s.ray.tmin, s.hit.t);
            let exit = res.err().unwrap_or(HIT);
            if let Ok(h) = res {
                s.hit = SlotHit {
                    t: h.t,
                    slot,
                    u: h.u,
                    v: h.v,
                };
                if s.any && d.opts.early_exit {
                    s.phase = Phase::Done;
                    return Step::Triangle {
                        slot,
                        hit: true,
                        exit,
                    };
                }
            }
            s.slot += 1;
            if s.slot == s.end {
                s.phase = Phase::Pop;
            }
            Step::Triangle {
                slot,
                hit: exit == HIT,
                exit,
            }
        }
        Phase::Pop => {
            // The next deferred subtree that can still hold a closer hit.
            if s.sp == 0 {
                s.phase = Phase::Done;
                return Step::Done(s.hit);
            }
            s.sp -= 1;
            c.stack_pops += 1;
            let (node, t_entry) = s.stack[s.sp as usize];
            // Beyond the closest hit (inclusive resume, as in the closed loop).
            let culled = t_entry > s.hit.t || t_entry.is_nan();
            if culled {
                c.stack_culls += 1;
            } else {
                s.node = node;
                s.phase = Phase::Visit;
            }
            Step::Pop {
                node,
                depth: s.sp,
                culled,
            }
        }
        Phase::Done => Step::Done(s.hit),
    }
}
