//! [`Cache`]: one exact, untimed cache — tags, replacement state and dirty bits of every set.
//!
//! Geometry is powers of two (validated), so an address splits with shifts and masks: line =
//! `addr >> log2(line_bytes)`, set = `line & (sets − 1)`. Each way stores its full line number
//! (no tag/set split to get wrong), with `INVALID` for an empty way. Replacement fills the
//! lowest empty way first, then picks the LRU line (smallest last-use stamp), the oldest fill
//! (FIFO), or a random way (PCG32, seeded: deterministic). The hot path allocates nothing;
//! direct-mapped caches take a path with no replacement state at all.
//!
//! Two levels of use: [`Cache::access`] does a whole access by the write policy (the functional
//! model), while [`Cache::lookup`] and [`Cache::fill`] split it for the timed model, where the
//! line arrives later.

use crate::config::{CacheLevel, Replacement, WritePolicy};
use crate::stats::CacheStats;
use rtsim_config::ConfigError;
use rtsim_core::{MemOp, Pcg32};

const INVALID: u64 = u64::MAX;

/// A line replaced by a fill.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Evicted {
    /// Byte address of the line's first byte.
    pub addr: u64,
    /// It was dirty (write-back: it must be written to the next level).
    pub dirty: bool,
}

/// What one functional access did.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Access {
    pub hit: bool,
    /// A miss that installed the line (reads; writes under write-back). The line must be
    /// fetched from the next level.
    pub allocated: bool,
    /// The line this access evicted, if any.
    pub evicted: Option<Evicted>,
    /// A write passed on to the next level (write-around).
    pub write_through: bool,
}

/// One cache's contents and counters.
#[derive(Clone, Debug)]
pub struct Cache {
    line_shift: u32,
    set_mask: u64,
    ways: usize,
    replacement: Replacement,
    policy: WritePolicy,
    write_touch: bool,
    /// Line number per way, `sets × ways`, set-major.
    lines: Vec<u64>,
    /// LRU: last use; FIFO: fill time (a running access counter). Empty when direct-mapped.
    stamps: Vec<u64>,
    dirty: Vec<bool>,
    clock: u64,
    rng: Pcg32,
    pub stats: CacheStats,
}

impl Cache {
    /// Build an empty cache. `name` prefixes the keys in errors (`l1`, `l2`); `stream` picks the
    /// random-replacement stream of `seed` (one per cache).
    pub fn new(
        name: &str,
        level: &CacheLevel,
        seed: u64,
        stream: u64,
    ) -> Result<Self, ConfigError> {
        level.validate_at(name)?;
        let sets = level.sets();
        let n = (sets * u64::from(level.ways)) as usize;
        let stamped = level.ways > 1;
        Ok(Cache {
            line_shift: level.line_bytes.trailing_zeros(),
            set_mask: sets - 1,
            ways: level.ways as usize,
            replacement: level.replacement,
            policy: level.write_policy,
            write_touch: level.write_hit_updates_lru && level.replacement == Replacement::Lru,
            lines: vec![INVALID; n],
            stamps: if stamped { vec![0; n] } else { Vec::new() },
            dirty: vec![false; n],
            clock: 0,
            rng: Pcg32::new(seed, stream),
            stats: CacheStats::default(),
        })
    }

    pub fn line_bytes(&self) -> u64 {
        1 << self.line_shift
    }
    pub fn write_policy(&self) -> WritePolicy {
        self.policy
    }
    /// The line number of a byte address.
    #[inline(always)]
    pub fn line_of(&self, addr: u64) -> u64 {
        addr >> self.line_shift
    }
    #[inline(always)]
    fn base(&self, line: u64) -> usize {
        ((line & self.set_mask) as usize) * self.ways
    }

    /// The way holding `line`, if any.
    #[inline(always)]
    fn find(&self, line: u64) -> Option<usize> {
        let b = self.base(line);
        if self.ways == 1 {
            return (self.lines[b] == line).then_some(b);
        }
        self.lines[b..b + self.ways]
            .iter()
            .position(|&l| l == line)
            .map(|w| b + w)
    }

    /// Is the line of `addr` present? No side effects.
    #[inline]
    pub fn contains(&self, addr: u64) -> bool {
        self.find(self.line_of(addr)).is_some()
    }

    /// [`Cache::lookup`] when the line of `addr` is present (and then true); nothing at all
    /// when it is not (false). One search where `contains` then `lookup` would make two.
    #[inline]
    pub fn lookup_if_present(&mut self, addr: u64, op: MemOp) -> bool {
        let Some(i) = self.find(self.line_of(addr)) else {
            return false;
        };
        self.clock += 1;
        self.count_hit(i, op);
        true
    }

