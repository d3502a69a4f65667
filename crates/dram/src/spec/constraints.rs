//! The timing constraints between DRAM commands, as one flat table of data.
//!
//! Each [`Rule`] reads "`next` after `prev`, in `scope`, at least `Σ plus − Σ minus` cycles
//! later" (Ramulator 2's style: "RD after ACT, same bank: nRCD"). A rule with `window = w > 1`
//! limits `prev` commands instead: the next one must come at least that long after the w-th most
//! recent one (tFAW: w = 4; GDDR5's t32AW: w = 32). The engine ([`crate::engine`]) enforces the
//! table; the checker ([`crate::checker`]) re-validates issued commands against it by brute
//! force. Scopes nest: a rule for a rank also binds banks of the same group and the same bank,
//! and the largest applicable delay wins.
//!
//! Auto-precharge commands (RDA, WRA) obey every RD/WR rule plus their own. Rank commands
//! (REF, PDE, PDX) appear only with rank-wide scopes.
//!
//! Sources: JESD79-3F (DDR3) and JESD79-4B (DDR4) command timing tables, JESD212 (GDDR5: tRCDWR,
//! t32AW, tCCDL, tPPD), and USIMM's derived constraints for the data bus (read-to-write
//! turnaround `CL + burst + tRTRS − CWL`, rank switch `burst + tRTRS`). The standards define
//! column spacing only within a rank; between ranks the rank switch is a system parameter
//! (tRTRS, and tRTRS_W2W between writes, see `config::Timing`).

use serde::Serialize;

/// A DRAM command.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize)]
pub enum Cmd {
    /// Activate (open) a row.
    Act,
    /// Precharge (close) one bank.
    Pre,
    /// Column read.
    Rd,
    /// Column write.
    Wr,
    /// Read with auto-precharge.
    Rda,
    /// Write with auto-precharge.
    Wra,
    /// All-bank refresh of one rank.
    Ref,
    /// Power-down entry (rank).
    Pde,
    /// Power-down exit (rank).
    Pdx,
}

impl Cmd {
    pub const ALL: [Cmd; 9] = [
        Cmd::Act,
        Cmd::Pre,
        Cmd::Rd,
        Cmd::Wr,
        Cmd::Rda,
        Cmd::Wra,
        Cmd::Ref,
        Cmd::Pde,
        Cmd::Pdx,
    ];
    /// Number of distinct kinds a command has as the *next* command (RDA/WRA check as RD/WR).
    pub const KINDS: usize = 7;

    /// Index of this command as the next command of a rule: RDA counts as RD, WRA as WR.
    #[inline]
    pub fn kind(self) -> usize {
        match self {
            Cmd::Act => 0,
            Cmd::Pre => 1,
            Cmd::Rd | Cmd::Rda => 2,
            Cmd::Wr | Cmd::Wra => 3,
            Cmd::Ref => 4,
            Cmd::Pde => 5,
            Cmd::Pdx => 6,
        }
    }
    /// Does a rule whose previous command is `self` apply when `issued` was issued?
    #[inline]
    pub fn covers(self, issued: Cmd) -> bool {
        self == issued
            || (self == Cmd::Rd && issued == Cmd::Rda)
            || (self == Cmd::Wr && issued == Cmd::Wra)
    }
    /// Commands addressed to a whole rank.
    pub fn is_rank_command(self) -> bool {
        matches!(self, Cmd::Ref | Cmd::Pde | Cmd::Pdx)
    }
    pub fn is_column(self) -> bool {
        matches!(self, Cmd::Rd | Cmd::Wr | Cmd::Rda | Cmd::Wra)
    }
    pub fn name(self) -> &'static str {
        match self {
            Cmd::Act => "ACT",
            Cmd::Pre => "PRE",
            Cmd::Rd => "RD",
            Cmd::Wr => "WR",
            Cmd::Rda => "RDA",
            Cmd::Wra => "WRA",
            Cmd::Ref => "REF",
            Cmd::Pde => "PDE",
            Cmd::Pdx => "PDX",
        }
    }
}

/// Which pairs of (previous, next) command targets a rule relates.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum Scope {
    /// Same rank and bank.
    Bank,
    /// Same rank and bank group (including the same bank).
    BankGroup,
    /// Same rank (any bank).
    Rank,
    /// A different rank of the same channel.
    OtherRanks,
    /// Anything on the channel.
    Channel,
}

