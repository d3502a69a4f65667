//! Statistics of a built BVH (`rtsim bvh-stats`): SAH cost, counts, depth, leaf sizes, build
//! time and memory image sizes. Numerators and denominators are kept; averages are computed
//! when reported.

use crate::config::BvhConfig;
use crate::flat::Bvh;
use crate::memory::MemoryImage;
use serde::Serialize;
use std::time::Duration;

/// Statistics of one BVH.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct BvhStats {
    pub triangles: u64,
    pub nodes: u64,
    pub inner_nodes: u64,
    pub leaves: u64,
    /// SAH cost normalised by the root's surface area: Σ over inner nodes of
    /// `A(n)/A(root) · traversal_cost` + Σ over leaves of `A(l)/A(root) · intersection_cost ·
    /// count`. (With a zero-area root every node counts with probability 1.)
    pub sah_cost: f64,
    pub traversal_cost: f32,
    pub intersection_cost: f32,
    /// Deepest leaf, in edges from the root.
    pub max_leaf_depth: u32,
    /// Sum of all leaves' depths (average = this / `leaves`).
    pub leaf_depth_sum: u64,
    pub min_leaf_size: u32,
    pub max_leaf_size: u32,
    /// `leaf_size_histogram[k]` = leaves holding `k` triangles (index 0 is always 0).
    pub leaf_size_histogram: Vec<u64>,
    /// Wall-clock build time, if measured.
    pub build_seconds: Option<f64>,
    /// Memory image: node records, triangle records, whole span (padding included).
    pub node_region_bytes: Option<u64>,
    pub triangle_region_bytes: Option<u64>,
    pub image_span_bytes: Option<u64>,
}

/// SAH cost of `bvh`, normalised by the root area (see [`BvhStats::sah_cost`]).
pub fn sah_cost(bvh: &Bvh, traversal_cost: f32, intersection_cost: f32) -> f64 {
    let Some(root) = bvh.nodes.first() else {
        return 0.0;
    };
    let root_area = root.bounds.surface_area() as f64;
    let p = |a: f32| {
        if root_area > 0.0 {
            a as f64 / root_area
        } else {
            1.0
        }
    };
    bvh.nodes
        .iter()
        .map(|n| {
            let w = if n.is_leaf() {
                intersection_cost as f64 * n.count as f64
            } else {
                traversal_cost as f64
            };
            p(n.bounds.surface_area()) * w
        })
        .sum()
}

impl BvhStats {
    /// Counts, depths, leaf sizes and SAH cost (with `config`'s costs).
    pub fn compute(bvh: &Bvh, config: &BvhConfig) -> Self {
        let mut s = BvhStats {
            triangles: bvh.prim_ids.len() as u64,
            nodes: bvh.nodes.len() as u64,
            sah_cost: sah_cost(bvh, config.traversal_cost, config.intersection_cost),
            traversal_cost: config.traversal_cost,
            intersection_cost: config.intersection_cost,
            min_leaf_size: u32::MAX,
            ..Default::default()
        };
        let depths = bvh.depths();
        for (n, &d) in bvh.nodes.iter().zip(&depths) {
            if n.is_leaf() {
                s.leaves += 1;
                s.leaf_depth_sum += d as u64;
                s.max_leaf_depth = s.max_leaf_depth.max(d);
                s.min_leaf_size = s.min_leaf_size.min(n.count);
                s.max_leaf_size = s.max_leaf_size.max(n.count);
                let k = n.count as usize;
                if s.leaf_size_histogram.len() <= k {
                    s.leaf_size_histogram.resize(k + 1, 0);
                }
                s.leaf_size_histogram[k] += 1;
            } else {
                s.inner_nodes += 1;
            }
        }
        if s.leaves == 0 {
            s.min_leaf_size = 0;
        }
        s
    }

    pub fn with_build_time(mut self, t: Duration) -> Self {
        self.build_seconds = Some(t.as_secs_f64());
        self
    }

    pub fn with_image(mut self, image: &MemoryImage) -> Self {
        let size = |name| image.region(name).map(|r| r.size_bytes);
        self.node_region_bytes = size(crate::memory::NODES_REGION);
        self.triangle_region_bytes = size(crate::memory::TRIANGLES_REGION);
        let (lo, hi) = image.span();
        self.image_span_bytes = Some(hi - lo);
        self
    }

    pub fn avg_leaf_depth(&self) -> f64 {
        ratio(self.leaf_depth_sum, self.leaves)
    }

    pub fn avg_leaf_size(&self) -> f64 {
        ratio(self.triangles, self.leaves)
    }
}

fn ratio(a: u64, b: u64) -> f64 {
    if b == 0 { 0.0 } else { a as f64 / b as f64 }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::flat::Node;
    use rtsim_core::{Aabb, Vec3};

    #[test]
    fn sah_of_hand_built_tree() {
        // Root: unit cube (area 6). Children: two half-cubes 0.5×1×1 (area 4 each), leaves
        // with 1 and 2 triangles. SAH = 1·C_t + (4/6)·1·C_i + (4/6)·2·C_i.
        let cube = Aabb::new(Vec3::ZERO, Vec3::ONE);
        let left = Aabb::new(Vec3::ZERO, Vec3::new(0.5, 1.0, 1.0));
        let right = Aabb::new(Vec3::new(0.5, 0.0, 0.0), Vec3::ONE);
        let bvh = Bvh {
            nodes: vec![
                Node {
                    bounds: cube,
                    index: 1,
                    count: 0,
                },
                Node {
                    bounds: left,
                    index: 0,
                    count: 1,
                },
                Node {
                    bounds: right,
                    index: 1,
                    count: 2,
                },
            ],
            prim_ids: vec![0, 1, 2],
        };
        let c = sah_cost(&bvh, 1.0, 1.0);
        assert!((c - (1.0 + 4.0 / 6.0 * 3.0)).abs() < 1e-9, "{c}");
        let c = sah_cost(&bvh, 2.0, 0.5);
        assert!((c - (2.0 + 4.0 / 6.0 * 1.5)).abs() < 1e-9, "{c}");
        let s = BvhStats::compute(&bvh, &BvhConfig::default());
        assert_eq!((s.nodes, s.inner_nodes, s.leaves), (3, 1, 2));
        assert_eq!((s.min_leaf_size, s.max_leaf_size), (1, 2));
        assert_eq!(s.leaf_size_histogram, vec![0, 1, 1]);
        assert_eq!((s.max_leaf_depth, s.avg_leaf_depth()), (1, 1.0));
        assert_eq!(s.avg_leaf_size(), 1.5);
    }

    #[test]
    fn empty_bvh_stats_are_zero() {
        let s = BvhStats::compute(&Bvh::default(), &BvhConfig::default());
        assert_eq!(
            (s.nodes, s.leaves, s.min_leaf_size, s.sah_cost),
            (0, 0, 0, 0.0)
        );
        assert_eq!(s.avg_leaf_depth(), 0.0);
    }
}
