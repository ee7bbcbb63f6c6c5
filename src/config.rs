//! Configuration: every number of the domain, with its default, its unit and its allowed range.
//!
//! The file format is TOML with kebab-case keys; unknown keys are rejected
//! (`deny_unknown_fields`). Units are part of the key names (`_deg`, `_s`, `_mps`, `_t`). Angles
//! are configured in degrees, which people read, and converted to radians, which the code uses,
//! by the accessor methods (`*_rad()`).
//!
//! Loading is two steps, as in ntpd-rs: serde parses the shape ([`Config::from_toml_str`]),
//! then [`Config::check`] enforces the semantic limits and names the offending key and its
//! allowed range in a [`ConfigError`]. The binary maps any such error to exit code 78
//! (`EX_CONFIG`).
//!
//! The defaults are the numbers of the domain brief (the ship, the servo, the autopilot, the
//! sensors and sea states, HBT, CLFRT and the safety limits).

use serde::{Deserialize, Serialize};
use std::path::Path;

/// A configuration value outside its allowed range, or a file that does not parse.
#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    /// A key holds a value outside its allowed range.
    #[error("configuration key `{key}` = {value}: allowed {allowed}")]
    OutOfRange {
        /// Dotted path of the key, e.g. `servo.max-rate-deg-s`.
        key: String,
        /// The offending value, as text.
        value: String,
        /// The allowed range or set, as text.
        allowed: String,
    },
    /// The file is not valid TOML for this schema (unknown key, wrong type...).
    #[error("configuration does not parse: {0}")]
    Parse(String),
    /// The file cannot be read.
    #[error("cannot read configuration file {path}: {source}")]
    Io {
        /// The path given.
        path: String,
        /// The I/O error.
        source: std::io::Error,
    },
}

impl ConfigError {
    /// The sysexits code for configuration errors (`EX_CONFIG`).
    pub const EXIT_CODE: i32 = 78;
}

/// Checks `lo <= v <= hi` (and finiteness), naming `key` on failure.
pub fn check_range(key: &str, v: f64, lo: f64, hi: f64) -> Result<(), ConfigError> {
    if v.is_finite() && v >= lo && v <= hi {
        Ok(())
    } else {
        Err(ConfigError::OutOfRange {
            key: key.to_string(),
            value: format!("{v}"),
            allowed: format!("[{lo}, {hi}]"),
        })
    }
}

/// Checks `lo < v <= hi` (and finiteness), naming `key` on failure.
pub fn check_range_open_low(key: &str, v: f64, lo: f64, hi: f64) -> Result<(), ConfigError> {
    if v.is_finite() && v > lo && v <= hi {
        Ok(())
    } else {
        Err(ConfigError::OutOfRange {
            key: key.to_string(),
            value: format!("{v}"),
            allowed: format!("({lo}, {hi}]"),
        })
    }
}

fn check_count(key: &str, v: u32, lo: u32, hi: u32) -> Result<(), ConfigError> {
    if v >= lo && v <= hi {
        Ok(())
    } else {
        Err(ConfigError::OutOfRange {
            key: key.to_string(),
            value: v.to_string(),
            allowed: format!("integer in [{lo}, {hi}]"),
        })
    }
}

fn fail(key: &str, value: impl std::fmt::Display, allowed: &str) -> ConfigError {
    ConfigError::OutOfRange {
        key: key.to_string(),
        value: value.to_string(),
        allowed: allowed.to_string(),
    }
}

const DEG: f64 = std::f64::consts::PI / 180.0;

/// The whole configuration file.
#[derive(Debug, Clone, Default, Serialize, Deserialize, PartialEq)]
#[serde(default, deny_unknown_fields, rename_all = "kebab-case")]
pub struct Config {
    /// The ship model and its nominal parameters.
    pub ship: ShipConfig,
    /// The rudder servo.
    pub servo: ServoConfig,
    /// The simulated heading autopilot (PID with wave filter).
    pub autopilot: AutopilotConfig,
    /// Sensor rates and noise.
    pub sensors: SensorConfig,
    /// Environmental disturbances per sea state.
    pub sea: SeaConfig,
    /// Simulation set-up (initial course, integration).
    pub simulation: SimulationConfig,
    /// When tests run.
    pub scheduler: SchedulerConfig,
    /// Harmonic balance (relay) test.
    pub hbt: HbtConfig,
    /// Closed-loop frequency response (multisine) test.
    pub clfrt: ClfrtConfig,
    /// Safety limits on excitation and abort conditions.
    pub safety: SafetyConfig,
    /// Input validation (plausibility limits on incoming samples).
    pub input: InputConfig,
    /// The daemon (`helmwatch run`): vessels, queues, timers.
    pub daemon: DaemonConfig,
    /// The daemon's Zenoh session.
    pub zenoh: ZenohConfig,
    /// The simulated ship as a Zenoh peer (`helmwatch ship`).
    pub ship_peer: ShipPeerConfig,
    /// The neural estimator's models (speed and displacement from the features).
    pub estimator: EstimatorConfig,
    /// Fault detection and isolation: residual spreads, decision rule, alarm state.
    pub fdi: FdiConfig,
    /// The time-domain baseline (equation-error least squares of a and b).
    pub baseline: BaselineConfig,
}

impl Config {
    /// Parses TOML text and checks every limit.
    pub fn from_toml_str(text: &str) -> Result<Self, ConfigError> {
        let cfg: Config = toml::from_str(text).map_err(|e| ConfigError::Parse(e.to_string()))?;
        cfg.check()?;
        Ok(cfg)
    }

    /// Reads, parses and checks a TOML file.
    pub fn from_file(path: &Path) -> Result<Self, ConfigError> {
        let text = std::fs::read_to_string(path).map_err(|source| ConfigError::Io {
            path: path.display().to_string(),
            source,
        })?;
        Self::from_toml_str(&text)
    }

    /// Checks every semantic limit; the first violation is returned, naming its key.
    pub fn check(&self) -> Result<(), ConfigError> {
        self.ship.check()?;
        self.servo.check()?;
        self.autopilot.check()?;
        self.sensors.check()?;
        self.sea.check()?;
        self.simulation.check()?;
        self.scheduler.check()?;
        self.hbt.check()?;
        self.clfrt.check(self.sensors.rate_hz)?;
        self.safety.check(&self.servo)?;
        self.clfrt
            .check_servo_check_safety(&self.safety, self.sensors.rate_hz)?;
        self.input.check()?;
        self.daemon.check()?;
        self.zenoh.check("zenoh")?;
        self.ship_peer.check()?;
        self.estimator.check()?;
        self.fdi.check()?;
        let nyquist = std::f64::consts::PI * self.sensors.rate_hz;
        if self.fdi.wave_band_rad_s[1] > nyquist {
            return Err(fail(
                "fdi.wave-band-rad-s",
                format!("{:?}", self.fdi.wave_band_rad_s),
                &format!("[lo, hi] with hi <= pi sensors.rate-hz = {nyquist:.3}"),
            ));
        }
        self.baseline.check()?;
        Ok(())
    }
}

// ---------------------------------------------------------------------------------------------
// FDI

/// The decision rule on the normalised residuals (see `crate::fdi`).
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq, Eq, Default)]
#[serde(rename_all = "kebab-case")]
pub enum DecisionRule {
    /// Chi-square on each residual group, with persistence over successive tests.
    #[default]
    ChiSquare,
    /// Two-sided CUSUM on each normalised residual.
    Cusum,
}

impl DecisionRule {
    /// Name in the configuration and the reports.
    pub fn name(self) -> &'static str {
        match self {
            DecisionRule::ChiSquare => "chi-square",
            DecisionRule::Cusum => "cusum",
        }
    }
}

