//! Resolving a `--scene` argument to a [`Scene`].
//!
//! A name is tried, in order, as
//! 1. a built-in procedural scene ([`crate::procedural::BUILTIN_NAMES`]);
//! 2. a descriptor shipped with rtsim (`scenes/*.toml` at the repository root, embedded in the
//!    binary); its mesh files are looked up in the scene directory;
//! 3. a path: a `.toml` descriptor (mesh paths relative to the descriptor, unless it says
//!    `paths = "scene-dir"`), or a mesh file (`.obj`/`.ply`, optionally `.zst`/`.gz`), which
//!    gets an automatic camera framing its bounds and an automatic light ([`crate::auto`]).
//!
//! Anything else is [`SceneError::UnknownScene`], listing the known names.

use crate::descriptor::{Descriptor, PathBase};
use crate::mesh::{self, mesh_format};
use crate::{PointLight, Scene, SceneError, auto, procedural};
use rtsim_core::{Aabb, Affine};
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
    /// Triangle count at default size, known without loading (descriptor `triangles` key,
    /// or computed for built-ins).
    pub triangles: Option<u64>,
    /// Mesh files of a descriptor scene, relative to the scene directory.
    pub files: Vec<String>,
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

/// The shipped descriptors: (name, TOML text), in `rtsim scenes` order.
pub const SHIPPED: [(&str, &str); 9] = [
    ("sibenik", include_str!("../../../scenes/sibenik.toml")),
    (
        "conference",
        include_str!("../../../scenes/conference.toml"),
    ),
    (
        "crytek-sponza",
        include_str!("../../../scenes/crytek-sponza.toml"),
    ),
    (
        "sponza-dabrovic",
        include_str!("../../../scenes/sponza-dabrovic.toml"),
    ),
    (
        "stanford-dragon",
        include_str!("../../../scenes/stanford-dragon.toml"),
    ),
    (
        "dragon-box",
        include_str!("../../../scenes/dragon-box.toml"),
    ),
    (
        "stanford-bunny",
        include_str!("../../../scenes/stanford-bunny.toml"),
    ),
    ("bunny-box", include_str!("../../../scenes/bunny-box.toml")),
    (
        "cornell-box",
        include_str!("../../../scenes/cornell-box.toml"),
    ),
];

/// The environment variable naming the scene directory.
pub const SCENE_DIR_ENV: &str = "RTSIM_SCENE_DIR";
/// The default scene directory, relative to the working directory.
pub const DEFAULT_SCENE_DIR: &str = "../shared/scenes";

/// The scene directory: the explicit one, else `$RTSIM_SCENE_DIR`, else `../shared/scenes`
/// (relative to the working directory) when it exists.
pub fn resolve_scene_dir(explicit: Option<&Path>) -> Option<PathBuf> {
    if let Some(p) = explicit {
        return Some(p.to_path_buf());
    }
    if let Some(p) = std::env::var_os(SCENE_DIR_ENV).filter(|p| !p.is_empty()) {
        return Some(PathBuf::from(p));
    }
    let default = PathBuf::from(DEFAULT_SCENE_DIR);
    default.is_dir().then_some(default)
}

/// The text of shipped descriptor `name`.
pub fn shipped_descriptor(name: &str) -> Option<&'static str> {
    SHIPPED.iter().find(|(n, _)| *n == name).map(|(_, t)| *t)
}

/// Origin shown in errors about shipped descriptor `name` (its path in the repository).
fn shipped_origin(name: &str) -> PathBuf {
    PathBuf::from(format!("scenes/{name}.toml"))
}

/// All names `--scene` accepts besides paths.
pub fn known_names() -> Vec<&'static str> {
    procedural::BUILTIN_NAMES
        .iter()
        .copied()
        .chain(SHIPPED.iter().map(|(n, _)| *n))
        .collect()
}

fn unknown(name: &str) -> SceneError {
    SceneError::UnknownScene {
        name: rtsim_core::text::echo(name),
        known: format!(
            "{} (or a path to a .toml descriptor or an .obj/.ply mesh, optionally .zst/.gz)",
            known_names().join(", ")
        ),
    }
}

