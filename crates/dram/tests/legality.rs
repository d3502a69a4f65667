//! Legality: for every constraint of the table in every preset, the following command is refused
//! one cycle early and accepted on time.
//!
//! Each rule gets a scenario: the banks it relates are chosen by its scope (same bank, another
//! bank of the group, another group of the rank, another rank), brought into the states the two
//! commands need long before, then the rule's first command is issued and the engine is asked
//! for the earliest cycle of the second. The independent checker (brute force over the history)
//! must agree on that cycle, the engine must refuse it one cycle earlier, and the rule's own
//! delay must be what binds — unless another rule of the table is at least as strict for every
//! possible pair, which the test reports and checks against a short, explained list.

use rtsim_dram::config::{PRESETS, preset_config};
use rtsim_dram::engine::CLOSED;
use rtsim_dram::spec::constraints::{Cmd, Constraint, Scope};
use rtsim_dram::{Checker, DramSpec, Engine, Requester};

const ROW: u32 = 7;
const GAP: u64 = 100_000;

struct Bench {
    eng: Engine,
    chk: Checker,
    now: u64,
}

impl Bench {
    fn new(spec: &DramSpec) -> Self {
        Bench {
            eng: Engine::new(spec),
            chk: Checker::new(spec, 0),
            now: 1000,
        }
    }
    /// Issue `cmd` as early as legal at or after `self.now`; returns its cycle.
    fn asap(&mut self, cmd: Cmd, b: usize) -> u64 {
        assert!(
            self.eng.state_allows(cmd, b, ROW),
            "{cmd:?} on bank {b} not allowed by state"
        );
        let t = self
            .now
            .max(self.eng.earliest(cmd, b))
            .max(self.eng.last_issue().map_or(0, |l| l + 1));
        assert!(self.eng.can_issue(cmd, b, ROW, t));
        let why = self.chk.judge(cmd, b, ROW, t);
        assert!(why.is_empty(), "checker disagrees: {why:?}");
        self.eng.issue(cmd, b, ROW, t);
        self.chk.record(cmd, b, ROW, t);
        self.now = t + 1;
        t
    }
    fn wait(&mut self) {
        self.now += GAP;
    }
    /// First cycle ≥ from at which the checker allows `cmd`.
    fn checker_first_legal(&self, cmd: Cmd, b: usize, from: u64) -> u64 {
        (from..from + GAP)
            .find(|&t| self.chk.judge(cmd, b, ROW, t).is_empty())
            .expect("legal within the gap")
    }
}

/// Banks `(a, b)` a rule relates, as flat indices, or `None` if the preset has no such pair.
fn pick_banks(spec: &DramSpec, c: &Constraint) -> Option<(usize, usize)> {
    let o = &spec.org;
    let bpr = o.banks_per_rank as usize;
    let bpg = o.banks_per_group as usize;
    let other_in_group = if bpg > 1 { 1 } else { 0 };
    let other_group = if o.bank_groups > 1 { bpg } else { 1 };
    let other_rank = (o.ranks > 1).then_some(bpr);
    if c.next.is_rank_command() || c.prev.is_rank_command() {
        return Some((0, 0));
    }
    Some(match c.scope {
        Scope::Bank => (0, 0),
        Scope::BankGroup => (0, other_in_group),
        Scope::Rank => (0, other_group),
        Scope::OtherRanks => (0, other_rank?),
        Scope::Channel => (0, other_group),
    })
}

/// Outcome of one rule's scenario.
#[derive(Debug)]
struct Outcome {
    prev_at: u64,
    earliest: u64,
}

fn run_rule(spec: &DramSpec, c: &Constraint) -> Option<Outcome> {
    let (a, b) = pick_banks(spec, c)?;
    let bpr = spec.org.banks_per_rank as usize;
    let mut x = Bench::new(spec);
    // Setup, long before: open what the commands need.
    let next_needs_open = matches!(c.next, Cmd::Pre | Cmd::Rd | Cmd::Wr);
    let prev_needs_open = matches!(c.prev, Cmd::Pre | Cmd::Rd | Cmd::Wr | Cmd::Rda | Cmd::Wra);
    let prev_leaves_open = matches!(c.prev, Cmd::Act | Cmd::Rd | Cmd::Wr);
    if next_needs_open && !(b == a && prev_leaves_open) {
        x.asap(Cmd::Act, b);
    }
    if prev_needs_open && x.eng.open_row(a) == CLOSED {
        x.asap(Cmd::Act, a);
    }
    if c.prev == Cmd::Pdx {
        x.wait();
        x.asap(Cmd::Pde, a);
    }
    x.wait();
    let prev_at = x.asap(c.prev, a);
    // Fix the state the second command needs, as early as legal.
    if c.next == Cmd::Act && x.eng.open_row(b) != CLOSED {
        x.asap(Cmd::Pre, b);
    }
    if c.next == Cmd::Ref {
        let rank = b / bpr;
        for bank in rank * bpr..(rank + 1) * bpr {
            if x.eng.open_row(bank) != CLOSED {
                x.asap(Cmd::Pre, bank);
            }
        }
    }
    Some(finish(&mut x, c.next, b, prev_at))
}

