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
    // Keys and values may come from input (`--set`, a file): echoed, escaped and cut.
    #[error("config key `{}`: {message}", rtsim_core::text::echo(.key))]
    Key { key: String, message: String },
    #[error(
        "config key `{}` = {}: out of range, allowed {allowed}",
        rtsim_core::text::echo(.key),
        rtsim_core::text::echo(.value)
    )]
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
    /// An error about a key, with the layer that set it (`cfg.toml:12`, `--set a.b=1`).
    #[error("{origin}: {source}")]
    Located {
        origin: String,
        source: Box<ConfigError>,
    },
}

impl ConfigError {
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
    /// This error with its key under `prefix` (a section's validation names keys relative
    /// to the section); a key already under it, or an empty prefix, is left as it is.
    pub fn under(self, prefix: &str) -> ConfigError {
        let p = |key: String| {
            if prefix.is_empty() || key.starts_with(&format!("{prefix}.")) {
                key
            } else {
                format!("{prefix}.{key}")
            }
        };
        match self {
            ConfigError::Key { key, message } => ConfigError::Key {
                key: p(key),
                message,
            },
            ConfigError::Range {
                key,
                value,
                allowed,
            } => ConfigError::Range {
                key: p(key),
                value,
                allowed,
            },
            other => other,
        }
    }

    /// The key a `Key` or `Range` error is about.
    pub fn key_path(&self) -> Option<&str> {
        match self {
            ConfigError::Key { key, .. } | ConfigError::Range { key, .. } => Some(key),
            ConfigError::Located { source, .. } => source.key_path(),
            _ => None,
        }
    }

