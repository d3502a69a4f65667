//! The timing engine of one channel: enforces the constraint table and tracks bank and rank
//! state (open rows, power-down).
//!
//! Issuing a command at cycle `t` raises "earliest allowed" times for every later command kind
//! at each level the table names (bank, bank group, rank, other ranks, channel) and records
//! activation windows (tFAW, t32AW) in per-rank rings. Bank commands' times are kept per bank
//! and per bank group, a rank's (and the channel's) rules raising every group of the ranks
//! they bind, so the earliest legal cycle of a bank command is the larger of two lookups — its
//! bank's and its group's (the [`Calendar`] the scheduler reads) — and of a rank command one. State rules (ACT
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
pub const BK: usize = 4;
/// Rank commands' kinds (REF, PDE, PDX): `BK..K`.
const RK: usize = K - BK;

/// Bank groups a channel can have: 16 ranks × 16 groups (`config::Organisation`'s limits).
const MAX_GROUPS: usize = 16 * 16;
/// Entries of the [`Calendar`].
pub const CALENDAR_LEN: usize = MAX_GROUPS * BK;
/// The earliest cycle of each bank-command kind `k` allowed by the rules shared by the banks of
/// flat bank group `g` (bank-group, rank, other-rank and channel rules, activation windows), at
/// `g × BK + k`. A fixed power-of-two size lets the scheduler index it without bounds checks.
pub type Calendar = [u64; CALENDAR_LEN];

/// The delays one issued command imposes, by scope and next-command kind (0 = none): the
/// table's rules for that command folded together (the largest delay per scope and kind), so
/// that issuing is a fixed pass over a few short arrays. For bank commands a rank rule raises
/// every group of the rank (`rank_groups`), an other-rank rule every group of the other ranks
/// (`other_groups`), and a channel rule both; with one bank group per rank the issuing rank's
/// only group is the issuing group, so its rank and channel rules are folded into `group`. Rank
/// commands' times are kept per rank (`rank`, `other_ranks`, channel rules in both). The
/// earliest times are maxima over the scopes, so folding changes none of them.
#[derive(Clone, Copy, Debug, Default)]
struct Delays {
    bank: [u32; BK],
    group: [u32; BK],
    rank_groups: [u32; BK],
    other_groups: [u32; BK],
    rank: [u32; RK],
    other_ranks: [u32; RK],
    /// The arrays above holding a delay (`SCOPE_*` bits): issuing skips the others.
    scopes: u8,
}

/// [`Delays::scopes`] bits.
const SCOPE_BANK: u8 = 1;
const SCOPE_GROUP: u8 = 2;
const SCOPE_RANK_GROUPS: u8 = 4;
const SCOPE_OTHER_GROUPS: u8 = 8;
const SCOPE_RANK: u8 = 16;
const SCOPE_OTHER_RANKS: u8 = 32;

/// An activation window: at most `window` ACTs in any `cycles` cycles of one rank.
#[derive(Clone, Debug)]
struct Window {
    window: usize,
    cycles: u64,
    /// Per rank (at `rank × window`), a ring of the earliest next ACT each of the last `window`
    /// ACTs allows (its time plus `cycles`); 0 where fewer ACTs have been issued, which allows
    /// any time.
    rings: Vec<u64>,
    heads: Vec<usize>,
}

