//! The functional ray tracer: the oracle every hardware model must match.
//!
//! Principal types and how they interact:
//!
//! - [`kernels`]: the ray–box slab test and three ray–triangle tests (Möller–Trumbore,
//!   Plücker, Wald) behind the [`TriKernel`] trait.
//! - [`traverse`]: the reference binary-BVH stack traversal (nearest child first or
//!   left-first, closest- or any-hit), generic over the kernel, filling [`RayCounters`].
//! - [`step`]: the traversal variants (`stack`, `bit-stack`, `short-stack`) as steppable state
//!   machines whose [`Step`]s say what the hardware fetches and does next; `stack` stepped
//!   equals the closed loop above, counters included.
//! - [`Tracer`]: a BVH plus triangle records in the selected kernel's format; answers
//!   `closest_hit` / `any_hit` queries with counters. Hardware models must reproduce its hits
//!   and counters for the variant they run.
//! - [`workload`]: per-pixel ray generation and shading (primary, AO, diffuse, path,
//!   specular) with per-pixel seeded streams ([`Integrator`]), counting rays by kind
//!   ([`FrameStats`]).
//! - [`film`]: renders a [`Frame`] in parallel (bit-identical for any thread count), tone maps
//!   it to sRGB PNG and draws the nodes-visited heat map.
//! - [`config`]: the `trace.*` and `workload.*` settings.

pub mod config;
pub mod counters;
pub mod fast;
pub mod film;
pub mod kernels;
pub mod ops;
pub mod query;
pub mod sampling;
pub mod shade;
pub mod step;
pub mod tracer;
pub mod traverse;
pub mod workload;

pub use config::{
    TraceConfig, Traversal, TraversalOrder, TriangleTest, WorkloadConfig, WorkloadKind,
};
pub use counters::{CounterTotals, RayCounters};
pub use film::{Frame, ToneMap, render_frame};
pub use kernels::TriKernel;
pub use step::{Query, Step};
pub use tracer::{Hit, NO_HIT, Tracer, TracerError, TraversalState, brute_force_closest};
pub use workload::{
    FrameStats, Integrator, Kernel, Next, PathState, PixelResult, RayId, RayJob, RayKind, Record,
    RecordAccess, Resumed, Shading, TraceResult, WorkloadParams,
};

#[cfg(test)]
pub(crate) mod testutil;
