//! Binned SAH builder (Wald, "On fast Construction of SAH-based Bounding Volume Hierarchies",
//! IEEE RT 2007).
//!
//! Per node: bin the triangles' centroids into `bins` equal intervals of the centroid bounds
//! on each axis (one pass, all three axes at once), sweep the bins for the cheapest plane, then
//! partition the triangle references in place (Hoare style), collecting each side's centroid
//! bounds on the way. Child boxes come from the bins. Large nodes bin in parallel chunks whose
//! bins are merged exactly (box min/max, integer counts); subtrees above
//! `parallel_threshold` are built with `rayon::join`.

use super::arena::{BuildTree, InnerSlot, LEAF};
use super::box4::Box4;
use super::{Decision, NodeRule, better, choose, key_cmp, widest_axis};
use crate::config::BvhConfig;
use rayon::prelude::*;
use rtsim_core::Aabb;

/// A triangle reference: its box with the scene id in lane 3 of `lo`, 32 bytes so two never
/// straddle a line.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(32))]
pub(crate) struct PrimRef {
    b: Box4,
}

impl PrimRef {
    fn new(b: &Aabb, id: u32) -> Self {
        let mut b = Box4::from_aabb(b);
        b.lo[3] = f32::from_bits(id);
        PrimRef { b }
    }
    #[inline(always)]
    fn id(&self) -> u32 {
        self.b.lo[3].to_bits()
    }
    /// Twice the box centre (the factor 2 cancels in every comparison and saves a multiply).
    #[inline(always)]
    fn c2(&self) -> [f32; 4] {
        let mut c = [0.0; 4];
        for (i, c) in c.iter_mut().enumerate() {
            *c = self.b.lo[i] + self.b.hi[i];
        }
        c
    }
}

/// Bin index transform of one node: bin `k = floor((c − cmin)·scale)` per axis, clamped.
#[derive(Clone, Copy, Debug)]
struct Binning {
    cmin: [f32; 4],
    /// 0 on axes that cannot be binned (zero or denormal extent): everything lands in bin 0.
    scale: [f32; 3],
    usable: [bool; 3],
    bins: usize,
}

impl Binning {
    fn new(cb: &Box4, bins: usize) -> Self {
        let mut scale = [0.0f32; 3];
        let mut usable = [false; 3];
        for a in 0..3 {
            let extent = cb.hi[a] - cb.lo[a];
            let s = bins as f32 / extent;
            if extent > 0.0 && s.is_finite() {
                scale[a] = s;
                usable[a] = true;
            }
        }
        Binning {
            cmin: cb.lo,
            scale,
            usable,
            bins,
        }
    }

    /// The one formula for a bin index, used by binning and by the partition so both agree
    /// bit for bit. `as i32` saturates (NaN gives 0) and is one instruction cheaper than a
    /// conversion to `usize`, which profiling showed in the hottest loop.
    #[inline(always)]
    fn bin(&self, c: f32, axis: usize) -> usize {
        (((c - self.cmin[axis]) * self.scale[axis]) as i32).clamp(0, self.bins as i32 - 1) as usize
    }
}

/// Per-axis bins: `bounds[axis * bins + k]`, `counts[axis * bins + k]`.
#[derive(Clone, Debug)]
struct Bins {
    bins: usize,
    bounds: Vec<Box4>,
    counts: Vec<u32>,
}

impl Bins {
    fn new(bins: usize) -> Self {
        Bins {
            bins,
            bounds: vec![Box4::EMPTY; 3 * bins],
            counts: vec![0; 3 * bins],
        }
    }

    /// Empty every bin (only the used ones need writing).
    fn reset(&mut self) {
        for (b, c) in self.bounds.iter_mut().zip(&mut self.counts) {
            if *c != 0 {
                *b = Box4::EMPTY;
                *c = 0;
            }
        }
    }

    fn add(&mut self, prims: &[PrimRef], t: &Binning) {
        let nb = self.bins;
        for p in prims {
            let c = p.c2();
            for (a, &ca) in c[..3].iter().enumerate() {
                let k = a * nb + t.bin(ca, a);
                self.bounds[k] = self.bounds[k].union(p.b);
                self.counts[k] += 1;
            }
        }
    }

    /// Exact merge: box unions and counts do not depend on the order of chunks.
    fn merge(&mut self, o: &Bins) {
        for (a, b) in self.bounds.iter_mut().zip(&o.bounds) {
            *a = a.union(*b);
        }
        for (a, b) in self.counts.iter_mut().zip(&o.counts) {
            *a += b;
        }
    }

