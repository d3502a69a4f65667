//! Legality re-validation ("checking mode"): an independent, brute-force referee.
//!
//! The checker keeps its own model of each channel — the recent command history, open rows,
//! power-down state and data-bus occupancy — and checks every command the controller issues
//! against the constraint table by scanning that history: for each earlier command and each
//! rule relating the two, the distance must be at least the rule's delay; activation windows are
//! checked by counting ACTs. It also checks what the table only implies: one command per channel
//! per cycle, and that no two data bursts overlap on the bus. It shares nothing with the fast
//! engine but the table, so a bug in the engine's bookkeeping shows up as a violation.

use crate::engine::CLOSED;
use crate::spec::DramSpec;
use crate::spec::constraints::{Cmd, Constraint, Scope};
use std::collections::VecDeque;

#[derive(Clone, Copy, Debug)]
struct Issued {
    t: u64,
    cmd: Cmd,
    rank: usize,
    bank: usize,
    group: usize,
}

/// Referee for one channel.
#[derive(Clone, Debug)]
pub struct Checker {
    channel: u32,
    constraints: Vec<Constraint>,
    /// Pairwise rules indexed by [previous command][next command kind].
    pairwise: Vec<Vec<Vec<Constraint>>>,
    history: VecDeque<Issued>,
    horizon: u64,
    open_row: Vec<u32>,
    powered_down: Vec<bool>,
    /// Data bursts on the bus: [start, end).
    bursts: VecDeque<(u64, u64)>,
    banks_per_rank: usize,
    banks_per_group: usize,
    cl: u64,
    cwl: u64,
    burst: u64,
    /// Violations found (the first few are kept in full).
    pub violations: Vec<String>,
    pub violation_count: u64,
    pub commands_checked: u64,
}

const KEEP: usize = 20;

impl Checker {
    pub fn new(spec: &DramSpec, channel: u32) -> Self {
        let o = &spec.org;
        let horizon = spec.constraints.iter().map(|c| c.cycles).max().unwrap_or(0) + 1;
        let banks = (o.ranks * o.banks_per_rank) as usize;
        let mut pairwise = vec![vec![Vec::new(); Cmd::KINDS]; Cmd::ALL.len()];
        for c in spec
            .constraints
            .iter()
            .filter(|c| c.window == 1 && c.cycles > 0)
        {
            for issued in Cmd::ALL {
                if c.prev.covers(issued) {
                    pairwise[issued as usize][c.next.kind()].push(*c);
                }
            }
        }
        Checker {
            channel,
            constraints: spec.constraints.clone(),
            pairwise,
            history: VecDeque::new(),
            horizon,
            open_row: vec![CLOSED; banks],
            powered_down: vec![false; o.ranks as usize],
            bursts: VecDeque::new(),
            banks_per_rank: o.banks_per_rank as usize,
            banks_per_group: o.banks_per_group as usize,
            cl: spec.t.cl,
            cwl: spec.t.cwl,
            burst: spec.t.burst,
            violations: Vec::new(),
            violation_count: 0,
            commands_checked: 0,
        }
    }

    fn fail(&mut self, msg: String) {
        self.violation_count += 1;
        if self.violations.len() < KEEP {
            self.violations
                .push(format!("channel {}: {msg}", self.channel));
        }
    }

