//! The suite's scenarios: the classic, the family's, the envelope's and the commissioning's,
//! each with its fault, its ranges of (u, D), its change of operating point and its onset
//! (their draw for one run is `draw`'s).

use helmwatch_core::wire::Cause;

/// Which part of the suite a scenario belongs to (`--scenarios`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ScenarioSet {
    /// Faults present from commissioning's end, the ship at one operating point.
    #[default]
    Classic,
    /// The operating point changes after commissioning (speed, declared loading).
    Envelope,
    /// Faults that arise during commissioning.
    Commissioning,
    /// All three.
    All,
}

impl ScenarioSet {
    /// Whether this selection includes `group`.
    pub fn includes(self, group: ScenarioSet) -> bool {
        self == ScenarioSet::All || self == group
    }

    /// The name on the command line.
    pub fn name(self) -> &'static str {
        match self {
            ScenarioSet::Classic => "classic",
            ScenarioSet::Envelope => "envelope",
            ScenarioSet::Commissioning => "commissioning",
            ScenarioSet::All => "all",
        }
    }
}

impl std::str::FromStr for ScenarioSet {
    type Err = helmwatch_core::config::UnknownName;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "classic" => Ok(ScenarioSet::Classic),
            "envelope" => Ok(ScenarioSet::Envelope),
            "commissioning" => Ok(ScenarioSet::Commissioning),
            "all" => Ok(ScenarioSet::All),
            other => Err(Self::Err::new(
                "scenario set",
                other,
                "classic, envelope, commissioning, all",
            )),
        }
    }
}

/// A change of operating point at the end of commissioning (not a fault).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Change {
    /// Magnitudes of the speed change to draw from [m/s] (empty: the speed stays); the sign
    /// is drawn among those that keep the speed in the configured range.
    pub speed_mps: &'static [f64],
    /// Range of the loading change, a fraction of the displacement (`set_loading_t`, declared
    /// as `design/displacement`); `None`: the loading stays.
    pub loading: Option<[f64; 2]>,
    /// How the sea changes.
    pub sea: SeaChange,
}

/// How the sea changes at an envelope run's change.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SeaChange {
    /// It stays.
    Stays,
    /// It rises one state (calm to moderate, moderate to rough; a rough sea stays).
    Rises,
    /// It falls one state (rough to moderate, moderate to calm; a calm sea stays): a
    /// reference learned in a rougher sea judges tests in a calmer one.
    Falls,
}

/// When the scenario's fault arises.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Onset {
    /// At the end of commissioning (with the change, when there is one); from `t = 0` when
    /// commissioning is off (classic scenarios).
    AfterCommissioning,
    /// After this many completed tests of the ship after the change.
    AfterChange(usize),
    /// Before commissioning test `k` of the ship (1 is the first), `k` drawn in this range
    /// (at most one past commissioning's last test).
    InCommissioning([usize; 2]),
}

/// A scenario of the suite.
#[derive(Debug, Clone, PartialEq)]
pub struct FdiScenario {
    /// Name in the tables.
    pub name: &'static str,
    /// Fault specification (`KIND:VALUE@0`), `None` for nominal; `drift` draws its own.
    pub fault: Option<&'static str>,
    /// A random heading drift of 0.25..1 deg/min (either sign) on every run.
    pub drift: bool,
    /// The cause the isolation must name (`None`: nominal, nothing to detect).
    pub expected: Option<Cause>,
    /// Range of u [m/s] and D [t] to draw from, stated on the family's box and mapped onto
    /// the configured one (`on_box`; `None`: the configured range).
    pub speed_mps: Option<[f64; 2]>,
    /// As above for D.
    pub displacement_t: Option<[f64; 2]>,
    /// The part of the suite it belongs to (never `All`).
    pub group: ScenarioSet,
    /// The change of operating point after commissioning (`None`: none).
    pub change: Option<Change>,
    /// When the fault arises.
    pub onset: Onset,
    /// Envelope scenarios: detection counts within this many tests of the ship from the onset
    /// (`None`: the classic windows).
    pub window_tests: Option<usize>,
}

