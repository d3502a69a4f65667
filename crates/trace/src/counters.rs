//! Per-ray work counters and their per-frame sums.
//!
//! The counters are part of the tracer's contract: a hardware model running the same
//! traversal variant must reproduce them exactly. Definitions (all variants; see
//! `docs/TRAVERSAL.md` for each variant's contract):
//!
//! - `nodes_visited`: nodes whose record was fetched to descend into them, the root included
//!   (a hardware model fetches exactly these; [`crate::step::Step::Node`]);
//! - `leaves_visited`: the leaves among them;
//! - `box_tests`: ray–box tests: the root's one, two per inner node visited (the child pair),
//!   plus the bit-stack variant's sibling re-tests;
//! - `tri_tests`: ray–triangle tests;
//! - `stack_pushes`: entries pushed (`stack`, `short-stack`: far children deferred with their
//!   entry distance, one local-memory write each; `bit-stack`: one bit per level descended);
//! - `stack_pops`: entries popped (local-memory reads for `stack`; bits for `bit-stack`),
//!   culled ones included;
//! - `stack_culls`: popped entries discarded because their entry distance is beyond the
//!   closest hit found since they were pushed (no node fetch);
//! - `max_stack`: deepest stack occupancy (entries; bits for `bit-stack`);
//! - `parent_fetches`: `bit-stack`: parent pointers read to move up the tree;
//! - `sibling_retests`: `bit-stack`: sibling boxes tested again on the way up (the price of
//!   not storing the far child's entry distance; also counted in `box_tests`);
//! - `treelet_crossings`: moves of the current node into another treelet (only when the
//!   tracer has treelet ids; 0 otherwise);
//! - `stack_overflows`: `short-stack`: pushes onto a full stack, which drop the oldest entry;
//! - `restarts`: `short-stack`: traversals restarted from the root because a dropped entry
//!   was still pending.

use rtsim_stats_derive::Stats;
use serde::{Deserialize, Serialize};

/// Work done by one ray.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct RayCounters {
    pub nodes_visited: u32,
    pub leaves_visited: u32,
    pub box_tests: u32,
    pub tri_tests: u32,
    pub stack_pushes: u32,
    pub stack_pops: u32,
    pub stack_culls: u32,
    pub max_stack: u32,
    pub parent_fetches: u32,
    pub sibling_retests: u32,
    pub treelet_crossings: u32,
    pub stack_overflows: u32,
    pub restarts: u32,
}

/// Sums over many rays of one kind (`+=` merges every field: the derive leaves none out).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, Stats)]
pub struct CounterTotals {
    pub rays: u64,
    pub hits: u64,
    pub nodes_visited: u64,
    pub leaves_visited: u64,
    pub box_tests: u64,
    pub tri_tests: u64,
    pub stack_pushes: u64,
    pub stack_pops: u64,
    pub stack_culls: u64,
    /// Deepest stack seen by any ray.
    #[stats(max)]
    pub max_stack: u64,
    pub parent_fetches: u64,
    pub sibling_retests: u64,
    pub treelet_crossings: u64,
    pub stack_overflows: u64,
    pub restarts: u64,
}

impl CounterTotals {
    /// Account one traced ray.
    #[inline]
    pub fn record(&mut self, c: &RayCounters, hit: bool) {
        self.rays += 1;
        self.hits += hit as u64;
        self.nodes_visited += c.nodes_visited as u64;
        self.leaves_visited += c.leaves_visited as u64;
        self.box_tests += c.box_tests as u64;
        self.tri_tests += c.tri_tests as u64;
        self.stack_pushes += c.stack_pushes as u64;
        self.stack_pops += c.stack_pops as u64;
        self.stack_culls += c.stack_culls as u64;
        self.max_stack = self.max_stack.max(c.max_stack as u64);
        self.parent_fetches += c.parent_fetches as u64;
        self.sibling_retests += c.sibling_retests as u64;
        self.treelet_crossings += c.treelet_crossings as u64;
        self.stack_overflows += c.stack_overflows as u64;
        self.restarts += c.restarts as u64;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::{Value, json};

    #[test]
    fn totals_merge_every_field() {
        rtsim_sim::testing::assert_merges_every_field(&CounterTotals::default());
    }

    /// `record` carries every per-ray counter into the totals.
    #[test]
    fn record_covers_every_counter() {
        let Value::Object(mut fields) = json!(RayCounters::default()) else {
            unreachable!()
        };
        for v in fields.values_mut() {
            *v = json!(3);
        }
        let c: RayCounters = serde_json::from_value(Value::Object(fields.clone())).unwrap();
        let mut t = CounterTotals::default();
        t.record(&c, true);
        let Value::Object(totals) = json!(t) else {
            unreachable!()
        };
        for k in fields.keys() {
            assert_eq!(totals[k], json!(3), "record() leaves out `{k}`");
        }
        assert_eq!((t.rays, t.hits), (1, 1));
    }
}
