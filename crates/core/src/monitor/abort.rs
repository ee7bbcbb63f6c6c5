//! Why a test was aborted, typed: the report's `reason` and the status's `aborted: <reason>`
//! are its text ([`std::fmt::Display`]), `fdi/stats` counts aborts by its [`AbortReason::code`].

use crate::monitor::record::RecordError;
use crate::wire::Stream;
use std::fmt;

/// Why a test stopped before its analysis completed.
#[derive(Debug, Clone, PartialEq)]
pub enum AbortReason {
    /// The autopilot left `auto` during the test.
    AutopilotLeftAuto,
    /// The heading left the course by more than `safety.max-heading-error-deg`.
    HeadingError {
        /// |heading - course| [deg].
        error_deg: f64,
        /// The limit [deg].
        limit_deg: f64,
    },
    /// The rudder reached `safety.rudder-saturation-deg`.
    RudderSaturated {
        /// The rudder angle [deg].
        rudder_deg: f64,
    },
    /// The autopilot's course (target heading) changed.
    CourseChanged,
    /// A stream fell silent for longer than `safety.stream-timeout-s`.
    StreamSilent {
        /// The stream.
        stream: Stream,
        /// How long [s].
        silent_s: f64,
    },
    /// The speed left the test's starting speed by more than `safety.max-speed-change-mps`.
    SpeedChanged {
        /// Speed at the start [m/s].
        from_mps: f64,
        /// Speed now [m/s].
        to_mps: f64,
    },
    /// The test ran past `safety.max-test-duration-s`.
    TooLong {
        /// The limit [s].
        limit_s: f64,
    },
    /// A test record refused a sample: more samples than the test can have (a flood), or a
    /// gap the analysis cannot bridge.
    Record(RecordError),
    /// HBT: no rudder sample in the trim window, so no relay centre.
    NoTrimRudder,
    /// HBT: two relay switches closer than `hbt.min-switch-interval-s`.
    RelayChatter {
        /// The interval [s].
        interval_s: f64,
        /// The relay's hysteresis [deg].
        hysteresis_deg: f64,
    },
    /// HBT: no limit cycle formed within `hbt.timeout-s`.
    NoLimitCycle {
        /// The time limit [s].
        timeout_s: f64,
        /// Switches to `+h` seen.
        up_switches: usize,
    },
    /// HBT: a cycle smaller than the hysteresis band, which no relay loop can produce.
    ImplausibleLimitCycle {
        /// Its amplitude [deg].
        amplitude_deg: f64,
        /// The hysteresis [deg].
        hysteresis_deg: f64,
    },
    /// The analysis of the records failed (what failed, in words).
    Analysis(String),
    /// HBT: the relay sizing predicts a limit cycle past the heading limit even with the
    /// smallest relay the wave yaw allows (`hbt.resize-*`).
    RelayTooLarge {
        /// The heading error's predicted peak with that relay [deg].
        predicted_deg: f64,
        /// `safety.max-heading-error-deg`.
        limit_deg: f64,
        /// The smallest hysteresis allowed [deg].
        hysteresis_deg: f64,
    },
    /// A stream's clock stepped: it re-synchronised on a new timeline
    /// ([`crate::monitor::input::Clocks`]), so the test's records no longer line up.
    ClockStep {
        /// The stream.
        stream: Stream,
        /// Its last `t` on the old timeline [s].
        from_t: f64,
        /// Its first `t` on the new one [s].
        to_t: f64,
    },
    /// The driver stopped (daemon shutdown), with its words.
    Shutdown(String),
}

impl AbortReason {
    /// Every code, in the order `fdi/stats` lists them.
    pub const CODES: [&'static str; 16] = [
        "autopilot_left_auto",
        "heading_error",
        "rudder_saturated",
        "course_changed",
        "stream_silent",
        "speed_changed",
        "too_long",
        "input_flood",
        "record_gap",
        "no_trim_rudder",
        "relay_chatter",
        "no_limit_cycle",
        "implausible_limit_cycle",
        "analysis",
        "clock_step",
        "relay_too_large",
    ];

    /// A stable snake_case name per kind of reason (the key in `fdi/stats`); `shutdown` is
    /// the last, outside [`AbortReason::CODES`]' index range by one.
    pub fn code(&self) -> &'static str {
        match self {
            AbortReason::Shutdown(_) => "shutdown",
            other => Self::CODES[other.index()],
        }
    }

    /// Index into a counter array of `CODES.len() + 1` entries (the last: shutdown).
    pub fn index(&self) -> usize {
        match self {
            AbortReason::AutopilotLeftAuto => 0,
            AbortReason::HeadingError { .. } => 1,
            AbortReason::RudderSaturated { .. } => 2,
            AbortReason::CourseChanged => 3,
            AbortReason::StreamSilent { .. } => 4,
            AbortReason::SpeedChanged { .. } => 5,
            AbortReason::TooLong { .. } => 6,
            AbortReason::Record(RecordError::Full(_)) => 7,
            AbortReason::Record(RecordError::Gap { .. }) => 8,
            AbortReason::NoTrimRudder => 9,
            AbortReason::RelayChatter { .. } => 10,
            AbortReason::NoLimitCycle { .. } => 11,
            AbortReason::ImplausibleLimitCycle { .. } => 12,
            AbortReason::Analysis(_) => 13,
            AbortReason::ClockStep { .. } => 14,
            AbortReason::RelayTooLarge { .. } => 15,
            AbortReason::Shutdown(_) => 16,
        }
    }
}

