//! The timing engine of one channel: enforces the constraint table and tracks bank and rank
//! state (open rows, power-down).
//!
//! Issuing a command at cycle `t` raises "earliest allowed" times for every later command kind
//! at each level the table names (bank, bank group, rank, other ranks, channel) and records
//! activation windows (tFAW, t32AW) in per-rank rings. The earliest legal cycle of a command is
//! then the maximum of four lookups — O(1), which keeps the scheduler cheap. State rules (ACT
//! needs a closed bank, RD/WR the right open row, REF all banks closed, nothing but PDX while
//! powered down) are checked separately by [`Engine::state_allows`]. One command per channel
//! per cycle is the controller's rule; [`Engine::can_issue`] includes it.

use crate::spec::DramSpec;
use crate::spec::constraints::{Cmd, Scope};

/// Row number meaning "no row open".
pub const CLOSED: u32 = u32::MAX;
const K: usize = Cmd::KINDS;
/// Bank commands (ACT, PRE, RD, WR) have the kinds below this; rank commands above. Bank and
/// bank-group rules only ever name bank commands as the next command, so the per-bank and
/// per-group tables are this narrow (32 bytes per bank: cache-friendly scans).
const BK: usize = 4;

/// The delays one issued command imposes, by scope and next-command kind (0 = none): the
/// table's rules for that command folded together (the largest delay per scope and kind), so
/// that issuing is a fixed pass over a few short arrays. A channel rule is the same rule for
/// the issuing rank and every other rank, so it is folded into `rank` and `other_ranks`; with
/// one bank group per rank, a bank-group rule is a rank rule and is folded into `rank`. The
/// earliest times are maxima over the scopes, so folding changes none of them.
#[derive(Clone, Copy, Debug, Default)]
struct Delays {
    bank: [u32; BK],
    group: [u32; BK],
    rank: [u32; K],
    other_ranks: [u32; K],
    /// The arrays above holding a delay (`SCOPE_*` bits): issuing skips the others.
    scopes: u8,
}

/// [`Delays::scopes`] bits.
const SCOPE_BANK: u8 = 1;
const SCOPE_GROUP: u8 = 2;
const SCOPE_RANK: u8 = 4;
const SCOPE_OTHER_RANKS: u8 = 8;

/// An activation window: at most `window` ACTs in any `cycles` cycles of one rank.
#[derive(Clone, Debug)]
struct Window {
    window: usize,
    cycles: u64,
    /// Ring of the last `window` ACT times, per rank.
    rings: Vec<Vec<u64>>,
    heads: Vec<usize>,
    counts: Vec<usize>,
}

/// Timing and state of one channel.
#[derive(Clone, Debug)]
pub struct Engine {
    ranks: usize,
    banks_per_rank: usize,
    /// log2(bank groups per rank), a power of two (`config::Organisation`): a group's rank is
    /// a shift.
    group_shift: u32,
    /// Delays by issued command (RDA also gets RD's rules, WRA WR's), window rules excluded.
    by_prev: Vec<Delays>,
    windows: Vec<Window>,
    bank_next: Vec<[u64; BK]>,
    group_next: Vec<[u64; BK]>,
    /// Rank-level earliest times, channel rules included (folded into every rank's).
    rank_next: Vec<[u64; K]>,
    /// For each issued command, a bit per next-command kind whose earliest time it can raise
    /// beyond its own bank (bank group, rank, other ranks, channel, activation windows).
    shared_raise: Vec<u8>,
    /// Rank and bank-group index of each flat bank.
    rank_of: Vec<u32>,
    group_of: Vec<u32>,
    open_row: Vec<u32>,
    act_time: Vec<u64>,
    open_in_rank: Vec<u32>,
    powered_down: Vec<bool>,
    /// Ranks powered down.
    powered_down_count: usize,
    last_issue: Option<u64>,
}

