//! The `bit-stack` variant: STRaTA's traversal (paper §3.2), stepped.
//!
//! The BVH carries parent pointers; the ray keeps, per level of the current path, one bit
//! saying which child of that level's node was visited first, in a 32-bit integer whose least
//! significant bit is the top (shift left to push, right to pop; no stack pointer). Children
//! are visited nearest first (`trace.order = left-first`: left first).
//!
//! - At an inner node, both children's boxes are tested. Both hit: descend into the first and
//!   push a bit naming its side (1 = left). One hit: descend into it and push a bit naming the
//!   *other* side, so that coming back up pops at once (no re-test: the other child was
//!   missed). None: the node is finished.
//! - At a leaf, its triangles are tested; then the leaf is finished.
//! - A finished node `C` is left through its parent pointer (`Parent`). If the top bit names
//!   `C`'s side, `C` was the first of two hit children: the sibling's box is tested again
//!   against the current closest hit (`SiblingRetest` — the variant's overhead: the far
//!   child's entry distance was not stored) and, if still hit, entered; the bit stays, and now
//!   names the side that is not the sibling's, so coming back from it pops. Otherwise (or if
//!   the re-test misses) the bit is popped and the parent is finished in turn. Leaving the
//!   root ends the traversal.
//!
//! The BVH must have at most 32 levels below the root (one bit each); the tracer refuses a
//! deeper one (build with `bvh.max_depth = 32`).
//!
//! # The 48-byte ray record
//!
//! [`State`] holds exactly what STRaTA's 48-byte ray record in stream memory holds (paper
//! §3.1: origin and direction 24 B, state 20 B, bit stack 4 B), plus the inverse direction,
//! which is recomputed when a record is loaded. [`State::to_record`] / [`State::from_record`]
//! convert, and a test checks that a ray parked as a record at any step continues exactly as
//! if it had not been. Layout (little-endian words):
//!
//! | offset | field | notes |
//! |---:|---|---|
//! | 0 | origin x y z (`f32`) | |
//! | 12 | direction x y z (`f32`) | 1/direction is recomputed on load |
//! | 24 | node (`u32`) | the node being entered, tested or left (see phase) |
//! | 28 | closest t (`f32`) | starts at the ray's tmax; tmin is 0 for every workload ray |
//! | 32 | hit slot (`u32`) | `0xFFFFFFFF`: none yet |
//! | 36 | bit stack (`u32`) | LSB = top |
//! | 40 | path id (`u32`) | the workload's path-state slot (throughput, radiance, RNG, pixel live there) |
//! | 44 | flags (`u32`) | bits 0–3 phase, 4 any-hit query, 5–12 triangle offset in the leaf, 13–15 ray kind (the workload's), 16 push pending, 17–22 level of the node (bits in use) |
//!
//! Not stored: tmin (must be 0: [`RecordError::NonZeroTmin`]), and the hit's barycentrics,
//! which [`step`] recomputes when the traversal finishes by testing the hit triangle again
//! (deterministic: the same kernel on the same inputs gives the same t, u, v; shading needs
//! them and would recompute them the same way).

use super::{Data, NONE, Query, Step, is_left, sibling};
use crate::counters::RayCounters;
use crate::kernels::{HIT, RayBox, TriKernel, slab_test};
use crate::traverse::SlotHit;
use rtsim_core::{Ray, Vec3};

/// Most levels below the root the bit stack can hold.
pub const MAX_LEVELS: u32 = 32;

/// Size of the ray record in stream memory (STRaTA paper §3.1).
pub const RECORD_BYTES: usize = 48;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
enum Phase {
    Root = 0,
    /// Enter `node` (fetch its record).
    Visit = 1,
    /// Test `node`'s child pair.
    Children = 2,
    /// Push the pending bit, then enter `node`.
    Push = 3,
    /// Test the triangle at `offset` within leaf `node`.
    Triangles = 4,
    /// `node` is finished: read its parent pointer.
    Up = 5,
    /// Re-test the sibling of `node`.
    Retest = 6,
    /// Pop the bit of `node`'s parent and finish the parent.
    Pop = 7,
    Done = 8,
    /// Moving down into `node`, which lies in another treelet than its parent.
    CrossDown = 9,
    /// Moving up to `node`, which lies in another treelet than its children.
    CrossUp = 10,
}

