//! `rtsim compare --arch A --arch B …`: the same frame on several presets of one chip.
//!
//! - SGRT presets (`--arch sgrt-sptrv --arch sgrt`, the SGRT paper's Table 4), optionally
//!   averaged over the scene's viewpoints as the paper averages over five: Mrays/s, steps per
//!   ray, utilisations and hit rates per preset and the speed and step ratios against the
//!   first, written as `compare.json`.
//! - The TRaX chip (`--arch trax-baseline --arch strata`): the STRaTA paper's Tables 1 and 3
//!   for the scene, ours beside the paper's (`compare_strata`).
//!
//! `compare.json` is deterministic; host time goes to `timing.json`, as for `simulate`.

use crate::cli::SceneArgs;
use crate::commands::simulate::{FrameArgs, sgrt};
use crate::run_config::{self, Flag};
use crate::session;
use anyhow::{Context, Result};
use clap::Args;
use rtsim_sgrt::Report;
use serde::Serialize;
use toml::Value;

#[derive(Debug, Args, Clone)]
pub struct CompareArgs {
    #[command(flatten)]
    pub scene: SceneArgs,
    /// An architecture preset (repeat), all of one chip: SGRT (`sgrt`, `sgrt-sptrv`,
    /// `sgrt-1`; e.g. `--arch sgrt-sptrv --arch sgrt`, ratios against the first) or TRaX
    /// (`--arch trax-baseline --arch strata`: STRaTA's Tables 1 and 3).
    #[arg(long = "arch", required = true, value_name = "PRESET")]
    pub archs: Vec<String>,
    /// Average over viewpoints: `all` (the scene's `[[viewpoint]]`s) or a list such as 1,3,5.
    /// Default: the scene's camera (`scene.viewpoint` if set).
    #[arg(long, value_name = "all|N,N,…")]
    pub viewpoints: Option<String>,
    #[command(flatten)]
    pub frame: FrameArgs,
}

/// Means over the viewpoints of one preset.
#[derive(Debug, Serialize)]
struct Mean {
    arch: String,
    mrays_per_second: f64,
    trv_steps_per_ray: f64,
    ist_steps_per_ray: f64,
    trv_utilisation: f64,
    ist_utilisation: f64,
    trv_l1_hit_rate: f64,
    trv_l2_hit_rate: f64,
    ist_l1_hit_rate: f64,
    dram_gbps: f64,
    /// Against the first preset: its Mrays/s over the first's, and its TRV steps over the
    /// first's (means of the per-viewpoint ratios).
    speed_ratio: f64,
    trv_step_ratio: f64,
}

#[derive(Debug, Serialize)]
struct Run {
    arch: String,
    viewpoint: Option<u32>,
    report: Report,
}

/// One run's host time, for `timing.json` (kept out of the deterministic `compare.json`).
#[derive(Debug, Serialize)]
pub(crate) struct RunTiming {
    pub arch: String,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub viewpoint: Option<u32>,
    pub simulate_seconds: f64,
}

/// `timing.json`: host-dependent figures of every run.
#[derive(Debug, Serialize)]
pub(crate) struct TimingFile {
    pub runs: Vec<RunTiming>,
}

/// The chips `compare` runs presets of.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Chip {
    Sgrt,
    Trax,
}

/// Which chip a preset runs on, if `compare` knows it.
fn chip_of(preset: &str) -> Option<Chip> {
    match preset {
        "trax-baseline" | "strata" => Some(Chip::Trax),
        p if p.starts_with("sgrt") => Some(Chip::Sgrt),
        _ => None,
    }
}

/// The chip every preset runs on; an error names the preset at fault (one `compare` does
/// not know, or the first of another chip than the first preset's).
pub(crate) fn chip(archs: &[String]) -> Result<Chip> {
    const KNOWN: &str = "SGRT: sgrt, sgrt-sptrv, sgrt-1; TRaX: trax-baseline, strata";
    let mut first: Option<(&str, Chip)> = None;
    for a in archs {
        let Some(c) = chip_of(a) else {
            anyhow::bail!("--arch `{a}`: not a preset rtsim compare runs ({KNOWN})");
        };
        match first {
            None => first = Some((a, c)),
            Some((f, fc)) if fc != c => anyhow::bail!(
                "--arch `{a}`: rtsim compare runs presets of one chip, and `{a}` is {} while the \
                 first, `{f}`, is {} ({KNOWN})",
                name(c),
                name(fc)
            ),
            Some(_) => {}
        }
    }
    fn name(c: Chip) -> &'static str {
        match c {
            Chip::Sgrt => "an SGRT preset",
            Chip::Trax => "a TRaX-chip preset",
        }
    }
    first
        .map(|(_, c)| c)
        .ok_or_else(|| anyhow::anyhow!("no --arch given"))
}

