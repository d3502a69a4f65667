//! The report of a run: derived figures (hit rates, latency percentiles in both clocks,
//! occupancy, bandwidth against peak, energy and power) next to the raw counters, serialised as
//! `dram_stats.json` and printed as a summary table.

use crate::energy::EnergyReport;
use crate::spec::DramSpec;
use crate::stats::DramStats;
use rtsim_core::stats::{Histogram, ratio};
use serde::Serialize;
use std::fmt::Write as _;

/// Mean and percentiles of a latency distribution.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct LatencySummary {
    pub count: u64,
    pub mean: f64,
    pub min: u64,
    pub p50: u64,
    pub p90: u64,
    pub p95: u64,
    pub p99: u64,
    pub max: u64,
}

impl LatencySummary {
    pub fn of(h: &Histogram) -> Self {
        LatencySummary {
            count: h.count,
            mean: h.mean(),
            min: if h.count == 0 { 0 } else { h.min },
            p50: h.percentile(50.0),
            p90: h.percentile(90.0),
            p95: h.percentile(95.0),
            p99: h.percentile(99.0),
            max: h.max,
        }
    }
}

#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Latencies {
    /// Memory-clock cycles.
    pub mem_cycles: LatencySummary,
    /// Requester-clock cycles.
    pub requester_cycles: LatencySummary,
    /// Mean in nanoseconds.
    pub mean_ns: f64,
}

#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct HitRates {
    /// Column reads that needed no ACT of their own.
    pub reads: f64,
    pub writes: f64,
    pub all: f64,
    /// USIMM's definition, 1 − ACTs for reads / column reads (charges rows opened and closed
    /// again before use); compare with USIMM's "Read Page Hit Rate".
    pub reads_by_activates: f64,
    pub writes_by_activates: f64,
}

#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Occupancy {
    pub read_capacity: u32,
    pub write_capacity: u32,
    /// Time-averaged arrived reads per channel queue.
    pub read_average: f64,
    pub read_max: u64,
    pub write_average: f64,
    pub write_max: u64,
}

#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Bandwidth {
    pub bytes_read: u64,
    pub bytes_written: u64,
    /// (read + written bytes) / simulated time, in GB/s (10^9 bytes).
    pub achieved_gbps: f64,
    pub peak_gbps: f64,
    /// achieved / peak.
    pub utilisation: f64,
    /// Fraction of channel-cycles the data buses carried data.
    pub data_bus_busy: f64,
}

/// Organisation and clocks the run used.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Setup {
    pub preset: String,
    pub channels: u32,
    pub ranks: u32,
    pub banks_per_rank: u32,
    pub rows: u32,
    pub row_bytes: u64,
    pub line_bytes: u32,
    pub capacity_bytes: u64,
    pub mapping: String,
    pub scheduler: String,
    pub row_policy: String,
    pub mem_clock_hz: u64,
    pub requester_clock_hz: u64,
    /// Unloaded read latency (memory cycles): row hit, closed bank, row conflict.
    pub unloaded_read_latency: [u64; 3],
}

/// A compact per-channel line.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct ChannelSummary {
    pub channel: usize,
    pub reads: u64,
    pub writes: u64,
    pub activates: u64,
    pub row_hit_rate: f64,
    pub read_latency_mean_mem: f64,
    pub data_bus_busy: f64,
}

/// Per requester tag (an L2, a unit): requests, row-buffer hit rate, read latency.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct TagSummary {
    pub tag: usize,
    pub reads: u64,
    pub writes: u64,
    pub refused: u64,
    /// Row hits over this tag's column accesses.
    pub row_hit_rate: f64,
    /// Requester cycles.
    pub read_latency_mean: f64,
}

/// Everything `dram_stats.json` holds.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Report {
    pub setup: Setup,
    pub mem_cycles: u64,
    pub seconds: f64,
    pub reads: u64,
    pub writes: u64,
    pub activates: u64,
    pub refreshes: u64,
    pub row_hit_rate: HitRates,
    pub read_latency: Latencies,
    pub write_latency: Latencies,
    pub queue_occupancy: Occupancy,
    pub bandwidth: Bandwidth,
    pub energy: EnergyReport,
    pub per_channel: Vec<ChannelSummary>,
    pub per_tag: Vec<TagSummary>,
    /// Raw counters (numerators and denominators), summed over channels.
    pub stats: DramStats,
}

