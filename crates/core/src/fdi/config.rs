//! The operator's `[fdi]` and `[reference]` sections, and the calibration the models carry.
//!
//! The operator sets what is required of the decision: the false-alarm budget every limit
//! follows from, the window and commissioning sample sizes, the faults commissioning must
//! resolve, and the physical floors of the residuals (docs/fdi.md, "The model"). Numbers
//! that describe the estimator on a class of hull (the sea anchors, the servo check's
//! spread, the model fit's floors, the commissioning spreads, the regression's bandwidths
//! and slope priors) are the models' [`Calibration`], written by `helmwatch train` into
//! `calibration.json` beside the networks.

use crate::config::{check_count, check_range, check_range_open_low, fail, ConfigError};
use serde::{Deserialize, Serialize};

/// The `[reference]` section: what commissioning must resolve before it ends.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(default, deny_unknown_fields, rename_all = "kebab-case")]
pub struct ReferenceConfig {
    /// Commissioning ends when a speed-log bias of this size would cross the single-test
    /// limit with 95 % probability [m/s] (and the displacement's below)...
    pub resolve_speed_mps: f64,
    /// ... and a displacement change of this fraction would.
    pub resolve_displacement: f64,
}

impl Default for ReferenceConfig {
    fn default() -> Self {
        Self {
            resolve_speed_mps: 0.5,
            resolve_displacement: 0.1,
        }
    }
}

impl ReferenceConfig {
    /// Checks the section's limits; the error names the key and its allowed range.
    pub fn check(&self) -> Result<(), ConfigError> {
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
        )
    }
}

/// The `[fdi]` section: the decision's budget, sample sizes and physical floors.
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
    /// good; else at least 5; from 6 the sample is checked for a change inside it).
    pub commissioning_tests: u32,
    /// Physical floor of the speed residual's standard deviation under the vessel's own
    /// reference [m/s]: the speed log's noise (the log is the speed residual's reference).
    pub floor_speed_mps: f64,
    /// Physical floor of the displacement residual's standard deviation [fraction of the
    /// nominal displacement]: how well a healthy ship's displacement is known between
    /// declarations (fuel and ballast move it).
    pub floor_displacement: f64,
}

