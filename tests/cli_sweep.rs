//! `rtsim sweep` on the real binary: grid points, resumption after a kill, refusal to reuse
//! another experiment's results, failed points, single points and merge-only runs, Slurm
//! scripts, and (ignored, run by CI's long checks) a real one-node Slurm cluster.

mod common;
use common::{fails, ok, rtsim};
use std::path::{Path, PathBuf};
use std::time::Duration;

/// An experiment of `n_leaf × 2` render points (plus one AO point) of `size`² Cornell pixels.
fn experiment(dir: &Path, size: u32, extra: &str) -> PathBuf {
    let p = dir.join("exp.toml");
    std::fs::write(
        &p,
        format!(
            r#"
name = "t"
command = "render"
[base]
"scene.name" = "cornell"
workload = {{ width = {size}, height = {size} }}
[grid]
"bvh.max_leaf_size" = [2, 4, 8]
"trace.traversal" = ["stack", "short-stack"]
[[point]]
"workload.kind" = "ao"
[quick]
"workload.width" = 8
{extra}
"#
        ),
    )
    .unwrap();
    p
}

fn sweep(exp: &Path, out: &Path) -> std::process::Command {
    let mut c = rtsim();
    c.arg("sweep").arg(exp).arg("--out").arg(out);
    c
}

fn table(out: &Path) -> String {
    std::fs::read_to_string(out.join("results.csv")).unwrap()
}

#[test]
fn a_sweep_runs_every_point_and_a_rerun_changes_nothing() {
    let tmp = tempfile::tempdir().unwrap();
    let exp = experiment(tmp.path(), 16, "");
    let out = tmp.path().join("r");
    ok(&mut sweep(&exp, &out));
    let first = table(&out);
    assert_eq!(first.lines().count(), 1 + 7, "{first}");
    assert!(first.starts_with("point,bvh.max_leaf_size,trace.traversal,workload.kind,"));
    assert!(first.contains("rays.total.nodes_visited"));
    for i in 0..7 {
        let d = out.join(format!("points/p{i:05}"));
        for f in [
            "point.json",
            "point-config.toml",
            "stats.json",
            "render.png",
        ] {
            assert!(d.join(f).is_file(), "{}", d.join(f).display());
        }
    }
    // Points that differ only in the traversal variant trace the same rays.
    let json: Vec<serde_json::Value> = std::fs::read_to_string(out.join("results.jsonl"))
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(
        json[0]["metrics"]["rays.total.rays"],
        json[1]["metrics"]["rays.total.rays"]
    );
    // A rerun finds everything done and writes the same table.
    let stderr = sweep(&exp, &out).output().unwrap().stderr;
    assert!(String::from_utf8_lossy(&stderr).contains("0 to run"));
    assert_eq!(table(&out), first);
    // --quick keeps its own results.
    let quick = tmp.path().join("q");
    ok(sweep(&exp, &quick).arg("--quick"));
    assert_ne!(table(&quick), first);
}

