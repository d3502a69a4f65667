//! Test support: scenes, the functional reference, small chips.
#![allow(dead_code)]

use rtsim_bvh::{ImageExtras, MemoryImage, MemoryLayoutConfig};
use rtsim_scene::{Scene, SceneRequest, load_scene};
use rtsim_trace::{
    FrameStats, Integrator, PixelResult, TraceConfig, Tracer, WorkloadKind, WorkloadParams,
};
use rtsim_trax::{Engine, Frame, Options, Output, TraxConfig};
use std::path::PathBuf;

/// A scene with its BVH, tracer and memory image.
pub struct World {
    pub scene: Scene,
    pub tracer: Tracer,
    pub image: MemoryImage,
    pub width: u32,
    pub height: u32,
}

/// The shared scene directory: `$RTSIM_SCENE_DIR`, else `../shared/scenes` beside the
/// repository.
pub fn scene_dir() -> Option<PathBuf> {
    if let Some(d) = std::env::var_os("RTSIM_SCENE_DIR").filter(|d| !d.is_empty()) {
        return Some(PathBuf::from(d));
    }
    let d = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/scenes");
    d.is_dir().then_some(d)
}

/// Scene `name` at `width × height` (`None`, with a note, when a shared scene's directory is
/// not configured).
pub fn world(name: &str, width: u32, height: u32) -> Option<World> {
    let dir = scene_dir();
    let builtin = rtsim_scene::procedural::BUILTIN_NAMES.contains(&name);
    if !builtin && dir.is_none() {
        eprintln!("skipping {name}: no scene directory (set RTSIM_SCENE_DIR)");
        return None;
    }
    let scene = load_scene(&SceneRequest {
        name,
        size: 1.0,
        seed: 1,
        scene_dir: dir.as_deref(),
    })
    .unwrap_or_else(|e| panic!("scene {name}: {e}"));
    let bvh = rtsim_bvh::build(
        &scene.triangles,
        &Default::default(),
        rtsim_bvh::NodeOrder::DepthFirst,
    )
    .unwrap();
    let mem = MemoryLayoutConfig::default();
    let extras = ImageExtras::for_run(&mem, false, scene.materials.len() as u32, width, height);
    let image = MemoryImage::build(&bvh, &mem, &extras).unwrap();
    let trace = TraceConfig::default();
    let tracer = Tracer::new(&scene.triangles, bvh, &trace).unwrap();
    Some(World {
        scene,
        tracer,
        image,
        width,
        height,
    })
}

pub fn params(w: &World, kind: WorkloadKind, spp: u32) -> WorkloadParams {
    WorkloadParams {
        kind,
        width: w.width,
        height: w.height,
        spp,
        max_depth: 5,
        specular_bounces: 2,
        ao_radius: 0.3,
        seed: 7,
    }
}

/// Every pixel of the image, row-major.
pub fn all_pixels(w: &World) -> Vec<u32> {
    (0..w.width * w.height).collect()
}

/// The functional tracer's image and counters for `pixels`.
pub fn functional(w: &World, p: &WorkloadParams, pixels: &[u32]) -> (Vec<PixelResult>, FrameStats) {
    let integ = Integrator::new(&w.scene, &w.tracer, p.clone());
    let mut out = vec![PixelResult::default(); (w.width * w.height) as usize];
    let mut stats = FrameStats::default();
    for &px in pixels {
        out[px as usize] = integ.pixel(px % w.width, px / w.width, &mut stats);
    }
    (out, stats)
}

/// A chip of `tms` × `tps` with otherwise default parameters.
pub fn chip(tms: u32, tps: u32) -> TraxConfig {
    TraxConfig {
        tms,
        tps_per_tm: tps,
        icaches_per_tm: 4.min(tps),
        ..TraxConfig::default()
    }
}

/// Simulate `pixels` of `w` on `cfg`.
pub fn simulate(
    w: &World,
    p: &WorkloadParams,
    cfg: &TraxConfig,
    engine: Engine,
    pixels: &[u32],
) -> Output {
    simulate_until(w, p, cfg, engine, pixels, None)
}

/// Simulate `pixels` of `w` on `cfg`, stopping after `cycle_limit` cycles if given.
pub fn simulate_until(
    w: &World,
    p: &WorkloadParams,
    cfg: &TraxConfig,
    engine: Engine,
    pixels: &[u32],
    cycle_limit: Option<u64>,
) -> Output {
    simulate_threads(w, p, cfg, engine, pixels, cycle_limit, 1)
}

/// [`simulate_until`] recording the time series every `every` cycles, on `threads` host
/// threads (the time series runs on one).
pub fn simulate_timeline(
    w: &World,
    p: &WorkloadParams,
    cfg: &TraxConfig,
    engine: Engine,
    cycle_limit: Option<u64>,
    every: u64,
    threads: usize,
) -> Output {
    let opts = Options {
        engine,
        cycle_limit,
        seed: 1,
        threads,
        timeline: Some(every),
    };
    simulate_with(w, p, cfg, &all_pixels(w), &opts)
}

/// [`simulate_until`] with the fast engine on `threads` host threads.
pub fn simulate_threads(
    w: &World,
    p: &WorkloadParams,
    cfg: &TraxConfig,
    engine: Engine,
    pixels: &[u32],
    cycle_limit: Option<u64>,
    threads: usize,
) -> Output {
    let opts = Options {
        engine,
        cycle_limit,
        seed: 1,
        threads,
        timeline: None,
    };
    simulate_with(w, p, cfg, pixels, &opts)
}

/// Simulate `pixels` of `w` on `cfg` with `opts`.
pub fn simulate_with(
    w: &World,
    p: &WorkloadParams,
    cfg: &TraxConfig,
    pixels: &[u32],
    opts: &Options,
) -> Output {
    let integ = Integrator::new(&w.scene, &w.tracer, p.clone());
    rtsim_trax::simulate(
        cfg,
        &rtsim_dram::DramConfig::default(),
        Frame {
            integ: &integ,
            tracer: &w.tracer,
            image: &w.image,
            pixels,
            image_pixels: (w.width * w.height) as usize,
        },
        opts,
        &mut |_| {},
    )
    .unwrap()
}

/// Pixels equal bit for bit.
pub fn assert_same_image(a: &[PixelResult], b: &[PixelResult]) {
    assert_eq!(a.len(), b.len());
    for (i, (x, y)) in a.iter().zip(b).enumerate() {
        assert_eq!(
            x.color.to_array().map(f32::to_bits),
            y.color.to_array().map(f32::to_bits),
            "pixel {i}"
        );
        assert_eq!(x.nodes_visited, y.nodes_visited, "pixel {i}");
    }
}