impl Default for FdiConfig {
    fn default() -> Self {
        Self {
            enabled: true,
            false_alarms_per_year: 0.1,
            window_tests: 4,
            commissioning_tests: 16,
            floor_speed_mps: 0.05,
            floor_displacement: 0.004,
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
        check_range("fdi.floor-speed-mps", self.floor_speed_mps, 0.0, 5.0)?;
        check_range("fdi.floor-displacement", self.floor_displacement, 0.0, 0.5)
    }
}

/// The calibration of the estimator on its class of hull (`calibration.json` in the models
/// directory, written by `helmwatch train`). Pairs are `[calm, moderate]` or `[e_u, e_D]`.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, rename_all = "kebab-case")]
pub struct Calibration {
    /// Band of the wave yaw on the heading (`features.wave_yaw_rad`) [rad/s].
    pub wave_band_rad_s: [f64; 2],
    /// The wave yaw of a calm and of a moderate sea [deg]: the sea index's anchors.
    pub sea_wave_yaw_deg: [f64; 2],
    /// Standard deviation of the servo check's rate ratio on a healthy servo.
    pub actuator_rate_sigma: f64,
    /// Floor of the ln-gain spread of a tone in the CLFRT model fit.
    pub model_fit_floor_ln_gain: f64,
    /// Floor of the phase spread of a tone in the model fit [deg].
    pub model_fit_floor_phase_deg: f64,
    /// Model-fit chi-square above which a report warns `model_mismatch` (never a fault).
    pub model_mismatch_chi2: f64,
    /// Speed spread of the design's reference while commissioning [m/s]: the networks'
    /// error on a hull of the class that is not the training model.
    pub commissioning_spread_speed_mps: f64,
    /// Displacement spread while commissioning [fraction of the nominal displacement].
    pub commissioning_spread_displacement: f64,
    /// Kernel width in speed of the reference's regression [m/s].
    pub bandwidth_speed_mps: f64,
    /// Kernel width in declared loading [ln D].
    pub bandwidth_loading: f64,
    /// Kernel width in the excitation's scale [ln s].
    pub bandwidth_excitation: f64,
    /// Kernel width in the sea [ln of the sea index over its calm anchor].
    pub bandwidth_sea: f64,
    /// Prior sd of the offset's slope in speed about the similarity law's: `[e_u, e_D]`
    /// [m/s per m/s, fraction of D per m/s].
    pub slope_speed: [f64; 2],
    /// The same for `e_b` [ln per m/s] (its other slopes take `e_D`'s).
    pub slope_speed_gain: f64,
    /// Prior sd of the slope in declared loading about `Raw::loading_slope` [per unit ln D].
    pub slope_loading: [f64; 2],
    /// Prior sd of the slope in the excitation's scale [per unit ln s].
    pub slope_excitation: [f64; 2],
    /// Prior sd of the slope in the sea [per unit of ln of the sea index].
    pub slope_sea: [f64; 2],
    /// The estimator's healthy scatter on the class, per method and sea, and its weight
    /// (`crate::fdi::prior`; absent: a vessel's own tests alone set its scatter).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub healthy_scatter: Option<ScatterPrior>,
    /// How a test's residual moves when the ship's true displacement changes, measured on
    /// the class (`crate::fdi::raw`, "The displacement's direction"; absent: `b ~ 1 / D`
    /// alone, the Nomoto class's law, read through the networks at each test).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub displacement_direction: Option<DisplacementDirection>,
    /// How a test's residual moves per m/s of the ship's true speed, measured on the class,
    /// for the components where that describes the class better than the similarity law
    /// (`crate::fdi::raw`; absent, or a component null: the law, read through the networks
    /// at each test).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub speed_slope: Option<SpeedSlope>,
}

/// One method's healthy scatter on the models' class, in design-spread units
/// (`crate::fdi::prior`; rows and columns `e_u`, `e_D`, `e_b`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, rename_all = "kebab-case")]
pub struct ClassScatter {
    /// `Psi` in a calm sea.
    pub calm: [[f64; 3]; 3],
    /// `Psi` in a moderate sea.
    pub moderate: [[f64; 3]; 3],
    /// `w_j`: the prior's weight per component [dof].
    pub dof: [f64; 3],
}

/// Both methods' (`calibration.json`'s `healthy-scatter`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, rename_all = "kebab-case")]
pub struct ScatterPrior {
    /// CLFRT's.
    pub clfrt: ClassScatter,
    /// HBT's.
    pub hbt: ClassScatter,
}

/// Per method, `[calm, moderate]`: how `(e_u [m/s], e_D [fraction of the declared
/// displacement], e_b [ln])` move per unit of `ln D` of the ship's true displacement, the
/// declared one fixed (`calibration.json`'s `displacement-direction`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, rename_all = "kebab-case")]
pub struct DisplacementDirection {
    /// CLFRT's.
    pub clfrt: [[f64; 3]; 2],
    /// HBT's.
    pub hbt: [[f64; 3]; 2],
}

impl DisplacementDirection {
    /// `method`'s.
    pub fn of(&self, method: crate::wire::Method) -> [[f64; 3]; 2] {
        match method {
            crate::wire::Method::Clfrt => self.clfrt,
            crate::wire::Method::Hbt => self.hbt,
        }
    }
}

/// Per method and component `(e_u [m/s], e_D [fraction], e_b [ln])`: the class's slope per
/// m/s of the ship's true speed, `[calm, moderate]`, or null where the similarity law is the
/// better centre (`calibration.json`'s `speed-slope`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, rename_all = "kebab-case")]
pub struct SpeedSlope {
    /// CLFRT's.
    pub clfrt: [Option<[f64; 2]>; 3],
    /// HBT's.
    pub hbt: [Option<[f64; 2]>; 3],
}

impl SpeedSlope {
    /// `method`'s.
    pub fn of(&self, method: crate::wire::Method) -> [Option<[f64; 2]>; 3] {
        match method {
            crate::wire::Method::Clfrt => self.clfrt,
            crate::wire::Method::Hbt => self.hbt,
        }
    }

