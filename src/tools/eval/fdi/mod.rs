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
//! | displacement +-10 %, +-20 %, +-12 % | `displacement_pct` | D in [5000, 8333] t, so D (1 +- 0.2) stays in range |
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
//! tests of each method: N times the number of methods tests of the ship). Commissioning
//! (classic and envelope sets) goes on past its tests while a method has no reference (an
//! aborted test is no commissioning test), for at most as many tests of the ship again: what
//! follows "after commissioning" follows the vessel's commissioning. Each report is
//! the vessel's (its alarm is the worse track's, its naming the vessel's: `helmwatch_core::fdi`).
//!
//! `scenarios` (`--scenarios`) selects the sets: the classic ones above (the default), the
//! envelope's and the commissioning's (all listed in the module `scenarios`).
//!
//! | set | what changes | figures |
//! |---|---|---|
//! | envelope, healthy | when commissioning ends, the speed by +-1.5 or +-2 m/s (a sign that keeps it in range) and/or the declared loading by -30..+20 % (`Ship::set_loading_t`) | false alarms over every test after commissioning |
//! | envelope, faults | a speed change of 1.5 m/s, then D +-10 % 4 tests of the ship later (window 3 tests of the ship), or D +-25 % with the change (window 2) | false alarms before the onset, detection and isolation within the window |
//! | commissioning | D +-12 %, speed log +0.5 m/s, servo 2 deg/s arising before commissioning test k of the ship (k in 2..6), and a healthy commissioning | runs flagged (track alert or alarm, or `fault`) from the onset through the confirmation (as many tests of the ship after commissioning as it had); false flags; "commissioning inconsistent" |
//!
//! Files: `scenarios` (the scenarios), `draw` (the draw of a run), `run` (one run), `score` (the
//! figures), `tables` (printing), `outcomes` (the JSON-lines file).

pub mod ablate;
pub mod compare;
pub mod draw;
mod outcomes;
pub mod run;
pub mod scenarios;
pub mod score;
mod tables;

pub use run::{run_one, Phase, RunOutcome, TestOutcome};
pub use scenarios::{
    commissioning_scenarios, envelope_scenarios, family_scenarios, scenarios, FdiScenario,
    ScenarioSet,
};
pub(crate) use score::quantiles;
pub use score::{score, score_commissioning, score_envelope, Cell, CommissioningCell};

use crate::config::Config;
use helmwatch_core::estimator::Estimator;
use helmwatch_core::model::SeaState;
use helmwatch_core::wire::Method;
use std::sync::Arc;

/// Options of the suite.
#[derive(Debug, Clone)]
pub struct FdiEvalOptions {
    /// Seed of the run draws and simulations.
    pub seed: u64,
    /// Runs per fault scenario.
    pub runs: usize,
    /// Runs per nominal scenario.
    pub nominal_runs: usize,
    /// Tests per run (after commissioning; envelope: after the change, and after the fault's
    /// onset when it comes later).
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
    /// Which scenario sets run (`--scenarios`).
    pub scenarios: ScenarioSet,
    /// Classic and envelope scenarios: the fault (envelope: the change, and its fault with
    /// or after it) arises this many tests of the ship after commissioning ends (the vessel
    /// learning its healthy tests meanwhile), not at its end (`--onset-after`).
    pub onset_after: usize,
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
            scenarios: ScenarioSet::Classic,
            onset_after: 0,
        }
    }
}

/// One row group of a table: a label, the scenario and the configuration its ships run.
pub(super) struct Row<'a> {
    label: String,
    scenario: &'a FdiScenario,
    cfg: Config,
    /// Where the row's scenario sits in the seed space.
    index: usize,
}

/// Seed-space offsets of the envelope and commissioning sets (the classic rows sit below).
const ENVELOPE_INDEX: usize = 1000;
const COMMISSIONING_INDEX: usize = 2000;