impl Engine {
    pub fn new(spec: &DramSpec) -> Self {
        let o = &spec.org;
        let ranks = o.ranks as usize;
        let banks_per_rank = o.banks_per_rank as usize;
        let mut by_prev = vec![Delays::default(); Cmd::ALL.len()];
        let mut windows = Vec::new();
        let mut shared_raise = vec![0u8; Cmd::ALL.len()];
        for c in &spec.constraints {
            if c.cycles == 0 {
                continue; // can never bind
            }
            assert!(
                c.next.kind() < BK || !matches!(c.scope, Scope::Bank | Scope::BankGroup),
                "bank-level rule for a rank command: {}",
                c.what
            );
            if c.window > 1 {
                windows.push(Window {
                    window: usize::from(c.window),
                    cycles: c.cycles,
                    rings: vec![vec![0; usize::from(c.window)]; ranks],
                    heads: vec![0; ranks],
                    counts: vec![0; ranks],
                });
                continue;
            }
            let mut shared_raise_bits = 0u8;
            let k = c.next.kind();
            if c.scope != Scope::Bank {
                shared_raise_bits |= 1 << k;
            }
            // Timing values are validated to at most 10^7 cycles, sums far below 2^32.
            let cycles = u32::try_from(c.cycles).unwrap_or(u32::MAX);
            for issued in Cmd::ALL {
                if c.prev.covers(issued) {
                    let d = &mut by_prev[issued as usize];
                    let fold = |slot: &mut u32| *slot = (*slot).max(cycles);
                    match c.scope {
                        Scope::Bank => fold(&mut d.bank[k]),
                        Scope::BankGroup if o.bank_groups == 1 => fold(&mut d.rank[k]),
                        Scope::BankGroup => fold(&mut d.group[k]),
                        Scope::Rank => fold(&mut d.rank[k]),
                        Scope::OtherRanks => fold(&mut d.other_ranks[k]),
                        Scope::Channel => {
                            fold(&mut d.rank[k]);
                            fold(&mut d.other_ranks[k]);
                        }
                    }
                    shared_raise[issued as usize] |= shared_raise_bits;
                }
            }
        }
        if !windows.is_empty() {
            shared_raise[Cmd::Act as usize] |= 1 << Cmd::Act.kind();
        }
        for d in &mut by_prev {
            let bit = |delays: &[u32], scope: u8| {
                if delays.iter().any(|&x| x != 0) {
                    scope
                } else {
                    0
                }
            };
            d.scopes = bit(&d.bank, SCOPE_BANK)
                | bit(&d.group, SCOPE_GROUP)
                | bit(&d.rank, SCOPE_RANK)
                | if ranks > 1 {
                    bit(&d.other_ranks, SCOPE_OTHER_RANKS)
                } else {
                    0
                };
        }
        Engine {
            shared_raise,
            ranks,
            banks_per_rank,
            group_shift: o.bank_groups.trailing_zeros(),
            by_prev,
            windows,
            bank_next: vec![[0; BK]; ranks * banks_per_rank],
            group_next: vec![[0; BK]; ranks * o.bank_groups as usize],
            rank_next: vec![[0; K]; ranks],
            rank_of: (0..ranks * banks_per_rank)
                .map(|b| (b / banks_per_rank) as u32)
                .collect(),
            group_of: (0..ranks * banks_per_rank)
                .map(|b| {
                    let (r, k) = (b / banks_per_rank, b % banks_per_rank);
                    (r * o.bank_groups as usize + k / o.banks_per_group as usize) as u32
                })
                .collect(),
            open_row: vec![CLOSED; ranks * banks_per_rank],
            act_time: vec![0; ranks * banks_per_rank],
            open_in_rank: vec![0; ranks],
            powered_down: vec![false; ranks],
            powered_down_count: 0,
            last_issue: None,
        }
    }

    /// Flat bank index within the channel.
    #[inline]
    pub fn bank_index(&self, rank: u32, bank: u32) -> usize {
        rank as usize * self.banks_per_rank + bank as usize
    }

    /// Earliest cycle at which `cmd` satisfies every timing rule at flat bank `b` (for rank
    /// commands any bank of the rank). Ignores state and the one-command-per-cycle rule.
    #[inline]
    pub fn earliest(&self, cmd: Cmd, b: usize) -> u64 {
        let k = cmd.kind();
        let rank = self.rank_of[b] as usize;
        let mut t = self.rank_next[rank][k];
        if !cmd.is_rank_command() {
            t = t
                .max(self.bank_next[b][k])
                .max(self.group_next[self.group_of[b] as usize][k]);
        }
        t
    }

    /// [`Engine::earliest`] for a bank command given by its kind index (`Cmd::kind`).
    #[inline(always)]
    pub fn earliest_bank(&self, k: usize, b: usize) -> u64 {
        self.rank_next[self.rank_of[b] as usize][k]
            .max(self.bank_next[b][k])
            .max(self.group_next[self.group_of[b] as usize][k])
    }

    /// The bank's own part of [`Engine::earliest_bank`]: rules of bank scope only. It changes
    /// only when a command is issued to bank `b`.
    #[inline(always)]
    pub fn bank_ready(&self, k: usize, b: usize) -> u64 {
        self.bank_next[b][k]
    }

    /// The shared part of [`Engine::earliest_bank`] for the banks of flat bank group `g`: rules
    /// of bank-group, rank and channel scope (with other-rank rules and activation windows,
    /// which raise the rank's entries). `earliest_bank(k, b) = max(bank_ready(k, b),
    /// group_ready(k, group_index(b)))`; issuing a command changes it only for the kinds in
    /// [`Engine::shared_raise`].
    #[inline(always)]
    pub fn group_ready(&self, k: usize, g: usize) -> u64 {
        self.group_next[g][k].max(self.rank_next[g >> self.group_shift][k])
    }

    /// Flat bank-group index (rank × groups per rank + group) of flat bank `b`.
    #[inline(always)]
    pub fn group_index(&self, b: usize) -> usize {
        self.group_of[b] as usize
    }

    /// Bank groups in the channel (all ranks).
    pub fn groups(&self) -> usize {
        self.group_next.len()
    }

