//! The `[arch]` section: which machine runs the frame.
//!
//! `arch.preset` names an architecture preset. A preset is a TOML fragment merged beneath the
//! user's layers (`rtsim_config::assemble`); it may set keys of any section — a chip picks its
//! traversal variant, triangle test, memory layout and DRAM standard — and the user's file,
//! flags and `--set`s override any of them. `functional` (the default) is the functional
//! tracer alone: no timing. Each chip model's own settings are a table of `[arch]`:
//! `trax-baseline` is the TRaX chip of the STRaTA paper's baseline (`rtsim-trax`,
//! `arch.trax.*`); the `sgrt` presets are SGRT (`rtsim-sgrt`, `arch.sgrt.*`).

use rtsim_config::{ConfigError, Validate};
use serde::{Deserialize, Serialize};
use toml::{Table, Value};

/// The preset used when none is named.
pub const DEFAULT: &str = "functional";

/// The architecture of a run.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ArchConfig {
    /// Architecture preset (see [`ARCH_PRESETS`]). Default `functional`.
    pub preset: String,
    /// SGRT's settings (`arch.sgrt.*`, documented in `rtsim_sgrt::config`); used by the `sgrt`
    /// presets.
    pub sgrt: rtsim_sgrt::SgrtConfig,
    /// The TRaX chip (`trax-baseline`): every parameter, documented in
    /// `rtsim_trax::TraxConfig` and `docs/TRAX.md`.
    pub trax: rtsim_trax::TraxConfig,
    /// STRaTA's additions to the TRaX chip (`strata` preset): every parameter, documented in
    /// `rtsim_strata::StrataConfig` and `docs/STRATA.md`.
    pub strata: rtsim_strata::StrataConfig,
}

impl Default for ArchConfig {
    fn default() -> Self {
        ArchConfig {
            preset: DEFAULT.into(),
            sgrt: rtsim_sgrt::SgrtConfig::default(),
            trax: rtsim_trax::TraxConfig::default(),
            strata: rtsim_strata::StrataConfig::default(),
        }
    }
}

impl ArchConfig {
    /// Whether the run's machine is the TRaX chip (its section must then fit the run).
    pub fn is_trax(&self) -> bool {
        self.preset == "trax-baseline"
    }

    /// Whether the run's machine is STRaTA on the TRaX chip.
    pub fn is_strata(&self) -> bool {
        self.preset == "strata"
    }
}

impl Validate for ArchConfig {
    fn validate(&self) -> Result<(), ConfigError> {
        preset(&self.preset)?;
        self.sgrt.validate()?;
        self.strata.validate()?;
        self.trax.validate()
    }
}

/// The tables only some chips read, each with the presets whose chip reads it: the TRaX
/// chip's (`arch.trax`) is read by the baseline and by STRaTA, which runs on it; STRaTA's
/// additions (`arch.strata`) by STRaTA alone; SGRT's by the SGRT presets; main memory
/// (`dram`) by every timed chip. `functional`, the untimed tracer, reads none of them. A
/// setting in a table its run's chip does not read has no effect on the run.
pub const CHIP_TABLES: &[(&str, &[&str])] = &[
    ("arch.sgrt", &["sgrt", "sgrt-sptrv", "sgrt-1"]),
    ("arch.trax", &["trax-baseline", "strata"]),
    ("arch.strata", &["strata"]),
    (
        "dram",
        &["sgrt", "sgrt-sptrv", "sgrt-1", "trax-baseline", "strata"],
    ),
];

/// Whether the chip of `preset` reads the setting `key` (a dotted key). Only the chips' own
/// tables ([`CHIP_TABLES`]) are decided here; any other key is taken to be read.
pub fn reads(preset: &str, key: &str) -> bool {
    chip_table(key).is_none_or(|(_, presets)| presets.contains(&preset))
}

