//! Request schedulers: which command each bank offers, and which offer wins.
//!
//! Every bank offers at most one command (its [`Candidate`]) from the requests of the queue
//! being served (reads, or writes in write-drain mode):
//! - closed bank: ACT for the request a precharge was issued for, else for the oldest;
//! - open bank, FR-FCFS: the column command of the oldest request hitting the open row; if there
//!   is none — or `row_hit_cap` hits have been served and the bank's oldest request wants
//!   another row — a PRE for the oldest request that misses;
//! - open bank, FCFS: the oldest request's command (column access if it hits, else PRE);
//! - USIMM's FCFS: closed bank, ACT for the oldest; open bank, the command of the older of its
//!   oldest hit and oldest miss, with the other as the *alternative* below — so the first
//!   issuable command of any request, in arrival order, wins (USIMM's `scheduler-fcfs.c`).
//!
//! With `protect_row_hits = false` (USIMM's FR-FCFS) an open bank whose offer is a row hit also
//! has an *alternative*: the PRE for its oldest missing request, considered when the hit cannot
//! issue this cycle.
//!
//! Among the candidates that are ready this cycle, FR-FCFS takes row hits first, then the
//! oldest; FCFS and USIMM's FCFS take the oldest.

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
    pub fn for_request(q: &RequestQueues, cmd: Cmd, slot: u32, hit: bool) -> Self {
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

/// The column command serving the request in `slot`.
#[inline]
fn column_cmd(q: &RequestQueues, slot: u32) -> Cmd {
    match q.get(slot).op {
        MemOp::Read => Cmd::Rd,
        MemOp::Write => Cmd::Wr,
    }
}

/// The oldest request of `list` hitting `open_row`.
#[inline]
fn oldest_hit(q: &RequestQueues, list: &[u32], open_row: u32) -> Option<u32> {
    list.iter().copied().find(|&s| q.row(s) == open_row)
}

/// The oldest request of `list` missing `open_row`.
#[inline]
fn oldest_miss(q: &RequestQueues, list: &[u32], open_row: u32) -> Option<u32> {
    list.iter().copied().find(|&s| q.row(s) != open_row)
}

/// The offer of bank `b` for the requests in `list` (oldest first; reads, writes or both),
/// with `open_row` open (or CLOSED), and its alternative: the command considered when the
/// offer cannot issue this cycle (USIMM's FCFS, and FR-FCFS/FCFS without row-hit protection).
/// Inlined into the controller's settling loop: its two offers then stay in registers.
#[inline]
pub fn bank_offers(
    kind: SchedulerKind,
    row_hit_cap: u32,
    protect_row_hits: bool,
    st: &BankSched,
    q: &RequestQueues,
    list: &[u32],
    open_row: u32,
) -> (Option<Candidate>, Option<Candidate>) {
    let Some(&first) = list.first() else {
        return (None, None);
    };
    let offer = |cmd, slot, hit| Some(Candidate::for_request(q, cmd, slot, hit));
    if open_row == CLOSED {
        // USIMM's FCFS: every request of a closed bank wants the same ACT; the oldest gets it.
        let target = if kind != SchedulerKind::UsimmFcfs
            && st.pre_target != NIL
            && list.contains(&st.pre_target)
        {
            st.pre_target
        } else {
            first
        };
        return (offer(Cmd::Act, target, false), None);
    }
    // The oldest hit and the oldest miss, each found only when needed: one of the two is the
    // first request, so a long list of hits (a stream) costs one look.
    let first_hits = q.row(first) == open_row;
    let hit = || {
        if first_hits {
            Some(first)
        } else {
            oldest_hit(q, list, open_row)
        }
    };
    let miss = || {
        if first_hits {
            oldest_miss(q, list, open_row)
        } else {
            Some(first)
        }
    };
    let pre_for_miss = |m| offer(Cmd::Pre, m, false);
    let primary = match kind {
        SchedulerKind::Fcfs => {
            if first_hits {
                offer(column_cmd(q, first), first, true)
            } else {
                pre_for_miss(first)
            }
        }
        SchedulerKind::FrFcfs => {
            if first_hits {
                offer(column_cmd(q, first), first, true)
            } else {
                match hit() {
                    // Starvation cap: the bank's oldest request (the first, a miss) wants
                    // another row; it gets its turn (DRAMsim3's rule, with its 4 column commands
                    // = the opening access plus a cap of 3 hits).
                    Some(_) if row_hit_cap > 0 && st.streak >= row_hit_cap => pre_for_miss(first),
                    Some(h) => offer(column_cmd(q, h), h, true),
                    None => pre_for_miss(first),
                }
            }
        }
        SchedulerKind::UsimmFcfs => {
            // The older of the oldest hit and the oldest miss first; the other one is the
            // alternative, so the first issuable command in arrival order wins.
            return if first_hits {
                (
                    offer(column_cmd(q, first), first, true),
                    miss().and_then(pre_for_miss),
                )
            } else {
                (
                    pre_for_miss(first),
                    hit().and_then(|h| offer(column_cmd(q, h), h, true)),
                )
            };
        }
    };
    // Without row-hit protection, a bank offering a hit may instead close the row for its
    // oldest miss when the hit cannot issue (USIMM 1.3's FR-FCFS second pass).
    let alt = match primary {
        Some(c) if c.hit && !protect_row_hits => miss().and_then(pre_for_miss),
        _ => None,
    };
    (primary, alt)
}

/// The priority of `c` under `kind`, smaller first: FR-FCFS orders by (not a hit, age), FCFS
/// and USIMM's FCFS by age. Ages (request sequence numbers) stay below 2^63, so the two FR-FCFS keys pack into
/// one word.
#[inline]
pub fn priority(kind: SchedulerKind, c: &Candidate) -> u64 {
    debug_assert!(c.seq < 1 << 63);
    match kind {
        SchedulerKind::FrFcfs => (u64::from(!c.hit) << 63) | c.seq,
        SchedulerKind::Fcfs | SchedulerKind::UsimmFcfs => c.seq,
    }
}

/// Does `a` win over `b` under `kind`?
#[inline]
pub fn wins(kind: SchedulerKind, a: &Candidate, b: &Candidate) -> bool {
    priority(kind, a) < priority(kind, b)
}
