//! Scenes: triangles, materials, a camera and a point light.
//!
//! A [`Scene`] is what every tracer consumes: a flat list of triangles in *scene order* (the
//! order that triangle ids in `hits.bin` and `export-triangles` refer to), one material per
//! triangle, a [`Camera`] and a [`PointLight`]. This crate never builds a BVH (pbrt's rule: the
//! parser knows nothing of acceleration structures).
//!
//! Sources:
//! - mesh files: Wavefront OBJ (+MTL `Kd`) and PLY (ascii, binary LE/BE), plain or compressed
//!   (`.zst`, `.gz`): [`mesh`];
//! - scene descriptors in TOML (meshes with transforms, camera, light, optional closed box,
//!   workload defaults), shipped for every scene in `shared/scenes`: [`descriptor`];
//! - built-in procedural scenes needing no files (`cornell`, `hairball`, `vegetation`),
//!   deterministic from a seed and scalable by a size factor: [`procedural`];
//! - [`registry`] resolves a `--scene` argument (built-in name, descriptor name, or path) and
//!   the scene directory (`--scene-dir`, `RTSIM_SCENE_DIR`, `../shared/scenes`).
//!
//! - [`export`] writes and reads `tris.bin`, the triangle file of `rtsim export-triangles`;
//! - [`auto`] frames a camera and places a light for meshes loaded without a descriptor, and
//!   computes the default light intensity.
//!
//! Degenerate input: zero-area or non-finite triangles are dropped and counted
//! ([`LoadReport`], see [`triangle_defect`]); out-of-range indices, truncated files and
//! malformed numbers are [`SceneError`]s naming the file and line (or byte offset and element
//! index for binary PLY). The descriptor format is documented in `docs/SCENES.md`.

pub mod auto;
pub mod descriptor;
pub mod export;
pub mod mesh;
pub mod procedural;
pub mod registry;

use rtsim_core::{Aabb, Real, Vec3};
use serde::{Deserialize, Serialize};
use std::path::PathBuf;

pub use registry::{
    SceneInfo, SceneRequest, SceneSource, list_scenes, load_scene, resolve_scene_dir,
};

/// A triangle given by its three vertices.
pub type Triangle = [Vec3; 3];

/// A Lambertian material (the only kind the papers' workloads use).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Material {
    pub name: String,
    /// Diffuse albedo (MTL `Kd`), each component in [0, 1].
    pub albedo: Vec3,
    /// Emitted radiance (MTL `Ke`); only seen by camera/bounce rays hitting the surface.
    pub emission: Vec3,
}

impl Material {
    /// The grey used when a mesh has no material or its MTL file is missing.
    pub fn default_grey() -> Material {
        Material {
            name: "default".into(),
            albedo: Vec3::splat(0.7),
            emission: Vec3::ZERO,
        }
    }
}

/// A pinhole camera.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Camera {
    pub eye: Vec3,
    /// Viewing direction (need not be normalised).
    pub direction: Vec3,
    pub up: Vec3,
    /// Vertical field of view in degrees, in (0, 180).
    pub fov_y_deg: f32,
}

impl Camera {
    /// The camera basis: (right, up, forward), orthonormal.
    pub fn basis(&self) -> (Vec3, Vec3, Vec3) {
        let f = self.direction.normalized();
        let mut r = f.cross(self.up).normalized();
        if r.length_squared() == 0.0 {
            // `up` parallel to the view direction: pick any perpendicular.
            r = f.orthonormal_basis().0;
        }
        let u = r.cross(f);
        (r, u, f)
    }

    /// Direction (not normalised) through image position (`x`, `y`) in pixels, measured from
    /// the top-left corner of a `width` × `height` image; pixel (i, j) has its centre at
    /// (i + 0.5, j + 0.5). Square pixels; the vertical field of view spans the image height.
    #[inline]
    pub fn direction_through(
        &self,
        basis: &(Vec3, Vec3, Vec3),
        x: f32,
        y: f32,
        width: u32,
        height: u32,
    ) -> Vec3 {
        let (tan_half, aspect) = self.frame_constants(width, height);
        camera_direction(basis, tan_half, aspect, x, y, width as f32, height as f32)
    }

