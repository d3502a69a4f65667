//! Cache configuration: one [`CacheLevel`] section per level and the [`CacheConfig`] tree of a
//! two-level hierarchy (L1s → L2s → memory) as `rtsim cache` and the chip models read it.
//!
//! Defaults are the TRaX baseline (`../shared/DESIGN.md` §3): per-TM L1 of 16 KB, direct-mapped,
//! 64 B lines, write-around, hit in 1 cycle; one 4 MB L2 shared by all TMs, hit in 3 cycles.
//! What the paper and SimTRaX's defaults do not give (bank counts, MSHRs, write buffers) is
//! marked "assumed" with the reason. Values are validated by [`Validate`] with errors naming
//! the key and the allowed range.

use rtsim_config::{ConfigError, Validate, check_range};
use serde::{Deserialize, Serialize};

/// Which line of a full set is replaced.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Replacement {
    /// Least recently used (a hit makes the line most recent; see `write_hit_updates_lru`).
    Lru,
    /// First in, first out: the oldest fill goes, hits change nothing.
    Fifo,
    /// A uniformly random way, from a PCG32 stream seeded per cache (deterministic).
    Random,
}

impl Replacement {
    pub const NAMES: [&'static str; 3] = ["lru", "fifo", "random"];
}

/// What a write does.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum WritePolicy {
    /// Write-around (TRaX, SimTRaX's default): every write goes on to the next level; a write
    /// hit also updates the cached line (write-through), a write miss does not allocate.
    /// Lines are never dirty.
    WriteAround,
    /// Write-back with write-allocate: a write hit marks the line dirty; a write miss fetches
    /// the line and marks it dirty; a dirty line is written to the next level when evicted.
    WriteBack,
}

impl WritePolicy {
    pub const NAMES: [&'static str; 2] = ["write-around", "write-back"];
}

/// One cache (every L1, or every L2, of a hierarchy has the same settings).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CacheLevel {
    /// Capacity in bytes. `size_bytes / (ways × line_bytes)` sets, which must be a power of
    /// two. L1 default 16384 (16 KB per TM, DESIGN.md §3); L2 default 4194304 (4 MB, §3).
    pub size_bytes: u64,
    /// Associativity, 1..=1024 (1 = direct-mapped). L1 and L2 default 1 (SimTRaX's caches are
    /// direct-mapped, DESIGN.md §3).
    pub ways: u32,
    /// Line size in bytes, a power of two in 4..=4096; on a DRAM model it must equal the DRAM's
    /// `organisation.line_bytes`. Default 64 (DESIGN.md §3; SGRT §4 also uses 64 B).
    pub line_bytes: u32,
    /// `lru`, `fifo` or `random`. Default `lru` (irrelevant when direct-mapped).
    pub replacement: Replacement,
    /// `write-around` or `write-back`. Default `write-around` (SimTRaX, DESIGN.md §3).
    pub write_policy: WritePolicy,
    /// LRU only: whether a write hit makes the line most recently used (true, as most hardware
    /// does) or leaves the order alone (false: only reads reorder, as pycachesim does).
    /// Default true.
    pub write_hit_updates_lru: bool,
    /// Banks, a power of two in 1..=256; each serves one access per cycle. The bank of an
    /// access is `(address / bank_bytes) mod banks`; with the default `bank_bytes` (the line)
    /// that is the line address modulo `banks` (the address bits just above the line offset),
    /// so consecutive lines go to consecutive banks. L1 default 8, L2 default 16
    /// (assumed: the papers say "banked" without a count; SGRT's L2 has 8, SGRT §4).
    pub banks: u32,
    /// Interleaving of the banks in bytes, a power of two in 4..=`line_bytes`: the bank of an
    /// access is `(address / bank_bytes) mod banks`. Unset (the default) = `line_bytes`: whole
    /// lines interleave. SimTRaX's L1 interleaves words (4: `bank_id = address % num_banks` on
    /// word addresses, `sim/L1Cache.cc`), so a TP's consecutive word loads go to consecutive
    /// banks.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bank_bytes: Option<u32>,
    /// Cycles from an access to its data on a hit (and to the request reaching the next level
    /// on a miss), 1..=10000. L1 default 1, L2 default 3 (SimTRaX, DESIGN.md §3).
    pub hit_latency: u32,
    /// Miss status holding registers: lines in flight at once, 1..=4096. A miss to a line
    /// already in flight merges into its MSHR; a miss with all MSHRs busy is refused
    /// (back-pressure). L1 default 32 (assumed: one per TP of a TM, which stalls on its own
    /// miss, so a TM's misses never wait for an MSHR); L2 default 4096 (SimTRaX's L2 has no
    /// limit, only the DRAM's read queues refuse; 4096 is more than `gddr5-trax`'s 16 × 80).
    pub mshrs: u32,
    /// Writes (write-throughs and write-backs) waiting for the next level to accept them,
    /// 1..=4096; a full write buffer refuses writes (back-pressure). L1 default 8, L2 default 64
    /// (assumed).
    pub write_buffer: u32,
    /// Inner caches (an L2) only: a read from a child that finds an earlier read of the same
    /// line still waiting for its bank joins it, and the one lookup answers both (request
    /// combining in the bank's input queue). Many TMs that start the same treelet at once ask
    /// the L2 for the same lines; without combining each asks separately and they queue on one
    /// bank. Default false (assumed: the papers do not say, and SimTRaX looks up every access);
    /// joined reads are counted in `combined`. Ignored at L1s (their misses merge in MSHRs).
    #[serde(default)]
    pub combine_reads: bool,
}

