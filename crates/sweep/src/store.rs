//! Where a sweep's points live, and how a finished point is recognised.
//!
//! ```text
//! results/NAME/
//!   points/p00042.tmp/     a point being run (the command writes its outputs here)
//!   points/p00042/         a finished point: the outputs and point.json, renamed into place
//!   points/p00042.failed/  a point whose command failed (exit.txt: its exit status or signal;
//!                          stderr.txt: its error output); retried next run
//!   results.csv, results.jsonl, summary.json   the merged table
//! ```
//!
//! A point is run in its `.tmp` directory; `point.json` ([`PointRecord`]) is written last, and
//! the directory is then renamed to its final name — one atomic step — so a point directory
//! either holds a complete run or does not exist. A killed sweep leaves at most `.tmp`
//! directories, which the next run removes and redoes. A finished point is skipped only if its
//! record matches the point exactly (command, arguments, settings); a directory holding another
//! experiment's point is an error, never silently reused or overwritten. The record also names
//! the build that ran the point ([`Build`]); a point finished by another build is still
//! finished (the sweep warns).

use crate::SweepError;
use crate::experiment::{Experiment, Point};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// The simulator build that ran a point.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Build {
    /// The rtsim version (`CARGO_PKG_VERSION`).
    pub version: String,
    /// `git rev-parse --short=12 HEAD` when it was built, or "unknown".
    pub commit: String,
}

impl Build {
    /// The running build.
    pub fn current() -> Build {
        Build {
            version: env!("CARGO_PKG_VERSION").to_string(),
            commit: env!("RTSIM_GIT_COMMIT").to_string(),
        }
    }
}

impl std::fmt::Display for Build {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if self.version.is_empty() {
            // A record written before builds were recorded.
            return f.write_str("an unrecorded build");
        }
        write!(f, "rtsim {} ({})", self.version, self.commit)
    }
}

/// What identifies a finished point.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PointRecord {
    pub experiment: String,
    pub index: usize,
    pub command: String,
    pub args: Vec<String>,
    pub quick: bool,
    pub params: serde_json::Map<String, serde_json::Value>,
    /// The config file the command read.
    pub config: String,
    /// The build that ran it (not part of the point's identity; empty in older records).
    #[serde(default)]
    pub build: Build,
    /// Where its outputs were copied from, if it was not run here but reused (`--reuse`; not
    /// part of the point's identity).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reused_from: Option<ReusedFrom>,
}

/// The finished point a reused point's outputs were copied from ([`crate::reuse`]).
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct ReusedFrom {
    /// Its experiment's name and point number.
    pub experiment: String,
    pub index: usize,
    /// Its directory, as given to `--reuse`.
    pub dir: String,
}

impl PointRecord {
    pub fn of(e: &Experiment, p: &Point, quick: bool) -> PointRecord {
        PointRecord {
            experiment: e.name.clone(),
            index: p.index,
            command: e.command.name().to_string(),
            args: e.args.clone(),
            quick,
            params: p.params_json(),
            config: p.config_toml.clone(),
            build: Build::current(),
            reused_from: None,
        }
    }

    /// Whether two records are of the same point (whatever build ran them, and wherever it
    /// ran).
    pub fn same_point(&self, other: &PointRecord) -> bool {
        let identity = |r: &PointRecord| PointRecord {
            build: Build::default(),
            reused_from: None,
            ..r.clone()
        };
        identity(self) == identity(other)
    }

