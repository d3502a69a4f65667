//! Reusing finished points of other results directories (`rtsim sweep … --reuse DIR`).
//!
//! Shipped experiments share points: the 4 MB points of Figures 5–6, the 128-TM points of
//! Figure 7 and Table 1's points of the same scene are one configuration each, and a
//! paper-scale point costs up to an hour. A point still to run whose *resolved*
//! configuration (every key of its `config.resolved.toml`, presets and scene defaults
//! applied) equals a finished point's elsewhere, run by the same command with the same
//! arguments, gets a copy of that point's outputs instead of a rerun. Keys that never change
//! results ([`result_neutral`]) are left out of the comparison. The copy's `point.json` is
//! this experiment's record, with the donor's build (who ran it) and where it came from
//! ([`crate::store::ReusedFrom`]).

use crate::SweepError;
use crate::store::{PointRecord, RECORD};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Configuration keys that never change a run's results: where it ran, what it wrote and how
/// the host ran it (the engine, the time series and the number of host threads give
/// identical results, tests check it). Not `sim.window` nor `sim.cycle_limit`: they decide
/// what is simulated. (`rtsim report` keeps runs apart by the other keys too.)
pub fn result_neutral(key: &str) -> bool {
    key.starts_with("output.")
        || matches!(
            key,
            "threads" | "scene.dir" | "bvh.parallel_threshold" | "sim.mode" | "sim.timeline_cycles"
        )
}

/// A resolved configuration's settings that decide its results: every leaf as a dotted key
/// and its value written as TOML, result-neutral keys left out; `None` if it does not parse.
pub fn settings(resolved_toml: &str) -> Option<BTreeMap<String, String>> {
    let mut all = crate::store::flatten_toml(resolved_toml)?;
    all.retain(|k, _| !result_neutral(k));
    Some(all)
}

/// A finished point that may be reused.
#[derive(Clone, Debug)]
pub struct Donor {
    /// Its directory (`ROOT/points/pNNNNN`).
    pub dir: PathBuf,
    pub record: PointRecord,
    /// Its resolved configuration's [`settings`].
    pub settings: BTreeMap<String, String>,
}

/// The name of a run's resolved configuration in its output directory.
pub const RESOLVED: &str = "config.resolved.toml";

/// The finished points of the results directories `roots`, in order (a directory's points by
/// number). A root without a `points` directory, or a point without a readable record and
/// resolved configuration, is an error naming it: a mistyped `--reuse` must not silently
/// reuse nothing.
pub fn donors(roots: &[PathBuf]) -> Result<Vec<Donor>, SweepError> {
    let mut out = Vec::new();
    for root in roots {
        let points = root.join("points");
        let entries = std::fs::read_dir(&points).map_err(|e| {
            SweepError::invalid(
                root,
                format!(
                    "not a sweep's results directory (reading {}: {e})",
                    points.display()
                ),
            )
        })?;
        let mut dirs: Vec<PathBuf> = Vec::new();
        for e in entries {
            let e = e.map_err(|e| rtsim_core::FileError::io(&points, e))?;
            let name = e.file_name().to_string_lossy().into_owned();
            // Finished points only: not `.tmp` (running or killed) nor `.failed`.
            let finished = name.len() == 6
                && name.starts_with('p')
                && name[1..].bytes().all(|b| b.is_ascii_digit());
            if finished && e.path().is_dir() {
                dirs.push(e.path());
            }
        }
        dirs.sort();
        for dir in dirs {
            out.push(donor(&dir)?);
        }
    }
    Ok(out)
}

/// The finished point in `dir`.
fn donor(dir: &Path) -> Result<Donor, SweepError> {
    let read = |name: &str| {
        let path = dir.join(name);
        std::fs::read_to_string(&path)
            .map_err(|e| SweepError::from(rtsim_core::FileError::io(&path, e)))
    };
    let path = dir.join(RECORD);
    let record: PointRecord =
        serde_json::from_str(&read(RECORD)?).map_err(|source| SweepError::Json {
            path: path.clone(),
            source,
        })?;
    let settings = settings(&read(RESOLVED)?)
        .ok_or_else(|| SweepError::invalid(dir.join(RESOLVED), "does not parse as TOML"))?;
    Ok(Donor {
        dir: dir.to_path_buf(),
        record,
        settings,
    })
}

