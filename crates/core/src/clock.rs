//! Clock domains and exact conversion between them.
//!
//! Requesters and memories tick at independent integer frequencies. A time is a cycle count in
//! one domain; converting to another domain is exact integer arithmetic in 128 bits
//! (`cycles · to_hz / from_hz`), rounded up when an event must not be seen early (a request
//! arriving at requester cycle `c` is visible to the memory at the first memory cycle at or
//! after that instant) and rounded down when reporting elapsed time.

use serde::{Deserialize, Serialize};

/// A clock domain given by its frequency in hertz.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Clock {
    pub hz: u64,
}

impl Clock {
    pub const fn from_mhz(mhz: u64) -> Self {
        Clock {
            hz: mhz * 1_000_000,
        }
    }
    pub const fn from_hz(hz: u64) -> Self {
        Clock { hz }
    }
    /// Period in picoseconds (rounded to nearest), for reports.
    pub fn period_ps(&self) -> f64 {
        1e12 / self.hz as f64
    }
    /// Seconds taken by `cycles` cycles of this clock.
    pub fn seconds(&self, cycles: u64) -> f64 {
        cycles as f64 / self.hz as f64
    }
    /// The first cycle of `to` at or after cycle `cycles` of `self`.
    #[inline]
    pub fn to_ceil(&self, cycles: u64, to: Clock) -> u64 {
        if self.hz == to.hz {
            return cycles;
        }
        let n = cycles as u128 * to.hz as u128;
        n.div_ceil(self.hz as u128) as u64
    }
    /// The last cycle of `to` at or before cycle `cycles` of `self`.
    #[inline]
    pub fn to_floor(&self, cycles: u64, to: Clock) -> u64 {
        if self.hz == to.hz {
            return cycles;
        }
        (cycles as u128 * to.hz as u128 / self.hz as u128) as u64
    }
    /// `cycles` of this clock expressed in `to`'s cycles, as a real number (for averages).
    pub fn to_f64(&self, cycles: f64, to: Clock) -> f64 {
        cycles * to.hz as f64 / self.hz as f64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn core_to_gddr5() {
        let core = Clock::from_mhz(1000);
        let mem = Clock::from_mhz(2000);
        assert_eq!(core.to_ceil(10, mem), 20);
        assert_eq!(mem.to_ceil(21, core), 11);
        assert_eq!(mem.to_floor(21, core), 10);
    }

    #[test]
    fn odd_ratio_is_exact() {
        // 500 MHz T&I unit and 800 MHz LPDDR3-1600 clock: 5 : 8.
        let trv = Clock::from_mhz(500);
        let mem = Clock::from_mhz(800);
        assert_eq!(trv.to_ceil(5, mem), 8);
        assert_eq!(trv.to_ceil(1, mem), 2); // 1.6 rounds up
        assert_eq!(mem.to_floor(8, trv), 5);
        assert_eq!(mem.to_ceil(u64::MAX / 2, mem), u64::MAX / 2);
    }
}
