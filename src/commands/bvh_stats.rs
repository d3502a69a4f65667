//! `rtsim bvh-stats`. PLACEHOLDER (skeleton).

use crate::cli::SceneArgs;
use anyhow::Result;

pub fn run(_args: SceneArgs) -> Result<()> {
    anyhow::bail!("`bvh-stats` is not built yet")
}