fn latencies(mem: &Histogram, req: &Histogram, spec: &DramSpec) -> Latencies {
    Latencies {
        mem_cycles: LatencySummary::of(mem),
        requester_cycles: LatencySummary::of(req),
        mean_ns: mem.mean() * 1e9 / spec.mem_clock.hz as f64,
    }
}

impl Report {
    pub fn new(spec: &DramSpec, s: DramStats, per_channel: &[DramStats]) -> Self {
        let o = &spec.org;
        let c = spec.controller();
        let seconds = spec.mem_clock.seconds(s.mem_cycles);
        let bytes_read = s.column_reads * u64::from(o.line_bytes);
        let bytes_written = s.column_writes * u64::from(o.line_bytes);
        let achieved = ratio((bytes_read + bytes_written) as f64, seconds) / 1e9;
        let peak = spec.peak_bytes_per_second() / 1e9;
        let chan_cycles = s.mem_cycles as f64 * f64::from(o.channels);
        let occ = |sum: u128| ratio(sum as f64, s.occupancy_cycles as f64);
        Report {
            setup: Setup {
                preset: spec.config.preset.clone(),
                channels: o.channels,
                ranks: o.ranks,
                banks_per_rank: o.banks_per_rank,
                rows: o.rows,
                row_bytes: o.row_bytes,
                line_bytes: o.line_bytes,
                capacity_bytes: o.capacity_bytes,
                mapping: spec.mapper.text().to_string(),
                scheduler: format!("{:?}", c.scheduler),
                row_policy: format!("{:?}", c.row_policy),
                mem_clock_hz: spec.mem_clock.hz,
                requester_clock_hz: spec.req_clock.hz,
                unloaded_read_latency: spec.unloaded_read_latency(),
            },
            mem_cycles: s.mem_cycles,
            seconds,
            reads: s.reads,
            writes: s.writes,
            activates: s.activates,
            refreshes: s.refreshes,
            row_hit_rate: HitRates {
                reads: s.read_row_hit_rate(),
                writes: s.write_row_hit_rate(),
                all: s.row_hit_rate(),
                reads_by_activates: s.read_row_hit_rate_by_activates(),
                writes_by_activates: s.write_row_hit_rate_by_activates(),
            },
            read_latency: latencies(&s.read_latency_mem, &s.read_latency_req, spec),
            write_latency: latencies(&s.write_latency_mem, &s.write_latency_req, spec),
            queue_occupancy: Occupancy {
                read_capacity: c.read_queue,
                write_capacity: c.write_queue,
                read_average: occ(s.read_queue_occupancy_sum),
                read_max: s.read_queue_max,
                write_average: occ(s.write_queue_occupancy_sum),
                write_max: s.write_queue_max,
            },
            bandwidth: Bandwidth {
                bytes_read,
                bytes_written,
                achieved_gbps: achieved,
                peak_gbps: peak,
                utilisation: ratio(achieved, peak),
                data_bus_busy: ratio(s.data_bus_busy_cycles as f64, chan_cycles),
            },
            energy: EnergyReport::new(&s, spec),
            per_channel: per_channel
                .iter()
                .enumerate()
                .map(|(i, c)| ChannelSummary {
                    channel: i,
                    reads: c.reads,
                    writes: c.writes,
                    activates: c.activates,
                    row_hit_rate: c.row_hit_rate(),
                    read_latency_mean_mem: c.read_latency_mem.mean(),
                    data_bus_busy: ratio(c.data_bus_busy_cycles as f64, s.mem_cycles as f64),
                })
                .collect(),
            per_tag: s
                .per_tag
                .iter()
                .enumerate()
                .map(|(tag, t)| TagSummary {
                    tag,
                    reads: t.reads,
                    writes: t.writes,
                    refused: t.refused,
                    row_hit_rate: ratio(t.row_hits as f64, t.column_accesses as f64),
                    read_latency_mean: t.read_latency_req.mean(),
                })
                .collect(),
            stats: s,
        }
    }

