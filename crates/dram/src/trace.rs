//! Request traces: three text formats and synthetic generators.
//!
//! | format     | line                          | time                                           |
//! |------------|-------------------------------|------------------------------------------------|
//! | `rtsim`    | `<cycle> <R\|W> <hex addr>`    | arrival cycle, requester clock, non-decreasing |
//! | `dramsim3` | `<hex addr> <READ\|WRITE> <cycle>` | arrival at the controller in *memory* cycles (as DRAMsim3), non-decreasing |
//! | `usimm`    | `<gap> <R\|W> <hex addr> [pc]`  | requester cycles since the previous request   |
//!
//! Blank lines and lines starting with `#` are skipped; hex addresses may have a `0x` prefix;
//! operations are case-insensitive and `R`/`READ`/`RD`, `W`/`WRITE`/`WR` are all accepted.
//! A malformed line is an error naming the file and line.

use rtsim_core::text::{Line, echo, line_too_long, read_line_bounded, utf8};
use rtsim_core::{MemOp, Pcg32};
use std::fmt;
use std::io::BufRead;
use std::path::{Path, PathBuf};

/// When a request arrives.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum When {
    /// At this requester cycle (or memory cycle for DRAMsim3 traces, whose runs set the
    /// requester clock to the memory clock).
    At(u64),
    /// This many requester cycles after the previous request was issued.
    Gap(u64),
}

/// One request of a trace.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TraceRecord {
    pub when: When,
    pub op: MemOp,
    pub addr: u64,
}

/// A trace file format.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TraceFormat {
    Rtsim,
    Dramsim3,
    Usimm,
}

impl TraceFormat {
    pub const NAMES: [&'static str; 3] = ["rtsim", "dramsim3", "usimm"];

    pub fn parse(name: &str) -> Option<TraceFormat> {
        match name {
            "rtsim" => Some(TraceFormat::Rtsim),
            "dramsim3" => Some(TraceFormat::Dramsim3),
            "usimm" => Some(TraceFormat::Usimm),
            _ => None,
        }
    }
}

impl fmt::Display for TraceFormat {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            TraceFormat::Rtsim => "rtsim",
            TraceFormat::Dramsim3 => "dramsim3",
            TraceFormat::Usimm => "usimm",
        })
    }
}

/// A trace that cannot be read: the file, the line, and what is wrong with it.
pub type TraceError = rtsim_core::FileError;

/// What is wrong with one line of a trace.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum LineError {
    #[error("`{0}` is not a hex address")]
    Hex(String),
    #[error("`{0}` is not a hex PC")]
    Pc(String),
    #[error("`{text}` is not a {what} (a non-negative integer)")]
    Integer { text: String, what: &'static str },
    #[error("{what} {value} exceeds the supported {limit}")]
    TooLarge {
        what: &'static str,
        value: u64,
        limit: u64,
    },
    #[error("`{0}` is not an operation (R or W, READ or WRITE)")]
    Op(String),
    #[error("expected `{form}` ({format} format), found {found} field(s)")]
    Fields {
        form: &'static str,
        format: TraceFormat,
        found: usize,
    },
    #[error("arrival cycle {cycle} is earlier than the previous request's {previous}")]
    Backwards { cycle: u64, previous: u64 },
}

fn parse_hex(s: &str) -> Result<u64, LineError> {
    let digits = s
        .strip_prefix("0x")
        .or_else(|| s.strip_prefix("0X"))
        .unwrap_or(s);
    if digits.is_empty() {
        return Err(LineError::Hex(echo(s)));
    }
    u64::from_str_radix(digits, 16).map_err(|_| LineError::Hex(echo(s)))
}

/// Largest arrival cycle a trace may give (2^48: ~3 days at 1 GHz), keeping all time
/// arithmetic far from overflow.
pub const MAX_TRACE_CYCLE: u64 = 1 << 48;
/// Largest gap one USIMM line may give.
pub const MAX_TRACE_GAP: u64 = 1 << 32;

fn parse_dec(s: &str, what: &'static str, limit: u64) -> Result<u64, LineError> {
    let v = s.parse::<u64>().map_err(|_| LineError::Integer {
        text: echo(s),
        what,
    })?;
    if v > limit {
        return Err(LineError::TooLarge {
            what,
            value: v,
            limit,
        });
    }
    Ok(v)
}

