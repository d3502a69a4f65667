//! Flattening a tree into the [`Bvh`] array in depth-first or breadth-first order.
//!
//! Both orders put the root at index 0 and allocate the two children of an inner node as one
//! adjacent pair when the parent is emitted, so pairs occupy indices (1, 2), (3, 4), ….
//! Triangle slots are handed out in the order the layout's walk emits leaves:
//! - depth-first: the parent's pair, then the whole left subtree, then the right subtree, so
//!   leaves (and their triangles) come in left-to-right order;
//! - breadth-first: level by level, so a leaf's triangle slots increase with its node index.
//!
//! The same code flattens the build-time tree and re-orders an existing [`Bvh`]
//! ([`Bvh::reordered`]), through the small [`TreeView`] trait.

use crate::build::arena::{ArenaRef, BuildTree};
use crate::config::NodeOrder;
use crate::flat::{Bvh, Node};
use rtsim_core::Aabb;
use std::collections::VecDeque;

/// Read access to a binary tree whose leaves hold scene triangle ids.
pub(crate) trait TreeView {
    type Ref: Copy;
    fn root(&self) -> Option<Self::Ref>;
    fn bounds(&self, r: &Self::Ref) -> Aabb;
    fn children(&self, r: &Self::Ref) -> Option<(Self::Ref, Self::Ref)>;
    /// Scene ids of a leaf's triangles, in slot order.
    fn leaf_prims(&self, r: &Self::Ref) -> &[u32];
    /// Total number of triangles.
    fn prim_count(&self) -> usize;
}

impl TreeView for BuildTree {
    type Ref = ArenaRef;
    fn root(&self) -> Option<ArenaRef> {
        BuildTree::root(self)
    }
    fn bounds(&self, r: &ArenaRef) -> Aabb {
        r.bounds
    }
    fn children(&self, r: &ArenaRef) -> Option<(ArenaRef, ArenaRef)> {
        BuildTree::children(self, r)
    }
    fn leaf_prims(&self, r: &ArenaRef) -> &[u32] {
        &self.prims[r.start as usize..r.end as usize]
    }
    fn prim_count(&self) -> usize {
        self.prims.len()
    }
}

impl TreeView for Bvh {
    type Ref = u32;
    fn root(&self) -> Option<u32> {
        (!self.nodes.is_empty()).then_some(0)
    }
    fn bounds(&self, r: &u32) -> Aabb {
        self.nodes[*r as usize].bounds
    }
    fn children(&self, r: &u32) -> Option<(u32, u32)> {
        let n = &self.nodes[*r as usize];
        (!n.is_leaf()).then_some((n.index, n.index + 1))
    }
    fn leaf_prims(&self, r: &u32) -> &[u32] {
        let n = &self.nodes[*r as usize];
        &self.prim_ids[n.index as usize..(n.index + n.count) as usize]
    }
    fn prim_count(&self) -> usize {
        self.prim_ids.len()
    }
}

/// Flatten `tree` in `order`.
pub(crate) fn flatten<T: TreeView>(tree: &T, order: NodeOrder) -> Bvh {
    let Some(root) = tree.root() else {
        return Bvh::default();
    };
    let mut out = Bvh {
        nodes: Vec::with_capacity(count_nodes(tree, root)),
        prim_ids: Vec::with_capacity(tree.prim_count()),
    };
    out.nodes.push(placeholder());
    match order {
        NodeOrder::DepthFirst => depth_first(tree, root, 0, &mut out),
        NodeOrder::BreadthFirst => {
            let mut queue = VecDeque::from([(root, 0usize)]);
            while let Some((r, slot)) = queue.pop_front() {
                if let Some((a, b)) = emit(tree, &r, slot, &mut out) {
                    queue.push_back((a, slot_of_pair(&out, slot)));
                    queue.push_back((b, slot_of_pair(&out, slot) + 1));
                }
            }
        }
    }
    debug_assert_eq!(out.prim_ids.len(), tree.prim_count());
    out
}

fn depth_first<T: TreeView>(tree: &T, r: T::Ref, slot: usize, out: &mut Bvh) {
    if let Some((a, b)) = emit(tree, &r, slot, out) {
        let c = slot_of_pair(out, slot);
        depth_first(tree, a, c, out);
        depth_first(tree, b, c + 1, out);
    }
}

/// Write node `r` at `slot`: a leaf takes the next triangle slots; an inner node allocates its
/// child pair at the end of the array and returns the children to place there.
fn emit<T: TreeView>(tree: &T, r: &T::Ref, slot: usize, out: &mut Bvh) -> Option<(T::Ref, T::Ref)> {
    let bounds = tree.bounds(r);
    match tree.children(r) {
        Some(pair) => {
            let c = out.nodes.len();
            out.nodes.push(placeholder());
            out.nodes.push(placeholder());
            out.nodes[slot] = Node {
                bounds,
                index: c as u32,
                count: 0,
            };
            Some(pair)
        }
        None => {
            let prims = tree.leaf_prims(r);
            out.nodes[slot] = Node {
                bounds,
                index: out.prim_ids.len() as u32,
                count: prims.len() as u32,
            };
            out.prim_ids.extend_from_slice(prims);
            None
        }
    }
}

fn slot_of_pair(out: &Bvh, parent: usize) -> usize {
    out.nodes[parent].index as usize
}

fn placeholder() -> Node {
    Node {
        bounds: Aabb::EMPTY,
        index: 0,
        count: 0,
    }
}

fn count_nodes<T: TreeView>(tree: &T, root: T::Ref) -> usize {
    let mut count = 0;
    let mut stack = vec![root];
    while let Some(r) = stack.pop() {
        count += 1;
        if let Some((a, b)) = tree.children(&r) {
            stack.push(a);
            stack.push(b);
        }
    }
    count
}

impl Bvh {
    /// The same tree laid out in `order` (nodes and triangle slots renumbered; boxes and
    /// leaf contents unchanged).
    pub fn reordered(&self, order: NodeOrder) -> Bvh {
        flatten(self, order)
    }
}
