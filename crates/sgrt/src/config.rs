//! `arch.sgrt.*`: every parameter of the SGRT model, with its default, unit and source.
//!
//! Sources: the SGRT paper (Lee et al., HPG 2013, `../shared/papers/sgrt-lee-mobile-gpu.txt`),
//! cited by section or table; `../shared/DESIGN.md` §4, which lists where the paper contradicts
//! itself; the STRaTA paper's 65 nm operation latencies (FP add and multiply 2 cycles, divide 16
//! cycles, comparators 1 cycle; DESIGN.md §3) for the pipeline latencies the paper does not
//! give. Everything marked *assumed* is not in the paper; the reason is given beside it and in
//! `docs/SGRT.md`, which also derives every pipeline latency and initiation interval.
//!
//! The struct is read from the run configuration's `[arch.sgrt]` table
//! (`deny_unknown_fields`, every field defaulted) and checked by [`SgrtConfig::validate`],
//! whose errors name the full key (`arch.sgrt.trv.stacks`) and the allowed range.

use crate::units;
use rtsim_cache::{CacheLevel, Replacement, WritePolicy};
use rtsim_config::{ConfigError, Validate, check_range};
use serde::{Deserialize, Serialize};
use std::path::PathBuf;

/// Prefix of every key of this section in error messages.
const P: &str = "arch.sgrt";

/// How the three traversal sub-pipelines are connected (SGRT §3.3.1, Figure 4).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Organisation {
    /// Parallel pipelined TRV: TRV_PRE, TRV_AABB and TRV_POST are independent, each with its
    /// own input queue, and a crossbar feeds a ray straight to the sub-pipeline it needs next.
    Pptrv,
    /// Single pipelined TRV: one deep pipeline PRE → AABB → POST that every pass goes through
    /// in full, bypassing the stages it does not need.
    Sptrv,
}

impl Organisation {
    pub fn name(self) -> &'static str {
        match self {
            Organisation::Pptrv => "pptrv",
            Organisation::Sptrv => "sptrv",
        }
    }
}

/// What the rays of `rays_file` ask.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum RaysQuery {
    /// The closest hit (primary, diffuse rays).
    Closest,
    /// Any hit (shadow and AO rays; stops at the first hit with `trace.early_exit`).
    Any,
}

/// The whole SGRT chip.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SgrtConfig {
    /// SGRT cores, each one T&I unit and one SRP, 1..=64. Default 4 (SGRT §4: "SGRT uses four
    /// cores"); the `sgrt-1` preset uses 1 for Table 4 ("executed on a single T&I unit").
    pub cores: u32,
    /// `pptrv` (default, SGRT §3.3.1) or `sptrv` (the conventional single pipeline, Table 4).
    pub organisation: Organisation,
    /// Traversal units per T&I unit, 1..=16. Default 4 (SGRT §3.3: "four traversal units";
    /// the 4:1 TRV:IST ratio).
    pub trvs: u32,
    /// T&I unit clock in MHz, 1..=10000. Default 500 (SGRT §4). The caches, their L2 and the
    /// DRAM's requester side run in this clock.
    pub ti_clock_mhz: u32,
    /// SRP (shader) clock in MHz, 1..=10000. Default 1000 (SGRT §4). Independent of the T&I
    /// clock; the two meet at the ray and hit buffers, converted exactly (`rtsim_sim::Ratio`).
    pub srp_clock_mhz: u32,
    /// Run the SRP (ray generation and shading). Default true. `false` is the T&I-only mode of
    /// Tables 4 and 5 ("T&I alone without shading"): rays are generated and shaded at no cost
    /// and only the workload's measured rays go through the T&I unit (see `docs/SGRT.md`).
    pub shader: bool,
    /// Trace the rays of this `rays.bin` (README: ray queries) instead of a workload: T&I only,
    /// `hits.bin` is written beside the stats. Default unset.
    pub rays_file: Option<PathBuf>,
    /// What the rays of `rays_file` ask: `closest` (default) or `any`.
    pub rays_query: RaysQuery,
    /// Rays per SRP packet, 1..=4096. Default 64 (SGRT §3.4.3: "we choose the size of the
    /// kernel loop (i.e., the size of a ray packet) to be 64").
    pub packet_rays: u32,
    /// Ray buffers of `packet_rays` rays between the SRP and the T&I unit, 1..=64. Default 3
    /// (SGRT §3.2: "the ray buffers are configured as triple buffers"). The paper's own total,
    /// 12 KB = 64 × (2 × 64 B + 3 × 24 B), counts 2 ray and 3 hit buffers instead; the text's
    /// reading is taken (its total would be 15 KB).
    pub ray_buffers: u32,
    /// Hit buffers of `packet_rays` hits between the T&I unit and the SRP, 1..=64. Default 2
    /// (SGRT §3.2: "the hit buffers are configured as double buffers"; see `ray_buffers`).
    pub hit_buffers: u32,
    /// Cycles (T&I clock) from writing a ray into any buffer or FIFO to its being visible at
    /// the other end, 0..=64. Default 1 (assumed: registered FIFOs; the crossbar adds no cycle,
    /// SGRT §3.3.1: "only minimal hardware").
    pub queue_latency: u32,
    pub trv: TrvConfig,
    pub ist: IstConfig,
    /// The L2 shared by a core's TRVs (the IST has its own L1 straight to memory). Default
    /// 128 KB, 2-way, 8 banks, 64 B lines, hit 20 cycles (SGRT §4.1 and §4.2); MSHRs 16
    /// (assumed: with the IST L1's 16, four cores keep at most 128 lines in flight, what
    /// the two LPDDR3 channels' read queues hold (2 × 64), so the memory controller's queue is
    /// never the limit; 28 lines in flight already cover LPDDR3's bandwidth × latency); write
    /// buffer 8 (assumed: the T&I unit only reads).
    pub l2: CacheLevel,
    pub srp: SrpConfig,
}

