//! The ray stream memory (STRaTA paper §3.1): a programmer-managed SRAM holding one ray
//! buffer per treelet, each a LIFO singly linked list inside the SRAM.
//!
//! The paper's simulator kept the buffers as "a simple collection data structure"; it
//! envisions "a hardware managed linked-list state machine with a pointer to the head of each
//! buffer stored in the SRAM. Link pointers for the nodes and a free list could be stored
//! within the SRAM as well", occupying "8 % or less of the total capacity". This module is
//! that hardware, with the overhead counted against capacity:
//!
//! - **Slots.** The SRAM is cut into slots of one 48-byte ray record plus one link pointer.
//! - **Head table.** Per buffer (one per treelet, node and triangle kinds alike) a head
//!   pointer and a ray count (the count is what the `most-rays` scheduling policy reads).
//! - **Free list.** The free slots form one more list, with its own head pointer.
//! - **Pointer width.** Every pointer and count is `ceil(log2(slots + 1))` bits (one value is
//!   the null pointer), the narrowest that addresses the memory: 17 bits for the default
//!   4 MB. A full 32-bit word per link would cost 4 / 52 = 7.7 % on links alone and, with a
//!   head table of a few thousand treelets, exceed the paper's 8 % (`docs/STRATA.md`).
//! - **Access unit.** One push or one pop moves one ray record and its link, and updates the
//!   buffer's head entry and the free list's head: one stream-memory access, charged at
//!   STRaTA Table 2's energy for the memory's size (the paper assumes the head lookup and
//!   push/pop circuitry cost what the L2's tag and bank circuitry cost). Slot `s` lives in
//!   bank `s mod banks`; accesses are counted per bank for the timing model.
//!
//! Push and pop are constant time: a push takes the free list's head slot and links it in
//! front of the buffer's head; a pop unlinks the buffer's head and returns it to the free list.

use crate::config::StreamConfig;
use rtsim_trace::step::bitstack::RECORD_BYTES;
use serde::Serialize;
use std::ops::AddAssign;

/// Bytes of one ray record (STRaTA §3.1: origin and direction 24 B, state 20 B, bit stack
/// 4 B), laid out by `rtsim_trace::step::bitstack`.
pub const RAY_BYTES: u32 = RECORD_BYTES as u32;

/// The null pointer inside the model (the hardware uses the all-ones value of its width).
const NULL: u32 = u32::MAX;

/// A ray record as stored.
pub type RayRecord = [u8; RECORD_BYTES];

/// How the SRAM's bytes are divided.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct StreamLayout {
    pub capacity_bytes: u64,
    /// Ray buffers (treelets).
    pub buffers: u32,
    /// Width of every pointer and count in bits.
    pub pointer_bits: u32,
    /// Ray slots.
    pub slots: u32,
    /// Bytes of the path-state record kept beside each slot (0: none; the timed chip keeps
    /// one per slot, `docs/STRATA.md` "Path state").
    pub path_bytes: u32,
}

impl StreamLayout {
    /// The most slots `capacity_bytes` holds beside a head table for `buffers` buffers
    /// (`None` if not even one). Each slot costs a record and a link; each buffer a head
    /// pointer and a count; the free list a head pointer; all `p` bits wide with
    /// `p = ceil(log2(slots + 1))`.
    pub fn new(capacity_bytes: u64, buffers: u32) -> Option<StreamLayout> {
        StreamLayout::with_path_table(capacity_bytes, buffers, 0)
    }

    /// [`StreamLayout::new`] with a `path_bytes` path-state record beside every slot.
    pub fn with_path_table(
        capacity_bytes: u64,
        buffers: u32,
        path_bytes: u32,
    ) -> Option<StreamLayout> {
        let bits = capacity_bytes.checked_mul(8)?;
        let record_bits = (RAY_BYTES as u64 + path_bytes as u64) * 8;
        let mut best: Option<StreamLayout> = None;
        for p in 1..=32u64 {
            let fixed = (2 * buffers as u64 + 1) * p;
            let Some(left) = bits.checked_sub(fixed) else {
                continue;
            };
            // Slots addressable with p bits: values 0 ..= 2^p − 2 (all ones is null).
            let slots = (left / (record_bits + p))
                .min((1u64 << p) - 1)
                .min(NULL as u64);
            if slots > 0 && best.is_none_or(|b| slots > b.slots as u64) {
                best = Some(StreamLayout {
                    capacity_bytes,
                    buffers,
                    pointer_bits: p as u32,
                    slots: slots as u32,
                    path_bytes,
                });
            }
        }
        best
    }

