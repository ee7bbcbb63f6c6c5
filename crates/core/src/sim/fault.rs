//! Faults injected into the simulated ship, each with an onset time.
//!
//! Syntax on the command line and in scenarios: `KIND:VALUE@ONSET_S`, e.g.
//! `displacement_pct:+10@300` (displacement +10 % from t = 300 s). A fault is active at ship
//! times `t >= onset_s` (with a 1e-9 s guard against rounding of the tick times) and inactive
//! before.
//!
//! | kind | effect from the onset | allowed value |
//! |---|---|---|
//! | `displacement_pct` | true displacement D -> D (1 + v/100), so b -> b / (1 + v/100) | [-50, 100] |
//! | `speed_log_bias_mps` | v [m/s] added to the speed log reading | [-5, 5] |
//! | `speed_log_scale` | speed log reading multiplied by v | (0.5, 1.5] |
//! | `servo_rate_deg_s` | servo rate limit becomes v [deg/s] | (0, 20] |
//! | `rudder_effectiveness` | rudder effectiveness e = v (1 nominal; 0.7 is -30 %) | (0, 1.5] |
//! | `heading_drift_deg_per_min` | ramp v (t - onset) / 60 [deg] added to the heading measurement | [-10, 10] |
//!
//! The onset must be finite and >= 0. Several faults combine in list order: displacement
//! factors and scale factors multiply, biases and drift ramps add, and for the servo rate and
//! the rudder effectiveness the last active fault in the list wins.

use std::fmt;
use std::str::FromStr;

/// Guard on onset comparisons [s]: tick times are computed as `start + k / rate`, which can
/// differ from the decimal onset by an ulp.
const ONSET_GUARD_S: f64 = 1e-9;

/// What a fault changes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum FaultKind {
    /// Displacement step in percent of the scenario displacement (cargo, ballast, flooding).
    DisplacementPct,
    /// Additive speed-log bias [m/s].
    SpeedLogBiasMps,
    /// Multiplicative speed-log scale error (1 nominal).
    SpeedLogScale,
    /// New servo rate limit [deg/s] (steering actuator degradation).
    ServoRateDegS,
    /// Rudder effectiveness e (1 nominal), multiplies the rudder's yaw moment.
    RudderEffectiveness,
    /// Heading sensor drift [deg/min], a ramp from the onset.
    HeadingDriftDegPerMin,
    /// The sensors' clock steps by VALUE [s] at the onset and stays stepped (a GNSS time fix,
    /// a reboot to the epoch): every published `t` carries it, and so does the autopilot's
    /// idea of now (it checks the excitation's validity against the clock it publishes).
    ClockStepS,
    /// The samples of the one tick at the onset carry a `t` off by VALUE [s] (a wild
    /// timestamp); the ticks after are right again.
    ClockOutlierS,
}

impl FaultKind {
    /// Every kind, in the order of the documentation.
    pub const ALL: [FaultKind; 8] = [
        FaultKind::DisplacementPct,
        FaultKind::SpeedLogBiasMps,
        FaultKind::SpeedLogScale,
        FaultKind::ServoRateDegS,
        FaultKind::RudderEffectiveness,
        FaultKind::HeadingDriftDegPerMin,
        FaultKind::ClockStepS,
        FaultKind::ClockOutlierS,
    ];

