//! [`TraxConfig`]: every parameter of the TRaX baseline chip (`arch.trax.*`), with its
//! default, unit and source, and its validation.
//!
//! Sources: the STRaTA paper (Kopta et al., "Memory Considerations for Low Energy Ray
//! Tracing", CGF 2015) §3 and §5 and Table 2; SimTRaX's configuration for what the paper leaves
//! open, as collected in `../shared/DESIGN.md` §3. Values that neither gives are marked
//! "assumed" with the reason. Errors name the full key (`arch.trax.units.fp_add.count`) and the
//! allowed range.

use rtsim_cache::CacheLevel;
use rtsim_config::{ConfigError, Validate, check_range};
use rtsim_trace::{TraceConfig, Traversal, TriangleTest};
use serde::{Deserialize, Serialize};

/// The key prefix of this section in the run configuration.
pub const PREFIX: &str = "arch.trax";

/// One class of shared execution units in a TM: how many operations it can start per cycle
/// (the units are fully pipelined), how long each takes, and what one costs in energy.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct UnitConfig {
    /// Operations the TM's units of this class can issue per cycle (the number of units),
    /// 1..=64.
    pub count: u32,
    /// Cycles from issue to the result being readable by the next instruction, 1..=1000.
    pub latency: u32,
    /// Energy per operation in nJ, ≥ 0.
    pub energy_nj: f64,
}

impl UnitConfig {
    const fn new(count: u32, latency: u32, energy_nj: f64) -> Self {
        UnitConfig {
            count,
            latency,
            energy_nj,
        }
    }

    fn validate_at(&self, key: &str) -> Result<(), ConfigError> {
        check_range(&format!("{key}.count"), self.count, 1, 64)?;
        check_range(&format!("{key}.latency"), self.latency, 1, 1000)?;
        check_energy(&format!("{key}.energy_nj"), self.energy_nj)
    }
}

/// The shared execution units of a TM, one entry per class.
///
/// Defaults: the paper's 8 FP multipliers and 8 FP adders of latency 2 and the 16-cycle divide
/// (STRaTA §3.3, §5); SimTRaX's matching configuration for the rest (`DESIGN.md` §3: 16 each of
/// min/max, compare, integer add, conversion, branch and bitwise, 2 integer multipliers, one
/// unit shared by divide and inverse square root; every other latency 1). Energies per
/// operation are SimTRaX's (`DESIGN.md` §3); conversion, branch and bitwise have none there
/// and are assumed to cost what an integer add costs (simple integer datapaths).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Units {
    /// FP add/subtract: 8, latency 2, 0.0074 nJ (STRaTA §3.3; SimTRaX energy).
    pub fp_add: UnitConfig,
    /// FP multiply: 8, latency 2, 0.0142 nJ (STRaTA §3.3; SimTRaX energy).
    pub fp_mul: UnitConfig,
    /// FP min/max: 16, latency 1, 0.000536 nJ (SimTRaX; "comparisons have a latency of one
    /// cycle", STRaTA §3.3).
    pub fp_minmax: UnitConfig,
    /// FP compare: 16, latency 1, 0.000536 nJ (SimTRaX).
    pub fp_cmp: UnitConfig,
    /// Integer add/subtract/compare: 16, latency 1, 0.000572 nJ (SimTRaX).
    pub int_add: UnitConfig,
    /// Integer multiply: 2, latency 1, 0.0177 nJ (SimTRaX).
    pub int_mul: UnitConfig,
    /// FP divide and inverse square root, one unit for both: 1, latency 16, 0.1563 nJ
    /// (STRaTA §3.3: "a high-latency divide (16 cycles)"; SimTRaX).
    pub div_sqrt: UnitConfig,
    /// Int ↔ float conversion: 16, latency 1, 0.000572 nJ (SimTRaX count; energy assumed =
    /// integer add).
    pub conv: UnitConfig,
    /// Branch: 16, latency 1, 0.000572 nJ (SimTRaX count; energy assumed = integer add). The
    /// TP has no branch prediction: the instruction after a branch issues `latency` cycles
    /// after it at the earliest.
    pub branch: UnitConfig,
    /// Bitwise and shift: 16, latency 1, 0.000572 nJ (SimTRaX count; energy assumed = integer
    /// add).
    pub bitwise: UnitConfig,
}