/// Fault detection and isolation (see `crate::fdi`). Pairs are `[calm, moderate]` values,
/// interpolated by the test's measured sea index.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(default, deny_unknown_fields, rename_all = "kebab-case")]
pub struct FdiConfig {
    /// Decide on completed tests (false: residuals are still reported, decision inconclusive).
    pub enabled: bool,
    /// `chi-square` (with persistence) or `cusum`.
    pub rule: DecisionRule,
    /// Chi-square limit of each two-dimensional residual group (13.82: 0.1 % for m = 2).
    pub chi2_threshold: f64,
    /// Exceeding tests in a row (of one method) before the alarm (chi-square rule).
    pub persistence: u32,
    /// Non-exceeding tests in a row that clear an alarm.
    pub clear_after: u32,
    /// CUSUM reference value k [sigma].
    pub cusum_k: f64,
    /// CUSUM decision interval h [sigma].
    pub cusum_h: f64,
    /// Name the second parameter cause too when its GLR cost is within this margin [chi2].
    pub isolation_margin: f64,
    /// Band of the wave yaw on the heading (`features.wave_yaw_rad`) [rad/s].
    pub wave_band_rad_s: [f64; 2],
    /// The measured wave yaw in a calm and a moderate sea [deg]: anchors of the spread
    /// interpolation (the sea index).
    pub sea_wave_yaw_deg: [f64; 2],
    /// Speed residual spread proportional to the speed log (model files' `relative_std`)
    /// rather than absolute.
    pub relative_spread_speed: bool,
    /// Displacement residual spread proportional to the nominal displacement.
    pub relative_spread_displacement: bool,
    /// Per-test decay of the remembered sea index (0: each test alone).
    pub sea_memory: f64,
    /// Spread of the servo check's rudder-rate ratio (CLFRT: the burst's 95th percentile, HBT:
    /// the relay slews' peak, over the healthy servo's) on a healthy servo, for the one-sided
    /// shortfall.
    pub actuator_rate_sigma: f64,
    /// Floor of the ln-gain spread of a tone in the model fit.
    pub model_fit_floor_ln_gain: f64,
    /// Floor of the phase spread of a tone in the model fit [deg].
    pub model_fit_floor_phase_deg: f64,
    /// Chi-square limit of the model fit (4 dof: 18.47 at 0.1 %).
    pub model_fit_threshold: f64,
    /// Let the model fit join the actuator group of the decision.
    pub model_fit_decides: bool,
    /// Baseline (equation error): spread of its speed from a, CLFRT record [m/s].
    pub baseline_clfrt_speed_sigma_mps: [f64; 2],
    /// Baseline: spread of its displacement from b and the speed log, CLFRT record [t].
    pub baseline_clfrt_displacement_sigma_t: [f64; 2],
    /// Baseline: spread of its speed, HBT record [m/s].
    pub baseline_hbt_speed_sigma_mps: [f64; 2],
    /// Baseline: spread of its displacement, HBT record [t].
    pub baseline_hbt_displacement_sigma_t: [f64; 2],
}

impl Default for FdiConfig {
    fn default() -> Self {
        Self {
            enabled: true,
            rule: DecisionRule::ChiSquare,
            chi2_threshold: 13.82,
            persistence: 2,
            clear_after: 3,
            cusum_k: 0.5,
            cusum_h: 5.0,
            isolation_margin: 0.0,
            wave_band_rad_s: [0.4, 2.0],
            sea_wave_yaw_deg: [0.05, 0.18],
            relative_spread_speed: false,
            relative_spread_displacement: true,
            sea_memory: 0.0,
            actuator_rate_sigma: 0.03,
            model_fit_floor_ln_gain: 0.01,
            model_fit_floor_phase_deg: 0.5,
            model_fit_threshold: 18.47,
            model_fit_decides: false,
            baseline_clfrt_speed_sigma_mps: [0.07, 0.33],
            baseline_clfrt_displacement_sigma_t: [20.0, 100.0],
            baseline_hbt_speed_sigma_mps: [0.04, 0.16],
            baseline_hbt_displacement_sigma_t: [12.0, 65.0],
        }
    }
}

impl FdiConfig {
    /// The baseline's `(speed, displacement)` spread pairs for `method`'s record.
    pub fn baseline_sigmas(&self, method: Method) -> ([f64; 2], [f64; 2]) {
        match method {
            Method::Clfrt => (
                self.baseline_clfrt_speed_sigma_mps,
                self.baseline_clfrt_displacement_sigma_t,
            ),
            Method::Hbt => (
                self.baseline_hbt_speed_sigma_mps,
                self.baseline_hbt_displacement_sigma_t,
            ),
        }
    }

    fn check(&self) -> Result<(), ConfigError> {
        check_range_open_low("fdi.chi2-threshold", self.chi2_threshold, 0.0, 1000.0)?;
        check_count("fdi.persistence", self.persistence, 1, 20)?;
        check_count("fdi.clear-after", self.clear_after, 1, 1000)?;
        check_range("fdi.cusum-k", self.cusum_k, 0.0, 10.0)?;
        check_range_open_low("fdi.cusum-h", self.cusum_h, 0.0, 1000.0)?;
        check_range("fdi.isolation-margin", self.isolation_margin, 0.0, 1000.0)?;
        let increasing = |key: &str, p: [f64; 2], hi: f64| -> Result<(), ConfigError> {
            check_range(key, p[0], 0.0, hi)?;
            check_range(key, p[1], 0.0, hi)?;
            if p[1] > p[0] {
                Ok(())
            } else {
                Err(fail(
                    key,
                    format!("[{}, {}]", p[0], p[1]),
                    "[calm, moderate] with calm < moderate",
                ))
            }
        };
        increasing("fdi.sea-wave-yaw-deg", self.sea_wave_yaw_deg, 10.0)?;
        increasing("fdi.wave-band-rad-s", self.wave_band_rad_s, 10.0)?;
        check_range("fdi.sea-memory", self.sea_memory, 0.0, 0.99)?;
        let spread = |key: &str, p: [f64; 2], hi: f64| -> Result<(), ConfigError> {
            check_range_open_low(key, p[0], 0.0, hi)?;
            check_range_open_low(key, p[1], 0.0, hi)
        };
        check_range_open_low(
            "fdi.actuator-rate-sigma",
            self.actuator_rate_sigma,
            0.0,
            1.0,
        )?;
        check_range_open_low(
            "fdi.model-fit-floor-ln-gain",
            self.model_fit_floor_ln_gain,
            0.0,
            10.0,
        )?;
        check_range_open_low(
            "fdi.model-fit-floor-phase-deg",
            self.model_fit_floor_phase_deg,
            0.0,
            90.0,
        )?;
        check_range_open_low(
            "fdi.model-fit-threshold",
            self.model_fit_threshold,
            0.0,
            1e6,
        )?;
        spread(
            "fdi.baseline-clfrt-speed-sigma-mps",
            self.baseline_clfrt_speed_sigma_mps,
            100.0,
        )?;
        spread(
            "fdi.baseline-clfrt-displacement-sigma-t",
            self.baseline_clfrt_displacement_sigma_t,
            1e6,
        )?;
        spread(
            "fdi.baseline-hbt-speed-sigma-mps",
            self.baseline_hbt_speed_sigma_mps,
            100.0,
        )?;
        spread(
            "fdi.baseline-hbt-displacement-sigma-t",
            self.baseline_hbt_displacement_sigma_t,
            1e6,
        )?;
        Ok(())
    }
}

