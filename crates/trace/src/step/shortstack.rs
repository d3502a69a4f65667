//! The `short-stack` variant: SGRT's traversal unit, stepped.
//!
//! The SGRT paper gives each TRV 16 short stacks, one per ray in flight (§3.3, §4), but not
//! their depth or what happens when one overflows. rtsim's contract:
//!
//! - Depth: `trace.short_stack_entries` entries of (node, entry distance), default 8
//!   (assumed: a few entries; Vaidyanathan et al., "Wide BVH Traversal with a Short Stack",
//!   HPG 2019, find five entries with a restart trail close to a full stack for wide BVHs,
//!   and a binary BVH defers more nodes per level of a wide one; a knob).
//! - Order and deferral as the `stack` variant: nearest child first (or left first), the far
//!   child pushed with its entry distance, culled on pop if a closer hit was found since.
//! - Overflow: pushing onto a full stack drops its *oldest* entry (`stack_overflows`).
//! - Restart trail (Laine, "Restart Trail for Stackless BVH Traversal", HPG 2010): one bit
//!   per level of the current path (a `u64`: at most 64 levels below the root, the
//!   tracer refuses deeper BVHs). Bit `k` set means "at level `k` the first child is done (or
//!   there was only one child to visit): take the second". When a subtree is finished, the
//!   deepest level with a clear bit is found, its bit set and the deeper ones cleared; the
//!   second child of that level is resumed from the stack's top entry, or — when the stack
//!   is empty because that entry was dropped — by restarting at the root (`restarts`) and
//!   walking down the trail: at a level whose bit is set, the second child if both are hit,
//!   or the only child hit; at a clear bit, the first child (pushing the second again). The
//!   trail only grows, so the traversal ends; a restart re-tests boxes with the current
//!   closest hit, so it may re-enter a subtree already done (a single hit child at a set
//!   level is taken to be the second), which costs work but never loses a hit.
//!
//! With at least as many entries as the BVH has levels the stack never overflows and the
//! steps and counters equal the `stack` variant's (tested).

use super::{Data, Query, Step};
use crate::counters::RayCounters;
use crate::kernels::{HIT, RayBox, TriKernel, slab_test};
use crate::traverse::SlotHit;
use rtsim_core::Ray;

/// Most entries a short stack can be configured with.
pub const MAX_ENTRIES: usize = 64;
/// Most levels below the root the restart trail can hold.
pub const MAX_LEVELS: u32 = 64;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Phase {
    Root,
    Visit,
    Children,
    Push,
    Triangles,
    Pop,
    Restart,
    Done,
}

/// A ray in flight through the `short-stack` traversal.
#[derive(Clone, Copy, Debug)]
pub struct State {
    ray: Ray,
    rb: RayBox,
    hit: SlotHit,
    node: u32,
    slot: u32,
    end: u32,
    pending: (u32, f32),
    treelet: u32,
    /// Level of `node` below the root.
    level: u32,
    /// Restart trail: bit `k - 1` for level `k`.
    trail: u64,
    /// Entries in use; the oldest at `bottom`, a ring of `capacity` slots.
    len: u32,
    bottom: u32,
    capacity: u32,
    phase: Phase,
    any: bool,
    stack: [(u32, f32); MAX_ENTRIES],
}

impl State {
    pub fn hit(&self) -> SlotHit {
        self.hit
    }
    pub fn is_done(&self) -> bool {
        self.phase == Phase::Done
    }
    /// Entries in use.
    pub fn depth(&self) -> u32 {
        self.len
    }
}

#[inline(always)]
fn bit(level: u32) -> u64 {
    1u64 << (level - 1)
}

/// Start a traversal with a stack of `entries` (1..=[`MAX_ENTRIES`]; clamped).
#[inline]
pub fn start<K: TriKernel>(d: &Data<'_, K>, ray: &Ray, query: Query, entries: u32) -> State {
    State {
        ray: *ray,
        rb: RayBox::new(ray),
        hit: SlotHit::miss(ray.tmax),
        node: 0,
        slot: 0,
        end: 0,
        pending: (0, 0.0),
        treelet: d.treelet(0).unwrap_or(0),
        level: 0,
        trail: 0,
        len: 0,
        bottom: 0,
        capacity: entries.clamp(1, MAX_ENTRIES as u32),
        phase: if d.nodes.is_empty() {
            Phase::Done
        } else {
            Phase::Root
        },
        any: query == Query::Any,
        stack: [(0, 0.0); MAX_ENTRIES],
    }
}

