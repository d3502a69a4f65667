//! `rtsim cache`: replay an address trace through a cache or a cache hierarchy.
//!
//! Functional mode gives exact hits, misses, evictions and write-backs per cache; timed mode
//! runs the banked, MSHR-limited hierarchy over the DRAM model (`--dram-preset`, DRAM keys with
//! `--set dram.KEY=VALUE`) in the chip clock `clock_mhz`. Cache keys come from the defaults
//! (TRaX), then `--config FILE` (its `[dram]` table, if any, configures the DRAM), then `--set`.
//! Writes `DIR/cache_stats.json` and `DIR/cache_config.resolved.toml` atomically. Trace format,
//! keys and model: `docs/CACHES.md`.

use super::StatsOutputs;
use anyhow::{Context, Result, bail};
use clap::Args;
use rtsim_cache::trace::{
    ReplayError, ReplaySummary, TraceAccess, TraceError, TraceReader, replay_functional,
    replay_timed,
};
use rtsim_cache::{
    CacheConfig, CacheStats, FunctionalHierarchy, Hierarchy, MemoryCounts, Parent, Topology,
};
use rtsim_config::{ConfigError, Layers};
use rtsim_core::output::OutputSet;
use rtsim_dram::config::UserLayers;
use rtsim_dram::{Dram, DramConfig, Report, Requester};
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::time::Instant;
use toml::{Table, Value};

#[derive(Debug, Args, Clone)]
pub struct CacheArgs {
    /// Address trace: one access per line, `R|W <hex addr> [cycle [l1]]`, `#` comments.
    #[arg(long, value_name = "FILE")]
    pub trace: PathBuf,
    /// functional (exact counts, no time) or timed (banks, MSHRs, DRAM).
    #[arg(long, default_value = "functional")]
    pub mode: String,
    /// DRAM preset behind the caches in timed mode.
    #[arg(long, default_value = "gddr5-trax")]
    pub dram_preset: String,
    /// TOML file: cache keys at its root; a [dram] table configures the DRAM (timed mode).
    #[arg(long, value_name = "FILE")]
    pub config: Option<PathBuf>,
    /// Override a key: cache keys (l1.ways=4, l2.size_bytes=1048576, levels=1 …) or DRAM keys
    /// prefixed with `dram.` (dram.timing.tRCD=30). Repeatable.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
    /// Output directory for cache_stats.json and cache_config.resolved.toml.
    #[arg(long, value_name = "DIR", default_value = "out")]
    pub out: PathBuf,
    /// Print functional accesses per second (the trace is read into memory first, so parsing
    /// is not timed).
    #[arg(long)]
    pub bench: bool,
}

#[derive(Debug, Serialize)]
struct RunInfo {
    trace: String,
    mode: String,
    accesses: u64,
    reads: u64,
    writes: u64,
    /// Timed: cycles accesses waited beyond their trace cycle (refusals).
    stall_cycles: u64,
    /// Timed: refused offers (bank conflicts, MSHRs or write buffer full).
    refusals: u64,
    /// Timed: the cycle the last access's data was ready.
    end_cycle: u64,
}

/// `timing.json`: host-dependent figures, kept out of the deterministic `cache_stats.json`.
#[derive(Debug, Serialize)]
struct CacheTiming {
    wall_seconds: f64,
    accesses_per_second: f64,
}

/// One cache's counters.
#[derive(Debug, Serialize)]
struct CacheEntry {
    index: usize,
    name: String,
    level: u32,
    hit_rate: f64,
    stats: CacheStats,
}

/// A level's caches summed.
#[derive(Debug, Serialize)]
struct LevelEntry {
    level: u32,
    name: String,
    caches: usize,
    hit_rate: f64,
    read_hit_rate: f64,
    stats: CacheStats,
}

#[derive(Debug, Serialize)]
struct StatsFile<'a> {
    run: RunInfo,
    config: &'a CacheConfig,
    levels: Vec<LevelEntry>,
    caches: Vec<CacheEntry>,
    /// Functional: line reads and writes that left the last level.
    memory: Option<MemoryCounts>,
    /// Timed: the DRAM report (requester tag i = the i-th cache that talks to memory).
    dram: Option<&'a Report>,
    dram_config: Option<&'a DramConfig>,
}

