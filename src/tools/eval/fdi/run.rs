//! One run of the suite: a drawn ship and a monitor in lockstep, its tests triggered one
//! after the other, the operating point changed and the fault injected on schedule, and each
//! report read into a [`TestOutcome`].

use super::draw::{draw, DrawnChange};
use super::scenarios::{FdiScenario, Onset, ScenarioSet};
use super::FdiEvalOptions;
use crate::config::Config;
use helmwatch_core::drivers::probe::Lockstep;
use helmwatch_core::estimator::Estimator;
use helmwatch_core::model::SeaState;
use helmwatch_core::monitor::{Monitor, Output};
use helmwatch_core::sim::{Scenario, SimError};
use helmwatch_core::wire::features::ToneFeatures;
use helmwatch_core::wire::residuals::TrackState;
use helmwatch_core::wire::Method;
use helmwatch_core::wire::{Cause, Decision, Features, Outcome, Report};
use std::sync::Arc;

/// Where a test sits in its run's schedule.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Phase {
    /// A commissioning test (a commissioning scenario's fault may be present: see
    /// [`TestOutcome::fault_present`]).
    Commissioning,
    /// A classic scenario's test after commissioning (its fault present, if it has one).
    Test,
    /// After commissioning, before any change and without a fault.
    BeforeChange,
    /// After the change of operating point, before any fault.
    AfterChange,
    /// After commissioning with the fault present.
    AfterFault,
}

impl Phase {
    /// The tag in the outcomes file.
    pub fn name(self) -> &'static str {
        match self {
            Phase::Commissioning => "commissioning",
            Phase::Test => "test",
            Phase::BeforeChange => "before change",
            Phase::AfterChange => "after change",
            Phase::AfterFault => "after fault",
        }
    }
}

/// One test's outcome as the suite reads it.
#[derive(Debug, Clone, PartialEq)]
pub struct TestOutcome {
    /// The test's method.
    pub method: Method,
    /// Completed (else aborted or no report).
    pub completed: bool,
    /// The method's decision.
    pub decision: Decision,
    /// The method's isolation.
    pub isolation: Vec<Cause>,
    /// The baseline's decision (`residuals.baseline.outcome`).
    pub baseline_decision: Decision,
    /// The baseline's isolation.
    pub baseline_isolation: Vec<Cause>,
    /// The method's parameter chi-square (NaN without residuals).
    pub q_param: f64,
    /// The test's sea index.
    pub sea_index: f64,
    /// The CLFRT model fit's chi-square (NaN for HBT).
    pub fit_chi2: f64,
    /// CLFRT: the widest of its tones' 90 % intervals, the gain's (relative) and the
    /// phase's [rad] (`features.tones`; NaN for HBT).
    pub tone_ci90: [f64; 2],
    /// CLFRT: the residual's standard deviations from the test's own tone intervals
    /// (`helmwatch_core::fdi::noise`; NaN for HBT).
    pub meas_sd: [f64; 3],
    /// `residuals.parameters.noise_ratio` (1 when absent, NaN without parameters).
    pub noise_ratio: f64,
    /// The servo check's chi-square (NaN without one).
    pub q_actuator: f64,
    /// The method's normalised speed, displacement and gain residuals (NaN without).
    pub z: [f64; 3],
    /// The raw residuals against the design (`residuals.raw`: `e_u` [m/s], `e_D`, `s_u`
    /// [m/s], `s_D`, `u_log` [m/s], `dD/du_log` [t per m/s], the similarity law's speed slope of
    /// `e_u` and `e_D` [per m/s], `e_b` and its speed slope, `e_a`; NaN without).
    pub raw: [f64; 11],
    /// The test's place in the schedule.
    pub phase: Phase,
    /// Whether the scenario's fault was present during the test.
    pub fault_present: bool,
    /// The mean speed log over the test (`features.speed_log_mps`) [m/s] (NaN without).
    pub speed_log_mps: f64,
    /// HBT: the relay's scale as played (`features.relay_scale`; 1 as designed, NaN for
    /// CLFRT or an aborted test).
    pub relay_scale: f64,
    /// The nominal displacement in force (`residuals.displacement_nominal_t`) [t] (NaN
    /// without).
    pub displacement_nominal_t: f64,
    /// The vessel's track state after the test (`residuals.decision.state`).
    pub state: Option<TrackState>,
    /// The reference the test was measured against (`residuals.reference.kind`, e.g.
    /// `commissioned`, `outside_commissioned_band`).
    pub reference_kind: Option<String>,
    /// Why an aborted test stopped (the report's `reason`; none when completed).
    pub abort_reason: Option<String>,
    /// The report says the commissioning was inconsistent (`commissioning inconsistent` in
    /// its message, or `inconsistent` in `residuals.reference`).
    pub inconsistent: bool,
    /// The parameter causes' costs (`residuals.decision.cause_costs`: speed log,
    /// displacement; NaN without).
    pub cause_costs: [f64; 2],
    /// The test's own standard deviations against the reference in force
    /// (`residuals.parameters`: speed [m/s], displacement [fraction of the nominal], `ln b`;
    /// NaN without).
    pub sigma: [f64; 3],
    /// The reference's predicted offset's standard deviations at the test's point
    /// (`residuals.reference.offset_*_sigma*`, the same units; NaN without).
    pub offset_sigma: [f64; 3],
    /// The estimate calibrated to the vessel (`calibrated_estimate`): speed [m/s],
    /// displacement [t], and the half-widths of their 95 % intervals (NaN without: before
    /// the vessel's reference).
    pub calibrated: [f64; 4],
}