/// Timing and state of one channel.
#[derive(Clone, Debug)]
pub struct Engine {
    ranks: usize,
    banks_per_rank: usize,
    /// Bank groups per rank (a power of two, `config::Organisation`).
    groups_per_rank: usize,
    /// Bank groups in the channel.
    groups: usize,
    /// Delays by issued command (RDA also gets RD's rules, WRA WR's), window rules excluded.
    by_prev: Vec<Delays>,
    windows: Vec<Window>,
    bank_next: Vec<[u64; BK]>,
    /// Bank commands' earliest times shared by each group's banks.
    calendar: Box<Calendar>,
    /// Rank commands' earliest times (kind − `BK`), channel rules included.
    rank_next: Vec<[u64; RK]>,
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
        let one_group = o.bank_groups == 1;
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
                    rings: vec![0; usize::from(c.window) * ranks],
                    heads: vec![0; ranks],
                });
                continue;
            }
            let k = c.next.kind();
            // Timing values are validated to at most 10^7 cycles, sums far below 2^32.
            let cycles = u32::try_from(c.cycles).unwrap_or(u32::MAX);
            let fold = |slot: &mut u32| *slot = (*slot).max(cycles);
            for issued in Cmd::ALL {
                if !c.prev.covers(issued) {
                    continue;
                }
                let d = &mut by_prev[issued as usize];
                if k >= BK {
                    // A rank command: rank-wide scopes only (asserted above).
                    let r = k - BK;
                    match c.scope {
                        Scope::Rank | Scope::BankGroup | Scope::Bank => fold(&mut d.rank[r]),
                        Scope::OtherRanks => fold(&mut d.other_ranks[r]),
                        Scope::Channel => {
                            fold(&mut d.rank[r]);
                            fold(&mut d.other_ranks[r]);
                        }
                    }
                    continue;
                }
                // The issuing rank's groups: with one group per rank, the issuing group.
                let own_rank = |d: &mut Delays| {
                    if one_group {
                        fold(&mut d.group[k]);
                    } else {
                        fold(&mut d.rank_groups[k]);
                    }
                };
                match c.scope {
                    Scope::Bank => fold(&mut d.bank[k]),
                    Scope::BankGroup => fold(&mut d.group[k]),
                    Scope::Rank => own_rank(d),
                    Scope::OtherRanks => fold(&mut d.other_groups[k]),
                    Scope::Channel => {
                        own_rank(d);
                        fold(&mut d.other_groups[k]);
                    }
                }
            }
        }
        for d in &mut by_prev {
            let bit = |delays: &[u32], scope: u8| {
                if delays.iter().any(|&x| x != 0) {
                    scope
                } else {
                    0
                }
            };
            let many_ranks = |scope: u8| if ranks > 1 { scope } else { 0 };
            d.scopes = bit(&d.bank, SCOPE_BANK)
                | bit(&d.group, SCOPE_GROUP)
                | bit(&d.rank_groups, SCOPE_RANK_GROUPS)
                | bit(&d.other_groups, many_ranks(SCOPE_OTHER_GROUPS))
                | bit(&d.rank, SCOPE_RANK)
                | bit(&d.other_ranks, many_ranks(SCOPE_OTHER_RANKS));
        }
        let groups = ranks * o.bank_groups as usize;
        assert!(
            groups <= MAX_GROUPS,
            "organisation validated to 16 x 16 groups"
        );
        Engine {
            ranks,
            banks_per_rank,
            groups_per_rank: o.bank_groups as usize,
            groups,
            by_prev,
            windows,
            bank_next: vec![[0; BK]; ranks * banks_per_rank],
            calendar: Box::new([0; CALENDAR_LEN]),
            rank_next: vec![[0; RK]; ranks],
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
        if cmd.is_rank_command() {
            self.rank_next[self.rank_of[b] as usize][k - BK]
        } else {
            self.bank_next[b][k].max(self.group_ready(k, self.group_of[b] as usize))
        }
    }

    /// The bank's own part of [`Engine::earliest`] for bank-command kind `k`: rules of bank
    /// scope only. It changes only when a command is issued to bank `b`.
    #[inline(always)]
    pub fn bank_ready(&self, k: usize, b: usize) -> u64 {
        self.bank_next[b][k]
    }

    /// The shared part of [`Engine::earliest`] for bank-command kind `k` at the banks of flat
    /// bank group `g`: `earliest(cmd, b) = max(bank_ready(k, b), group_ready(k,
    /// group_index(b)))`.
    #[inline(always)]
    pub fn group_ready(&self, k: usize, g: usize) -> u64 {
        self.calendar[(g * BK + k) % CALENDAR_LEN]
    }

    /// Every group's [`Engine::group_ready`], at `g × BK + k`.
    #[inline(always)]
    pub fn calendar(&self) -> &Calendar {
        &self.calendar
    }

    /// Flat bank-group index (rank × groups per rank + group) of flat bank `b`.
    #[inline(always)]
    pub fn group_index(&self, b: usize) -> usize {
        self.group_of[b] as usize
    }

    /// Bank groups in the channel (all ranks).
    pub fn groups(&self) -> usize {
        self.groups
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
    /// The caller has checked [`Engine::can_issue`]. The controller calls the per-kind
    /// methods below directly ([`Engine::issue_act`], [`Engine::issue_pre`],
    /// [`Engine::issue_column`]): each inlined where the kind is known, its delay passes and
    /// state change take no dispatch on the command.
    pub fn issue(&mut self, cmd: Cmd, b: usize, row: u32, t: u64) {
        match cmd {
            Cmd::Act => self.issue_act(b, row, t),
            Cmd::Pre => self.issue_pre(b, t),
            Cmd::Rd | Cmd::Wr | Cmd::Rda | Cmd::Wra => self.issue_column(cmd, b, row, t),
            Cmd::Ref | Cmd::Pde | Cmd::Pdx => self.issue_rank_command(cmd, b, t),
        }
    }

    /// ACT at flat bank `b`, opening `row`: [`Engine::issue`] for a known kind.
    #[inline(always)]
    pub fn issue_act(&mut self, b: usize, row: u32, t: u64) {
        debug_assert!(
            self.can_issue(Cmd::Act, b, row, t),
            "ACT at {t} on bank {b}"
        );
        let rank = self.raise_delays(Cmd::Act, b, t);
        let gpr = self.groups_per_rank;
        self.open_row[b] = row;
        self.act_time[b] = t;
        self.open_in_rank[rank] += 1;
        let act = Cmd::Act.kind();
        for w in &mut self.windows {
            let ring = &mut w.rings[rank * w.window..][..w.window];
            let head = &mut w.heads[rank];
            // `head` stays below `window`: an index, not a division.
            ring[*head] = t + w.cycles;
            *head = if *head + 1 == w.window { 0 } else { *head + 1 };
            // The oldest in the ring is the w-th most recent ACT: no ACT in the rank before it
            // plus the window's cycles (0 before w ACTs: no constraint).
            let at = ring[*head];
            for g in rank * gpr..(rank + 1) * gpr {
                raise(&mut self.calendar[(g * BK + act) % CALENDAR_LEN], at);
            }
        }
    }

    /// PRE at flat bank `b`: [`Engine::issue`] for a known kind.
    #[inline(always)]
    pub fn issue_pre(&mut self, b: usize, t: u64) {
        debug_assert!(self.can_issue(Cmd::Pre, b, 0, t), "PRE at {t} on bank {b}");
        let rank = self.raise_delays(Cmd::Pre, b, t);
        self.open_row[b] = CLOSED;
        self.open_in_rank[rank] -= 1;
    }

    /// A column command (RD, WR, RDA, WRA) at flat bank `b`: [`Engine::issue`] for a known
    /// kind; with auto-precharge the row closes.
    #[inline(always)]
    pub fn issue_column(&mut self, cmd: Cmd, b: usize, row: u32, t: u64) {
        debug_assert!(self.can_issue(cmd, b, row, t), "{cmd:?} at {t} on bank {b}");
        let rank = self.raise_delays(cmd, b, t);
        if matches!(cmd, Cmd::Rda | Cmd::Wra) {
            self.open_row[b] = CLOSED;
            self.open_in_rank[rank] -= 1;
        }
    }

    /// A rank command (REF, PDE, PDX) at the rank of flat bank `b`.
    fn issue_rank_command(&mut self, cmd: Cmd, b: usize, t: u64) {
        debug_assert!(self.can_issue(cmd, b, 0, t), "{cmd:?} at {t} on bank {b}");
        let rank = self.raise_delays(cmd, b, t);
        match cmd {
            Cmd::Pde => {
                self.powered_down[rank] = true;
                self.powered_down_count += 1;
            }
            Cmd::Pdx => {
                self.powered_down[rank] = false;
                self.powered_down_count -= 1;
            }
            _ => {}
        }
    }

    /// The delay passes of `cmd` issued at `t` at flat bank `b`: raise the times of every
    /// scope its rules name. Returns the bank's rank.
    #[inline(always)]
    fn raise_delays(&mut self, cmd: Cmd, b: usize, t: u64) -> usize {
        self.last_issue = Some(t);
        let rank = self.rank_of[b] as usize;
        let group = self.group_of[b] as usize;
        let d = &self.by_prev[cmd as usize];
        let gpr = self.groups_per_rank;
        if d.scopes & SCOPE_BANK != 0 {
            raise_all(&mut self.bank_next[b], &d.bank, t);
        }
        if d.scopes & SCOPE_GROUP != 0 {
            raise_all(group_mut(&mut self.calendar, group), &d.group, t);
        }
        if d.scopes & SCOPE_RANK_GROUPS != 0 {
            for g in rank * gpr..(rank + 1) * gpr {
                raise_all(group_mut(&mut self.calendar, g), &d.rank_groups, t);
            }
        }
        if d.scopes & SCOPE_OTHER_GROUPS != 0 {
            for g in (0..self.groups).filter(|&g| g / gpr != rank) {
                raise_all(group_mut(&mut self.calendar, g), &d.other_groups, t);
            }
        }
        if d.scopes & SCOPE_RANK != 0 {
            raise_all(&mut self.rank_next[rank], &d.rank, t);
        }
        if d.scopes & SCOPE_OTHER_RANKS != 0 {
            for r in (0..self.ranks).filter(|&r| r != rank) {
                raise_all(&mut self.rank_next[r], &d.other_ranks, t);
            }
        }
        rank
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

/// Group `g`'s entries of the calendar.
#[inline(always)]
fn group_mut(calendar: &mut Calendar, g: usize) -> &mut [u64; BK] {
    let at = (g % MAX_GROUPS) * BK;
    (&mut calendar[at..at + BK]).try_into().expect("BK entries")
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