/// Classify a `--scene` argument without loading anything.
pub fn find_scene(name: &str) -> Result<SceneSource, SceneError> {
    if let Some(&b) = procedural::BUILTIN_NAMES.iter().find(|&&b| b == name) {
        return Ok(SceneSource::Builtin(b));
    }
    if let Some(&(n, _)) = SHIPPED.iter().find(|(n, _)| *n == name) {
        return Ok(SceneSource::Shipped(n));
    }
    let path = Path::new(name);
    let looks_like_file = is_descriptor_path(path) || mesh_format(path).is_some();
    // Anything that exists is taken as a file, so a directory or device is reported as one.
    if path.is_file() || looks_like_file || path.exists() {
        // A missing file with a scene-file extension is reported as missing when loading.
        return Ok(SceneSource::File(path.to_path_buf()));
    }
    Err(unknown(name))
}

fn is_descriptor_path(p: &Path) -> bool {
    p.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("toml"))
}

/// Load a scene.
pub fn load_scene(req: &SceneRequest<'_>) -> Result<Scene, SceneError> {
    match find_scene(req.name)? {
        SceneSource::Builtin(name) => {
            procedural::generate(name, req.size, req.seed).expect("name is a built-in")
        }
        SceneSource::Shipped(name) => {
            let text = shipped_descriptor(name).expect("name is shipped");
            let d = Descriptor::parse(text, &shipped_origin(name))?;
            let base = scene_dir_base(name, &d, req.scene_dir)?;
            d.build(name, &base)
        }
        SceneSource::File(path) => {
            // Checked before opening: a FIFO would wait for a writer, a directory has no text.
            let meta = std::fs::metadata(&path).map_err(|e| {
                let e = match e.kind() {
                    std::io::ErrorKind::NotFound => {
                        std::io::Error::new(e.kind(), "no such scene file")
                    }
                    _ => e,
                };
                rtsim_core::FileError::io(&path, e)
            })?;
            if !meta.is_file() {
                let kind = rtsim_core::error::describe_file_type(&meta.file_type());
                return Err(rtsim_core::FileError::io(
                    &path,
                    std::io::Error::new(
                        std::io::ErrorKind::InvalidInput,
                        format!("it is {kind}, not a scene file"),
                    ),
                )
                .into());
            }
            let name = scene_name_of(&path);
            if is_descriptor_path(&path) {
                let text = rtsim_core::text::read_text_file(&path)?;
                let d = Descriptor::parse(&text, &path)?;
                let base = match d.paths {
                    PathBase::Descriptor => {
                        path.parent().map(Path::to_path_buf).unwrap_or_default()
                    }
                    PathBase::SceneDir => scene_dir_base(&name, &d, req.scene_dir)?,
                };
                d.build(&name, &base)
            } else {
                load_bare_mesh(&path, &name)
            }
        }
    }
}

/// The scene directory for a descriptor whose paths are relative to it, after checking that
/// every mesh file is there ([`SceneError::MissingSceneFile`] otherwise).
fn scene_dir_base(
    name: &str,
    d: &Descriptor,
    scene_dir: Option<&Path>,
) -> Result<PathBuf, SceneError> {
    let missing = |file: &str, dir: String| SceneError::MissingSceneFile {
        name: name.to_string(),
        file: file.to_string(),
        dir,
    };
    let Some(dir) = scene_dir else {
        let file = d
            .meshes
            .first()
            .map(|m| m.file.as_str())
            .unwrap_or("its meshes");
        return Err(missing(
            file,
            format!("(none: no --scene-dir, ${SCENE_DIR_ENV} unset, no {DEFAULT_SCENE_DIR})"),
        ));
    };
    if d.paths != PathBase::SceneDir {
        // A shipped descriptor must name scene-directory paths; checked by the tests.
        return Err(SceneError::Format {
            path: shipped_origin(name),
            message: "a shipped descriptor needs `paths = \"scene-dir\"`".into(),
        });
    }
    for i in 0..d.meshes.len() {
        if !d.mesh_path(i, dir).is_file() {
            return Err(missing(&d.meshes[i].file, dir.display().to_string()));
        }
    }
    Ok(dir.to_path_buf())
}