// ---------------------------------------------------------------------------------------------
// Estimator

/// Where the estimator's model files come from (see `crate::estimator`).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(default, deny_unknown_fields, rename_all = "kebab-case")]
pub struct EstimatorConfig {
    /// Attach the estimator to the monitor cores: completed tests carry an `estimate`.
    pub enabled: bool,
    /// Directory of the model files (`clfrt_speed.json`, ...); absent: the models embedded in
    /// the binary (those of the repository's `models/` at build time).
    pub models_dir: Option<String>,
}

impl Default for EstimatorConfig {
    fn default() -> Self {
        Self {
            enabled: true,
            models_dir: None,
        }
    }
}

impl EstimatorConfig {
    fn check(&self) -> Result<(), ConfigError> {
        if let Some(d) = &self.models_dir {
            if d.is_empty() {
                return Err(fail(
                    "estimator.models-dir",
                    "\"\"",
                    "a directory path (leave the key out for the embedded models)",
                ));
            }
        }
        Ok(())
    }
}

// ---------------------------------------------------------------------------------------------
// Baseline

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
    fn check(&self) -> Result<(), ConfigError> {
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

// ---------------------------------------------------------------------------------------------
// Ship

/// Nomoto ship model parameters (DOMAIN: a = a0 u / l, b = 0.5 (u/l)^2 A l / V, V = D / rho).
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
    fn check(&self) -> Result<(), ConfigError> {
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

// ---------------------------------------------------------------------------------------------
// Servo

/// Rudder servo (DOMAIN, paper Fig. 7): command clamped, first-order lag, rate limit, angle limit.
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
    fn check(&self) -> Result<(), ConfigError> {
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
// Autopilot

/// Simulated heading autopilot: PID on the wave-filtered heading error, pole placement defaults.
///
/// Fossen: Kp = (T/K) wn^2, Td = T/(K Kp) (2 zeta wn - 1/T), Ti = factor / wn, computed for
/// the nominal ship unless overridden.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(default, deny_unknown_fields, rename_all = "kebab-case")]
pub struct AutopilotConfig {
    /// Closed-loop natural frequency wn for pole placement [rad/s].
    pub natural_frequency_rad_s: f64,
    /// Closed-loop damping ratio zeta.
    pub damping: f64,
    /// Ti = integral-time-factor / wn.
    pub integral_time_factor: f64,
    /// Cut-off of the critically damped 2nd-order low-pass on the heading error [rad/s].
    pub wave_filter_rad_s: f64,
    /// Override of the proportional gain Kp [rad rudder / rad error].
    pub kp: Option<f64>,
    /// Override of the derivative time Td [s].
    pub td_s: Option<f64>,
    /// Override of the integral time Ti [s].
    pub ti_s: Option<f64>,
    /// Gain scheduling on speed, as commercial autopilots do with their speed input: the
    /// pole placement uses the ship at its speed (and nominal displacement). Off: the gains
    /// are those of the nominal ship at every speed (the loop then loses its margins on a
    /// fast, light ship: |S| peaks near 13 at 10 m/s, 4000 t).
    pub speed_scheduling: bool,
}

impl Default for AutopilotConfig {
    fn default() -> Self {
        Self {
            natural_frequency_rad_s: 0.05,
            damping: 0.9,
            integral_time_factor: 10.0,
            wave_filter_rad_s: 0.25,
            kp: None,
            td_s: None,
            ti_s: None,
            speed_scheduling: true,
        }
    }
}

/// PID gains resolved from [`AutopilotConfig`] and the nominal ship.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PidGains {
    /// Proportional gain [rad/rad].
    pub kp: f64,
    /// Derivative time [s].
    pub td_s: f64,
    /// Integral time [s].
    pub ti_s: f64,
}

impl AutopilotConfig {
    fn check(&self) -> Result<(), ConfigError> {
        check_range_open_low(
            "autopilot.natural-frequency-rad-s",
            self.natural_frequency_rad_s,
            0.0,
            1.0,
        )?;
        check_range_open_low("autopilot.damping", self.damping, 0.0, 5.0)?;
        check_range_open_low(
            "autopilot.integral-time-factor",
            self.integral_time_factor,
            0.0,
            1000.0,
        )?;
        check_range_open_low(
            "autopilot.wave-filter-rad-s",
            self.wave_filter_rad_s,
            0.0,
            10.0,
        )?;
        if let Some(kp) = self.kp {
            check_range_open_low("autopilot.kp", kp, 0.0, 100.0)?;
        }
        if let Some(td) = self.td_s {
            check_range("autopilot.td-s", td, 0.0, 1000.0)?;
        }
        if let Some(ti) = self.ti_s {
            check_range_open_low("autopilot.ti-s", ti, 0.0, 1.0e5)?;
        }
        Ok(())
    }

    /// Gains by pole placement for the nominal ship of `ship`, with overrides applied.
    pub fn gains(&self, ship: &ShipConfig) -> PidGains {
        self.gains_for(ship, ship.nominal_speed_mps)
    }

    /// Gains for a ship sailing at `speed_mps`: pole placement at that speed and the nominal
    /// displacement when `speed-scheduling` is on, else the nominal ship's gains.
    pub fn gains_at(&self, ship: &ShipConfig, speed_mps: f64) -> PidGains {
        if self.speed_scheduling {
            self.gains_for(ship, speed_mps)
        } else {
            self.gains(ship)
        }
    }

    fn gains_for(&self, ship: &ShipConfig, speed_mps: f64) -> PidGains {
        let (a, b) = ship.nomoto(speed_mps, ship.nominal_displacement_t);
        let t = 1.0 / a;
        let k = b / a;
        let wn = self.natural_frequency_rad_s;
        let kp = self.kp.unwrap_or(t / k * wn * wn);
        let td_s = self
            .td_s
            .unwrap_or((t / (k * kp) * (2.0 * self.damping * wn - 1.0 / t)).max(0.0));
        let ti_s = self.ti_s.unwrap_or(self.integral_time_factor / wn);
        PidGains { kp, td_s, ti_s }
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
    fn check(&self) -> Result<(), ConfigError> {
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
// Sea

/// Named sea states of the domain brief.
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
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "calm" => Ok(SeaState::Calm),
            "moderate" => Ok(SeaState::Moderate),
            "rough" => Ok(SeaState::Rough),
            other => Err(format!(
                "unknown sea state `{other}`: allowed calm, moderate, rough"
            )),
        }
    }
}

/// Disturbance levels of one sea state (standard deviations).
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, rename_all = "kebab-case")]
pub struct SeaLevels {
    /// First-order wave yaw on the heading measurement [deg].
    pub wave_yaw_deg: f64,
    /// Rudder-equivalent slowly varying yaw moment (Markov bias) [deg].
    pub bias_deg: f64,
}

/// Disturbance model: Markov rudder-equivalent bias and Fossen's wave filter on the heading.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(default, deny_unknown_fields, rename_all = "kebab-case")]
pub struct SeaConfig {
    /// Sea state used when none is given on the command line.
    pub state: SeaState,
    /// Time constant T_b of the first-order Markov bias [s].
    pub bias_time_constant_s: f64,
    /// Wave filter peak frequency w0 [rad/s].
    pub wave_frequency_rad_s: f64,
    /// Wave filter damping lambda.
    pub wave_damping: f64,
    /// Levels in a calm sea.
    pub calm: SeaLevels,
    /// Levels in a moderate sea.
    pub moderate: SeaLevels,
    /// Levels in a rough sea.
    pub rough: SeaLevels,
}

