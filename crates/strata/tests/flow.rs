//! The functional ray flow against the functional tracer: every pixel equal, every ray's
//! counters equal, nothing lost or duplicated, whatever the stream size and policy.

use rtsim_strata::config::{Policy, StrataConfig, StreamConfig};
use rtsim_strata::flow::{self, FlowChip, FlowOutput, Frame};
use rtsim_strata::world::{self, World};
use rtsim_trace::{FrameStats, Integrator, PixelResult, WorkloadKind, WorkloadParams};
use std::path::PathBuf;

/// The shared scene directory: `$RTSIM_SCENE_DIR`, else `../shared/scenes` beside the
/// repository.
fn scene_dir() -> Option<PathBuf> {
    if let Some(d) = std::env::var_os("RTSIM_SCENE_DIR").filter(|d| !d.is_empty()) {
        return Some(PathBuf::from(d));
    }
    let d = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/scenes");
    d.is_dir().then_some(d)
}

fn load(name: &str, w: u32, h: u32) -> Option<World> {
    let dir = scene_dir();
    if name != "cornell" && dir.is_none() {
        eprintln!("skipping {name}: no scene directory (set RTSIM_SCENE_DIR)");
        return None;
    }
    Some(
        World::load(
            name,
            dir.as_deref(),
            w,
            h,
            &world::memory_config(16 << 10),
            &world::trace_config(),
        )
        .unwrap(),
    )
}

fn params(w: &World, spp: u32) -> WorkloadParams {
    WorkloadParams {
        kind: WorkloadKind::Path,
        width: w.width,
        height: w.height,
        spp,
        max_depth: 5,
        specular_bounces: 2,
        ao_radius: 0.3,
        seed: 7,
    }
}

fn functional(w: &World, p: &WorkloadParams) -> (Vec<PixelResult>, FrameStats) {
    let integ = Integrator::new(&w.scene, &w.tracer, p.clone());
    let mut stats = FrameStats::default();
    let out = (0..w.width * w.height)
        .map(|px| integ.pixel(px % w.width, px / w.width, &mut stats))
        .collect();
    (out, stats)
}

fn strata(w: &World, p: &WorkloadParams, cfg: &StrataConfig, chip: &FlowChip) -> FlowOutput {
    let integ = Integrator::new(&w.scene, &w.tracer, p.clone());
    let pixels: Vec<u32> = (0..w.width * w.height).collect();
    flow::run(
        cfg,
        chip,
        Frame {
            integ: &integ,
            tracer: &w.tracer,
            image: &w.image,
            pixels: &pixels,
            image_pixels: pixels.len(),
        },
    )
    .unwrap()
}

fn chip(tms: u32, tps: u32) -> FlowChip {
    FlowChip::new(tms, tps)
}

fn assert_same(out: &FlowOutput, reference: &(Vec<PixelResult>, FrameStats)) {
    assert_eq!(out.pixels.len(), reference.0.len());
    for (i, (a, b)) in out.pixels.iter().zip(&reference.0).enumerate() {
        assert_eq!(
            a.color.to_array().map(f32::to_bits),
            b.color.to_array().map(f32::to_bits),
            "pixel {i}"
        );
        assert_eq!(a.nodes_visited, b.nodes_visited, "pixel {i}");
    }
    assert_eq!(out.rays, reference.1, "per-kind ray counters");
}

