//! Clock steps on the ship's streams: a wild timestamp (one tick of every stream far in the
//! future or the past), and the sensors' clock stepping back an hour or ahead, never stop the
//! monitor. It answers the headings again within 10 s of ship time, counts what it rejected
//! and how often each stream re-synchronised, aborts a test under way ("clock step"), and
//! completes the next one. The simulated ship steps its clock with the `clock_step_s` and
//! `clock_outlier_s` faults; the core runs as in the daemon (lockstep).

use helmwatch::config::Config;
use helmwatch_core::drivers::probe::Lockstep;
use helmwatch_core::monitor::input::RejectReason;
use helmwatch_core::monitor::Output;
use helmwatch_core::sim::Scenario;
use helmwatch_core::wire::{Method, Outcome, Report, Stream};

const ONSET_S: f64 = 400.0;

fn lockstep(faults: &[&str]) -> Lockstep {
    let mut cfg = Config::default();
    cfg.scheduler.enabled = false;
    let sim = cfg.sim();
    let sc = Scenario {
        faults: faults.iter().map(|f| f.parse().unwrap()).collect(),
        ..Scenario::nominal(&sim, 7)
    };
    Lockstep::new(&cfg.core(), &sim, &sc).unwrap()
}

/// Runs to ship time `until_s`; returns, per tick, its ship time and whether its heading
/// was answered with an excitation, and the reports.
fn run(ls: &mut Lockstep, until_s: f64) -> (Vec<(f64, bool)>, Vec<Report>) {
    let mut ticks = Vec::new();
    let mut reports = Vec::new();
    let mut out = Vec::new();
    while ls.time_s() < until_s {
        let t = ls.time_s();
        out.clear();
        ls.tick(&mut out, true);
        let answered = out.iter().any(|o| matches!(o, Output::Excitation(_)));
        ticks.push((t, answered));
        reports.extend(out.drain(..).filter_map(|o| match o {
            Output::Report(r) => Some(*r),
            _ => None,
        }));
    }
    (ticks, reports)
}

/// Headings not answered from the onset on.
fn missed(ticks: &[(f64, bool)]) -> usize {
    ticks
        .iter()
        .filter(|(t, answered)| *t >= ONSET_S - 1e-9 && !answered)
        .count()
}

/// Ship time from the onset until every later heading is answered [s].
fn recovery_s(ticks: &[(f64, bool)]) -> f64 {
    let last_missed = ticks
        .iter()
        .filter(|(t, answered)| *t >= ONSET_S - 1e-9 && !answered)
        .map(|(t, _)| *t)
        .fold(ONSET_S, f64::max);
    last_missed - ONSET_S
}

/// An HBT test triggered now, to its report.
fn test_completes(ls: &mut Lockstep) -> Report {
    let reply = ls.trigger(Method::Hbt);
    assert!(reply.accepted, "{:?}", reply.reason);
    let t0 = ls.time_s();
    let (_, reports) = run(ls, t0 + 2000.0);
    let r = reports.into_iter().next().expect("a report");
    assert_eq!(r.outcome, Outcome::Completed, "{:?}", r.reason);
    r
}

#[test]
fn a_wild_timestamp_on_every_stream_is_rejected_and_forgotten() {
    for offset in ["1e6", "-1e6"] {
        let mut ls = lockstep(&[&format!("clock_outlier_s:{offset}@{ONSET_S}")]);
        let (ticks, _) = run(&mut ls, ONSET_S + 300.0);
        // The wild tick's heading is not answered; the next one is.
        assert_eq!(missed(&ticks), 1, "{offset}");
        assert!(recovery_s(&ticks) < 0.05, "{offset}");
        let c = ls.monitor.counters();
        let reason = if offset.starts_with('-') {
            RejectReason::OutOfOrder
        } else {
            RejectReason::TimeJump
        };
        for s in [Stream::Heading, Stream::Rudder, Stream::Speed] {
            assert_eq!(c.rejected(s, reason), 1, "{offset} {s:?}");
            assert_eq!(c.resyncs(s), 0, "{offset} {s:?}");
        }
        test_completes(&mut ls);
    }
}

#[test]
fn the_clock_stepping_back_an_hour_or_ahead_resynchronises_every_stream() {
    for step in ["-3600", "3600", "-1.7e9"] {
        let mut ls = lockstep(&[&format!("clock_step_s:{step}@{ONSET_S}")]);
        let (ticks, _) = run(&mut ls, ONSET_S + 300.0);
        let r = recovery_s(&ticks);
        assert!(r < 10.0, "step {step}: headings answered again after {r} s");
        // A step is not taken on one sample: the new timeline's first samples wait.
        let m = missed(&ticks);
        assert!((2..=10).contains(&m), "step {step}: {m} headings missed");
        let c = ls.monitor.counters();
        for s in [
            Stream::Heading,
            Stream::Rudder,
            Stream::Speed,
            Stream::AutopilotState,
            Stream::TargetHeading,
        ] {
            assert_eq!(c.resyncs(s), 1, "step {step} {s:?}");
        }
        let report = test_completes(&mut ls);
        // The report is on the new timeline.
        let shift: f64 = step.parse().unwrap();
        assert!(report.t_start > ONSET_S + shift, "{}", report.t_start);
    }
}

#[test]
fn a_test_under_way_is_aborted_by_a_clock_step_and_the_next_one_completes() {
    let mut ls = lockstep(&[&format!("clock_step_s:-3600@{}", ONSET_S + 300.0)]);
    run(&mut ls, ONSET_S);
    let reply = ls.trigger(Method::Hbt);
    assert!(reply.accepted, "{:?}", reply.reason);
    let (_, reports) = run(&mut ls, ONSET_S + 400.0);
    assert_eq!(reports.len(), 1, "{reports:?}");
    let r = &reports[0];
    assert_eq!(r.outcome, Outcome::Aborted);
    let reason = r.reason.as_deref().unwrap_or_default();
    assert!(reason.starts_with("clock step"), "{reason}");
    assert_eq!(ls.monitor.stats().aborts.get("clock_step"), 1);
    let t = ls.time_s();
    run(&mut ls, t + 120.0);
    test_completes(&mut ls);
}
