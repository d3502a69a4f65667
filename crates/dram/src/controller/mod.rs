//! The memory controller of one channel, simulated event by event at the memory clock.
//!
//! Each step handles one memory cycle `t`: requests arriving by `t` are admitted (forwarded,
//! merged or queued at their bank, see [`queue`]); due refreshes become pending ([`refresh`]);
//! the write-drain mode is updated (enter at the high watermark or when no read waits, leave at
//! the low watermark); then at most one command is issued, in this priority: power-down exit,
//! refresh preparation (PRE, REF), the scheduler's pick among the banks' ready candidates
//! ([`scheduler`]), power-down entry ([`power`]). The step ends by computing the next cycle at
//! which anything can happen — the earliest ready time of any candidate, arrival or refresh —
//! so idle cycles are skipped without changing the result: the outcome is identical to ticking
//! every cycle.

pub mod power;
pub mod queue;
pub mod refresh;
pub mod row_policy;
pub mod scheduler;

use crate::checker::Checker;
use crate::completions::CompletionQueue;
use crate::config::{
    BankArbitration, ControllerConfig, PowerDownKind, SchedulerKind, WriteDrainKind,
};
use crate::engine::{BK, CALENDAR_LEN, CLOSED, Calendar, Engine};
use crate::spec::DramSpec;
use crate::spec::Ratio;
use crate::spec::constraints::Cmd;
use crate::stats::{DramStats, TagStats};
use power::RankPower;
use queue::{Admit, Entry, NIL, QueuePolicy, RequestQueues};
use refresh::Refresh;
use rtsim_core::stats::Tally;
use rtsim_core::{MemCompletion, MemOp};
use scheduler::{BankSched, Candidate};

/// Latencies below this many cycles are tallied by value ([`Tally`]) and added to the
/// histograms when the books are closed: the histograms' exact range
/// ([`rtsim_core::stats::EXACT_LIMIT`]); longer ones are recorded directly.
const LATENCY_TALLY: usize = rtsim_core::stats::EXACT_LIMIT as usize;

/// What to issue this cycle.
#[derive(Clone, Copy, Debug)]
struct Choice {
    cmd: Cmd,
    bank: usize,
    row: u32,
    /// The request served, or NIL for refresh and power-down commands.
    slot: u32,
}

/// One channel: controller queues, scheduler state, the timing engine and the stats.
#[derive(Debug)]
pub struct Channel {
    pub index: u32,
    engine: Engine,
    q: RequestQueues,
    ctl: ControllerConfig,
    /// Each bank's offer, recomputed lazily for `dirty` banks.
    offers: Offers,
    /// Alternative offers: the command a bank offers when its offer cannot issue (USIMM's
    /// FCFS; PRE behind a row hit without row-hit protection). Used only when `use_alts`.
    alts: Offers,
    use_alts: bool,
    /// No alternatives, no command queues, and not `write_drain = mixed` (whose merged list an
    /// appended request may enter in the middle): then an appended request changes its bank's
    /// offer only in the ways [`Channel::append_keeps_offer`] checks, and a command often leaves
    /// the offer [`Channel::offer_after`] names.
    direct_offers: bool,
    /// A power-down policy or command queues: events beside arrivals, refresh due times and
    /// offers may come from [`Channel::rank_events`] even with no refresh pending and no rank
    /// powered down.
    rank_events_possible: bool,
    /// One requester tag: its counters are the channel's, copied by [`Channel::finish`]
    /// instead of counted twice.
    single_tag: bool,
    /// Scratch list for offers over reads and writes together (`write_drain = mixed`).
    merged_list: Vec<u32>,
    dirty: Vec<bool>,
    dirty_list: Vec<u32>,
    sched: Vec<BankSched>,
    refresh: Refresh,
    power: Vec<RankPower>,
    /// Cycle of the last command or arrival per rank (power-down idleness).
    last_busy: Vec<u64>,
    write_mode: bool,
    /// `write_drain = dramsim3`: writes still to move into command queues in this drain.
    drain_budget: u32,
    drain_since: u64,
    occ_since: u64,
    /// Earliest cycle at which something can happen (u64::MAX: nothing scheduled).
    next_event: u64,
    /// The earliest ready time of every offer and alternative as the last pass over them
    /// found it, while no offer and no calendar time has changed since; 0 otherwise. A step
    /// at an earlier cycle (an admission that left every offer as it was) then knows that
    /// nothing is ready without choosing.
    offers_min: u64,
    /// All cycles below this have been simulated.
    done_below: u64,
    banks_per_rank: usize,
    /// log2(`banks_per_rank`) (a power of two, `config::Organisation`): a bank's rank is a shift.
    rank_shift: u32,
    cl: u64,
    cwl: u64,
    burst: u64,
    rtp: u64,
    ras: u64,
    wr: u64,
    mem_to_req: Ratio,
    pub stats: DramStats,
    /// The latencies of `stats` below [`LATENCY_TALLY`] cycles, counted here and added to the
    /// histograms when the books are closed ([`Channel::finish`]): read and write, memory and
    /// requester clock.
    latency_tallies: [Tally; 4],
    pub checker: Option<Checker>,
}

impl Channel {
    pub fn new(spec: &DramSpec, index: u32) -> Self {
        let o = &spec.org;
        let ctl = spec.controller().clone();
        let banks = (o.ranks * o.banks_per_rank) as usize;
        let policy = QueuePolicy {
            read_capacity: ctl.read_queue,
            write_capacity: ctl.write_queue,
            merge_reads: ctl.merge_reads,
            merge_writes: ctl.merge_writes,
            forward_reads: ctl.forward_reads,
            admission_delay: ctl.admission_delay.into(),
            command_queue_depth: ctl.command_queue_depth,
        };
        let mut ch = Channel {
            index,
            engine: Engine::new(spec),
            q: RequestQueues::new(policy, banks, o.ranks as usize),
            offers: Offers::new(banks, o.banks_per_group as usize, ctl.bank_arbitration),
            alts: Offers::new(banks, o.banks_per_group as usize, ctl.bank_arbitration),
            use_alts: !ctl.protect_row_hits || ctl.scheduler == SchedulerKind::UsimmFcfs,
            direct_offers: ctl.protect_row_hits
                && ctl.scheduler != SchedulerKind::UsimmFcfs
                && ctl.command_queue_depth == 0
                && ctl.write_drain != WriteDrainKind::Mixed,
            single_tag: spec.tags == 1,
            rank_events_possible: ctl.power_down != PowerDownKind::Off
                || ctl.command_queue_depth > 0,
            merged_list: Vec::with_capacity(
                (ctl.read_queue + ctl.write_queue) as usize
                    + banks * ctl.command_queue_depth as usize,
            ),
            ctl,
            dirty: vec![true; banks],
            dirty_list: (0..banks as u32).collect(),
            sched: vec![BankSched::default(); banks],
            refresh: Refresh::new(spec),
            power: vec![RankPower::default(); o.ranks as usize],
            last_busy: vec![0; o.ranks as usize],
            write_mode: false,
            drain_budget: 0,
            drain_since: 0,
            occ_since: 0,
            next_event: u64::MAX,
            offers_min: 0,
            done_below: 0,
            banks_per_rank: o.banks_per_rank as usize,
            rank_shift: o.banks_per_rank.trailing_zeros(),
            cl: spec.t.cl,
            cwl: spec.t.cwl,
            burst: spec.t.burst,
            rtp: spec.t.rtp,
            ras: spec.t.ras,
            wr: spec.t.wr,
            mem_to_req: spec.mem_to_req,
            stats: DramStats {
                per_tag: vec![TagStats::default(); spec.tags as usize],
                ..DramStats::default()
            },
            latency_tallies: std::array::from_fn(|_| Tally::new(LATENCY_TALLY)),
            checker: spec.config.check.then(|| Checker::new(spec, index)),
        };
        ch.next_event = ch.compute_next_event(0);
        ch
    }

