//! Experiments: many runs of one rtsim command over a grid of parameters, resumable, merged
//! into one table, on one machine or a batch scheduler.
//!
//! Principal types:
//!
//! - [`Experiment`] (`experiment`): an experiment file — the command to run, the settings
//!   every point shares (`[base]`), a grid whose every combination is a point (`[grid]`),
//!   explicit points (`[[point]]`), and overrides for a quick version (`[quick]`). Parsed and
//!   validated with errors naming the file and key.
//! - [`Point`]: one run, numbered in a fixed order, with its parameters and the config file
//!   the command reads.
//! - [`store`]: where each point's outputs live (`points/p00042/`), how a finished point is
//!   recognised ([`store::PointRecord`], written last, after the point's directory was renamed
//!   into place), so a killed sweep resumes without redoing or trusting half-written work.
//! - [`results`]: every numeric value of a point's `stats.json` flattened to a dotted key, and
//!   all points merged into CSV and JSON lines.
//! - [`slurm`]: an `sbatch` array job (one task per point) and a dependent merge job.
//! - [`select`]: the points a command line names (`--point 3,7-9`).
//! - [`reuse`]: finished points of other results directories whose resolved configuration a
//!   point to run shares (`--reuse DIR`).
//!
//! The crate decides *what* to run and where results go; the `rtsim sweep` command runs the
//! processes.

pub mod experiment;
pub mod results;
pub mod reuse;
pub mod select;
pub mod slurm;
pub mod store;

pub use experiment::{Experiment, Point, SweepCommand};

use std::path::PathBuf;

/// Why an experiment cannot be run or merged.
#[derive(Debug, thiserror::Error)]
pub enum SweepError {
    #[error(transparent)]
    File(#[from] rtsim_core::FileError),
    #[error("{path}: {message}")]
    Invalid { path: PathBuf, message: String },
    #[error("{path}: {source}")]
    Json {
        path: PathBuf,
        source: serde_json::Error,
    },
    #[error("writing {path}: {source}")]
    Write {
        path: PathBuf,
        source: std::io::Error,
    },
}

impl SweepError {
    pub(crate) fn invalid(path: impl Into<PathBuf>, message: impl std::fmt::Display) -> Self {
        SweepError::Invalid {
            path: path.into(),
            message: message.to_string(),
        }
    }
}
