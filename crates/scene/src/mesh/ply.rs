//! PLY (Turk's polygon file format): `ascii`, `binary_little_endian`, `binary_big_endian`.
//!
//! - The `vertex` element must have scalar `x`, `y`, `z` properties of any numeric type; its
//!   other properties (normals, colours, confidence …) are skipped.
//! - The `face` element must have a list property `vertex_indices` (or `vertex_index`) with
//!   any integer count and index types; other properties are skipped. Polygons are
//!   fan-triangulated like OBJ's.
//! - Other elements (`edge`, `material`, …) are skipped, in binary files by decoding their
//!   list lengths so the following elements stay aligned.
//! - A file without a `face` element, or with zero faces, is an error: point clouds cannot be
//!   ray traced.
//!
//! ASCII bodies are read one element instance per line (what every writer produces) and
//! errors name the line; binary errors name the element, the instance index and the byte
//! offset from the start of the (decompressed) file.

use super::input::LineReader;
use super::num::{parse_f64, parse_i64, tokens};
use super::{IndexedMesh, parse_error};
use crate::{LoadReport, Material, SceneError};
use rtsim_core::Vec3;
use rtsim_core::text::echo;
use std::io::{BufRead, Read};
use std::path::Path;

/// Most elements reserved up front, whatever the header claims (assumed: 1 M, 12 MB of
/// positions; a corrupt count must not allocate before the body proves it, and beyond this
/// the vectors grow by doubling as the records arrive).
const MAX_RESERVE: u64 = 1 << 20;

/// List entries read per block in binary files (assumed: 4096 covers any real polygon in one
/// read while bounding the buffer).
const LIST_BLOCK: usize = 4096;

/// Scalar property types (PLY 1.0 names and their sized aliases).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Scalar {
    fn from_name(name: &[u8]) -> Option<Scalar> {
        Some(match name {
            b"char" | b"int8" => Scalar::I8,
            b"uchar" | b"uint8" => Scalar::U8,
            b"short" | b"int16" => Scalar::I16,
            b"ushort" | b"uint16" => Scalar::U16,
            b"int" | b"int32" => Scalar::I32,
            b"uint" | b"uint32" => Scalar::U32,
            b"float" | b"float32" => Scalar::F32,
            b"double" | b"float64" => Scalar::F64,
            _ => return None,
        })
    }

    fn size(self) -> usize {
        match self {
            Scalar::I8 | Scalar::U8 => 1,
            Scalar::I16 | Scalar::U16 => 2,
            Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
            Scalar::F64 => 8,
        }
    }

    fn is_integer(self) -> bool {
        !matches!(self, Scalar::F32 | Scalar::F64)
    }

    /// Decode `b` (exactly `size()` bytes) as a number.
    #[inline]
    fn decode(self, b: &[u8], big: bool) -> f64 {
        match self {
            Scalar::F32 => f32::from_bits(read_u32(b, big)) as f64,
            Scalar::F64 => {
                let a: [u8; 8] = b.try_into().expect("8 bytes");
                if big {
                    f64::from_be_bytes(a)
                } else {
                    f64::from_le_bytes(a)
                }
            }
            _ => self.decode_int(b, big) as f64,
        }
    }

    /// Decode an integer type (`is_integer()`).
    #[inline]
    fn decode_int(self, b: &[u8], big: bool) -> i64 {
        match self {
            Scalar::I8 => b[0] as i8 as i64,
            Scalar::U8 => b[0] as i64,
            Scalar::I16 => read_u16(b, big) as i16 as i64,
            Scalar::U16 => read_u16(b, big) as i64,
            Scalar::I32 => read_u32(b, big) as i32 as i64,
            Scalar::U32 => read_u32(b, big) as i64,
            Scalar::F32 | Scalar::F64 => {
                unreachable!("float types are rejected for counts and indices")
            }
        }
    }
}

#[inline]
fn read_u16(b: &[u8], big: bool) -> u16 {
    let a: [u8; 2] = b.try_into().expect("2 bytes");
    if big {
        u16::from_be_bytes(a)
    } else {
        u16::from_le_bytes(a)
    }
}

#[inline]
fn read_u32(b: &[u8], big: bool) -> u32 {
    let a: [u8; 4] = b.try_into().expect("4 bytes");
    if big {
        u32::from_be_bytes(a)
    } else {
        u32::from_le_bytes(a)
    }
}

#[derive(Clone, Debug)]
enum Property {
    Scalar {
        ty: Scalar,
        name: String,
    },
    List {
        count: Scalar,
        item: Scalar,
        name: String,
    },
}

#[derive(Clone, Debug)]
struct Element {
    name: String,
    count: u64,
    props: Vec<Property>,
}