    /// Count a hit on way `i` by `op` at the current clock (see [`Cache::lookup`]).
    #[inline(always)]
    fn count_hit(&mut self, i: usize, op: MemOp) {
        let s = &mut self.stats;
        match op {
            MemOp::Read => {
                s.reads += 1;
                s.read_hits += 1;
                if self.replacement == Replacement::Lru && !self.stamps.is_empty() {
                    self.stamps[i] = self.clock;
                }
            }
            MemOp::Write => {
                s.writes += 1;
                s.write_hits += 1;
                if self.write_touch && !self.stamps.is_empty() {
                    self.stamps[i] = self.clock;
                }
                if self.policy == WritePolicy::WriteBack {
                    self.dirty[i] = true;
                }
            }
        }
    }

    /// Look `addr` up for `op` and count it: a hit updates replacement state (reads; writes if
    /// `write_hit_updates_lru`) and, under write-back, marks a written line dirty. A miss
    /// changes nothing (see [`Cache::fill`]). Returns whether it hit.
    #[inline]
    pub fn lookup(&mut self, addr: u64, op: MemOp) -> bool {
        let line = self.line_of(addr);
        self.clock += 1;
        if let Some(i) = self.find(line) {
            self.count_hit(i, op);
            return true;
        }
        let s = &mut self.stats;
        match op {
            MemOp::Read => {
                s.reads += 1;
                s.read_misses += 1;
            }
            MemOp::Write => {
                s.writes += 1;
                s.write_misses += 1;
            }
        }
        false
    }

    /// Install the line of `addr` (dirty or clean), replacing a line by the policy; counts the
    /// fill, the eviction and, if the victim was dirty, the write-back. A line already present
    /// is only marked dirty if asked (a fill racing a write-allocate of the same line).
    #[inline]
    pub fn fill(&mut self, addr: u64, dirty: bool) -> Option<Evicted> {
        let line = self.line_of(addr);
        if let Some(i) = self.find(line) {
            self.dirty[i] |= dirty;
            return None;
        }
        self.clock += 1;
        let b = self.base(line);
        let way = if self.ways == 1 {
            b
        } else {
            b + self.victim(b)
        };
        let old = self.lines[way];
        let evicted = (old != INVALID).then(|| Evicted {
            addr: old << self.line_shift,
            dirty: self.dirty[way],
        });
        self.lines[way] = line;
        self.dirty[way] = dirty;
        if !self.stamps.is_empty() {
            self.stamps[way] = self.clock;
        }
        let s = &mut self.stats;
        s.fills += 1;
        if let Some(e) = evicted {
            s.evictions += 1;
            if e.dirty {
                s.writebacks += 1;
            }
        }
        evicted
    }

    /// The way of the set at `b` to replace: the first empty one, else by the policy.
    fn victim(&mut self, b: usize) -> usize {
        let set = &self.lines[b..b + self.ways];
        if let Some(w) = set.iter().position(|&l| l == INVALID) {
            return w;
        }
        match self.replacement {
            Replacement::Random => self.rng.below(self.ways as u32) as usize,
            // LRU: the smallest last-use stamp; FIFO: the smallest fill stamp. Stamps are
            // unique (one clock tick per access), so there are no ties.
            Replacement::Lru | Replacement::Fifo => {
                let st = &self.stamps[b..b + self.ways];
                let mut best = 0;
                for (w, &t) in st.iter().enumerate().skip(1) {
                    if t < st[best] {
                        best = w;
                    }
                }
                best
            }
        }
    }

    /// One whole access by the write policy, with the line available at once (functional).
    #[inline]
    pub fn access(&mut self, addr: u64, op: MemOp) -> Access {
        let hit = self.lookup(addr, op);
        let allocate = !hit && (op == MemOp::Read || self.policy == WritePolicy::WriteBack);
        let evicted = if allocate {
            self.fill(addr, op == MemOp::Write)
        } else {
            None
        };
        let write_through = op == MemOp::Write && self.policy == WritePolicy::WriteAround;
        if write_through {
            self.stats.write_throughs += 1;
        }
        Access {
            hit,
            allocated: allocate,
            evicted,
            write_through,
        }
    }

