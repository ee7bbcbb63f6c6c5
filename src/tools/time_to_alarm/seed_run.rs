//! One seeded run of `helmwatch bench --time-to-alarm` at one scheduler interval: the healthy
//! ship through commissioning, its confirmation and a watch, its rudder travel against the
//! autopilot alone, then each fault from the watch's start to the first alarm (the module `time_to_alarm` says how).

use super::{Alarm, BenchFault, FaultRun, SeedRun, TimeToAlarmError, Travel};
use crate::config::Config;
use helmwatch_core::drivers::probe::Lockstep;
use helmwatch_core::dsp::multisine::Multisine;
use helmwatch_core::estimator::Estimator;
use helmwatch_core::model::SeaState;
use helmwatch_core::monitor::{Monitor, Output};
use helmwatch_core::sim::{Fault, Scenario};
use helmwatch_core::wire::{AlarmState, Outcome};
use std::sync::Arc;

/// Sums the absolute increments of the true rudder angle, tick by tick [rad].
#[derive(Debug, Clone, Copy, Default)]
struct TravelMeter {
    last_rad: Option<f64>,
    total_rad: f64,
}

impl TravelMeter {
    fn sample(&mut self, ls: &Lockstep) {
        let d = ls.ship.truth().delta_rad;
        if let Some(l) = self.last_rad {
            self.total_rad += (d - l).abs();
        }
        self.last_rad = Some(d);
    }
}

/// Ship time cap of commissioning [s]: three times the tests it needs, each a whole cycle.
fn commissioning_cap_s(cfg: &Config) -> f64 {
    let tests = 2.0 * f64::from(cfg.fdi.commissioning_tests.max(1));
    let cycle =
        cfg.scheduler.interval_s + cfg.scheduler.steady_time_s + cfg.safety.max_test_duration_s;
    3.0 * tests * cycle + cycle
}

/// The parts every run of one configuration shares: the estimator and the multisine.
#[derive(Debug, Clone)]
pub struct Parts {
    estimator: Option<Arc<Estimator>>,
    multisine: Option<Multisine>,
}

impl Parts {
    /// The configured estimator (as the daemon loads it) and the designed multisine.
    pub fn new(cfg: &Config) -> Result<Self, TimeToAlarmError> {
        let core = cfg.core();
        Ok(Self {
            estimator: Estimator::from_config(&core)
                .map_err(|e| TimeToAlarmError::Estimator(e.to_string()))?,
            multisine: Monitor::design_multisine(&core).ok(),
        })
    }
}

/// One run at `cfg`'s scheduler: commissioning, its rudder travel against the autopilot
/// alone, then each of `faults` from the onset for up to `cap_s` (see the module
/// documentation).
pub fn run_seed(
    cfg: &Config,
    parts: &Parts,
    faults: &[BenchFault],
    sea: SeaState,
    seed: u64,
    cap_s: f64,
) -> Result<SeedRun, TimeToAlarmError> {
    let mut scenario = Scenario::nominal(&cfg.sim(), seed);
    scenario.sea = sea;
    let build = |cfg: &Config| {
        Lockstep::with_parts(
            &cfg.core(),
            &cfg.sim(),
            &scenario,
            parts.multisine.clone(),
            parts.estimator.clone(),
        )
    };
    let mut ls = build(cfg)?;
    let t_start = ls.time_s();
    let t_cap = t_start + commissioning_cap_s(cfg);
    let mut meter = TravelMeter::default();
    meter.sample(&ls);
    // Commissioning: to the first report (the window's start), then to both methods
    // commissioned; then the confirmation (at the commissioning cadence) and `cap_s` of the
    // watch. Each window's end with the meter's reading there and its reports.
    let (first, mut alarms) = run_healthy(&mut ls, &mut meter, |l, n| n == 0 && l.time_s() < t_cap);
    let window_start = (first > 0).then(|| (ls.time_s(), meter.total_rad));
    let (more, a) = run_healthy(&mut ls, &mut meter, |l, _| {
        !l.monitor.commissioned() && l.time_s() < t_cap
    });
    alarms += a;
    let reports = first + more;
    let commissioned_s = (reports > 0 && ls.monitor.commissioned()).then(|| ls.time_s());
    let t_end = ls.time_s();
    let (t_a, travel_a) = window_start.unwrap_or((t_start, 0.0));
    let mut marks = vec![(t_a, travel_a), (t_end, meter.total_rad)];
    let mut window_reports = Vec::new();
    let mut watch_start = None;
    if commissioned_s.is_some() {
        let t_confirm_cap = t_end + (t_cap - t_start);
        let (n, a) = run_healthy(&mut ls, &mut meter, |l, _| {
            l.monitor.establishing() && l.time_s() < t_confirm_cap
        });
        alarms += a;
        marks.push((ls.time_s(), meter.total_rad));
        window_reports.push(n);
        if !ls.monitor.establishing() {
            watch_start = Some((ls.time_s(), ls.clone()));
        }
        let t1 = ls.time_s();
        let (n, a) = run_healthy(&mut ls, &mut meter, |l, _| l.time_s() < t1 + cap_s);
        alarms += a;
        marks.push((ls.time_s(), meter.total_rad));
        window_reports.push(n);
    }
    // The autopilot alone: the same ship, the scheduler off, read at the same moments.
    let mut out = Vec::new();
    let mut off_cfg = cfg.clone();
    off_cfg.scheduler.enabled = false;
    let mut off = build(&off_cfg)?;
    let mut off_meter = TravelMeter::default();
    off_meter.sample(&off);
    let mut off_marks = Vec::with_capacity(marks.len());
    for &(t, _) in &marks {
        while off.time_s() < t {
            off.tick(&mut out, false);
            off_meter.sample(&off);
            out.clear();
        }
        off_marks.push(off_meter.total_rad);
    }
    let window = |i: usize, tests: usize| Travel {
        hours: (marks[i + 1].0 - marks[i].0) / 3600.0,
        with_tests_deg: (marks[i + 1].1 - marks[i].1).to_degrees(),
        autopilot_deg: (off_marks[i + 1] - off_marks[i]).to_degrees(),
        tests,
    };
    let travel = window(0, reports.saturating_sub(1));
    let mut run = SeedRun {
        seed,
        start_s: t_start,
        commissioned_s,
        commissioning_reports: reports,
        healthy_alarms: alarms,
        travel,
        confirmation: (marks.len() > 2).then(|| window(1, window_reports[0])),
        watch: (marks.len() > 3).then(|| window(2, window_reports[1])),
        watch_start_s: None,
        faults: Vec::new(),
    };
    if let Some((t1, at_watch)) = watch_start {
        run.watch_start_s = Some(t1);
        run.faults = faults
            .iter()
            .map(|f| run_fault(at_watch.clone(), f.fault, t1, cap_s))
            .collect();
    }
    Ok(run)
}

