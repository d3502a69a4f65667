//! [`Chip`]: the TRaX chip's state shared by both timing engines — the TPs (their instruction
//! streams, scoreboards and priority keys), the functional work they run, the cache hierarchy
//! with the DRAM behind it, the atomic pixel counter — and the operations whose effect does
//! not depend on the engine: performing a data-cache or atomic access, applying a completed
//! miss, issuing an instruction, attributing a stall cycle.
//!
//! The engines ([`crate::fast`], [`crate::reference`]) differ only in how they find the cycle
//! each instruction issues: the reference looks at every TP every cycle; the fast engine
//! books issue slots ahead in per-TM calendars and jumps between synchronisation points. The
//! rules they both implement are in `docs/TRAX.md` ("Timing rules").

use crate::config::TraxConfig;
use crate::isa::{CLASSES, Class, Inst, Mem, NO_REG, UNIT_CLASSES};
use crate::program::{Program, Run};
use crate::source::{Source, SourceAccess, TraxSource};
use crate::stats::{IssueStats, Stall};
use crate::timeline::Sampler;
use crate::work::PixelDone;
use rtsim_cache::{Completion, Hierarchy, HierarchyError, Outcome, Request, Topology};
use rtsim_config::ConfigError;
use rtsim_core::{Clock, MemOp, Vec3};
use rtsim_dram::{Dram, DramConfig, Requester};
use rtsim_trace::{FrameStats, PixelResult};

/// Why a chip could not be built or run.
#[derive(Debug, thiserror::Error)]
pub enum ChipError {
    #[error(transparent)]
    Config(#[from] ConfigError),
    #[error("cache hierarchy: {0}")]
    Hierarchy(#[from] HierarchyError),
    #[error("starting the engine's threads: {0}")]
    Threads(String),
}

/// A decoded instruction, as the engines read it.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Dec {
    pub class: Class,
    pub dst: u8,
    /// Instruction-cache bank of the instruction.
    pub bank: u8,
    /// Registers read or written (sources and destination).
    pub regs: u32,
    pub mem: Mem,
    /// Register-file reads and writes.
    pub rf: (u8, u8),
    /// `Inst::deps`: more registers waited for (and, for a stream load, filled).
    pub deps: u32,
    /// `class.is_unit()` and `class.is_sync()`, decoded once (the engines ask per issue).
    pub unit: bool,
    pub sync: bool,
}

fn bit(r: u8) -> u32 {
    if r == NO_REG { 0 } else { 1 << r }
}

impl Dec {
    fn new(i: &Inst, banks: u32) -> Dec {
        let (r, w) = i.register_accesses();
        Dec {
            class: i.class,
            dst: i.dst,
            bank: ((i.pc / crate::isa::INST_BYTES) % banks) as u8,
            regs: bit(i.src[0]) | bit(i.src[1]) | bit(i.dst) | i.deps,
            mem: i.mem,
            rf: (r as u8, w as u8),
            deps: i.deps,
            unit: i.class.is_unit(),
            sync: i.class.is_sync(),
        }
    }
}

/// What a TP is waiting for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Wait {
    /// Nothing outside itself: its next instruction issues when operands and slots allow.
    Ready,
    /// Its current instruction is a data-cache or atomic access, fetched, to be offered to
    /// the cache (or counter) at `Core::access_at`.
    Access,
    /// Its current instruction reads or writes a register whose miss has not returned.
    Blocked,
    Halted,
}

/// One TP's timing state, hot fields first (four cache lines).
#[derive(Clone, Debug)]
#[repr(C, align(64))]
pub(crate) struct Core {
    /// Earliest cycle of the next instruction (in order, single issue; after a branch, its
    /// resolution).
    pub next_issue: u64,
    /// Priority key: the cycle of the TP's last synchronisation (see `docs/TRAX.md`).
    pub key: u64,
    /// Register ready cycles are `base + ready[r]` (see [`Core::ready_at`]).
    base: u64,
    /// The cycle the pending access is offered to the cache (first try or retry).
    pub access_at: u64,
    /// Registers waiting for a miss.
    pub pending: u32,
    /// Registers last written by a data-cache load (a wait on them is a memory stall).
    pub from_mem: u32,
    /// Registers whose value came from a miss (their completion cycles are in
    /// [`Chip::miss_done`]).
    pub missed: u32,
    pub ip: u32,
    pub tm: u32,
    /// First column of its instruction cache's banks in a calendar row.
    pub icache_col: u32,
    /// Its instruction cache within its TM (`tp % tps_per_tm % icaches_per_tm`, kept so the
    /// engines do not divide for it at every turn).
    pub icache: u32,
    pub wait: Wait,
    /// Cycle each register's value can be read, relative to `base`.
    ready: [u32; 32],
    pub run: Run,
    pub halted_at: u64,
    /// The pixel in progress and the cycle its `atominc` returned it.
    pub pixel: Option<u32>,
    pub pixel_since: u64,
}