    /// Room for a request of kind `op`?
    #[inline]
    pub fn has_room(&self, op: MemOp) -> bool {
        self.q.has_room(op)
    }

    /// Accept a request (room checked by the caller). It arrives at `e.arrival_mem`, which is
    /// not before the first unsimulated cycle.
    pub fn enqueue(&mut self, e: Entry) {
        debug_assert!(e.arrival_mem >= self.done_below);
        match e.op {
            MemOp::Read => self.stats.reads += 1,
            MemOp::Write => self.stats.writes += 1,
        }
        if !self.single_tag {
            let tag = &mut self.stats.per_tag[e.tag as usize];
            match e.op {
                MemOp::Read => tag.reads += 1,
                MemOp::Write => tag.writes += 1,
            }
        }
        self.q.push_pending(e);
        self.next_event = self
            .next_event
            .min(e.arrival_mem + u64::from(self.ctl.admission_delay));
    }

    /// Count a refused request.
    pub fn refused(&mut self, op: MemOp, tag: u32) {
        self.refused_times(op, tag, 1);
    }

    /// Count `times` refusals of a request of kind `op` from `tag`.
    pub fn refused_times(&mut self, op: MemOp, tag: u32, times: u64) {
        if !self.single_tag {
            self.stats.per_tag[tag as usize].refused += times;
        }
        match op {
            MemOp::Read => self.stats.reads_refused += times,
            MemOp::Write => self.stats.writes_refused += times,
        }
    }

    /// Has requests queued or arriving.
    pub fn busy(&self) -> bool {
        !self.q.is_empty()
    }

    /// Earliest cycle at which the channel can change state (`u64::MAX` if never).
    #[inline]
    pub fn next_event(&self) -> u64 {
        self.next_event
    }

    /// Simulate every cycle up to and including `limit`; completions go to `out`.
    pub fn run_until(&mut self, limit: u64, out: &mut CompletionQueue) {
        while self.next_event <= limit {
            if self.skip_idle_refreshes(limit) {
                self.next_event = self.compute_next_event(self.done_below);
                continue;
            }
            let t = self.next_event;
            self.step(t, out);
        }
        self.done_below = self.done_below.max(limit + 1);
    }

    /// While the channel is idle (no request queued or arriving before `limit`, all banks
    /// closed, no refresh pending, no power-down policy), its only events are refreshes, each
    /// issued at its due time and leaving nothing behind once tRFC has passed. So all but the
    /// last due refresh of each rank up to `limit` are counted without being simulated; the last
    /// is simulated normally, which leaves exactly the state ticking would. Returns whether any
    /// refresh was skipped.
    #[inline]
    fn skip_idle_refreshes(&mut self, limit: u64) -> bool {
        if self.q.reads_arrived + self.q.writes_arrived > 0
            || !self.refresh.enabled
            || self.ctl.power_down != PowerDownKind::Off
        {
            return false;
        }
        let end = match self.q.next_arrival() {
            Some(a) if a <= limit => a.saturating_sub(1),
            _ => limit,
        };
        let period = self.refresh.period();
        let batch = u64::from(self.refresh.batch());
        let mut skipped = false;
        for r in 0..self.engine.ranks() {
            if self.refresh.pending[r] || self.engine.open_banks(r) > 0 {
                return skipped;
            }
        }
        for r in 0..self.engine.ranks() {
            let due = self.refresh.due[r];
            if due <= end {
                let n = (end - due) / period;
                if n > 0 {
                    self.refresh.skip(r, n);
                    self.stats.refreshes += n * batch;
                    skipped = true;
                }
            }
        }
        skipped
    }

    fn step(&mut self, t: u64, out: &mut CompletionQueue) {
        let mut admitted = false;
        while let Some(slot) = self.q.pop_arrived(t) {
            self.admit(slot, t, out);
            admitted = true;
        }
        if self.refresh.poll(t) {
            self.mark_all_dirty();
        }
        // The drain mode depends only on the numbers of arrived reads and writes, which change
        // only by admitting (here) and serving (followed by `update_mode` below): without an
        // admission the mode is already current.
        if admitted {
            self.update_mode(t);
        }
        if self.ctl.command_queue_depth > 0 {
            // One request per cycle into its bank's command queue: writes while draining.
            if let Some(b) = self.q.transfer(self.served_op()) {
                if self.write_mode && self.ctl.write_drain == WriteDrainKind::Dramsim3 {
                    self.drain_budget = self.drain_budget.saturating_sub(1);
                    self.update_mode(t);
                }
                self.mark_dirty(b);
            }
        }
        let (choice, offers_min) = if self.offers_min > t
            && !self.refresh.any_pending()
            && !self.engine.any_powered_down()
            && self.ctl.power_down == PowerDownKind::Off
        {
            // No offer has changed since the pass that found none ready before
            // `offers_min`, and no rank command is due: nothing to choose.
            (None, self.offers_min)
        } else {
            self.choose(t)
        };
        self.done_below = t + 1;
        if let Some(c) = choice {
            self.issue(c, t, out);
            // Serving a request (a column command) changes the queue lengths the drain mode
            // depends on; `write_drain = dramsim3` also looks at the command queues, which
            // requests enter between commands, so it is re-evaluated after every command.
            if c.cmd.is_column() || self.ctl.write_drain == WriteDrainKind::Dramsim3 {
                self.update_mode(t + 1);
            }
            self.settle_candidates();
            self.offers_min = self.offers_ready();
            self.next_event = self.next_event_from(t + 1, self.offers_min);
        } else {
            self.offers_min = offers_min;
            self.next_event = self.next_event_from(t + 1, offers_min);
        }
    }

    fn integrate_occupancy(&mut self, t: u64) {
        if t > self.occ_since {
            let dt = u128::from(t - self.occ_since);
            self.stats.read_queue_occupancy_sum += u128::from(self.q.reads_arrived) * dt;
            self.stats.write_queue_occupancy_sum += u128::from(self.q.writes_arrived) * dt;
            self.stats.occupancy_cycles += t - self.occ_since;
            self.occ_since = t;
        }
    }

