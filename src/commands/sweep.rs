//! `rtsim sweep EXPERIMENT.toml`: run every point of an experiment (each one ordinary rtsim
//! run in its own directory), resumably, on all cores or as a Slurm array job, and merge the
//! results into one table. The experiment format, the directory layout and the merge are in
//! `rtsim-sweep` (`docs/EXPERIMENTS.md`).

use crate::progress;
use anyhow::{Context, Result, bail};
use clap::Args;
use rtsim_sweep::results::{CSV_FILE, JSONL_FILE, collect, to_csv, to_jsonl};
use rtsim_sweep::slurm::{SlurmJob, scripts};
use rtsim_sweep::store::{Build, CONFIG, PointRecord, Status, Store, describe_exit};
use rtsim_sweep::{Experiment, Point};
use serde::Serialize;
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};

#[derive(Debug, Args, Clone)]
pub struct SweepArgs {
    /// The experiment file (see docs/EXPERIMENTS.md).
    pub experiment: PathBuf,
    /// Results directory. Default `results/NAME` (`results/NAME-quick` with --quick).
    #[arg(long, value_name = "DIR")]
    pub out: Option<PathBuf>,
    /// Points run at once, 1 to 256. Default: the number of cores.
    #[arg(long, value_name = "N")]
    pub jobs: Option<usize>,
    /// Apply the experiment's [quick] overrides (minutes instead of hours).
    #[arg(long)]
    pub quick: bool,
    /// Run only these points, without merging: one number (what each task of a batch array
    /// runs) or numbers and ranges in the order to run them, e.g. `93-95,108-110` (a range
    /// skips the grid points `[[exclude]]` leaves out). With --emit-slurm: the array's points.
    #[arg(long, value_name = "LIST", conflicts_with = "merge")]
    pub point: Option<String>,
    /// Only merge the finished points into the table.
    #[arg(long, conflicts_with = "emit_slurm")]
    pub merge: bool,
    /// Write Slurm scripts (an array job and a dependent merge job) into DIR instead of running.
    #[arg(long, value_name = "DIR")]
    pub emit_slurm: Option<PathBuf>,
    /// With --emit-slurm: an extra `#SBATCH` option for both jobs, repeatable (e.g.
    /// `--sbatch=--time=4:00:00 --sbatch=--mem=8G --sbatch=--partition=long`). Each point
    /// runs on the CPUs Slurm gives its task (`--cpus-per-task`, default 1).
    #[arg(
        long,
        value_name = "OPTION",
        requires = "emit_slurm",
        allow_hyphen_values = true
    )]
    pub sbatch: Vec<String>,
    /// List the points, where each stands in the results directory (finished, failed,
    /// staged: running or killed, not run) and their parameters, then exit.
    #[arg(long, conflicts_with_all = ["merge", "emit_slurm"])]
    pub list: bool,
    /// Another sweep's results directory (repeatable): a point still to run whose resolved
    /// configuration equals one of its finished points' (`simulate` experiments, the same
    /// arguments; keys that cannot change results aside) gets a copy of that point's outputs
    /// instead of a run. Its `point.json` names the donor and the build that ran it.
    /// With --list: say which points still to run a donor would finish.
    #[arg(long, value_name = "DIR", conflicts_with_all = ["merge", "emit_slurm"])]
    pub reuse: Vec<PathBuf>,
}

/// `summary.json`: what the merged table holds.
#[derive(Debug, Serialize)]
struct Summary<'a> {
    experiment: &'a str,
    command: &'a str,
    quick: bool,
    points: usize,
    finished: usize,
    /// Points not finished (never run, killed or failed): rerun the sweep to complete them.
    missing: &'a [usize],
}

/// Most points run at once (`--jobs`).
const MAX_JOBS: usize = 256;

