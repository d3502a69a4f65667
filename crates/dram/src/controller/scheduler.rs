//! Request schedulers: which command each bank offers, and which offer wins.
//!
//! Every bank offers at most one command (its [`Candidate`]) from the requests of the queue
//! being served (reads, or writes in write-drain mode):
//! - closed bank: ACT for the request a precharge was issued for, else for the oldest;
//! - open bank, FR-FCFS: the column command of the oldest request hitting the open row; if there
//!   is none — or `row_hit_cap` hits have been served and the bank's oldest request wants
//!   another row — a PRE for the oldest request that misses;
//! - open bank, FCFS: the oldest request's command (column access if it hits, else PRE).
//!
//! With `protect_row_hits = false` (USIMM's FR-FCFS) an open bank whose offer is a row hit also
//! has an *alternative*: the PRE for its oldest missing request, considered when the hit cannot
//! issue this cycle.
//!
//! Among the candidates that are ready this cycle, FR-FCFS takes row hits first, then the
//! oldest; FCFS takes the oldest.

use super::queue::{NIL, RequestQueues};
use crate::config::SchedulerKind;
use crate::engine::CLOSED;
use crate::spec::constraints::Cmd;
use rtsim_core::MemOp;

/// The command one bank offers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Candidate {
    pub cmd: Cmd,
    /// `cmd.kind()`, cached for the timing lookup.
    pub kind: u8,
    /// The request it serves.
    pub slot: u32,
    /// A column access to the open row.
    pub hit: bool,
    /// Age of the request (smaller = older).
    pub seq: u64,
    pub row: u32,
}

impl Candidate {
    /// `cmd` for the queued request in `slot`.
    #[inline]
    fn new(q: &RequestQueues, cmd: Cmd, slot: u32, hit: bool) -> Self {
        let e = q.get(slot);
        Candidate {
            cmd,
            kind: cmd.kind() as u8,
            slot,
            hit,
            seq: e.seq,
            row: e.row,
        }
    }

    /// Placeholder for banks without an offer.
    pub const NONE: Candidate = Candidate {
        cmd: Cmd::Act,
        kind: 0,
        slot: NIL,
        hit: false,
        seq: u64::MAX,
        row: CLOSED,
    };
}

/// Per-bank scheduler state.
#[derive(Clone, Copy, Debug)]
pub struct BankSched {
    /// Row hits served since the row was opened.
    pub streak: u32,
    /// The request the last PRE was issued for (gets the next ACT), or NIL.
    pub pre_target: u32,
}

impl Default for BankSched {
    fn default() -> Self {
        BankSched {
            streak: 0,
            pre_target: NIL,
        }
    }
}

/// The alternative offer of an open bank whose offer is a row hit: a PRE for the oldest request
/// that misses (FR-FCFS without row-hit protection), or `None`.
pub fn bank_alternative(
    q: &RequestQueues,
    b: usize,
    op: MemOp,
    open_row: u32,
) -> Option<Candidate> {
    let list = q.bank_list(op, b);
    let m = list.iter().copied().find(|&s| q.row(s) != open_row)?;
    Some(Candidate::new(q, Cmd::Pre, m, false))
}

/// The candidate of bank `b` when serving `op` requests, with `open_row` open (or CLOSED).
pub fn bank_candidate(
    kind: SchedulerKind,
    row_hit_cap: u32,
    st: &BankSched,
    q: &RequestQueues,
    b: usize,
    op: MemOp,
    open_row: u32,
) -> Option<Candidate> {
    let list = q.bank_list(op, b);
    let &first = list.first()?;
    let col = match op {
        MemOp::Read => Cmd::Rd,
        MemOp::Write => Cmd::Wr,
    };
    let offer = |cmd, slot, hit| Candidate::new(q, cmd, slot, hit);
    if open_row == CLOSED {
        let target = if st.pre_target != NIL && list.contains(&st.pre_target) {
            st.pre_target
        } else {
            first
        };
        return Some(offer(Cmd::Act, target, false));
    }
    match kind {
        SchedulerKind::Fcfs => {
            if q.row(first) == open_row {
                Some(offer(col, first, true))
            } else {
                Some(offer(Cmd::Pre, first, false))
            }
        }
        SchedulerKind::FrFcfs => {
            // The oldest hit and the oldest miss, in one pass.
            let (mut hit, mut miss) = (None, None);
            for &s in list {
                if q.row(s) == open_row {
                    if hit.is_none() {
                        hit = Some(s);
                        if miss.is_some() {
                            break;
                        }
                    }
                } else if miss.is_none() {
                    miss = Some(s);
                    if hit.is_some() {
                        break;
                    }
                }
            }
            match (hit, miss) {
                (Some(_), Some(m)) if m == first && row_hit_cap > 0 && st.streak >= row_hit_cap => {
                    // Starvation cap: the bank's oldest request wants another row; it gets its
                    // turn (DRAMsim3's rule, with its 4 column commands = the opening access
                    // plus a cap of 3 hits).
                    Some(offer(Cmd::Pre, m, false))
                }
                (Some(h), _) => Some(offer(col, h, true)),
                (None, Some(m)) => Some(offer(Cmd::Pre, m, false)),
                (None, None) => None,
            }
        }
    }
}

/// The priority of `c` under `kind`, smaller first: FR-FCFS orders by (not a hit, age), FCFS
/// by age. Ages (request sequence numbers) stay below 2^63, so the two FR-FCFS keys pack into
/// one word.
#[inline]
pub fn priority(kind: SchedulerKind, c: &Candidate) -> u64 {
    debug_assert!(c.seq < 1 << 63);
    match kind {
        SchedulerKind::FrFcfs => (u64::from(!c.hit) << 63) | c.seq,
        SchedulerKind::Fcfs => c.seq,
    }
}

/// Does `a` win over `b` under `kind`?
#[inline]
pub fn wins(kind: SchedulerKind, a: &Candidate, b: &Candidate) -> bool {
    priority(kind, a) < priority(kind, b)
}