/// A scene's name from its file: the file name without `.zst`/`.gz` and the format extension.
fn scene_name_of(path: &Path) -> String {
    let mut name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    for ext in [".zst", ".gz", ".toml", ".obj", ".ply"] {
        if name.to_ascii_lowercase().ends_with(ext) {
            name.truncate(name.len() - ext.len());
        }
    }
    name
}

/// A mesh without a descriptor: automatic camera and light (see [`crate::auto`]).
fn load_bare_mesh(path: &Path, name: &str) -> Result<Scene, SceneError> {
    let m = mesh::load_mesh(path, &Affine::IDENTITY)?;
    if m.triangles.is_empty() {
        return Err(SceneError::Empty {
            name: name.to_string(),
            why: m.report.why_empty(),
        });
    }
    let mut bounds = Aabb::EMPTY;
    for t in &m.triangles {
        for &v in t {
            bounds.grow(v);
        }
    }
    let position = auto::framing_light(&bounds);
    let intensity = auto::light_intensity(&m.triangles, position);
    Ok(Scene {
        name: name.to_string(),
        triangles: m.triangles,
        material_ids: m.material_ids,
        materials: m.materials,
        camera: auto::framing_camera(&bounds),
        viewpoints: Vec::new(),
        light: PointLight {
            position,
            intensity,
        },
        workload_defaults: toml::Table::new(),
        files: vec![path.to_path_buf()],
        report: m.report,
    })
}

