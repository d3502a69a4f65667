//! Wavefront OBJ: `v`, `f` (all four vertex-reference forms, negative indices, polygons),
//! `mtllib` / `usemtl`.
//!
//! - `f` takes `v`, `v/vt`, `v//vn` or `v/vt/vn` references; only the position index is used,
//!   the others are checked for being integers. Negative indices count back from the last
//!   vertex defined so far (`-1` is the latest). Polygons with more than three vertices are
//!   fan-triangulated around their first vertex (exact for the convex polygons OBJ exporters
//!   write) and counted in [`LoadReport::polygons_triangulated`].
//! - A positive index may refer to a vertex defined later in the file (rare, but legal for
//!   loaders that resolve at the end); it is an error only if it is still out of range at the
//!   end of the file, reported at the line that used it.
//! - `mtllib` files are looked up beside the OBJ, also as `NAME.zst` and `NAME.gz`; a missing
//!   library is a warning and its materials become grey. `usemtl` names no library defines are
//!   grey too (one warning lists them). Faces before any `usemtl` get the grey `default`.
//! - `vt`, `vn`, `vp`, `o`, `g`, `s`, `mg` and the other OBJ statements are accepted and
//!   ignored; `l`, `p`, curves and surfaces are counted in one warning (only polygons are
//!   loaded); an unknown statement is a warning naming its first line.
//! - A `#` starts a comment anywhere on a line; a line ending in `\` continues on the next.

use super::input::{LineReader, open_decompressed};
use super::mtl::{parse_mtl, rest_after_keyword, strip_comment};
use super::num::{parse_f32, parse_i64, tokens};
use super::{IndexedMesh, parse_error};
use crate::{LoadReport, Material, SceneError};
use rtsim_core::Vec3;
use rtsim_core::text::echo;
use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::io::BufRead;
use std::path::{Path, PathBuf};

/// OBJ statements that carry nothing a triangle tracer uses (statement names from the OBJ
/// specification, Appendix B1 of Wavefront's Advanced Visualizer manual).
const IGNORED: &[&[u8]] = &[
    b"vt",
    b"vn",
    b"vp",
    b"o",
    b"g",
    b"s",
    b"mg",
    b"maplib",
    b"usemap",
    b"lod",
    b"shadow_obj",
    b"trace_obj",
    b"ctech",
    b"stech",
    b"bevel",
    b"c_interp",
    b"d_interp",
    b"call",
    b"csh",
];

/// Statements describing non-polygonal geometry, skipped with a warning.
const NOT_POLYGONS: &[&[u8]] = &[
    b"l", b"p", b"curv", b"curv2", b"surf", b"cstype", b"deg", b"bmat", b"step", b"parm", b"trim",
    b"hole", b"scrv", b"sp", b"end", b"con",
];

/// Parse an OBJ stream. `path` names the file in errors and locates `mtllib` files.
pub fn parse_obj<R: BufRead>(reader: R, path: &Path) -> Result<IndexedMesh, SceneError> {
    let mut p = ObjParser::new(path);
    let mut lines = LineReader::new(reader, path, true);
    while let Some((line_no, raw)) = lines.next_line()? {
        p.statement(line_no, raw)?;
    }
    p.finish()
}

struct ObjParser<'p> {
    path: &'p Path,
    positions: Vec<Vec3>,
    indices: Vec<[u32; 3]>,
    material_ids: Vec<u32>,
    /// Materials used so far, in order of first use.
    materials: Vec<Material>,
    used: HashMap<String, u32>,
    /// Materials defined by the `mtllib` files read so far.
    library: HashMap<String, Material>,
    libraries_loaded: usize,
    /// `usemtl` name in effect (`None`: the grey default), and its id once a face used it.
    current_name: Option<String>,
    current_id: Option<u32>,
    undefined: BTreeSet<String>,
    /// The largest positive index beyond the vertices defined at the time, and its line.
    forward: Option<(u64, u64)>,
    face: Vec<u32>,
    not_polygons: u64,
    unknown: BTreeMap<String, u64>,
    report: LoadReport,
}

impl<'p> ObjParser<'p> {
    fn new(path: &'p Path) -> Self {
        ObjParser {
            path,
            positions: Vec::new(),
            indices: Vec::new(),
            material_ids: Vec::new(),
            materials: Vec::new(),
            used: HashMap::new(),
            library: HashMap::new(),
            libraries_loaded: 0,
            current_name: None,
            current_id: None,
            undefined: BTreeSet::new(),
            forward: None,
            face: Vec::with_capacity(8),
            not_polygons: 0,
            unknown: BTreeMap::new(),
            report: LoadReport::default(),
        }
    }

