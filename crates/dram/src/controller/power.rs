//! Rank power states over time, for background energy (Micron TN-41-01): precharge standby (all
//! banks closed), active standby (some bank open), and the two power-down states.
//!
//! A bank counts as open from its ACT until its precharge: an explicit PRE closes it at once;
//! an auto-precharge (RDA/WRA) closes it when the device actually precharges, a few cycles after
//! the column command, so those closes are queued and applied in time order.

/// Background states, in the order of [`RankPower::cycles`].
pub const STATES: [&str; 4] = [
    "precharge_standby",
    "active_standby",
    "precharge_power_down",
    "active_power_down",
];

#[derive(Clone, Debug, Default)]
pub struct RankPower {
    open: u32,
    powered_down: bool,
    since: u64,
    /// Cycles spent in each of [`STATES`].
    pub cycles: [u64; 4],
    /// Future bank closes (auto-precharge), sorted.
    closes: Vec<u64>,
}

impl RankPower {
    #[inline]
    fn state(&self) -> usize {
        usize::from(self.open > 0) + 2 * usize::from(self.powered_down)
    }

    #[inline]
    fn account(&mut self, t: u64) {
        let s = self.state();
        self.cycles[s] += t.saturating_sub(self.since);
        self.since = self.since.max(t);
    }

    /// Apply queued closes up to cycle `t`.
    #[inline]
    fn settle(&mut self, t: u64) {
        while let Some(&c) = self.closes.first() {
            if c > t {
                break;
            }
            self.closes.remove(0);
            self.account(c);
            self.open -= 1;
        }
    }

    /// A bank opened (ACT) at `t`.
    pub fn open(&mut self, t: u64) {
        self.settle(t);
        self.account(t);
        self.open += 1;
    }

    /// A bank closed (PRE) at `t`.
    pub fn close(&mut self, t: u64) {
        self.settle(t);
        self.account(t);
        self.open -= 1;
    }

    /// A bank will close at `at` (auto-precharge); `now` is the current cycle.
    pub fn close_at(&mut self, now: u64, at: u64) {
        self.settle(now);
        let pos = self.closes.partition_point(|&c| c <= at);
        self.closes.insert(pos, at.max(now));
    }

    /// Power-down entered (`true`) or left at `t`.
    pub fn set_powered_down(&mut self, t: u64, down: bool) {
        self.settle(t);
        self.account(t);
        self.powered_down = down;
    }

    /// Account up to `t` (end of the run or a snapshot).
    pub fn finish(&mut self, t: u64) {
        self.settle(t);
        self.account(t);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn states_accumulate_in_time_order() {
        let mut p = RankPower::default();
        p.open(10); // 0..10 precharge standby
        p.close_at(20, 30); // auto-precharge completes at 30
        p.set_powered_down(40, true); // 10..30 active, 30..40 precharge standby
        p.set_powered_down(50, false); // 40..50 precharge power-down
        p.finish(60); // 50..60 precharge standby
        assert_eq!(p.cycles, [30, 20, 10, 0]);
    }
}
