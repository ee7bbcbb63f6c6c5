//! The ship as the method models it, its particulars and its streams: the first-order
//! Nomoto model both ways (particulars and (u, D) to (a, b), and back), the rudder servo,
//! the sensors' rates and noise, and the named sea states.
//!
//! Model (docs/architecture.md, "The model and its units"), heading psi [rad], rudder
//! delta [rad]:
//!
//! ```text
//! psi(s) / delta(s) = b / (s (s + a))
//! a = a0 u / l  [1/s],   b = 0.5 (u/l)^2 A l / V  [1/s^2],   V = D / rho  [m^3]
//! ```

use crate::config::{check_range, check_range_open_low, ConfigError, DEG};
use serde::{Deserialize, Serialize};

// ---------------------------------------------------------------------------------------------
// Ship

/// Nomoto ship model parameters (a = a0 u / l, b = 0.5 (u/l)^2 A l / V, V = D / rho).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(default, deny_unknown_fields, rename_all = "kebab-case")]
pub struct ShipConfig {
    /// Ship length l [m].
    pub length_m: f64,
    /// Non-dimensional yaw damping a0 (1/T').
    pub yaw_damping_a0: f64,
    /// Rudder area A [m^2].
    pub rudder_area_m2: f64,
    /// Sea-water density rho [t/m^3].
    pub water_density_t_m3: f64,
    /// Nominal speed through water [m/s].
    pub nominal_speed_mps: f64,
    /// Nominal displacement [t].
    pub nominal_displacement_t: f64,
    /// Speed range the method covers [m/s] (training range of the estimator).
    pub speed_range_mps: [f64; 2],
    /// Displacement range the method covers [t].
    pub displacement_range_t: [f64; 2],
}

impl Default for ShipConfig {
    fn default() -> Self {
        Self {
            length_m: 120.0,
            yaw_damping_a0: 0.25,
            rudder_area_m2: 20.0,
            water_density_t_m3: 1.025,
            nominal_speed_mps: 7.0,
            nominal_displacement_t: 7000.0,
            speed_range_mps: [4.0, 10.0],
            displacement_range_t: [4000.0, 10000.0],
        }
    }
}

impl ShipConfig {
    /// Checks the section's limits; the error names the key and its allowed range.
    pub fn check(&self) -> Result<(), ConfigError> {
        check_range_open_low("ship.length-m", self.length_m, 0.0, 500.0)?;
        check_range_open_low("ship.yaw-damping-a0", self.yaw_damping_a0, 0.0, 10.0)?;
        check_range_open_low("ship.rudder-area-m2", self.rudder_area_m2, 0.0, 500.0)?;
        check_range("ship.water-density-t-m3", self.water_density_t_m3, 0.9, 1.1)?;
        check_range(
            "ship.speed-range-mps[0]",
            self.speed_range_mps[0],
            0.5,
            30.0,
        )?;
        check_range(
            "ship.speed-range-mps[1]",
            self.speed_range_mps[1],
            self.speed_range_mps[0],
            30.0,
        )?;
        check_range(
            "ship.displacement-range-t[0]",
            self.displacement_range_t[0],
            1.0,
            1.0e6,
        )?;
        check_range(
            "ship.displacement-range-t[1]",
            self.displacement_range_t[1],
            self.displacement_range_t[0],
            1.0e6,
        )?;
        check_range(
            "ship.nominal-speed-mps",
            self.nominal_speed_mps,
            self.speed_range_mps[0],
            self.speed_range_mps[1],
        )?;
        check_range(
            "ship.nominal-displacement-t",
            self.nominal_displacement_t,
            self.displacement_range_t[0],
            self.displacement_range_t[1],
        )?;
        Ok(())
    }

    /// Nomoto parameters `(a [1/s], b [1/s^2])` at speed `u` [m/s] and displacement `d` [t].
    pub fn nomoto(&self, speed_mps: f64, displacement_t: f64) -> (f64, f64) {
        let ul = speed_mps / self.length_m;
        let volume_m3 = displacement_t / self.water_density_t_m3;
        let a = self.yaw_damping_a0 * ul;
        let b = 0.5 * ul * ul * self.rudder_area_m2 * self.length_m / volume_m3;
        (a, b)
    }
}

// The model the other way: from the Nomoto parameters back to the ship's state.

/// Speed through water from the yaw damping: `u = a l / a0` [m/s].
pub fn speed_from_a(a_per_s: f64, ship: &ShipConfig) -> f64 {
    a_per_s * ship.length_m / ship.yaw_damping_a0
}

/// Displacement from the rudder gain at speed `speed_mps`:
/// `D = rho 0.5 (u/l)^2 A l / b` [t].
pub fn displacement_from_b(b_per_s2: f64, speed_mps: f64, ship: &ShipConfig) -> f64 {
    let ul = speed_mps / ship.length_m;
    ship.water_density_t_m3 * 0.5 * ul * ul * ship.rudder_area_m2 * ship.length_m / b_per_s2
}

