//! `helmwatch eval --fdi`: the seeded scenario suite of the fault decision.
//!
//! A *run* is one simulated ship, `(u, D)` drawn from the run's seed, the configuration's
//! nominal displacement set to that `D` (the operator's reference), a fault present from
//! `t = 0`, and `tests` tests of one method in a row, each triggered after a warm-up
//! (`warmup_s`, so the autopilot and any drift transient settle) and a short gap after the
//! previous report. The monitor core does everything - features, estimate, residuals,
//! decision, isolation - exactly as in the daemon; the suite only reads the reports
//! (`decision`, `isolation`, and `residuals.baseline` for the equation-error baseline, which
//! runs through the same rule on the same records).
//!
//! | scenario | fault | (u, D) drawn from |
//! |---|---|---|
//! | nominal | none | the full range |
//! | nominal, drift | heading drift of 0.25..1 deg/min, either sign | the full range |
//! | displacement +-10 %, +-20 % | `displacement_pct` | D in [5000, 8333] t, so D (1 +- 0.2) stays in range |
//! | speed log +0.5 m/s | `speed_log_bias_mps:0.5` | u in [4, 9.5] m/s |
//! | servo 2 deg/s | `servo_rate_deg_s:2` | the full range |
//! | rudder effectiveness -30 % | `rudder_effectiveness:0.7` | D in [4000, 7000] t (D / 0.7 in range) |
//!
//! Figures per method, sea and scenario: the false-alarm rate (tests whose decision is
//! `fault`, and runs with any), the detection rate within `detect_within` tests and the mean
//! delay (in tests, the first test is 1), and the correct isolation rate (the last test's
//! isolation is exactly the expected cause; for the speed log also "detected and isolated
//! within N tests").
//!
//! With `in_turn` the methods take turns on each ship, as the daemon runs them: the
//! commissioning and the tests count tests of each method, and so do the windows (within N
//! tests of each method: N times the number of methods tests of the ship). Each report is
//! the vessel's (its alarm is the worse track's, its naming the vessel's: `crate::core::fdi`).

use crate::config::Config;
use crate::core::estimator::Estimator;
use crate::core::model::SeaState;
use crate::core::monitor::{Monitor, Output};
use crate::core::wire::Method;
use crate::core::wire::{Cause, Decision, Outcome, Report};
use crate::drivers::probe::Lockstep;
use crate::sim::{Fault, Scenario};
use crate::tools::training::database::par_map;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::sync::Arc;

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
    /// Range of u [m/s] and D [t] to draw from (`None`: the configured range).
    pub speed_mps: Option<[f64; 2]>,
    /// As above for D.
    pub displacement_t: Option<[f64; 2]>,
}

/// The scenarios of the suite, in print order.
pub fn scenarios() -> Vec<FdiScenario> {
    let s = |name, fault, drift, expected, speed_mps, displacement_t| FdiScenario {
        name,
        fault,
        drift,
        expected,
        speed_mps,
        displacement_t,
    };
    let d_pm20 = Some([5000.0, 8333.0]);
    vec![
        s("nominal", None, false, None, None, None),
        s("nominal, drift <= 1 deg/min", None, true, None, None, None),
        s(
            "displacement +10 %",
            Some("displacement_pct:10@0"),
            false,
            Some(Cause::DisplacementOrRudderEffectiveness),
            None,
            d_pm20,
        ),
        s(
            "displacement -10 %",
            Some("displacement_pct:-10@0"),
            false,
            Some(Cause::DisplacementOrRudderEffectiveness),
            None,
            d_pm20,
        ),
        s(
            "displacement +20 %",
            Some("displacement_pct:20@0"),
            false,
            Some(Cause::DisplacementOrRudderEffectiveness),
            None,
            d_pm20,
        ),
        s(
            "displacement -20 %",
            Some("displacement_pct:-20@0"),
            false,
            Some(Cause::DisplacementOrRudderEffectiveness),
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
            Some(Cause::DisplacementOrRudderEffectiveness),
            None,
            Some([4000.0, 7000.0]),
        ),
    ]
}