impl Default for Units {
    fn default() -> Self {
        const INT_ADD_NJ: f64 = 0.000572;
        Units {
            fp_add: UnitConfig::new(8, 2, 0.0074),
            fp_mul: UnitConfig::new(8, 2, 0.0142),
            fp_minmax: UnitConfig::new(16, 1, 0.000536),
            fp_cmp: UnitConfig::new(16, 1, 0.000536),
            int_add: UnitConfig::new(16, 1, INT_ADD_NJ),
            int_mul: UnitConfig::new(2, 1, 0.0177),
            div_sqrt: UnitConfig::new(1, 16, 0.1563),
            conv: UnitConfig::new(16, 1, INT_ADD_NJ),
            branch: UnitConfig::new(16, 1, INT_ADD_NJ),
            bitwise: UnitConfig::new(16, 1, INT_ADD_NJ),
        }
    }
}

impl Units {
    /// The classes in [`crate::isa::Class`] order (the first [`crate::isa::UNIT_CLASSES`]).
    pub fn by_class(&self) -> [(&'static str, &UnitConfig); crate::isa::CONFIGURED_UNITS] {
        [
            ("fp_add", &self.fp_add),
            ("fp_mul", &self.fp_mul),
            ("fp_minmax", &self.fp_minmax),
            ("fp_cmp", &self.fp_cmp),
            ("int_add", &self.int_add),
            ("int_mul", &self.int_mul),
            ("div_sqrt", &self.div_sqrt),
            ("conv", &self.conv),
            ("branch", &self.branch),
            ("bitwise", &self.bitwise),
        ]
    }
}

/// Per-access energies of the memories (per-operation energies are in [`Units`]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct EnergyConfig {
    /// nJ per L1 data-cache access. Unset: from SimTRaX's CACTI table by the L1's size
    /// (32 KB 0.165, 128 KB 0.364, 512 KB 0.560 nJ; `DESIGN.md` §3), power-law interpolated
    /// between its two nearest sizes — for the 16 KB baseline, extrapolated to 0.111 nJ
    /// (assumed: the table has no 16 KB entry).
    pub l1_access_nj: Option<f64>,
    /// nJ per L2 access. Unset: STRaTA Table 2 (CACTI 6.5) by the L2's size (512 KB 0.524 …
    /// 4 MB 0.901 … 16 MB 1.61), interpolated the same way between table sizes.
    pub l2_access_nj: Option<f64>,
    /// nJ per instruction fetch: 0.014 (STRaTA Table 2, 4 KB instruction cache).
    pub icache_fetch_nj: f64,
    /// nJ per register-file access (one per source register read and per destination
    /// written): 0.008 (STRaTA Table 2, 128 B register file).
    pub register_access_nj: f64,
    /// nJ per local-memory word access: 0.00693 (SimTRaX's local store, `DESIGN.md` §3).
    pub local_access_nj: f64,
    /// nJ per atomic increment: 0.000572 (assumed: an integer add on the global counter).
    pub atomic_nj: f64,
}

impl Default for EnergyConfig {
    fn default() -> Self {
        EnergyConfig {
            l1_access_nj: None,
            l2_access_nj: None,
            icache_fetch_nj: 0.014,
            register_access_nj: 0.008,
            local_access_nj: 0.00693,
            atomic_nj: 0.000572,
        }
    }
}