impl fmt::Display for AbortReason {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            AbortReason::AutopilotLeftAuto => f.write_str("autopilot left auto"),
            AbortReason::HeadingError {
                error_deg,
                limit_deg,
            } => write!(
                f,
                "heading error {error_deg:.1} deg over the limit {limit_deg:.1} deg"
            ),
            AbortReason::RudderSaturated { rudder_deg } => {
                write!(f, "rudder saturated at {rudder_deg:.1} deg")
            }
            AbortReason::CourseChanged => f.write_str("autopilot course changed"),
            AbortReason::StreamSilent { stream, silent_s } => {
                write!(f, "{} stream silent for {silent_s:.1} s", stream.name())
            }
            AbortReason::SpeedChanged { from_mps, to_mps } => {
                write!(f, "speed changed from {from_mps:.2} to {to_mps:.2} m/s")
            }
            AbortReason::TooLong { limit_s } => write!(f, "test longer than {limit_s:.0} s"),
            AbortReason::Record(e) => write!(f, "{e}"),
            AbortReason::NoTrimRudder => f.write_str("no rudder samples during the trim window"),
            AbortReason::RelayChatter {
                interval_s,
                hysteresis_deg,
            } => write!(
                f,
                "relay chatter: switches {interval_s:.1} s apart (heading noise above the \
                 {hysteresis_deg:.2} deg hysteresis?)"
            ),
            AbortReason::NoLimitCycle {
                timeout_s,
                up_switches,
            } => write!(
                f,
                "no limit cycle within {timeout_s:.0} s ({up_switches} switches to +h)"
            ),
            AbortReason::ImplausibleLimitCycle {
                amplitude_deg,
                hysteresis_deg,
            } => write!(
                f,
                "implausible limit cycle: amplitude {amplitude_deg:.2} deg within the \
                 {hysteresis_deg:.2} deg hysteresis"
            ),
            AbortReason::Analysis(what) => write!(f, "analysis: {what}"),
            AbortReason::ClockStep {
                stream,
                from_t,
                to_t,
            } => write!(
                f,
                "clock step: the {} stream went from t = {from_t:.1} to {to_t:.1} s",
                stream.name()
            ),
            AbortReason::RelayTooLarge {
                predicted_deg,
                limit_deg,
                hysteresis_deg,
            } => write!(
                f,
                "relay too large for this ship: the limit cycle is predicted to reach \
                 {predicted_deg:.1} deg of heading error, over the limit {limit_deg:.1} deg, \
                 even scaled down to the smallest hysteresis the wave yaw allows \
                 ({hysteresis_deg:.2} deg)"
            ),
            AbortReason::Shutdown(why) => f.write_str(why),
        }
    }
}

/// Aborted tests counted by reason, in O(1) memory.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct AbortCounts([u64; AbortReason::CODES.len() + 1]);

impl AbortCounts {
    /// Counts one abort.
    pub fn add(&mut self, reason: &AbortReason) {
        self.0[reason.index()] += 1;
    }

    /// The count of one code (0 for an unknown one).
    pub fn get(&self, code: &str) -> u64 {
        self.iter().find(|(c, _)| *c == code).map_or(0, |(_, n)| n)
    }

    /// `(code, count)` for every code, shutdown last.
    pub fn iter(&self) -> impl Iterator<Item = (&'static str, u64)> + '_ {
        AbortReason::CODES
            .iter()
            .copied()
            .chain(["shutdown"])
            .zip(self.0.iter().copied())
    }

    /// The `fdi/stats` object `{code: count}`, every code present.
    pub fn to_json(&self) -> serde_json::Value {
        serde_json::Value::Object(
            self.iter()
                .map(|(c, n)| (c.to_string(), n.into()))
                .collect(),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The texts are the ones reports carried before the type existed (the golden files hold
    /// some of them), and every kind has its own code.
    #[test]
    fn texts_and_codes() {
        let cases = [
            (AbortReason::AutopilotLeftAuto, "autopilot left auto"),
            (
                AbortReason::HeadingError {
                    error_deg: 10.26,
                    limit_deg: 10.0,
                },
                "heading error 10.3 deg over the limit 10.0 deg",
            ),
            (
                AbortReason::RudderSaturated { rudder_deg: 25.04 },
                "rudder saturated at 25.0 deg",
            ),
            (
                AbortReason::StreamSilent {
                    stream: Stream::Heading,
                    silent_s: 2.54,
                },
                "heading stream silent for 2.5 s",
            ),
            (
                AbortReason::TooLong { limit_s: 1800.0 },
                "test longer than 1800 s",
            ),
            (
                AbortReason::Record(RecordError::Full(12000)),
                "more than 12000 samples in one test (input flood)",
            ),
            (
                AbortReason::Analysis("heading: too short".into()),
                "analysis: heading: too short",
            ),
            (
                AbortReason::Shutdown("daemon stopping".into()),
                "daemon stopping",
            ),
        ];
        for (r, text) in cases {
            assert_eq!(r.to_string(), text);
        }
        let mut counts = AbortCounts::default();
        counts.add(&AbortReason::TooLong { limit_s: 1.0 });
        counts.add(&AbortReason::TooLong { limit_s: 2.0 });
        counts.add(&AbortReason::Record(RecordError::Gap { t: 1.0 }));
        counts.add(&AbortReason::Shutdown("x".into()));
        assert_eq!(counts.get("too_long"), 2);
        assert_eq!(counts.get("record_gap"), 1);
        assert_eq!(counts.get("input_flood"), 0);
        assert_eq!(counts.get("shutdown"), 1);
        let v = counts.to_json();
        assert_eq!(v.as_object().unwrap().len(), AbortReason::CODES.len() + 1);
        assert_eq!(v["too_long"], 2);
        assert_eq!(
            AbortReason::Record(RecordError::Gap { t: 0.0 }).code(),
            "record_gap"
        );
    }
}