    fn range_bounds(&self, axis: usize, range: std::ops::Range<usize>) -> Box4 {
        self.bounds[axis * self.bins..][range]
            .iter()
            .fold(Box4::EMPTY, |acc, b| acc.union(*b))
    }
}

#[derive(Clone, Copy, Debug)]
struct Best {
    /// `A_L·n_L + A_R·n_R`.
    weighted: f32,
    /// `|n_L − n_R|`, the tie-break.
    imbalance: u32,
    axis: usize,
    /// First bin of the right child.
    bin: usize,
}

/// Per-task scratch, reused down a sequential recursion so the hot path allocates nothing.
#[derive(Debug)]
struct Scratch {
    bins: Bins,
    /// Indices of the non-empty bins of one axis.
    nonempty: Vec<u32>,
    /// Indexed like `nonempty`.
    right_area: Vec<f32>,
    right_count: Vec<u32>,
}

impl Scratch {
    fn new(bins: usize) -> Self {
        Scratch {
            bins: Bins::new(bins),
            nonempty: Vec::with_capacity(bins),
            right_area: vec![0.0; bins],
            right_count: vec![0; bins],
        }
    }

    /// Cheapest valid plane over all usable axes; ties go to the more balanced split, then the
    /// lower axis, then the lower bin.
    ///
    /// Only non-empty bins are visited: every plane between two consecutive non-empty bins
    /// gives the same partition and cost, and the lowest of them is the one the full sweep
    /// would keep. Small nodes (most of a tree) thus cost O(n), not O(bins).
    fn best(&mut self, t: &Binning, rule: &NodeRule) -> Option<Best> {
        let nb = self.bins.bins;
        let mut best: Option<Best> = None;
        for axis in (0..3).filter(|&a| t.usable[a]) {
            let bounds = &self.bins.bounds[axis * nb..(axis + 1) * nb];
            let counts = &self.bins.counts[axis * nb..(axis + 1) * nb];
            self.nonempty.clear();
            self.nonempty
                .extend((0..nb as u32).filter(|&k| counts[k as usize] != 0));
            let ne = &self.nonempty;
            let (mut acc, mut cnt) = (Box4::EMPTY, 0u32);
            for j in (1..ne.len()).rev() {
                let k = ne[j] as usize;
                acc = acc.union(bounds[k]);
                cnt += counts[k];
                self.right_area[j] = acc.surface_area();
                self.right_count[j] = cnt;
            }
            let (mut acc, mut cnt) = (Box4::EMPTY, 0u32);
            for j in 1..ne.len() {
                let k = ne[j - 1] as usize;
                acc = acc.union(bounds[k]);
                cnt += counts[k];
                let rc = self.right_count[j];
                if !rule.fits(cnt as usize, rc as usize) {
                    continue;
                }
                let w = acc.surface_area() * cnt as f32 + self.right_area[j] * rc as f32;
                let imbalance = cnt.abs_diff(rc);
                if best.is_none_or(|b| better(w, imbalance, b.weighted, b.imbalance)) {
                    best = Some(Best {
                        weighted: w,
                        imbalance,
                        axis,
                        bin: k + 1,
                    });
                }
            }
        }
        best
    }
}

struct Ctx<'a> {
    config: &'a BvhConfig,
    bins: usize,
    /// Subtrees with at least this many triangles fork.
    par_min: usize,
    /// Nodes with at least this many triangles bin in parallel chunks of `chunk`.
    par_bin_min: usize,
    chunk: usize,
}

pub(crate) fn build(
    n: usize,
    config: &BvhConfig,
    prim_box: &(impl Fn(usize) -> Aabb + Sync),
) -> BuildTree {
    debug_assert!(n > 0, "build_tree handles the empty scene");
    let mut prims: Vec<PrimRef> = (0..n)
        .into_par_iter()
        .map(|i| PrimRef::new(&prim_box(i), i as u32))
        .collect();
    let (bounds, cb) = prims
        .par_iter()
        .map(|p| {
            (
                p.b,
                Box4 {
                    lo: p.c2(),
                    hi: p.c2(),
                },
            )
        })
        .reduce(
            || (Box4::EMPTY, Box4::EMPTY),
            |a, b| (a.0.union(b.0), a.1.union(b.1)),
        );
    let threshold = config.parallel_threshold as usize;
    let ctx = Ctx {
        config,
        bins: config.bins as usize,
        par_min: threshold,
        par_bin_min: threshold.saturating_mul(4),
        chunk: threshold,
    };
    let mut inner = vec![InnerSlot::UNUSED; n];
    let mut scratch = Scratch::new(ctx.bins);
    let root_split = node(&ctx, &mut prims, &mut inner, 0, bounds, cb, 0, &mut scratch);
    BuildTree {
        root_bounds: bounds.to_aabb(),
        root_split,
        inner,
        prims: prims.iter().map(|p| p.id()).collect(),
    }
}

