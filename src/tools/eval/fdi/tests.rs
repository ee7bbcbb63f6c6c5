//! Unit tests of the suite: scoring, the outcomes file, and one run of each new set.

use super::outcomes::write_outcomes;
use super::*;
use crate::config::Config;
use helmwatch_core::estimator::Estimator;
use helmwatch_core::wire::{Cause, Decision};

fn outcome(decision: Decision, raw0: f64) -> TestOutcome {
    TestOutcome {
        method: Method::Hbt,
        completed: true,
        decision,
        isolation: if decision == Decision::Fault {
            vec![Cause::SpeedLog]
        } else {
            Vec::new()
        },
        baseline_decision: Decision::Inconclusive,
        baseline_isolation: Vec::new(),
        q_param: 1.5,
        sea_index: 0.1,
        fit_chi2: f64::NAN,
        tone_ci90: [f64::NAN; 2],
        meas_sd: [f64::NAN; 3],
        noise_ratio: f64::NAN,
        q_actuator: f64::NAN,
        z: [0.5, -1.0, 0.0],
        raw: [
            raw0, -0.02, 0.06, 0.002, 7.0, 1900.0, 0.0, 0.0, 0.0, 0.0, 0.0,
        ],
        phase: Phase::Test,
        fault_present: false,
        speed_log_mps: 7.0,
        relay_scale: f64::NAN,
        displacement_nominal_t: 6000.0,
        state: None,
        inconsistent: false,
        cause_costs: [f64::NAN; 2],
        sigma: [f64::NAN; 3],
        offset_sigma: [f64::NAN; 3],
        calibrated: [f64::NAN; 4],
        reference_kind: None,
        abort_reason: None,
    }
}

/// A run at 7 m/s and 6000 t, its operating point unchanged, of `tests`.
fn healthy_run(tests: Vec<TestOutcome>) -> RunOutcome {
    RunOutcome {
        speed_mps: 7.0,
        displacement_t: 6000.0,
        speed_after_mps: f64::NAN,
        declared_after_t: f64::NAN,
        commissioning: Vec::new(),
        tests,
        error: None,
    }
}

/// The run's naming at its end: with one method the last test's (nominal: none, even
/// after an earlier test named a cause); with the methods in turn, the latest naming of
/// the last test of each method (a healthy-looking last HBT test leaves CLFRT's in force).
#[test]
fn the_naming_at_the_end_is_the_last_of_each_method() {
    let d = Cause::DisplacementOrRudderEffectiveness;
    let clfrt = |decision, iso: Vec<Cause>| TestOutcome {
        method: Method::Clfrt,
        isolation: iso,
        ..outcome(decision, 0.0)
    };
    let run = healthy_run;
    let one = vec![run(vec![
        outcome(Decision::Fault, 0.0),
        outcome(Decision::Nominal, 0.0),
    ])];
    assert_eq!(score(&one, Some(Cause::SpeedLog), 2, false).isolated, 0);
    let turn = |last_hbt| {
        vec![run(vec![
            outcome(Decision::Fault, 0.0),
            clfrt(Decision::Fault, vec![d]),
            outcome(last_hbt, 0.0),
        ])]
    };
    // The last HBT test nominal: CLFRT's naming stands.
    assert_eq!(
        score(&turn(Decision::Nominal), Some(d), 3, false).isolated,
        1
    );
    // The last HBT test names the speed log: the latest naming is the vessel's.
    assert_eq!(score(&turn(Decision::Fault), Some(d), 3, false).isolated, 0);
    assert_eq!(
        score(&turn(Decision::Fault), Some(Cause::SpeedLog), 3, false).isolated,
        1
    );
    // An earlier CLFRT test does not count once a later CLFRT test names nothing.
    let stale = vec![run(vec![
        clfrt(Decision::Fault, vec![d]),
        clfrt(Decision::Nominal, Vec::new()),
        outcome(Decision::Nominal, 0.0),
    ])];
    assert_eq!(score(&stale, Some(d), 3, false).isolated, 0);
}