// ---------------------------------------------------------------------------------------------
// Servo

/// Rudder servo (Fig. 7 of the method's paper, named in the README; docs/sim.md, "Servo"):
/// command clamped, first-order lag, rate limit, angle limit.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(default, deny_unknown_fields, rename_all = "kebab-case")]
pub struct ServoConfig {
    /// Angle limit on command and rudder [deg].
    pub max_angle_deg: f64,
    /// Rate limit [deg/s].
    pub max_rate_deg_s: f64,
    /// Time constant T_r of the servo loop [s].
    pub time_constant_s: f64,
}

impl Default for ServoConfig {
    fn default() -> Self {
        Self {
            max_angle_deg: 30.0,
            max_rate_deg_s: 4.0,
            time_constant_s: 1.0,
        }
    }
}

impl ServoConfig {
    /// Checks the section's limits; the error names the key and its allowed range.
    pub fn check(&self) -> Result<(), ConfigError> {
        check_range_open_low("servo.max-angle-deg", self.max_angle_deg, 0.0, 45.0)?;
        check_range_open_low("servo.max-rate-deg-s", self.max_rate_deg_s, 0.0, 20.0)?;
        check_range_open_low("servo.time-constant-s", self.time_constant_s, 0.0, 10.0)?;
        Ok(())
    }
    /// Angle limit [rad].
    pub fn max_angle_rad(&self) -> f64 {
        self.max_angle_deg * DEG
    }
    /// Rate limit [rad/s].
    pub fn max_rate_rad_s(&self) -> f64 {
        self.max_rate_deg_s * DEG
    }
}

// ---------------------------------------------------------------------------------------------
// Sensors

/// Sensor rates and white-noise levels (standard deviations).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(default, deny_unknown_fields, rename_all = "kebab-case")]
pub struct SensorConfig {
    /// Sample rate of heading, rudder and speed [Hz] (also the autopilot's rate).
    pub rate_hz: f64,
    /// Gyro heading noise [deg].
    pub heading_noise_deg: f64,
    /// Rudder angle indicator noise [deg].
    pub rudder_noise_deg: f64,
    /// Speed log noise [m/s].
    pub speed_noise_mps: f64,
    /// Period of the autopilot state and target heading publications [s].
    pub status_period_s: f64,
}

impl Default for SensorConfig {
    fn default() -> Self {
        Self {
            rate_hz: 10.0,
            heading_noise_deg: 0.05,
            rudder_noise_deg: 0.1,
            speed_noise_mps: 0.05,
            status_period_s: 1.0,
        }
    }
}

impl SensorConfig {
    /// Checks the section's limits; the error names the key and its allowed range.
    pub fn check(&self) -> Result<(), ConfigError> {
        check_range("sensors.rate-hz", self.rate_hz, 1.0, 100.0)?;
        check_range(
            "sensors.heading-noise-deg",
            self.heading_noise_deg,
            0.0,
            5.0,
        )?;
        check_range("sensors.rudder-noise-deg", self.rudder_noise_deg, 0.0, 5.0)?;
        check_range("sensors.speed-noise-mps", self.speed_noise_mps, 0.0, 2.0)?;
        check_range_open_low("sensors.status-period-s", self.status_period_s, 0.0, 60.0)?;
        Ok(())
    }
    /// Sample period [s].
    pub fn dt_s(&self) -> f64 {
        1.0 / self.rate_hz
    }
}

// ---------------------------------------------------------------------------------------------
// Sea states

/// Named sea states (docs/sim.md, "Sea").
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq, Eq, Hash, Default)]
#[serde(rename_all = "kebab-case")]
pub enum SeaState {
    /// Wave yaw 0.05 deg, bias 0.1 deg.
    Calm,
    /// Wave yaw 0.2 deg, bias 0.5 deg (default).
    #[default]
    Moderate,
    /// Wave yaw 0.5 deg, bias 1.0 deg.
    Rough,
}

impl SeaState {
    /// All sea states, calm first.
    pub const ALL: [SeaState; 3] = [SeaState::Calm, SeaState::Moderate, SeaState::Rough];
    /// The lower-case name used on the command line and in reports.
    pub fn name(self) -> &'static str {
        match self {
            SeaState::Calm => "calm",
            SeaState::Moderate => "moderate",
            SeaState::Rough => "rough",
        }
    }
}

impl std::str::FromStr for SeaState {
    type Err = crate::config::UnknownName;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "calm" => Ok(SeaState::Calm),
            "moderate" => Ok(SeaState::Moderate),
            "rough" => Ok(SeaState::Rough),
            other => Err(Self::Err::new("sea state", other, "calm, moderate, rough")),
        }
    }
}
