//! What a recording's messages are: each channel's kind and JSON schema, the analysis
//! channel's key, and the time a message is logged at.

use helmwatch_core::wire::{Keys, Stream};

/// What kind of message a channel carries (its schema).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Kind {
    /// An input stream, as received.
    Input(Stream),
    /// `steering/autopilot/excitation`.
    Excitation,
    /// `fdi/status`.
    Status,
    /// `fdi/report`.
    Report,
    /// `notifications/steering/fdi`.
    Notification,
    /// `fdi/analysis`: one grid point of a test's analysis.
    Analysis,
    /// `fdi/rejected`: a rejected input, bounded.
    Rejected,
}

/// `vessels/<v>/fdi/analysis`: the channel of the analysis records (recordings only, never
/// published on Zenoh).
pub fn analysis_key(keys: &Keys) -> String {
    format!("{}/fdi/analysis", keys.prefix)
}

impl Kind {
    /// The schema's name and its JSON schema.
    pub(super) fn schema(self) -> (&'static str, serde_json::Value) {
        use serde_json::json;
        let num = json!({"type": "number"});
        let t = json!({"type": "number", "description": "ship time [s] (UNIX time in service)"});
        let nullable_str = json!({"type": ["string", "null"]});
        match self {
            Kind::Input(Stream::AutopilotState) => (
                "helmwatch.AutopilotState",
                json!({"type": "object", "properties": {"t": t, "value": {"type": "string"}}}),
            ),
            Kind::Input(s) => (
                "helmwatch.Scalar",
                json!({"type": "object", "title": s.name(),
                    "properties": {"t": t, "value": {"type": "number", "description": "SI units: rad, m/s, kg"}}}),
            ),
            Kind::Excitation => (
                "helmwatch.Excitation",
                json!({"type": "object", "properties": {
                    "t": t,
                    "mode": {"type": "string", "enum": ["none", "add", "replace"]},
                    "value": {"type": "number", "description": "rad"},
                    "hold_s": num,
                    "test": nullable_str}}),
            ),
            Kind::Status => (
                "helmwatch.Status",
                json!({"type": "object", "properties": {
                    "t": t,
                    "state": {"type": "string", "enum": ["idle", "settling", "exciting", "analysing"]},
                    "test": nullable_str,
                    "method": {"type": ["string", "null"], "enum": ["hbt", "clfrt", null]},
                    "reason": nullable_str}}),
            ),
            Kind::Report => (
                "helmwatch.Report",
                json!({"type": "object", "properties": {
                    "test": {"type": "string"},
                    "method": {"type": "string", "enum": ["hbt", "clfrt"]},
                    "t_start": num, "t_end": num,
                    "outcome": {"type": "string", "enum": ["completed", "aborted"]},
                    "reason": nullable_str,
                    "features": {"type": "object"},
                    "estimate": {"type": ["object", "null"], "properties": {
                        "speed_mps": num, "displacement_t": num}},
                    "calibrated_estimate": {"type": ["object", "null"], "properties": {
                        "speed_mps": num,
                        "speed_interval_mps": {"type": "array", "items": num},
                        "displacement_t": num,
                        "displacement_interval_t": {"type": "array", "items": num},
                        "reference": {"type": "string", "enum": ["commissioned", "predicted"]}}},
                    "residuals": {"type": "object"},
                    "decision": {"type": "string", "enum": ["nominal", "fault", "inconclusive"]},
                    "isolation": {"type": "array", "items": {"type": "string"}},
                    "message": {"type": "string"}}}),
            ),
            Kind::Notification => (
                "helmwatch.Notification",
                json!({"type": "object", "properties": {
                    "state": {"type": "string", "enum": ["normal", "alert", "warn", "alarm"]},
                    "method": {"type": "array", "items": {"type": "string"}},
                    "message": {"type": "string"}}}),
            ),
            Kind::Rejected => (
                "helmwatch.Rejected",
                json!({"type": "object", "properties": {
                    "stream": {"type": "string"},
                    "reason": {"type": "string"},
                    "len": {"type": "integer", "description": "the payload's length [bytes]"},
                    "head": {"type": "string", "description": "its first bytes (lossy UTF-8)"},
                    "suppressed": {"type": "integer", "description": "rejected samples of the stream left out before this one"}}}),
            ),
            Kind::Analysis => (
                "helmwatch.AnalysisPoint",
                json!({"type": "object", "properties": {
                    "test": {"type": "string"},
                    "method": {"type": "string", "enum": ["hbt", "clfrt"]},
                    "t": t,
                    "heading": {"type": "number", "description": "continuous heading, resampled [rad]"},
                    "rudder": {"type": "number", "description": "rudder, resampled [rad]"},
                    "excitation": {"type": "number", "description": "CLFRT: the multisine reference; HBT: the relay command [rad]"}}}),
            ),
        }
    }
}

/// Nanoseconds of ship time `t` [s] for `log_time` (negative or not finite: 0).
pub fn ship_ns(t: f64) -> u64 {
    if t.is_finite() && t > 0.0 {
        // `as` saturates at u64::MAX.
        (t * 1e9).round() as u64
    } else {
        0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ship_time_in_nanoseconds_clamps_negatives() {
        assert_eq!(ship_ns(-5.0), 0);
        assert_eq!(ship_ns(f64::NAN), 0);
        assert_eq!(ship_ns(1.5), 1_500_000_000);
        assert_eq!(ship_ns(1.7e9), 1_700_000_000_000_000_000);
    }
}
