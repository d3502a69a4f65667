//! `rtsim dram`: run the DRAM model alone on a request trace or synthetic traffic.
//!
//! The configuration is the chosen preset, then `--config FILE`, then `--set key=value` (keys
//! relative to the DRAM tree, optionally prefixed `dram.`). Prints a summary table and writes
//! `DIR/dram_stats.json` (and the resolved configuration) atomically. See `docs/DRAM.md`.

use super::StatsOutputs;
use anyhow::{Result, bail};
use clap::Args;
use rtsim_config::ConfigError;
use rtsim_core::output::OutputSet;
use rtsim_dram::config::{PRESETS, UserLayers};
use rtsim_dram::trace::{Pattern, Synthetic, TraceError, TraceFormat, TraceReader};
use rtsim_dram::{Dram, DramConfig, DriveOptions, DriveSummary, Report, Requester, drive};
use serde::Serialize;
use std::convert::Infallible;
use std::io::Read;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

#[derive(Debug, Args, Clone)]
pub struct DramArgs {
    /// DRAM preset (default gddr5-trax); `--list-presets` shows them all.
    #[arg(long)]
    pub preset: Option<String>,
    /// Request trace to run to completion.
    #[arg(long, value_name = "FILE", conflicts_with = "synthetic")]
    pub trace: Option<PathBuf>,
    /// Trace format: rtsim (`<cycle> <R|W> <hex addr>`), dramsim3 (`<hex addr> <READ|WRITE>
    /// <cycle>`, memory cycles) or usimm (`<gap> <R|W> <hex addr> [pc]`).
    #[arg(long, default_value = "rtsim")]
    pub format: String,
    /// Generate traffic instead of reading a trace: stream, random or strided.
    #[arg(long, value_name = "PATTERN")]
    pub synthetic: Option<String>,
    /// Synthetic requests to generate.
    #[arg(long, default_value_t = 1_000_000, value_parser = crate::cli::u64_arg, allow_negative_numbers = true)]
    pub requests: u64,
    /// Fraction of synthetic requests that are reads (0..=1).
    #[arg(long, default_value_t = 1.0, allow_negative_numbers = true)]
    pub read_ratio: f64,
    /// Stride in bytes of `--synthetic strided` (default: one row of one channel).
    #[arg(long, value_name = "BYTES", value_parser = crate::cli::u64_arg, allow_negative_numbers = true)]
    pub stride: Option<u64>,
    /// Requester cycles between synthetic requests (0: as fast as the queues accept them).
    #[arg(long, default_value_t = 0, value_parser = crate::cli::u64_arg, allow_negative_numbers = true)]
    pub interval: u64,
    /// Seed of the synthetic generator.
    #[arg(long, default_value_t = 1, value_parser = crate::cli::u64_arg, allow_negative_numbers = true)]
    pub seed: u64,
    /// USIMM traces: at most this many reads outstanding (default
    /// `trace.usimm_max_outstanding_reads`).
    #[arg(long, value_name = "N", value_parser = crate::cli::u32_arg, allow_negative_numbers = true)]
    pub max_outstanding: Option<u32>,
    /// TOML file merged over the preset (a DRAM tree, or a file with a [dram] table).
    #[arg(long, value_name = "FILE")]
    pub config: Option<PathBuf>,
    /// Override any DRAM key, e.g. --set timing.tRCD=30 --set controller.scheduler=fcfs.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
    /// Output directory for dram_stats.json and dram_config.resolved.toml.
    #[arg(long, value_name = "DIR", default_value = "out")]
    pub out: PathBuf,
    /// Report simulation speed (requests per second on one core).
    #[arg(long)]
    pub bench: bool,
    /// List the presets and exit.
    #[arg(long)]
    pub list_presets: bool,
}

