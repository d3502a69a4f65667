//! Hand-computed cycle counts: known instruction blocks on one TP, and two TPs contending for
//! a unit or a fetch bank, under both engines.

use crate::chip::Chip;
use crate::isa::{Class, Inst, NO_REG, regs};
use crate::program::{Program, Run, Seg};
use crate::work::{Ctx, Work};
use crate::{Engine, Options, Output, TraxConfig};
use rtsim_bvh::{ImageExtras, MemoryImage, MemoryLayoutConfig};
use rtsim_scene::{SceneRequest, load_scene};
use rtsim_trace::{Integrator, TraceConfig, Tracer, WorkloadKind, WorkloadParams};

const T0: u8 = regs::FIRST_TEMP;

fn inst(class: Class, dst: u8, a: u8, b: u8) -> Inst {
    Inst::new(class, dst, [a, b])
}

/// Run `scripts[tp]` (a block each, or nothing) on a chip of one TM with `cfg`'s units;
/// returns the output.
fn run(cfg: &TraxConfig, block: &[Inst], scripts: &[bool], engine: Engine) -> Output {
    let scene = load_scene(&SceneRequest {
        name: "cornell",
        size: 1.0,
        seed: 1,
        scene_dir: None,
    })
    .unwrap();
    let bvh = rtsim_bvh::build(
        &scene.triangles,
        &Default::default(),
        rtsim_bvh::NodeOrder::DepthFirst,
    )
    .unwrap();
    let mem = MemoryLayoutConfig::default();
    let image = MemoryImage::build(
        &bvh,
        &mem,
        &ImageExtras::for_run(&mem, false, scene.materials.len() as u32, 4, 4),
    )
    .unwrap();
    let tracer = Tracer::new(&scene.triangles, bvh, &TraceConfig::default()).unwrap();
    let integ = Integrator::new(
        &scene,
        &tracer,
        WorkloadParams {
            kind: WorkloadKind::Primary,
            width: 4,
            height: 4,
            spp: 1,
            max_depth: 1,
            specular_bounces: 0,
            ao_radius: 1.0,
            seed: 1,
        },
    );
    let mut program = Program::new();
    let start = program.insts.len() as u32;
    for (k, i) in block.iter().enumerate() {
        program.insts.push(Inst {
            pc: (start + k as u32) * 4,
            ..*i
        });
    }
    let seg = Seg {
        start,
        len: block.len() as u32,
    };
    let ctx = Ctx {
        integ: &integ,
        tracer: &tracer,
        image: &image,
        program: &program,
        pixels: &[],
    };
    let src = crate::TraxSource::new(ctx, cfg.total_tps() as usize);
    let mut chip = Chip::new(cfg, src, &program, 16, &Default::default(), 1).unwrap();
    for (tp, &scripted) in scripts.iter().enumerate() {
        chip.cores[tp].run = Run::new(Seg { start: 0, len: 0 });
        let runs: &[Run] = if scripted { &[Run::new(seg)] } else { &[] };
        chip.src.works[tp] = Work::scripted(runs);
    }
    let opts = Options {
        engine,
        cycle_limit: None,
        seed: 1,
        threads: 1,
        timeline: None,
    };
    let last = match engine {
        Engine::Fast => crate::fast::run(&mut chip, None, &mut |_, _, _| {}).unwrap(),
        Engine::Reference => crate::reference::run(&mut chip, None, &mut |_, _, _| {}).unwrap(),
    };
    chip.finish(last, &opts, &program).unwrap().0
}

fn chip(tps: u32) -> TraxConfig {
    TraxConfig {
        tms: 1,
        tps_per_tm: tps,
        icaches_per_tm: 1,
        ..TraxConfig::default()
    }
}

fn both(cfg: &TraxConfig, block: &[Inst], scripts: &[bool]) -> Output {
    let f = run(cfg, block, scripts, Engine::Fast);
    let r = run(cfg, block, scripts, Engine::Reference);
    assert_eq!(f.report.cycles, r.report.cycles);
    assert_eq!(f.report.issue, r.report.issue);
    f
}

#[test]
fn one_tp_runs_a_dependent_chain_in_the_hand_computed_cycles() {
    let o = regs::ORG;
    let block = [
        inst(Class::FpAdd, T0, o[0], o[1]),           // issues 0, ready 2
        inst(Class::FpMul, T0 + 1, T0, T0),           // waits for T0: 2, ready 4
        inst(Class::FpAdd, T0 + 2, T0 + 1, NO_REG),   // 4, ready 6
        inst(Class::IntAdd, T0 + 3, o[0], NO_REG),    // independent: 5, ready 6
        inst(Class::DivSqrt, T0 + 4, T0 + 2, NO_REG), // 6, ready 22
        inst(Class::FpAdd, T0 + 5, T0 + 4, T0 + 3),   // 22, ready 24
        inst(Class::Branch, NO_REG, T0 + 5, NO_REG),  // 24, resolves 25
    ];
    let out = both(&chip(1), &block, &[true]);
    let r = &out.report;
    assert_eq!(r.cycles, 25);
    assert_eq!(r.instructions.total, 7);
    // Stalls: 1 (mul) + 1 (add) + 15 (add after the divide) + 1 (branch) = 18 operand cycles.
    assert_eq!(r.tp_cycles.stalls_by_cause["operand_not_ready"], 18);
    assert_eq!(r.tp_cycles.stalls, 18);
    // A slower branch delays the halt by its latency.
    let mut cfg = chip(1);
    cfg.units.branch.latency = 4;
    assert_eq!(both(&cfg, &block, &[true]).report.cycles, 28);
}