impl CacheLevel {
    /// TRaX's per-TM L1 (DESIGN.md §3).
    pub fn trax_l1() -> Self {
        CacheLevel {
            size_bytes: 16 * 1024,
            ways: 1,
            line_bytes: 64,
            replacement: Replacement::Lru,
            write_policy: WritePolicy::WriteAround,
            write_hit_updates_lru: true,
            banks: 8,
            bank_bytes: None,
            hit_latency: 1,
            mshrs: 32,
            write_buffer: 8,
            combine_reads: false,
        }
    }

    /// TRaX's shared L2 (DESIGN.md §3).
    pub fn trax_l2() -> Self {
        CacheLevel {
            size_bytes: 4 * 1024 * 1024,
            banks: 16,
            hit_latency: 3,
            // SimTRaX's L2 has no MSHR limit: a miss joins a line already coming (its pending
            // list is unbounded) or goes to USIMM, whose full read queue refuses it
            // (`sim/L2Cache.cc`). The range's top, 4096, exceeds the 16 × 80 read-queue
            // entries of `gddr5-trax`, so as there the DRAM's queues bound the reads in flight.
            mshrs: 4096,
            write_buffer: 64,
            ..Self::trax_l1()
        }
    }

    /// Bytes per bank before the next bank (`bank_bytes`, or the line).
    pub fn bank_interleave(&self) -> u32 {
        self.bank_bytes.unwrap_or(self.line_bytes)
    }

    /// Sets of the cache (valid after validation).
    pub fn sets(&self) -> u64 {
        self.size_bytes / (u64::from(self.ways) * u64::from(self.line_bytes))
    }

    /// Check ranges; `prefix` names the section in errors (`l1`, `l2`).
    pub fn validate_at(&self, prefix: &str) -> Result<(), ConfigError> {
        let key = |k: &str| {
            if prefix.is_empty() {
                k.to_string()
            } else {
                format!("{prefix}.{k}")
            }
        };
        let pow2 = |k: &str, v: u64, lo: u64, hi: u64| {
            if (lo..=hi).contains(&v) && v.is_power_of_two() {
                Ok(())
            } else {
                Err(ConfigError::range(
                    &key(k),
                    v,
                    format!("a power of two in {lo}..={hi}"),
                ))
            }
        };
        pow2("line_bytes", self.line_bytes.into(), 4, 4096)?;
        check_range(&key("ways"), self.ways, 1, 1024)?;
        let way_line = u64::from(self.ways) * u64::from(self.line_bytes);
        if self.size_bytes < way_line
            || self.size_bytes % way_line != 0
            || !(self.size_bytes / way_line).is_power_of_two()
            || self.size_bytes > 1 << 40
        {
            return Err(ConfigError::range(
                &key("size_bytes"),
                self.size_bytes,
                format!(
                    "ways × line_bytes ({way_line}) × a power of two, at most 2^40 (sets must be a \
                     power of two)"
                ),
            ));
        }
        pow2("banks", self.banks.into(), 1, 256)?;
        if let Some(b) = self.bank_bytes {
            pow2("bank_bytes", b.into(), 4, self.line_bytes.into())?;
        }
        check_range(&key("hit_latency"), self.hit_latency, 1, 10_000)?;
        check_range(&key("mshrs"), self.mshrs, 1, 4096)?;
        check_range(&key("write_buffer"), self.write_buffer, 1, 4096)?;
        Ok(())
    }
}

