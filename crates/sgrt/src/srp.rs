//! The SRP shader (SGRT §3.4) as a throughput-and-latency unit, and the free feeder of the
//! T&I-only mode.
//!
//! # The SRP (`arch.sgrt.shader = true`)
//!
//! One SRP per core runs one kernel at a time on a packet of up to `packet_rays` items, in its
//! own clock (1 GHz), against the T&I unit's (500 MHz): times cross with exact ratios. A
//! kernel either generates camera rays for the next pixels of the frame, or shades a packet of
//! hits (resuming each pixel's state machine, which may produce its next ray). Its cost is the
//! operations of the kernels the state machines ran (`rtsim_trace::ops`, measured per kernel)
//! at `srp.ops_per_cycle`, plus `srp.packet_overhead_cycles` per launch; the records they read
//! (hit triangle, material) go through the SRP's data cache into the shared memory path, and a
//! kernel ends when both its computation and its data are done. Finished pixels write the
//! framebuffer (posted writes). Its output rays enter the ray buffers when it ends; room for
//! them is reserved when it starts.
//!
//! Scheduling when idle (SGRT §3.4.3 describes a job queue with a simple scheduler; this
//! policy is assumed): (1) a full packet of hits; (2) a packet of camera rays, if the frame has
//! pixels left, the ray buffers have room for it and the core holds fewer than
//! `ray buffers + hit buffers + short stacks − 1` pixels (with at most that many, some buffer
//! always has room, so the loop SRP → T&I → SRP cannot deadlock); (3) a partial packet of hits
//! when no full one can form from the rays still in the T&I unit and its ray buffers.
//!
//! # The feeder (`shader = false`, Tables 4–5: "T&I alone without shading")
//!
//! Generation and shading take no time and touch no memory: finished rays are shaded in the
//! cycle they leave the T&I unit, and the core keeps `ray buffers + short stacks` items in
//! flight so the T&I unit never waits for rays.

use crate::config::SgrtConfig;
use crate::core::{Core, tag};
use crate::error::SgrtError;
use crate::stats::SrpStats;
use crate::work::{Charge, Work};
use rtsim_cache::{Hierarchy, Outcome, Request};
use rtsim_core::{Clock, MemOp, MemoryPort};
use rtsim_sim::{PushError, Ratio};
use rtsim_trace::Tracer;
use std::collections::VecDeque;

/// A kernel in progress.
#[derive(Debug)]
struct Kernel {
    /// SRP cycle its computation ends.
    end_srp: u64,
    /// The same, as the first T&I cycle at or after it.
    end_ti: u64,
    /// Reads not yet back.
    loads_left: u32,
    /// T&I cycle the last read's data was ready.
    data_ti: u64,
    rays: Vec<u32>,
}

/// One core's shader, or its free feeder.
#[derive(Debug)]
pub(crate) struct Shader {
    timed: bool,
    to_srp: Ratio,
    to_ti: Ratio,
    ops_per_cycle: f64,
    overhead: u64,
    packet: u32,
    /// Items of this core in flight (each has one ray somewhere, or is being shaded).
    pub active: u32,
    cap: u32,
    ray_cap: u32,
    /// Feeder: rays waiting for room in the ray buffers.
    pending: VecDeque<u32>,
    /// SRP cycle from which the SRP is free.
    free_srp: u64,
    kernel: Option<Kernel>,
    /// Line requests waiting to go to the data cache (reads of the running kernel, writes).
    mem: VecDeque<(u64, MemOp)>,
    mem_retry: u64,
    leaf: usize,
    charge: Charge,
    pub stats: SrpStats,
}

impl Shader {
    pub fn new(c: &SgrtConfig, dcache_leaf: usize) -> Shader {
        let ti = Clock::from_mhz(c.ti_clock_mhz.into());
        let srp = Clock::from_mhz(c.srp_clock_mhz.into());
        let ray_cap = c.ray_buffer_rays();
        let cap = if c.shader {
            ray_cap + c.hit_buffer_rays() + c.rays_in_flight() - 1
        } else {
            ray_cap + c.rays_in_flight()
        };
        Shader {
            timed: c.shader,
            to_srp: Ratio::new(ti, srp),
            to_ti: Ratio::new(srp, ti),
            ops_per_cycle: c.srp.ops_per_cycle,
            overhead: c.srp.packet_overhead_cycles.into(),
            packet: c.packet_rays,
            active: 0,
            cap,
            ray_cap,
            pending: VecDeque::new(),
            free_srp: 0,
            kernel: None,
            mem: VecDeque::new(),
            mem_retry: 0,
            leaf: dcache_leaf,
            charge: Charge::default(),
            stats: SrpStats::default(),
        }
    }

