//! [`World`]: a scene prepared the way STRaTA needs it — a BVH no deeper than the bit stack
//! (32 levels, §3.2), the treelet memory layout with parent pointers and treelet tags (§3.1),
//! and a `bit-stack` tracer that knows every node's treelet, so its traversal steps through
//! treelet crossings.

use rtsim_bvh::{BvhConfig, ImageExtras, Layout, MemoryImage, MemoryLayoutConfig, Treelets};
use rtsim_scene::{Scene, SceneRequest, load_scene};
use rtsim_trace::step::bitstack::MAX_LEVELS;
use rtsim_trace::{TraceConfig, Tracer, Traversal, TriangleTest};
use std::path::Path;

/// A scene, its treelet memory image and its `bit-stack` tracer.
#[derive(Debug)]
pub struct World {
    pub scene: Scene,
    pub tracer: Tracer,
    pub image: MemoryImage,
    pub width: u32,
    pub height: u32,
}

/// Why a world could not be built.
#[derive(Debug, thiserror::Error)]
pub enum WorldError {
    #[error("scene {name}: {message}")]
    Scene { name: String, message: String },
    #[error("BVH or memory image: {0}")]
    Build(String),
}

/// The memory layout STRaTA reads: treelets of `treelet_bytes` with parent pointers (40-byte
/// node records carrying parent and treelet tag, `docs/MEMORY_IMAGE.md`).
pub fn memory_config(treelet_bytes: u64) -> MemoryLayoutConfig {
    MemoryLayoutConfig {
        layout: Layout::Treelets,
        parent_pointers: true,
        treelet_bytes,
        ..MemoryLayoutConfig::default()
    }
}

/// The tracer settings STRaTA runs: the `bit-stack` traversal (§3.2), nearest child first,
/// and the Plücker triangle test of its triangle pipeline (§3.3).
pub fn trace_config() -> TraceConfig {
    TraceConfig {
        traversal: Traversal::BitStack,
        triangle_test: TriangleTest::Plucker,
        ..TraceConfig::default()
    }
}

impl World {
    /// Load scene `name` (built-in, or shipped from `scene_dir`) and prepare it for an image
    /// of `width × height` with `memory`'s layout (use [`memory_config`]).
    pub fn load(
        name: &str,
        scene_dir: Option<&Path>,
        width: u32,
        height: u32,
        memory: &MemoryLayoutConfig,
        trace: &TraceConfig,
    ) -> Result<World, WorldError> {
        let scene = load_scene(&SceneRequest {
            name,
            size: 1.0,
            seed: 1,
            scene_dir,
        })
        .map_err(|e| WorldError::Scene {
            name: name.into(),
            message: e.to_string(),
        })?;
        World::new(scene, width, height, memory, trace)
    }

    /// Prepare a loaded scene.
    pub fn new(
        scene: Scene,
        width: u32,
        height: u32,
        memory: &MemoryLayoutConfig,
        trace: &TraceConfig,
    ) -> Result<World, WorldError> {
        let bvh_cfg = BvhConfig {
            max_depth: MAX_LEVELS,
            ..BvhConfig::default()
        };
        let bvh = rtsim_bvh::build(&scene.triangles, &bvh_cfg, memory.order)
            .map_err(|e| WorldError::Build(e.to_string()))?;
        let extras =
            ImageExtras::for_run(memory, false, scene.materials.len() as u32, width, height);
        let image = MemoryImage::build(&bvh, memory, &extras)
            .map_err(|e| WorldError::Build(e.to_string()))?;
        let mut tracer = Tracer::new(&scene.triangles, bvh, trace)
            .map_err(|e| WorldError::Build(e.to_string()))?;
        if let Some(t) = image.treelets() {
            tracer
                .set_treelets(t.node_treelet.clone())
                .map_err(|e| WorldError::Build(e.to_string()))?;
        }
        Ok(World {
            scene,
            tracer,
            image,
            width,
            height,
        })
    }

    /// The treelets of the image (`None` in the linear layout).
    pub fn treelets(&self) -> Option<&Treelets> {
        self.image.treelets()
    }
}
