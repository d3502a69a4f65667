//! TOML scene descriptors: meshes with transforms, camera, light, an optional closed box, and
//! workload defaults. The format is documented in `docs/SCENES.md`; the shipped descriptors
//! are `scenes/*.toml` at the repository root.
//!
//! ```toml
//! description = "Sibenik cathedral (McGuire)"
//! triangles = 75275            # expected count after loading (for `rtsim scenes`, tests)
//! paths = "scene-dir"          # relative mesh paths: "scene-dir" or "descriptor" (default)
//!
//! [[mesh]]
//! file = "sibenik/sibenik.obj.zst"
//! scale = 1.0                  # or [sx, sy, sz]; applied first
//! rotate = { axis = [0, 1, 0], degrees = 90 }   # then this
//! translate = [0, 0, 0]        # then this
//! material = { albedo = [0.7, 0.7, 0.7] }       # replaces the file's materials
//!
//! [camera]
//! eye = [-15, -5, 0]
//! direction = [1, -0.2, 0]     # or look_at = [x, y, z]
//! up = [0, 1, 0]               # default +y
//! fov_y = 60                   # vertical field of view, degrees
//!
//! [[viewpoint]]                # further cameras, chosen with scene.viewpoint = 1, 2, …
//! eye = [-19.2, -10.6, 1.5]    # the same keys as [camera]
//! direction = [0.96, -0.04, -0.29]
//! fov_y = 73.74
//!
//! [light]
//! position = [0, 5, 0]
//! intensity = 1000.0           # or [r, g, b]; default: see auto::light_intensity
//!
//! [box]                        # optional closed box (12 triangles), appended last
//! min = [-1, -1, -1]
//! max = [1, 1, 1]
//! albedo = [0.7, 0.7, 0.7]
//!
//! [workload]                   # defaults under the user's config, e.g. ao_radius = 5.0
//! ```
//!
//! Scene order: the meshes in the order listed, each in file order, then the box.

use crate::auto;
use crate::mesh::{self, MAX_COORDINATE, Mesh};
use crate::{Camera, Material, PointLight, Scene, SceneError, Triangle};
use rtsim_core::{Aabb, Affine, Vec3};
use serde::Deserialize;
use std::path::{Path, PathBuf};

/// Albedo of a `[box]` without one (assumed: the grey of [`Material::default_grey`], like
/// simtrax's `dragon_walls`, whose MTL is not published).
const BOX_ALBEDO: f32 = 0.7;

/// A parsed descriptor. Field names are the TOML keys.
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Descriptor {
    /// One line for `rtsim scenes`.
    #[serde(default)]
    pub description: String,
    /// Triangle count after loading (degenerates dropped, box included). Shown by
    /// `rtsim scenes` without loading; the tests check it.
    pub triangles: Option<u64>,
    /// What relative mesh paths are relative to.
    #[serde(default)]
    pub paths: PathBase,
    /// `[[mesh]]` entries, in scene order.
    #[serde(rename = "mesh", default)]
    pub meshes: Vec<MeshSpec>,
    /// `[camera]`; default: [`auto::framing_camera`] of the scene bounds.
    pub camera: Option<CameraSpec>,
    /// `[[viewpoint]]`: further cameras, in order (`scene.viewpoint = 1` is the first).
    #[serde(rename = "viewpoint", default)]
    pub viewpoints: Vec<ViewpointSpec>,
    /// `[light]`; default: [`auto::framing_light`] of the scene bounds.
    pub light: Option<LightSpec>,
    /// `[box]`: a closed box around the model.
    #[serde(rename = "box")]
    pub enclosure: Option<BoxSpec>,
    /// `[workload]`: defaults merged under the user's `workload` settings.
    #[serde(default)]
    pub workload: toml::Table,
}

/// Base directory of relative mesh paths.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum PathBase {
    /// The directory holding the descriptor file (default; user descriptors).
    #[default]
    Descriptor,
    /// The scene directory (`--scene-dir`, `RTSIM_SCENE_DIR`, `../shared/scenes`); what the
    /// shipped descriptors use.
    SceneDir,
}