/// One JSON line per test, commissioning first, the run's index and phase on each, NaN
/// written as null (JSON has no NaN), the raw residuals as they came.
/// The calibrated estimates' 95th percentiles, over all tests and each method's alone,
/// against the nearest-rank percentile worked by hand: twenty CLFRT tests 0.01..0.20 m/s and
/// 0.1..2.0 % from the log and the declared, ten HBT tests 0.1..1.0 m/s and 1..10 %.
#[test]
fn the_calibrated_fit_splits_by_method() {
    let test = |method, k: f64, du: f64, dd: f64| TestOutcome {
        method,
        calibrated: [7.0 + k * du, 6000.0 * (1.0 + k * dd), 1.0, 1.0],
        ..outcome(Decision::Nominal, 0.0)
    };
    let mut tests: Vec<TestOutcome> = (1..=20)
        .map(|k| test(Method::Clfrt, k as f64, 0.01, 0.001))
        .collect();
    tests.extend((1..=10).map(|k| test(Method::Hbt, k as f64, 0.1, 0.01)));
    let c = score::calibrated_fit(&[healthy_run(tests)]);
    let close = |a: f64, b: f64| (a - b).abs() < 1e-9;
    assert_eq!(c.tests, 30);
    // All 30: the 29th smallest (ceil(0.95 * 30)), HBT's 0.9 m/s and 9 %.
    assert!(
        close(c.speed_p95_mps, 0.9) && close(c.displacement_p95, 0.09),
        "{c:?}"
    );
    // CLFRT's 20: the 19th, 0.19 m/s and 1.9 %; HBT's 10: the 10th, 1.0 m/s and 10 %.
    let [(nc, uc, dc), (nh, uh, dh)] = c.by_method;
    assert_eq!((nc, nh), (20, 10));
    assert!(close(uc, 0.19) && close(dc, 0.019), "{c:?}");
    assert!(close(uh, 1.0) && close(dh, 0.1), "{c:?}");
}

#[test]
fn outcomes_are_one_json_line_per_test() {
    let runs = vec![RunOutcome {
        speed_mps: 7.0,
        displacement_t: 6000.0,
        speed_after_mps: f64::NAN,
        declared_after_t: f64::NAN,
        commissioning: vec![TestOutcome {
            phase: Phase::Commissioning,
            completed: false,
            abort_reason: Some("relay chatter".into()),
            ..outcome(Decision::Nominal, f64::NAN)
        }],
        tests: vec![
            outcome(Decision::Nominal, 0.1),
            outcome(Decision::Fault, 0.9),
        ],
        error: None,
    }];
    let mut buf = Vec::new();
    write_outcomes(&mut buf, "m: s", SeaState::Moderate, &runs);
    let text = String::from_utf8(buf).unwrap();
    let lines: Vec<serde_json::Value> = text
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(lines.len(), 3);
    assert_eq!(lines[0]["phase"], "commissioning");
    assert_eq!(lines[0]["reason"], "relay chatter");
    assert!(lines[0]["raw"][0].is_null());
    assert!(lines[0]["chi2_actuator"].is_null());
    assert!(lines[1]["reason"].is_null());
    assert_eq!(lines[1]["phase"], "test");
    assert_eq!(lines[1]["speed_log_mps"], 7.0);
    assert_eq!(lines[1]["displacement_nominal_t"], 6000.0);
    assert_eq!(lines[1]["fault_present"], false);
    assert!(lines[1]["speed_after_mps"].is_null());
    assert!(lines[1]["reference"].is_null());
    assert_eq!(lines[2]["test"], 1);
    assert_eq!(lines[2]["decision"], "fault");
    assert_eq!(lines[2]["isolation"][0], "speed_log");
    assert_eq!(lines[2]["raw"][0], 0.9);
    assert_eq!(lines[2]["raw"][5], 1900.0);
    for l in &lines {
        assert_eq!(
            (l["row"].as_str(), l["method"].as_str(), l["sea"].as_str()),
            (Some("m: s"), Some("hbt"), Some("moderate"))
        );
        assert_eq!(l["run"], 0);
    }
}

fn by_name(scs: Vec<FdiScenario>, name: &str) -> FdiScenario {
    scs.into_iter().find(|s| s.name == name).unwrap()
}