#[test]
fn a_killed_sweep_resumes_to_the_same_results() {
    let tmp = tempfile::tempdir().unwrap();
    // Points of about a second each, one at a time, so the kill lands mid-sweep.
    let exp = experiment(tmp.path(), 256, "");
    let reference = tmp.path().join("ref");
    ok(sweep(&exp, &reference).args(["--jobs", "2"]));
    let out = tmp.path().join("killed");
    let mut child = sweep(&exp, &out)
        .args(["--jobs", "1"])
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    // Kill once at least one point has finished (or after a generous wait).
    for _ in 0..200 {
        if out.join("points/p00000").exists() {
            break;
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    child.kill().unwrap(); // SIGKILL
    child.wait().unwrap();
    // Whatever is left is either a finished point or a staging directory.
    let mut finished = 0;
    for e in std::fs::read_dir(out.join("points")).unwrap() {
        let p = e.unwrap().path();
        let name = p.file_name().unwrap().to_string_lossy().into_owned();
        if name.ends_with(".tmp") {
            continue;
        }
        assert!(p.join("point.json").is_file(), "{name} is incomplete");
        assert!(p.join("stats.json").is_file(), "{name} is incomplete");
        finished += 1;
    }
    assert!(finished < 7, "the kill came too late to test anything");
    // The merge says what is missing; a rerun completes it with identical results.
    let line = fails(sweep(&exp, &out).arg("--merge"));
    assert!(line.contains("not finished"), "{line}");
    ok(&mut sweep(&exp, &out));
    assert_eq!(table(&out), table(&reference));
    assert!(
        std::fs::read_dir(out.join("points")).unwrap().all(|e| !e
            .unwrap()
            .file_name()
            .to_string_lossy()
            .ends_with(".tmp"))
    );
}

#[test]
fn another_experiments_results_are_never_reused() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("r");
    let exp = experiment(tmp.path(), 8, "");
    ok(&mut sweep(&exp, &out));
    let changed = tmp.path().join("changed");
    std::fs::create_dir(&changed).unwrap();
    let exp2 = experiment(&changed, 9, "");
    let line = fails(&mut sweep(&exp2, &out));
    assert!(
        line.contains("p00000") && line.contains("other settings"),
        "{line}"
    );
}

/// A `simulate` experiment named `name` of tiny TRaX baseline frames: `base` and `grid`
/// lines added to the shared settings.
fn sim_experiment(dir: &Path, name: &str, base: &str, grid: &str) -> PathBuf {
    let p = dir.join(format!("{name}.toml"));
    std::fs::write(
        &p,
        format!(
            r#"
name = "{name}"
command = "simulate"
[base]
"scene.name" = "cornell"
"arch.preset" = "trax-baseline"
"arch.trax.tps_per_tm" = 4
workload = {{ width = 6, height = 6 }}
{base}
[grid]
{grid}
"#
        ),
    )
    .unwrap();
    p
}

#[test]
fn a_point_another_sweep_ran_with_the_same_configuration_is_reused() {
    let tmp = tempfile::tempdir().unwrap();
    // a: 2 TMs, L2 512 KB or 1 MB. b: L2 512 KB, 1 or 2 TMs. b's second point is a's first,
    // reached through other layers (a grid key there, [base] here).
    let a = sim_experiment(
        tmp.path(),
        "a",
        "\"arch.trax.tms\" = 2",
        "\"arch.trax.l2.size_bytes\" = [524288, 1048576]",
    );
    let b = sim_experiment(
        tmp.path(),
        "b",
        "\"arch.trax.l2.size_bytes\" = 524288",
        "\"arch.trax.tms\" = [1, 2]",
    );
    let (ra, rb, fresh) = (
        tmp.path().join("ra"),
        tmp.path().join("rb"),
        tmp.path().join("fresh"),
    );
    ok(&mut sweep(&a, &ra));
    // --list says which point a donor would finish, and runs nothing.
    let listed = ok(sweep(&b, &rb).arg("--list").arg("--reuse").arg(&ra));
    let reusable: Vec<&str> = listed.lines().filter(|l| l.contains("reusable:")).collect();
    assert_eq!(reusable.len(), 1, "{listed}");
    assert!(
        listed.contains("p00001  not run") && reusable[0].contains("(a point 0, run by"),
        "{listed}"
    );
    assert!(!rb.exists());
    let out = sweep(&b, &rb).arg("--reuse").arg(&ra).output().unwrap();
    assert!(out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("point p00001 reused from") && stderr.contains("(a point 0, run by"),
        "{stderr}"
    );
    assert!(!stderr.contains("point p00000 reused"), "{stderr}");
    // The copy: the donor's outputs, this experiment's record, naming the donor.
    let (got, donor) = (rb.join("points/p00001"), ra.join("points/p00000"));
    for f in ["stats.json", "config.resolved.toml", "render.png"] {
        assert_eq!(
            std::fs::read(got.join(f)).unwrap(),
            std::fs::read(donor.join(f)).unwrap(),
            "{f}"
        );
    }
    let rec: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(got.join("point.json")).unwrap()).unwrap();
    assert_eq!(rec["experiment"], "b");
    assert_eq!(rec["params"]["arch.trax.tms"], 2);
    assert_eq!(rec["reused_from"]["experiment"], "a");
    assert_eq!(rec["reused_from"]["index"], 0);
    let ran: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(rb.join("points/p00000/point.json")).unwrap(),
    )
    .unwrap();
    assert!(ran.get("reused_from").is_none(), "{ran}");
    // The table equals a sweep that ran every point, and a rerun reuses nothing more.
    ok(&mut sweep(&b, &fresh));
    assert_eq!(table(&rb), table(&fresh));
    let again = sweep(&b, &rb).arg("--reuse").arg(&ra).output().unwrap();
    assert!(String::from_utf8_lossy(&again.stderr).contains("0 to run"));
    // A cycle limit decides what is simulated: no donor then.
    let c = sim_experiment(
        tmp.path(),
        "c",
        "\"arch.trax.l2.size_bytes\" = 524288\n\"sim.cycle_limit\" = 300",
        "\"arch.trax.tms\" = [1, 2]",
    );
    let limited = sweep(&c, &tmp.path().join("rl"))
        .arg("--reuse")
        .arg(&ra)
        .output()
        .unwrap();
    assert!(limited.status.success());
    let stderr = String::from_utf8_lossy(&limited.stderr);
    assert!(!stderr.contains("reused"), "{stderr}");
    // A directory that is not a sweep's results is an error naming it; other commands than
    // `simulate` do not reuse.
    let e = fails(
        sweep(&b, &tmp.path().join("rx"))
            .arg("--reuse")
            .arg(tmp.path()),
    );
    assert!(e.contains("not a sweep's results directory"), "{e}");
    let render = experiment(tmp.path(), 8, "");
    let e = fails(
        sweep(&render, &tmp.path().join("ry"))
            .arg("--reuse")
            .arg(&ra),
    );
    assert!(e.contains("only `simulate` experiments"), "{e}");
}