    /// A name not among the known ones (presets, scenes, policies).
    pub fn unknown(kind: &str, name: &str, known: &[&str]) -> Self {
        ConfigError::Unknown {
            kind: kind.into(),
            name: rtsim_core::text::echo(name),
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

/// An assignment that does not fit the tree's shape.
#[derive(Debug, thiserror::Error)]
enum ShapeError {
    #[error("`{0}` is a value, not a section")]
    NotASection(String),
    #[error("`{0}` is a section; set one of its keys instead")]
    IsASection(String),
}

/// A stack of merged TOML layers.
#[derive(Clone, Debug, Default)]
pub struct Layers {
    root: Table,
    origins: Vec<String>,
    /// Per layer, top last: where it came from and what it set, to say which layer set a key
    /// that turns out wrong.
    sources: Vec<Source>,
}

/// What one layer set, for locating errors.
#[derive(Clone, Debug)]
enum Source {
    /// TOML text from a file (origin is its path).
    Text { origin: String, text: String },
    /// One `--set` or flag assignment of a dotted key.
    Assignment { origin: String, key: String },
    /// A table merged under `prefix` (presets, a descriptor's `[workload]`).
    Table {
        origin: String,
        prefix: String,
        table: Table,
    },
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
        self.sources.pop();
        self.sources.push(Source::Text {
            origin: origin.to_string(),
            text: text.to_string(),
        });
        Ok(())
    }

    /// Merge a TOML file (at most 16 MiB of UTF-8; a bad byte is reported by line and column).
    pub fn merge_file(&mut self, path: &Path) -> Result<(), ConfigError> {
        let text = read_config_file(path)?;
        self.merge_str(&text, &path.display().to_string())
    }

    /// Say which layer set the key of `e` (the topmost that did): `file:line`, `--set …`, or
    /// a preset's name. Errors without a key, or whose key no layer set, are returned as they
    /// are.
    pub fn locate(&self, e: ConfigError) -> ConfigError {
        let Some(key) = e.key_path().map(str::to_string) else {
            return e;
        };
        if matches!(e, ConfigError::Located { .. }) {
            return e;
        }
        let Some((i, mut origin)) = self.set_by(&key) else {
            return e;
        };
        // A value from a lower layer (the defaults, a preset) is often wrong only because of
        // a later assignment beside it (`--set arch.trax.l1.ways=3` makes the default size
        // invalid): name those too.
        let beside = self.later_assignments_beside(i + 1, &key);
        if !beside.is_empty() {
            origin = format!("{origin}, with {}", beside.join(", "));
        }
        ConfigError::Located {
            origin,
            source: Box::new(e),
        }
    }

    /// Which layer set `key` (the topmost that did): `file:line`, `--set …`, or a preset's
    /// name.
    pub fn origin(&self, key: &str) -> Option<String> {
        self.set_by(key).map(|(_, origin)| origin)
    }

    /// The topmost layer that set `key`: its index and [`Layers::origin`].
    fn set_by(&self, key: &str) -> Option<(usize, String)> {
        self.sources.iter().enumerate().rev().find_map(|(i, src)| {
            let origin = match src {
                Source::Text { origin, text } => {
                    key_line(text, key).map(|line| format!("{origin}:{line}"))
                }
                Source::Assignment { origin, key: k } => covers(k, key).then(|| origin.clone()),
                Source::Table {
                    origin,
                    prefix,
                    table,
                } => table_has(table, prefix, key).then(|| origin.clone()),
            };
            origin.map(|o| (i, o))
        })
    }

    /// The origins of assignments (`--set`, flags) from source `from` on that set a key in the
    /// same section as `key` (its siblings or their children).
    fn later_assignments_beside(&self, from: usize, key: &str) -> Vec<String> {
        let Some((section, _)) = key.rsplit_once('.') else {
            return Vec::new();
        };
        let prefix = format!("{section}.");
        let mut out: Vec<String> = Vec::new();
        for src in &self.sources[from.min(self.sources.len())..] {
            if let Source::Assignment { origin, key: k } = src
                && k.starts_with(&prefix)
                && !out.contains(origin)
            {
                out.push(origin.clone());
            }
        }
        out
    }

    /// Merge a table under a key prefix (`prefix = "dram"` puts `{a = 1}` at `dram.a`).
    pub fn merge_table_at(&mut self, prefix: &str, table: Table, origin: &str) {
        let source = Source::Table {
            origin: origin.to_string(),
            prefix: prefix.to_string(),
            table: table.clone(),
        };
        let mut wrapped = table;
        for part in prefix.split('.').filter(|p| !p.is_empty()).rev() {
            let mut t = Table::new();
            t.insert(part.to_string(), Value::Table(wrapped));
            wrapped = t;
        }
        self.merge_table(wrapped, origin);
        self.sources.pop();
        self.sources.push(source);
    }

    /// Merge an already-parsed table.
    pub fn merge_table(&mut self, table: Table, origin: &str) {
        self.sources.push(Source::Table {
            origin: origin.to_string(),
            prefix: String::new(),
            table: table.clone(),
        });
        deep_merge(&mut self.root, table);
        self.origins.push(origin.to_string());
    }

    /// Apply one `a.b.c=value` assignment. The value is parsed as a TOML value (`28`, `1.5`,
    /// `true`, `"x"`, `[1, 2]`, `inf`); anything that does not parse is taken as a bare string,
    /// so `--set scene.name=sibenik` works without quotes.
    pub fn set(&mut self, assignment: &str) -> Result<(), ConfigError> {
        let bad = |m: &str| ConfigError::BadSet {
            arg: rtsim_core::text::echo(assignment),
            message: m.into(),
        };
        let (key, raw) = assignment
            .split_once('=')
            .ok_or_else(|| bad("expected key=value"))?;
        let key = key.trim();
        if key.is_empty() || key.split('.').any(|p| p.trim().is_empty()) {
            return Err(bad("empty key or key segment"));
        }
        let value = parse_value(raw.trim()).map_err(|m| bad(&m))?;
        self.set_value_inner(key, value)
            .map_err(|e| bad(&e.to_string()))?;
        self.origins.push(format!("--set {assignment}"));
        self.sources.push(Source::Assignment {
            origin: format!("--set {}", rtsim_core::text::echo(assignment)),
            key: key.to_string(),
        });
        Ok(())
    }

    /// Set a dotted key to a value, creating intermediate tables. Errors name the key.
    pub fn set_value(&mut self, dotted: &str, value: Value) -> Result<(), ConfigError> {
        self.set_value_inner(dotted, value)
            .map_err(|m| ConfigError::key(dotted, m))?;
        self.sources.push(Source::Assignment {
            origin: format!("the flag for `{dotted}`"),
            key: dotted.to_string(),
        });
        Ok(())
    }

    fn set_value_inner(&mut self, dotted: &str, value: Value) -> Result<(), ShapeError> {
        let parts: Vec<&str> = dotted.split('.').map(str::trim).collect();
        let (last, parents) = parts.split_last().expect("split yields at least one part");
        let mut cur = &mut self.root;
        for (i, p) in parents.iter().enumerate() {
            let entry = cur
                .entry(p.to_string())
                .or_insert_with(|| Value::Table(Table::new()));
            cur = match entry {
                Value::Table(t) => t,
                _ => return Err(ShapeError::NotASection(parts[..=i].join("."))),
            };
        }
        match (cur.get_mut(*last), value) {
            (Some(Value::Table(existing)), Value::Table(new)) => deep_merge(existing, new),
            (Some(Value::Table(_)), _) => {
                return Err(ShapeError::IsASection(dotted.to_string()));
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
        let value: T = deserialize_table(&self.root, "").map_err(|e| self.locate(e))?;
        value.validate().map_err(|e| self.locate(e))?;
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
        let value: T = deserialize_table(table, prefix).map_err(|e| self.locate(e))?;
        value.validate().map_err(|e| self.locate(e.under(prefix)))?;
        Ok(value)
    }
}

/// Whether an assignment to `set` (a dotted key) covers `key` (itself, or a key inside it).
fn covers(set: &str, key: &str) -> bool {
    key == set || key.starts_with(&format!("{set}.")) || set.starts_with(&format!("{key}."))
}

/// Whether `table`, merged under `prefix`, sets `key`.
fn table_has(table: &Table, prefix: &str, key: &str) -> bool {
    let rel = if prefix.is_empty() {
        Some(key)
    } else {
        key.strip_prefix(prefix).and_then(|k| k.strip_prefix('.'))
    };
    let Some(rel) = rel else {
        return false;
    };
    let mut cur = table;
    let parts: Vec<&str> = rel.split('.').collect();
    for (i, part) in parts.iter().enumerate() {
        let part = part.split('[').next().unwrap_or(part);
        match cur.get(part) {
            Some(Value::Table(t)) if i + 1 < parts.len() => cur = t,
            Some(_) => return true,
            None => return false,
        }
    }
    true
}

/// The line (1-based) of dotted `key` in TOML `text` (`a.b`, `mesh[0].scale`): the line of the
/// key itself, or of the deepest table on the path that the text has.
pub fn key_line(text: &str, key: &str) -> Option<u64> {
    use toml::de::{DeTable, DeValue};
    let root = DeTable::parse(text).ok()?;
    let line = |at: usize| text[..at.min(text.len())].matches('\n').count() as u64 + 1;
    let mut table: &DeTable<'_> = root.get_ref();
    let mut found = None;
    for part in key.split('.') {
        let (name, index) = match part.split_once('[') {
            Some((n, rest)) => (n, rest.trim_end_matches(']').parse::<usize>().ok()),
            None => (part, None),
        };
        let (k, v) = table.get_key_value(name)?;
        found = Some(line(k.span().start));
        let mut value = v.get_ref();
        if let (Some(i), DeValue::Array(a)) = (index, value) {
            let item = a.get(i)?;
            found = Some(line(item.span().start));
            value = item.get_ref();
        }
        match value {
            DeValue::Table(t) => table = t,
            _ => break,
        }
    }
    found
}

/// The text of a configuration file: at most 16 MiB of UTF-8, a bad byte reported by line
/// and column, errors naming the file.
pub fn read_config_file(path: &Path) -> Result<String, ConfigError> {
    rtsim_core::text::read_text_file(path).map_err(|e| match e {
        rtsim_core::FileError::Io { path, source } => ConfigError::Io {
            path: path.display().to_string(),
            source,
        },
        rtsim_core::FileError::Parse {
            path,
            line,
            message,
        } => ConfigError::Parse {
            origin: format!("{}:{line}", path.display()),
            message,
        },
    })
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
    all.sources.pop();
    all.sources.extend(upper.sources.iter().cloned());
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
        // serde quotes the offending field or string raw: echo it, escaped and cut.
        let message = ['`', '"']
            .iter()
            .fold(message, |m, &q| rtsim_core::text::echo_quoted(&m, q));
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
            message: toml_message(&e, text),
        }
    })
}

/// A TOML parse error's message, naming the key where the parser only says "duplicate key".
pub fn toml_message(e: &toml::de::Error, text: &str) -> String {
    let msg = e.message().trim();
    match e.span() {
        Some(s) if msg.starts_with("duplicate key") && s.end <= text.len() => format!(
            "duplicate key `{}` (each key may be given once per table)",
            rtsim_core::text::echo(text[s].trim())
        ),
        _ => msg.to_string(),
    }
}

/// Parse the right-hand side of `--set`: a TOML value, or a bare string. An integer beyond
/// TOML's 64-bit signed range is an error, not the string it would otherwise become.
pub fn parse_value(raw: &str) -> Result<Value, String> {
    match format!("v = {raw}").parse::<Table>() {
        Ok(mut t) => Ok(t
            .remove("v")
            .unwrap_or_else(|| Value::String(raw.to_string()))),
        Err(_) => {
            let digits = raw.strip_prefix(['+', '-']).unwrap_or(raw).replace('_', "");
            if !digits.is_empty() && digits.bytes().all(|b| b.is_ascii_digit()) {
                return Err(format!(
                    "{} is beyond the integers a configuration holds ({}..={})",
                    rtsim_core::text::echo(raw),
                    i64::MIN,
                    i64::MAX
                ));
            }
            Ok(Value::String(raw.to_string()))
        }
    }
}

/// Flatten a table into (dotted key, leaf value) pairs, in the table's order; arrays are
/// leaves. (Sweeps flatten their experiments and `rtsim report` each point's
/// `config.resolved.toml` through it.)
pub fn flatten(prefix: &str, t: &Table, out: &mut Vec<(String, Value)>) {
    for (k, v) in t {
        let key = if prefix.is_empty() {
            k.clone()
        } else {
            format!("{prefix}.{k}")
        };
        match v {
            Value::Table(inner) => flatten(&key, inner, out),
            _ => out.push((key, v.clone())),
        }
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
        let e = ConfigError::key("dram.x", "bad").under("dram");
        assert!(e.to_string().contains("`dram.x`"), "{e}");
        let e = ConfigError::range("timing.nRCD", 0, "1..=100").under("dram");
        assert!(e.to_string().contains("`dram.timing.nRCD` = 0"), "{e}");
        let e = ConfigError::key("l1.size_bytes", "too big").under("arch.trax");
        assert!(e.to_string().contains("`arch.trax.l1.size_bytes`"), "{e}");
        let e = ConfigError::unknown("preset", "x", &["a"]).under("dram");
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
    fn errors_name_the_layer_that_set_the_key() {
        let mut l = Layers::new();
        l.merge_value(&Root::default(), "defaults").unwrap();
        l.merge_str("name = \"a\"\n\n[inner]\nbins = 1\n", "user.toml")
            .unwrap();
        let e = l.build::<Root>().unwrap_err().to_string();
        assert!(e.starts_with("user.toml:4: config key `inner.bins`"), "{e}");
        l.set("inner.bins=0").unwrap();
        let e = l.build::<Root>().unwrap_err().to_string();
        assert!(e.starts_with("--set inner.bins=0: "), "{e}");
        let mut l = Layers::new();
        l.merge_str("[inner]\nbinz = 3\n", "u.toml").unwrap();
        let e = l.build::<Root>().unwrap_err().to_string();
        assert!(e.starts_with("u.toml:"), "{e}");
        assert_eq!(
            key_line("a = 1\n[[m]]\nx = 1\n[[m]]\nx = 2\n", "m[1].x"),
            Some(5)
        );
    }

    #[test]
    fn a_default_made_invalid_by_an_assignment_beside_it_names_both() {
        // `inner.bins` comes from the defaults, but `--set inner.cost=…` is what the user
        // changed in that section: the error names the assignment too.
        let mut l = Layers::new();
        l.merge_value(&Root::default(), "defaults").unwrap();
        l.set("inner.cost=2").unwrap();
        l.set("name=\"x\"").unwrap();
        let e = l
            .locate(ConfigError::range("inner.bins", 16, "a multiple of cost"))
            .to_string();
        assert!(
            e.starts_with("defaults, with --set inner.cost=2: config key `inner.bins`"),
            "{e}"
        );
        // Without an assignment in the section, the origin alone.
        let mut l = Layers::new();
        l.merge_value(&Root::default(), "defaults").unwrap();
        l.set("name=\"x\"").unwrap();
        let e = l
            .locate(ConfigError::range("inner.bins", 16, "x"))
            .to_string();
        assert!(e.starts_with("defaults: config key"), "{e}");
    }

    #[test]
    fn duplicate_keys_are_named() {
        let e = Layers::new()
            .merge_str("a = 1\nb = 2\na = 3\n", "d.toml")
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("d.toml:3:") && e.contains("`a`"), "{e}");
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
        assert_eq!(parse_value("28").unwrap(), Value::Integer(28));
        assert_eq!(parse_value("inf").unwrap(), Value::Float(f64::INFINITY));
        assert_eq!(
            parse_value("fr-fcfs").unwrap(),
            Value::String("fr-fcfs".into())
        );
        assert_eq!(parse_value("\"x y\"").unwrap(), Value::String("x y".into()));
        let e = parse_value("18446744073709551615").unwrap_err();
        assert!(e.contains("9223372036854775807"), "{e}");
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