// The hot fields share the first cache line; the whole state is four.
const _: () = assert!(std::mem::size_of::<Core>() == 256);

impl Core {
    /// The cycle register `r` can be read (meaningless while it waits for a miss).
    #[inline(always)]
    pub fn ready_at(&self, r: usize) -> u64 {
        self.base + self.ready[r] as u64
    }

    /// Register `r` is readable from cycle `v` (at least the current cycle, so at least
    /// `base`).
    #[inline(always)]
    pub fn set_ready(&mut self, r: usize, v: u64) {
        debug_assert!(v >= self.base);
        let off = v - self.base;
        if off > u32::MAX as u64 {
            self.rebase(v);
            return self.set_ready(r, v);
        }
        self.ready[r] = off as u32;
    }

    /// Move `base` up to `v − 2^20` (ready times before it, all in the past, become it): a
    /// TP never waits 2^20 cycles on one operand, so no decision changes.
    #[cold]
    fn rebase(&mut self, v: u64) {
        let nb = v - (1 << 20);
        for off in &mut self.ready {
            let abs = self.base + *off as u64;
            *off = abs.saturating_sub(nb) as u32;
        }
        self.base = nb;
    }
}

impl Core {
    /// Instruction `d` issued at cycle `c` (a unit or local-memory instruction, or an accepted
    /// access whose destination the access already set), `lat` its unit's latency: count it,
    /// set its destination's ready cycle, move to the next instruction.
    #[inline(always)]
    pub(crate) fn retire(&mut self, d: &Dec, lat: u64, c: u64, s: &mut IssueStats) {
        if d.dst != NO_REG && !d.sync {
            let r = d.dst as usize;
            self.set_ready(r, c + lat);
            self.from_mem &= !(1 << r);
            self.missed &= !(1 << r);
        }
        self.ip += 1;
        if d.class == Class::Branch {
            // No branch prediction: the next instruction waits for the branch to resolve;
            // those cycles are counted here, when they become certain.
            self.next_issue = c + lat;
            s.stall[Stall::Operand as usize] += lat - 1;
        } else {
            self.next_issue = c + 1;
        }
        s.instructions[d.class as usize] += 1;
        s.register_reads += d.rf.0 as u64;
        s.register_writes += d.rf.1 as u64;
    }

    /// The earliest cycle from `s` at which every register instruction `d` reads or writes
    /// is readable (the operands must be known), accounting the cycles before it: a cycle is a
    /// memory stall while an operand written by a data-cache load is not yet readable, an
    /// operand stall otherwise.
    #[inline]
    pub(crate) fn operands_ready(&self, d: &Dec, s: u64, st: &mut IssueStats) -> u64 {
        let mut e = s;
        let mut m = d.regs;
        while m != 0 {
            let r = m.trailing_zeros() as usize;
            m &= m - 1;
            e = e.max(self.ready_at(r));
        }
        if e > s {
            // A wait: which of it is for memory (a second pass, only when there is a wait).
            let mut mem_until = 0;
            let mut m = d.regs & self.from_mem;
            while m != 0 {
                let r = m.trailing_zeros() as usize;
                m &= m - 1;
                mem_until = mem_until.max(self.ready_at(r));
            }
            let mem = mem_until.clamp(s, e) - s;
            st.stall[Stall::Memory as usize] += mem;
            st.stall[Stall::Operand as usize] += e - s - mem;
        }
        e
    }

    /// The data-cache request of this TP's (`tp`'s) load or store `d` at cycle `t`.
    #[inline]
    pub(crate) fn data_request(&self, d: &Dec, tp: usize, t: u64) -> Request {
        let Mem::Word { base, word } = d.mem else {
            unreachable!("data-cache instructions name a record word");
        };
        Request {
            cycle: t,
            l1: self.tm as usize,
            addr: self.run.base[base as usize] + 4 * word as u64,
            op: if d.class == Class::Load {
                MemOp::Read
            } else {
                MemOp::Write
            },
            tag: ((tp as u64) << 8) | d.dst as u64,
        }
    }