/// The draw of an envelope run: a speed change of 0.5, 1, 1.5 or 2 m/s whose sign keeps the speed in
/// 4..10 m/s (at the box's corners too), a loading of -30..+20 % that keeps D in
/// 4000..10000 t; the same seed draws the same run.
#[test]
fn envelope_draws_stay_in_the_envelope() {
    let cfg = Config::default();
    let sc = by_name(envelope_scenarios(), "envelope: speed and loading");
    for seed in 0..200 {
        let corner = (seed % 2 == 0).then_some(seed as usize / 2);
        let d = draw::draw(&cfg, &sc, SeaState::Calm, seed, corner).unwrap();
        let c = d.change.unwrap();
        let (u0, d0) = (d.scenario.speed_mps, d.scenario.displacement_t);
        let u1 = c.speed_mps.unwrap();
        let step = (u1 - u0).abs();
        assert!(
            [0.5, 1.0, 1.5, 2.0].iter().any(|m| (step - m).abs() < 1e-9),
            "{u0} -> {u1}"
        );
        assert!((4.0 - 1e-9..=10.0 + 1e-9).contains(&u1), "{u0} -> {u1}");
        let d1 = c.displacement_t.unwrap();
        assert!(
            (-0.3 - 1e-12..=0.2 + 1e-12).contains(&(d1 / d0 - 1.0)),
            "{d0} -> {d1}"
        );
        assert!(
            (4000.0 - 1e-6..=10000.0 + 1e-6).contains(&d1),
            "{d0} -> {d1}"
        );
        let again = draw::draw(&cfg, &sc, SeaState::Calm, seed, corner).unwrap();
        assert_eq!(again.change, d.change);
        assert_eq!(again.scenario, d.scenario);
    }
}

/// A vessel of another class (its own `ship.*-range`): every scenario draws inside its box
/// (the family's ranges mapped onto it), its corners at the mapped ends; on the family's box
/// the numbers are the scenarios' own. (Before the mapping, every displacement scenario
/// drew the family's 4444-9091 t on a 18 000-32 000 t class and its runs broke.)
#[test]
fn another_class_draws_inside_its_own_box() {
    let mut cfg = Config::default();
    cfg.ship.length_m = 175.0;
    cfg.ship.nominal_speed_mps = 9.0;
    cfg.ship.nominal_displacement_t = 25000.0;
    cfg.ship.speed_range_mps = [6.0, 12.0];
    cfg.ship.displacement_range_t = [18000.0, 32000.0];
    let all = [scenarios(), envelope_scenarios(), commissioning_scenarios()].concat();
    for sc in &all {
        for seed in 0..8 {
            let corner = (seed % 2 == 0).then_some(seed as usize / 2);
            let d = draw::draw(&cfg, sc, SeaState::Calm, seed, corner)
                .unwrap_or_else(|e| panic!("{}: {e}", sc.name));
            let (u, dt) = (d.scenario.speed_mps, d.scenario.displacement_t);
            assert!((6.0..=12.0).contains(&u), "{}: {u}", sc.name);
            assert!((18000.0..=32000.0).contains(&dt), "{}: {dt}", sc.name);
        }
    }
    let sc = by_name(scenarios(), "displacement +10 %");
    let lo = draw::draw(&cfg, &sc, SeaState::Calm, 0, Some(0)).unwrap();
    // The family's 5000 t (1000 t over its 4000) maps to 18 000 + 1000 x 14 000 / 6000.
    assert!((lo.scenario.displacement_t - (18000.0 + 1000.0 * 14.0 / 6.0)).abs() < 1e-6);
    let family = draw::draw(&Config::default(), &sc, SeaState::Calm, 0, Some(0)).unwrap();
    assert_eq!(family.scenario.displacement_t, 5000.0);
}

/// A cheap configuration: five commissioning tests of HBT, one test after commissioning.
fn cheap() -> (Config, FdiEvalOptions, Arc<Estimator>) {
    let mut cfg = Config::default();
    cfg.fdi.commissioning_tests = 5;
    let o = FdiEvalOptions {
        tests: 1,
        warmup_s: 900.0,
        gap_s: 300.0,
        methods: vec![Method::Hbt],
        seas: vec![SeaState::Calm],
        ..FdiEvalOptions::default()
    };
    let est = Arc::new(Estimator::embedded(&cfg.core()).unwrap());
    (cfg, o, est)
}

