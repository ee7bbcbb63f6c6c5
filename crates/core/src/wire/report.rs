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
    /// Estimated parameters, null for an aborted test or when no estimator is loaded.
    pub estimate: Option<Estimate>,
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