/// Most host memory a chip's cache models may take for their per-line state (tags,
/// replacement stamps, dirty flags): assumed, a quarter of the reference machine's 24 GB, so
/// that a mistyped size is an error naming the key, not an allocation failure or hours of
/// swapping.
pub const STATE_LIMIT_BYTES: u64 = 6 << 30;
/// Host bytes of state per cache line, at most: an 8-byte tag, an 8-byte replacement stamp
/// and a dirty flag ([`crate::Cache`]).
pub const STATE_BYTES_PER_LINE: u64 = 17;

/// Refuse a chip whose caches' simulated state would not fit the host: `caches` lists each
/// kind of cache as (its key, its level, how many the chip has). The error names the key of
/// the kind that takes the most.
pub fn check_state_memory(caches: &[(&str, &CacheLevel, u64)]) -> Result<(), ConfigError> {
    let bytes = |c: &CacheLevel, n: u64| {
        (c.size_bytes / u64::from(c.line_bytes.max(1)))
            .saturating_mul(n)
            .saturating_mul(STATE_BYTES_PER_LINE)
    };
    let total = caches
        .iter()
        .fold(0u64, |t, &(_, c, n)| t.saturating_add(bytes(c, n)));
    if total <= STATE_LIMIT_BYTES {
        return Ok(());
    }
    let &(key, worst, _) = caches
        .iter()
        .max_by_key(|&&(_, c, n)| bytes(c, n))
        .expect("a total above the limit comes from some cache");
    let gib = |b: u64| b as f64 / (1u64 << 30) as f64;
    let counts: Vec<String> = caches
        .iter()
        .map(|&(k, _, n)| format!("{n} × {}", k.trim_end_matches(".size_bytes")))
        .collect();
    Err(ConfigError::key(
        key,
        format!(
            "= {}: the chip's caches ({}) would need {:.1} GiB of host memory for their line \
             state (about {STATE_BYTES_PER_LINE} bytes per line); at most {:.0} GiB: make the \
             caches, or the number of them, smaller",
            worst.size_bytes,
            counts.join(", "),
            gib(total),
            gib(STATE_LIMIT_BYTES)
        ),
    ))
}

/// A two-level hierarchy: `l1_count` identical L1s, their L2s, then memory.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CacheConfig {
    /// Chip clock in MHz, in which every cache latency counts and requests are timed; the DRAM
    /// model's requester clock. 1..=100000. Default 1000 (TRaX's 1 GHz core, DESIGN.md §3).
    pub clock_mhz: u32,
    /// Number of L1 caches, 1..=65536. Default 1 (`rtsim cache` replays one stream; a TRaX chip
    /// has 128, one per TM).
    pub l1_count: u32,
    /// Seed of the `random` replacement streams (each cache has its own stream). Default 1.
    pub seed: u64,
    /// Cache levels, 1..=2: 1 = the L1s go straight to memory, 2 = L1s → L2s → memory.
    /// Default 2.
    pub levels: u32,
    /// L1s per L2 ("groups of TMs per L2"): 0 = one L2 shared by all L1s (the TRaX baseline);
    /// otherwise L1 `i` uses L2 `i / l1s_per_l2`. 0..=l1_count. Default 0.
    pub l1s_per_l2: u32,
    pub l1: CacheLevel,
    /// Settings of every L2 (ignored with `levels = 1`).
    pub l2: CacheLevel,
}

impl Default for CacheConfig {
    fn default() -> Self {
        CacheConfig {
            clock_mhz: 1000,
            l1_count: 1,
            seed: 1,
            levels: 2,
            l1s_per_l2: 0,
            l1: CacheLevel::trax_l1(),
            l2: CacheLevel::trax_l2(),
        }
    }
}

impl CacheConfig {
    /// Number of L2 caches (0 when disabled).
    pub fn l2_count(&self) -> u32 {
        match (self.levels, self.l1s_per_l2) {
            (1, _) => 0,
            (_, 0) => 1,
            (_, g) => self.l1_count.div_ceil(g),
        }
    }
}

impl Validate for CacheConfig {
    fn validate(&self) -> Result<(), ConfigError> {
        check_range("clock_mhz", self.clock_mhz, 1, 100_000)?;
        check_range("l1_count", self.l1_count, 1, 65_536)?;
        self.l1.validate_at("l1")?;
        check_range("levels", self.levels, 1, 2)?;
        if self.levels == 2 {
            self.l2.validate_at("l2")?;
            check_range("l1s_per_l2", self.l1s_per_l2, 0, self.l1_count)?;
        }
        Ok(())
    }
}
