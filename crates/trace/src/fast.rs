//! A faster path for `rtsim trace` and `rtsim bench`: an 8-wide BVH collapsed from the binary
//! one, with eight boxes (AVX where the CPU has it) or four triangles (SSE) tested per step.
//!
//! It answers exactly the same queries as the reference [`Tracer`](crate::Tracer) with the
//! Möller–Trumbore kernel: each triangle lane performs the same IEEE operations in the same
//! order as [`moller_trumbore`](crate::kernels::moller_trumbore), so hit distances and
//! barycentrics are bit-identical; only which of two triangles hit at exactly the same
//! distance (a shared edge) may differ, since the visiting order differs. It keeps no
//! counters: the reference path is the one whose counters hardware models reproduce.
//!
//! Layout: [`Node8`] holds its children's boxes as structure of arrays (256 bytes, four cache
//! lines); leaves point at runs of [`Tri4`] packets (four triangles as `v0, e1, e2` in
//! structure of arrays, padded with degenerate lanes that never hit). Subtrees of at most four
//! triangles become one leaf, since one packet test costs about one box test.

use crate::kernels::RayBox;
use crate::tracer::{Hit, NO_HIT};
use rtsim_bvh::Bvh;
use rtsim_core::{Ray, Vec3};
use std::mem::MaybeUninit;

/// Children per node.
const W: usize = 8;
const EMPTY: u32 = u32::MAX;
const LEAF: u32 = 1 << 31;
const COUNT_SHIFT: u32 = 25;
const COUNT_MASK: u32 = 0x3f;
const FIRST_MASK: u32 = (1 << COUNT_SHIFT) - 1;
/// Subtrees with at most this many triangles become one leaf (one full packet).
const MERGE_LEAVES: u32 = 4;
/// Traversal stack entries: at most `W - 1` per level, and levels are bounded by the binary
/// BVH's depth limit (`bvh.max_depth` ≤ 128).
const STACK: usize = 1024;

/// Eight children's boxes (structure of arrays) and their references.
///
/// `child[i]`: `EMPTY`, an inner node index, or `LEAF | (packets - 1) << 25 | first_packet`.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
pub struct Node8 {
    /// `bounds[axis][0]` = the children's minima, `bounds[axis][1]` = their maxima.
    bounds: [[[f32; W]; 2]; 3],
    child: [u32; W],
    /// Bit `i` set when lane `i` holds a child (empty lanes have inverted boxes, which the
    /// slab test would see as everything).
    valid: u32,
}

/// Four triangles as `v0`, `e1 = v1 - v0`, `e2 = v2 - v0` in structure of arrays, with their
/// scene ids (`NO_HIT` for padding lanes) in the same 160-byte record, so a hit needs no
/// further memory access.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(32))]
pub struct Tri4 {
    v0: [[f32; 4]; 3],
    e1: [[f32; 4]; 3],
    e2: [[f32; 4]; 3],
    ids: [u32; 4],
}

/// A BVH the fast path cannot collapse.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum FastBvhError {
    #[error("{0} triangles exceed the fast path's limit")]
    TooManyTriangles(usize),
    #[error("BVH node {0} does not point forward to its children")]
    Backward(usize),
    #[error("leaf of {0} triangles does not fit the fast path")]
    LeafTooLarge(usize),
}

/// The wide BVH.
#[derive(Clone, Debug, Default)]
pub struct FastBvh {
    nodes: Vec<Node8>,
    packets: Vec<Tri4>,
    /// The root is a leaf (a scene of one small leaf).
    root_leaf: Option<u32>,
    /// Present when the CPU has AVX: box tests take eight lanes at once.
    #[cfg(target_arch = "x86_64")]
    avx: Option<avx::Avx>,
}

