//! Shared vocabulary of rtsim.
//!
//! Every other crate speaks in these types, so they are deliberately small and stable:
//!
//! - [`math`]: [`Vec3`] and [`Aabb`], the geometry of scenes and BVHs, plus [`Affine`]
//!   transforms for scene descriptors.
//! - [`ray`]: the [`Ray`] every tracer and hardware model consumes.
//! - [`real`]: [`Real`], the scalar the kernels are generic over (`f32`, or a counting scalar
//!   for operation counts).
//! - [`rng`]: [`Pcg32`], a seeded, counter-friendly generator; per-pixel streams are derived
//!   with [`rng::stream_seed`] so results do not depend on thread scheduling.
//! - [`mem`]: the request interface between requesters (caches, TMs, T&I units) and memory
//!   models (the DRAM crate): [`MemRequest`], [`MemCompletion`] and the [`MemoryPort`] trait.
//! - [`clock`]: [`Clock`] domains and exact cycle conversion between them (1 GHz core with a
//!   2 GHz DRAM, a 500 MHz T&I unit with 800 MHz LPDDR3, any integer frequencies).
//! - [`error`]: [`FileError`], the located error of every input-file reader.
//! - [`output`]: every output file: a run's outputs as one [`output::OutputSet`], checked before
//!   the work, staged and committed together; devices and FIFOs written through, never replaced.
//! - [`text`]: bounded line reading, UTF-8 checks with positions, and [`text::echo`], which
//!   escapes and cuts input quoted in messages.
//! - [`stats`]: helpers for typed statistics (numerators and denominators kept, ratios
//!   computed only when reporting).

pub mod clock;
pub mod error;
pub mod math;
pub mod mem;
pub mod output;
pub mod ray;
pub mod real;
pub mod rng;
pub mod stats;
pub mod text;

pub use clock::Clock;
pub use error::FileError;
pub use math::{Aabb, Affine, Vec3};
pub use mem::{MemCompletion, MemError, MemOp, MemRequest, MemoryPort, QueueFull};
pub use ray::Ray;
pub use real::Real;
pub use rng::Pcg32;