impl Element {
    /// Record size when the element has no list properties.
    fn fixed_size(&self) -> Option<usize> {
        self.props
            .iter()
            .map(|p| match p {
                Property::Scalar { ty, .. } => Some(ty.size()),
                Property::List { .. } => None,
            })
            .sum()
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Encoding {
    Ascii,
    Binary { big: bool },
}

/// Which property of which element we read.
#[derive(Clone, Copy, Debug)]
struct Layout {
    vertex: usize,
    xyz: [usize; 3],
    face: usize,
    indices: usize,
}

/// Parse a PLY stream; `path` names the file in errors.
pub fn parse_ply<R: BufRead>(reader: R, path: &Path) -> Result<IndexedMesh, SceneError> {
    parse_ply_sized(reader, path, None)
}

/// Parse a PLY stream of `len` bytes if known (a plain file; not a compressed stream), so
/// that every element count is checked against what the file can hold before it is read.
pub fn parse_ply_sized<R: BufRead>(
    reader: R,
    path: &Path,
    len: Option<u64>,
) -> Result<IndexedMesh, SceneError> {
    let mut lines = LineReader::new(reader, path, false);
    let (encoding, elements) = parse_header(&mut lines, path)?;
    let layout = find_layout(&elements, path)?;
    check_counts(
        &elements,
        encoding,
        len.map(|l| l.saturating_sub(lines.bytes_read())),
        path,
    )?;
    let vertex_count = elements[layout.vertex].count;
    if vertex_count > u32::MAX as u64 {
        return Err(format_error(
            path,
            format!("{vertex_count} vertices exceed the supported 2^32"),
        ));
    }
    let face_count = elements[layout.face].count;
    let mut body = Body {
        path,
        elements: &elements,
        layout,
        positions: Vec::with_capacity(vertex_count.min(MAX_RESERVE) as usize),
        indices: Vec::with_capacity(face_count.min(MAX_RESERVE) as usize),
        polygons: 0,
        face: Vec::with_capacity(8),
    };
    match encoding {
        Encoding::Ascii => {
            body.read_ascii(&mut lines)?;
            // Anything but blank lines after the last element is not PLY data.
            while let Some((n, l)) = lines.next_line()? {
                if !l.trim_ascii().is_empty() {
                    return Err(parse_error(
                        path,
                        n,
                        format!(
                            "data after the last element (`{}`): the header declares fewer \
                             elements than the file has",
                            echo(l)
                        ),
                    ));
                }
            }
        }
        Encoding::Binary { big } => {
            let offset = lines.bytes_read();
            let mut reader = BinReader {
                inner: lines.into_inner(),
                offset,
            };
            body.read_binary(&mut reader, big)?;
            let mut extra = [0u8; 1];
            let at = reader.offset;
            if reader
                .inner
                .read(&mut extra)
                .map_err(|e| format_error(path, format!("read error at byte offset {at}: {e}")))?
                > 0
            {
                return Err(format_error(
                    path,
                    format!(
                        "data after the last element, from byte offset {at}: the header declares \
                         fewer or smaller elements than the file has"
                    ),
                ));
            }
        }
    }
    let n = body.indices.len();
    let report = LoadReport {
        polygons_triangulated: body.polygons,
        ..LoadReport::default()
    };
    Ok(IndexedMesh {
        positions: body.positions,
        indices: body.indices,
        material_ids: vec![0; n],
        materials: vec![Material::default_grey()],
        report,
    })
}

fn format_error(path: &Path, message: impl Into<String>) -> SceneError {
    SceneError::Format {
        path: path.to_path_buf(),
        message: message.into(),
    }
}

fn parse_header<R: BufRead>(
    lines: &mut LineReader<'_, R>,
    path: &Path,
) -> Result<(Encoding, Vec<Element>), SceneError> {
    match lines.next_line()? {
        Some((_, l)) if l.trim_ascii() == b"ply" => {}
        _ => {
            return Err(format_error(
                path,
                "not a PLY file (first line is not `ply`)",
            ));
        }
    }
    let mut encoding = None;
    let mut elements: Vec<Element> = Vec::new();
    loop {
        let Some((n, line)) = lines.next_line()? else {
            return Err(format_error(path, "truncated header: no `end_header` line"));
        };
        let toks: Vec<&[u8]> = tokens(line).collect();
        let text = |t: &[u8]| String::from_utf8_lossy(t).into_owned();
        let quote = |t: &[u8]| echo(t);
        match toks.as_slice() {
            [] => {}
            [b"end_header"] => break,
            [b"comment", ..] | [b"obj_info", ..] => {}
            [b"format", fmt, version] => {
                if *version != b"1.0" {
                    return Err(parse_error(
                        path,
                        n,
                        format!("unsupported PLY version `{}`", quote(version)),
                    ));
                }
                encoding = Some(match *fmt {
                    b"ascii" => Encoding::Ascii,
                    b"binary_little_endian" => Encoding::Binary { big: false },
                    b"binary_big_endian" => Encoding::Binary { big: true },
                    other => {
                        return Err(parse_error(
                            path,
                            n,
                            format!("unknown PLY format `{}`", quote(other)),
                        ));
                    }
                });
            }
            [b"element", name, count] => {
                let count = parse_i64(count)
                    .and_then(|c| u64::try_from(c).ok())
                    .ok_or_else(|| {
                        parse_error(
                            path,
                            n,
                            format!("malformed element count `{}`", quote(count)),
                        )
                    })?;
                if elements.iter().any(|e| e.name.as_bytes() == *name) {
                    return Err(parse_error(
                        path,
                        n,
                        format!("element `{}` is declared twice", quote(name)),
                    ));
                }
                elements.push(Element {
                    name: text(name),
                    count,
                    props: Vec::new(),
                });
            }
            [b"property", rest @ ..] => {
                let Some(el) = elements.last_mut() else {
                    return Err(parse_error(path, n, "`property` before any `element`"));
                };
                let ty = |t: &[u8]| {
                    Scalar::from_name(t).ok_or_else(|| {
                        parse_error(path, n, format!("unknown property type `{}`", quote(t)))
                    })
                };
                let prop = match rest {
                    [b"list", count, item, name] => {
                        let (count, item) = (ty(count)?, ty(item)?);
                        if !count.is_integer() {
                            return Err(parse_error(
                                path,
                                n,
                                "list count type must be an integer type",
                            ));
                        }
                        Property::List {
                            count,
                            item,
                            name: text(name),
                        }
                    }
                    [t, name] => Property::Scalar {
                        ty: ty(t)?,
                        name: text(name),
                    },
                    _ => {
                        return Err(parse_error(
                            path,
                            n,
                            format!("malformed property line `{}`", quote(line)),
                        ));
                    }
                };
                let name = match &prop {
                    Property::Scalar { name, .. } | Property::List { name, .. } => name,
                };
                if el.props.iter().any(|p| match p {
                    Property::Scalar { name: q, .. } | Property::List { name: q, .. } => q == name,
                }) {
                    return Err(parse_error(
                        path,
                        n,
                        format!(
                            "property `{}` of element `{}` is declared twice",
                            echo(name),
                            echo(&el.name)
                        ),
                    ));
                }
                el.props.push(prop);
            }
            _ => {
                return Err(parse_error(
                    path,
                    n,
                    format!("unexpected header line `{}`", quote(line)),
                ));
            }
        }
    }
    let encoding = encoding.ok_or_else(|| format_error(path, "header has no `format` line"))?;
    Ok((encoding, elements))
}

/// Fewest bytes one instance of `el` takes: binary, each scalar and each list's length; ASCII,
/// one digit and one separator per value.
fn min_record_bytes(el: &Element, encoding: Encoding) -> u64 {
    match encoding {
        Encoding::Binary { .. } => el
            .props
            .iter()
            .map(|p| match p {
                Property::Scalar { ty, .. } => ty.size() as u64,
                Property::List { count, .. } => count.size() as u64,
            })
            .sum(),
        Encoding::Ascii => 2 * el.props.len() as u64,
    }
}

/// Every element count against what the body (`body` bytes, when known) can hold.
fn check_counts(
    elements: &[Element],
    encoding: Encoding,
    body: Option<u64>,
    path: &Path,
) -> Result<(), SceneError> {
    let mut need: u128 = 0;
    for el in elements {
        let min = min_record_bytes(el, encoding);
        if min == 0 && el.count > 0 && encoding == Encoding::Ascii {
            return Err(format_error(
                path,
                format!(
                    "element `{}` has no properties but {} instances: an ASCII instance is a \
                     line of values",
                    echo(&el.name),
                    el.count
                ),
            ));
        }
        need += u128::from(el.count) * u128::from(min);
        if let Some(body) = body
            && need > u128::from(body)
        {
            return Err(format_error(
                path,
                format!(
                    "the header declares {} `{}` element(s) of at least {min} bytes each, more \
                     than the {body} bytes after the header can hold (corrupt count?)",
                    el.count,
                    echo(&el.name)
                ),
            ));
        }
    }
    Ok(())
}

fn find_layout(elements: &[Element], path: &Path) -> Result<Layout, SceneError> {
    let find = |name: &str| elements.iter().position(|e| e.name == name);
    let vertex =
        find("vertex").ok_or_else(|| format_error(path, "no `vertex` element in the header"))?;
    let Some(face) = find("face") else {
        return Err(format_error(
            path,
            "no `face` element: nothing to ray trace (point clouds are not supported)",
        ));
    };
    if elements[face].count == 0 {
        return Err(format_error(
            path,
            "the `face` element has 0 faces: nothing to ray trace",
        ));
    }
    let mut xyz = [usize::MAX; 3];
    for (slot, axis) in xyz.iter_mut().zip(["x", "y", "z"]) {
        *slot = elements[vertex]
            .props
            .iter()
            .position(|p| matches!(p, Property::Scalar { name, .. } if name == axis))
            .ok_or_else(|| {
                format_error(
                    path,
                    format!("the `vertex` element has no scalar `{axis}` property"),
                )
            })?;
    }
    let indices = elements[face]
        .props
        .iter()
        .position(|p| {
            matches!(p, Property::List { name, .. } if name == "vertex_indices" || name == "vertex_index")
        })
        .ok_or_else(|| {
            format_error(
                path,
                "the `face` element has no list property `vertex_indices` or `vertex_index`",
            )
        })?;
    if let Property::List { item, .. } = elements[face].props[indices]
        && !item.is_integer()
    {
        return Err(format_error(
            path,
            "face vertex indices must have an integer type",
        ));
    }
    Ok(Layout {
        vertex,
        xyz,
        face,
        indices,
    })
}

/// A binary reader that knows its byte offset in the file.
struct BinReader<R> {
    inner: R,
    offset: u64,
}

impl<R: Read> BinReader<R> {
    #[inline]
    fn read_exact(&mut self, buf: &mut [u8]) -> std::io::Result<()> {
        self.inner.read_exact(buf)?;
        self.offset += buf.len() as u64;
        Ok(())
    }
}

struct Body<'a> {
    path: &'a Path,
    elements: &'a [Element],
    layout: Layout,
    positions: Vec<Vec3>,
    indices: Vec<[u32; 3]>,
    polygons: u64,
    face: Vec<u32>,
}

impl Body<'_> {
    /// Add one face's triangles; `at` locates the face in error messages.
    fn push_face(&mut self, at: &dyn Fn() -> String) -> Result<(), SceneError> {
        let n = self.face.len();
        if n < 3 {
            return Err(format_error(
                self.path,
                format!("{}: face has {n} vertex index(es), needs at least 3", at()),
            ));
        }
        if n > 3 {
            self.polygons += 1;
        }
        let f0 = self.face[0];
        for i in 1..n - 1 {
            self.indices.push([f0, self.face[i], self.face[i + 1]]);
        }
        Ok(())
    }