impl FastBvh {
    /// Collapse `bvh` (built over `triangles`, scene order) into an 8-wide BVH.
    pub fn new(triangles: &[[Vec3; 3]], bvh: &Bvh) -> Result<FastBvh, FastBvhError> {
        let mut f = FastBvh {
            #[cfg(target_arch = "x86_64")]
            avx: avx::Avx::detect(),
            ..FastBvh::default()
        };
        if bvh.nodes.is_empty() {
            return Ok(f);
        }
        if bvh.prim_ids.len() >= (FIRST_MASK as usize) * 4 {
            return Err(FastBvhError::TooManyTriangles(bvh.prim_ids.len()));
        }
        let n = bvh.nodes.len();
        if let Some(i) = (0..n).find(|&i| {
            let c = bvh.nodes[i].index as usize;
            !bvh.nodes[i].is_leaf() && (c <= i || c + 1 >= n)
        }) {
            return Err(FastBvhError::Backward(i));
        }
        let sizes = subtree_sizes(bvh);
        let is_leaf = |k: usize| bvh.nodes[k].is_leaf() || sizes[k] <= MERGE_LEAVES;
        if is_leaf(0) {
            f.root_leaf = Some(f.leaf(triangles, bvh, 0)?);
            return Ok(f);
        }
        f.nodes.push(empty_node());
        // (wide node index, binary node whose children it takes)
        let mut work = vec![(0usize, 0usize)];
        while let Some((wi, bi)) = work.pop() {
            let kids = open_children(bvh, bi, &is_leaf);
            let mut node = empty_node();
            for (lane, &k) in kids.iter().enumerate() {
                let b = &bvh.nodes[k];
                for a in 0..3 {
                    node.bounds[a][0][lane] = b.bounds.min[a];
                    node.bounds[a][1][lane] = b.bounds.max[a];
                }
                node.valid |= 1 << lane;
                node.child[lane] = if is_leaf(k) {
                    f.leaf(triangles, bvh, k)?
                } else {
                    let ci = f.nodes.len();
                    f.nodes.push(empty_node());
                    work.push((ci, k));
                    ci as u32
                };
            }
            f.nodes[wi] = node;
        }
        Ok(f)
    }

    /// Pack the triangles of the subtree at `k` into consecutive packets; returns the child
    /// reference.
    fn leaf(&mut self, triangles: &[[Vec3; 3]], bvh: &Bvh, k: usize) -> Result<u32, FastBvhError> {
        let first = self.packets.len();
        let mut slots = Vec::new();
        let mut todo = vec![k];
        while let Some(i) = todo.pop() {
            let n = &bvh.nodes[i];
            if n.is_leaf() {
                slots.extend(n.index..n.index + n.count);
            } else {
                todo.push(n.index as usize + 1);
                todo.push(n.index as usize);
            }
        }
        for chunk in slots.chunks(4) {
            let mut p = Tri4 {
                v0: [[0.0; 4]; 3],
                e1: [[0.0; 4]; 3],
                e2: [[0.0; 4]; 3],
                ids: [NO_HIT; 4],
            };
            for (lane, &slot) in chunk.iter().enumerate() {
                let id = bvh.prim_ids[slot as usize];
                let t = &triangles[id as usize];
                let (e1, e2) = (t[1] - t[0], t[2] - t[0]);
                for a in 0..3 {
                    p.v0[a][lane] = t[0][a];
                    p.e1[a][lane] = e1[a];
                    p.e2[a][lane] = e2[a];
                }
                p.ids[lane] = id;
            }
            self.packets.push(p);
        }
        let count = self.packets.len() - first;
        if count == 0 || count > COUNT_MASK as usize + 1 {
            return Err(FastBvhError::LeafTooLarge(slots.len()));
        }
        Ok(LEAF | ((count as u32 - 1) << COUNT_SHIFT) | first as u32)
    }

    /// Closest hit with `tmin < t < tmax`.
    #[inline]
    pub fn closest_hit(&self, ray: &Ray) -> Hit {
        self.dispatch::<false>(ray)
    }

