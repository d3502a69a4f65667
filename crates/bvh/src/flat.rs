//! The flat BVH that traversal reads: [`Node`] and [`Bvh`], plus structural queries (parents,
//! depths) and an invariant check ([`InvariantError`]) used by tests and `rtsim bvh-stats`.

use crate::config::BvhConfig;
use rtsim_core::{Aabb, Vec3};

/// A flat BVH node: 32 bytes, 32-byte aligned, two per 64-byte cache line.
///
/// Inner node: `count == 0`, children at `index` and `index + 1` (siblings are adjacent in the
/// array; the memory image places each pair in one 64-byte line by default). Leaf:
/// `count >= 1` triangles in BVH slots `index .. index + count`.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(32))]
pub struct Node {
    pub bounds: Aabb,
    pub index: u32,
    pub count: u32,
}

const _: () = assert!(std::mem::size_of::<Node>() == 32);

impl Node {
    #[inline(always)]
    pub fn is_leaf(&self) -> bool {
        self.count > 0
    }
}

/// `parents()[root]`: the root has no parent.
pub const NO_PARENT: u32 = u32::MAX;

/// The first structural violation [`Bvh::check_invariants`] finds; the message names the node,
/// slot or triangle.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum InvariantError {
    #[error("empty scene but non-empty BVH")]
    NodesWithoutTriangles,
    #[error("no nodes for a non-empty scene")]
    NoNodes,
    #[error("{slots} triangle slots for {triangles} triangles")]
    SlotCount { slots: usize, triangles: usize },
    #[error("slot {slot} holds triangle {triangle}, out of range")]
    TriangleOutOfRange { slot: usize, triangle: u32 },
    #[error("triangle {triangle} appears in two slots")]
    TriangleInTwoSlots { triangle: u32 },
    #[error("node {node} at depth {depth} > {max_depth}")]
    TooDeep {
        node: usize,
        depth: u32,
        max_depth: u32,
    },
    #[error("leaf {node} holds {count} triangles > {max_leaf_size}")]
    LeafTooLarge {
        node: usize,
        count: u32,
        max_leaf_size: u32,
    },
    #[error("leaf {node} slots {start}..{end} out of range")]
    LeafSlotsOutOfRange {
        node: usize,
        start: usize,
        end: usize,
    },
    #[error("slot {slot} in two leaves")]
    SlotInTwoLeaves { slot: usize },
    #[error("leaf {node} box {stored:?} is not the bounds of its triangles {actual:?}")]
    LeafBox {
        node: usize,
        stored: Aabb,
        actual: Aabb,
    },
    #[error("node {node} has children {left},{} out of order", left + 1)]
    ChildrenOutOfOrder { node: usize, left: usize },
    #[error("node {node}: sibling pair starts at even index {left}")]
    PairAtEvenIndex { node: usize, left: usize },
    #[error("node {node}: a child box leaves the parent box")]
    ChildOutsideParent { node: usize },
    #[error("node {node}: box is not the union of its children")]
    NotUnionOfChildren { node: usize },
    #[error("node {node} reached twice")]
    ReachedTwice { node: usize },
    #[error("node {node} unreachable from the root")]
    Unreachable { node: usize },
    #[error("slot {slot} in no leaf")]
    SlotInNoLeaf { slot: usize },
}

/// A built BVH. Node 0 is the root. An empty scene has no nodes.
#[derive(Clone, Debug, Default)]
pub struct Bvh {
    pub nodes: Vec<Node>,
    /// `prim_ids[slot]` is the scene triangle id stored at BVH triangle slot `slot`; leaves
    /// reference contiguous slot ranges.
    pub prim_ids: Vec<u32>,
}

