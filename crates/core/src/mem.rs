//! The request interface between requesters and memory models.
//!
//! A requester (a cache's miss path, a TM, an SGRT T&I unit, a trace reader) hands timed line
//! requests to a [`MemoryPort`] and later drains [`MemCompletion`]s. Time on this interface is
//! always in the *requester's* clock; a memory model with its own clock (the DRAM controller)
//! converts at the boundary (see [`crate::clock`]). A full queue refuses a request with
//! [`QueueFull`]: that is back-pressure, and the requester retries on a later cycle.
//!
//! Memory models know nothing about rays: addresses come from the scene's memory image (the
//! BVH crate) or from a trace file.

use serde::{Deserialize, Serialize};

/// Read or write.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum MemOp {
    Read,
    Write,
}

/// One line-sized request.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MemRequest {
    /// Caller-chosen identifier, returned with the completion. Need not be unique: duplicate
    /// reads to one line may be merged by the memory model, each id still completes.
    pub id: u64,
    /// Byte address; the model aligns it down to its line size.
    pub addr: u64,
    pub op: MemOp,
    /// Requester-clock cycle at which the request reaches the memory controller.
    pub arrival: u64,
}

/// A finished request. Writes complete when the controller has accepted their data into the
/// DRAM (the write burst ended); reads when the last beat of data is back.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MemCompletion {
    pub id: u64,
    pub addr: u64,
    pub op: MemOp,
    /// Requester-clock cycle of arrival (as given in the request).
    pub arrival: u64,
    /// Requester-clock cycle at which the data is available to the requester (rounded up to
    /// the requester's clock).
    pub finish: u64,
}

/// The request was refused because the target queue is full (back-pressure).
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
#[error("memory request queue full")]
pub struct QueueFull;

/// A timed memory model seen from its requester. All cycles are requester-clock cycles.
pub trait MemoryPort {
    /// Offer a request. `req.arrival` must not be earlier than the time already advanced to.
    fn try_enqueue(&mut self, req: MemRequest) -> Result<(), QueueFull>;
    /// Simulate up to and including requester cycle `cycle`.
    fn advance_to(&mut self, cycle: u64);
    /// The earliest requester cycle at which something can change (a completion, a queued
    /// command becoming issuable, a refresh), or `None` when the model is idle and empty.
    /// Callers use it to jump over idle time.
    fn next_event(&self) -> Option<u64>;
    /// Move finished requests into `out`, in completion order.
    fn drain_completions(&mut self, out: &mut Vec<MemCompletion>);
    /// Number of requests accepted but not yet completed.
    fn outstanding(&self) -> usize;
}
