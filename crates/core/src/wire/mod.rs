//! The wire contract: Zenoh keys and JSON payloads, parsed and built without any I/O.
//!
//! Keys live under `vessels/<vessel>/` and follow Signal K paths with `/` for `.`. Units are
//! SI: angles in radians (heading in [0, 2 pi) clockwise from north, rudder positive to
//! starboard), speed in m/s, time `t` in seconds on the ship's clock (f64).
//!
//! | key (after `vessels/<v>/`) | direction | payload |
//! |---|---|---|
//! | `navigation/headingTrue` | ship -> daemon | [`Scalar`] |
//! | `steering/rudderAngle` | ship -> daemon | [`Scalar`] |
//! | `navigation/speedThroughWater` | ship -> daemon | [`Scalar`] |
//! | `steering/autopilot/state` | ship -> daemon | [`StateValue`] |
//! | `steering/autopilot/target/headingTrue` | ship -> daemon | [`Scalar`] |
//! | `steering/autopilot/excitation` | daemon -> autopilot | [`Excitation`] |
//! | `fdi/status` | daemon -> world | [`Status`] |
//! | `fdi/report` | daemon -> world | [`Report`] |
//! | `notifications/steering/fdi` | daemon -> world | [`Notification`] |
//! | `fdi/trigger` (queryable, `method=hbt\|clfrt`) | world -> daemon | reply [`TriggerReply`] |
//! | `fdi/alive` (liveliness token) | the daemon that drives the vessel | - |
//! | `fdi/candidate/<id>`, `fdi/holder/<id>` (liveliness tokens) | every daemon of the vessel; its driver | - (`core::ownership`) |
//! | `fdi/ownership` | each daemon of the vessel, on a change of role | JSON (`shells::daemon`) |
//! | `fdi/state` (and queryable) | the driver, on every change | the vessel's state (`shells::daemon`) |
//!
//! A recording (the output of `helmwatch simulate`, the input of `helmwatch replay`) is JSON
//! lines, one [`RecordLine`] `{"key": .., "payload": {..}}` per publication.

use serde::{Deserialize, Serialize};

pub mod features;
pub mod residuals;
pub mod vessel_key;

pub use features::Features;

mod input;
mod report;
pub use input::{decode, decode_value, DecodeError, Input, Scalar, StateValue};
pub use report::{CalibratedEstimate, Cause, Decision, Estimate, Outcome, Report};

/// Key expressions of one vessel.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Keys {
    /// `vessels/<vessel>`.
    pub prefix: String,
}

/// The streams the daemon subscribes to.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Stream {
    /// `navigation/headingTrue` [rad].
    Heading,
    /// `steering/rudderAngle` [rad].
    Rudder,
    /// `navigation/speedThroughWater` [m/s].
    Speed,
    /// `steering/autopilot/state` (string).
    AutopilotState,
    /// `steering/autopilot/target/headingTrue` [rad].
    TargetHeading,
    /// `design/displacement` [kg, Signal K]: the parity test's nominal displacement when the
    /// ship publishes it (optional; the configuration's value otherwise).
    DesignDisplacement,
}

impl Stream {
    /// Every input stream, in the order a lockstep ship publishes them (heading last).
    pub const ALL: [Stream; 6] = [
        Stream::Rudder,
        Stream::Speed,
        Stream::AutopilotState,
        Stream::TargetHeading,
        Stream::DesignDisplacement,
        Stream::Heading,
    ];
    /// Every input stream in [`Stream::index`] order.
    pub const BY_INDEX: [Stream; 6] = [
        Stream::Heading,
        Stream::Rudder,
        Stream::Speed,
        Stream::AutopilotState,
        Stream::TargetHeading,
        Stream::DesignDisplacement,
    ];
    /// The streams a test needs (fresh before it starts, watched for silence while it runs);
    /// `design/displacement` is optional and rare.
    pub const REQUIRED: [Stream; 5] = [
        Stream::Heading,
        Stream::Rudder,
        Stream::Speed,
        Stream::AutopilotState,
        Stream::TargetHeading,
    ];
    /// Path below the vessel prefix.
    pub fn path(self) -> &'static str {
        match self {
            Stream::Heading => "navigation/headingTrue",
            Stream::Rudder => "steering/rudderAngle",
            Stream::Speed => "navigation/speedThroughWater",
            Stream::AutopilotState => "steering/autopilot/state",
            Stream::TargetHeading => "steering/autopilot/target/headingTrue",
            Stream::DesignDisplacement => "design/displacement",
        }
    }
    /// Short name for logs and counters.
    pub fn name(self) -> &'static str {
        match self {
            Stream::Heading => "heading",
            Stream::Rudder => "rudder",
            Stream::Speed => "speed",
            Stream::AutopilotState => "autopilot_state",
            Stream::TargetHeading => "target_heading",
            Stream::DesignDisplacement => "design_displacement",
        }
    }
    /// Index 0..6, for per-stream arrays.
    pub fn index(self) -> usize {
        match self {
            Stream::Heading => 0,
            Stream::Rudder => 1,
            Stream::Speed => 2,
            Stream::AutopilotState => 3,
            Stream::TargetHeading => 4,
            Stream::DesignDisplacement => 5,
        }
    }
}

