//! Mesh files: Wavefront OBJ (+MTL) and PLY, plain or compressed.
//!
//! [`load_mesh`] picks the parser from the file name: `.obj` or `.ply`, optionally followed by
//! `.zst` (zstd) or `.gz` (gzip), e.g. `sibenik.obj.zst`. Both parsers stream: they read the
//! (decompressed) bytes once through a buffered reader and keep only the vertex positions and
//! the triangle index triples, never the file text.
//!
//! A parser produces an [`IndexedMesh`] (positions, index triples, one material per triangle);
//! [`IndexedMesh::into_mesh`] applies a transform and turns it into a [`Mesh`] in file order,
//! dropping zero-area and non-finite triangles ([`crate::triangle_defect`]) and counting them in
//! the [`LoadReport`]. Dropping happens *after* the transform, so a scale that collapses a
//! triangle drops it too.
//!
//! Errors ([`SceneError`]) name the file and the line (text formats) or the byte offset and
//! element index (binary PLY).

pub mod mtl;
pub mod obj;
pub mod ply;

mod input;
mod num;

pub use input::{Compression, decompress, open_decompressed};

use crate::{LoadReport, Material, SceneError, Triangle, triangle_defect};
use rtsim_core::{Affine, Vec3};
use std::path::Path;

/// Triangles in file order with their materials: the contribution of one mesh to a scene.
#[derive(Clone, Debug, Default)]
pub struct Mesh {
    pub triangles: Vec<Triangle>,
    /// Index into `materials`, one per triangle.
    pub material_ids: Vec<u32>,
    pub materials: Vec<Material>,
    pub report: LoadReport,
}

impl Mesh {
    /// Append `t` with material `material` unless it is defective (then count it).
    #[inline]
    pub fn push(&mut self, t: Triangle, material: u32) {
        debug_assert!((material as usize) < self.materials.len());
        match triangle_defect(&t) {
            None => {
                self.triangles.push(t);
                self.material_ids.push(material);
            }
            Some(d) => self.report.count_defect(d),
        }
    }

    /// Add a material and return its id.
    pub fn add_material(&mut self, m: Material) -> u32 {
        self.materials.push(m);
        (self.materials.len() - 1) as u32
    }

    /// Append another mesh after this one (scene order: `self` first), renumbering its
    /// materials.
    pub fn append(&mut self, other: Mesh) {
        let offset = self.materials.len() as u32;
        self.materials.extend(other.materials);
        self.triangles.extend(other.triangles);
        self.material_ids
            .extend(other.material_ids.into_iter().map(|m| m + offset));
        self.report.merge(other.report);
    }

    /// Replace every material by `m` (a descriptor's per-mesh material override).
    pub fn override_material(&mut self, m: Material) {
        self.materials = vec![m];
        self.material_ids.iter_mut().for_each(|id| *id = 0);
    }
}

/// What a parser produces: positions, triangles as index triples (already fan-triangulated
/// and range-checked) and their materials.
#[derive(Clone, Debug, Default)]
pub struct IndexedMesh {
    pub positions: Vec<Vec3>,
    pub indices: Vec<[u32; 3]>,
    /// One per entry of `indices`.
    pub material_ids: Vec<u32>,
    pub materials: Vec<Material>,
    pub report: LoadReport,
}

impl IndexedMesh {
    /// Transform the positions and build the triangles, dropping defective ones.
    pub fn into_mesh(self, transform: &Affine) -> Mesh {
        let positions: Vec<Vec3> = if transform.is_identity() {
            self.positions
        } else {
            self.positions
                .iter()
                .map(|&p| transform.apply_point(p))
                .collect()
        };
        let mut mesh = Mesh {
            triangles: Vec::with_capacity(self.indices.len()),
            material_ids: Vec::with_capacity(self.indices.len()),
            materials: self.materials,
            report: self.report,
        };
        for (ix, &m) in self.indices.iter().zip(&self.material_ids) {
            let t = [
                positions[ix[0] as usize],
                positions[ix[1] as usize],
                positions[ix[2] as usize],
            ];
            mesh.push(t, m);
        }
        mesh
    }
}

/// Mesh file formats.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MeshFormat {
    Obj,
    Ply,
}

/// The format and compression of `path`, from its name (`x.obj`, `x.ply.zst`, `x.obj.gz`, any
/// case).
pub fn mesh_format(path: &Path) -> Option<(MeshFormat, Compression)> {
    let (stem, compression) = input::split_compression(path);
    let ext = Path::new(&stem)
        .extension()?
        .to_string_lossy()
        .to_ascii_lowercase();
    match ext.as_str() {
        "obj" => Some((MeshFormat::Obj, compression)),
        "ply" => Some((MeshFormat::Ply, compression)),
        _ => None,
    }
}

/// Load a mesh file (format from the name, see [`mesh_format`]) and apply `transform`.
pub fn load_mesh(path: &Path, transform: &Affine) -> Result<Mesh, SceneError> {
    let mesh = load_indexed(path)?.into_mesh(transform);
    check_extent(&mesh, path)?;
    Ok(mesh)
}

