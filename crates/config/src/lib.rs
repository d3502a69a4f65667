//! Layered configuration.
//!
//! Every run is described by one typed config tree (serde structs with
//! `#[serde(deny_unknown_fields)]` and a documented default on every field). It is assembled
//! from layers, later layers overriding earlier ones key by key:
//!
//! 1. built-in defaults (the structs' `Default`), then named presets (embedded TOML files);
//! 2. a user file (`--config FILE`);
//! 3. command-line flags (`--width` …) and `--set a.b.c=value` assignments.
//!
//! [`Layers`] holds the merged TOML table and remembers where each layer came from;
//! [`Layers::build`] deserialises it into the typed tree, naming the full key path of any
//! unknown key or ill-typed value, then runs [`Validate::validate`], whose errors name the key
//! and the allowed range. [`to_toml_string`] writes the resolved tree back
//! (`config.resolved.toml`), so any run can be repeated exactly.

use serde::Serialize;
use serde::de::DeserializeOwned;
use std::fmt;
use std::path::Path;
use toml::{Table, Value};

/// Everything that can go wrong while assembling a configuration. Messages name the file and
/// line, or the key, and where relevant the allowed values.
#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    #[error("{origin}: {message}")]
    Parse { origin: String, message: String },
    #[error("cannot read config file {path}: {source}")]
    Io {
        path: String,
        source: std::io::Error,
    },
    #[error("invalid --set `{arg}`: {message}")]
    BadSet { arg: String, message: String },
    #[error("config key `{key}`: {message}")]
    Key { key: String, message: String },
    #[error("config key `{key}` = {value}: out of range, allowed {allowed}")]
    Range {
        key: String,
        value: String,
        allowed: String,
    },
    #[error("unknown {kind} `{name}`; known: {known}")]
    Unknown {
        kind: String,
        name: String,
        known: String,
    },
}

impl ConfigError {
    /// The same error with `prefix` put before its key (a section's own validation names
    /// keys relative to the section: `prefixed("dram.")` makes `timing.nRCD` `dram.timing.nRCD`).
    /// Errors without a key are returned as they are.
    pub fn prefixed(self, prefix: &str) -> Self {
        match self {
            ConfigError::Key { key, message } => ConfigError::Key {
                key: format!("{prefix}{key}"),
                message,
            },
            ConfigError::Range {
                key,
                value,
                allowed,
            } => ConfigError::Range {
                key: format!("{prefix}{key}"),
                value,
                allowed,
            },
            other => other,
        }
    }

    /// A value outside its allowed range (`allowed` is human-readable, e.g. "1..=64").
    pub fn range(key: &str, value: impl fmt::Display, allowed: impl fmt::Display) -> Self {
        ConfigError::Range {
            key: key.into(),
            value: value.to_string(),
            allowed: allowed.to_string(),
        }
    }
    /// Any other problem with one key.
    pub fn key(key: &str, message: impl fmt::Display) -> Self {
        ConfigError::Key {
            key: key.into(),
            message: message.to_string(),
        }
    }
    /// A name not among the known ones (presets, scenes, policies).
    pub fn unknown(kind: &str, name: &str, known: &[&str]) -> Self {
        ConfigError::Unknown {
            kind: kind.into(),
            name: name.into(),
            known: known.join(", "),
        }
    }
}

/// Checks of a typed config that serde cannot express (ranges, consistency between keys).
pub trait Validate {
    fn validate(&self) -> Result<(), ConfigError>;
}

/// Helper for `validate()`: require `lo <= v <= hi`.
pub fn check_range<T: PartialOrd + fmt::Display>(
    key: &str,
    v: T,
    lo: T,
    hi: T,
) -> Result<(), ConfigError> {
    if v >= lo && v <= hi {
        Ok(())
    } else {
        Err(ConfigError::range(key, v, format!("{lo}..={hi}")))
    }
}

/// Helper for `validate()`: require a finite value `> 0`.
pub fn check_positive(key: &str, v: f64) -> Result<(), ConfigError> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(ConfigError::range(key, v, "a finite value > 0"))
    }
}