    /// Any hit with `tmin < t < tmax`.
    #[inline]
    pub fn any_hit(&self, ray: &Ray) -> bool {
        self.dispatch::<true>(ray).is_hit()
    }

    /// Any-hit query reporting the triangle that ended it.
    #[inline]
    pub fn any_hit_detail(&self, ray: &Ray) -> Hit {
        self.dispatch::<true>(ray)
    }

    #[inline]
    fn dispatch<const ANY: bool>(&self, ray: &Ray) -> Hit {
        #[cfg(target_arch = "x86_64")]
        if let Some(a) = self.avx {
            // SAFETY: an `Avx` exists only when the CPU reports AVX.
            return unsafe { self.traverse_avx::<ANY>(a, ray) };
        }
        self.traverse::<ANY, Portable>(&Portable, ray)
    }

    /// The traversal compiled with AVX enabled (the token proves the CPU has it).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx")]
    unsafe fn traverse_avx<const ANY: bool>(&self, a: avx::Avx, ray: &Ray) -> Hit {
        self.traverse::<ANY, avx::Avx>(&a, ray)
    }

    #[inline(always)]
    fn traverse<const ANY: bool, B: Box8>(&self, boxes: &B, ray: &Ray) -> Hit {
        let mut hit = Hit {
            t: ray.tmax,
            prim: NO_HIT,
            u: 0.0,
            v: 0.0,
        };
        if let Some(leaf) = self.root_leaf {
            self.leaf_test::<ANY>(leaf, ray, &mut hit);
            return hit;
        }
        if self.nodes.is_empty() {
            return hit;
        }
        let rb = RayBox::new(ray);
        // Per axis, which bound the ray meets first (1: the maximum, for negative directions).
        let near_side = [
            (rb.inv_dir.x < 0.0) as usize,
            (rb.inv_dir.y < 0.0) as usize,
            (rb.inv_dir.z < 0.0) as usize,
        ];
        // Uninitialised: zeroing 8 KB per ray would cost more than the traversal.
        let mut stack = [const { MaybeUninit::<(u32, f32)>::uninit() }; STACK];
        let mut sp = 0usize;
        let mut cur = 0u32;
        loop {
            // Inner node: eight box tests, then descend into the nearest hit child and push
            // the others far-to-near.
            let node = &self.nodes[cur as usize];
            let (mut mask, tnear) = boxes.test(node, &rb, &near_side, ray.tmin, hit.t);
            let mut next = None;
            if mask != 0 {
                let first = mask.trailing_zeros() as usize;
                mask &= mask - 1;
                if mask == 0 {
                    // One child hit: no sorting.
                    next = Some(node.child[first]);
                } else if ANY {
                    // Occlusion: any order finds a hit; skip sorting (as Embree's occluded
                    // traversal does).
                    while mask != 0 {
                        let lane = mask.trailing_zeros() as usize;
                        mask &= mask - 1;
                        stack[sp].write((node.child[lane], tnear[lane]));
                        sp += 1;
                    }
                    next = Some(node.child[first]);
                } else if mask & (mask - 1) == 0 {
                    // Two children hit (the common case): descend into the nearer, push the
                    // other (the lower lane first on ties, as the general sort).
                    let second = mask.trailing_zeros() as usize;
                    let (a, b) = (
                        (tnear[first], node.child[first]),
                        (tnear[second], node.child[second]),
                    );
                    let (near, far) = if b.0 < a.0 { (b, a) } else { (a, b) };
                    stack[sp].write((far.1, far.0));
                    sp += 1;
                    self.prefetch(far.1);
                    next = Some(near.1);
                } else {
                    let mut order = [(0f32, 0u32); W];
                    order[0] = (tnear[first], node.child[first]);
                    let mut n = 1;
                    while mask != 0 {
                        let lane = mask.trailing_zeros() as usize;
                        mask &= mask - 1;
                        // Insertion sort, nearest first (stable: lower lane first on ties).
                        let t = tnear[lane];
                        let mut j = n;
                        while j > 0 && order[j - 1].0 > t {
                            order[j] = order[j - 1];
                            j -= 1;
                        }
                        order[j] = (t, node.child[lane]);
                        n += 1;
                    }
                    for &(t, c) in order[1..n].iter().rev() {
                        stack[sp].write((c, t));
                        sp += 1;
                    }
                    // The next entry to pop is the second nearest child: start fetching it
                    // while the nearest subtree is traversed.
                    self.prefetch(order[1].1);
                    next = Some(order[0].1);
                }
            }
            let mut candidate = next;
            loop {
                let c = match candidate.take() {
                    Some(c) => c,
                    None => loop {
                        if sp == 0 {
                            return hit;
                        }
                        sp -= 1;
                        // SAFETY: entries below `sp` were written by the pushes above.
                        let (c, t) = unsafe { stack[sp].assume_init() };
                        // Inclusive, as in the reference traversal.
                        if t <= hit.t {
                            break c;
                        }
                    },
                };
                if c & LEAF == 0 {
                    cur = c;
                    break;
                }
                self.leaf_test::<ANY>(c, ray, &mut hit);
                if ANY && hit.is_hit() {
                    return hit;
                }
            }
        }
    }