    fn check_index(&self, i: i64, at: &dyn Fn() -> String) -> Result<u32, SceneError> {
        let n = self.elements[self.layout.vertex].count;
        if i < 0 || i as u64 >= n {
            return Err(format_error(
                self.path,
                format!("{}: vertex index {i} out of range ({n} vertices)", at()),
            ));
        }
        Ok(i as u32)
    }

    fn read_binary<R: Read>(&mut self, r: &mut BinReader<R>, big: bool) -> Result<(), SceneError> {
        let mut buf = vec![0u8; 64];
        for (ei, el) in self.elements.iter().enumerate() {
            let fixed = el.fixed_size();
            if fixed == Some(0) {
                // Records of no bytes: nothing to read, however many the header claims (a
                // count of 2^62 must not spin for years).
                continue;
            }
            // For a fixed-size vertex record: byte offset and type of x, y and z.
            let xyz_at: Option<[(usize, Scalar); 3]> =
                (ei == self.layout.vertex && fixed.is_some()).then(|| {
                    let mut offsets = Vec::with_capacity(el.props.len());
                    let mut o = 0;
                    for p in &el.props {
                        offsets.push(o);
                        if let Property::Scalar { ty, .. } = p {
                            o += ty.size();
                        }
                    }
                    self.layout.xyz.map(|pi| match el.props[pi] {
                        Property::Scalar { ty, .. } => (offsets[pi], ty),
                        Property::List { .. } => unreachable!("layout checked x/y/z are scalars"),
                    })
                });
            for k in 0..el.count {
                let start = r.offset;
                let at = || {
                    format!(
                        "element `{}` #{k} (of {}) at byte offset {start}",
                        el.name, el.count
                    )
                };
                let truncated = |e: std::io::Error| {
                    let why = if e.kind() == std::io::ErrorKind::UnexpectedEof {
                        "file ends early (truncated)".to_string()
                    } else {
                        format!("read error: {e}")
                    };
                    format_error(self.path, format!("{}: {why}", at()))
                };
                if let Some(size) = fixed {
                    // Fast path: one read per record.
                    if buf.len() < size {
                        buf.resize(size, 0);
                    }
                    r.read_exact(&mut buf[..size]).map_err(truncated)?;
                    if let Some(xyz) = xyz_at {
                        let v = |(o, ty): (usize, Scalar)| {
                            ty.decode(&buf[o..o + ty.size()], big) as f32
                        };
                        self.positions
                            .push(Vec3::new(v(xyz[0]), v(xyz[1]), v(xyz[2])));
                    }
                    continue;
                }
                // General path: property by property.
                let mut xyz = [0.0f32; 3];
                self.face.clear();
                for (pi, p) in el.props.iter().enumerate() {
                    match p {
                        Property::Scalar { ty, .. } => {
                            let b = &mut buf[..ty.size()];
                            r.read_exact(b).map_err(truncated)?;
                            if ei == self.layout.vertex
                                && let Some(a) = self.layout.xyz.iter().position(|&x| x == pi)
                            {
                                xyz[a] = ty.decode(b, big) as f32;
                            }
                        }
                        Property::List { count, item, name } => {
                            r.read_exact(&mut buf[..count.size()]).map_err(truncated)?;
                            let len = count.decode_int(&buf[..count.size()], big);
                            if len < 0 {
                                return Err(format_error(
                                    self.path,
                                    format!("{}: list `{name}` has negative length {len}", at()),
                                ));
                            }
                            // Read in bounded blocks: a corrupt length (up to 2^32 entries)
                            // must end in a truncation error, not a huge allocation.
                            let wanted = self.layout.face == ei && self.layout.indices == pi;
                            let mut left = len as u64;
                            while left > 0 {
                                let n = left.min(LIST_BLOCK as u64) as usize;
                                let bytes = n * item.size();
                                if buf.len() < bytes {
                                    buf.resize(bytes, 0);
                                }
                                r.read_exact(&mut buf[..bytes]).map_err(truncated)?;
                                if wanted {
                                    for c in buf[..bytes].chunks_exact(item.size()) {
                                        let i = self.check_index(item.decode_int(c, big), &at)?;
                                        self.face.push(i);
                                    }
                                }
                                left -= n as u64;
                            }
                        }
                    }
                }
                if ei == self.layout.vertex {
                    self.positions.push(Vec3::from_array(xyz));
                } else if ei == self.layout.face {
                    self.push_face(&at)?;
                }
            }
        }
        Ok(())
    }

