//! The `[baseline]` section: the state-variable filter of the equation-error fit.

use crate::core::config::{check_range, ConfigError};
use serde::{Deserialize, Serialize};

/// The time-domain baseline (see `crate::core::baseline`): a state-variable filter
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
}

impl Default for BaselineConfig {
    fn default() -> Self {
        Self {
            filter_rad_s: 0.15,
            transient_s: 80.0,
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
        Ok(())
    }
}