/// Load a mesh file without building triangles.
pub fn load_indexed(path: &Path) -> Result<IndexedMesh, SceneError> {
    let Some((format, compression)) = mesh_format(path) else {
        return Err(SceneError::Format {
            path: path.to_path_buf(),
            message: "unsupported mesh format: expected .obj or .ply, optionally followed by \
                      .zst or .gz"
                .into(),
        });
    };
    let reader = open_decompressed(path)?;
    match format {
        MeshFormat::Obj => obj::parse_obj(reader, path),
        MeshFormat::Ply => {
            // A plain file's length bounds every element count before anything is read.
            let len = match compression {
                Compression::None => std::fs::metadata(path).ok().map(|m| m.len()),
                _ => None,
            };
            ply::parse_ply_sized(reader, path, len)
        }
    }
}

/// Largest coordinate magnitude a scene may have (assumed: 10^18; a BVH node's surface area,
/// a product of two extents of up to 2·10^18, then stays far below `f32::MAX` ≈ 3.4·10^38, and
/// so do the SAH cost, the automatic camera distance and the AO radius).
pub const MAX_COORDINATE: f32 = 1e18;

/// The first triangle of `mesh` with a coordinate beyond [`MAX_COORDINATE`], as an error
/// naming `path` (coordinates are checked after the transform).
pub fn check_extent(mesh: &Mesh, path: &Path) -> Result<(), SceneError> {
    for (i, t) in mesh.triangles.iter().enumerate() {
        if t.iter().any(|v| v.abs().max_component() > MAX_COORDINATE) {
            return Err(SceneError::Format {
                path: path.to_path_buf(),
                message: format!(
                    "triangle {i} has a vertex at {:?}, beyond the ±{MAX_COORDINATE:e} rtsim \
                     supports (BVH surface areas would overflow f32): rescale the mesh",
                    t.map(|v| v.to_array())
                ),
            });
        }
    }
    Ok(())
}

/// An I/O error while reading `path` (decompression errors, truncated compressed streams).
pub(crate) fn io_error(path: &Path, source: std::io::Error) -> SceneError {
    rtsim_core::FileError::io(path, source).into()
}