/// One run: the drawn ship and its tests.
#[derive(Debug, Clone, PartialEq)]
pub struct RunOutcome {
    /// Drawn speed [m/s].
    pub speed_mps: f64,
    /// Drawn displacement [t].
    pub displacement_t: f64,
    /// The speed after the change [m/s] (NaN: no speed change).
    pub speed_after_mps: f64,
    /// The declared displacement after the change [t] (NaN: none declared).
    pub declared_after_t: f64,
    /// The commissioning's tests (a commissioning scenario's fault arises among them).
    pub commissioning: Vec<TestOutcome>,
    /// Tests in order after commissioning (classic: after the fault's onset; fewer when the
    /// ship refused or timed out).
    pub tests: Vec<TestOutcome>,
    /// Why the run ended early, if it did.
    pub error: Option<String>,
}

impl RunOutcome {
    /// A run of the drawn ship, its tests to come.
    fn drawn(scenario: &Scenario, change: Option<DrawnChange>) -> Self {
        RunOutcome {
            speed_mps: scenario.speed_mps,
            displacement_t: scenario.displacement_t,
            speed_after_mps: change.and_then(|c| c.speed_mps).unwrap_or(f64::NAN),
            declared_after_t: change.and_then(|c| c.displacement_t).unwrap_or(f64::NAN),
            commissioning: Vec::new(),
            tests: Vec::new(),
            error: None,
        }
    }

    fn broken(error: String) -> Self {
        RunOutcome {
            speed_mps: f64::NAN,
            displacement_t: f64::NAN,
            speed_after_mps: f64::NAN,
            declared_after_t: f64::NAN,
            commissioning: Vec::new(),
            tests: Vec::new(),
            error: Some(error),
        }
    }
}

/// Whether a report says its commissioning was inconsistent.
fn says_inconsistent(r: &Report) -> bool {
    let message = r
        .message
        .to_lowercase()
        .contains("commissioning inconsistent");
    let reference = r
        .residuals
        .reference
        .as_ref()
        .and_then(|x| serde_json::to_string(x).ok())
        .is_some_and(|s| s.to_lowercase().contains("inconsistent"));
    message || reference
}

