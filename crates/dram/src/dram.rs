//! [`Dram`]: the whole memory system behind one [`MemoryPort`].
//!
//! Requests are decoded by the address mapper and handed to their channel's controller; a full
//! queue refuses them ([`QueueFull`], with the cycle from which a retry can succeed); a request
//! arriving at a cycle already simulated, or with a tag outside the requester's range, is an
//! error ([`MemError`]). Time on the port is in requester cycles. `advance_to(c)`
//! simulates every memory cycle that starts before requester cycle `c + 1` — channel by
//! channel, since channels share nothing — and collects completions, whose finish times are
//! rounded up to the requester clock. A request arriving at requester cycle `a` reaches the
//! controller at the first memory cycle at or after that instant. Between events nothing is
//! simulated, so callers may jump to [`MemoryPort::next_event`] or tick cycle by cycle with the
//! same result.

use crate::completions::CompletionQueue;
use crate::config::DramConfig;
use crate::controller::Channel;
use crate::controller::queue::{Entry, NIL};
use crate::energy::EnergyReport;
use crate::report::Report;
use crate::spec::{DramSpec, Requester};
use crate::stats::DramStats;
use rtsim_config::ConfigError;
use rtsim_core::{MemCompletion, MemError, MemOp, MemRequest, MemoryPort, QueueFull};

/// Requester cycles beyond this are clamped (2^52: ~52 days at 1 GHz), so that conversions
/// between clocks (ratios up to 1024 : 1) stay within 64 bits.
pub const MAX_CYCLE: u64 = 1 << 52;

/// The DRAM model: controllers and devices of every channel.
#[derive(Debug)]
pub struct Dram {
    spec: DramSpec,
    channels: Vec<Channel>,
    /// Completions waiting for the requester to reach their finish cycle, in order of finish
    /// and, among equal finishes, of collection: the channels add them as they produce them,
    /// in buckets by finish cycle.
    ready: CompletionQueue,
    /// Last requester cycle advanced to.
    now_req: Option<u64>,
    /// Memory cycles below this are simulated.
    mem_done: u64,
    outstanding: usize,
    seq: u64,
    /// Channels are simulated only when they must be ([`Dram::set_lazy`]).
    lazy: bool,
}

impl Dram {
    /// Build from a configuration and the requester it serves (its clock, which the chip
    /// provides, and its number of tags); both validated here.
    pub fn new(config: &DramConfig, requester: Requester) -> Result<Self, ConfigError> {
        Ok(Dram::from_spec(DramSpec::new(config, requester)?))
    }

    /// Build from a resolved spec.
    pub fn from_spec(spec: DramSpec) -> Self {
        let channels = (0..spec.org.channels)
            .map(|i| Channel::new(&spec, i))
            .collect();
        let cap = (spec.controller().read_queue + spec.controller().write_queue) as usize
            * spec.org.channels as usize;
        Dram {
            spec,
            channels,
            ready: CompletionQueue::with_capacity(cap),
            now_req: None,
            mem_done: 0,
            outstanding: 0,
            seq: 0,
            lazy: false,
        }
    }

    pub fn spec(&self) -> &DramSpec {
        &self.spec
    }

    /// The last requester cycle simulated, if any.
    pub fn now(&self) -> Option<u64> {
        self.now_req
    }

    /// Memory cycles simulated so far.
    pub fn mem_cycles(&self) -> u64 {
        self.mem_done
    }

    /// Advance by one requester cycle (cycle-by-cycle use).
    pub fn tick(&mut self) {
        let next = self.now_req.map_or(0, |n| n + 1);
        self.advance_to(next);
    }

    /// The channels (for inspection in tests and reports; with [`Dram::set_lazy`] on, a
    /// channel may not have been simulated up to the port's time yet).
    pub fn channels(&self) -> &[Channel] {
        &self.channels
    }