pub fn run(args: SweepArgs) -> Result<()> {
    if let Some(j) = args.jobs.filter(|j| !(1..=MAX_JOBS).contains(j)) {
        bail!("--jobs {j}: give 1 to {MAX_JOBS} points at once");
    }
    let e = Experiment::load(&args.experiment)?;
    if args.quick && !e.has_quick() {
        bail!(
            "--quick: {} has no [quick] section (add one with the settings of a quick version, \
             or run without --quick)",
            args.experiment.display()
        );
    }
    let points = e.points(args.quick)?;
    let out = args.out.clone().unwrap_or_else(|| {
        let suffix = if args.quick { "-quick" } else { "" };
        PathBuf::from("results").join(format!("{}{suffix}", e.name))
    });
    let store = Store::new(&out);
    let chosen: Option<Vec<usize>> = match &args.point {
        Some(list) => {
            let have: Vec<usize> = points.iter().map(|p| p.index).collect();
            let entries = rtsim_sweep::select::parse(list).map_err(anyhow::Error::msg)?;
            let numbers = e.numbers(args.quick);
            Some(
                rtsim_sweep::select::resolve(&entries, &have, numbers)
                    .map_err(anyhow::Error::msg)?,
            )
        }
        None => None,
    };
    if args.list {
        let donors = if args.reuse.is_empty() {
            None
        } else {
            Some(Donors::load(&e, &args.reuse)?)
        };
        return list(
            &e,
            &points,
            chosen.as_deref(),
            args.quick,
            &store,
            donors.as_ref(),
        );
    }
    validate_points(&e, &points)?;
    if let Some(dir) = &args.emit_slurm {
        let mut indices: Vec<usize> = match &chosen {
            Some(c) => c.clone(),
            None => points.iter().map(|p| p.index).collect(),
        };
        indices.sort_unstable();
        return emit_slurm(&args, &e, &out, &indices, dir);
    }
    if args.merge {
        if !out.is_dir() {
            bail!(
                "--merge: no results directory at {} (run the sweep first, or give its --out)",
                out.display()
            );
        }
        let missing = merge(&e, &points, args.quick, &store)?;
        return unfinished(&missing);
    }
    let todo: Vec<&Point> = match &chosen {
        Some(chosen) => by_number(&points, chosen),
        None => {
            store.clean_stale()?;
            points.iter().collect()
        }
    };
    let mut pending = Vec::new();
    let mut other_builds = Vec::new();
    let build = Build::current();
    for p in todo {
        if store.status(&PointRecord::of(&e, p, args.quick))? == Status::Todo {
            pending.push(p);
        } else if let Some(rec) = store.record(p.index)?.filter(|r| r.build != build) {
            other_builds.push(format!("p{:05} ({})", p.index, rec.build));
        }
    }
    if !args.reuse.is_empty() {
        pending = reuse(&e, pending, args.quick, &store, &args.reuse)?;
    }
    if !other_builds.is_empty() {
        // Kept, not rerun: a rebuild rarely changes results, and rerunning is the user's call.
        let n = other_builds.len();
        other_builds.truncate(10);
        eprintln!(
            "warning: {n} finished point(s) were run by another build than this {build}: {}{}; \
             remove their directories to rerun them",
            other_builds.join(", "),
            if n > 10 { ", …" } else { "" }
        );
    }
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let jobs = args
        .jobs
        .unwrap_or(cores)
        .clamp(1, MAX_JOBS)
        .min(pending.len().max(1));
    eprintln!(
        "rtsim sweep: {} `{}`, {} points, {} to run ({} at once), results in {}",
        e.name,
        e.command.name(),
        points.len(),
        pending.len(),
        jobs,
        out.display()
    );
    let failures = run_points(&e, &pending, args.quick, &store, jobs)?;
    let missing = match chosen {
        None => merge(&e, &points, args.quick, &store)?,
        Some(_) => Vec::new(),
    };
    if !failures.is_empty() {
        let list: Vec<String> = failures
            .iter()
            .map(|(i, dir, exit)| format!("p{i:05} {exit} ({})", dir.join("stderr.txt").display()))
            .collect();
        bail!(
            "{} point(s) failed: {}; rerun the sweep to retry them",
            failures.len(),
            list.join(", ")
        );
    }
    unfinished(&missing)
}