impl Default for SeaConfig {
    fn default() -> Self {
        Self {
            state: SeaState::Moderate,
            bias_time_constant_s: 300.0,
            wave_frequency_rad_s: 0.8,
            wave_damping: 0.1,
            calm: SeaLevels {
                wave_yaw_deg: 0.05,
                bias_deg: 0.1,
            },
            moderate: SeaLevels {
                wave_yaw_deg: 0.2,
                bias_deg: 0.5,
            },
            rough: SeaLevels {
                wave_yaw_deg: 0.5,
                bias_deg: 1.0,
            },
        }
    }
}

impl SeaConfig {
    fn check(&self) -> Result<(), ConfigError> {
        check_range_open_low(
            "sea.bias-time-constant-s",
            self.bias_time_constant_s,
            0.0,
            1.0e5,
        )?;
        check_range_open_low(
            "sea.wave-frequency-rad-s",
            self.wave_frequency_rad_s,
            0.0,
            10.0,
        )?;
        check_range_open_low("sea.wave-damping", self.wave_damping, 0.0, 2.0)?;
        for (name, l) in [
            ("calm", &self.calm),
            ("moderate", &self.moderate),
            ("rough", &self.rough),
        ] {
            check_range(
                &format!("sea.{name}.wave-yaw-deg"),
                l.wave_yaw_deg,
                0.0,
                10.0,
            )?;
            check_range(&format!("sea.{name}.bias-deg"), l.bias_deg, 0.0, 10.0)?;
        }
        Ok(())
    }
    /// Levels of a sea state.
    pub fn levels(&self, state: SeaState) -> SeaLevels {
        match state {
            SeaState::Calm => self.calm,
            SeaState::Moderate => self.moderate,
            SeaState::Rough => self.rough,
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Simulation

/// Simulation set-up.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(default, deny_unknown_fields, rename_all = "kebab-case")]
pub struct SimulationConfig {
    /// Course set on the autopilot at the start [deg, 0..360].
    pub initial_course_deg: f64,
    /// Integration sub-steps per sensor sample.
    pub substeps: u32,
    /// Time of the first sample [s] (any origin in simulation).
    pub start_time_s: f64,
    /// Vessel name used in the keys (`vessels/<vessel>/...`).
    pub vessel: String,
}

impl Default for SimulationConfig {
    fn default() -> Self {
        Self {
            initial_course_deg: 45.0,
            substeps: 5,
            start_time_s: 0.0,
            vessel: "self".to_string(),
        }
    }
}

impl SimulationConfig {
    fn check(&self) -> Result<(), ConfigError> {
        check_range(
            "simulation.initial-course-deg",
            self.initial_course_deg,
            0.0,
            360.0,
        )?;
        check_count("simulation.substeps", self.substeps, 1, 1000)?;
        check_range(
            "simulation.start-time-s",
            self.start_time_s,
            -1.0e12,
            1.0e12,
        )?;
        check_vessel_name("simulation.vessel", &self.vessel)?;
        Ok(())
    }
}

/// A vessel name must be one non-empty Zenoh key chunk: no `/`, `*`, `$`, `#`, `?`, spaces.
pub fn check_vessel_name(key: &str, name: &str) -> Result<(), ConfigError> {
    let ok = !name.is_empty()
        && name.len() <= 64
        && name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_' || c == '.');
    if ok {
        Ok(())
    } else {
        Err(fail(
            key,
            format!("{name:?}"),
            "1 to 64 characters among A-Z a-z 0-9 - _ .",
        ))
    }
}

// ---------------------------------------------------------------------------------------------
// Monitor: scheduler, tests, safety, input

/// Test method.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq, Eq, Hash)]
#[serde(rename_all = "lowercase")]
pub enum Method {
    /// Harmonic balance test (relay feedback replaces the autopilot).
    Hbt,
    /// Closed-loop frequency response test (multisine added to the autopilot's command).
    Clfrt,
}

impl Method {
    /// Name on the wire (`"hbt"`, `"clfrt"`).
    pub fn name(self) -> &'static str {
        match self {
            Method::Hbt => "hbt",
            Method::Clfrt => "clfrt",
        }
    }
}

impl std::str::FromStr for Method {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "hbt" => Ok(Method::Hbt),
            "clfrt" => Ok(Method::Clfrt),
            other => Err(format!("unknown method `{other}`: allowed hbt, clfrt")),
        }
    }
}

/// When the monitor starts a test on its own.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(default, deny_unknown_fields, rename_all = "kebab-case")]
pub struct SchedulerConfig {
    /// Run tests on schedule (tests on trigger are always possible).
    pub enabled: bool,
    /// Methods run on schedule, in turn.
    pub methods: Vec<Method>,
    /// Minimum time from the end of one test to the start of the next [s].
    pub interval_s: f64,
    /// The course must be steady this long before a scheduled test [s].
    pub steady_time_s: f64,
    /// Steady: |heading error| below this [deg].
    pub steady_heading_error_deg: f64,
    /// Steady: |rudder - its mean over the steady window| below this [deg].
    pub steady_rudder_deg: f64,
    /// Steady: speed within this of its mean over the steady window [m/s].
    pub steady_speed_mps: f64,
}

impl Default for SchedulerConfig {
    fn default() -> Self {
        Self {
            enabled: true,
            methods: vec![Method::Clfrt, Method::Hbt],
            interval_s: 3600.0,
            steady_time_s: 120.0,
            steady_heading_error_deg: 3.0,
            steady_rudder_deg: 5.0,
            steady_speed_mps: 0.3,
        }
    }
}

impl SchedulerConfig {
    fn check(&self) -> Result<(), ConfigError> {
        if self.enabled && self.methods.is_empty() {
            return Err(fail(
                "scheduler.methods",
                "[]",
                "at least one of \"hbt\", \"clfrt\" when scheduler.enabled = true",
            ));
        }
        check_range("scheduler.interval-s", self.interval_s, 0.0, 30.0 * 86400.0)?;
        check_range("scheduler.steady-time-s", self.steady_time_s, 0.0, 3600.0)?;
        check_range_open_low(
            "scheduler.steady-heading-error-deg",
            self.steady_heading_error_deg,
            0.0,
            45.0,
        )?;
        check_range_open_low(
            "scheduler.steady-rudder-deg",
            self.steady_rudder_deg,
            0.0,
            30.0,
        )?;
        check_range_open_low(
            "scheduler.steady-speed-mps",
            self.steady_speed_mps,
            0.0,
            5.0,
        )?;
        Ok(())
    }
}

/// Relay feedback test (DOMAIN: HBT).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(default, deny_unknown_fields, rename_all = "kebab-case")]
pub struct HbtConfig {
    /// Relay height h around the trim rudder [deg].
    pub relay_height_deg: f64,
    /// Relay hysteresis eps on the heading error [deg]; must exceed the wave yaw.
    pub hysteresis_deg: f64,
    /// Time over which the trim rudder delta0 is measured before the relay starts [s].
    pub trim_window_s: f64,
    /// Limit-cycle periods to let settle before measuring.
    pub settle_periods: u32,
    /// Limit-cycle periods measured.
    pub measure_periods: u32,
    /// Abort when the measurement is not complete after this long [s] (no limit cycle formed).
    pub timeout_s: f64,
    /// Relay-centre adaptation per period, in [0, 1]: after each full period the centre moves
    /// this fraction of the way to the period's mean rudder, which makes the cycle symmetric.
    /// A heading-sensor drift or a slow yaw moment then leaves the cycle unchanged (the ship
    /// turns with the drift at the mean rudder; superposition). 0 keeps delta0 fixed; 1 is a
    /// full Newton step, at the edge of a period-2 oscillation of the centre; 0.5 is damped.
    pub bias_adaptation: f64,
    /// Hand-back lead tau [s]: after the last measured period the relay keeps running until
    /// the instant the cycle predicts for `e + tau de/dt = 0`, where the autopilot's PD term
    /// `Kp (e + Td de/dt)` is zero when tau matches its derivative time Td, so taking back
    /// control starts from the trim instead of a full-scale rudder. 0 hands back at once.
    /// Capped by `safety.max-test-duration-s`.
    pub handback_lead_s: f64,
    /// Abort when two relay switches come closer than this [s]: the relay chatters (waves
    /// above the hysteresis), which only wears the steering gear.
    pub min_switch_interval_s: f64,
}

