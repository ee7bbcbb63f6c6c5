//! Scoring the runs of one scenario: false alarms, detection, delay and isolation (classic and
//! envelope scenarios), flags raised during commissioning (commissioning scenarios).

use super::run::{Phase, RunOutcome, TestOutcome};
use helmwatch_core::wire::residuals::TrackState;
use helmwatch_core::wire::{Cause, Decision, Method};

/// Figures of one (method or baseline, sea, scenario) cell.
#[derive(Debug, Clone, PartialEq)]
pub struct Cell {
    /// Runs.
    pub runs: usize,
    /// Tests with a decision (completed).
    pub tests: usize,
    /// Tests decided `fault`.
    pub fault_tests: usize,
    /// Runs with any `fault`.
    pub fault_runs: usize,
    /// Runs detected within the window.
    pub detected: usize,
    /// Sum of the detection delays of the detected runs [tests].
    pub delay_sum: usize,
    /// Runs whose last test names exactly the expected cause.
    pub isolated: usize,
    /// Runs detected and isolated (exactly) within the window.
    pub isolated_within: usize,
    /// Aborted tests.
    pub aborted: usize,
    /// Runs that ended early.
    pub broken: usize,
}

impl Cell {
    fn empty(runs: usize) -> Self {
        Cell {
            runs,
            tests: 0,
            fault_tests: 0,
            fault_runs: 0,
            detected: 0,
            delay_sum: 0,
            isolated: 0,
            isolated_within: 0,
            aborted: 0,
            broken: 0,
        }
    }
}

/// Scores the runs of one scenario for the method (`baseline = false`) or the baseline.
pub fn score(runs: &[RunOutcome], expected: Option<Cause>, within: usize, baseline: bool) -> Cell {
    let mut c = Cell::empty(runs.len());
    for r in runs {
        c.broken += usize::from(r.error.is_some());
        let pick = |t: &TestOutcome| {
            if baseline {
                (t.baseline_decision, t.baseline_isolation.clone())
            } else {
                (t.decision, t.isolation.clone())
            }
        };
        let mut first_fault = None;
        let mut first_isolated = None;
        // A nominal run's commissioning tests count among its tests (false alarms); a fault
        // run's do not (its fault appears after them).
        let before: &[TestOutcome] = if expected.is_none() {
            &r.commissioning
        } else {
            &[]
        };
        // A fault run's tests before the onset (`eval --fdi --onset-after`) are not its
        // detection's: the healthy rows count false alarms.
        let after = r
            .tests
            .iter()
            .skip_while(|t| expected.is_some() && !t.fault_present);
        for (k, t) in before.iter().chain(after).enumerate() {
            if !t.completed {
                c.aborted += 1;
                continue;
            }
            c.tests += 1;
            let (d, iso) = pick(t);
            if d == Decision::Fault {
                c.fault_tests += 1;
                first_fault.get_or_insert(k + 1);
                if expected.is_some_and(|e| iso.len() == 1 && iso[0] == e) {
                    first_isolated.get_or_insert(k + 1);
                }
            }
        }
        c.fault_runs += usize::from(first_fault.is_some());
        if let Some(k) = first_fault.filter(|&k| k <= within) {
            c.detected += 1;
            c.delay_sum += k;
        }
        c.isolated_within += usize::from(first_isolated.is_some_and(|k| k <= within));
        if let Some(e) = expected {
            let iso = end_naming(&r.tests, &pick);
            c.isolated += usize::from(iso.len() == 1 && iso[0] == e);
        }
    }
    c
}

/// Scores envelope runs: false alarms over the tests after commissioning without the fault
/// (`fault_tests`, `fault_runs`, `tests` counting those), detection and isolation within
/// `within` tests of the ship from the fault's onset (the first test with it is 1; aborted
/// tests count), the naming at the end.
pub fn score_envelope(runs: &[RunOutcome], expected: Option<Cause>, within: usize) -> Cell {
    let mut c = Cell::empty(runs.len());
    let pick = |t: &TestOutcome| (t.decision, t.isolation.clone());
    for r in runs {
        c.broken += usize::from(r.error.is_some());
        let (healthy, faulty): (Vec<&TestOutcome>, Vec<&TestOutcome>) =
            r.tests.iter().partition(|t| !t.fault_present);
        let mut alarmed = false;
        for t in healthy {
            if !t.completed {
                c.aborted += 1;
                continue;
            }
            c.tests += 1;
            if t.decision == Decision::Fault {
                c.fault_tests += 1;
                alarmed = true;
            }
        }
        c.fault_runs += usize::from(alarmed);
        let mut first_fault = None;
        let mut first_isolated = None;
        for (k, t) in faulty.iter().enumerate() {
            if !t.completed {
                c.aborted += 1;
                continue;
            }
            if t.decision == Decision::Fault {
                first_fault.get_or_insert(k + 1);
                if expected.is_some_and(|e| t.isolation.len() == 1 && t.isolation[0] == e) {
                    first_isolated.get_or_insert(k + 1);
                }
            }
        }
        if let Some(k) = first_fault.filter(|&k| k <= within) {
            c.detected += 1;
            c.delay_sum += k;
        }
        c.isolated_within += usize::from(first_isolated.is_some_and(|k| k <= within));
        if let Some(e) = expected {
            let iso = end_naming(&r.tests, &pick);
            c.isolated += usize::from(iso.len() == 1 && iso[0] == e);
        }
    }
    c
}