/// Issue `w` ACTs to distinct banks (not `b`) of rank 0 as fast as legal, precharging banks
/// before reuse; the rule's reference is the first of the last `w` ACTs.
fn run_window(spec: &DramSpec, c: &Constraint) -> Outcome {
    let bpr = spec.org.banks_per_rank as usize;
    let b = bpr - 1;
    let mut x = Bench::new(spec);
    let mut acts = Vec::new();
    let used = bpr - 1;
    for i in 0..usize::from(c.window) {
        // Precharge the bank used half a round ago, so reuse never waits for tRP.
        let ahead = (i + used / 2) % used;
        if x.eng.open_row(ahead) != CLOSED && x.eng.earliest(Cmd::Pre, ahead) <= x.now {
            x.asap(Cmd::Pre, ahead);
        }
        let bank = i % used;
        if x.eng.open_row(bank) != CLOSED {
            x.asap(Cmd::Pre, bank);
        }
        acts.push(x.asap(Cmd::Act, bank));
    }
    let prev_at = acts[acts.len() - usize::from(c.window)];
    finish(&mut x, Cmd::Act, b, prev_at)
}

fn finish(x: &mut Bench, next: Cmd, b: usize, prev_at: u64) -> Outcome {
    assert!(
        x.eng.state_allows(next, b, ROW),
        "{next:?} state on bank {b}"
    );
    let e = x.eng.earliest(next, b).max(x.now);
    let by_checker = x.checker_first_legal(next, b, x.now);
    assert_eq!(e, by_checker, "engine and checker disagree on {next:?}");
    assert!(
        !x.eng.can_issue(next, b, ROW, e - 1),
        "accepted one cycle early"
    );
    assert!(x.eng.can_issue(next, b, ROW, e), "refused on time");
    Outcome {
        prev_at,
        earliest: e,
    }
}

/// Does scope `outer` contain every pair of banks `inner` relates?
fn contains(outer: Scope, inner: Scope) -> bool {
    use Scope::*;
    matches!(
        (outer, inner),
        (Channel, _)
            | (Rank, Rank | BankGroup | Bank)
            | (BankGroup, BankGroup | Bank)
            | (Bank, Bank)
            | (OtherRanks, OtherRanks)
    )
}

/// A rule that can never bind because another rule between the same commands covers every pair
/// it relates with a strictly longer delay (e.g. tCCD when a line takes two bursts).
fn dominated_by<'a>(spec: &'a DramSpec, c: &Constraint) -> Option<&'a Constraint> {
    spec.constraints.iter().find(|o| {
        o.window == 1
            && o.prev.covers(c.prev)
            && o.next.kind() == c.next.kind()
            && contains(o.scope, c.scope)
            && o.cycles > c.cycles
    })
}

#[test]
fn every_constraint_in_every_preset_is_enforced_on_time() {
    let mut tested = 0;
    let mut binding = 0;
    let mut report = Vec::new();
    let mut unexplained = Vec::new();
    for p in PRESETS {
        let mut cfg = preset_config(p.name).unwrap();
        cfg.refresh.enabled = false;
        let spec = DramSpec::new(&cfg, Requester::mhz(1000.0)).unwrap();
        for c in &spec.constraints {
            if c.cycles == 0 {
                report.push(format!("{}: `{}` is 0 cycles here", p.name, c.what));
                continue;
            }
            let out = if c.window > 1 {
                Some(run_window(&spec, c))
            } else {
                run_rule(&spec, c)
            };
            let Some(out) = out else {
                report.push(format!("{}: `{}` needs two ranks", p.name, c.what));
                continue;
            };
            tested += 1;
            let own = out.prev_at + c.cycles;
            assert!(
                out.earliest >= own,
                "{}: `{}` not enforced: allowed at {} < {}",
                p.name,
                c.what,
                out.earliest,
                own
            );
            if out.earliest == own {
                binding += 1;
            } else {
                match dominated_by(&spec, c) {
                    Some(o) => report.push(format!(
                        "{}: `{}` ({}) is dominated by `{}` ({})",
                        p.name, c.what, c.cycles, o.what, o.cycles
                    )),
                    None => unexplained.push(format!(
                        "{}: `{}` ({} cycles) does not bind: the next command waits {} cycles",
                        p.name,
                        c.what,
                        c.cycles,
                        out.earliest - out.prev_at
                    )),
                }
            }
        }
    }
    eprintln!(
        "{tested} constraints tested, {binding} binding\n{}",
        report.join("\n")
    );
    assert!(unexplained.is_empty(), "{}", unexplained.join("\n"));
    assert!(tested > 150, "{tested}");
    assert!(binding * 10 >= tested * 9, "{binding} of {tested} bind");
}

