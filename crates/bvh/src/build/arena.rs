//! The build-time tree.
//!
//! Builders partition one array of triangle ids in place, so every node owns a contiguous
//! range `[s, e)` and an inner node is fully described by its split position `m`
//! (`s < m < e`): left child `[s, m)`, right child `[m, e)`. Distinct inner nodes have distinct
//! split positions, so the arena stores inner node `m` at `inner[m]`, with the boxes of its two
//! children and, for each child, the child's own split position or [`LEAF`].
//!
//! This numbering needs no allocator shared between threads: a subtree over `[s, e)` writes
//! only slots `s + 1 .. e`, so parallel subtrees get disjoint `&mut` slices of one array
//! (`split_at_mut`), and the arena's content depends only on the tree, never on scheduling.

use rtsim_core::Aabb;

/// Child marker: the child is a leaf (its triangle range follows from the parent's split).
pub(crate) const LEAF: u32 = u32::MAX;

/// One inner node, stored at the index of its split position.
#[derive(Clone, Copy, Debug)]
pub(crate) struct InnerSlot {
    pub child_bounds: [Aabb; 2],
    /// Split position of each child, or [`LEAF`].
    pub child_split: [u32; 2],
}

impl InnerSlot {
    pub const UNUSED: InnerSlot = InnerSlot {
        child_bounds: [Aabb::EMPTY; 2],
        child_split: [LEAF; 2],
    };
}

/// A complete build-time tree over `prims.len()` triangles.
#[derive(Clone, Debug)]
pub(crate) struct BuildTree {
    pub root_bounds: Aabb,
    /// Split position of the root, or [`LEAF`] (also for an empty tree).
    pub root_split: u32,
    /// `inner[m]`: the inner node splitting at `m`; other slots unused.
    pub inner: Vec<InnerSlot>,
    /// Scene triangle ids in leaf order: each leaf owns a contiguous range.
    pub prims: Vec<u32>,
}

/// A node of a [`BuildTree`] as seen while walking it: its range, box and split.
#[derive(Clone, Copy, Debug)]
pub(crate) struct ArenaRef {
    pub start: u32,
    pub end: u32,
    pub split: u32,
    pub bounds: Aabb,
}

impl BuildTree {
    pub fn empty() -> Self {
        BuildTree {
            root_bounds: Aabb::EMPTY,
            root_split: LEAF,
            inner: Vec::new(),
            prims: Vec::new(),
        }
    }

    pub fn root(&self) -> Option<ArenaRef> {
        (!self.prims.is_empty()).then_some(ArenaRef {
            start: 0,
            end: self.prims.len() as u32,
            split: self.root_split,
            bounds: self.root_bounds,
        })
    }

    pub fn children(&self, r: &ArenaRef) -> Option<(ArenaRef, ArenaRef)> {
        if r.split == LEAF {
            return None;
        }
        let slot = &self.inner[r.split as usize];
        Some((
            ArenaRef {
                start: r.start,
                end: r.split,
                split: slot.child_split[0],
                bounds: slot.child_bounds[0],
            },
            ArenaRef {
                start: r.split,
                end: r.end,
                split: slot.child_split[1],
                bounds: slot.child_bounds[1],
            },
        ))
    }
}
