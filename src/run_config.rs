//! The command line's side of the run configuration: flags and `--set`s become
//! [`rtsim_run::Inputs`]; the tree, its layering and validation live in `rtsim-run`.

use crate::cli::SceneArgs;
use anyhow::Result;
use rtsim_config::ConfigError;
pub use rtsim_run::{Resolved, RunConfig};
use toml::Value;

/// A flag given on the command line, as a dotted key and value.
pub type Flag = (&'static str, Value);

/// The built-in configuration (before presets and scene defaults) as TOML: what a key that a
/// point's build predates is taken to be (`rtsim sweep --reuse`, `rtsim report`).
pub fn builtin_defaults_toml() -> Result<String> {
    Ok(rtsim_config::to_toml_string(
        &rtsim_run::RunConfig::default(),
    )?)
}

/// The configuration an `arch.preset` alone gives (no scene, workload or other setting; the
/// DRAM preset it names unless `dram` gives another) as TOML: what `rtsim report` names a
/// point's departures from.
pub fn preset_toml(arch: &str, dram: Option<&str>) -> Result<String> {
    let mut inputs = rtsim_run::Inputs::default();
    inputs.flag("arch.preset", arch);
    if let Some(d) = dram {
        inputs.flag("dram.preset", d);
    }
    let config: RunConfig = rtsim_run::layers(&inputs, None)?.build()?;
    Ok(rtsim_config::to_toml_string(&config)?)
}

/// The run's inputs from the shared scene flags plus a command's own `flags`.
pub fn inputs(args: &SceneArgs, flags: &[Flag]) -> Result<rtsim_run::Inputs> {
    let mut i = rtsim_run::Inputs {
        config_file: args.config.clone(),
        config_text: None,
        flags: Vec::new(),
        sets: args.set.clone(),
    };
    if let Some(s) = &args.scene {
        i.flag("scene.name", s.clone());
    }
    if let Some(d) = &args.scene_dir {
        i.flag("scene.dir", d.display().to_string());
    }
    if let Some(seed) = args.seed {
        let seed = i64::try_from(seed)
            .map_err(|_| ConfigError::range("seed", seed, format!("0..={}", i64::MAX)))?;
        i.flag("seed", seed);
    }
    if let Some(t) = args.threads {
        let max = rtsim_run::MAX_THREADS;
        if t > max {
            return Err(
                ConfigError::range("--threads", t, format!("0..={max} (0 = all cores)")).into(),
            );
        }
        i.flag("threads", t as i64);
    }
    for (k, v) in flags {
        i.flag(k, v.clone());
    }
    Ok(i)
}

/// Resolve the configuration and load the scene, printing what loading noticed to stderr,
/// each note once per process (`rtsim compare` loads the scene once per architecture).
pub fn resolve(args: &SceneArgs, flags: &[Flag]) -> Result<Resolved> {
    static SAID: std::sync::Mutex<std::collections::BTreeSet<String>> =
        std::sync::Mutex::new(std::collections::BTreeSet::new());
    let inputs = inputs(args, flags)?;
    Ok(rtsim_run::resolve(&inputs, &mut |line| {
        let first = SAID
            .lock()
            .map_or(true, |mut said| said.insert(line.to_string()));
        if first {
            eprintln!("note: {}", rtsim_core::text::escape_controls(line))
        }
    })?)
}
