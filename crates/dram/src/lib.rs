//! Cycle-level DRAM model.
//!
//! PLACEHOLDER (skeleton): the DRAM issue fills this crate.