/// A timing parameter, in memory cycles.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum Param {
    CL,
    CWL,
    RCD,
    RCDWR,
    RP,
    RAS,
    RC,
    RRD,
    RRDL,
    FAW,
    A32W,
    WR,
    WTR,
    WTRL,
    RTP,
    CCD,
    CCDL,
    RTRS,
    /// Rank switch between two writes (default tRTRS).
    RTRSW2W,
    /// GDDR5 precharge to precharge.
    PPD,
    RFC,
    XP,
    CKE,
    /// Data transfer time of one line (bursts per line × burst length / data rate).
    Burst,
    /// One cycle.
    One,
}

/// One row of the constraint table.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Rule {
    pub prev: Cmd,
    pub next: Cmd,
    pub scope: Scope,
    /// 1 for an ordinary rule; w > 1 for an activation window over the last w `prev` commands.
    pub window: u8,
    pub plus: &'static [Param],
    pub minus: &'static [Param],
    pub what: &'static str,
}

const fn r(
    prev: Cmd,
    next: Cmd,
    scope: Scope,
    plus: &'static [Param],
    minus: &'static [Param],
    what: &'static str,
) -> Rule {
    Rule {
        prev,
        next,
        scope,
        window: 1,
        plus,
        minus,
        what,
    }
}

use Cmd::*;
use Param::*;
use Scope::*;

/// The table. Every delay is in memory cycles of the standard being modelled.
pub const RULES: &[Rule] = &[
    // Same bank: row cycle.
    r(Act, Act, Bank, &[RC], &[], "ACT to ACT, same bank: tRC"),
    r(Act, Rd, Bank, &[RCD], &[], "RD after ACT, same bank: tRCD"),
    r(
        Act,
        Wr,
        Bank,
        &[RCDWR],
        &[],
        "WR after ACT, same bank: tRCDWR (= tRCD unless set)",
    ),
    r(
        Act,
        Pre,
        Bank,
        &[RAS],
        &[],
        "PRE after ACT, same bank: tRAS",
    ),
    r(Pre, Act, Bank, &[RP], &[], "ACT after PRE, same bank: tRP"),
    r(Rd, Pre, Bank, &[RTP], &[], "PRE after RD, same bank: tRTP"),
    r(
        Wr,
        Pre,
        Bank,
        &[CWL, Burst, WR],
        &[],
        "PRE after WR, same bank: CWL + burst + tWR",
    ),
    r(
        Rda,
        Act,
        Bank,
        &[RTP, RP],
        &[],
        "ACT after RDA, same bank: tRTP + tRP",
    ),
    r(
        Wra,
        Act,
        Bank,
        &[CWL, Burst, WR, RP],
        &[],
        "ACT after WRA, same bank: CWL + burst + tWR + tRP",
    ),
    // Same bank group.
    r(
        Act,
        Act,
        BankGroup,
        &[RRDL],
        &[],
        "ACT to ACT, same bank group: tRRD_L",
    ),
    r(
        Rd,
        Rd,
        BankGroup,
        &[CCDL],
        &[],
        "RD to RD, same bank group: tCCD_L",
    ),
    r(
        Wr,
        Wr,
        BankGroup,
        &[CCDL],
        &[],
        "WR to WR, same bank group: tCCD_L",
    ),
    r(
        Wr,
        Rd,
        BankGroup,
        &[CWL, Burst, WTRL],
        &[],
        "RD after WR, same bank group: CWL + burst + tWTR_L",
    ),
    // Same rank.
    r(Act, Act, Rank, &[RRD], &[], "ACT to ACT, same rank: tRRD"),
    Rule {
        prev: Act,
        next: Act,
        scope: Rank,
        window: 4,
        plus: &[FAW],
        minus: &[],
        what: "fifth ACT in a rank: tFAW after the fourth most recent",
    },
    Rule {
        prev: Act,
        next: Act,
        scope: Rank,
        window: 32,
        plus: &[A32W],
        minus: &[],
        what: "thirty-third ACT in a rank: t32AW after the 32nd most recent (GDDR5)",
    },
    r(Rd, Rd, Rank, &[CCD], &[], "RD to RD, same rank: tCCD"),
    r(Wr, Wr, Rank, &[CCD], &[], "WR to WR, same rank: tCCD"),
    r(
        Wr,
        Rd,
        Rank,
        &[CWL, Burst, WTR],
        &[],
        "RD after WR, same rank: CWL + burst + tWTR",
    ),
    r(
        Pre,
        Pre,
        Rank,
        &[PPD],
        &[],
        "PRE to PRE, same rank: tPPD (GDDR5, JESD212; 0 elsewhere)",
    ),
    r(Act, Ref, Rank, &[RC], &[], "REF after ACT, same rank: tRC"),
    r(Pre, Ref, Rank, &[RP], &[], "REF after PRE, same rank: tRP"),
    r(
        Rda,
        Ref,
        Rank,
        &[RTP, RP],
        &[],
        "REF after RDA, same rank: tRTP + tRP",
    ),
    r(
        Wra,
        Ref,
        Rank,
        &[CWL, Burst, WR, RP],
        &[],
        "REF after WRA, same rank: CWL + burst + tWR + tRP",
    ),
    r(
        Ref,
        Act,
        Rank,
        &[RFC],
        &[],
        "ACT after REF, same rank: tRFC",
    ),
    r(Ref, Ref, Rank, &[RFC], &[], "REF to REF, same rank: tRFC"),
    // Power-down (rank): enter only when the rank's data and recovery are done; exit costs tXP.
    r(Act, Pde, Rank, &[One], &[], "PDE after ACT: 1 cycle"),
    r(Pre, Pde, Rank, &[One], &[], "PDE after PRE: 1 cycle"),
    r(
        Rd,
        Pde,
        Rank,
        &[CL, Burst, One],
        &[],
        "PDE after RD: CL + burst + 1 (read data done)",
    ),
    r(
        Wr,
        Pde,
        Rank,
        &[CWL, Burst, WR],
        &[],
        "PDE after WR: CWL + burst + tWR (write recovered)",
    ),
    r(Ref, Pde, Rank, &[RFC], &[], "PDE after REF: tRFC"),
    r(
        Pde,
        Pdx,
        Rank,
        &[CKE],
        &[],
        "PDX after PDE: tCKE (minimum power-down time)",
    ),
    r(Pdx, Pde, Rank, &[CKE], &[], "PDE after PDX: tCKE"),
    r(Pdx, Act, Rank, &[XP], &[], "ACT after PDX: tXP"),
    r(Pdx, Pre, Rank, &[XP], &[], "PRE after PDX: tXP"),
    r(Pdx, Rd, Rank, &[XP], &[], "RD after PDX: tXP"),
    r(Pdx, Wr, Rank, &[XP], &[], "WR after PDX: tXP"),
    r(Pdx, Ref, Rank, &[XP], &[], "REF after PDX: tXP"),
    // The channel's data bus.
    r(
        Rd,
        Rd,
        Channel,
        &[Burst],
        &[],
        "RD to RD, any rank: burst (data bus)",
    ),
    r(
        Wr,
        Wr,
        Channel,
        &[Burst],
        &[],
        "WR to WR, any rank: burst (data bus)",
    ),
    r(
        Rd,
        Wr,
        Channel,
        &[CL, Burst, RTRS],
        &[CWL],
        "WR after RD, any rank: CL + burst + tRTRS - CWL",
    ),
    r(
        Rd,
        Rd,
        OtherRanks,
        &[Burst, RTRS],
        &[],
        "RD to RD, other rank: burst + tRTRS",
    ),
    r(
        Wr,
        Wr,
        OtherRanks,
        &[Burst, RTRSW2W],
        &[],
        "WR to WR, other rank: burst + tRTRS_W2W (= tRTRS unless set)",
    ),
    r(
        Wr,
        Rd,
        OtherRanks,
        &[CWL, Burst, RTRS],
        &[CL],
        "RD after WR, other rank: CWL + burst + tRTRS - CL",
    ),
];

