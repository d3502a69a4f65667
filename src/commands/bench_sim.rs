//! `rtsim bench-sim`: how fast the TRaX chip model runs (issue 8 §7; `--arch strata` for
//! STRaTA on it, issue 10 §6) — simulated core cycles,
//! TP-cycles (cycles × TPs, the figure other simulators print) and instructions per host
//! second, and the process's peak memory — for the full 4,096-TP chip on Sibenik by default.
//!
//! A paper frame (1024², path tracing, about 64 G instructions) takes far longer than a
//! benchmark should, so the run stops after `--cycle-limit` core cycles (default 200,000,
//! past the cold start of the caches) unless told otherwise; every `rtsim simulate` flag
//! applies (a window, a lower resolution, fewer TMs with `--set arch.trax.tms=N`). Rates are
//! given per wall-clock second and per CPU second of the process, since the machine may be
//! shared; the load average is printed beside them. The baseline's fast engine runs on
//! `--threads` host threads (default: all cores; results identical whatever the number), so
//! its CPU seconds include the threads' waits for each other.

use crate::commands::simulate::{self, SimulateArgs};
use crate::commands::thousands;
use crate::session;
use anyhow::Result;
use clap::Args;
use rtsim_trax::isa::Class;

/// Default cycle limit (assumed: long enough that the L1s and L2 are warm and the DRAM
/// queues are in their steady state on Sibenik, short enough for a minute's run here).
const DEFAULT_CYCLES: u64 = 200_000;

/// The issue 8 §7 target: the paper's full Sibenik frame (about 64 G instructions, from
/// STRaTA Table 3's instruction-cache energy at 0.014 nJ per fetch) in 15 minutes.
const PAPER_FRAME_INSTRUCTIONS: f64 = 64e9;

#[derive(Debug, Args, Clone)]
pub struct BenchSimArgs {
    #[command(flatten)]
    pub sim: SimulateArgs,
    /// Run the whole frame (no cycle limit unless --cycle-limit is given).
    #[arg(long)]
    pub full: bool,
    /// With `--arch strata`: also run the TRaX baseline with the same flags, both on one host
    /// thread, and print each chip's host time per simulated instruction and per simulated
    /// cycle, and their ratios. (`--arch` here: trax-baseline, the default, or strata.)
    #[arg(long)]
    pub against_baseline: bool,
}