/// The table's delays for the default preset are the values the issue gives.
#[test]
fn gddr5_trax_delays_match_the_issue() {
    let spec = DramSpec::new(
        &preset_config("gddr5-trax").unwrap(),
        Requester::mhz(1000.0),
    )
    .unwrap();
    let delay = |what: &str| {
        spec.constraints
            .iter()
            .find(|c| c.what.starts_with(what))
            .unwrap_or_else(|| panic!("no rule `{what}`"))
            .cycles
    };
    assert_eq!(delay("RD after ACT, same bank"), 28);
    assert_eq!(delay("ACT after PRE, same bank"), 28);
    assert_eq!(delay("ACT to ACT, same bank"), 98);
    assert_eq!(delay("PRE after ACT, same bank"), 70);
    assert_eq!(delay("ACT to ACT, same rank"), 13);
    assert_eq!(delay("fifth ACT in a rank"), 80);
    assert_eq!(delay("PRE after WR, same bank"), 13 + 4 + 30);
    assert_eq!(delay("RD after WR, same rank"), 13 + 4 + 15);
    assert_eq!(delay("PRE after RD, same bank"), 15);
    assert_eq!(delay("RD to RD, same rank"), 4);
    assert_eq!(delay("REF to REF"), 220);
    assert_eq!(delay("WR after RD, any rank"), 28 + 4 + 2 - 13);
    assert_eq!(spec.t.burst, 4);
    assert_eq!(spec.t.refi, 15600);
}

/// The rules issue 12 added, each named: the second command is refused at `t − 1` and accepted
/// at `t`, the rule's own delay binds, and the independent checker agrees (inside `run_rule`).
#[test]
fn issue_12_rules_bind_at_their_delay() {
    // (preset, settings, rule, expected delay in memory cycles)
    type Case<'a> = (&'a str, &'a [(&'a str, u32)], &'a str, u64);
    let cases: [Case; 4] = [
        // GDDR5 tPPD: DRAMsim3's GDDR5_8Gb_x32 value, 5 tCK.
        ("gddr5-strata", &[], "PRE to PRE, same rank: tPPD", 5),
        (
            "gddr5-8gb-x32",
            &[("tPPD", 9)],
            "PRE to PRE, same rank: tPPD",
            9,
        ),
        // WR after WR to another rank: burst (4) + tRTRS (2) by default.
        ("ddr3-1600", &[], "WR to WR, other rank", 4 + 2),
        (
            "ddr3-1600",
            &[("tRTRS_W2W", 5)],
            "WR to WR, other rank",
            4 + 5,
        ),
    ];
    for (preset, sets, what, delay) in cases {
        let mut cfg = preset_config(preset).unwrap();
        cfg.refresh.enabled = false;
        for &(k, v) in sets {
            match k {
                "tPPD" => cfg.timing.t_ppd = v,
                "tRTRS_W2W" => cfg.timing.t_rtrs_w2w = Some(v),
                _ => unreachable!("{k}"),
            }
        }
        let spec = DramSpec::new(&cfg, Requester::mhz(1000.0)).unwrap();
        let c = spec
            .constraints
            .iter()
            .find(|c| c.what.starts_with(what))
            .unwrap_or_else(|| panic!("{preset}: no rule `{what}`"));
        assert_eq!(c.cycles, delay, "{preset}: `{what}`");
        let out = run_rule(&spec, c).expect("scenario");
        assert_eq!(
            out.earliest,
            out.prev_at + delay,
            "{preset}: `{what}` binds"
        );
    }
    // tRTRS_W2W = 0 (DRAMsim3): only the data burst separates writes to different ranks.
    let mut cfg = preset_config("ddr3-1600").unwrap();
    cfg.refresh.enabled = false;
    cfg.timing.t_rtrs_w2w = Some(0);
    let spec = DramSpec::new(&cfg, Requester::mhz(1000.0)).unwrap();
    let c = spec
        .constraints
        .iter()
        .find(|c| c.what.starts_with("WR to WR, any rank"))
        .unwrap();
    let mut other_rank = *c;
    other_rank.scope = Scope::OtherRanks;
    let out = run_rule(&spec, &other_rank).expect("scenario");
    assert_eq!(out.earliest, out.prev_at + 4);
}