/// `--onset-after 2`: a classic fault arises two tests of the ship after commissioning ends;
/// the tests before it are healthy (`fault_present` false) and not the run's detection's,
/// which counts from the onset: a gross step (+20 %) is detected at the first test with it.
#[test]
fn a_classic_fault_can_arise_after_the_vessel_has_learned_more() {
    let (cfg, mut o, est) = cheap();
    o.onset_after = 2;
    let sc = by_name(scenarios(), "displacement +20 %");
    let r = run_one(&cfg, &sc, SeaState::Calm, &o.methods, 3, &est, &o, None);
    assert_eq!(r.error, None);
    assert_eq!(r.commissioning.len(), 5);
    let present: Vec<bool> = r.tests.iter().map(|t| t.fault_present).collect();
    assert_eq!(present, [false, false, true]);
    assert!(r.tests[..2].iter().all(|t| t.decision != Decision::Fault));
    let c = score(std::slice::from_ref(&r), sc.expected, 1, false);
    assert_eq!((c.detected, c.delay_sum), (1, 1));
}

/// The suite's commissioning ends when the vessel's does: with room for 12 tests, this calm
/// sea's CLFRT sample resolves the design's faults sooner (`reference.resolve-*`), and the
/// fault arises at the first test on the vessel's own reference (the last commissioning
/// test still on the design's, the first after it not), not after the 12.
#[test]
fn a_classic_fault_arises_when_the_vessels_commissioning_ends() {
    let (mut cfg, mut o, est) = cheap();
    cfg.fdi.commissioning_tests = 12;
    o.methods = vec![Method::Clfrt];
    let sc = by_name(scenarios(), "displacement +20 %");
    let r = run_one(&cfg, &sc, SeaState::Calm, &o.methods, 2, &est, &o, None);
    assert_eq!(r.error, None);
    let n = r.commissioning.len();
    assert!((6..12).contains(&n), "{n}");
    let kind = |t: &TestOutcome| t.reference_kind.clone().unwrap_or_default();
    assert_eq!(kind(&r.commissioning[n - 1]), "commissioning");
    assert_ne!(kind(&r.tests[0]), "commissioning");
    assert!(r.tests[0].fault_present);
}

/// `--onset-after 2` on an envelope run: the operating point changes two tests of the ship
/// after commissioning ends; the tests before it are at the commissioned point.
#[test]
fn an_envelope_change_can_arise_after_the_vessel_has_learned_more() {
    let (cfg, mut o, est) = cheap();
    o.onset_after = 2;
    let sc = by_name(envelope_scenarios(), "envelope: speed and loading");
    let r = run_one(&cfg, &sc, SeaState::Calm, &o.methods, 11, &est, &o, None);
    assert_eq!(r.error, None);
    let phases: Vec<Phase> = r.tests.iter().map(|t| t.phase).collect();
    assert_eq!(
        phases,
        [Phase::BeforeChange, Phase::BeforeChange, Phase::AfterChange]
    );
    for t in &r.tests[..2] {
        assert!((t.speed_log_mps - r.speed_mps).abs() < 0.3, "{t:?}");
    }
    assert!((r.tests[2].speed_log_mps - r.speed_after_mps).abs() < 0.3);
}

/// One healthy envelope run: commissioning at the drawn point (its D the nominal one), then the
/// speed and the declared loading change: the test after it is tagged `after change`, its
/// speed log within 0.3 m/s of the new speed, its nominal displacement the declared one.
#[test]
fn an_envelope_run_changes_the_operating_point_as_scheduled() {
    let (cfg, o, est) = cheap();
    let sc = by_name(envelope_scenarios(), "envelope: speed and loading");
    let r = run_one(&cfg, &sc, SeaState::Calm, &o.methods, 11, &est, &o, None);
    assert_eq!(r.error, None);
    assert_eq!(r.commissioning.len(), 5);
    for t in &r.commissioning {
        assert_eq!((t.phase, t.fault_present), (Phase::Commissioning, false));
        assert!((t.speed_log_mps - r.speed_mps).abs() < 0.3, "{t:?}");
        let rel = (t.displacement_nominal_t / r.displacement_t - 1.0).abs();
        assert!(rel < 1e-9, "{t:?}");
    }
    assert_eq!(r.tests.len(), 1);
    let step = (r.speed_after_mps - r.speed_mps).abs();
    assert!(
        [0.5, 1.0, 1.5, 2.0].iter().any(|m| (step - m).abs() < 1e-9),
        "{r:?}"
    );
    for t in &r.tests {
        assert_eq!((t.phase, t.fault_present), (Phase::AfterChange, false));
        assert!(t.completed, "{t:?}");
        assert!(
            (t.speed_log_mps - r.speed_after_mps).abs() < 0.3,
            "speed log {} m/s, scheduled {} m/s",
            t.speed_log_mps,
            r.speed_after_mps
        );
        let rel = (t.displacement_nominal_t / r.declared_after_t - 1.0).abs();
        assert!(
            rel < 1e-9,
            "{} t declared, {} t in force",
            r.declared_after_t,
            t.displacement_nominal_t
        );
    }
}