impl Keys {
    /// Keys of vessel `vessel` (already checked by the configuration).
    pub fn new(vessel: &str) -> Self {
        Self {
            prefix: format!("vessels/{vessel}"),
        }
    }
    /// Key of an input stream.
    pub fn stream(&self, s: Stream) -> String {
        format!("{}/{}", self.prefix, s.path())
    }
    /// Which input stream a key names, if any.
    pub fn stream_of(&self, key: &str) -> Option<Stream> {
        let rest = key.strip_prefix(&self.prefix)?.strip_prefix('/')?;
        Stream::ALL.into_iter().find(|s| s.path() == rest)
    }
    /// `steering/autopilot/excitation`.
    pub fn excitation(&self) -> String {
        format!("{}/steering/autopilot/excitation", self.prefix)
    }
    /// `fdi/status`.
    pub fn status(&self) -> String {
        format!("{}/fdi/status", self.prefix)
    }
    /// `fdi/report`.
    pub fn report(&self) -> String {
        format!("{}/fdi/report", self.prefix)
    }
    /// `notifications/steering/fdi`.
    pub fn notification(&self) -> String {
        format!("{}/notifications/steering/fdi", self.prefix)
    }
    /// `fdi/trigger` (queryable).
    pub fn trigger(&self) -> String {
        format!("{}/fdi/trigger", self.prefix)
    }
    /// `fdi/commission` (queryable: the commissioning's progress; `start` begins it again).
    pub fn commission(&self) -> String {
        format!("{}/fdi/commission", self.prefix)
    }
    /// `fdi/history` (queryable: the report history).
    pub fn history(&self) -> String {
        format!("{}/fdi/history", self.prefix)
    }
    /// `fdi/alive` (liveliness token).
    pub fn alive(&self) -> String {
        format!("{}/fdi/alive", self.prefix)
    }
    /// `fdi/candidate/<daemon>` (liveliness token of every daemon configured for the vessel).
    pub fn candidate(&self, daemon: &str) -> String {
        format!("{}/fdi/candidate/{daemon}", self.prefix)
    }
    /// `fdi/holder/<daemon>` (liveliness token of the daemon that drives the vessel).
    pub fn holder(&self, daemon: &str) -> String {
        format!("{}/fdi/holder/{daemon}", self.prefix)
    }
    /// `fdi/yielded/<daemon>` (liveliness token of a daemon standing by after it yielded to
    /// another holder: it drove the vessel until then).
    pub fn yielded(&self, daemon: &str) -> String {
        format!("{}/fdi/yielded/{daemon}", self.prefix)
    }
    /// `fdi/ownership`: each daemon's role, published on every change.
    pub fn ownership(&self) -> String {
        format!("{}/fdi/ownership", self.prefix)
    }
    /// `fdi/state`: the vessel's state, published by its driver on every change (and a
    /// queryable answering the last one).
    pub fn state(&self) -> String {
        format!("{}/fdi/state", self.prefix)
    }
}

/// Excitation mode.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum ExcitationMode {
    /// The autopilot's own command alone.
    None,
    /// The autopilot adds `value` to its command (CLFRT).
    Add,
    /// The autopilot uses `value` as its command (HBT relay).
    Replace,
}