    /// Does the bank/rank state allow `cmd` (to `row`, for ACT and column commands)?
    pub fn state_allows(&self, cmd: Cmd, b: usize, row: u32) -> bool {
        let rank = b / self.banks_per_rank;
        if self.powered_down[rank] {
            return cmd == Cmd::Pdx;
        }
        match cmd {
            Cmd::Act => self.open_row[b] == CLOSED,
            Cmd::Pre => self.open_row[b] != CLOSED,
            Cmd::Rd | Cmd::Wr | Cmd::Rda | Cmd::Wra => {
                self.open_row[b] != CLOSED && self.open_row[b] == row
            }
            Cmd::Ref => self.open_in_rank[rank] == 0,
            Cmd::Pde => true,
            Cmd::Pdx => false,
        }
    }

    /// May `cmd` be issued at cycle `t`: state, timing and one command per cycle.
    pub fn can_issue(&self, cmd: Cmd, b: usize, row: u32, t: u64) -> bool {
        self.last_issue.is_none_or(|l| t > l)
            && self.state_allows(cmd, b, row)
            && t >= self.earliest(cmd, b)
    }

    /// Issue `cmd` at cycle `t` at flat bank `b` (any bank of the rank for rank commands).
    /// The caller has checked [`Engine::can_issue`].
    pub fn issue(&mut self, cmd: Cmd, b: usize, row: u32, t: u64) {
        debug_assert!(self.can_issue(cmd, b, row, t), "{cmd:?} at {t} on bank {b}");
        self.last_issue = Some(t);
        let rank = self.rank_of[b] as usize;
        let group = self.group_of[b] as usize;
        let d = &self.by_prev[cmd as usize];
        if d.scopes & SCOPE_BANK != 0 {
            raise_all(&mut self.bank_next[b], &d.bank, t);
        }
        if d.scopes & SCOPE_GROUP != 0 {
            raise_all(&mut self.group_next[group], &d.group, t);
        }
        if d.scopes & SCOPE_RANK != 0 {
            raise_all(&mut self.rank_next[rank], &d.rank, t);
        }
        if d.scopes & SCOPE_OTHER_RANKS != 0 {
            for r in (0..self.ranks).filter(|&r| r != rank) {
                raise_all(&mut self.rank_next[r], &d.other_ranks, t);
            }
        }
        match cmd {
            Cmd::Act => {
                self.open_row[b] = row;
                self.act_time[b] = t;
                self.open_in_rank[rank] += 1;
                let act = Cmd::Act.kind();
                for w in &mut self.windows {
                    let ring = &mut w.rings[rank];
                    let head = &mut w.heads[rank];
                    ring[*head] = t;
                    *head = (*head + 1) % w.window;
                    w.counts[rank] = (w.counts[rank] + 1).min(w.window);
                    if w.counts[rank] == w.window {
                        // The oldest in the ring is the w-th most recent ACT.
                        raise(&mut self.rank_next[rank][act], ring[*head] + w.cycles);
                    }
                }
            }
            Cmd::Pre | Cmd::Rda | Cmd::Wra => {
                self.open_row[b] = CLOSED;
                self.open_in_rank[rank] -= 1;
            }
            Cmd::Pde => {
                self.powered_down[rank] = true;
                self.powered_down_count += 1;
            }
            Cmd::Pdx => {
                self.powered_down[rank] = false;
                self.powered_down_count -= 1;
            }
            Cmd::Rd | Cmd::Wr | Cmd::Ref => {}
        }
    }

    /// Kinds (bit `1 << kind`) whose earliest time at banks other than its own issuing `cmd`
    /// may raise: the scheduler recomputes only offers of these kinds after an issue.
    #[inline]
    pub fn shared_raise(&self, cmd: Cmd) -> u8 {
        self.shared_raise[cmd as usize]
    }

    /// The open row of flat bank `b`, or [`CLOSED`].
    #[inline]
    pub fn open_row(&self, b: usize) -> u32 {
        self.open_row[b]
    }

    /// Cycle of the last ACT to flat bank `b`.
    #[inline]
    pub fn act_time(&self, b: usize) -> u64 {
        self.act_time[b]
    }

    /// Number of open banks in `rank`.
    #[inline]
    pub fn open_banks(&self, rank: usize) -> u32 {
        self.open_in_rank[rank]
    }

    /// Is any rank powered down?
    #[inline]
    pub fn any_powered_down(&self) -> bool {
        self.powered_down_count > 0
    }

    #[inline]
    pub fn is_powered_down(&self, rank: usize) -> bool {
        self.powered_down[rank]
    }

    /// Cycle of the last command issued on the channel.
    pub fn last_issue(&self) -> Option<u64> {
        self.last_issue
    }

    pub fn banks_per_rank(&self) -> usize {
        self.banks_per_rank
    }

    pub fn ranks(&self) -> usize {
        self.ranks
    }
}

/// Raise each `next[k]` to `t + delay[k]` where the delay is not 0 (no rule).
#[inline(always)]
fn raise_all<const N: usize>(next: &mut [u64; N], delay: &[u32; N], t: u64) {
    for (n, &d) in next.iter_mut().zip(delay) {
        if d != 0 {
            raise(n, t + u64::from(d));
        }
    }
}

#[inline]
fn raise(slot: &mut u64, at: u64) {
    if at > *slot {
        *slot = at;
    }
}