/// An aborted test is no commissioning test: the fault of a classic scenario arises when
/// every method has its reference, however many of the ship's tests that took. HBT in a rough
/// sea, its first relay sized before the sea is known: some commissioning tests chatter and
/// abort; commissioning then holds as many tests of the ship as it needed for 5 completed, and
/// the fault's first test is measured against the vessel's commissioned reference.
#[test]
fn commissioning_waits_for_the_methods_references_past_aborted_tests() {
    let (cfg, mut o, est) = cheap();
    o.seas = vec![SeaState::Rough];
    let sc = by_name(scenarios(), "displacement +10 %");
    let mut aborted = 0;
    for seed in 1..=3 {
        let r = run_one(&cfg, &sc, SeaState::Rough, &o.methods, seed, &est, &o, None);
        assert_eq!(r.error, None);
        let completed = r.commissioning.iter().filter(|t| t.completed).count();
        aborted += r.commissioning.len() - completed;
        assert_eq!(completed, 5, "{:?}", r.commissioning);
        assert!(r.commissioning.last().is_some_and(|t| t.completed));
        assert!(r.commissioning.iter().all(|t| !t.fault_present));
        assert_eq!(r.tests.len(), 1);
        let t = &r.tests[0];
        assert!(t.fault_present && t.phase == Phase::Test, "{t:?}");
        if t.completed {
            assert_eq!(t.reference_kind.as_deref(), Some("commissioned"), "{t:?}");
        }
    }
    assert!(
        aborted > 0,
        "no commissioning test aborted: the check saw nothing"
    );
}

/// Wave yaw bands of the sea index [deg] by the simulator's levels (calm 0.05, moderate 0.2,
/// the gyro's noise in the band on top).
const CALM_INDEX: (f64, f64) = (0.03, 0.1);
const MODERATE_INDEX: (f64, f64) = (0.15, 0.3);

/// Checks an envelope row whose sea changes at commissioning's end (no speed or loading
/// change): the draw from each sea of `steps` gives its sea after, and a run from `from`
/// measures its commissioning in the band `before` and the test after the change in `after`.
fn check_sea_change(
    row: &str,
    steps: [(SeaState, SeaState); 3],
    from: SeaState,
    before: (f64, f64),
    after: (f64, f64),
) {
    let cfg = Config::default();
    let sc = by_name(envelope_scenarios(), row);
    for (a, b) in steps {
        let c = draw::draw(&cfg, &sc, a, 3, None).unwrap().change.unwrap();
        assert_eq!(
            (c.sea, c.speed_mps, c.displacement_t),
            (Some(b), None, None)
        );
    }
    let (cfg, o, est) = cheap();
    let r = run_one(&cfg, &sc, from, &o.methods, 11, &est, &o, None);
    assert_eq!(r.error, None);
    let inside = |x: f64, (lo, hi): (f64, f64)| x > lo && x < hi;
    for t in &r.commissioning {
        assert!(inside(t.sea_index, before), "{t:?}");
    }
    assert_eq!(r.tests.len(), 1);
    for t in &r.tests {
        assert_eq!(t.phase, Phase::AfterChange);
        assert!(inside(t.sea_index, after), "{t:?}");
    }
}

/// The sea rises a state at commissioning's end (calm to moderate, moderate to rough, a rough
/// sea stays): the test after it measures the new sea's wave yaw.
#[test]
fn an_envelope_run_whose_sea_rises_measures_the_new_sea() {
    use SeaState::{Calm, Moderate, Rough};
    check_sea_change(
        "envelope: the sea rises a state",
        [(Calm, Moderate), (Moderate, Rough), (Rough, Rough)],
        Calm,
        CALM_INDEX,
        MODERATE_INDEX,
    );
}

