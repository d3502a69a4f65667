//! The ray-query file formats of `rtsim trace` (all little-endian):
//!
//! - `rays.bin`: `u64` ray count, then per ray 8 `f32`: origin x y z, direction x y z, tmin,
//!   tmax. `tmax` may be +infinity; directions need not be normalised (t is in their units).
//! - `hits.bin`: per ray, `f32` t, `i32` triangle index (scene order, as written by
//!   `rtsim export-triangles`; -1 for a miss), `f32` u, `f32` v. A miss writes t = +infinity
//!   and u = v = 0.
//!
//! Rays with a non-finite origin, direction or tmin, or a NaN tmax, are errors naming the ray.
//! A zero direction or an empty interval (tmin > tmax) is a valid query that misses.
//! Files are read and written in chunks, so ray files larger than memory work.

use crate::tracer::Hit;
use rtsim_core::output::AtomicFile;
use rtsim_core::{Ray, Vec3};
use std::fs::File;
use std::io::{self, BufReader, Read, Write};
use std::path::{Path, PathBuf};

/// Bytes per ray record.
pub const RAY_BYTES: u64 = 32;
/// Bytes per hit record.
pub const HIT_BYTES: usize = 16;

#[derive(Debug, thiserror::Error)]
pub enum QueryError {
    #[error("{path}: {source}")]
    Io { path: PathBuf, source: io::Error },
    #[error("{path}: {message}")]
    Format { path: PathBuf, message: String },
    #[error("{path}: ray {index}: {message}")]
    BadRay {
        path: PathBuf,
        index: u64,
        message: String,
    },
}

/// A streaming reader of `rays.bin`.
pub struct RayReader {
    path: PathBuf,
    reader: Box<dyn Read + Send>,
    count: u64,
    next: u64,
    buf: Vec<u8>,
}

impl std::fmt::Debug for RayReader {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RayReader")
            .field("path", &self.path)
            .field("count", &self.count)
            .field("next", &self.next)
            .finish_non_exhaustive()
    }
}

impl RayReader {
    /// Open and check the header against the file length.
    pub fn open(path: &Path) -> Result<Self, QueryError> {
        let io_err = |source| QueryError::Io {
            path: path.to_path_buf(),
            source,
        };
        // Checked before opening: a FIFO would wait for a writer and has no length.
        let meta = std::fs::metadata(path).map_err(io_err)?;
        if !meta.is_file() {
            return Err(QueryError::Format {
                path: path.into(),
                message: format!(
                    "is {}, not a rays file",
                    rtsim_core::error::describe_file_type(&meta.file_type())
                ),
            });
        }
        let file = File::open(path).map_err(io_err)?;
        let len = file.metadata().map_err(io_err)?.len();
        Self::from_reader(Box::new(BufReader::with_capacity(1 << 20, file)), len, path)
    }

    /// Read rays from memory (`path` names them in errors).
    pub fn from_bytes(bytes: Vec<u8>, path: &Path) -> Result<Self, QueryError> {
        let len = bytes.len() as u64;
        Self::from_reader(Box::new(io::Cursor::new(bytes)), len, path)
    }

    /// Read `len` bytes of `rays.bin` from `reader`, checking the header against `len`.
    pub fn from_reader(
        mut reader: Box<dyn Read + Send>,
        len: u64,
        path: &Path,
    ) -> Result<Self, QueryError> {
        let io_err = |source| QueryError::Io {
            path: path.to_path_buf(),
            source,
        };
        let mut head = [0u8; 8];
        if len < 8 {
            return Err(QueryError::Format {
                path: path.into(),
                message: format!("truncated: {len} bytes, the header alone is 8"),
            });
        }
        reader.read_exact(&mut head).map_err(io_err)?;
        let count = u64::from_le_bytes(head);
        let expected = count.checked_mul(RAY_BYTES).and_then(|b| b.checked_add(8));
        if expected != Some(len) {
            return Err(QueryError::Format {
                path: path.into(),
                message: format!(
                    "header says {count} rays ({} bytes expected) but the file has {len} bytes",
                    expected.map_or_else(|| "too many".to_string(), |e| e.to_string())
                ),
            });
        }
        Ok(RayReader {
            path: path.into(),
            reader,
            count,
            next: 0,
            buf: Vec::new(),
        })
    }

    pub fn count(&self) -> u64 {
        self.count
    }

