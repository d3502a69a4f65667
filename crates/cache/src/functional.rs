//! [`FunctionalHierarchy`]: exact hit/miss/eviction/write-back counts of a cache tree, no time.
//!
//! Caches form a tree ([`Topology`]): each access enters at a leaf (an L1) and, on a miss,
//! travels towards memory. The order of events within one access is fixed and documented,
//! because it decides the next level's contents:
//!
//! 1. look the address up in the cache (a hit updates replacement state; a write hit under
//!    write-back marks the line dirty);
//! 2. a read miss, or a write miss under write-back (write-allocate), first reads the line from
//!    the next level (recursively), *then* installs it, evicting a victim; a dirty victim is then
//!    written to the next level (write-back);
//! 3. a write under write-around is then passed to the next level as a write (hit or miss).
//!
//! This is pycachesim's order (its `Cache__load` loads from the next level before injecting the
//! line), which is why the counts agree exactly (`docs/CACHES.md`).

use crate::cache::Cache;
use crate::config::{CacheConfig, WritePolicy};
use crate::stats::CacheStats;
use crate::topology::{Parent, Topology};
use rtsim_config::ConfigError;
use rtsim_core::MemOp;
use serde::{Deserialize, Serialize};

/// Requests that left the last level for memory.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize, rtsim_sim::Stats)]
pub struct MemoryCounts {
    pub reads: u64,
    pub writes: u64,
}

/// An untimed cache tree.
#[derive(Clone, Debug)]
pub struct FunctionalHierarchy {
    topology: Topology,
    caches: Vec<Cache>,
    pub memory: MemoryCounts,
}

impl FunctionalHierarchy {
    /// Build the tree of a [`CacheConfig`] (validated here).
    pub fn new(config: &CacheConfig) -> Result<Self, ConfigError> {
        Self::from_topology(Topology::from_config(config)?)
    }

    /// Build any tree.
    pub fn from_topology(topology: Topology) -> Result<Self, ConfigError> {
        let caches = topology.build_caches()?;
        Ok(FunctionalHierarchy {
            topology,
            caches,
            memory: MemoryCounts::default(),
        })
    }

    pub fn topology(&self) -> &Topology {
        &self.topology
    }

    /// Access `addr` from leaf cache `l1` (an index into [`Topology::leaves`]).
    #[inline]
    pub fn access(&mut self, l1: usize, addr: u64, op: MemOp) -> bool {
        let node = self.topology.leaves()[l1];
        self.access_node(node, addr, op)
    }

    /// Access at cache node `n`; returns whether it hit there.
    fn access_node(&mut self, n: usize, addr: u64, op: MemOp) -> bool {
        let c = &mut self.caches[n];
        let hit = c.lookup(addr, op);
        let policy = c.write_policy();
        let allocate = !hit && (op == MemOp::Read || policy == WritePolicy::WriteBack);
        if allocate {
            self.pass_down(n, addr, MemOp::Read);
            let evicted = self.caches[n].fill(addr, op == MemOp::Write);
            if let Some(e) = evicted.filter(|e| e.dirty) {
                self.pass_down(n, e.addr, MemOp::Write);
            }
        }
        if op == MemOp::Write && policy == WritePolicy::WriteAround {
            self.caches[n].stats.write_throughs += 1;
            self.pass_down(n, addr, MemOp::Write);
        }
        hit
    }

    fn pass_down(&mut self, n: usize, addr: u64, op: MemOp) {
        match self.topology.parent(n) {
            Parent::Cache(p) => {
                self.access_node(p, addr, op);
            }
            Parent::Memory => match op {
                MemOp::Read => self.memory.reads += 1,
                MemOp::Write => self.memory.writes += 1,
            },
        }
    }

    /// Counters of cache node `n`.
    pub fn stats(&self, n: usize) -> &CacheStats {
        &self.caches[n].stats
    }

    /// The caches, in node order.
    pub fn caches(&self) -> &[Cache] {
        &self.caches
    }
}
