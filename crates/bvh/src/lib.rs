//! Bounding volume hierarchy for rtsim.
//!
//! - [`BvhConfig`]: builder (full-sweep SAH or binned SAH), bins, leaf size, SAH costs, depth
//!   limit; validated before anything is built.
//! - [`build`]: builds the tree (a build-time arena, parallel with rayon for large inputs) and
//!   flattens it into a [`Bvh`]: a flat array of 32-byte [`Node`]s plus the permutation from
//!   BVH triangle slots to scene triangle ids.
//! - [`MemoryImage`]: every node and triangle gets a byte address in the simulated address
//!   space. This is the interface between the functional tracer and the hardware models:
//!   caches and DRAM see exactly these addresses.
//! - [`BvhStats`]: SAH cost, node and leaf counts, depth, triangles per leaf (`rtsim bvh-stats`).
//!
//! PLACEHOLDER (skeleton): builders, memory image and stats are filled in by the BVH work.

use rtsim_config::{ConfigError, Validate, check_positive, check_range};
use rtsim_core::{Aabb, Vec3};
use serde::{Deserialize, Serialize};

/// A flat BVH node: 32 bytes, 32-byte aligned, two per 64-byte cache line.
///
/// Inner node: `count == 0`, children at `index` and `index + 1` (siblings are adjacent in the
/// array, so one line fetch gives both). Leaf: `count >= 1` triangles in BVH slots
/// `index .. index + count`.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(32))]
pub struct Node {
    pub bounds: Aabb,
    pub index: u32,
    pub count: u32,
}

impl Node {
    #[inline(always)]
    pub fn is_leaf(&self) -> bool {
        self.count > 0
    }
}

/// A built BVH. Node 0 is the root. An empty scene has no nodes.
#[derive(Clone, Debug, Default)]
pub struct Bvh {
    pub nodes: Vec<Node>,
    /// `prim_ids[slot]` is the scene triangle id stored at BVH triangle slot `slot`; leaves
    /// reference contiguous slot ranges.
    pub prim_ids: Vec<u32>,
}

/// Which SAH builder to run.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Builder {
    /// Full sweep SAH over sorted centroids on all three axes (best quality, O(n log² n)).
    Sweep,
    /// Binned SAH (Wald 2007): `bins` buckets over the centroid bounds per axis.
    Binned,
}

/// BVH build settings.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct BvhConfig {
    /// SAH builder. Default `binned`. `sweep` is slower to build, slightly better trees.
    pub builder: Builder,
    /// Bins per axis for the binned builder. Default 32; range 2..=1024.
    pub bins: u32,
    /// Largest leaf, in triangles. Default 4; range 1..=255. Larger leaves mean fewer nodes
    /// and more triangle tests per ray.
    pub max_leaf_size: u32,
    /// SAH cost of one traversal step, relative to `intersection_cost`. Default 1.0.
    pub traversal_cost: f32,
    /// SAH cost of one triangle test. Default 1.0.
    pub intersection_cost: f32,
    /// Maximum tree depth (root = depth 0 ... ). Default 64; STRaTA's one-bit-per-level stack
    /// needs 32. Range 1..=128.
    pub max_depth: u32,
    /// Subtrees with at least this many triangles are built in parallel. Default 4096.
    pub parallel_threshold: u32,
}

impl Default for BvhConfig {
    fn default() -> Self {
        BvhConfig {
            builder: Builder::Binned,
            bins: 32,
            max_leaf_size: 4,
            traversal_cost: 1.0,
            intersection_cost: 1.0,
            max_depth: 64,
            parallel_threshold: 4096,
        }
    }
}

impl Validate for BvhConfig {
    fn validate(&self) -> Result<(), ConfigError> {
        check_range("bvh.bins", self.bins, 2, 1024)?;
        check_range("bvh.max_leaf_size", self.max_leaf_size, 1, 255)?;
        check_range("bvh.max_depth", self.max_depth, 1, 128)?;
        check_positive("bvh.traversal_cost", self.traversal_cost as f64)?;
        check_positive("bvh.intersection_cost", self.intersection_cost as f64)?;
        Ok(())
    }
}

/// Triangle centroid helper used by builders and tests.
#[inline]
pub fn centroid(t: &[Vec3; 3]) -> Vec3 {
    (t[0] + t[1] + t[2]) * (1.0 / 3.0)
}

/// Order of nodes in the flat array and hence in memory.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum NodeOrder {
    /// Depth-first, sibling pairs adjacent (default).
    DepthFirst,
    /// Breadth-first (level order), sibling pairs adjacent.
    BreadthFirst,
}

/// How the BVH is laid out in the simulated address space (see [`MemoryImage`] once built).
///
/// PLACEHOLDER (skeleton): the BVH work completes this.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct MemoryLayoutConfig {
    /// Node order. Default `depth-first`.
    pub order: NodeOrder,
    /// Store a parent index with every node (STRaTA's bit-stack traversal needs it).
    pub parent_pointers: bool,
    /// First byte address of the scene data. Default 0.
    pub base_address: u64,
}

impl Default for MemoryLayoutConfig {
    fn default() -> Self {
        MemoryLayoutConfig {
            order: NodeOrder::DepthFirst,
            parent_pointers: false,
            base_address: 0,
        }
    }
}

impl Validate for MemoryLayoutConfig {
    fn validate(&self) -> Result<(), ConfigError> {
        Ok(())
    }
}