    /// Read up to `max` rays into `out` (cleared first); returns how many were read.
    pub fn read_chunk(&mut self, max: usize, out: &mut Vec<Ray>) -> Result<usize, QueryError> {
        out.clear();
        let n = (self.count - self.next).min(max as u64) as usize;
        self.buf.resize(n * RAY_BYTES as usize, 0);
        self.reader
            .read_exact(&mut self.buf)
            .map_err(|source| QueryError::Io {
                path: self.path.clone(),
                source,
            })?;
        for (i, rec) in self.buf.chunks_exact(RAY_BYTES as usize).enumerate() {
            let f =
                |k: usize| f32::from_le_bytes(rec[4 * k..4 * k + 4].try_into().expect("4 bytes"));
            let ray = Ray::new(
                Vec3::new(f(0), f(1), f(2)),
                Vec3::new(f(3), f(4), f(5)),
                f(6),
                f(7),
            );
            let index = self.next + i as u64;
            let bad = |message: &str| QueryError::BadRay {
                path: self.path.clone(),
                index,
                message: message.into(),
            };
            if !ray.origin.is_finite() {
                return Err(bad("origin is not finite"));
            }
            if !ray.direction.is_finite() {
                return Err(bad("direction is not finite"));
            }
            if !ray.tmin.is_finite() {
                return Err(bad("tmin is not finite"));
            }
            if ray.tmax.is_nan() {
                return Err(bad("tmax is NaN"));
            }
            out.push(ray);
        }
        self.next += n as u64;
        Ok(n)
    }
}

/// Whether a ray can hit anything at all (a zero direction or empty interval cannot).
#[inline]
pub fn is_traceable(ray: &Ray) -> bool {
    ray.direction.length_squared() > 0.0 && ray.tmin <= ray.tmax
}

/// Encode hits as `hits.bin` records.
pub fn encode_hits(hits: &[Hit], out: &mut Vec<u8>) {
    out.reserve(hits.len() * HIT_BYTES);
    for h in hits {
        let (t, id, u, v) = if h.is_hit() {
            (h.t, h.prim as i32, h.u, h.v)
        } else {
            (f32::INFINITY, -1, 0.0, 0.0)
        };
        out.extend_from_slice(&t.to_le_bytes());
        out.extend_from_slice(&id.to_le_bytes());
        out.extend_from_slice(&u.to_le_bytes());
        out.extend_from_slice(&v.to_le_bytes());
    }
}

/// Encode `rays` in the `rays.bin` layout into `w`.
pub fn encode_rays<W: Write>(mut w: W, rays: &[Ray]) -> io::Result<()> {
    w.write_all(&(rays.len() as u64).to_le_bytes())?;
    let mut buf = Vec::with_capacity(rays.len().min(1 << 16) * RAY_BYTES as usize);
    for chunk in rays.chunks(1 << 16) {
        buf.clear();
        for r in chunk {
            for v in [
                r.origin.x,
                r.origin.y,
                r.origin.z,
                r.direction.x,
                r.direction.y,
                r.direction.z,
                r.tmin,
                r.tmax,
            ] {
                buf.extend_from_slice(&v.to_le_bytes());
            }
        }
        w.write_all(&buf)?;
    }
    Ok(())
}

/// Write `rays.bin` atomically.
pub fn write_rays(path: &Path, rays: &[Ray]) -> io::Result<()> {
    let mut f = AtomicFile::create(path)?;
    encode_rays(&mut f, rays)?;
    f.commit()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tracer::NO_HIT;

    #[test]
    fn rays_round_trip_in_chunks() {
        let dir = std::env::temp_dir().join(format!("rtsim-query-{}", std::process::id()));
        let p = dir.join("rays.bin");
        let rays: Vec<Ray> = (0..10)
            .map(|i| {
                Ray::new(
                    Vec3::splat(i as f32),
                    Vec3::new(0.0, 1.0, 0.0),
                    0.0,
                    f32::INFINITY,
                )
            })
            .collect();
        write_rays(&p, &rays).unwrap();
        let mut r = RayReader::open(&p).unwrap();
        assert_eq!(r.count(), 10);
        let mut all = Vec::new();
        let mut chunk = Vec::new();
        while r.read_chunk(3, &mut chunk).unwrap() > 0 {
            all.extend_from_slice(&chunk);
        }
        assert_eq!(all, rays);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn header_mismatch_and_nan_are_errors() {
        let dir = std::env::temp_dir().join(format!("rtsim-query-bad-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("short.bin");
        let mut bytes = 2u64.to_le_bytes().to_vec();
        bytes.extend_from_slice(&[0u8; 40]);
        std::fs::write(&p, &bytes).unwrap();
        let e = RayReader::open(&p).unwrap_err().to_string();
        assert!(
            e.contains("header says 2 rays") && e.contains("short.bin"),
            "{e}"
        );

        let q = dir.join("nan.bin");
        write_rays(
            &q,
            &[Ray::new(Vec3::new(f32::NAN, 0.0, 0.0), Vec3::ONE, 0.0, 1.0)],
        )
        .unwrap();
        let mut r = RayReader::open(&q).unwrap();
        let e = r.read_chunk(10, &mut Vec::new()).unwrap_err().to_string();
        assert!(e.contains("ray 0") && e.contains("origin"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn miss_encoding() {
        let mut out = Vec::new();
        encode_hits(
            &[Hit {
                t: 5.0,
                prim: NO_HIT,
                u: 0.3,
                v: 0.3,
            }],
            &mut out,
        );
        assert_eq!(&out[0..4], &f32::INFINITY.to_le_bytes());
        assert_eq!(&out[4..8], &(-1i32).to_le_bytes());
        assert_eq!(&out[8..16], &[0u8; 8]);
    }
}
