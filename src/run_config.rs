//! The configuration tree of a run and how it is assembled from layers.
//!
//! Layer order (later wins): built-in defaults → the scene descriptor's `[workload]` defaults →
//! `--config FILE` → command-line flags (`--width`, `--seed` …) → `--set key=value`. The result
//! is validated before anything is built and written back as `config.resolved.toml`.

use crate::cli::SceneArgs;
use anyhow::{Context, Result};
use rtsim_bvh::{BvhConfig, MemoryLayoutConfig};
use rtsim_config::{ConfigError, Layers, Validate, check_range};
use rtsim_scene::{Scene, SceneRequest};
use rtsim_trace::{TraceConfig, WorkloadConfig};
use serde::{Deserialize, Serialize};
use std::path::PathBuf;
use toml::Value;

/// Everything a functional run needs. Each section's fields are documented in its crate.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RunConfig {
    /// Run seed: procedural scenes and all sampling derive from it. Default 1.
    pub seed: u64,
    /// Worker threads; 0 = all cores. Default 0. Results do not depend on it.
    pub threads: usize,
    pub scene: SceneConfig,
    pub bvh: BvhConfig,
    pub memory: MemoryLayoutConfig,
    pub trace: TraceConfig,
    pub workload: WorkloadConfig,
    pub output: OutputConfig,
}

impl Default for RunConfig {
    fn default() -> Self {
        RunConfig {
            seed: 1,
            threads: 0,
            scene: SceneConfig::default(),
            bvh: BvhConfig::default(),
            memory: MemoryLayoutConfig::default(),
            trace: TraceConfig::default(),
            workload: WorkloadConfig::default(),
            output: OutputConfig::default(),
        }
    }
}

/// Which scene to load.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SceneConfig {
    /// Built-in name, descriptor name, or path. Default `cornell` (built in, needs no files).
    pub name: String,
    /// Size factor for procedural scenes; 1 = documented default size. Range (0, 4].
    pub size: f64,
    /// Scene directory. Default: `$RTSIM_SCENE_DIR`, else `../shared/scenes` if it exists.
    pub dir: Option<PathBuf>,
}

impl Default for SceneConfig {
    fn default() -> Self {
        SceneConfig {
            name: "cornell".into(),
            size: 1.0,
            dir: None,
        }
    }
}

/// Where and what to write.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct OutputConfig {
    /// Output directory. Default `out`.
    pub dir: PathBuf,
    /// Write the nodes-visited heat map PNG. Default true.
    pub heatmap: bool,
    /// Image exposure: unset = automatic (the frame's log-average luminance is mapped to
    /// middle grey, then Reinhard's L/(1+L)); a number = linear scale then clamp. AO images
    /// are always linear (their values are visibility fractions).
    pub exposure: Option<f32>,
}

impl Default for OutputConfig {
    fn default() -> Self {
        OutputConfig {
            dir: PathBuf::from("out"),
            heatmap: true,
            exposure: None,
        }
    }
}

impl Validate for RunConfig {
    fn validate(&self) -> Result<(), ConfigError> {
        check_range("threads", self.threads, 0, 4096)?;
        if !(self.scene.size > 0.0 && self.scene.size <= 4.0) {
            return Err(ConfigError::range("scene.size", self.scene.size, "(0, 4]"));
        }
        if self.scene.name.trim().is_empty() {
            return Err(ConfigError::key("scene.name", "must not be empty"));
        }
        if let Some(e) = self.output.exposure {
            rtsim_config::check_positive("output.exposure", e as f64)?;
        }
        self.bvh.validate()?;
        self.memory.validate()?;
        self.trace.validate()?;
        self.workload.validate()?;
        Ok(())
    }
}