#[test]
fn bad_points_fail_before_anything_runs_and_failing_points_are_reported() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("r");
    // A value out of range: refused before any point runs, naming the point and key.
    let bad = tmp.path().join("bad.toml");
    std::fs::write(
        &bad,
        "name = \"b\"\ncommand = \"render\"\n[grid]\n\"workload.width\" = [8, 0]\n",
    )
    .unwrap();
    let line = fails(&mut sweep(&bad, &out));
    assert!(
        line.contains("point 1") && line.contains("workload.width"),
        "{line}"
    );
    assert!(!out.join("points").exists());
    // A scene that does not exist: also refused before any point runs.
    let missing = tmp.path().join("missing.toml");
    std::fs::write(
        &missing,
        "name = \"m\"\ncommand = \"render\"\n[base]\nworkload = { width = 8, height = 8 }\n\
         [grid]\n\"scene.name\" = [\"cornell\", \"no-such-scene\"]\n",
    )
    .unwrap();
    let line = fails(&mut sweep(&missing, &out));
    assert!(
        line.contains("point 1") && line.contains("no-such-scene"),
        "{line}"
    );
    assert!(!out.join("points").exists());
    // A scene file that exists but does not parse fails when its point runs; the others
    // finish, and the failed point says how its process ended.
    let broken = tmp.path().join("broken.obj");
    std::fs::write(&broken, "v 0 0 0\nf 1 2 oops\n").unwrap();
    let failing = tmp.path().join("failing.toml");
    std::fs::write(
        &failing,
        format!(
            "name = \"f\"\ncommand = \"render\"\n[base]\nworkload = {{ width = 8, height = 8 }}\n\
             [grid]\n\"scene.name\" = [\"cornell\", {:?}]\n",
            broken.display().to_string()
        ),
    )
    .unwrap();
    let run = sweep(&failing, &out).output().unwrap();
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert_eq!(run.status.code(), Some(2), "{stderr}");
    let last = stderr.lines().last().unwrap();
    assert!(
        last.starts_with("error: 1 point(s) failed: p00001"),
        "{stderr}"
    );
    let stderr = std::fs::read_to_string(out.join("points/p00001.failed/stderr.txt")).unwrap();
    assert!(stderr.contains("broken.obj"), "{stderr}");
    let exit = std::fs::read_to_string(out.join("points/p00001.failed/exit.txt")).unwrap();
    assert!(exit.contains("exit status"), "{exit}");
    assert!(out.join("points/p00000/point.json").is_file());
    let summary = std::fs::read_to_string(out.join("summary.json")).unwrap();
    assert!(summary.contains("\"finished\": 1"), "{summary}");
}