    /// The name used in the `KIND:VALUE@ONSET_S` syntax.
    pub fn name(self) -> &'static str {
        match self {
            FaultKind::DisplacementPct => "displacement_pct",
            FaultKind::SpeedLogBiasMps => "speed_log_bias_mps",
            FaultKind::SpeedLogScale => "speed_log_scale",
            FaultKind::ServoRateDegS => "servo_rate_deg_s",
            FaultKind::RudderEffectiveness => "rudder_effectiveness",
            FaultKind::HeadingDriftDegPerMin => "heading_drift_deg_per_min",
            FaultKind::ClockStepS => "clock_step_s",
            FaultKind::ClockOutlierS => "clock_outlier_s",
        }
    }

    /// Allowed values as `(low, high, low_is_open)`; the high end is always closed.
    pub fn range(self) -> (f64, f64, bool) {
        match self {
            FaultKind::DisplacementPct => (-50.0, 100.0, false),
            FaultKind::SpeedLogBiasMps => (-5.0, 5.0, false),
            FaultKind::SpeedLogScale => (0.5, 1.5, true),
            FaultKind::ServoRateDegS => (0.0, 20.0, true),
            FaultKind::RudderEffectiveness => (0.0, 1.5, true),
            FaultKind::HeadingDriftDegPerMin => (-10.0, 10.0, false),
            FaultKind::ClockStepS | FaultKind::ClockOutlierS => (-1.0e10, 1.0e10, false),
        }
    }

    /// The allowed range as text, e.g. `(0, 20]`.
    pub fn allowed(self) -> String {
        let (lo, hi, open) = self.range();
        format!("{}{lo}, {hi}]", if open { "(" } else { "[" })
    }

    fn admits(self, v: f64) -> bool {
        let (lo, hi, open) = self.range();
        v.is_finite() && v <= hi && if open { v > lo } else { v >= lo }
    }
}

impl fmt::Display for FaultKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

fn kind_names() -> String {
    FaultKind::ALL.map(FaultKind::name).join(", ")
}

impl FromStr for FaultKind {
    type Err = FaultParseError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        FaultKind::ALL
            .into_iter()
            .find(|k| k.name() == s)
            .ok_or_else(|| FaultParseError::UnknownKind {
                kind: s.to_string(),
                allowed: kind_names(),
            })
    }
}

/// Why a fault specification was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FaultParseError {
    /// Not of the form `KIND:VALUE@ONSET_S`.
    #[error("fault `{text}`: expected KIND:VALUE@ONSET_S, e.g. displacement_pct:+10@300")]
    Syntax {
        /// The text given.
        text: String,
    },
    /// The kind is not one of [`FaultKind::ALL`].
    #[error("unknown fault kind `{kind}`: allowed {allowed}")]
    UnknownKind {
        /// The kind given.
        kind: String,
        /// The allowed kinds.
        allowed: String,
    },
    /// The value or the onset is not a number.
    #[error("fault `{text}`: {what} `{number}` is not a number")]
    Number {
        /// The whole fault text.
        text: String,
        /// `value` or `onset`.
        what: &'static str,
        /// The offending text.
        number: String,
    },
    /// The value is outside the kind's range.
    #[error("fault {kind}: value {value} outside the allowed range {allowed}")]
    Value {
        /// The fault kind.
        kind: FaultKind,
        /// The offending value.
        value: f64,
        /// The allowed range.
        allowed: String,
    },
    /// The onset is negative or not finite.
    #[error("fault {kind}: onset {onset_s} s must be finite and >= 0")]
    Onset {
        /// The fault kind.
        kind: FaultKind,
        /// The offending onset [s].
        onset_s: f64,
    },
}

/// One fault: what, how much, from when.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Fault {
    /// What the fault changes.
    pub kind: FaultKind,
    /// Its size, in the unit of the kind (see the module table).
    pub value: f64,
    /// Ship time from which it is active [s].
    pub onset_s: f64,
}

impl Fault {
    /// A fault with its value and onset checked against the kind's range.
    pub fn new(kind: FaultKind, value: f64, onset_s: f64) -> Result<Self, FaultParseError> {
        if !kind.admits(value) {
            return Err(FaultParseError::Value {
                kind,
                value,
                allowed: kind.allowed(),
            });
        }
        if !(onset_s.is_finite() && onset_s >= 0.0) {
            return Err(FaultParseError::Onset { kind, onset_s });
        }
        Ok(Self {
            kind,
            value,
            onset_s,
        })
    }

    /// Checks a fault built field by field (the fields are public).
    pub fn check(&self) -> Result<(), FaultParseError> {
        Fault::new(self.kind, self.value, self.onset_s).map(|_| ())
    }