    /// Bits spent on links, heads, counts and the free-list head.
    pub fn overhead_bits(&self) -> u64 {
        (self.slots as u64 + 2 * self.buffers as u64 + 1) * self.pointer_bits as u64
    }

    /// Fraction of the capacity not holding ray records (links, head table, and the unused
    /// remainder).
    pub fn overhead_fraction(&self) -> f64 {
        1.0 - (self.slots as f64 * RAY_BYTES as f64) / self.capacity_bytes as f64
    }

    /// Fraction of the capacity spent on links and the head table alone.
    pub fn link_fraction(&self) -> f64 {
        self.overhead_bits() as f64 / (self.capacity_bytes as f64 * 8.0)
    }
}

/// Stream-memory event counts (numerators only; ratios are computed when reporting).
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize)]
pub struct StreamStats {
    pub pushes: u64,
    pub pops: u64,
    /// Accesses (pushes + pops) per bank.
    pub bank_accesses: Vec<u64>,
    /// Most rays held at once.
    pub peak_rays: u32,
    /// Most rays one buffer held at once.
    pub peak_buffer_rays: u32,
    /// Pushes refused because no slot was free (the one-for-one replacement keeps this 0).
    pub overflows: u64,
    /// Path-state record reads and writes (the timed chip, which keeps them in the stream
    /// memory; one access each).
    pub path_reads: u64,
    pub path_writes: u64,
}

impl StreamStats {
    /// Accesses: pushes, pops and path-state reads and writes.
    pub fn accesses(&self) -> u64 {
        self.pushes + self.pops + self.path_reads + self.path_writes
    }
}

impl AddAssign<&StreamStats> for StreamStats {
    fn add_assign(&mut self, o: &StreamStats) {
        self.pushes += o.pushes;
        self.pops += o.pops;
        if self.bank_accesses.len() < o.bank_accesses.len() {
            self.bank_accesses.resize(o.bank_accesses.len(), 0);
        }
        for (a, b) in self.bank_accesses.iter_mut().zip(&o.bank_accesses) {
            *a += b;
        }
        self.peak_rays = self.peak_rays.max(o.peak_rays);
        self.peak_buffer_rays = self.peak_buffer_rays.max(o.peak_buffer_rays);
        self.overflows += o.overflows;
        self.path_reads += o.path_reads;
        self.path_writes += o.path_writes;
    }
}

/// Why a stream memory cannot be built or used.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum StreamError {
    #[error(
        "arch.strata.stream.bytes = {bytes} cannot hold the head table of {buffers} treelet \
         buffers and one {RAY_BYTES}-byte ray: raise it"
    )]
    TooSmall { bytes: u64, buffers: u32 },
    #[error("the stream memory is full ({slots} rays): a push needs a free slot")]
    Full { slots: u32 },
    #[error("ray buffer {buffer} does not exist ({buffers} buffers)")]
    NoBuffer { buffer: u32, buffers: u32 },
}

/// The stream memory's contents: records, links, heads, counts and the free list.
#[derive(Clone, Debug)]
pub struct StreamMemory {
    layout: StreamLayout,
    banks: u32,
    records: Vec<RayRecord>,
    next: Vec<u32>,
    heads: Vec<u32>,
    counts: Vec<u32>,
    /// One free list per bank (slot `s` in bank `s mod banks`): a push can take a slot in
    /// any bank whose port is free this cycle, not only the one slot a single free list
    /// offers (which is usually the slot a pop just freed, in the bank that pop used). The
    /// extra heads are registers in the banks' controllers (assumed; not counted against the
    /// capacity, like the single head they replace would be 1 pointer).
    free: Vec<u32>,
    /// The bank the next [`StreamMemory::push`] tries first (rotating).
    rr: u32,
    len: u32,
    stats: StreamStats,
}

impl StreamMemory {
    /// An empty stream memory of `cfg.bytes` with `buffers` buffers.
    pub fn new(cfg: &StreamConfig, buffers: u32) -> Result<StreamMemory, StreamError> {
        StreamMemory::with_path_table(cfg, buffers, 0)
    }