/// What `--reuse` compares with: the finished points of its directories, and the settings
/// of the built-in defaults (for keys a donor's build predates).
struct Donors {
    donors: Vec<rtsim_sweep::reuse::Donor>,
    defaults: std::collections::BTreeMap<String, String>,
}

impl Donors {
    fn load(e: &Experiment, roots: &[PathBuf]) -> Result<Donors> {
        if e.command != rtsim_sweep::SweepCommand::Simulate {
            bail!(
                "--reuse: only `simulate` experiments reuse points; {} runs `{}`",
                e.path.display(),
                e.command.name()
            );
        }
        let defaults = rtsim_sweep::reuse::settings(&crate::run_config::builtin_defaults_toml()?)
            .context("the built-in defaults do not parse")?;
        Ok(Donors {
            donors: rtsim_sweep::reuse::donors(roots)?,
            defaults,
        })
    }

    /// The donor for point `p`, if any, with what it says of it: where it comes from, and the
    /// keys its build predates.
    fn find(
        &self,
        e: &Experiment,
        p: &Point,
    ) -> Result<Option<(&rtsim_sweep::reuse::Donor, String)>> {
        let settings = resolved_settings(e, p)?;
        let found = rtsim_sweep::reuse::find(
            &self.donors,
            e.command.name(),
            &e.args,
            &settings,
            &self.defaults,
        );
        Ok(found.map(|(d, predates)| {
            let mut about = format!(
                "{} ({} point {}, run by {})",
                d.dir.display(),
                d.record.experiment,
                d.record.index,
                d.record.build
            );
            if !predates.is_empty() {
                about += &format!(
                    "; its build predates {}, here at the default",
                    predates.join(", ")
                );
            }
            (d, about)
        }))
    }
}

/// `--reuse`: finish each of `pending` whose resolved configuration a finished point of
/// `roots` shares with a copy of its outputs; returns the points still to run.
fn reuse<'a>(
    e: &Experiment,
    pending: Vec<&'a Point>,
    quick: bool,
    store: &Store,
    roots: &[PathBuf],
) -> Result<Vec<&'a Point>> {
    let donors = Donors::load(e, roots)?;
    let mut left = Vec::new();
    for p in pending {
        let Some((d, about)) = donors.find(e, p)? else {
            left.push(p);
            continue;
        };
        store.adopt(&PointRecord::of(e, p, quick), d)?;
        eprintln!("rtsim sweep: point p{:05} reused from {about}", p.index);
    }
    Ok(left)
}

/// The settings of point `p`'s resolved configuration ([`rtsim_sweep::reuse::settings`]):
/// resolved here as its `rtsim simulate` process would (its scene is loaded for the scene's
/// defaults).
fn resolved_settings(
    e: &Experiment,
    p: &Point,
) -> Result<std::collections::BTreeMap<String, String>> {
    use clap::Parser;
    let mut line: Vec<String> = vec!["rtsim".into(), e.command.name().into()];
    line.extend(e.args.iter().cloned());
    let cli = crate::cli::Cli::try_parse_from(&line)
        .with_context(|| format!("{}: parsing `args`", e.path.display()))?;
    let crate::cli::Command::Simulate(a) = cli.command else {
        unreachable!("only simulate experiments reuse points")
    };
    let flags = crate::commands::simulate::flags(&a)?;
    let mut inputs = crate::run_config::inputs(&a.scene, &flags)?;
    let origin = format!("{} point {}", e.path.display(), p.index);
    inputs.config_text = Some((origin, p.config_toml.clone()));
    let resolved = rtsim_run::resolve(&inputs, &mut |_| {})?;
    let text = rtsim_config::to_toml_string(&resolved.config)?;
    rtsim_sweep::reuse::settings(&text).with_context(|| {
        format!(
            "point {}: its resolved configuration does not parse",
            p.index
        )
    })
}

/// The points numbered `chosen`, in that order (numbers `select` already checked).
fn by_number<'a>(points: &'a [Point], chosen: &[usize]) -> Vec<&'a Point> {
    chosen
        .iter()
        .map(|k| {
            points
                .iter()
                .find(|p| p.index == *k)
                .expect("a resolved point")
        })
        .collect()
}