/// One traversal unit (four per T&I unit).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct TrvConfig {
    /// Short stacks, i.e. rays in flight per TRV, 1..=256. Default 16 (SGRT §4: "A TRV has 16
    /// stacks"). Their depth is `trace.short_stack_entries`.
    pub stacks: u32,
    /// Input buffer (SPTRV: the only queue; PPTRV: TRV_PRE's queue) in rays, at least
    /// `stacks` (a smaller one could deadlock the feedback loop), at most 4096. Default 16
    /// (assumed: one entry per short stack).
    pub input_buffer: u32,
    /// PPTRV only: entries of each of the two FIFOs in front of TRV_AABB and TRV_POST, at least
    /// `stacks`, at most 4096. Default 16 (SGRT §4.2: "only two 16-entry FIFO buffers").
    pub fifo_entries: u32,
    /// Ray accumulation unit: rays parked on a cache miss, 1..=4096. A lookup needs a free
    /// entry (it may miss); a full RAU stalls the memory stage. Default 16 (assumed: every ray
    /// of the TRV can wait on a miss).
    pub rau_entries: u32,
    /// TRV_PRE latency in cycles after the node arrives (leaf or inner: one integer
    /// comparison), 1..=1000. Default 1 (assumed, `docs/SGRT.md`).
    pub pre_latency: u32,
    /// TRV_PRE initiation interval, 1..=1000. Default 1.
    pub pre_interval: u32,
    /// TRV_AABB latency in cycles after the child pair arrives, 1..=1000. Default 9 (derived:
    /// one slab test is subtract 2 + multiply 2 + four comparator levels = 8 cycles at the
    /// STRaTA paper's 65 nm latencies; the second box of the pair follows one cycle later).
    pub aabb_latency: u32,
    /// TRV_AABB initiation interval: cycles per child pair, 1..=1000. Default 2 (derived: the
    /// 6 adders, 6 multipliers and 11 comparators of a TRV (Tables 1–2) are one slab test's
    /// worth, so a pass tests one box per cycle and a pair in two).
    pub aabb_interval: u32,
    /// TRV_POST latency (near/far comparison, short-stack read or write), 1..=1000. Default 2
    /// (assumed, `docs/SGRT.md`).
    pub post_latency: u32,
    /// TRV_POST initiation interval, 1..=1000. Default 1.
    pub post_interval: u32,
    /// Each TRV's L1. Default 16 KB, 2-way, 64 B lines, hit 1 cycle (SGRT §4.1–4.2); 2 banks
    /// (assumed: TRV_PRE and TRV_AABB can both look up in a cycle when their lines differ in
    /// bank); MSHRs 16 (assumed: one per short stack); write buffer 4 (assumed: read only).
    pub l1: CacheLevel,
}

