//! Helpers for typed statistics.
//!
//! Stats structs keep numerators and denominators (counts, sums); ratios, rates and averages
//! are computed only when reporting, with [`ratio`]. [`Histogram`] records a distribution of
//! small non-negative integers (latencies in cycles) exactly up to a bound and in power-of-two
//! buckets beyond it, so percentiles are exact for the common case and bounded in memory.

use serde::{Deserialize, Serialize};
use std::ops::AddAssign;

/// `num / den`, or 0 when the denominator is 0 (reports must stay valid JSON: no NaN).
#[inline]
pub fn ratio(num: f64, den: f64) -> f64 {
    if den == 0.0 { 0.0 } else { num / den }
}

/// Values below this are counted exactly.
pub const EXACT_LIMIT: u64 = 4096;

/// Distribution of u64 samples: exact below 4096, power-of-two buckets above.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Histogram {
    exact: Vec<u64>,
    /// `log2_buckets[k]` counts values in `[2^k, 2^(k+1))` for values ≥ `EXACT_LIMIT`.
    log2_buckets: Vec<u64>,
    pub count: u64,
    pub sum: u128,
    pub min: u64,
    pub max: u64,
}

impl Histogram {
    pub fn new() -> Self {
        Histogram::default()
    }

    #[inline]
    pub fn record(&mut self, v: u64) {
        if v < EXACT_LIMIT {
            let i = v as usize;
            if self.exact.len() <= i {
                self.exact.resize(i + 1, 0);
            }
            self.exact[i] += 1;
        } else {
            let k = 63 - v.leading_zeros() as usize;
            if self.log2_buckets.len() <= k {
                self.log2_buckets.resize(k + 1, 0);
            }
            self.log2_buckets[k] += 1;
        }
        if self.count == 0 || v < self.min {
            self.min = v;
        }
        self.max = self.max.max(v);
        self.count += 1;
        self.sum += v as u128;
    }

    /// Record `v` `n` times: the same as `n` calls of [`Histogram::record`] (for tallies kept
    /// elsewhere and added when reporting).
    pub fn record_n(&mut self, v: u64, n: u64) {
        if n == 0 {
            return;
        }
        if v < EXACT_LIMIT {
            let i = v as usize;
            if self.exact.len() <= i {
                self.exact.resize(i + 1, 0);
            }
            self.exact[i] += n;
        } else {
            let k = 63 - v.leading_zeros() as usize;
            if self.log2_buckets.len() <= k {
                self.log2_buckets.resize(k + 1, 0);
            }
            self.log2_buckets[k] += n;
        }
        if self.count == 0 || v < self.min {
            self.min = v;
        }
        self.max = self.max.max(v);
        self.count += n;
        self.sum += u128::from(v) * u128::from(n);
    }

    pub fn mean(&self) -> f64 {
        ratio(self.sum as f64, self.count as f64)
    }

    /// The smallest recorded value `v` such that at least `p` percent of samples are ≤ `v`
    /// (nearest-rank). Exact below 4096; above, the upper end of the bucket, capped at `max`.
    pub fn percentile(&self, p: f64) -> u64 {
        if self.count == 0 {
            return 0;
        }
        let rank = ((p / 100.0) * self.count as f64).ceil().max(1.0) as u64;
        let mut seen = 0u64;
        for (v, &c) in self.exact.iter().enumerate() {
            seen += c;
            if seen >= rank {
                return v as u64;
            }
        }
        for (k, &c) in self.log2_buckets.iter().enumerate() {
            seen += c;
            if seen >= rank {
                let upper = if k >= 63 {
                    u64::MAX
                } else {
                    (1u64 << (k + 1)) - 1
                };
                return upper.min(self.max);
            }
        }
        self.max
    }
}