    /// The L1's answer `out` to this TP's load or store `d` at `t`: the destination's state
    /// if accepted; the refusal's stall cycles counted.
    #[inline]
    pub(crate) fn data_outcome(
        &mut self,
        d: &Dec,
        out: Outcome,
        t: u64,
        st: &mut IssueStats,
    ) -> Offered {
        let r = d.dst as usize;
        match out {
            Outcome::Busy { retry_at, .. } => {
                st.stall[Stall::Memory as usize] += retry_at - t;
                return Offered::Busy { retry_at };
            }
            Outcome::Done { ready, .. } => {
                if d.class == Class::Load {
                    self.set_ready(r, ready);
                    self.from_mem |= 1 << r;
                    self.missed &= !(1 << r);
                }
            }
            // A store that misses a write-back L1 (`arch.trax.l1.write_policy`) allocates its
            // line; the TP does not wait for it (nothing is read), so it is posted too.
            Outcome::Pending if d.class == Class::Store => {}
            Outcome::Pending => {
                self.pending |= 1 << r;
                self.from_mem |= 1 << r;
                self.missed |= 1 << r;
            }
        }
        Offered::Accepted
    }

    /// The atomic counter handed this TP `next_pixel` (its `atominc` `d`, of latency `lat`,
    /// accepted at `t`): the per-pixel cycles of the pixel it finished, and its destination.
    #[inline]
    pub(crate) fn atomic_granted(
        &mut self,
        d: &Dec,
        lat: u64,
        next_pixel: Option<u32>,
        heat: &mut [u64],
        t: u64,
    ) {
        if let Some(p) = self.pixel {
            heat[p as usize] = t - self.pixel_since;
        }
        self.pixel = next_pixel;
        self.pixel_since = t;
        let r = d.dst as usize;
        self.set_ready(r, t + lat);
        self.from_mem &= !(1 << r);
        self.missed &= !(1 << r);
    }

    /// A miss of this TP finished (`c`, tagged by [`Core::data_request`]); `miss_done` is the
    /// TP's row of [`Chip::miss_done`].
    #[inline]
    pub(crate) fn complete(&mut self, c: &Completion, miss_done: &mut [u64; 32]) {
        let r = (c.tag & 0xFF) as usize;
        if r == NO_REG as usize {
            // A store's line (write-back L1): no register waits for it.
            return;
        }
        self.set_ready(r, c.ready);
        self.pending &= !(1 << r);
        miss_done[r] = c.ready;
    }

    /// This TP's access `d` was accepted at `t`: it issues now.
    #[inline]
    pub(crate) fn accepted(&mut self, d: &Dec, t: u64, s: &mut IssueStats) {
        self.key = t;
        self.next_issue = t + 1;
        self.ip += 1;
        self.wait = Wait::Ready;
        s.instructions[d.class as usize] += 1;
        s.register_reads += d.rf.0 as u64;
        s.register_writes += d.rf.1 as u64;
    }

    /// This TP's run is finished and its work gave it `next`: start it, or halt. Returns
    /// the first instruction, and whether it halted.
    #[inline]
    pub(crate) fn start_run(&mut self, next: Option<Run>) -> Option<usize> {
        match next {
            Some(run) => {
                self.run = run;
                self.ip = 0;
                Some(run.seg.start as usize)
            }
            None => {
                self.wait = Wait::Halted;
                self.halted_at = self.next_issue;
                None
            }
        }
    }
}

/// The TP a completion belongs to (its tag, [`Core::data_request`]).
#[inline]
pub(crate) fn completion_tp(c: &Completion) -> usize {
    (c.tag >> 8) as usize
}

/// The atomic pixel counter's issue slots: `count` accesses per cycle.
#[derive(Clone, Debug, Default)]
pub(crate) struct Atomic {
    cycle: u64,
    used: u32,
}