    fn err(&self, line: u64, message: impl Into<String>) -> SceneError {
        parse_error(self.path, line, message)
    }

    fn statement(&mut self, line_no: u64, raw: &[u8]) -> Result<(), SceneError> {
        let line = strip_comment(raw);
        let mut toks = tokens(line);
        let Some(key) = toks.next() else {
            return Ok(());
        };
        match key {
            // A PLY file named `.obj` would otherwise load as an OBJ with no faces.
            b"ply" if line_no == 1 && toks.next().is_none() => {
                return Err(self.err(
                    line_no,
                    "this is a PLY file (its first line is `ply`), not OBJ: name it .ply",
                ));
            }
            b"v" => {
                let mut xyz = [0.0f32; 3];
                for (i, c) in xyz.iter_mut().enumerate() {
                    let tok = toks.next().ok_or_else(|| {
                        self.err(
                            line_no,
                            format!("vertex has {i} coordinate(s), needs x y z"),
                        )
                    })?;
                    *c = parse_f32(tok).ok_or_else(|| {
                        self.err(line_no, format!("malformed number `{}`", echo(tok)))
                    })?;
                }
                self.positions.push(Vec3::from_array(xyz));
            }
            b"f" | b"fo" => self.face_statement(line_no, toks)?,
            b"usemtl" => {
                let name = rest_after_keyword(line, key);
                if name.is_empty() {
                    return Err(self.err(line_no, "`usemtl` without a material name"));
                }
                if self.current_name.as_deref() != Some(name.as_str()) {
                    self.current_name = Some(name);
                    self.current_id = None;
                }
            }
            b"mtllib" => {
                let names: Vec<String> = toks
                    .map(|t| String::from_utf8_lossy(t).into_owned())
                    .collect();
                if names.is_empty() {
                    return Err(self.err(line_no, "`mtllib` without a file name"));
                }
                for name in names {
                    self.load_library(line_no, &name)?;
                }
            }
            k if IGNORED.contains(&k) => {}
            k if NOT_POLYGONS.contains(&k) => self.not_polygons += 1,
            k => {
                self.unknown.entry(echo(k)).or_insert(line_no);
            }
        }
        Ok(())
    }