/// A stack of merged TOML layers.
#[derive(Clone, Debug, Default)]
pub struct Layers {
    root: Table,
    origins: Vec<String>,
}

impl Layers {
    pub fn new() -> Self {
        Layers::default()
    }

    /// Layers merged so far, in order (for logs and `config.resolved.toml`'s header).
    pub fn origins(&self) -> &[String] {
        &self.origins
    }

    /// The merged table (read-only), e.g. to look up `scene.name` before the full build.
    pub fn table(&self) -> &Table {
        &self.root
    }

    /// Look up a dotted key in the merged table.
    pub fn get(&self, dotted: &str) -> Option<&Value> {
        let mut cur = &self.root;
        let mut parts = dotted.split('.').peekable();
        while let Some(p) = parts.next() {
            let v = cur.get(p)?;
            if parts.peek().is_none() {
                return Some(v);
            }
            cur = v.as_table()?;
        }
        None
    }

    /// Merge a serialisable value (e.g. a struct's defaults) as a layer.
    pub fn merge_value<T: Serialize>(
        &mut self,
        value: &T,
        origin: &str,
    ) -> Result<(), ConfigError> {
        let table = Table::try_from(value).map_err(|e| ConfigError::Parse {
            origin: origin.into(),
            message: e.to_string(),
        })?;
        self.merge_table(table, origin);
        Ok(())
    }

    /// Merge TOML text. Parse errors name `origin` and the line and column.
    pub fn merge_str(&mut self, text: &str, origin: &str) -> Result<(), ConfigError> {
        let table = parse_toml(text, origin)?;
        self.merge_table(table, origin);
        Ok(())
    }

    /// Merge a TOML file.
    pub fn merge_file(&mut self, path: &Path) -> Result<(), ConfigError> {
        let text = std::fs::read_to_string(path).map_err(|source| ConfigError::Io {
            path: path.display().to_string(),
            source,
        })?;
        self.merge_str(&text, &path.display().to_string())
    }

    /// Merge a table under a key prefix (`prefix = "dram"` puts `{a = 1}` at `dram.a`).
    pub fn merge_table_at(&mut self, prefix: &str, table: Table, origin: &str) {
        let mut wrapped = table;
        for part in prefix.split('.').filter(|p| !p.is_empty()).rev() {
            let mut t = Table::new();
            t.insert(part.to_string(), Value::Table(wrapped));
            wrapped = t;
        }
        self.merge_table(wrapped, origin);
    }

    /// Merge an already-parsed table.
    pub fn merge_table(&mut self, table: Table, origin: &str) {
        deep_merge(&mut self.root, table);
        self.origins.push(origin.to_string());
    }

    /// Apply one `a.b.c=value` assignment. The value is parsed as a TOML value (`28`, `1.5`,
    /// `true`, `"x"`, `[1, 2]`, `inf`); anything that does not parse is taken as a bare string,
    /// so `--set scene.name=sibenik` works without quotes.
    pub fn set(&mut self, assignment: &str) -> Result<(), ConfigError> {
        let bad = |m: &str| ConfigError::BadSet {
            arg: assignment.into(),
            message: m.into(),
        };
        let (key, raw) = assignment
            .split_once('=')
            .ok_or_else(|| bad("expected key=value"))?;
        let key = key.trim();
        if key.is_empty() || key.split('.').any(|p| p.trim().is_empty()) {
            return Err(bad("empty key or key segment"));
        }
        let value = parse_value(raw.trim());
        self.set_value_inner(key, value).map_err(|m| bad(&m))?;
        self.origins.push(format!("--set {assignment}"));
        Ok(())
    }

    /// Set a dotted key to a value, creating intermediate tables. Errors name the key.
    pub fn set_value(&mut self, dotted: &str, value: Value) -> Result<(), ConfigError> {
        self.set_value_inner(dotted, value)
            .map_err(|m| ConfigError::key(dotted, m))
    }

