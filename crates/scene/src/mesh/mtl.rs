//! Wavefront MTL material libraries: `newmtl`, `Kd` (diffuse albedo) and `Ke` (emission).
//!
//! Everything else (`Ka`, `Ks`, `Ns`, `d`, `illum`, texture maps …) is accepted and ignored:
//! the papers' workloads are Lambertian. `Kd` is clamped to [0, 1] (an albedo above 1 would
//! create energy) with a warning; the simtrax Cornell box, for one, gives its light `Kd 15`.

use super::input::LineReader;
use super::num::{parse_f32, tokens};
use super::parse_error;
use crate::{LoadReport, Material, SceneError};
use rtsim_core::Vec3;
use rtsim_core::text::echo;
use std::io::BufRead;
use std::path::Path;

/// Parse an MTL file. Materials come back in file order; a name defined twice keeps the
/// later definition (with a warning).
pub fn parse_mtl<R: BufRead>(
    reader: R,
    path: &Path,
    report: &mut LoadReport,
) -> Result<Vec<Material>, SceneError> {
    let mut lines = LineReader::new(reader, path, true);
    let mut out: Vec<Material> = Vec::new();
    let mut clamped: Vec<String> = Vec::new();
    while let Some((line_no, raw)) = lines.next_line()? {
        let line = strip_comment(raw);
        let mut toks = tokens(line);
        let Some(key) = toks.next() else { continue };
        match key {
            b"newmtl" => {
                let name = rest_after_keyword(line, key);
                if name.is_empty() {
                    return Err(parse_error(path, line_no, "`newmtl` without a name"));
                }
                if let Some(i) = out.iter().position(|m| m.name == name) {
                    report.warnings.push(format!(
                        "{}:{line_no}: material `{}` defined again; the later definition wins",
                        path.display(),
                        echo(&name)
                    ));
                    out.remove(i);
                }
                out.push(Material {
                    name,
                    albedo: Material::default_grey().albedo,
                    emission: Vec3::ZERO,
                });
            }
            b"Kd" | b"Ke" => {
                let args: Vec<&[u8]> = toks.collect();
                let Some(current) = out.last_mut() else {
                    return Err(parse_error(
                        path,
                        line_no,
                        format!("`{}` before any `newmtl`", echo(key)),
                    ));
                };
                if matches!(args.first(), Some(&b"spectral") | Some(&b"xyz")) {
                    report.warnings.push(format!(
                        "{}:{line_no}: `{} {}` colours are not supported; kept the default",
                        path.display(),
                        echo(key),
                        echo(args[0])
                    ));
                    continue;
                }
                let c = parse_colour(&args).ok_or_else(|| {
                    parse_error(
                        path,
                        line_no,
                        format!(
                            "malformed `{}`: expected 1 or 3 finite non-negative numbers, found `{}`",
                            echo(key),
                            echo(rest_bytes(line, key).trim_ascii())
                        ),
                    )
                })?;
                if key == b"Kd" {
                    let clamped_c = c.min(Vec3::ONE);
                    if clamped_c != c {
                        clamped.push(current.name.clone());
                    }
                    current.albedo = clamped_c;
                } else {
                    current.emission = c;
                }
            }
            _ => {}
        }
    }
    if !clamped.is_empty() {
        report.warnings.push(format!(
            "{}: Kd above 1 clamped to 1 for material(s) {}",
            path.display(),
            clamped.join(", ")
        ));
    }
    Ok(out)
}

/// `r [g b]`: one value means grey (MTL spec).
fn parse_colour(args: &[&[u8]]) -> Option<Vec3> {
    let vals: Option<Vec<f32>> = args.iter().map(|t| parse_f32(t)).collect();
    let vals = vals?;
    let c = match vals.as_slice() {
        [g] => Vec3::splat(*g),
        [r, g, b] => Vec3::new(*r, *g, *b),
        _ => return None,
    };
    (c.is_finite() && c.min_component() >= 0.0).then_some(c)
}

/// The line without a trailing `# comment`.
pub(crate) fn strip_comment(line: &[u8]) -> &[u8] {
    match line.iter().position(|&b| b == b'#') {
        Some(i) => &line[..i],
        None => line,
    }
}

/// The bytes after `key`, a token of `line` (a sub-slice from `tokens(line)`).
fn rest_bytes<'a>(line: &'a [u8], key: &[u8]) -> &'a [u8] {
    let start = (key.as_ptr() as usize)
        .checked_sub(line.as_ptr() as usize)
        .map(|off| off + key.len())
        .filter(|&end| end <= line.len());
    debug_assert!(start.is_some(), "key is not a token of line");
    &line[start.unwrap_or(line.len())..]
}

/// The text after the keyword, trimmed (names may contain spaces).
pub(crate) fn rest_after_keyword(line: &[u8], key: &[u8]) -> String {
    String::from_utf8_lossy(rest_bytes(line, key))
        .trim()
        .to_string()
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Cursor;

    fn parse(text: &str) -> (Result<Vec<Material>, SceneError>, LoadReport) {
        let mut r = LoadReport::default();
        let m = parse_mtl(Cursor::new(text.as_bytes()), Path::new("m.mtl"), &mut r);
        (m, r)
    }

    #[test]
    fn kd_and_ke() {
        let (m, r) = parse(
            "# c\nnewmtl White\nKa 1 1 1\nKd 0.8 0.7 0.6\nillum 0\n\nnewmtl Light Source\nKd 15 15 15\nKe 15 15 5\nnewmtl G\nKd 0.5\n",
        );
        let m = m.unwrap();
        assert_eq!(m.len(), 3);
        assert_eq!(m[0].name, "White");
        assert_eq!(m[0].albedo, Vec3::new(0.8, 0.7, 0.6));
        assert_eq!(m[0].emission, Vec3::ZERO);
        assert_eq!(m[1].name, "Light Source");
        assert_eq!(m[1].albedo, Vec3::ONE);
        assert_eq!(m[1].emission, Vec3::new(15.0, 15.0, 5.0));
        assert_eq!(m[2].albedo, Vec3::splat(0.5));
        assert!(r.warnings.iter().any(|w| w.contains("clamped")), "{r:?}");
    }

    #[test]
    fn errors_name_file_and_line() {
        let (m, _) = parse("newmtl a\nKd 0.5 x 0.5\n");
        assert_eq!(
            m.unwrap_err().to_string().split(": ").next(),
            Some("m.mtl:2")
        );
        let (m, _) = parse("Kd 1 1 1\n");
        assert!(m.unwrap_err().to_string().starts_with("m.mtl:1:"));
        let (m, _) = parse("newmtl a\nKd 1 1\n");
        assert!(m.is_err());
        let (m, _) = parse("newmtl a\nKd -1 0 0\n");
        assert!(m.is_err());
        let (m, _) = parse("newmtl\n");
        assert!(m.is_err());
    }

    #[test]
    fn redefinition_keeps_the_later_one() {
        let (m, r) = parse("newmtl a\nKd 0.1 0.1 0.1\nnewmtl a\nKd 0.2 0.2 0.2\n");
        let m = m.unwrap();
        assert_eq!(m.len(), 1);
        assert_eq!(m[0].albedo, Vec3::splat(0.2));
        assert_eq!(r.warnings.len(), 1);
    }
}
