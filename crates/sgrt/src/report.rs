//! Figures of the paper's tables, computed from the counters.

/// Placeholder until the report lands.
#[derive(Debug)]
pub struct Report;