impl Phase {
    fn from_bits(b: u32) -> Option<Phase> {
        Some(match b {
            0 => Phase::Root,
            1 => Phase::Visit,
            2 => Phase::Children,
            3 => Phase::Push,
            4 => Phase::Triangles,
            5 => Phase::Up,
            6 => Phase::Retest,
            7 => Phase::Pop,
            8 => Phase::Done,
            9 => Phase::CrossDown,
            10 => Phase::CrossUp,
            _ => return None,
        })
    }
}

/// A ray in flight through the `bit-stack` traversal.
#[derive(Clone, Copy, Debug)]
pub struct State {
    origin: Vec3,
    dir: Vec3,
    tmin: f32,
    /// Closest hit distance so far (the ray's tmax until something is hit).
    t: f32,
    slot: u32,
    node: u32,
    bits: u32,
    /// Bits 0–3 phase, 4 any-hit, 5 pending push bit, 8–15 triangle offset in the leaf,
    /// 16–21 level of `node` (bits in use).
    flags: u32,
    /// Recomputed from `dir` (not part of the record).
    inv_dir: Vec3,
}

const PHASE_MASK: u32 = 0xF;
const ANY_BIT: u32 = 1 << 4;
const PENDING_BIT: u32 = 1 << 5;
const OFFSET_SHIFT: u32 = 8;
const LEVEL_SHIFT: u32 = 16;

/// A ray record that cannot be stored or read.
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
pub enum RecordError {
    #[error("the 48-byte ray record has no tmin: it must be 0 (got {0})")]
    NonZeroTmin(f32),
    #[error("ray kind {0} does not fit the record's 3 bits")]
    Kind(u8),
    #[error("ray record has an invalid phase {0}")]
    Phase(u32),
    #[error("ray record has level {0}, more than the bit stack's 32")]
    Level(u32),
}

impl State {
    #[inline(always)]
    fn phase(&self) -> Phase {
        // Only `set_phase` and `from_record` (which validates) write these bits.
        Phase::from_bits(self.flags & PHASE_MASK).unwrap_or(Phase::Done)
    }
    #[inline(always)]
    fn set_phase(&mut self, p: Phase) {
        self.flags = (self.flags & !PHASE_MASK) | p as u32;
    }
    #[inline(always)]
    fn offset(&self) -> u32 {
        (self.flags >> OFFSET_SHIFT) & 0xFF
    }
    #[inline(always)]
    fn set_offset(&mut self, o: u32) {
        self.flags = (self.flags & !(0xFF << OFFSET_SHIFT)) | ((o & 0xFF) << OFFSET_SHIFT);
    }
    /// Bits in use: the level of the current node below the root.
    #[inline(always)]
    pub fn level(&self) -> u32 {
        (self.flags >> LEVEL_SHIFT) & 0x3F
    }
    #[inline(always)]
    fn set_level(&mut self, l: u32) {
        self.flags = (self.flags & !(0x3F << LEVEL_SHIFT)) | ((l & 0x3F) << LEVEL_SHIFT);
    }
    #[inline(always)]
    fn ray(&self) -> Ray {
        Ray::new(self.origin, self.dir, self.tmin, self.t)
    }
    #[inline(always)]
    fn ray_box(&self) -> RayBox {
        RayBox {
            origin: self.origin,
            inv_dir: self.inv_dir,
        }
    }
    /// The ray's direction (what a loaded record's inverse direction is recomputed from).
    pub fn direction(&self) -> Vec3 {
        self.dir
    }

    pub fn is_done(&self) -> bool {
        self.phase() == Phase::Done
    }
    /// The bit stack (LSB = top).
    pub fn bits(&self) -> u32 {
        self.bits
    }

    /// The 48-byte ray record of this state (layout in the module docs). `path_id` and
    /// `kind` (3 bits) belong to the workload.
    pub fn to_record(&self, path_id: u32, kind: u8) -> Result<[u8; RECORD_BYTES], RecordError> {
        if self.tmin != 0.0 {
            return Err(RecordError::NonZeroTmin(self.tmin));
        }
        if kind > 7 {
            return Err(RecordError::Kind(kind));
        }
        let flags = (self.flags & (PHASE_MASK | ANY_BIT))
            | (self.offset() << 5)
            | ((kind as u32) << 13)
            | ((self.flags & PENDING_BIT != 0) as u32) << 16
            | (self.level() << 17);
        let words: [u32; 12] = [
            self.origin.x.to_bits(),
            self.origin.y.to_bits(),
            self.origin.z.to_bits(),
            self.dir.x.to_bits(),
            self.dir.y.to_bits(),
            self.dir.z.to_bits(),
            self.node,
            self.t.to_bits(),
            self.slot,
            self.bits,
            path_id,
            flags,
        ];
        let mut r = [0u8; RECORD_BYTES];
        for (k, w) in words.iter().enumerate() {
            r[4 * k..4 * k + 4].copy_from_slice(&w.to_le_bytes());
        }
        Ok(r)
    }