/// The intersection unit (one per T&I unit).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct IstConfig {
    /// Input buffer in rays, 1..=4096. Default 16 (assumed: as a TRV's). Rays looping back for
    /// the next triangle of their leaf wait in a separate loop queue that can hold every ray
    /// of the core, so the loop never deadlocks (SGRT §3.3: "a feedback loop path to the input
    /// buffer").
    pub input_buffer: u32,
    /// Ray accumulation unit, 1..=4096. Default 32 (assumed: half the rays of four TRVs; the
    /// IST's 8 KB register file, Table 1, holds about 128 ray records of 64 B).
    pub rau_entries: u32,
    /// Pipeline latency in cycles after the Wald record arrives, 1..=1000. Default 37
    /// (derived: the critical path of Wald's test at the STRaTA paper's latencies — add 2,
    /// multiply 2, comparator 1, reciprocal 16 — see `docs/SGRT.md`).
    pub latency: u32,
    /// Initiation interval, 1..=1000. Default 1 (derived: 12 adders, 10 multipliers, 1
    /// reciprocal and 5 comparators, SGRT §3.3 and Table 1, are one Wald test's worth).
    pub interval: u32,
    /// The IST's L1. Default 128 KB, 4-way, 64 B lines, hit 1 cycle (SGRT §4.1); 2 banks
    /// (assumed: a 48-byte Wald record that straddles two lines is read in one cycle); MSHRs
    /// 16 (assumed: see `arch.sgrt.l2`); write buffer 4 (assumed: read only).
    pub l1: CacheLevel,
}

/// The SRP shader as a throughput-and-latency unit.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SrpConfig {
    /// Sustained operations per SRP cycle over a ray-generation or shading kernel, where an
    /// operation is one entry of `rtsim_trace::ops` (measured per kernel), in (0, 10000].
    /// Default 6.678 (derived from SGRT Table 3: Sibenik primary rays, untextured, run at
    /// 182.11 Mrays/s on four 1 GHz SRPs, i.e. 21.965 SRP cycles per ray; a primary ray's
    /// camera-ray and hit-shading kernels are 140 operations; with `packet_overhead_cycles` =
    /// 32 per kernel launch (2 launches per 64 rays: 1 cycle per ray), 140 / 20.965 = 6.678;
    /// a test checks it).
    pub ops_per_cycle: f64,
    /// SRP cycles per kernel launch on a packet (VLIW control, CGRA configuration, software
    /// pipeline prologue and epilogue), 0..=100000. Default 32 (assumed: SGRT §3.4.3 sizes
    /// packets to hide this overhead, without giving it).
    pub packet_overhead_cycles: u32,
    /// The SRP's data cache for triangle and material reads and framebuffer writes. Default
    /// 4 KB (SGRT §3.4.1); 4-way, 1 bank, hit 1 T&I cycle, 8 MSHRs (assumed). Its misses share
    /// the memory path with the T&I unit's. (The 32 KB texture cache of §3.4.1 is not modelled:
    /// no shipped scene has textures.)
    pub dcache: CacheLevel,
}

impl Default for SgrtConfig {
    fn default() -> Self {
        SgrtConfig {
            cores: 4,
            organisation: Organisation::Pptrv,
            trvs: 4,
            ti_clock_mhz: 500,
            srp_clock_mhz: 1000,
            shader: true,
            rays_file: None,
            rays_query: RaysQuery::Closest,
            packet_rays: 64,
            ray_buffers: 3,
            hit_buffers: 2,
            queue_latency: 1,
            trv: TrvConfig::default(),
            ist: IstConfig::default(),
            l2: CacheLevel {
                size_bytes: 128 * 1024,
                ways: 2,
                banks: 8,
                hit_latency: 20,
                mshrs: 16,
                write_buffer: 8,
                ..read_only_level()
            },
            srp: SrpConfig::default(),
        }
    }
}

/// The settings every SGRT cache shares: 64 B lines (SGRT §4.1), LRU (assumed), write-around
/// (the T&I unit never writes; the SRP's framebuffer writes go through).
fn read_only_level() -> CacheLevel {
    CacheLevel {
        size_bytes: 16 * 1024,
        ways: 2,
        line_bytes: 64,
        replacement: Replacement::Lru,
        write_policy: WritePolicy::WriteAround,
        write_hit_updates_lru: true,
        banks: 2,
        // Whole lines per bank (the cache crate's default; SGRT does not say).
        bank_bytes: None,
        hit_latency: 1,
        mshrs: 16,
        write_buffer: 4,
        combine_reads: false,
    }
}

