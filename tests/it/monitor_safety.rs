//! The monitor core's safety and input contract, independent of the feature accuracy:
//! abort paths, exactly one excitation per accepted heading sample, bounded excitation under
//! any input, counted rejections.

use helmwatch::config::Config;
use helmwatch_core::drivers::probe::Lockstep;
use helmwatch_core::monitor::input::RejectReason;
use helmwatch_core::monitor::{Monitor, Output};
use helmwatch_core::sim::Scenario;
use helmwatch_core::wire::Method;
use helmwatch_core::wire::{
    Excitation, ExcitationMode, Input, MonitorState, Outcome, Report, Scalar, StateValue, Stream,
};
use proptest::prelude::*;

const DT: f64 = 0.1;

/// A synthetic ship for the monitor: a steady course with a small heading wobble.
struct Feed {
    t: f64,
    target: f64,
    auto: bool,
    heading_offset: f64,
    rudder: f64,
}

impl Feed {
    fn new() -> Self {
        Self {
            t: 1000.0,
            target: 1.0,
            auto: true,
            heading_offset: 0.0,
            rudder: 0.01,
        }
    }
    /// One 10 Hz tick: rudder, speed, state, target, then heading (unless `skip_heading`).
    fn tick(&mut self, m: &mut Monitor, skip_heading: bool) -> Vec<Output> {
        let t = self.t;
        let wobble = 0.002 * (0.05 * t).sin();
        let inputs = [
            Input::Rudder(Scalar {
                t,
                value: self.rudder,
            }),
            Input::Speed(Scalar { t, value: 7.0 }),
            Input::AutopilotState(StateValue {
                t,
                value: if self.auto { "auto" } else { "standby" }.into(),
            }),
            Input::TargetHeading(Scalar {
                t,
                value: self.target,
            }),
        ];
        for i in inputs {
            m.handle_input(i).unwrap();
        }
        if !skip_heading {
            let h = self.target + wobble + self.heading_offset;
            m.handle_input(Input::Heading(Scalar { t, value: h }))
                .unwrap();
        }
        self.t += DT;
        std::iter::from_fn(|| m.poll_output()).collect()
    }
    fn run(&mut self, m: &mut Monitor, seconds: f64) -> Vec<Output> {
        let n = (seconds / DT).round() as usize;
        (0..n).flat_map(|_| self.tick(m, false)).collect()
    }
}

fn monitor() -> Monitor {
    let mut cfg = Config::default();
    cfg.scheduler.enabled = false;
    Monitor::new(&cfg.core(), "self")
}

fn excitations(out: &[Output]) -> Vec<&Excitation> {
    out.iter()
        .filter_map(|o| match o {
            Output::Excitation(e) => Some(e),
            _ => None,
        })
        .collect()
}

fn reports(out: &[Output]) -> Vec<&Report> {
    out.iter()
        .filter_map(|o| match o {
            Output::Report(r) => Some(r.as_ref()),
            _ => None,
        })
        .collect()
}

/// Starts a test on the synthetic feed and runs it well into its excitation.
fn started(method: Method) -> (Monitor, Feed) {
    let mut m = monitor();
    let mut f = Feed::new();
    f.run(&mut m, 10.0);
    let reply = m.trigger(method);
    assert!(reply.accepted, "{reply:?}");
    let out = f.run(&mut m, 120.0);
    let exc = excitations(&out);
    let mode = if method == Method::Hbt {
        ExcitationMode::Replace
    } else {
        ExcitationMode::Add
    };
    assert_eq!(exc.last().unwrap().mode, mode, "test is exciting");
    (m, f)
}

/// The tick that aborts: its excitation is `none`, and an aborted report comes with it.
fn assert_aborts_now(out: &[Output], reason_part: &str) {
    let exc = excitations(out);
    assert_eq!(
        exc.len(),
        1,
        "exactly one excitation for the heading sample"
    );
    assert_eq!(exc[0].mode, ExcitationMode::None);
    assert_eq!(exc[0].value, 0.0);
    let reps = reports(out);
    assert_eq!(reps.len(), 1);
    assert_eq!(reps[0].outcome, Outcome::Aborted);
    assert!(reps[0].estimate.is_none());
    let reason = reps[0].reason.as_deref().unwrap_or("");
    assert!(reason.contains(reason_part), "reason {reason:?}");
    assert!(out
        .iter()
        .any(|o| matches!(o, Output::Status(s) if s.state == MonitorState::Idle)));
}