#[test]
fn two_tps_contend_for_one_multiplier() {
    let o = regs::ORG;
    // Three independent multiplies per TP.
    let block = [
        inst(Class::FpMul, T0, o[0], o[1]),
        inst(Class::FpMul, T0 + 1, o[1], o[2]),
        inst(Class::FpMul, T0 + 2, o[2], o[0]),
    ];
    let mut cfg = chip(2);
    cfg.icaches_per_tm = 2; // separate fetch paths: only the unit is shared
    cfg.units.fp_mul.count = 1;
    let out = both(&cfg, &block, &[true, true]);
    // Same key (cycle 0): TP 0 wins every cycle it asks (0, 1, 2), TP 1 issues at 3, 4, 5.
    assert_eq!(out.report.cycles, 6);
    assert_eq!(out.report.tp_cycles.stalls_by_cause["unit_busy"], 3);
    assert_eq!(out.report.tp_cycles.idle, 3);
    // With two multipliers both run in three cycles.
    cfg.units.fp_mul.count = 2;
    let out = both(&cfg, &block, &[true, true]);
    assert_eq!(out.report.cycles, 3);
    assert_eq!(out.report.tp_cycles.stalls, 0);
}

#[test]
fn two_tps_contend_for_one_fetch_bank() {
    let o = regs::ORG;
    let block = [
        inst(Class::IntAdd, T0, o[0], NO_REG),
        inst(Class::IntAdd, T0 + 1, o[1], NO_REG),
        inst(Class::IntAdd, T0 + 2, o[2], NO_REG),
    ];
    // One instruction cache for both TPs, one fetch per bank per cycle.
    let mut cfg = chip(2);
    cfg.fetches_per_bank = 1;
    // 16 banks: consecutive instructions are in consecutive banks, so TP 1 loses cycle 0
    // only (TP 0 fetches instruction k at cycle k, TP 1 at k + 1, in another bank).
    let out = both(&cfg, &block, &[true, true]);
    assert_eq!(out.report.cycles, 4);
    assert_eq!(out.report.tp_cycles.stalls_by_cause["fetch_conflict"], 1);
    // One bank: every fetch of TP 1 waits for TP 0's three.
    cfg.icache_banks = 1;
    let out = both(&cfg, &block, &[true, true]);
    assert_eq!(out.report.cycles, 6);
    assert_eq!(out.report.tp_cycles.stalls_by_cause["fetch_conflict"], 3);
    // Two fetches per bank (the default): no conflict.
    cfg.fetches_per_bank = 2;
    assert_eq!(both(&cfg, &block, &[true, true]).report.cycles, 3);
}

#[test]
fn fetch_caps_packed_and_unpacked_match_the_reference() {
    // The fast engine keeps up to 3 fetches per bank in two bits (four banks a byte) and more
    // in a byte per bank: either way it must equal the reference, and a larger cap can only
    // shorten the run. Eight TPs on one instruction cache of one or two banks contend hard.
    let o = regs::ORG;
    let block = [
        inst(Class::IntAdd, T0, o[0], NO_REG),
        inst(Class::Bitwise, T0 + 1, o[1], NO_REG),
        inst(Class::IntAdd, T0 + 2, o[2], NO_REG),
        inst(Class::Branch, NO_REG, T0 + 2, NO_REG),
    ];
    for banks in [1, 2] {
        let mut cfg = chip(8);
        cfg.icache_banks = banks;
        let mut last = (u64::MAX, u64::MAX);
        for cap in 1..=5 {
            cfg.fetches_per_bank = cap;
            let r = both(&cfg, &block, &[true; 8]).report;
            let stalls = r.tp_cycles.stalls_by_cause["fetch_conflict"];
            assert!(r.cycles <= last.0 && stalls <= last.1, "cap {cap}: {r:?}");
            if banks == 1 && cap != 3 {
                // One bank: 32 fetches at `cap` a cycle, and never under the 8 cycles the
                // block takes without contention (cap 5).
                assert_eq!(r.cycles, 32u64.div_ceil(cap as u64).max(8), "cap {cap}");
            }
            last = (r.cycles, stalls);
        }
    }
}