/// Ticks the healthy ship `ls` while `go(ls, reports so far)` holds, its rudder travel on
/// `meter`; returns the reports and the alarm notifications it made meanwhile.
fn run_healthy(
    ls: &mut Lockstep,
    meter: &mut TravelMeter,
    go: impl Fn(&Lockstep, usize) -> bool,
) -> (usize, usize) {
    let (mut out, mut reports, mut alarms) = (Vec::new(), 0, 0);
    while go(ls, reports) {
        ls.tick(&mut out, false);
        meter.sample(ls);
        for o in out.drain(..) {
            match o {
                Output::Report(_) => reports += 1,
                Output::Notification(n) if n.state == AlarmState::Alarm => alarms += 1,
                _ => {}
            }
        }
    }
    (reports, alarms)
}

/// Injects `fault` into the commissioned run `ls` at `t0` and runs to the first alarm or
/// `t0 + cap_s`.
fn run_fault(mut ls: Lockstep, fault: Fault, t0: f64, cap_s: f64) -> FaultRun {
    ls.ship.inject(fault);
    let mut out = Vec::new();
    let mut run = FaultRun {
        alarm: None,
        tests: 0,
        aborted: 0,
    };
    let mut last_isolation = Vec::new();
    let mut last_end = t0;
    while ls.time_s() < t0 + cap_s {
        ls.tick(&mut out, false);
        // A tick's report before its notification, whatever their order in the queue.
        for o in &out {
            if let Output::Report(r) = o {
                if r.outcome == Outcome::Completed {
                    run.tests += 1;
                    last_isolation.clone_from(&r.isolation);
                    last_end = r.t_end;
                } else {
                    run.aborted += 1;
                }
            }
        }
        let alarmed = out
            .iter()
            .any(|o| matches!(o, Output::Notification(n) if n.state == AlarmState::Alarm));
        out.clear();
        if alarmed {
            run.alarm = Some(Alarm {
                tests: run.tests,
                hours: (last_end - t0) / 3600.0,
                isolation: last_isolation,
            });
            break;
        }
    }
    run
}

#[cfg(test)]
mod tests {
    use super::*;
    use helmwatch_core::sim::FaultKind;
    use helmwatch_core::wire::Cause;

    /// A short schedule: five commissioning tests per method (the fewest the K-sample
    /// factor allows), a minute between tests.
    fn short() -> Config {
        let mut cfg = Config::default();
        cfg.fdi.commissioning_tests = 5;
        cfg.scheduler.interval_s = 60.0;
        cfg
    }

    fn gross() -> BenchFault {
        BenchFault {
            name: "displacement +50 %".into(),
            fault: Fault::new(FaultKind::DisplacementPct, 50.0, 0.0).unwrap(),
            expected: Some(Cause::DisplacementOrRudderEffectiveness),
        }
    }