/// Build the subtree over `prims` (absolute start `start`), writing its inner nodes into
/// `inner` (the arena slots `start .. start + n`). Returns its split position or [`LEAF`].
#[allow(clippy::too_many_arguments)]
fn node(
    ctx: &Ctx<'_>,
    prims: &mut [PrimRef],
    inner: &mut [InnerSlot],
    start: u32,
    bounds: Box4,
    cb: Box4,
    depth: u32,
    scratch: &mut Scratch,
) -> u32 {
    let n = prims.len();
    let rule = NodeRule::new(ctx.config, n, depth);
    if rule.leaf_forced {
        return LEAF;
    }
    let t = Binning::new(&cb, ctx.bins);
    if n >= ctx.par_bin_min {
        scratch.bins = prims
            .par_chunks(ctx.chunk)
            .map(|chunk| {
                let mut b = Bins::new(ctx.bins);
                b.add(chunk, &t);
                b
            })
            .reduce_with(|mut a, b| {
                a.merge(&b);
                a
            })
            .expect("a node has at least one triangle");
    } else {
        scratch.bins.reset();
        scratch.bins.add(prims, &t);
    }
    let best = scratch.best(&t, &rule);
    let decision = choose(
        ctx.config,
        &rule,
        n,
        bounds.surface_area(),
        best.map(|b| b.weighted),
    );
    let (m, lb, rb, lcb, rcb) = match (decision, best) {
        (Decision::Leaf, _) => return LEAF,
        (Decision::Split, Some(b)) => {
            let (m, lcb, rcb) = partition(prims, &t, b.axis, b.bin);
            debug_assert_eq!(
                m as u32,
                scratch.bins.counts[b.axis * ctx.bins..][..b.bin]
                    .iter()
                    .sum::<u32>()
            );
            let lb = scratch.bins.range_bounds(b.axis, 0..b.bin);
            let rb = scratch.bins.range_bounds(b.axis, b.bin..ctx.bins);
            (m, lb, rb, lcb, rcb)
        }
        _ => median(prims, &cb),
    };

    let abs_m = start + m as u32;
    let (prims_l, prims_r) = prims.split_at_mut(m);
    let (inner_l, inner_r) = inner.split_at_mut(m);
    let (ls, rs) = if n >= ctx.par_min {
        rayon::join(
            || node(ctx, prims_l, inner_l, start, lb, lcb, depth + 1, scratch),
            || {
                let mut s = Scratch::new(ctx.bins);
                node(ctx, prims_r, inner_r, abs_m, rb, rcb, depth + 1, &mut s)
            },
        )
    } else {
        let ls = node(ctx, prims_l, inner_l, start, lb, lcb, depth + 1, scratch);
        let rs = node(ctx, prims_r, inner_r, abs_m, rb, rcb, depth + 1, scratch);
        (ls, rs)
    };
    inner[m] = InnerSlot {
        child_bounds: [lb.to_aabb(), rb.to_aabb()],
        child_split: [ls, rs],
    };
    abs_m
}

/// In-place partition: triangles whose bin on `axis` is below `bin` go left. Returns the left
/// count and both sides' centroid bounds.
fn partition(prims: &mut [PrimRef], t: &Binning, axis: usize, bin: usize) -> (usize, Box4, Box4) {
    let (mut i, mut j) = (0, prims.len());
    let (mut lcb, mut rcb) = (Box4::EMPTY, Box4::EMPTY);
    while i < j {
        let c = prims[i].c2();
        if t.bin(c[axis], axis) < bin {
            lcb.grow(c);
            i += 1;
        } else {
            rcb.grow(c);
            j -= 1;
            prims.swap(i, j);
        }
    }
    (i, lcb, rcb)
}

/// Object median along the widest centroid axis, ties by triangle id (see the split policy).
fn median(prims: &mut [PrimRef], cb: &Box4) -> (usize, Box4, Box4, Box4, Box4) {
    let axis = widest_axis(&cb.to_aabb());
    let m = prims.len() / 2;
    prims.select_nth_unstable_by(m, |x, y| {
        key_cmp((x.c2()[axis], x.id()), (y.c2()[axis], y.id()))
    });
    let side = |s: &[PrimRef]| {
        s.iter()
            .fold((Box4::EMPTY, Box4::EMPTY), |(mut b, mut c), p| {
                b = b.union(p.b);
                c.grow(p.c2());
                (b, c)
            })
    };
    let (lb, lcb) = side(&prims[..m]);
    let (rb, rcb) = side(&prims[m..]);
    (m, lb, rb, lcb, rcb)
}