    /// Read a record back: the state (1/direction recomputed), the path id and the ray kind.
    pub fn from_record(r: &[u8; RECORD_BYTES]) -> Result<(State, u32, u8), RecordError> {
        let w = |k: usize| u32::from_le_bytes([r[4 * k], r[4 * k + 1], r[4 * k + 2], r[4 * k + 3]]);
        let f = |k: usize| f32::from_bits(w(k));
        let flags = w(11);
        let phase = flags & PHASE_MASK;
        if Phase::from_bits(phase).is_none() {
            return Err(RecordError::Phase(phase));
        }
        let level = (flags >> 17) & 0x3F;
        if level > MAX_LEVELS {
            return Err(RecordError::Level(level));
        }
        let dir = Vec3::new(f(3), f(4), f(5));
        let mut s = State {
            origin: Vec3::new(f(0), f(1), f(2)),
            dir,
            tmin: 0.0,
            t: f(7),
            slot: w(8),
            node: w(6),
            bits: w(9),
            flags: flags & (PHASE_MASK | ANY_BIT),
            inv_dir: RayBox::new(&Ray::new(Vec3::ZERO, dir, 0.0, 0.0)).inv_dir,
        };
        if (flags >> 16) & 1 == 1 {
            s.flags |= PENDING_BIT;
        }
        s.set_offset((flags >> 5) & 0xFF);
        s.set_level(level);
        Ok((s, w(10), ((flags >> 13) & 7) as u8))
    }
}

/// Start a traversal.
#[inline]
pub fn start<K: TriKernel>(d: &Data<'_, K>, ray: &Ray, query: Query) -> State {
    let rb = RayBox::new(ray);
    let mut s = State {
        origin: ray.origin,
        dir: ray.direction,
        tmin: ray.tmin,
        t: ray.tmax,
        slot: NONE,
        node: 0,
        bits: 0,
        flags: if query == Query::Any { ANY_BIT } else { 0 },
        inv_dir: rb.inv_dir,
    };
    s.set_phase(if d.nodes.is_empty() {
        Phase::Done
    } else {
        Phase::Root
    });
    s
}

/// The final hit: the barycentrics are recomputed from the hit triangle (see module docs).
#[inline]
fn final_hit<K: TriKernel>(d: &Data<'_, K>, s: &State) -> SlotHit {
    if s.slot == NONE {
        return SlotHit::miss(s.t);
    }
    let ray = Ray::new(s.origin, s.dir, s.tmin, f32::INFINITY);
    let (u, v) = K::intersect(&d.tris[s.slot as usize], &ray, s.tmin, f32::INFINITY)
        .map_or((1.0 / 3.0, 1.0 / 3.0), |h| (h.u, h.v));
    SlotHit {
        t: s.t,
        slot: s.slot,
        u,
        v,
    }
}

/// Whether `a` and `b` lie in different treelets (never without treelet ids).
#[inline(always)]
fn crosses<K: TriKernel>(d: &Data<'_, K>, a: u32, b: u32) -> bool {
    matches!((d.treelet(a), d.treelet(b)), (Some(x), Some(y)) if x != y)
}

