//! The lifecycle every hardware unit follows: build from config → advance through events →
//! finish into stats (`../shared/STYLE.md` §2).
//!
//! A [`Component`] owns its state; the chip owns its components and the [`Link`](crate::Link)s
//! between them. Time is pulled, never pushed: the owner asks each component for
//! [`next_event`](Component::next_event), advances the earliest to that cycle, and repeats, so
//! idle hardware is never ticked. Advancing cycle by cycle ([`tick_until`]) must give exactly
//! the same result as jumping from event to event ([`run_until`]); components test that.
//!
//! # Example
//!
//! A unit that answers each request `delay` cycles later through a bounded link:
//!
//! ```
//! use rtsim_sim::{Component, Link, PushError, Stats, run_until, tick_until};
//!
//! #[derive(Clone, Debug, Default, PartialEq, Stats)]
//! struct EchoStats { answered: u64, #[stats(max)] last_cycle: u64 }
//!
//! struct Echo { link: Link<u32>, now: u64, stats: EchoStats }
//!
//! impl Component for Echo {
//!     type Config = (usize, u64); // (capacity, delay)
//!     type Stats = EchoStats;
//!     type Error = rtsim_sim::LinkError;
//!     fn build((cap, delay): Self::Config) -> Result<Self, Self::Error> {
//!         Ok(Echo { link: Link::new(cap, delay)?, now: 0, stats: EchoStats::default() })
//!     }
//!     fn next_event(&self) -> Option<u64> {
//!         self.link.next_ready()
//!     }
//!     fn advance_to(&mut self, cycle: u64) -> Result<(), Self::Error> {
//!         while let Some(_item) = self.link.pop(cycle)? {
//!             self.stats.answered += 1;
//!             self.stats.last_cycle = cycle;
//!         }
//!         self.now = cycle;
//!         Ok(())
//!     }
//!     fn finish(self, _end: u64) -> EchoStats {
//!         self.stats
//!     }
//! }
//!
//! let feed = |e: &mut Echo| -> Result<(), PushError<u32>> {
//!     for i in 0..3 { e.link.push(0, i)?; }
//!     Ok(())
//! };
//! let mut jumping = Echo::build((4, 10)).unwrap();
//! let mut ticking = Echo::build((4, 10)).unwrap();
//! feed(&mut jumping).unwrap();
//! feed(&mut ticking).unwrap();
//! run_until(&mut jumping, 100).unwrap();
//! tick_until(&mut ticking, 0, 100).unwrap();
//! assert_eq!(jumping.finish(100), ticking.finish(100));
//! ```

/// A hardware unit with a build → advance → finish lifecycle. Cycles are in the unit's clock.
pub trait Component: Sized {
    /// What it is built from: usually a validated config section, plus whatever the unit must
    /// own (e.g. the memory model behind a cache hierarchy).
    type Config;
    /// Its counters, summed with `+=` (derive them with [`Stats`](crate::Stats)).
    type Stats;
    /// Errors of building and of misuse (time going backwards).
    type Error: std::error::Error;

    /// Build from a configuration, validating it.
    fn build(config: Self::Config) -> Result<Self, Self::Error>;
    /// The earliest cycle at which the unit's state can change without new input, or `None`
    /// when it has nothing to do. Owners jump there instead of ticking idle cycles.
    fn next_event(&self) -> Option<u64>;
    /// Handle everything due up to and including `cycle`.
    fn advance_to(&mut self, cycle: u64) -> Result<(), Self::Error>;
    /// End of the run: account time up to `end` and hand over the counters.
    fn finish(self, end: u64) -> Self::Stats;
}

/// Jump from event to event until there is none at or before `limit`; returns the cycle of the
/// last event handled (`None` if there was none).
pub fn run_until<C: Component>(c: &mut C, limit: u64) -> Result<Option<u64>, C::Error> {
    let mut last = None;
    while let Some(t) = c.next_event().filter(|&t| t <= limit) {
        c.advance_to(t)?;
        last = Some(t);
    }
    Ok(last)
}

/// The plain cycle-by-cycle mode: advance through every cycle `from..=to`. Used by tests to
/// show that event skipping changes nothing.
pub fn tick_until<C: Component>(c: &mut C, from: u64, to: u64) -> Result<(), C::Error> {
    for t in from..=to {
        c.advance_to(t)?;
    }
    Ok(())
}