    fn admit(&mut self, slot: u32, t: u64, out: &mut CompletionQueue) {
        // The queue lengths integrated over time change only by admitting and serving.
        self.integrate_occupancy(t);
        let e = *self.q.get(slot);
        self.last_busy[e.rank as usize] = t;
        match self.q.admit(slot) {
            Admit::Queued => {
                let b = e.bank as usize;
                if !self.append_keeps_offer(b, slot, e.op) {
                    match self.offer_for_only(b, slot, e.op) {
                        Some(o) if !self.dirty[b] => {
                            self.offers_min = 0;
                            self.offers
                                .set(b, Some(o), self.ctl.scheduler, &self.engine);
                        }
                        _ => self.mark_dirty(b),
                    }
                }
            }
            Admit::Staged => {}
            Admit::Merged(_) => match e.op {
                MemOp::Read => self.stats.reads_merged += 1,
                MemOp::Write => self.stats.writes_merged += 1,
            },
            Admit::Forwarded => {
                self.stats.reads_forwarded += 1;
                self.complete(&e, t + u64::from(self.ctl.forward_latency), out);
                self.q.release(slot, false);
            }
        }
        self.stats.read_queue_max = self.stats.read_queue_max.max(self.q.reads_arrived.into());
        self.stats.write_queue_max = self.stats.write_queue_max.max(self.q.writes_arrived.into());
    }

    /// Does bank `b` offer the same as before `slot` (of kind `op`) was appended to its list?
    /// Without alternatives, command queues or mixed drain (`direct_offers`), a bank's offer
    /// is a function of the first request of its served list, its open row, the oldest request
    /// of each list hitting that row, and its scheduler state (`BankSched`: the row-hit streak,
    /// which admitting does not change, and the request its last PRE was for). An appended
    /// request is the last of its list: when the list
    /// already held a request, it changes none of these unless it hits the open row or, at a
    /// closed bank, is the PRE's request; and a hit changes nothing where the bank already
    /// offers the column command of an older hit of the served kind. Otherwise the bank is
    /// recomputed as before.
    #[inline]
    fn append_keeps_offer(&self, b: usize, slot: u32, op: MemOp) -> bool {
        if !self.direct_offers || self.q.bank_list(op, b).len() < 2 {
            return false;
        }
        let open_row = self.engine.open_row(b);
        if open_row == CLOSED {
            return slot != self.sched[b].pre_target;
        }
        if self.q.row(slot) != open_row {
            return true;
        }
        let served_column = if self.write_mode { Cmd::Wr } else { Cmd::Rd };
        !self.dirty[b] && self.offers.offers_command(b, served_column)
    }

    /// The offer of bank `b` when `slot` (of kind `op`), just appended, is the only request of
    /// its served list (`direct_offers`, rank not blocked): at a closed bank the ACT for it, at
    /// an open bank its column command if it hits the row, else the PRE for it — where no
    /// request of the other kind waits at the bank (`write_drain = protect-rows` would serve
    /// one wanting the open row before a PRE). `None`: recompute from the lists.
    #[inline]
    fn offer_for_only(&self, b: usize, slot: u32, op: MemOp) -> Option<Candidate> {
        if !self.direct_offers || op != self.served_op() || self.q.bank_list(op, b).len() != 1 {
            return None;
        }
        if self.rank_blocked(b >> self.rank_shift) {
            return None;
        }
        let open_row = self.engine.open_row(b);
        let (cmd, hit) = if open_row == CLOSED {
            (Cmd::Act, false)
        } else if self.q.row(slot) == open_row {
            let column = match op {
                MemOp::Read => Cmd::Rd,
                MemOp::Write => Cmd::Wr,
            };
            (column, true)
        } else if self.ctl.write_drain == WriteDrainKind::ProtectRows
            && !match op {
                MemOp::Read => &self.q.writes[b],
                MemOp::Write => &self.q.reads[b],
            }
            .is_empty()
        {
            return None;
        } else {
            (Cmd::Pre, false)
        };
        Some(Candidate::for_request(&self.q, cmd, slot, hit))
    }

    /// The offer of bank `b` right after a command was issued there, where it follows from
    /// the command and the first request of the served list — its oldest, where the
    /// scheduler's ACT and PRE come from (`direct_offers`, rank not blocked):
    /// - after a PRE for the first request, the ACT for it (the bank's `pre_target`);
    /// - after an ACT for the first request, its column command (it hits the row just opened);
    /// - after a column command that leaves the row open, the column command of the first
    ///   request if that hits the row (an open bank whose oldest request hits offers that);
    ///   otherwise under FCFS the PRE for the first, under FR-FCFS the column command of the
    ///   oldest hit (unless the row-hit cap has been reached) or else the PRE for the first —
    ///   where no request of the other kind waits at the bank (`write_drain = protect-rows`
    ///   would serve one wanting the open row before a PRE);
    /// - after a column command with auto-precharge, the ACT for the first (the bank's
    ///   `pre_target` was cleared by the ACT);
    /// - with the served list empty, no offer.
    ///
    /// `None`: recompute from the lists. Each kind has its own method (`offer_after_pre`,
    /// `_act`, `_column`, `_rank`), called where the controller already knows the kind.
    /// This part is common to all: `Ok` the first request of the served list, or `Err` the
    /// answer (not direct, or the list is empty).
    #[inline(always)]
    fn offer_after_first(&self, b: usize) -> Result<u32, Option<Option<Candidate>>> {
        if !self.direct_offers || self.rank_blocked(b >> self.rank_shift) {
            return Err(None);
        }
        match self.served_list(b).first() {
            Some(&first) => Ok(first),
            None => Err(Some(None)),
        }
    }

    /// Bank `b`'s queue being served (writes in write-drain mode) and the other.
    #[inline(always)]
    fn served_list(&self, b: usize) -> &[u32] {
        if self.write_mode {
            &self.q.writes[b]
        } else {
            &self.q.reads[b]
        }
    }

    /// The column command serving the request in `slot`.
    #[inline(always)]
    fn column_cmd(&self, slot: u32) -> Cmd {
        match self.q.get(slot).op {
            MemOp::Read => Cmd::Rd,
            MemOp::Write => Cmd::Wr,
        }
    }

    /// [`Channel::offer_after_first`] after a PRE for the request in `slot`.
    #[inline(always)]
    fn offer_after_pre(&self, b: usize, slot: u32) -> Option<Option<Candidate>> {
        match self.offer_after_first(b) {
            Ok(first) if first == slot => Some(Some(Candidate::for_request(
                &self.q,
                Cmd::Act,
                first,
                false,
            ))),
            Ok(_) => None,
            Err(o) => o,
        }
    }

    /// [`Channel::offer_after_first`] after an ACT for the request in `slot`.
    #[inline(always)]
    fn offer_after_act(&self, b: usize, slot: u32) -> Option<Option<Candidate>> {
        match self.offer_after_first(b) {
            Ok(first) if first == slot => Some(Some(Candidate::for_request(
                &self.q,
                self.column_cmd(first),
                first,
                true,
            ))),
            Ok(_) => None,
            Err(o) => o,
        }
    }

