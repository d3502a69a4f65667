//! Steppable traversals: a ray's BVH traversal as a small state machine.
//!
//! A hardware model needs to know, one unit of work at a time, what a ray fetches and does, so
//! that it can time each fetch through its caches, park the ray in a queue or a buffer, and
//! resume it later, possibly on another unit. Each variant here has a plain-data state
//! (`Copy`, no pointers) and two functions:
//!
//! - `start(data, ray, query) -> State`;
//! - `step(data, &mut State, &mut RayCounters) -> Step`: performs the next unit of work and
//!   says what it was ([`Step`]): fetch a node record, test a child pair, push or pop, fetch
//!   and test a triangle, read a parent pointer, re-test a sibling, cross into another
//!   treelet, restart, or finish with the hit. [`Step::access`] names the record or
//!   local-memory word the step reads or writes; the memory image turns that into byte
//!   addresses and cache lines ([`Access::lines`]).
//!
//! Variants (`trace.traversal`), each with its contract in `docs/TRAVERSAL.md`:
//!
//! | variant | module | used by | stack |
//! |---|---|---|---|
//! | `stack` | [`stack`] | TRaX baseline; the reference | entries of (node, entry t) in the TP's 512 B local memory |
//! | `bit-stack` | [`bitstack`] | STRaTA (paper §3.2) | one bit per level in a `u32`, parent pointers; state fits the 48-byte ray record |
//! | `short-stack` | [`shortstack`] | SGRT's TRV | a few entries, oldest dropped on overflow, restart trail (Laine 2010) |
//!
//! All three find the same closest hit (see [`crate::tracer`] tests for the tie rule) and
//! agree on hit/miss for any-hit queries. The `stack` variant's steps reproduce the closed
//! loop of [`crate::traverse`] exactly, counters included.

pub mod bitstack;
pub mod shortstack;
pub mod stack;

use crate::kernels::TriKernel;
use crate::traverse::{SlotHit, TraverseOptions};
use rtsim_bvh::{LineSpan, MemoryImage, Node, lines_touched};

/// What a traversal answers.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Query {
    /// The closest hit in `(tmin, tmax)`.
    Closest,
    /// Whether anything is hit in `(tmin, tmax)` (shadow and AO rays); stops at the first hit
    /// when the tracer's `early_exit` is on.
    Any,
}

/// Node index meaning "none" in steps.
pub const NONE: u32 = u32::MAX;

/// One unit of traversal work, as the hardware would do it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Step {
    /// Fetched the root's record and tested the ray against its box; `hit`: the ray enters the
    /// scene (otherwise the next step is [`Step::Done`]).
    RootBox { hit: bool },
    /// Fetched `node`'s record (child index and count; the parent word too for `bit-stack`)
    /// to descend into it. A leaf's triangle tests follow; an inner node's child pair test.
    Node { node: u32, leaf: bool },
    /// Fetched the records of the children `left`, `left + 1` of the current inner node (one
    /// pair, stored side by side) and tested the ray against both boxes.
    ChildPair { left: u32, hit: [bool; 2] },
    /// Pushed onto the stack: `node` deferred (`stack`, `short-stack`; [`NONE`] for
    /// `bit-stack`, which pushes one bit), at stack depth `depth` (the slot written; [`NONE`]
    /// for `bit-stack`, whose stack is a register).
    /// `dropped`: `short-stack` only, the stack was full and its oldest entry was dropped.
    Push {
        node: u32,
        depth: u32,
        dropped: bool,
    },
    /// Popped the stack entry at `depth`: `node` is resumed, or discarded when `culled`
    /// (a closer hit was found since it was pushed). `bit-stack` pops a bit (`depth` is
    /// [`NONE`]); `node` is then the parent the traversal moves up to.
    Pop { node: u32, depth: u32, culled: bool },
    /// Fetched the triangle record at BVH slot `slot` and tested the ray against it; `exit`
    /// says which way the test ended (`kernels::HIT` or the kernel's numbered miss), which
    /// fixes the operations it ran (`crate::ops`).
    Triangle { slot: u32, hit: bool, exit: u8 },
    /// `bit-stack`: read `node`'s parent pointer to move up the tree.
    Parent { node: u32, parent: u32 },
    /// `bit-stack`: on the way up, fetched and tested again the box of `node`, the sibling of
    /// the subtree just finished, because it was deferred without its entry distance.
    SiblingRetest { node: u32, hit: bool },
    /// `short-stack`: the stack ran empty while a dropped entry was still pending; the
    /// traversal starts again at the root and follows the restart trail.
    Restart,
    /// The next node lies in treelet `to` (the current one is `from`); a streaming
    /// architecture parks the ray in `to`'s buffer here.
    Treelet { from: u32, to: u32 },
    /// Finished: the closest hit (any hit for an any-hit query), or a miss. Every further
    /// `step` returns the same.
    Done(SlotHit),
}

