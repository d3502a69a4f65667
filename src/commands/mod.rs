//! One module per subcommand; each owns its clap arguments where they are its alone.

pub mod bench;
pub mod bench_sim;
pub mod bvh_stats;
pub mod cache;
pub mod dram;
pub mod export;
pub mod render;
pub mod scenes;
pub mod simulate;
pub mod trace;

use crate::cli::{Cli, Command};
use anyhow::Result;

pub fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Render(a) => render::run(a),
        Command::Simulate(a) => simulate::run(a),
        Command::Trace(a) => trace::run(a),
        Command::ExportTriangles(a) => export::run(a),
        Command::BvhStats(a) => bvh_stats::run(a),
        Command::Scenes(a) => scenes::run(a),
        Command::Bench(a) => bench::run(a),
        Command::BenchSim(a) => bench_sim::run(a),
        Command::Dram(a) => dram::run(a),
        Command::Cache(a) => cache::run(a),
    }
}

/// `1234567` → `1,234,567`.
pub(crate) fn thousands(n: u64) -> String {
    let s = n.to_string();
    let mut out = String::with_capacity(s.len() + s.len() / 3);
    for (i, c) in s.chars().enumerate() {
        if i > 0 && (s.len() - i) % 3 == 0 {
            out.push(',');
        }
        out.push(c);
    }
    out
}