    /// [`Channel::offer_after_first`] after a column command, with auto-precharge if
    /// `closed`.
    #[inline(always)]
    fn offer_after_column(&self, b: usize, closed: bool) -> Option<Option<Candidate>> {
        let first = match self.offer_after_first(b) {
            Ok(first) => first,
            Err(o) => return o,
        };
        if closed {
            return (self.sched[b].pre_target == NIL)
                .then(|| Some(Candidate::for_request(&self.q, Cmd::Act, first, false)));
        }
        let open_row = self.engine.open_row(b);
        let (offer, target) = if self.q.row(first) == open_row {
            (self.column_cmd(first), first)
        } else {
            let c = &self.ctl;
            let hit = match c.scheduler {
                SchedulerKind::FrFcfs
                    if c.row_hit_cap == 0 || self.sched[b].streak < c.row_hit_cap =>
                {
                    self.served_list(b)
                        .iter()
                        .copied()
                        .find(|&s| self.q.row(s) == open_row)
                }
                SchedulerKind::FrFcfs | SchedulerKind::Fcfs => None,
                SchedulerKind::UsimmFcfs => return None,
            };
            match hit {
                Some(h) => (self.column_cmd(h), h),
                None => {
                    let other = if self.write_mode {
                        &self.q.reads[b]
                    } else {
                        &self.q.writes[b]
                    };
                    if c.write_drain == WriteDrainKind::ProtectRows && !other.is_empty() {
                        return None;
                    }
                    return Some(Some(Candidate::for_request(
                        &self.q,
                        Cmd::Pre,
                        first,
                        false,
                    )));
                }
            }
        };
        Some(Some(Candidate::for_request(&self.q, offer, target, true)))
    }

    /// [`Channel::offer_after_first`] after a rank command (or a refresh's PRE): recompute,
    /// unless the served list is empty.
    #[inline]
    fn offer_after_rank(&self, b: usize) -> Option<Option<Candidate>> {
        match self.offer_after_first(b) {
            Err(o) => o,
            Ok(_) => None,
        }
    }

    #[inline]
    fn mark_dirty(&mut self, b: usize) {
        self.offers_min = 0;
        if !self.dirty[b] {
            self.dirty[b] = true;
            self.dirty_list.push(b as u32);
        }
    }

    fn mark_all_dirty(&mut self) {
        for b in 0..self.dirty.len() {
            self.mark_dirty(b);
        }
    }

    fn mark_rank_dirty(&mut self, rank: usize) {
        for b in rank * self.banks_per_rank..(rank + 1) * self.banks_per_rank {
            self.mark_dirty(b);
        }
    }

    /// Write-drain mode (USIMM's policy): enter at the high watermark or when no read waits,
    /// stay until the low watermark unless there is still nothing else to do.
    #[inline]
    fn update_mode(&mut self, t: u64) {
        if self.ctl.write_drain == WriteDrainKind::Dramsim3 {
            self.update_mode_dramsim3(t);
            return;
        }
        let wq = self.q.writes_arrived;
        let rq = self.q.reads_arrived;
        let want = if self.write_mode {
            wq > self.ctl.write_low_watermark
        } else {
            wq >= self.ctl.write_high_watermark
        } || (rq == 0 && wq > 0);
        if want != self.write_mode {
            self.switch_mode(want, t);
        }
    }

    /// `write_drain = dramsim3` (DRAMsim3's `ScheduleTransaction`): drain when the write queue
    /// (writes not yet in command queues) reaches the high watermark, or exceeds the low one
    /// while every command queue is empty; a drain moves as many writes into the command queues
    /// as the write queue held when it began. Also when no read is queued at all, so that the
    /// last writes are served (DRAMsim3 answers writes on acceptance and may leave up to the
    /// low watermark of them in its buffer indefinitely).
    #[inline(never)]
    fn update_mode_dramsim3(&mut self, t: u64) {
        let staged = self.q.staged_len(MemOp::Write);
        let want = if self.write_mode {
            self.drain_budget > 0 && staged > 0
        } else {
            staged >= self.ctl.write_high_watermark
                || (staged > self.ctl.write_low_watermark && self.q.in_cq_len() == 0)
                || (staged > 0 && self.q.reads_arrived == 0)
        };
        if want != self.write_mode {
            if want {
                self.drain_budget = staged;
            }
            self.switch_mode(want, t);
        }
    }

    /// Enter (`want`) or leave write-drain mode at `t`: the rare path of `update_mode`, kept
    /// out of line so that the per-step check inlines.
    #[inline(never)]
    fn switch_mode(&mut self, want: bool, t: u64) {
        if want {
            self.stats.write_drain_episodes += 1;
            self.drain_since = t;
        } else {
            self.stats.write_drain_cycles += t - self.drain_since;
        }
        self.write_mode = want;
        self.mark_all_dirty();
    }

    #[inline]
    fn rank_blocked(&self, rank: usize) -> bool {
        (self.refresh.any_pending() || self.engine.any_powered_down())
            && (self.refresh.pending[rank] || self.engine.is_powered_down(rank))
    }

    /// The kind of request being served: writes in write-drain mode, else reads.
    #[inline]
    fn served_op(&self) -> MemOp {
        if self.write_mode {
            MemOp::Write
        } else {
            MemOp::Read
        }
    }

    /// Recompute the offers of banks whose inputs changed.
    #[inline]
    fn settle_candidates(&mut self) {
        if !self.dirty_list.is_empty() {
            self.settle_dirty();
        }
    }

    /// [`Channel::settle_candidates`] when some bank is dirty.
    fn settle_dirty(&mut self) {
        while let Some(b) = self.dirty_list.pop() {
            let b = b as usize;
            self.dirty[b] = false;
            let rank = b >> self.rank_shift;
            let (offer, alt) = if self.rank_blocked(rank) {
                (None, None)
            } else {
                self.bank_offers(b)
            };
            let kind = self.ctl.scheduler;
            self.offers.set(b, offer, kind, &self.engine);
            if self.use_alts {
                self.alts.set(b, alt, kind, &self.engine);
            }
        }
    }