/// A donor for a point: the first of `donors` that ran `command` with `args` on a
/// configuration with the point's `settings`, and the keys it predates.
///
/// A key the donor's configuration lacks, where the point has it at its built-in default
/// (`defaults`: the settings of the built-in defaults, before presets), counts as equal: the
/// donor's build predates that setting, and a new setting's default keeps the behaviour it
/// had before (the rule every knob here was added under; the sweep names those keys, and the
/// donor's build, when it reuses). Every other difference, a key only the donor has among
/// them, rules the donor out.
pub fn find<'a>(
    donors: &'a [Donor],
    command: &str,
    args: &[String],
    settings: &BTreeMap<String, String>,
    defaults: &BTreeMap<String, String>,
) -> Option<(&'a Donor, Vec<String>)> {
    donors
        .iter()
        .filter(|d| d.record.command == command && d.record.args == args)
        .find_map(|d| {
            let mut predates = Vec::new();
            for (k, v) in settings {
                match d.settings.get(k) {
                    Some(dv) if dv == v => {}
                    None if defaults.get(k) == Some(v) => predates.push(k.clone()),
                    _ => return None,
                }
            }
            let extra = d.settings.keys().any(|k| !settings.contains_key(k));
            (!extra).then_some((d, predates))
        })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn neutral_keys_are_left_out_and_the_others_kept() {
        let a = settings(
            "# a comment\nthreads = 0\nseed = 1\n[output]\ndir = \"/a\"\n[scene]\nname = \"s\"\n\
             dir = \"/x\"\n[sim]\nmode = \"fast\"\ncycle_limit = 100\n",
        )
        .unwrap();
        let b = settings(
            "threads = 1\nseed = 1\n[output]\ndir = \"/b\"\n[scene]\nname = \"s\"\n\
             dir = \"/y\"\n[sim]\nmode = \"reference\"\ncycle_limit = 100\n",
        )
        .unwrap();
        assert_eq!(a, b);
        assert_eq!(
            a.keys().collect::<Vec<_>>(),
            ["scene.name", "seed", "sim.cycle_limit"]
        );
        // A key that decides what is simulated tells them apart.
        let c = settings("seed = 1\n[scene]\nname = \"s\"\n[sim]\ncycle_limit = 200\n").unwrap();
        assert_ne!(a, c);
        assert!(settings("not toml = = 1").is_none());
    }

    fn donor(settings: &str) -> Donor {
        Donor {
            dir: PathBuf::from("d"),
            record: PointRecord {
                experiment: "e".into(),
                index: 0,
                command: "simulate".into(),
                args: vec![],
                quick: false,
                params: Default::default(),
                config: String::new(),
                build: Default::default(),
                reused_from: None,
            },
            settings: super::settings(settings).unwrap(),
        }
    }

    #[test]
    fn a_donor_matches_on_every_setting_or_on_keys_it_predates_at_their_defaults() {
        let defaults = settings("seed = 1\n[knob]\nnew = \"off\"\n").unwrap();
        let s = |t: &str| settings(t).unwrap();
        let donors = [donor("seed = 2\n"), donor("seed = 1\n")];
        // The second donor, which predates `knob.new`, at its default here.
        let (d, predates) = find(
            &donors,
            "simulate",
            &[],
            &s("seed = 1\n[knob]\nnew = \"off\"\n"),
            &defaults,
        )
        .expect("a donor");
        assert_eq!(d.settings, s("seed = 1\n"));
        assert_eq!(predates, ["knob.new"]);
        // Not at its default: no donor.
        let on = s("seed = 1\n[knob]\nnew = \"on\"\n");
        assert!(find(&donors, "simulate", &[], &on, &defaults).is_none());
        // A key only the donor has, another command or other arguments: no donor.
        let extra = [donor("seed = 1\nold = 3\n")];
        assert!(find(&extra, "simulate", &[], &s("seed = 1\n"), &defaults).is_none());
        assert!(find(&donors, "render", &[], &s("seed = 1\n"), &defaults).is_none());
        let args = ["--spp".to_string(), "2".to_string()];
        assert!(find(&donors, "simulate", &args, &s("seed = 1\n"), &defaults).is_none());
        // Equal settings: no keys predated.
        let (_, predates) = find(&donors, "simulate", &[], &s("seed = 2\n"), &defaults).unwrap();
        assert!(predates.is_empty());
    }
}