impl Default for HbtConfig {
    fn default() -> Self {
        Self {
            relay_height_deg: 8.0,
            hysteresis_deg: 1.0,
            trim_window_s: 60.0,
            settle_periods: 1,
            measure_periods: 4,
            timeout_s: 1740.0,
            bias_adaptation: 0.5,
            handback_lead_s: 30.0,
            min_switch_interval_s: 10.0,
        }
    }
}

impl HbtConfig {
    fn check(&self) -> Result<(), ConfigError> {
        check_range_open_low("hbt.relay-height-deg", self.relay_height_deg, 0.0, 15.0)?;
        check_range_open_low("hbt.hysteresis-deg", self.hysteresis_deg, 0.0, 10.0)?;
        check_range_open_low("hbt.trim-window-s", self.trim_window_s, 0.0, 600.0)?;
        check_count("hbt.settle-periods", self.settle_periods, 1, 20)?;
        check_count("hbt.measure-periods", self.measure_periods, 1, 50)?;
        check_range_open_low("hbt.timeout-s", self.timeout_s, 0.0, 86400.0)?;
        check_range("hbt.bias-adaptation", self.bias_adaptation, 0.0, 1.0)?;
        check_range("hbt.handback-lead-s", self.handback_lead_s, 0.0, 300.0)?;
        check_range(
            "hbt.min-switch-interval-s",
            self.min_switch_interval_s,
            0.0,
            600.0,
        )?;
        Ok(())
    }
    /// Relay height [rad].
    pub fn relay_height_rad(&self) -> f64 {
        self.relay_height_deg * DEG
    }
    /// Hysteresis [rad].
    pub fn hysteresis_rad(&self) -> f64 {
        self.hysteresis_deg * DEG
    }
}

/// Multisine test (DOMAIN: CLFRT).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(default, deny_unknown_fields, rename_all = "kebab-case")]
pub struct ClfrtConfig {
    /// Analysis window T_w [s]; every tone has a whole number of periods in it.
    pub window_s: f64,
    /// Tone harmonics k of the window (omega_k = 2 pi k / T_w).
    pub harmonics: Vec<u32>,
    /// Amplitude of each tone [deg].
    pub amplitude_deg: f64,
    /// Windows to let settle before measuring.
    pub settle_windows: u32,
    /// Windows measured (averaged).
    pub measure_windows: u32,
    /// Fade-in time of the multisine [s] (within the settle window, after the servo check).
    pub fade_s: f64,
    /// Seed of the crest-factor phase optimisation (the design is deterministic).
    pub phase_seed: u64,
    /// Servo check: frequency of the sinusoid played at the start of the settle window, before
    /// the multisine fades in [rad/s]. Adjusted by < 0.1 % so that the measured periods span a
    /// whole number of samples ([`ClfrtConfig::servo_check_omega_rad_s`]).
    pub servo_check_frequency_rad_s: f64,
    /// Servo check: amplitude of the sinusoid [deg] (0 disables the check).
    pub servo_check_amplitude_deg: f64,
    /// Servo check: periods at full amplitude, all measured, 3 .. 100 (0 disables the check).
    pub servo_check_periods: u32,
    /// Servo check: periods of raised-cosine fade-in, and again of fade-out, around them.
    pub servo_check_fade_periods: u32,
}

impl Default for ClfrtConfig {
    fn default() -> Self {
        Self {
            window_s: 590.0,
            harmonics: vec![3, 7, 17],
            amplitude_deg: 4.0,
            settle_windows: 1,
            measure_windows: 2,
            fade_s: 30.0,
            phase_seed: 1,
            servo_check_frequency_rad_s: 0.6,
            servo_check_amplitude_deg: 5.0,
            servo_check_periods: 10,
            servo_check_fade_periods: 1,
        }
    }
}

impl ClfrtConfig {
    fn check(&self, rate_hz: f64) -> Result<(), ConfigError> {
        check_range("clfrt.window-s", self.window_s, 60.0, 7200.0)?;
        if self.harmonics.is_empty() || self.harmonics.len() > 8 {
            return Err(fail(
                "clfrt.harmonics",
                format!("{:?}", self.harmonics),
                "1 to 8 distinct harmonics, increasing, each >= 1 and below the Nyquist bin",
            ));
        }
        let nyquist_bin = (self.window_s * rate_hz / 2.0).floor() as u32;
        let mut prev = 0;
        for &k in &self.harmonics {
            if k <= prev || k >= nyquist_bin {
                return Err(fail(
                    "clfrt.harmonics",
                    format!("{:?}", self.harmonics),
                    &format!(
                        "increasing harmonics in [1, {}) (the Nyquist bin)",
                        nyquist_bin
                    ),
                ));
            }
            prev = k;
        }
        check_range_open_low("clfrt.amplitude-deg", self.amplitude_deg, 0.0, 10.0)?;
        check_count("clfrt.settle-windows", self.settle_windows, 0, 10)?;
        check_count("clfrt.measure-windows", self.measure_windows, 1, 20)?;
        check_range("clfrt.fade-s", self.fade_s, 0.0, self.window_s)?;
        // At least 4 samples per period: the check's bin stays far below Nyquist.
        let w_max = (std::f64::consts::PI * rate_hz / 4.0).min(5.0);
        check_range_open_low(
            "clfrt.servo-check-frequency-rad-s",
            self.servo_check_frequency_rad_s,
            0.0,
            w_max,
        )?;
        check_range(
            "clfrt.servo-check-amplitude-deg",
            self.servo_check_amplitude_deg,
            0.0,
            10.0,
        )?;
        if self.servo_check_periods != 0 {
            // The tone's bin needs neighbours on both sides (the autopilot's rudder fit).
            check_count(
                "clfrt.servo-check-periods",
                self.servo_check_periods,
                3,
                100,
            )?;
        }
        check_count(
            "clfrt.servo-check-fade-periods",
            self.servo_check_fade_periods,
            0,
            10,
        )?;
        if self.servo_check_enabled() {
            let settle_s = self.settle_windows as f64 * self.window_s;
            let burst_s = self.servo_check_duration_s(rate_hz);
            if burst_s + self.fade_s > settle_s {
                return Err(fail(
                    "clfrt.servo-check-periods",
                    self.servo_check_periods,
                    &format!(
                        "a servo check of (periods + 2 fade-periods) x 2 pi / frequency = \
                         {burst_s:.1} s plus fade-s within the settle windows \
                         ({settle_s:.1} s); or 0 to disable the check"
                    ),
                ));
            }
        }
        Ok(())
    }

    /// Whether the servo check runs (non-zero amplitude and periods).
    pub fn servo_check_enabled(&self) -> bool {
        self.servo_check_amplitude_deg > 0.0 && self.servo_check_periods > 0
    }

    /// Servo check amplitude [rad].
    pub fn servo_check_amplitude_rad(&self) -> f64 {
        self.servo_check_amplitude_deg * DEG
    }

