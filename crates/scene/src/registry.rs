//! Resolving a `--scene` argument to a [`Scene`].
//!
//! PLACEHOLDER (skeleton): the scene issue's loader work replaces this file.

use crate::{Scene, SceneError};
use std::path::{Path, PathBuf};

/// Where a scene comes from.
#[derive(Clone, Debug, PartialEq)]
pub enum SceneSource {
    /// A procedural scene built into the binary.
    Builtin(&'static str),
    /// A descriptor shipped with rtsim (name, TOML text).
    Shipped(&'static str),
    /// A user file: a `.toml` descriptor or a mesh.
    File(PathBuf),
}

/// One line of `rtsim scenes`.
#[derive(Clone, Debug)]
pub struct SceneInfo {
    pub name: String,
    pub kind: &'static str,
    pub description: String,
    /// For descriptor scenes: whether all mesh files were found in the scene directory.
    pub available: bool,
}

/// Parameters of a scene load.
#[derive(Clone, Debug)]
pub struct SceneRequest<'a> {
    /// Built-in name, shipped descriptor name, or a path to a `.toml` descriptor or mesh file.
    pub name: &'a str,
    /// Size factor for procedural scenes (1 = the documented default size).
    pub size: f64,
    /// Seed for procedural scenes.
    pub seed: u64,
    /// Scene directory for descriptor meshes.
    pub scene_dir: Option<&'a Path>,
}

/// The scene directory: the explicit one, else `$RTSIM_SCENE_DIR`, else `../shared/scenes`
/// (relative to the working directory) when it exists.
pub fn resolve_scene_dir(explicit: Option<&Path>) -> Option<PathBuf> {
    if let Some(p) = explicit {
        return Some(p.to_path_buf());
    }
    if let Some(p) = std::env::var_os("RTSIM_SCENE_DIR").filter(|p| !p.is_empty()) {
        return Some(PathBuf::from(p));
    }
    let default = PathBuf::from("../shared/scenes");
    default.is_dir().then_some(default)
}

/// Load a scene.
pub fn load_scene(req: &SceneRequest<'_>) -> Result<Scene, SceneError> {
    Err(SceneError::UnknownScene {
        name: req.name.to_string(),
        known: String::new(),
    })
}

/// All scenes `rtsim scenes` lists.
pub fn list_scenes(_scene_dir: Option<&Path>) -> Vec<SceneInfo> {
    Vec::new()
}