    /// Every slope given finite within +-10 per m/s; the error names the method's key.
    fn check(&self) -> Result<(), ConfigError> {
        for (name, per) in [("clfrt", self.clfrt), ("hbt", self.hbt)] {
            for pair in per.iter().flatten() {
                if !pair.iter().all(|x| x.is_finite() && x.abs() <= 10.0) {
                    return Err(fail(
                        &format!("calibration.speed-slope.{name}"),
                        format!("{pair:?}"),
                        "per component null or [calm, moderate] finite within +-10 per m/s",
                    ));
                }
            }
        }
        Ok(())
    }
}

/// Symmetric and positive definite (Sylvester's leading minors).
fn positive_definite(m: &[[f64; 3]; 3]) -> bool {
    let sym =
        (0..3).all(|i| (0..3).all(|j| (m[i][j] - m[j][i]).abs() <= 1e-9 * (1.0 + m[i][j].abs())));
    let d1 = m[0][0];
    let d2 = m[0][0] * m[1][1] - m[0][1] * m[1][0];
    let d3 = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
        - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
        + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
    m.iter().flatten().all(|v| v.is_finite()) && sym && d1 > 0.0 && d2 > 0.0 && d3 > 0.0
}

/// The calibration of the models shipped in `models/` (the embedded default).
pub const EMBEDDED_CALIBRATION: &str = include_str!(concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../../models/calibration.json"
));

impl Default for Calibration {
    /// The shipped models' (`models/calibration.json`, embedded). The text is a constant of
    /// the binary, parsed and checked by this module's unit test: it cannot fail at run time.
    #[allow(clippy::expect_used)]
    fn default() -> Self {
        Self::from_json(EMBEDDED_CALIBRATION)
            .expect("models/calibration.json is checked by a unit test")
    }
}

impl Calibration {
    /// Parses and checks a `calibration.json`; the error names the key and its range.
    pub fn from_json(text: &str) -> Result<Self, ConfigError> {
        let c: Calibration =
            serde_json::from_str(text).map_err(|e| ConfigError::Parse(e.to_string()))?;
        c.check()?;
        Ok(c)
    }