    /// Hint the cache to fetch the record of child reference `c` (a node or a leaf's first
    /// packet).
    #[inline(always)]
    fn prefetch(&self, c: u32) {
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
            let (ptr, lines) = if c & LEAF == 0 {
                (self.nodes.as_ptr().wrapping_add(c as usize) as *const i8, 4)
            } else {
                (
                    self.packets
                        .as_ptr()
                        .wrapping_add((c & FIRST_MASK) as usize) as *const i8,
                    3,
                )
            };
            for l in 0..lines {
                // SAFETY: prefetching is a hint and never faults, even for a bad address.
                unsafe { _mm_prefetch::<_MM_HINT_T0>(ptr.wrapping_add(64 * l)) };
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        let _ = c;
    }

    #[inline(always)]
    fn leaf_test<const ANY: bool>(&self, c: u32, ray: &Ray, hit: &mut Hit) {
        let first = (c & FIRST_MASK) as usize;
        let count = ((c >> COUNT_SHIFT) & COUNT_MASK) as usize + 1;
        for p in first..first + count {
            if let Some((lane, t, u, v)) = tri4(&self.packets[p], ray, ray.tmin, hit.t) {
                *hit = Hit {
                    t,
                    prim: self.packets[p].ids[lane],
                    u,
                    v,
                };
                if ANY {
                    return;
                }
            }
        }
    }
}

fn empty_node() -> Node8 {
    Node8 {
        bounds: [[[f32::INFINITY; W], [f32::NEG_INFINITY; W]]; 3],
        child: [EMPTY; W],
        valid: 0,
    }
}

/// Triangles under each binary node.
fn subtree_sizes(bvh: &Bvh) -> Vec<u32> {
    let mut sizes = vec![0u32; bvh.nodes.len()];
    // Children follow their parent (checked by the caller), so a reverse sweep sees children
    // first.
    for i in (0..bvh.nodes.len()).rev() {
        let n = &bvh.nodes[i];
        sizes[i] = if n.is_leaf() {
            n.count
        } else {
            sizes[n.index as usize].saturating_add(sizes[n.index as usize + 1])
        };
    }
    sizes
}

/// Up to eight binary nodes covering the children of inner node `bi`: open the inner child
/// with the largest surface area until there are eight or only leaves remain.
fn open_children(bvh: &Bvh, bi: usize, is_leaf: &dyn Fn(usize) -> bool) -> Vec<usize> {
    let n = &bvh.nodes[bi];
    let mut kids = vec![n.index as usize, n.index as usize + 1];
    while kids.len() < W {
        let best = kids
            .iter()
            .enumerate()
            .filter(|(_, k)| !is_leaf(**k))
            .max_by(|a, b| {
                let area = |k: usize| bvh.nodes[k].bounds.surface_area();
                area(*a.1).total_cmp(&area(*b.1))
            })
            .map(|(i, _)| i);
        let Some(i) = best else { break };
        let c = bvh.nodes[kids[i]].index as usize;
        kids.splice(i..=i, [c, c + 1]);
    }
    kids
}

/// Eight slab tests: the hit mask and the entry distances. Same arithmetic per lane as
/// [`slab_test`](crate::kernels::slab_test).
///
/// `near_side[a]` says which bound the ray meets first on axis `a`: 0 (the minimum) for a
/// positive direction, 1 (the maximum) for a negative one. Since `(min - o) · inv <=
/// (max - o) · inv` for `inv >= 0` (rounding is monotonic), reading the near and far bounds
/// directly gives exactly the slab test's `min(t0, t1)` and `max(t0, t1)`.
///
/// The method takes `&self` so that an implementation can demand proof of what it needs:
/// a value of [`avx::Avx`] exists only after the CPU was found to have AVX.
trait Box8 {
    fn test(
        &self,
        n: &Node8,
        r: &RayBox,
        near_side: &[usize; 3],
        tmin: f32,
        tmax: f32,
    ) -> (u32, [f32; W]);
}

/// Scalar lanes: the reference for the AVX version and the path without AVX.
struct Portable;

impl Box8 for Portable {
    #[inline(always)]
    fn test(
        &self,
        n: &Node8,
        r: &RayBox,
        _near_side: &[usize; 3],
        tmin: f32,
        tmax: f32,
    ) -> (u32, [f32; W]) {
        let mut near = [tmin; W];
        let mut far = [tmax; W];
        for a in 0..3 {
            let (o, inv) = (r.origin[a], r.inv_dir[a]);
            for l in 0..W {
                let t0 = (n.bounds[a][0][l] - o) * inv;
                let t1 = (n.bounds[a][1][l] - o) * inv;
                near[l] = near[l].max(t0.min(t1));
                far[l] = far[l].min(t0.max(t1));
            }
        }
        let mut mask = 0;
        for l in 0..W {
            mask |= ((near[l] <= far[l]) as u32) << l;
        }
        (mask & n.valid, near)
    }
}

/// AVX lanes. IEEE add, sub and mul are exact in every lane; min/max agree with the scalar
/// ones because no NaN can arise (inverse directions are finite, bounds finite or ±inf).
#[cfg(target_arch = "x86_64")]
mod avx {
    use super::*;
    use std::arch::x86_64::*;

