//! A small scene with its SGRT tracer, memory image and workload, for the tests.
#![allow(dead_code)]

use rtsim_bvh::{Builder, BvhConfig, ImageExtras, MemoryImage, MemoryLayoutConfig, NodeOrder};
use rtsim_cache::FixedLatency;
use rtsim_dram::{Dram, Requester};
use rtsim_scene::{Scene, SceneRequest, load_scene};
use rtsim_sgrt::{Engine, Input, Sgrt, SgrtConfig, SgrtResult, memory_tags};
use rtsim_trace::{
    Integrator, TraceConfig, Tracer, Traversal, TriangleTest, WorkloadKind, WorkloadParams,
};

pub struct Setup {
    pub scene: Scene,
    pub tracer: Tracer,
    pub image: MemoryImage,
    pub params: WorkloadParams,
}

/// The built-in Cornell box with SGRT's traversal (short stack of `entries`), Wald's test and
/// the sweep SAH builder.
pub fn cornell(kind: WorkloadKind, width: u32, height: u32, spp: u32, entries: u32) -> Setup {
    let scene = load_scene(&SceneRequest {
        name: "cornell",
        size: 1.0,
        seed: 1,
        scene_dir: None,
    })
    .unwrap();
    setup(scene, kind, width, height, spp, entries)
}

pub fn setup(
    scene: Scene,
    kind: WorkloadKind,
    width: u32,
    height: u32,
    spp: u32,
    entries: u32,
) -> Setup {
    setup_leaves(scene, kind, width, height, spp, entries, 4)
}

/// [`setup`] with leaves of at most `max_leaf` triangles.
pub fn setup_leaves(
    scene: Scene,
    kind: WorkloadKind,
    width: u32,
    height: u32,
    spp: u32,
    entries: u32,
    max_leaf: u32,
) -> Setup {
    let bvh_cfg = BvhConfig {
        builder: Builder::Sweep,
        max_leaf_size: max_leaf,
        ..BvhConfig::default()
    };
    let bvh = rtsim_bvh::build(&scene.triangles, &bvh_cfg, NodeOrder::DepthFirst).unwrap();
    let mem = MemoryLayoutConfig::default();
    let extras = ImageExtras::for_run(&mem, true, scene.materials.len() as u32, width, height);
    let image = MemoryImage::build(&bvh, &mem, &extras).unwrap();
    let tc = TraceConfig {
        traversal: Traversal::ShortStack,
        triangle_test: TriangleTest::Wald,
        short_stack_entries: entries,
        fast_path: false,
        ..TraceConfig::default()
    };
    let tracer = Tracer::new(&scene.triangles, bvh, &tc).unwrap();
    let b = scene.bounds();
    let params = WorkloadParams {
        kind,
        width,
        height,
        spp,
        max_depth: 5,
        specular_bounces: 2,
        ao_radius: 0.2 * b.extent().length(),
        seed: 7,
    };
    Setup {
        scene,
        tracer,
        image,
        params,
    }
}

/// LPDDR3-1600 at the T&I clock with the tags the chip needs.
pub fn lpddr3(c: &SgrtConfig) -> Dram {
    let d = rtsim_dram::config::preset_config("lpddr3-1600").unwrap();
    Dram::new(
        &d,
        Requester::mhz(f64::from(c.ti_clock_mhz)).with_tags(memory_tags(c)),
    )
    .unwrap()
}

/// A memory answering every line after `latency` cycles.
pub fn fixed(c: &SgrtConfig, latency: u64) -> FixedLatency {
    FixedLatency::new(latency, 1 << 16, 64, memory_tags(c))
}

/// Run the frame of `s` on the chip of `c` over LPDDR3.
pub fn run_frame(s: &Setup, c: &SgrtConfig, engine: Engine) -> SgrtResult<Dram> {
    let pixels: Vec<u32> = (0..s.params.width * s.params.height).collect();
    run_pixels(s, c, engine, pixels, lpddr3(c))
}

/// Run `pixels` of the frame of `s` on the chip of `c` over `memory`.
pub fn run_pixels<M: rtsim_core::MemoryPort>(
    s: &Setup,
    c: &SgrtConfig,
    engine: Engine,
    pixels: Vec<u32>,
    memory: M,
) -> SgrtResult<M> {
    let integ = Integrator::new(&s.scene, &s.tracer, s.params.clone());
    let timed = Input::timed_kinds(s.params.kind, c.shader);
    let mut chip = Sgrt::new(
        c,
        &s.tracer,
        &s.image,
        Input::Frame {
            integ: &integ,
            pixels,
            timed,
        },
        memory,
        1,
    )
    .unwrap();
    chip.run(engine, None, &mut |_, _| {}).unwrap();
    chip.finish().unwrap()
}

/// The functional frame: per-pixel colours and counters by kind.
pub fn functional(s: &Setup) -> (Vec<rtsim_trace::PixelResult>, rtsim_trace::FrameStats) {
    let integ = Integrator::new(&s.scene, &s.tracer, s.params.clone());
    let mut stats = rtsim_trace::FrameStats::default();
    let (w, h) = (s.params.width, s.params.height);
    let px = (0..w * h)
        .map(|i| integ.pixel(i % w, i / w, &mut stats))
        .collect();
    (px, stats)
}

/// Pixel colours as bits, for exact comparison.
pub fn bits(p: &[rtsim_trace::PixelResult]) -> Vec<[u32; 3]> {
    p.iter()
        .map(|p| p.color.to_array().map(f32::to_bits))
        .collect()
}