    /// The per-frame constants of [`Camera::direction_through`]: tan(fov/2) and the aspect
    /// ratio.
    #[inline]
    pub fn frame_constants(&self, width: u32, height: u32) -> (f32, f32) {
        (
            (self.fov_y_deg.to_radians() * 0.5).tan(),
            width as f32 / height as f32,
        )
    }
}

/// [`Camera::direction_through`]'s per-ray arithmetic, generic over the scalar so its
/// operation count can be taken (`rtsim_trace::ops`).
#[inline(always)]
pub fn camera_direction<R: Real>(
    basis: &(Vec3<R>, Vec3<R>, Vec3<R>),
    tan_half: R,
    aspect: R,
    x: R,
    y: R,
    width: R,
    height: R,
) -> Vec3<R> {
    let (r, u, f) = *basis;
    let (one, two) = (R::from_f32(1.0), R::from_f32(2.0));
    let sx = (two * x / width - one) * tan_half * aspect;
    let sy = (one - two * y / height) * tan_half;
    f + r * sx + u * sy
}

/// An isotropic point light.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct PointLight {
    pub position: Vec3,
    /// Radiant intensity per colour channel (W/sr, in scene units): irradiance at distance d
    /// is intensity / d².
    pub intensity: Vec3,
}

/// What loading dropped or noticed (logged, and written to stats.json).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct LoadReport {
    /// Triangles dropped for zero area.
    pub dropped_degenerate: u64,
    /// Triangles dropped for non-finite coordinates.
    pub dropped_non_finite: u64,
    /// Polygons with more than three vertices, fan-triangulated.
    pub polygons_triangulated: u64,
    /// Warnings (missing MTL, unknown material, unused elements), one line each.
    pub warnings: Vec<String>,
}

impl LoadReport {
    pub fn merge(&mut self, o: LoadReport) {
        self.dropped_degenerate += o.dropped_degenerate;
        self.dropped_non_finite += o.dropped_non_finite;
        self.polygons_triangulated += o.polygons_triangulated;
        self.warnings.extend(o.warnings);
    }

    /// Count one dropped triangle.
    pub fn count_defect(&mut self, defect: TriangleDefect) {
        match defect {
            TriangleDefect::NonFinite => self.dropped_non_finite += 1,
            TriangleDefect::ZeroArea => self.dropped_degenerate += 1,
        }
    }

    /// Why a load gave no triangles (for [`SceneError::Empty`]).
    pub fn why_empty(&self) -> String {
        let dropped = self.dropped_degenerate + self.dropped_non_finite;
        if dropped == 0 {
            "the input has no faces (OBJ `f` lines, a PLY `face` element, a [box])".into()
        } else {
            format!(
                "all {dropped} of its triangles were dropped ({} zero-area, {} with non-finite \
                 coordinates)",
                self.dropped_degenerate, self.dropped_non_finite
            )
        }
    }

    /// One human-readable line per noteworthy item, for the caller's log (empty when loading
    /// was clean). Fan-triangulated polygons are normal input and not listed.
    pub fn log_lines(&self) -> Vec<String> {
        let mut out = Vec::new();
        if self.dropped_degenerate > 0 {
            out.push(format!(
                "dropped {} zero-area triangle(s)",
                self.dropped_degenerate
            ));
        }
        if self.dropped_non_finite > 0 {
            out.push(format!(
                "dropped {} triangle(s) with non-finite coordinates",
                self.dropped_non_finite
            ));
        }
        out.extend(self.warnings.iter().cloned());
        out
    }
}

/// Why a triangle is dropped on load.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TriangleDefect {
    /// A coordinate is NaN or infinite.
    NonFinite,
    /// The edge cross product is exactly zero in `f32` (repeated or collinear vertices): no
    /// ray can hit it (the determinant of every triangle test is zero), and it would only
    /// inflate BVH leaves.
    ZeroArea,
}

/// The defect that makes `t` unusable, if any. Non-finite takes precedence.
#[inline]
pub fn triangle_defect(t: &Triangle) -> Option<TriangleDefect> {
    if !(t[0].is_finite() && t[1].is_finite() && t[2].is_finite()) {
        return Some(TriangleDefect::NonFinite);
    }
    let n = (t[1] - t[0]).cross(t[2] - t[0]);
    // Exact comparison on purpose: any non-zero component means a hittable plane.
    if n.x == 0.0 && n.y == 0.0 && n.z == 0.0 {
        return Some(TriangleDefect::ZeroArea);
    }
    None
}

