//! `rtsim scenes`. PLACEHOLDER (skeleton).

use crate::cli::ScenesArgs;
use anyhow::Result;

pub fn run(_args: ScenesArgs) -> Result<()> {
    anyhow::bail!("`scenes` is not built yet")
}