/// `--list`: each point (or each of `chosen`), where it stands in `store` and its
/// parameters (with `--reuse`: which points still to run a donor would finish); then, on
/// stderr, how many are finished and the others as a `--point` list.
fn list(
    e: &Experiment,
    points: &[Point],
    chosen: Option<&[usize]>,
    quick: bool,
    store: &Store,
    donors: Option<&Donors>,
) -> Result<()> {
    let shown: Vec<&Point> = match chosen {
        Some(c) => by_number(points, c),
        None => points.iter().collect(),
    };
    let mut unfinished = Vec::new();
    for p in &shown {
        let wanted = PointRecord::of(e, p, quick);
        let status = match store.status(&wanted) {
            Ok(Status::Done) => "finished",
            Ok(Status::Todo) if store.failed_dir(p.index).is_dir() => "failed",
            Ok(Status::Todo) if store.staging_dir(p.index).is_dir() => "staged",
            Ok(Status::Todo) => "not run",
            // The directory holds another point's results (or an unreadable record): the
            // sweep would refuse to run; say so here, with what differs.
            Err(_) => "conflict",
        };
        if status != "finished" {
            unfinished.push(p.index);
        }
        println!(
            "p{:05}  {status:<8}  {}",
            p.index,
            serde_json::Value::Object(p.params_json())
        );
        if status != "finished"
            && status != "conflict"
            && let Some(donors) = donors
            && let Some((_, about)) = donors.find(e, p)?
        {
            println!("          reusable: {about}");
        }
        if status == "conflict" {
            let why = match store.record(p.index) {
                Ok(Some(found)) => rtsim_sweep::store::first_few(&found.differences(&wanted), 3),
                Ok(None) => "no record".to_string(),
                Err(err) => err.to_string(),
            };
            println!("          {why}");
        }
    }
    unfinished.sort_unstable();
    eprintln!(
        "{} of {} point(s) finished in {}{}{}",
        shown.len() - unfinished.len(),
        shown.len(),
        store.root().display(),
        if unfinished.is_empty() {
            ""
        } else {
            "; the others: --point "
        },
        rtsim_sweep::slurm::array_spec(&unfinished)
    );
    Ok(())
}

/// An error naming the points not finished, if any.
fn unfinished(missing: &[usize]) -> Result<()> {
    if missing.is_empty() {
        return Ok(());
    }
    let shown: Vec<String> = missing
        .iter()
        .take(20)
        .map(|i| format!("p{i:05}"))
        .collect();
    bail!(
        "{} point(s) not finished ({}{}); run the sweep again to complete them",
        missing.len(),
        shown.join(", "),
        if missing.len() > 20 { ", …" } else { "" }
    )
}

/// Check every point's settings before any runs (a typo in a grid value fails now, not hours
/// later): the command line every point runs, its settings, and its scene's name.
fn validate_points(e: &Experiment, points: &[Point]) -> Result<()> {
    validate_args(e)?;
    if !e.command.reads_run_config() {
        return Ok(());
    }
    for p in points {
        let origin = format!("{} point {}", e.path.display(), p.index);
        let inputs = rtsim_run::Inputs {
            config_text: Some((origin.clone(), p.config_toml.clone())),
            ..rtsim_run::Inputs::default()
        };
        let config = rtsim_run::layers(&inputs, None)
            .and_then(|l| l.build::<rtsim_run::RunConfig>())
            .map_err(|err| {
                // Located errors already start with the point's origin.
                let text = err.to_string();
                if text.starts_with(&origin) {
                    anyhow::anyhow!(text)
                } else {
                    anyhow::anyhow!("{origin}: {text}")
                }
            })?;
        // Only the name: loading every point's scene here would take as long as the sweep.
        let name = &config.scene.name;
        let missing = match rtsim_scene::registry::find_scene(name) {
            Err(err) => Some(err.to_string()),
            Ok(rtsim_scene::SceneSource::File(path)) if !path.is_file() => {
                Some(format!("no scene file at {}", path.display()))
            }
            Ok(_) => None,
        };
        if let Some(why) = missing {
            bail!("{origin}: `scene.name` = {name:?}: {why}");
        }
    }
    Ok(())
}