    /// Bank `b`'s offer and alternative for the requests being served.
    fn bank_offers(&mut self, b: usize) -> (Option<Candidate>, Option<Candidate>) {
        let open_row = self.engine.open_row(b);
        let c = &self.ctl;
        let offers = |q: &RequestQueues, list: &[u32], st: &BankSched| {
            scheduler::bank_offers(
                c.scheduler,
                c.row_hit_cap,
                c.protect_row_hits,
                st,
                q,
                list,
                open_row,
            )
        };
        let (served, other) = if self.write_mode {
            (&self.q.writes[b], &self.q.reads[b])
        } else {
            (&self.q.reads[b], &self.q.writes[b])
        };
        // Command queues: a bank holding only requests of the other kind serves those.
        // Otherwise a drain whose writes wait for room in banks full of reads (or reads
        // waiting behind banks full of writes) would wait forever; DRAMsim3 likewise serves
        // whatever its command queues hold.
        let (served, other) = if self.ctl.command_queue_depth > 0 && served.is_empty() {
            (other, served)
        } else {
            (served, other)
        };
        if c.write_drain == WriteDrainKind::ProtectRows {
            let (offer, alt) = offers(&self.q, served, &self.sched[b]);
            if open_row == CLOSED {
                return (offer, alt);
            }
            // A PRE would close a row that queued requests of the other kind want: serve the
            // oldest of those first instead (its own kind's column command).
            let Some(h) = other.iter().copied().find(|&s| self.q.row(s) == open_row) else {
                return (offer, alt);
            };
            let cmd = if self.write_mode { Cmd::Rd } else { Cmd::Wr };
            let protect = |c: Option<Candidate>| match c {
                Some(c) if c.cmd == Cmd::Pre => Some(Candidate::for_request(&self.q, cmd, h, true)),
                other => other,
            };
            let offer = protect(offer);
            let alt = protect(alt);
            // Both may now be the same request; keep one.
            let alt = if alt.map(|a| a.slot) == offer.map(|o| o.slot) {
                None
            } else {
                alt
            };
            return (offer, alt);
        }
        if !self.write_mode && c.write_drain != WriteDrainKind::Dramsim3 {
            return offers(&self.q, served, &self.sched[b]);
        }
        match c.write_drain {
            WriteDrainKind::ProtectRows => unreachable!("handled above"),
            WriteDrainKind::WritesOnly => offers(&self.q, served, &self.sched[b]),
            // Dramsim3: each bank's command queue in and out of drains.
            WriteDrainKind::Mixed | WriteDrainKind::Dramsim3 => {
                // Reads and writes of the bank together, oldest first.
                let (r, w) = (&self.q.reads[b], &self.q.writes[b]);
                self.merged_list.clear();
                let (mut i, mut j) = (0, 0);
                while i < r.len() || j < w.len() {
                    let take_read = j == w.len()
                        || (i < r.len() && self.q.get(r[i]).seq < self.q.get(w[j]).seq);
                    if take_read {
                        self.merged_list.push(r[i]);
                        i += 1;
                    } else {
                        self.merged_list.push(w[j]);
                        j += 1;
                    }
                }
                offers(&self.q, &self.merged_list, &self.sched[b])
            }
        }
    }

    fn wants_wake(&self, rank: usize) -> bool {
        self.q.per_rank[rank] > 0 || self.refresh.pending[rank]
    }

    fn may_power_down(&self, rank: usize) -> bool {
        self.ctl.power_down == PowerDownKind::Fast
            && !self.engine.is_powered_down(rank)
            && self.q.per_rank[rank] == 0
            && !self.refresh.pending[rank]
    }

    /// Pick the command to issue at `t`, if any is ready; with the earliest ready time of any
    /// bank's offer (`u64::MAX` if not scanned or none).
    fn choose(&mut self, t: u64) -> (Option<Choice>, u64) {
        let mut offers_min = u64::MAX;
        let c = self.choose_inner(t, &mut offers_min);
        (c, offers_min)
    }

    fn choose_inner(&mut self, t: u64, offers_min: &mut u64) -> Option<Choice> {
        let bpr = self.banks_per_rank;
        let ranks = self.engine.ranks();
        if self.refresh.any_pending() || self.engine.any_powered_down() {
            if let Some(c) = self.rank_command(t) {
                return Some(c);
            }
        }
        // Requests.
        self.settle_candidates();
        let alts = self.use_alts.then_some(&self.alts);
        let pick = self.offers.scan(alts, self.engine.calendar(), t);
        *offers_min = pick.min_ready;
        if let Some((b, alt)) = pick.best {
            if self.ctl.bank_arbitration == BankArbitration::RoundRobin {
                self.offers.turn_after(b);
                self.alts.turn_after(b);
            }
            let c = if alt {
                self.alts.cand[b]
            } else {
                self.offers.cand[b]
            };
            return Some(Choice {
                cmd: c.cmd,
                bank: b,
                row: c.row,
                slot: c.slot,
            });
        }
        // Power-down entry.
        if self.ctl.power_down == PowerDownKind::Off {
            return None;
        }
        for r in 0..ranks {
            if self.may_power_down(r)
                && t >= self.last_busy[r] + u64::from(self.ctl.power_down_idle)
                && self.engine.earliest(Cmd::Pde, r * bpr) <= t
            {
                return Some(Choice {
                    cmd: Cmd::Pde,
                    bank: r * bpr,
                    row: CLOSED,
                    slot: NIL,
                });
            }
        }
        None
    }

    /// Power-down exit or refresh preparation (PRE, then REF) ready at `t`: these come before
    /// requests.
    fn rank_command(&self, t: u64) -> Option<Choice> {
        let bpr = self.banks_per_rank;
        let ranks = self.engine.ranks();
        // Power-down exit.
        for r in 0..ranks {
            if self.engine.is_powered_down(r)
                && self.wants_wake(r)
                && self.engine.earliest(Cmd::Pdx, r * bpr) <= t
            {
                return Some(Choice {
                    cmd: Cmd::Pdx,
                    bank: r * bpr,
                    row: CLOSED,
                    slot: NIL,
                });
            }
        }
        // Refresh: precharge the rank, then REF.
        for r in 0..ranks {
            if !self.refresh.pending[r] || self.engine.is_powered_down(r) {
                continue;
            }
            if self.engine.open_banks(r) > 0 {
                for b in r * bpr..(r + 1) * bpr {
                    if self.engine.open_row(b) != CLOSED && self.engine.earliest(Cmd::Pre, b) <= t {
                        return Some(Choice {
                            cmd: Cmd::Pre,
                            bank: b,
                            row: CLOSED,
                            slot: NIL,
                        });
                    }
                }
            } else if self.engine.earliest(Cmd::Ref, r * bpr) <= t {
                return Some(Choice {
                    cmd: Cmd::Ref,
                    bank: r * bpr,
                    row: CLOSED,
                    slot: NIL,
                });
            }
        }
        None
    }

    /// Issue the choice `c` at `t`: one dispatch on its kind, whose branch then updates the
    /// engine, the stats and the bank's offer with the kind known.
    fn issue(&mut self, c: Choice, t: u64, out: &mut CompletionQueue) {
        let b = c.bank;
        let rank = b >> self.rank_shift;
        // The calendar and the bank's offer change.
        self.offers_min = 0;
        self.last_busy[rank] = t;
        let offer = match c.cmd {
            Cmd::Act => {
                self.engine.issue_act(b, c.row, t);
                self.record(Cmd::Act, b, c.row, t);
                self.stats.activates += 1;
                let e = self.q.get_mut(c.slot);
                e.act_for = true;
                match e.op {
                    MemOp::Read => self.stats.activates_for_reads += 1,
                    MemOp::Write => self.stats.activates_for_writes += 1,
                }
                self.sched[b] = BankSched::default();
                self.power[rank].open(t);
                self.offer_after_act(b, c.slot)
            }
            Cmd::Pre if c.slot != NIL => {
                self.engine.issue_pre(b, t);
                self.record(Cmd::Pre, b, c.row, t);
                self.stats.precharges += 1;
                self.q.get_mut(c.slot).pre_for = true;
                self.sched[b].pre_target = c.slot;
                self.power[rank].close(t);
                self.offer_after_pre(b, c.slot)
            }
            Cmd::Rd | Cmd::Wr => {
                let auto_close =
                    row_policy::auto_precharge(self.ctl.row_policy, &self.q, b, c.row, c.slot);
                let read = c.cmd == Cmd::Rd;
                let cmd = match (read, auto_close) {
                    (true, false) => Cmd::Rd,
                    (false, false) => Cmd::Wr,
                    (true, true) => Cmd::Rda,
                    (false, true) => Cmd::Wra,
                };
                let act_time = self.engine.act_time(b);
                self.engine.issue_column(cmd, b, c.row, t);
                self.record(cmd, b, c.row, t);
                self.column(c.slot, b, t, read, out);
                if auto_close {
                    self.stats.auto_precharges += 1;
                    let at = if read {
                        (t + self.rtp).max(act_time + self.ras)
                    } else {
                        (t + self.cwl + self.burst + self.wr).max(act_time + self.ras)
                    };
                    self.power[rank].close_at(t, at);
                }
                self.offer_after_column(b, auto_close)
            }
            _ => {
                self.issue_rank_command(c, t);
                self.offer_after_rank(b)
            }
        };
        match offer {
            Some(o) if !self.dirty[b] => {
                self.offers.set(b, o, self.ctl.scheduler, &self.engine);
            }
            _ => self.mark_dirty(b),
        }
        self.settle_candidates();
    }