    fn face_statement<'a>(
        &mut self,
        line_no: u64,
        refs: impl Iterator<Item = &'a [u8]>,
    ) -> Result<(), SceneError> {
        let n = self.positions.len() as u64;
        self.face.clear();
        for r in refs {
            let mut parts = r.split(|&b| b == b'/');
            let first = parts.next().unwrap_or_default();
            let malformed = || {
                self.err(
                    line_no,
                    format!(
                        "malformed vertex reference `{}` (expected v, v/vt, v//vn or v/vt/vn)",
                        echo(r)
                    ),
                )
            };
            let idx = parse_i64(first).ok_or_else(malformed)?;
            // Texture and normal indices are unused but must still be numbers (or empty).
            let mut extra = 0;
            for p in parts {
                extra += 1;
                if extra > 2 || !(p.is_empty() || parse_i64(p).is_some()) {
                    return Err(malformed());
                }
            }
            let resolved: u64 = match idx {
                0 => {
                    return Err(self.err(line_no, "vertex index 0 (OBJ indices start at 1)"));
                }
                i if i > 0 => {
                    let i = (i - 1) as u64;
                    if i >= n && self.forward.is_none_or(|(m, _)| i > m) {
                        self.forward = Some((i, line_no));
                    }
                    i
                }
                i => {
                    let back = i.unsigned_abs();
                    if back > n {
                        return Err(self.err(
                            line_no,
                            format!(
                                "relative vertex index {i} out of range: only {n} vertices defined before this line"
                            ),
                        ));
                    }
                    n - back
                }
            };
            let resolved = u32::try_from(resolved).map_err(|_| {
                self.err(
                    line_no,
                    format!("vertex index {idx} exceeds the supported 2^32 vertices"),
                )
            })?;
            self.face.push(resolved);
        }
        if self.face.len() < 3 {
            return Err(self.err(
                line_no,
                format!(
                    "face has {} vertex reference(s), needs at least 3",
                    self.face.len()
                ),
            ));
        }
        if self.face.len() > 3 {
            self.report.polygons_triangulated += 1;
        }
        let m = self.current_material();
        let f0 = self.face[0];
        for w in self.face[1..].windows(2) {
            self.indices.push([f0, w[0], w[1]]);
            self.material_ids.push(m);
        }
        Ok(())
    }

    /// The id of the material in effect, registering it on first use.
    fn current_material(&mut self) -> u32 {
        if let Some(id) = self.current_id {
            return id;
        }
        let name = self
            .current_name
            .clone()
            .unwrap_or_else(|| "default".into());
        let id = match self.used.get(&name) {
            Some(&id) => id,
            None => {
                let m = match (&self.current_name, self.library.get(&name)) {
                    (Some(_), Some(m)) => m.clone(),
                    (Some(_), None) => {
                        self.undefined.insert(name.clone());
                        Material {
                            name: name.clone(),
                            ..Material::default_grey()
                        }
                    }
                    (None, _) => Material::default_grey(),
                };
                self.materials.push(m);
                let id = (self.materials.len() - 1) as u32;
                self.used.insert(name, id);
                id
            }
        };
        self.current_id = Some(id);
        id
    }

    fn load_library(&mut self, line_no: u64, name: &str) -> Result<(), SceneError> {
        let dir = self.path.parent().unwrap_or(Path::new(""));
        // `mtllib ./x.mtl` is common; drop the `.` so messages show `dir/x.mtl`.
        let base: PathBuf = std::iter::once(dir.as_os_str())
            .chain(
                Path::new(name)
                    .components()
                    .filter(|c| *c != std::path::Component::CurDir)
                    .map(|c| c.as_os_str()),
            )
            .collect();
        let candidates = [
            base.clone(),
            with_suffix(&base, ".zst"),
            with_suffix(&base, ".gz"),
        ];
        let Some(found) = candidates.iter().find(|c| c.is_file()) else {
            self.report.warnings.push(format!(
                "{}:{line_no}: material library {} not found (also tried .zst and .gz); its materials are grey",
                self.path.display(),
                echo(base.display().to_string())
            ));
            return Ok(());
        };
        let reader = open_decompressed(found)?;
        for m in parse_mtl(reader, found, &mut self.report)? {
            self.library.insert(m.name.clone(), m);
        }
        self.libraries_loaded += 1;
        Ok(())
    }

    fn finish(mut self) -> Result<IndexedMesh, SceneError> {
        let n = self.positions.len() as u64;
        if let Some((i, line)) = self.forward
            && i >= n
        {
            return Err(self.err(
                line,
                format!(
                    "vertex index {} out of range: the file defines {n} vertices",
                    i + 1
                ),
            ));
        }
        let path = self.path.display();
        if !self.undefined.is_empty() {
            const SHOWN: usize = 8;
            let mut names: Vec<String> = self.undefined.iter().take(SHOWN).map(echo).collect();
            if self.undefined.len() > SHOWN {
                names.push("…".into());
            }
            let why = if self.libraries_loaded == 0 {
                "no material library was loaded"
            } else {
                "not defined in its material libraries"
            };
            self.report.warnings.push(format!(
                "{path}: {} material(s) used but {why}; they are grey: {}",
                self.undefined.len(),
                names.join(", ")
            ));
        }
        if self.not_polygons > 0 {
            self.report.warnings.push(format!(
                "{path}: ignored {} line/point/curve/surface statement(s); only polygons are loaded",
                self.not_polygons
            ));
        }
        for (k, line) in &self.unknown {
            self.report.warnings.push(format!(
                "{path}:{line}: unknown OBJ statement `{k}` ignored (and any later ones)"
            ));
        }
        Ok(IndexedMesh {
            positions: self.positions,
            indices: self.indices,
            material_ids: self.material_ids,
            materials: self.materials,
            report: self.report,
        })
    }
}