/// A classic scenario: no change, the fault after commissioning.
fn classic(
    name: &'static str,
    fault: Option<&'static str>,
    drift: bool,
    expected: Option<Cause>,
    speed_mps: Option<[f64; 2]>,
    displacement_t: Option<[f64; 2]>,
) -> FdiScenario {
    FdiScenario {
        name,
        fault,
        drift,
        expected,
        speed_mps,
        displacement_t,
        group: ScenarioSet::Classic,
        change: None,
        onset: Onset::AfterCommissioning,
        window_tests: None,
    }
}

/// The scenarios of the suite, in print order.
pub fn scenarios() -> Vec<FdiScenario> {
    let s = classic;
    let d_pm20 = Some([5000.0, 8333.0]);
    let disp = Some(Cause::DisplacementOrRudderEffectiveness);
    vec![
        s("nominal", None, false, None, None, None),
        s("nominal, drift <= 1 deg/min", None, true, None, None, None),
        s(
            "displacement +10 %",
            Some("displacement_pct:10@0"),
            false,
            disp,
            None,
            d_pm20,
        ),
        s(
            "displacement -10 %",
            Some("displacement_pct:-10@0"),
            false,
            disp,
            None,
            d_pm20,
        ),
        s(
            "displacement +20 %",
            Some("displacement_pct:20@0"),
            false,
            disp,
            None,
            d_pm20,
        ),
        s(
            "displacement -20 %",
            Some("displacement_pct:-20@0"),
            false,
            disp,
            None,
            d_pm20,
        ),
        s(
            "speed log +0.5 m/s",
            Some("speed_log_bias_mps:0.5@0"),
            false,
            Some(Cause::SpeedLog),
            Some([4.0, 9.5]),
            None,
        ),
        s(
            "servo rate 2 deg/s",
            Some("servo_rate_deg_s:2@0"),
            false,
            Some(Cause::SteeringActuator),
            None,
            None,
        ),
        s(
            "rudder effectiveness -30 %",
            Some("rudder_effectiveness:0.7@0"),
            false,
            disp,
            None,
            Some([4000.0, 7000.0]),
        ),
        // Appended (the rows above keep their place in the seed space): the size the
        // nonlinear hull's acceptance is stated at (issue 25).
        s(
            "displacement +12 %",
            Some("displacement_pct:12@0"),
            false,
            disp,
            None,
            d_pm20,
        ),
        s(
            "displacement -12 %",
            Some("displacement_pct:-12@0"),
            false,
            disp,
            None,
            d_pm20,
        ),
    ]
}

/// The scenarios of the family suite: healthy with drift, then the faults of the acceptance.
pub fn family_scenarios() -> Vec<FdiScenario> {
    let wanted = [
        "nominal, drift <= 1 deg/min",
        "displacement +10 %",
        "displacement -10 %",
        "speed log +0.5 m/s",
        "servo rate 2 deg/s",
        "displacement +12 %",
        "displacement -12 %",
    ];
    scenarios()
        .into_iter()
        .filter(|s| wanted.contains(&s.name))
        .collect()
}

/// Speed changes of the healthy envelope runs [m/s] (either sign).
const ENVELOPE_SPEEDS_MPS: &[f64] = &[0.5, 1.0, 1.5, 2.0];
/// Speed change of the envelope runs with a fault [m/s] (either sign).
const FAULT_SPEED_MPS: &[f64] = &[1.5];
/// Loading changes of the healthy envelope runs (fraction of the displacement).
const LOADING: [f64; 2] = [-0.3, 0.2];

/// The envelope scenarios: a healthy ship whose speed and/or declared loading changes after
/// commissioning, then displacement faults after a speed change (4 tests later, or with it);
/// then the same for a sea that rises a state, then for one that falls. A row's seeds follow
/// its place in the list: new rows go at its end.
pub fn envelope_scenarios() -> Vec<FdiScenario> {
    let mut rows = envelope_healthy();
    rows.extend(envelope_speed_faults());
    // Last: each row's seeds follow its place in this list.
    rows.extend(envelope_sea());
    rows
}