#[test]
fn single_points_merge_and_slurm_scripts() {
    let tmp = tempfile::tempdir().unwrap();
    let exp = experiment(tmp.path(), 8, "");
    let out = tmp.path().join("r");
    for k in [3, 0, 6] {
        ok(sweep(&exp, &out).args(["--point", &k.to_string()]));
    }
    assert!(!out.join("results.csv").exists());
    let line = fails(sweep(&exp, &out).arg("--merge"));
    assert!(line.contains("4 point(s) not finished"), "{line}");
    assert_eq!(table(&out).lines().count(), 1 + 3);
    let line = fails(sweep(&exp, &out).args(["--point", "7"]));
    assert!(line.contains("the experiment's points are 0-6"), "{line}");
    let jobs = tmp.path().join("jobs");
    ok(sweep(&exp, &out).arg("--emit-slurm").arg(&jobs));
    ok(sweep(&exp, &out).arg("--emit-slurm").arg(&jobs).args([
        "--sbatch=--time=1:00:00",
        "--sbatch",
        "--mem=2G",
    ]));
    let points = std::fs::read_to_string(jobs.join("points.sbatch")).unwrap();
    assert!(points.contains("#SBATCH --array=0-6"), "{points}");
    assert!(
        points.contains("#SBATCH --time=1:00:00\n#SBATCH --mem=2G\n"),
        "{points}"
    );
    let line = fails(
        sweep(&exp, &out)
            .arg("--emit-slurm")
            .arg(&jobs)
            .arg("--sbatch=--array=0-1"),
    );
    assert!(line.contains("--array"), "{line}");
    assert!(points.contains("--point \"$SLURM_ARRAY_TASK_ID\""));
    assert!(
        std::fs::read_to_string(jobs.join("submit.sh"))
            .unwrap()
            .contains("--dependency=afterany")
    );
}

#[test]
fn a_point_list_runs_those_points_and_list_shows_where_each_stands() {
    let tmp = tempfile::tempdir().unwrap();
    let exp = experiment(tmp.path(), 8, "");
    let out = tmp.path().join("r");
    let run = sweep(&exp, &out)
        .args(["--point", "6,1-2", "--jobs", "2"])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "{stderr}");
    assert!(
        stderr.contains("7 points, 3 to run (2 at once)"),
        "{stderr}"
    );
    assert!(
        !out.join("results.csv").exists(),
        "a point list does not merge"
    );
    // A point killed mid-run leaves its staging directory; a failed one its `.failed`.
    std::fs::create_dir_all(out.join("points/p00004.tmp")).unwrap();
    std::fs::create_dir_all(out.join("points/p00005.failed")).unwrap();
    let listed = sweep(&exp, &out).arg("--list").output().unwrap();
    assert!(listed.status.success());
    let stdout = String::from_utf8_lossy(&listed.stdout);
    let status: Vec<(&str, &str)> = stdout
        .lines()
        .map(|l| (&l[..6], l[8..18].trim_end()))
        .collect();
    assert_eq!(
        status,
        [
            ("p00000", "not run"),
            ("p00001", "finished"),
            ("p00002", "finished"),
            ("p00003", "not run"),
            ("p00004", "staged"),
            ("p00005", "failed"),
            ("p00006", "finished")
        ],
        "{stdout}"
    );
    let summary = String::from_utf8_lossy(&listed.stderr);
    assert!(
        summary.contains("3 of 7 point(s) finished in")
            && summary.contains("the others: --point 0,3-5"),
        "{summary}"
    );
    // The list reads back as a point list, and runs the rest in the order given.
    ok(sweep(&exp, &out).args(["--point", "5,0,3-4"]));
    ok(sweep(&exp, &out).arg("--merge"));
    assert_eq!(table(&out).lines().count(), 1 + 7);
    let line = fails(sweep(&exp, &out).args(["--point", "2,1-3"]));
    assert!(line.contains("point 2 is named twice"), "{line}");
    let line = fails(sweep(&exp, &out).args(["--point", "4-2"]));
    assert!(line.contains("the range 4-2 runs backwards"), "{line}");
    // With --emit-slurm, the array's points.
    let jobs = tmp.path().join("jobs");
    ok(sweep(&exp, &out)
        .args(["--point", "6,0-1"])
        .arg("--emit-slurm")
        .arg(&jobs));
    let script = std::fs::read_to_string(jobs.join("points.sbatch")).unwrap();
    assert!(script.contains("#SBATCH --array=0-1,6\n"), "{script}");
}

