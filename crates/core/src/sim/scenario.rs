//! What is simulated (the true speed and displacement, the sea, the faults, the seed) and
//! the switches for tests (noise, disturbances).

use super::config::SimConfig;
use super::{Fault, SimError};
use crate::model::SeaState;

/// What is simulated: the true speed and displacement, the sea, the faults, the seed.
#[derive(Debug, Clone, PartialEq)]
pub struct Scenario {
    /// True speed through water u [m/s] (> 0).
    pub speed_mps: f64,
    /// True displacement D [t] (> 0), before any displacement fault.
    pub displacement_t: f64,
    /// Sea state (disturbance levels from `SeaConfig::levels`).
    pub sea: SeaState,
    /// Faults, each with its onset.
    pub faults: Vec<Fault>,
    /// Seed of the only random generator.
    pub seed: u64,
}

impl Scenario {
    /// The nominal ship of `cfg` in its configured sea state, no fault.
    pub fn nominal(cfg: &SimConfig, seed: u64) -> Self {
        Self {
            speed_mps: cfg.ship.nominal_speed_mps,
            displacement_t: cfg.ship.nominal_displacement_t,
            sea: cfg.sea.state,
            faults: Vec::new(),
            seed,
        }
    }

    /// Checks the speed and displacement (finite, > 0) and every fault.
    pub(super) fn check(&self) -> Result<(), SimError> {
        let positive = |field, value: f64| {
            if value.is_finite() && value > 0.0 {
                Ok(())
            } else {
                Err(SimError::Scenario {
                    field,
                    value,
                    allowed: "finite and > 0",
                })
            }
        };
        positive("speed_mps", self.speed_mps)?;
        positive("displacement_t", self.displacement_t)?;
        for f in &self.faults {
            f.check()?;
        }
        Ok(())
    }
}

/// Switches for tests: run without sensor noise, without sea disturbances, or both.
///
/// Switching off scales the random draws by zero; the draws still happen, so the rest of the
/// realisation is unchanged.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SimOptions {
    /// White noise on heading, rudder and speed measurements.
    pub noise: bool,
    /// Rudder-equivalent bias and wave yaw.
    pub disturbances: bool,
}

impl Default for SimOptions {
    fn default() -> Self {
        Self {
            noise: true,
            disturbances: true,
        }
    }
}

impl SimOptions {
    /// No noise, no disturbance: the deterministic ship.
    pub const CLEAN: SimOptions = SimOptions {
        noise: false,
        disturbances: false,
    };
}
