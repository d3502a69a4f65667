//! [`CacheStats`]: the counters of one cache, functional and timed. Numerators and
//! denominators are kept; hit rates are computed when reporting. Merged with `+=`
//! (`#[derive(Stats)]`), so per-L1 stats sum into a level total.

use rtsim_core::stats::{Histogram, ratio};
use rtsim_sim::Stats;
use serde::{Deserialize, Serialize};

/// Counters of one cache (or, summed, of a level).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize, Stats)]
pub struct CacheStats {
    /// Read accesses performed (refused attempts are not accesses).
    pub reads: u64,
    /// Write accesses performed.
    pub writes: u64,
    /// Reads that found their line.
    pub read_hits: u64,
    /// Reads that did not (timed: including those merged into an MSHR).
    pub read_misses: u64,
    pub write_hits: u64,
    pub write_misses: u64,
    /// Lines installed.
    pub fills: u64,
    /// Valid lines replaced by a fill.
    pub evictions: u64,
    /// Evicted lines that were dirty and written to the next level (write-back).
    pub writebacks: u64,
    /// Writes passed on to the next level (write-around: every write).
    pub write_throughs: u64,
    /// Timed: accesses that found their bank busy this cycle (each refused or delayed attempt
    /// counts once).
    pub bank_conflicts: u64,
    /// Timed, inner caches: cycles each access from a child waited for its bank (0 when the
    /// bank was free), so queueing at the banks shows apart from hit and miss latency.
    pub bank_wait: Histogram,
    /// Timed, inner caches with `combine_reads`: reads that joined an earlier read of the same
    /// line waiting for its bank (served by that lookup: one bank cycle and one array access
    /// for all of them). Counted in `reads` and the hit or miss counts too.
    pub combined: u64,
    /// Timed: misses to a line already in flight, merged into its MSHR.
    pub mshr_merges: u64,
    /// Timed: misses refused or delayed because every MSHR was busy.
    pub mshr_full_stalls: u64,
    /// Timed: writes refused or delayed because the write buffer was full.
    pub write_buffer_full_stalls: u64,
    /// Timed: most MSHRs in use at once.
    #[stats(max)]
    pub mshr_peak: u64,
    /// Timed: cycles from a miss's lookup to its line arriving (per MSHR, not per merge).
    pub miss_latency: Histogram,
}

impl CacheStats {
    pub fn accesses(&self) -> u64 {
        self.reads + self.writes
    }
    pub fn hits(&self) -> u64 {
        self.read_hits + self.write_hits
    }
    pub fn misses(&self) -> u64 {
        self.read_misses + self.write_misses
    }
    /// Hits over accesses (0 with no access).
    pub fn hit_rate(&self) -> f64 {
        ratio(self.hits() as f64, self.accesses() as f64)
    }
    pub fn read_hit_rate(&self) -> f64 {
        ratio(self.read_hits as f64, self.reads as f64)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_counter_is_merged() {
        let mut s = CacheStats::default();
        s.miss_latency.record(3);
        rtsim_sim::testing::assert_merges_every_field(&s);
    }
}