/// An envelope scenario: the change when commissioning ends, the fault (if any) at `onset`.
fn envelope(
    name: &'static str,
    fault: Option<&'static str>,
    expected: Option<Cause>,
    displacement_t: Option<[f64; 2]>,
    change: Change,
    onset: Onset,
    window_tests: Option<usize>,
) -> FdiScenario {
    FdiScenario {
        name,
        fault,
        drift: false,
        expected,
        speed_mps: None,
        displacement_t,
        group: ScenarioSet::Envelope,
        change: Some(change),
        onset,
        window_tests,
    }
}

/// A change of speed only, its magnitude one of `speed_mps`.
fn speed_change(speed_mps: &'static [f64]) -> Change {
    Change {
        speed_mps,
        loading: None,
        sea: SeaChange::Stays,
    }
}

/// The range of D for a displacement fault of +-10 %: D (1 +- 0.1) stays in the family's
/// 4000..10000 t (on another class's box, mapped linearly by `on_box`, within a few per cent
/// of it).
fn d_pm10() -> Option<[f64; 2]> {
    Some([4000.0 / 0.9, 10000.0 / 1.1])
}

/// The healthy envelope: the speed, the declared loading, or both change.
fn envelope_healthy() -> Vec<FdiScenario> {
    let e = envelope;
    let after = Onset::AfterCommissioning;
    // D (1 + x) stays in the family's 4000..10000 t for every x drawn (on another class's
    // box, mapped linearly by `on_box`, within a few per cent of it).
    let loaded = Some([4000.0 / (1.0 + LOADING[0]), 10000.0 / (1.0 + LOADING[1])]);
    vec![
        e(
            "envelope: speed +-0.5..2 m/s",
            None,
            None,
            None,
            speed_change(ENVELOPE_SPEEDS_MPS),
            after,
            None,
        ),
        e(
            "envelope: loading -30..+20 %",
            None,
            None,
            loaded,
            Change {
                speed_mps: &[],
                loading: Some(LOADING),
                sea: SeaChange::Stays,
            },
            after,
            None,
        ),
        e(
            "envelope: speed and loading",
            None,
            None,
            loaded,
            Change {
                speed_mps: ENVELOPE_SPEEDS_MPS,
                loading: Some(LOADING),
                sea: SeaChange::Stays,
            },
            after,
            None,
        ),
    ]
}

/// Displacement faults after a speed change of 1.5 m/s: +-10 % 4 tests later, +-25 % with it.
fn envelope_speed_faults() -> Vec<FdiScenario> {
    let e = envelope;
    let disp = Some(Cause::DisplacementOrRudderEffectiveness);
    let d_pm25 = Some([4000.0 / 0.75, 10000.0 / 1.25]);
    vec![
        e(
            "envelope: speed 1.5 m/s, D +10 % 4 tests later",
            Some("displacement_pct:10@0"),
            disp,
            d_pm10(),
            speed_change(FAULT_SPEED_MPS),
            Onset::AfterChange(4),
            Some(3),
        ),
        e(
            "envelope: speed 1.5 m/s, D -10 % 4 tests later",
            Some("displacement_pct:-10@0"),
            disp,
            d_pm10(),
            speed_change(FAULT_SPEED_MPS),
            Onset::AfterChange(4),
            Some(3),
        ),
        e(
            "envelope: speed 1.5 m/s with D +25 %",
            Some("displacement_pct:25@0"),
            disp,
            d_pm25,
            speed_change(FAULT_SPEED_MPS),
            Onset::AfterCommissioning,
            Some(2),
        ),
        e(
            "envelope: speed 1.5 m/s with D -25 %",
            Some("displacement_pct:-25@0"),
            disp,
            d_pm25,
            speed_change(FAULT_SPEED_MPS),
            Onset::AfterCommissioning,
            Some(2),
        ),
    ]
}

