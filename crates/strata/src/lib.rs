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
//! - [`world`]: [`World`], a scene prepared for STRaTA: a BVH of at most 32 levels, the treelet
//!   memory image with parent pointers, and a `bit-stack` tracer that steps through treelet
//!   crossings.
//! - [`flow`]: the functional (untimed) ray flow: initial fill of the root buffer, TMs picking
//!   buffers by policy, rays pushed to the buffer of the treelet they enter, one-for-one
//!   successor replacement; it renders the functional tracer's image and counts treelet
//!   switches, pushes and pops, and L1 footprints.
//!
//! The timed chip (the flow on the TRaX engine, fused box and triangle pipelines) is not built
//! yet; `docs/STRATA.md` describes the model, every constant with its source, and what
//! remains.

pub mod config;
pub mod flow;
pub mod paper;
pub mod pipeline;
pub mod program;
pub mod stream;
pub mod timed;
pub mod world;

pub use config::{Fill, Policy, StrataConfig, StreamConfig, Switch};
pub use flow::{FlowChip, FlowError, FlowOutput, FlowStats, Frame};
pub use stream::{StreamLayout, StreamMemory, StreamStats};
pub use world::World;
