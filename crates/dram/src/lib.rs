//! Cycle-level DRAM model with IDD-based energy; runs behind the chip models or alone on traces.
//!
//! The crate knows nothing about rays: it takes timed line requests and returns completions
//! through [`rtsim_core::MemoryPort`].
//!
//! - [`config`]: [`DramConfig`], the settings tree (organisation, timing, currents, controller,
//!   refresh, mapping), its validation and the cited presets ([`config::PRESETS`]).
//! - [`spec`]: the config resolved into a [`DramSpec`] — derived sizes, timing in memory
//!   cycles, the flat constraint table ([`spec::constraints`], standards as data) and per-event
//!   energies ([`spec::power`], Micron TN-41-01).
//! - [`mapping`]: [`AddressMapper`], byte address → channel, rank, bank group, bank, row, column.
//! - [`engine`]: [`Engine`], one channel's timing state; enforces the constraint table.
//! - [`controller`]: one channel's controller ([`controller::Channel`]): read/write queues with
//!   merging and forwarding ([`controller::queue`]), FR-FCFS/FCFS ([`controller::scheduler`]),
//!   open/closed page ([`controller::row_policy`]), refresh ([`controller::refresh`]), rank power
//!   states ([`controller::power`]), write-drain watermarks; simulated event by event.
//! - [`dram`]: [`Dram`], all channels behind one `MemoryPort`, with the clock-domain crossing
//!   between the requester and memory clocks. The requester — its clock and its number of
//!   tags — is given by the chip at construction ([`Requester`]); stats are split per tag.
//! - [`completions`]: [`completions::CompletionQueue`], completions waiting for the requester
//!   in buckets by finish cycle.
//! - [`checker`]: [`Checker`], an independent referee that re-validates every issued command
//!   (checking mode, `check = true`).
//! - [`stats`], [`energy`], [`report`]: [`DramStats`] (typed counters, `+=`), energy by
//!   component, and the [`Report`] written as `dram_stats.json`.
//! - [`trace`], [`driver`]: rtsim/DRAMsim3/USIMM trace readers, synthetic traffic, and
//!   [`drive`], which runs a request stream to completion.
//!
//! Data flow: requests → [`Dram::try_enqueue`] (decode, queue or refuse) → per channel, each
//! event: admit arrivals → refresh → write-drain mode → the scheduler picks among the banks'
//! candidates → [`Engine`] checks and records the command → completions with finish times →
//! [`MemoryPort::drain_completions`](rtsim_core::MemoryPort::drain_completions).

pub mod checker;
pub mod completions;
pub mod config;
pub mod controller;
pub mod dram;
pub mod driver;
pub mod energy;
pub mod engine;
pub mod mapping;
pub mod report;
pub mod spec;
pub mod stats;
pub mod trace;

pub use checker::Checker;
pub use config::{DramConfig, PRESETS};
pub use dram::Dram;
pub use driver::{DriveOptions, DriveSummary, drive};
pub use engine::Engine;
pub use mapping::AddressMapper;
pub use report::Report;
pub use spec::{DramSpec, MAX_TAGS, Requester};
pub use stats::{DramStats, TagStats};