    /// Tell the checker, if any, of a command issued.
    #[inline(always)]
    fn record(&mut self, cmd: Cmd, b: usize, row: u32, t: u64) {
        if let Some(ch) = &mut self.checker {
            ch.record(cmd, b, row, t);
        }
    }

    /// [`Channel::issue`] for a refresh's PRE (no request) and the rank commands.
    #[inline(never)]
    fn issue_rank_command(&mut self, c: Choice, t: u64) {
        let b = c.bank;
        let rank = b >> self.rank_shift;
        self.engine.issue(c.cmd, b, c.row, t);
        self.record(c.cmd, b, c.row, t);
        match c.cmd {
            Cmd::Pre => {
                self.stats.refresh_precharges += 1;
                self.power[rank].close(t);
            }
            Cmd::Ref => {
                self.stats.refreshes += 1;
                self.refresh.issued(rank);
                self.mark_rank_dirty(rank);
            }
            Cmd::Pde => {
                self.stats.power_downs += 1;
                self.power[rank].set_powered_down(t, true);
                self.mark_rank_dirty(rank);
            }
            Cmd::Pdx => {
                self.power[rank].set_powered_down(t, false);
                self.mark_rank_dirty(rank);
            }
            Cmd::Act | Cmd::Rd | Cmd::Wr | Cmd::Rda | Cmd::Wra => {
                unreachable!("request commands are issued by Channel::issue")
            }
        }
    }

    /// A column command for the request in `slot`: classify it, schedule its completion (and
    /// that of requests merged into it) and free its queue slots.
    fn column(&mut self, slot: u32, b: usize, t: u64, read: bool, out: &mut CompletionQueue) {
        self.integrate_occupancy(t);
        self.q.unlist(slot);
        let e = *self.q.get(slot);
        let s = &mut self.stats;
        let (hits, misses, conflicts) = if read {
            s.column_reads += 1;
            (
                &mut s.read_row_hits,
                &mut s.read_row_misses,
                &mut s.read_row_conflicts,
            )
        } else {
            s.column_writes += 1;
            (
                &mut s.write_row_hits,
                &mut s.write_row_misses,
                &mut s.write_row_conflicts,
            )
        };
        if !self.single_tag {
            let tag = &mut s.per_tag[e.tag as usize];
            tag.column_accesses += 1;
            tag.row_hits += u64::from(!e.act_for);
        }
        match (e.act_for, e.pre_for) {
            (false, _) => {
                *hits += 1;
                self.sched[b].streak += 1;
            }
            (true, false) => *misses += 1,
            (true, true) => *conflicts += 1,
        }
        s.data_bus_busy_cycles += self.burst;
        let finish = t + if read { self.cl } else { self.cwl } + self.burst;
        self.complete(&e, finish, out);
        let mut m = e.merged;
        while m != NIL {
            let child = *self.q.get(m);
            self.complete(&child, finish, out);
            self.q.release(m, true);
            m = child.next_merged;
        }
        self.q.release(slot, true);
    }

    /// Record the completion of request `e` at memory cycle `finish`.
    fn complete(&mut self, e: &Entry, finish: u64, out: &mut CompletionQueue) {
        let finish_req = self.mem_to_req.ceil(finish);
        let lat_mem = finish - e.arrival_mem;
        let lat_req = finish_req.saturating_sub(e.arrival_req);
        match e.op {
            MemOp::Read => {
                self.stats.reads_done += 1;
                let [mem, req, ..] = &mut self.latency_tallies;
                if !mem.record(lat_mem) {
                    self.stats.read_latency_mem.record(lat_mem);
                }
                if !req.record(lat_req) {
                    self.stats.read_latency_req.record(lat_req);
                }
                if !self.single_tag {
                    self.stats.per_tag[e.tag as usize]
                        .read_latency_req
                        .record(lat_req);
                }
            }
            MemOp::Write => {
                self.stats.writes_done += 1;
                let [.., mem, req] = &mut self.latency_tallies;
                if !mem.record(lat_mem) {
                    self.stats.write_latency_mem.record(lat_mem);
                }
                if !req.record(lat_req) {
                    self.stats.write_latency_req.record(lat_req);
                }
            }
        }
        out.push(MemCompletion {
            id: e.id,
            addr: e.req_addr,
            op: e.op,
            arrival: e.arrival_req,
            finish: finish_req,
            tag: e.tag,
        });
    }

    /// The earliest cycle ≥ `from` at which something can happen.
    fn compute_next_event(&mut self, from: u64) -> u64 {
        self.settle_candidates();
        self.exact_next_event(from)
    }

    /// [`Channel::compute_next_event`] with every offer settled.
    fn exact_next_event(&self, from: u64) -> u64 {
        self.next_event_from(from, self.offers_ready())
    }

    /// The earliest ready time of any offer or alternative (every offer settled).
    #[inline]
    fn offers_ready(&self) -> u64 {
        debug_assert!(self.dirty_list.is_empty());
        let alts = self.use_alts.then_some(&self.alts);
        let mut min = self.offers.min_ready(self.engine.calendar());
        if let Some(a) = alts {
            min = min.min(a.min_ready(self.engine.calendar()));
        }
        min
    }

    /// The earliest cycle ≥ `from` at which something can happen, given the earliest ready
    /// time of any offer.
    #[inline]
    fn next_event_from(&self, from: u64, offers_min: u64) -> u64 {
        let mut e = offers_min
            .min(self.q.next_arrival().unwrap_or(u64::MAX))
            .min(self.refresh.next_due().unwrap_or(u64::MAX));
        if self.rank_events_possible || self.refresh.any_pending() || self.engine.any_powered_down()
        {
            e = e.min(self.rank_events(from));
        }
        if e == u64::MAX { e } else { e.max(from) }
    }