    fn set_value_inner(&mut self, dotted: &str, value: Value) -> Result<(), String> {
        let parts: Vec<&str> = dotted.split('.').map(str::trim).collect();
        let (last, parents) = parts.split_last().expect("split yields at least one part");
        let mut cur = &mut self.root;
        for (i, p) in parents.iter().enumerate() {
            let entry = cur
                .entry(p.to_string())
                .or_insert_with(|| Value::Table(Table::new()));
            cur = match entry {
                Value::Table(t) => t,
                _ => {
                    return Err(format!(
                        "`{}` is a value, not a section",
                        parts[..=i].join(".")
                    ));
                }
            };
        }
        match (cur.get_mut(*last), value) {
            (Some(Value::Table(existing)), Value::Table(new)) => deep_merge(existing, new),
            (Some(Value::Table(_)), _) => {
                return Err(format!(
                    "`{dotted}` is a section; set one of its keys instead"
                ));
            }
            (_, value) => {
                cur.insert(last.to_string(), value);
            }
        }
        Ok(())
    }

    /// Deserialise the merged table into `T` and validate it. Unknown keys and ill-typed
    /// values are reported with their full dotted path.
    pub fn build<T: DeserializeOwned + Validate>(&self) -> Result<T, ConfigError> {
        let value: T = deserialize_table(&self.root, "")?;
        value.validate()?;
        Ok(value)
    }

    /// Like [`Layers::build`] for the sub-table at `prefix` (e.g. the `dram` section).
    pub fn build_at<T: DeserializeOwned + Validate>(&self, prefix: &str) -> Result<T, ConfigError> {
        let empty = Table::new();
        let table = match self.get(prefix) {
            Some(Value::Table(t)) => t,
            Some(_) => return Err(ConfigError::key(prefix, "expected a section")),
            None => &empty,
        };
        let value: T = deserialize_table(table, prefix)?;
        value.validate()?;
        Ok(value)
    }
}

/// A family of named presets: a key of the tree names which preset of the family to merge
/// beneath the user's layers (the DRAM standard under `dram.preset`, the chip under
/// `arch.preset`, or the standalone DRAM model's root `preset`).
pub struct PresetFamily<'a> {
    /// Dotted key holding the preset's name.
    pub key: &'a str,
    /// Where the preset's table is merged (`""`: the root; a preset may then set any key).
    pub at: &'a str,
    /// Name used when no layer names one.
    pub default: &'a str,
    /// The preset's table, or an error naming the known presets.
    pub lookup: &'a dyn Fn(&str) -> Result<Table, ConfigError>,
}

impl std::fmt::Debug for PresetFamily<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("PresetFamily")
            .field("key", &self.key)
            .field("at", &self.at)
            .field("default", &self.default)
            .finish_non_exhaustive()
    }
}