/// The operating point the reports saw after the change, over the envelope runs' completed
/// tests after commissioning.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OperatingPoint {
    /// Tests after the change with a speed log.
    pub tests: usize,
    /// The largest |mean speed log - scheduled speed| [m/s] (NaN: none).
    pub speed_error_max_mps: f64,
    /// Tests after a declared loading.
    pub declared_tests: usize,
    /// Of those, the tests whose `displacement_nominal_t` is the declared D (within 0.01 %).
    pub declared_seen: usize,
}

/// Checks the scheduled operating point against the reports (speed-log faults excluded).
pub fn operating_point(runs: &[RunOutcome]) -> OperatingPoint {
    let mut p = OperatingPoint {
        tests: 0,
        speed_error_max_mps: f64::NAN,
        declared_tests: 0,
        declared_seen: 0,
    };
    for r in runs {
        let speed = if r.speed_after_mps.is_finite() {
            r.speed_after_mps
        } else {
            r.speed_mps
        };
        for t in r.tests.iter().filter(|t| t.completed) {
            if t.speed_log_mps.is_finite() {
                p.tests += 1;
                let e = (t.speed_log_mps - speed).abs();
                p.speed_error_max_mps = p.speed_error_max_mps.max(e);
            }
            if r.declared_after_t.is_finite() {
                p.declared_tests += 1;
                let rel =
                    (t.displacement_nominal_t - r.declared_after_t).abs() / r.declared_after_t;
                p.declared_seen += usize::from(rel <= 1e-4);
            }
        }
    }
    p
}

/// How far the estimate calibrated to the vessel (`calibrated_estimate`) lies from the truth
/// a healthy ship's crew knows: the speed log, and the declared displacement; over the
/// completed tests after commissioning of a healthy scenario's runs (a heading drift is
/// healthy: it must move neither).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CalibratedFit {
    /// Such tests with a calibrated estimate.
    pub tests: usize,
    /// Such tests without one (completed, after commissioning, no vessel reference).
    pub missing: usize,
    /// The 95th percentile of `|u_cal - u_log|` [m/s] (NaN: no test).
    pub speed_p95_mps: f64,
    /// The 95th percentile of `|D_cal / D_nom - 1|` (NaN: no test).
    pub displacement_p95: f64,
    /// Tests whose 95 % speed interval holds the log, and whose displacement interval holds
    /// the declared displacement (`[speed, displacement]`): the intervals' honesty.
    pub covered: [usize; 2],
    /// Tests after a change of speed with a calibrated estimate.
    pub after_speed_change: usize,
    /// Their 95th percentile of `|u_cal - u_log|` [m/s] (NaN: none).
    pub after_speed_change_p95_mps: f64,
    /// The same two percentiles over each method's tests alone, CLFRT's then HBT's: which
    /// test's reading is the wider (`(tests, speed [m/s], displacement)`; NaN: no test).
    pub by_method: [(usize, f64, f64); 2],
}

/// The calibrated estimates of `runs` against the log and the declared displacement.
pub fn calibrated_fit(runs: &[RunOutcome]) -> CalibratedFit {
    let (mut du, mut dd, mut after) = (Vec::new(), Vec::new(), Vec::new());
    let mut per: [(Vec<f64>, Vec<f64>); 2] = Default::default();
    let mut missing = 0;
    let mut covered = [0; 2];
    for r in runs {
        let after_commissioning =
            (r.tests.iter()).filter(|t| t.completed && t.phase != Phase::Commissioning);
        for t in after_commissioning {
            let [u, d, u_half, d_half] = t.calibrated;
            if !(u.is_finite() && d.is_finite()) {
                missing += 1;
                continue;
            }
            let e = (u - t.speed_log_mps).abs();
            let ed = (d / t.displacement_nominal_t - 1.0).abs();
            du.push(e);
            dd.push(ed);
            let m = &mut per[usize::from(t.method == Method::Hbt)];
            m.0.push(e);
            m.1.push(ed);
            covered[0] += usize::from(e <= u_half);
            covered[1] += usize::from((d - t.displacement_nominal_t).abs() <= d_half);
            if r.speed_after_mps.is_finite() && t.phase == Phase::AfterChange {
                after.push(e);
            }
        }
    }
    CalibratedFit {
        tests: du.len(),
        missing,
        speed_p95_mps: quantile(&mut du, 0.95),
        displacement_p95: quantile(&mut dd, 0.95),
        covered,
        after_speed_change: after.len(),
        after_speed_change_p95_mps: quantile(&mut after, 0.95),
        by_method: per
            .map(|(mut u, mut d)| (u.len(), quantile(&mut u, 0.95), quantile(&mut d, 0.95))),
    }
}