    /// The earliest cycle ≥ `from` of a rank command (refresh preparation, power-down entry
    /// or exit) or a transfer into a command queue (`u64::MAX` if none): the rare part of
    /// [`Channel::next_event_from`], kept out of line.
    #[inline(never)]
    fn rank_events(&self, from: u64) -> u64 {
        let bpr = self.banks_per_rank;
        let mut e = u64::MAX;
        let rank_events = self.refresh.any_pending()
            || self.engine.any_powered_down()
            || self.ctl.power_down != PowerDownKind::Off;
        for r in 0..self.engine.ranks() {
            if !rank_events {
                break;
            }
            if self.engine.is_powered_down(r) {
                if self.wants_wake(r) {
                    e = e.min(self.engine.earliest(Cmd::Pdx, r * bpr));
                }
                continue;
            }
            if self.refresh.pending[r] {
                if self.engine.open_banks(r) > 0 {
                    for b in r * bpr..(r + 1) * bpr {
                        if self.engine.open_row(b) != CLOSED {
                            e = e.min(self.engine.earliest(Cmd::Pre, b));
                        }
                    }
                } else {
                    e = e.min(self.engine.earliest(Cmd::Ref, r * bpr));
                }
            } else if self.may_power_down(r) {
                let at = (self.last_busy[r] + u64::from(self.ctl.power_down_idle))
                    .max(self.engine.earliest(Cmd::Pde, r * bpr));
                e = e.min(at);
            }
        }
        if self.ctl.command_queue_depth > 0 && self.q.can_transfer(self.served_op()) {
            e = e.min(from);
        }
        e
    }

    /// Close the books at cycle `end` (exclusive): occupancy, write-drain time and background
    /// states are accounted up to `end`, and stats take the background cycles.
    pub fn finish(&mut self, end: u64) {
        self.integrate_occupancy(end);
        let [rm, rr, wm, wr] = &mut self.latency_tallies;
        rm.flush_into(&mut self.stats.read_latency_mem);
        rr.flush_into(&mut self.stats.read_latency_req);
        wm.flush_into(&mut self.stats.write_latency_mem);
        wr.flush_into(&mut self.stats.write_latency_req);
        if self.single_tag {
            let s = &mut self.stats;
            s.per_tag[0] = TagStats {
                reads: s.reads,
                writes: s.writes,
                refused: s.reads_refused + s.writes_refused,
                column_accesses: s.column_reads + s.column_writes,
                row_hits: s.read_row_hits + s.write_row_hits,
                read_latency_req: s.read_latency_req.clone(),
            };
        }
        if self.write_mode && end > self.drain_since {
            self.stats.write_drain_cycles += end - self.drain_since;
            self.drain_since = end;
        }
        let mut cycles = [0u64; 4];
        for p in &mut self.power {
            p.finish(end);
            for (a, b) in cycles.iter_mut().zip(p.cycles) {
                *a += b;
            }
        }
        self.stats.rank_cycles_precharge_standby = cycles[0];
        self.stats.rank_cycles_active_standby = cycles[1];
        self.stats.rank_cycles_precharge_power_down = cycles[2];
        self.stats.rank_cycles_active_power_down = cycles[3];
        self.stats.mem_cycles = self.stats.mem_cycles.max(end);
        if let Some(ch) = &self.checker {
            self.stats.commands_checked = ch.commands_checked;
            self.stats.violations = ch.violation_count;
        }
    }

    /// Violations found by the checker (empty when checking is off).
    pub fn violations(&self) -> &[String] {
        self.checker.as_ref().map_or(&[], |c| &c.violations)
    }

    /// Write-drain mode on?
    pub fn in_write_mode(&self) -> bool {
        self.write_mode
    }

    /// Arrived reads and writes in the queues.
    pub fn queue_lengths(&self) -> (u32, u32) {
        (self.q.reads_arrived, self.q.writes_arrived)
    }

    /// The timing engine (for inspection in tests).
    pub fn engine(&self) -> &Engine {
        &self.engine
    }
}

/// Stride of a bank group's entries in the engine's calendar of shared ready times (one per
/// bank-command kind, so that the scans over the entries have no gaps).
const SHARED_STRIDE: usize = BK;

/// One offer per bank: the candidate, and apart from it, packed for the scans, its priority,
/// the bank's own ready time for it and where its shared ready time is in the engine's
/// calendar. The banks offering are also filed by calendar entry (bank group and kind): a
/// bitmask of them and the smallest of their own ready times. An entry's offers are all ready
/// no earlier than the larger of that minimum and the shared time, so the earliest ready time
/// of all offers takes one look per entry, and choosing looks only at the banks of entries
/// that can be ready, instead of at every bank.
#[derive(Clone, Debug)]
struct Offers {
    cand: Vec<Candidate>,
    slots: Vec<OfferSlot>,
    /// The banks offering each calendar entry's kind, by calendar index.
    entries: Vec<CalendarOffers>,
    banks_per_group: usize,
    /// `bank_arbitration = round-robin`: every offer has the same priority, and among equals
    /// the first bank from `turn` on (cyclically) wins; `turn` is 0 otherwise (where no two
    /// offers have equal priority).
    round_robin: bool,
    turn: usize,
    /// Banks − 1 (a power of two minus one).
    bank_mask: usize,
    /// `bank_mask` under round robin, else 0: the part of a bank's position from `turn` in
    /// [`Offers::pick`]'s key.
    rr_mask: usize,
}

/// The offers of one calendar entry (a bank group and a kind).
#[derive(Clone, Copy, Debug)]
struct CalendarOffers {
    /// Bit `j`: bank `group × banks_per_group + j` offers the kind (at most 64 banks per group,
    /// `config::Organisation`'s limit).
    members: u64,
    /// The smallest `OfferSlot::local` among the members (`u64::MAX` if none).
    min_local: u64,
}

#[derive(Clone, Copy, Debug)]
struct OfferSlot {
    /// `Engine::bank_ready` for the offer's kind (`u64::MAX` where the bank has no offer). It
    /// changes only when the bank's offer changes or a command is issued to the bank, both of
    /// which re-set the offer.
    local: u64,
    /// [`scheduler::priority`] of the offer (smaller wins).
    priority: u64,
    /// Index of the offer's shared ready time in the calendar (`group × 4 + kind`).
    shared_at: usize,
}

impl OfferSlot {
    const NONE: OfferSlot = OfferSlot {
        local: u64::MAX,
        priority: u64::MAX,
        shared_at: 0,
    };

    /// The earliest cycle at which the offer is legal (`u64::MAX` if none).
    #[inline(always)]
    fn ready(&self, shared: &Calendar) -> u64 {
        self.local.max(shared[self.shared_at % CALENDAR_LEN])
    }
}

/// The result of a scan over the offers at cycle `t`.
#[derive(Clone, Copy, Debug)]
struct Pick {
    /// The ready offer of highest priority: its bank, and whether it is the alternative.
    best: Option<(usize, bool)>,
    /// The earliest ready time of any offer or alternative.
    min_ready: u64,
}