/// One `[[mesh]]`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MeshSpec {
    /// `.obj` or `.ply`, optionally `.zst` / `.gz`; relative or absolute.
    pub file: String,
    /// Uniform or per-axis scale, applied first.
    pub scale: Option<ScaleSpec>,
    /// Rotation, applied after the scale.
    pub rotate: Option<RotateSpec>,
    /// Translation, applied last.
    pub translate: Option<[f32; 3]>,
    /// Replaces all of the file's materials.
    pub material: Option<MaterialSpec>,
}

#[derive(Clone, Copy, Debug, Deserialize)]
#[serde(untagged)]
pub enum ScaleSpec {
    Uniform(f32),
    PerAxis([f32; 3]),
}

#[derive(Clone, Copy, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RotateSpec {
    pub axis: [f32; 3],
    /// Right-handed, degrees.
    pub degrees: f32,
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MaterialSpec {
    pub name: Option<String>,
    /// Diffuse albedo in [0, 1].
    pub albedo: [f32; 3],
    /// Emitted radiance, ≥ 0. Default 0.
    #[serde(default)]
    pub emission: [f32; 3],
}

#[derive(Clone, Copy, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraSpec {
    pub eye: [f32; 3],
    /// View direction (any length); exactly one of `direction` and `look_at`.
    pub direction: Option<[f32; 3]>,
    pub look_at: Option<[f32; 3]>,
    /// Default +y.
    #[serde(default = "y_up")]
    pub up: [f32; 3],
    /// Vertical field of view in degrees, in (0, 180).
    pub fov_y: f32,
}

/// One `[[viewpoint]]`: a camera, with the keys of `[camera]`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ViewpointSpec {
    pub eye: [f32; 3],
    pub direction: Option<[f32; 3]>,
    pub look_at: Option<[f32; 3]>,
    #[serde(default = "y_up")]
    pub up: [f32; 3],
    pub fov_y: f32,
}

impl ViewpointSpec {
    fn camera(&self) -> CameraSpec {
        CameraSpec {
            eye: self.eye,
            direction: self.direction,
            look_at: self.look_at,
            up: self.up,
            fov_y: self.fov_y,
        }
    }
}

fn y_up() -> [f32; 3] {
    [0.0, 1.0, 0.0]
}

#[derive(Clone, Copy, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LightSpec {
    pub position: [f32; 3],
    /// Radiant intensity per channel; default [`auto::light_intensity`].
    pub intensity: Option<IntensitySpec>,
}

#[derive(Clone, Copy, Debug, Deserialize)]
#[serde(untagged)]
pub enum IntensitySpec {
    Grey(f32),
    Rgb([f32; 3]),
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BoxSpec {
    pub min: [f32; 3],
    pub max: [f32; 3],
    /// Default 0.7 grey.
    pub albedo: Option<[f32; 3]>,
    /// Default 0.
    pub emission: Option<[f32; 3]>,
}

/// A descriptor value that fails validation: its key and what is wrong.
#[derive(Debug)]
struct Invalid {
    key: String,
    message: String,
}

impl Invalid {
    /// As an error naming `origin`, and the key's line when the descriptor `text` is known.
    fn at(self, origin: &Path, text: Option<&str>) -> SceneError {
        let message = format!("key `{}`: {}", self.key, self.message);
        match text.and_then(|t| rtsim_config::key_line(t, &self.key)) {
            Some(line) => rtsim_core::FileError::at(origin, line, message).into(),
            None => SceneError::Format {
                path: origin.to_path_buf(),
                message,
            },
        }
    }
}

fn v3(a: [f32; 3]) -> Vec3 {
    Vec3::from_array(a)
}

impl CameraSpec {
    /// The camera (validated: exactly one of `direction` and `look_at`).
    fn to_camera(self) -> Camera {
        Camera {
            eye: v3(self.eye),
            direction: match (self.direction, self.look_at) {
                (Some(d), _) => v3(d),
                (None, Some(t)) => v3(t) - v3(self.eye),
                (None, None) => unreachable!("validated: direction or look_at"),
            },
            up: v3(self.up),
            fov_y_deg: self.fov_y,
        }
    }
}

impl Descriptor {
    /// Parse descriptor text; `origin` names it in errors (file:line: key `a.b`: message).
    pub fn parse(text: &str, origin: &Path) -> Result<Descriptor, SceneError> {
        let located = |e: toml::de::Error, key: Option<String>| {
            let msg = rtsim_config::toml_message(&e, text);
            let message = match key.filter(|k| !k.is_empty() && k != ".") {
                Some(k) => format!("key `{k}`: {msg}"),
                None => msg,
            };
            match e.span() {
                Some(s) => rtsim_core::FileError::at(
                    origin,
                    text[..s.start.min(text.len())].matches('\n').count() as u64 + 1,
                    message,
                )
                .into(),
                None => SceneError::Format {
                    path: origin.to_path_buf(),
                    message,
                },
            }
        };
        let de = toml::Deserializer::parse(text).map_err(|e| located(e, None))?;
        let d: Descriptor = serde_path_to_error::deserialize(de).map_err(|e| {
            let key = e.path().to_string();
            located(e.into_inner(), Some(key))
        })?;
        d.check().map_err(|i| i.at(origin, Some(text)))?;
        Ok(d)
    }