/// What a step reads or writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Access {
    /// Nothing outside the unit's registers.
    None,
    /// A node record (its box, child index and count; parent and treelet words if present).
    Node(u32),
    /// The records of a sibling pair starting at the left child.
    NodePair(u32),
    /// A triangle record, by BVH slot.
    Triangle(u32),
    /// A stack entry in the unit's local memory: `depth` is the entry index; `write` for a push.
    Stack { depth: u32, write: bool },
}

impl Step {
    /// What this step reads or writes.
    #[inline]
    pub fn access(&self) -> Access {
        match *self {
            Step::RootBox { .. } => Access::Node(0),
            Step::Node { node, .. } | Step::Parent { node, .. } => Access::Node(node),
            Step::SiblingRetest { node, .. } => Access::Node(node),
            Step::ChildPair { left, .. } => Access::NodePair(left),
            Step::Triangle { slot, .. } => Access::Triangle(slot),
            // `bit-stack` keeps its stack in a register (depth NONE).
            Step::Push { depth, .. } if depth != NONE => Access::Stack { depth, write: true },
            Step::Pop { depth, .. } if depth != NONE => Access::Stack {
                depth,
                write: false,
            },
            Step::Push { .. } | Step::Pop { .. } => Access::None,
            Step::Restart | Step::Treelet { .. } | Step::Done(_) => Access::None,
        }
    }

    /// Whether this is the final step.
    #[inline]
    pub fn is_done(&self) -> bool {
        matches!(self, Step::Done(_))
    }
}

impl Access {
    /// Like [`Access::lines`], with triangle records in the format `test` reads: Wald's
    /// precomputed record (its own region of the image) for `wald`, the vertex record
    /// otherwise.
    pub fn lines_for(
        &self,
        image: &MemoryImage,
        line_bytes: u32,
        test: crate::TriangleTest,
    ) -> Option<LineSpan> {
        match (*self, test) {
            (Access::Triangle(slot), crate::TriangleTest::Wald) => {
                Some(image.wald_lines(slot, line_bytes))
            }
            _ => self.lines(image, line_bytes),
        }
    }

    /// The cache lines of `line_bytes` that the access touches in the memory image (none for
    /// register and local-memory accesses; triangle records as vertex records — see
    /// [`Access::lines_for`] for Wald's). A pair touches the lines of both records (one line
    /// with the default 32-byte nodes and aligned pairs).
    pub fn lines(&self, image: &MemoryImage, line_bytes: u32) -> Option<LineSpan> {
        match *self {
            Access::None | Access::Stack { .. } => None,
            Access::Node(n) => Some(image.node_lines(n, line_bytes)),
            Access::NodePair(left) => {
                let a = image.node_addr(left);
                let b = image.node_addr(left + 1);
                let bytes = image.node_data_bytes();
                if b == a + image.node_bytes() as u64 {
                    Some(lines_touched(a, image.node_bytes() + bytes, line_bytes))
                } else {
                    // A layout that separates siblings: report the left record's lines (the
                    // right one is a second fetch; no shipped layout does this).
                    Some(lines_touched(a, bytes, line_bytes))
                }
            }
            Access::Triangle(slot) => Some(image.triangle_lines(slot, line_bytes)),
        }
    }
}

/// Everything a stepped traversal reads besides the ray: the flat nodes, the triangle records
/// in the kernel's format (BVH slot order), the parent of every node (`bit-stack` only; may be
/// empty otherwise) and the treelet id of every node (empty: no treelets, no crossings).
#[derive(Debug)]
pub struct Data<'a, K: TriKernel> {
    pub nodes: &'a [Node],
    pub tris: &'a [K::Data],
    pub parents: &'a [u32],
    pub treelets: &'a [u32],
    pub opts: TraverseOptions,
}

impl<K: TriKernel> Clone for Data<'_, K> {
    fn clone(&self) -> Self {
        *self
    }
}
impl<K: TriKernel> Copy for Data<'_, K> {}

impl<K: TriKernel> Data<'_, K> {
    /// The treelet of `node`, if the tracer has treelet ids.
    #[inline(always)]
    pub(crate) fn treelet(&self, node: u32) -> Option<u32> {
        self.treelets.get(node as usize).copied()
    }
}

/// The sibling of a child: pairs are `(odd, odd + 1)` in the flat array (the root is alone at
/// 0; `Bvh::check_invariants` enforces it), so the left child is the odd one.
#[inline(always)]
pub(crate) fn sibling(child: u32) -> u32 {
    if child & 1 == 1 { child + 1 } else { child - 1 }
}

/// Whether a child is the left one of its pair.
#[inline(always)]
pub(crate) fn is_left(child: u32) -> bool {
    child & 1 == 1
}

/// Run a stepped traversal to the end (the functional use of a stepper).
#[inline]
pub fn run<S>(mut step: impl FnMut(&mut S) -> Step, state: &mut S) -> SlotHit {
    loop {
        if let Step::Done(h) = step(state) {
            return h;
        }
    }
}

#[cfg(test)]
mod tests;
