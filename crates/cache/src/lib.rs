//! Caches: an exact functional model and a timed, banked hierarchy over a `MemoryPort`.
//!
//! - [`config`]: [`CacheLevel`] (size, ways, line, [`Replacement`], [`WritePolicy`], banks,
//!   hit latency, MSHRs, write buffer) and [`CacheConfig`], the two-level tree `rtsim cache` and
//!   the chip models read, with TRaX defaults.
//! - [`cache`]: [`Cache`], one cache's tags, replacement state and dirty bits; exact and fast
//!   (shifts and masks, no allocation per access).
//! - [`topology`]: [`Topology`], which cache misses to which (L1s → L2s → memory, or any tree).
//! - [`functional`]: [`FunctionalHierarchy`], exact counts per cache with no time.
//! - [`stats`]: [`CacheStats`], counters per cache, summed with `+=`.
//! - [`timed`]: [`Hierarchy`], the timed tree over a `MemoryPort`: banks, hit latencies, MSHRs
//!   with merging, write buffers, back-pressure; requests in cycle order, hits answered at once,
//!   misses completed later.
//!
//! - [`memory`]: [`FixedLatency`], a constant-latency memory with a bounded queue (tests,
//!   studies without DRAM effects).
//! - [`trace`]: the `rtsim cache` trace format ([`trace::TraceReader`]) and replaying a trace
//!   through either model.
//!
//! The functional and timed models share [`Cache`]; the timed one adds time and resources,
//! never different contents rules, so with no merging and no reordering their counts agree
//! (a test checks it).

pub mod cache;
pub mod config;
pub mod functional;
pub mod memory;
pub mod stats;
pub mod timed;
pub mod topology;
pub mod trace;

pub use cache::{Access, Cache, Evicted};
pub use config::{CacheConfig, CacheLevel, Replacement, WritePolicy, check_state_memory};
pub use functional::{FunctionalHierarchy, MemoryCounts};
pub use memory::FixedLatency;
pub use stats::CacheStats;
pub use timed::{
    BusyCause, Completion, Hierarchy, HierarchyError, HierarchyParts, HierarchyStats, LeafOutcome,
    LeafSend, Leaves, Outcome, Request, busy_retry,
};
pub use topology::{Node, Parent, Topology};
