//! SAH BVH construction: a build-time tree (`arena::BuildTree`) made by one of two builders,
//! then flattened into a [`Bvh`] (module `flatten`).
//!
//! - `binned`: binned SAH (Wald 2007), parallel binning on large nodes;
//! - `sweep`: full-sweep SAH over three pre-sorted index lists.
//!
//! Both share the split policy below, so they differ only in which candidate splits they see.
//!
//! # Split policy
//! At a node with `n` triangles, box area `A`, remaining depth budget `r = max_depth − depth`:
//! 1. `n == 1` or `r == 0`: leaf.
//! 2. The best split minimises `C_t·A + C_i·(A_L·n_L + A_R·n_R)` over the candidates (exact
//!    ties: the more balanced split). Only candidates leaving each child at most
//!    `max_leaf_size · 2^(r−1)` triangles (what a subtree of depth `r − 1` can hold) are
//!    considered, so the depth limit can always be met.
//! 3. `n <= max_leaf_size` and `C_i·n·A <= ` the best split cost (or no candidate): leaf.
//! 4. Otherwise split at the best candidate, even where a leaf would be cheaper (leaves never
//!    exceed `max_leaf_size`). With no usable candidate (all centroids equal, a zero-area or
//!    overflowing box, or the depth constraint excluding every SAH candidate) split at the
//!    object median along the widest centroid axis, ties broken by triangle id: both halves
//!    then fit, since `n <= max_leaf_size · 2^r`.
//!
//! # Determinism
//! Every floating-point reduction is done in a fixed order per node; parallel work is either
//! independent subtrees or exact reductions (min/max of boxes, integer counts). The tree is
//! therefore bit-identical whatever the thread count.

pub(crate) mod arena;
pub(crate) mod binned;
mod box4;
pub(crate) mod sweep;

use crate::config::{Builder, BvhConfig, NodeOrder};
use crate::flat::Bvh;
use crate::flatten;
use rtsim_config::{ConfigError, Validate};
use rtsim_core::{Aabb, Vec3};
use std::cmp::Ordering;

/// Why a BVH could not be built. Every variant is an input or configuration problem.
#[derive(Debug, thiserror::Error)]
pub enum BuildError {
    #[error(transparent)]
    Config(#[from] ConfigError),
    #[error("triangle {index} has a non-finite vertex coordinate")]
    NonFinite { index: usize },
    #[error("{count} triangles exceed the BVH's limit of {limit} (32-bit node indices)")]
    TooMany { count: usize, limit: usize },
    #[error(
        "bvh.max_depth = {max_depth} cannot hold {triangles} triangles with \
         bvh.max_leaf_size = {max_leaf_size} (at most {max_leaf_size} × 2^{max_depth}); \
         raise bvh.max_depth to at least {needed} or bvh.max_leaf_size"
    )]
    DepthTooSmall {
        triangles: usize,
        max_depth: u32,
        max_leaf_size: u32,
        needed: u32,
    },
}

/// Most triangles a BVH may hold: its at most `2n − 1` nodes must have 32-bit indices.
pub const MAX_TRIANGLES: usize = (u32::MAX / 2) as usize;

/// Build a BVH over `triangles` (scene order) and flatten it in `order`.
///
/// Runs on the current rayon pool (wrap the call in `ThreadPool::install` to choose the thread
/// count); the result does not depend on it. Non-finite vertices are an error (the scene
/// loader drops them first).
pub fn build(
    triangles: &[[Vec3; 3]],
    config: &BvhConfig,
    order: NodeOrder,
) -> Result<Bvh, BuildError> {
    if let Some(index) = triangles
        .iter()
        .position(|t| !t.iter().all(|v| v.is_finite()))
    {
        return Err(BuildError::NonFinite { index });
    }
    let tree = build_tree(triangles.len(), config, |i| {
        Aabb::from_points(&triangles[i])
    })?;
    Ok(flatten::flatten(&tree, order))
}

/// Build a BVH over arbitrary primitives given by their boxes (non-empty, finite). Leaves get
/// the union of their primitives' boxes.
pub fn build_from_boxes(
    boxes: &[Aabb],
    config: &BvhConfig,
    order: NodeOrder,
) -> Result<Bvh, BuildError> {
    if let Some(index) = boxes
        .iter()
        .position(|b| b.is_empty() || !b.min.is_finite() || !b.max.is_finite())
    {
        return Err(BuildError::NonFinite { index });
    }
    let tree = build_tree(boxes.len(), config, |i| boxes[i])?;
    Ok(flatten::flatten(&tree, order))
}