/// `base` with `suffix` appended to its file name (`a.mtl` → `a.mtl.zst`).
fn with_suffix(base: &Path, suffix: &str) -> PathBuf {
    let mut s = base.as_os_str().to_os_string();
    s.push(suffix);
    PathBuf::from(s)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::{Cursor, Write};

    fn parse_at(text: &str, path: &Path) -> Result<IndexedMesh, SceneError> {
        parse_obj(Cursor::new(text.as_bytes().to_vec()), path)
    }
    fn parse(text: &str) -> Result<IndexedMesh, SceneError> {
        parse_at(text, Path::new("/nonexistent-dir/t.obj"))
    }
    fn err(text: &str) -> String {
        parse(text).unwrap_err().to_string()
    }

    const QUAD: &str = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n";

    #[test]
    fn all_vertex_reference_forms() {
        let text = format!(
            "{QUAD}vt 0 0\nvt 1 0\nvt 1 1\nvn 0 0 1\nf 1 2 3\nf 1/1 2/2 3/3\nf 1//1 2//1 3//1\nf 1/1/1 2/2/1 3/3/1\n"
        );
        let m = parse(&text).unwrap();
        assert_eq!(m.indices, vec![[0, 1, 2]; 4]);
        assert_eq!(m.positions.len(), 4);
        assert_eq!(m.positions[2], Vec3::new(1.0, 1.0, 0.0));
    }

    #[test]
    fn polygons_are_fan_triangulated() {
        let text = "v 0 0 0\nv 1 0 0\nv 2 1 0\nv 1 2 0\nv 0 1 0\nf 1 2 3 4 5\nf 1 2 3 4\n";
        let m = parse(text).unwrap();
        assert_eq!(
            m.indices,
            vec![[0, 1, 2], [0, 2, 3], [0, 3, 4], [0, 1, 2], [0, 2, 3]]
        );
        assert_eq!(m.report.polygons_triangulated, 2);
    }

    #[test]
    fn negative_indices_are_relative() {
        let text = format!("{QUAD}f -4 -3 -2\nv 5 5 5\nf -1 -2 -3\nf 1/1/1 -1//2 -2/3\n");
        let m = parse(&text).unwrap();
        assert_eq!(m.indices, vec![[0, 1, 2], [4, 3, 2], [0, 4, 3]]);
    }

    #[test]
    fn forward_references_resolve_at_the_end() {
        let m = parse("f 1 2 3\nv 0 0 0\nv 1 0 0\nv 0 1 0\n").unwrap();
        assert_eq!(m.indices, vec![[0, 1, 2]]);
    }

    #[test]
    fn statements_ignored_and_comments() {
        let text = format!(
            "# header\n\no thing\ng a b\ns off\ns 1\n{QUAD}  \nvp 0.1\nf 1 2 3 # trailing\nl 1 2\nfrobnicate 1\nfrobnicate 2\n"
        );
        let m = parse(&text).unwrap();
        assert_eq!(m.indices.len(), 1);
        let w = m.report.warnings.join("\n");
        assert!(w.contains("1 line/point"), "{w}");
        assert!(
            w.contains("t.obj:15: unknown OBJ statement `frobnicate`"),
            "{w}"
        );
    }

    #[test]
    fn crlf_and_continuation_lines() {
        let text = "v 0 0 0\r\nv 1 0 0\r\nv 0 1 \\\r\n 0\r\nf 1 2 \\\n3\r\n";
        let m = parse(text).unwrap();
        assert_eq!(m.positions[2], Vec3::new(0.0, 1.0, 0.0));
        assert_eq!(m.indices, vec![[0, 1, 2]]);
    }

    #[test]
    fn vertex_extras_are_allowed() {
        // `v x y z w` and `v x y z r g b` (vertex colours) both occur in the wild.
        let m = parse("v 0 0 0 1\nv 1 0 0 0.5 0.5 0.5\nv 0 1 0\nf 1 2 3\n").unwrap();
        assert_eq!(m.positions[1], Vec3::new(1.0, 0.0, 0.0));
    }

    #[test]
    fn errors_name_file_and_line() {
        let e = err(&format!("{QUAD}f 1 2 7\n"));
        assert!(
            e.starts_with("/nonexistent-dir/t.obj:5:") && e.contains("out of range"),
            "{e}"
        );
        let e = err(&format!("{QUAD}f 1 2 -5\n"));
        assert!(e.starts_with("/nonexistent-dir/t.obj:5:"), "{e}");
        let e = err(&format!("{QUAD}f 0 1 2\n"));
        assert!(e.contains(":5:") && e.contains("index 0"), "{e}");
        let e = err("v 0 0 0\nv 1 0 x\n");
        assert!(
            e.contains(":2:") && e.contains("malformed number `x`"),
            "{e}"
        );
        let e = err("v 0 0 0\nv 1 0 1.2.3\n");
        assert!(e.contains(":2:") && e.contains("1.2.3"), "{e}");
        let e = err("v 0 0 0\nv 1 0\n");
        assert!(e.contains(":2:") && e.contains("needs x y z"), "{e}");
        let e = err(&format!("{QUAD}f 1 2\n"));
        assert!(e.contains(":5:") && e.contains("at least 3"), "{e}");
        let e = err(&format!("{QUAD}f 1 2 3a\n"));
        assert!(e.contains(":5:") && e.contains("`3a`"), "{e}");
        let e = err(&format!("{QUAD}f 1/x 2 3\n"));
        assert!(e.contains(":5:"), "{e}");
        let e = err(&format!("{QUAD}f 1/1/1/1 2 3\n"));
        assert!(e.contains(":5:"), "{e}");
        let e = err(&format!("{QUAD}f 1 2 99999999999\n"));
        assert!(e.contains(":5:"), "{e}");
    }

    #[test]
    fn truncated_file_is_an_error() {
        // A file cut in the middle of a face line.
        let full = format!("{QUAD}f 1 2 3\nf 1 3 4\n");
        let cut = &full[..full.len() - 4];
        let e = err(cut);
        assert!(e.contains(":6:") && e.contains("at least 3"), "{e}");
        // Cut in the middle of a vertex line.
        let e = err("v 0 0 0\nv 1 0");
        assert!(e.contains(":2:") && e.contains("needs x y z"), "{e}");
    }

    #[test]
    fn forward_reference_out_of_range_names_its_line() {
        let e = err("f 1 2 9\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
        assert!(e.starts_with("/nonexistent-dir/t.obj:1:"), "{e}");
    }

    #[test]
    fn materials_from_mtl_and_default() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(
            dir.path().join("m.mtl"),
            "newmtl red\nKd 1 0 0\nnewmtl lamp\nKd 1 1 1\nKe 5 5 5\n",
        )
        .unwrap();
        let text = format!(
            "mtllib m.mtl\n{QUAD}f 1 2 3\nusemtl red\nf 1 2 3\nusemtl lamp\nf 1 3 4\nusemtl red\nf 2 3 4\nusemtl nowhere\nf 1 2 4\n"
        );
        let m = parse_at(&text, &dir.path().join("x.obj")).unwrap();
        assert_eq!(m.material_ids, vec![0, 1, 2, 1, 3]);
        let names: Vec<&str> = m.materials.iter().map(|m| m.name.as_str()).collect();
        assert_eq!(names, ["default", "red", "lamp", "nowhere"]);
        assert_eq!(m.materials[1].albedo, Vec3::new(1.0, 0.0, 0.0));
        assert_eq!(m.materials[2].emission, Vec3::splat(5.0));
        assert_eq!(m.materials[3].albedo, Material::default_grey().albedo);
        let w = m.report.warnings.join("\n");
        assert!(w.contains("1 material(s) used but not defined") && w.contains("nowhere"));
    }

    #[test]
    fn mtl_found_compressed() {
        let mtl = b"newmtl red\nKd 1 0 0\n";
        let text = format!("mtllib lib.mtl\nusemtl red\n{QUAD}f 1 2 3\n");
        for suffix in ["zst", "gz"] {
            let dir = tempfile::tempdir().unwrap();
            let bytes = if suffix == "zst" {
                zstd::encode_all(&mtl[..], 3).unwrap()
            } else {
                let mut e =
                    flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
                e.write_all(mtl).unwrap();
                e.finish().unwrap()
            };
            std::fs::write(dir.path().join(format!("lib.mtl.{suffix}")), bytes).unwrap();
            let m = parse_at(&text, &dir.path().join("x.obj")).unwrap();
            assert_eq!(m.materials[0].albedo, Vec3::new(1.0, 0.0, 0.0), "{suffix}");
            assert!(m.report.warnings.is_empty(), "{:?}", m.report.warnings);
        }
    }

    #[test]
    fn missing_mtl_is_a_warning_and_grey() {
        let text = format!("mtllib gone.mtl\nusemtl red\n{QUAD}f 1 2 3\n");
        let m = parse(&text).unwrap();
        assert_eq!(m.materials[0].name, "red");
        assert_eq!(m.materials[0].albedo, Material::default_grey().albedo);
        let w = m.report.warnings.join("\n");
        assert!(
            w.contains("t.obj:1: material library") && w.contains("gone.mtl not found"),
            "{w}"
        );
        assert!(w.contains("no material library was loaded"), "{w}");
    }

    #[test]
    fn bad_mtl_is_an_error_naming_the_mtl() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("m.mtl"), "newmtl a\nKd 1 oops 1\n").unwrap();
        let e = parse_at(&format!("mtllib m.mtl\n{QUAD}"), &dir.path().join("x.obj"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("m.mtl:2:"), "{e}");
    }
}