fn parse_op(s: &str) -> Result<MemOp, LineError> {
    match s.to_ascii_uppercase().as_str() {
        "R" | "READ" | "RD" => Ok(MemOp::Read),
        "W" | "WRITE" | "WR" => Ok(MemOp::Write),
        _ => Err(LineError::Op(echo(s))),
    }
}

/// Parse one line; `Ok(None)` for blank and comment lines.
pub fn parse_line(format: TraceFormat, line: &str) -> Result<Option<TraceRecord>, LineError> {
    let line = line.trim();
    if line.is_empty() || line.starts_with('#') {
        return Ok(None);
    }
    let f: Vec<&str> = line.split_ascii_whitespace().collect();
    let expect = |n: &[usize], form: &'static str| {
        if n.contains(&f.len()) {
            Ok(())
        } else {
            Err(LineError::Fields {
                form,
                format,
                found: f.len(),
            })
        }
    };
    let rec = match format {
        TraceFormat::Rtsim => {
            expect(&[3], "<cycle> <R|W> <hex addr>")?;
            TraceRecord {
                when: When::At(parse_dec(f[0], "cycle", MAX_TRACE_CYCLE)?),
                op: parse_op(f[1])?,
                addr: parse_hex(f[2])?,
            }
        }
        TraceFormat::Dramsim3 => {
            expect(&[3], "<hex addr> <READ|WRITE> <cycle>")?;
            TraceRecord {
                when: When::At(parse_dec(f[2], "cycle", MAX_TRACE_CYCLE)?),
                op: parse_op(f[1])?,
                addr: parse_hex(f[0])?,
            }
        }
        TraceFormat::Usimm => {
            expect(&[3, 4], "<gap> <R|W> <hex addr> [pc]")?;
            if f.len() == 4 {
                parse_hex(f[3]).map_err(|_| LineError::Pc(echo(f[3])))?;
            }
            TraceRecord {
                when: When::Gap(parse_dec(f[0], "gap", MAX_TRACE_GAP)?),
                op: parse_op(f[1])?,
                addr: parse_hex(f[2])?,
            }
        }
    };
    Ok(Some(rec))
}

/// Reads a trace file record by record (no whole-file buffering).
pub struct TraceReader<R> {
    reader: R,
    path: PathBuf,
    format: TraceFormat,
    line_no: u64,
    buf: Vec<u8>,
    last_at: u64,
}

/// Longest trace line accepted (assumed: 4 KiB; a real line is under 64 bytes, and a file
/// without line breaks — `/dev/zero` — must fail fast rather than fill memory).
pub const MAX_TRACE_LINE_BYTES: usize = 4096;

impl<R> fmt::Debug for TraceReader<R> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("TraceReader")
            .field("path", &self.path)
            .field("format", &self.format)
            .field("line", &self.line_no)
            .finish()
    }
}

impl TraceReader<std::io::BufReader<std::fs::File>> {
    /// Open a trace file.
    pub fn open(path: &Path, format: TraceFormat) -> Result<Self, TraceError> {
        let file = std::fs::File::open(path).map_err(|source| TraceError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        Ok(TraceReader::new(
            std::io::BufReader::with_capacity(1 << 16, file),
            path,
            format,
        ))
    }
}

impl<R: BufRead> TraceReader<R> {
    /// Read a trace from any buffered reader; `path` names it in errors.
    pub fn new(reader: R, path: &Path, format: TraceFormat) -> Self {
        TraceReader {
            reader,
            path: path.to_path_buf(),
            format,
            line_no: 0,
            buf: Vec::new(),
            last_at: 0,
        }
    }
}

impl<R: BufRead> Iterator for TraceReader<R> {
    type Item = Result<TraceRecord, TraceError>;