    /// Samples `N` of the measured (full-amplitude) part of the servo check at `rate_hz`: the
    /// configured periods rounded to a whole number of samples (at least 1).
    pub fn servo_check_samples(&self, rate_hz: f64) -> usize {
        let period_s = 2.0 * std::f64::consts::PI / self.servo_check_frequency_rad_s;
        ((self.servo_check_periods as f64 * period_s * rate_hz).round() as usize).max(1)
    }

    /// Frequency actually played by the servo check [rad/s]: `2 pi periods / (N dt)`, so that
    /// the measured periods fall exactly on bin `periods` of their `N`-sample DFT (within
    /// `pi / (periods N)` relative of the configured frequency, < 0.05 % by default).
    pub fn servo_check_omega_rad_s(&self, rate_hz: f64) -> f64 {
        if self.servo_check_periods == 0 {
            return self.servo_check_frequency_rad_s;
        }
        let n = self.servo_check_samples(rate_hz) as f64;
        2.0 * std::f64::consts::PI * self.servo_check_periods as f64 * rate_hz / n
    }

    /// Duration of the whole servo check, fades included [s] (0 when disabled).
    pub fn servo_check_duration_s(&self, rate_hz: f64) -> f64 {
        if !self.servo_check_enabled() {
            return 0.0;
        }
        let periods = (self.servo_check_periods + 2 * self.servo_check_fade_periods) as f64;
        periods * 2.0 * std::f64::consts::PI / self.servo_check_omega_rad_s(rate_hz)
    }

    /// Largest rate of the servo check's excitation [rad/s]: `A sqrt(w^2 + w_f^2)` with
    /// `w_f = pi / (2 T_f)` the largest rate of its raised-cosine envelope (fade time `T_f`),
    /// a bound of `|d/dt (env(t) A sin(w t))|`.
    pub fn servo_check_max_rate_rad_s(&self, rate_hz: f64) -> f64 {
        if !self.servo_check_enabled() {
            return 0.0;
        }
        let w = self.servo_check_omega_rad_s(rate_hz);
        let fade_s = self.servo_check_fade_periods as f64 * 2.0 * std::f64::consts::PI / w;
        let wf = if fade_s > 0.0 {
            std::f64::consts::PI / (2.0 * fade_s)
        } else {
            0.0
        };
        self.servo_check_amplitude_rad() * (w * w + wf * wf).sqrt()
    }

    /// The servo check against the safety gate: amplitude within `safety.max-excitation-deg`
    /// and rate within `safety.max-excitation-rate-deg-s` (the gate would otherwise distort it).
    fn check_servo_check_safety(
        &self,
        safety: &SafetyConfig,
        rate_hz: f64,
    ) -> Result<(), ConfigError> {
        if !self.servo_check_enabled() {
            return Ok(());
        }
        check_range(
            "clfrt.servo-check-amplitude-deg",
            self.servo_check_amplitude_deg,
            0.0,
            safety.max_excitation_deg,
        )?;
        let rate_per_deg_deg_s =
            self.servo_check_max_rate_rad_s(rate_hz) / self.servo_check_amplitude_rad();
        let max_amp_deg = safety.max_excitation_rate_deg_s / rate_per_deg_deg_s;
        if self.servo_check_amplitude_deg > max_amp_deg {
            return Err(fail(
                "clfrt.servo-check-amplitude-deg",
                self.servo_check_amplitude_deg,
                &format!(
                    "[0, {max_amp_deg:.3}]: its rate (amplitude x {rate_per_deg_deg_s:.3} /s) \
                     within safety.max-excitation-rate-deg-s"
                ),
            ));
        }
        Ok(())
    }

    /// Tone amplitude [rad].
    pub fn amplitude_rad(&self) -> f64 {
        self.amplitude_deg * DEG
    }
    /// Tone frequencies [rad/s].
    pub fn tone_frequencies_rad_s(&self) -> Vec<f64> {
        self.harmonics
            .iter()
            .map(|&k| 2.0 * std::f64::consts::PI * k as f64 / self.window_s)
            .collect()
    }
}

/// Safety limits: bounded excitation and abort conditions (DOMAIN: Safety).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(default, deny_unknown_fields, rename_all = "kebab-case")]
pub struct SafetyConfig {
    /// Largest excitation value ever published, add or replace-minus-trim [deg].
    pub max_excitation_deg: f64,
    /// Largest change of the excitation value between two samples, divided by their
    /// spacing [deg/s]. The relay's switch is a step and is exempt up to 2 h. Default 3.5:
    /// above the CLFRT servo check (5 deg at 0.6 rad/s, 3.0 deg/s, which must exceed a
    /// degraded 2 deg/s servo to see it), below the servo's nominal 4 deg/s.
    pub max_excitation_rate_deg_s: f64,
    /// Abort when |heading - target| exceeds this during a test [deg].
    pub max_heading_error_deg: f64,
    /// Abort when |rudder| reaches this during a test [deg] (saturation).
    pub rudder_saturation_deg: f64,
    /// Abort when any stream is silent longer than this during a test [s].
    pub stream_timeout_s: f64,
    /// Abort when speed leaves the test's starting speed by more than this [m/s].
    pub max_speed_change_mps: f64,
    /// Validity of each excitation message (`hold_s` on the wire) [s].
    pub hold_s: f64,
    /// Hard limit on a test's total duration, settling included [s].
    pub max_test_duration_s: f64,
}

impl Default for SafetyConfig {
    fn default() -> Self {
        Self {
            max_excitation_deg: 10.0,
            max_excitation_rate_deg_s: 3.5,
            max_heading_error_deg: 10.0,
            rudder_saturation_deg: 25.0,
            stream_timeout_s: 2.0,
            max_speed_change_mps: 0.5,
            hold_s: 1.0,
            max_test_duration_s: 1800.0,
        }
    }
}

impl SafetyConfig {
    fn check(&self, servo: &ServoConfig) -> Result<(), ConfigError> {
        check_range_open_low(
            "safety.max-excitation-deg",
            self.max_excitation_deg,
            0.0,
            20.0,
        )?;
        check_range_open_low(
            "safety.max-excitation-rate-deg-s",
            self.max_excitation_rate_deg_s,
            0.0,
            20.0,
        )?;
        check_range_open_low(
            "safety.max-heading-error-deg",
            self.max_heading_error_deg,
            0.0,
            45.0,
        )?;
        check_range_open_low(
            "safety.rudder-saturation-deg",
            self.rudder_saturation_deg,
            0.0,
            servo.max_angle_deg,
        )?;
        check_range_open_low("safety.stream-timeout-s", self.stream_timeout_s, 0.0, 60.0)?;
        check_range_open_low(
            "safety.max-speed-change-mps",
            self.max_speed_change_mps,
            0.0,
            5.0,
        )?;
        check_range_open_low("safety.hold-s", self.hold_s, 0.0, 10.0)?;
        check_range_open_low(
            "safety.max-test-duration-s",
            self.max_test_duration_s,
            0.0,
            86400.0,
        )?;
        Ok(())
    }
}

/// Input validation (plausibility limits on incoming samples).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(default, deny_unknown_fields, rename_all = "kebab-case")]
pub struct InputConfig {
    /// Largest plausible speed through water [m/s]; above is rejected.
    pub max_speed_mps: f64,
    /// Largest plausible |rudder angle| [deg]; above is rejected.
    pub max_rudder_deg: f64,
}

impl Default for InputConfig {
    fn default() -> Self {
        Self {
            max_speed_mps: 30.0,
            max_rudder_deg: 45.0,
        }
    }
}