    /// Whether the fault is active at ship time `t_s`.
    pub fn active_at(&self, t_s: f64) -> bool {
        t_s >= self.onset_s - ONSET_GUARD_S
    }
}

impl fmt::Display for Fault {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}:{}@{}", self.kind, self.value, self.onset_s)
    }
}

impl FromStr for Fault {
    type Err = FaultParseError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let syntax = || FaultParseError::Syntax {
            text: s.to_string(),
        };
        let (kind, rest) = s.trim().split_once(':').ok_or_else(syntax)?;
        let (value, onset) = rest.split_once('@').ok_or_else(syntax)?;
        let kind: FaultKind = kind.trim().parse()?;
        let number = |what: &'static str, x: &str| {
            x.trim()
                .parse::<f64>()
                .map_err(|_| FaultParseError::Number {
                    text: s.to_string(),
                    what,
                    number: x.to_string(),
                })
        };
        Fault::new(kind, number("value", value)?, number("onset", onset)?)
    }
}

/// The combined effect of the active faults at one instant.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Effects {
    /// Factor on the scenario displacement.
    pub displacement_factor: f64,
    /// Added to the speed log [m/s].
    pub speed_log_bias_mps: f64,
    /// Multiplies the speed log.
    pub speed_log_scale: f64,
    /// Replacement servo rate limit [rad/s], if any.
    pub servo_rate_rad_s: Option<f64>,
    /// Rudder effectiveness (1 nominal).
    pub rudder_effectiveness: f64,
    /// Added to the heading measurement [rad].
    pub heading_drift_rad: f64,
    /// Added to every published `t` (a stepped sensor clock) [s].
    pub clock_offset_s: f64,
}

impl Effects {
    /// No fault.
    pub const NONE: Effects = Effects {
        displacement_factor: 1.0,
        speed_log_bias_mps: 0.0,
        speed_log_scale: 1.0,
        servo_rate_rad_s: None,
        rudder_effectiveness: 1.0,
        heading_drift_rad: 0.0,
        clock_offset_s: 0.0,
    };

