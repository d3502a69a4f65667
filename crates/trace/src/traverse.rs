//! The reference traversal: binary BVH, stack-based, with per-ray counters.
//!
//! This is the oracle path. It stays even where `render` and `trace` use a faster one; hardware
//! models running the baseline variant must reproduce its hits and its [`RayCounters`].
//!
//! Algorithm (one short comment per step below): test the root box; at an inner node test both
//! children's boxes against `[tmin, closest t]`; if both are hit, descend into the nearer one
//! (or the left one, for `left-first`) and push the other with its entry distance; at a leaf,
//! test its triangles, shrinking the interval on every hit; then pop, discarding entries whose
//! entry distance is beyond the closest hit.

use crate::counters::RayCounters;
use crate::kernels::{RayBox, TriKernel, slab_test};
use rtsim_bvh::Node;
use rtsim_core::Ray;
use std::mem::MaybeUninit;

/// Deepest stack the traversal supports; BVH depth is validated against it (`bvh.max_depth`
/// is at most 128, and a stack never holds more entries than the tree has levels).
pub const STACK_SIZE: usize = 256;

/// Result of a traversal in BVH triangle slots (`slot == u32::MAX`: no hit).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SlotHit {
    pub t: f32,
    pub slot: u32,
    pub u: f32,
    pub v: f32,
}

impl SlotHit {
    #[inline(always)]
    pub fn miss(tmax: f32) -> Self {
        SlotHit {
            t: tmax,
            slot: u32::MAX,
            u: 0.0,
            v: 0.0,
        }
    }
    #[inline(always)]
    pub fn is_hit(&self) -> bool {
        self.slot != u32::MAX
    }
}

/// Traversal options fixed per frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TraverseOptions {
    /// Visit the nearer child first (else always the left one).
    pub nearest_first: bool,
    /// For any-hit queries: stop at the first hit.
    pub early_exit: bool,
}

/// Traverse `nodes` with triangle records `tris` (BVH slot order). `ANY`: occlusion query.
/// `treelets`: the treelet id of every node, to count treelet crossings, or empty.
#[inline]
pub fn traverse<K: TriKernel, const ANY: bool>(
    nodes: &[Node],
    tris: &[K::Data],
    treelets: &[u32],
    ray: &Ray,
    opts: TraverseOptions,
    c: &mut RayCounters,
) -> SlotHit {
    let mut hit = SlotHit::miss(ray.tmax);
    let Some(root) = nodes.first() else {
        return hit;
    };
    let rb = RayBox::new(ray);
    // The root's box.
    c.box_tests += 1;
    if slab_test(&rb, &root.bounds, ray.tmin, hit.t).is_none() {
        return hit;
    }
    // Uninitialised: zeroing the whole stack per ray would cost more than short traversals.
    let mut stack = [const { MaybeUninit::<(u32, f32)>::uninit() }; STACK_SIZE];
    let mut sp = 0usize;
    let mut node = 0u32;
    let mut treelet = treelets.first().copied().unwrap_or(0);
    loop {
        if let Some(&t) = treelets.get(node as usize) {
            // Moving into another treelet (STRaTA would park the ray in that treelet's buffer).
            if t != treelet {
                c.treelet_crossings += 1;
                treelet = t;
            }
        }
        let n = &nodes[node as usize];
        c.nodes_visited += 1;
        if n.is_leaf() {
            // Leaf: test its triangles, shrinking the interval at each hit.
            c.leaves_visited += 1;
            for slot in n.index..n.index + n.count {
                c.tri_tests += 1;
                if let Some(h) = K::intersect(&tris[slot as usize], ray, ray.tmin, hit.t) {
                    hit = SlotHit {
                        t: h.t,
                        slot,
                        u: h.u,
                        v: h.v,
                    };
                    if ANY && opts.early_exit {
                        return hit;
                    }
                }
            }
        } else {
            // Inner node: test both children against the current interval.
            let (li, ri) = (n.index, n.index + 1);
            c.box_tests += 2;
            let tl = slab_test(&rb, &nodes[li as usize].bounds, ray.tmin, hit.t);
            let tr = slab_test(&rb, &nodes[ri as usize].bounds, ray.tmin, hit.t);
            match (tl, tr) {
                (Some(a), Some(b)) => {
                    // Both hit: descend into the first, defer the other with its entry distance.
                    let (first, second, t_second) = if !opts.nearest_first || a <= b {
                        (li, ri, b)
                    } else {
                        (ri, li, a)
                    };
                    stack[sp].write((second, t_second));
                    sp += 1;
                    c.stack_pushes += 1;
                    c.max_stack = c.max_stack.max(sp as u32);
                    node = first;
                    continue;
                }
                (Some(_), None) => {
                    node = li;
                    continue;
                }
                (None, Some(_)) => {
                    node = ri;
                    continue;
                }
                (None, None) => {}
            }
        }
        // Pop the next deferred subtree that can still hold a closer hit.
        loop {
            if sp == 0 {
                return hit;
            }
            sp -= 1;
            c.stack_pops += 1;
            // SAFETY: entries below `sp` were written by the pushes above.
            let (n, t_entry) = unsafe { stack[sp].assume_init() };
            // Inclusive, as the box test is (`near <= far` with far clipped at the closest
            // hit): a box entered exactly at the closest distance can still hold a closer hit
            // after rounding, and every variant must make the same decision here.
            if t_entry <= hit.t {
                node = n;
                break;
            }
            c.stack_culls += 1;
        }
    }
}
