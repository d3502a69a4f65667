//! Bounding volume hierarchy for rtsim.
//!
//! - [`BvhConfig`] (`bvh.*`): builder (full-sweep SAH or binned SAH), bins, leaf size, SAH
//!   costs, depth limit; validated before anything is built.
//! - [`build()`]: builds a build-time tree (an arena indexed by split position, parallel with
//!   rayon for large inputs, identical for any thread count; `build::arena`) with one of two
//!   builders (`build::binned`, `build::sweep`) and flattens it (`flatten`) into a
//!   [`Bvh`]: a flat array of 32-byte [`Node`]s in depth-first or breadth-first order plus
//!   the permutation from BVH triangle slots to scene triangle ids.
//! - [`MemoryImage`] (`memory.*`, [`MemoryLayoutConfig`]): every node and triangle gets a byte
//!   address in the simulated address space. This is the interface between the functional
//!   tracer and the hardware models: caches and DRAM see exactly these addresses. Record
//!   layouts and address rules: `docs/MEMORY_IMAGE.md`.
//! - [`Treelets`] (`treelet`, `memory.layout = "treelets"`): STRaTA's node treelets (grown
//!   by sibling pairs in order of surface area) and triangle treelets, each contiguous and
//!   row-aligned, and [`check_rows`] against a DRAM row size; the memory image places records
//!   treelet by treelet. [`ImageExtras`] adds the regions a chip reads or writes besides the
//!   BVH (Wald records, materials, framebuffer, path state).
//! - [`BvhStats`]: SAH cost, node and leaf counts, depth, triangles per leaf, build time and
//!   image sizes (`rtsim bvh-stats`).
//!
//! The crate never sees a file format: it takes triangles as `[Vec3; 3]` in scene order.

pub mod build;
pub mod config;
pub mod flat;
mod flatten;
pub mod memory;
pub mod stats;
pub mod treelet;

pub use build::{BuildError, MAX_TRIANGLES, build, build_from_boxes};
pub use config::{Builder, BvhConfig, Layout, MemoryLayoutConfig, NodeOrder, RowCheck};
pub use flat::{Bvh, InvariantError, NO_PARENT, Node};
pub use memory::{
    ImageExtras, ImageParts, LineSpan, MemoryImage, MemoryImageError, Placement, RecordKind,
    RecordSet, Region, RegionBytes, SceneData, lines_touched,
};
pub use stats::{BvhStats, sah_cost};
pub use treelet::{
    RowFinding, TreeletError, TreeletInfo, TreeletKind, TreeletSummary, Treelets, check_rows,
    enforce_row_check,
};

use rtsim_core::Vec3;

/// Triangle centroid (mean of the vertices). The builders split on the centre of each
/// triangle's bounding box instead (Wald 2007's choice, cheaper and order-free).
#[inline]
pub fn centroid(t: &[Vec3; 3]) -> Vec3 {
    (t[0] + t[1] + t[2]) * (1.0 / 3.0)
}