pub(super) fn outcome_of(r: &Report) -> TestOutcome {
    let res = &r.residuals;
    let bl = res.baseline.as_ref();
    let nan = f64::NAN;
    let p = res.parameters.as_ref();
    TestOutcome {
        method: r.method,
        completed: r.outcome == Outcome::Completed,
        decision: r.decision,
        isolation: r.isolation.clone(),
        baseline_decision: bl.map_or(Decision::Inconclusive, |b| b.outcome),
        baseline_isolation: bl.map(|b| b.isolation.clone()).unwrap_or_default(),
        q_param: p.map_or(nan, |p| p.chi2),
        sea_index: res.sea_index.unwrap_or(nan),
        fit_chi2: res.model_fit.as_ref().map_or(nan, |f| f.chi2),
        tone_ci90: {
            let tones = match &r.features {
                Features::Clfrt(c) => &c.tones[..],
                _ => &[],
            };
            let widest = |f: fn(&ToneFeatures) -> f64| tones.iter().map(f).fold(nan, f64::max);
            [widest(|t| t.gain_ci90_rel), widest(|t| t.phase_ci90_rad)]
        },
        meas_sd: [nan; 3],
        noise_ratio: p.map_or(nan, |p| p.noise_ratio.unwrap_or(1.0)),
        q_actuator: res
            .servo_check
            .as_ref()
            .map_or(nan, |s| s.z_rate * s.z_rate),
        z: p.map_or([nan; 3], |p| {
            [p.z_speed, p.z_displacement, p.z_ln_gain.unwrap_or(nan)]
        }),
        raw: res.raw.as_ref().map_or([nan; 11], |r| {
            [
                r.speed_mps,
                r.displacement,
                r.speed_sigma_mps,
                r.displacement_sigma,
                r.speed_log_mps,
                r.dd_du_t_per_mps,
                r.speed_slope[0],
                r.speed_slope[1],
                r.ln_gain.unwrap_or(nan),
                r.speed_slope[2],
                r.ln_damping.unwrap_or(nan),
            ]
        }),
        phase: Phase::Test,
        fault_present: false,
        speed_log_mps: r.features.speed_log_mps().unwrap_or(nan),
        relay_scale: match &r.features {
            helmwatch_core::wire::Features::Hbt(f) => f.relay_scale.unwrap_or(1.0),
            _ => nan,
        },
        displacement_nominal_t: res.displacement_nominal_t.unwrap_or(nan),
        state: res.decision.as_ref().map(|d| d.state),
        cause_costs: res
            .decision
            .as_ref()
            .and_then(|d| d.cause_costs)
            .map_or([nan; 2], |c| {
                [c.speed_log, c.displacement_or_rudder_effectiveness]
            }),
        sigma: p.map_or([nan; 3], |p| {
            [
                p.speed_sigma_mps,
                p.displacement_sigma_t / res.displacement_nominal_t.unwrap_or(nan),
                p.ln_gain_sigma.unwrap_or(nan),
            ]
        }),
        offset_sigma: res.reference.as_ref().map_or([nan; 3], |x| {
            [
                x.offset_speed_sigma_mps.unwrap_or(nan),
                x.offset_displacement_sigma_t.unwrap_or(nan)
                    / res.displacement_nominal_t.unwrap_or(nan),
                x.offset_ln_gain_sigma.unwrap_or(nan),
            ]
        }),
        calibrated: r.calibrated_estimate.map_or([nan; 4], |c| {
            let half = |[lo, hi]: [f64; 2]| 0.5 * (hi - lo);
            [
                c.speed_mps,
                c.displacement_t,
                half(c.speed_interval_mps),
                half(c.displacement_interval_t),
            ]
        }),
        inconsistent: says_inconsistent(r),
        reference_kind: res
            .reference
            .as_ref()
            .and_then(|x| serde_json::to_value(x).ok())
            .and_then(|v| v.get("kind").and_then(|k| k.as_str()).map(String::from)),
        abort_reason: (r.outcome != Outcome::Completed)
            .then(|| r.reason.clone())
            .flatten(),
    }
}

/// The run's schedule in tests of the ship (0 is the first test).
struct Schedule {
    /// Commissioning's tests.
    commissioning: usize,
    /// Tests in all.
    total: usize,
    /// The change of operating point comes before this test.
    change_at: Option<usize>,
    /// The late faults arise before this test.
    inject_at: usize,
}

fn schedule(
    sc: &FdiScenario,
    commissioning: usize,
    after: usize,
    onset: Option<usize>,
    onset_after: usize,
) -> Schedule {
    let window = sc.window_tests.unwrap_or(0);
    match (sc.group, sc.onset) {
        (ScenarioSet::Commissioning, _) => {
            let at = onset.unwrap_or(1).saturating_sub(1).min(commissioning);
            Schedule {
                commissioning,
                // The confirmation: as many tests again (`changepoint::confirm`).
                total: 2 * commissioning,
                change_at: sc.change.map(|_| at),
                inject_at: at,
            }
        }
        // A classic fault, or an envelope's change (and its fault with or after it), may
        // arise later (`--onset-after`), the vessel learning its healthy tests meanwhile.
        (_, Onset::AfterChange(n)) => Schedule {
            commissioning,
            total: commissioning + onset_after + n + after.max(window),
            change_at: sc.change.map(|_| commissioning + onset_after),
            inject_at: commissioning + onset_after + n,
        },
        _ => Schedule {
            commissioning,
            total: commissioning + onset_after + after.max(window),
            change_at: sc.change.map(|_| commissioning + onset_after),
            inject_at: commissioning + onset_after,
        },
    }
}

