//! The `[baseline]` section: the state-variable filter of the equation-error fit.

use crate::config::{check_range, check_range_open_low, ConfigError};
use crate::wire::Method;
use serde::{Deserialize, Serialize};

/// The time-domain baseline (see `crate::baseline`): a state-variable filter
/// `F(s) = lambda^2 / (s + lambda)^2` on heading and rudder, then least squares of
/// `s^2 F psi = -a s F psi + b F delta + c`.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(default, deny_unknown_fields, rename_all = "kebab-case")]
pub struct BaselineConfig {
    /// Filter bandwidth lambda [rad/s]: above the ship's band (0.01 .. 0.2 rad/s) so its
    /// motion passes, below the wave band (0.8 rad/s), which leaks into the regressor
    /// `s F psi` as an error in the variables and biases `a` towards zero.
    pub filter_rad_s: f64,
    /// Filtered samples left out at the start of each record: the filter's start-up
    /// transient, which decays as `(lambda t) e^{-lambda t}` [s]; at least 5 / lambda.
    pub transient_s: f64,
    /// Spread of its speed from a, CLFRT record, `[calm, moderate]` [m/s]: the rms error of
    /// its calibration table (`tests/it/baseline.rs`, `calibration_table`).
    pub clfrt_speed_sigma_mps: [f64; 2],
    /// Spread of its displacement from b and the speed log, CLFRT record [t].
    pub clfrt_displacement_sigma_t: [f64; 2],
    /// Spread of its speed, HBT record [m/s].
    pub hbt_speed_sigma_mps: [f64; 2],
    /// Spread of its displacement, HBT record [t].
    pub hbt_displacement_sigma_t: [f64; 2],
}

impl Default for BaselineConfig {
    fn default() -> Self {
        Self {
            filter_rad_s: 0.15,
            transient_s: 80.0,
            clfrt_speed_sigma_mps: [0.07, 0.33],
            clfrt_displacement_sigma_t: [20.0, 100.0],
            hbt_speed_sigma_mps: [0.04, 0.16],
            hbt_displacement_sigma_t: [12.0, 65.0],
        }
    }
}

impl BaselineConfig {
    /// Checks the section's limits; the error names the key and its allowed range.
    pub fn check(&self) -> Result<(), ConfigError> {
        check_range("baseline.filter-rad-s", self.filter_rad_s, 0.01, 2.0)?;
        check_range(
            "baseline.transient-s",
            self.transient_s,
            5.0 / self.filter_rad_s,
            600.0,
        )?;
        for (key, p, hi) in [
            (
                "baseline.clfrt-speed-sigma-mps",
                self.clfrt_speed_sigma_mps,
                100.0,
            ),
            (
                "baseline.clfrt-displacement-sigma-t",
                self.clfrt_displacement_sigma_t,
                1e6,
            ),
            (
                "baseline.hbt-speed-sigma-mps",
                self.hbt_speed_sigma_mps,
                100.0,
            ),
            (
                "baseline.hbt-displacement-sigma-t",
                self.hbt_displacement_sigma_t,
                1e6,
            ),
        ] {
            check_range_open_low(key, p[0], 0.0, hi)?;
            check_range_open_low(key, p[1], 0.0, hi)?;
        }
        Ok(())
    }

    /// The `(speed [m/s], displacement [t])` spread pairs for `method`'s record.
    pub fn sigmas(&self, method: Method) -> ([f64; 2], [f64; 2]) {
        match method {
            Method::Clfrt => (self.clfrt_speed_sigma_mps, self.clfrt_displacement_sigma_t),
            Method::Hbt => (self.hbt_speed_sigma_mps, self.hbt_displacement_sigma_t),
        }
    }
}