    /// What makes this finished point's record differ from `wanted`'s (the build aside), one
    /// phrase each: the settings of their config files key by key
    /// ("`workload.spp` is 16 here, 32 in the experiment"), then the record's other fields.
    pub fn differences(&self, wanted: &PointRecord) -> Vec<String> {
        let mut out = Vec::new();
        if self.config != wanted.config {
            match (flatten_toml(&self.config), flatten_toml(&wanted.config)) {
                (Some(here), Some(there)) => {
                    let keys: std::collections::BTreeSet<&String> =
                        here.keys().chain(there.keys()).collect();
                    for k in keys {
                        let (a, b) = (here.get(k), there.get(k));
                        if a != b {
                            let show = |v: Option<&String>| v.map_or("unset".into(), Clone::clone);
                            out.push(format!(
                                "`{k}` is {} here, {} in the experiment",
                                show(a),
                                show(b)
                            ));
                        }
                    }
                    if out.is_empty() {
                        out.push("the config files differ in layout only".into());
                    }
                }
                _ => out.push("the config files differ".into()),
            }
        }
        let mut field = |name: &str, here: String, there: String| {
            if here != there {
                out.push(format!("{name} is {here} here, {there} in the experiment"));
            }
        };
        field(
            "the experiment",
            self.experiment.clone(),
            wanted.experiment.clone(),
        );
        field("the command", self.command.clone(), wanted.command.clone());
        field(
            "the arguments",
            format!("{:?}", self.args),
            format!("{:?}", wanted.args),
        );
        field("--quick", self.quick.to_string(), wanted.quick.to_string());
        field(
            "the grid parameters",
            serde_json::Value::Object(self.params.clone()).to_string(),
            serde_json::Value::Object(wanted.params.clone()).to_string(),
        );
        out
    }
}

/// A TOML document's settings as dotted keys and their values written as TOML; `None` if it
/// does not parse.
pub(crate) fn flatten_toml(text: &str) -> Option<std::collections::BTreeMap<String, String>> {
    let table: toml::Table = text.parse().ok()?;
    let mut leaves = Vec::new();
    crate::experiment::flatten("", &table, &mut leaves);
    Some(
        leaves
            .into_iter()
            .map(|(k, v)| (k, v.to_string()))
            .collect(),
    )
}

/// At most `n` of `items` joined by "; ", then how many more there are.
pub fn first_few(items: &[String], n: usize) -> String {
    let mut s = items[..items.len().min(n)].join("; ");
    if items.len() > n {
        s.push_str(&format!("; and {} more", items.len() - n));
    }
    s
}

/// How a process ended, for a failed point's record: "exit status 2", "killed by signal 9
/// (SIGKILL)".
pub fn describe_exit(status: std::process::ExitStatus) -> String {
    if let Some(code) = status.code() {
        return format!("exit status {code}");
    }
    #[cfg(unix)]
    {
        use std::os::unix::process::ExitStatusExt;
        if let Some(sig) = status.signal() {
            let name = signal_name(sig).map_or(String::new(), |n| format!(" ({n})"));
            let core = if status.core_dumped() {
                ", core dumped"
            } else {
                ""
            };
            return format!("killed by signal {sig}{name}{core}");
        }
    }
    format!("ended without an exit status ({status})")
}

/// The name of a signal whose number POSIX (or, for the rest, Linux) fixes.
#[cfg(unix)]
fn signal_name(sig: i32) -> Option<&'static str> {
    Some(match sig {
        1 => "SIGHUP",
        2 => "SIGINT",
        3 => "SIGQUIT",
        4 => "SIGILL",
        5 => "SIGTRAP",
        6 => "SIGABRT",
        8 => "SIGFPE",
        9 => "SIGKILL",
        11 => "SIGSEGV",
        13 => "SIGPIPE",
        14 => "SIGALRM",
        15 => "SIGTERM",
        #[cfg(target_os = "linux")]
        7 => "SIGBUS",
        #[cfg(target_os = "linux")]
        10 => "SIGUSR1",
        #[cfg(target_os = "linux")]
        12 => "SIGUSR2",
        _ => return None,
    })
}

/// Where a point stands.
#[derive(Clone, Debug, PartialEq)]
pub enum Status {
    Done,
    Todo,
}

/// The results directory of one experiment.
#[derive(Clone, Debug)]
pub struct Store {
    root: PathBuf,
}

