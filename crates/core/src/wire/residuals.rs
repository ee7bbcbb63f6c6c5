//! A report's `residuals`: what the FDI measured on a completed test, typed.
//!
//! One struct per group, one name per quantity, every field present only when it was
//! measured (`None` is left out of the JSON). An aborted test's report carries the empty
//! object `{}`. The model behind the numbers is in `crate::fdi` and docs/fdi.md; the
//! key list is docs/contract.md's, checked against these types by a test.
//!
//! Units: raw and reference residuals carry their units in their names (`_mps`, `_t`) or are
//! fractions of the nominal displacement (`displacement`, no suffix); `z_*` and `chi2`,
//! `statistic` are dimensionless (normalised by the reference's spread).

use crate::wire::{Cause, Decision};
use serde::{Deserialize, Serialize};

/// The report's `residuals`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct Residuals {
    /// The sea index in force [deg of wave yaw] (`None`: the test had no wave yaw).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sea_index: Option<f64>,
    /// Where the index sits between the calm (0) and moderate (1) anchors (up to 3).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sea_fraction: Option<f64>,
    /// The nominal displacement in force [t].
    #[serde(skip_serializing_if = "Option::is_none")]
    pub displacement_nominal_t: Option<f64>,
    /// The residuals against the design, before any reference (what commissioning samples).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub raw: Option<RawResiduals>,
    /// The parameter residuals against the reference in force.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub parameters: Option<ParameterResiduals>,
    /// The servo check (both methods).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub servo_check: Option<ServoCheck>,
    /// The CLFRT model fit.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub model_fit: Option<ModelFitReport>,
    /// Present when the model fit says the ship is outside the trained family.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub model_mismatch: Option<ModelMismatch>,
    /// The reference the test was measured against.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub reference: Option<ReferenceReport>,
    /// The vessel's sequential test after this test.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub decision: Option<DecisionReport>,
    /// The equation-error baseline's residuals and decision (comparison only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub baseline: Option<BaselineReport>,
    /// The servo time constant configured [s].
    #[serde(skip_serializing_if = "Option::is_none")]
    pub servo_time_constant_s: Option<f64>,
}

impl Residuals {
    /// The empty object of an aborted test or a test without residuals.
    pub fn is_empty(&self) -> bool {
        *self == Self::default()
    }
}

/// Residuals against the design (see `crate::fdi::reference`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct RawResiduals {
    /// `e_u = u_est - u_log - m_u` [m/s].
    pub speed_mps: f64,
    /// `e_D = (D_est - D_nom - m_D) / D_nom` [fraction].
    pub displacement: f64,
    /// The design spread of `e_u` at this test's sea [m/s].
    pub speed_sigma_mps: f64,
    /// The design spread of `e_D` [fraction].
    pub displacement_sigma: f64,
    /// The mean speed log over the test [m/s].
    pub speed_log_mps: f64,
    /// `dD_est / du_log` through the displacement network [t per m/s].
    pub dd_du_t_per_mps: f64,
    /// `e_b = ln b^`: the ln of the test's own high-frequency gain, read from the features
    /// (CLFRT's highest tone, HBT's cycle; docs/fdi.md) [ln 1/s^2].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ln_gain: Option<f64>,
    /// `e_a = ln(a^ / u_log)`: the test's own yaw damping (the first-order corner its
    /// response phase gives) over the speed log [ln 1/m]; reported, not decided on
    /// (docs/fdi.md, "Isolation").
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ln_damping: Option<f64>,
    /// How `(e_u [m/s], e_D, e_b)` move per m/s of the ship's own speed by the similarity law
    /// (the features at another speed, read by the networks; docs/fdi.md).
    #[serde(default)]
    pub speed_slope: [f64; 3],
    /// How they move per unit of `ln D` of a declared change of loading, `b` scaling by
    /// `1 / D` (docs/fdi.md).
    #[serde(default)]
    pub loading_slope: [f64; 3],
}

/// Parameter residuals against the reference in force.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ParameterResiduals {
    /// `r_u` [m/s].
    pub speed_mps: f64,
    /// Its standard deviation under the reference [m/s].
    pub speed_sigma_mps: f64,
    /// `r_u / speed_sigma_mps`.
    pub z_speed: f64,
    /// `r_D` [t].
    pub displacement_t: f64,
    /// Its standard deviation [t].
    pub displacement_sigma_t: f64,
    /// `r_D / displacement_sigma_t`.
    pub z_displacement: f64,
    /// `r_b`: `e_b` against the vessel's reference [ln] (`None`: measured without it,
    /// against the design or commissioning's wide limits).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ln_gain: Option<f64>,
    /// Its standard deviation under the reference [ln].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ln_gain_sigma: Option<f64>,
    /// `r_b / ln_gain_sigma`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub z_ln_gain: Option<f64>,
    /// The correlation of the speed and displacement residuals under the reference.
    pub correlation: f64,
    /// `r' Sigma^-1 r`, calibrated: the test's own Mahalanobis chi-square (`dof` degrees of
    /// freedom).
    pub chi2: f64,
    /// Its degrees of freedom: 3 with `ln_gain`, else 2.
    #[serde(default = "two")]
    pub dof: usize,
    /// How much the test's own measurement error beyond the vessel's typical widened its
    /// covariance, in the direction it widened most (`1 +` that share); absent when it did
    /// not (a test as clean as the vessel's typical, an HBT test, or against the design or
    /// commissioning's wide limits).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub noise_ratio: Option<f64>,
}

fn two() -> usize {
    2
}