/// The TRaX baseline chip (`arch.trax`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct TraxConfig {
    /// Thread multiprocessors (TMs), 1..=4096. Default 128 (STRaTA §5: "128 TMs which results
    /// in 4096 total TPs").
    pub tms: u32,
    /// Thread processors (TPs) per TM, 1..=1024. Default 32 (STRaTA Figure 3 and §5).
    pub tps_per_tm: u32,
    /// Core clock in MHz, 1..=100000. Default 1000 (STRaTA §5: "a 1 GHz core clock rate").
    /// The DRAM runs at its own clock (`dram.organisation`/`dram.timing`, `gddr5-trax`: 2 GHz).
    pub clock_mhz: u32,
    /// General-purpose registers per TP, 32..=256. Default 32 (STRaTA §5). The ray program is
    /// written for 32 (`docs/TRAX_PROGRAM.md`); more registers change nothing but are allowed
    /// for the record.
    pub registers: u32,
    /// Local memory per TP in bytes (the traversal stack, 8 B per entry), a multiple of 8 in
    /// 8..=65536, and at least `trace.stack_entries × 8`. Default 512 (STRaTA §5).
    pub local_memory_bytes: u32,
    /// Local-memory access latency in cycles, 1..=1000. Default 1 (issue 8: "512 B local
    /// memory at 1 cycle").
    pub local_latency: u32,
    /// The shared execution units of a TM.
    pub units: Units,
    /// Instruction caches per TM, 1..=`tps_per_tm`; TP `i` of a TM fetches from cache
    /// `i mod icaches_per_tm`. Default 4 (SimTRaX's scripts, `DESIGN.md` §3).
    pub icaches_per_tm: u32,
    /// Bytes of each instruction cache, 64..=1048576; the whole program must fit (it is
    /// resident: no instruction misses). Default 4096 (STRaTA Table 2).
    pub icache_bytes: u32,
    /// Banks per instruction cache, a power of two in 1..=256; instruction `pc` is in bank
    /// `(pc / 4) mod banks`. Default 16 (SimTRaX's scripts).
    pub icache_banks: u32,
    /// Fetches each bank serves per cycle, 1..=64. Default 2 (SimTRaX, `DESIGN.md` §3).
    pub fetches_per_bank: u32,
    /// The chip-wide atomic increment that hands out pixels (TRaX's `atominc` on a global
    /// register): increments per cycle, latency to the result, energy. Default 1 per cycle,
    /// latency 1 (assumed: one global register port; SimTRaX serialises atomics).
    pub atomic: UnitConfig,
    /// TMs per L2: 0 = one L2 shared by all TMs (the baseline, STRaTA §5); otherwise TM `i`
    /// uses L2 `i / l1s_per_l2`. 0..=`tms`.
    pub l1s_per_l2: u32,
    /// The L1 data cache of each TM. Default: 16 KB (STRaTA §5) direct-mapped, 64 B lines,
    /// hit 1, write-around (SimTRaX, `DESIGN.md` §3), 16 word-interleaved banks
    /// (`bank_bytes = 4`: SimTRaX's `samples/configs/bigcache.config` gives the L1 16 banks and
    /// its `sim/L1Cache.cc` picks the bank from the word address), 32 MSHRs (assumed, one per
    /// TP).
    pub l1: CacheLevel,
    /// Each L2. Default 4 MB direct-mapped, 16 banks, hit 3 (`CacheLevel::trax_l2`; STRaTA
    /// §5, SimTRaX).
    pub l2: CacheLevel,
    /// Per-access energies of the memories.
    pub energy: EnergyConfig,
}

impl Default for TraxConfig {
    fn default() -> Self {
        TraxConfig {
            tms: 128,
            tps_per_tm: 32,
            clock_mhz: 1000,
            registers: 32,
            local_memory_bytes: 512,
            local_latency: 1,
            units: Units::default(),
            icaches_per_tm: 4,
            icache_bytes: 4096,
            icache_banks: 16,
            fetches_per_bank: 2,
            atomic: UnitConfig::new(1, 1, 0.000572),
            l1s_per_l2: 0,
            l1: CacheLevel {
                banks: 16,
                bank_bytes: Some(4),
                ..CacheLevel::trax_l1()
            },
            l2: CacheLevel::trax_l2(),
            energy: EnergyConfig::default(),
        }
    }
}

fn key(k: &str) -> String {
    format!("{PREFIX}.{k}")
}

fn check_energy(key: &str, v: f64) -> Result<(), ConfigError> {
    if v.is_finite() && v >= 0.0 {
        Ok(())
    } else {
        Err(ConfigError::range(key, v, "a finite value ≥ 0 (nJ)"))
    }
}