    /// Lines currently valid (for tests and reports).
    pub fn valid_lines(&self) -> usize {
        self.lines.iter().filter(|&&l| l != INVALID).count()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use MemOp::{Read, Write};

    fn level(size: u64, ways: u32, r: Replacement, w: WritePolicy) -> CacheLevel {
        CacheLevel {
            size_bytes: size,
            ways,
            replacement: r,
            write_policy: w,
            ..CacheLevel::trax_l1()
        }
    }

    #[test]
    fn direct_mapped_conflicts() {
        let mut c = Cache::new("l1", &CacheLevel::trax_l1(), 1, 0).unwrap();
        // 16 KB direct-mapped, 64 B lines: addresses 16 KB apart share a set.
        assert!(!c.access(0x40, Read).hit);
        assert!(c.access(0x7f, Read).hit);
        let a = c.access(0x40 + 16384, Read);
        assert!(!a.hit && a.allocated);
        assert_eq!(
            a.evicted,
            Some(Evicted {
                addr: 0x40,
                dirty: false
            })
        );
        assert!(!c.access(0x40, Read).hit);
        let s = &c.stats;
        assert_eq!(
            (s.reads, s.read_hits, s.read_misses, s.evictions),
            (4, 1, 3, 2)
        );
    }

    #[test]
    fn lru_fifo_and_random_victims() {
        // One set of 4 ways: lines 0..4 fill it; touching 0 then filling 4 evicts 1 under LRU
        // and 0 under FIFO.
        let line = 64u64;
        let size = 4 * line;
        for (r, expect) in [(Replacement::Lru, 1u64), (Replacement::Fifo, 0)] {
            let mut c =
                Cache::new("c", &level(size, 4, r, WritePolicy::WriteAround), 1, 0).unwrap();
            for i in 0..4 {
                c.access(i * line, Read);
            }
            assert!(c.access(0, Read).hit);
            let e = c.access(4 * line, Read).evicted.unwrap();
            assert_eq!(e.addr, expect * line, "{r:?}");
        }
        // Random: deterministic for a seed, and only ever evicts a resident line.
        let run = |seed| {
            let mut c = Cache::new(
                "c",
                &level(size, 4, Replacement::Random, WritePolicy::WriteAround),
                seed,
                0,
            )
            .unwrap();
            (0..200u64)
                .map(|i| {
                    c.access((i * 7919 % 13) * line, Read)
                        .evicted
                        .map(|e| e.addr)
                })
                .collect::<Vec<_>>()
        };
        assert_eq!(run(5), run(5));
        assert_ne!(run(5), run(6));
    }

    #[test]
    fn write_around_never_allocates_or_dirties() {
        let mut c = Cache::new("l1", &CacheLevel::trax_l1(), 1, 0).unwrap();
        let a = c.access(0x1000, Write);
        assert!(!a.hit && !a.allocated && a.write_through);
        assert!(!c.contains(0x1000));
        c.access(0x1000, Read);
        let a = c.access(0x1000, Write);
        assert!(a.hit && a.write_through);
        let e = c.access(0x1000 + 16384, Read).evicted.unwrap();
        assert!(!e.dirty);
        assert_eq!(c.stats.write_throughs, 2);
        assert_eq!(c.stats.writebacks, 0);
    }

    #[test]
    fn write_back_allocates_and_writes_back_dirty_victims() {
        let wb = level(16384, 1, Replacement::Lru, WritePolicy::WriteBack);
        let mut c = Cache::new("l1", &wb, 1, 0).unwrap();
        let a = c.access(0x1000, Write);
        assert!(!a.hit && a.allocated && !a.write_through);
        assert!(c.access(0x1000, Read).hit);
        let e = c.access(0x1000 + 16384, Read).evicted.unwrap();
        assert_eq!(
            e,
            Evicted {
                addr: 0x1000,
                dirty: true
            }
        );
        let e = c.access(0x1000, Read).evicted.unwrap();
        assert!(!e.dirty, "a line only read is clean");
        assert_eq!((c.stats.evictions, c.stats.writebacks), (2, 1));
    }

    #[test]
    fn write_hits_and_lru_order() {
        // LRU, 2 ways, one set: fill A, B; write A; fill C. With write_hit_updates_lru the write
        // made A recent, so B goes; without it (pycachesim) A goes.
        for (touch, victim) in [(true, 64u64), (false, 0)] {
            let mut l = level(128, 2, Replacement::Lru, WritePolicy::WriteBack);
            l.write_hit_updates_lru = touch;
            let mut c = Cache::new("c", &l, 1, 0).unwrap();
            c.access(0, Read);
            c.access(64, Read);
            c.access(0, Write);
            assert_eq!(c.access(128, Read).evicted.unwrap().addr, victim);
        }
    }

    #[test]
    fn bad_geometry_names_the_key() {
        let mut l = CacheLevel::trax_l1();
        l.size_bytes = 3000;
        let e = Cache::new("l1", &l, 1, 0).unwrap_err().to_string();
        assert!(e.contains("l1.size_bytes"), "{e}");
        let mut l = CacheLevel::trax_l1();
        l.line_bytes = 48;
        let e = Cache::new("l2", &l, 1, 0).unwrap_err().to_string();
        assert!(
            e.contains("l2.line_bytes") && e.contains("power of two"),
            "{e}"
        );
        let mut l = CacheLevel::trax_l1();
        l.ways = 3; // 16384 / (3 × 64) is not whole
        assert!(Cache::new("l1", &l, 1, 0).is_err());
        l.size_bytes = 3 * 64 * 32; // 32 sets of 3 ways: fine
        assert!(Cache::new("l1", &l, 1, 0).is_ok());
    }
}