#[test]
fn standby_mid_test_aborts_on_the_next_heading_sample() {
    for method in [Method::Hbt, Method::Clfrt] {
        let (mut m, mut f) = started(method);
        f.auto = false;
        let out = f.tick(&mut m, false);
        assert_aborts_now(&out, "autopilot left auto");
        // And it stays idle: the next samples get `none`.
        let out = f.run(&mut m, 5.0);
        assert!(excitations(&out)
            .iter()
            .all(|e| e.mode == ExcitationMode::None));
    }
}

#[test]
fn heading_error_over_the_limit_aborts() {
    for method in [Method::Hbt, Method::Clfrt] {
        let (mut m, mut f) = started(method);
        f.heading_offset = 11f64.to_radians();
        let out = f.tick(&mut m, false);
        assert_aborts_now(&out, "heading error");
    }
}

#[test]
fn a_five_second_heading_gap_aborts() {
    for method in [Method::Hbt, Method::Clfrt] {
        let (mut m, mut f) = started(method);
        for _ in 0..50 {
            let out = f.tick(&mut m, true);
            assert!(excitations(&out).is_empty(), "no heading, no excitation");
        }
        let out = f.tick(&mut m, false);
        assert_aborts_now(&out, "heading stream silent");
    }
}

#[test]
fn silence_noticed_by_timeout_aborts_without_a_heading_sample() {
    let (mut m, f) = started(Method::Clfrt);
    let last = m.last_heading_t().unwrap();
    m.handle_timeout(last + 1.0);
    assert!(
        m.poll_output().is_none(),
        "1 s of silence is within the limit"
    );
    m.handle_timeout(last + 3.0);
    let out: Vec<Output> = std::iter::from_fn(|| m.poll_output()).collect();
    assert!(excitations(&out).is_empty());
    assert_eq!(reports(&out)[0].outcome, Outcome::Aborted);
    assert_eq!(m.state(), MonitorState::Idle);
    let _ = f;
}

#[test]
fn course_change_and_rudder_saturation_abort() {
    let (mut m, mut f) = started(Method::Clfrt);
    f.target += 0.2;
    f.heading_offset = -0.2; // heading still on the old course
    let out = f.tick(&mut m, false);
    assert_aborts_now(&out, "course changed");

    let (mut m, mut f) = started(Method::Clfrt);
    f.rudder = 26f64.to_radians();
    let out = f.tick(&mut m, false);
    assert_aborts_now(&out, "rudder saturated");
}

#[test]
fn trigger_is_refused_while_a_test_runs_or_without_auto() {
    let (mut m, _f) = started(Method::Clfrt);
    let r = m.trigger(Method::Hbt);
    assert!(!r.accepted && r.reason.unwrap().contains("under way"));
    let mut m = monitor();
    assert!(!m.trigger(Method::Hbt).accepted, "no data yet");
    let mut f = Feed::new();
    f.auto = false;
    f.run(&mut m, 5.0);
    let r = m.trigger(Method::Hbt);
    assert!(!r.accepted && r.reason.unwrap().contains("auto"));
}

#[test]
fn standby_in_the_simulated_ship_aborts_a_lockstep_test() {
    let mut cfg = Config::default();
    cfg.scheduler.enabled = false;
    let mut ls = Lockstep::new(&cfg.core(), &cfg.sim(), &Scenario::nominal(&cfg.sim(), 7)).unwrap();
    let mut out = Vec::new();
    ls.run_until(300.0, &mut out);
    assert!(ls.trigger(Method::Clfrt).accepted);
    ls.run_until(600.0, &mut out);
    ls.ship.set_autopilot_engaged(false);
    out.clear();
    // The state is published once a second: within 1.1 s the monitor knows and stops.
    for _ in 0..11 {
        ls.tick(&mut out, true);
    }
    let reps = reports(&out);
    assert_eq!(reps.len(), 1, "aborted exactly once");
    assert!(reps[0].reason.as_deref().unwrap().contains("auto"));
    // Every excitation after the report is `none`.
    let idx = out
        .iter()
        .position(|o| matches!(o, Output::Report(_)))
        .unwrap();
    assert!(out[idx..].iter().all(|o| match o {
        Output::Excitation(e) => e.mode == ExcitationMode::None,
        _ => true,
    }));
}