impl Atomic {
    /// Whether an access at cycle `t` (nondecreasing across calls) finds one of the cycle's
    /// `count` slots free, taking it if so.
    #[inline]
    pub(crate) fn admit(&mut self, t: u64, count: u32) -> bool {
        if self.cycle != t {
            self.cycle = t;
            self.used = 0;
        }
        if self.used >= count {
            return false;
        }
        self.used += 1;
        true
    }
}

/// The result of offering an access.
pub(crate) enum Offered {
    Accepted,
    Busy { retry_at: u64 },
}

/// Everything both engines share; `S` is where the TPs' work comes from (the TRaX ray
/// program by default; STRaTA's treelet streams in `rtsim-strata`).
pub struct Chip<'a, S: Source = TraxSource<'a>> {
    pub(crate) cfg: TraxConfig,
    pub(crate) src: S,
    pub(crate) pixel_count: u64,
    pub(crate) dec: Vec<Dec>,
    /// Per TM: issue slots per cycle per unit class (a TM's units may be reconfigured,
    /// STRaTA §3.3); latency per class (units, then local memory and the atomic counter).
    pub(crate) caps: Vec<[u8; UNIT_CLASSES]>,
    pub(crate) lat: [u64; CLASSES],
    pub(crate) fetch_cap: u8,
    /// Calendar row width: the unit classes, then every instruction-cache bank of the TM.
    pub(crate) row_width: usize,
    pub(crate) cores: Vec<Core>,
    /// Per TP and register: the completion cycle of the miss that wrote it (valid where
    /// `Core::missed` says so; read by the reference engine's keys).
    pub(crate) miss_done: Vec<[u64; 32]>,
    pub(crate) hier: Hierarchy<Dram>,
    pub(crate) atomic: Atomic,
    pub(crate) completions: Vec<Completion>,
    pub(crate) issue: IssueStats,
    pub(crate) frame: FrameStats,
    pub(crate) pixels: Vec<PixelResult>,
    pub(crate) heat: Vec<u64>,
    pub(crate) pixels_done: u64,
    pub(crate) rays_done: u64,
    /// TPs not yet halted.
    pub(crate) live: usize,
    /// The frame's time series, when asked for (`Options::timeline`).
    pub(crate) sampler: Sampler,
    _life: std::marker::PhantomData<&'a ()>,
}

impl<S: Source> std::fmt::Debug for Chip<'_, S> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Chip")
            .field("tms", &self.cfg.tms)
            .field("tps_per_tm", &self.cfg.tps_per_tm)
            .field("live", &self.live)
            .finish_non_exhaustive()
    }
}