/// The name of the record file in a finished point's directory.
pub const RECORD: &str = "point.json";
/// The file in a failed point's directory saying how its command ended.
pub const EXIT: &str = "exit.txt";
/// The config file a point's command reads.
pub const CONFIG: &str = "point-config.toml";

impl Store {
    pub fn new(root: impl Into<PathBuf>) -> Store {
        Store { root: root.into() }
    }

    pub fn root(&self) -> &Path {
        &self.root
    }

    fn points(&self) -> PathBuf {
        self.root.join("points")
    }

    /// A finished point's directory.
    pub fn point_dir(&self, index: usize) -> PathBuf {
        self.points().join(format!("p{index:05}"))
    }

    /// Where a point runs.
    pub fn staging_dir(&self, index: usize) -> PathBuf {
        self.points().join(format!("p{index:05}.tmp"))
    }

    /// Where a failed point's leftovers go.
    pub fn failed_dir(&self, index: usize) -> PathBuf {
        self.points().join(format!("p{index:05}.failed"))
    }

    fn io(path: &Path, e: std::io::Error) -> SweepError {
        SweepError::Write {
            path: path.to_path_buf(),
            source: e,
        }
    }

    /// Whether `record`'s point is finished here; an error if its directory holds another
    /// point.
    pub fn status(&self, record: &PointRecord) -> Result<Status, SweepError> {
        let dir = self.point_dir(record.index);
        let Some(found) = self.record(record.index)? else {
            return Ok(Status::Todo);
        };
        if found.same_point(record) {
            Ok(Status::Done)
        } else {
            Err(SweepError::invalid(
                &dir,
                format!(
                    "holds a finished point with other settings ({}): the experiment changed, \
                     or another experiment used this directory; choose another output \
                     directory with --out, or remove it",
                    first_few(&found.differences(record), 3)
                ),
            ))
        }
    }

    /// The record of finished point `index`, if there is one.
    pub fn record(&self, index: usize) -> Result<Option<PointRecord>, SweepError> {
        let dir = self.point_dir(index);
        if !dir.exists() {
            return Ok(None);
        }
        let path = dir.join(RECORD);
        let text =
            std::fs::read_to_string(&path).map_err(|e| rtsim_core::FileError::io(&path, e))?;
        let found: PointRecord =
            serde_json::from_str(&text).map_err(|source| SweepError::Json {
                path: path.clone(),
                source,
            })?;
        Ok(Some(found))
    }

    /// Remove the leftovers of killed runs (`.tmp` directories); returns how many.
    pub fn clean_stale(&self) -> Result<usize, SweepError> {
        let dir = self.points();
        let Ok(entries) = std::fs::read_dir(&dir) else {
            return Ok(0);
        };
        let mut n = 0;
        for e in entries {
            let e = e.map_err(|err| Self::io(&dir, err))?;
            let name = e.file_name();
            if name.to_string_lossy().ends_with(".tmp") {
                std::fs::remove_dir_all(e.path()).map_err(|err| Self::io(&e.path(), err))?;
                n += 1;
            }
        }
        Ok(n)
    }

    /// A fresh, empty staging directory for a point, with its config file written.
    pub fn begin(&self, record: &PointRecord) -> Result<PathBuf, SweepError> {
        let dir = self.staging_dir(record.index);
        for old in [&dir, &self.failed_dir(record.index)] {
            if old.exists() {
                std::fs::remove_dir_all(old).map_err(|e| Self::io(old, e))?;
            }
        }
        std::fs::create_dir_all(&dir).map_err(|e| Self::io(&dir, e))?;
        let cfg = dir.join(CONFIG);
        rtsim_core::output::write_atomic(&cfg, record.config.as_bytes())
            .map_err(|e| Self::io(&cfg, e))?;
        Ok(dir)
    }

