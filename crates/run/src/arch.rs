//! The `[arch]` section: which machine runs the frame.
//!
//! `arch.preset` names an architecture preset. A preset is a TOML fragment merged beneath the
//! user's layers (`rtsim_config::assemble`); it may set keys of any section — a chip picks its
//! traversal variant, triangle test, memory layout and DRAM standard — and the user's file,
//! flags and `--set`s override any of them. `functional` (the default) is the functional
//! tracer alone: no timing.

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
}

impl Default for ArchConfig {
    fn default() -> Self {
        ArchConfig {
            preset: DEFAULT.into(),
        }
    }
}

impl Validate for ArchConfig {
    fn validate(&self) -> Result<(), ConfigError> {
        preset(&self.preset).map(|_| ())
    }
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
pub const ARCH_PRESETS: &[ArchPreset] = &[ArchPreset {
    name: "functional",
    about: "the functional tracer alone (no timing): the oracle every chip model matches",
    toml: "",
}];

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