impl<'a, S: Source> Chip<'a, S> {
    /// Build the chip for a frame: `src` says what the TPs run (`program`, resident in every
    /// instruction cache), `image_pixels` how many pixels the image has, `dram` the memory
    /// behind the L2s, `seed` the caches' replacement streams.
    pub fn new(
        cfg: &TraxConfig,
        src: S,
        program: &Program,
        image_pixels: usize,
        dram: &DramConfig,
        seed: u64,
    ) -> Result<Chip<'a, S>, ChipError> {
        use rtsim_config::Validate;
        cfg.validate()?;
        if program.bytes() > cfg.icache_bytes {
            return Err(ConfigError::key(
                "arch.trax.icache_bytes",
                format!(
                    "= {} cannot hold the ray program ({} bytes), which is resident",
                    cfg.icache_bytes,
                    program.bytes()
                ),
            )
            .into());
        }
        let dec = program
            .insts
            .iter()
            .map(|i| Dec::new(i, cfg.icache_banks))
            .collect();
        let mut cap = [0u8; UNIT_CLASSES];
        let mut lat = [1u64; CLASSES];
        for (k, (_, u)) in cfg.units.by_class().iter().enumerate() {
            cap[k] = u.count as u8;
            lat[k] = u.latency as u64;
        }
        lat[Class::LocalLoad as usize] = cfg.local_latency as u64;
        lat[Class::LocalStore as usize] = cfg.local_latency as u64;
        lat[Class::Atomic as usize] = cfg.atomic.latency as u64;
        let topo =
            Topology::from_config(&cfg.cache_config(seed)).map_err(|e| e.under("arch.trax"))?;
        let l2s = cfg.cache_config(seed).l2_count().max(1);
        let memory = Dram::new(
            dram,
            Requester {
                clock: Clock::from_mhz(cfg.clock_mhz as u64),
                tags: l2s,
            },
        )
        .map_err(|e| e.under("dram"))?;
        let hier = Hierarchy::new(topo, memory)?;
        let n = cfg.total_tps() as usize;
        let banks = cfg.icaches_per_tm * cfg.icache_banks;
        let cores = (0..n as u32)
            .map(|tp| Core {
                tm: tp / cfg.tps_per_tm,
                icache: tp % cfg.tps_per_tm % cfg.icaches_per_tm,
                icache_col: UNIT_CLASSES as u32
                    + (tp % cfg.tps_per_tm % cfg.icaches_per_tm) * cfg.icache_banks,
                run: src.first_run(),
                ip: 0,
                base: 0,
                ready: [0; 32],
                pending: 0,
                from_mem: 0,
                missed: 0,
                next_issue: 0,
                key: 0,
                wait: Wait::Ready,
                access_at: 0,
                halted_at: 0,
                pixel: None,
                pixel_since: 0,
            })
            .collect();
        Ok(Chip {
            cfg: cfg.clone(),
            dec,
            caps: vec![cap; cfg.tms as usize],
            lat,
            fetch_cap: cfg.fetches_per_bank as u8,
            row_width: UNIT_CLASSES + banks as usize,
            cores,
            miss_done: vec![[0; 32]; n],
            pixel_count: src.pixel_count() as u64,
            hier,
            atomic: Atomic::default(),
            completions: Vec::with_capacity(256),
            issue: IssueStats::default(),
            frame: FrameStats::default(),
            pixels: vec![PixelResult::default(); image_pixels],
            heat: vec![0; image_pixels],
            pixels_done: 0,
            rays_done: 0,
            live: n,
            sampler: Sampler::default(),
            src,
            _life: std::marker::PhantomData,
        })
    }

    /// Set every TM's unit capacities (a source whose TMs start reconfigured, STRaTA §3.3).
    pub fn set_caps(&mut self, caps: [u8; UNIT_CLASSES]) {
        self.caps.fill(caps);
    }

    /// Set the latency of unit class `class` (a unit the source adds, such as STRaTA's box
    /// pipeline).
    pub fn set_latency(&mut self, class: Class, cycles: u64) {
        self.lat[class as usize] = cycles;
    }

    pub fn tps(&self) -> usize {
        self.cores.len()
    }

    /// The current instruction of TP `tp`, fetching the next block from its work when the
    /// current one is finished; `None` once it has halted (recorded at `next_issue`).
    #[inline(always)]
    pub(crate) fn current(&mut self, tp: usize) -> Option<usize> {
        let c = &mut self.cores[tp];
        if c.ip < c.run.seg.len {
            return Some((c.run.seg.start + c.ip) as usize);
        }
        self.next_run(tp)
    }

    /// [`Chip::current`] once TP `tp`'s run is finished: its next run from the work source.
    #[inline(never)]
    fn next_run(&mut self, tp: usize) -> Option<usize> {
        let mut done: Option<PixelDone> = None;
        let next = self
            .src
            .next(tp, &mut self.frame, &mut self.rays_done, &mut done);
        if let Some(d) = done {
            self.pixels[d.pixel as usize] = d.result();
            self.pixels_done += 1;
        }
        let first = self.cores[tp].start_run(next);
        if first.is_none() {
            self.live -= 1;
        }
        first
    }

    /// Instruction `i` issued by TP `tp` at cycle `c` (see [`Core::retire`]).
    #[inline(always)]
    pub(crate) fn retire_issue(&mut self, tp: usize, i: usize, c: u64) {
        let d = self.dec[i];
        let lat = self.lat[d.class as usize];
        self.cores[tp].retire(&d, lat, c, &mut self.issue);
    }

    /// Sample the time series at every interval boundary up to and including `t`: the
    /// engine has handled every cycle before `t` and nothing of `t`.
    #[inline(always)]
    pub(crate) fn sample_until(&mut self, t: u64) {
        if t >= self.sampler.next {
            self.sample_boundaries(t);
        }
    }

    #[inline(never)]
    fn sample_boundaries(&mut self, t: u64) {
        while self.sampler.next <= t {
            let src = &mut self.src;
            self.sampler.sample(&self.hier, |v| src.timeline_values(v));
        }
    }

    /// Start the time series: a sample every `every` cycles (`None`: none) of a run stopped
    /// at `limit`.
    pub(crate) fn start_timeline(&mut self, every: Option<u64>, limit: Option<u64>) {
        self.sampler = Sampler::new(every, limit, self.src.timeline_columns());
    }

    /// The key instruction `i` of TP `tp` arbitrates with: the TP's key, raised to the
    /// completion cycle of any miss it reads or overwrites.
    #[inline]
    pub(crate) fn key_of(&self, tp: usize, i: usize) -> u64 {
        let d = &self.dec[i];
        let core = &self.cores[tp];
        let mut k = core.key;
        let mut m = d.regs & core.missed;
        while m != 0 {
            let r = m.trailing_zeros() as usize;
            m &= m - 1;
            k = k.max(self.miss_done[tp][r]);
        }
        k
    }

    /// Offer TP `tp`'s current access instruction `i` at cycle `t` (nondecreasing across
    /// calls). Accepted: the instruction issues at `t` and the TP's key becomes `t`.
    pub(crate) fn access(&mut self, tp: usize, i: usize, t: u64) -> Result<Offered, ChipError> {
        let d = self.dec[i];
        let core = &self.cores[tp];
        let dst = d.dst;
        match d.class {
            Class::Atomic => {
                if !self.atomic.admit(t, self.cfg.atomic.count) {
                    self.issue.stall[Stall::Atomic as usize] += 1;
                    return Ok(Offered::Busy { retry_at: t + 1 });
                }
                self.sampler.atomic_grants += 1;
                let next_pixel = self.src.atomic(tp);
                let lat = self.lat[Class::Atomic as usize];
                self.cores[tp].atomic_granted(&d, lat, next_pixel, &mut self.heat, t);
            }
            Class::Load | Class::Store => {
                let out = self.hier.submit(core.data_request(&d, tp, t))?;
                if let busy @ Offered::Busy { .. } =
                    self.cores[tp].data_outcome(&d, out, t, &mut self.issue)
                {
                    return Ok(busy);
                }
            }
            Class::TriTest | Class::StreamLoad | Class::StreamStore => {
                let tm = core.tm as usize;
                match self
                    .src
                    .access(tp, tm, d.class, d.mem, t, &mut self.caps[tm])?
                {
                    SourceAccess::Busy { retry_at, stall } => {
                        self.issue.stall[stall as usize] += retry_at - t;
                        return Ok(Offered::Busy { retry_at });
                    }
                    SourceAccess::Done { ready } => {
                        let core = &mut self.cores[tp];
                        // A stream load fills the registers it names; the others write
                        // their destination only.
                        let mut m = bit(dst);
                        if d.class == Class::StreamLoad {
                            m |= d.deps;
                        }
                        while m != 0 {
                            let r = m.trailing_zeros() as usize;
                            m &= m - 1;
                            core.set_ready(r, ready);
                            core.from_mem &= !(1 << r);
                            core.missed &= !(1 << r);
                        }
                    }
                }
            }
            _ => unreachable!(
                "only data-cache, atomic, pipeline and stream instructions are offered"
            ),
        }
        self.cores[tp].accepted(&d, t, &mut self.issue);
        self.sampler.issue(t);
        Ok(Offered::Accepted)
    }

    /// Apply a finished miss; returns the TP it belongs to.
    #[inline]
    pub(crate) fn complete(&mut self, c: &Completion) -> usize {
        let tp = completion_tp(c);
        self.cores[tp].complete(c, &mut self.miss_done[tp]);
        tp
    }

    /// The frame's result so far.
    pub fn pixels(&self) -> &[PixelResult] {
        &self.pixels
    }

    /// Progress: (pixels finished, rays traced).
    pub fn progress(&self) -> (u64, u64) {
        (self.pixels_done, self.rays_done)
    }

    /// A colour for tests.
    pub fn pixel_color(&self, p: usize) -> Vec3 {
        self.pixels[p].color
    }
}

