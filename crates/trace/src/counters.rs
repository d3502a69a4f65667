//! Per-ray work counters and their per-frame sums.
//!
//! The counters are part of the tracer's contract: a hardware model running the same
//! traversal variant must reproduce them exactly. Definitions (baseline stack traversal):
//!
//! - `nodes_visited`: nodes whose record was fetched and processed, the root included (a
//!   hardware model fetches exactly these);
//! - `leaves_visited`: the leaves among them;
//! - `box_tests`: ray–box tests, the root's one plus two per inner node visited;
//! - `tri_tests`: ray–triangle tests;
//! - `stack_pushes`: far children deferred to the stack;
//! - `stack_culls`: stack entries popped and discarded because a closer hit was found since
//!   they were pushed (no node fetch);
//! - `max_stack`: deepest stack occupancy.

use serde::{Deserialize, Serialize};
use std::ops::AddAssign;

/// Work done by one ray.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct RayCounters {
    pub nodes_visited: u32,
    pub leaves_visited: u32,
    pub box_tests: u32,
    pub tri_tests: u32,
    pub stack_pushes: u32,
    pub stack_culls: u32,
    pub max_stack: u32,
}

/// Sums over many rays of one kind.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct CounterTotals {
    pub rays: u64,
    pub hits: u64,
    pub nodes_visited: u64,
    pub leaves_visited: u64,
    pub box_tests: u64,
    pub tri_tests: u64,
    pub stack_pushes: u64,
    pub stack_culls: u64,
    /// Deepest stack seen by any ray.
    pub max_stack: u64,
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
        self.stack_culls += c.stack_culls as u64;
        self.max_stack = self.max_stack.max(c.max_stack as u64);
    }
}

impl AddAssign for CounterTotals {
    fn add_assign(&mut self, o: CounterTotals) {
        self.rays += o.rays;
        self.hits += o.hits;
        self.nodes_visited += o.nodes_visited;
        self.leaves_visited += o.leaves_visited;
        self.box_tests += o.box_tests;
        self.tri_tests += o.tri_tests;
        self.stack_pushes += o.stack_pushes;
        self.stack_culls += o.stack_culls;
        self.max_stack = self.max_stack.max(o.max_stack);
    }
}