    /// Proof that the CPU has AVX: the only way to make one is [`Avx::detect`], so holding
    /// one makes the AVX code safe to call (sound by construction).
    #[derive(Clone, Copy, Debug)]
    pub(super) struct Avx {
        _proof: (),
    }

    impl Avx {
        /// `Some` exactly when the CPU reports AVX.
        pub(super) fn detect() -> Option<Avx> {
            std::arch::is_x86_feature_detected!("avx").then_some(Avx { _proof: () })
        }
    }

    impl Box8 for Avx {
        #[inline(always)]
        fn test(
            &self,
            n: &Node8,
            r: &RayBox,
            near_side: &[usize; 3],
            tmin: f32,
            tmax: f32,
        ) -> (u32, [f32; W]) {
            // SAFETY: `self` exists only if `Avx::detect` found AVX; `Node8` is 64-byte
            // aligned and its arrays start at multiples of 32 bytes.
            unsafe { box8(n, r, near_side, tmin, tmax) }
        }
    }

    #[inline]
    #[target_feature(enable = "avx")]
    unsafe fn box8(
        n: &Node8,
        r: &RayBox,
        near_side: &[usize; 3],
        tmin: f32,
        tmax: f32,
    ) -> (u32, [f32; W]) {
        unsafe {
            let mut near = _mm256_set1_ps(tmin);
            let mut far = _mm256_set1_ps(tmax);
            for (a, &side) in near_side.iter().enumerate() {
                let o = _mm256_set1_ps(r.origin[a]);
                let inv = _mm256_set1_ps(r.inv_dir[a]);
                let side = side & 1;
                let lo = &n.bounds[a][side];
                let hi = &n.bounds[a][side ^ 1];
                let t0 = _mm256_mul_ps(_mm256_sub_ps(_mm256_load_ps(lo.as_ptr()), o), inv);
                let t1 = _mm256_mul_ps(_mm256_sub_ps(_mm256_load_ps(hi.as_ptr()), o), inv);
                near = _mm256_max_ps(near, t0);
                far = _mm256_min_ps(far, t1);
            }
            let mask = _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(near, far)) as u32 & n.valid;
            let mut out = [0f32; W];
            _mm256_storeu_ps(out.as_mut_ptr(), near);
            (mask, out)
        }
    }
}

