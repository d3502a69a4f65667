//! The run configuration: one typed tree for every architecture, and how it is assembled.
//!
//! Principal types:
//!
//! - [`RunConfig`]: the whole tree — `seed`, `threads`, `[scene]`, `[bvh]`, `[memory]`,
//!   `[trace]`, `[workload]`, `[output]`, `[arch]` (which machine runs the frame), `[dram]`
//!   (the DRAM model behind a chip) and `[sim]` (window, cycle limit, timing engine). Each section's fields are documented in its crate.
//! - [`arch`]: the architecture presets (`functional`, and the chip models as they land).
//! - [`Inputs`]: what a command line gives (config file, flags, `--set`s), independent of
//!   the CLI parser.
//! - [`resolve`]: layers → validated tree → loaded scene ([`Resolved`]); written back by
//!   [`resolved_toml`] as `config.resolved.toml`, which repeats the run exactly.
//! - [`facts`]: the typed facts (scene, BVH, workload, rays) every `stats.json` starts with.
//!
//! Layer order (later wins): built-in defaults → the DRAM preset named by `dram.preset` →
//! the architecture preset named by `arch.preset` (which may set keys of any section, its DRAM
//! standard included) → the scene descriptor's `[workload]` defaults → `--config FILE` →
//! command-line flags → `--set key=value`. Presets are found by the name the layers above them
//! give (`rtsim_config::assemble`), exactly as the standalone `rtsim dram` command layers its
//! DRAM presets.

pub mod arch;
pub mod facts;
pub mod sim;

pub use arch::{ARCH_PRESETS, ArchConfig, ArchPreset};
pub use sim::{SimConfig, SimMode};

use rtsim_bvh::{BvhConfig, MemoryLayoutConfig};
use rtsim_config::{ConfigError, Layers, PresetFamily, Validate, check_range};
use rtsim_dram::DramConfig;
use rtsim_scene::{Scene, SceneError, SceneRequest};
use rtsim_trace::{TraceConfig, Traversal, WorkloadConfig, WorkloadParams};
use serde::{Deserialize, Serialize};
use std::path::PathBuf;
use toml::Value;

/// Everything a run needs.
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
    pub arch: ArchConfig,
    pub dram: DramConfig,
    pub sim: SimConfig,
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
            arch: ArchConfig::default(),
            dram: DramConfig::default(),
            sim: SimConfig::default(),
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
    /// Which camera: unset = the descriptor's `[camera]`; N ≥ 1 = its N-th `[[viewpoint]]`
    /// (the sibenik and conference descriptors ship five, for the SGRT paper's averages).
    pub viewpoint: Option<u32>,
}

impl Default for SceneConfig {
    fn default() -> Self {
        SceneConfig {
            name: "cornell".into(),
            size: 1.0,
            dir: None,
            viewpoint: None,
        }
    }
}

/// Where and what to write.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct OutputConfig {
    /// Output directory. Default `out`.
    pub dir: PathBuf,
    /// Write the heat map PNG. Default true.
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

/// Most worker threads a run may ask for (assumed: 256; rtsim's parallel loops stop scaling
/// long before, and each thread reserves stack: thousands of them can exhaust a memory limit
/// while the pool is created, which aborts instead of failing cleanly).
pub const MAX_THREADS: usize = 256;

impl Validate for RunConfig {
    fn validate(&self) -> Result<(), ConfigError> {
        check_range("threads", self.threads, 0, MAX_THREADS)?;
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
        self.arch.validate()?;
        if self.arch.is_trax() {
            self.arch.trax.validate_run(&self.trace)?;
        }
        if self.sim.timeline_cycles.is_some() && !(self.arch.is_trax() || self.arch.is_strata()) {
            return Err(ConfigError::key(
                "sim.timeline_cycles",
                format!(
                    "records a time series on the TRaX-family chips only (arch.preset = \
                     trax-baseline or strata); arch.preset = {} has none: unset it",
                    self.arch.preset
                ),
            ));
        }
        if self.arch.is_strata() {
            self.arch.strata.validate_run(
                &self.trace,
                &self.memory,
                self.arch.trax.l1.size_bytes,
            )?;
            let baseline_l2 = rtsim_trax::TraxConfig::default().l2.size_bytes;
            if self.arch.strata.streaming && self.arch.trax.l2.size_bytes != baseline_l2 {
                // The L2 STRaTA runs with is `arch.strata.l2_bytes`: a changed baseline L2
                // would otherwise be ignored without a word.
                return Err(ConfigError::key(
                    "arch.trax.l2.size_bytes",
                    format!(
                        "= {} has no effect with arch.strata.streaming = true: STRaTA's L2 is \
                         arch.strata.l2_bytes (the rest of the baseline's {} L2 became the \
                         stream memory, STRaTA §5.1); set arch.strata.l2_bytes instead",
                        self.arch.trax.l2.size_bytes, baseline_l2
                    ),
                ));
            }
        }
        let (w, h, _) = self.workload.resolved_size();
        self.sim.validate_for(w, h)?;
        self.dram.validate().map_err(|e| e.under("dram"))?;
        if self.trace.traversal == Traversal::BitStack
            && self.bvh.max_depth > rtsim_trace::step::bitstack::MAX_LEVELS
        {
            return Err(ConfigError::key(
                "bvh.max_depth",
                format!(
                    "is {}, but trace.traversal = bit-stack keeps one bit per level in 32 bits: \
                     set bvh.max_depth to at most 32 (it defaults to 32 with bit-stack)",
                    self.bvh.max_depth
                ),
            ));
        }
        if self.trace.traversal == Traversal::BitStack && !self.memory.parent_pointers {
            return Err(ConfigError::key(
                "memory.parent_pointers",
                "trace.traversal = bit-stack walks up through parent pointers: set \
                 memory.parent_pointers = true",
            ));
        }
        Ok(())
    }
}