/// The family of real ships (but the first-order ship, index 0), each as `(index in the
/// family, name, cfg with its structure and autopilot)`; with `member`, only those whose name
/// contains it.
pub fn family_members(cfg: &Config, member: Option<&str>) -> Vec<(usize, &'static str, Config)> {
    let members = helmwatch_core::sim::config::family();
    (members.iter().enumerate().skip(1))
        .filter(|(_, m)| member.is_none_or(|w| m.name.contains(w)))
        .map(|(mi, m)| {
            let mut c = cfg.clone();
            m.apply(&mut c.structure, &mut c.autopilot);
            (mi, m.name, c)
        })
        .collect()
}

/// The rows of one set: on the first-order ship, or on every member of the family of real
/// ships (but the first-order ship) when `o.family`.
fn rows<'a>(
    cfg: &Config,
    o: &FdiEvalOptions,
    scs: &'a [FdiScenario],
    offset: usize,
) -> Vec<Row<'a>> {
    let mut rows = Vec::new();
    if o.family {
        for (mi, name, c) in family_members(cfg, o.member.as_deref()) {
            for (si, sc) in scs.iter().enumerate() {
                rows.push(Row {
                    label: format!("{name}: {}", sc.name),
                    scenario: sc,
                    cfg: c.clone(),
                    index: offset + mi * 16 + si,
                });
            }
        }
    } else {
        for (si, sc) in scs.iter().enumerate() {
            rows.push(Row {
                label: sc.name.to_string(),
                scenario: sc,
                cfg: cfg.clone(),
                index: offset + si,
            });
        }
    }
    rows
}

/// One row of the suite's tables, as the ablation and the before/after comparison read it.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct RowFigures {
    /// `classic`, `envelope` or `commissioning`.
    pub set: String,
    /// The sea state's name.
    pub sea: String,
    /// The row's label.
    pub scenario: String,
    /// Runs.
    pub runs: usize,
    /// A healthy row (no fault): its false alarms count, its detection does not.
    pub healthy: bool,
    /// Tests the row's false alarms are counted over (commissioning set: the window's).
    pub tests: usize,
    /// Healthy rows: tests decided `fault` (commissioning set: runs flagged).
    pub false_alarm_tests: usize,
    /// Fault rows: runs detected within 3 tests of each method (envelope: its window;
    /// commissioning: flagged).
    pub detected: usize,
    /// Fault rows: runs detected and named right within the same window (none for the
    /// commissioning set).
    pub named: Option<usize>,
    /// Healthy rows: completed tests after commissioning whose vessel state was alert or
    /// alarm (a tail about a thousand times the alarm's, so measurable where false alarms
    /// are not), and those tests.
    #[serde(default)]
    pub alerts: [usize; 2],
    /// Commissioning set, fault rows: runs in which a report said "commissioning
    /// inconsistent" (the fault found in the vessel's own sample).
    #[serde(default)]
    pub inconsistent: Option<usize>,
}

impl RowFigures {
    /// What a healthy row's false alarms are counted over: its tests, but a commissioning
    /// row's runs (each run is judged whole: flagged or not).
    pub fn healthy_units(&self) -> usize {
        if self.set == "commissioning" {
            self.runs
        } else {
            self.tests
        }
    }
}

/// Completed tests after commissioning of healthy runs, alert or alarm, and all of them.
pub(super) fn alerts(runs: &[RunOutcome]) -> [usize; 2] {
    use helmwatch_core::wire::residuals::TrackState;
    let done = || {
        runs.iter()
            .flat_map(|r| r.tests.iter())
            .filter(|t| t.completed)
    };
    [
        done()
            .filter(|t| matches!(t.state, Some(TrackState::Alert | TrackState::Alarm)))
            .count(),
        done().count(),
    ]
}

/// What the suite wrote: its tables (markdown) and their rows' figures.
#[derive(Debug, Clone, Default)]
pub struct SuiteResult {
    /// The tables, as printed.
    pub text: String,
    /// Every row's figures.
    pub figures: Vec<RowFigures>,
}

