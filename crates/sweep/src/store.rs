//! Where a sweep's points live, and how a finished point is recognised.
//!
//! ```text
//! results/NAME/
//!   points/p00042.tmp/     a point being run (the command writes its outputs here)
//!   points/p00042/         a finished point: the outputs and point.json, renamed into place
//!   points/p00042.failed/  a point whose command failed (stderr.txt says why); retried next run
//!   results.csv, results.jsonl, summary.json   the merged table
//! ```
//!
//! A point is run in its `.tmp` directory; `point.json` ([`PointRecord`]) is written last, and
//! the directory is then renamed to its final name — one atomic step — so a point directory
//! either holds a complete run or does not exist. A killed sweep leaves at most `.tmp`
//! directories, which the next run removes and redoes. A finished point is skipped only if its
//! record matches the point exactly (command, arguments, settings); a directory holding another
//! experiment's point is an error, never silently reused or overwritten.

use crate::SweepError;
use crate::experiment::{Experiment, Point};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

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
        }
    }
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
        if !dir.exists() {
            return Ok(Status::Todo);
        }
        let path = dir.join(RECORD);
        let text =
            std::fs::read_to_string(&path).map_err(|e| rtsim_core::FileError::io(&path, e))?;
        let found: PointRecord =
            serde_json::from_str(&text).map_err(|source| SweepError::Json {
                path: path.clone(),
                source,
            })?;
        if &found == record {
            Ok(Status::Done)
        } else {
            Err(SweepError::invalid(
                &dir,
                "holds a finished point with other settings (the experiment changed, or \
                 another experiment used this directory): choose another output directory \
                 with --out, or remove it",
            ))
        }
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

    /// The point's command failed: keep its leftovers (and `stderr`) for inspection.
    pub fn fail(&self, index: usize, stderr: &[u8]) -> Result<PathBuf, SweepError> {
        let staging = self.staging_dir(index);
        let path = staging.join("stderr.txt");
        rtsim_core::output::write_atomic(&path, stderr).map_err(|e| Self::io(&path, e))?;
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
        // A failed point keeps its stderr and is retried.
        let p0 = PointRecord::of(&e, &e.points(false).unwrap()[0], false);
        store.begin(&p0).unwrap();
        let failed = store.fail(0, b"boom").unwrap();
        assert_eq!(std::fs::read(failed.join("stderr.txt")).unwrap(), b"boom");
        assert_eq!(store.status(&p0).unwrap(), Status::Todo);
        store.begin(&p0).unwrap();
        assert!(!failed.exists());
    }
}
