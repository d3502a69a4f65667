//! Seeded, deterministic random numbers.
//!
//! [`Pcg32`] is O'Neill's PCG-XSH-RR generator (64-bit state, 32-bit output; "PCG: A Family of
//! Simple Fast Space-Efficient Statistically Good Algorithms for Random Number Generation",
//! 2014), the generator pbrt-v4 uses. Work is split into independent streams derived from
//! (seed, pixel, sample) by [`stream_seed`], so every pixel sees the same numbers whatever the
//! thread count or scheduling order: renders are bit-identical single- and multi-threaded.

const PCG_MULT: u64 = 0x5851_f42d_4c95_7f2d;

/// PCG-XSH-RR 64/32. `Copy`, so that a parked path state is plain data (a hardware model
/// moves it between queues); a copy continues the same sequence independently.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Pcg32 {
    state: u64,
    inc: u64,
}

impl Pcg32 {
    /// A generator on stream `stream` (any value; distinct streams are independent sequences)
    /// starting from `seed`.
    pub fn new(seed: u64, stream: u64) -> Self {
        let mut g = Pcg32 {
            state: 0,
            inc: (stream << 1) | 1,
        };
        g.next_u32();
        g.state = g.state.wrapping_add(seed);
        g.next_u32();
        g
    }

    #[inline(always)]
    pub fn next_u32(&mut self) -> u32 {
        let old = self.state;
        self.state = old.wrapping_mul(PCG_MULT).wrapping_add(self.inc);
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        let rot = (old >> 59) as u32;
        xorshifted.rotate_right(rot)
    }

    #[inline(always)]
    pub fn next_u64(&mut self) -> u64 {
        ((self.next_u32() as u64) << 32) | self.next_u32() as u64
    }

    /// Uniform in `[0, 1)`, using the top 24 bits so every value is exactly representable.
    #[inline(always)]
    pub fn next_f32(&mut self) -> f32 {
        (self.next_u32() >> 8) as f32 * (1.0 / (1u32 << 24) as f32)
    }

    /// Uniform in `[0, 1)` with 53 bits.
    #[inline(always)]
    pub fn next_f64(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    /// Uniform integer in `[0, n)` (Lemire's multiply-shift with rejection; `n > 0`).
    #[inline]
    pub fn below(&mut self, n: u32) -> u32 {
        debug_assert!(n > 0);
        let threshold = n.wrapping_neg() % n;
        loop {
            let m = self.next_u32() as u64 * n as u64;
            if (m as u32) >= threshold {
                return (m >> 32) as u32;
            }
        }
    }
}

/// SplitMix64 finaliser (Steele et al., 2014): a bijective 64-bit mixer.
#[inline(always)]
pub fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// Seed for the generator of one work item (a pixel's sample, a procedural object, ...):
/// a hash of the run seed and the item's coordinates, independent of evaluation order.
#[inline]
pub fn stream_seed(seed: u64, a: u64, b: u64) -> u64 {
    mix64(mix64(seed ^ 0x9e37_79b9_7f4a_7c15).wrapping_add(a) ^ mix64(b.wrapping_add(0x632b_e59b)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reference_sequence() {
        // pcg32-demo from the PCG reference implementation: seed 42, stream 54.
        let mut g = Pcg32::new(42, 54);
        let got: Vec<u32> = (0..6).map(|_| g.next_u32()).collect();
        assert_eq!(
            got,
            [
                0xa15c02b7, 0x7b47f409, 0xba1d3330, 0x83d2f293, 0xbfa4784b, 0xcbed606e
            ]
        );
    }

    #[test]
    fn f32_in_unit_interval() {
        let mut g = Pcg32::new(1, 2);
        for _ in 0..10_000 {
            let v = g.next_f32();
            assert!((0.0..1.0).contains(&v));
        }
    }

    #[test]
    fn below_is_in_range_and_covers() {
        let mut g = Pcg32::new(7, 0);
        let mut seen = [false; 5];
        for _ in 0..1000 {
            seen[g.below(5) as usize] = true;
        }
        assert!(seen.iter().all(|&s| s));
    }

    #[test]
    fn streams_differ() {
        assert_ne!(stream_seed(1, 0, 0), stream_seed(1, 1, 0));
        assert_ne!(stream_seed(1, 0, 0), stream_seed(1, 0, 1));
        assert_ne!(stream_seed(1, 0, 0), stream_seed(2, 0, 0));
    }
}
