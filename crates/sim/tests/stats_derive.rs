//! `#[derive(Stats)]`: every field is merged, by sum or by max, through nesting, histograms,
//! arrays and growing Vecs.

use rtsim_core::stats::Histogram;
use rtsim_sim::Stats;
use rtsim_sim::testing::assert_merges_every_field;
use serde::{Deserialize, Serialize};

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize, Stats)]
struct Inner {
    hits: u64,
    #[stats(max)]
    peak: u32,
}

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize, Stats)]
struct Outer {
    reads: u64,
    bytes: u128,
    energy_j: f64,
    #[stats(max)]
    max_queue: u64,
    latency: Histogram,
    inner: Inner,
    per_bank: [u64; 4],
    #[stats(max)]
    per_bank_peak: [u32; 3],
    grid: [[u16; 2]; 2],
    per_tag: Vec<u64>,
    per_unit: Vec<Inner>,
    #[stats(max)]
    per_tag_peak: Vec<u64>,
}

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize, Stats)]
struct Pair(u64, #[stats(max)] u64);

fn sample(k: u64) -> Outer {
    let mut latency = Histogram::new();
    latency.record(k);
    Outer {
        reads: k,
        bytes: u128::from(k) * 64,
        energy_j: k as f64 * 0.5,
        max_queue: 10 * k,
        latency,
        inner: Inner {
            hits: k + 1,
            peak: k as u32 * 3,
        },
        per_bank: [k, 2 * k, 3 * k, 4 * k],
        per_bank_peak: [k as u32, 9, 1],
        grid: [[1, 2], [3, k as u16]],
        per_tag: vec![k; k as usize],
        per_unit: vec![
            Inner {
                hits: k,
                peak: k as u32
            };
            2
        ],
        per_tag_peak: vec![k; k as usize],
    }
}

#[test]
fn sums_and_maxes_each_field() {
    let (mut a, b) = (sample(2), sample(5));
    a += &b;
    assert_eq!(a.reads, 7);
    assert_eq!(a.bytes, 7 * 64);
    assert_eq!(a.energy_j, 3.5);
    assert_eq!(a.max_queue, 50);
    assert_eq!((a.latency.count, a.latency.min, a.latency.max), (2, 2, 5));
    assert_eq!(a.inner, Inner { hits: 9, peak: 15 });
    assert_eq!(a.per_bank, [7, 14, 21, 28]);
    assert_eq!(a.per_bank_peak, [5, 9, 1]);
    assert_eq!(a.grid, [[2, 4], [6, 7]]);
    // Vecs grow to the longer side; missing elements count as default (0).
    assert_eq!(a.per_tag, vec![7, 7, 5, 5, 5]);
    assert_eq!(a.per_tag_peak, vec![5; 5]);
    assert_eq!(a.per_unit, vec![Inner { hits: 7, peak: 5 }; 2]);
}

#[test]
fn by_value_equals_by_reference() {
    let (mut x, mut y) = (sample(3), sample(3));
    x += sample(4);
    y += &sample(4);
    assert_eq!(x, y);
    let mut p = Pair(1, 7);
    p += Pair(2, 3);
    assert_eq!(p, Pair(3, 7));
}

#[test]
fn every_field_is_merged() {
    assert_merges_every_field(&sample(2));
    assert_merges_every_field(&Pair(1, 1));
    assert_merges_every_field(&rtsim_sim::LinkStats::default());
}

/// The checker itself must catch a field left out of a hand-written sum.
#[test]
#[should_panic(expected = "missed")]
fn checker_catches_a_forgotten_field() {
    #[derive(Clone, Debug, Default, Serialize, Deserialize)]
    struct Forgetful {
        counted: u64,
        missed: u64,
    }
    impl std::ops::AddAssign<&Forgetful> for Forgetful {
        fn add_assign(&mut self, o: &Forgetful) {
            self.counted += o.counted;
        }
    }
    assert_merges_every_field(&Forgetful::default());
}