#[test]
fn excluded_grid_points_are_never_run_and_the_rest_keep_their_numbers() {
    let tmp = tempfile::tempdir().unwrap();
    let exp = experiment(tmp.path(), 8, "[[exclude]]\n\"bvh.max_leaf_size\" = 4");
    let out = tmp.path().join("r");
    let list = ok(sweep(&exp, &out).arg("--list"));
    let numbers: Vec<&str> = list.lines().map(|l| &l[..6]).collect();
    assert_eq!(
        numbers,
        ["p00000", "p00001", "p00004", "p00005", "p00006"],
        "{list}"
    );
    ok(sweep(&exp, &out).args(["--jobs", "2"]));
    let t = table(&out);
    let points: Vec<&str> = t
        .lines()
        .skip(1)
        .map(|l| &l[..l.find(',').unwrap()])
        .collect();
    assert_eq!(points, ["0", "1", "4", "5", "6"], "{t}");
    assert!(!out.join("points/p00002").exists() && !out.join("points/p00003").exists());
    let line = fails(sweep(&exp, &out).args(["--point", "2"]));
    assert!(
        line.contains("[[exclude]] leaves that grid point out (its points: 0-1,4-6)"),
        "{line}"
    );
    let line = fails(sweep(&exp, &out).args(["--point", "7"]));
    assert!(
        line.contains("the experiment's points are 0-1,4-6"),
        "{line}"
    );
    let jobs = tmp.path().join("jobs");
    ok(sweep(&exp, &out).arg("--emit-slurm").arg(&jobs));
    let script = std::fs::read_to_string(jobs.join("points.sbatch")).unwrap();
    assert!(script.contains("#SBATCH --array=0-1,4-6\n"), "{script}");
}

/// The Slurm path for real: a one-node cluster on localhost (root and Debian's slurm-wlm and
/// munge, installed here if missing), the emitted array job and merge, and the merged table
/// equal to a local run's. Skips, saying why, where that cannot run.
#[test]
#[ignore = "starts a Slurm cluster; run by CI's long checks"]
fn slurm_array_job_on_a_one_node_cluster() {
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("scripts/slurm_one_node.sh");
    let is_root = std::process::Command::new("id")
        .arg("-u")
        .output()
        .is_ok_and(|o| String::from_utf8_lossy(&o.stdout).trim() == "0");
    if !is_root {
        eprintln!("skipping: not root, cannot start Slurm daemons");
        return;
    }
    if which("sbatch").is_none() || which("munged").is_none() {
        let st = std::process::Command::new("apt-get")
            .args(["install", "-y", "-qq", "slurm-wlm", "munge"])
            .env("DEBIAN_FRONTEND", "noninteractive")
            .status();
        if !st.is_ok_and(|s| s.success()) {
            eprintln!("skipping: slurm-wlm and munge cannot be installed here");
            return;
        }
    }
    let tmp = tempfile::tempdir().unwrap();
    let cluster = tmp.path().join("cluster");
    let start = std::process::Command::new(&script)
        .arg("start")
        .arg(&cluster)
        .output()
        .unwrap();
    if start.status.code() == Some(3) {
        eprintln!("skipping: {}", String::from_utf8_lossy(&start.stderr));
        return;
    }
    struct Stop<'a>(&'a Path, &'a Path);
    impl Drop for Stop<'_> {
        fn drop(&mut self) {
            let _ = std::process::Command::new(self.0)
                .arg("stop")
                .arg(self.1)
                .status();
        }
    }
    let _stop = Stop(&script, &cluster);
    assert!(
        start.status.success(),
        "cluster did not start: {}",
        String::from_utf8_lossy(&start.stderr)
    );
    let conf = cluster.join("slurm.conf");
    let exp = experiment(tmp.path(), 16, "");
    let local = tmp.path().join("local");
    ok(&mut sweep(&exp, &local));
    let out = tmp.path().join("slurm");
    let jobs = tmp.path().join("jobs");
    ok(sweep(&exp, &out).arg("--emit-slurm").arg(&jobs));
    let submit = std::process::Command::new(jobs.join("submit.sh"))
        .env("SLURM_CONF", &conf)
        .output()
        .unwrap();
    assert!(
        submit.status.success(),
        "{}",
        String::from_utf8_lossy(&submit.stderr)
    );
    // Wait for the array and the merge to leave the queue.
    let mut done = false;
    for _ in 0..300 {
        let q = std::process::Command::new("squeue")
            .args(["-h"])
            .env("SLURM_CONF", &conf)
            .output()
            .unwrap();
        if q.status.success() && q.stdout.is_empty() && out.join("results.csv").exists() {
            done = true;
            break;
        }
        std::thread::sleep(Duration::from_millis(500));
    }
    assert!(
        done,
        "the Slurm jobs did not finish; logs in {}",
        out.join("slurm").display()
    );
    assert_eq!(table(&out), table(&local));
}