impl Bvh {
    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }

    /// Bounds of the whole scene (empty box for an empty BVH).
    pub fn root_bounds(&self) -> Aabb {
        self.nodes.first().map_or(Aabb::EMPTY, |n| n.bounds)
    }

    /// Parent index of every node; [`NO_PARENT`] for the root.
    pub fn parents(&self) -> Vec<u32> {
        let mut p = vec![NO_PARENT; self.nodes.len()];
        for (i, n) in self.nodes.iter().enumerate() {
            if !n.is_leaf() {
                p[n.index as usize] = i as u32;
                p[n.index as usize + 1] = i as u32;
            }
        }
        p
    }

    /// Depth of every node in edges from the root (root = 0); nodes not reachable from the
    /// root (none in a built BVH) get 0.
    pub fn depths(&self) -> Vec<u32> {
        let mut d = vec![0u32; self.nodes.len()];
        let mut stack: Vec<usize> = if self.nodes.is_empty() {
            vec![]
        } else {
            vec![0]
        };
        while let Some(i) = stack.pop() {
            let n = self.nodes[i];
            if !n.is_leaf() {
                for c in [n.index as usize, n.index as usize + 1] {
                    d[c] = d[i] + 1;
                    stack.push(c);
                }
            }
        }
        d
    }

    /// Check every structural invariant against the scene triangles and the build limits:
    /// each node reached exactly once from the root, children after their parent, sibling
    /// pairs adjacent, child boxes inside parent boxes, inner boxes equal to the union of their
    /// children, leaf boxes equal to the bounds of their triangles, leaf sizes within
    /// `config.max_leaf_size`, depth within `config.max_depth`, leaves covering every slot
    /// exactly once, and `prim_ids` a permutation of the scene's triangle ids.
    ///
    /// Returns the first violation found; its message names the node.
    pub fn check_invariants(
        &self,
        triangles: &[[Vec3; 3]],
        config: &BvhConfig,
    ) -> Result<(), InvariantError> {
        use InvariantError as E;
        let n_nodes = self.nodes.len();
        if triangles.is_empty() {
            return if n_nodes == 0 && self.prim_ids.is_empty() {
                Ok(())
            } else {
                Err(E::NodesWithoutTriangles)
            };
        }
        if n_nodes == 0 {
            return Err(E::NoNodes);
        }
        if self.prim_ids.len() != triangles.len() {
            return Err(E::SlotCount {
                slots: self.prim_ids.len(),
                triangles: triangles.len(),
            });
        }
        let mut seen_id = vec![false; triangles.len()];
        for (slot, &id) in self.prim_ids.iter().enumerate() {
            let Some(s) = seen_id.get_mut(id as usize) else {
                return Err(E::TriangleOutOfRange { slot, triangle: id });
            };
            if std::mem::replace(s, true) {
                return Err(E::TriangleInTwoSlots { triangle: id });
            }
        }
        let mut reached = vec![false; n_nodes];
        let mut slot_covered = vec![false; self.prim_ids.len()];
        // (node, depth)
        let mut stack = vec![(0usize, 0u32)];
        reached[0] = true;
        while let Some((i, depth)) = stack.pop() {
            let n = &self.nodes[i];
            if depth > config.max_depth {
                return Err(E::TooDeep {
                    node: i,
                    depth,
                    max_depth: config.max_depth,
                });
            }
            if n.is_leaf() {
                if n.count > config.max_leaf_size {
                    return Err(E::LeafTooLarge {
                        node: i,
                        count: n.count,
                        max_leaf_size: config.max_leaf_size,
                    });
                }
                let (start, end) = (n.index as usize, n.index as usize + n.count as usize);
                if end > slot_covered.len() {
                    return Err(E::LeafSlotsOutOfRange {
                        node: i,
                        start,
                        end,
                    });
                }
                let mut b = Aabb::EMPTY;
                for slot in start..end {
                    if std::mem::replace(&mut slot_covered[slot], true) {
                        return Err(E::SlotInTwoLeaves { slot });
                    }
                    for &v in &triangles[self.prim_ids[slot] as usize] {
                        b.grow(v);
                    }
                }
                if b != n.bounds {
                    return Err(E::LeafBox {
                        node: i,
                        stored: n.bounds,
                        actual: b,
                    });
                }
            } else {
                let c = n.index as usize;
                if c <= i || c + 1 >= n_nodes {
                    return Err(E::ChildrenOutOfOrder { node: i, left: c });
                }
                if c % 2 == 0 {
                    return Err(E::PairAtEvenIndex { node: i, left: c });
                }
                let (l, r) = (&self.nodes[c], &self.nodes[c + 1]);
                if !n.bounds.contains_box(&l.bounds) || !n.bounds.contains_box(&r.bounds) {
                    return Err(E::ChildOutsideParent { node: i });
                }
                if l.bounds.union(r.bounds) != n.bounds {
                    return Err(E::NotUnionOfChildren { node: i });
                }
                for k in [c, c + 1] {
                    if std::mem::replace(&mut reached[k], true) {
                        return Err(E::ReachedTwice { node: k });
                    }
                    stack.push((k, depth + 1));
                }
            }
        }
        if let Some(node) = reached.iter().position(|&r| !r) {
            return Err(E::Unreachable { node });
        }
        if let Some(slot) = slot_covered.iter().position(|&c| !c) {
            return Err(E::SlotInNoLeaf { slot });
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn leaf(b: Aabb, index: u32, count: u32) -> Node {
        Node {
            bounds: b,
            index,
            count,
        }
    }

    fn tri(x: f32) -> [Vec3; 3] {
        [
            Vec3::new(x, 0.0, 0.0),
            Vec3::new(x + 1.0, 0.0, 0.0),
            Vec3::new(x, 1.0, 0.0),
        ]
    }

    fn tri_box(t: &[Vec3; 3]) -> Aabb {
        Aabb::from_points(t)
    }

    fn two_leaf_bvh(tris: &[[Vec3; 3]]) -> Bvh {
        let (a, b) = (tri_box(&tris[0]), tri_box(&tris[1]));
        Bvh {
            nodes: vec![
                Node {
                    bounds: a.union(b),
                    index: 1,
                    count: 0,
                },
                leaf(a, 0, 1),
                leaf(b, 1, 1),
            ],
            prim_ids: vec![0, 1],
        }
    }

    #[test]
    fn parents_and_depths() {
        let tris = [tri(0.0), tri(5.0)];
        let bvh = two_leaf_bvh(&tris);
        assert_eq!(bvh.parents(), vec![NO_PARENT, 0, 0]);
        assert_eq!(bvh.depths(), vec![0, 1, 1]);
        bvh.check_invariants(&tris, &BvhConfig::default()).unwrap();
    }

    #[test]
    fn invariant_check_catches_each_violation() {
        let tris = [tri(0.0), tri(5.0)];
        let cfg = BvhConfig::default();
        let good = two_leaf_bvh(&tris);

        let mut b = good.clone();
        b.prim_ids = vec![0, 0];
        let e = b.check_invariants(&tris, &cfg).unwrap_err();
        assert_eq!(e, InvariantError::TriangleInTwoSlots { triangle: 0 });
        assert_eq!(e.to_string(), "triangle 0 appears in two slots");

        let mut b = good.clone();
        b.nodes[1].bounds.max.x += 1.0;
        let e = b.check_invariants(&tris, &cfg).unwrap_err();
        assert!(matches!(e, InvariantError::LeafBox { node: 1, .. }), "{e}");
        assert!(e.to_string().starts_with("leaf 1 box"), "{e}");

        let mut b = good.clone();
        b.nodes[2].index = 0; // both leaves claim slot 0; leaf 2 is checked first
        let e = b.check_invariants(&tris, &cfg).unwrap_err();
        assert!(matches!(e, InvariantError::LeafBox { node: 2, .. }), "{e}");
        b.nodes[2].bounds = b.nodes[1].bounds;
        b.nodes[0].bounds = b.nodes[1].bounds;
        assert_eq!(
            b.check_invariants(&tris, &cfg),
            Err(InvariantError::SlotInTwoLeaves { slot: 0 })
        );

        let mut b = good.clone();
        b.nodes[0].bounds.max.y += 1.0; // parent not the union of its children
        let e = b.check_invariants(&tris, &cfg).unwrap_err();
        assert_eq!(e, InvariantError::NotUnionOfChildren { node: 0 });
        assert_eq!(
            e.to_string(),
            "node 0: box is not the union of its children"
        );

        let mut b = good.clone();
        b.nodes[0].index = 2; // the pair would start at an even index
        b.nodes.push(b.nodes[2]);
        assert_eq!(
            b.check_invariants(&tris, &cfg),
            Err(InvariantError::PairAtEvenIndex { node: 0, left: 2 })
        );

        let shallow = BvhConfig {
            max_depth: 0,
            ..Default::default()
        };
        assert_eq!(
            good.check_invariants(&tris, &shallow)
                .unwrap_err()
                .to_string(),
            "node 2 at depth 1 > 0"
        );

        let one = BvhConfig {
            max_leaf_size: 1,
            ..Default::default()
        };
        let mut b = good.clone();
        b.nodes.truncate(1);
        b.nodes[0] = leaf(good.nodes[0].bounds, 0, 2);
        assert_eq!(
            b.check_invariants(&tris, &one).unwrap_err().to_string(),
            "leaf 0 holds 2 triangles > 1"
        );
        b.check_invariants(&tris, &cfg).unwrap();
    }
}