    /// The effect of `faults` at ship time `t_s`.
    pub fn at(faults: &[Fault], t_s: f64) -> Effects {
        let mut fx = Effects::NONE;
        for f in faults.iter().filter(|f| f.active_at(t_s)) {
            let v = f.value;
            match f.kind {
                FaultKind::DisplacementPct => fx.displacement_factor *= 1.0 + v / 100.0,
                FaultKind::SpeedLogBiasMps => fx.speed_log_bias_mps += v,
                FaultKind::SpeedLogScale => fx.speed_log_scale *= v,
                FaultKind::ServoRateDegS => fx.servo_rate_rad_s = Some(crate::angle::deg(v)),
                FaultKind::RudderEffectiveness => fx.rudder_effectiveness = v,
                FaultKind::HeadingDriftDegPerMin => {
                    let minutes = (t_s - f.onset_s).max(0.0) / 60.0;
                    fx.heading_drift_rad += crate::angle::deg(v * minutes);
                }
                FaultKind::ClockStepS => fx.clock_offset_s += v,
                // One tick only: applied by the ship when it publishes that tick.
                FaultKind::ClockOutlierS => {}
            }
        }
        fx
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn parses_every_kind_of_the_brief() {
        let cases = [
            (
                "displacement_pct:+10@300",
                FaultKind::DisplacementPct,
                10.0,
                300.0,
            ),
            (
                "heading_drift_deg_per_min:1@0",
                FaultKind::HeadingDriftDegPerMin,
                1.0,
                0.0,
            ),
            (
                "speed_log_scale:1.05@600",
                FaultKind::SpeedLogScale,
                1.05,
                600.0,
            ),
            ("servo_rate_deg_s:2@0", FaultKind::ServoRateDegS, 2.0, 0.0),
            (
                "rudder_effectiveness:0.7@0",
                FaultKind::RudderEffectiveness,
                0.7,
                0.0,
            ),
            (
                "speed_log_bias_mps:-0.5@12.5",
                FaultKind::SpeedLogBiasMps,
                -0.5,
                12.5,
            ),
        ];
        for (text, kind, value, onset_s) in cases {
            let f: Fault = text.parse().unwrap();
            assert_eq!(
                f,
                Fault {
                    kind,
                    value,
                    onset_s
                },
                "{text}"
            );
        }
    }

    #[test]
    fn display_round_trips() {
        for text in [
            "displacement_pct:-12.5@300",
            "speed_log_scale:1.05@600.1",
            "heading_drift_deg_per_min:0.3333333333333333@0",
        ] {
            let f: Fault = text.parse().unwrap();
            assert_eq!(f.to_string(), text);
            assert_eq!(f.to_string().parse::<Fault>().unwrap(), f);
        }
        let f: Fault = "displacement_pct:+10@300".parse().unwrap();
        assert_eq!(f.to_string(), "displacement_pct:10@300");
    }

    #[test]
    fn refuses_bad_syntax_kind_number_range_onset() {
        let err = |s: &str| s.parse::<Fault>().unwrap_err();
        assert!(matches!(
            err("displacement_pct+10@300"),
            FaultParseError::Syntax { .. }
        ));
        assert!(matches!(
            err("displacement_pct:10"),
            FaultParseError::Syntax { .. }
        ));
        let e = err("ballast:10@0");
        assert!(matches!(e, FaultParseError::UnknownKind { .. }));
        let msg = e.to_string();
        for k in FaultKind::ALL {
            assert!(msg.contains(k.name()), "{msg}");
        }
        assert!(matches!(
            err("speed_log_scale:x@0"),
            FaultParseError::Number { what: "value", .. }
        ));
        assert!(matches!(
            err("speed_log_scale:1@soon"),
            FaultParseError::Number { what: "onset", .. }
        ));
        let out_of_range = [
            "displacement_pct:-50.1@0",
            "displacement_pct:100.1@0",
            "rudder_effectiveness:0@0",
            "rudder_effectiveness:1.51@0",
            "servo_rate_deg_s:0@0",
            "servo_rate_deg_s:20.5@0",
            "speed_log_scale:0.5@0",
            "speed_log_scale:1.6@0",
            "speed_log_bias_mps:5.1@0",
            "heading_drift_deg_per_min:-10.5@0",
            "displacement_pct:NaN@0",
            "displacement_pct:inf@0",
        ];
        for s in out_of_range {
            let e = err(s);
            assert!(matches!(e, FaultParseError::Value { .. }), "{s}: {e}");
            assert!(e.to_string().contains("allowed"), "{e}");
        }
        // Closed ends are admitted.
        for s in [
            "displacement_pct:-50@0",
            "displacement_pct:100@0",
            "rudder_effectiveness:1.5@0",
        ] {
            assert!(s.parse::<Fault>().is_ok(), "{s}");
        }
        assert!(matches!(
            err("servo_rate_deg_s:2@-1"),
            FaultParseError::Onset { .. }
        ));
        assert!(matches!(
            err("servo_rate_deg_s:2@inf"),
            FaultParseError::Onset { .. }
        ));
    }

    #[test]
    fn effects_start_at_onset_and_combine() {
        let faults: Vec<Fault> = [
            "displacement_pct:10@100",
            "heading_drift_deg_per_min:2@100",
            "displacement_pct:10@200",
        ]
        .iter()
        .map(|s| s.parse().unwrap())
        .collect();
        assert_eq!(Effects::at(&faults, 99.9), Effects::NONE);
        let fx = Effects::at(&faults, 100.0);
        assert!((fx.displacement_factor - 1.1).abs() < 1e-15);
        assert_eq!(fx.heading_drift_rad, 0.0);
        let fx = Effects::at(&faults, 250.0);
        assert!((fx.displacement_factor - 1.21).abs() < 1e-12);
        // 2 deg/min over 150 s = 5 deg.
        assert!((fx.heading_drift_rad - 5f64.to_radians()).abs() < 1e-12);
    }
}