    /// The summary table printed by `rtsim dram`.
    pub fn summary(&self) -> String {
        let mut o = String::new();
        let s = &self.setup;
        let _ = writeln!(
            o,
            "DRAM {}: {} ch x {} rank x {} banks, {} B rows, {:.0} GB/s peak, mem {} MHz, \
             requester {} MHz",
            s.preset,
            s.channels,
            s.ranks,
            s.banks_per_rank,
            s.row_bytes,
            self.bandwidth.peak_gbps,
            s.mem_clock_hz as f64 / 1e6,
            s.requester_clock_hz as f64 / 1e6
        );
        let _ = writeln!(
            o,
            "  mapping {}  scheduler {}  row policy {}",
            s.mapping, s.scheduler, s.row_policy
        );
        let st = &self.stats;
        let row = |o: &mut String, k: &str, v: String| {
            let _ = writeln!(o, "  {k:<28} {v}");
        };
        row(
            &mut o,
            "simulated time",
            format!(
                "{} mem cycles ({:.3} us)",
                self.mem_cycles,
                self.seconds * 1e6
            ),
        );
        row(
            &mut o,
            "reads / writes",
            format!(
                "{} / {} (merged {}, forwarded {}, writes merged {})",
                self.reads, self.writes, st.reads_merged, st.reads_forwarded, st.writes_merged
            ),
        );
        row(
            &mut o,
            "refused (queue full)",
            format!("{} reads, {} writes", st.reads_refused, st.writes_refused),
        );
        row(
            &mut o,
            "activates / precharges",
            format!(
                "{} / {} (+{} auto, +{} for refresh); {} rows opened and closed unused",
                self.activates,
                st.precharges,
                st.auto_precharges,
                st.refresh_precharges,
                st.unused_activates()
            ),
        );
        row(
            &mut o,
            "row-buffer hit rate",
            format!(
                "reads {:.1} %, writes {:.1} %, all {:.1} %",
                100.0 * self.row_hit_rate.reads,
                100.0 * self.row_hit_rate.writes,
                100.0 * self.row_hit_rate.all
            ),
        );
        row(
            &mut o,
            "  by ACT count (USIMM)",
            format!(
                "reads {:.1} %, writes {:.1} %",
                100.0 * self.row_hit_rate.reads_by_activates,
                100.0 * self.row_hit_rate.writes_by_activates
            ),
        );
        let l = &self.read_latency;
        row(
            &mut o,
            "read latency (mem cycles)",
            format!(
                "mean {:.1}  p50 {}  p90 {}  p99 {}  max {}",
                l.mem_cycles.mean,
                l.mem_cycles.p50,
                l.mem_cycles.p90,
                l.mem_cycles.p99,
                l.mem_cycles.max
            ),
        );
        row(
            &mut o,
            "read latency (req cycles)",
            format!(
                "mean {:.1}  p50 {}  p90 {}  p99 {}  max {}  ({:.1} ns)",
                l.requester_cycles.mean,
                l.requester_cycles.p50,
                l.requester_cycles.p90,
                l.requester_cycles.p99,
                l.requester_cycles.max,
                l.mean_ns
            ),
        );
        row(
            &mut o,
            "write latency (mem cycles)",
            format!(
                "mean {:.1}  p99 {}",
                self.write_latency.mem_cycles.mean, self.write_latency.mem_cycles.p99
            ),
        );
        let q = &self.queue_occupancy;
        row(
            &mut o,
            "queue occupancy (per ch)",
            format!(
                "reads avg {:.1} max {} of {}; writes avg {:.1} max {} of {}",
                q.read_average,
                q.read_max,
                q.read_capacity,
                q.write_average,
                q.write_max,
                q.write_capacity
            ),
        );
        row(
            &mut o,
            "write drain",
            format!(
                "{} episodes, {} cycles",
                st.write_drain_episodes, st.write_drain_cycles
            ),
        );
        let b = &self.bandwidth;
        row(
            &mut o,
            "bandwidth",
            format!(
                "{:.2} GB/s of {:.1} GB/s peak ({:.1} %)",
                b.achieved_gbps,
                b.peak_gbps,
                100.0 * b.utilisation
            ),
        );
        row(&mut o, "refreshes", format!("{}", self.refreshes));
        let e = &self.energy;
        row(
            &mut o,
            "energy (J)",
            format!(
                "total {:.4e}: act/pre {:.3e}, read {:.3e}, write {:.3e}, refresh {:.3e}, \
                 background {:.3e}",
                e.total_j, e.act_pre_j, e.read_j, e.write_j, e.refresh_j, e.background_j
            ),
        );
        row(
            &mut o,
            "average power",
            format!("{:.3} W ({:.1} pJ/B)", e.average_power_w, e.pj_per_byte),
        );
        if st.commands_checked > 0 {
            row(
                &mut o,
                "checking mode",
                format!(
                    "{} commands re-validated, {} violations",
                    st.commands_checked, st.violations
                ),
            );
        }
        o
    }
}