/// The cache config, and the DRAM assignments (file's [dram] table, then `--set dram.*`).
fn resolve(args: &CacheArgs) -> Result<(CacheConfig, Vec<String>)> {
    let mut layers = Layers::new();
    layers.merge_value(&CacheConfig::default(), "built-in defaults (TRaX)")?;
    let mut dram_sets = Vec::new();
    if let Some(path) = &args.config {
        let text = rtsim_config::read_config_file(path)?;
        let origin = path.display().to_string();
        let mut table = rtsim_config::parse_toml(&text, &origin)?;
        if let Some(d) = table.remove("dram") {
            let Value::Table(d) = d else {
                return Err(ConfigError::key("dram", format!("{origin}: expected a table")).into());
            };
            let mut leaves = Vec::new();
            rtsim_config::flatten("", &d, &mut leaves);
            let sets = leaves.into_iter().map(|(k, v)| format!("{k}={v}"));
            // An explicit --dram-preset beats the file's preset.
            let flag = args.dram_preset != "gddr5-trax";
            dram_sets.extend(sets.filter(|s| !(flag && s.starts_with("preset="))));
        }
        layers.merge_table(table, &origin);
    }
    for s in &args.set {
        match s.split_once('=') {
            Some((k, _)) if k.trim().starts_with("dram.") => dram_sets.push(s.clone()),
            _ => layers.set(s)?,
        }
    }
    Ok((layers.build()?, dram_sets))
}