    /// Checks the limits; the error names the key and its allowed range.
    pub fn check(&self) -> Result<(), ConfigError> {
        let increasing = |key: &str, p: [f64; 2], hi: f64| -> Result<(), ConfigError> {
            check_range(key, p[0], 0.0, hi)?;
            check_range(key, p[1], 0.0, hi)?;
            if p[1] > p[0] {
                Ok(())
            } else {
                Err(fail(
                    key,
                    format!("[{}, {}]", p[0], p[1]),
                    "[low, high] with low < high",
                ))
            }
        };
        increasing("calibration.sea-wave-yaw-deg", self.sea_wave_yaw_deg, 10.0)?;
        increasing("calibration.wave-band-rad-s", self.wave_band_rad_s, 10.0)?;
        let open = |key: &str, v: f64, hi: f64| check_range_open_low(key, v, 0.0, hi);
        open(
            "calibration.actuator-rate-sigma",
            self.actuator_rate_sigma,
            1.0,
        )?;
        open(
            "calibration.model-fit-floor-ln-gain",
            self.model_fit_floor_ln_gain,
            10.0,
        )?;
        open(
            "calibration.model-fit-floor-phase-deg",
            self.model_fit_floor_phase_deg,
            90.0,
        )?;
        open(
            "calibration.model-mismatch-chi2",
            self.model_mismatch_chi2,
            1e9,
        )?;
        open(
            "calibration.commissioning-spread-speed-mps",
            self.commissioning_spread_speed_mps,
            10.0,
        )?;
        open(
            "calibration.commissioning-spread-displacement",
            self.commissioning_spread_displacement,
            1.0,
        )?;
        open(
            "calibration.bandwidth-speed-mps",
            self.bandwidth_speed_mps,
            20.0,
        )?;
        open("calibration.bandwidth-loading", self.bandwidth_loading, 2.0)?;
        open(
            "calibration.bandwidth-excitation",
            self.bandwidth_excitation,
            2.0,
        )?;
        open("calibration.bandwidth-sea", self.bandwidth_sea, 5.0)?;
        let pair = |key: &str, p: [f64; 2], hi: [f64; 2]| -> Result<(), ConfigError> {
            for (v, h) in p.iter().zip(hi) {
                if !(v.is_finite() && *v > 0.0 && *v <= h) {
                    return Err(fail(
                        key,
                        format!("[{}, {}]", p[0], p[1]),
                        &format!("[e_u, e_D], in (0, {}] and (0, {}]", hi[0], hi[1]),
                    ));
                }
            }
            Ok(())
        };
        pair("calibration.slope-speed", self.slope_speed, [10.0, 1.0])?;
        open("calibration.slope-speed-gain", self.slope_speed_gain, 1.0)?;
        pair(
            "calibration.slope-loading",
            self.slope_loading,
            [100.0, 10.0],
        )?;
        pair(
            "calibration.slope-excitation",
            self.slope_excitation,
            [100.0, 10.0],
        )?;
        pair("calibration.slope-sea", self.slope_sea, [10.0, 1.0])?;
        if let Some(h) = &self.healthy_scatter {
            for (name, c) in [("clfrt", h.clfrt), ("hbt", h.hbt)] {
                let key = format!("calibration.healthy-scatter.{name}");
                for w in c.dof {
                    check_range(&format!("{key}.dof"), w, 0.0, 10_000.0)?;
                }
                for (sea, psi) in [("calm", c.calm), ("moderate", c.moderate)] {
                    if !positive_definite(&psi) {
                        return Err(fail(
                            &format!("{key}.{sea}"),
                            format!("{psi:?}"),
                            "a symmetric positive definite 3 x 3 matrix",
                        ));
                    }
                }
            }
        }
        if let Some(d) = &self.displacement_direction {
            for (name, pair) in [("clfrt", d.clfrt), ("hbt", d.hbt)] {
                for (sea, v) in ["calm", "moderate"].iter().zip(pair) {
                    // A direction the displacement reads: finite, and e_D moving with D.
                    if !(v.iter().all(|x| x.is_finite() && x.abs() <= 100.0) && v[1] > 0.0) {
                        return Err(fail(
                            &format!("calibration.displacement-direction.{name}.{sea}"),
                            format!("{v:?}"),
                            "[e_u, e_D, e_b] finite within +-100, e_D > 0",
                        ));
                    }
                }
            }
        }
        self.speed_slope.as_ref().map_or(Ok(()), SpeedSlope::check)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_shipped_calibration_parses_and_a_bad_one_names_its_key() {
        let c = Calibration::default();
        assert!(c.sea_wave_yaw_deg[0] < c.sea_wave_yaw_deg[1]);
        let mut v: serde_json::Value = serde_json::from_str(EMBEDDED_CALIBRATION).unwrap();
        v["sea-wave-yaw-deg"] = serde_json::json!([0.2, 0.1]);
        let e = Calibration::from_json(&v.to_string()).unwrap_err();
        assert!(
            e.to_string().contains("calibration.sea-wave-yaw-deg"),
            "{e}"
        );
        v["sea-wave-yaw-deg"] = serde_json::json!([0.05, 0.18]);
        // A displacement direction e_D does not move along is no direction of D.
        let dir = |e_d: f64| {
            serde_json::json!({
                "clfrt": [[0.0, 1.0, -0.5], [0.0, 1.0, -0.5]],
                "hbt": [[0.0, 1.0, -1.0], [0.0, e_d, -1.0]],
            })
        };
        v["displacement-direction"] = dir(0.9);
        let c = Calibration::from_json(&v.to_string()).unwrap();
        assert_eq!(
            c.displacement_direction
                .unwrap()
                .of(crate::wire::Method::Hbt)[1],
            [0.0, 0.9, -1.0]
        );
        v["displacement-direction"] = dir(-0.1);
        let e = Calibration::from_json(&v.to_string()).unwrap_err();
        assert!(
            e.to_string()
                .contains("calibration.displacement-direction.hbt.moderate"),
            "{e}"
        );
        v["displacement-direction"] = dir(0.9);
        // The speed's slope: a component null is the similarity law's; a NaN names its key.
        v["speed-slope"] = serde_json::json!({
            "clfrt": [[0.01, 0.02], null, null],
            "hbt": [null, [-0.003, -0.004], null],
        });
        let c = Calibration::from_json(&v.to_string()).unwrap();
        let s = c.speed_slope.unwrap();
        assert_eq!(s.of(crate::wire::Method::Clfrt)[0], Some([0.01, 0.02]));
        assert_eq!(s.of(crate::wire::Method::Hbt)[0], None);
        v["speed-slope"]["hbt"][1] = serde_json::json!([0.0, 11.0]);
        let e = Calibration::from_json(&v.to_string()).unwrap_err();
        assert!(e.to_string().contains("calibration.speed-slope.hbt"), "{e}");
        v["speed-slope"]["hbt"][1] = serde_json::Value::Null;
        v["unknown-key"] = serde_json::json!(1);
        let e = Calibration::from_json(&v.to_string()).unwrap_err();
        assert!(e.to_string().contains("unknown-key"), "{e}");
    }
}
