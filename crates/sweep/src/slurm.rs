//! Batch-scheduler scripts: one Slurm array task per point, and a merge job that runs after
//! all of them.
//!
//! `rtsim sweep EXP --emit-slurm DIR` writes `DIR/points.sbatch` (an array job whose task `i`
//! runs `rtsim sweep EXP --point i`), `DIR/merge.sbatch` (`rtsim sweep EXP --merge`) and
//! `DIR/submit.sh`, which submits the array and the merge with `--dependency=afterany` on it
//! (the merge reports any point that did not finish, so it must run whatever happened).
//! Every path is absolute, so the scripts run from any working directory of any node that sees
//! the same file system; the jobs run in the directory the scripts were emitted from
//! (`--chdir`), so relative paths in the experiment (scene files) mean what they do locally.
//! Slurm's default `MaxArraySize` is 1001: larger sweeps need it raised
//! in `slurm.conf`.

use std::path::Path;

/// What the scripts run.
#[derive(Clone, Debug)]
pub struct SlurmJob<'a> {
    pub name: &'a str,
    /// The directory the sweep was emitted from: the jobs run there, so relative paths in
    /// the experiment (scene files) mean what they mean to a local run.
    pub workdir: &'a Path,
    /// The rtsim binary, the experiment file and the results directory (all absolute).
    pub binary: &'a Path,
    pub experiment: &'a Path,
    pub out: &'a Path,
    /// The points' numbers, ascending (gaps where the experiment excludes grid points).
    pub points: &'a [usize],
    pub quick: bool,
    /// Extra `#SBATCH` options for both jobs (`--time=4:00:00`, `--mem=8G`,
    /// `--partition=long`, `--cpus-per-task=2`), each after the defaults so it wins.
    pub options: &'a [String],
}

/// Slurm's default `MaxArraySize` (`slurm.conf`): an array job's indices must be below it.
pub const DEFAULT_MAX_ARRAY_SIZE: usize = 1001;

/// Check one extra `#SBATCH` option: a long option (`--name=value` or `--flag`), on one
/// line; anything else would be a broken or misleading script.
pub fn check_option(o: &str) -> Result<(), String> {
    let ok = o.starts_with("--")
        && o.len() > 2
        && !o
            .chars()
            .any(|c| c.is_control() || c.is_whitespace() && c != ' ')
        && !o.contains(" #");
    if !ok {
        return Err(format!(
            "--sbatch {o:?}: give one long sbatch option, e.g. --sbatch=--time=4:00:00"
        ));
    }
    for reserved in [
        "--array",
        "--output",
        "--error",
        "--job-name",
        "--dependency",
    ] {
        if o == reserved || o.starts_with(&format!("{reserved}=")) {
            return Err(format!(
                "--sbatch {o:?}: the scripts set {reserved} themselves (one task per point, \
                 logs under the results directory)"
            ));
        }
    }
    Ok(())
}

/// Slurm's `--array` value for ascending indices: runs of consecutive numbers as ranges,
/// joined by commas (`0-29,60-149`).
pub fn array_spec(indices: &[usize]) -> String {
    let mut parts: Vec<String> = Vec::new();
    let mut i = 0;
    while i < indices.len() {
        let mut j = i;
        while j + 1 < indices.len() && indices[j + 1] == indices[j] + 1 {
            j += 1;
        }
        parts.push(if i == j {
            indices[i].to_string()
        } else {
            format!("{}-{}", indices[i], indices[j])
        });
        i = j + 1;
    }
    parts.join(",")
}

/// Quote for a POSIX shell.
pub fn shell_quote(s: &str) -> String {
    if !s.is_empty()
        && s.chars()
            .all(|c| c.is_ascii_alphanumeric() || "/._-+=:@%".contains(c))
    {
        s.to_string()
    } else {
        format!("'{}'", s.replace('\'', "'\\''"))
    }
}

