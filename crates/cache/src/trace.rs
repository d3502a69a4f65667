//! Address traces for `rtsim cache`, and replaying them.
//!
//! Format, one access per line: `<R|W> <hex address> [cycle [l1]]`. `R`/`W` are
//! case-insensitive (`READ`/`WRITE`, `LOAD`/`STORE` too); the address is hex with or without
//! `0x`; `cycle` (decimal) is when the access is issued, nondecreasing, default the previous
//! access's cycle + 1 (the first at 0); `l1` (decimal) picks the L1, default 0. Blank lines and
//! everything after `#` are ignored. Errors name the file and line.
//!
//! [`replay_timed`] issues the accesses in order like one in-order requester that never waits
//! for data: an access is offered at its cycle, and when refused (bank conflict, MSHRs or write
//! buffer full) it is offered again at the refusal's retry cycle, later accesses waiting behind
//! it (stall cycles are reported).

use crate::functional::FunctionalHierarchy;
use crate::timed::{Completion, Hierarchy, HierarchyError, Outcome, Request};
use rtsim_core::text::{Line, echo, line_too_long, read_line_bounded, utf8};
use rtsim_core::{MemOp, MemoryPort};
use std::io::BufRead;
use std::path::{Path, PathBuf};

/// One access of a trace.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TraceAccess {
    pub op: MemOp,
    pub addr: u64,
    pub cycle: u64,
    pub l1: usize,
}

/// A trace that cannot be read: the file, the line, and what is wrong with it.
pub type TraceError = rtsim_core::FileError;

/// Reads a trace line by line.
#[derive(Debug)]
pub struct TraceReader<R> {
    input: R,
    path: PathBuf,
    line_no: u64,
    buf: Vec<u8>,
    next_cycle: u64,
}

/// Longest trace line accepted (assumed: 4 KiB; a real line is under 64 bytes, and a file
/// without line breaks must fail fast rather than fill memory).
pub const MAX_TRACE_LINE_BYTES: usize = 4096;

impl<R: BufRead> TraceReader<R> {
    pub fn new(input: R, path: &Path) -> Self {
        TraceReader {
            input,
            path: path.to_path_buf(),
            line_no: 0,
            buf: Vec::new(),
            next_cycle: 0,
        }
    }

    fn err(&self, message: String) -> TraceError {
        TraceError::at(&self.path, self.line_no, message)
    }

    fn parse(&mut self) -> Result<Option<TraceAccess>, TraceError> {
        let text = utf8(&self.buf).map_err(|m| self.err(m))?;
        let text = text.split('#').next().unwrap_or_default().trim();
        if text.is_empty() {
            return Ok(None);
        }
        let mut f = text.split_whitespace();
        let op = match f.next().unwrap_or_default().to_ascii_uppercase().as_str() {
            "R" | "READ" | "LOAD" => MemOp::Read,
            "W" | "WRITE" | "STORE" => MemOp::Write,
            other => return Err(self.err(format!("expected R or W, found `{}`", echo(other)))),
        };
        let a = f
            .next()
            .ok_or_else(|| self.err("missing address after the operation".into()))?;
        let hex = a
            .strip_prefix("0x")
            .or_else(|| a.strip_prefix("0X"))
            .unwrap_or(a);
        let addr = u64::from_str_radix(hex, 16)
            .map_err(|_| self.err(format!("`{}` is not a hexadecimal address", echo(a))))?;
        let cycle = match f.next() {
            Some(c) => {
                let c: u64 = c
                    .parse()
                    .map_err(|_| self.err(format!("`{}` is not a decimal cycle", echo(c))))?;
                if c > 1 << 48 {
                    return Err(self.err(format!("cycle {c} is beyond 2^48")));
                }
                if c + 1 < self.next_cycle {
                    return Err(self.err(format!(
                        "cycle {c} is before the previous access's cycle {} (cycles must not \
                         decrease)",
                        self.next_cycle - 1
                    )));
                }
                c
            }
            None => self.next_cycle,
        };
        let l1 = match f.next() {
            Some(l) => l
                .parse()
                .map_err(|_| self.err(format!("`{}` is not an L1 index", echo(l))))?,
            None => 0,
        };
        if let Some(extra) = f.next() {
            return Err(self.err(format!(
                "unexpected `{}`: a line is `R|W <hex addr> [cycle [l1]]`",
                echo(extra)
            )));
        }
        self.next_cycle = cycle + 1;
        Ok(Some(TraceAccess {
            op,
            addr,
            cycle,
            l1,
        }))
    }
}

