//! The triangle file `rtsim export-triangles` writes (`tris.bin`).
//!
//! Little-endian: a `u64` triangle count n, then n × 9 `f32` — vertex 0 xyz, vertex 1 xyz,
//! vertex 2 xyz — in scene order, the order of the triangle indices in `hits.bin`. An external
//! ray caster that reads it rebuilds exactly the geometry rtsim traces.

use crate::Triangle;
use rtsim_core::Vec3;
use rtsim_core::output::AtomicFile;
use std::io::{self, Write};
use std::path::Path;

/// Bytes per triangle record.
pub const TRIANGLE_BYTES: usize = 9 * 4;

/// Write `triangles` to `w` in the `tris.bin` layout.
pub fn write_triangles<W: Write>(mut w: W, triangles: &[Triangle]) -> io::Result<()> {
    w.write_all(&(triangles.len() as u64).to_le_bytes())?;
    // Encode in blocks so a 2.9 M-triangle scene does not need a second 100 MB buffer.
    let mut buf = Vec::with_capacity(4096 * TRIANGLE_BYTES);
    for block in triangles.chunks(4096) {
        buf.clear();
        for t in block {
            for v in t {
                for c in v.to_array() {
                    buf.extend_from_slice(&c.to_le_bytes());
                }
            }
        }
        w.write_all(&buf)?;
    }
    Ok(())
}

/// Write `triangles` to the file `path` atomically (it appears complete or not at all).
pub fn write_triangles_file(path: &Path, triangles: &[Triangle]) -> io::Result<()> {
    let mut f = AtomicFile::create(path)?;
    write_triangles(&mut f, triangles)?;
    f.commit()
}

/// A `tris.bin` image that cannot be decoded.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum TrisError {
    #[error("shorter than the 8-byte triangle count")]
    Short,
    #[error("count {count} needs {needed} bytes of triangles, the file has {got}")]
    Length {
        count: u64,
        needed: u128,
        got: usize,
    },
}

/// Decode a `tris.bin` image; the error says what is wrong with it.
pub fn read_triangles(bytes: &[u8]) -> Result<Vec<Triangle>, TrisError> {
    let (head, body) = bytes.split_at_checked(8).ok_or(TrisError::Short)?;
    let n = u64::from_le_bytes(head.try_into().expect("8 bytes"));
    if n.checked_mul(TRIANGLE_BYTES as u64) != Some(body.len() as u64) {
        return Err(TrisError::Length {
            count: n,
            needed: n as u128 * TRIANGLE_BYTES as u128,
            got: body.len(),
        });
    }
    let f = |b: &[u8]| f32::from_le_bytes(b.try_into().expect("4 bytes"));
    Ok(body
        .chunks_exact(TRIANGLE_BYTES)
        .map(|r| {
            let v = |i: usize| {
                Vec3::new(
                    f(&r[12 * i..12 * i + 4]),
                    f(&r[12 * i + 4..12 * i + 8]),
                    f(&r[12 * i + 8..12 * i + 12]),
                )
            };
            [v(0), v(1), v(2)]
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn layout_is_count_then_nine_floats() {
        let t = [
            Vec3::new(1.0, 2.0, 3.0),
            Vec3::new(4.0, 5.0, 6.0),
            Vec3::new(7.0, 8.0, -0.5),
        ];
        let mut out = Vec::new();
        write_triangles(&mut out, &[t, t]).unwrap();
        assert_eq!(out.len(), 8 + 2 * TRIANGLE_BYTES);
        assert_eq!(&out[..8], &2u64.to_le_bytes());
        assert_eq!(&out[8..12], &1.0f32.to_le_bytes());
        assert_eq!(&out[8 + 32..8 + 36], &(-0.5f32).to_le_bytes());
        assert_eq!(read_triangles(&out).unwrap(), vec![t, t]);
    }

    #[test]
    fn round_trip_through_a_file_of_many_blocks() {
        let tris: Vec<Triangle> = (0..10_000)
            .map(|i| {
                let x = i as f32;
                [
                    Vec3::new(x, 0.0, 0.0),
                    Vec3::new(x, 1.0, 0.0),
                    Vec3::new(x, 0.0, 1.0),
                ]
            })
            .collect();
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("t.bin");
        write_triangles_file(&p, &tris).unwrap();
        assert_eq!(read_triangles(&std::fs::read(&p).unwrap()).unwrap(), tris);
    }

    #[test]
    fn malformed_images_are_rejected() {
        assert!(read_triangles(&[0; 4]).is_err());
        let mut b = 1u64.to_le_bytes().to_vec();
        b.extend_from_slice(&[0; 35]);
        assert!(
            read_triangles(&b)
                .unwrap_err()
                .to_string()
                .contains("36 bytes")
        );
        assert!(read_triangles(&u64::MAX.to_le_bytes()).is_err());
        assert!(read_triangles(&0u64.to_le_bytes()).unwrap().is_empty());
    }
}