    /// The point ran: write its record and move it into place.
    pub fn finish(&self, record: &PointRecord) -> Result<(), SweepError> {
        let staging = self.staging_dir(record.index);
        let path = staging.join(RECORD);
        let text = serde_json::to_string_pretty(record).map_err(|source| SweepError::Json {
            path: path.clone(),
            source,
        })?;
        rtsim_core::output::write_atomic(&path, text.as_bytes()).map_err(|e| Self::io(&path, e))?;
        let done = self.point_dir(record.index);
        std::fs::rename(&staging, &done).map_err(|e| Self::io(&done, e))
    }

    /// Finish `record`'s point with a copy of `donor`'s outputs (every file of its directory
    /// but its record and config file) instead of running it: staged and renamed into place
    /// like a run, its record naming the donor's build and directory.
    pub fn adopt(
        &self,
        record: &PointRecord,
        donor: &crate::reuse::Donor,
    ) -> Result<(), SweepError> {
        let staging = self.begin(record)?;
        let entries =
            std::fs::read_dir(&donor.dir).map_err(|e| rtsim_core::FileError::io(&donor.dir, e))?;
        for e in entries {
            let e = e.map_err(|e| rtsim_core::FileError::io(&donor.dir, e))?;
            let name = e.file_name();
            if name == RECORD || name == CONFIG || !e.path().is_file() {
                continue;
            }
            let to = staging.join(&name);
            std::fs::copy(e.path(), &to).map_err(|err| Self::io(&to, err))?;
        }
        let rec = PointRecord {
            build: donor.record.build.clone(),
            reused_from: Some(ReusedFrom {
                experiment: donor.record.experiment.clone(),
                index: donor.record.index,
                dir: donor.dir.display().to_string(),
            }),
            ..record.clone()
        };
        self.finish(&rec)
    }