/// All scenes `rtsim scenes` lists: built-ins, then shipped descriptors (whose files are
/// looked for in `scene_dir`).
pub fn list_scenes(scene_dir: Option<&Path>) -> Vec<SceneInfo> {
    let mut out = Vec::new();
    for name in procedural::BUILTIN_NAMES {
        out.push(SceneInfo {
            name: name.to_string(),
            kind: "built-in",
            description: procedural::describe(name).unwrap_or_default().to_string(),
            available: true,
            triangles: procedural::triangle_count(name, 1.0),
            files: Vec::new(),
        });
    }
    for (name, text) in SHIPPED {
        // The shipped descriptors parse (a test checks); show a broken one rather than hide it.
        let (description, triangles, files) = match Descriptor::parse(text, &shipped_origin(name)) {
            Ok(d) => (
                d.description.clone(),
                d.triangles,
                d.meshes.iter().map(|m| m.file.clone()).collect::<Vec<_>>(),
            ),
            Err(e) => (format!("invalid descriptor: {e}"), None, Vec::new()),
        };
        let available = !files.is_empty()
            && scene_dir.is_some_and(|dir| files.iter().all(|f| dir.join(f).is_file()));
        out.push(SceneInfo {
            name: name.to_string(),
            kind: "descriptor",
            description,
            available,
            triangles,
            files,
        });
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn req(name: &str) -> SceneRequest<'_> {
        SceneRequest {
            name,
            size: 0.01,
            seed: 1,
            scene_dir: None,
        }
    }

    #[test]
    fn every_shipped_descriptor_parses_and_uses_the_scene_dir() {
        for (name, text) in SHIPPED {
            let d = Descriptor::parse(text, &shipped_origin(name))
                .unwrap_or_else(|e| panic!("{name}: {e}"));
            assert_eq!(d.paths, PathBase::SceneDir, "{name}");
            assert!(d.triangles.is_some(), "{name}: no `triangles`");
            assert!(!d.description.is_empty(), "{name}: no description");
            assert!(d.camera.is_some() && d.light.is_some(), "{name}");
            assert!(!d.meshes.is_empty(), "{name}");
        }
    }

    #[test]
    fn names_resolve_in_order() {
        assert_eq!(
            find_scene("cornell").unwrap(),
            SceneSource::Builtin("cornell")
        );
        assert_eq!(
            find_scene("sibenik").unwrap(),
            SceneSource::Shipped("sibenik")
        );
        assert_eq!(
            find_scene("x/y.obj.zst").unwrap(),
            SceneSource::File(PathBuf::from("x/y.obj.zst"))
        );
        let e = find_scene("sibenick").unwrap_err().to_string();
        assert!(e.contains("unknown scene `sibenick`"), "{e}");
        assert!(e.contains("cornell") && e.contains("bunny-box"), "{e}");
    }

    #[test]
    fn builtins_load() {
        let s = load_scene(&req("hairball")).unwrap();
        assert_eq!(s.name, "hairball");
        assert_eq!(s.triangles.len(), 75 * 384);
    }

    #[test]
    fn shipped_without_scene_dir_names_the_remedy() {
        let e = load_scene(&req("sibenik")).unwrap_err().to_string();
        assert!(
            e.contains("sibenik/sibenik.obj.zst") && e.contains("RTSIM_SCENE_DIR"),
            "{e}"
        );
        let dir = tempfile::tempdir().unwrap();
        let r = SceneRequest {
            scene_dir: Some(dir.path()),
            ..req("dragon-box")
        };
        let e = load_scene(&r).unwrap_err().to_string();
        assert!(
            e.contains("stanford-dragon/dragon_from_drc.ply.zst")
                && e.contains(&dir.path().display().to_string())
                && e.contains("--scene-dir"),
            "{e}"
        );
    }

    #[test]
    fn missing_file_and_unknown_scene() {
        let e = load_scene(&req("/nonexistent/m.obj"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("/nonexistent/m.obj:"), "{e}");
        let e = load_scene(&req("/nonexistent/d.toml"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("/nonexistent/d.toml:"), "{e}");
        let e = load_scene(&req("nothing-like-this"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("unknown scene"), "{e}");
    }

    #[test]
    fn bare_mesh_gets_camera_and_light() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("tri.obj.gz");
        let mut enc = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
        std::io::Write::write_all(&mut enc, b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
        std::fs::write(&p, enc.finish().unwrap()).unwrap();
        let s = load_scene(&req(p.to_str().unwrap())).unwrap();
        assert_eq!(s.name, "tri");
        assert_eq!(s.triangles.len(), 1);
        let b = s.bounds();
        assert!(!b.contains(s.camera.eye));
        let to_centre = (b.center() - s.camera.eye).normalized();
        assert!(to_centre.dot(s.camera.direction.normalized()) > 0.9999);
        assert!(s.light.intensity.x > 0.0);
    }

    #[test]
    fn user_descriptor_paths_are_relative_to_it() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::create_dir(dir.path().join("m")).unwrap();
        std::fs::write(
            dir.path().join("m/a.obj"),
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
        )
        .unwrap();
        let d = dir.path().join("s.toml");
        std::fs::write(
            &d,
            "[[mesh]]\nfile = \"m/a.obj\"\n[camera]\neye = [0, 0, 3]\ndirection = [0, 0, -1]\nfov_y = 40\n",
        )
        .unwrap();
        let s = load_scene(&req(d.to_str().unwrap())).unwrap();
        assert_eq!(s.name, "s");
        assert_eq!(s.camera.fov_y_deg, 40.0);
        // The same file under scene-dir rules needs a scene directory.
        std::fs::write(&d, "paths = \"scene-dir\"\n[[mesh]]\nfile = \"m/a.obj\"\n").unwrap();
        assert!(matches!(
            load_scene(&req(d.to_str().unwrap())),
            Err(SceneError::MissingSceneFile { .. })
        ));
        let r = SceneRequest {
            scene_dir: Some(dir.path()),
            ..req(d.to_str().unwrap())
        };
        assert_eq!(load_scene(&r).unwrap().triangles.len(), 1);
    }

    #[test]
    fn listing_has_every_scene() {
        let list = list_scenes(None);
        assert_eq!(list.len(), 3 + SHIPPED.len());
        assert!(list.iter().all(|s| s.triangles.is_some()));
        assert!(
            list.iter()
                .filter(|s| s.kind == "descriptor")
                .all(|s| !s.available)
        );
        assert_eq!(list[1].triangles, Some(2_880_000));
    }

    #[test]
    fn scene_names_from_paths() {
        assert_eq!(scene_name_of(Path::new("a/b/dragon.ply.zst")), "dragon");
        assert_eq!(scene_name_of(Path::new("x.toml")), "x");
        assert_eq!(scene_name_of(Path::new("x.OBJ")), "x");
    }
}
