//! [`TraxReport`]: what a frame on the chip did, as `stats.json` holds it — the raw counters
//! (numerators and denominators) beside the figures derived from them — and the terminal
//! summary.

use crate::energy::Energy;
use crate::isa::Class;
use crate::stats::{IssueStats, Stall};
use rtsim_cache::CacheStats;
use rtsim_core::stats::ratio;
use serde::Serialize;
use std::collections::BTreeMap;

/// The chip that ran.
#[derive(Clone, Debug, Serialize)]
pub struct ChipFacts {
    pub tms: u32,
    pub tps_per_tm: u32,
    pub tps: u32,
    pub clock_mhz: u32,
    pub l2s: u32,
    pub program_instructions: u32,
    pub program_bytes: u32,
    /// `fast` or `reference`.
    pub engine: &'static str,
}

/// Instructions issued.
#[derive(Clone, Debug, Serialize)]
pub struct InstructionFacts {
    pub total: u64,
    pub by_class: BTreeMap<&'static str, u64>,
    /// Ray segments traced (every ray of the frame).
    pub rays: u64,
    pub per_ray: f64,
    /// Instructions per TP-cycle (at most 1: single issue).
    pub issue_rate: f64,
    /// Instructions per chip cycle.
    pub per_cycle: f64,
}

/// Where the TP-cycles went.
#[derive(Clone, Debug, Serialize)]
pub struct TpCycleFacts {
    /// Cycles × TPs.
    pub total: u64,
    pub issued: u64,
    pub stalls: u64,
    pub stalls_by_cause: BTreeMap<&'static str, u64>,
    /// Unit-busy stalls by unit class.
    pub unit_busy_by_class: BTreeMap<&'static str, u64>,
    pub idle: u64,
}

/// One cache level, summed over its caches.
#[derive(Clone, Debug, Serialize)]
pub struct CacheFacts {
    pub caches: usize,
    pub accesses: u64,
    pub hits: u64,
    pub misses: u64,
    pub hit_rate: f64,
    pub bank_conflicts: u64,
    pub mshr_merges: u64,
    pub stats: CacheStats,
}

impl CacheFacts {
    pub fn of(caches: usize, s: CacheStats) -> CacheFacts {
        CacheFacts {
            caches,
            accesses: s.accesses(),
            hits: s.hits(),
            misses: s.misses(),
            hit_rate: s.hit_rate(),
            bank_conflicts: s.bank_conflicts,
            mshr_merges: s.mshr_merges,
            stats: s,
        }
    }
}

/// The DRAM behind the L2s.
#[derive(Clone, Debug, Serialize)]
pub struct DramFacts {
    /// Line reads and writes accepted.
    pub accesses: u64,
    pub reads: u64,
    pub writes: u64,
    /// Column accesses that found their row open.
    pub row_hit_rate: f64,
    /// Mean read latency in core cycles, from arrival at the memory controller to data
    /// return (STRaTA Table 1's "average read latency").
    pub average_read_latency_core_cycles: f64,
    pub bandwidth_gbps: f64,
    pub peak_gbps: f64,
    pub energy_j: f64,
    /// The DRAM model's full report (every raw counter).
    pub report: rtsim_dram::Report,
}

/// Ratios the paper's tables imply (issue 8 §2).
#[derive(Clone, Debug, Serialize)]
pub struct Calibration {
    /// Register-file accesses (reads + writes) per instruction fetched; STRaTA Table 3's
    /// RF : icache energy ratio of 1.31 implies 1.31 × 0.014 / 0.008 ≈ 2.29.
    pub register_accesses_per_instruction: f64,
    /// Register-file energy over instruction-cache energy (Table 3: 1.31 on every baseline
    /// row).
    pub rf_to_icache_energy: f64,
    /// Instructions per ray segment (Table 3's icache energy at 0.014 nJ per fetch implies
    /// about 6,000 for Sibenik).
    pub instructions_per_ray: f64,
}

/// Everything a TRaX run reports.
#[derive(Clone, Debug, Serialize)]
pub struct TraxReport {
    /// Whether every pixel was finished (false when the cycle limit stopped the run).
    pub complete: bool,
    pub chip: ChipFacts,
    /// Core cycles of the frame: until the last TP found no pixel left.
    pub cycles: u64,
    pub seconds: f64,
    pub ms_per_frame: f64,
    pub fps: f64,
    pub pixels: u64,
    pub pixels_done: u64,
    pub instructions: InstructionFacts,
    pub tp_cycles: TpCycleFacts,
    pub register_file: RegisterFacts,
    pub l1: CacheFacts,
    pub l2: CacheFacts,
    pub dram: DramFacts,
    pub energy: Energy,
    pub calibration: Calibration,
    /// The raw issue counters.
    pub issue: IssueStats,
}

