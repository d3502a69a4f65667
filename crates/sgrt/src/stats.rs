//! Typed counters of the SGRT model, merged with `+=` (`#[derive(Stats)]`): numerators and
//! denominators only; rates, utilisations and per-ray averages are computed in
//! [`crate::report`].
//!
//! Every counter counts an event that happens at the same cycle whichever timing engine runs
//! (fast or reference), or a time integral kept lazily, so the two engines give equal stats.

use rtsim_sim::Stats;
use serde::{Deserialize, Serialize};

/// One pipeline (a TRV sub-pipeline, the SPTRV's deep pipeline, the IST's).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize, Stats)]
pub struct PipeStats {
    /// Rays that entered.
    pub entries: u64,
    /// Issue cycles taken: Σ initiation interval over entries.
    pub issue_cycles: u64,
    /// Cycles with at least one ray inside (from entry to leaving, a wait at a full exit
    /// included).
    pub busy_cycles: u64,
    /// Cycles a finished ray waited at the exit because its next queue was full.
    pub blocked_cycles: u64,
}

/// The memory processing module in front of a pipeline (lookup, RAU hand-off).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize, Stats)]
pub struct MemStats {
    /// Records looked up (one per pass that reads memory).
    pub lookups: u64,
    /// Line requests sent to the L1 (a record may straddle two lines).
    pub lines: u64,
    /// Lines that hit in the L1.
    pub line_hits: u64,
    /// Lines that missed (the ray parks in the RAU).
    pub line_misses: u64,
    /// Line requests the L1 refused (bank busy, MSHRs full) and that were offered again.
    pub refusals: u64,
}

/// A ray accumulation unit.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize, Stats)]
pub struct RauStats {
    /// Rays parked on a miss.
    pub parks: u64,
    /// Σ rays held × cycles (parked or waiting to re-enter the pipeline).
    pub occupancy_sum: u128,
    #[stats(max)]
    pub max_occupancy: u64,
}

/// One traversal unit (or several, summed).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize, Stats)]
pub struct TrvStats {
    /// Rays dispatched to it.
    pub rays: u64,
    /// Steps: passes of a ray through a sub-pipeline (TRV_PRE, TRV_AABB, TRV_POST). SPTRV
    /// counts all three for every pass through its deep pipeline, bypassed ones included.
    pub steps: u64,
    /// Steps that did work (the rest are SPTRV bypasses).
    pub active_steps: u64,
    /// Entries into the unit's pipelines (SPTRV: passes through the deep pipeline).
    pub passes: u64,
    /// Operations done, by sub-pipeline: node fetches (TRV_PRE), box tests (TRV_AABB: the
    /// root's one box, or a child pair's two), stack operations (TRV_POST).
    pub pre_ops: u64,
    pub boxes: u64,
    pub post_ops: u64,
    /// PPTRV sub-pipelines.
    pub pre: PipeStats,
    pub aabb: PipeStats,
    pub post: PipeStats,
    /// SPTRV's deep pipeline.
    pub deep: PipeStats,
    /// Cycles with a ray in any of the unit's pipelines.
    pub busy_cycles: u64,
    /// Σ rays held (short stacks in use) × cycles.
    pub stack_occupancy_sum: u128,
    pub mem: MemStats,
    pub rau: RauStats,
}

/// The intersection unit (or several, summed).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize, Stats)]
pub struct IstStats {
    /// Steps: passes of a ray through the pipeline, one triangle each.
    pub steps: u64,
    /// Rays sent back to the IST's input for the next triangle of the leaf.
    pub loops: u64,
    /// Rays received from the TRVs.
    pub arrivals: u64,
    pub pipe: PipeStats,
    pub mem: MemStats,
    pub rau: RauStats,
}

/// Ray dispatch.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize, Stats)]
pub struct RdStats {
    /// Rays handed to a TRV.
    pub dispatched: u64,
    /// Σ rays in the ray buffers × cycles.
    pub ray_buffer_occupancy_sum: u128,
    /// Σ hits in the hit buffers × cycles.
    pub hit_buffer_occupancy_sum: u128,
}

/// The shader.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize, Stats)]
pub struct SrpStats {
    /// Kernel launches (a packet of camera rays, or a packet of hits shaded).
    pub launches: u64,
    /// Camera-ray packets.
    pub generate_launches: u64,
    /// Hits shaded.
    pub hits_shaded: u64,
    /// Rays generated (camera rays and the follow-up rays shading produced).
    pub rays_generated: u64,
    /// Operations charged (`rtsim_trace::ops` per kernel run).
    pub ops: u64,
    /// SRP cycles of computation (operations / rate + launch overhead).
    pub compute_cycles: u64,
    /// SRP cycles kernels waited for their data past their computation.
    pub memory_wait_cycles: u64,
    /// Record reads and framebuffer writes through the data cache (line requests).
    pub loads: u64,
    pub stores: u64,
}

/// Per ray kind (timed rays only), in `rtsim_trace::RayKind` order: primary, shadow, bounce,
/// ao, diffuse, specular.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize, Stats)]
pub struct KindStats {
    pub rays: u64,
    pub hits: u64,
    pub trv_steps: u64,
    pub trv_active_steps: u64,
    pub trv_passes: u64,
    pub ist_steps: u64,
    /// Σ cycles from dispatch to leaving the T&I unit.
    pub latency_cycles: u64,
}

/// One core (or all, summed).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize, Stats)]
pub struct CoreStats {
    pub trv: TrvStats,
    pub ist: IstStats,
    pub rd: RdStats,
    pub srp: SrpStats,
    pub kinds: [KindStats; 6],
}

#[cfg(test)]
mod tests {
    use super::*;
    use rtsim_sim::testing::assert_merges_every_field;

    #[test]
    fn every_counter_merges() {
        assert_merges_every_field(&CoreStats::default());
    }
}
