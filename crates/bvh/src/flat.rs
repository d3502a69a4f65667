//! The flat BVH that traversal reads: [`Node`] and [`Bvh`], plus structural queries (parents,
//! depths) and an invariant check used by tests and `rtsim bvh-stats`.

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
    /// Returns the first violation found, as a sentence naming the node.
    pub fn check_invariants(
        &self,
        triangles: &[[Vec3; 3]],
        config: &BvhConfig,
    ) -> Result<(), String> {
        let n_nodes = self.nodes.len();
        if triangles.is_empty() {
            return if n_nodes == 0 && self.prim_ids.is_empty() {
                Ok(())
            } else {
                Err("empty scene but non-empty BVH".into())
            };
        }
        if n_nodes == 0 {
            return Err("no nodes for a non-empty scene".into());
        }
        if self.prim_ids.len() != triangles.len() {
            return Err(format!(
                "{} triangle slots for {} triangles",
                self.prim_ids.len(),
                triangles.len()
            ));
        }
        let mut seen_id = vec![false; triangles.len()];
        for (slot, &id) in self.prim_ids.iter().enumerate() {
            let Some(s) = seen_id.get_mut(id as usize) else {
                return Err(format!("slot {slot} holds triangle {id}, out of range"));
            };
            if std::mem::replace(s, true) {
                return Err(format!("triangle {id} appears in two slots"));
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
                return Err(format!("node {i} at depth {depth} > {}", config.max_depth));
            }
            if n.is_leaf() {
                if n.count > config.max_leaf_size {
                    return Err(format!(
                        "leaf {i} holds {} triangles > {}",
                        n.count, config.max_leaf_size
                    ));
                }
                let (s, e) = (n.index as usize, n.index as usize + n.count as usize);
                if e > slot_covered.len() {
                    return Err(format!("leaf {i} slots {s}..{e} out of range"));
                }
                let mut b = Aabb::EMPTY;
                for slot in s..e {
                    if std::mem::replace(&mut slot_covered[slot], true) {
                        return Err(format!("slot {slot} in two leaves"));
                    }
                    for &v in &triangles[self.prim_ids[slot] as usize] {
                        b.grow(v);
                    }
                }
                if b != n.bounds {
                    return Err(format!(
                        "leaf {i} box {:?} is not the bounds of its triangles {b:?}",
                        n.bounds
                    ));
                }
            } else {
                let c = n.index as usize;
                if c <= i || c + 1 >= n_nodes {
                    return Err(format!("node {i} has children {c},{} out of order", c + 1));
                }
                if c % 2 == 0 {
                    return Err(format!("node {i}: sibling pair starts at even index {c}"));
                }
                let (l, r) = (&self.nodes[c], &self.nodes[c + 1]);
                if !n.bounds.contains_box(&l.bounds) || !n.bounds.contains_box(&r.bounds) {
                    return Err(format!("node {i}: a child box leaves the parent box"));
                }
                if l.bounds.union(r.bounds) != n.bounds {
                    return Err(format!("node {i}: box is not the union of its children"));
                }
                for k in [c, c + 1] {
                    if std::mem::replace(&mut reached[k], true) {
                        return Err(format!("node {k} reached twice"));
                    }
                    stack.push((k, depth + 1));
                }
            }
        }
        if let Some(k) = reached.iter().position(|&r| !r) {
            return Err(format!("node {k} unreachable from the root"));
        }
        if let Some(s) = slot_covered.iter().position(|&c| !c) {
            return Err(format!("slot {s} in no leaf"));
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
        assert!(
            b.check_invariants(&tris, &cfg)
                .unwrap_err()
                .contains("two slots")
        );

        let mut b = good.clone();
        b.nodes[1].bounds.max.x += 1.0;
        assert!(b.check_invariants(&tris, &cfg).is_err());

        let mut b = good.clone();
        b.nodes[2].index = 0; // both leaves claim slot 0
        assert!(b.check_invariants(&tris, &cfg).is_err());

        let mut b = good.clone();
        b.nodes[0].bounds.max.y += 1.0; // parent not the union of its children
        assert!(
            b.check_invariants(&tris, &cfg)
                .unwrap_err()
                .contains("union")
        );

        let shallow = BvhConfig {
            max_depth: 0,
            ..Default::default()
        };
        assert!(good.check_invariants(&tris, &shallow).is_err());

        let one = BvhConfig {
            max_leaf_size: 1,
            ..Default::default()
        };
        let mut b = good.clone();
        b.nodes.truncate(1);
        b.nodes[0] = leaf(good.nodes[0].bounds, 0, 2);
        assert!(
            b.check_invariants(&tris, &one)
                .unwrap_err()
                .contains("holds 2")
        );
        b.check_invariants(&tris, &cfg).unwrap();
    }
}