/// Runs one run of `methods` (in turn) on the drawn ship: `fdi.commissioning-tests` tests
/// of each method (the heading drift, when the scenario has one, from the start), then
/// `o.tests` tests of each. Classic scenarios: the fault arises when commissioning ends, or
/// `o.onset_after` tests of the ship later.
/// Envelope scenarios: the operating point changes when commissioning ends, the fault arises
/// with it or `n` tests of the ship later, and at least the detection window's tests follow
/// it. Commissioning scenarios: the fault arises before commissioning test `k` of the ship,
/// and the confirmation's tests follow commissioning (as many as commissioning's: the
/// reference's sample is tested for a change until it holds twice the commissioning tests).
#[allow(clippy::too_many_arguments)]
pub fn run_one(
    cfg: &Config,
    sc: &FdiScenario,
    sea: SeaState,
    methods: &[Method],
    seed: u64,
    estimator: &Arc<Estimator>,
    o: &FdiEvalOptions,
    corner: Option<usize>,
) -> RunOutcome {
    let drawn = match draw(cfg, sc, sea, seed, corner) {
        Ok(x) => x,
        Err(e) => return RunOutcome::broken(e),
    };
    let (scenario, cfg, late) = (&drawn.scenario, &drawn.cfg, &drawn.late);
    let change = drawn.change;
    let mut run = RunOutcome::drawn(scenario, change);
    let Some(&first) = methods.first() else {
        run.error = Some("no method to run".into());
        return run;
    };
    // Commissioning and the tests after it, of each method in turn.
    let plan = schedule(
        sc,
        cfg.fdi.commissioning_tests as usize * methods.len(),
        o.tests * methods.len(),
        drawn.onset_test,
        o.onset_after,
    );
    let classic = sc.group == ScenarioSet::Classic;
    // A classic fault is present from the start when commissioning is off.
    let mut injected = sc.fault.is_some() && late.is_empty();
    let mut changed = false;
    let mut ls = match lockstep(cfg, scenario, estimator) {
        Ok(ls) => ls,
        Err(e) => {
            run.error = Some(e);
            return run;
        }
    };
    let mut out = Vec::new();
    let mut next = ls.time_s() + o.warmup_s;
    let max_test_s = cfg.safety.max_test_duration_s + 120.0;
    // Commissioning ends when the vessel's does: as soon as every method has its reference
    // (`fdi.commissioning-tests` is the latest; the sample may resolve the design's faults
    // sooner), and it goes on until then (an aborted test is no commissioning test), for at
    // most as many tests of the ship again. The schedule after it moves with it. Not in the
    // commissioning set, whose faults arise inside it.
    let mut extra: isize = 0;
    loop {
        let raw = run.commissioning.len() + run.tests.len();
        if sc.group != ScenarioSet::Commissioning {
            extra = stretch_commissioning(extra, raw, plan.commissioning, || {
                methods.iter().all(|&m| ls.monitor.method_commissioned(m))
            });
        }
        let method = methods.get(raw % methods.len()).copied().unwrap_or(first);
        let done = (raw as isize - extra).max(0) as usize;
        if done >= plan.total {
            break;
        }
        if plan.change_at == Some(done) && !changed {
            changed = true;
            if let Err(e) = apply_change(&mut ls, change, cfg) {
                run.error = Some(format!("the operating point cannot change: {e}"));
                return run;
            }
        }
        if done == plan.inject_at && !injected && !late.is_empty() {
            injected = true;
            for f in late {
                ls.ship.inject(*f);
            }
        }
        ls.run_until(next, &mut out);
        out.clear();
        let Some(t_trigger) = trigger(&mut ls, method, o.warmup_s, &mut out) else {
            run.error = Some("the monitor refused the test".into());
            return run;
        };
        let Some(r) = await_report(&mut ls, t_trigger + max_test_s, &mut out) else {
            run.error = Some("no report in time".into());
            return run;
        };
        let phase = phase_of(done, &plan, classic, injected, changed);
        let t = read_report(&r, estimator, phase, injected);
        if done < plan.commissioning {
            run.commissioning.push(t);
        } else {
            run.tests.push(t);
        }
        next = ls.time_s() + o.gap_s;
    }
    run
}

