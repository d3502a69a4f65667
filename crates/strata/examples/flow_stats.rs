//! Measure STRaTA's functional ray flow on a scene and check it against the functional
//! tracer:
//!
//! ```text
//! cargo run -p rtsim-strata --example flow_stats -- SCENE WIDTH HEIGHT [TMS TPS STREAM_BYTES POLICY TMS_PER_BUFFER]
//! ```
//!
//! Path tracing, 1 sample, depth 5 (STRaTA §5). Defaults: 128 TMs × 32 TPs, 4 MB stream,
//! `most-rays`, no limit of TMs per buffer.

use rtsim_strata::config::{Policy, StrataConfig, StreamConfig};
use rtsim_strata::flow::{self, FlowChip, Frame};
use rtsim_strata::world::{self, World};
use rtsim_trace::{FrameStats, Integrator, WorkloadKind, WorkloadParams};
use std::path::PathBuf;

fn main() {
    let a: Vec<String> = std::env::args().skip(1).collect();
    let arg = |i: usize, d: &str| a.get(i).cloned().unwrap_or_else(|| d.to_string());
    let name = arg(0, "sibenik");
    let (w, h): (u32, u32) = (arg(1, "64").parse().unwrap(), arg(2, "64").parse().unwrap());
    let trax = rtsim_trax::TraxConfig {
        tms: arg(3, "128").parse().unwrap(),
        tps_per_tm: arg(4, "32").parse().unwrap(),
        ..rtsim_trax::TraxConfig::default()
    };
    let cfg = StrataConfig {
        stream: StreamConfig {
            bytes: arg(5, "4194304").parse().unwrap(),
            ..StreamConfig::default()
        },
        policy: match arg(6, "most-rays").as_str() {
            "round-robin" => Policy::RoundRobin,
            "rays-per-tm" => Policy::RaysPerTm,
            _ => Policy::MostRays,
        },
        tms_per_buffer: arg(7, "0").parse().unwrap(),
        ..StrataConfig::default()
    };
    let chip = FlowChip::of(&trax, &cfg, 1);
    let dir = std::env::var_os("RTSIM_SCENE_DIR")
        .map(PathBuf::from)
        .or_else(|| Some(PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/scenes")));
    let wd = World::load(
        &name,
        dir.as_deref(),
        w,
        h,
        &world::memory_config(16 << 10),
        &world::trace_config(),
    )
    .unwrap();
    let t = wd.treelets().unwrap();
    let p = WorkloadParams {
        kind: WorkloadKind::Path,
        width: w,
        height: h,
        spp: 1,
        max_depth: 5,
        specular_bounces: 2,
        ao_radius: 0.3,
        seed: 7,
    };
    let integ = Integrator::new(&wd.scene, &wd.tracer, p);
    let pixels: Vec<u32> = (0..w * h).collect();
    let t0 = std::time::Instant::now();
    let out = flow::run(
        &cfg,
        &chip,
        Frame {
            integ: &integ,
            tracer: &wd.tracer,
            image: &wd.image,
            pixels: &pixels,
            image_pixels: pixels.len(),
        },
    )
    .unwrap();
    let secs = t0.elapsed().as_secs_f64();
    let mut reference = FrameStats::default();
    let mut same = true;
    for &px in &pixels {
        let r = integ.pixel(px % w, px / w, &mut reference);
        let o = out.pixels[px as usize];
        same &= r.color.to_array().map(f32::to_bits) == o.color.to_array().map(f32::to_bits)
            && r.nodes_visited == o.nodes_visited;
    }
    let s = &out.stats;
    let l = s.layout.unwrap();
    let rays = s.rays as f64;
    println!(
        "scene {name} {w}x{h} path depth 5, {} TMs x {} TPs, policy {}, tms_per_buffer {}",
        chip.tms,
        chip.tps_per_tm,
        cfg.policy.name(),
        cfg.tms_per_buffer
    );
    println!(
        "treelets: {} node + {} triangle",
        t.node_treelet_count,
        t.len() as u32 - t.node_treelet_count
    );
    println!(
        "stream {} B: {} slots, {}-bit pointers, overhead {:.2} % (links+heads {:.2} %)",
        l.capacity_bytes,
        l.slots,
        l.pointer_bits,
        100.0 * l.overhead_fraction(),
        100.0 * l.link_fraction()
    );
    println!(
        "image equals functional: {same}; counters equal: {}",
        out.rays == reference
    );
    println!(
        "rays {} pixels {} steps {} initial paths {}",
        s.rays, s.pixels_done, s.steps, s.initial_paths
    );
    println!(
        "pushes {} pops {} per ray {:.2}: root {} crossing {} to-tri {} from-tri {}",
        s.stream.pushes,
        s.stream.pops,
        s.stream.pushes as f64 / rays,
        s.pushes_root,
        s.pushes_crossing,
        s.pushes_to_triangles,
        s.pushes_from_triangles
    );
    println!(
        "peak rays {} peak per buffer {}",
        s.stream.peak_rays, s.stream.peak_buffer_rays
    );
    println!(
        "rounds {} tm-rounds active {} idle {}; tp-rounds idle {} ({:.1} % of active TP-rounds)",
        s.rounds,
        s.tm_rounds_active,
        s.tm_rounds_idle,
        s.tp_rounds_idle,
        100.0 * s.tp_rounds_idle as f64 / (s.tm_rounds_active * chip.tps_per_tm as u64) as f64
    );
    println!(
        "treelet switches {} (kind switches {}), rays per tenure {:.1}",
        s.treelet_switches,
        s.kind_switches,
        s.tenure_rays as f64 / s.tenures as f64
    );
    println!(
        "lines per tenure: own {:.1} (max {}), foreign {:.1} (max {}); foreign pair reads {} other {}",
        s.tenure_lines as f64 / s.tenures as f64,
        s.tenure_lines_max,
        s.tenure_foreign_lines as f64 / s.tenures as f64,
        s.tenure_foreign_lines_max,
        s.foreign_pair_reads,
        s.foreign_other_reads
    );
    println!(
        "stream energy {:.6} J at {:.3} nJ/access; path-state reads {} writes {}",
        s.stream_energy_j(),
        s.stream_access_nj,
        s.path_state_reads,
        s.path_state_writes
    );
    println!(
        "caches (one access per line; shading reads {} writes {}): L1 {} accesses {} misses \
         ({:.2} % hits), L2 {} accesses {} misses, DRAM line reads {} writes {}",
        s.shading_line_reads,
        s.shading_line_writes,
        s.l1_accesses,
        s.l1_misses,
        100.0 * (1.0 - s.l1_misses as f64 / s.l1_accesses as f64),
        s.l2_accesses,
        s.l2_misses,
        s.dram_line_reads,
        s.dram_line_writes
    );
    println!(
        "fetches per ray: traversal {:.1} scalar, {:.1} fused ({:.1} %); stream {:.2}; shading {:.1}",
        s.fetches_traversal_scalar as f64 / rays,
        s.fetches_traversal_fused as f64 / rays,
        100.0 * s.fetches_traversal_fused as f64 / s.fetches_traversal_scalar as f64,
        s.fetches_stream as f64 / rays,
        s.fetches_shading as f64 / rays
    );
    let all = |t: u64| t + s.fetches_stream + s.fetches_shading;
    println!(
        "all fetches: {} scalar, {} fused ({:.1} %)",
        all(s.fetches_traversal_scalar),
        all(s.fetches_traversal_fused),
        100.0 * all(s.fetches_traversal_fused) as f64 / all(s.fetches_traversal_scalar) as f64
    );
    println!("host seconds {secs:.2}");
}