    /// Lazy simulation (`true`) for a requester that needs neither the completions in time
    /// nor the port's next event, only to know whether each request is accepted — the
    /// standalone driver without a limit on outstanding reads. Then `advance_to` only moves
    /// the port's clock, and a channel is simulated up to it when a request is offered to it
    /// (its queue's room and next event are then exactly as eager advancing leaves them),
    /// one channel over many requests' time at once instead of every channel at every step
    /// of the requester. Channels share nothing, so each runs the same steps either way; the
    /// completions of a channel simulated late reach [`MemoryPort::drain_completions`] late
    /// (still in finish order among themselves). Switching it off simulates every channel up
    /// to the port's time; do so before asking for [`MemoryPort::next_event`].
    pub fn set_lazy(&mut self, lazy: bool) {
        if !lazy {
            self.catch_up_all();
        }
        self.lazy = lazy;
    }

    /// Simulate every channel up to the port's time (lazy simulation leaves them behind).
    fn catch_up_all(&mut self) {
        for c in 0..self.channels.len() {
            self.catch_up(c);
        }
    }

    /// Simulate channel `c` up to the port's time (the last memory cycle `advance_to` reached).
    #[inline]
    fn catch_up(&mut self, c: usize) {
        let ch = &mut self.channels[c];
        if ch.next_event() < self.mem_done {
            ch.run_until(self.mem_done - 1, &mut self.ready);
        }
    }

    /// Stats of each channel, accounted up to the simulated time.
    pub fn channel_stats(&mut self) -> Vec<DramStats> {
        self.catch_up_all();
        let end = self.mem_done;
        self.channels
            .iter_mut()
            .map(|ch| {
                ch.finish(end);
                ch.stats.clone()
            })
            .collect()
    }

    /// Stats of the whole memory, accounted up to the simulated time.
    pub fn stats(&mut self) -> DramStats {
        let mut total = DramStats::default();
        for s in self.channel_stats() {
            total += &s;
        }
        total.mem_cycles = self.mem_done;
        total
    }

    /// Energy so far.
    pub fn energy(&mut self) -> EnergyReport {
        let s = self.stats();
        EnergyReport::new(&s, &self.spec)
    }

    /// Advance to requester cycle `end` (simulating refresh and background time) and report.
    pub fn report(&mut self, end: u64) -> Report {
        self.advance_to(end);
        let per_channel = self.channel_stats();
        let mut total = DramStats::default();
        for s in &per_channel {
            total += s;
        }
        total.mem_cycles = self.mem_done;
        Report::new(&self.spec, total, &per_channel)
    }

    /// The requester cycle whose `advance_to` simulates memory cycle `m` (`u64::MAX` stays).
    #[inline]
    fn mem_event_to_req(&self, m: u64) -> u64 {
        if m == u64::MAX {
            return u64::MAX;
        }
        self.spec
            .mem_to_req
            .floor(m)
            .max(self.now_req.map_or(0, |n| n + 1))
    }

    /// The earliest requester cycle at which the channel serving `addr` can change state: a
    /// refused request for that channel cannot be accepted before the cycle after it. Other
    /// channels' events in between are simulated by the same `advance_to` call, so a requester
    /// blocked on one channel may jump straight there. With [`Dram::set_lazy`] on, a channel
    /// not offered a request since the last `advance_to` may report an earlier cycle.
    pub fn next_event_for(&self, addr: u64) -> Option<u64> {
        let loc = self.spec.mapper.decode(self.spec.mapper.line_addr(addr));
        self.channel_event(loc.channel as usize)
    }

    /// The number [`QueueFull::queue`] gives a channel's read or write queue.
    fn queue_id(channel: u32, op: MemOp) -> u32 {
        2 * channel + u32::from(op == MemOp::Write)
    }

    fn channel_event(&self, channel: usize) -> Option<u64> {
        let e = self.mem_event_to_req(self.channels[channel].next_event());
        (e != u64::MAX).then_some(e)
    }

    /// Legality violations found in checking mode (empty otherwise, and when all is well).
    pub fn violations(&self) -> Vec<String> {
        self.channels
            .iter()
            .flat_map(|c| c.violations().iter().cloned())
            .collect()
    }
}