/// The current node is finished: mark the deepest level with a pending second child as
/// taken, or finish the traversal.
#[inline(always)]
fn finish_node(s: &mut State) {
    // Levels 1..=level with a clear bit still have their second child pending.
    let mask = if s.level >= 64 {
        u64::MAX
    } else {
        (1u64 << s.level) - 1
    };
    let open = !s.trail & mask;
    if open == 0 {
        s.phase = Phase::Done;
        return;
    }
    let j = 64 - open.leading_zeros();
    // Set bit j, clear the deeper ones.
    s.trail = (s.trail & (bit(j) | (bit(j) - 1))) | bit(j);
    s.level = j;
    s.phase = if s.len > 0 {
        Phase::Pop
    } else {
        Phase::Restart
    };
}

/// Perform the next unit of work.
#[inline]
pub fn step<K: TriKernel>(d: &Data<'_, K>, s: &mut State, c: &mut RayCounters) -> Step {
    match s.phase {
        Phase::Root => {
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
            let left = d.nodes[s.node as usize].index;
            let right = left + 1;
            c.box_tests += 2;
            let tl = slab_test(&s.rb, &d.nodes[left as usize].bounds, s.ray.tmin, s.hit.t);
            let tr = slab_test(&s.rb, &d.nodes[right as usize].bounds, s.ray.tmin, s.hit.t);
            let k = s.level + 1;
            match (tl, tr) {
                (Some(a), Some(b)) => {
                    let (first, second, t_second) = if !d.opts.nearest_first || a <= b {
                        (left, right, b)
                    } else {
                        (right, left, a)
                    };
                    s.level = k;
                    if s.trail & bit(k) != 0 {
                        // The first child is done (before a restart): take the second.
                        s.node = second;
                        s.phase = Phase::Visit;
                    } else {
                        s.pending = (second, t_second);
                        s.node = first;
                        s.phase = Phase::Push;
                    }
                }
                (Some(_), None) | (None, Some(_)) => {
                    // One child: nothing to come back for at this level.
                    s.level = k;
                    s.trail |= bit(k);
                    s.node = if tl.is_some() { left } else { right };
                    s.phase = Phase::Visit;
                }
                (None, None) => finish_node(s),
            }
            Step::ChildPair {
                left,
                hit: [tl.is_some(), tr.is_some()],
            }
        }
        Phase::Push => {
            let cap = s.capacity;
            let dropped = s.len == cap;
            if dropped {
                // Full: drop the oldest entry; a restart will recover it.
                s.bottom = (s.bottom + 1) % cap;
                s.len -= 1;
                c.stack_overflows += 1;
            }
            let depth = (s.bottom + s.len) % cap;
            s.stack[depth as usize] = s.pending;
            s.len += 1;
            c.stack_pushes += 1;
            c.max_stack = c.max_stack.max(s.len);
            s.phase = Phase::Visit;
            Step::Push {
                node: s.pending.0,
                depth,
                dropped,
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
                finish_node(s);
            }
            Step::Triangle {
                slot,
                hit: exit == HIT,
                exit,
            }
        }
        Phase::Pop => {
            // The top entry is the second child of level `s.level` (the trail and the stack
            // agree: entries are pushed for clear bits, deepest on top).
            s.len -= 1;
            let depth = (s.bottom + s.len) % s.capacity;
            c.stack_pops += 1;
            let (node, t_entry) = s.stack[depth as usize];
            // Beyond the closest hit (inclusive resume, as in the closed loop).
            let culled = t_entry > s.hit.t || t_entry.is_nan();
            if culled {
                c.stack_culls += 1;
                // Nothing closer in there: that level is finished too.
                finish_node(s);
            } else {
                s.node = node;
                s.phase = Phase::Visit;
            }
            Step::Pop {
                node,
                depth,
                culled,
            }
        }
        Phase::Restart => {
            c.restarts += 1;
            s.node = 0;
            s.level = 0;
            s.phase = Phase::Visit;
            Step::Restart
        }
        Phase::Done => Step::Done(s.hit),
    }
}
