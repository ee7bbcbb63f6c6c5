//! The monitor's own sections (scheduler, safety limits, input validation) and
//! [`CoreConfig`], everything one monitor core needs and nothing else.

use crate::baseline::config::BaselineConfig;
use crate::config::{check_count, check_range, check_range_open_low, fail, ConfigError};
use crate::design::{ClfrtConfig, HbtConfig};
use crate::estimator::config::EstimatorConfig;
use crate::fdi::config::{Calibration, FdiConfig, ReferenceConfig};
use crate::model::{SensorConfig, ServoConfig, ShipConfig};
use crate::wire::Method;
use serde::{Deserialize, Serialize};

/// `scheduler.commissioning-interval-s`'s default [s], from a stated budget of added rudder
/// travel: while the reference is established, the tests may add at most the rudder travel
/// the autopilot itself does in a calm sea (about 800 deg/h on the design's ship; a rougher
/// sea only raises the autopilot's own), so commissioning and its confirmation at most double
/// the steering gear's calm-sea work while they last (`monitor::cadence` measures the budget
/// after each test and shortens the gap where the tests add less). One scheduled test adds at most about
/// 470 deg (the two methods' mean, the confirmation's tests the larger), and a test with its
/// steady wait takes about 1360 s on average over the two methods: at most 800 / 470 = 1.70
/// tests per hour, a cycle of at least 2115 s, an interval of at least 2115 - 1360 = 755 s,
/// rounded up to 13 minutes. `helmwatch bench --time-to-alarm` measures the travel added
/// during commissioning, its confirmation and the watch.
pub const COMMISSIONING_INTERVAL_S: f64 = 780.0;

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
    /// The most while the vessel's reference is being established: a scheduled method
    /// commissioning, or confirming its commissioning (`Fdi::establishing`); the gap is the
    /// one the measured added-travel budget allows (`monitor::cadence`), at most this and at
    /// most `interval-s` [s]. Default 780 s: see [`COMMISSIONING_INTERVAL_S`].
    pub commissioning_interval_s: f64,
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
            commissioning_interval_s: COMMISSIONING_INTERVAL_S,
            steady_time_s: 120.0,
            steady_heading_error_deg: 3.0,
            steady_rudder_deg: 5.0,
            steady_speed_mps: 0.3,
        }
    }
}

impl SchedulerConfig {
    /// Checks the section's limits; the error names the key and its allowed range.
    pub fn check(&self) -> Result<(), ConfigError> {
        if self.enabled && self.methods.is_empty() {
            return Err(fail(
                "scheduler.methods",
                "[]",
                "at least one of \"hbt\", \"clfrt\" when scheduler.enabled = true",
            ));
        }
        check_range("scheduler.interval-s", self.interval_s, 0.0, 30.0 * 86400.0)?;
        check_range(
            "scheduler.commissioning-interval-s",
            self.commissioning_interval_s,
            0.0,
            30.0 * 86400.0,
        )?;
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

/// Safety limits: bounded excitation and abort conditions (`[safety]`).
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
    /// Checks the section's limits; the error names the key and its allowed range.
    pub fn check(&self, servo: &ServoConfig) -> Result<(), ConfigError> {
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
    /// A sample later than its stream's last accepted one by more than this is a jump in
    /// time (a clock step or a wild timestamp), not the next sample [s]. Above any outage
    /// the streams recover from without notice; a longer gap costs `resync-samples` samples.
    pub time_jump_s: f64,
    /// Consecutive samples of a new timeline (after a jump ahead, or time going backwards)
    /// that re-synchronise a stream on it; a lone outlier never gets there.
    pub resync_samples: u32,
}

impl Default for InputConfig {
    fn default() -> Self {
        Self {
            max_speed_mps: 30.0,
            max_rudder_deg: 45.0,
            time_jump_s: 60.0,
            resync_samples: 5,
        }
    }
}

impl InputConfig {
    /// Checks the section's limits; the error names the key and its allowed range.
    pub fn check(&self) -> Result<(), ConfigError> {
        check_range_open_low("input.max-speed-mps", self.max_speed_mps, 0.0, 100.0)?;
        check_range_open_low("input.max-rudder-deg", self.max_rudder_deg, 0.0, 90.0)?;
        check_range_open_low("input.time-jump-s", self.time_jump_s, 0.0, 86400.0)?;
        check_count("input.resync-samples", self.resync_samples, 2, 1000)?;
        Ok(())
    }
}

/// Everything one monitor core needs, and nothing else (no vessel list, no session): the
/// sections of the configuration file that the core reads, cloned from
/// [`crate::config::Config::core`] or built by hand in tests.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct CoreConfig {
    /// The ship model and its nominal parameters.
    pub ship: ShipConfig,
    /// The rudder servo (nominal).
    pub servo: ServoConfig,
    /// Sensor rates (the resampling grid) and noise.
    pub sensors: SensorConfig,
    /// When tests run.
    pub scheduler: SchedulerConfig,
    /// Harmonic balance (relay) test.
    pub hbt: HbtConfig,
    /// Closed-loop frequency response (multisine) test.
    pub clfrt: ClfrtConfig,
    /// Safety limits on excitation and abort conditions.
    pub safety: SafetyConfig,
    /// Input validation.
    pub input: InputConfig,
    /// The estimator's models.
    pub estimator: EstimatorConfig,
    /// Fault detection and isolation.
    pub fdi: FdiConfig,
    /// What commissioning must resolve.
    pub reference: ReferenceConfig,
    /// The models' calibration on the class of hull (not a section of the file: the
    /// models directory's `calibration.json`, or the shipped models').
    pub calibration: Calibration,
    /// The time-domain baseline.
    pub baseline: BaselineConfig,
}

impl CoreConfig {
    /// Checks every section the core reads, and the limits between them.
    pub fn check(&self) -> Result<(), ConfigError> {
        self.ship.check()?;
        self.servo.check()?;
        self.sensors.check()?;
        self.scheduler.check()?;
        self.hbt.check()?;
        self.clfrt.check(self.sensors.rate_hz)?;
        self.safety.check(&self.servo)?;
        self.clfrt.check_servo_check_safety(
            self.safety.max_excitation_deg,
            self.safety.max_excitation_rate_deg_s,
            self.sensors.rate_hz,
        )?;
        self.input.check()?;
        self.estimator.check()?;
        self.fdi.check()?;
        self.reference.check()?;
        let nyquist = std::f64::consts::PI * self.sensors.rate_hz;
        if self.calibration.wave_band_rad_s[1] > nyquist {
            return Err(fail(
                "calibration.wave-band-rad-s",
                format!("{:?}", self.calibration.wave_band_rad_s),
                &format!("[lo, hi] with hi <= pi sensors.rate-hz = {nyquist:.3}"),
            ));
        }
        self.baseline.check()?;
        Ok(())
    }
}