/// `(file name, contents)` of the three scripts.
pub fn scripts(job: &SlurmJob<'_>) -> Vec<(&'static str, String)> {
    let q = |p: &Path| shell_quote(&p.display().to_string());
    let logs = job.out.join("slurm");
    let quick = if job.quick { " --quick" } else { "" };
    let extra: String = job
        .options
        .iter()
        .map(|o| format!("#SBATCH {o}\n"))
        .collect();
    let base = format!(
        "{} sweep {} --out {}",
        q(job.binary),
        q(job.experiment),
        q(job.out)
    );
    let points = format!(
        "#!/bin/bash\n\
         # One task per point of experiment `{name}` ({n} points), written by `rtsim sweep --emit-slurm`.\n\
         #SBATCH --job-name=rtsim-{name}\n\
         #SBATCH --array={array}\n\
         #SBATCH --ntasks=1\n\
         #SBATCH --cpus-per-task=1\n\
         #SBATCH --output={logs}/point-%a.log\n\
         #SBATCH --chdir={dir}\n\
         {extra}\
         set -euo pipefail\n\
         exec {base} --point \"$SLURM_ARRAY_TASK_ID\"{quick}\n",
        name = job.name,
        n = job.points.len(),
        array = array_spec(job.points),
        logs = q(&logs),
        dir = q(job.workdir),
    );
    let merge = format!(
        "#!/bin/bash\n\
         # Merges the points of experiment `{name}` once the array job has ended.\n\
         #SBATCH --job-name=rtsim-{name}-merge\n\
         #SBATCH --ntasks=1\n\
         #SBATCH --cpus-per-task=1\n\
         #SBATCH --output={logs}/merge.log\n\
         #SBATCH --chdir={dir}\n\
         {extra}\
         set -euo pipefail\n\
         exec {base} --merge{quick}\n",
        name = job.name,
        logs = q(&logs),
        dir = q(job.workdir),
    );
    let submit = format!(
        "#!/bin/sh\n\
         # Submit the points of experiment `{name}`, then the merge after all of them.\n\
         set -eu\n\
         mkdir -p {logs}\n\
         cd \"$(dirname \"$0\")\"\n\
         jid=$(sbatch --parsable points.sbatch)\n\
         jid=${{jid%%;*}}\n\
         mid=$(sbatch --parsable --dependency=afterany:\"$jid\" merge.sbatch)\n\
         echo \"points: job $jid; merge: job ${{mid%%;*}}\"\n",
        name = job.name,
        logs = q(&logs),
    );
    vec![
        ("points.sbatch", points),
        ("merge.sbatch", merge),
        ("submit.sh", submit),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scripts_run_each_point_and_merge_after() {
        let job = SlurmJob {
            name: "fig7",
            workdir: Path::new("/home/u/work"),
            binary: Path::new("/opt/rtsim"),
            experiment: Path::new("/home/u/exp dir/fig7.toml"),
            out: Path::new("/scratch/results/fig7"),
            points: &(0..16).collect::<Vec<_>>(),
            quick: true,
            options: &["--time=4:00:00".into(), "--mem=8G".into()],
        };
        let s = scripts(&job);
        assert_eq!(s[0].0, "points.sbatch");
        assert!(s[0].1.contains("#SBATCH --array=0-15\n"));
        assert!(s[0].1.contains(
            "exec /opt/rtsim sweep '/home/u/exp dir/fig7.toml' --out /scratch/results/fig7 \
             --point \"$SLURM_ARRAY_TASK_ID\" --quick\n"
        ));
        assert!(s[1].1.contains("--merge --quick\n"));
        assert!(s[0].1.contains("#SBATCH --chdir=/home/u/work\n"));
        assert!(s[1].1.contains("#SBATCH --chdir=/home/u/work\n"));
        for script in &s[..2] {
            assert!(
                script
                    .1
                    .contains("#SBATCH --time=4:00:00\n#SBATCH --mem=8G\nset -euo"),
                "{}",
                script.1
            );
        }
        check_option("--partition=long").unwrap();
        check_option("--exclusive").unwrap();
        for bad in [
            "time=4",
            "--array=0-3",
            "--mem=8G\nrm -rf /",
            "--",
            "--output=x",
        ] {
            assert!(check_option(bad).is_err(), "{bad}");
        }
        assert!(
            s[2].1
                .contains("--dependency=afterany:\"$jid\" merge.sbatch")
        );
        assert_eq!(shell_quote("it's"), "'it'\\''s'");
    }

    #[test]
    fn excluded_points_leave_gaps_in_the_array() {
        assert_eq!(array_spec(&[0, 1, 2, 5, 7, 8]), "0-2,5,7-8");
        assert_eq!(array_spec(&[3]), "3");
        let points: Vec<usize> = (0..30).chain(60..150).collect();
        assert_eq!(array_spec(&points), "0-29,60-149");
    }
}