/// What the command line gives, whatever parses it.
#[derive(Clone, Debug, Default)]
pub struct Inputs {
    /// `--config FILE`.
    pub config_file: Option<PathBuf>,
    /// Config text merged where a file would be (origin, text): a sweep's point settings.
    pub config_text: Option<(String, String)>,
    /// Typed flags as dotted keys (`--scene` → `scene.name`, `--width` → `workload.width` …).
    pub flags: Vec<(String, Value)>,
    /// `--set key=value`, in order.
    pub sets: Vec<String>,
}

impl Inputs {
    /// Add a flag.
    pub fn flag(&mut self, key: &str, value: impl Into<Value>) -> &mut Self {
        self.flags.push((key.to_string(), value.into()));
        self
    }
}

/// Why a run could not be set up.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    #[error(transparent)]
    Config(#[from] ConfigError),
    #[error("loading scene `{name}`: {source}")]
    Scene { name: String, source: SceneError },
}

/// The loaded configuration and scene of a run.
#[derive(Debug)]
pub struct Resolved {
    pub config: RunConfig,
    pub scene: Scene,
    /// Where each layer came from, in order.
    pub origins: Vec<String>,
}

/// The user's layers (file, flags, `--set`s), optionally above a scene's workload defaults.
fn upper_layers(
    inputs: &Inputs,
    workload_defaults: Option<(&toml::Table, &str)>,
) -> Result<Layers, ConfigError> {
    let mut l = Layers::new();
    if let Some((w, origin)) = workload_defaults {
        l.merge_table_at("workload", w.clone(), origin);
    }
    if let Some(path) = &inputs.config_file {
        l.merge_file(path)?;
    }
    if let Some((origin, text)) = &inputs.config_text {
        l.merge_str(text, origin)?;
    }
    for (key, value) in &inputs.flags {
        l.set_value(key, value.clone())?;
    }
    for s in &inputs.sets {
        l.set(s)?;
        // A `--set` that contradicts a typed flag (`--arch functional --set
        // arch.preset=strata`) is a mistake on the command line, not an override: say so.
        let key = s.split_once('=').map_or("", |(k, _)| k.trim());
        let flag = inputs.flags.iter().find(|(k, _)| k == key);
        if let Some((_, flag)) = flag.filter(|(_, v)| l.get(key) != Some(v)) {
            return Err(ConfigError::BadSet {
                arg: rtsim_core::text::echo(s),
                message: format!(
                    "`{key}` is also given by its command-line flag (= {flag}); give it once"
                ),
            });
        }
    }
    Ok(l)
}

/// All layers of a run, presets included (no scene is loaded).
pub fn layers(
    inputs: &Inputs,
    workload_defaults: Option<&toml::Table>,
) -> Result<Layers, ConfigError> {
    layers_named(
        inputs,
        workload_defaults.map(|w| (w, "scene descriptor [workload]")),
    )
}

/// [`layers`] with the scene descriptor's `[workload]` table and where it came from (named
/// in errors about its keys).
pub fn layers_named(
    inputs: &Inputs,
    workload_defaults: Option<(&toml::Table, &str)>,
) -> Result<Layers, ConfigError> {
    let upper = upper_layers(inputs, workload_defaults)?;
    let mut base = Layers::new();
    base.merge_value(&RunConfig::default(), "built-in defaults")?;
    let families = [
        rtsim_dram::config::preset_family("dram.preset", "dram"),
        PresetFamily {
            key: "arch.preset",
            at: "",
            default: arch::DEFAULT,
            lookup: &arch::preset_table,
        },
    ];
    let mut all = rtsim_config::assemble(&base, &families, &upper)?;
    // The bit stack holds 32 levels: build the BVH for it unless the user chose a depth.
    let traversal = all.get("trace.traversal").and_then(Value::as_str);
    if traversal == Some(Traversal::BitStack.name()) {
        let preset_depth = all.get("bvh.max_depth").and_then(Value::as_integer);
        let limit = rtsim_trace::step::bitstack::MAX_LEVELS as i64;
        if upper.get("bvh.max_depth").is_none() && preset_depth.is_none_or(|d| d > limit) {
            all.set_value("bvh.max_depth", Value::Integer(limit))?;
        }
        if upper.get("memory.parent_pointers").is_none() {
            all.set_value("memory.parent_pointers", Value::Boolean(true))?;
        }
    }
    Ok(all)
}