/// Samples of a [`Histogram`] below a bound, counted by value while simulating and added to
/// the histogram when the books are closed ([`Tally::flush_into`]): a hot path records a sample
/// with one increment instead of updating the histogram's count, sum, minimum and maximum. The
/// histogram's fields depend only on the multiset of samples, so it ends as if every sample had
/// been recorded into it directly. Values at or above the bound are for the caller to record
/// directly ([`Tally::record`] says so).
#[derive(Clone, Debug)]
pub struct Tally {
    counts: Vec<u64>,
    /// One above the largest value counted since the last flush (0: none).
    hi: usize,
}

impl Tally {
    /// Counts values below `bound`.
    pub fn new(bound: usize) -> Self {
        Tally {
            counts: vec![0; bound],
            hi: 0,
        }
    }

    /// Count `v`; false if `v` is beyond the bound (not counted).
    #[inline(always)]
    pub fn record(&mut self, v: u64) -> bool {
        match self.counts.get_mut(v as usize) {
            Some(c) => {
                *c += 1;
                self.hi = self.hi.max(v as usize + 1);
                true
            }
            None => false,
        }
    }

    /// Add the counted samples to `h` and forget them.
    pub fn flush_into(&mut self, h: &mut Histogram) {
        for (v, c) in self.counts[..self.hi].iter_mut().enumerate() {
            h.record_n(v as u64, *c);
            *c = 0;
        }
        self.hi = 0;
    }
}

impl AddAssign<&Histogram> for Histogram {
    fn add_assign(&mut self, o: &Histogram) {
        if o.count == 0 {
            return;
        }
        if self.exact.len() < o.exact.len() {
            self.exact.resize(o.exact.len(), 0);
        }
        for (a, b) in self.exact.iter_mut().zip(&o.exact) {
            *a += b;
        }
        if self.log2_buckets.len() < o.log2_buckets.len() {
            self.log2_buckets.resize(o.log2_buckets.len(), 0);
        }
        for (a, b) in self.log2_buckets.iter_mut().zip(&o.log2_buckets) {
            *a += b;
        }
        self.min = if self.count == 0 {
            o.min
        } else {
            self.min.min(o.min)
        };
        self.max = self.max.max(o.max);
        self.count += o.count;
        self.sum += o.sum;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn percentiles_exact_region() {
        let mut h = Histogram::new();
        for v in 1..=100 {
            h.record(v);
        }
        assert_eq!(h.percentile(50.0), 50);
        assert_eq!(h.percentile(99.0), 99);
        assert_eq!(h.percentile(100.0), 100);
        assert_eq!(h.min, 1);
        assert_eq!(h.mean(), 50.5);
    }

    #[test]
    fn large_values_bucketed_and_capped() {
        let mut h = Histogram::new();
        h.record(10_000);
        assert_eq!(h.percentile(50.0), 10_000);
        h.record(5);
        assert_eq!(h.percentile(50.0), 5);
    }

    #[test]
    fn merge_equals_recording_all() {
        let (mut a, mut b, mut all) = (Histogram::new(), Histogram::new(), Histogram::new());
        for v in [3u64, 9, 5000, 12] {
            a.record(v);
            all.record(v);
        }
        for v in [1u64, 70000] {
            b.record(v);
            all.record(v);
        }
        a += &b;
        assert_eq!(a, all);
    }

    /// A tally flushed (twice, with samples between) leaves the histogram equal to recording
    /// every sample directly, values beyond its bound recorded directly.
    #[test]
    fn tally_equals_recording_all() {
        let (mut h, mut all, mut t) = (Histogram::new(), Histogram::new(), Tally::new(64));
        for (i, v) in [7u64, 0, 63, 64, 9000, 7, 12, 63].into_iter().enumerate() {
            all.record(v);
            if !t.record(v) {
                h.record(v);
            }
            if i == 4 {
                t.flush_into(&mut h);
            }
        }
        t.flush_into(&mut h);
        t.flush_into(&mut h);
        assert_eq!(h, all);
    }

    #[test]
    fn ratio_of_zero_denominator_is_zero() {
        assert_eq!(ratio(1.0, 0.0), 0.0);
    }
}
