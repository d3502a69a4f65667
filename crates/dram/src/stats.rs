//! Typed statistics of the DRAM model. Counters keep numerators and denominators; rates,
//! averages and energies are computed when reporting ([`crate::report`]). Per-channel stats are
//! summed with `+=`, derived field by field (`rtsim_sim::Stats`), so no counter can be left out.

use rtsim_core::stats::{Histogram, ratio};
use rtsim_sim::Stats;
use serde::{Deserialize, Serialize};

/// Counters of one requester tag (an L2, a unit) in one channel, or summed.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize, Stats)]
pub struct TagStats {
    /// Read requests accepted.
    pub reads: u64,
    /// Write requests accepted.
    pub writes: u64,
    /// Requests refused because their queue was full.
    pub refused: u64,
    /// Column commands (reads and writes) issued for this tag's requests (merged and forwarded
    /// requests issue none).
    pub column_accesses: u64,
    /// Those that found their row open.
    pub row_hits: u64,
    /// Read latency from arrival to the last data beat, requester cycles.
    pub read_latency_req: Histogram,
}

/// Counters of one channel (or, summed, of the whole memory).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize, Stats)]
pub struct DramStats {
    /// Read requests accepted.
    pub reads: u64,
    /// Write requests accepted.
    pub writes: u64,
    /// Reads refused because the read queue was full (back-pressure; the requester retries).
    pub reads_refused: u64,
    /// Writes refused because the write queue was full.
    pub writes_refused: u64,
    /// Reads merged into a queued read of the same line.
    pub reads_merged: u64,
    /// Reads answered from a queued write to the same line.
    pub reads_forwarded: u64,
    /// Writes merged into a queued write of the same line.
    pub writes_merged: u64,
    /// Read requests completed (including merged and forwarded ones).
    pub reads_done: u64,
    /// Write requests completed (including merged ones).
    pub writes_done: u64,

    /// Column reads that found their row open (no ACT issued for them).
    pub read_row_hits: u64,
    /// Column reads that needed an ACT to a closed bank.
    pub read_row_misses: u64,
    /// Column reads that needed a PRE and an ACT (another row was open).
    pub read_row_conflicts: u64,
    pub write_row_hits: u64,
    pub write_row_misses: u64,
    pub write_row_conflicts: u64,

    /// ACT commands.
    pub activates: u64,
    /// ACTs issued for a read request (with `activates_for_writes`, all ACTs but none: refresh
    /// never activates). A row opened and closed again before its request was served counts
    /// twice, which USIMM's hit-rate definition charges to the hit rate.
    pub activates_for_reads: u64,
    pub activates_for_writes: u64,
    /// PRE commands issued for requests (row conflicts, or the row-hit cap).
    pub precharges: u64,
    /// PRE commands issued to prepare a refresh.
    pub refresh_precharges: u64,
    /// Column accesses with auto-precharge (closed-page policy).
    pub auto_precharges: u64,
    /// Column read commands (each moves one line).
    pub column_reads: u64,
    /// Column write commands.
    pub column_writes: u64,
    /// REF commands.
    pub refreshes: u64,
    /// Power-down entries.
    pub power_downs: u64,

    /// Read latency from arrival at the controller to the last data beat, memory cycles
    /// (merged and forwarded reads included).
    pub read_latency_mem: Histogram,
    /// The same in requester cycles (finish rounded up to the requester clock).
    pub read_latency_req: Histogram,
    /// Write latency (arrival to the end of the write burst), memory cycles.
    pub write_latency_mem: Histogram,
    /// The same in requester cycles.
    pub write_latency_req: Histogram,

    /// Σ (arrived reads in the queue × cycles), for the average occupancy.
    pub read_queue_occupancy_sum: u128,
    /// Σ (arrived writes in the queue × cycles).
    pub write_queue_occupancy_sum: u128,
    /// Cycles over which occupancy was integrated (per channel).
    pub occupancy_cycles: u64,
    /// Largest read-queue occupancy seen.
    #[stats(max)]
    pub read_queue_max: u64,
    /// Largest write-queue occupancy seen.
    #[stats(max)]
    pub write_queue_max: u64,

    /// Memory cycles the data bus carried data.
    pub data_bus_busy_cycles: u64,
    /// Times the controller entered write-drain mode.
    pub write_drain_episodes: u64,
    /// Memory cycles spent in write-drain mode.
    pub write_drain_cycles: u64,

    /// Rank-cycles in each background state: precharge standby, active standby, precharge
    /// power-down, active power-down (summed over ranks).
    pub rank_cycles_precharge_standby: u64,
    pub rank_cycles_active_standby: u64,
    pub rank_cycles_precharge_power_down: u64,
    pub rank_cycles_active_power_down: u64,

    /// Memory cycles simulated (the largest over channels when summed).
    #[stats(max)]
    pub mem_cycles: u64,
    /// Commands re-validated by the checker (checking mode).
    pub commands_checked: u64,
    /// Legality violations the checker found (must be 0).
    pub violations: u64,
    /// The same split by requester tag (`MemRequest::tag`), one entry per tag.
    pub per_tag: Vec<TagStats>,
}

impl DramStats {
    /// Column accesses (reads + writes) that were row hits, over all column accesses.
    pub fn row_hit_rate(&self) -> f64 {
        ratio(
            (self.read_row_hits + self.write_row_hits) as f64,
            (self.column_reads + self.column_writes) as f64,
        )
    }
    pub fn read_row_hit_rate(&self) -> f64 {
        ratio(self.read_row_hits as f64, self.column_reads as f64)
    }
    pub fn write_row_hit_rate(&self) -> f64 {
        ratio(self.write_row_hits as f64, self.column_writes as f64)
    }
    /// ACTs whose row was closed again before the request they opened it for was served (a
    /// refresh, a write-drain switch or a conflicting older request in between): they cost
    /// activation energy for nothing, and are why USIMM's hit-rate definition can go below
    /// zero.
    pub fn unused_activates(&self) -> u64 {
        let used = self.read_row_misses
            + self.read_row_conflicts
            + self.write_row_misses
            + self.write_row_conflicts;
        self.activates.saturating_sub(used)
    }
    /// USIMM's definition: 1 − ACTs for reads / column reads (can be negative when rows are
    /// opened and closed again before use).
    pub fn read_row_hit_rate_by_activates(&self) -> f64 {
        by_activates(self.activates_for_reads, self.column_reads)
    }
    pub fn write_row_hit_rate_by_activates(&self) -> f64 {
        by_activates(self.activates_for_writes, self.column_writes)
    }
}

fn by_activates(acts: u64, accesses: u64) -> f64 {
    if accesses == 0 {
        0.0
    } else {
        1.0 - acts as f64 / accesses as f64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_counter_is_merged() {
        let mut s = DramStats {
            per_tag: vec![TagStats::default(); 2],
            ..DramStats::default()
        };
        s.read_latency_mem.record(5);
        s.per_tag[1].read_latency_req.record(7);
        rtsim_sim::testing::assert_merges_every_field(&s);
    }
}