impl Default for TrvConfig {
    fn default() -> Self {
        TrvConfig {
            stacks: 16,
            input_buffer: 16,
            fifo_entries: 16,
            rau_entries: 16,
            pre_latency: units::pre_latency(),
            pre_interval: 1,
            aabb_latency: units::aabb_latency(),
            aabb_interval: units::aabb_interval(),
            post_latency: units::post_latency(),
            post_interval: 1,
            l1: read_only_level(),
        }
    }
}

impl Default for IstConfig {
    fn default() -> Self {
        IstConfig {
            input_buffer: 16,
            rau_entries: 32,
            latency: units::ist_latency(),
            interval: units::ist_interval(),
            l1: CacheLevel {
                size_bytes: 128 * 1024,
                ways: 4,
                mshrs: 16,
                ..read_only_level()
            },
        }
    }
}

impl Default for SrpConfig {
    fn default() -> Self {
        SrpConfig {
            ops_per_cycle: 6.678,
            packet_overhead_cycles: 32,
            dcache: CacheLevel {
                size_bytes: 4 * 1024,
                ways: 4,
                banks: 1,
                mshrs: 8,
                write_buffer: 8,
                ..read_only_level()
            },
        }
    }
}

impl SgrtConfig {
    /// Rays the ray buffers hold.
    pub fn ray_buffer_rays(&self) -> u32 {
        self.ray_buffers * self.packet_rays
    }
    /// Hits the hit buffers hold.
    pub fn hit_buffer_rays(&self) -> u32 {
        self.hit_buffers * self.packet_rays
    }
    /// Rays one T&I unit holds in flight (short stacks of all its TRVs).
    pub fn rays_in_flight(&self) -> u32 {
        self.trvs * self.trv.stacks
    }
}

fn k(key: &str) -> String {
    format!("{P}.{key}")
}

fn range(key: &str, v: u32, lo: u32, hi: u32) -> Result<(), ConfigError> {
    check_range(&k(key), v, lo, hi)
}

