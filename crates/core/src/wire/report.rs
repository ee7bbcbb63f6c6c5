//! `fdi/report`: a test's outcome, estimate, decision and suspected causes.

use super::{residuals, Features};
use serde::{Deserialize, Serialize};

/// Test outcome.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum Outcome {
    /// The test ran to the end.
    Completed,
    /// The test was stopped by a safety condition.
    Aborted,
}

/// Decision of one test.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum Decision {
    /// Residuals consistent with the nominal ship.
    Nominal,
    /// A fault is declared.
    Fault,
    /// No decision (aborted test, no estimator, residuals pending persistence).
    Inconclusive,
}

/// A suspected cause in a report's `isolation` (and the FDI's notification).
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq, Eq, Hash)]
#[serde(rename_all = "snake_case")]
pub enum Cause {
    /// The speed log reads wrong.
    SpeedLog,
    /// The ship is heavier or lighter, or the rudder lost effectiveness (both move b).
    DisplacementOrRudderEffectiveness,
    /// The steering actuator (servo) responds unlike the nominal one.
    SteeringActuator,
}

impl Cause {
    /// Every cause.
    pub const ALL: [Cause; 3] = [
        Cause::SpeedLog,
        Cause::DisplacementOrRudderEffectiveness,
        Cause::SteeringActuator,
    ];

    /// The wire name (serde's), for messages.
    pub fn name(self) -> &'static str {
        match self {
            Cause::SpeedLog => "speed_log",
            Cause::DisplacementOrRudderEffectiveness => "displacement_or_rudder_effectiveness",
            Cause::SteeringActuator => "steering_actuator",
        }
    }
}

impl std::fmt::Display for Cause {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// `estimate` of a report.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq)]
pub struct Estimate {
    /// Estimated speed through water [m/s].
    pub speed_mps: f64,
    /// Estimated displacement [t].
    pub displacement_t: f64,
}

/// `calibrated_estimate` of a report (an addition to the contract): the networks' reading
/// corrected by the vessel's learned offset at the test's operating point, with the 95 %
/// interval of the vessel's healthy scatter there. The networks' own reading (`estimate`) is
/// biased on any real hull, by as much as a third on one outside the training family; this
/// is the number a person reads.
///
/// ```text
/// (b, g) = (V' Sigma^-1 V)^-1 V' Sigma^-1 r,  V = [v_log v_D]   (the two causes at once)
/// speed        u_cal = u_log - b          [m/s],  sd from (V' Sigma^-1 V)^-1
/// displacement D_cal = D_nom (1 + r_D)    [t],    sd = sqrt(Sigma_DD)
/// interval     value -+ 1.96 sd
/// ```
///
/// `r` is the residual against the reference in force (`residuals.parameters`: the networks'
/// reading less their validation bias and the vessel's learned offset), `Sigma` its
/// covariance, `v_log` and `v_D` how it moves per m/s of speed-log bias and per unit fraction
/// of the true displacement (`crate::fdi::report::cause_reading`); where the two cannot be
/// told apart, the speed component alone (`u_log + r_u`). The displacement is its own
/// component: the displacement network's reading given the log. Read with the log bias it
/// would take in the speed network's noise through the network's slope in the log. Only against the
/// vessel's own reference (`commissioned` or `predicted`): before it (the design's, or
/// commissioning's wide limits) there is no offset to correct by, and the report carries
/// `null`. A speed-log fault leaves `u_cal` at the speed through the water the hull shows.
/// Made by the FDI with the report's residuals (`crate::fdi::report::calibrated_estimate`).
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq)]
pub struct CalibratedEstimate {
    /// `u_cal` [m/s].
    pub speed_mps: f64,
    /// Its 95 % interval `[low, high]` [m/s].
    pub speed_interval_mps: [f64; 2],
    /// `D_cal` [t].
    pub displacement_t: f64,
    /// Its 95 % interval `[low, high]` [t].
    pub displacement_interval_t: [f64; 2],
    /// The reference the offset came from: `commissioned`, or `predicted` at an operating
    /// point not yet learned (a wider interval).
    pub reference: residuals::ReferenceKind,
}

impl CalibratedEstimate {
    /// The message's words: `calibrated to the vessel 7.02 m/s (6.81..7.23), 7010 t
    /// (6890..7130)`.
    pub fn sentence(&self) -> String {
        let [ul, uh] = self.speed_interval_mps;
        let [dl, dh] = self.displacement_interval_t;
        format!(
            "calibrated to the vessel {:.2} m/s ({ul:.2}..{uh:.2}), {:.0} t ({dl:.0}..{dh:.0})",
            self.speed_mps, self.displacement_t
        )
    }
}

/// `fdi/report`, after every test, completed or aborted.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct Report {
    /// Test id.
    pub test: String,
    /// Method.
    pub method: crate::wire::Method,
    /// Start of the test (ship time) [s].
    pub t_start: f64,
    /// End of the test (ship time) [s].
    pub t_end: f64,
    /// Completed or aborted.
    pub outcome: Outcome,
    /// Abort reason, or null.
    pub reason: Option<String>,
    /// Method-specific features (documented in docs/contract.md; `{}` for an aborted test).
    pub features: Features,
    /// The networks' estimate, raw: null for an aborted test or when no estimator is loaded.
    pub estimate: Option<Estimate>,
    /// The estimate calibrated to the vessel (an addition): null until the vessel's own
    /// reference is in force.
    #[serde(default)]
    pub calibrated_estimate: Option<CalibratedEstimate>,
    /// Residuals (documented in docs/contract.md; `{}` for an aborted test).
    #[serde(default)]
    pub residuals: residuals::Residuals,
    /// The decision.
    pub decision: Decision,
    /// Suspected causes.
    pub isolation: Vec<Cause>,
    /// Human-readable summary.
    pub message: String,
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The names in messages are serde's wire names, for every variant.
    #[test]
    fn cause_names_are_the_wire_names() {
        for c in Cause::ALL {
            assert_eq!(serde_json::to_value(c).unwrap(), c.name());
            assert_eq!(serde_json::from_value::<Cause>(c.name().into()).unwrap(), c);
        }
    }
}
