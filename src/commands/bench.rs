//! `rtsim bench`. PLACEHOLDER (skeleton).

use crate::cli::BenchArgs;
use anyhow::Result;

pub fn run(_args: BenchArgs) -> Result<()> {
    anyhow::bail!("`bench` is not built yet")
}