/// Parse the command line each point runs (the experiment's `args` and what the sweep adds), as
/// the point's process will, so an unknown flag fails before the sweep starts.
fn validate_args(e: &Experiment) -> Result<()> {
    use clap::Parser;
    let mut line: Vec<String> = vec!["rtsim".into(), e.command.name().into()];
    line.extend(e.args.iter().cloned());
    line.extend(["--config".into(), CONFIG.into()]);
    if e.command.has_out_dir() {
        line.extend(["--out".into(), "out".into()]);
    }
    if e.command.reads_run_config() {
        line.extend(["--threads".into(), "1".into()]);
    }
    match crate::cli::Cli::try_parse_from(&line) {
        Ok(cli) => {
            // A flag that sets a configuration key the experiment's tables also set would
            // override the grid or the points for every point, while their records say
            // otherwise: refused. (A flag for a key no table sets is a fixed setting, as in
            // [base]; each point's config.resolved.toml records it.)
            let mut clash: Vec<String> = Vec::new();
            for (key, flag) in settings_of(&cli.command)? {
                let set_by_tables = [false, true].iter().any(|&quick| {
                    e.points(quick).is_ok_and(|points| {
                        points.iter().any(|p| {
                            p.config_toml
                                .parse::<toml::Table>()
                                .is_ok_and(|t| dotted(&t, &key))
                        })
                    })
                });
                if set_by_tables && !clash.iter().any(|c| c.starts_with(&key)) {
                    clash.push(format!("{key} ({flag})"));
                }
            }
            if clash.is_empty() {
                return Ok(());
            }
            bail!(
                "{}: `args` = {:?} set {}, which the experiment's tables also set: the flag \
                 would override them for every point, unrecorded; set it in one place only \
                 ([base], [grid] or [[point]])",
                e.path.display(),
                e.args,
                clash.join(", ")
            )
        }
        Err(err) => {
            let text = err.to_string();
            let first = text.lines().next().unwrap_or_default();
            let first = first.strip_prefix("error: ").unwrap_or(first);
            bail!(
                "{}: `args` = {:?}: `rtsim {}` rejects them: {first}",
                e.path.display(),
                e.args,
                e.command.name()
            )
        }
    }
}

/// Whether the table sets the dotted key.
fn dotted(t: &toml::Table, key: &str) -> bool {
    let mut cur = t;
    let mut parts = key.split('.').peekable();
    while let Some(part) = parts.next() {
        match cur.get(part) {
            Some(_) if parts.peek().is_none() => return true,
            Some(toml::Value::Table(inner)) => cur = inner,
            _ => return false,
        }
    }
    false
}

/// The configuration keys a parsed command line sets through its flags, each with its flag
/// (the output directory aside, which the sweep sets).
fn settings_of(c: &crate::cli::Command) -> Result<Vec<(String, String)>> {
    use crate::cli::Command;
    let flag_of = |key: &str| match key {
        "workload.kind" => "--workload",
        "workload.width" => "--width",
        "workload.height" => "--height",
        "workload.spp" => "--spp",
        "sim.window" => "--window",
        "sim.cycle_limit" => "--cycle-limit",
        "sim.mode" => "--mode",
        "sim.timeline_cycles" => "--timeline",
        "arch.preset" => "--arch",
        "dram.preset" => "--dram-preset",
        "scene.name" => "--scene",
        "seed" => "--seed",
        _ => "a flag",
    };
    let mut keys: Vec<&str> = Vec::new();
    let scene = |a: &crate::cli::SceneArgs, keys: &mut Vec<&str>| {
        if a.scene.is_some() {
            keys.push("scene.name");
        }
        if a.seed.is_some() {
            keys.push("seed");
        }
    };
    let flags;
    match c {
        Command::Render(a) => {
            scene(&a.scene, &mut keys);
            for (key, set) in [
                ("workload.kind", a.workload.is_some()),
                ("workload.width", a.width.is_some()),
                ("workload.height", a.height.is_some()),
                ("workload.spp", a.spp.is_some()),
            ] {
                if set {
                    keys.push(key);
                }
            }
        }
        Command::Simulate(a) => {
            scene(&a.scene, &mut keys);
            flags = crate::commands::simulate::flags(a)?;
            keys.extend(flags.iter().map(|(k, _)| *k).filter(|k| *k != "output.dir"));
        }
        Command::BvhStats(a) => {
            scene(&a.scene, &mut keys);
            if a.dram_preset.is_some() {
                keys.push("dram.preset");
            }
        }
        Command::Bench(a) => scene(&a.scene, &mut keys),
        _ => {}
    }
    Ok(keys
        .into_iter()
        .map(|k| (k.to_string(), flag_of(k).to_string()))
        .collect())
}