impl<S: Source> Chip<'_, S> {
    /// After an engine stopped at `last`: close the accounts, drain the memory system and
    /// report.
    pub(crate) fn finish(
        mut self,
        last: u64,
        opts: &crate::Options,
        program: &Program,
    ) -> Result<(crate::Output, S), ChipError> {
        use crate::energy::{Energy, Events};
        use crate::report::*;
        let complete = self.live == 0;
        let cycles = if complete {
            self.cores.iter().map(|c| c.halted_at).max().unwrap_or(0)
        } else {
            opts.cycle_limit.unwrap_or(last + 1)
        };
        for c in &self.cores {
            if c.wait == Wait::Halted {
                self.issue.idle += cycles.saturating_sub(c.halted_at);
            }
        }
        // Boundaries of the time series the engine stopped short of (it stops once every TP
        // has halted, or at the limit): the memory system's events before each, then the
        // sample, as an engine running on would have taken it.
        while self.sampler.next < cycles {
            self.hier.advance_to(self.sampler.next - 1)?;
            let t = self.sampler.next;
            self.sample_boundaries(t);
        }
        let drained = self.hier.drain()?;
        let end = cycles.max(drained).max(self.hier.now());
        let mut l1 = rtsim_cache::CacheStats::default();
        let mut l2 = rtsim_cache::CacheStats::default();
        let (mut n1, mut n2) = (0, 0);
        for (_, level, s) in &self.hier.all_stats().caches {
            if *level == 1 {
                l1 += s;
                n1 += 1;
            } else {
                l2 += s;
                n2 += 1;
            }
        }
        let dram = self.hier.memory_mut().report(end);
        let clock_hz = self.cfg.clock_mhz as f64 * 1e6;
        let (stream_j, pipeline_j) = self.src.extra_energy(&self.cfg, &self.issue);
        let seconds = cycles as f64 / clock_hz;
        let energy = Energy::of(
            &self.cfg,
            &self.issue,
            &Events {
                l1_accesses: l1.accesses(),
                // Reads that joined another's lookup (`combine_reads`) share its array access.
                l2_accesses: l2.accesses() - l2.combined,
                dram_j: dram.energy.total_j,
                seconds,
                stream_j,
                pipeline_j,
            },
        );
        let total = self.issue.total_instructions();
        let rays = self.frame.total().rays;
        let tps = self.cores.len() as u64;
        let ratio = rtsim_core::stats::ratio;
        let rf = (self.issue.register_reads + self.issue.register_writes) as f64;
        let report = TraxReport {
            complete,
            chip: ChipFacts {
                tms: self.cfg.tms,
                tps_per_tm: self.cfg.tps_per_tm,
                tps: self.cfg.total_tps(),
                clock_mhz: self.cfg.clock_mhz,
                l2s: n2,
                program_instructions: program.insts.len() as u32,
                program_bytes: program.bytes(),
                engine: opts.engine.name(),
            },
            cycles,
            seconds,
            ms_per_frame: seconds * 1e3,
            fps: ratio(1.0, seconds),
            pixels: self.pixel_count,
            pixels_done: self.pixels_done,
            instructions: InstructionFacts {
                total,
                by_class: self.issue.by_class(),
                rays,
                per_ray: ratio(total as f64, rays as f64),
                issue_rate: ratio(total as f64, (cycles * tps) as f64),
                per_cycle: ratio(total as f64, cycles as f64),
            },
            tp_cycles: TpCycleFacts::of(&self.issue, cycles * tps),
            register_file: RegisterFacts {
                reads: self.issue.register_reads,
                writes: self.issue.register_writes,
            },
            l1: CacheFacts::of(n1, l1),
            l2: CacheFacts::of(n2 as usize, l2),
            dram: DramFacts {
                accesses: dram.reads + dram.writes,
                reads: dram.reads,
                writes: dram.writes,
                row_hit_rate: dram.row_hit_rate.all,
                average_read_latency_core_cycles: dram.read_latency.requester_cycles.mean,
                bandwidth_gbps: dram.bandwidth.achieved_gbps,
                peak_gbps: dram.bandwidth.peak_gbps,
                energy_j: dram.energy.total_j,
                report: dram,
            },
            calibration: Calibration {
                register_accesses_per_instruction: ratio(rf, total as f64),
                rf_to_icache_energy: ratio(energy.register_file_j, energy.icache_j),
                instructions_per_ray: ratio(total as f64, rays as f64),
            },
            energy,
            issue: self.issue.clone(),
        };
        let src = &mut self.src;
        let running = self.sampler.running(&self.hier, |v| src.timeline_values(v));
        let timeline = self.sampler.finish(cycles, tps, &running);
        Ok((
            crate::Output {
                pixels: self.pixels,
                heat: self.heat,
                rays: self.frame,
                report,
                timeline,
            },
            self.src,
        ))
    }
}