    /// A read of the data cache came back at `ready`.
    pub fn load_done(&mut self, ready: u64) {
        if let Some(k) = &mut self.kernel {
            k.loads_left -= 1;
            k.data_ti = k.data_ti.max(ready);
        }
    }

    /// Whether the shader holds no work and its memory requests are all out.
    pub fn is_idle(&self) -> bool {
        self.active == 0 && self.kernel.is_none() && self.pending.is_empty() && self.mem.is_empty()
    }

    /// One T&I cycle of the shader.
    pub fn tick<M: MemoryPort>(
        &mut self,
        t: u64,
        core: &mut Core,
        work: &mut Work<'_>,
        tracer: &Tracer,
        hier: &mut Hierarchy<M>,
    ) -> Result<(), SgrtError> {
        if self.timed {
            self.tick_srp(t, core, work, tracer, hier)
        } else {
            self.tick_free(t, core, work, tracer)
        }
    }

    fn tick_free(
        &mut self,
        t: u64,
        core: &mut Core,
        work: &mut Work<'_>,
        tracer: &Tracer,
    ) -> Result<(), SgrtError> {
        let mut c = std::mem::take(&mut self.charge);
        while let Some(job) = core.hit_fifo.pop(t)? {
            c.clear();
            work.resume(job, core, tracer, &mut c);
            self.active -= 1;
            self.active += c.rays.len() as u32;
            self.pending.extend(c.rays.iter().copied());
        }
        while self.active < self.cap && work.remaining() > 0 {
            c.clear();
            work.begin(core, &mut c)?;
            self.active += c.rays.len() as u32;
            self.pending.extend(c.rays.iter().copied());
        }
        self.charge = c;
        while let Some(&job) = self.pending.front() {
            match core.ray_fifo.push(t, job) {
                Ok(()) => {
                    self.pending.pop_front();
                    core.ray_pushed(t);
                }
                Err(PushError::Full(_)) => break,
                Err(PushError::Link(e)) => return Err(e.into()),
            }
        }
        Ok(())
    }

    fn tick_srp<M: MemoryPort>(
        &mut self,
        t: u64,
        core: &mut Core,
        work: &mut Work<'_>,
        tracer: &Tracer,
        hier: &mut Hierarchy<M>,
    ) -> Result<(), SgrtError> {
        self.issue_memory(t, core.id, hier)?;
        // A kernel ends: its rays go to the ray buffers (room was reserved).
        if let Some(k) = &self.kernel
            && t >= k.end_ti
            && k.loads_left == 0
            && t >= k.data_ti
        {
            let k = self.kernel.take().expect("checked");
            let end = self.to_srp.ceil(t).max(k.end_srp);
            self.stats.memory_wait_cycles += end - k.end_srp;
            self.free_srp = end;
            for &job in &k.rays {
                core.ray_fifo.push(t, job).map_err(|e| match e {
                    PushError::Full(_) => unreachable!("room was reserved when the kernel began"),
                    PushError::Link(e) => SgrtError::from(e),
                })?;
                core.ray_pushed(t);
            }
            self.charge.rays = k.rays;
        }
        if self.kernel.is_some() || self.to_ti.ceil(self.free_srp) > t {
            return Ok(());
        }
        let Some((shade, n)) = self.choose(t, core, work) else {
            return Ok(());
        };
        let start = self.free_srp.max(self.to_srp.ceil(t));
        let mut c = std::mem::take(&mut self.charge);
        c.clear();
        if shade {
            for _ in 0..n {
                let job = core.hit_fifo.pop(t)?.expect("counted visible");
                let before = c.rays.len();
                work.resume(job, core, tracer, &mut c);
                self.active -= 1;
                self.active += (c.rays.len() - before) as u32;
            }
            self.stats.hits_shaded += u64::from(n);
        } else {
            for _ in 0..n {
                let before = c.rays.len();
                work.begin(core, &mut c)?;
                self.active += (c.rays.len() - before) as u32;
            }
            self.stats.generate_launches += 1;
        }
        let compute = (c.ops as f64 / self.ops_per_cycle).ceil() as u64 + self.overhead;
        self.stats.launches += 1;
        self.stats.ops += c.ops;
        self.stats.compute_cycles += compute;
        self.stats.rays_generated += c.rays.len() as u64;
        let mut loads = 0;
        for &(addr, op) in &c.memory {
            loads += u32::from(op == MemOp::Read);
            self.mem.push_back((addr, op));
        }
        let end_srp = start + compute;
        self.kernel = Some(Kernel {
            end_srp,
            end_ti: self.to_ti.ceil(end_srp),
            loads_left: loads,
            data_ti: 0,
            rays: std::mem::take(&mut c.rays),
        });
        self.charge = c;
        Ok(())
    }