/// A failed point: its number, directory and how its command ended.
type Failure = (usize, PathBuf, String);

/// Run `pending` points, `jobs` at a time; returns the failed ones.
fn run_points(
    e: &Experiment,
    pending: &[&Point],
    quick: bool,
    store: &Store,
    jobs: usize,
) -> Result<Vec<Failure>> {
    if pending.is_empty() {
        return Ok(Vec::new());
    }
    let exe = std::env::current_exe().context("locating the rtsim binary")?;
    let next = AtomicUsize::new(0);
    let failures = Mutex::new(Vec::new());
    let errors = Mutex::new(Vec::new());
    let bar = progress::bar(pending.len() as u64, "sweep");
    // Without a terminal (nohup, a batch log) there is no bar: a line per finished point
    // instead, with the elapsed time, so a long sweep's log shows where it is.
    let lines = !std::io::stderr().is_terminal();
    let (start, done) = (std::time::Instant::now(), AtomicUsize::new(0));
    let total = pending.len();
    std::thread::scope(|s| {
        for _ in 0..jobs {
            s.spawn(|| {
                loop {
                    let k = next.fetch_add(1, Ordering::Relaxed);
                    let Some(p) = pending.get(k) else { break };
                    let how = match run_point(&exe, e, p, quick, store, jobs > 1) {
                        Ok(None) => "finished".to_string(),
                        Ok(Some((dir, exit))) => {
                            let how = format!("FAILED ({exit})");
                            failures
                                .lock()
                                .expect("no panics")
                                .push((p.index, dir, exit));
                            how
                        }
                        Err(err) => {
                            errors.lock().expect("no panics").push(err);
                            "stopped the sweep".to_string()
                        }
                    };
                    bar.inc(1);
                    if lines {
                        let n = done.fetch_add(1, Ordering::Relaxed) + 1;
                        eprintln!(
                            "rtsim sweep: point p{:05} {how} ({n} of {total}, {:.0} s elapsed)",
                            p.index,
                            start.elapsed().as_secs_f64()
                        );
                    }
                }
            });
        }
    });
    bar.finish_and_clear();
    if let Some(err) = errors.into_inner().expect("no panics").into_iter().next() {
        return Err(err);
    }
    let mut f = failures.into_inner().expect("no panics");
    f.sort();
    Ok(f)
}

/// Run one point in its staging directory; `Some((dir, how it ended))` if its command failed.
fn run_point(
    exe: &Path,
    e: &Experiment,
    p: &Point,
    quick: bool,
    store: &Store,
    one_thread: bool,
) -> Result<Option<(PathBuf, String)>> {
    let rec = PointRecord::of(e, p, quick);
    let dir = store.begin(&rec)?;
    let mut cmd = Command::new(exe);
    cmd.arg(e.command.name())
        .args(&e.args)
        .arg("--config")
        .arg(dir.join(CONFIG));
    if e.command.has_out_dir() {
        cmd.arg("--out").arg(&dir);
    }
    if one_thread && e.command.reads_run_config() {
        // Points run side by side: one thread each (results never depend on it).
        cmd.args(["--threads", "1"]);
    }
    let stdout = std::fs::File::create(dir.join("stdout.txt"))
        .with_context(|| format!("creating {}", dir.join("stdout.txt").display()))?;
    cmd.stdin(Stdio::null())
        .stdout(stdout)
        .stderr(Stdio::piped());
    die_with_parent(&mut cmd);
    let output = cmd
        .output()
        .with_context(|| format!("running point {} ({})", p.index, exe.display()))?;
    if output.status.success() {
        store.finish(&rec)?;
        Ok(None)
    } else {
        // Why it ended (an exit status, or a signal: the OOM killer, a kill -9) goes beside its
        // stderr, which a killed process may have left empty.
        let exit = describe_exit(output.status);
        let dir = store.fail(p.index, &exit, &output.stderr)?;
        Ok(Some((dir, exit)))
    }
}

