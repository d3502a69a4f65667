//! A frame's time series (`sim.timeline_cycles`): what the chip did in each interval of a
//! fixed number of core cycles, for questions a frame's totals cannot answer — when the issue
//! rate falls, how long the STRaTA fill takes, when DRAM traffic peaks.
//!
//! Both engines produce the same rows (tests compare them). A row is exact because every
//! column counts events at the cycle they happen:
//!
//! - instructions are bucketed by their issue cycle (the fast engine books issues ahead, so
//!   it counts them into the interval of the booked cycle, not of the cycle it books at);
//! - everything else is sampled at each interval's first cycle `B`, once the engine has
//!   handled every cycle before `B` and nothing of `B`: the atomic counter's grants, the
//!   caches' and the DRAM's counters (both engines drive the memory system with the same
//!   events), and the source's columns ([`crate::Source::timeline_columns`]), which change
//!   only at accesses.
//!
//! Under a cycle limit the instructions are those issued before it (the report's totals from
//! the fast engine also hold those it booked past the limit, `docs/TRAX.md`). Stall causes
//! are not columns: the fast engine charges a wait's cycles when it ends, not
//! cycle by cycle. The last row ends at the frame's last cycle and also holds what the memory
//! system finished after it (its writes drained).

use rtsim_cache::Hierarchy;
use rtsim_dram::Dram;

/// What a column holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// Events in the interval (the difference of a running count between its ends).
    Count,
    /// A level at the interval's end (the last row's: at the frame's end, after the drain),
    /// or a most-in-the-interval the source resets at each sample.
    Level,
}

/// A column of the time series.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Column {
    pub name: &'static str,
    pub kind: Kind,
}

impl Column {
    pub const fn count(name: &'static str) -> Column {
        Column {
            name,
            kind: Kind::Count,
        }
    }
    pub const fn level(name: &'static str) -> Column {
        Column {
            name,
            kind: Kind::Level,
        }
    }
}

/// The chip's own columns, after `instructions`.
const CHIP: [Column; 9] = [
    Column::count("atomic_grants"),
    Column::count("l1_accesses"),
    Column::count("l1_misses"),
    Column::count("l2_accesses"),
    Column::count("l2_misses"),
    Column::count("dram_reads"),
    Column::count("dram_writes"),
    Column::count("dram_row_hits"),
    Column::count("dram_column_accesses"),
];

/// A finished time series.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Timeline {
    /// Core cycles per interval.
    pub every: u64,
    /// TPs of the chip (for issue rates).
    pub tps: u64,
    /// Column names, `instructions` first.
    pub columns: Vec<Column>,
    /// Per interval: its first cycle, its length (the last may be shorter) and one value per
    /// column.
    pub rows: Vec<Row>,
}

#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Row {
    pub start: u64,
    pub cycles: u64,
    pub values: Vec<u64>,
}

impl Timeline {
    /// The series as CSV: `cycle,cycles,issue_rate,` then every column.
    pub fn to_csv(&self) -> String {
        let mut s = String::from("cycle,cycles,issue_rate");
        for c in &self.columns {
            s.push(',');
            s.push_str(c.name);
        }
        s.push('\n');
        for r in &self.rows {
            let rate = r.values[0] as f64 / (r.cycles * self.tps).max(1) as f64;
            s.push_str(&format!("{},{},{rate:.6}", r.start, r.cycles));
            for v in &r.values {
                s.push_str(&format!(",{v}"));
            }
            s.push('\n');
        }
        s
    }

    /// The values of column `name`, one per row.
    pub fn column(&self, name: &str) -> Option<Vec<u64>> {
        let k = self.columns.iter().position(|c| c.name == name)?;
        Some(self.rows.iter().map(|r| r.values[k]).collect())
    }
}

/// Samples taken while a frame runs; off (`every == 0`) unless asked for.
#[derive(Debug)]
pub(crate) struct Sampler {
    pub(crate) every: u64,
    /// The next interval's first cycle (`u64::MAX` when off).
    pub(crate) next: u64,
    /// Instructions issued, per interval of their issue cycle.
    issued: Vec<u64>,
    /// Issues from this cycle on are not counted (the cycle limit: the fast engine books
    /// instructions past it, which the reference never issues).
    limit: u64,
    /// The running values at each sampled boundary (`every`, `2 × every`, …), columns after
    /// `instructions`, flattened.
    samples: Vec<u64>,
    /// Columns after `instructions`: the chip's, then the source's.
    columns: Vec<Column>,
    pub(crate) atomic_grants: u64,
}

impl Default for Sampler {
    /// Off: no boundary is ever reached.
    fn default() -> Sampler {
        Sampler::new(None, None, &[])
    }
}