    /// [`StreamMemory::new`] with a `path_bytes` path-state record beside every slot.
    pub fn with_path_table(
        cfg: &StreamConfig,
        buffers: u32,
        path_bytes: u32,
    ) -> Result<StreamMemory, StreamError> {
        let layout = StreamLayout::with_path_table(cfg.bytes, buffers, path_bytes).ok_or(
            StreamError::TooSmall {
                bytes: cfg.bytes,
                buffers,
            },
        )?;
        let n = layout.slots as usize;
        let banks = cfg.banks;
        // Free lists: bank k holds k → k + banks → …, so the first pushes (rotating over
        // the banks) fill slots in order.
        let next = (0..n as u32)
            .map(|s| {
                let t = s as u64 + banks as u64;
                if t < n as u64 { t as u32 } else { NULL }
            })
            .collect();
        let free = (0..banks)
            .map(|k| if (k as usize) < n { k } else { NULL })
            .collect();
        Ok(StreamMemory {
            layout,
            banks: cfg.banks,
            records: vec![[0; RECORD_BYTES]; n],
            next,
            heads: vec![NULL; buffers as usize],
            counts: vec![0; buffers as usize],
            free,
            rr: 0,
            len: 0,
            stats: StreamStats {
                bank_accesses: vec![0; cfg.banks as usize],
                ..StreamStats::default()
            },
        })
    }

    pub fn layout(&self) -> &StreamLayout {
        &self.layout
    }

    /// Rays held.
    pub fn len(&self) -> u32 {
        self.len
    }

    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Rays the memory can hold.
    pub fn capacity(&self) -> u32 {
        self.layout.slots
    }

    /// Rays in buffer `b`.
    pub fn count(&self, b: u32) -> u32 {
        self.counts[b as usize]
    }

    /// Ray counts of every buffer (what the head table holds).
    pub fn counts(&self) -> &[u32] {
        &self.counts
    }

    pub fn stats(&self) -> &StreamStats {
        &self.stats
    }

    /// The bank a pop from buffer `b` reads (its head slot's), if it holds a ray.
    pub fn pop_bank(&self, b: u32) -> Option<u32> {
        let h = *self.heads.get(b as usize)?;
        (h != NULL).then_some(h % self.banks)
    }

    /// Whether bank `bank` has a free slot.
    pub fn has_free(&self, bank: u32) -> bool {
        self.free[bank as usize] != NULL
    }

    /// The bank of path `id`'s state record (record `id` sits beside slot `id`).
    pub fn path_bank(&self, id: u32) -> u32 {
        id % self.banks
    }

    /// Count one access to path `id`'s state record.
    pub fn path_access(&mut self, id: u32, write: bool) {
        if write {
            self.stats.path_writes += 1;
        } else {
            self.stats.path_reads += 1;
        }
        self.stats.bank_accesses[(id % self.banks) as usize] += 1;
    }

    fn check_buffer(&self, b: u32) -> Result<(), StreamError> {
        if (b as usize) < self.heads.len() {
            Ok(())
        } else {
            Err(StreamError::NoBuffer {
                buffer: b,
                buffers: self.heads.len() as u32,
            })
        }
    }

    /// Push `ray` onto buffer `b` into a slot of the first bank with a free slot, rotating
    /// over the banks from one push to the next; returns the slot it went to.
    pub fn push(&mut self, b: u32, ray: &RayRecord) -> Result<u32, StreamError> {
        let bank = (0..self.banks)
            .map(|k| (self.rr + k) % self.banks)
            .find(|&k| self.has_free(k));
        let Some(bank) = bank else {
            self.check_buffer(b)?;
            self.stats.overflows += 1;
            return Err(StreamError::Full {
                slots: self.layout.slots,
            });
        };
        self.rr = (bank + 1) % self.banks;
        self.push_in(b, ray, bank)
    }

    /// Push `ray` onto buffer `b` into a free slot of bank `bank` (which must have one:
    /// [`StreamMemory::has_free`]); returns the slot.
    pub fn push_in(&mut self, b: u32, ray: &RayRecord, bank: u32) -> Result<u32, StreamError> {
        self.check_buffer(b)?;
        let slot = self.free[bank as usize];
        if slot == NULL {
            self.stats.overflows += 1;
            return Err(StreamError::Full {
                slots: self.layout.slots,
            });
        }
        let s = slot as usize;
        self.free[bank as usize] = self.next[s];
        self.records[s] = *ray;
        self.next[s] = self.heads[b as usize];
        self.heads[b as usize] = slot;
        self.counts[b as usize] += 1;
        self.len += 1;
        self.stats.pushes += 1;
        self.stats.bank_accesses[(slot % self.banks) as usize] += 1;
        self.stats.peak_rays = self.stats.peak_rays.max(self.len);
        self.stats.peak_buffer_rays = self.stats.peak_buffer_rays.max(self.counts[b as usize]);
        Ok(slot)
    }