pub fn run(mut args: BenchSimArgs) -> Result<()> {
    let a = &mut args.sim;
    let arch = a.arch.get_or_insert_with(|| "trax-baseline".into()).clone();
    if arch != "trax-baseline" && arch != "strata" {
        anyhow::bail!(
            "bench-sim measures the TRaX chip: --arch must be trax-baseline or strata, not {arch}"
        );
    }
    if args.against_baseline && arch != "strata" {
        anyhow::bail!(
            "--against-baseline compares STRaTA with the baseline: it needs --arch strata"
        );
    }
    if let Some(out) = &a.frame.out {
        anyhow::bail!(
            "bench-sim writes no files (it prints its rates): drop --out {} (use `rtsim \
             simulate` for a run's outputs)",
            out.display()
        );
    }
    a.scene.scene.get_or_insert_with(|| "sibenik".into());
    if !args.full {
        a.frame.cycle_limit.get_or_insert(DEFAULT_CYCLES);
    }
    let baseline_args = args.against_baseline.then(|| {
        let mut b = a.clone();
        b.arch = Some("trax-baseline".into());
        b.scene.threads = Some(1);
        b
    });
    // The benchmark writes nothing (`--out` is refused above).
    let flags = simulate::flags(a)?;
    let load_before = load_average();
    let s = session::open(&a.scene, &flags, false)?;
    let (ran, strata) = if arch == "strata" {
        let r = simulate::strata::frame(&s)?;
        let ran = simulate::trax::Ran {
            out: r.out.out,
            params: r.params,
            pixels: r.pixels,
            seconds: r.seconds,
            cpu_seconds: r.cpu_seconds,
            threads: r.threads,
        };
        (ran, Some(r.out.strata))
    } else {
        (simulate::trax::frame(&s)?, None)
    };
    let load_after = load_average();
    let r = &ran.out.report;
    let cfg = &s.resolved.config;
    println!(
        "scene            {} ({} triangles), {}x{} {:?}, {} of {} pixels simulated",
        s.resolved.scene.name,
        s.resolved.scene.triangles.len(),
        ran.params.width,
        ran.params.height,
        ran.params.kind,
        r.pixels_done,
        ran.pixels.len()
    );
    // STRaTA's engine runs on one thread; the baseline's fast engine on `--threads` (one
    // shard of TMs each).
    let threads =
        if strata.is_some() || r.chip.engine != "fast" || cfg.sim.timeline_cycles.is_some() {
            1
        } else {
            s.pool.current_num_threads().min(r.chip.tms as usize)
        };
    println!(
        "chip             {} TMs × {} TPs = {} TPs, {} engine on {} host thread{}{}",
        r.chip.tms,
        r.chip.tps_per_tm,
        r.chip.tps,
        r.chip.engine,
        threads,
        if threads == 1 { "" } else { "s" },
        cfg.sim
            .cycle_limit
            .map(|c| format!(", cycle limit {}", thousands(c)))
            .unwrap_or_default()
    );
    println!(
        "simulated        {} cycles, {} instructions, {} rays",
        thousands(r.cycles),
        thousands(r.instructions.total),
        thousands(ran.out.rays.total().rays)
    );
    let rates = |secs: f64| {
        format!(
            "{:>10.0} cycles/s {:>8.1} M TP-cycles/s {:>7.1} M instructions/s",
            r.cycles as f64 / secs,
            r.cycles as f64 * r.chip.tps as f64 / secs / 1e6,
            r.instructions.total as f64 / secs / 1e6
        )
    };
    println!(
        "wall             {:>7.2} s {}",
        ran.seconds,
        rates(ran.seconds)
    );
    if let Some(cpu) = ran.cpu_seconds {
        println!("CPU              {:>7.2} s {}", cpu, rates(cpu));
    }
    // The target is per host (wall) second on the reference machine; CPU seconds count every
    // thread's, spinning included, so they measure the work, not the wait.
    let ips = r.instructions.total as f64 / ran.seconds;
    println!(
        "paper frame      64 G instructions at the wall rate: {:.1} min (target 15 min)",
        PAPER_FRAME_INSTRUCTIONS / ips / 60.0
    );
    println!(
        "peak memory      {} (VmHWM of the process, scene and BVH included)",
        peak_memory()
            .map(|kb| format!("{:.0} MB", kb as f64 / 1024.0))
            .unwrap_or_else(|| "unavailable".into())
    );
    println!(
        "host load        {} before, {} after (1-, 5-, 15-minute load averages; {} CPUs)",
        load_before.as_deref().unwrap_or("?"),
        load_after.as_deref().unwrap_or("?"),
        std::thread::available_parallelism().map_or(0, |n| n.get())
    );
    println!(
        "BVH build        {:.2} s (not in the rates)",
        s.build_seconds
    );
    if let Some(f) = strata {
        println!(
            "stream memory    {} pushes, {} pops, {} treelet switches, {} reconfigurations",
            thousands(f.stream.pushes),
            thousands(f.stream.pops),
            thousands(f.treelet_switches),
            thousands(f.reconfigurations)
        );
    }
    if let Some(b) = baseline_args {
        let flags = simulate::flags(&b)?;
        let sb = session::open(&b.scene, &flags, false)?;
        let base = simulate::trax::frame(&sb)?;
        let (ns, how) = per_instruction(&ran);
        let (base_ns, _) = per_instruction(&base);
        println!(
            "per instruction  STRaTA {ns:.1} ns, baseline {base_ns:.1} ns ({how}, one host thread \
             each; baseline: {} instructions in {} cycles): STRaTA {:.2}× the baseline's",
            thousands(base.out.report.instructions.total),
            thousands(base.out.report.cycles),
            ns / base_ns
        );
        // Per instruction favours the baseline: a fused box or triangle test is one STRaTA
        // instruction for the work of dozens of the baseline's, and STRaTA's programs are
        // half loads. Per simulated cycle of the same chip is what a user's frame costs.
        let (cyc_ns, _) = per_cycle(&ran);
        let (base_cyc_ns, _) = per_cycle(&base);
        println!(
            "per cycle        STRaTA {:.2} µs, baseline {:.2} µs ({how}, the same chip): STRaTA \
             {:.2}× the baseline's",
            cyc_ns / 1e3,
            base_cyc_ns / 1e3,
            cyc_ns / base_cyc_ns
        );
        // The engine's cost is mostly per synchronising access (each one an event in global
        // time order, `docs/STRATA.md`, "Per access event"), and STRaTA's fused tests read
        // their inputs through one load each: the per-instruction ratio is mostly the ratio
        // of the two chips' access densities.
        let (acc, acc_share) = sync_accesses(&ran);
        let (base_acc, base_share) = sync_accesses(&base);
        let (acc_ns, _) = per(&ran, acc);
        let (base_acc_ns, _) = per(&base, base_acc);
        println!(
            "per access       STRaTA {acc_ns:.1} ns, baseline {base_acc_ns:.1} ns ({how}; \
             synchronising accesses — loads, stores, atomics, stream and pipeline accesses — \
             {acc_share:.3} and {base_share:.3} per instruction): STRaTA {:.2}× the baseline's",
            acc_ns / base_acc_ns
        );
    }
    Ok(())
}

/// A run's accepted synchronising accesses (instructions whose class [`Class::is_sync`]:
/// data-cache, atomic, stream and triangle-pipeline accesses) and their share of its
/// instructions. Refused offers that were retried are not counted.
fn sync_accesses(r: &simulate::trax::Ran) -> (u64, f64) {
    let i = &r.out.report.instructions;
    let n = Class::ALL
        .iter()
        .filter(|c| c.is_sync())
        .map(|c| i.by_class.get(c.mnemonic()).copied().unwrap_or(0))
        .sum();
    (n, n as f64 / i.total.max(1) as f64)
}

/// Host nanoseconds per simulated core cycle of a run.
fn per_cycle(r: &simulate::trax::Ran) -> (f64, &'static str) {
    per(r, r.out.report.cycles)
}

/// Host nanoseconds per simulated instruction of a run.
fn per_instruction(r: &simulate::trax::Ran) -> (f64, &'static str) {
    per(r, r.out.report.instructions.total)
}

/// Host nanoseconds per `n` of a run: per CPU second where the platform reports it (both runs
/// measured alike), else per wall second.
fn per(r: &simulate::trax::Ran, n: u64) -> (f64, &'static str) {
    let n = n.max(1) as f64;
    match r.cpu_seconds {
        Some(cpu) => (cpu * 1e9 / n, "CPU"),
        None => (r.seconds * 1e9 / n, "wall"),
    }
}

/// The process's peak resident set in KiB (`VmHWM` in `/proc/self/status`; Linux only).
fn peak_memory() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    line.split_whitespace().nth(1)?.parse().ok()
}

/// The first three fields of `/proc/loadavg` (Linux only).
fn load_average() -> Option<String> {
    let s = std::fs::read_to_string("/proc/loadavg").ok()?;
    Some(s.split_whitespace().take(3).collect::<Vec<_>>().join(" "))
}