fn build_tree(
    n: usize,
    config: &BvhConfig,
    prim_box: impl Fn(usize) -> Aabb + Sync,
) -> Result<arena::BuildTree, BuildError> {
    config.validate()?;
    if n > MAX_TRIANGLES {
        return Err(BuildError::TooMany {
            count: n,
            limit: MAX_TRIANGLES,
        });
    }
    if (n as u64) > capacity(config.max_leaf_size, config.max_depth) {
        let mut needed = config.max_depth;
        while (n as u64) > capacity(config.max_leaf_size, needed) {
            needed += 1;
        }
        return Err(BuildError::DepthTooSmall {
            triangles: n,
            max_depth: config.max_depth,
            max_leaf_size: config.max_leaf_size,
            needed,
        });
    }
    if n == 0 {
        return Ok(arena::BuildTree::empty());
    }
    Ok(match config.builder {
        Builder::Binned => binned::build(n, config, &prim_box),
        Builder::Sweep => sweep::build(n, config, &prim_box),
    })
}

/// Most triangles a subtree with `levels` levels below its root can hold.
#[inline]
pub(crate) fn capacity(max_leaf_size: u32, levels: u32) -> u64 {
    // 255 << 55 still fits in u64; beyond that no scene can reach the limit anyway.
    if levels >= 55 {
        u64::MAX
    } else {
        (max_leaf_size as u64) << levels
    }
}

/// Split constraints and SAH weights of one node, shared by both builders.
#[derive(Clone, Copy, Debug)]
pub(crate) struct NodeRule {
    /// Largest child allowed by the depth limit.
    pub child_cap: u64,
    /// `n` may become a leaf without splitting (size within `max_leaf_size`).
    pub leaf_allowed: bool,
    /// Must become a leaf (one triangle or no depth left).
    pub leaf_forced: bool,
}

impl NodeRule {
    pub fn new(config: &BvhConfig, n: usize, depth: u32) -> Self {
        let remaining = config.max_depth - depth;
        NodeRule {
            child_cap: if remaining == 0 {
                0
            } else {
                capacity(config.max_leaf_size, remaining - 1)
            },
            leaf_allowed: n <= config.max_leaf_size as usize,
            leaf_forced: n <= 1 || remaining == 0,
        }
    }

    /// Does a split into `left` and `right` triangles respect the depth limit?
    #[inline(always)]
    pub fn fits(&self, left: usize, right: usize) -> bool {
        left > 0 && right > 0 && left as u64 <= self.child_cap && right as u64 <= self.child_cap
    }
}

/// The SAH decision once the best candidate is known. `best_weighted` is
/// `min(A_L·n_L + A_R·n_R)` over valid candidates, `None` if there were none.
pub(crate) fn choose(
    config: &BvhConfig,
    rule: &NodeRule,
    n: usize,
    area: f32,
    best_weighted: Option<f32>,
) -> Decision {
    if rule.leaf_forced {
        return Decision::Leaf;
    }
    let usable = area.is_finite() && area > 0.0;
    match best_weighted {
        Some(w) if usable && w.is_finite() => {
            let split = config.traversal_cost * area + config.intersection_cost * w;
            let leaf = config.intersection_cost * n as f32 * area;
            if rule.leaf_allowed && leaf <= split {
                Decision::Leaf
            } else {
                Decision::Split
            }
        }
        _ if rule.leaf_allowed => Decision::Leaf,
        _ => Decision::Median,
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Decision {
    Leaf,
    Split,
    Median,
}

/// Is candidate `(w, imbalance)` better than the best so far? Lower SAH weight wins; on an
/// exact tie (common with identical or nested boxes) the more balanced split wins, which keeps
/// degenerate inputs from producing one-triangle-per-level chains.
#[inline(always)]
pub(crate) fn better(w: f32, imbalance: u32, best_w: f32, best_imbalance: u32) -> bool {
    w < best_w || (w == best_w && imbalance < best_imbalance)
}

/// Total order on (centroid coordinate, triangle id): the tie-break that makes median splits
/// and sorted lists deterministic.
#[inline(always)]
pub(crate) fn key_cmp(a: (f32, u32), b: (f32, u32)) -> Ordering {
    a.0.total_cmp(&b.0).then(a.1.cmp(&b.1))
}

/// The axis with the largest centroid extent (ties to the lower axis).
#[inline]
pub(crate) fn widest_axis(cb: &Aabb) -> usize {
    if cb.is_empty() {
        0
    } else {
        cb.extent().max_axis()
    }
}