    /// Checks serde cannot express; errors name the file and key.
    pub fn validate(&self, origin: &Path) -> Result<(), SceneError> {
        self.check().map_err(|i| i.at(origin, None))
    }

    fn check(&self) -> Result<(), Invalid> {
        let bad = invalid;
        let colour = |key: &str, a: [f32; 3], max: f32| {
            finite(key, &a)?;
            if a.iter().all(|&v| (0.0..=max).contains(&v)) {
                Ok(())
            } else {
                Err(bad(
                    key,
                    format!("components must be in [0, {max}], got {a:?}"),
                ))
            }
        };
        if self.meshes.is_empty() && self.enclosure.is_none() {
            return Err(bad(
                "mesh",
                "a descriptor needs at least one [[mesh]] or a [box]".into(),
            ));
        }
        for (i, m) in self.meshes.iter().enumerate() {
            let k = |f: &str| format!("mesh[{i}].{f}");
            if m.file.trim().is_empty() {
                return Err(bad(&k("file"), "must not be empty".into()));
            }
            if let Some(s) = m.scale {
                let a = match s {
                    ScaleSpec::Uniform(s) => [s; 3],
                    ScaleSpec::PerAxis(a) => a,
                };
                finite(&k("scale"), &a)?;
                if a.contains(&0.0) {
                    return Err(bad(
                        &k("scale"),
                        "must be non-zero (it would flatten the mesh)".into(),
                    ));
                }
            }
            if let Some(r) = m.rotate {
                finite(&k("rotate.axis"), &r.axis)?;
                finite(&k("rotate.degrees"), &[r.degrees])?;
                if v3(r.axis).length_squared() == 0.0 {
                    return Err(bad(&k("rotate.axis"), "must be non-zero".into()));
                }
            }
            if let Some(t) = m.translate {
                coord(&k("translate"), &t)?;
            }
            if let Some(mat) = &m.material {
                colour(&k("material.albedo"), mat.albedo, 1.0)?;
                colour(&k("material.emission"), mat.emission, f32::MAX)?;
            }
        }
        if let Some(c) = &self.camera {
            check_camera(c, "camera", &bad)?;
        }
        for (i, v) in self.viewpoints.iter().enumerate() {
            check_camera(&v.camera(), &format!("viewpoint[{i}]"), &bad)?;
        }
        if let Some(l) = &self.light {
            coord("light.position", &l.position)?;
            if let Some(i) = l.intensity {
                let a = match i {
                    IntensitySpec::Grey(g) => [g; 3],
                    IntensitySpec::Rgb(a) => a,
                };
                colour("light.intensity", a, f32::MAX)?;
            }
        }
        if let Some(b) = &self.enclosure {
            coord("box.min", &b.min)?;
            coord("box.max", &b.max)?;
            if (0..3).any(|i| b.min[i] >= b.max[i]) {
                return Err(bad(
                    "box",
                    format!(
                        "min {:?} must be below max {:?} on every axis",
                        b.min, b.max
                    ),
                ));
            }
            if let Some(a) = b.albedo {
                colour("box.albedo", a, 1.0)?;
            }
            if let Some(e) = b.emission {
                colour("box.emission", e, f32::MAX)?;
            }
        }
        Ok(())
    }