/// Möller–Trumbore on four triangles; the nearest valid lane (lowest lane on ties).
#[inline(always)]
fn tri4(p: &Tri4, ray: &Ray, tmin: f32, tmax: f32) -> Option<(usize, f32, f32, f32)> {
    #[cfg(target_arch = "x86_64")]
    {
        // SAFETY: SSE2 is part of the x86_64 baseline; loads are from 16-byte aligned arrays.
        unsafe { sse::tri4(p, ray, tmin, tmax) }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        portable_tri4(p, ray, tmin, tmax)
    }
}

/// Scalar lanes: same operations, same order as `moller_trumbore`.
#[cfg_attr(target_arch = "x86_64", allow(dead_code))]
fn portable_tri4(p: &Tri4, ray: &Ray, tmin: f32, tmax: f32) -> Option<(usize, f32, f32, f32)> {
    let (o, d) = (ray.origin, ray.direction);
    let mut best: Option<(usize, f32, f32, f32)> = None;
    for l in 0..4 {
        let (e1x, e1y, e1z) = (p.e1[0][l], p.e1[1][l], p.e1[2][l]);
        let (e2x, e2y, e2z) = (p.e2[0][l], p.e2[1][l], p.e2[2][l]);
        let px = d.y * e2z - d.z * e2y;
        let py = d.z * e2x - d.x * e2z;
        let pz = d.x * e2y - d.y * e2x;
        let det = e1x * px + e1y * py + e1z * pz;
        let inv = 1.0 / det;
        let sx = o.x - p.v0[0][l];
        let sy = o.y - p.v0[1][l];
        let sz = o.z - p.v0[2][l];
        let u = (sx * px + sy * py + sz * pz) * inv;
        let qx = sy * e1z - sz * e1y;
        let qy = sz * e1x - sx * e1z;
        let qz = sx * e1y - sy * e1x;
        let v = (d.x * qx + d.y * qy + d.z * qz) * inv;
        let t = (e2x * qx + e2y * qy + e2z * qz) * inv;
        let ok = det != 0.0
            && (0.0..=1.0).contains(&u)
            && v >= 0.0
            && u + v <= 1.0
            && t > tmin
            && t < tmax;
        if ok && best.is_none_or(|b| t < b.1) {
            best = Some((l, t, u, v));
        }
    }
    best
}

#[cfg(target_arch = "x86_64")]
mod sse {
    use super::*;
    use std::arch::x86_64::*;

    #[inline(always)]
    unsafe fn ld(a: &[f32; 4]) -> __m128 {
        // SAFETY: `Tri4`'s arrays are 16-byte aligned.
        unsafe { _mm_load_ps(a.as_ptr()) }
    }

