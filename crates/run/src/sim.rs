//! The `[sim]` section: controls of a timed simulation that are not part of any chip —
//! which pixels, how long, and which timing engine.

use rtsim_config::{ConfigError, Validate};
use serde::{Deserialize, Serialize};

/// How time advances.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum SimMode {
    /// Event-driven: idle hardware costs nothing, units run ahead until they touch shared
    /// state (default). Proven equal to `reference` by the chips' tests.
    Fast,
    /// Plain cycle-by-cycle stepping of every unit: slow, for small configurations and for
    /// checking `fast`.
    Reference,
}

/// Simulation controls.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SimConfig {
    /// Pixels to simulate, `[x0, y0, x1, y1]` (x1, y1 exclusive) of the workload image; the
    /// rest of the image stays black. Unset = the whole image.
    pub window: Option<[u32; 4]>,
    /// Stop after this many core cycles; the frame is then incomplete and the stats say so.
    /// Unset = run to the end.
    pub cycle_limit: Option<u64>,
    /// `fast` (default) or `reference`.
    pub mode: SimMode,
    /// Record the frame's time series (`timeline.csv`: instructions, atomic grants, cache,
    /// DRAM and, on STRaTA, stream-memory counters per interval) in intervals of this many
    /// core cycles. TRaX-family chips (`trax-baseline`, `strata`) only; the run then uses one
    /// host thread. Unset = none.
    pub timeline_cycles: Option<u64>,
}

impl Default for SimConfig {
    fn default() -> Self {
        SimConfig {
            window: None,
            cycle_limit: None,
            mode: SimMode::Fast,
            timeline_cycles: None,
        }
    }
}

impl SimConfig {
    /// Check the window against the image size.
    pub fn validate_for(&self, width: u32, height: u32) -> Result<(), ConfigError> {
        if let Some([x0, y0, x1, y1]) = self.window
            && !(x0 < x1 && y0 < y1 && x1 <= width && y1 <= height)
        {
            return Err(ConfigError::range(
                "sim.window",
                format!("[{x0}, {y0}, {x1}, {y1}]"),
                format!("x0 < x1 <= {width} and y0 < y1 <= {height} (the workload image)"),
            ));
        }
        if self.cycle_limit == Some(0) {
            return Err(ConfigError::range(
                "sim.cycle_limit",
                0,
                "at least 1, or unset",
            ));
        }
        if self.timeline_cycles == Some(0) {
            return Err(ConfigError::range(
                "sim.timeline_cycles",
                0,
                "at least 1, or unset",
            ));
        }
        Ok(())
    }

    /// The pixels to simulate, row-major within the window.
    pub fn pixels(&self, width: u32, height: u32) -> Vec<u32> {
        let [x0, y0, x1, y1] = self.window.unwrap_or([0, 0, width, height]);
        (y0..y1)
            .flat_map(|y| (x0..x1).map(move |x| y * width + x))
            .collect()
    }
}

impl Validate for SimConfig {
    fn validate(&self) -> Result<(), ConfigError> {
        Ok(())
    }
}