/// A point's process must not outlive a killed sweep (it would keep writing into a staging
/// directory the next run removes): on Linux it is killed when its parent dies.
fn die_with_parent(cmd: &mut Command) {
    #[cfg(target_os = "linux")]
    {
        use std::os::unix::process::CommandExt;
        // SAFETY: prctl is async-signal-safe; the closure touches no memory of the parent.
        unsafe {
            cmd.pre_exec(|| {
                if libc::prctl(libc::PR_SET_PDEATHSIG, libc::SIGKILL) != 0 {
                    return Err(std::io::Error::last_os_error());
                }
                Ok(())
            });
        }
    }
    #[cfg(not(target_os = "linux"))]
    let _ = cmd;
}

/// Merge the finished points into `results.csv`, `results.jsonl` and `summary.json`; returns
/// the points not finished.
fn merge(e: &Experiment, points: &[Point], quick: bool, store: &Store) -> Result<Vec<usize>> {
    let m = collect(e, points, quick, store)?;
    let root = store.root();
    std::fs::create_dir_all(root).with_context(|| format!("creating {}", root.display()))?;
    let summary = Summary {
        experiment: &e.name,
        command: e.command.name(),
        quick,
        points: points.len(),
        finished: m.rows.len(),
        missing: &m.missing,
    };
    for (name, text) in [
        (CSV_FILE, to_csv(&m)),
        (JSONL_FILE, to_jsonl(&m)),
        (
            "summary.json",
            serde_json::to_string_pretty(&summary)? + "\n",
        ),
    ] {
        let path = root.join(name);
        rtsim_core::output::write_atomic(&path, text.as_bytes())
            .with_context(|| format!("writing {}", path.display()))?;
    }
    println!(
        "merged {} of {} points into {}",
        m.rows.len(),
        points.len(),
        root.join(CSV_FILE).display()
    );
    Ok(m.missing)
}