/// The servo check: the rudder's measured rate against the healthy servo's.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ServoCheck {
    /// `rho`: measured rate over the healthy servo's.
    pub rate_ratio: f64,
    /// `max(0, 1 - rho) / calibration.actuator-rate-sigma`.
    pub z_rate: f64,
}

/// The CLFRT model fit (a first-order Nomoto model through the three tones).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ModelFitReport {
    /// Chi-square of the fit.
    pub chi2: f64,
    /// Its degrees of freedom.
    pub dof: usize,
    /// Fitted `a` [1/s].
    pub a_per_s: f64,
    /// Fitted `b` [1/s^2].
    pub b_per_s2: f64,
    /// The speed `a` gives [m/s].
    pub speed_mps: f64,
    /// The displacement `b` and that speed give [t].
    pub displacement_t: f64,
}

/// The `model_mismatch` warning (never a decision).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ModelMismatch {
    /// The model fit's chi-square.
    pub chi2: f64,
    /// `calibration.model-mismatch-chi2`.
    pub threshold: f64,
    /// What to do.
    pub advice: String,
}

/// Which reference a test was measured against.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ReferenceKind {
    /// The design's (no commissioning configured).
    Design,
    /// Commissioning: the design's, with wide limits.
    Commissioning,
    /// The commissioning sample held a change: wide limits until commissioned again.
    CommissioningInconsistent,
    /// The vessel's own, at an operating point within a bandwidth of a learned test.
    Commissioned,
    /// The vessel's own, predicted at an operating point not yet learned (a wider interval).
    Predicted,
}

/// The reference a test was measured against.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ReferenceReport {
    /// Which.
    pub kind: ReferenceKind,
    /// E.g. `commissioning 3 of 8`.
    pub text: String,
    /// Tests in the commissioning sample.
    pub tests: u32,
    /// Tests commissioning takes at most.
    pub of: u32,
    /// Tests the vessel's reference has learned (commissioning included).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub learned: Option<u32>,
    /// The reference's speed offset at this test's operating point [m/s].
    #[serde(skip_serializing_if = "Option::is_none")]
    pub speed_offset_mps: Option<f64>,
    /// The reference's displacement offset [t] at this test's operating point and the
    /// nominal displacement in force.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub displacement_offset_t: Option<f64>,
    /// The standard deviation of the speed offset's prediction [m/s].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub offset_speed_sigma_mps: Option<f64>,
    /// The standard deviation of the displacement offset's prediction [t].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub offset_displacement_sigma_t: Option<f64>,
    /// The reference's level of `ln b^` at this test's operating point.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ln_gain_offset: Option<f64>,
    /// The standard deviation of its prediction.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub offset_ln_gain_sigma: Option<f64>,
    /// The learned tests' kernel weight at this operating point [tests].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub support: Option<f64>,
    /// The correlation of speed and displacement errors in the learned tests.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub correlation: Option<f64>,
    /// The learned tests' mean speed log [m/s].
    #[serde(skip_serializing_if = "Option::is_none")]
    pub speed_log_mps: Option<f64>,
}

/// The vessel's sequential test after this test (`crate::fdi::decision`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DecisionReport {
    /// The track's state after the test.
    pub state: TrackState,
    /// The parameter channel's look nearest its limit (`None`: no parameter residuals yet).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub parameters: Option<Look>,
    /// The servo channel's look nearest its limit.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub servo: Option<Look>,
    /// The per-look false-alarm probability the limits were set for (both channels).
    pub false_alarm_per_test: f64,
    /// How well each parameter cause explains the parameter look's window: `J_c`, the part
    /// of its evidence the cause's model leaves (chi-square units; the likelier at its own
    /// degrees of freedom names it: `crate::fdi::isolation`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cause_costs: Option<CauseCosts>,
    /// The speed log's step those costs took: the mean reading over the look's tests less the
    /// reading before the fault [m/s] (a log bias is a jump of the reading, a loading change
    /// none; absent when not known, or at a point the vessel has not learned).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub log_step_mps: Option<f64>,
    /// The other parameter causes the evidence behind the report's `isolation` does not rule
    /// out at 95 % (`crate::fdi::isolation::not_ruled_out`; absent when none).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub not_ruled_out: Vec<Cause>,
}

/// The parameter causes' costs over a window (`crate::fdi::isolation`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct CauseCosts {
    /// A speed-log bias's.
    pub speed_log: f64,
    /// A displacement or rudder-effectiveness change's.
    pub displacement_or_rudder_effectiveness: f64,
}

/// One channel's window statistic.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Look {
    /// `T_n` (parameters: chi-square; servo: a one-sided normal score).
    pub statistic: f64,
    /// `n`: tests of the ship in the window.
    pub window: usize,
    /// Degrees of freedom (parameters: 2 per method in the window for a free shift, 1 per
    /// method along one cause's direction; servo: 1).
    pub dof: usize,
    /// The alarm limit for this window.
    pub threshold: f64,
    /// The alert limit for this window.
    pub alert_threshold: f64,
    /// The parameter cause whose direction the look tests (absent: a free shift, or the
    /// servo channel).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cause: Option<Cause>,
}

/// A track's alarm state.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum TrackState {
    /// Nothing over the limits lately.
    #[default]
    Normal,
    /// Over the alert limit, not the alarm's.
    Alert,
    /// Over the alarm limit: a fault.
    Alarm,
}

/// The equation-error baseline (comparison only; never drives the alarm).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BaselineReport {
    /// Its parameter residuals against the design (`None`: no estimate).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub parameters: Option<ParameterResiduals>,
    /// Its one-test decision at the same per-test limit.
    pub outcome: Decision,
    /// Its cause.
    pub isolation: Vec<Cause>,
}
