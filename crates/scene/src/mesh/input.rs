//! Opening mesh files, plain or compressed, and reading them line by line.

use super::io_error;
use crate::SceneError;
use rtsim_core::text::{Line, MAX_LINE_BYTES, line_too_long, read_line_bounded};
use std::ffi::OsString;
use std::fs::File;
use std::io::{BufRead, BufReader, Read};
use std::path::Path;

/// Bytes that never occur in a text mesh file: NUL and the C0 controls other than tab, line
/// feed, vertical tab, form feed and carriage return, plus a carriage return left inside a
/// line (CR-only line endings).
fn is_binary(b: u8) -> bool {
    (b < 0x20 && !matches!(b, b'\t' | b'\n' | b'\x0b' | b'\x0c')) || b == 0x7f
}

/// Read buffer for decompressed text: large enough that `read_until` rarely refills
/// (assumed: 1 MiB; the largest staged file, Crytek Sponza, is 26 MB of text).
const READ_BUFFER_BYTES: usize = 1 << 20;

/// How a file is compressed, from its last extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Compression {
    None,
    /// `.zst`, read with the `zstd` crate.
    Zstd,
    /// `.gz`, read with `flate2` (multi-member streams included).
    Gzip,
}

/// The name without its compression extension, and the compression.
pub(crate) fn split_compression(path: &Path) -> (OsString, Compression) {
    let name = path.file_name().map(OsString::from).unwrap_or_default();
    let lower = name.to_string_lossy().to_ascii_lowercase();
    for (ext, c) in [(".zst", Compression::Zstd), (".gz", Compression::Gzip)] {
        if lower.ends_with(ext) {
            let s = name.to_string_lossy();
            return (OsString::from(&s[..s.len() - ext.len()]), c);
        }
    }
    (name, Compression::None)
}

/// Open `path` for buffered reading, decompressing by extension (`.zst`, `.gz`). A
/// directory, device or FIFO is refused with what it is.
pub fn open_decompressed(path: &Path) -> Result<Box<dyn BufRead + Send>, SceneError> {
    // Checked before opening: opening a FIFO would wait for a writer.
    let m = std::fs::metadata(path).map_err(|e| io_error(path, e))?;
    if !m.is_file() {
        let kind = rtsim_core::error::describe_file_type(&m.file_type());
        return Err(io_error(
            path,
            std::io::Error::new(
                std::io::ErrorKind::InvalidInput,
                format!("it is {kind}, not a mesh file"),
            ),
        ));
    }
    let file = File::open(path).map_err(|e| io_error(path, e))?;
    decompress(file, split_compression(path).1).map_err(|e| io_error(path, e))
}

/// `input` decompressed as `compression` says, buffered. Decompression errors read as
/// "corrupt gzip data: …" (or zstd), never as a problem with the text.
pub fn decompress<R: Read + Send + 'static>(
    input: R,
    compression: Compression,
) -> std::io::Result<Box<dyn BufRead + Send>> {
    Ok(match compression {
        Compression::None => Box::new(BufReader::with_capacity(READ_BUFFER_BYTES, input)),
        Compression::Zstd => {
            let dec = zstd::stream::read::Decoder::new(input).map_err(|e| corrupt("zstd", e))?;
            Box::new(BufReader::with_capacity(
                READ_BUFFER_BYTES,
                Decoding {
                    inner: dec,
                    what: "zstd",
                },
            ))
        }
        Compression::Gzip => {
            let dec = flate2::read::MultiGzDecoder::new(BufReader::new(input));
            Box::new(BufReader::with_capacity(
                READ_BUFFER_BYTES,
                Decoding {
                    inner: dec,
                    what: "gzip",
                },
            ))
        }
    })
}

/// A decoder whose errors say they are the compressed stream's.
struct Decoding<R> {
    inner: R,
    what: &'static str,
}

impl<R: Read> Read for Decoding<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        self.inner.read(buf).map_err(|e| corrupt(self.what, e))
    }
}

fn corrupt(what: &str, e: std::io::Error) -> std::io::Error {
    let kind = match e.kind() {
        // A cut stream stays recognisable as one.
        std::io::ErrorKind::UnexpectedEof => std::io::ErrorKind::UnexpectedEof,
        _ => std::io::ErrorKind::InvalidData,
    };
    std::io::Error::new(kind, format!("corrupt {what} data ({e})"))
}