impl Sampler {
    /// Sampling every `every` cycles (`None` or 0: off) of a run stopped at `limit`;
    /// `source` are the source's columns.
    pub(crate) fn new(every: Option<u64>, limit: Option<u64>, source: &[Column]) -> Sampler {
        let every = every.unwrap_or(0);
        Sampler {
            every,
            next: if every == 0 { u64::MAX } else { every },
            limit: limit.unwrap_or(u64::MAX),
            columns: CHIP.iter().chain(source).copied().collect(),
            issued: Vec::new(),
            samples: Vec::new(),
            atomic_grants: 0,
        }
    }

    /// An instruction issued at cycle `c` (the fast engine's booking loop calls it only when
    /// the time series is on: it has a copy without the call).
    #[inline(always)]
    pub(crate) fn issue(&mut self, c: u64) {
        if self.every != 0 {
            self.count_issue(c);
        }
    }

    #[cold]
    #[inline(never)]
    fn count_issue(&mut self, c: u64) {
        if c < self.limit {
            let k = (c / self.every) as usize;
            if k >= self.issued.len() {
                self.issued.resize(k + 1, 0);
            }
            self.issued[k] += 1;
        }
    }

    /// Record the boundary `self.next`: the running values now ([`Sampler::running`]).
    pub(crate) fn sample(&mut self, hier: &Hierarchy<Dram>, source: impl FnOnce(&mut Vec<u64>)) {
        let v = self.running(hier, source);
        debug_assert_eq!(v.len(), self.columns.len());
        self.samples.extend_from_slice(&v);
        self.next += self.every;
    }

    /// The series of a frame that ended at cycle `end` (exclusive), with `last` the running
    /// values at the end; samples at boundaries from `end` on are dropped (an engine may have
    /// sampled a little past the frame's last cycle).
    pub(crate) fn finish(self, end: u64, tps: u64, last: &[u64]) -> Option<Timeline> {
        if self.every == 0 {
            return None;
        }
        let w = self.columns.len();
        let intervals = end.div_ceil(self.every).max(1) as usize;
        let sampled = (self.samples.len() / w).min(intervals - 1);
        debug_assert_eq!(
            sampled,
            intervals - 1,
            "every boundary before the end sampled"
        );
        let at = |b: usize| -> &[u64] {
            // Boundary b (0: the frame's start, all zero; `intervals`: its end).
            if b == intervals {
                last
            } else {
                &self.samples[(b - 1) * w..b * w]
            }
        };
        let zero = vec![0; w];
        let mut rows = Vec::with_capacity(intervals);
        for k in 0..intervals {
            let start = k as u64 * self.every;
            let stop = if k + 1 == intervals {
                end.max(start)
            } else {
                start + self.every
            };
            let (a, b) = (if k == 0 { &zero[..] } else { at(k) }, at(k + 1));
            let issued = if k + 1 == intervals {
                self.issued.iter().skip(k).sum()
            } else {
                self.issued.get(k).copied().unwrap_or(0)
            };
            let mut values = Vec::with_capacity(w + 1);
            values.push(issued);
            for (j, c) in self.columns.iter().enumerate() {
                values.push(match c.kind {
                    Kind::Count => b[j] - a[j],
                    Kind::Level => b[j],
                });
            }
            rows.push(Row {
                start,
                cycles: stop - start,
                values,
            });
        }
        let mut columns = vec![Column::count("instructions")];
        columns.extend(self.columns.iter().copied());
        Some(Timeline {
            every: self.every,
            tps,
            columns,
            rows,
        })
    }

    /// The running values of the chip's columns now, then the source's (`source`).
    pub(crate) fn running(
        &self,
        hier: &Hierarchy<Dram>,
        source: impl FnOnce(&mut Vec<u64>),
    ) -> Vec<u64> {
        let mut v = Vec::with_capacity(self.columns.len());
        chip_values(self.atomic_grants, hier, &mut v);
        source(&mut v);
        v
    }
}

/// The running values of [`CHIP`]'s columns.
fn chip_values(atomic_grants: u64, hier: &Hierarchy<Dram>, v: &mut Vec<u64>) {
    let (mut l1, mut l1m, mut l2, mut l2m) = (0, 0, 0, 0);
    for (n, t) in hier.topology().nodes().iter().enumerate() {
        let s = hier.stats(n);
        if t.level == 1 {
            l1 += s.accesses();
            l1m += s.misses();
        } else {
            l2 += s.accesses();
            l2m += s.misses();
        }
    }
    let (mut reads, mut writes, mut row_hits, mut columns) = (0, 0, 0, 0);
    for ch in hier.memory().channels() {
        let s = &ch.stats;
        reads += s.reads;
        writes += s.writes;
        row_hits += s.read_row_hits + s.write_row_hits;
        columns += s.column_reads + s.column_writes;
    }
    v.extend_from_slice(&[
        atomic_grants,
        l1,
        l1m,
        l2,
        l2m,
        reads,
        writes,
        row_hits,
        columns,
    ]);
}
