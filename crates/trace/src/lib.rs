//! The functional ray tracer: the oracle every hardware model must match.
//!
//! PLACEHOLDER (skeleton).

pub mod config;
pub use config::{TraceConfig, TraversalOrder, TriangleTest, WorkloadConfig, WorkloadKind};