/// The user's settings (file, flags, `--set`s) in a chip's table that the chip of `preset`
/// does not read ([`arch::reads`]: `arch.strata.*` on the baseline, `arch.trax.*` on SGRT),
/// each as a line naming where it was set. Such a setting has no effect on the run; it is
/// not an error, since `rtsim compare` and `rtsim bench-sim --against-baseline` run several
/// presets on one command line, and a setting meant for one is rightly unread by the other.
/// A setting at its built-in default is not named: a run's `config.resolved.toml`, given
/// back with `--config`, holds every chip's table.
pub fn unread_settings(inputs: &Inputs, preset: &str) -> Result<Vec<String>, ConfigError> {
    let upper = upper_layers(inputs, None)?;
    let mut builtin = Layers::new();
    builtin.merge_value(&RunConfig::default(), "built-in defaults")?;
    let mut leaves = Vec::new();
    rtsim_config::flatten("", upper.table(), &mut leaves);
    Ok(leaves
        .into_iter()
        .filter_map(|(key, value)| {
            let (table, readers) = arch::chip_table(&key)?;
            if readers.contains(&preset) || builtin.get(&key) == Some(&value) {
                return None;
            }
            let line = format!(
                "`{key}` has no effect: arch.preset = {preset} does not read [{table}] (read \
                 by {})",
                readers.join(", ")
            );
            // Where it was set (`run.toml:2`, `--set …`).
            Some(match upper.origin(&key) {
                Some(origin) => format!("{origin}: {line}"),
                None => line,
            })
        })
        .collect())
}

/// Assemble the layers, load the scene (calling `note` with what loading dropped or noticed),
/// and re-assemble with the scene's workload defaults beneath the user's layers.
pub fn resolve(inputs: &Inputs, note: &mut dyn FnMut(&str)) -> Result<Resolved, RunError> {
    let first = layers(inputs, None)?;
    let config: RunConfig = first.build()?;
    let scene_dir = rtsim_scene::resolve_scene_dir(config.scene.dir.as_deref());
    let scene = rtsim_scene::load_scene(&SceneRequest {
        name: &config.scene.name,
        size: config.scene.size,
        seed: config.seed,
        scene_dir: scene_dir.as_deref(),
    })
    .map_err(|source| RunError::Scene {
        name: rtsim_core::text::echo(&config.scene.name),
        source,
    })?;
    let mut scene = scene;
    if let Some(v) = config.scene.viewpoint {
        let n = scene.viewpoints.len();
        let Some(cam) = scene.viewpoints.get((v as usize).wrapping_sub(1)) else {
            return Err(ConfigError::range(
                "scene.viewpoint",
                v,
                if n == 0 {
                    format!("unset (scene `{}` has no [[viewpoint]] list)", scene.name)
                } else {
                    format!("1..={n} (the [[viewpoint]]s of scene `{}`)", scene.name)
                },
            )
            .into());
        };
        scene.camera = *cam;
    }
    for line in scene.report.log_lines() {
        note(&format!("scene `{}`: {line}", scene.name));
    }
    for line in unread_settings(inputs, &config.arch.preset)? {
        note(&line);
    }
    let (mut config, origins) = if scene.workload_defaults.is_empty() {
        (config, first.origins().to_vec())
    } else {
        let origin = format!(
            "the [workload] table of scene `{}`'s descriptor",
            config.scene.name
        );
        let second = layers_named(inputs, Some((&scene.workload_defaults, &origin)))?;
        (second.build()?, second.origins().to_vec())
    };
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

/// `config.resolved.toml` text: a header naming the layers, then the full tree.
pub fn resolved_toml(r: &Resolved, command: &str) -> Result<String, ConfigError> {
    let mut s = format!(
        "# rtsim resolved configuration: `rtsim {command} --config THIS_FILE` repeats the run.\n"
    );
    for o in &r.origins {
        s.push_str(&format!("# layer: {o}\n"));
    }
    s.push_str(&rtsim_config::to_toml_string(&r.config)?);
    Ok(s)
}

/// The frame parameters of a resolved run (defaults filled in).
pub fn workload_params(r: &Resolved) -> WorkloadParams {
    let w = &r.config.workload;
    let (width, height, spp) = w.resolved_size();
    WorkloadParams {
        kind: w.kind,
        width,
        height,
        spp,
        max_depth: w.max_depth,
        specular_bounces: w.specular_bounces,
        // `resolve` fills the radius; a hand-built config without one gets the same default
        // rule's fallback for an empty scene.
        ao_radius: w.ao_radius.unwrap_or(0.1),
        seed: r.config.seed,
    }
}

#[cfg(test)]
mod tests;