/// One hostile sample for the property test.
#[derive(Debug, Clone)]
enum Hostile {
    Good,
    Nan,
    Inf,
    Backwards(f64),
    Duplicate,
    HeadingOutOfRange(f64),
    Trigger(bool),
}

fn hostile() -> impl Strategy<Value = Hostile> {
    prop_oneof![
        20 => Just(Hostile::Good),
        1 => Just(Hostile::Nan),
        1 => Just(Hostile::Inf),
        1 => (0.01f64..100.0).prop_map(Hostile::Backwards),
        1 => Just(Hostile::Duplicate),
        1 => prop_oneof![Just(9.0), Just(-0.5), Just(7.0)].prop_map(Hostile::HeadingOutOfRange),
        1 => any::<bool>().prop_map(Hostile::Trigger),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]

    /// Whatever arrives, no excitation leaves its bounds, every accepted heading sample gets
    /// exactly one excitation with its `t`, and every rejection is counted.
    #[test]
    fn excitation_stays_bounded_and_rejections_are_counted(
        events in proptest::collection::vec(hostile(), 200..3000),
        wobble in 0.0f64..0.3,
    ) {
        let cfg = Config::default();
        let max_exc = cfg.safety.max_excitation_deg.to_radians();
        let servo = cfg.servo.max_angle_rad();
        let mut m = Monitor::new(&cfg.core(), "self");
        let mut t = 0.0;
        let mut accepted_headings = 0u64;
        let mut errors = 0u64;
        let mut excitation_ts = Vec::new();
        let mut last_add: Option<(f64, f64)> = None;
        for (k, ev) in events.iter().enumerate() {
            t += DT;
            let h = (1.0 + wobble * (0.03 * t).sin()).rem_euclid(std::f64::consts::TAU);
            let base = [
                Input::Rudder(Scalar { t, value: 0.02 * (0.1 * t).sin() }),
                Input::Speed(Scalar { t, value: 7.0 }),
                Input::AutopilotState(StateValue { t, value: "auto".into() }),
                Input::TargetHeading(Scalar { t, value: 1.0 }),
            ];
            for i in base {
                if m.handle_input(i).is_err() { errors += 1; }
            }
            let heading = match ev {
                Hostile::Good | Hostile::Trigger(_) => Input::Heading(Scalar { t, value: h }),
                Hostile::Nan => Input::Heading(Scalar { t, value: f64::NAN }),
                Hostile::Inf => Input::Heading(Scalar { t: f64::INFINITY, value: h }),
                Hostile::Backwards(back) => Input::Heading(Scalar { t: t - back, value: h }),
                Hostile::Duplicate => Input::Heading(Scalar { t: t - DT, value: h }),
                Hostile::HeadingOutOfRange(v) => Input::Heading(Scalar { t, value: *v }),
            };
            // A duplicate is only a duplicate if the previous heading was accepted at t - DT;
            // otherwise it is out of order or fine: the monitor decides, we count its answers.
            match m.handle_input(heading) {
                Ok(()) => accepted_headings += 1,
                Err(_) => errors += 1,
            }
            if let Hostile::Trigger(hbt) = ev {
                let method = if *hbt { Method::Hbt } else { Method::Clfrt };
                let _ = m.trigger(method);
            }
            let _ = k;
            while let Some(o) = m.poll_output() {
                if let Output::Excitation(e) = o {
                    excitation_ts.push(e.t);
                    prop_assert!(e.value.is_finite());
                    match e.mode {
                        ExcitationMode::None => prop_assert_eq!(e.value, 0.0),
                        ExcitationMode::Add => {
                            prop_assert!(e.value.abs() <= max_exc + 1e-12);
                            if let Some((tp, vp)) = last_add {
                                let dmax = cfg.safety.max_excitation_rate_deg_s.to_radians() * (e.t - tp);
                                prop_assert!((e.value - vp).abs() <= dmax + 1e-12);
                            }
                            last_add = Some((e.t, e.value));
                        }
                        ExcitationMode::Replace => prop_assert!(e.value.abs() <= servo + 1e-12),
                    }
                    if e.mode != ExcitationMode::Add { last_add = None; }
                }
            }
        }
        prop_assert_eq!(excitation_ts.len() as u64, accepted_headings);
        prop_assert!(excitation_ts.windows(2).all(|w| w[0] < w[1]));
        prop_assert_eq!(m.counters().rejected_total(), errors);
        prop_assert_eq!(m.counters().accepted(Stream::Heading), accepted_headings);
        let _ = RejectReason::ALL;
    }
}
