//! [`Ratio`]: exact cycle conversion between two clock domains, fast on the hot path.
//!
//! The frequencies are [`rtsim_core::Clock`]s (independent integers in hertz: a 1 GHz TRaX core
//! with a 2 GHz GDDR5 clock, a 500 MHz SGRT T&I unit with 800 MHz LPDDR3). `Ratio` reduces the
//! fraction once, so the common ratios convert with one multiply and one division in 64 bits,
//! falling back to `Clock`'s 128-bit arithmetic only when the product would overflow; the result
//! always equals [`Clock::to_ceil`] / [`Clock::to_floor`].

use rtsim_core::Clock;

/// Exact conversion `cycles · num / den` from one clock to another, with the fraction reduced.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Ratio {
    num: u64,
    den: u64,
    /// log2(`den`) where `den` is a power of two (a 2 GHz memory under a 1 GHz requester),
    /// else `u32::MAX`: those divisions are shifts.
    den_shift: u32,
    from: Clock,
    to: Clock,
}

fn gcd(mut a: u64, mut b: u64) -> u64 {
    while b != 0 {
        (a, b) = (b, a % b);
    }
    a
}

impl Ratio {
    /// Conversion from cycles of `from` to cycles of `to`.
    pub fn new(from: Clock, to: Clock) -> Self {
        let g = gcd(from.hz, to.hz).max(1);
        let den = from.hz / g;
        Ratio {
            num: to.hz / g,
            den,
            den_shift: if den.is_power_of_two() {
                den.trailing_zeros()
            } else {
                u32::MAX
            },
            from,
            to,
        }
    }
    /// The source clock.
    pub fn from_clock(&self) -> Clock {
        self.from
    }
    /// The target clock.
    pub fn to_clock(&self) -> Clock {
        self.to
    }
    /// The reverse conversion.
    pub fn inverse(&self) -> Ratio {
        Ratio::new(self.to, self.from)
    }
    /// The first cycle of the target clock at or after `cycles` of the source clock.
    #[inline]
    pub fn ceil(&self, cycles: u64) -> u64 {
        match cycles.checked_mul(self.num) {
            Some(n) if self.den_shift != u32::MAX => {
                (n >> self.den_shift) + u64::from(n & (self.den - 1) != 0)
            }
            Some(n) => n.div_ceil(self.den),
            None => self.from.to_ceil(cycles, self.to),
        }
    }
    /// The last cycle of the target clock at or before `cycles` of the source clock.
    #[inline]
    pub fn floor(&self, cycles: u64) -> u64 {
        match cycles.checked_mul(self.num) {
            Some(n) if self.den_shift != u32::MAX => n >> self.den_shift,
            Some(n) => n / self.den,
            None => self.from.to_floor(cycles, self.to),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ratio_matches_clock_conversion() {
        for (a, b) in [
            (1000, 2000),
            (500, 800),
            (733, 1600),
            (1600, 1600),
            (2000, 1000),
            (2000, 500),
        ] {
            let (x, y) = (Clock::from_mhz(a), Clock::from_mhz(b));
            let r = Ratio::new(x, y);
            for c in [
                0u64,
                1,
                2,
                3,
                7,
                1000,
                123_456_789,
                u64::MAX / 3,
                u64::MAX / 2000,
            ] {
                assert_eq!(r.ceil(c), x.to_ceil(c, y), "{a}->{b} ceil {c}");
                assert_eq!(r.floor(c), x.to_floor(c, y), "{a}->{b} floor {c}");
            }
        }
    }

    #[test]
    fn sgrt_and_trax_ratios() {
        let r = Ratio::new(Clock::from_mhz(500), Clock::from_mhz(800));
        assert_eq!((r.ceil(1), r.floor(1)), (2, 1)); // 1.6 memory cycles
        assert_eq!(r.inverse().ceil(8), 5);
        let t = Ratio::new(Clock::from_mhz(1000), Clock::from_mhz(2000));
        assert_eq!(
            (t.ceil(21), t.inverse().ceil(21), t.inverse().floor(21)),
            (42, 11, 10)
        );
        assert_eq!(t.from_clock(), Clock::from_mhz(1000));
        assert_eq!(t.to_clock(), Clock::from_mhz(2000));
    }
}