impl MemoryPort for Dram {
    fn try_enqueue(&mut self, req: MemRequest) -> Result<(), MemError> {
        if let Some(now) = self.now_req.filter(|&n| req.arrival <= n) {
            return Err(MemError::Past {
                id: req.id,
                arrival: req.arrival,
                now,
            });
        }
        if req.tag >= self.spec.tags {
            return Err(MemError::Tag {
                id: req.id,
                tag: req.tag,
                tags: self.spec.tags,
            });
        }
        let map = &self.spec.mapper;
        let line = map.line_addr(req.addr);
        let loc = map.decode(line);
        if self.lazy {
            self.catch_up(loc.channel as usize);
        }
        let ch = &mut self.channels[loc.channel as usize];
        if !ch.has_room(req.op) {
            ch.refused(req.op, req.tag);
            // Room can only appear when the channel next acts, simulated by advancing to the
            // cycle of that event; the retried request then arrives in the cycle after it.
            let e = self
                .channel_event(loc.channel as usize)
                .expect("a full queue implies a future event");
            return Err(QueueFull {
                retry_at: e.max(req.arrival) + 1,
                queue: Self::queue_id(loc.channel, req.op),
                domain: loc.channel,
            }
            .into());
        }
        let arrival_mem = self
            .spec
            .req_to_mem
            .ceil(req.arrival.min(MAX_CYCLE))
            .max(self.mem_done);
        self.seq += 1;
        ch.enqueue(Entry {
            id: req.id,
            addr: line,
            req_addr: req.addr,
            op: req.op,
            arrival_req: req.arrival,
            arrival_mem,
            tag: req.tag,
            seq: self.seq,
            rank: loc.rank,
            bank: loc.rank * self.spec.org.banks_per_rank + loc.bank,
            row: loc.row,
            act_for: false,
            pre_for: false,
            in_cq: false,
            merged: NIL,
            next_merged: NIL,
        });
        self.outstanding += 1;
        Ok(())
    }

    fn advance_to(&mut self, cycle: u64) {
        let cycle = cycle.min(MAX_CYCLE);
        if self.now_req.is_some_and(|n| cycle <= n) {
            return;
        }
        // The last memory cycle that starts before requester cycle `cycle + 1`.
        let limit = self
            .spec
            .req_to_mem
            .ceil(cycle.saturating_add(1))
            .saturating_sub(1);
        // Only a channel that runs produces completions, added to `ready` as they are
        // produced: channel by channel, as collecting after each channel's run did. Lazily,
        // a channel runs when a request is offered to it (`catch_up`).
        if !self.lazy {
            for ch in &mut self.channels {
                if ch.next_event() <= limit {
                    ch.run_until(limit, &mut self.ready);
                }
            }
        }
        self.mem_done = limit + 1;
        self.now_req = Some(cycle);
    }

    fn next_event(&self) -> Option<u64> {
        debug_assert!(
            !self.lazy,
            "set_lazy(false) before asking for the next event"
        );
        if self.outstanding == 0 {
            return None;
        }
        let ready = self.ready.first_finish().unwrap_or(u64::MAX);
        let m = self
            .channels
            .iter()
            .map(Channel::next_event)
            .min()
            .unwrap_or(u64::MAX);
        let e = ready.min(self.mem_event_to_req(m));
        (e != u64::MAX).then_some(e)
    }

    fn drain_completions(&mut self, out: &mut Vec<MemCompletion>) {
        let Some(now) = self.now_req else { return };
        self.outstanding -= self.ready.drain_to(now, out);
    }

    fn outstanding(&self) -> usize {
        self.outstanding
    }

    fn now(&self) -> Option<u64> {
        self.now_req
    }

    fn line_bytes(&self) -> u32 {
        self.spec.org.line_bytes
    }

    fn refuse_again(&mut self, req: &MemRequest, times: u64) {
        let map = &self.spec.mapper;
        let channel = map.decode(map.line_addr(req.addr)).channel as usize;
        self.channels[channel].refused_times(req.op, req.tag, times);
    }
}

/// Convenience for tests and tools: a read or write request with tag 0.
pub fn request(id: u64, addr: u64, op: MemOp, arrival: u64) -> MemRequest {
    MemRequest {
        id,
        addr,
        op,
        arrival,
        tag: 0,
    }
}
