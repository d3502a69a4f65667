//! `rtsim trace`. PLACEHOLDER (skeleton).

use crate::cli::TraceArgs;
use anyhow::Result;

pub fn run(_args: TraceArgs) -> Result<()> {
    anyhow::bail!("`trace` is not built yet")
}