fn emit_slurm(
    args: &SweepArgs,
    e: &Experiment,
    out: &Path,
    indices: &[usize],
    dir: &Path,
) -> Result<()> {
    let abs = |p: &Path| -> Result<PathBuf> {
        std::path::absolute(p).with_context(|| format!("resolving {}", p.display()))
    };
    let binary = std::env::current_exe().context("locating the rtsim binary")?;
    let (experiment, out) = (abs(&args.experiment)?, abs(out)?);
    for o in &args.sbatch {
        rtsim_sweep::slurm::check_option(o).map_err(|m| anyhow::anyhow!(m))?;
    }
    let workdir = std::env::current_dir().context("locating the working directory")?;
    let job = SlurmJob {
        name: &e.name,
        workdir: &workdir,
        binary: &binary,
        experiment: &experiment,
        out: &out,
        points: indices,
        quick: args.quick,
        options: &args.sbatch,
    };
    let last = indices.last().copied().unwrap_or(0);
    if last >= rtsim_sweep::slurm::DEFAULT_MAX_ARRAY_SIZE {
        eprintln!(
            "warning: array task indices up to {last}: Slurm's default MaxArraySize is {}, so \
             the cluster's slurm.conf must allow more, or the submission is refused",
            rtsim_sweep::slurm::DEFAULT_MAX_ARRAY_SIZE
        );
    }
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    for (name, text) in scripts(&job) {
        let path = dir.join(name);
        rtsim_core::output::write_atomic(&path, text.as_bytes())
            .with_context(|| format!("writing {}", path.display()))?;
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o755))
                .with_context(|| format!("making {} executable", path.display()))?;
        }
    }
    println!(
        "wrote {}/{{points.sbatch,merge.sbatch,submit.sh}}: {} array tasks and a merge; \
         run {}/submit.sh on the cluster",
        dir.display(),
        indices.len(),
        dir.display()
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn args(dir: &Path, text: &str) -> SweepArgs {
        let experiment = dir.join("exp.toml");
        std::fs::write(&experiment, text).unwrap();
        SweepArgs {
            experiment,
            out: Some(dir.join("r")),
            jobs: None,
            quick: false,
            point: None,
            merge: false,
            emit_slurm: None,
            sbatch: Vec::new(),
            list: false,
            reuse: Vec::new(),
        }
    }

    const EXP: &str = "name = \"t\"\ncommand = \"render\"\n[grid]\nseed = [1, 2]\n";

    fn err(a: SweepArgs) -> String {
        format!("{:#}", run(a).unwrap_err())
    }

    #[test]
    fn flags_out_of_range_or_without_meaning_are_errors() {
        let tmp = tempfile::tempdir().unwrap();
        for (jobs, needle) in [(0, "--jobs 0"), (1000, "--jobs 1000")] {
            let mut a = args(tmp.path(), EXP);
            a.jobs = Some(jobs);
            let e = err(a);
            assert!(e.contains(needle) && e.contains("1 to 256"), "{e}");
        }
        let mut a = args(tmp.path(), EXP);
        a.quick = true;
        let e = err(a);
        assert!(e.contains("no [quick] section"), "{e}");
        let mut a = args(tmp.path(), EXP);
        a.merge = true;
        let e = err(a);
        assert!(e.contains("no results directory at"), "{e}");
        assert!(!tmp.path().join("r").exists());
    }

    #[test]
    fn bad_scene_names_and_arguments_fail_before_any_point_runs() {
        let tmp = tempfile::tempdir().unwrap();
        let e = err(args(
            tmp.path(),
            "name = \"t\"\ncommand = \"render\"\n[grid]\n\
             \"scene.name\" = [\"cornell\", \"nosuchscene\"]\n",
        ));
        assert!(
            e.contains("point 1") && e.contains("scene.name") && e.contains("nosuchscene"),
            "{e}"
        );
        let e = err(args(
            tmp.path(),
            "name = \"t\"\ncommand = \"render\"\nargs = [\"--frobnicate\"]\n",
        ));
        assert!(e.contains("`args`") && e.contains("--frobnicate"), "{e}");
        assert!(!tmp.path().join("r").exists());
        // A fixed setting no table gives is accepted (each point's resolved config records
        // it).
        let e = Experiment::parse(
            "name = \"t\"\ncommand = \"simulate\"\nargs = [\"--arch\", \"strata\"]\n",
            Path::new("t.toml"),
        )
        .unwrap();
        validate_args(&e).unwrap();
        // A flag for a key the grid or [base] sets would override it unrecorded: refused,
        // naming the keys (it ran four identical points recorded as four different ones).
        let e = err(args(
            tmp.path(),
            "name = \"t\"\ncommand = \"render\"\nargs = [\"--width\", \"12\", \"--spp\", \"1\"]\n\
             [base]\n\"workload.height\" = 8\n[grid]\n\"workload.width\" = [8, 16]\n\
             \"workload.spp\" = [1, 2]\n",
        ));
        assert!(
            e.contains("workload.width (--width)") && e.contains("workload.spp (--spp)"),
            "{e}"
        );
        let e = err(args(
            tmp.path(),
            "name = \"t\"\ncommand = \"simulate\"\nargs = [\"--arch\", \"strata\"]\n\
             [base]\n\"arch.preset\" = \"sgrt\"\n",
        ));
        assert!(e.contains("arch.preset (--arch)"), "{e}");
    }
}