/// A scene ready for BVH construction.
#[derive(Clone, Debug)]
pub struct Scene {
    pub name: String,
    /// Triangles in scene order.
    pub triangles: Vec<Triangle>,
    /// Material index per triangle (parallel to `triangles`).
    pub material_ids: Vec<u32>,
    pub materials: Vec<Material>,
    pub camera: Camera,
    /// Further named viewpoints (a descriptor's `[[viewpoint]]` list, in order): the five per
    /// scene that the SGRT paper's tables average over. `scene.viewpoint = N` (1-based)
    /// replaces `camera` with the N-th.
    pub viewpoints: Vec<Camera>,
    pub light: PointLight,
    /// Workload defaults from the descriptor (`[workload]` table), merged under user settings.
    pub workload_defaults: toml::Table,
    /// Files the scene was read from (for reports).
    pub files: Vec<PathBuf>,
    pub report: LoadReport,
}

impl Scene {
    pub fn bounds(&self) -> Aabb {
        let mut b = Aabb::EMPTY;
        for t in &self.triangles {
            for &v in t {
                b.grow(v);
            }
        }
        b
    }

    pub fn material_of(&self, triangle: u32) -> &Material {
        &self.materials[self.material_ids[triangle as usize] as usize]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn v(x: f32, y: f32, z: f32) -> Vec3 {
        Vec3::new(x, y, z)
    }

    #[test]
    fn defects_are_classified() {
        let ok = [v(0.0, 0.0, 0.0), v(1.0, 0.0, 0.0), v(0.0, 1.0, 0.0)];
        assert_eq!(triangle_defect(&ok), None);
        let repeated = [v(0.0, 0.0, 0.0), v(0.0, 0.0, 0.0), v(0.0, 1.0, 0.0)];
        assert_eq!(triangle_defect(&repeated), Some(TriangleDefect::ZeroArea));
        let collinear = [v(0.0, 0.0, 0.0), v(1.0, 1.0, 1.0), v(2.0, 2.0, 2.0)];
        assert_eq!(triangle_defect(&collinear), Some(TriangleDefect::ZeroArea));
        let nan = [v(f32::NAN, 0.0, 0.0), v(1.0, 0.0, 0.0), v(0.0, 1.0, 0.0)];
        assert_eq!(triangle_defect(&nan), Some(TriangleDefect::NonFinite));
        let inf = [
            v(0.0, 0.0, 0.0),
            v(1.0, 0.0, f32::INFINITY),
            v(0.0, 1.0, 0.0),
        ];
        assert_eq!(triangle_defect(&inf), Some(TriangleDefect::NonFinite));
        // Tiny but non-zero area stays: a ray can still hit it.
        let tiny = [v(0.0, 0.0, 0.0), v(1e-20, 0.0, 0.0), v(0.0, 1e-20, 0.0)];
        assert_eq!(triangle_defect(&tiny), None);
    }

    #[test]
    fn report_lines_and_merge() {
        let mut a = LoadReport::default();
        assert!(a.log_lines().is_empty());
        a.count_defect(TriangleDefect::ZeroArea);
        let mut b = LoadReport::default();
        b.count_defect(TriangleDefect::NonFinite);
        b.warnings.push("w".into());
        a.merge(b);
        assert_eq!(a.dropped_degenerate, 1);
        assert_eq!(a.dropped_non_finite, 1);
        assert_eq!(a.log_lines().len(), 3);
    }
}

/// Errors name the file and, where there is one, the line.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// A file that cannot be read, or a line of it that is wrong.
    #[error(transparent)]
    File(#[from] rtsim_core::FileError),
    #[error("{path}: {message}")]
    Format { path: PathBuf, message: String },
    #[error("unknown scene `{name}`; known scenes: {known}")]
    UnknownScene { name: String, known: String },
    #[error(
        "scene `{name}` needs {file}, which is not in the scene directory {dir} (set --scene-dir or RTSIM_SCENE_DIR)"
    )]
    MissingSceneFile {
        name: String,
        file: String,
        dir: String,
    },
    #[error("{0}")]
    Config(#[from] rtsim_config::ConfigError),
    #[error("scene `{name}` has no triangles to trace: {why}")]
    Empty { name: String, why: String },
}