/// A rule with its delay resolved for one configuration.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Constraint {
    pub prev: Cmd,
    pub next: Cmd,
    pub scope: Scope,
    pub window: u8,
    /// Minimum distance in memory cycles (negative sums saturate to 0).
    pub cycles: u64,
    pub what: &'static str,
}

/// Resolve the table against timing values (`value(p)` gives each parameter in cycles). Rules
/// whose delay is 0 can never bind and are kept with `cycles = 0`.
pub fn resolve(value: impl Fn(Param) -> u64) -> Vec<Constraint> {
    RULES
        .iter()
        .map(|rule| {
            let plus: u64 = rule.plus.iter().map(|&p| value(p)).sum();
            let minus: u64 = rule.minus.iter().map(|&p| value(p)).sum();
            Constraint {
                prev: rule.prev,
                next: rule.next,
                scope: rule.scope,
                window: rule.window,
                cycles: plus.saturating_sub(minus),
                what: rule.what,
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rank_commands_only_have_rank_wide_rules() {
        for rule in RULES {
            if rule.next.is_rank_command() || rule.prev.is_rank_command() {
                assert!(
                    matches!(rule.scope, Rank | OtherRanks | Channel),
                    "{}",
                    rule.what
                );
            }
        }
    }

    #[test]
    fn next_commands_are_plain_kinds() {
        // RDA/WRA check as RD/WR; rules name the plain command as `next`.
        for rule in RULES {
            assert!(!matches!(rule.next, Rda | Wra), "{}", rule.what);
        }
    }
}