    fn read_ascii<R: BufRead>(&mut self, lines: &mut LineReader<'_, R>) -> Result<(), SceneError> {
        let path = self.path;
        for (ei, el) in self.elements.iter().enumerate() {
            for k in 0..el.count {
                let (line_no, line) = loop {
                    match lines.next_line()? {
                        None => {
                            return Err(parse_error(
                                path,
                                lines.lines_read() + 1,
                                format!(
                                    "file ends early (truncated): expected element `{}` #{k} of {}",
                                    el.name, el.count
                                ),
                            ));
                        }
                        Some((_, l)) if l.trim_ascii().is_empty() => continue,
                        Some((n, l)) => break (n, l),
                    }
                };
                let at = || format!("element `{}` #{k}", el.name);
                let err = |m: String| parse_error(path, line_no, format!("{}: {m}", at()));
                let mut toks = tokens(line);
                let mut next = |what: &str| {
                    toks.next()
                        .ok_or_else(|| err(format!("too few values (missing {what})")))
                };
                let mut xyz = [0.0f32; 3];
                self.face.clear();
                for (pi, p) in el.props.iter().enumerate() {
                    match p {
                        Property::Scalar { ty, name } => {
                            let t = next(name)?;
                            let v = parse_scalar(*ty, t).ok_or_else(|| {
                                err(format!("malformed {ty:?} value `{}` for `{name}`", echo(t)))
                            })?;
                            if ei == self.layout.vertex
                                && let Some(a) = self.layout.xyz.iter().position(|&x| x == pi)
                            {
                                xyz[a] = v as f32;
                            }
                        }
                        Property::List { item, name, .. } => {
                            let t = next(name)?;
                            let len = parse_i64(t).filter(|&l| l >= 0).ok_or_else(|| {
                                err(format!("malformed list length `{}` for `{name}`", echo(t)))
                            })?;
                            for _ in 0..len {
                                let t = next(name)?;
                                let v = parse_scalar(*item, t).ok_or_else(|| {
                                    err(format!(
                                        "malformed {item:?} value `{}` in `{name}`",
                                        echo(t)
                                    ))
                                })?;
                                if ei == self.layout.face && pi == self.layout.indices {
                                    let n = self.elements[self.layout.vertex].count;
                                    if v < 0.0 || v as u64 >= n {
                                        return Err(err(format!(
                                            "vertex index {v} out of range ({n} vertices)"
                                        )));
                                    }
                                    self.face.push(v as u32);
                                }
                            }
                        }
                    }
                }
                if toks.next().is_some() {
                    return Err(err("more values than the header declares".into()));
                }
                if ei == self.layout.vertex {
                    self.positions.push(Vec3::from_array(xyz));
                } else if ei == self.layout.face {
                    let n = self.face.len();
                    if n < 3 {
                        return Err(err(format!(
                            "face has {n} vertex index(es), needs at least 3"
                        )));
                    }
                    self.push_face(&at)?;
                }
            }
        }
        Ok(())
    }
}