/// Reads a text file one line at a time into a reused buffer, counting lines (1-based).
pub(crate) struct LineReader<'p, R> {
    reader: R,
    path: &'p Path,
    buf: Vec<u8>,
    /// Number of physical lines consumed so far.
    lines_read: u64,
    /// Bytes consumed so far.
    bytes_read: u64,
    /// Join a line ending in `\` with the next one (OBJ's continuation rule).
    continuation: bool,
}

impl<'p, R: BufRead> LineReader<'p, R> {
    pub(crate) fn new(reader: R, path: &'p Path, continuation: bool) -> Self {
        LineReader {
            reader,
            path,
            buf: Vec::with_capacity(256),
            lines_read: 0,
            bytes_read: 0,
            continuation,
        }
    }

    /// The next logical line without its line ending, and the number of its first physical
    /// line; `None` at the end of the file. Lines longer than [`MAX_LINE_BYTES`], binary data
    /// (NUL and other control bytes) and CR-only line endings are errors naming the line.
    pub(crate) fn next_line(&mut self) -> Result<Option<(u64, &[u8])>, SceneError> {
        self.buf.clear();
        let first = self.lines_read + 1;
        loop {
            let start = self.buf.len();
            let line_no = self.lines_read + 1;
            let done = self.lines_read;
            let read = read_line_bounded(&mut self.reader, &mut self.buf, MAX_LINE_BYTES).map_err(
                |e| {
                    if e.kind() == std::io::ErrorKind::InvalidData
                        || e.kind() == std::io::ErrorKind::UnexpectedEof
                    {
                        // The compressed stream's problem, not the text's.
                        rtsim_core::FileError::io(
                            self.path,
                            std::io::Error::new(
                                e.kind(),
                                format!("{e}, after {done} line(s) of text"),
                            ),
                        )
                        .into()
                    } else {
                        super::parse_error(self.path, line_no, format!("read error: {e}"))
                    }
                },
            )?;
            let n = match read {
                Line::Eof => {
                    if start == 0 && self.lines_read + 1 == first {
                        return Ok(None);
                    }
                    break; // a continuation at the very end: take what there is
                }
                Line::TooLong => {
                    return Err(super::parse_error(
                        self.path,
                        line_no,
                        line_too_long(MAX_LINE_BYTES),
                    ));
                }
                Line::Read(n) => n,
            };
            self.lines_read += 1;
            self.bytes_read += n as u64;
            // A UTF-8 byte order mark (some Windows exporters write one) is not content.
            if self.lines_read == 1 && self.buf.starts_with(b"\xEF\xBB\xBF") {
                self.buf.drain(..3);
            }
            if self.buf.last() == Some(&b'\n') {
                self.buf.pop();
            }
            if self.buf.last() == Some(&b'\r') {
                self.buf.pop();
            }
            if let Some(bad) = self.buf[start..].iter().find(|&&b| is_binary(b)) {
                let why = if *bad == b'\r' {
                    "carriage return inside a line: CR-only (classic Mac) line endings are not \
                     supported; convert them to LF"
                        .to_string()
                } else {
                    format!(
                        "binary data (byte 0x{bad:02x}): not a text file, or a binary file with \
                         the wrong extension"
                    )
                };
                return Err(super::parse_error(self.path, line_no, why));
            }
            if self.continuation && self.buf.len() > start && self.buf.last() == Some(&b'\\') {
                self.buf.pop();
                self.buf.push(b' ');
                continue;
            }
            break;
        }
        Ok(Some((first, &self.buf)))
    }

    /// Physical lines consumed so far.
    pub(crate) fn lines_read(&self) -> u64 {
        self.lines_read
    }

    /// Bytes consumed so far (the start of PLY's binary body after the header).
    pub(crate) fn bytes_read(&self) -> u64 {
        self.bytes_read
    }

