//! The `[fdi]` section: the vessel's normal, one sequential test, one operator-facing number.
//!
//! Every limit of the decision follows from `false-alarms-per-year` and the scheduler's test
//! rate (`crate::core::fdi::decision`); the other keys describe the measurement (floors,
//! sea anchors, the servo check's noise) or the commissioning.

use crate::core::config::{check_count, check_range, check_range_open_low, fail, ConfigError};
use serde::{Deserialize, Serialize};

/// The `[reference]` section: the vessel's own reference over its operating envelope (see
/// `crate::core::fdi::reference` and `crate::core::fdi::envelope`).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(default, deny_unknown_fields, rename_all = "kebab-case")]
pub struct ReferenceConfig {
    /// Kernel width in speed of the local regression [m/s]: tests this far apart lend each
    /// other half their weight.
    pub bandwidth_speed_mps: f64,
    /// Kernel width in declared loading [ln D]: 0.1 is about 10 % of the displacement.
    pub bandwidth_loading: f64,
    /// Prior standard deviation of the offset's slope in speed about the similarity law's
    /// slope: `[e_u, e_D]` [m/s per m/s, fraction of D per m/s].
    pub slope_speed: [f64; 2],
    /// Prior standard deviation of `e_b`'s slope in speed about the similarity law's [ln per
    /// m/s]: the population's spread of the law's error (docs/fdi.md, "The reference follows the
    /// ship"). Its other slopes take `e_D`'s.
    pub slope_speed_gain: f64,
    /// Prior standard deviation of the offset's slope in declared loading about the slope of
    /// `b` scaling by `1 / D`: `[e_u, e_D]` [m/s, fraction of D, per unit of ln D].
    pub slope_loading: [f64; 2],
    /// Kernel width in the excitation's scale [ln s]: a test sized down to the loop it
    /// found (HBT's relay, CLFRT's tones) is another operating point; 0.1 is about 10 %.
    pub bandwidth_excitation: f64,
    /// Prior standard deviation of the offset's slope in the excitation's scale: `[e_u,
    /// e_D]` [m/s, fraction of D, per unit of ln s].
    pub slope_excitation: [f64; 2],
    /// Kernel width in the sea [ln of the sea index]: the sea index (the test's wave yaw)
    /// this factor `e^b` apart lends half its weight; a calm and a moderate sea are 1.3 apart
    /// at the default anchors.
    pub bandwidth_sea: f64,
    /// Prior standard deviation of the offset's slope in the sea: `[e_u, e_D]` [m/s,
    /// fraction of D, per unit of ln of the sea index].
    pub slope_sea: [f64; 2],
    /// At most this many learned tests per method.
    pub memory_tests: u32,
    /// Commissioning ends when a speed-log bias of this size would cross the single-test
    /// limit with 95 % probability [m/s] (and the displacement's below)...
    pub resolve_speed_mps: f64,
    /// ... and a displacement change of this fraction would.
    pub resolve_displacement: f64,
    /// A test whose own measurement error widens its covariance by more than this factor in
    /// some direction (`noise_ratio`) is judged but not learned: it says little of the
    /// vessel's normal, and learned as a typical test it would widen the scatter.
    pub learn_noise_ratio_max: f64,
}

impl Default for ReferenceConfig {
    fn default() -> Self {
        Self {
            bandwidth_speed_mps: 1.0,
            bandwidth_loading: 0.1,
            slope_speed: [0.5, 0.03],
            slope_speed_gain: 0.017,
            slope_loading: [4.0, 0.3],
            bandwidth_excitation: 0.1,
            slope_excitation: [3.0, 0.3],
            bandwidth_sea: 0.5,
            slope_sea: [0.5, 0.04],
            memory_tests: 200,
            resolve_speed_mps: 0.5,
            resolve_displacement: 0.1,
            learn_noise_ratio_max: 4.0,
        }
    }
}

impl ReferenceConfig {
    /// Checks the section's limits; the error names the key and its allowed range.
    pub fn check(&self) -> Result<(), ConfigError> {
        check_range_open_low(
            "reference.bandwidth-speed-mps",
            self.bandwidth_speed_mps,
            0.0,
            20.0,
        )?;
        check_range_open_low(
            "reference.bandwidth-loading",
            self.bandwidth_loading,
            0.0,
            2.0,
        )?;
        let pair = |key: &str, p: [f64; 2], hi: [f64; 2]| -> Result<(), ConfigError> {
            for (v, h) in p.iter().zip(hi) {
                if !(v.is_finite() && *v > 0.0 && *v <= h) {
                    return Err(fail(
                        key,
                        format!("[{}, {}]", p[0], p[1]),
                        &format!(
                            "[e_u, e_D], each in (0, {h}] for e_u and (0, {}] for e_D",
                            hi[1]
                        ),
                    ));
                }
            }
            Ok(())
        };
        pair("reference.slope-speed", self.slope_speed, [10.0, 1.0])?;
        check_range_open_low(
            "reference.slope-speed-gain",
            self.slope_speed_gain,
            0.0,
            1.0,
        )?;
        pair("reference.slope-loading", self.slope_loading, [100.0, 10.0])?;
        check_range_open_low(
            "reference.bandwidth-excitation",
            self.bandwidth_excitation,
            0.0,
            2.0,
        )?;
        pair(
            "reference.slope-excitation",
            self.slope_excitation,
            [100.0, 10.0],
        )?;
        check_range_open_low("reference.bandwidth-sea", self.bandwidth_sea, 0.0, 5.0)?;
        pair("reference.slope-sea", self.slope_sea, [10.0, 1.0])?;
        check_count("reference.memory-tests", self.memory_tests, 6, 5000)?;
        check_range_open_low(
            "reference.resolve-speed-mps",
            self.resolve_speed_mps,
            0.0,
            10.0,
        )?;
        check_range_open_low(
            "reference.resolve-displacement",
            self.resolve_displacement,
            0.0,
            1.0,
        )?;
        check_range(
            "reference.learn-noise-ratio-max",
            self.learn_noise_ratio_max,
            1.0,
            1e6,
        )?;
        Ok(())
    }
}