impl InputConfig {
    fn check(&self) -> Result<(), ConfigError> {
        check_range_open_low("input.max-speed-mps", self.max_speed_mps, 0.0, 100.0)?;
        check_range_open_low("input.max-rudder-deg", self.max_rudder_deg, 0.0, 90.0)?;
        Ok(())
    }
}

// ---------------------------------------------------------------------------------------------
// Daemon, Zenoh, ship peer

/// The daemon (`helmwatch run`): one monitor core per vessel, each fed by a bounded queue.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(default, deny_unknown_fields, rename_all = "kebab-case")]
pub struct DaemonConfig {
    /// Vessels monitored, one monitor core each (`vessels/<vessel>/...`); 1 to 100000 names.
    pub vessels: Vec<String>,
    /// Capacity of each vessel's input queue [messages]. A full queue drops new samples and
    /// counts them (`dropped.flood` in the stats): a flood never grows memory.
    pub queue_capacity: u32,
    /// Period of the silence check [s]: ship time is estimated as the last heading's `t` plus
    /// the wall time since it arrived, so a silent heading stream aborts a test.
    pub tick_s: f64,
    /// Period of the statistics (log at debug level, `fdi/stats` publication) [s]; 0 = never.
    pub stats_period_s: f64,
    /// Publish the statistics on `vessels/<v>/fdi/stats` (an addition to the contract).
    pub publish_stats: bool,
    /// Longest wait for the final publications (`mode: none`, status) at shutdown [s].
    pub shutdown_timeout_s: f64,
}

impl Default for DaemonConfig {
    fn default() -> Self {
        Self {
            vessels: vec!["self".to_string()],
            queue_capacity: 256,
            tick_s: 0.5,
            stats_period_s: 60.0,
            publish_stats: true,
            shutdown_timeout_s: 5.0,
        }
    }
}

impl DaemonConfig {
    fn check(&self) -> Result<(), ConfigError> {
        if self.vessels.is_empty() || self.vessels.len() > 100_000 {
            return Err(fail(
                "daemon.vessels",
                format!("{} names", self.vessels.len()),
                "1 to 100000 vessel names",
            ));
        }
        let mut seen = std::collections::HashSet::new();
        for (i, v) in self.vessels.iter().enumerate() {
            let key = format!("daemon.vessels[{i}]");
            check_vessel_name(&key, v)?;
            if !seen.insert(v.as_str()) {
                return Err(fail(&key, format!("{v:?}"), "each vessel once"));
            }
        }
        check_count("daemon.queue-capacity", self.queue_capacity, 16, 1_000_000)?;
        check_range_open_low("daemon.tick-s", self.tick_s, 0.0, 10.0)?;
        check_range("daemon.stats-period-s", self.stats_period_s, 0.0, 86400.0)?;
        check_range_open_low(
            "daemon.shutdown-timeout-s",
            self.shutdown_timeout_s,
            0.0,
            60.0,
        )?;
        Ok(())
    }
}

/// Zenoh node mode.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq, Eq, Default)]
#[serde(rename_all = "lowercase")]
pub enum ZenohMode {
    /// Peer: talks directly to other peers and routers (default).
    #[default]
    Peer,
    /// Client: talks through one router.
    Client,
    /// Router: routes for others (a shore server usually runs `zenohd` instead).
    Router,
}

impl ZenohMode {
    /// The name Zenoh uses (`"peer"`, `"client"`, `"router"`).
    pub fn name(self) -> &'static str {
        match self {
            ZenohMode::Peer => "peer",
            ZenohMode::Client => "client",
            ZenohMode::Router => "router",
        }
    }
}

/// A Zenoh session: mode, endpoints, scouting, or a Zenoh JSON5 configuration file.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(default, deny_unknown_fields, rename_all = "kebab-case")]
pub struct ZenohConfig {
    /// Node mode: `peer`, `client` or `router`.
    pub mode: ZenohMode,
    /// Endpoints to listen on, e.g. `tcp/127.0.0.1:7447` (`--listen` overrides).
    pub listen: Vec<String>,
    /// Endpoints to connect to, e.g. `tcp/192.0.2.10:7447` (`--connect` overrides).
    pub connect: Vec<String>,
    /// UDP multicast scouting (off: only the endpoints above are used).
    pub multicast_scouting: bool,
    /// A Zenoh JSON5 configuration file (routers, TLS, access control). When set, the session
    /// is configured from that file alone and the four keys above are ignored; `--listen` and
    /// `--connect` still override its endpoints.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub config_file: Option<std::path::PathBuf>,
}

impl Default for ZenohConfig {
    fn default() -> Self {
        Self {
            mode: ZenohMode::Peer,
            listen: vec!["tcp/127.0.0.1:7447".to_string()],
            connect: Vec::new(),
            multicast_scouting: false,
            config_file: None,
        }
    }
}

/// Checks that `endpoint` parses as a Zenoh endpoint (`proto/address[?metadata][#config]`).
pub fn check_endpoint(key: &str, endpoint: &str) -> Result<(), ConfigError> {
    match endpoint.parse::<zenoh::config::EndPoint>() {
        Ok(_) => Ok(()),
        Err(e) => Err(fail(
            key,
            format!("{endpoint:?}"),
            &format!("a Zenoh endpoint such as \"tcp/127.0.0.1:7447\" ({e})"),
        )),
    }
}

impl ZenohConfig {
    /// Checks the endpoints; `section` names the table in errors (`zenoh`, `ship-peer`).
    pub fn check(&self, section: &str) -> Result<(), ConfigError> {
        for (i, e) in self.listen.iter().enumerate() {
            check_endpoint(&format!("{section}.listen[{i}]"), e)?;
        }
        for (i, e) in self.connect.iter().enumerate() {
            check_endpoint(&format!("{section}.connect[{i}]"), e)?;
        }
        if self.mode == ZenohMode::Client && self.connect.is_empty() && self.config_file.is_none() {
            return Err(fail(
                &format!("{section}.connect"),
                "[]",
                "at least one endpoint when mode = \"client\"",
            ));
        }
        Ok(())
    }
}

/// The simulated ship as a Zenoh peer (`helmwatch ship`): its pace, its faults, its session.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(default, deny_unknown_fields, rename_all = "kebab-case")]
pub struct ShipPeerConfig {
    /// Lockstep: after each heading, wait for the daemon's excitation with that `t` (while a
    /// daemon holds `fdi/alive`); otherwise tick on a timer.
    pub lockstep: bool,
    /// Ship seconds per wall second when ticking on the timer (real time = 1), (0, 10000].
    pub speed_up: f64,
    /// Longest wait for the excitation of one heading in lockstep [s, wall]; then the ship
    /// steps on with what its autopilot holds (its own command once `hold_s` has run out).
    pub excitation_timeout_s: f64,
    /// Faults `KIND:VALUE@ONSET_S` (e.g. `displacement_pct:+10@300`); `--fault` adds more.
    pub faults: Vec<String>,
    /// Zenoh node mode of the ship.
    pub mode: ZenohMode,
    /// Endpoints the ship listens on (none by default).
    pub listen: Vec<String>,
    /// Endpoints the ship connects to (the daemon's by default).
    pub connect: Vec<String>,
    /// UDP multicast scouting.
    pub multicast_scouting: bool,
}

impl Default for ShipPeerConfig {
    fn default() -> Self {
        Self {
            lockstep: true,
            speed_up: 1.0,
            excitation_timeout_s: 1.0,
            faults: Vec::new(),
            mode: ZenohMode::Peer,
            listen: Vec::new(),
            connect: vec!["tcp/127.0.0.1:7447".to_string()],
            multicast_scouting: false,
        }
    }
}