    fn next(&mut self) -> Option<Self::Item> {
        loop {
            self.buf.clear();
            self.line_no += 1;
            let at = |m: String| Some(Err(TraceError::at(&self.path, self.line_no, m)));
            match read_line_bounded(&mut self.reader, &mut self.buf, MAX_TRACE_LINE_BYTES) {
                Ok(Line::Eof) => return None,
                Ok(Line::Read(_)) => {}
                Ok(Line::TooLong) => return at(line_too_long(MAX_TRACE_LINE_BYTES)),
                Err(e) => return at(format!("read error: {e}")),
            }
            let text = match utf8(&self.buf) {
                Ok(t) => t,
                Err(m) => return at(m),
            };
            let parsed = parse_line(self.format, text).and_then(|r| match r {
                Some(TraceRecord {
                    when: When::At(t), ..
                }) if t < self.last_at => Err(LineError::Backwards {
                    cycle: t,
                    previous: self.last_at,
                }),
                Some(rec) => {
                    if let When::At(t) = rec.when {
                        self.last_at = t;
                    }
                    Ok(Some(rec))
                }
                None => Ok(None),
            });
            match parsed {
                Ok(Some(rec)) => return Some(Ok(rec)),
                Ok(None) => continue,
                Err(e) => return Some(Err(TraceError::at(&self.path, self.line_no, e))),
            }
        }
    }
}

/// Synthetic access patterns.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Pattern {
    /// Consecutive lines from address 0 (wrapping at the capacity).
    Stream,
    /// Uniformly random lines over the whole capacity.
    Random,
    /// Addresses `i × stride` bytes (wrapping at the capacity).
    Strided { stride: u64 },
}

impl Pattern {
    pub const NAMES: [&'static str; 3] = ["stream", "random", "strided"];
}

/// A seeded generator of `requests` requests, each a read with probability `read_ratio`, issued
/// `interval` requester cycles apart (0: as fast as the queues accept them).
#[derive(Clone, Debug)]
pub struct Synthetic {
    pattern: Pattern,
    remaining: u64,
    read_ratio: f64,
    interval: u64,
    line_bytes: u64,
    capacity_mask: u64,
    i: u64,
    rng: Pcg32,
}

impl Synthetic {
    /// `capacity` must be a power of two (the DRAM's capacity in bytes).
    pub fn new(
        pattern: Pattern,
        requests: u64,
        read_ratio: f64,
        interval: u64,
        line_bytes: u64,
        capacity: u64,
        seed: u64,
    ) -> Self {
        debug_assert!(capacity.is_power_of_two());
        Synthetic {
            pattern,
            remaining: requests,
            read_ratio,
            interval,
            line_bytes,
            capacity_mask: capacity - 1,
            i: 0,
            rng: Pcg32::new(seed, 0xd7a3),
        }
    }
}

impl Iterator for Synthetic {
    type Item = TraceRecord;