/// What ran, for `dram_stats.json`.
#[derive(Debug, Serialize)]
struct RunInfo {
    source: String,
    format: Option<String>,
    pattern: Option<String>,
    seed: Option<u64>,
    requests: u64,
    reads: u64,
    writes: u64,
    /// Requester cycles requests waited for queue room (or the read limit).
    stall_cycles: u64,
    /// Requester cycle of the last completion.
    end_cycle: u64,
    max_outstanding_reads: Option<u32>,
}

/// `timing.json`: host-dependent figures, kept out of the deterministic `dram_stats.json`.
#[derive(Debug, Serialize)]
struct DramTiming {
    wall_seconds: f64,
    requests_per_second: f64,
}

#[derive(Debug, Serialize)]
struct StatsFile<'a> {
    run: RunInfo,
    config: &'a DramConfig,
    report: &'a Report,
}

/// Counts bytes read, for the progress bar of trace runs.
struct Counting<R> {
    inner: R,
    bytes: Arc<AtomicU64>,
}

impl<R: Read> Read for Counting<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = self.inner.read(buf)?;
        self.bytes.fetch_add(n as u64, Ordering::Relaxed);
        Ok(n)
    }
}

fn parse_pattern(name: &str, stride: Option<u64>, default_stride: u64) -> Result<Pattern> {
    Ok(match name {
        "stream" => Pattern::Stream,
        "random" => Pattern::Random,
        "strided" => {
            let s = stride.unwrap_or(default_stride);
            if s == 0 {
                bail!("--stride must be at least 1 byte");
            }
            Pattern::Strided { stride: s }
        }
        other => {
            return Err(ConfigError::unknown("synthetic pattern", other, &Pattern::NAMES).into());
        }
    })
}