fn open_trace(path: &Path) -> Result<TraceReader<std::io::BufReader<std::fs::File>>, TraceError> {
    let f = std::fs::File::open(path).map_err(|source| TraceError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    Ok(TraceReader::new(
        std::io::BufReader::with_capacity(1 << 16, f),
        path,
    ))
}

pub fn run(args: CacheArgs) -> Result<()> {
    let timed = match args.mode.as_str() {
        "functional" => false,
        "timed" => true,
        other => {
            return Err(ConfigError::unknown("mode", other, &["functional", "timed"]).into());
        }
    };
    let (config, dram_sets) = resolve(&args)?;
    let topology = Topology::from_config(&config)?;
    // Pre-flight: the outputs are checked and staged before the replay.
    let (files, outputs) = StatsOutputs::prepare(
        &args.out,
        "cache_stats.json",
        "cache_config.resolved.toml",
        &[
            ("--trace", Some(&args.trace)),
            ("--config", args.config.as_deref()),
        ],
    )?;
    let bar = crate::progress::bar(0, "accesses");
    let start = Instant::now();
    let mut dram_out = None;
    let (summary, stats, memory, bench) = if timed {
        let dram_config = rtsim_dram::config::resolve(&UserLayers {
            preset: Some(&args.dram_preset),
            file: None,
            sets: &dram_sets,
        })?;
        let tags = topology
            .nodes()
            .iter()
            .filter(|n| n.parent == Parent::Memory)
            .count() as u32;
        let dram = Dram::new(
            &dram_config,
            Requester::mhz(f64::from(config.clock_mhz)).with_tags(tags),
        )?;
        let mut h = Hierarchy::new(topology.clone(), dram)?;
        let s = replay_timed(&mut h, open_trace(&args.trace)?, |n| bar.set_position(n))
            .map_err(replay_error)?;
        let stats: Vec<CacheStats> = (0..topology.nodes().len())
            .map(|n| h.stats(n).clone())
            .collect();
        let mut dram = h.into_memory();
        let end = s.end_cycle.max(dram.now().unwrap_or(0));
        dram_out = Some((dram.report(end), dram_config));
        (s, stats, None, None)
    } else {
        let mut h = FunctionalHierarchy::from_topology(topology.clone())?;
        let (s, bench) = if args.bench {
            let accesses: Vec<TraceAccess> = open_trace(&args.trace)?.collect::<Result<_, _>>()?;
            let leaves = topology.leaves().len();
            if let Some(a) = accesses.iter().find(|a| a.l1 >= leaves) {
                bail!(
                    "{}: access to L1 {} but the hierarchy has {leaves}",
                    args.trace.display(),
                    a.l1
                );
            }
            let t0 = Instant::now();
            for a in &accesses {
                std::hint::black_box(h.access(a.l1, a.addr, a.op));
            }
            let secs = t0.elapsed().as_secs_f64();
            let mut s = ReplaySummary::default();
            for a in &accesses {
                s.accesses += 1;
                match a.op {
                    rtsim_core::MemOp::Read => s.reads += 1,
                    rtsim_core::MemOp::Write => s.writes += 1,
                }
            }
            (s, Some(secs))
        } else {
            let s = replay_functional(&mut h, open_trace(&args.trace)?, |n| bar.set_position(n))
                .map_err(replay_error)?;
            (s, None)
        };
        let stats = h.caches().iter().map(|c| c.stats.clone()).collect();
        (s, stats, Some(h.memory.clone()), bench)
    };
    bar.finish_and_clear();
    let wall = start.elapsed().as_secs_f64();
    if summary.accesses == 0 {
        bail!(
            "{}: the trace has no accesses (only blank or comment lines): nothing to replay",
            args.trace.display()
        );
    }

    let caches: Vec<CacheEntry> = topology
        .nodes()
        .iter()
        .zip(stats)
        .enumerate()
        .map(|(index, (n, stats))| CacheEntry {
            index,
            name: n.name.clone(),
            level: n.level,
            hit_rate: stats.hit_rate(),
            stats,
        })
        .collect();
    let mut levels: Vec<LevelEntry> = Vec::new();
    for c in &caches {
        match levels
            .iter_mut()
            .find(|l| l.level == c.level && l.name == c.name)
        {
            Some(l) => {
                l.caches += 1;
                l.stats += &c.stats;
            }
            None => levels.push(LevelEntry {
                level: c.level,
                name: c.name.clone(),
                caches: 1,
                hit_rate: 0.0,
                read_hit_rate: 0.0,
                stats: c.stats.clone(),
            }),
        }
    }
    for l in &mut levels {
        l.hit_rate = l.stats.hit_rate();
        l.read_hit_rate = l.stats.read_hit_rate();
    }

    println!(
        "{} replay of {}: {} accesses ({} reads, {} writes)",
        args.mode,
        args.trace.display(),
        summary.accesses,
        summary.reads,
        summary.writes
    );
    for l in &levels {
        let s = &l.stats;
        println!(
            "  {:<6} x{:<5} accesses {:>12}  hits {:>12} ({:.2} %)  misses {:>10}  evictions {:>10}  \
             write-backs {:>9}  write-throughs {:>9}",
            l.name,
            l.caches,
            s.accesses(),
            s.hits(),
            100.0 * l.hit_rate,
            s.misses(),
            s.evictions,
            s.writebacks,
            s.write_throughs
        );
        if timed {
            println!(
                "  {:<6}        bank conflicts {}  MSHR merges {}  MSHR-full stalls {}  \
                 write-buffer-full stalls {}  mean miss latency {:.1} cycles",
                "",
                s.bank_conflicts,
                s.mshr_merges,
                s.mshr_full_stalls,
                s.write_buffer_full_stalls,
                s.miss_latency.mean()
            );
        }
    }
    if let Some(m) = &memory {
        println!("  memory  reads {}  writes {}", m.reads, m.writes);
    }
    if let Some((report, _)) = &dram_out {
        println!(
            "  timing  last data at cycle {} ({} MHz); {} refusals, {} stall cycles",
            summary.end_cycle, config.clock_mhz, summary.refusals, summary.stall_cycles
        );
        print!("{}", report.summary());
    }
    let rate = match bench {
        Some(secs) => summary.accesses as f64 / secs.max(1e-9),
        None => summary.accesses as f64 / wall.max(1e-9),
    };
    if args.bench {
        match bench {
            Some(secs) => println!(
                "  functional speed: {:.1} M accesses/s ({} accesses in {:.3} s, one core, trace \
                 parsing excluded)",
                rate / 1e6,
                summary.accesses,
                secs
            ),
            None => println!(
                "  timed speed: {:.2} M accesses/s ({:.3} s including trace parsing)",
                rate / 1e6,
                wall
            ),
        }
    }
    let file = StatsFile {
        run: RunInfo {
            trace: args.trace.display().to_string(),
            mode: args.mode.clone(),
            accesses: summary.accesses,
            reads: summary.reads,
            writes: summary.writes,
            stall_cycles: summary.stall_cycles,
            refusals: summary.refusals,
            end_cycle: summary.end_cycle,
        },
        config: &config,
        levels,
        caches,
        memory,
        dram: dram_out.as_ref().map(|d| &d.0),
        dram_config: dram_out.as_ref().map(|d| &d.1),
    };
    let timing = CacheTiming {
        wall_seconds: wall,
        accesses_per_second: rate,
    };
    write_outputs(
        outputs,
        &files,
        &file,
        &timing,
        dram_out.as_ref().map(|d| &d.1),
    )
}

fn replay_error(e: ReplayError) -> anyhow::Error {
    anyhow::Error::new(e)
}

fn write_outputs(
    set: OutputSet,
    files: &StatsOutputs,
    file: &StatsFile<'_>,
    timing: &CacheTiming,
    dram: Option<&DramConfig>,
) -> Result<()> {
    let mut toml = format!(
        "# rtsim resolved cache configuration: `rtsim cache --config THIS_FILE` repeats the run.\n{}",
        rtsim_config::to_toml_string(file.config)?
    );
    if let Some(d) = dram {
        let mut t = Table::new();
        t.insert(
            "dram".into(),
            Value::try_from(d).context("serialising the DRAM config")?,
        );
        toml.push('\n');
        toml.push_str(&rtsim_config::to_toml_string(&t)?);
    }
    files.write(set, file, &toml, timing)
}
