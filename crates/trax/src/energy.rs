//! Energy per frame, after the run: event counts × per-event energies (`arch.trax.energy`,
//! `arch.trax.units.*.energy_nj`), plus the DRAM model's own energy (activate/precharge,
//! bursts, refresh and background over the frame's run time).
//!
//! Sources (`../shared/DESIGN.md` §3): STRaTA Table 2 (CACTI 6.5): L2 by size, the 4 KB
//! instruction cache 0.014 nJ, the 128 B register file 0.008 nJ; SimTRaX's CACTI table for
//! data caches (32 KB 0.165, 128 KB 0.364, 512 KB 0.560 nJ; the 16 KB L1 extrapolated:
//! assumed), its local store 0.00693 nJ and its per-operation energies.

use crate::config::TraxConfig;
use crate::isa::Class;
use crate::stats::IssueStats;
use serde::Serialize;

/// STRaTA Table 2: L2 / stream memory energy per access (nJ) by size (CACTI 6.5).
pub const L2_TABLE: [(u64, f64); 6] = [
    (512 << 10, 0.524),
    (1 << 20, 0.579),
    (2 << 20, 0.686),
    (4 << 20, 0.901),
    (8 << 20, 1.17),
    (16 << 20, 1.61),
];

/// SimTRaX's CACTI table for data caches (nJ per access) by size (`DESIGN.md` §3).
pub const DATA_CACHE_TABLE: [(u64, f64); 3] =
    [(32 << 10, 0.165), (128 << 10, 0.364), (512 << 10, 0.560)];

/// Energy per access of a `bytes` memory from `table`: power-law interpolation (a straight
/// line in log–log) between the two nearest sizes, extrapolated from the end pair outside
/// the table (assumed: CACTI energies grow roughly as a power of capacity between points).
pub fn interpolate(table: &[(u64, f64)], bytes: u64) -> f64 {
    let x = (bytes as f64).ln();
    let k = table
        .windows(2)
        .position(|w| bytes <= w[1].0)
        .unwrap_or(table.len() - 2);
    let ((s0, e0), (s1, e1)) = (table[k], table[k + 1]);
    let (x0, x1) = ((s0 as f64).ln(), (s1 as f64).ln());
    let (y0, y1) = (e0.ln(), e1.ln());
    (y0 + (y1 - y0) * (x - x0) / (x1 - x0)).exp()
}

/// Energy of a frame by component, in joules.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Energy {
    pub dram_j: f64,
    pub l2_j: f64,
    /// The ray stream memory (STRaTA; 0 on the TRaX baseline).
    pub stream_j: f64,
    pub l1_j: f64,
    pub icache_j: f64,
    pub register_file_j: f64,
    pub local_memory_j: f64,
    /// Execution units (all classes) and the atomic counter.
    pub execution_units_j: f64,
    pub total_j: f64,
    /// Total over the frame's run time.
    pub average_power_w: f64,
    /// Execution-unit energy by class (J).
    pub units_by_class_j: std::collections::BTreeMap<&'static str, f64>,
    /// The per-event energies used (nJ).
    pub per_event_nj: PerEvent,
}

/// The per-event energies of a run, resolved (nJ).
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct PerEvent {
    pub l1_access: f64,
    pub l2_access: f64,
    pub icache_fetch: f64,
    pub register_access: f64,
    pub local_access: f64,
}

impl PerEvent {
    pub fn of(cfg: &TraxConfig) -> PerEvent {
        let e = &cfg.energy;
        PerEvent {
            l1_access: e
                .l1_access_nj
                .unwrap_or_else(|| interpolate(&DATA_CACHE_TABLE, cfg.l1.size_bytes)),
            l2_access: e
                .l2_access_nj
                .unwrap_or_else(|| interpolate(&L2_TABLE, cfg.l2.size_bytes)),
            icache_fetch: e.icache_fetch_nj,
            register_access: e.register_access_nj,
            local_access: e.local_access_nj,
        }
    }
}

/// Counts the energy model needs besides the issue stats.
#[derive(Clone, Copy, Debug, Default)]
pub struct Events {
    pub l1_accesses: u64,
    pub l2_accesses: u64,
    pub dram_j: f64,
    pub seconds: f64,
    /// Stream-memory energy (STRaTA), J.
    pub stream_j: f64,
    /// Energy of the operations performed inside fused pipelines (STRaTA §3.3: the shared
    /// units do the work; charged per operation like any other), J.
    pub pipeline_j: f64,
}