/// Perform the next unit of work.
#[inline]
pub fn step<K: TriKernel>(d: &Data<'_, K>, s: &mut State, c: &mut RayCounters) -> Step {
    match s.phase() {
        Phase::Root => {
            c.box_tests += 1;
            let hit = slab_test(&s.ray_box(), &d.nodes[0].bounds, s.tmin, s.t).is_some();
            s.set_phase(if hit { Phase::Visit } else { Phase::Done });
            Step::RootBox { hit }
        }
        Phase::Visit => {
            let n = &d.nodes[s.node as usize];
            c.nodes_visited += 1;
            let leaf = n.is_leaf();
            if leaf {
                c.leaves_visited += 1;
                s.set_offset(0);
                s.set_phase(Phase::Triangles);
            } else {
                s.set_phase(Phase::Children);
            }
            Step::Node { node: s.node, leaf }
        }
        Phase::Children => {
            let left = d.nodes[s.node as usize].index;
            let right = left + 1;
            c.box_tests += 2;
            let rb = s.ray_box();
            let tl = slab_test(&rb, &d.nodes[left as usize].bounds, s.tmin, s.t);
            let tr = slab_test(&rb, &d.nodes[right as usize].bounds, s.tmin, s.t);
            let next = match (tl, tr) {
                // Both: push the first one's side.
                (Some(a), Some(b)) => Some(if !d.opts.nearest_first || a <= b {
                    (left, true)
                } else {
                    (right, false)
                }),
                // One: push the other side, so that coming back pops without a re-test.
                (Some(_), None) => Some((left, false)),
                (None, Some(_)) => Some((right, true)),
                (None, None) => None,
            };
            match next {
                Some((child, left_bit)) => {
                    s.node = child;
                    if left_bit {
                        s.flags |= PENDING_BIT;
                    } else {
                        s.flags &= !PENDING_BIT;
                    }
                    s.set_phase(Phase::Push);
                }
                None => s.set_phase(Phase::Up),
            }
            Step::ChildPair {
                left,
                hit: [tl.is_some(), tr.is_some()],
            }
        }
        Phase::Push => {
            s.bits = (s.bits << 1) | (s.flags & PENDING_BIT != 0) as u32;
            s.flags &= !PENDING_BIT;
            let level = s.level() + 1;
            s.set_level(level);
            c.stack_pushes += 1;
            c.max_stack = c.max_stack.max(level);
            // The child may lie in another treelet: cross before fetching its record.
            s.set_phase(if crosses(d, d.parents[s.node as usize], s.node) {
                Phase::CrossDown
            } else {
                Phase::Visit
            });
            Step::Push {
                node: NONE,
                depth: NONE,
                dropped: false,
            }
        }
        Phase::CrossDown | Phase::CrossUp => {
            // Sibling pairs share a treelet, so the treelet left is that of the node's
            // parent (down) or of the node's children (up).
            let from_node = if s.phase() == Phase::CrossDown {
                d.parents[s.node as usize]
            } else {
                d.nodes[s.node as usize].index
            };
            let (from, to) = (
                d.treelet(from_node).unwrap_or(0),
                d.treelet(s.node).unwrap_or(0),
            );
            c.treelet_crossings += 1;
            s.set_phase(if s.phase() == Phase::CrossDown {
                Phase::Visit
            } else {
                Phase::Up
            });
            Step::Treelet { from, to }
        }
        Phase::Triangles => {
            let leaf = &d.nodes[s.node as usize];
            let slot = leaf.index + s.offset();
            c.tri_tests += 1;
            let exit = match K::test(&d.tris[slot as usize], &s.ray(), s.tmin, s.t) {
                Ok(h) => {
                    s.t = h.t;
                    s.slot = slot;
                    HIT
                }
                Err(e) => e,
            };
            let hit = exit == HIT;
            if hit && s.flags & ANY_BIT != 0 && d.opts.early_exit {
                s.set_phase(Phase::Done);
            } else if s.offset() + 1 >= leaf.count {
                s.set_phase(Phase::Up);
            } else {
                s.set_offset(s.offset() + 1);
            }
            Step::Triangle { slot, hit, exit }
        }
        Phase::Up => {
            if s.node == 0 {
                // Leaving the root: finished.
                s.set_phase(Phase::Done);
                return Step::Done(final_hit(d, s));
            }
            let parent = d.parents[s.node as usize];
            c.parent_fetches += 1;
            // The top bit names the side visited first; if it is this node's side, the
            // sibling is still to do, if it can still hold a closer hit.
            let first_was_this = (s.bits & 1 == 1) == is_left(s.node);
            s.set_phase(if first_was_this {
                Phase::Retest
            } else {
                Phase::Pop
            });
            Step::Parent {
                node: s.node,
                parent,
            }
        }
        Phase::Retest => {
            let sib = sibling(s.node);
            c.box_tests += 1;
            c.sibling_retests += 1;
            let hit = slab_test(&s.ray_box(), &d.nodes[sib as usize].bounds, s.tmin, s.t).is_some();
            if hit {
                s.node = sib;
                s.set_phase(Phase::Visit);
            } else {
                s.set_phase(Phase::Pop);
            }
            Step::SiblingRetest { node: sib, hit }
        }
        Phase::Pop => {
            let child = s.node;
            let parent = d.parents[child as usize];
            s.bits >>= 1;
            s.set_level(s.level().saturating_sub(1));
            c.stack_pops += 1;
            s.node = parent;
            s.set_phase(if crosses(d, child, parent) {
                Phase::CrossUp
            } else {
                Phase::Up
            });
            Step::Pop {
                node: parent,
                depth: NONE,
                culled: false,
            }
        }
        Phase::Done => Step::Done(final_hit(d, s)),
    }
}
