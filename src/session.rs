//! What every tracing command does first: resolve the configuration, load the scene, set up
//! the thread pool, build the BVH and the tracer, and say what was loaded.

use crate::cli::SceneArgs;
use crate::run_config::{self, Flag, Resolved};
use anyhow::{Context, Result};
use rtsim_trace::fast::FastBvh;
use rtsim_trace::{Tracer, TriangleTest};
use std::time::Instant;

/// A loaded scene with its tracer.
#[derive(Debug)]
pub struct Session {
    pub resolved: Resolved,
    pub tracer: Tracer,
    /// The memory image (addresses of every record; treelets with `memory.layout =
    /// "treelets"`, whose ids the tracer then counts crossings of).
    pub image: rtsim_bvh::MemoryImage,
    pub pool: rayon::ThreadPool,
    /// The 4-wide fast path, when asked for and enabled (`trace.fast_path` with the
    /// Möller–Trumbore kernel).
    pub fast: Option<FastBvh>,
    /// Wall-clock seconds of the BVH build.
    pub build_seconds: f64,
}

/// A rayon pool with `threads` workers (0 = all cores).
pub fn thread_pool(threads: usize) -> Result<rayon::ThreadPool> {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .context("creating the thread pool")
}

/// Resolve, load, build (for commands without output files to check first).
#[allow(dead_code)]
pub fn open(args: &SceneArgs, flags: &[Flag], want_fast: bool) -> Result<Session> {
    build(run_config::resolve(args, flags)?, want_fast)
}

/// Build the BVH, memory image and tracer of a resolved run (commands that write files plan
/// their outputs between resolving and this, so a bad `--out` fails before the work).
pub fn build(resolved: Resolved, want_fast: bool) -> Result<Session> {
    let scene = &resolved.scene;
    let pool = thread_pool(resolved.config.threads)?;
    let start = Instant::now();
    let cfg = &resolved.config;
    let bvh = pool.install(|| rtsim_bvh::build(&scene.triangles, &cfg.bvh, cfg.memory.order))?;
    let build_seconds = start.elapsed().as_secs_f64();
    let fast = fast_path(&cfg.trace, want_fast, &scene.triangles, &bvh)?;
    let (width, height, _) = cfg.workload.resolved_size();
    let extras = rtsim_bvh::ImageExtras::for_run(
        &cfg.memory,
        cfg.trace.triangle_test == TriangleTest::Wald,
        scene.materials.len() as u32,
        width,
        height,
    );
    let image = rtsim_bvh::MemoryImage::build(&bvh, &cfg.memory, &extras)?;
    let mut tracer = Tracer::new(&scene.triangles, bvh, &cfg.trace)?;
    if let Some(t) = image.treelets() {
        tracer.set_treelets(t.node_treelet.clone())?;
    }
    Ok(Session {
        resolved,
        tracer,
        image,
        pool,
        fast,
        build_seconds,
    })
}

/// The fast path if it is wanted and applies to the configured kernel.
pub fn fast_path(
    cfg: &rtsim_trace::TraceConfig,
    want: bool,
    triangles: &[[rtsim_core::Vec3; 3]],
    bvh: &rtsim_bvh::Bvh,
) -> Result<Option<FastBvh>> {
    // The fast path answers like the `stack` variant; other variants answer themselves.
    if !(want
        && cfg.fast_path
        && cfg.triangle_test == TriangleTest::MollerTrumbore
        && cfg.traversal == rtsim_trace::Traversal::Stack)
    {
        return Ok(None);
    }
    Ok(Some(FastBvh::new(triangles, bvh)?))
}