/// The `p` quantile of the finite values (nearest rank; NaN when none).
fn quantile(v: &mut Vec<f64>, p: f64) -> f64 {
    v.retain(|x| x.is_finite());
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    v[((v.len() as f64 * p).ceil() as usize).clamp(1, v.len()) - 1]
}

/// Figures of one commissioning scenario (the methods' tracks together, as the vessel's).
#[derive(Debug, Clone, PartialEq)]
pub struct CommissioningCell {
    /// Runs.
    pub runs: usize,
    /// Completed tests in the flag window.
    pub tests: usize,
    /// Sum of the onsets' tests of the ship (1 is the first commissioning test).
    pub onset_sum: usize,
    /// Runs flagged: a report from the onset (a healthy run: from the first test) through
    /// the tests after commissioning with the track at `alert` or `alarm`, or `fault`.
    pub flagged: usize,
    /// Runs flagged before commissioning ended.
    pub flagged_in_commissioning: usize,
    /// Runs with a `fault` decision in the window.
    pub fault_runs: usize,
    /// Runs with a report saying the commissioning was inconsistent.
    pub inconsistent: usize,
    /// Aborted tests.
    pub aborted: usize,
    /// Runs that ended early.
    pub broken: usize,
}

fn flags(t: &TestOutcome) -> bool {
    t.decision == Decision::Fault
        || matches!(t.state, Some(TrackState::Alert) | Some(TrackState::Alarm))
}

/// Scores commissioning runs (see [`CommissioningCell`]).
pub fn score_commissioning(runs: &[RunOutcome], healthy: bool) -> CommissioningCell {
    let mut c = CommissioningCell {
        runs: runs.len(),
        tests: 0,
        onset_sum: 0,
        flagged: 0,
        flagged_in_commissioning: 0,
        fault_runs: 0,
        inconsistent: 0,
        aborted: 0,
        broken: 0,
    };
    for r in runs {
        c.broken += usize::from(r.error.is_some());
        let all: Vec<&TestOutcome> = r.commissioning.iter().chain(r.tests.iter()).collect();
        let onset = all.iter().position(|t| t.fault_present);
        c.onset_sum += onset.map_or(0, |k| k + 1);
        let from = if healthy {
            0
        } else {
            onset.unwrap_or(all.len())
        };
        let window = all.get(from..).unwrap_or(&[]);
        let (mut flagged, mut early, mut fault) = (false, false, false);
        for t in window {
            if !t.completed {
                c.aborted += 1;
                continue;
            }
            c.tests += 1;
            if flags(t) {
                flagged = true;
                early |= t.phase == Phase::Commissioning;
            }
            fault |= t.decision == Decision::Fault;
        }
        c.flagged += usize::from(flagged);
        c.flagged_in_commissioning += usize::from(early);
        c.fault_runs += usize::from(fault);
        c.inconsistent += usize::from(all.iter().any(|t| t.inconsistent));
    }
    c
}

/// The run's naming at its end: of the last completed test of each method, the latest that
/// names a cause. With one method, the last test's isolation; with the methods in turn, a
/// last test whose own track is back to (or still at) `normal` leaves the other method's
/// naming in force, as the vessel's alarm does.
fn end_naming(
    tests: &[TestOutcome],
    pick: &impl Fn(&TestOutcome) -> (Decision, Vec<Cause>),
) -> Vec<Cause> {
    let mut seen: Vec<Method> = Vec::new();
    for t in tests.iter().rev().filter(|t| t.completed) {
        if seen.contains(&t.method) {
            continue;
        }
        seen.push(t.method);
        let (_, iso) = pick(t);
        if !iso.is_empty() {
            return iso;
        }
    }
    Vec::new()
}

/// `n / d` as a percentage, `-` without a denominator.
pub(super) fn pct(n: usize, d: usize) -> String {
    if d == 0 {
        "-".into()
    } else {
        format!("{:.1} %", 100.0 * n as f64 / d as f64)
    }
}

/// `(median, 99th percentile, max)` of the finite values.
pub(crate) fn quantiles(mut v: Vec<f64>) -> Option<(f64, f64, f64)> {
    v.retain(|x| x.is_finite());
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    let q = |p: f64| v[((v.len() - 1) as f64 * p).round() as usize];
    Some((q(0.5), q(0.99), q(1.0)))
}
