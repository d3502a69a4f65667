//! Energy of a run, computed after the fact from event counts and time spent in each background
//! state, times the per-event energies of [`crate::spec::power`] (Micron TN-41-01).

use crate::spec::DramSpec;
use crate::stats::DramStats;
use serde::Serialize;

/// Energy by component, in joules, and the average power.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct EnergyReport {
    /// Activate + precharge (one pair per ACT).
    pub act_pre_j: f64,
    pub read_j: f64,
    pub write_j: f64,
    pub refresh_j: f64,
    pub background_precharge_standby_j: f64,
    pub background_active_standby_j: f64,
    pub background_precharge_power_down_j: f64,
    pub background_active_power_down_j: f64,
    /// Sum of the background components.
    pub background_j: f64,
    pub total_j: f64,
    /// Total energy over the simulated time.
    pub average_power_w: f64,
    /// Energy per byte moved (reads + writes), in picojoules.
    pub pj_per_byte: f64,
}

impl EnergyReport {
    pub fn new(s: &DramStats, spec: &DramSpec) -> Self {
        let e = &spec.energy;
        let tck = 1.0 / spec.mem_clock.hz as f64;
        let bg = |cycles: u64, w: f64| cycles as f64 * tck * w;
        let mut r = EnergyReport {
            act_pre_j: s.activates as f64 * e.act_pre_j,
            read_j: s.column_reads as f64 * e.read_j,
            write_j: s.column_writes as f64 * e.write_j,
            refresh_j: s.refreshes as f64 * e.refresh_j,
            background_precharge_standby_j: bg(
                s.rank_cycles_precharge_standby,
                e.precharge_standby_w,
            ),
            background_active_standby_j: bg(s.rank_cycles_active_standby, e.active_standby_w),
            background_precharge_power_down_j: bg(
                s.rank_cycles_precharge_power_down,
                e.precharge_power_down_w,
            ),
            background_active_power_down_j: bg(
                s.rank_cycles_active_power_down,
                e.active_power_down_w,
            ),
            ..Default::default()
        };
        r.background_j = r.background_precharge_standby_j
            + r.background_active_standby_j
            + r.background_precharge_power_down_j
            + r.background_active_power_down_j;
        r.total_j = r.act_pre_j + r.read_j + r.write_j + r.refresh_j + r.background_j;
        let seconds = s.mem_cycles as f64 * tck;
        r.average_power_w = rtsim_core::stats::ratio(r.total_j, seconds);
        let bytes = (s.column_reads + s.column_writes) as f64 * f64::from(spec.org.line_bytes);
        r.pj_per_byte = rtsim_core::stats::ratio(r.total_j * 1e12, bytes);
        r
    }
}
