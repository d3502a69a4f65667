//! Typed statistics of the DRAM model. Counters keep numerators and denominators; rates,
//! averages and energies are computed when reporting ([`crate::report`]). Per-channel stats are
//! summed with `+=`.

use rtsim_core::stats::{Histogram, ratio};
use serde::{Deserialize, Serialize};
use std::ops::AddAssign;

/// Counters of one channel (or, summed, of the whole memory).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
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
    pub read_queue_max: u64,
    /// Largest write-queue occupancy seen.
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
    pub mem_cycles: u64,
    /// Commands re-validated by the checker (checking mode).
    pub commands_checked: u64,
    /// Legality violations the checker found (must be 0).
    pub violations: u64,
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

impl AddAssign<&DramStats> for DramStats {
    fn add_assign(&mut self, o: &DramStats) {
        self.reads += o.reads;
        self.writes += o.writes;
        self.reads_refused += o.reads_refused;
        self.writes_refused += o.writes_refused;
        self.reads_merged += o.reads_merged;
        self.reads_forwarded += o.reads_forwarded;
        self.writes_merged += o.writes_merged;
        self.reads_done += o.reads_done;
        self.writes_done += o.writes_done;
        self.read_row_hits += o.read_row_hits;
        self.read_row_misses += o.read_row_misses;
        self.read_row_conflicts += o.read_row_conflicts;
        self.write_row_hits += o.write_row_hits;
        self.write_row_misses += o.write_row_misses;
        self.write_row_conflicts += o.write_row_conflicts;
        self.activates += o.activates;
        self.activates_for_reads += o.activates_for_reads;
        self.activates_for_writes += o.activates_for_writes;
        self.precharges += o.precharges;
        self.refresh_precharges += o.refresh_precharges;
        self.auto_precharges += o.auto_precharges;
        self.column_reads += o.column_reads;
        self.column_writes += o.column_writes;
        self.refreshes += o.refreshes;
        self.power_downs += o.power_downs;
        self.read_latency_mem += &o.read_latency_mem;
        self.read_latency_req += &o.read_latency_req;
        self.write_latency_mem += &o.write_latency_mem;
        self.write_latency_req += &o.write_latency_req;
        self.read_queue_occupancy_sum += o.read_queue_occupancy_sum;
        self.write_queue_occupancy_sum += o.write_queue_occupancy_sum;
        self.occupancy_cycles += o.occupancy_cycles;
        self.read_queue_max = self.read_queue_max.max(o.read_queue_max);
        self.write_queue_max = self.write_queue_max.max(o.write_queue_max);
        self.data_bus_busy_cycles += o.data_bus_busy_cycles;
        self.write_drain_episodes += o.write_drain_episodes;
        self.write_drain_cycles += o.write_drain_cycles;
        self.rank_cycles_precharge_standby += o.rank_cycles_precharge_standby;
        self.rank_cycles_active_standby += o.rank_cycles_active_standby;
        self.rank_cycles_precharge_power_down += o.rank_cycles_precharge_power_down;
        self.rank_cycles_active_power_down += o.rank_cycles_active_power_down;
        self.mem_cycles = self.mem_cycles.max(o.mem_cycles);
        self.commands_checked += o.commands_checked;
        self.violations += o.violations;
    }
}

impl AddAssign for DramStats {
    fn add_assign(&mut self, o: DramStats) {
        *self += &o;
    }
}