#[derive(Debug, Serialize)]
struct CompareFile {
    scene: String,
    viewpoints: Vec<Option<u32>>,
    means: Vec<Mean>,
    runs: Vec<Run>,
}

/// The viewpoints to run: `None` is the configured camera.
fn viewpoints(args: &CompareArgs, frame: &[Flag]) -> Result<Vec<Option<u32>>> {
    let Some(v) = &args.viewpoints else {
        return Ok(vec![None]);
    };
    if v == "all" {
        let r = run_config::resolve(&args.scene, frame)?;
        let n = r.scene.viewpoints.len() as u32;
        anyhow::ensure!(
            n > 0,
            "--viewpoints all: scene `{}` has no [[viewpoint]] list",
            r.scene.name
        );
        return Ok((1..=n).map(Some).collect());
    }
    v.split(',')
        .map(|s| {
            s.trim()
                .parse::<u32>()
                .map(Some)
                .with_context(|| format!("--viewpoints: `{s}` is not a viewpoint number"))
        })
        .collect()
}

pub fn run(args: CompareArgs) -> Result<()> {
    if chip(&args.archs)? == Chip::Trax {
        return super::compare_strata::run(&args);
    }
    let frame = args.frame.flags()?;
    let views = viewpoints(&args, &frame)?;
    let mut runs = Vec::new();
    let mut scene = String::new();
    // Pre-flight: `compare.json` is checked and staged before the runs.
    let dir = crate::run_config::resolve(&args.scene, &frame)?
        .config
        .output
        .dir;
    let path = dir.join("compare.json");
    let timing_path = dir.join("timing.json");
    let mut plan = rtsim_core::output::OutputPlan::new();
    plan.dir(&dir, "the output directory (--out, output.dir)")
        .file(&path)
        .file(&timing_path);
    let mut outputs = plan.prepare()?;
    let mut timing = TimingFile { runs: Vec::new() };
    for &v in &views {
        for arch in &args.archs {
            let mut flags = frame.clone();
            flags.push(("arch.preset", Value::String(arch.clone())));
            if let Some(v) = v {
                flags.push(("scene.viewpoint", Value::Integer(v.into())));
            }
            let s = session::open(&args.scene, &flags, false)?;
            scene = s.resolved.scene.name.clone();
            let r = sgrt::simulate(&s)?;
            let view = v.map_or("camera".to_string(), |v| format!("viewpoint {v}"));
            eprintln!(
                "{arch:<12} {view:<12} {:>8.1} Mrays/s  TRV steps {:>7.2}  IST steps {:>5.2}  ({:.1} s)",
                r.report.mrays_per_second,
                r.report.trv_steps_per_ray,
                r.report.ist_steps_per_ray,
                r.output.timing.simulate_seconds
            );
            if !r.report.complete {
                eprintln!(
                    "warning: {arch} {view}: the frame is incomplete (stopped by the cycle limit \
                     after {} cycles); its figures are not a whole frame's",
                    r.report.cycles
                );
            }
            timing.runs.push(RunTiming {
                arch: arch.clone(),
                viewpoint: v,
                simulate_seconds: r.output.timing.simulate_seconds,
            });
            runs.push(Run {
                arch: arch.clone(),
                viewpoint: v,
                report: r.report,
            });
        }
    }
    let means = means(&args.archs, &runs);
    println!(
        "{:<12} {:>9} {:>10} {:>10} {:>8} {:>8} {:>7} {:>7} {:>7} {:>7}",
        "arch",
        "Mrays/s",
        "TRV steps",
        "IST steps",
        "TRV %",
        "IST %",
        "L1 %",
        "L2 %",
        "IST L1",
        "GB/s"
    );
    for m in &means {
        println!(
            "{:<12} {:>9.1} {:>10.2} {:>10.2} {:>8.1} {:>8.1} {:>7.1} {:>7.1} {:>7.1} {:>7.2}",
            m.arch,
            m.mrays_per_second,
            m.trv_steps_per_ray,
            m.ist_steps_per_ray,
            100.0 * m.trv_utilisation,
            100.0 * m.ist_utilisation,
            100.0 * m.trv_l1_hit_rate,
            100.0 * m.trv_l2_hit_rate,
            100.0 * m.ist_l1_hit_rate,
            m.dram_gbps
        );
    }
    for m in means.iter().skip(1) {
        println!(
            "{} / {}: speed {:.3}×, TRV steps {:.3}× ({:.2}× fewer)",
            m.arch,
            means[0].arch,
            m.speed_ratio,
            m.trv_step_ratio,
            1.0 / m.trv_step_ratio
        );
    }
    let file = CompareFile {
        scene,
        viewpoints: views,
        means,
        runs,
    };
    outputs.write(&path, serde_json::to_string_pretty(&file)?.as_bytes())?;
    outputs.write(
        &timing_path,
        serde_json::to_string_pretty(&timing)?.as_bytes(),
    )?;
    outputs.commit()?;
    for p in [&path, &timing_path] {
        println!("wrote            {}", p.display());
    }
    Ok(())
}