/// An ASCII value of type `ty`: integers must be integral, floats any decimal.
fn parse_scalar(ty: Scalar, t: &[u8]) -> Option<f64> {
    if ty.is_integer() {
        parse_i64(t).map(|v| v as f64)
    } else {
        parse_f64(t)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Cursor;

    fn parse(bytes: Vec<u8>) -> Result<IndexedMesh, SceneError> {
        parse_ply(Cursor::new(bytes), Path::new("t.ply"))
    }

    /// A tetrahedron-ish mesh (4 vertices, a triangle and a quad) with extra vertex
    /// properties and an extra element between vertices and faces, and after faces.
    fn binary_fixture(big: bool) -> Vec<u8> {
        let fmt = if big {
            "binary_big_endian"
        } else {
            "binary_little_endian"
        };
        let mut b = format!(
            "ply\nformat {fmt} 1.0\ncomment made by a test\nobj_info nothing\n\
             element vertex 4\nproperty double nx\nproperty float x\nproperty uchar red\n\
             property int16 y\nproperty float64 z\nproperty list uchar int extra\n\
             element edge 2\nproperty int vertex1\nproperty list ushort uint stuff\n\
             element face 2\nproperty uchar flags\nproperty list uint8 uint32 vertex_indices\nproperty float quality\n\
             element material 1\nproperty list int float rgb\n\
             end_header\n"
        )
        .into_bytes();
        macro_rules! put {
            ($v:expr) => {
                if big {
                    b.extend_from_slice(&$v.to_be_bytes())
                } else {
                    b.extend_from_slice(&$v.to_le_bytes())
                }
            };
        }
        let verts: [(f32, i16, f64); 4] =
            [(0.0, 0, 0.0), (1.0, 0, 0.0), (1.0, 1, 0.0), (0.0, 1, 0.5)];
        for (i, (x, y, z)) in verts.iter().enumerate() {
            put!(7.5f64);
            put!(*x);
            put!(200u8);
            put!(*y);
            put!(*z);
            put!(i as u8); // list of i ints
            for j in 0..i {
                put!(j as i32);
            }
        }
        for _ in 0..2 {
            put!(1i32);
            put!(3u16);
            for j in 0..3u32 {
                put!(j);
            }
        }
        put!(0u8);
        put!(3u8);
        for j in [0u32, 1, 2] {
            put!(j);
        }
        put!(0.5f32);
        put!(0u8);
        put!(4u8);
        for j in [0u32, 1, 2, 3] {
            put!(j);
        }
        put!(0.25f32);
        put!(2i32);
        put!(1.0f32);
        put!(2.0f32);
        b
    }

    fn check_fixture(m: &IndexedMesh) {
        assert_eq!(m.positions.len(), 4);
        assert_eq!(m.positions[3], Vec3::new(0.0, 1.0, 0.5));
        assert_eq!(m.positions[1], Vec3::new(1.0, 0.0, 0.0));
        assert_eq!(m.indices, vec![[0, 1, 2], [0, 1, 2], [0, 2, 3]]);
        assert_eq!(m.report.polygons_triangulated, 1);
        assert_eq!(m.material_ids, vec![0; 3]);
    }

    #[test]
    fn binary_little_and_big_endian() {
        check_fixture(&parse(binary_fixture(false)).unwrap());
        check_fixture(&parse(binary_fixture(true)).unwrap());
    }

    const ASCII: &str = "ply\r\nformat ascii 1.0\r\ncomment c\r\nelement vertex 4\r\nproperty float x\r\nproperty float y\r\nproperty float z\r\nproperty uchar red\r\n\
element edge 1\r\nproperty int a\r\nproperty int b\r\n\
element face 2\r\nproperty list uchar int vertex_index\r\nproperty float q\r\nend_header\r\n\
0 0 0 1\r\n1 0 0 2\r\n1 1 0 3\r\n0 1 0.5 255\r\n0 1\r\n3 0 1 2 0.5\r\n\r\n4 0 1 2 3 0.5\r\n";

    #[test]
    fn ascii_with_extra_properties_and_elements() {
        check_fixture(&parse(ASCII.as_bytes().to_vec()).unwrap());
    }

    #[test]
    fn fixed_size_face_records_take_the_general_path_correctly() {
        // The dragon's layout: float xyz, then `list uchar int vertex_indices`.
        let mut b = b"ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n".to_vec();
        for v in [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0] {
            b.extend_from_slice(&v.to_le_bytes());
        }
        b.push(3);
        for i in [2i32, 1, 0] {
            b.extend_from_slice(&i.to_le_bytes());
        }
        let m = parse(b).unwrap();
        assert_eq!(m.indices, vec![[2, 1, 0]]);
        assert_eq!(m.positions[2], Vec3::new(0.0, 1.0, 0.0));
    }

    fn err(bytes: Vec<u8>) -> String {
        parse(bytes).unwrap_err().to_string()
    }

    #[test]
    fn no_faces_is_an_error() {
        let e = err(b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nend_header\n0 0 0\n".to_vec());
        assert!(e.starts_with("t.ply: no `face` element"), "{e}");
        let e = err(b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nelement face 0\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n".to_vec());
        assert!(e.contains("0 faces"), "{e}");
    }

    #[test]
    fn header_errors() {
        assert!(err(b"plx\n".to_vec()).contains("not a PLY file"));
        assert!(err(b"ply\nformat ascii 1.0\n".to_vec()).contains("no `end_header`"));
        let e =
            err(b"ply\nformat ascii 1.0\nelement vertex 1\nproperty quad x\nend_header\n".to_vec());
        assert!(e.starts_with("t.ply:4:") && e.contains("`quad`"), "{e}");
        let e = err(b"ply\nformat utf8 1.0\nend_header\n".to_vec());
        assert!(e.starts_with("t.ply:2:"), "{e}");
        let e = err(b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n".to_vec());
        assert!(e.contains("no scalar `z`"), "{e}");
        let e = err(b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar float vertex_indices\nend_header\n".to_vec());
        assert!(e.contains("integer type"), "{e}");
        let e = err(b"ply\nformat ascii 1.0\nelement vertex x\nend_header\n".to_vec());
        assert!(e.starts_with("t.ply:3:"), "{e}");
    }

    #[test]
    fn ascii_body_errors_name_the_line() {
        let bad_index = ASCII.replace("3 0 1 2 0.5", "3 0 1 9 0.5");
        let e = err(bad_index.into_bytes());
        assert!(
            e.starts_with("t.ply:21:") && e.contains("out of range"),
            "{e}"
        );
        let bad_num = ASCII.replace("1 1 0 3", "1 1.5.2 0 3");
        let e = err(bad_num.into_bytes());
        assert!(e.starts_with("t.ply:18:") && e.contains("1.5.2"), "{e}");
        let cut = &ASCII[..ASCII.len() - 7];
        let e = err(cut.as_bytes().to_vec());
        assert!(
            e.contains("t.ply:23:") && e.contains("too few values"),
            "{e}"
        );
        let cut = &ASCII[..ASCII.find("\r\n0 1\r\n").unwrap() + 2];
        let e = err(cut.as_bytes().to_vec());
        assert!(
            e.starts_with("t.ply:20:") && e.contains("truncated") && e.contains("`edge` #0"),
            "{e}"
        );
        let extra = ASCII.replace("0 1\r\n", "0 1 2\r\n");
        assert!(err(extra.into_bytes()).contains("more values"));
        let two = ASCII.replace("3 0 1 2 0.5", "2 0 1 0.5");
        assert!(err(two.into_bytes()).contains("needs at least 3"));
    }

    #[test]
    fn binary_errors_name_element_and_offset() {
        let full = binary_fixture(false);
        for cut in [full.len() - 3, full.len() - 40, full.len() - 100] {
            let e = err(full[..cut].to_vec());
            assert!(
                e.starts_with("t.ply: element `")
                    && e.contains("byte offset")
                    && e.contains("truncated"),
                "{e}"
            );
        }
        // Corrupt the first face's first index (after its `flags` byte and count byte).
        let header_end = full.windows(11).position(|w| w == b"end_header\n").unwrap() + 11;
        let vertex_bytes: usize = (0..4).map(|i| 8 + 4 + 1 + 2 + 8 + 1 + 4 * i).sum();
        let edge_bytes = 2 * (4 + 2 + 12);
        let at = header_end + vertex_bytes + edge_bytes + 2;
        let mut bad = full.clone();
        bad[at..at + 4].copy_from_slice(&77u32.to_le_bytes());
        let e = err(bad);
        assert!(
            e.contains("element `face` #0")
                && e.contains("index 77 out of range")
                && e.contains(&format!("byte offset {}", at - 2)),
            "{e}"
        );
    }

    #[test]
    fn corrupt_list_length_is_a_truncation_not_an_allocation() {
        let mut b = b"ply\nformat binary_big_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uint int vertex_indices\nend_header\n".to_vec();
        for v in [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0] {
            b.extend_from_slice(&v.to_be_bytes());
        }
        b.extend_from_slice(&u32::MAX.to_be_bytes());
        for i in [0i32, 1, 2] {
            b.extend_from_slice(&i.to_be_bytes());
        }
        let e = err(b);
        assert!(
            e.contains("element `face` #0") && e.contains("truncated"),
            "{e}"
        );
    }

    #[test]
    fn zero_area_and_non_finite_faces_are_dropped_later() {
        let text = "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\nelement face 3\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\nnan 0 0\n3 0 1 2\n3 0 0 1\n3 0 1 3\n";
        let m = parse(text.as_bytes().to_vec())
            .unwrap()
            .into_mesh(&rtsim_core::Affine::IDENTITY);
        assert_eq!(m.triangles.len(), 1);
        assert_eq!(m.report.dropped_degenerate, 1);
        assert_eq!(m.report.dropped_non_finite, 1);
    }

    fn tri_header(format: &str, extra: &str) -> Vec<u8> {
        format!(
            "ply\nformat {format} 1.0\n{extra}element vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
        )
        .into_bytes()
    }

    fn tri_body_le(b: &mut Vec<u8>) {
        for v in [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0] {
            b.extend_from_slice(&v.to_le_bytes());
        }
        b.push(3);
        for i in [0i32, 1, 2] {
            b.extend_from_slice(&i.to_le_bytes());
        }
    }

    #[test]
    fn empty_records_with_a_huge_count_are_skipped_not_spun() {
        // The hostile 251-byte file: an element of no properties and a count of 2^62.
        let mut b = tri_header("binary_little_endian", "element junk 4611686018427387904\n");
        tri_body_le(&mut b);
        let start = std::time::Instant::now();
        let m = parse(b).unwrap();
        assert_eq!(m.indices.len(), 1);
        assert!(start.elapsed().as_secs() < 5);
        // In ASCII such an element cannot be written at all.
        let e = err(tri_header("ascii", "element junk 5\n"));
        assert!(e.contains("`junk` has no properties"), "{e}");
    }

    #[test]
    fn counts_beyond_the_file_length_are_errors_before_reading() {
        let mut b = tri_header("binary_little_endian", "");
        tri_body_le(&mut b);
        let huge = String::from_utf8(b.clone())
            .unwrap_or_default()
            .replace("vertex 3", "vertex 4000000000");
        let bytes = if huge.is_empty() {
            let mut h = tri_header("binary_little_endian", "").to_vec();
            let at = h.windows(8).position(|w| w == b"vertex 3").unwrap();
            h.splice(at..at + 8, b"vertex 4000000000".iter().copied());
            tri_body_le(&mut h);
            h
        } else {
            huge.into_bytes()
        };
        let len = bytes.len() as u64;
        let e = parse_ply_sized(Cursor::new(bytes), Path::new("t.ply"), Some(len))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("4000000000 `vertex` element(s)") && e.contains("bytes after the header"),
            "{e}"
        );
    }

    #[test]
    fn duplicated_declarations_are_errors() {
        let e = err(b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float x\nend_header\n".to_vec());
        assert!(
            e.starts_with("t.ply:5:") && e.contains("`x` of element `vertex` is declared twice"),
            "{e}"
        );
        let e = err(tri_header("ascii", "element vertex 1\nproperty float x\n"));
        assert!(e.contains("element `vertex` is declared twice"), "{e}");
    }

    #[test]
    fn trailing_data_is_an_error() {
        let text = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n\n";
        assert!(parse(text.as_bytes().to_vec()).is_ok());
        let e = err(format!("{text}3 0 1 2\n").into_bytes());
        assert!(
            e.starts_with("t.ply:15:") && e.contains("after the last element"),
            "{e}"
        );
        let mut b = tri_header("binary_little_endian", "");
        tri_body_le(&mut b);
        assert!(parse(b.clone()).is_ok());
        b.extend_from_slice(b"garbage");
        let e = err(b);
        assert!(
            e.contains("data after the last element, from byte offset"),
            "{e}"
        );
    }
}