impl Validate for TraxConfig {
    fn validate(&self) -> Result<(), ConfigError> {
        check_range(&key("tms"), self.tms, 1, 4096)?;
        check_range(&key("tps_per_tm"), self.tps_per_tm, 1, 1024)?;
        check_range(&key("clock_mhz"), self.clock_mhz, 1, 100_000)?;
        check_range(&key("registers"), self.registers, 32, 256)?;
        if !(8..=65536).contains(&self.local_memory_bytes) || self.local_memory_bytes % 8 != 0 {
            return Err(ConfigError::range(
                &key("local_memory_bytes"),
                self.local_memory_bytes,
                "a multiple of 8 in 8..=65536",
            ));
        }
        check_range(&key("local_latency"), self.local_latency, 1, 1000)?;
        for (name, u) in self.units.by_class() {
            u.validate_at(&key(&format!("units.{name}")))?;
        }
        check_range(
            &key("icaches_per_tm"),
            self.icaches_per_tm,
            1,
            self.tps_per_tm,
        )?;
        check_range(&key("icache_bytes"), self.icache_bytes, 64, 1 << 20)?;
        if !(1..=256).contains(&self.icache_banks) || !self.icache_banks.is_power_of_two() {
            return Err(ConfigError::range(
                &key("icache_banks"),
                self.icache_banks,
                "a power of two in 1..=256",
            ));
        }
        check_range(&key("fetches_per_bank"), self.fetches_per_bank, 1, 64)?;
        self.atomic.validate_at(&key("atomic"))?;
        check_range(&key("l1s_per_l2"), self.l1s_per_l2, 0, self.tms)?;
        self.l1.validate_at(&key("l1"))?;
        self.l2.validate_at(&key("l2"))?;
        self.check_cache_state_memory()?;
        if self.l1.line_bytes != self.l2.line_bytes {
            return Err(ConfigError::key(
                &key("l1.line_bytes"),
                format!(
                    "= {} must equal {} = {} (one line moves between the caches)",
                    self.l1.line_bytes,
                    key("l2.line_bytes"),
                    self.l2.line_bytes
                ),
            ));
        }
        let e = &self.energy;
        for (k, v) in [
            ("energy.l1_access_nj", e.l1_access_nj),
            ("energy.l2_access_nj", e.l2_access_nj),
        ] {
            if let Some(v) = v {
                check_energy(&key(k), v)?;
            }
        }
        for (k, v) in [
            ("energy.icache_fetch_nj", e.icache_fetch_nj),
            ("energy.register_access_nj", e.register_access_nj),
            ("energy.local_access_nj", e.local_access_nj),
            ("energy.atomic_nj", e.atomic_nj),
        ] {
            check_energy(&key(k), v)?;
        }
        Ok(())
    }
}

impl TraxConfig {
    /// The number of L2s: one per `l1s_per_l2` TMs (the last group may be smaller), or one.
    fn l2_count(&self) -> u64 {
        match self.l1s_per_l2 {
            0 => 1,
            g => u64::from(self.tms.div_ceil(g)),
        }
    }

    /// Refuse caches whose simulated state would not fit the host: every TM's L1 and every
    /// L2 keeps state per line.
    fn check_cache_state_memory(&self) -> Result<(), ConfigError> {
        rtsim_cache::check_state_memory(&[
            (&key("l1.size_bytes"), &self.l1, u64::from(self.tms)),
            (&key("l2.size_bytes"), &self.l2, self.l2_count()),
        ])
    }

    /// Checks against the rest of the run: the program is the `stack` traversal with
    /// Möller–Trumbore (issue 8 §2), and the stack must fit the local memory.
    pub fn validate_run(&self, trace: &TraceConfig) -> Result<(), ConfigError> {
        self.validate()?;
        if trace.traversal != Traversal::Stack {
            return Err(ConfigError::key(
                "trace.traversal",
                format!(
                    "= {}: the TRaX baseline's ray program is the `stack` traversal (STRaTA §5 \
                     baseline); set trace.traversal = \"stack\"",
                    trace.traversal.name()
                ),
            ));
        }
        if trace.triangle_test != TriangleTest::MollerTrumbore {
            return Err(ConfigError::key(
                "trace.triangle_test",
                "the TRaX baseline's ray program tests triangles with Möller–Trumbore; set \
                 trace.triangle_test = \"moller-trumbore\"",
            ));
        }
        let need = trace.stack_entries * rtsim_trace::step::stack::ENTRY_BYTES;
        if self.local_memory_bytes < need {
            return Err(ConfigError::key(
                &key("local_memory_bytes"),
                format!(
                    "= {} cannot hold trace.stack_entries = {} stack entries of {} B ({need} B); \
                     raise it or lower trace.stack_entries",
                    self.local_memory_bytes,
                    trace.stack_entries,
                    rtsim_trace::step::stack::ENTRY_BYTES
                ),
            ));
        }
        Ok(())
    }

    /// Thread processors on the chip.
    pub fn total_tps(&self) -> u32 {
        self.tms * self.tps_per_tm
    }

