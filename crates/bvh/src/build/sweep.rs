//! Full-sweep SAH builder: every object split along every axis is evaluated (MacDonald &
//! Booth 1990; the "full SAH" SGRT's BVH used).
//!
//! Three index lists hold the node's triangles sorted by centroid along x, y and z (ties by
//! triangle id, a total order), sorted once at the root. Per node and axis, a right-to-left
//! pass stores suffix box areas and a left-to-right pass evaluates each split position; the
//! chosen split partitions the other two lists stably by comparing each triangle's sort key
//! with the first right triangle's, so all three lists stay sorted without re-sorting:
//! O(n) per level, O(n log n) in all after the initial sort. Subtrees above
//! `parallel_threshold` are built with `rayon::join`.

use super::arena::{BuildTree, InnerSlot, LEAF};
use super::box4::Box4;
use super::{Decision, NodeRule, better, choose};
use crate::config::BvhConfig;
use rayon::prelude::*;
use rtsim_core::{Aabb, Vec3};

/// Order-preserving integer key of (coordinate, id): comparing keys as `u64` is
/// `f32::total_cmp` on the coordinate, then the id.
#[inline(always)]
fn sort_key(c: f32, id: u32) -> u64 {
    let b = c.to_bits();
    // Flip all bits of negatives and the sign bit of positives (the `total_cmp` mapping).
    let ord = if b >> 31 == 1 { !b } else { b | 0x8000_0000 };
    ((ord as u64) << 32) | id as u64
}

struct Ctx<'a> {
    config: &'a BvhConfig,
    boxes: &'a [Box4],
    /// Twice the box centre of each triangle.
    cents: &'a [Vec3],
    par_min: usize,
}

/// The per-node slices a subtree owns: three sorted lists, one scratch list, arena slots.
struct Work<'s> {
    lists: [&'s mut [u32]; 3],
    /// Suffix areas (as `f32` bits) during the sweep, partition scratch afterwards.
    tmp: &'s mut [u32],
    inner: &'s mut [InnerSlot],
}

impl<'s> Work<'s> {
    fn split_at(self, m: usize) -> (Work<'s>, Work<'s>) {
        let [a, b, c] = self.lists;
        let (a0, a1) = a.split_at_mut(m);
        let (b0, b1) = b.split_at_mut(m);
        let (c0, c1) = c.split_at_mut(m);
        let (t0, t1) = self.tmp.split_at_mut(m);
        let (i0, i1) = self.inner.split_at_mut(m);
        (
            Work {
                lists: [a0, b0, c0],
                tmp: t0,
                inner: i0,
            },
            Work {
                lists: [a1, b1, c1],
                tmp: t1,
                inner: i1,
            },
        )
    }
}

pub(crate) fn build(
    n: usize,
    config: &BvhConfig,
    prim_box: &(impl Fn(usize) -> Aabb + Sync),
) -> BuildTree {
    debug_assert!(n > 0, "build_tree handles the empty scene");
    let boxes: Vec<Box4> = (0..n)
        .into_par_iter()
        .map(|i| Box4::from_aabb(&prim_box(i)))
        .collect();
    let cents: Vec<Vec3> = boxes
        .par_iter()
        .map(|b| Vec3::new(b.lo[0] + b.hi[0], b.lo[1] + b.hi[1], b.lo[2] + b.hi[2]))
        .collect();
    let bounds = boxes
        .par_iter()
        .copied()
        .reduce(|| Box4::EMPTY, Box4::union);
    let mut lists: [Vec<u32>; 3] = std::array::from_fn(|axis| {
        let mut keys: Vec<u64> = cents
            .par_iter()
            .enumerate()
            .map(|(i, c)| sort_key(c[axis], i as u32))
            .collect();
        // Keys are unique (they contain the id), so the unstable sort is deterministic.
        keys.par_sort_unstable();
        keys.into_par_iter().map(|k| k as u32).collect()
    });
    let mut tmp = vec![0u32; n];
    let mut inner = vec![InnerSlot::UNUSED; n];
    let ctx = Ctx {
        config,
        boxes: &boxes,
        cents: &cents,
        par_min: config.parallel_threshold as usize,
    };
    let [l0, l1, l2] = &mut lists;
    let work = Work {
        lists: [l0, l1, l2],
        tmp: &mut tmp,
        inner: &mut inner,
    };
    let root_split = node(&ctx, work, 0, bounds, 0);
    let [prims, _, _] = lists;
    BuildTree {
        root_bounds: bounds.to_aabb(),
        root_split,
        inner,
        prims,
    }
}

