//! SGRT (Lee et al., "SGRT: A Mobile GPU Architecture for Real-Time Ray Tracing", HPG 2013):
//! a cycle-level model of the mobile GPU whose cores pair a fixed-function traversal and
//! intersection (T&I) unit with a programmable shader (SRP), on LPDDR3.
//!
//! Principal types and how they interact:
//!
//! - [`SgrtConfig`] (`arch.sgrt.*`): every parameter with its default, unit and source
//!   (paper section, or "assumed" with the reason); validated with errors naming the key.
//! - [`units`]: the paper's unit counts (Tables 1–2), the 65 nm operation latencies, the
//!   pipeline latencies and initiation intervals derived from them, area (Table 2) and the
//!   energy basis.
//! - [`core`]: one core's T&I unit — ray dispatch, the TRVs as PPTRV (three sub-pipelines
//!   behind a crossbar) or SPTRV (one deep pipeline), the IST, the memory stage and RAU in
//!   front of each pipeline, the ray and hit buffers; the definition of a *step*.
//! - [`srp`]: the SRP as a throughput-and-latency unit (kernel costs from measured operation
//!   counts, reads through its data cache), or the free feeder of the T&I-only mode.
//! - [`work`]: the frame (pixel state machines of `rtsim_trace::Integrator`) or the rays of a
//!   `rays.bin`, handed out in packets; results and functional counters.
//! - [`chip`]: [`Sgrt`], the cores over one cache tree ([`rtsim_cache::Hierarchy`]) and one
//!   memory (the LPDDR3 model, `rtsim_dram::Dram`, or any `MemoryPort`), with the fast
//!   (event-driven) and reference (cycle-by-cycle) engines, proven equal by the tests.
//! - [`stats`] and [`report`]: typed counters summed with `+=`, and the figures of the
//!   paper's tables computed from them (Mrays/s, utilisations, steps per ray, hit rates,
//!   bandwidth, frames per second, area, energy).
//!
//! Clocks: the T&I unit and its caches at `ti_clock_mhz` (500), the SRP at `srp_clock_mhz`
//! (1000), the DRAM at its own (LPDDR3-1600: 800 MHz), converted exactly where they meet.
//! The image and the hits are the functional tracer's by construction: the hardware drives
//! the same steppable traversal and the same pixel state machines, and timing only decides
//! when. `docs/SGRT.md` documents every rule of the model.

pub mod chip;
pub mod config;
pub mod core;
pub mod error;
pub mod pipe;
pub mod report;
pub mod srp;
pub mod stats;
pub mod units;
pub mod work;

pub use chip::{Engine, Input, Sgrt, SgrtResult, SgrtStats, memory_tags};
pub use config::{IstConfig, Organisation, RaysQuery, SgrtConfig, SrpConfig, TrvConfig};
pub use error::SgrtError;
pub use report::Report;
pub use stats::CoreStats;
