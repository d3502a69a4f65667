//! Intersection kernels shared by the functional tracer, the stepped traversals the hardware
//! models run, and the operation counts (`crate::ops`): each is generic over
//! [`rtsim_core::Real`], and each triangle test reports which exit it took.
//!
//! - [`slab`]: ray–box slab test with a precomputed inverse direction.
//! - [`triangle`]: three ray–triangle tests that agree away from edges: Möller–Trumbore (the
//!   baseline TRaX kernel), Plücker (STRaTA's triangle pipeline: no divide unless it hits) and
//!   Wald's precomputed projection test (SGRT's IST unit).

pub mod slab;
pub mod triangle;

pub use slab::{RayBox, box_entry, inverse_direction, slab_test};
pub use triangle::{Exit, HIT, TriHit, TriKernel, moller_trumbore, plucker, wald};