    /// SSE2 lanes of `portable_tri4`: IEEE operations are exact per lane, so results are
    /// bit-identical.
    #[inline(always)]
    pub(super) unsafe fn tri4(
        p: &Tri4,
        ray: &Ray,
        tmin: f32,
        tmax: f32,
    ) -> Option<(usize, f32, f32, f32)> {
        unsafe {
            let (o, d) = (ray.origin, ray.direction);
            let (dx, dy, dz) = (_mm_set1_ps(d.x), _mm_set1_ps(d.y), _mm_set1_ps(d.z));
            let (e1x, e1y, e1z) = (ld(&p.e1[0]), ld(&p.e1[1]), ld(&p.e1[2]));
            let (e2x, e2y, e2z) = (ld(&p.e2[0]), ld(&p.e2[1]), ld(&p.e2[2]));
            let px = _mm_sub_ps(_mm_mul_ps(dy, e2z), _mm_mul_ps(dz, e2y));
            let py = _mm_sub_ps(_mm_mul_ps(dz, e2x), _mm_mul_ps(dx, e2z));
            let pz = _mm_sub_ps(_mm_mul_ps(dx, e2y), _mm_mul_ps(dy, e2x));
            let dot = |ax, ay, az, bx, by, bz| {
                _mm_add_ps(
                    _mm_add_ps(_mm_mul_ps(ax, bx), _mm_mul_ps(ay, by)),
                    _mm_mul_ps(az, bz),
                )
            };
            let det = dot(e1x, e1y, e1z, px, py, pz);
            let inv = _mm_div_ps(_mm_set1_ps(1.0), det);
            let sx = _mm_sub_ps(_mm_set1_ps(o.x), ld(&p.v0[0]));
            let sy = _mm_sub_ps(_mm_set1_ps(o.y), ld(&p.v0[1]));
            let sz = _mm_sub_ps(_mm_set1_ps(o.z), ld(&p.v0[2]));
            let u = _mm_mul_ps(dot(sx, sy, sz, px, py, pz), inv);
            let zero = _mm_setzero_ps();
            let one = _mm_set1_ps(1.0);
            // Staged: most lanes fail on u, so test it before computing v and t (the values
            // and the acceptance rule are unchanged, only evaluated lazily).
            let ok_u = _mm_and_ps(
                _mm_cmpneq_ps(det, zero),
                _mm_and_ps(_mm_cmpge_ps(u, zero), _mm_cmple_ps(u, one)),
            );
            if _mm_movemask_ps(ok_u) == 0 {
                return None;
            }
            let qx = _mm_sub_ps(_mm_mul_ps(sy, e1z), _mm_mul_ps(sz, e1y));
            let qy = _mm_sub_ps(_mm_mul_ps(sz, e1x), _mm_mul_ps(sx, e1z));
            let qz = _mm_sub_ps(_mm_mul_ps(sx, e1y), _mm_mul_ps(sy, e1x));
            let v = _mm_mul_ps(dot(dx, dy, dz, qx, qy, qz), inv);
            let ok_uv = _mm_and_ps(
                ok_u,
                _mm_and_ps(_mm_cmpge_ps(v, zero), _mm_cmple_ps(_mm_add_ps(u, v), one)),
            );
            if _mm_movemask_ps(ok_uv) == 0 {
                return None;
            }
            let t = _mm_mul_ps(dot(e2x, e2y, e2z, qx, qy, qz), inv);
            let ok = _mm_and_ps(
                ok_uv,
                _mm_and_ps(
                    _mm_cmpgt_ps(t, _mm_set1_ps(tmin)),
                    _mm_cmplt_ps(t, _mm_set1_ps(tmax)),
                ),
            );
            let okm = _mm_movemask_ps(ok) as u32;
            if okm == 0 {
                return None;
            }
            let mut ts = [0f32; 4];
            _mm_storeu_ps(ts.as_mut_ptr(), t);
            // Nearest valid lane, lowest lane on ties (as the scalar loop).
            let mut best = okm.trailing_zeros() as usize;
            let mut rest = okm & (okm - 1);
            while rest != 0 {
                let l = rest.trailing_zeros() as usize;
                if ts[l] < ts[best] {
                    best = l;
                }
                rest &= rest - 1;
            }
            let (mut us, mut vs) = ([0f32; 4], [0f32; 4]);
            _mm_storeu_ps(us.as_mut_ptr(), u);
            _mm_storeu_ps(vs.as_mut_ptr(), v);
            Some((best, ts[best], us[best], vs[best]))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::TraceConfig;
    use crate::counters::RayCounters;
    use crate::testutil::{median_bvh, random_rays, random_soup};
    use crate::tracer::Tracer;

    #[test]
    fn matches_reference_bit_for_bit() {
        let tris = random_soup(3000, 31, 1.5);
        let rays = random_rays(4000, 32);
        for leaf in [1, 3, 4, 9] {
            let bvh = median_bvh(&tris, leaf);
            let fast = FastBvh::new(&tris, &bvh).unwrap();
            let reference = Tracer::new(&tris, bvh, &TraceConfig::default()).unwrap();
            for r in &rays {
                let a = reference.closest_hit(r, &mut RayCounters::default());
                let b = fast.closest_hit(r);
                assert_eq!(a.is_hit(), b.is_hit());
                if a.is_hit() {
                    assert_eq!(a.t.to_bits(), b.t.to_bits(), "leaf {leaf}");
                    if a.prim == b.prim {
                        assert_eq!(
                            (a.u.to_bits(), a.v.to_bits()),
                            (b.u.to_bits(), b.v.to_bits())
                        );
                    }
                }
                assert_eq!(
                    reference.any_hit(r, &mut RayCounters::default()),
                    fast.any_hit(r)
                );
            }
        }
    }

    #[test]
    fn simd_lanes_equal_scalar_lanes() {
        let tris = random_soup(4000, 41, 2.0);
        let rays = random_rays(3000, 42);
        let mut fast = FastBvh::new(&tris, &median_bvh(&tris, 4)).unwrap();
        for r in &rays {
            #[cfg(target_arch = "x86_64")]
            if let Some(a) = fast.avx {
                let rb = RayBox::new(r);
                for n in &fast.nodes {
                    let side = [0, 1, 2].map(|a| (rb.inv_dir[a] < 0.0) as usize);
                    let (mask, near) = a.test(n, &rb, &side, r.tmin, r.tmax);
                    let (pmask, pnear) = Portable.test(n, &rb, &side, r.tmin, r.tmax);
                    assert_eq!(mask, pmask);
                    // Entry distances matter only for lanes that were hit.
                    for l in (0..W).filter(|l| mask & (1 << l) != 0) {
                        assert_eq!(near[l].to_bits(), pnear[l].to_bits());
                    }
                }
            }
            for p in fast.packets.iter().take(300) {
                assert_eq!(
                    tri4(p, r, r.tmin, r.tmax),
                    portable_tri4(p, r, r.tmin, r.tmax)
                );
            }
        }
        // The portable traversal gives the same answers as the AVX one.
        let reference = fast.clone();
        #[cfg(target_arch = "x86_64")]
        {
            fast.avx = None;
        }
        for r in &rays {
            assert_eq!(fast.closest_hit(r), reference.closest_hit(r));
        }
    }

    #[test]
    fn tiny_scenes() {
        let tris = random_soup(3, 1, 5.0);
        let rays = random_rays(500, 2);
        let bvh = median_bvh(&tris, 4); // a single leaf
        let fast = FastBvh::new(&tris, &bvh).unwrap();
        let reference = Tracer::new(&tris, bvh, &TraceConfig::default()).unwrap();
        for r in &rays {
            assert_eq!(
                fast.closest_hit(r),
                reference.closest_hit(r, &mut RayCounters::default())
            );
        }
        let empty = FastBvh::new(&[], &median_bvh(&[], 4)).unwrap();
        assert!(!empty.closest_hit(&rays[0]).is_hit());
    }
}