    /// A gross fault is over the sequential test's single-test limit: the alarm comes at
    /// the first test after the onset, whichever method runs it. The test starts at least
    /// `interval-s` after the previous end (the end of the confirmation) and ends within
    /// `steady-time-s` + `max-test-duration-s` of that.
    #[test]
    fn a_gross_fault_alarms_at_the_first_test_after_the_onset() {
        {
            let cfg = short();
            let parts = Parts::new(&cfg).unwrap();
            let run = run_seed(&cfg, &parts, &[gross()], SeaState::Calm, 7, 12.0 * 3600.0).unwrap();
            assert!(run.commissioned_s.is_some(), "not commissioned");
            assert_eq!(run.healthy_alarms, 0);
            let fr = &run.faults[0];
            let alarm = fr.alarm.as_ref().expect("no alarm");
            let k = 1usize;
            assert_eq!(alarm.tests, k);
            assert_eq!(fr.tests, k);
            let lo = k as f64 * cfg.scheduler.interval_s / 3600.0;
            let hi = k as f64
                * (cfg.scheduler.interval_s
                    + cfg.scheduler.steady_time_s
                    + cfg.safety.max_test_duration_s)
                / 3600.0;
            assert!(
                alarm.hours > lo && alarm.hours < hi,
                "{} h outside ({lo}, {hi})",
                alarm.hours
            );
            assert_eq!(
                alarm.isolation,
                vec![Cause::DisplacementOrRudderEffectiveness]
            );
        }
    }

    /// Commissioning and its confirmation run at their own cadence, a gap of at most
    /// `commissioning-interval-s` (`monitor::cadence`), the watch after them at
    /// `interval-s`. A cycle is at least the least gap (the steady wait may run within it)
    /// and at most the most gap, the steady wait and `max-test-duration-s`; a window's tests
    /// fit those bounds: whole cycles for commissioning and the confirmation (both end at a
    /// report), the cycles begun for the watch.
    #[test]
    fn commissioning_and_its_confirmation_come_at_their_own_cadence() {
        let mut cfg = Config::default();
        cfg.fdi.commissioning_tests = 5;
        let parts = Parts::new(&cfg).unwrap();
        let run = run_seed(&cfg, &parts, &[], SeaState::Calm, 7, 8.0 * 3600.0).unwrap();
        assert!(run.commissioned_s.is_some(), "not commissioned");
        let sc = &cfg.scheduler;
        let between = |least: f64, most: f64| {
            (
                least.max(sc.steady_time_s),
                most + sc.steady_time_s + cfg.safety.max_test_duration_s,
            )
        };
        let cycle = |interval: f64| between(interval, interval);
        let establishing = between(0.0, sc.commissioning_interval_s);
        let whole = |t: &Travel| {
            let ((lo, hi), n, w) = (establishing, t.tests as f64, t.hours * 3600.0);
            assert!(
                n * lo <= w + 1.0 && w <= n * hi + 1.0,
                "({lo}, {hi}) s: {t:?}"
            );
        };
        whole(&run.travel);
        let confirmation = run.confirmation.expect("a confirmation");
        assert!(confirmation.tests >= 8, "{confirmation:?}");
        whole(&confirmation);
        let watch = run.watch.expect("a watch");
        let ((lo, hi), w) = (cycle(sc.interval_s), watch.hours * 3600.0);
        let n = watch.tests as f64;
        assert!(
            (w / hi).floor() <= n && n <= (w / lo).ceil(),
            "({lo}, {hi}) s: {watch:?}"
        );
        // The cadences differ: the commissioning's longest cycle is shorter than the watch's
        // shortest.
        assert!(establishing.1 < cycle(sc.interval_s).0);
    }

    /// With the scheduler off the run and the autopilot-alone run are the same ship: the
    /// tests add exactly nothing (and no commissioning, so no fault runs). With it on they
    /// add travel in a calm sea, where the autopilot alone barely moves the rudder.
    #[test]
    fn travel_added_is_zero_without_tests_and_positive_with_them() {
        let mut off = short();
        off.scheduler.enabled = false;
        let parts = Parts::new(&off).unwrap();
        let run = run_seed(&off, &parts, &[gross()], SeaState::Calm, 7, 3600.0).unwrap();
        assert_eq!(run.commissioned_s, None);
        assert_eq!(run.commissioning_reports, 0);
        assert!(run.faults.is_empty());
        assert!(run.travel.hours > 1.0);
        assert!(run.travel.autopilot_deg > 0.0);
        assert_eq!(run.travel.with_tests_deg, run.travel.autopilot_deg);
        assert_eq!(run.travel.added_deg_per_h(), 0.0);

        let on = short();
        let run = run_seed(&on, &parts, &[], SeaState::Calm, 7, 3600.0).unwrap();
        assert!(run.commissioned_s.is_some());
        assert_eq!(run.travel.tests, run.commissioning_reports - 1);
        assert!(run.travel.added_deg_per_h() > 0.0, "{:?}", run.travel);
    }
}