/// The sea falls a state at commissioning's end (rough to moderate, moderate to calm, a calm
/// sea stays): a reference learned in the rougher sea judges the test in the calmer one.
#[test]
fn an_envelope_run_whose_sea_falls_measures_the_calmer_sea() {
    use SeaState::{Calm, Moderate, Rough};
    check_sea_change(
        "envelope: the sea falls a state",
        [(Rough, Moderate), (Moderate, Calm), (Calm, Calm)],
        Moderate,
        MODERATE_INDEX,
        CALM_INDEX,
    );
}

/// The commissioning run of seed 5 with D +12 % in a calm sea: the onset's test of the ship
/// and the run (which completed).
fn displacement_during_commissioning(
    cfg: &Config,
    o: &FdiEvalOptions,
    est: &Arc<Estimator>,
) -> (usize, RunOutcome) {
    let sc = by_name(commissioning_scenarios(), "commissioning: D +12 %");
    let seed = 5;
    let k = draw::draw(cfg, &sc, SeaState::Calm, seed, None)
        .unwrap()
        .onset_test
        .unwrap();
    let r = run_one(cfg, &sc, SeaState::Calm, &o.methods, seed, est, o, None);
    assert_eq!(r.error, None);
    (k, r)
}

/// One commissioning run with D +12 %: the fault is present from commissioning test k of the
/// ship on (k drawn in 2..6, at most one past the last commissioning test), and in the
/// confirmation's tests after commissioning (as many), tagged `after fault`; nothing is declared (the nominal D stays).
#[test]
fn a_commissioning_fault_arises_at_test_k() {
    let (cfg, o, est) = cheap();
    let (k, r) = displacement_during_commissioning(&cfg, &o, &est);
    assert!((2..=6).contains(&k), "{k}");
    assert_eq!(r.commissioning.len(), 5);
    assert_eq!(
        r.tests.len(),
        r.commissioning.len(),
        "the confirmation's tests"
    );
    for (i, t) in r.commissioning.iter().enumerate() {
        assert_eq!(t.phase, Phase::Commissioning);
        assert_eq!(
            t.fault_present,
            i + 1 >= k,
            "test {} of the ship, onset {k}",
            i + 1
        );
    }
    for t in &r.tests {
        assert_eq!((t.phase, t.fault_present), (Phase::AfterFault, true));
    }
    for t in r.commissioning.iter().chain(&r.tests) {
        assert!((t.speed_log_mps - r.speed_mps).abs() < 0.3, "{t:?}");
        let rel = (t.displacement_nominal_t / r.displacement_t - 1.0).abs();
        assert!(rel < 1e-9, "{t:?}");
    }
    let c = score_commissioning(std::slice::from_ref(&r), false);
    assert_eq!(c.onset_sum, k.min(6));
}

/// Both methods in turn, 6 commissioning tests each, D +12 % arising before the vessel's
/// test k: nothing is flagged "inconsistent" before a method completes its sample; when the
/// first one does, the vessel's change-point test finds the change in both samples (the
/// other's partial one with it) and every report from then on says so, at alert or above,
/// with neither method's reference set.
#[test]
fn a_fault_arising_during_commissioning_is_found_in_both_samples_when_one_completes() {
    let (mut cfg, mut o, est) = cheap();
    cfg.fdi.commissioning_tests = 6;
    o.methods = vec![Method::Clfrt, Method::Hbt];
    o.in_turn = true;
    let (k, r) = displacement_during_commissioning(&cfg, &o, &est);
    assert!((3..=6).contains(&k), "{k}: the change splits both samples");
    assert_eq!(r.commissioning.len(), 12);
    let first = r.commissioning.iter().position(|t| t.inconsistent);
    assert_eq!(
        first,
        Some(10),
        "the first completion is the vessel's 11th test"
    );
    for t in r.commissioning[10..].iter().chain(&r.tests) {
        assert!(t.inconsistent, "{t:?}");
        assert_ne!(
            t.state,
            Some(helmwatch_core::wire::residuals::TrackState::Normal),
            "{t:?}"
        );
    }
    for t in &r.tests {
        assert_eq!(
            t.reference_kind.as_deref(),
            Some("commissioning_inconsistent")
        );
    }
}