/// Per preset, the means over its runs (one per viewpoint), and the means of the per-viewpoint
/// ratios against the first preset.
fn means(archs: &[String], runs: &[Run]) -> Vec<Mean> {
    fn of<'a>(runs: &'a [Run], a: &'a str) -> impl Iterator<Item = &'a Run> {
        runs.iter().filter(move |r| r.arch == a)
    }
    let mean = |a: &str, f: &dyn Fn(&Report) -> f64| {
        let v: Vec<f64> = of(runs, a).map(|r| f(&r.report)).collect();
        v.iter().sum::<f64>() / v.len().max(1) as f64
    };
    let ratio = |a: &str, f: &dyn Fn(&Report) -> f64| {
        let v: Vec<f64> = of(runs, a)
            .zip(of(runs, &archs[0]))
            .map(|(x, y)| f(&x.report) / f(&y.report))
            .collect();
        v.iter().sum::<f64>() / v.len().max(1) as f64
    };
    archs
        .iter()
        .map(|a| Mean {
            arch: a.clone(),
            mrays_per_second: mean(a, &|r| r.mrays_per_second),
            trv_steps_per_ray: mean(a, &|r| r.trv_steps_per_ray),
            ist_steps_per_ray: mean(a, &|r| r.ist_steps_per_ray),
            trv_utilisation: mean(a, &|r| r.trv_utilisation),
            ist_utilisation: mean(a, &|r| r.ist_utilisation),
            trv_l1_hit_rate: mean(a, &|r| r.hit_rates.trv_l1),
            trv_l2_hit_rate: mean(a, &|r| r.hit_rates.trv_l2),
            ist_l1_hit_rate: mean(a, &|r| r.hit_rates.ist_l1),
            dram_gbps: mean(a, &|r| r.dram.as_ref().map_or(0.0, |d| d.bandwidth_gbps)),
            speed_ratio: ratio(a, &|r| r.mrays_per_second),
            trv_step_ratio: ratio(a, &|r| r.trv_steps_per_ray),
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn archs(a: &[&str]) -> Vec<String> {
        a.iter().map(|s| s.to_string()).collect()
    }

    #[test]
    fn a_mix_of_chips_blames_the_preset_at_fault() {
        assert_eq!(chip(&archs(&["sgrt-sptrv", "sgrt"])).unwrap(), Chip::Sgrt);
        assert_eq!(
            chip(&archs(&["trax-baseline", "strata"])).unwrap(),
            Chip::Trax
        );
        let e = chip(&archs(&["trax-baseline", "sgrt"]))
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("--arch `sgrt`"), "{e}");
        assert!(e.contains("the first, `trax-baseline`"), "{e}");
        let e = chip(&archs(&["sgrt", "sgrt-1", "strata"]))
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("--arch `strata`"), "{e}");
        let e = chip(&archs(&["strata", "gpu"])).unwrap_err().to_string();
        assert!(e.starts_with("--arch `gpu`: not a preset"), "{e}");
    }
}