/// The drawn ship and a monitor (with the design's multisine, when it has one, and the suite's
/// estimator) in lockstep.
fn lockstep(
    cfg: &Config,
    scenario: &Scenario,
    estimator: &Arc<Estimator>,
) -> Result<Lockstep, String> {
    let ms = Monitor::design_multisine(&cfg.core()).ok();
    Lockstep::with_parts(
        &cfg.core(),
        &cfg.sim(),
        scenario,
        ms,
        Some(estimator.clone()),
    )
    .map_err(|e| e.to_string())
}

/// Changes the ship's operating point as drawn (speed, declared loading, sea; each when
/// drawn, in that order).
fn apply_change(
    ls: &mut Lockstep,
    change: Option<DrawnChange>,
    cfg: &Config,
) -> Result<(), SimError> {
    let c = change.unwrap_or(DrawnChange {
        speed_mps: None,
        displacement_t: None,
        sea: None,
    });
    c.speed_mps
        .map_or(Ok(()), |u| ls.ship.set_speed_mps(u))
        .and_then(|()| {
            c.displacement_t
                .map_or(Ok(()), |d| ls.ship.set_loading_t(d))
        })
        .and_then(|()| {
            c.sea
                .map_or(Ok(()), |s| ls.ship.set_sea(cfg.sim().sea.levels(s)))
        })
}

/// Triggers `method`, retried each second for up to one warm-up (the course must be steady).
/// The time it was accepted, or `None` when the monitor kept refusing.
fn trigger(ls: &mut Lockstep, method: Method, warmup_s: f64, out: &mut Vec<Output>) -> Option<f64> {
    let give_up = ls.time_s() + warmup_s;
    loop {
        if ls.trigger(method).accepted {
            break Some(ls.time_s());
        }
        if ls.time_s() > give_up {
            break None;
        }
        let t = ls.time_s();
        ls.run_until(t + 1.0, out);
        out.clear();
    }
}

/// Ticks until the test's report (the last one of a tick, if several), or `None` at `until_s`.
fn await_report(ls: &mut Lockstep, until_s: f64, out: &mut Vec<Output>) -> Option<Box<Report>> {
    let mut report = None;
    while report.is_none() && ls.time_s() < until_s {
        ls.tick(out, false);
        for x in out.drain(..) {
            if let Output::Report(r) = x {
                report = Some(r);
            }
        }
    }
    report
}

/// The commissioning's stretch: `extra` tests of the ship past its planned end (negative:
/// it ended sooner), given `raw` tests so far, its planned `end` and whether every method is
/// `commissioned` now. It ends as soon as every method has its reference and goes on, one test
/// at a time, while one has none, for at most `end` tests more.
fn stretch_commissioning(
    extra: isize,
    raw: usize,
    end: usize,
    commissioned: impl Fn() -> bool,
) -> isize {
    let planned = raw as isize - extra;
    let end = end as isize;
    if planned < end && raw > 0 && commissioned() {
        raw as isize - end
    } else if planned == end && extra < end && !commissioned() {
        extra + 1
    } else {
        extra
    }
}

/// A test's place in the schedule: `done` tests of the ship before it.
fn phase_of(done: usize, plan: &Schedule, classic: bool, injected: bool, changed: bool) -> Phase {
    if done < plan.commissioning {
        Phase::Commissioning
    } else if classic {
        Phase::Test
    } else if injected {
        Phase::AfterFault
    } else if changed {
        Phase::AfterChange
    } else {
        Phase::BeforeChange
    }
}

/// A report read into a [`TestOutcome`], with its measurement's standard deviations, its
/// `phase` and whether the fault was present.
fn read_report(
    r: &Report,
    estimator: &Arc<Estimator>,
    phase: Phase,
    fault_present: bool,
) -> TestOutcome {
    let mut t = outcome_of(r);
    if let Some(c) = helmwatch_core::fdi::raw::measurement_cov(
        r.method,
        &r.features,
        estimator,
        &mut estimator.scratch(),
        t.displacement_nominal_t,
    ) {
        t.meas_sd = c.variances().map(f64::sqrt);
    }
    t.fault_present = fault_present;
    t.phase = phase;
    t
}