impl ShipPeerConfig {
    fn check(&self) -> Result<(), ConfigError> {
        check_range_open_low("ship-peer.speed-up", self.speed_up, 0.0, 10000.0)?;
        check_range_open_low(
            "ship-peer.excitation-timeout-s",
            self.excitation_timeout_s,
            0.0,
            60.0,
        )?;
        for (i, f) in self.faults.iter().enumerate() {
            if let Err(e) = f.parse::<crate::sim::Fault>() {
                return Err(fail(
                    &format!("ship-peer.faults[{i}]"),
                    format!("{f:?}"),
                    &format!("KIND:VALUE@ONSET_S ({e})"),
                ));
            }
        }
        self.zenoh().check("ship-peer")
    }

    /// The ship's Zenoh session settings.
    pub fn zenoh(&self) -> ZenohConfig {
        ZenohConfig {
            mode: self.mode,
            listen: self.listen.clone(),
            connect: self.connect.clone(),
            multicast_scouting: self.multicast_scouting,
            config_file: None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_pass_check() {
        Config::default().check().unwrap();
    }

    #[test]
    fn nominal_ship_matches_domain_brief() {
        let s = ShipConfig::default();
        let (a, b) = s.nomoto(7.0, 7000.0);
        approx::assert_relative_eq!(a, 0.014583, max_relative = 1e-3);
        approx::assert_relative_eq!(b, 5.98e-4, max_relative = 2e-3);
        approx::assert_relative_eq!(b / a, 0.041, max_relative = 1e-2);
    }

    #[test]
    fn pole_placement_gains_match_domain_brief() {
        let g = AutopilotConfig::default().gains(&ShipConfig::default());
        assert!((g.kp - 4.2).abs() < 0.1, "kp {}", g.kp);
        assert!((g.td_s - 30.0).abs() < 1.5, "td {}", g.td_s);
        approx::assert_relative_eq!(g.ti_s, 200.0, max_relative = 1e-12);
    }

    #[test]
    fn unknown_key_is_rejected() {
        let e = Config::from_toml_str("[servo]\nmax-rate-deg-s = 4\nbogus = 1\n").unwrap_err();
        assert!(
            matches!(e, ConfigError::Parse(ref m) if m.contains("bogus")),
            "{e}"
        );
    }

    #[test]
    fn out_of_range_names_key_and_range() {
        let e = Config::from_toml_str("[servo]\nmax-rate-deg-s = -1\n").unwrap_err();
        let m = e.to_string();
        assert!(
            m.contains("servo.max-rate-deg-s") && m.contains("(0, 20]"),
            "{m}"
        );
    }

    #[test]
    fn daemon_and_zenoh_keys_are_checked() {
        let e = Config::from_toml_str("[daemon]\nvessels = [\"a\", \"a\"]\n").unwrap_err();
        assert!(e.to_string().contains("daemon.vessels[1]"), "{e}");
        let e = Config::from_toml_str("[daemon]\nvessels = [\"a/b\"]\n").unwrap_err();
        assert!(e.to_string().contains("daemon.vessels[0]"), "{e}");
        let e = Config::from_toml_str("[zenoh]\nlisten = [\"nonsense\"]\n").unwrap_err();
        assert!(e.to_string().contains("zenoh.listen[0]"), "{e}");
        let e = Config::from_toml_str("[ship-peer]\nfaults = [\"bogus:1@0\"]\n").unwrap_err();
        assert!(e.to_string().contains("ship-peer.faults[0]"), "{e}");
        let e = Config::from_toml_str("[daemon]\ntick-s = 0\n").unwrap_err();
        assert!(e.to_string().contains("daemon.tick-s"), "{e}");
    }

    #[test]
    fn servo_check_keys_are_checked() {
        let e = Config::from_toml_str("[clfrt]\nservo-check-periods = 2\n").unwrap_err();
        assert!(e.to_string().contains("clfrt.servo-check-periods"), "{e}");
        // 60 periods of 10.5 s do not fit in the 590 s settle window.
        let e = Config::from_toml_str("[clfrt]\nservo-check-periods = 60\n").unwrap_err();
        assert!(e.to_string().contains("clfrt.servo-check-periods"), "{e}");
        let e = Config::from_toml_str("[clfrt]\nservo-check-frequency-rad-s = 0\n").unwrap_err();
        assert!(e.to_string().contains("(0, 5]"), "{e}");
        // 8 deg at 0.6 rad/s is 4.8 deg/s, over the gate's 3.5 deg/s.
        let e = Config::from_toml_str("[clfrt]\nservo-check-amplitude-deg = 8\n").unwrap_err();
        assert!(
            e.to_string().contains("clfrt.servo-check-amplitude-deg")
                && e.to_string().contains("safety.max-excitation-rate-deg-s"),
            "{e}"
        );
        // Disabled: no settle window needed for it.
        let cfg =
            Config::from_toml_str("[clfrt]\nservo-check-amplitude-deg = 0\nsettle-windows = 0\n")
                .unwrap();
        assert_eq!(cfg.clfrt.servo_check_duration_s(cfg.sensors.rate_hz), 0.0);
        // Defaults: 10 periods on 1047 samples, 12 periods in all.
        let c = Config::default();
        assert_eq!(c.clfrt.servo_check_samples(10.0), 1047);
        let w = c.clfrt.servo_check_omega_rad_s(10.0);
        assert!((w / 0.6 - 1.0).abs() < 5e-4, "{w}");
        let d = c.clfrt.servo_check_duration_s(10.0);
        assert!((d - 12.0 * 104.7 / 10.0).abs() < 1e-9, "{d}");
    }

    #[test]
    fn sea_keys_are_checked() {
        let e = Config::from_toml_str("[fdi]\nsea-wave-yaw-deg = [0.2, 0.05]\n").unwrap_err();
        assert!(e.to_string().contains("fdi.sea-wave-yaw-deg"), "{e}");
        let e = Config::from_toml_str("[fdi]\nwave-band-rad-s = [2.0, 0.4]\n").unwrap_err();
        assert!(e.to_string().contains("fdi.wave-band-rad-s"), "{e}");
        // 8 rad/s is above the Nyquist frequency of 2 Hz sensors (6.28 rad/s).
        let e =
            Config::from_toml_str("[sensors]\nrate-hz = 2\n[fdi]\nwave-band-rad-s = [0.4, 8.0]\n")
                .unwrap_err();
        assert!(e.to_string().contains("fdi.wave-band-rad-s"), "{e}");
    }

    #[test]
    fn baseline_keys_are_checked() {
        let e = Config::from_toml_str("[baseline]\nfilter-rad-s = 0\n").unwrap_err();
        assert!(e.to_string().contains("baseline.filter-rad-s"), "{e}");
        // 5 / lambda = 50 s at 0.1 rad/s.
        let e = Config::from_toml_str("[baseline]\nfilter-rad-s = 0.1\ntransient-s = 40\n")
            .unwrap_err();
        assert!(e.to_string().contains("baseline.transient-s"), "{e}");
        Config::from_toml_str("[baseline]\nfilter-rad-s = 0.1\ntransient-s = 60\n").unwrap();
        let e = Config::from_toml_str("[baseline]\nlambda = 0.1\n").unwrap_err();
        assert!(e.to_string().contains("lambda"), "{e}");
    }

    #[test]
    fn harmonics_must_increase() {
        let e = Config::from_toml_str("[clfrt]\nharmonics = [7, 3]\n").unwrap_err();
        assert!(e.to_string().contains("clfrt.harmonics"));
    }
}