pub fn run(args: DramArgs) -> Result<()> {
    if args.list_presets {
        for p in PRESETS {
            println!("{:<14} {}", p.name, p.about);
        }
        return Ok(());
    }
    let format = TraceFormat::parse(&args.format)
        .ok_or_else(|| ConfigError::unknown("trace format", &args.format, &TraceFormat::NAMES))?;
    if args.trace.is_none() && args.synthetic.is_none() {
        bail!("give a request source: --trace FILE or --synthetic stream|random|strided");
    }
    if !(0.0..=1.0).contains(&args.read_ratio) {
        return Err(ConfigError::range("--read-ratio", args.read_ratio, "0..=1").into());
    }
    let max_gap = rtsim_dram::trace::MAX_TRACE_GAP;
    if args.interval > max_gap {
        return Err(
            ConfigError::range("--interval", args.interval, format!("0..={max_gap}")).into(),
        );
    }
    if args.synthetic.is_some() && args.requests == 0 {
        return Err(ConfigError::range("--requests", 0, format!("1..={}", u64::MAX)).into());
    }
    let mut config = rtsim_dram::config::resolve(&UserLayers {
        preset: args.preset.as_deref(),
        file: args.config.as_deref(),
        sets: &args.set,
    })?;
    if args.trace.is_some() && format == TraceFormat::Dramsim3 {
        // DRAMsim3 traces are timed in memory cycles at the controller.
        config.trace.requester_clock_mhz = config.timing.clock_mhz;
    }
    let mut dram = Dram::new(&config, Requester::mhz(config.trace.requester_clock_mhz))?;
    let max_outstanding = match (&args.trace, format) {
        (Some(_), TraceFormat::Usimm) => Some(
            args.max_outstanding
                .unwrap_or(config.trace.usimm_max_outstanding_reads),
        ),
        _ => None,
    };
    if args.max_outstanding == Some(0) {
        return Err(ConfigError::range("--max-outstanding", 0, "1..=1000000").into());
    }
    let opts = DriveOptions {
        max_outstanding_reads: max_outstanding,
        max_per_cycle: config.trace.max_per_cycle,
    };
    // Pre-flight: the outputs are checked and staged before the run.
    let (files, outputs) = StatsOutputs::prepare(
        &args.out,
        "dram_stats.json",
        "dram_config.resolved.toml",
        &[
            ("--trace", args.trace.as_deref()),
            ("--config", args.config.as_deref()),
        ],
    )?;
    let start = Instant::now();
    let (summary, info_source, pattern) = if let Some(path) = &args.trace {
        (
            run_trace(&mut dram, path, format, opts)?,
            path.display().to_string(),
            None,
        )
    } else {
        let name = args.synthetic.as_deref().unwrap_or_default();
        let spec = dram.spec();
        let pattern = parse_pattern(name, args.stride, spec.org.row_bytes)?;
        let traffic = Synthetic::new(
            pattern,
            args.requests,
            args.read_ratio,
            args.interval,
            spec.org.line_bytes.into(),
            spec.org.capacity_bytes,
            args.seed,
        );
        let bar = crate::progress::bar(args.requests, "requests");
        let s = drive(&mut dram, traffic.map(Ok::<_, Infallible>), opts, |n| {
            bar.set_position(n)
        });
        bar.finish_and_clear();
        (
            s.unwrap_or_else(|e| match e {}),
            format!("synthetic {name}"),
            Some(name.to_string()),
        )
    };
    let wall = start.elapsed().as_secs_f64();
    if summary.requests == 0 {
        bail!(
            "{}: the trace has no requests (only blank or comment lines): nothing to simulate",
            args.trace.as_deref().unwrap_or(Path::new("-")).display()
        );
    }
    let report = dram.report(summary.end_cycle);
    let violations = dram.violations();

    print!("{}", report.summary());
    println!(
        "  {:<28} {} requests ({} reads, {} writes), {} stall cycles, done at requester cycle {}",
        "requester",
        summary.requests,
        summary.reads,
        summary.writes,
        summary.stall_cycles,
        summary.end_cycle
    );
    let rate = summary.requests as f64 / wall.max(1e-9);
    if args.bench {
        println!(
            "  {:<28} {:.3} s, {:.3} M requests/s (one core)",
            "simulation speed",
            wall,
            rate / 1e6
        );
    }
    let info = RunInfo {
        source: info_source,
        format: args.trace.is_some().then(|| format.to_string()),
        pattern,
        seed: args.synthetic.is_some().then_some(args.seed),
        requests: summary.requests,
        reads: summary.reads,
        writes: summary.writes,
        stall_cycles: summary.stall_cycles,
        end_cycle: summary.end_cycle,
        max_outstanding_reads: max_outstanding,
    };
    let timing = DramTiming {
        wall_seconds: wall,
        requests_per_second: rate,
    };
    write_outputs(outputs, &files, &config, &report, info, &timing)?;
    if !violations.is_empty() {
        bail!(
            "checking mode found {} timing violation(s), first: {}",
            report.stats.violations,
            violations[0]
        );
    }
    Ok(())
}

fn run_trace(
    dram: &mut Dram,
    path: &Path,
    format: TraceFormat,
    opts: DriveOptions,
) -> Result<DriveSummary> {
    let file = std::fs::File::open(path).map_err(|source| TraceError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    let len = file.metadata().map(|m| m.len()).unwrap_or(0);
    let bytes = Arc::new(AtomicU64::new(0));
    let reader = std::io::BufReader::with_capacity(
        1 << 16,
        Counting {
            inner: file,
            bytes: bytes.clone(),
        },
    );
    let records = TraceReader::new(reader, path, format);
    let bar = crate::progress::bar(len, "trace");
    let s = drive(dram, records, opts, |_| {
        bar.set_position(bytes.load(Ordering::Relaxed))
    });
    bar.finish_and_clear();
    Ok(s?)
}

fn write_outputs(
    set: OutputSet,
    files: &StatsOutputs,
    config: &DramConfig,
    report: &Report,
    run: RunInfo,
    timing: &DramTiming,
) -> Result<()> {
    let file = StatsFile {
        run,
        config,
        report,
    };
    let toml = format!(
        "# rtsim resolved DRAM configuration: `rtsim dram --config THIS_FILE` repeats the run.\n{}",
        rtsim_config::to_toml_string(config)?
    );
    files.write(set, &file, &toml, timing)
}