/// `steering/autopilot/excitation`: one per accepted heading sample, valid `t .. t + hold_s`.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct Excitation {
    /// Ship time of the heading sample this answers [s].
    pub t: f64,
    /// How the autopilot uses `value`.
    pub mode: ExcitationMode,
    /// Rudder angle [rad] (0 when `mode` is `none`).
    pub value: f64,
    /// Validity after `t` [s].
    pub hold_s: f64,
    /// Test id, or null when idle.
    pub test: Option<String>,
}

impl Excitation {
    /// The idle heartbeat at `t`.
    pub fn none(t: f64, hold_s: f64) -> Self {
        Self {
            t,
            mode: ExcitationMode::None,
            value: 0.0,
            hold_s,
            test: None,
        }
    }
    /// Whether this message is valid at ship time `now` (`t <= now <= t + hold_s`).
    pub fn valid_at(&self, now: f64) -> bool {
        now >= self.t && now <= self.t + self.hold_s
    }
}

/// Monitor state on `fdi/status`.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum MonitorState {
    /// No test under way.
    Idle,
    /// Test started; letting the loop settle (trim measurement, first window, first cycles).
    Settling,
    /// Measuring.
    Exciting,
    /// Computing features, estimates and the decision.
    Analysing,
}

/// `fdi/status`, published on every change.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct Status {
    /// Ship time [s].
    pub t: f64,
    /// Monitor state.
    pub state: MonitorState,
    /// Test id, or null.
    pub test: Option<String>,
    /// Method, or null.
    pub method: Option<crate::wire::Method>,
    /// Why the state changed (e.g. an abort reason), or null.
    pub reason: Option<String>,
}

/// Signal K notification state.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq, Eq, PartialOrd, Ord)]
#[serde(rename_all = "lowercase")]
pub enum AlarmState {
    /// No alarm.
    Normal,
    /// Something to look at.
    Alert,
    /// Warning.
    Warn,
    /// Alarm.
    Alarm,
}

/// `notifications/steering/fdi`: Signal K notification value.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct Notification {
    /// Alarm state.
    pub state: AlarmState,
    /// Signal K methods, e.g. `["visual", "sound"]`.
    pub method: Vec<String>,
    /// Human-readable message.
    pub message: String,
}

/// Reply of the `fdi/trigger` queryable.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct TriggerReply {
    /// Whether a test was started.
    pub accepted: bool,
    /// Id of the started test.
    pub test: Option<String>,
    /// Why not, when refused.
    pub reason: Option<String>,
}

/// One line of a recording: `{"key": "<zenoh key>", "payload": {...}}`.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct RecordLine {
    /// Zenoh key.
    pub key: String,
    /// JSON payload as published.
    pub payload: serde_json::Value,
}

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
    type Err = crate::config::UnknownName;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "hbt" => Ok(Method::Hbt),
            "clfrt" => Ok(Method::Clfrt),
            other => Err(Self::Err::new("method", other, "hbt, clfrt")),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keys_follow_contract() {
        let k = Keys::new("self");
        assert_eq!(
            k.stream(Stream::Heading),
            "vessels/self/navigation/headingTrue"
        );
        assert_eq!(
            k.stream(Stream::TargetHeading),
            "vessels/self/steering/autopilot/target/headingTrue"
        );
        assert_eq!(k.excitation(), "vessels/self/steering/autopilot/excitation");
        assert_eq!(k.notification(), "vessels/self/notifications/steering/fdi");
        assert_eq!(
            k.stream_of("vessels/self/steering/rudderAngle"),
            Some(Stream::Rudder)
        );
        assert_eq!(k.stream_of("vessels/other/steering/rudderAngle"), None);
    }

    #[test]
    fn by_index_matches_index() {
        for (i, s) in Stream::BY_INDEX.into_iter().enumerate() {
            assert_eq!(s.index(), i);
        }
        let mut all = Stream::ALL;
        all.sort();
        assert_eq!(all, Stream::BY_INDEX);
    }

    #[test]
    fn excitation_serialises_as_contract() {
        let e = Excitation::none(12.5, 1.0);
        let v = serde_json::to_value(&e).unwrap();
        assert_eq!(
            v,
            serde_json::json!({"t": 12.5, "mode": "none", "value": 0.0, "hold_s": 1.0, "test": null})
        );
        assert!(e.valid_at(13.5) && !e.valid_at(13.6) && !e.valid_at(12.4));
    }
}