fn node(ctx: &Ctx<'_>, w: Work<'_>, start: u32, bounds: Box4, depth: u32) -> u32 {
    let n = w.lists[0].len();
    let rule = NodeRule::new(ctx.config, n, depth);
    if rule.leaf_forced {
        return LEAF;
    }
    // Split positions p (left = first p of a list) allowed by the depth limit.
    let cap = rule.child_cap.min(n as u64 - 1) as usize;
    let (lo, hi) = ((n - cap).max(1), cap);

    // Sweep all three axes; ties go to the more balanced split, then the lower axis, then the
    // lower position. (weighted cost, imbalance, axis, position, left box)
    let mut best: Option<(f32, u32, usize, usize, Box4)> = None;
    for axis in 0..3 {
        let list = &*w.lists[axis];
        let mut acc = Box4::EMPTY;
        for p in (lo..n).rev() {
            acc = acc.union(ctx.boxes[list[p] as usize]);
            w.tmp[p] = acc.surface_area().to_bits();
        }
        let mut acc = Box4::EMPTY;
        for p in 1..=hi {
            acc = acc.union(ctx.boxes[list[p - 1] as usize]);
            if p < lo {
                continue;
            }
            let wgt = acc.surface_area() * p as f32 + f32::from_bits(w.tmp[p]) * (n - p) as f32;
            let imbalance = (2 * p).abs_diff(n) as u32;
            if best.is_none_or(|b| better(wgt, imbalance, b.0, b.1)) {
                best = Some((wgt, imbalance, axis, p, acc));
            }
        }
    }
    let decision = choose(
        ctx.config,
        &rule,
        n,
        bounds.surface_area(),
        best.map(|b| b.0),
    );
    let (axis, m, lb) = match (decision, best) {
        (Decision::Leaf, _) => return LEAF,
        (Decision::Split, Some((_, _, axis, p, lb))) => (axis, p, lb),
        _ => {
            // Median on the widest centroid axis: the sorted lists give the extents directly.
            let extent = |a: usize| {
                let l = &*w.lists[a];
                ctx.cents[l[n - 1] as usize][a] - ctx.cents[l[0] as usize][a]
            };
            let (ex, ey, ez) = (extent(0), extent(1), extent(2));
            let axis = Vec3::new(ex, ey, ez).max_axis();
            let m = n / 2;
            let lb = w.lists[axis][..m]
                .iter()
                .fold(Box4::EMPTY, |b, &i| b.union(ctx.boxes[i as usize]));
            (axis, m, lb)
        }
    };
    let rb = w.lists[axis][m..]
        .iter()
        .fold(Box4::EMPTY, |b, &i| b.union(ctx.boxes[i as usize]));

    // Stable partition of the other lists around the first right triangle's key.
    let Work {
        mut lists,
        tmp,
        inner,
    } = w;
    let pivot_id = lists[axis][m];
    let pivot = sort_key(ctx.cents[pivot_id as usize][axis], pivot_id);
    for (b, list) in lists.iter_mut().enumerate() {
        if b == axis {
            continue;
        }
        let (mut wl, mut wr) = (0, 0);
        for k in 0..n {
            let x = list[k];
            if sort_key(ctx.cents[x as usize][axis], x) < pivot {
                list[wl] = x;
                wl += 1;
            } else {
                tmp[wr] = x;
                wr += 1;
            }
        }
        debug_assert_eq!(wl, m);
        list[wl..].copy_from_slice(&tmp[..wr]);
    }

    let abs_m = start + m as u32;
    let (wl, wr) = Work {
        lists: lists.each_mut().map(|l| &mut **l),
        tmp: &mut *tmp,
        inner: &mut *inner,
    }
    .split_at(m);
    let (ls, rs) = if n >= ctx.par_min {
        rayon::join(
            || node(ctx, wl, start, lb, depth + 1),
            || node(ctx, wr, abs_m, rb, depth + 1),
        )
    } else {
        (
            node(ctx, wl, start, lb, depth + 1),
            node(ctx, wr, abs_m, rb, depth + 1),
        )
    };
    // The children's borrows have ended; this node's slot is index m of its range, which the
    // right subtree (splits strictly inside (m, end)) never writes.
    inner[m] = InnerSlot {
        child_bounds: [lb.to_aabb(), rb.to_aabb()],
        child_split: [ls, rs],
    };
    abs_m
}
