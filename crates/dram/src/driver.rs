//! Runs a request stream through a [`Dram`] to completion, as a standalone DRAM simulator does.
//!
//! The stream is issued in order, like a single in-order requester: a request is offered at its
//! arrival cycle (`When::At`) or `gap` cycles after the previous one was issued (`When::Gap`);
//! when its queue is full it is retried every cycle until accepted (the driver jumps to the next
//! event instead of ticking, with the same result), and later requests wait behind it. For USIMM
//! traces an optional limit on outstanding reads stalls the stream until a read returns. An
//! optional limit on requests per cycle (1: DRAMsim3's trace front end) moves the requests beyond
//! it to the next cycle.

use crate::dram::Dram;
use crate::trace::{TraceRecord, When};
use rtsim_core::{MemCompletion, MemError, MemOp, MemRequest, MemoryPort};

/// Options of a run.
#[derive(Clone, Copy, Debug, Default)]
pub struct DriveOptions {
    /// Stall while this many reads are outstanding (USIMM traces).
    pub max_outstanding_reads: Option<u32>,
    /// Issue at most this many requests per requester cycle; 0 = no limit.
    pub max_per_cycle: u32,
}

/// What happened at the requester side.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct DriveSummary {
    pub requests: u64,
    pub reads: u64,
    pub writes: u64,
    /// Requester cycles requests waited beyond their arrival (full queues, read limit).
    pub stall_cycles: u64,
    /// Requester cycle of the last completion.
    pub end_cycle: u64,
}

struct State<'a> {
    dram: &'a mut Dram,
    buf: Vec<MemCompletion>,
    reads_out: u64,
    end: u64,
}

impl State<'_> {
    #[inline]
    fn advance(&mut self, cycle: u64) {
        self.dram.advance_to(cycle);
        self.buf.clear();
        self.dram.drain_completions(&mut self.buf);
        for c in &self.buf {
            if c.op == MemOp::Read {
                self.reads_out -= 1;
            }
            self.end = self.end.max(c.finish);
        }
    }
    #[inline]
    fn next_cycle(&self) -> u64 {
        self.dram.now().map_or(0, |n| n + 1)
    }
}

/// Run `records` through `dram` until every request has completed. `on_progress` is called with
/// the number of requests issued so far every 65 536 requests.
pub fn drive<E>(
    dram: &mut Dram,
    records: impl IntoIterator<Item = Result<TraceRecord, E>>,
    opts: DriveOptions,
    mut on_progress: impl FnMut(u64),
) -> Result<DriveSummary, E> {
    let mut st = State {
        dram,
        buf: Vec::with_capacity(1024),
        reads_out: 0,
        end: 0,
    };
    let mut sum = DriveSummary::default();
    let mut last_issue = 0u64;
    // Requests issued in cycle `last_issue`.
    let mut in_cycle = 0u64;
    let per_cycle = u64::from(opts.max_per_cycle);
    // Without a read limit nothing here waits for completions or asks for the next event
    // until the stream has been offered: the channels may be simulated lazily.
    st.dram.set_lazy(opts.max_outstanding_reads.is_none());
    for (id, rec) in records.into_iter().enumerate() {
        let rec = rec?;
        let wanted = match rec.when {
            When::At(c) => c,
            When::Gap(g) => last_issue.saturating_add(g),
        };
        let mut t = wanted.max(st.next_cycle());
        if rec.op == MemOp::Read {
            if let Some(limit) = opts.max_outstanding_reads {
                while st.reads_out >= u64::from(limit) {
                    let e = st
                        .dram
                        .next_event()
                        .expect("outstanding reads imply a future event");
                    st.advance(e.max(t.saturating_sub(1)));
                    t = t.max(st.next_cycle());
                }
            }
        }
        loop {
            if per_cycle > 0 && in_cycle >= per_cycle && t == last_issue {
                t += 1;
            }
            if t > 0 && st.dram.now().is_none_or(|n| n < t - 1) {
                st.advance(t - 1);
            }
            let req = MemRequest {
                id: id as u64,
                addr: rec.addr,
                op: rec.op,
                arrival: t,
                tag: 0,
            };
            match st.dram.try_enqueue(req) {
                Ok(()) => break,
                // Full: nothing changes for this channel before its next event; retry when the
                // port says (other channels are simulated up to then on the way).
                Err(MemError::Full(q)) => {
                    st.advance(q.retry_at - 1);
                    t = q.retry_at;
                }
                // The driver advances to t − 1 before offering arrival t, with tag 0.
                Err(e) => unreachable!("driver request rejected: {e}"),
            }
        }
        sum.stall_cycles += t - wanted;
        in_cycle = if sum.requests > 0 && t == last_issue {
            in_cycle + 1
        } else {
            1
        };
        last_issue = t;
        sum.requests += 1;
        match rec.op {
            MemOp::Read => {
                sum.reads += 1;
                st.reads_out += 1;
            }
            MemOp::Write => sum.writes += 1,
        }
        if sum.requests % 65_536 == 0 {
            on_progress(sum.requests);
        }
    }
    st.dram.set_lazy(false);
    while let Some(e) = st.dram.next_event() {
        st.advance(e);
    }
    sum.end_cycle = st.end;
    Ok(sum)
}
