//! `rtsim render`. PLACEHOLDER (skeleton).

use crate::cli::RenderArgs;
use anyhow::Result;

pub fn run(_args: RenderArgs) -> Result<()> {
    anyhow::bail!("`render` is not built yet")
}