/// A parse error at a line of `path`.
pub(crate) fn parse_error(path: &Path, line: u64, message: impl Into<String>) -> SceneError {
    rtsim_core::FileError::at(path, line, message.into()).into()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn formats_from_names() {
        let f = |s: &str| mesh_format(Path::new(s));
        assert_eq!(f("a.obj"), Some((MeshFormat::Obj, Compression::None)));
        assert_eq!(f("dir/a.OBJ"), Some((MeshFormat::Obj, Compression::None)));
        assert_eq!(f("a.ply.zst"), Some((MeshFormat::Ply, Compression::Zstd)));
        assert_eq!(f("a.obj.gz"), Some((MeshFormat::Obj, Compression::Gzip)));
        assert_eq!(f("a.stl"), None);
        assert_eq!(f("a.zst"), None);
        assert_eq!(f("obj"), None);
    }

    #[test]
    fn unsupported_extension_is_an_error() {
        let e = load_indexed(Path::new("x/scene.stl"))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("x/scene.stl") && e.contains("unsupported"),
            "{e}"
        );
    }

    const PLY: &[u8] = b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n2 0 0\n0 2 0\n3 0 1 2\n";

    fn gzip(bytes: &[u8]) -> Vec<u8> {
        let mut e = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
        std::io::Write::write_all(&mut e, bytes).unwrap();
        e.finish().unwrap()
    }

    #[test]
    fn compressed_meshes_load_by_extension() {
        let dir = tempfile::tempdir().unwrap();
        let obj = b"v 0 0 0\nv 2 0 0\nv 0 2 0\nf 1 2 3\n";
        let files: [(&str, Vec<u8>); 5] = [
            ("a.ply", PLY.to_vec()),
            ("a.ply.zst", zstd::encode_all(PLY, 3).unwrap()),
            ("a.ply.gz", gzip(PLY)),
            ("a.obj.zst", zstd::encode_all(&obj[..], 3).unwrap()),
            ("a.obj.gz", gzip(obj)),
        ];
        for (name, bytes) in files {
            let p = dir.path().join(name);
            std::fs::write(&p, bytes).unwrap();
            let m = load_mesh(&p, &Affine::IDENTITY).unwrap();
            assert_eq!(m.triangles.len(), 1, "{name}");
            assert_eq!(m.triangles[0][1], Vec3::new(2.0, 0.0, 0.0), "{name}");
        }
    }

    #[test]
    fn truncated_compressed_files_are_errors() {
        let dir = tempfile::tempdir().unwrap();
        let big: String = (0..5000).map(|i| format!("v {i} 0 0\n")).collect();
        for (name, bytes) in [
            ("t.obj.zst", zstd::encode_all(big.as_bytes(), 3).unwrap()),
            ("t.obj.gz", gzip(big.as_bytes())),
            ("t.ply.gz", gzip(PLY)),
        ] {
            let p = dir.path().join(name);
            std::fs::write(&p, &bytes[..bytes.len() * 2 / 3]).unwrap();
            let e = load_mesh(&p, &Affine::IDENTITY).unwrap_err().to_string();
            assert!(
                e.contains(&p.display().to_string()) && e.contains("corrupt"),
                "{name}: {e}"
            );
        }
    }

    #[test]
    fn append_renumbers_materials() {
        let tri = [
            Vec3::ZERO,
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
        ];
        let mut a = Mesh::default();
        let ma = a.add_material(Material::default_grey());
        a.push(tri, ma);
        let mut b = Mesh::default();
        let mb0 = b.add_material(Material::default_grey());
        let mb1 = b.add_material(Material::default_grey());
        b.push(tri, mb1);
        b.push([Vec3::ZERO; 3], mb0); // dropped
        a.append(b);
        assert_eq!(a.material_ids, vec![0, 2]);
        assert_eq!(a.materials.len(), 3);
        assert_eq!(a.report.dropped_degenerate, 1);
    }

    #[test]
    fn transform_is_applied_before_the_defect_check() {
        let m = IndexedMesh {
            positions: vec![
                Vec3::ZERO,
                Vec3::new(1.0, 0.0, 0.0),
                Vec3::new(0.0, 1.0, 0.0),
            ],
            indices: vec![[0, 1, 2]],
            material_ids: vec![0],
            materials: vec![Material::default_grey()],
            report: LoadReport::default(),
        };
        let moved = m
            .clone()
            .into_mesh(&Affine::translate(Vec3::new(0.0, 0.0, 5.0)));
        assert_eq!(moved.triangles[0][2], Vec3::new(0.0, 1.0, 5.0));
        let flat = m.into_mesh(&Affine::scale(Vec3::new(1.0, 0.0, 1.0)));
        assert!(flat.triangles.is_empty());
        assert_eq!(flat.report.dropped_degenerate, 1);
    }

    mod no_panics {
        //! Corrupt input must give an error or a mesh, never a panic.
        use super::super::{obj, ply};
        use proptest::prelude::*;
        use std::io::Cursor;
        use std::path::Path;

        const OBJ: &str = "mtllib none.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvn 0 0 1\n\
                           usemtl a\nf 1/1/1 2/1/1 3/1/1 4/1/1\nf -1 -2 -3\ng x\ns off\n";
        const PLY_HEAD: &str = "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 2\nproperty list uchar int vertex_indices\nend_header\n";

        fn parse_obj(bytes: Vec<u8>) {
            let _ = obj::parse_obj(Cursor::new(bytes), Path::new("/nonexistent/f.obj"));
        }
        fn parse_ply(bytes: Vec<u8>) {
            let _ = ply::parse_ply(Cursor::new(bytes), Path::new("f.ply"));
        }

        proptest! {
            #[test]
            fn mutated_obj(edits in prop::collection::vec((any::<usize>(), any::<u8>(), 0u8..3), 1..8)) {
                let mut b = OBJ.as_bytes().to_vec();
                for (at, byte, op) in edits {
                    let i = at % (b.len() + 1);
                    match op {
                        0 => b.insert(i, byte),
                        1 if i < b.len() => { b.remove(i); }
                        _ if i < b.len() => b[i] = byte,
                        _ => {}
                    }
                }
                parse_obj(b);
            }

            #[test]
            fn random_binary_ply_body(body in prop::collection::vec(any::<u8>(), 0..80)) {
                let mut b = PLY_HEAD.as_bytes().to_vec();
                b.extend(body);
                parse_ply(b);
            }

            #[test]
            fn mutated_ascii_ply(edits in prop::collection::vec((any::<usize>(), any::<u8>()), 1..6)) {
                let mut b = b"ply\nformat ascii 1.0\nelement vertex 3\nproperty double x\nproperty double y\nproperty double z\nelement face 1\nproperty list uchar uint vertex_index\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n".to_vec();
                for (at, byte) in edits {
                    let i = at % b.len();
                    b[i] = byte;
                }
                parse_ply(b);
            }
        }

        #[test]
        fn every_truncation_of_a_binary_ply_is_an_error() {
            let mut b = PLY_HEAD.as_bytes().to_vec();
            for v in [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0] {
                b.extend_from_slice(&v.to_le_bytes());
            }
            for face in [[0i32, 1, 2], [2, 1, 0]] {
                b.push(3);
                for i in face {
                    b.extend_from_slice(&i.to_le_bytes());
                }
            }
            assert!(ply::parse_ply(Cursor::new(b.clone()), Path::new("f.ply")).is_ok());
            for cut in 0..b.len() {
                let r = ply::parse_ply(Cursor::new(b[..cut].to_vec()), Path::new("f.ply"));
                assert!(r.is_err(), "cut at {cut} parsed");
            }
        }
    }
}