impl Validate for SgrtConfig {
    fn validate(&self) -> Result<(), ConfigError> {
        range("cores", self.cores, 1, 64)?;
        range("trvs", self.trvs, 1, 16)?;
        range("ti_clock_mhz", self.ti_clock_mhz, 1, 10_000)?;
        range("srp_clock_mhz", self.srp_clock_mhz, 1, 10_000)?;
        range("packet_rays", self.packet_rays, 1, 4096)?;
        range("ray_buffers", self.ray_buffers, 1, 64)?;
        range("hit_buffers", self.hit_buffers, 1, 64)?;
        range("queue_latency", self.queue_latency, 0, 64)?;
        let t = &self.trv;
        range("trv.stacks", t.stacks, 1, 256)?;
        // The TRV's internal queues take every ray the TRV can hold, so the loop
        // PRE → AABB → POST → PRE never blocks on itself (SGRT §4.2 sizes the FIFOs to the 16
        // stacks).
        for (key, v) in [
            ("trv.input_buffer", t.input_buffer),
            ("trv.fifo_entries", t.fifo_entries),
        ] {
            if !(t.stacks..=4096).contains(&v) {
                return Err(ConfigError::range(
                    &k(key),
                    v,
                    format!(
                        "{}..=4096 (at least arch.sgrt.trv.stacks: a queue of the TRV's loop \
                         must hold every ray of the TRV, or the loop can deadlock)",
                        t.stacks
                    ),
                ));
            }
        }
        range("trv.rau_entries", t.rau_entries, 1, 4096)?;
        for (key, v) in [
            ("trv.pre_latency", t.pre_latency),
            ("trv.pre_interval", t.pre_interval),
            ("trv.aabb_latency", t.aabb_latency),
            ("trv.aabb_interval", t.aabb_interval),
            ("trv.post_latency", t.post_latency),
            ("trv.post_interval", t.post_interval),
            ("ist.latency", self.ist.latency),
            ("ist.interval", self.ist.interval),
        ] {
            range(key, v, 1, 1000)?;
        }
        range("ist.input_buffer", self.ist.input_buffer, 1, 4096)?;
        range("ist.rau_entries", self.ist.rau_entries, 1, 4096)?;
        let s = &self.srp;
        if !(s.ops_per_cycle.is_finite() && s.ops_per_cycle > 0.0 && s.ops_per_cycle <= 10_000.0) {
            return Err(ConfigError::range(
                &k("srp.ops_per_cycle"),
                s.ops_per_cycle,
                "(0, 10000]",
            ));
        }
        range(
            "srp.packet_overhead_cycles",
            s.packet_overhead_cycles,
            0,
            100_000,
        )?;
        self.trv.l1.validate_at(&k("trv.l1"))?;
        self.ist.l1.validate_at(&k("ist.l1"))?;
        self.l2.validate_at(&k("l2"))?;
        self.srp.dcache.validate_at(&k("srp.dcache"))?;
        // Per core: a TRV L1 per traversal unit, the IST's L1, the SRP's data cache (counted
        // even with the shader off) and the core's L2 (`chip.rs`, `topology`).
        let cores = u64::from(self.cores);
        rtsim_cache::check_state_memory(&[
            (
                &k("trv.l1.size_bytes"),
                &self.trv.l1,
                cores * u64::from(self.trvs),
            ),
            (&k("ist.l1.size_bytes"), &self.ist.l1, cores),
            (&k("srp.dcache.size_bytes"), &self.srp.dcache, cores),
            (&k("l2.size_bytes"), &self.l2, cores),
        ])?;
        if self.trv.l1.line_bytes != self.l2.line_bytes {
            return Err(ConfigError::key(
                &k("trv.l1.line_bytes"),
                format!(
                    "= {} must equal arch.sgrt.l2.line_bytes = {} (the L1s miss to the L2)",
                    self.trv.l1.line_bytes, self.l2.line_bytes
                ),
            ));
        }
        if self
            .rays_file
            .as_ref()
            .is_some_and(|p| p.as_os_str().is_empty())
        {
            return Err(ConfigError::key(&k("rays_file"), "must not be empty"));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_validate_and_name_keys_in_errors() {
        SgrtConfig::default().validate().unwrap();
        let mut c = SgrtConfig::default();
        c.trv.fifo_entries = 8;
        let e = c.validate().unwrap_err().to_string();
        assert!(
            e.contains("arch.sgrt.trv.fifo_entries") && e.contains("16..=4096"),
            "{e}"
        );
        let c = SgrtConfig {
            cores: 0,
            ..SgrtConfig::default()
        };
        let e = c.validate().unwrap_err().to_string();
        assert!(e.contains("arch.sgrt.cores") && e.contains("1..=64"), "{e}");
        let mut c = SgrtConfig::default();
        c.srp.ops_per_cycle = 0.0;
        assert!(
            c.validate()
                .unwrap_err()
                .to_string()
                .contains("srp.ops_per_cycle")
        );
        let mut c = SgrtConfig::default();
        c.l2.line_bytes = 128;
        let e = c.validate().unwrap_err().to_string();
        assert!(e.contains("arch.sgrt.trv.l1.line_bytes"), "{e}");
        let mut c = SgrtConfig::default();
        c.ist.l1.size_bytes = 1000;
        let e = c.validate().unwrap_err().to_string();
        assert!(e.contains("arch.sgrt.ist.l1.size_bytes"), "{e}");
    }

    #[test]
    fn caches_too_large_for_the_host_name_the_key() {
        // 2^40 bytes is a valid cache size on its own; sixteen TRV L1s of it are not.
        let mut c = SgrtConfig::default();
        c.trv.l1.size_bytes = 1 << 40;
        let e = c.validate().unwrap_err().to_string();
        assert!(
            e.contains("arch.sgrt.trv.l1.size_bytes") && e.contains("GiB of host memory"),
            "{e}"
        );
        let mut c = SgrtConfig::default();
        c.l2.size_bytes = 1 << 38;
        let e = c.validate().unwrap_err().to_string();
        assert!(e.contains("arch.sgrt.l2.size_bytes"), "{e}");
    }

    #[test]
    fn unknown_keys_are_refused() {
        let e = toml::from_str::<SgrtConfig>("cores = 2\nwarp = 9\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("warp"), "{e}");
        let c: SgrtConfig =
            toml::from_str("organisation = \"sptrv\"\n[trv]\nstacks = 8\n").unwrap();
        assert_eq!(c.organisation, Organisation::Sptrv);
        assert_eq!(c.trv.stacks, 8);
        assert_eq!(c.trv.fifo_entries, 16);
    }
}
