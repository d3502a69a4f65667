//! Typed counters of the TPs' issue logic, summed with `+=` (`#[derive(Stats)]`).

use crate::isa::{CLASSES, Class, UNIT_CLASSES};
use rtsim_sim::Stats;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// Why a TP did not issue in a cycle.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum Stall {
    /// An operand was not yet readable and none of the late ones came from a data-cache load
    /// (unit latency, or a branch being resolved).
    Operand = 0,
    /// Waiting for data from the data cache (a late operand written by a load), or for the
    /// cache to accept an access (bank busy, MSHRs or write buffer full).
    Memory = 1,
    /// Operands ready, but the TM's units of the instruction's class were all taken this
    /// cycle by TPs of higher priority.
    Unit = 2,
    /// Operands and unit ready, but the instruction's fetch bank had served its fetches for
    /// the cycle.
    Fetch = 3,
    /// The atomic pixel counter was taken this cycle.
    Atomic = 4,
    /// STRaTA: waiting for the stream memory (its bank busy, or no ray to pop) or for a
    /// triangle pipeline instance.
    Stream = 5,
}

pub const STALLS: usize = 6;

impl Stall {
    pub const ALL: [Stall; STALLS] = [
        Stall::Operand,
        Stall::Memory,
        Stall::Unit,
        Stall::Fetch,
        Stall::Atomic,
        Stall::Stream,
    ];
    pub fn name(self) -> &'static str {
        match self {
            Stall::Operand => "operand_not_ready",
            Stall::Memory => "memory",
            Stall::Unit => "unit_busy",
            Stall::Fetch => "fetch_conflict",
            Stall::Atomic => "atomic_busy",
            Stall::Stream => "stream_or_pipeline_wait",
        }
    }
}

/// What the TPs did, cycle by cycle, summed over TPs. Every TP-cycle of the frame is exactly
/// one of: an issue (one per instruction), a stall (by cause), or idle (after the TP's last
/// pixel).
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize, Stats)]
pub struct IssueStats {
    /// Instructions issued, by [`Class`] (in `Class` order). Each was fetched once.
    pub instructions: [u64; CLASSES],
    /// Stall cycles by [`Stall`] cause.
    pub stall: [u64; STALLS],
    /// Unit-busy stall cycles by unit class.
    pub unit_busy: [u64; UNIT_CLASSES],
    /// TP-cycles after a TP's last pixel, to the end of the frame.
    pub idle: u64,
    /// Register-file reads (register source operands) and writes (register destinations).
    pub register_reads: u64,
    pub register_writes: u64,
}

impl IssueStats {
    pub fn total_instructions(&self) -> u64 {
        self.instructions.iter().sum()
    }
    pub fn stalls(&self) -> u64 {
        self.stall.iter().sum()
    }
    pub fn count(&self, c: Class) -> u64 {
        self.instructions[c as usize]
    }
    /// Instructions by class name.
    pub fn by_class(&self) -> BTreeMap<&'static str, u64> {
        Class::ALL
            .iter()
            .map(|&c| (c.name(), self.instructions[c as usize]))
            .collect()
    }
    /// Stall cycles by cause name.
    pub fn by_cause(&self) -> BTreeMap<&'static str, u64> {
        Stall::ALL
            .iter()
            .map(|&s| (s.name(), self.stall[s as usize]))
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_counter_is_merged() {
        rtsim_sim::testing::assert_merges_every_field(&IssueStats::default());
    }
}