/// The sea rises a state (healthy, then D +-10 % 4 tests later), then falls a state (healthy,
/// then D +10 % 4 tests later).
fn envelope_sea() -> Vec<FdiScenario> {
    let e = envelope;
    let disp = Some(Cause::DisplacementOrRudderEffectiveness);
    let rises = Change {
        speed_mps: &[],
        loading: None,
        sea: SeaChange::Rises,
    };
    let falls = Change {
        sea: SeaChange::Falls,
        ..rises
    };
    let after = Onset::AfterCommissioning;
    vec![
        e(
            "envelope: the sea rises a state",
            None,
            None,
            None,
            rises,
            after,
            None,
        ),
        e(
            "envelope: the sea rises, D +10 % 4 tests later",
            Some("displacement_pct:10@0"),
            disp,
            d_pm10(),
            rises,
            Onset::AfterChange(4),
            Some(3),
        ),
        e(
            "envelope: the sea rises, D -10 % 4 tests later",
            Some("displacement_pct:-10@0"),
            disp,
            d_pm10(),
            rises,
            Onset::AfterChange(4),
            Some(3),
        ),
        e(
            "envelope: the sea falls a state",
            None,
            None,
            None,
            falls,
            after,
            None,
        ),
        e(
            "envelope: the sea falls, D +10 % 4 tests later",
            Some("displacement_pct:10@0"),
            disp,
            d_pm10(),
            falls,
            Onset::AfterChange(4),
            Some(3),
        ),
    ]
}

/// Commissioning's onsets: before commissioning test 2..6 of the ship.
const COMMISSIONING_ONSET: [usize; 2] = [2, 6];

/// The commissioning scenarios: a healthy commissioning, then faults that arise during it.
pub fn commissioning_scenarios() -> Vec<FdiScenario> {
    let c = |name, fault, expected, speed_mps, displacement_t| FdiScenario {
        name,
        fault,
        drift: false,
        expected,
        speed_mps,
        displacement_t,
        group: ScenarioSet::Commissioning,
        change: None,
        onset: Onset::InCommissioning(COMMISSIONING_ONSET),
        window_tests: None,
    };
    // A healthy ship whose operating point changes at test k.
    let healthy_change = |name, speed_mps, sea| FdiScenario {
        change: Some(Change {
            speed_mps,
            loading: None,
            sea,
        }),
        ..c(name, None, None, None, None)
    };
    let disp = Some(Cause::DisplacementOrRudderEffectiveness);
    let d_pm12 = Some([4000.0 / 0.88, 10000.0 / 1.12]);
    vec![
        c("commissioning: healthy", None, None, None, None),
        c(
            "commissioning: D +12 %",
            Some("displacement_pct:12@0"),
            disp,
            None,
            d_pm12,
        ),
        c(
            "commissioning: D -12 %",
            Some("displacement_pct:-12@0"),
            disp,
            None,
            d_pm12,
        ),
        c(
            "commissioning: speed log +0.5 m/s",
            Some("speed_log_bias_mps:0.5@0"),
            Some(Cause::SpeedLog),
            Some([4.0, 9.5]),
            None,
        ),
        c(
            "commissioning: servo rate 2 deg/s",
            Some("servo_rate_deg_s:2@0"),
            Some(Cause::SteeringActuator),
            None,
            None,
        ),
        // A healthy ship whose speed changes during commissioning: no change of health.
        healthy_change(
            "commissioning: healthy, speed +-1..1.5 m/s at test k",
            &[1.0, 1.5],
            SeaChange::Stays,
        ),
        // A healthy ship whose sea changes a state during commissioning (a day and a half
        // of it at sea): no change of health.
        healthy_change(
            "commissioning: healthy, the sea rises a state at test k",
            &[],
            SeaChange::Rises,
        ),
        healthy_change(
            "commissioning: healthy, the sea falls a state at test k",
            &[],
            SeaChange::Falls,
        ),
    ]
}