/// The chip table ([`CHIP_TABLES`]) holding `key`, if any.
pub fn chip_table(key: &str) -> Option<(&'static str, &'static [&'static str])> {
    CHIP_TABLES
        .iter()
        .copied()
        .find(|(table, _)| key.strip_prefix(table).is_some_and(|r| r.starts_with('.')))
}

/// What every SGRT preset sets besides `[arch.sgrt]` (SGRT paper §3–§4).
macro_rules! sgrt_common {
    () => {
        r#"
[trace]
traversal = "short-stack"   # the TRV's short stacks (SGRT §3.3; depth: trace.short_stack_entries)
triangle_test = "wald"      # the IST runs Wald's test (SGRT §3.2)

[bvh]
builder = "sweep"           # "built with a full SAH-based algorithm" (SGRT §4.2)

[dram]
preset = "lpddr3-1600"      # "32 bit 2-channel, close to LPDDR3", 12.8 GB/s (SGRT §4.2)
"#
    };
}

/// A named architecture preset.
#[derive(Clone, Copy, Debug)]
pub struct ArchPreset {
    pub name: &'static str,
    pub about: &'static str,
    /// The fragment merged beneath the user's layers (every value cited in it).
    pub toml: &'static str,
}

/// The architecture presets shipped with rtsim.
pub const ARCH_PRESETS: &[ArchPreset] = &[
    ArchPreset {
        name: "functional",
        about: "the functional tracer alone (no timing): the oracle every chip model matches",
        toml: "",
    },
    ArchPreset {
        name: "sgrt",
        about: "SGRT: 4 cores (T&I unit with parallel pipelined TRVs + SRP) on LPDDR3-1600",
        toml: concat!(
            "# SGRT (Lee et al., HPG 2013): four cores, parallel pipelined TRVs (SGRT §4).\n",
            "[arch.sgrt]\ncores = 4\norganisation = \"pptrv\"\n",
            sgrt_common!()
        ),
    },
    ArchPreset {
        name: "sgrt-sptrv",
        about: "SGRT with the conventional single pipelined TRV (Table 4's SPTRV), 4 cores",
        toml: concat!(
            "# SGRT with single pipelined TRVs (SGRT Table 4, §4.2).\n",
            "[arch.sgrt]\ncores = 4\norganisation = \"sptrv\"\n",
            sgrt_common!()
        ),
    },
    ArchPreset {
        name: "sgrt-1",
        about: "one SGRT core (Table 4: \"executed on a single T&I unit\"), PPTRV",
        toml: concat!(
            "# One SGRT core (Table 4: one T&I unit).\n",
            "[arch.sgrt]\ncores = 1\norganisation = \"pptrv\"\n",
            sgrt_common!()
        ),
    },
    ArchPreset {
        name: "trax-baseline",
        about: "the TRaX baseline chip of the STRaTA paper (128 TMs x 32 TPs at 1 GHz, 4 MB L2, \
                GDDR5): cycle-level timing and energy (docs/TRAX.md)",
        toml: TRAX_BASELINE,
    },
    ArchPreset {
        name: "strata",
        about: "STRaTA on the TRaX chip: 512 KB L2 + 4 MB ray stream memory, 16 KB treelets, \
                bit-stack traversal, fused box/triangle pipelines (docs/STRATA.md)",
        toml: STRATA,
    },
];

/// STRaTA (Kopta et al. 2015): the baseline chip (`arch.trax.*` defaults) with the stream
/// memory and fused pipelines (`arch.strata.*` defaults, each cited in
/// `rtsim_strata::StrataConfig`); the preset picks what STRaTA needs from the other sections.
const STRATA: &str = r#"
[trace]
# STRaTA §3.2: the bit-stack traversal (a ray carries a 4-byte stack); §3.3: the Plücker
# test of the triangle pipeline.
traversal = "bit-stack"
triangle_test = "plucker"

[memory]
# STRaTA §3.1: node and triangle treelets the size of the L1 (16 KB), with parent pointers.
layout = "treelets"
parent_pointers = true
treelet_bytes = 16384

[dram]
# The baseline's DRAM (Table 1 compares the two on the same memory).
preset = "gddr5-trax"
"#;

/// The TRaX baseline: the chip's own parameters are `arch.trax.*`'s defaults (each cited in
/// `rtsim_trax::TraxConfig`); the preset picks what the chip needs from the other sections.
const TRAX_BASELINE: &str = r#"
[trace]
# STRaTA §3.2 and §5: the baseline keeps a full traversal stack in the TP's 512 B local memory
# and visits the nearer child first.
traversal = "stack"
order = "nearest-first"
# DESIGN.md §2: Möller–Trumbore is the baseline TRaX triangle kernel.
triangle_test = "moller-trumbore"

[memory]
# SimTRaX lays nodes out so that sibling pairs share a 64-byte line (BVH::LoadIntoMemory;
# docs/MEMORY_IMAGE.md); the baseline has no treelets.
layout = "linear"
align_sibling_pairs = true

[dram]
# DESIGN.md §3: what the STRaTA authors simulated (16 x 32 GB/s channels, DDR3-1600 timings
# at 2 GHz, DDR3 currents x 16 chips) is the model that reproduces Table 1's DRAM energies.
preset = "gddr5-trax"
"#;

/// Look up a preset by name.
pub fn preset(name: &str) -> Result<&'static ArchPreset, ConfigError> {
    ARCH_PRESETS.iter().find(|p| p.name == name).ok_or_else(|| {
        let known: Vec<&str> = ARCH_PRESETS.iter().map(|p| p.name).collect();
        ConfigError::unknown("architecture preset (arch.preset)", name, &known)
    })
}

/// A preset's fragment as a table, with `arch.preset` set to its name.
pub fn preset_table(name: &str) -> Result<Table, ConfigError> {
    let p = preset(name)?;
    let mut t = rtsim_config::parse_toml(p.toml, &format!("architecture preset {name}"))?;
    let arch = t
        .entry("arch")
        .or_insert_with(|| Value::Table(Table::new()));
    if let Value::Table(a) = arch {
        a.insert("preset".into(), Value::String(name.into()));
    }
    Ok(t)
}
