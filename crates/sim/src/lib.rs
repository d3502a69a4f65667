//! Simulation building blocks shared by every hardware model.
//!
//! - [`link`]: [`Link`], a bounded queue with a latency — items pushed at `t` are visible at
//!   `t + latency`, a full link refuses the push (back-pressure), [`Link::next_ready`] lets the
//!   owner skip idle time — and its [`LinkStats`].
//! - [`event`]: [`EventQueue`], events ordered by (cycle, insertion order): deterministic ties,
//!   never hash order.
//! - [`clock`]: [`Ratio`], exact cycle conversion between two [`rtsim_core::Clock`] domains (the
//!   chip's clock and the DRAM's are independent integers).
//! - [`component`]: the [`Component`] trait — build from config → advance through events →
//!   finish into stats — with [`run_until`] (event skipping) and [`tick_until`] (every cycle).
//! - [`crew`]: [`Crew`], host threads that each take one job per hand-over, spinning between
//!   hand-overs, for engines that split every simulated cycle between threads.
//! - [`Stats`]: `#[derive(Stats)]` (from `rtsim-stats-derive`) writes `AddAssign` for stats
//!   structs field by field, so no counter is left out of a sum; `#[stats(max)]` for
//!   high-water marks; nested stats, `Histogram`s, arrays and Vecs merge element-wise.
//!   [`testing::assert_merges_every_field`] checks it on any stats struct.
//!
//! How they fit: a chip is a set of components joined by links; the chip asks each component for
//! its next event, advances the earliest, and moves items between links, so only cycles in which
//! something happens are simulated. Components count into `Stats` structs that the chip sums
//! with `+=`.

pub mod clock;
pub mod component;
pub mod crew;
pub mod event;
pub mod link;
pub mod testing;

pub use clock::Ratio;
pub use component::{Component, run_until, tick_until};
pub use crew::Crew;
pub use event::{EventError, EventQueue};
pub use link::{Link, LinkError, LinkStats, PushError};
pub use rtsim_stats_derive::Stats;
