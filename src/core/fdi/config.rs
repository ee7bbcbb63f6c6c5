//! The `[fdi]` section: residual spreads, decision rule, alarm state.

use crate::core::config::{check_count, check_range, check_range_open_low, fail, ConfigError};
use crate::core::wire::Method;
use serde::{Deserialize, Serialize};

/// The decision rule on the normalised residuals (see `crate::core::fdi`).
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq, Eq, Default)]
#[serde(rename_all = "kebab-case")]
pub enum DecisionRule {
    /// Chi-square on each residual group, with persistence over successive tests.
    #[default]
    ChiSquare,
    /// Two-sided CUSUM on each normalised residual.
    Cusum,
    /// A window GLR: the mean of the last n tests' normalised residuals, n = 1 to
    /// `glr-window`, against `glr-threshold` (one overwhelming test is enough).
    Glr,
}

impl DecisionRule {
    /// Name in the configuration and the reports.
    pub fn name(self) -> &'static str {
        match self {
            DecisionRule::ChiSquare => "chi-square",
            DecisionRule::Cusum => "cusum",
            DecisionRule::Glr => "glr",
        }
    }
}

/// The commissioning keys of `[fdi]` (see `crate::core::fdi::reference`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Commissioning {
    /// K: tests per method (0: the design reference for good).
    pub tests: u32,
    /// Speed spread floor while commissioning [m/s].
    pub wide_speed_mps: f64,
    /// Displacement spread floor while commissioning [fraction of D_nom].
    pub wide_displacement: f64,
    /// `f`.
    pub spread_factor: f64,
    /// The reference's speed band [m/s].
    pub speed_band_mps: f64,
    /// The commissioned displacement spread's floor [fraction of D_nom].
    pub floor_displacement: f64,
}

/// Fault detection and isolation (see `crate::core::fdi`). Pairs are `[calm, moderate]` values,
/// interpolated by the test's measured sea index.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(default, deny_unknown_fields, rename_all = "kebab-case")]
pub struct FdiConfig {
    /// Decide on completed tests (false: residuals are still reported, decision inconclusive).
    pub enabled: bool,
    /// `chi-square` (with persistence), `cusum` or `glr`.
    pub rule: DecisionRule,
    /// Chi-square limit of each two-dimensional residual group (13.82: 0.1 % for m = 2).
    pub chi2_threshold: f64,
    /// Exceeding tests in a row (of one method) before the alarm (chi-square rule).
    pub persistence: u32,
    /// Chi-square rule: one test whose parameter chi-square exceeds this is an alarm by
    /// itself (overwhelming evidence; healthy ships of the family reached 44 in 5755 tests).
    pub chi2_single_threshold: f64,
    /// Chi-square rule: one test whose servo-check chi-square `z_rate^2` exceeds this is an
    /// alarm by itself (healthy family: at most 2.2; a 2 deg/s servo: 31 to 37).
    pub actuator_single_threshold: f64,
    /// Chi-square rule: the mean of this many consecutive tests' parameter residuals (each
    /// clipped to `glr-clip`, against one reference) is tested too (0: off). A persistent
    /// shift too small for one test's limit adds up over them.
    pub mean_window: u32,
    /// Chi-square rule: the limit of that mean's statistic `T_n` (chi-square, 2 degrees of
    /// freedom for a healthy ship); over it the alarm is raised at once.
    pub mean_threshold: f64,
    /// Chi-square rule, both methods in turn: the sum of the last this many tests' parameter
    /// chi-square of the ship (each clipped to `glr-clip^2`, each against its method's
    /// commissioned reference, both methods among them) is tested too (0: off).
    pub vessel_window: u32,
    /// Chi-square rule: the limit of that sum (at most chi-square with 2 `vessel-window`
    /// degrees of freedom for a healthy ship); over it the alarm is raised at once.
    pub vessel_threshold: f64,
    /// Non-exceeding tests in a row that clear an alarm.
    pub clear_after: u32,
    /// CUSUM reference value k [sigma].
    pub cusum_k: f64,
    /// CUSUM decision interval h [sigma].
    pub cusum_h: f64,
    /// GLR rule: the longest window of tests (of one method) whose mean is tested.
    pub glr_window: u32,
    /// GLR rule: the limit of each window's statistic (chi-square, 2 degrees of freedom),
    /// windows of two tests or more.
    pub glr_threshold: f64,
    /// GLR rule: the limit of the newest test alone (its chi-square).
    pub glr_single_threshold: f64,
    /// GLR rule: in windows of two tests or more, each test's z is clipped to this norm.
    pub glr_clip: f64,
    /// Name the second parameter cause too when its GLR cost is within this margin [chi2].
    pub isolation_margin: f64,
    /// One fault at a time: a servo check over its limit names `steering_actuator` alone (a
    /// slow servo also moves the parameter residuals; the servo check measures it directly).
    pub single_fault: bool,
    /// Name the cause for the vessel when both methods are out of `normal`: the parameter
    /// cause from CLFRT's episode (HBT's when CLFRT's parameter residuals did not exceed),
    /// the steering actuator when either method's servo check exceeded; off, each method
    /// names from its own tests alone.
    pub isolation_across_methods: bool,
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
    /// Commissioning: completed tests per method that set the vessel's own reference (0: the
    /// design reference for good; see `crate::core::fdi::reference`).
    pub commissioning_tests: u32,
    /// Speed spread floor while commissioning (and outside the reference's speed band) [m/s].
    pub commissioning_spread_speed_mps: f64,
    /// Displacement spread floor while commissioning [fraction of the nominal displacement].
    pub commissioning_spread_displacement: f64,
    /// Factor on the commissioning sample's standard deviation in the reference's spread.
    pub commissioning_spread_factor: f64,
    /// The reference holds for speed logs within this of the commissioning's mean [m/s].
    pub commissioning_speed_band_mps: f64,
    /// The commissioned reference's displacement spread is at least this [fraction of the
    /// nominal displacement]: a healthy ship's displacement, read by a test, is not known
    /// better (fuel and ballast move it; a dead band's operating point moves the estimate).
    pub commissioned_floor_displacement: f64,
    /// CLFRT model-fit chi-square above which a test reports `model_mismatch` (a warning,
    /// never a fault).
    pub model_mismatch_chi2: f64,
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
            glr_window: 3,
            glr_threshold: 25.0,
            glr_single_threshold: 60.0,
            chi2_single_threshold: 60.0,
            actuator_single_threshold: 25.0,
            mean_window: 3,
            mean_threshold: 20.0,
            vessel_window: 3,
            vessel_threshold: 30.0,
            glr_clip: 4.0,
            isolation_margin: 0.0,
            single_fault: true,
            isolation_across_methods: true,
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
            commissioning_tests: 8,
            commissioning_spread_speed_mps: 2.2,
            commissioning_spread_displacement: 0.25,
            commissioning_spread_factor: 1.25,
            commissioning_speed_band_mps: 1.0,
            commissioned_floor_displacement: 0.004,
            model_mismatch_chi2: 100.0,
            baseline_clfrt_speed_sigma_mps: [0.07, 0.33],
            baseline_clfrt_displacement_sigma_t: [20.0, 100.0],
            baseline_hbt_speed_sigma_mps: [0.04, 0.16],
            baseline_hbt_displacement_sigma_t: [12.0, 65.0],
        }
    }
}