    /// The transform of mesh `i`: scale, then rotate, then translate.
    pub fn transform(&self, i: usize) -> Affine {
        let m = &self.meshes[i];
        let mut t = Affine::IDENTITY;
        if let Some(s) = m.scale {
            let s = match s {
                ScaleSpec::Uniform(s) => Vec3::splat(s),
                ScaleSpec::PerAxis(a) => v3(a),
            };
            t = Affine::scale(s);
        }
        if let Some(r) = m.rotate {
            t = Affine::rotate(v3(r.axis), r.degrees).then_after(&t);
        }
        if let Some(d) = m.translate {
            t = Affine::translate(v3(d)).then_after(&t);
        }
        t
    }

    /// The file of mesh `i` resolved against `base` (absolute paths stay as they are).
    pub fn mesh_path(&self, i: usize, base: &Path) -> PathBuf {
        let f = Path::new(&self.meshes[i].file);
        if f.is_absolute() {
            f.to_path_buf()
        } else {
            base.join(f)
        }
    }

    /// Load the meshes (relative paths against `base`) and assemble the scene `name`.
    pub fn build(&self, name: &str, base: &Path) -> Result<Scene, SceneError> {
        let mut all = Mesh::default();
        let mut files = Vec::with_capacity(self.meshes.len());
        for (i, spec) in self.meshes.iter().enumerate() {
            let path = self.mesh_path(i, base);
            let mut m = mesh::load_mesh(&path, &self.transform(i))?;
            if let Some(ms) = &spec.material {
                m.override_material(Material {
                    name: ms.name.clone().unwrap_or_else(|| format!("mesh{i}")),
                    albedo: v3(ms.albedo),
                    emission: v3(ms.emission),
                });
            }
            all.append(m);
            files.push(path);
        }
        if let Some(b) = &self.enclosure {
            let mut m = Mesh::default();
            let id = m.add_material(Material {
                name: "box".into(),
                albedo: b.albedo.map(v3).unwrap_or(Vec3::splat(BOX_ALBEDO)),
                emission: b.emission.map(v3).unwrap_or(Vec3::ZERO),
            });
            for t in box_triangles(&Aabb::new(v3(b.min), v3(b.max))) {
                m.push(t, id);
            }
            all.append(m);
        }
        if all.triangles.is_empty() {
            return Err(SceneError::Empty {
                name: name.to_string(),
                why: all.report.why_empty(),
            });
        }
        if let Some(n) = self.triangles
            && n != all.triangles.len() as u64
        {
            all.report.warnings.push(format!(
                "descriptor of `{name}` declares {n} triangles but {} were loaded (changed files?)",
                all.triangles.len()
            ));
        }
        let mut bounds = Aabb::EMPTY;
        for t in &all.triangles {
            for &v in t {
                bounds.grow(v);
            }
        }
        let camera = match &self.camera {
            Some(c) => c.to_camera(),
            None => auto::framing_camera(&bounds),
        };
        let viewpoints = self
            .viewpoints
            .iter()
            .map(|v| v.camera().to_camera())
            .collect();
        let position = self
            .light
            .map(|l| v3(l.position))
            .unwrap_or_else(|| auto::framing_light(&bounds));
        let intensity = match self.light.and_then(|l| l.intensity) {
            Some(IntensitySpec::Grey(g)) => Vec3::splat(g),
            Some(IntensitySpec::Rgb(a)) => v3(a),
            None => auto::light_intensity(&all.triangles, position),
        };
        Ok(Scene {
            name: name.to_string(),
            triangles: all.triangles,
            material_ids: all.material_ids,
            materials: all.materials,
            camera,
            viewpoints,
            light: PointLight {
                position,
                intensity,
            },
            workload_defaults: self.workload.clone(),
            files,
            report: all.report,
        })
    }
}

fn invalid(key: &str, message: String) -> Invalid {
    Invalid {
        key: key.to_string(),
        message,
    }
}

/// Every component finite.
fn finite(key: &str, a: &[f32]) -> Result<(), Invalid> {
    if a.iter().all(|v| v.is_finite()) {
        Ok(())
    } else {
        Err(invalid(key, format!("must be finite, got {a:?}")))
    }
}

/// A position: finite and within what the BVH and camera arithmetic can hold.
fn coord(key: &str, a: &[f32]) -> Result<(), Invalid> {
    finite(key, a)?;
    if a.iter().all(|v| v.abs() <= MAX_COORDINATE) {
        Ok(())
    } else {
        Err(invalid(
            key,
            format!("must be within ±{MAX_COORDINATE:e}, got {a:?}"),
        ))
    }
}

/// Checks of a camera (`[camera]` or a `[[viewpoint]]`), errors naming `key`.
fn check_camera(
    c: &CameraSpec,
    key: &str,
    bad: &dyn Fn(&str, String) -> Invalid,
) -> Result<(), Invalid> {
    coord(&format!("{key}.eye"), &c.eye)?;
    finite(&format!("{key}.up"), &c.up)?;
    let dir = match (c.direction, c.look_at) {
        (Some(d), None) => {
            finite(&format!("{key}.direction"), &d)?;
            v3(d)
        }
        (None, Some(t)) => {
            coord(&format!("{key}.look_at"), &t)?;
            v3(t) - v3(c.eye)
        }
        _ => {
            return Err(bad(
                key,
                "give exactly one of `direction` and `look_at`".into(),
            ));
        }
    };
    if dir.length_squared() == 0.0 {
        return Err(bad(
            key,
            "view direction is zero (look_at equals eye?)".into(),
        ));
    }
    let up = v3(c.up);
    if dir.normalized().cross(up.normalized()).length() < 1e-6 {
        return Err(bad(
            &format!("{key}.up"),
            "must not be zero or parallel to the view direction".into(),
        ));
    }
    if !(c.fov_y > 0.0 && c.fov_y < 180.0) {
        return Err(bad(
            &format!("{key}.fov_y"),
            format!("must be in (0, 180) degrees, got {}", c.fov_y),
        ));
    }
    Ok(())
}

/// The 12 triangles of a box's faces (two per face; -x, +x, -y, +y, -z, +z).
pub fn box_triangles(b: &Aabb) -> [Triangle; 12] {
    let c = |i: usize| {
        Vec3::new(
            if i & 1 == 0 { b.min.x } else { b.max.x },
            if i & 2 == 0 { b.min.y } else { b.max.y },
            if i & 4 == 0 { b.min.z } else { b.max.z },
        )
    };
    // Corner index bits: x = 1, y = 2, z = 4. Each face as a quad, split along a diagonal.
    const FACES: [[usize; 4]; 6] = [
        [0, 4, 6, 2], // -x
        [1, 3, 7, 5], // +x
        [0, 1, 5, 4], // -y
        [2, 6, 7, 3], // +y
        [0, 2, 3, 1], // -z
        [4, 5, 7, 6], // +z
    ];
    let mut out = [[Vec3::ZERO; 3]; 12];
    for (f, q) in FACES.iter().enumerate() {
        out[2 * f] = [c(q[0]), c(q[1]), c(q[2])];
        out[2 * f + 1] = [c(q[0]), c(q[2]), c(q[3])];
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<Descriptor, SceneError> {
        Descriptor::parse(text, Path::new("d.toml"))
    }
    fn err(text: &str) -> String {
        parse(text).unwrap_err().to_string()
    }

    const MIN: &str = "[[mesh]]\nfile = \"m.obj\"\n";

    #[test]
    fn full_descriptor_parses() {
        let d = parse(
            r#"
description = "test"
triangles = 14
paths = "scene-dir"
[[mesh]]
file = "a/m.obj.zst"
scale = [1, 2, 3]
rotate = { axis = [0, 0, 1], degrees = 90 }
translate = [10, 0, 0]
material = { albedo = [0.5, 0.5, 0.5], emission = [1, 1, 1] }
[[mesh]]
file = "/abs/n.ply"
scale = 2.0
[camera]
eye = [0, 0, 5]
look_at = [0, 0, 0]
fov_y = 45
[light]
position = [1, 2, 3]
intensity = [1, 2, 3]
[box]
min = [-1, -1, -1]
max = [1, 1, 1]
[workload]
ao_radius = 5.0
"#,
        )
        .unwrap();
        assert_eq!(d.paths, PathBase::SceneDir);
        assert_eq!(d.meshes.len(), 2);
        assert_eq!(d.triangles, Some(14));
        assert_eq!(d.workload.get("ao_radius").unwrap().as_float(), Some(5.0));
        // Scale (1,2,3), then 90° about z, then +10 x: (1,1,1) -> (1,2,3) -> (-2,1,3) -> (8,1,3).
        let p = d.transform(0).apply_point(Vec3::ONE);
        assert!((p - Vec3::new(8.0, 1.0, 3.0)).length() < 1e-5, "{p:?}");
        assert_eq!(d.transform(1).apply_point(Vec3::ONE), Vec3::splat(2.0));
        assert_eq!(
            d.mesh_path(0, Path::new("/s")),
            PathBuf::from("/s/a/m.obj.zst")
        );
        assert_eq!(d.mesh_path(1, Path::new("/s")), PathBuf::from("/abs/n.ply"));
    }

    #[test]
    fn viewpoints_parse_in_order_and_are_checked() {
        let d = parse(&format!(
            "{MIN}[[viewpoint]]\neye = [0, 0, 0]\ndirection = [1, 0, 0]\nfov_y = 60\n\
             [[viewpoint]]\neye = [1, 2, 3]\nlook_at = [1, 2, 4]\nfov_y = 45\n"
        ))
        .unwrap();
        assert_eq!(d.viewpoints.len(), 2);
        let c = d.viewpoints[1].camera().to_camera();
        assert_eq!(c.direction, Vec3::new(0.0, 0.0, 1.0));
        assert_eq!(c.fov_y_deg, 45.0);
        let e = err(&format!(
            "{MIN}[[viewpoint]]\neye = [0, 0, 0]\ndirection = [1, 0, 0]\nfov_y = 60\n\
             [[viewpoint]]\neye = [0, 0, 0]\ndirection = [1, 0, 0]\nfov_y = 200\n"
        ));
        assert!(e.contains("viewpoint[1].fov_y"), "{e}");
    }

    #[test]
    fn errors_name_file_line_and_key() {
        let e = err(&format!(
            "{MIN}[camera]\neye = [0, 0, 0]\ndirection = [1, 0, 0]\nfovy = 3\n"
        ));
        assert!(e.starts_with("d.toml:6:") && e.contains("fovy"), "{e}");
        let e = err(&format!(
            "{MIN}[camera]\neye = [0, 0]\ndirection = [1, 0, 0]\nfov_y = 3\n"
        ));
        assert!(
            e.starts_with("d.toml:4:") && e.contains("camera.eye"),
            "{e}"
        );
        let e = err("[[mesh]]\nfile = \"m.obj\"\nscale = \"big\"\n");
        assert!(
            e.starts_with("d.toml:3:") && e.contains("mesh[0].scale"),
            "{e}"
        );
        let e = err("colour = 1\n");
        assert!(e.starts_with("d.toml:1:") && e.contains("colour"), "{e}");
        let e = err("[[mesh]\nfile = 1\n");
        assert!(e.starts_with("d.toml:1:"), "{e}");
        let e = err("[[mesh]]\n");
        assert!(e.contains("file"), "{e}");
    }

    #[test]
    fn validation_errors_name_the_key() {
        let cam = |body: &str| err(&format!("{MIN}[camera]\neye = [0, 0, 0]\n{body}"));
        assert!(cam("fov_y = 45\n").contains("exactly one of"));
        assert!(
            cam("direction = [1,0,0]\nlook_at = [1,0,0]\nfov_y = 45\n").contains("exactly one of")
        );
        assert!(cam("look_at = [0,0,0]\nfov_y = 45\n").contains("zero"));
        assert!(cam("direction = [0,1,0]\nfov_y = 45\n").contains("camera.up"));
        assert!(cam("direction = [1,0,0]\nfov_y = 180\n").contains("camera.fov_y"));
        assert!(cam("direction = [1,0,0]\nfov_y = nan\n").contains("camera.fov_y"));
        let e = err(&format!("{MIN}[box]\nmin = [0, 0, 0]\nmax = [1, 0, 1]\n"));
        assert!(e.starts_with("d.toml:3: key `box`"), "{e}");
        let e = err(&format!("{MIN}[light]\nposition = [0, 3e38, 0]\n"));
        assert!(e.starts_with("d.toml:4: key `light.position`"), "{e}");
        let e = err("[[mesh]]\nfile = \"a.obj\"\n[[mesh]]\nfile = \"b.obj\"\nscale = 0\n");
        assert!(e.starts_with("d.toml:5: key `mesh[1].scale`"), "{e}");
        let e = err("[[mesh]]\nfile = \"m.obj\"\nscale = 0\n");
        assert!(e.contains("mesh[0].scale"), "{e}");
        let e = err("[[mesh]]\nfile = \"m.obj\"\nmaterial = { albedo = [2, 0, 0] }\n");
        assert!(e.contains("mesh[0].material.albedo"), "{e}");
        let e = err(&format!(
            "{MIN}[light]\nposition = [0, 0, 0]\nintensity = -1\n"
        ));
        assert!(e.contains("light.intensity"), "{e}");
        assert!(err("description = \"x\"\n").contains("at least one [[mesh]]"));
        assert!(
            err("paths = \"elsewhere\"\n[[mesh]]\nfile = \"a.obj\"\n").starts_with("d.toml:1:")
        );
    }

    #[test]
    fn box_is_closed_and_non_degenerate() {
        let b = Aabb::new(Vec3::new(-1.0, 0.0, 2.0), Vec3::new(1.0, 3.0, 4.0));
        let tris = box_triangles(&b);
        let mut area = 0.0;
        for t in &tris {
            assert!(crate::triangle_defect(t).is_none());
            for v in t {
                assert!(b.contains(*v));
            }
            area += 0.5 * (t[1] - t[0]).cross(t[2] - t[0]).length();
        }
        assert!((area - b.surface_area()).abs() < 1e-4);
        // Closed: every edge is shared by exactly two triangles.
        let mut edges = std::collections::BTreeMap::new();
        for t in &tris {
            for i in 0..3 {
                let (a, c) = (t[i].to_array(), t[(i + 1) % 3].to_array());
                let key = if a < c { (a, c) } else { (c, a) };
                let key = (key.0.map(f32::to_bits), key.1.map(f32::to_bits));
                *edges.entry(key).or_insert(0) += 1;
            }
        }
        assert!(edges.values().all(|&n| n == 2), "{edges:?}");
    }

    #[test]
    fn build_loads_meshes_in_order_with_box_last() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(
            dir.path().join("a.obj"),
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 1 2\n",
        )
        .unwrap();
        std::fs::write(
            dir.path().join("b.ply"),
            "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 1\n1 0 1\n0 1 1\n3 0 1 2\n",
        )
        .unwrap();
        let d = parse(
            "[[mesh]]\nfile = \"a.obj\"\ntranslate = [0, 0, 5]\n[[mesh]]\nfile = \"b.ply\"\nmaterial = { name = \"red\", albedo = [1, 0, 0] }\n[box]\nmin = [-1, -1, -1]\nmax = [2, 2, 7]\n[workload]\nao_radius = 0.5\n",
        )
        .unwrap();
        let s = d.build("t", dir.path()).unwrap();
        assert_eq!(s.triangles.len(), 1 + 1 + 12);
        assert_eq!(s.triangles[0][0], Vec3::new(0.0, 0.0, 5.0));
        assert_eq!(s.triangles[1][0], Vec3::new(0.0, 0.0, 1.0));
        assert_eq!(s.material_of(1).name, "red");
        assert_eq!(s.material_of(13).name, "box");
        assert_eq!(s.report.dropped_degenerate, 1);
        assert_eq!(s.files.len(), 2);
        assert!(s.workload_defaults.contains_key("ao_radius"));
        assert!(s.report.warnings.is_empty(), "{:?}", s.report.warnings);
        // No [camera] / [light]: automatic ones, and an intensity > 0.
        assert!(!s.bounds().contains(s.camera.eye));
        assert!(s.light.intensity.x > 0.0);
    }

    #[test]
    fn a_wrong_declared_count_is_a_warning() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(
            dir.path().join("a.obj"),
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
        )
        .unwrap();
        let d = parse("triangles = 2\n[[mesh]]\nfile = \"a.obj\"\n").unwrap();
        let s = d.build("t", dir.path()).unwrap();
        assert!(
            s.report.warnings[0].contains("declares 2 triangles but 1"),
            "{:?}",
            s.report
        );
    }

    #[test]
    fn missing_mesh_file_is_an_error_naming_it() {
        let dir = tempfile::tempdir().unwrap();
        let d = parse("[[mesh]]\nfile = \"nope.obj\"\n").unwrap();
        let e = d.build("t", dir.path()).unwrap_err().to_string();
        assert!(e.contains("nope.obj"), "{e}");
    }
}