/// Runs the suite and returns its tables (markdown). With `o.family`, every member of the
/// family of real ships (but the first-order ship) runs the family scenarios, half its runs
/// at the corners of the (u, D) box.
pub fn run_suite(cfg: &Config, estimator: Arc<Estimator>, o: &FdiEvalOptions) -> SuiteResult {
    use std::fmt::Write;
    let mut sink = tables::Sink::default();
    let classic_scs = if o.family {
        family_scenarios()
    } else {
        scenarios()
    };
    let envelope_scs = envelope_scenarios();
    let commissioning_scs = commissioning_scenarios();
    let pick = |set: ScenarioSet, scs, offset| {
        if o.scenarios.includes(set) {
            rows(cfg, o, scs, offset)
        } else {
            Vec::new()
        }
    };
    let classic = pick(ScenarioSet::Classic, &classic_scs, 0);
    let envelope = pick(ScenarioSet::Envelope, &envelope_scs, ENVELOPE_INDEX);
    let commissioning = pick(
        ScenarioSet::Commissioning,
        &commissioning_scs,
        COMMISSIONING_INDEX,
    );
    sink.outcomes = o
        .outcomes
        .as_ref()
        .and_then(|p| match std::fs::File::create(p) {
            Ok(f) => Some(std::io::BufWriter::new(f)),
            Err(e) => {
                eprintln!("cannot write {}: {e}; no outcomes written", p.display());
                None
            }
        });
    let _ = writeln!(
        sink.text,

        "# FDI scenario suite{}: seed {}, {} runs per fault scenario, {} per nominal one, commissioning (at most {} tests of each method) then {} tests per run{}",
        if o.family { " on the family of real ships" } else { "" },
        o.seed,
        o.runs,
        o.nominal_runs,
        cfg.fdi.commissioning_tests,
        o.tests,
        match o.scenarios {
            ScenarioSet::Classic => String::new(),
            s => format!(" (scenarios: {})", s.name()),
        }
    );
    let f = &cfg.fdi;
    let limits = helmwatch_core::fdi::limits::DecisionLimits::new(
        f.false_alarms_per_year,
        cfg.scheduler.interval_s + cfg.scheduler.steady_time_s,
        f.window_tests,
    );
    let _ = writeln!(
        sink.text,

        "decision: window GLR over {} tests of the ship, {} false alarms per vessel-year ({:.2e} per test): limits {:.1} (one method) / {:.1} (both), along one cause {:.1} / {:.1}, servo {:.2}",
        f.window_tests,
        f.false_alarms_per_year,
        limits.alpha_test,
        limits.param[helmwatch_core::fdi::stats::P],
        limits.param[2 * helmwatch_core::fdi::stats::P],
        limits.cause[0],
        limits.cause[1],
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
            sink.text.push('\n');
            if turns > 1 {
                let _ = writeln!(
        sink.text,

                    "## {} in turn in a {} sea (windows of N tests of each method: {turns} N tests of the ship; delay in tests of the ship)",
                    names.join(" and "),
                    sea.name()
                );
            } else {
                let _ = writeln!(sink.text, "## {} in a {} sea", names.join(""), sea.name());
            }
            sink.text.push('\n');
            if !classic.is_empty() {
                tables::classic_table(&classic, sea, methods, turns, o, &estimator, &mut sink);
            }
            if !envelope.is_empty() {
                if !classic.is_empty() {
                    sink.text.push('\n');
                }
                tables::envelope_table(&envelope, sea, methods, o, &estimator, &mut sink);
            }
            if !commissioning.is_empty() {
                if !classic.is_empty() || !envelope.is_empty() {
                    sink.text.push('\n');
                }
                tables::commissioning_table(&commissioning, sea, methods, o, &estimator, &mut sink);
            }
        }
    }
    SuiteResult {
        text: sink.text,
        figures: sink.figures,
    }
}

#[cfg(test)]
mod tests;