impl Energy {
    pub fn of(cfg: &TraxConfig, issue: &IssueStats, ev: &Events) -> Energy {
        const NJ: f64 = 1e-9;
        let pe = PerEvent::of(cfg);
        let mut units_by_class = std::collections::BTreeMap::new();
        let mut units = 0.0;
        for (k, (name, u)) in cfg.units.by_class().iter().enumerate() {
            let j = issue.instructions[k] as f64 * u.energy_nj * NJ;
            units += j;
            units_by_class.insert(*name, j);
        }
        let atomic = issue.count(Class::Atomic) as f64 * cfg.energy.atomic_nj * NJ;
        units_by_class.insert("atomic", atomic);
        units += atomic;
        if ev.pipeline_j > 0.0 {
            units_by_class.insert("fused_pipelines", ev.pipeline_j);
            units += ev.pipeline_j;
        }
        let fetches = issue.total_instructions();
        let local = issue.count(Class::LocalLoad) + issue.count(Class::LocalStore);
        let mut e = Energy {
            dram_j: ev.dram_j,
            l2_j: ev.l2_accesses as f64 * pe.l2_access * NJ,
            stream_j: ev.stream_j,
            l1_j: ev.l1_accesses as f64 * pe.l1_access * NJ,
            icache_j: fetches as f64 * pe.icache_fetch * NJ,
            register_file_j: (issue.register_reads + issue.register_writes) as f64
                * pe.register_access
                * NJ,
            local_memory_j: local as f64 * pe.local_access * NJ,
            execution_units_j: units,
            total_j: 0.0,
            average_power_w: 0.0,
            units_by_class_j: units_by_class,
            per_event_nj: pe,
        };
        e.total_j = e.dram_j
            + e.l2_j
            + e.stream_j
            + e.l1_j
            + e.icache_j
            + e.register_file_j
            + e.local_memory_j
            + e.execution_units_j;
        e.average_power_w = if ev.seconds > 0.0 {
            e.total_j / ev.seconds
        } else {
            0.0
        };
        e
    }

    /// (component, joules) in report order.
    pub fn components(&self) -> [(&'static str, f64); 8] {
        [
            ("DRAM", self.dram_j),
            ("L2", self.l2_j),
            ("stream memory", self.stream_j),
            ("L1", self.l1_j),
            ("instruction cache", self.icache_j),
            ("register file", self.register_file_j),
            ("local memory", self.local_memory_j),
            ("execution units", self.execution_units_j),
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn interpolation_hits_the_table_and_extrapolates_the_16kb_l1() {
        for (s, e) in L2_TABLE {
            assert!((interpolate(&L2_TABLE, s) - e).abs() < 1e-12);
        }
        let l1 = interpolate(&DATA_CACHE_TABLE, 16 << 10);
        assert!((l1 - 0.1110).abs() < 5e-4, "{l1}");
        let mid = interpolate(&L2_TABLE, 3 << 20);
        assert!(mid > 0.686 && mid < 0.901);
        let defaults = PerEvent::of(&TraxConfig::default());
        assert!((defaults.l2_access - 0.901).abs() < 1e-12);
    }

    #[test]
    fn components_add_up_and_power_is_energy_over_time() {
        let cfg = TraxConfig::default();
        let mut issue = IssueStats::default();
        issue.instructions[Class::FpAdd as usize] = 1000;
        issue.instructions[Class::LocalLoad as usize] = 10;
        issue.register_reads = 2000;
        issue.register_writes = 900;
        let e = Energy::of(
            &cfg,
            &issue,
            &Events {
                l1_accesses: 100,
                l2_accesses: 10,
                dram_j: 1e-6,
                seconds: 1e-3,
                ..Events::default()
            },
        );
        let sum: f64 = e.components().iter().map(|c| c.1).sum();
        assert!((sum - e.total_j).abs() < 1e-18);
        assert!((e.icache_j - 1010.0 * 0.014e-9).abs() < 1e-18);
        assert!((e.register_file_j - 2900.0 * 0.008e-9).abs() < 1e-18);
        assert!((e.units_by_class_j["fp_add"] - 1000.0 * 0.0074e-9).abs() < 1e-18);
        assert!((e.average_power_w - e.total_j / 1e-3).abs() < 1e-12);
    }
}