fn which(bin: &str) -> Option<PathBuf> {
    std::env::var_os("PATH").and_then(|paths| {
        std::env::split_paths(&paths)
            .chain([PathBuf::from("/usr/sbin"), PathBuf::from("/sbin")])
            .map(|d| d.join(bin))
            .find(|p| p.is_file())
    })
}

/// Every experiment shipped in `experiments/` is valid: its points list, and the first and last
/// points of its `--quick` version run.
#[test]
fn shipped_experiments_run_at_quick_scale() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("experiments");
    let mut n = 0;
    for e in std::fs::read_dir(&dir).unwrap() {
        let exp = e.unwrap().path();
        if exp.extension().is_none_or(|x| x != "toml") {
            continue;
        }
        n += 1;
        let tmp = tempfile::tempdir().unwrap();
        let out = tmp.path().join("r");
        // The first and last point numbers (an [[exclude]] leaves gaps between them).
        let list = ok(sweep(&exp, &out).args(["--list", "--quick"]));
        let numbers: Vec<usize> = list
            .lines()
            .filter_map(|l| l.strip_prefix('p')?.get(..5)?.parse().ok())
            .collect();
        assert!(!numbers.is_empty(), "{}: {list}", exp.display());
        for p in [numbers[0], numbers[numbers.len() - 1]] {
            ok(sweep(&exp, &out)
                .arg("--quick")
                .args(["--point", &p.to_string()]));
        }
    }
    assert!(n > 0, "no experiments in {}", dir.display());
}

/// The paper-scale points kept in `docs/results/` (they cost CPU hours) still belong to the
/// shipped experiments: an edit of an experiment that changes a recorded point's settings
/// would make the sweep refuse the directory, so it fails here first; and `rtsim report`
/// reads them.
#[test]
fn recorded_results_belong_to_the_shipped_experiments() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut n = 0;
    for d in std::fs::read_dir(root.join("docs/results")).unwrap() {
        let dir = d.unwrap().path();
        if !dir.join("points").is_dir() {
            continue;
        }
        n += 1;
        let name = dir.file_name().unwrap().to_string_lossy().to_string();
        let exp = root.join("experiments").join(format!("{name}.toml"));
        assert!(
            exp.is_file(),
            "{}: no experiment {}",
            dir.display(),
            exp.display()
        );
        let listed = sweep(&exp, &dir).arg("--list").output().unwrap();
        let stdout = String::from_utf8_lossy(&listed.stdout);
        let stderr = String::from_utf8_lossy(&listed.stderr);
        assert!(listed.status.success(), "{stderr}");
        assert!(!stdout.contains("conflict"), "{}: {stdout}", dir.display());
        let kept = std::fs::read_dir(dir.join("points"))
            .unwrap()
            .filter(|p| {
                !p.as_ref()
                    .unwrap()
                    .file_name()
                    .to_string_lossy()
                    .contains('.')
            })
            .count();
        assert!(kept > 0, "{}", dir.display());
        assert!(
            stderr.starts_with(&format!("{kept} of ")),
            "{}: {kept} point directories, but: {stderr}",
            dir.display()
        );
        let tmp = tempfile::tempdir().unwrap();
        ok(rtsim().arg("report").arg(&dir).arg("--out").arg(tmp.path()));
        assert!(tmp.path().join("report.html").is_file());
    }
    assert!(n >= 2, "docs/results holds the recorded experiments");
}