    /// The point's command failed: keep its leftovers, why it ended (`exit`, e.g. "exit status
    /// 2" or "killed by signal 9 (SIGKILL)") and its `stderr` for inspection.
    pub fn fail(&self, index: usize, exit: &str, stderr: &[u8]) -> Result<PathBuf, SweepError> {
        let staging = self.staging_dir(index);
        for (name, bytes) in [
            (EXIT, format!("{exit}\n").as_bytes()),
            ("stderr.txt", stderr),
        ] {
            let path = staging.join(name);
            rtsim_core::output::write_atomic(&path, bytes).map_err(|e| Self::io(&path, e))?;
        }
        let failed = self.failed_dir(index);
        std::fs::rename(&staging, &failed).map_err(|e| Self::io(&failed, e))?;
        Ok(failed)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn exp() -> Experiment {
        Experiment::parse(
            "name = \"t\"\ncommand = \"render\"\n[grid]\nseed = [1, 2]\n",
            Path::new("t.toml"),
        )
        .unwrap()
    }

    #[test]
    fn a_point_is_done_only_when_renamed_into_place_with_a_matching_record() {
        let tmp = tempfile::tempdir().unwrap();
        let store = Store::new(tmp.path());
        let e = exp();
        let p = &e.points(false).unwrap()[1];
        let rec = PointRecord::of(&e, p, false);
        assert_eq!(store.status(&rec).unwrap(), Status::Todo);
        let dir = store.begin(&rec).unwrap();
        assert!(dir.join(CONFIG).is_file());
        // Killed here: still to do, and the next run cleans the staging directory.
        assert_eq!(store.status(&rec).unwrap(), Status::Todo);
        assert_eq!(store.clean_stale().unwrap(), 1);
        assert!(!dir.exists());
        store.begin(&rec).unwrap();
        store.finish(&rec).unwrap();
        assert_eq!(store.status(&rec).unwrap(), Status::Done);
        // The same index from a changed experiment is refused.
        let mut other = rec.clone();
        other.config.push_str("# changed\n");
        let err = store.status(&other).unwrap_err().to_string();
        assert!(err.contains("other settings"), "{err}");
        assert!(err.contains("layout only"), "{err}");
        // A failed point keeps its stderr and is retried.
        let p0 = PointRecord::of(&e, &e.points(false).unwrap()[0], false);
        store.begin(&p0).unwrap();
        let failed = store.fail(0, "exit status 2", b"boom").unwrap();
        assert_eq!(std::fs::read(failed.join("stderr.txt")).unwrap(), b"boom");
        assert_eq!(
            std::fs::read_to_string(failed.join(EXIT)).unwrap(),
            "exit status 2\n"
        );
        assert_eq!(store.status(&p0).unwrap(), Status::Todo);
        store.begin(&p0).unwrap();
        assert!(!failed.exists());
    }

    #[test]
    fn a_conflict_names_the_settings_that_differ() {
        let e = exp();
        let wanted = PointRecord::of(&e, &e.points(false).unwrap()[0], false);
        let mut found = wanted.clone();
        assert!(found.differences(&wanted).is_empty());
        found.config = "[workload]\nspp = 16\nkind = \"ao\"\n".into();
        let mut want = wanted.clone();
        want.config = "[workload]\nspp = 32\nkind = \"ao\"\nmax_depth = 5\n".into();
        want.quick = true;
        let d = found.differences(&want);
        assert_eq!(
            d,
            [
                "`workload.max_depth` is unset here, 5 in the experiment",
                "`workload.spp` is 16 here, 32 in the experiment",
                "--quick is false here, true in the experiment",
            ]
        );
        assert_eq!(
            first_few(&d, 1),
            "`workload.max_depth` is unset here, 5 in the experiment; and 2 more"
        );
        // Through the store: the refusal names them.
        let tmp = tempfile::tempdir().unwrap();
        let store = Store::new(tmp.path());
        store.begin(&found).unwrap();
        store.finish(&found).unwrap();
        let err = store.status(&want).unwrap_err().to_string();
        assert!(
            err.contains("`workload.spp` is 16 here, 32 in the experiment"),
            "{err}"
        );
    }

    #[cfg(unix)]
    #[test]
    fn exit_statuses_and_signals_are_described() {
        use std::os::unix::process::ExitStatusExt;
        use std::process::ExitStatus;
        // Wait statuses: an exit code in bits 8..16, a signal in the low 7 bits.
        assert_eq!(describe_exit(ExitStatus::from_raw(2 << 8)), "exit status 2");
        assert_eq!(
            describe_exit(ExitStatus::from_raw(9)),
            "killed by signal 9 (SIGKILL)"
        );
        assert_eq!(
            describe_exit(ExitStatus::from_raw(15)),
            "killed by signal 15 (SIGTERM)"
        );
        assert_eq!(
            describe_exit(ExitStatus::from_raw(11 | 0x80)),
            "killed by signal 11 (SIGSEGV), core dumped"
        );
    }

    #[test]
    fn a_record_names_its_build_and_another_build_still_counts_as_done() {
        let tmp = tempfile::tempdir().unwrap();
        let store = Store::new(tmp.path());
        let e = exp();
        let rec = PointRecord::of(&e, &e.points(false).unwrap()[0], false);
        assert_eq!(rec.build.version, env!("CARGO_PKG_VERSION"));
        assert!(!rec.build.commit.is_empty());
        let mut old = rec.clone();
        old.build.commit = "0123456789ab".into();
        store.begin(&old).unwrap();
        store.finish(&old).unwrap();
        let text = std::fs::read_to_string(store.point_dir(0).join(RECORD)).unwrap();
        assert!(text.contains("\"commit\": \"0123456789ab\""), "{text}");
        assert_eq!(store.status(&rec).unwrap(), Status::Done);
        assert_eq!(store.record(0).unwrap().unwrap().build, old.build);
        // A record written before builds were recorded still reads, as an unrecorded build.
        let mut v: serde_json::Value = serde_json::from_str(&text).unwrap();
        v.as_object_mut().unwrap().remove("build");
        std::fs::write(store.point_dir(0).join(RECORD), v.to_string()).unwrap();
        assert_eq!(store.status(&rec).unwrap(), Status::Done);
        let found = store.record(0).unwrap().unwrap().build;
        assert_eq!(found.to_string(), "an unrecorded build");
    }
}
