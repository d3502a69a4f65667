//! The request interface between requesters and memory models.
//!
//! A requester (a cache's miss path, a TM, an SGRT T&I unit, a trace reader) hands timed line
//! requests to a [`MemoryPort`] and later drains [`MemCompletion`]s. Time on this interface is
//! always in the *requester's* clock — the chip's, given to the memory model when it is built —
//! and a memory model with its own clock (the DRAM controller) converts at the boundary (see
//! [`crate::clock`]). A full queue refuses a request with [`QueueFull`], which says when
//! retrying can first succeed: that is back-pressure, and the requester skips to that cycle
//! instead of polling. Requests carry a requester tag so that the memory's statistics can be
//! split by source (per L2, per unit).
//!
//! Memory models know nothing about rays: addresses come from the scene's memory image (the
//! BVH crate) or from a trace file.

use serde::{Deserialize, Serialize};

/// 2^64 / φ, rounded to odd: the multiplier of Fibonacci hashing (Knuth, *The Art of Computer
/// Programming* vol. 3, §6.4). The top bits of `addr × FIBONACCI_HASH` spread line addresses,
/// multiples of the line size, evenly over a power-of-two table; the caches' and the DRAM
/// controller's line tables use it.
pub const FIBONACCI_HASH: u64 = 0x9E37_79B9_7F4A_7C15;

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
    /// Requester-clock cycle at which the request reaches the memory controller. Must be later
    /// than the last cycle the model was advanced to ([`MemError::Past`] otherwise).
    pub arrival: u64,
    /// Which requester sent it (an L2, a unit), `0..tags` as the model was built with; the
    /// model's statistics are split by it. Out of range is [`MemError::Tag`].
    pub tag: u32,
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
    /// The request's tag.
    pub tag: u32,
}

/// The request was refused because the target queue is full (back-pressure).
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
#[error("memory request queue full; retry at requester cycle {retry_at}")]
pub struct QueueFull {
    /// When to offer the request again: with `arrival = retry_at`, after advancing the model to
    /// `retry_at − 1`. It is the cycle after the refusing queue's next event (or after the
    /// refused arrival, if later): no room can appear before that event, so polling earlier is
    /// wasted. The retry may still be refused if other requests took the room first.
    pub retry_at: u64,
    /// The queue that refused it, as the model numbers its queues. Until the model accepts
    /// a request into the same domain or is advanced, every request it would put in that
    /// queue is refused too, with the same `retry_at`: a requester holding several such
    /// requests may count them refused with [`MemoryPort::refuse_again`] instead of offering
    /// each.
    pub queue: u32,
    /// The part of the model the queue belongs to (a DRAM channel): requests to different
    /// domains never change each other's acceptance, retry cycles or completions, so a
    /// requester may offer them in either order.
    pub domain: u32,
}

/// Why a request was not accepted.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
pub enum MemError {
    /// Back-pressure: retry later.
    #[error(transparent)]
    Full(#[from] QueueFull),
    /// The request arrives at a cycle the model has already simulated: a requester bug.
    #[error(
        "request {id} arrives at requester cycle {arrival}, but the memory has already \
         simulated up to cycle {now}"
    )]
    Past { id: u64, arrival: u64, now: u64 },
    /// The tag is outside `0..tags`.
    #[error("request {id} has requester tag {tag}; this memory was built for tags 0..{tags}")]
    Tag { id: u64, tag: u32, tags: u32 },
}

/// A timed memory model seen from its requester. All cycles are requester-clock cycles.
pub trait MemoryPort {
    /// Offer a request arriving after the last cycle advanced to. A full queue refuses it with
    /// [`MemError::Full`], carrying the cycle at which to retry.
    fn try_enqueue(&mut self, req: MemRequest) -> Result<(), MemError>;
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
    /// The last requester cycle simulated (`None` before the first `advance_to`); requests
    /// must arrive after it.
    fn now(&self) -> Option<u64>;
    /// Bytes per request (the model's line); requesters with caches must use the same.
    fn line_bytes(&self) -> u32;
    /// Count `times` more refusals of `req`, which the model has just refused ([`QueueFull`])
    /// with nothing accepted or advanced since: what offering it `times` more times would
    /// have done (it changes nothing but the model's refusal counters).
    fn refuse_again(&mut self, req: &MemRequest, times: u64);
}