#[derive(Clone, Debug, Serialize)]
pub struct RegisterFacts {
    pub reads: u64,
    pub writes: u64,
}

impl TpCycleFacts {
    pub fn of(issue: &IssueStats, total: u64) -> TpCycleFacts {
        TpCycleFacts {
            total,
            issued: issue.total_instructions(),
            stalls: issue.stalls(),
            stalls_by_cause: issue.by_cause(),
            unit_busy_by_class: Class::ALL
                .iter()
                .filter(|c| c.is_unit())
                .map(|&c| (c.name(), issue.unit_busy[c as usize]))
                .collect(),
            idle: issue.idle,
        }
    }
}

impl TraxReport {
    /// The terminal summary (issue 8 §5).
    pub fn summary(&self) -> Vec<String> {
        let mut v = Vec::new();
        let c = &self.chip;
        v.push(format!(
            "chip             TRaX chip: {} TMs × {} TPs = {} TPs at {} MHz, {} L2 ({} engine)",
            c.tms, c.tps_per_tm, c.tps, c.clock_mhz, c.l2s, c.engine
        ));
        v.push(format!(
            "frame            {} cycles = {:.3} ms/frame = {:.1} FPS{}",
            self.cycles,
            self.ms_per_frame,
            self.fps,
            if self.complete {
                String::new()
            } else {
                format!(
                    " (INCOMPLETE: stopped by the cycle limit, {} of {} pixels)",
                    self.pixels_done, self.pixels
                )
            }
        ));
        let i = &self.instructions;
        v.push(format!(
            "instructions     {} ({:.0} per ray over {} rays), issue rate {:.3} per TP-cycle, {:.1} per cycle",
            i.total, i.per_ray, i.rays, i.issue_rate, i.per_cycle
        ));
        let by: Vec<String> = i
            .by_class
            .iter()
            .filter(|(_, n)| **n > 0)
            .map(|(k, n)| format!("{k} {:.1}%", 100.0 * ratio(*n as f64, i.total as f64)))
            .collect();
        v.push(format!("  by class       {}", by.join(", ")));
        let t = &self.tp_cycles;
        let pct = |n: u64| 100.0 * ratio(n as f64, t.total as f64);
        let stalls: Vec<String> = Stall::ALL
            .iter()
            .map(|s| {
                let n = t.stalls_by_cause[s.name()];
                format!("{} {:.1}%", s.name(), pct(n))
            })
            .collect();
        v.push(format!(
            "TP-cycles        {}: issue {:.1}%, stalls {:.1}% ({}), idle {:.1}%",
            t.total,
            pct(t.issued),
            pct(t.stalls),
            stalls.join(", "),
            pct(t.idle)
        ));
        for (name, l) in [("L1", &self.l1), ("L2", &self.l2)] {
            v.push(format!(
                "{name}               {} accesses, {} hits, {} misses ({:.2}% hit), {} bank conflicts, {} MSHR merges",
                l.accesses,
                l.hits,
                l.misses,
                100.0 * l.hit_rate,
                l.bank_conflicts,
                l.mshr_merges
            ));
        }
        let d = &self.dram;
        v.push(format!(
            "DRAM             {} accesses ({} reads, {} writes), row-buffer hit rate {:.1}%, avg read latency {:.1} core cycles, {:.1} GB/s of {:.0}",
            d.accesses,
            d.reads,
            d.writes,
            100.0 * d.row_hit_rate,
            d.average_read_latency_core_cycles,
            d.bandwidth_gbps,
            d.peak_gbps
        ));
        let e = &self.energy;
        let parts: Vec<String> = e
            .components()
            .iter()
            .map(|(n, j)| format!("{n} {:.4} J ({:.1}%)", j, 100.0 * ratio(*j, e.total_j)))
            .collect();
        v.push(format!(
            "energy           {:.4} J/frame, {:.1} W average: {}",
            e.total_j,
            e.average_power_w,
            parts.join(", ")
        ));
        let k = &self.calibration;
        v.push(format!(
            "calibration      {:.2} register accesses per instruction (paper ≈ 2.29), RF:icache energy {:.2} (paper 1.31)",
            k.register_accesses_per_instruction, k.rf_to_icache_energy
        ));
        v
    }
}