impl FdiConfig {
    /// The commissioning keys.
    pub fn commissioning(&self) -> Commissioning {
        Commissioning {
            tests: self.commissioning_tests,
            wide_speed_mps: self.commissioning_spread_speed_mps,
            wide_displacement: self.commissioning_spread_displacement,
            spread_factor: self.commissioning_spread_factor,
            speed_band_mps: self.commissioning_speed_band_mps,
            floor_displacement: self.commissioned_floor_displacement,
        }
    }

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

    /// Checks the section's limits; the error names the key and its allowed range.
    pub fn check(&self) -> Result<(), ConfigError> {
        check_range_open_low("fdi.chi2-threshold", self.chi2_threshold, 0.0, 1000.0)?;
        check_count("fdi.persistence", self.persistence, 1, 20)?;
        for (key, v) in [
            ("fdi.chi2-single-threshold", self.chi2_single_threshold),
            (
                "fdi.actuator-single-threshold",
                self.actuator_single_threshold,
            ),
        ] {
            if !(v.is_finite() && v >= self.chi2_threshold && v <= 1e6) {
                return Err(fail(
                    key,
                    v,
                    &format!("[fdi.chi2-threshold = {}, 1e6]", self.chi2_threshold),
                ));
            }
        }
        if self.mean_window == 1 || self.mean_window > 20 {
            return Err(fail(
                "fdi.mean-window",
                self.mean_window,
                "0 (off) or [2, 20] tests",
            ));
        }
        check_range_open_low("fdi.mean-threshold", self.mean_threshold, 0.0, 1000.0)?;
        if self.vessel_window == 1 || self.vessel_window > 20 {
            return Err(fail(
                "fdi.vessel-window",
                self.vessel_window,
                "0 (off) or [2, 20] tests",
            ));
        }
        check_range_open_low("fdi.vessel-threshold", self.vessel_threshold, 0.0, 1000.0)?;
        check_count("fdi.clear-after", self.clear_after, 1, 1000)?;
        check_range("fdi.cusum-k", self.cusum_k, 0.0, 10.0)?;
        check_range_open_low("fdi.cusum-h", self.cusum_h, 0.0, 1000.0)?;
        check_count("fdi.glr-window", self.glr_window, 1, 20)?;
        check_range_open_low("fdi.glr-threshold", self.glr_threshold, 0.0, 1000.0)?;
        check_range_open_low(
            "fdi.glr-single-threshold",
            self.glr_single_threshold,
            0.0,
            10000.0,
        )?;
        check_range("fdi.glr-clip", self.glr_clip, 1.0, 100.0)?;
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
        check_count("fdi.commissioning-tests", self.commissioning_tests, 0, 50)?;
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
        check_range(
            "fdi.commissioning-spread-factor",
            self.commissioning_spread_factor,
            1.0,
            10.0,
        )?;
        check_range_open_low(
            "fdi.commissioning-speed-band-mps",
            self.commissioning_speed_band_mps,
            0.0,
            30.0,
        )?;
        check_range(
            "fdi.commissioned-floor-displacement",
            self.commissioned_floor_displacement,
            0.0,
            0.5,
        )?;
        check_range_open_low(
            "fdi.model-mismatch-chi2",
            self.model_mismatch_chi2,
            0.0,
            1e9,
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