    /// The two-level cache tree this chip builds (`rtsim_cache` form).
    pub fn cache_config(&self, seed: u64) -> rtsim_cache::CacheConfig {
        rtsim_cache::CacheConfig {
            clock_mhz: self.clock_mhz,
            l1_count: self.tms,
            seed,
            levels: 2,
            l1s_per_l2: self.l1s_per_l2,
            l1: self.l1.clone(),
            l2: self.l2.clone(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn err(f: impl FnOnce(&mut TraxConfig)) -> String {
        let mut c = TraxConfig::default();
        f(&mut c);
        c.validate().unwrap_err().to_string()
    }

    #[test]
    fn defaults_are_valid_and_the_papers() {
        let c = TraxConfig::default();
        c.validate().unwrap();
        assert_eq!(c.total_tps(), 4096);
        assert_eq!((c.units.fp_add.count, c.units.fp_add.latency), (8, 2));
        assert_eq!((c.units.div_sqrt.count, c.units.div_sqrt.latency), (1, 16));
        assert_eq!(c.l1.size_bytes, 16 * 1024);
        assert_eq!((c.l1.banks, c.l1.bank_interleave()), (16, 4));
        assert_eq!(c.l2.size_bytes, 4 << 20);
    }

    #[test]
    fn bad_values_name_their_keys() {
        let e = err(|c| c.tms = 0);
        assert!(e.contains("arch.trax.tms") && e.contains("1..=4096"), "{e}");
        let e = err(|c| c.units.fp_mul.count = 0);
        assert!(
            e.contains("arch.trax.units.fp_mul.count") && e.contains("1..=64"),
            "{e}"
        );
        let e = err(|c| c.units.div_sqrt.latency = 0);
        assert!(e.contains("arch.trax.units.div_sqrt.latency"), "{e}");
        // An L1 larger than the cache model can address (2^40 bytes).
        let e = err(|c| c.l1.size_bytes = 1 << 41);
        assert!(
            e.contains("arch.trax.l1.size_bytes") && e.contains("2^40"),
            "{e}"
        );
        let e = err(|c| c.l1.size_bytes = 3000);
        assert!(e.contains("arch.trax.l1.size_bytes"), "{e}");
        let e = err(|c| c.icache_banks = 3);
        assert!(e.contains("arch.trax.icache_banks"), "{e}");
        let e = err(|c| c.icaches_per_tm = 33);
        assert!(e.contains("arch.trax.icaches_per_tm"), "{e}");
        // 2^40 bytes is a valid cache size, but 128 of them do not fit the host: an error
        // naming the key, not an allocation failure (nor 8 GB L1s that swap for hours).
        for size in [1u64 << 40, 8 << 30] {
            let e = err(|c| c.l1.size_bytes = size);
            assert!(
                e.contains("arch.trax.l1.size_bytes") && e.contains("GiB of host memory"),
                "{e}"
            );
        }
        let e = err(|c| c.l2.size_bytes = 1 << 40);
        assert!(e.contains("arch.trax.l2.size_bytes"), "{e}");
        // Paper-scale sizes pass: Figure 5's 16 MB L2.
        let mut c = TraxConfig::default();
        c.l2.size_bytes = 16 << 20;
        c.validate().unwrap();
        let e = err(|c| c.l1s_per_l2 = 129);
        assert!(e.contains("arch.trax.l1s_per_l2"), "{e}");
        let e = err(|c| c.local_memory_bytes = 100);
        assert!(e.contains("arch.trax.local_memory_bytes"), "{e}");
        let e = err(|c| c.energy.register_access_nj = -1.0);
        assert!(e.contains("arch.trax.energy.register_access_nj"), "{e}");
        let e = err(|c| c.l2.line_bytes = 128);
        assert!(e.contains("arch.trax.l1.line_bytes"), "{e}");
    }

    #[test]
    fn the_run_must_use_the_stack_traversal_that_fits() {
        let c = TraxConfig::default();
        let mut t = TraceConfig::default();
        c.validate_run(&t).unwrap();
        t.traversal = Traversal::BitStack;
        assert!(
            c.validate_run(&t)
                .unwrap_err()
                .to_string()
                .contains("trace.traversal")
        );
        let mut t = TraceConfig {
            triangle_test: TriangleTest::Plucker,
            ..TraceConfig::default()
        };
        assert!(
            c.validate_run(&t)
                .unwrap_err()
                .to_string()
                .contains("trace.triangle_test")
        );
        t.triangle_test = TriangleTest::MollerTrumbore;
        let small = TraxConfig {
            local_memory_bytes: 256,
            ..TraxConfig::default()
        };
        let e = small.validate_run(&t).unwrap_err().to_string();
        assert!(
            e.contains("arch.trax.local_memory_bytes") && e.contains("64"),
            "{e}"
        );
    }

    #[test]
    fn unknown_keys_are_refused() {
        let e = toml::from_str::<TraxConfig>("tms = 4\nwarp = 1\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("warp"), "{e}");
        let c: TraxConfig =
            toml::from_str("tms = 4\n[units.fp_add]\ncount = 4\nlatency = 3\nenergy_nj = 0.01\n")
                .unwrap();
        assert_eq!(c.units.fp_add.count, 4);
        assert_eq!(c.units.fp_mul, Units::default().fp_mul);
    }
}