impl<R: BufRead> Iterator for TraceReader<R> {
    type Item = Result<TraceAccess, TraceError>;
    fn next(&mut self) -> Option<Self::Item> {
        loop {
            self.buf.clear();
            self.line_no += 1;
            match read_line_bounded(&mut self.input, &mut self.buf, MAX_TRACE_LINE_BYTES) {
                Ok(Line::Eof) => return None,
                Ok(Line::Read(_)) => {}
                Ok(Line::TooLong) => {
                    return Some(Err(self.err(line_too_long(MAX_TRACE_LINE_BYTES))));
                }
                Err(e) => return Some(Err(self.err(format!("read error: {e}")))),
            }
            match self.parse() {
                Ok(None) => continue,
                Ok(Some(a)) => return Some(Ok(a)),
                Err(e) => return Some(Err(e)),
            }
        }
    }
}

/// Errors of a replay: the trace's or the hierarchy's.
#[derive(Debug, thiserror::Error)]
pub enum ReplayError {
    #[error(transparent)]
    Trace(#[from] TraceError),
    #[error(transparent)]
    Hierarchy(#[from] HierarchyError),
    #[error("{path}:{line}: L1 {l1} does not exist; the hierarchy has {count} (0..{count})")]
    NoSuchL1 {
        path: PathBuf,
        line: u64,
        l1: usize,
        count: usize,
    },
}

/// What a replay did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ReplaySummary {
    pub accesses: u64,
    pub reads: u64,
    pub writes: u64,
    /// Cycles accesses waited beyond their trace cycle (refusals).
    pub stall_cycles: u64,
    /// Refused offers.
    pub refusals: u64,
    /// Cycle the last access's data was ready (timed).
    pub end_cycle: u64,
}

fn count(s: &mut ReplaySummary, op: MemOp) {
    s.accesses += 1;
    match op {
        MemOp::Read => s.reads += 1,
        MemOp::Write => s.writes += 1,
    }
}

fn check_l1(path: &Path, line: u64, l1: usize, count: usize) -> Result<(), ReplayError> {
    if l1 >= count {
        return Err(ReplayError::NoSuchL1 {
            path: path.to_path_buf(),
            line,
            l1,
            count,
        });
    }
    Ok(())
}

/// Replay a trace through a functional hierarchy. `on_access` sees the running count.
pub fn replay_functional<R: BufRead>(
    h: &mut FunctionalHierarchy,
    mut trace: TraceReader<R>,
    mut on_access: impl FnMut(u64),
) -> Result<ReplaySummary, ReplayError> {
    let mut s = ReplaySummary::default();
    let leaves = h.topology().leaves().len();
    while let Some(a) = trace.next() {
        let a = a?;
        check_l1(&trace.path, trace.line_no, a.l1, leaves)?;
        h.access(a.l1, a.addr, a.op);
        count(&mut s, a.op);
        if s.accesses % 65_536 == 0 {
            on_access(s.accesses);
        }
    }
    Ok(s)
}

/// Replay a trace through a timed hierarchy (see the module docs) and run it dry.
pub fn replay_timed<R: BufRead, M: MemoryPort>(
    h: &mut Hierarchy<M>,
    mut trace: TraceReader<R>,
    mut on_access: impl FnMut(u64),
) -> Result<ReplaySummary, ReplayError> {
    let mut s = ReplaySummary::default();
    let leaves = h.topology().leaves().len();
    let mut done: Vec<Completion> = Vec::new();
    let mut t = 0u64;
    let mut tag = 0u64;
    while let Some(a) = trace.next() {
        let a = a?;
        check_l1(&trace.path, trace.line_no, a.l1, leaves)?;
        t = t.max(a.cycle);
        loop {
            let r = Request {
                cycle: t,
                l1: a.l1,
                addr: a.addr,
                op: a.op,
                tag,
            };
            match h.submit(r)? {
                Outcome::Done { ready, .. } => {
                    s.end_cycle = s.end_cycle.max(ready);
                    break;
                }
                Outcome::Pending => break,
                Outcome::Busy { retry_at, .. } => {
                    s.refusals += 1;
                    t = retry_at;
                }
            }
        }
        s.stall_cycles += t - a.cycle;
        tag += 1;
        count(&mut s, a.op);
        if s.accesses % 65_536 == 0 {
            on_access(s.accesses);
        }
        h.drain_completions(&mut done);
        for c in done.drain(..) {
            s.end_cycle = s.end_cycle.max(c.ready);
        }
    }
    h.drain()?;
    h.drain_completions(&mut done);
    for c in done.drain(..) {
        s.end_cycle = s.end_cycle.max(c.ready);
    }
    Ok(s)
}