    #[inline]
    fn next(&mut self) -> Option<TraceRecord> {
        if self.remaining == 0 {
            return None;
        }
        self.remaining -= 1;
        let addr = match self.pattern {
            Pattern::Stream => self.i.wrapping_mul(self.line_bytes),
            Pattern::Random => self.rng.next_u64(),
            Pattern::Strided { stride } => self.i.wrapping_mul(stride),
        } & self.capacity_mask
            & !(self.line_bytes - 1);
        self.i += 1;
        let op = if self.read_ratio >= 1.0 || self.rng.next_f64() < self.read_ratio {
            MemOp::Read
        } else {
            MemOp::Write
        };
        Some(TraceRecord {
            when: When::Gap(if self.i == 1 { 0 } else { self.interval }),
            op,
            addr,
        })
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        let n = usize::try_from(self.remaining).unwrap_or(usize::MAX);
        (n, Some(n))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_the_three_formats() {
        assert_eq!(
            parse_line(TraceFormat::Rtsim, "12 R 0x1f40").unwrap(),
            Some(TraceRecord {
                when: When::At(12),
                op: MemOp::Read,
                addr: 0x1f40
            })
        );
        assert_eq!(
            parse_line(TraceFormat::Dramsim3, "0x12345680 WRITE 121").unwrap(),
            Some(TraceRecord {
                when: When::At(121),
                op: MemOp::Write,
                addr: 0x1234_5680
            })
        );
        assert_eq!(
            parse_line(TraceFormat::Usimm, "3 R 0x7f64768a7900 0x400a5c").unwrap(),
            Some(TraceRecord {
                when: When::Gap(3),
                op: MemOp::Read,
                addr: 0x7f64_768a_7900
            })
        );
        assert_eq!(
            parse_line(TraceFormat::Usimm, "0 W 7f64768a7940").unwrap(),
            Some(TraceRecord {
                when: When::Gap(0),
                op: MemOp::Write,
                addr: 0x7f64_768a_7940
            })
        );
        assert_eq!(parse_line(TraceFormat::Rtsim, "  # comment").unwrap(), None);
        assert_eq!(parse_line(TraceFormat::Rtsim, "").unwrap(), None);
    }

    #[test]
    fn malformed_lines_say_why() {
        for (fmt, line, needle) in [
            (TraceFormat::Rtsim, "12 X 0x40", "operation"),
            (TraceFormat::Rtsim, "12 R 0xzz", "hex"),
            (TraceFormat::Rtsim, "-1 R 0x40", "cycle"),
            (TraceFormat::Rtsim, "12 R", "field"),
            (TraceFormat::Dramsim3, "0x40 READ", "field"),
            (TraceFormat::Usimm, "1 R 0x40 0x1 extra", "field"),
            (TraceFormat::Usimm, "1 R 0x40 pc", "PC"),
            (TraceFormat::Usimm, "9999999999999 R 0x40", "exceeds"),
            (TraceFormat::Rtsim, "999999999999999999 R 0x40", "exceeds"),
        ] {
            let e = parse_line(fmt, line).unwrap_err().to_string();
            assert!(e.contains(needle), "{line}: {e}");
        }
    }

    #[test]
    fn reader_names_file_and_line() {
        let text = "0 R 0x0\n# c\n\n5 W 0x40\n3 R 0x80\n";
        let mut r = TraceReader::new(text.as_bytes(), Path::new("t.trc"), TraceFormat::Rtsim);
        assert!(r.next().unwrap().is_ok());
        assert!(r.next().unwrap().is_ok());
        let e = r.next().unwrap().unwrap_err().to_string();
        assert!(e.starts_with("t.trc:5:") && e.contains("earlier"), "{e}");
    }

    #[test]
    fn endless_lines_and_bad_bytes_are_located_errors() {
        let zeros = std::io::BufReader::new(std::io::repeat(0));
        let mut r = TraceReader::new(zeros, Path::new("/dev/zero"), TraceFormat::Rtsim);
        let e = r.next().unwrap().unwrap_err().to_string();
        assert!(
            e.starts_with("/dev/zero:1:") && e.contains("longer than"),
            "{e}"
        );
        let bad = b"0 R 0x0\n1 R \xff\n";
        let mut r = TraceReader::new(&bad[..], Path::new("t"), TraceFormat::Rtsim);
        assert!(r.next().unwrap().is_ok());
        let e = r.next().unwrap().unwrap_err().to_string();
        assert!(
            e.starts_with("t:2:") && e.contains("UTF-8") && e.contains("column 5"),
            "{e}"
        );
        let e = parse_line(
            TraceFormat::Rtsim,
            &format!("1 R 0x{}\u{1b}", "f".repeat(10_000)),
        )
        .unwrap_err()
        .to_string();
        assert!(e.len() < 200 && !e.contains('\u{1b}'), "{e}");
    }

    #[test]
    fn synthetic_is_deterministic_and_in_range() {
        let a: Vec<_> = Synthetic::new(Pattern::Random, 100, 0.7, 0, 64, 1 << 20, 9).collect();
        let b: Vec<_> = Synthetic::new(Pattern::Random, 100, 0.7, 0, 64, 1 << 20, 9).collect();
        assert_eq!(a, b);
        assert!(a.iter().all(|r| r.addr < (1 << 20) && r.addr % 64 == 0));
        let reads = a.iter().filter(|r| r.op == MemOp::Read).count();
        assert!((50..=90).contains(&reads), "{reads}");
        let s: Vec<u64> = Synthetic::new(Pattern::Stream, 4, 1.0, 0, 64, 1 << 20, 1)
            .map(|r| r.addr)
            .collect();
        assert_eq!(s, [0, 64, 128, 192]);
        let s: Vec<u64> =
            Synthetic::new(Pattern::Strided { stride: 8192 }, 3, 1.0, 0, 64, 1 << 20, 1)
                .map(|r| r.addr)
                .collect();
        assert_eq!(s, [0, 8192, 16384]);
    }
}