    /// The underlying reader (for PLY's binary body after the text header).
    pub(crate) fn into_inner(self) -> R {
        self.reader
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::{Cursor, Read, Write};

    fn lines(text: &str, continuation: bool) -> Vec<(u64, String)> {
        let p = Path::new("t.obj");
        let mut r = LineReader::new(Cursor::new(text.as_bytes().to_vec()), p, continuation);
        let mut out = Vec::new();
        while let Some((n, l)) = r.next_line().unwrap() {
            out.push((n, String::from_utf8(l.to_vec()).unwrap()));
        }
        out
    }

    #[test]
    fn line_numbers_and_endings() {
        assert_eq!(
            lines("a\r\nb\n\nc", false),
            vec![
                (1, "a".into()),
                (2, "b".into()),
                (3, "".into()),
                (4, "c".into())
            ]
        );
        assert!(lines("", false).is_empty());
    }

    #[test]
    fn byte_order_mark_is_skipped() {
        assert_eq!(lines("\u{feff}v 1 2 3\nx", false)[0], (1, "v 1 2 3".into()));
    }

    #[test]
    fn continuation_joins_lines_and_keeps_numbering() {
        assert_eq!(
            lines("f 1 2 \\\n 3\nv 1\n", true),
            vec![(1, "f 1 2   3".into()), (3, "v 1".into())]
        );
        // Without continuation support the backslash stays.
        assert_eq!(lines("a\\\nb", false)[0].1, "a\\");
    }

    #[test]
    fn compression_from_name() {
        let (s, c) = split_compression(Path::new("d/x.obj.ZST"));
        assert_eq!((s.to_str().unwrap(), c), ("x.obj", Compression::Zstd));
        let (s, c) = split_compression(Path::new("x.ply.gz"));
        assert_eq!((s.to_str().unwrap(), c), ("x.ply", Compression::Gzip));
        assert_eq!(split_compression(Path::new("x.ply")).1, Compression::None);
    }

    #[test]
    fn reads_zstd_and_gzip() {
        let dir = tempfile::tempdir().unwrap();
        let text = b"hello\nworld\n";
        let zp = dir.path().join("a.txt.zst");
        std::fs::write(&zp, zstd::encode_all(&text[..], 3).unwrap()).unwrap();
        let gp = dir.path().join("a.txt.gz");
        let mut enc = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
        enc.write_all(text).unwrap();
        std::fs::write(&gp, enc.finish().unwrap()).unwrap();
        for p in [zp, gp] {
            let mut s = String::new();
            open_decompressed(&p)
                .unwrap()
                .read_to_string(&mut s)
                .unwrap();
            assert_eq!(s.as_bytes(), text);
        }
    }

    #[test]
    fn truncated_zstd_is_an_error_naming_the_line() {
        let dir = tempfile::tempdir().unwrap();
        let text: String = (0..20000).map(|i| format!("v {i} {i} {i}\n")).collect();
        let z = zstd::encode_all(text.as_bytes(), 3).unwrap();
        let p = dir.path().join("a.obj.zst");
        std::fs::write(&p, &z[..z.len() / 2]).unwrap();
        let mut r = LineReader::new(open_decompressed(&p).unwrap(), &p, false);
        let err = loop {
            match r.next_line() {
                Ok(Some(_)) => continue,
                Ok(None) => panic!("truncated stream read to the end without error"),
                Err(e) => break e.to_string(),
            }
        };
        assert!(
            err.contains("a.obj.zst:") && err.contains("corrupt zstd data"),
            "{err}"
        );
    }

    #[test]
    fn binary_data_and_cr_only_endings_are_named() {
        let p = Path::new("t.obj");
        let err = |bytes: &[u8]| {
            let mut r = LineReader::new(Cursor::new(bytes.to_vec()), p, false);
            loop {
                match r.next_line() {
                    Ok(Some(_)) => continue,
                    Ok(None) => panic!("read to the end"),
                    Err(e) => break e.to_string(),
                }
            }
        };
        let e = err(b"v 1 2 3\rv 4 5 6\r");
        assert!(e.starts_with("t.obj:1:") && e.contains("CR-only"), "{e}");
        let e = err(b"v 1 2 3\n\x89PNG\x00\x01");
        assert!(
            e.starts_with("t.obj:2:") && e.contains("binary data"),
            "{e}"
        );
        let long = vec![b'x'; MAX_LINE_BYTES + 10];
        let e = err(&long);
        assert!(
            e.starts_with("t.obj:1:") && e.contains("longer than"),
            "{e}"
        );
    }

    #[test]
    fn corrupt_gzip_is_a_decompression_error() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a.obj.gz");
        std::fs::write(&p, b"v 0 0 0\nnot gzip at all\n").unwrap();
        let mut r = LineReader::new(open_decompressed(&p).unwrap(), &p, false);
        let e = r.next_line().unwrap_err().to_string();
        assert!(
            e.starts_with(&format!("cannot read {}", p.display())) && e.contains("corrupt gzip"),
            "{e}"
        );
    }

    #[test]
    fn directories_are_not_mesh_files() {
        let dir = tempfile::tempdir().unwrap();
        let e = open_decompressed(dir.path()).err().unwrap().to_string();
        assert!(e.contains("it is a directory, not a mesh file"), "{e}");
    }

    #[test]
    fn missing_file_names_the_path() {
        let e = open_decompressed(Path::new("/nonexistent/x.obj"))
            .err()
            .unwrap()
            .to_string();
        assert!(e.contains("/nonexistent/x.obj:"), "{e}");
    }
}