    /// What an idle SRP does next at `t`: (shade?, items).
    fn choose(&self, t: u64, core: &Core, work: &Work<'_>) -> Option<(bool, u32)> {
        let visible = core.hit_fifo.visible_len(t) as u32;
        let room = self.ray_cap - core.ray_fifo.len() as u32;
        if visible >= self.packet && room > 0 {
            return Some((true, self.packet.min(room)));
        }
        let n = (work.remaining().min(u64::from(self.packet))) as u32;
        if n > 0 && self.active + n <= self.cap && room >= n {
            return Some((false, n));
        }
        let coming = visible + core.in_flight + core.ray_fifo.len() as u32;
        if visible > 0 && room > 0 && coming < self.packet {
            return Some((true, visible.min(room)));
        }
        None
    }

    /// Offer the next data-cache request (one per T&I cycle).
    fn issue_memory<M: MemoryPort>(
        &mut self,
        t: u64,
        core: u32,
        hier: &mut Hierarchy<M>,
    ) -> Result<(), SgrtError> {
        if t < self.mem_retry {
            return Ok(());
        }
        let Some(&(addr, op)) = self.mem.front() else {
            return Ok(());
        };
        match hier.submit(Request {
            cycle: t,
            l1: self.leaf,
            addr,
            op,
            tag: tag(core, true, 0),
        })? {
            Outcome::Busy { retry_at, .. } => {
                self.mem_retry = retry_at;
                return Ok(());
            }
            Outcome::Done { ready, .. } => {
                if op == MemOp::Read {
                    self.load_done(ready);
                }
            }
            Outcome::Pending => {}
        }
        match op {
            MemOp::Read => self.stats.loads += 1,
            MemOp::Write => self.stats.stores += 1,
        }
        self.mem.pop_front();
        Ok(())
    }

    /// The next T&I cycle after `now` at which the shader can act on its own.
    pub fn next_event(&self, now: u64, core: &Core, work: &Work<'_>) -> Option<u64> {
        let mut next = u64::MAX;
        let mut at = |c: u64| next = next.min(c.max(now + 1));
        if !self.timed {
            if let Some(v) = core.hit_fifo.next_ready() {
                at(v);
            }
            if !self.pending.is_empty() && !core.ray_fifo.is_full() {
                at(now + 1);
            }
            if self.active < self.cap && work.remaining() > 0 {
                at(now + 1);
            }
            return (next != u64::MAX).then_some(next);
        }
        if !self.mem.is_empty() {
            at(self.mem_retry);
        }
        match &self.kernel {
            Some(k) if k.loads_left == 0 => at(k.end_ti.max(k.data_ti)),
            Some(_) => {}
            None => {
                let first = self.to_ti.ceil(self.free_srp).max(now + 1);
                if self.choose(first, core, work).is_some() {
                    at(first);
                } else if let Some(v) = core.hit_fifo.next_ready_after(now) {
                    at(v.max(first));
                }
            }
        }
        (next != u64::MAX).then_some(next)
    }
}
