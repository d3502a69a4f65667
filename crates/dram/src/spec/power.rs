//! Energy per DRAM event from datasheet IDD currents, after Micron TN-41-01 ("Calculating Memory
//! System Power for DDR3", 2007).
//!
//! Per device, with VDD and currents in A and tCK in s:
//! - activate + precharge pair: `VDD · (IDD0·tRC − (IDD3N·tRAS + IDD2N·(tRC − tRAS))) · tCK`
//!   (the ACT/PRE current above the background it replaces);
//! - read (write) burst: `VDD · (IDD4R − IDD3N) · burst_cycles · tCK` (IDD4W for writes);
//! - refresh: `VDD · (IDD5 − IDD3N) · tRFC · tCK`;
//! - background power by rank state: precharge standby `VDD·IDD2N`, active standby `VDD·IDD3N`,
//!   precharge power-down `VDD·IDD2P` (fast exit, IDD2P1), active power-down `VDD·IDD3P`.
//!
//! Everything is multiplied by the devices per rank. I/O and termination power are not modelled
//! (TN-41-01 adds them from board-level values that the presets do not have).

use super::{Org, Timings};
use crate::config::Currents;
use rtsim_config::ConfigError;
use rtsim_core::Clock;
use serde::Serialize;

/// Energies per event and background powers, for one rank.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct EventEnergy {
    /// Joules per ACT-PRE pair.
    pub act_pre_j: f64,
    /// Joules per line read (all of its bursts).
    pub read_j: f64,
    /// Joules per line written.
    pub write_j: f64,
    /// Joules per REF.
    pub refresh_j: f64,
    /// Watts in precharge standby (all banks closed).
    pub precharge_standby_w: f64,
    /// Watts in active standby (some bank open).
    pub active_standby_w: f64,
    /// Watts in precharge power-down.
    pub precharge_power_down_w: f64,
    /// Watts in active power-down.
    pub active_power_down_w: f64,
}

impl EventEnergy {
    pub fn new(c: &Currents, t: &Timings, org: &Org, clock: Clock) -> Result<Self, ConfigError> {
        let tck = 1.0 / clock.hz as f64;
        let n = f64::from(org.devices_per_rank);
        let ma = |i: f64| i * 1e-3;
        let act_charge = ma(c.idd0) * t.rc as f64
            - (ma(c.idd3n) * t.ras as f64 + ma(c.idd2n) * (t.rc - t.ras) as f64);
        if act_charge < 0.0 {
            return Err(ConfigError::range(
                "current.idd0",
                c.idd0,
                format!(
                    ">= (idd3n·tRAS + idd2n·(tRC−tRAS)) / tRC = {:.1} mA (the activate energy \
                     of TN-41-01 would be negative)",
                    (c.idd3n * t.ras as f64 + c.idd2n * (t.rc - t.ras) as f64) / t.rc as f64
                ),
            ));
        }
        Ok(EventEnergy {
            act_pre_j: n * c.vdd * act_charge * tck,
            read_j: n * c.vdd * ma(c.idd4r - c.idd3n) * t.burst as f64 * tck,
            write_j: n * c.vdd * ma(c.idd4w - c.idd3n) * t.burst as f64 * tck,
            refresh_j: n * c.vdd * ma(c.idd5 - c.idd3n) * t.rfc as f64 * tck,
            precharge_standby_w: n * c.vdd * ma(c.idd2n),
            active_standby_w: n * c.vdd * ma(c.idd3n),
            precharge_power_down_w: n * c.vdd * ma(c.idd2p1),
            active_power_down_w: n * c.vdd * ma(c.idd3p),
        })
    }
}