    /// Would `cmd` at cycle `t` on flat bank `b` (row `row`) be legal? Returns the reasons it
    /// is not (empty when legal). Does not record anything.
    pub fn judge(&self, cmd: Cmd, b: usize, row: u32, t: u64) -> Vec<String> {
        let mut why = Vec::new();
        let rank = b / self.banks_per_rank;
        let group = b / self.banks_per_group;
        if let Some(last) = self.history.back() {
            if t <= last.t {
                why.push(format!(
                    "{} at {t}: a command was already issued at {} (one per cycle)",
                    cmd.name(),
                    last.t
                ));
            }
        }
        // State.
        let rank_banks = rank * self.banks_per_rank..(rank + 1) * self.banks_per_rank;
        let state_ok = if self.powered_down[rank] {
            cmd == Cmd::Pdx
        } else {
            match cmd {
                Cmd::Act => self.open_row[b] == CLOSED,
                Cmd::Pre => self.open_row[b] != CLOSED,
                Cmd::Rd | Cmd::Wr | Cmd::Rda | Cmd::Wra => self.open_row[b] == row,
                Cmd::Ref => self.open_row[rank_banks].iter().all(|&r| r == CLOSED),
                Cmd::Pde => true,
                Cmd::Pdx => false,
            }
        };
        if !state_ok {
            why.push(format!(
                "{} at {t} on rank {rank} bank {}: illegal in the current state (open row {:?}, \
                 powered down {})",
                cmd.name(),
                b % self.banks_per_rank,
                (self.open_row[b] != CLOSED).then_some(self.open_row[b]),
                self.powered_down[rank]
            ));
        }
        // Pairwise rules.
        for h in &self.history {
            for c in &self.pairwise[h.cmd as usize][cmd.kind()] {
                let related = match c.scope {
                    Scope::Bank => h.rank == rank && h.bank == b,
                    Scope::BankGroup => h.rank == rank && h.group == group,
                    Scope::Rank => h.rank == rank,
                    Scope::OtherRanks => h.rank != rank,
                    Scope::Channel => true,
                };
                if related && t < h.t + c.cycles {
                    why.push(format!(
                        "{} at {t} violates `{}`: {} at {} needs {} cycles (rank {rank}, bank {})",
                        cmd.name(),
                        c.what,
                        h.cmd.name(),
                        h.t,
                        c.cycles,
                        b % self.banks_per_rank
                    ));
                }
            }
        }
        // Activation windows.
        if cmd == Cmd::Act {
            for c in self
                .constraints
                .iter()
                .filter(|c| c.window > 1 && c.cycles > 0)
            {
                let recent = self
                    .history
                    .iter()
                    .filter(|h| h.cmd == Cmd::Act && h.rank == rank && t < h.t + c.cycles)
                    .count();
                if recent >= usize::from(c.window) {
                    why.push(format!(
                        "ACT at {t} violates `{}`: {recent} ACTs in the last {} cycles",
                        c.what, c.cycles
                    ));
                }
            }
        }
        // Data bus.
        if cmd.is_column() {
            let start = t + if matches!(cmd, Cmd::Rd | Cmd::Rda) {
                self.cl
            } else {
                self.cwl
            };
            let end = start + self.burst;
            for &(s, e) in &self.bursts {
                if start < e && s < end {
                    why.push(format!(
                        "{} at {t}: data burst [{start}, {end}) overlaps [{s}, {e}) on the bus",
                        cmd.name()
                    ));
                }
            }
        }
        why
    }

    /// Check and record a command the controller issued.
    pub fn record(&mut self, cmd: Cmd, b: usize, row: u32, t: u64) {
        self.commands_checked += 1;
        for why in self.judge(cmd, b, row, t) {
            self.fail(why);
        }
        let rank = b / self.banks_per_rank;
        match cmd {
            Cmd::Act => self.open_row[b] = row,
            Cmd::Pre | Cmd::Rda | Cmd::Wra => self.open_row[b] = CLOSED,
            Cmd::Pde => self.powered_down[rank] = true,
            Cmd::Pdx => self.powered_down[rank] = false,
            _ => {}
        }
        if cmd.is_column() {
            let start = t + if matches!(cmd, Cmd::Rd | Cmd::Rda) {
                self.cl
            } else {
                self.cwl
            };
            self.bursts.push_back((start, start + self.burst));
            while self.bursts.len() > 64 {
                self.bursts.pop_front();
            }
        }
        self.history.push_back(Issued {
            t,
            cmd,
            rank,
            bank: b,
            group: b / self.banks_per_group,
        });
        while let Some(h) = self.history.front() {
            if h.t + self.horizon < t {
                self.history.pop_front();
            } else {
                break;
            }
        }
    }
}