/// Options of the suite.
#[derive(Debug, Clone)]
pub struct FdiEvalOptions {
    /// Seed of the run draws and simulations.
    pub seed: u64,
    /// Runs per fault scenario.
    pub runs: usize,
    /// Runs per nominal scenario.
    pub nominal_runs: usize,
    /// Tests per run.
    pub tests: usize,
    /// Ship time before the first trigger [s].
    pub warmup_s: f64,
    /// Ship time between a report and the next trigger [s].
    pub gap_s: f64,
    /// Methods.
    pub methods: Vec<Method>,
    /// Sea states.
    pub seas: Vec<SeaState>,
    /// Worker threads.
    pub threads: usize,
    /// Run the family of real ships (`eval --fdi --family`) instead of the first-order ship.
    pub family: bool,
    /// With `family`: only members whose name contains this.
    pub member: Option<String>,
    /// Write every test's outcome as JSON lines here (for analysis of the residuals).
    pub outcomes: Option<std::path::PathBuf>,
    /// The methods take turns on each ship (as the daemon runs them) instead of one method
    /// per run: `tests` tests of each, windows counted in tests of each method.
    pub in_turn: bool,
}

impl Default for FdiEvalOptions {
    fn default() -> Self {
        Self {
            seed: 1,
            runs: 60,
            nominal_runs: 60,
            tests: 4,
            warmup_s: 1800.0,
            gap_s: 600.0,
            methods: vec![Method::Clfrt, Method::Hbt],
            seas: vec![SeaState::Calm, SeaState::Moderate],
            threads: 1,
            family: false,
            member: None,
            outcomes: None,
            in_turn: false,
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
    /// The servo check's chi-square (NaN without one).
    pub q_actuator: f64,
    /// The method's normalised speed and displacement residuals (NaN without).
    pub z: [f64; 2],
    /// The raw residuals against the design (`residuals.raw`: `e_u` [m/s], `e_D`, `s_u`
    /// [m/s], `s_D`, `u_log` [m/s], `dD/du_log` [t per m/s]; NaN without).
    pub raw: [f64; 6],
}

/// One run: the drawn ship and its tests.
#[derive(Debug, Clone, PartialEq)]
pub struct RunOutcome {
    /// Drawn speed [m/s].
    pub speed_mps: f64,
    /// Drawn displacement [t].
    pub displacement_t: f64,
    /// The commissioning's tests, before the fault appears.
    pub commissioning: Vec<TestOutcome>,
    /// Tests in order after the fault's onset (fewer when the ship refused or timed out).
    pub tests: Vec<TestOutcome>,
    /// Why the run ended early, if it did.
    pub error: Option<String>,
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

fn outcome_of(r: &Report) -> TestOutcome {
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
        q_actuator: res
            .servo_check
            .as_ref()
            .map_or(nan, |s| s.z_rate * s.z_rate),
        z: p.map_or([nan; 2], |p| [p.z_speed, p.z_displacement]),
        raw: res.raw.as_ref().map_or([nan; 6], |r| {
            [
                r.speed_mps,
                r.displacement,
                r.speed_sigma_mps,
                r.displacement_sigma,
                r.speed_log_mps,
                r.dd_du_t_per_mps,
            ]
        }),
    }
}

/// Draws the run's ship and fault list: `(scenario, configuration, faults that appear after
/// commissioning)`. With `corner = Some(k)` the ship sits at corner `k % 4` of the
/// scenario's (u, D) box (low/high speed, low/high displacement) instead of a random point.
fn draw(
    cfg: &Config,
    sc: &FdiScenario,
    sea: SeaState,
    seed: u64,
    corner: Option<usize>,
) -> Result<(Scenario, Config, Vec<Fault>), String> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let [u_lo, u_hi] = sc.speed_mps.unwrap_or(cfg.ship.speed_range_mps);
    let [d_lo, d_hi] = sc.displacement_t.unwrap_or(cfg.ship.displacement_range_t);
    let mut u = rng.gen_range(u_lo..=u_hi);
    let mut d = rng.gen_range(d_lo..=d_hi);
    if let Some(k) = corner {
        u = if k % 2 == 0 { u_lo } else { u_hi };
        d = if (k / 2) % 2 == 0 { d_lo } else { d_hi };
    }
    let mut faults = Vec::new();
    let mut late = Vec::new();
    if let Some(f) = sc.fault {
        let f = f.parse::<Fault>().map_err(|e| e.to_string())?;
        // With commissioning, the fault appears once the vessel is commissioned.
        if cfg.fdi.commissioning_tests > 0 {
            late.push(f);
        } else {
            faults.push(f);
        }
    }
    if sc.drift {
        let v = rng.gen_range(0.25..=1.0) * if rng.gen_bool(0.5) { 1.0 } else { -1.0 };
        let spec = format!("heading_drift_deg_per_min:{v}@0");
        faults.push(spec.parse::<Fault>().map_err(|e| e.to_string())?);
    }
    let mut cfg = cfg.clone();
    cfg.ship.nominal_displacement_t = d;
    cfg.scheduler.enabled = false;
    Ok((
        Scenario {
            speed_mps: u,
            displacement_t: d,
            sea,
            faults,
            seed: rng.gen(),
        },
        cfg,
        late,
    ))
}

/// Runs one run of `method` on the drawn ship: `fdi.commissioning-tests` tests on the healthy
/// ship (the heading drift, when the scenario has one, from the start), then the scenario's
/// fault, then `o.tests` tests.
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
    let (scenario, cfg, late) = match draw(cfg, sc, sea, seed, corner) {
        Ok(x) => x,
        Err(e) => {
            return RunOutcome {
                speed_mps: f64::NAN,
                displacement_t: f64::NAN,
                commissioning: Vec::new(),
                tests: Vec::new(),
                error: Some(e),
            }
        }
    };
    let mut run = RunOutcome {
        speed_mps: scenario.speed_mps,
        displacement_t: scenario.displacement_t,
        commissioning: Vec::new(),
        tests: Vec::new(),
        error: None,
    };
    let Some(&first) = methods.first() else {
        run.error = Some("no method to run".into());
        return run;
    };
    // Commissioning and the tests after it, of each method in turn.
    let commissioning = cfg.fdi.commissioning_tests as usize * methods.len();
    let tests = o.tests * methods.len();
    let mut injected = false;
    let ms = Monitor::design_multisine(&cfg.core()).ok();
    let mut ls = match Lockstep::with_parts(
        &cfg.core(),
        &cfg.sim(),
        &scenario,
        ms,
        Some(estimator.clone()),
    ) {
        Ok(ls) => ls,
        Err(e) => {
            run.error = Some(e.to_string());
            return run;
        }
    };
    let mut out = Vec::new();
    let mut next = ls.time_s() + o.warmup_s;
    let max_test_s = cfg.safety.max_test_duration_s + 120.0;
    while run.tests.len() < tests {
        let done = run.commissioning.len() + run.tests.len();
        let method = methods.get(done % methods.len()).copied().unwrap_or(first);
        if run.commissioning.len() == commissioning && !injected {
            injected = true;
            for f in &late {
                ls.ship.inject(*f);
            }
        }
        ls.run_until(next, &mut out);
        out.clear();
        // Trigger, retried each second for up to one warm-up (the course must be steady).
        let give_up = ls.time_s() + o.warmup_s;
        let t_trigger = loop {
            if ls.trigger(method).accepted {
                break Some(ls.time_s());
            }
            if ls.time_s() > give_up {
                break None;
            }
            let t = ls.time_s();
            ls.run_until(t + 1.0, &mut out);
            out.clear();
        };
        let Some(t_trigger) = t_trigger else {
            run.error = Some("the monitor refused the test".into());
            return run;
        };
        let mut report = None;
        while report.is_none() && ls.time_s() < t_trigger + max_test_s {
            ls.tick(&mut out, false);
            for x in out.drain(..) {
                if let Output::Report(r) = x {
                    report = Some(r);
                }
            }
        }
        let Some(r) = report else {
            run.error = Some("no report in time".into());
            return run;
        };
        if run.commissioning.len() < commissioning {
            run.commissioning.push(outcome_of(&r));
        } else {
            run.tests.push(outcome_of(&r));
        }
        next = ls.time_s() + o.gap_s;
    }
    run
}

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

