//! The timed STRaTA chip against the functional tracer and against itself: every pixel and
//! every ray's counters equal the functional `bit-stack` tracer's, the fast engine equals the
//! cycle-by-cycle reference, nothing is lost with a tiny stream memory, and runs repeat
//! bit for bit.

use rtsim_strata::config::{Policy, StrataConfig, StreamConfig, Switch};
use rtsim_strata::timed::{self, StrataOutput};
use rtsim_strata::world::{self, World};
use rtsim_trace::{FrameStats, Integrator, PixelResult, WorkloadKind, WorkloadParams};
use rtsim_trax::stats::Stall;
use rtsim_trax::{Engine, Frame, Options, TraxConfig};

fn world(w: u32, h: u32) -> World {
    World::load(
        "cornell",
        None,
        w,
        h,
        &world::memory_config(16 << 10),
        &world::trace_config(),
    )
    .unwrap()
}

fn params(w: &World) -> WorkloadParams {
    WorkloadParams {
        kind: WorkloadKind::Path,
        width: w.width,
        height: w.height,
        spp: 1,
        max_depth: 3,
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

fn chip(tms: u32, tps: u32) -> TraxConfig {
    TraxConfig {
        tms,
        tps_per_tm: tps,
        ..TraxConfig::default()
    }
}

fn run(w: &World, cfg: &StrataConfig, trax: &TraxConfig, engine: Engine) -> StrataOutput {
    run_to(w, cfg, trax, engine, None)
}

fn run_to(
    w: &World,
    cfg: &StrataConfig,
    trax: &TraxConfig,
    engine: Engine,
    cycle_limit: Option<u64>,
) -> StrataOutput {
    run_timeline(w, cfg, trax, engine, cycle_limit, None)
}

fn run_timeline(
    w: &World,
    cfg: &StrataConfig,
    trax: &TraxConfig,
    engine: Engine,
    cycle_limit: Option<u64>,
    timeline: Option<u64>,
) -> StrataOutput {
    let p = params(w);
    let integ = Integrator::new(&w.scene, &w.tracer, p);
    let pixels: Vec<u32> = (0..w.width * w.height).collect();
    timed::simulate(
        trax,
        cfg,
        &rtsim_dram::DramConfig::default(),
        Frame {
            integ: &integ,
            tracer: &w.tracer,
            image: &w.image,
            pixels: &pixels,
            image_pixels: pixels.len(),
        },
        &Options {
            engine,
            cycle_limit,
            seed: 1,
            threads: 1,
            timeline,
        },
        &mut |_| {},
    )
    .unwrap()
}

fn assert_same(o: &StrataOutput, reference: &(Vec<PixelResult>, FrameStats)) {
    for (i, (a, b)) in o.out.pixels.iter().zip(&reference.0).enumerate() {
        assert_eq!(
            a.color.to_array().map(f32::to_bits),
            b.color.to_array().map(f32::to_bits),
            "pixel {i}"
        );
        assert_eq!(a.nodes_visited, b.nodes_visited, "pixel {i}");
    }
    assert_eq!(o.out.rays, reference.1, "per-kind ray counters");
    assert!(o.out.report.complete);
    let s = &o.strata;
    // Every ray pushed was popped; one root push per ray; the memory never overflowed.
    assert_eq!(s.stream.pushes, s.stream.pops);
    assert_eq!(s.pushes_root, o.out.rays.total().rays);
    assert_eq!(s.stream.overflows, 0);
    assert_eq!(s.stream.path_reads, o.out.rays.total().rays);
    assert_eq!(s.pushes_crossing, o.out.rays.total().treelet_crossings);
}

#[test]
fn the_timed_chip_renders_the_functional_image_fused_and_unfused() {
    let w = world(16, 16);
    let reference = functional(&w, &params(&w));
    for fused in [true, false] {
        let cfg = StrataConfig {
            fused,
            ..StrataConfig::default()
        };
        let o = run(&w, &cfg, &chip(2, 8), Engine::Fast);
        assert_same(&o, &reference);
        let r = &o.out.report;
        let boxes = r.issue.count(rtsim_trax::isa::Class::BoxTest);
        assert_eq!(boxes > 0, fused, "fused box tests only with fusing");
        if fused {
            assert!(o.strata.reconfigurations > 0);
            assert!(o.strata.pipeline_energy_j > 0.0);
        }
        assert!(r.energy.stream_j > 0.0);
    }
}

#[test]
fn fast_equals_reference() {
    let w = world(8, 8);
    for fused in [true, false] {
        let cfg = StrataConfig {
            fused,
            ..StrataConfig::default()
        };
        let f = run(&w, &cfg, &chip(2, 4), Engine::Fast);
        let r = run(&w, &cfg, &chip(2, 4), Engine::Reference);
        assert_eq!(f.out.report.cycles, r.out.report.cycles, "fused {fused}");
        assert_eq!(f.out.report.issue, r.out.report.issue, "fused {fused}");
        assert_eq!(f.strata, r.strata, "fused {fused}");
        assert_eq!(f.out.report.dram.accesses, r.out.report.dram.accesses);
    }
}

#[test]
fn fast_equals_reference_under_stream_contention() {
    // Two stream banks with one port each and 24 TPs per TM: pops queue for the head of a
    // buffer every cycle, which the fast engine parks instead of offering; round-robin and
    // drained switching exercise the other ways a parked TP's buffer changes under it.
    let w = world(12, 10);
    for (policy, switch) in [
        (Policy::MostRays, Switch::Empty),
        (Policy::RoundRobin, Switch::Drained),
        (Policy::RaysPerTm, Switch::Empty),
    ] {
        let cfg = StrataConfig {
            policy,
            switch,
            stream: StreamConfig {
                banks: 2,
                ..StreamConfig::default()
            },
            ..StrataConfig::default()
        };
        let f = run(&w, &cfg, &chip(3, 24), Engine::Fast);
        let r = run(&w, &cfg, &chip(3, 24), Engine::Reference);
        assert!(f.strata.bank_conflicts_by_op[0] > 1000, "{:?}", f.strata);
        assert_eq!(f.out.report.cycles, r.out.report.cycles, "{policy:?}");
        assert_eq!(f.out.report.issue, r.out.report.issue, "{policy:?}");
        assert_eq!(f.strata, r.strata, "{policy:?}");
    }
}

#[test]
fn a_tiny_stream_memory_loses_nothing_and_runs_repeat_exactly() {
    let w = world(12, 12);
    let reference = functional(&w, &params(&w));
    let cfg = StrataConfig {
        stream: StreamConfig {
            bytes: 2 << 10,
            ..StreamConfig::default()
        },
        ..StrataConfig::default()
    };
    let a = run(&w, &cfg, &chip(2, 8), Engine::Fast);
    assert_same(&a, &reference);
    assert!(
        a.strata.paths < 144,
        "the stream memory limits the paths in flight"
    );
    assert!(a.strata.stream.peak_rays <= a.strata.layout.unwrap().slots);
    let b = run(&w, &cfg, &chip(2, 8), Engine::Fast);
    assert_eq!(a.out.report.cycles, b.out.report.cycles);
    assert_eq!(a.out.report.issue, b.out.report.issue);
    assert_eq!(a.strata, b.strata);
}

#[test]
fn the_drained_switch_rule_changes_timing_not_the_image() {
    let w = world(12, 12);
    let reference = functional(&w, &params(&w));
    let cfg = StrataConfig {
        switch: rtsim_strata::Switch::Drained,
        ..StrataConfig::default()
    };
    let f = run(&w, &cfg, &chip(2, 8), Engine::Fast);
    assert_same(&f, &reference);
    let r = run(&w, &cfg, &chip(2, 8), Engine::Reference);
    assert_eq!(f.out.report.cycles, r.out.report.cycles);
    assert_eq!(f.strata, r.strata);
}

#[test]
fn fast_equals_reference_when_the_triangle_pipelines_are_busy() {
    // One triangle pipeline (a test every 18 cycles) for 24 TPs per TM: refused triangle
    // tests wait for it, and the fast engine offers only the first of them each time it
    // frees (`UnitQueue`), charging the others' refusals later. Partial frames stop with TPs
    // still waiting, whose skipped refusals are charged at the end.
    let w = world(12, 10);
    let cfg = StrataConfig {
        triangle_pipelines: 1,
        ..StrataConfig::default()
    };
    let f = run(&w, &cfg, &chip(3, 24), Engine::Fast);
    let r = run(&w, &cfg, &chip(3, 24), Engine::Reference);
    assert!(f.strata.pipeline_waits > 1000, "{:?}", f.strata);
    assert_eq!(f.out.report.cycles, r.out.report.cycles);
    assert_eq!(f.out.report.issue, r.out.report.issue);
    assert_eq!(f.strata, r.strata);
    // Stopped while TPs wait: their refusals and stall cycles up to the limit count too.
    // (Only these compare: the fast engine books instructions ahead of the limit, so a
    // stopped run's other counts differ, `docs/TRAX.md`.)
    let whole = f.out.report.cycles;
    for limit in [whole / 3, whole / 2 + 7, whole - 101] {
        let f = run_to(&w, &cfg, &chip(3, 24), Engine::Fast, Some(limit));
        let r = run_to(&w, &cfg, &chip(3, 24), Engine::Reference, Some(limit));
        let stream = |o: &StrataOutput| o.out.report.issue.stall[Stall::Stream as usize];
        assert_eq!(
            f.strata.pipeline_waits, r.strata.pipeline_waits,
            "limit {limit}"
        );
        assert_eq!(stream(&f), stream(&r), "limit {limit}");
    }
}

#[test]
fn a_tms_per_buffer_cap_at_or_above_the_tm_count_is_no_cap() {
    // The cap counts the TMs already holding a buffer, and a TM that picks holds none, so
    // with 3 TMs a cap of 3 (or more) never binds; a cap of 1 does.
    let w = world(12, 12);
    let reference = functional(&w, &params(&w));
    let with = |cap| {
        let cfg = StrataConfig {
            tms_per_buffer: cap,
            ..StrataConfig::default()
        };
        run(&w, &cfg, &chip(3, 4), Engine::Fast)
    };
    let free = with(0);
    assert_same(&free, &reference);
    for cap in [3, 4, 4096] {
        let o = with(cap);
        assert_eq!(o.out.report.cycles, free.out.report.cycles, "cap {cap}");
        assert_eq!(o.strata, free.strata, "cap {cap}");
    }
    let one = with(1);
    assert_same(&one, &reference);
    assert_ne!(one.strata, free.strata);
    // The sharing counters see the cap: one TM a buffer under a cap of 1, more without.
    assert_eq!(one.strata.max_holders, 1);
    assert_eq!(one.strata.holders_at_pick, one.strata.treelet_switches);
    assert!(free.strata.max_holders > 1, "{:?}", free.strata);
    assert!(free.strata.holders_at_pick > free.strata.treelet_switches);
    assert!(free.strata.max_holders <= 3);
}

#[test]
fn the_time_series_is_the_same_from_both_engines_and_adds_up() {
    // Two stream banks and 24 TPs per TM: parked pops, queued triangle tests and the fill's
    // wait on the counter all cross interval boundaries.
    let w = world(12, 10);
    let cfg = StrataConfig {
        stream: StreamConfig {
            banks: 2,
            ..StreamConfig::default()
        },
        ..StrataConfig::default()
    };
    for (every, limit) in [(400, None), (97, None), (1000, Some(5555))] {
        let f = run_timeline(&w, &cfg, &chip(3, 24), Engine::Fast, limit, Some(every));
        let r = run_timeline(
            &w,
            &cfg,
            &chip(3, 24),
            Engine::Reference,
            limit,
            Some(every),
        );
        let (tf, tr) = (
            f.out.timeline.as_ref().unwrap(),
            r.out.timeline.as_ref().unwrap(),
        );
        assert_eq!(tf.rows.len(), tr.rows.len(), "every {every}");
        for (a, b) in tf.rows.iter().zip(&tr.rows) {
            assert_eq!(
                a, b,
                "every {every}, limit {limit:?}: row at cycle {}",
                a.start
            );
        }
        assert!(tf.rows.len() > 3, "{} rows", tf.rows.len());
        let sum = |c: &str| tf.column(c).unwrap().iter().sum::<u64>();
        if limit.is_none() {
            assert_eq!(sum("instructions"), f.out.report.instructions.total);
            let last = |c: &str| *tf.column(c).unwrap().last().unwrap();
            assert_eq!(last("live_paths"), 0, "every path retired");
            assert_eq!(last("rays_buffered"), 0, "the buffers drained");
        }
        assert_eq!(sum("stream_pops"), f.strata.stream.pops);
        assert_eq!(sum("stream_pushes"), f.strata.stream.pushes);
        assert_eq!(sum("treelet_switches"), f.strata.treelet_switches);
        assert_eq!(sum("holders_at_pick"), f.strata.holders_at_pick);
        assert_eq!(
            tf.column("max_holders").unwrap().into_iter().max().unwrap(),
            f.strata.max_holders as u64
        );
        // The fill: paths start in the first rows, and their first rays wait in the root
        // buffer.
        let live = tf.column("live_paths").unwrap();
        assert!(live[0] > 0 && tf.column("root_rays").unwrap()[..3].iter().any(|&n| n > 0));
        // The time series changes nothing else.
        let plain = run_to(&w, &cfg, &chip(3, 24), Engine::Fast, limit);
        assert_eq!(plain.out.report.issue, f.out.report.issue);
        assert_eq!(plain.strata, f.strata);
        assert!(plain.out.timeline.is_none());
    }
}

#[test]
fn a_static_fill_renders_the_same_image_without_the_counter() {
    use rtsim_strata::Fill;
    use rtsim_trax::isa::Class;
    // All 144 pixels fit in the default stream memory, one path slot each; 2 KB holds fewer
    // slots than pixels, so slots are reused through the counter after the fill.
    let w = world(12, 12);
    let reference = functional(&w, &params(&w));
    let pixels = 144;
    for bytes in [StreamConfig::default().bytes, 2 << 10] {
        let stream = StreamConfig {
            bytes,
            ..StreamConfig::default()
        };
        let counter = StrataConfig {
            stream: stream.clone(),
            ..StrataConfig::default()
        };
        let fixed = StrataConfig {
            fill: Fill::Static,
            ..counter.clone()
        };
        let trax = chip(2, 8);
        let c = run(&w, &counter, &trax, Engine::Fast);
        let f = run(&w, &fixed, &trax, Engine::Fast);
        assert_same(&f, &reference);
        let r = run(&w, &fixed, &trax, Engine::Reference);
        assert_eq!(f.out.report.cycles, r.out.report.cycles, "{bytes} B");
        assert_eq!(f.out.report.issue, r.out.report.issue, "{bytes} B");
        assert_eq!(f.strata, r.strata, "{bytes} B");
        assert_eq!(f.strata.paths, c.strata.paths);
        // The counter hands out every pixel after the fill and one failed ask per retiring
        // slot (`pixels` grants in all); the counter fill adds one per slot and one failed
        // ask per TP, the static fill none.
        let n = u64::from(c.strata.paths);
        let tps = u64::from(trax.total_tps());
        let atomics = |o: &StrataOutput| o.out.report.issue.count(Class::Atomic);
        assert_eq!(atomics(&f), pixels, "{bytes} B");
        assert_eq!(atomics(&c), pixels + n + tps, "{bytes} B");
        // Each of the fill's slots runs `fill_slot` once, and each TP once more to find none
        // left: the integer adds it has in place of the counter's grants.
        let adds = |o: &StrataOutput| o.out.report.issue.count(Class::IntAdd);
        assert_eq!(adds(&f), adds(&c) + n + tps, "{bytes} B");
    }
}
