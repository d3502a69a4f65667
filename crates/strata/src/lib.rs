//! STRaTA on the TRaX chip (Kopta et al., "Memory Considerations for Low Energy Ray Tracing",
//! CGF 2015, §3; issue 10): the ray stream memory, treelet scheduling and the ray flow between
//! treelet buffers.
//!
//! Principal types and how they interact:
//!
//! - [`StrataConfig`] (`arch.strata.*`): the stream memory, the L2 beside it, the scheduling
//!   policy and the feature switches, each with its default and source, validated with errors
//!   naming the key.
//! - [`stream`]: [`StreamMemory`], the SRAM of 48-byte ray records kept as one LIFO linked list
//!   per treelet with a head table and a free list, links and heads counted against capacity
//!   ([`StreamLayout`]), accesses counted per bank and charged by STRaTA Table 2.
//!
//! The timed chip (the flow on the TRaX engine, fused box and triangle pipelines) is not built
//! yet; `docs/STRATA.md` describes the model, every constant with its source, and what
//! remains.

pub mod config;
pub mod stream;

pub use config::{Policy, StrataConfig, StreamConfig};
pub use stream::{StreamLayout, StreamMemory, StreamStats};