/// What every run must satisfy, whatever the scene and settings.
fn assert_invariants(out: &FlowOutput, pixels: u64) {
    let s = &out.stats;
    assert_eq!(s.pixels_done, pixels);
    assert_eq!(s.rays, out.rays.total().rays);
    // Every push was popped: the memory ends empty, no ray lost or left behind.
    assert_eq!(s.stream.pushes, s.stream.pops);
    assert_eq!(
        s.stream.pushes,
        s.pushes_root + s.pushes_crossing + s.pushes_to_triangles + s.pushes_from_triangles
    );
    // One root push per ray (its first), one-for-one.
    assert_eq!(s.pushes_root, s.rays);
    assert_eq!(s.stream.overflows, 0);
    // Every node-treelet crossing of the traversal is one push.
    assert_eq!(s.pushes_crossing, out.rays.total().treelet_crossings);
    // Trips to triangle treelets come back, except for rays that end there (any-hit exit).
    assert!(s.pushes_from_triangles <= s.pushes_to_triangles);
    assert!(s.stream.peak_rays <= s.layout.unwrap().slots);
    assert_eq!(s.wrong_kind_steps, 0, "node and triangle work never mix");
    assert_eq!(s.path_state_reads, s.rays);
    assert_eq!(s.path_state_writes, s.rays);
    assert_eq!(s.framebuffer_writes, pixels);
    // The fused pipelines replace box and triangle arithmetic by single tests.
    assert!(s.fetches_traversal_fused < s.fetches_traversal_scalar);
    assert_eq!(s.fetches_stream, s.stream.pushes + s.stream.pops);
    assert!(s.fetches_shading > 0);
}

#[test]
fn cornell_equals_the_functional_tracer() {
    let w = load("cornell", 24, 24).unwrap();
    let p = params(&w, 1);
    let reference = functional(&w, &p);
    let out = strata(&w, &p, &StrataConfig::default(), &chip(4, 8));
    assert_same(&out, &reference);
    assert_invariants(&out, 24 * 24);
    // All 576 paths fit the default 4 MB at once.
    assert_eq!(out.stats.initial_paths, 576);
    // Each push and pop is one access at Table 2's 4 MB energy.
    let s = &out.stats;
    assert_eq!(s.stream_access_nj, 0.901);
    let j = (s.stream.pushes + s.stream.pops) as f64 * 0.901e-9;
    assert!((s.stream_energy_j() - j).abs() <= 1e-12 * j);
    assert_eq!(
        s.stream.bank_accesses.iter().sum::<u64>(),
        s.stream.pushes + s.stream.pops
    );
}

#[test]
fn a_tiny_stream_memory_replaces_rays_one_for_one() {
    let w = load("cornell", 16, 16).unwrap();
    let p = params(&w, 2);
    let reference = functional(&w, &p);
    let cfg = StrataConfig {
        stream: StreamConfig {
            bytes: 1024,
            ..StreamConfig::default()
        },
        ..StrataConfig::default()
    };
    let out = strata(&w, &p, &cfg, &chip(2, 4));
    let slots = out.stats.layout.unwrap().slots;
    assert!(slots < 32, "{slots} slots in 1 KB");
    assert_eq!(out.stats.initial_paths, slots as u64);
    assert_eq!(out.stats.stream.peak_rays, slots);
    assert_same(&out, &reference);
    assert_invariants(&out, 256);
}

#[test]
fn policies_and_sharing_change_the_schedule_not_the_image() {
    let w = load("cornell", 16, 16).unwrap();
    let p = params(&w, 1);
    let reference = functional(&w, &p);
    let mut switches = Vec::new();
    for (policy, share) in [
        (Policy::MostRays, 1),
        (Policy::RoundRobin, 1),
        (Policy::MostRays, 0),
        (Policy::RoundRobin, 2),
        (Policy::RaysPerTm, 0),
    ] {
        let cfg = StrataConfig {
            policy,
            tms_per_buffer: share,
            ..StrataConfig::default()
        };
        let out = strata(&w, &p, &cfg, &chip(3, 4));
        assert_same(&out, &reference);
        assert_invariants(&out, 256);
        switches.push(out.stats.treelet_switches);
    }
    assert!(switches.iter().any(|&s| s != switches[0]), "{switches:?}");
}