/// Scores the runs of one scenario for the method (`baseline = false`) or the baseline.
pub fn score(runs: &[RunOutcome], expected: Option<Cause>, within: usize, baseline: bool) -> Cell {
    let mut c = Cell {
        runs: runs.len(),
        tests: 0,
        fault_tests: 0,
        fault_runs: 0,
        detected: 0,
        delay_sum: 0,
        isolated: 0,
        isolated_within: 0,
        aborted: 0,
        broken: 0,
    };
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
        for (k, t) in before.iter().chain(r.tests.iter()).enumerate() {
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

fn pct(n: usize, d: usize) -> String {
    if d == 0 {
        "-".into()
    } else {
        format!("{:.1} %", 100.0 * n as f64 / d as f64)
    }
}

/// One row group of a table: a label, the scenario and the configuration its ships run.
struct Row<'a> {
    label: String,
    scenario: &'a FdiScenario,
    cfg: Config,
    /// Where the row's scenario sits in the seed space.
    index: usize,
}

/// Writes one JSON line per test of `runs` (commissioning and after it) for analysis.
fn write_outcomes(w: &mut impl std::io::Write, label: &str, sea: SeaState, runs: &[RunOutcome]) {
    let nan_null = |x: f64| x.is_finite().then_some(x);
    for (k, r) in runs.iter().enumerate() {
        let phases = [("commissioning", &r.commissioning), ("test", &r.tests)];
        for (phase, tests) in phases {
            for (i, t) in tests.iter().enumerate() {
                let line = serde_json::json!({
                    "row": label,
                    "method": t.method.name(),
                    "sea": sea.name(),
                    "run": k,
                    "speed_mps": nan_null(r.speed_mps),
                    "displacement_t": nan_null(r.displacement_t),
                    "phase": phase,
                    "test": i,
                    "completed": t.completed,
                    "decision": t.decision,
                    "isolation": t.isolation,
                    "chi2": nan_null(t.q_param),
                    "chi2_actuator": nan_null(t.q_actuator),
                    "sea_index": nan_null(t.sea_index),
                    "z": t.z.map(nan_null),
                    "raw": t.raw.map(nan_null),
                });
                if let Err(e) = writeln!(w, "{line}") {
                    eprintln!("outcomes not written: {e}");
                    return;
                }
            }
        }
    }
}

/// The scenarios of the family suite: healthy with drift, then the faults of the acceptance.
pub fn family_scenarios() -> Vec<FdiScenario> {
    let wanted = [
        "nominal, drift <= 1 deg/min",
        "displacement +10 %",
        "displacement -10 %",
        "speed log +0.5 m/s",
        "servo rate 2 deg/s",
    ];
    scenarios()
        .into_iter()
        .filter(|s| wanted.contains(&s.name))
        .collect()
}

/// Runs the suite and prints its tables (markdown) to standard output. With `o.family`,
/// every member of the family of real ships (but the first-order ship) runs the family
/// scenarios, half its runs at the corners of the (u, D) box.
pub fn run_suite(cfg: &Config, estimator: Arc<Estimator>, o: &FdiEvalOptions) {
    let scs = if o.family {
        family_scenarios()
    } else {
        scenarios()
    };
    let mut outcomes = o
        .outcomes
        .as_ref()
        .and_then(|p| match std::fs::File::create(p) {
            Ok(f) => Some(std::io::BufWriter::new(f)),
            Err(e) => {
                eprintln!("cannot write {}: {e}; no outcomes written", p.display());
                None
            }
        });
    let mut rows = Vec::new();
    if o.family {
        let members = crate::sim::config::family();
        for (mi, m) in members.iter().enumerate().skip(1) {
            if o.member
                .as_ref()
                .is_some_and(|w| !m.name.contains(w.as_str()))
            {
                continue;
            }
            let mut c = cfg.clone();
            m.apply(&mut c.structure, &mut c.autopilot);
            for (si, sc) in scs.iter().enumerate() {
                rows.push(Row {
                    label: format!("{}: {}", m.name, sc.name),
                    scenario: sc,
                    cfg: c.clone(),
                    index: mi * 16 + si,
                });
            }
        }
    } else {
        for (si, sc) in scs.iter().enumerate() {
            rows.push(Row {
                label: sc.name.to_string(),
                scenario: sc,
                cfg: cfg.clone(),
                index: si,
            });
        }
    }
    println!(
        "# FDI scenario suite{}: seed {}, {} runs per fault scenario, {} per nominal one, {} commissioning tests then {} tests per run",
        if o.family { " on the family of real ships" } else { "" },
        o.seed, o.runs, o.nominal_runs, cfg.fdi.commissioning_tests, o.tests
    );
    let f = &cfg.fdi;
    let limits = crate::core::fdi::decision::Limits::new(
        f.false_alarms_per_year,
        cfg.scheduler.interval_s + cfg.scheduler.steady_time_s,
        f.window_tests,
    );
    println!(
        "decision: window GLR over {} tests of the ship, {} false alarms per vessel-year ({:.2e} per test): limits {:.1} (one method) / {:.1} (both), servo {:.2}",
        f.window_tests,
        f.false_alarms_per_year,
        limits.alpha_test,
        limits.param[0],
        limits.param[1],
        limits.servo
    );
    let schedules: Vec<Vec<Method>> = if o.in_turn {
        vec![o.methods.clone()]
    } else {
        o.methods.iter().map(|m| vec![*m]).collect()
    };
    for methods in &schedules {
        // Windows count tests of each method: with k methods in turn, k times the ship's.
        let turns = methods.len().max(1);
        let names: Vec<String> = methods.iter().map(|m| m.name().to_uppercase()).collect();
        for &sea in &o.seas {
            println!();
            if turns > 1 {
                println!(
                    "## {} in turn in a {} sea (windows of N tests of each method: {turns} N tests of the ship; delay in tests of the ship)",
                    names.join(" and "),
                    sea.name()
                );
            } else {
                println!("## {} in a {} sea", names.join(""), sea.name());
            }
            println!();
            println!("| scenario | who | runs | tests | false alarms (tests / runs) | detected <= 2 | detected <= 3 | mean delay | detected <= 4 | isolated (last test) | isolated <= 2 | isolated <= 3 | isolated <= 4 | aborted |");
            println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|");
            let mut notes = Vec::new();
            for (si, row) in rows.iter().enumerate() {
                let sc = row.scenario;
                let rcfg = &row.cfg;
                let n = if sc.expected.is_none() {
                    o.nominal_runs
                } else {
                    o.runs
                };
                let base = o
                    .seed
                    .wrapping_mul(1_000_003)
                    .wrapping_add((row.index as u64) << 20)
                    .wrapping_add(u64::from(sea == SeaState::Moderate) << 16);
                let runs = par_map(n, o.threads, |k| {
                    let corner = (o.family && k % 2 == 0).then_some(k / 2);
                    run_one(
                        rcfg,
                        sc,
                        sea,
                        methods,
                        base + k as u64,
                        &estimator,
                        o,
                        corner,
                    )
                });
                if let Some(w) = outcomes.as_mut() {
                    write_outcomes(w, &row.label, sea, &runs);
                }
                {
                    let all = || runs.iter().flat_map(|r| r.tests.iter());
                    let zs: Vec<[f64; 2]> =
                        all().map(|t| t.z).filter(|z| z[0].is_finite()).collect();
                    if !zs.is_empty() {
                        let n = zs.len() as f64;
                        let m = |i: usize| zs.iter().map(|z| z[i]).sum::<f64>() / n;
                        let sd = |i: usize| {
                            let mi = m(i);
                            (zs.iter().map(|z| (z[i] - mi).powi(2)).sum::<f64>() / n).sqrt()
                        };
                        let (m0, m1) = (m(0), m(1));
                        let cov = zs.iter().map(|z| (z[0] - m0) * (z[1] - m1)).sum::<f64>() / n;
                        notes.push(format!(
                            "{}: z_speed mean {:+.2} sd {:.2}, z_displacement mean {:+.2} sd {:.2}, correlation {:+.2}",
                            row.label,
                            m0,
                            sd(0),
                            m1,
                            sd(1),
                            cov / (sd(0) * sd(1))
                        ));
                    }
                }
                if sc.expected.is_none() {
                    let all = || runs.iter().flat_map(|r| r.tests.iter());
                    for (what, v) in [
                        ("chi2", all().map(|t| t.q_param).collect::<Vec<_>>()),
                        (
                            "commissioning chi2",
                            runs.iter()
                                .flat_map(|r| r.commissioning.iter())
                                .map(|t| t.q_param)
                                .collect(),
                        ),
                        ("servo-check chi2", all().map(|t| t.q_actuator).collect()),
                        ("model-fit chi2", all().map(|t| t.fit_chi2).collect()),
                        ("sea index", all().map(|t| t.sea_index).collect()),
                    ] {
                        if let Some((m, p99, mx)) = quantiles(v) {
                            notes.push(format!(
                                "{}: {what} median {m:.4}, 99th percentile {p99:.4}, max {mx:.4}",
                                row.label
                            ));
                        }
                    }
                }
                // The baseline's rows only when its estimate exists (features.baseline).
                let has_baseline = runs
                    .iter()
                    .flat_map(|r| r.tests.iter())
                    .any(|t| t.baseline_decision != Decision::Inconclusive);
                if !has_baseline && si == 0 {
                    notes.push(
                        "baseline: no equation-error estimate in the features, no rows".into(),
                    );
                }
                let whos: &[(&str, bool)] = if has_baseline {
                    &[("ours", false), ("baseline", true)]
                } else {
                    &[("ours", false)]
                };
                for &(who, baseline) in whos {
                    let c2 = score(&runs, sc.expected, 2 * turns, baseline);
                    let c3 = score(&runs, sc.expected, 3 * turns, baseline);
                    let c4 = score(&runs, sc.expected, 4 * turns, baseline);
                    let nominal = sc.expected.is_none();
                    let fa = if nominal {
                        format!(
                            "{} / {} ({})",
                            c2.fault_tests,
                            c2.fault_runs,
                            pct(c2.fault_tests, c2.tests)
                        )
                    } else {
                        "-".into()
                    };
                    let dash = || -> [String; 8] { std::array::from_fn(|_| "-".to_string()) };
                    let [det2, det3, delay, det4, iso, iso2, iso3, iso4] = if nominal {
                        dash()
                    } else {
                        [
                            pct(c2.detected, c2.runs),
                            pct(c3.detected, c3.runs),
                            if c4.detected > 0 {
                                format!("{:.2}", c4.delay_sum as f64 / c4.detected as f64)
                            } else {
                                "-".into()
                            },
                            pct(c4.detected, c4.runs),
                            pct(c4.isolated, c4.runs),
                            pct(c2.isolated_within, c2.runs),
                            pct(c3.isolated_within, c3.runs),
                            pct(c4.isolated_within, c4.runs),
                        ]
                    };
                    println!(
                        "| {} | {who} | {} | {} | {fa} | {det2} | {det3} | {delay} | {det4} | {iso} | {iso2} | {iso3} | {iso4} | {}{} |",
                        row.label,
                        c2.runs,
                        c2.tests,
                        c2.aborted,
                        if c2.broken > 0 {
                            format!(" ({} runs broken)", c2.broken)
                        } else {
                            String::new()
                        }
                    );
                }
            }
            println!();
            for n in notes {
                println!("- {n}");
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
            q_actuator: f64::NAN,
            z: [0.5, -1.0],
            raw: [raw0, -0.02, 0.06, 0.002, 7.0, 1900.0],
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
        let run = |tests| RunOutcome {
            speed_mps: 7.0,
            displacement_t: 6000.0,
            commissioning: Vec::new(),
            tests,
            error: None,
        };
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
    #[test]
    fn outcomes_are_one_json_line_per_test() {
        let runs = vec![RunOutcome {
            speed_mps: 7.0,
            displacement_t: 6000.0,
            commissioning: vec![outcome(Decision::Nominal, f64::NAN)],
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
        assert!(lines[0]["raw"][0].is_null());
        assert!(lines[0]["chi2_actuator"].is_null());
        assert_eq!(lines[1]["phase"], "test");
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
}