/// A flag given on the command line, as a dotted key and value.
pub type Flag = (&'static str, Value);

/// The loaded configuration and scene of a run.
#[derive(Debug)]
pub struct Resolved {
    pub config: RunConfig,
    pub scene: Scene,
    /// Where each layer came from, in order.
    pub origins: Vec<String>,
}

/// Assemble the layers for `args` plus extra command-line `flags`, load the scene (logging
/// what loading dropped or noticed to stderr), and re-assemble with the scene's workload defaults underneath the user's layers.
pub fn resolve(args: &SceneArgs, flags: &[Flag]) -> Result<Resolved> {
    let first = layers(args, flags, None)?;
    let config: RunConfig = first.build()?;
    let scene_dir = rtsim_scene::resolve_scene_dir(config.scene.dir.as_deref());
    let scene = rtsim_scene::load_scene(&SceneRequest {
        name: &config.scene.name,
        size: config.scene.size,
        seed: config.seed,
        scene_dir: scene_dir.as_deref(),
    })
    .with_context(|| format!("loading scene `{}`", config.scene.name))?;
    // What loading dropped or noticed (zero-area triangles, missing MTL files …).
    for line in scene.report.log_lines() {
        eprintln!("note: scene `{}`: {line}", scene.name);
    }
    let (config, origins) = if scene.workload_defaults.is_empty() {
        (config, first.origins().to_vec())
    } else {
        let second = layers(args, flags, Some(&scene.workload_defaults))?;
        (second.build()?, second.origins().to_vec())
    };
    let mut config = config;
    // Record the concrete values the defaults resolved to, so the resolved file repeats the run.
    let (w, h, s) = config.workload.resolved_size();
    config.workload.width = Some(w);
    config.workload.height = Some(h);
    config.workload.spp = Some(s);
    if config.workload.ao_radius.is_none() {
        // Assumed default: 10 % of the scene diagonal when neither the descriptor nor the user
        // gives a radius (Aila–Laine use per-scene constants, e.g. 5 for Sibenik).
        let b = scene.bounds();
        let diag = if b.is_empty() {
            1.0
        } else {
            b.extent().length()
        };
        config.workload.ao_radius = Some(0.1 * diag);
    }
    if config.scene.dir.is_none() {
        config.scene.dir = scene_dir;
    }
    Ok(Resolved {
        config,
        scene,
        origins,
    })
}

/// The configuration layers without loading a scene (for commands that need none).
pub fn layers(
    args: &SceneArgs,
    flags: &[Flag],
    workload_defaults: Option<&toml::Table>,
) -> Result<Layers> {
    let mut l = Layers::new();
    l.merge_value(&RunConfig::default(), "built-in defaults")?;
    if let Some(w) = workload_defaults {
        l.merge_table_at("workload", w.clone(), "scene descriptor [workload]");
    }
    if let Some(path) = &args.config {
        l.merge_file(path)?;
    }
    let mut all: Vec<Flag> = Vec::new();
    if let Some(s) = &args.scene {
        all.push(("scene.name", Value::String(s.clone())));
    }
    if let Some(d) = &args.scene_dir {
        all.push(("scene.dir", Value::String(d.display().to_string())));
    }
    if let Some(seed) = args.seed {
        all.push(("seed", Value::Integer(clamp_i64(seed)?)));
    }
    if let Some(t) = args.threads {
        all.push(("threads", Value::Integer(t.min(i64::MAX as usize) as i64)));
    }
    all.extend(flags.iter().cloned());
    for (key, value) in all {
        l.set_value(key, value)
            .map_err(|m| ConfigError::key(key, m))?;
    }
    for s in &args.set {
        l.set(s)?;
    }
    Ok(l)
}

fn clamp_i64(v: u64) -> Result<i64> {
    i64::try_from(v).map_err(|_| ConfigError::range("seed", v, format!("0..={}", i64::MAX)).into())
}

/// `config.resolved.toml` text: a header naming the layers, then the full tree.
pub fn resolved_toml(r: &Resolved) -> Result<String> {
    let mut s = String::from(
        "# rtsim resolved configuration: `rtsim render --config THIS_FILE` repeats the run.\n",
    );
    for o in &r.origins {
        s.push_str(&format!("# layer: {o}\n"));
    }
    s.push_str(&rtsim_config::to_toml_string(&r.config)?);
    Ok(s)
}
