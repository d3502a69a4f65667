//! The typed facts every `stats.json` starts with: what was run (scene, BVH, workload) and
//! the rays it traced. Counters only; ratios are computed when reporting.

use rtsim_bvh::{Bvh, MemoryImage};
use rtsim_scene::Scene;
use rtsim_trace::{CounterTotals, FrameStats, WorkloadKind, WorkloadParams};
use serde::Serialize;
use std::collections::BTreeMap;

/// The scene and what loading it dropped.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SceneFacts {
    pub name: String,
    pub triangles: usize,
    pub materials: usize,
    pub dropped_degenerate: u64,
    pub dropped_non_finite: u64,
    pub polygons_triangulated: u64,
}

impl SceneFacts {
    pub fn of(scene: &Scene) -> SceneFacts {
        SceneFacts {
            name: scene.name.clone(),
            triangles: scene.triangles.len(),
            materials: scene.materials.len(),
            dropped_degenerate: scene.report.dropped_degenerate,
            dropped_non_finite: scene.report.dropped_non_finite,
            polygons_triangulated: scene.report.polygons_triangulated,
        }
    }
}

/// The BVH and, with a treelet layout, its treelets.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct BvhFacts {
    pub nodes: usize,
    pub leaves: usize,
    /// Levels, the root's included.
    pub depth: usize,
    pub node_treelets: Option<usize>,
    pub triangle_treelets: Option<usize>,
}

impl BvhFacts {
    pub fn of(bvh: &Bvh, image: Option<&MemoryImage>) -> BvhFacts {
        let treelets = image.and_then(|i| i.treelets());
        BvhFacts {
            nodes: bvh.nodes.len(),
            leaves: bvh.nodes.iter().filter(|n| n.is_leaf()).count(),
            depth: rtsim_trace::tracer::bvh_depth(bvh),
            node_treelets: treelets.map(|t| t.node_treelets().len()),
            triangle_treelets: treelets.map(|t| t.triangle_treelets().len()),
        }
    }
}

/// The frame's workload, defaults resolved.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct WorkloadFacts {
    pub kind: WorkloadKind,
    pub width: u32,
    pub height: u32,
    pub spp: u32,
    pub max_depth: u32,
    pub specular_bounces: u32,
    pub ao_radius: f32,
    pub seed: u64,
}

impl WorkloadFacts {
    pub fn of(p: &WorkloadParams) -> WorkloadFacts {
        WorkloadFacts {
            kind: p.kind,
            width: p.width,
            height: p.height,
            spp: p.spp,
            max_depth: p.max_depth,
            specular_bounces: p.specular_bounces,
            ao_radius: p.ao_radius,
            seed: p.seed,
        }
    }
}

/// The rays traced, by kind and in total.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct RayFacts {
    /// Kinds that traced rays (`primary`, `shadow`, `bounce`, `ao`, `diffuse`, `specular`).
    pub by_kind: BTreeMap<String, CounterTotals>,
    pub total: CounterTotals,
    /// Path tracing: camera rays, bounces and shadow rays (STRaTA's "ray segments").
    pub path_segments: Option<u64>,
}

impl RayFacts {
    pub fn of(stats: &FrameStats, kind: WorkloadKind) -> RayFacts {
        RayFacts {
            by_kind: stats
                .by_kind()
                .into_iter()
                .map(|(k, c)| (k.to_string(), c))
                .collect(),
            total: stats.total(),
            path_segments: (kind == WorkloadKind::Path).then(|| stats.path_segments()),
        }
    }
}