    /// Pop the most recently pushed ray of buffer `b` (LIFO, §3.1), if any.
    pub fn pop(&mut self, b: u32) -> Result<Option<RayRecord>, StreamError> {
        self.check_buffer(b)?;
        let slot = self.heads[b as usize];
        if slot == NULL {
            return Ok(None);
        }
        let s = slot as usize;
        self.heads[b as usize] = self.next[s];
        let f = &mut self.free[(slot % self.banks) as usize];
        self.next[s] = *f;
        *f = slot;
        self.counts[b as usize] -= 1;
        self.len -= 1;
        self.stats.pops += 1;
        self.stats.bank_accesses[(slot % self.banks) as usize] += 1;
        Ok(Some(self.records[s]))
    }

    /// Walk every list and check that each slot is on exactly one (a buffer or the free
    /// list) and that the counts match: the structure loses and duplicates nothing.
    pub fn check(&self) -> Result<(), String> {
        let n = self.layout.slots as usize;
        let mut seen = vec![false; n];
        let mut walk = |mut s: u32, what: &str| -> Result<u32, String> {
            let mut k = 0u32;
            while s != NULL {
                let i = s as usize;
                if i >= n {
                    return Err(format!("{what}: pointer {s} past {n} slots"));
                }
                if seen[i] {
                    return Err(format!("{what}: slot {s} is on two lists"));
                }
                seen[i] = true;
                k += 1;
                s = self.next[i];
            }
            Ok(k)
        };
        let mut total = 0u32;
        for (b, &h) in self.heads.iter().enumerate() {
            let k = walk(h, &format!("buffer {b}"))?;
            if k != self.counts[b] {
                return Err(format!(
                    "buffer {b}: {k} rays linked, count {}",
                    self.counts[b]
                ));
            }
            total += k;
        }
        let mut free = 0;
        for (k, &h) in self.free.iter().enumerate() {
            free += walk(h, &format!("free list of bank {k}"))?;
            let mut s = h;
            while s != NULL {
                if s % self.banks != k as u32 {
                    return Err(format!("slot {s} on the free list of bank {k}"));
                }
                s = self.next[s as usize];
            }
        }
        if total != self.len || total + free != n as u32 {
            return Err(format!(
                "{total} rays in buffers + {free} free != {n} slots (len {})",
                self.len
            ));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cfg(bytes: u64) -> StreamConfig {
        StreamConfig {
            bytes,
            ..StreamConfig::default()
        }
    }

    fn ray(k: u32) -> RayRecord {
        let mut r = [0u8; RECORD_BYTES];
        r[..4].copy_from_slice(&k.to_le_bytes());
        r[44..].copy_from_slice(&(!k).to_le_bytes());
        r
    }

    fn id(r: &RayRecord) -> u32 {
        u32::from_le_bytes([r[0], r[1], r[2], r[3]])
    }

    #[test]
    fn layout_counts_links_and_heads_against_capacity() {
        // 4 MB and Sibenik's 4,155 treelets (3,952 node + 203 triangle with STRaTA's 40-byte
        // nodes and 32-level BVH; docs/STRATA.md).
        let l = StreamLayout::new(4 << 20, 4155).unwrap();
        assert_eq!((l.pointer_bits, l.slots), (17, 83_324));
        let bits = l.slots as u64 * (384 + 17) + (2 * 4155 + 1) * 17;
        assert!(bits <= (4u64 << 20) * 8);
        // One more slot would not fit.
        assert!(bits + 384 + 17 > (4u64 << 20) * 8);
        assert!(l.overhead_fraction() <= 0.08, "{}", l.overhead_fraction());
        // Every swept size (Figures 5–6) with Sibenik's treelets, and from 2 MB up with
        // Conference's 19,950, stays within the paper's 8 %; Conference's head table makes a
        // 512 KB memory lose 16 % (docs/STRATA.md).
        for (bytes, buffers) in [
            (512u64 << 10, 4155u32),
            (1 << 20, 4155),
            (2 << 20, 4155),
            (4 << 20, 4155),
            (8 << 20, 4155),
            (16 << 20, 4155),
            (2 << 20, 19950),
            (4 << 20, 19950),
        ] {
            let l = StreamLayout::new(bytes, buffers).unwrap();
            assert!(
                l.overhead_fraction() <= 0.08,
                "{bytes} B, {buffers} buffers: {}",
                l.overhead_fraction()
            );
        }
        let l = StreamLayout::new(512 << 10, 19950).unwrap();
        assert!(l.overhead_fraction() > 0.16, "{}", l.overhead_fraction());
        // With whole 32-bit words for every pointer the default size would exceed 8 %.
        let word = ((4u64 << 23) - (2 * 4155 + 1) * 32) / (384 + 32);
        assert!(1.0 - word as f64 * 48.0 / (4u64 << 20) as f64 > 0.08);
    }

    #[test]
    fn layout_refuses_a_memory_too_small_for_one_ray() {
        assert!(StreamLayout::new(64, 100).is_none());
        let Err(e) = StreamMemory::new(&cfg(1024), 5000) else {
            panic!("1 KB cannot hold a head table of 5000 buffers");
        };
        assert!(e.to_string().contains("arch.strata.stream.bytes"), "{e}");
        // 1 KB with 4 buffers: 20 rays of 48 B with 5-bit pointers (20 × 389 + 9 × 5 = 7825
        // bits of 8192; 21 rays would need 21 × 389 + 45 = 8214).
        let l = StreamLayout::new(1024, 4).unwrap();
        assert_eq!((l.pointer_bits, l.slots), (5, 20));
    }

    #[test]
    fn fills_to_capacity_then_refuses_and_loses_nothing() {
        let mut m = StreamMemory::new(&cfg(1024), 3).unwrap();
        let cap = m.capacity();
        for k in 0..cap {
            m.push(k % 3, &ray(k)).unwrap();
        }
        assert_eq!(m.len(), cap);
        assert_eq!(m.push(0, &ray(999)), Err(StreamError::Full { slots: cap }));
        assert_eq!(m.stats().overflows, 1);
        m.check().unwrap();
        // Drain: every ray comes back once, LIFO within each buffer.
        let mut got = Vec::new();
        for b in 0..3 {
            let mut last = None;
            while let Some(r) = m.pop(b).unwrap() {
                let k = id(&r);
                assert_eq!(r, ray(k), "record intact");
                assert_eq!(k % 3, b);
                if let Some(l) = last {
                    assert!(k < l, "LIFO");
                }
                last = Some(k);
                got.push(k);
            }
        }
        got.sort_unstable();
        assert_eq!(got, (0..cap).collect::<Vec<_>>());
        assert!(m.is_empty());
        m.check().unwrap();
        assert_eq!(m.stats().pushes, cap as u64);
        assert_eq!(m.stats().pops, cap as u64);
        assert_eq!(m.stats().bank_accesses.iter().sum::<u64>(), 2 * cap as u64);
        assert_eq!(m.stats().peak_rays, cap);
    }

    #[test]
    fn interleaved_pushes_and_pops_keep_every_ray_once() {
        // A deterministic scramble of pushes and pops over 7 buffers.
        let mut m = StreamMemory::new(&cfg(4096), 7).unwrap();
        let mut live = std::collections::BTreeMap::new();
        let mut x = 12345u32;
        for k in 0..10_000u32 {
            x = x.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            let b = (x >> 8) % 7;
            if (x >> 20) % 3 != 0 && m.len() < m.capacity() {
                m.push(b, &ray(k)).unwrap();
                live.insert(k, b);
            } else if let Some(r) = m.pop(b).unwrap() {
                assert_eq!(live.remove(&id(&r)), Some(b));
            }
            assert_eq!(m.len() as usize, live.len());
        }
        m.check().unwrap();
        for b in 0..7 {
            assert_eq!(
                m.count(b) as usize,
                live.values().filter(|&&v| v == b).count()
            );
        }
    }

    #[test]
    fn unknown_buffers_are_errors() {
        let mut m = StreamMemory::new(&cfg(1024), 2).unwrap();
        assert!(matches!(
            m.push(2, &ray(0)),
            Err(StreamError::NoBuffer { .. })
        ));
        assert!(matches!(m.pop(5), Err(StreamError::NoBuffer { .. })));
    }
}