impl Offers {
    fn new(banks: usize, banks_per_group: usize, arbitration: BankArbitration) -> Self {
        let entries = banks / banks_per_group * SHARED_STRIDE;
        Offers {
            round_robin: arbitration == BankArbitration::RoundRobin,
            turn: 0,
            bank_mask: banks - 1,
            rr_mask: if arbitration == BankArbitration::RoundRobin {
                banks - 1
            } else {
                0
            },
            cand: vec![Candidate::NONE; banks],
            slots: vec![OfferSlot::NONE; banks],
            entries: vec![
                CalendarOffers {
                    members: 0,
                    min_local: u64::MAX,
                };
                entries
            ],
            banks_per_group,
        }
    }

    /// Bank `b` offers `c` (or nothing).
    #[inline(always)]
    fn set(&mut self, b: usize, c: Option<Candidate>, sched: SchedulerKind, engine: &Engine) {
        // Banks per group is a power of two (`config::Organisation`).
        let j = b & (self.banks_per_group - 1);
        let bit = 1u64 << j;
        let old = self.slots[b];
        if old.local != u64::MAX {
            // Leave the old entry; its minimum is recomputed if it was this bank's.
            let e = &mut self.entries[old.shared_at];
            e.members &= !bit;
            if old.local == e.min_local {
                let group = &self.slots[b - j..][..self.banks_per_group];
                let mut min = u64::MAX;
                let mut m = e.members;
                while m != 0 {
                    min = min.min(group[m.trailing_zeros() as usize % group.len()].local);
                    m &= m - 1;
                }
                e.min_local = min;
            }
        }
        self.slots[b] = match c {
            Some(c) => {
                let k = usize::from(c.kind);
                self.cand[b] = c;
                let slot = OfferSlot {
                    local: engine.bank_ready(k, b),
                    priority: if self.round_robin {
                        0
                    } else {
                        scheduler::priority(sched, &c)
                    },
                    shared_at: engine.group_index(b) * SHARED_STRIDE + k,
                };
                let e = &mut self.entries[slot.shared_at];
                e.members |= bit;
                e.min_local = e.min_local.min(slot.local);
                slot
            }
            None => OfferSlot::NONE,
        };
    }

    /// Round robin: bank `b` issued a request command; the next turn starts after it.
    #[inline]
    fn turn_after(&mut self, b: usize) {
        self.turn = (b + 1) & self.bank_mask;
    }

    /// Does bank `b` offer `cmd`?
    #[inline]
    fn offers_command(&self, b: usize, cmd: Cmd) -> bool {
        self.slots[b].local != u64::MAX && self.cand[b].cmd == cmd
    }

    /// The earliest ready time of any offer (`u64::MAX` if none): one look per calendar entry
    /// (an entry without members has `min_local = u64::MAX`).
    #[inline]
    fn min_ready(&self, shared: &Calendar) -> u64 {
        let mut min = u64::MAX;
        for (i, e) in self.entries.iter().enumerate() {
            min = min.min(e.min_local.max(shared[i % CALENDAR_LEN]));
        }
        min
    }

    /// The ready offer of highest priority at `t` among the entries' members (under round
    /// robin the first from `turn` on), offers whose bank's `primary` offer is ready excepted when given (an
    /// alternative yields to its bank's offer); `best` is updated in place, and the earliest
    /// ready time of all is returned.
    ///
    /// Which offers are ready depends on the data, so the pass avoids branching on it: per
    /// bank group, the members of its entries whose time has passed form one mask (a bank
    /// offers one kind, so the entries' members are disjoint), and a member replaces `best`
    /// by a selection on its key. (priority, position from `turn`) orders the banks totally,
    /// so the order of the visits does not change the pick.
    #[inline]
    fn pick(&self, primary: Option<&Offers>, shared: &Calendar, t: u64, best: &mut Best) -> u64 {
        let mut min = u64::MAX;
        // In registers for the pass.
        let Best {
            key: mut best_key,
            bank: mut best_bank,
            alt: mut best_alt,
        } = *best;
        for (g, group) in self.entries.chunks_exact(SHARED_STRIDE).enumerate() {
            let mut ready = 0u64;
            for (k, e) in group.iter().enumerate() {
                // No members: `min_local` is `u64::MAX`, never ready.
                let r = e
                    .min_local
                    .max(shared[(g * SHARED_STRIDE + k) % CALENDAR_LEN]);
                min = min.min(r);
                // The shared time has passed: the members whose own time has are ready.
                ready |= e.members & mask(r <= t);
            }
            let base = g * self.banks_per_group;
            while ready != 0 {
                let b = base + ready.trailing_zeros() as usize;
                ready &= ready - 1;
                let o = &self.slots[b];
                // Round robin: every priority is 0, and the first bank from `turn` on wins.
                // Otherwise the priorities of the offers and alternatives are distinct (each
                // serves its own request, and a request's age is its own), so they alone are
                // the key.
                let key = o.priority | (b.wrapping_sub(self.turn) & self.rr_mask) as u64;
                let ready = (o.local <= t) & primary.is_none_or(|p| p.slots[b].ready(shared) > t);
                debug_assert!(!ready || key != best_key, "two offers of equal priority");
                let take = ready & (key < best_key);
                let m = mask(take);
                best_key = (key & m) | (best_key & !m);
                best_bank = (b & m as usize) | (best_bank & !m as usize);
                best_alt = (take & primary.is_some()) | (!take & best_alt);
            }
        }
        *best = Best {
            key: best_key,
            bank: best_bank,
            alt: best_alt,
        };
        min
    }

    /// The ready offer of highest priority at `t` (under round robin the first bank from
    /// `turn` on), where an
    /// offer that cannot issue yields to its bank's alternative (`alts`), if that can; and the
    /// earliest ready time of all.
    #[inline]
    fn scan(&self, alts: Option<&Offers>, shared: &Calendar, t: u64) -> Pick {
        let mut best = Best {
            key: u64::MAX,
            bank: usize::MAX,
            alt: false,
        };
        let mut min = self.pick(None, shared, t, &mut best);
        if let Some(a) = alts {
            min = min.min(a.pick(Some(self), shared, t, &mut best));
        }
        Pick {
            best: (best.bank != usize::MAX).then_some((best.bank, best.alt)),
            min_ready: min,
        }
    }
}

/// The best offer so far in [`Offers::pick`]: its key (priority, or under round robin the
/// position from the turn; smaller wins), bank and whether it is an alternative.
#[derive(Clone, Copy, Debug)]
struct Best {
    key: u64,
    bank: usize,
    alt: bool,
}

/// All ones if `c`, else 0: for selections on data the branch predictor cannot learn. The
/// mask is hidden from the optimiser (an empty `asm!` that passes it through a register), which
/// would otherwise turn the selection back into a branch.
#[inline(always)]
fn mask(c: bool) -> u64 {
    #[allow(unused_mut)]
    let mut m = 0u64.wrapping_sub(u64::from(c));
    #[cfg(target_arch = "x86_64")]
    // SAFETY: the template is empty: `m` is left as it is, no memory, stack or flags touched.
    unsafe {
        std::arch::asm!("/* {0} */", inout(reg) m, options(pure, nomem, nostack, preserves_flags));
    }
    m
}