/// Fault detection and isolation (see `crate::core::fdi`). Pairs are `[calm, moderate]`.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(default, deny_unknown_fields, rename_all = "kebab-case")]
pub struct FdiConfig {
    /// Decide on completed tests (false: residuals are still reported, decision inconclusive).
    pub enabled: bool,
    /// The false alarms per vessel-year the operator accepts from a healthy ship at sea all
    /// year at the scheduler's test rate: every limit of the decision follows from it.
    pub false_alarms_per_year: f64,
    /// The longest window of the vessel's tests (both methods) the sequential test looks
    /// back over; an alarm clears after this many tests under the alert limits.
    pub window_tests: u32,
    /// Commissioning: at most this many completed tests per method set the vessel's own
    /// reference, fewer when they resolve `reference.resolve-*` (0: the design reference for
    /// good; else at least 5, which the covariance's K-sample factor needs; from 6 the
    /// sample is checked for a change inside it).
    pub commissioning_tests: u32,
    /// Speed spread floor while commissioning (and outside the reference's speed band) [m/s].
    pub commissioning_spread_speed_mps: f64,
    /// Displacement spread floor while commissioning [fraction of the nominal displacement].
    pub commissioning_spread_displacement: f64,
    /// Physical floor of the speed residual's standard deviation under the vessel's own
    /// reference [m/s]: the speed log's noise (the log is the speed residual's reference).
    pub floor_speed_mps: f64,
    /// Physical floor of the displacement residual's standard deviation [fraction of the
    /// nominal displacement]: how well a healthy ship's displacement is known between
    /// declarations (fuel and ballast move it).
    pub floor_displacement: f64,
    /// Band of the wave yaw on the heading (`features.wave_yaw_rad`) [rad/s].
    pub wave_band_rad_s: [f64; 2],
    /// The measured wave yaw in a calm and a moderate sea [deg]: anchors of the sea index.
    pub sea_wave_yaw_deg: [f64; 2],
    /// Standard deviation of the servo check's rate ratio on a healthy servo.
    pub actuator_rate_sigma: f64,
    /// Floor of the ln-gain spread of a tone in the model fit.
    pub model_fit_floor_ln_gain: f64,
    /// Floor of the phase spread of a tone in the model fit [deg].
    pub model_fit_floor_phase_deg: f64,
    /// CLFRT model-fit chi-square above which a test reports `model_mismatch` (a warning,
    /// never a fault).
    pub model_mismatch_chi2: f64,
}

impl Default for FdiConfig {
    fn default() -> Self {
        Self {
            enabled: true,
            false_alarms_per_year: 0.1,
            window_tests: 4,
            commissioning_tests: 16,
            commissioning_spread_speed_mps: 2.2,
            commissioning_spread_displacement: 0.25,
            floor_speed_mps: 0.05,
            floor_displacement: 0.004,
            wave_band_rad_s: [0.4, 2.0],
            sea_wave_yaw_deg: [0.05, 0.18],
            actuator_rate_sigma: 0.03,
            model_fit_floor_ln_gain: 0.01,
            model_fit_floor_phase_deg: 0.5,
            model_mismatch_chi2: 100.0,
        }
    }
}

impl FdiConfig {
    /// Checks the section's limits; the error names the key and its allowed range.
    pub fn check(&self) -> Result<(), ConfigError> {
        check_range_open_low(
            "fdi.false-alarms-per-year",
            self.false_alarms_per_year,
            0.0,
            100.0,
        )?;
        check_count("fdi.window-tests", self.window_tests, 1, 12)?;
        if self.commissioning_tests != 0 && !(5..=50).contains(&self.commissioning_tests) {
            return Err(fail(
                "fdi.commissioning-tests",
                self.commissioning_tests,
                "0 (the design reference) or [5, 50] tests",
            ));
        }
        check_range_open_low(
            "fdi.commissioning-spread-speed-mps",
            self.commissioning_spread_speed_mps,
            0.0,
            10.0,
        )?;
        check_range_open_low(
            "fdi.commissioning-spread-displacement",
            self.commissioning_spread_displacement,
            0.0,
            1.0,
        )?;
        check_range("fdi.floor-speed-mps", self.floor_speed_mps, 0.0, 5.0)?;
        check_range("fdi.floor-displacement", self.floor_displacement, 0.0, 0.5)?;
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
            "fdi.model-mismatch-chi2",
            self.model_mismatch_chi2,
            0.0,
            1e9,
        )?;
        Ok(())
    }
}
