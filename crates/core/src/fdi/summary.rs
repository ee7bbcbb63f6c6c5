//! The summary of a vessel's own reference of one method that status, the commissioning
//! queryable and the plots show (`reference::MethodReference::summarize` makes it).

use super::stats::Cov;
use serde::{Deserialize, Serialize};

/// A summary of the vessel's own reference of one method (status, plots).
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct Reference {
    /// Tests it was commissioned on (K).
    pub tests: u32,
    /// Tests it has learned in all (commissioning included).
    pub learned: u32,
    /// Offset of `e_u` at the learned tests' mean operating point [m/s].
    pub speed_offset_mps: f64,
    /// Offset of `e_D` there [fraction of D_nom].
    pub displacement_offset: f64,
    /// Level of `e_b`, the ln of the high-frequency gain, there [ln 1/s^2].
    pub ln_gain: f64,
    /// The scatter's covariance at the learned tests' mean design spreads (rows `e_u` [m/s],
    /// `e_D` [fraction], `e_b` [ln]).
    pub covariance: Cov,
    /// Its effective degrees of freedom.
    pub dof: f64,
    /// Mean design spread of the speed over the learned tests [m/s].
    pub speed_design_sigma_mps: f64,
    /// Mean design spread of the displacement [fraction].
    pub displacement_design_sigma: f64,
    /// Mean speed log of the learned tests [m/s].
    pub speed_log_mps: f64,
    /// Slowest and fastest learned speed log [m/s].
    pub speed_range_mps: [f64; 2],
    /// Lightest and heaviest learned declared displacement [t].
    pub displacement_range_t: [f64; 2],
    /// The vessel's scatter over its class's (`prior`; `None`: no prior, or too few tests).
    pub class_scatter_ratio: Option<f64>,
    /// The class's prior is pooled into the covariance (the scatter test keeps it).
    pub class_prior: bool,
}