/// Assemble a configuration with presets: `base` (the built-in defaults) at the bottom, then
/// the preset of each family (listed bottom first: a later family's preset lies above an
/// earlier one's, so a chip preset can override its DRAM standard's values), then `upper`
/// (scene defaults, the user's file, flags and `--set`s) on top. Each family's preset is the
/// one named at its key by the layers above it — `upper`, then the presets of later families
/// — or its default. Origins record every layer, presets included.
pub fn assemble(
    base: &Layers,
    families: &[PresetFamily<'_>],
    upper: &Layers,
) -> Result<Layers, ConfigError> {
    // Names, top-down: what `upper` says, else what a preset above says, else the default.
    let mut names: Vec<String> = vec![String::new(); families.len()];
    let mut tables: Vec<Table> = vec![Table::new(); families.len()];
    for i in (0..families.len()).rev() {
        let fam = &families[i];
        let mut above = Layers::new();
        for j in i + 1..families.len() {
            above.merge_table_at(families[j].at, tables[j].clone(), "");
        }
        above.merge_table(upper.root.clone(), "");
        let name = match above.get(fam.key) {
            Some(Value::String(s)) => s.clone(),
            Some(other) => {
                return Err(ConfigError::key(
                    fam.key,
                    format!("expected a preset name, found {other}"),
                ));
            }
            None => fam.default.to_string(),
        };
        let mut table = (fam.lookup)(&name)?;
        // The preset records its own name, so the resolved tree says what it was built on.
        let own_key = fam
            .key
            .strip_prefix(fam.at)
            .map(|k| k.trim_start_matches('.'))
            .unwrap_or(fam.key);
        let mut named = Layers::new();
        named.merge_table(table, "");
        named.set_value(own_key, Value::String(name.clone()))?;
        table = named.root;
        names[i] = name;
        tables[i] = table;
    }
    let mut all = base.clone();
    for (i, fam) in families.iter().enumerate() {
        let origin = format!("preset {} = {}", fam.key, names[i]);
        all.merge_table_at(fam.at, std::mem::take(&mut tables[i]), &origin);
    }
    all.merge_table(upper.root.clone(), "");
    all.origins.pop();
    all.origins.extend(upper.origins.iter().cloned());
    Ok(all)
}

/// Deserialise a table, naming the full key path (`prefix` + the path serde reports) on error.
pub fn deserialize_table<T: DeserializeOwned>(
    table: &Table,
    prefix: &str,
) -> Result<T, ConfigError> {
    let de = Value::Table(table.clone());
    serde_path_to_error::deserialize(de).map_err(|e| {
        let inner = e.path().to_string();
        let key = match (prefix.is_empty(), inner.as_str()) {
            (true, ".") | (true, "") => "<root>".to_string(),
            (true, _) => inner,
            (false, ".") | (false, "") => prefix.to_string(),
            (false, _) => format!("{prefix}.{inner}"),
        };
        // The toml deserializer appends "in `a.b`" lines; the key already says where.
        let message = e.into_inner().to_string();
        let message = message
            .lines()
            .next()
            .unwrap_or_default()
            .trim()
            .to_string();
        ConfigError::Key { key, message }
    })
}

/// Parse TOML text into a table; errors name `origin`, line and column.
pub fn parse_toml(text: &str, origin: &str) -> Result<Table, ConfigError> {
    text.parse::<Table>().map_err(|e| {
        let location = e
            .span()
            .map(|s| {
                let before = &text[..s.start.min(text.len())];
                let line = before.matches('\n').count() + 1;
                let col = before.len() - before.rfind('\n').map_or(0, |i| i + 1) + 1;
                format!(":{line}:{col}")
            })
            .unwrap_or_default();
        ConfigError::Parse {
            origin: format!("{origin}{location}"),
            message: e.message().to_string(),
        }
    })
}

/// Parse the right-hand side of `--set`: a TOML value, or a bare string.
pub fn parse_value(raw: &str) -> Value {
    match format!("v = {raw}").parse::<Table>() {
        Ok(mut t) => t
            .remove("v")
            .unwrap_or_else(|| Value::String(raw.to_string())),
        Err(_) => Value::String(raw.to_string()),
    }
}

/// Serialise a resolved config as TOML (for `config.resolved.toml`).
pub fn to_toml_string<T: Serialize>(value: &T) -> Result<String, ConfigError> {
    toml::to_string_pretty(value).map_err(|e| ConfigError::Parse {
        origin: "resolved config".into(),
        message: e.to_string(),
    })
}

/// Recursively merge `over` into `base`: tables merge key by key, anything else replaces.
fn deep_merge(base: &mut Table, over: Table) {
    for (k, v) in over {
        match (base.get_mut(&k), v) {
            (Some(Value::Table(b)), Value::Table(o)) => deep_merge(b, o),
            (_, v) => {
                base.insert(k, v);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde::Deserialize;

    #[derive(Debug, Deserialize, Serialize, PartialEq)]
    #[serde(deny_unknown_fields, default)]
    struct Inner {
        bins: u32,
        cost: f64,
    }
    impl Default for Inner {
        fn default() -> Self {
            Inner {
                bins: 16,
                cost: 1.0,
            }
        }
    }
    #[derive(Debug, Deserialize, Serialize, PartialEq, Default)]
    #[serde(deny_unknown_fields, default)]
    struct Root {
        name: String,
        inner: Inner,
    }
    impl Validate for Root {
        fn validate(&self) -> Result<(), ConfigError> {
            check_range("inner.bins", self.inner.bins, 2, 256)
        }
    }

    #[test]
    fn layers_override_in_order() {
        let mut l = Layers::new();
        l.merge_value(&Root::default(), "defaults").unwrap();
        l.merge_str("name = \"a\"\n[inner]\nbins = 8\n", "user.toml")
            .unwrap();
        l.set("inner.cost=2").unwrap();
        l.set("name=sibenik").unwrap();
        let r: Root = l.build().unwrap();
        assert_eq!(
            r,
            Root {
                name: "sibenik".into(),
                inner: Inner { bins: 8, cost: 2.0 }
            }
        );
    }

    #[test]
    fn unknown_key_names_full_path() {
        let mut l = Layers::new();
        l.set("inner.binz=3").unwrap();
        let e = l.build::<Root>().unwrap_err().to_string();
        assert!(e.contains("inner") && e.contains("binz"), "{e}");
    }

    #[test]
    fn wrong_type_names_key() {
        let mut l = Layers::new();
        l.set("inner.bins=lots").unwrap();
        let e = l.build::<Root>().unwrap_err().to_string();
        assert!(e.contains("inner.bins"), "{e}");
    }

    #[test]
    fn range_error_states_allowed_range() {
        let mut l = Layers::new();
        l.set("inner.bins=1").unwrap();
        let e = l.build::<Root>().unwrap_err().to_string();
        assert!(e.contains("inner.bins") && e.contains("2..=256"), "{e}");
    }

    #[test]
    fn a_prefix_goes_before_the_key_of_key_and_range_errors_only() {
        let e = ConfigError::range("timing.nRCD", 0, "1..=100").prefixed("dram.");
        assert!(e.to_string().contains("`dram.timing.nRCD` = 0"), "{e}");
        let e = ConfigError::key("l1.size_bytes", "too big").prefixed("arch.trax.");
        assert!(e.to_string().contains("`arch.trax.l1.size_bytes`"), "{e}");
        let e = ConfigError::unknown("preset", "x", &["a"]).prefixed("dram.");
        assert!(!e.to_string().contains("dram."), "{e}");
    }

    #[test]
    fn parse_error_names_origin_and_line() {
        let mut l = Layers::new();
        let e = l
            .merge_str("a = 1\nb = = 2\n", "x.toml")
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("x.toml:2:"), "{e}");
    }

    #[test]
    fn malformed_set_is_rejected() {
        let mut l = Layers::new();
        assert!(l.set("novalue").is_err());
        assert!(l.set("a..b=1").is_err());
        l.set("a=1").unwrap();
        assert!(l.set("a.b=1").is_err());
    }

    #[test]
    fn set_values_parse_as_toml() {
        assert_eq!(parse_value("28"), Value::Integer(28));
        assert_eq!(parse_value("inf"), Value::Float(f64::INFINITY));
        assert_eq!(parse_value("fr-fcfs"), Value::String("fr-fcfs".into()));
        assert_eq!(parse_value("\"x y\""), Value::String("x y".into()));
    }

    #[test]
    fn build_at_prefix_reports_prefixed_keys() {
        let mut l = Layers::new();
        l.set("dram.inner.bins=x").unwrap();
        #[derive(Debug, Deserialize)]
        #[serde(deny_unknown_fields)]
        struct D {
            #[allow(dead_code)]
            inner: Inner,
        }
        impl Validate for D {
            fn validate(&self) -> Result<(), ConfigError> {
                Ok(())
            }
        }
        let e = l.build_at::<D>("dram").unwrap_err().to_string();
        assert!(e.contains("dram.inner.bins"), "{e}");
    }
}