#[test]
fn the_flow_is_deterministic() {
    let w = load("cornell", 12, 12).unwrap();
    let p = params(&w, 1);
    let cfg = StrataConfig::default();
    let trax = rtsim_trax::TraxConfig {
        tms: 2,
        tps_per_tm: 4,
        ..rtsim_trax::TraxConfig::default()
    };
    let fc = FlowChip::of(&trax, &cfg, 1);
    let a = strata(&w, &p, &cfg, &fc);
    let b = strata(&w, &p, &cfg, &fc);
    assert_eq!(a.stats, b.stats);
    assert_eq!(a.rays, b.rays);
    assert!(a.stats.l1_accesses > 0);
}

#[test]
fn sibenik_equals_the_functional_tracer() {
    let Some(w) = load("sibenik", 16, 12) else {
        return;
    };
    let t = w.treelets().unwrap();
    // Every treelet within its budget, on a line, never across more DRAM rows than needed
    // (the image's own check), and every record inside its treelet.
    assert!(
        t.treelets
            .iter()
            .all(|i| i.bytes <= 16 << 10 && i.base % 64 == 0)
    );
    w.image.check().unwrap();
    assert!(rtsim_bvh::treelet::check_rows(t, 8192).is_empty());
    let p = params(&w, 1);
    let reference = functional(&w, &p);
    let out = strata(&w, &p, &StrataConfig::default(), &chip(8, 8));
    assert_same(&out, &reference);
    assert_invariants(&out, 16 * 12);
    let s = &out.stats;
    assert!(s.pushes_crossing > 0 && s.pushes_to_triangles > 0);
    // A tenure's own lines fit the L1: a treelet is at most 16 KB from a line boundary.
    assert!(
        s.tenure_lines_max <= (16 << 10) / 64,
        "{}",
        s.tenure_lines_max
    );
    // Outside it, it reads only the child pairs at its frontier (see docs/STRATA.md).
    assert_eq!(s.foreign_other_reads, 0);
    assert!(s.foreign_pair_reads > 0);
    // And with a stream memory just big enough for Sibenik's head table and a few rays.
    let small = StrataConfig {
        stream: StreamConfig {
            bytes: 8 << 10,
            ..StreamConfig::default()
        },
        ..StrataConfig::default()
    };
    let out = strata(&w, &p, &small, &chip(8, 8));
    assert!(out.stats.layout.unwrap().slots < 192);
    assert_same(&out, &reference);
    assert_invariants(&out, 16 * 12);
}

#[test]
fn record_reads_go_through_the_l1s_and_the_small_l2() {
    let w = load("cornell", 16, 16).unwrap();
    let p = params(&w, 1);
    let cfg = StrataConfig::default();
    let trax = rtsim_trax::TraxConfig {
        tms: 4,
        tps_per_tm: 8,
        ..rtsim_trax::TraxConfig::default()
    };
    let fc = FlowChip::of(&trax, &cfg, 1);
    // STRaTA's L2 is the 512 KB beside the stream memory (§5.1).
    assert_eq!(fc.caches.as_ref().unwrap().l2.size_bytes, 512 << 10);
    let out = strata(&w, &p, &cfg, &fc);
    assert_same(&out, &functional(&w, &p));
    let s = &out.stats;
    // Every line a tenure touched was one L1 access or more; misses and writes (around the
    // L1) reach the L2.
    assert!(s.l1_accesses >= s.tenure_lines + s.tenure_foreign_lines + s.shading_line_reads);
    // (`l1_accesses` and `l1_misses` are reads.)
    assert!(s.l1_misses > 0 && s.l1_misses < s.l1_accesses);
    assert_eq!(s.l2_accesses, s.l1_misses + s.shading_line_writes);
    // Path state: one line read and one written per ray; framebuffer: one line per pixel.
    assert_eq!(s.shading_line_writes, s.rays + 256);
    assert!(s.shading_line_reads >= s.rays);
    assert_eq!(s.dram_line_writes, s.shading_line_writes);
    // The Cornell box's data fits the 512 KB L2: DRAM reads each line once at most.
    let lines = (w.image.span().1 - w.image.span().0) / 64 + 1;
    assert!(
        s.dram_line_reads <= lines,
        "{} > {lines}",
        s.dram_line_reads
    );
}
