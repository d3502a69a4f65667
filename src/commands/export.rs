//! `rtsim export`. PLACEHOLDER (skeleton).

use crate::cli::ExportArgs;
use anyhow::Result;

pub fn run(_args: ExportArgs) -> Result<()> {
    anyhow::bail!("`export` is not built yet")
}
