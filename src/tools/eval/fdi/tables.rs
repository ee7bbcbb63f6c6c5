//! The suite's tables: per sea and schedule, the classic scenarios' table (false alarms,
//! detection, delay, isolation, beside the baseline), the envelope's and the commissioning's.

use super::outcomes::write_outcomes;
use super::run::{run_one, RunOutcome};
use super::score::{
    calibrated_fit, operating_point, pct, quantiles, score, score_commissioning, score_envelope,
    Cell,
};
use super::RowFigures;
use super::{FdiEvalOptions, Row};
use crate::tools::training::database::par_map;
use helmwatch_core::estimator::Estimator;
use helmwatch_core::model::SeaState;
use helmwatch_core::wire::{Decision, Method};
use std::fmt::Write;
use std::sync::Arc;

/// Where the outcomes go (`--outcomes`), if anywhere.
pub(super) type OutcomesFile = Option<std::io::BufWriter<std::fs::File>>;

/// Where a table goes: the outcomes file, the tables' text and the rows' figures.
#[derive(Default)]
pub(super) struct Sink {
    pub(super) outcomes: OutcomesFile,
    pub(super) text: String,
    pub(super) figures: Vec<RowFigures>,
}

/// Runs a row's runs in parallel: `nominal_runs` for a healthy scenario, else `runs`, each
/// seeded from the suite's seed, the row's index and the sea (half at the corners of the
/// (u, D) box on the family).
fn runs_of(
    row: &Row,
    sea: SeaState,
    methods: &[Method],
    o: &FdiEvalOptions,
    estimator: &Arc<Estimator>,
) -> Vec<RunOutcome> {
    let sc = row.scenario;
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
    par_map(n, o.threads, |k| {
        let corner = (o.family && k % 2 == 0).then_some(k / 2);
        run_one(
            &row.cfg,
            sc,
            sea,
            methods,
            base + k as u64,
            estimator,
            o,
            corner,
        )
    })
}

/// The classic scenarios' table and its notes (`turns` methods in turn: windows of N tests
/// of each method).
pub(super) fn classic_table(
    rows: &[Row],
    sea: SeaState,
    methods: &[Method],
    turns: usize,
    o: &FdiEvalOptions,
    estimator: &Arc<Estimator>,
    sink: &mut Sink,
) {
    let Sink {
        outcomes,
        text: out,
        figures,
    } = sink;
    let _ = writeln!(
        out,
        "| scenario | who | runs | tests | false alarms (tests / runs) | detected <= 2 | detected <= 3 | mean delay | detected <= 4 | isolated (last test) | isolated <= 2 | isolated <= 3 | isolated <= 4 | aborted |");
    let _ = writeln!(
        out,
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"
    );
    let mut notes = Vec::new();
    for (si, row) in rows.iter().enumerate() {
        let sc = row.scenario;
        let runs = runs_of(row, sea, methods, o, estimator);
        if let Some(w) = outcomes.as_mut() {
            write_outcomes(w, &row.label, sea, &runs);
        }
        notes.extend(z_note(&row.label, &runs));
        if sc.expected.is_none() {
            healthy_notes(&row.label, &runs, &mut notes);
            notes.extend(calibrated_note(&row.label, &runs));
        }
        // The baseline's rows only when its estimate exists (features.baseline).
        let has_baseline = runs
            .iter()
            .flat_map(|r| r.tests.iter())
            .any(|t| t.baseline_decision != Decision::Inconclusive);
        if !has_baseline && si == 0 {
            notes.push("baseline: no equation-error estimate in the features, no rows".into());
        }
        let whos: &[(&str, bool)] = if has_baseline {
            &[("ours", false), ("baseline", true)]
        } else {
            &[("ours", false)]
        };
        for &(who, baseline) in whos {
            classic_row(row, who, baseline, &runs, sea, turns, out, figures);
        }
    }
    out.push('\n');
    for n in notes {
        let _ = writeln!(out, "- {n}");
    }
}

/// The note on a row's normalised speed and displacement residuals over its tests after
/// commissioning: their means, standard deviations and correlation (none without residuals).
fn z_note(label: &str, runs: &[RunOutcome]) -> Option<String> {
    let all = || runs.iter().flat_map(|r| r.tests.iter());
    let zs: Vec<[f64; 3]> = all().map(|t| t.z).filter(|z| z[0].is_finite()).collect();
    if zs.is_empty() {
        return None;
    }
    let n = zs.len() as f64;
    let m = |i: usize| zs.iter().map(|z| z[i]).sum::<f64>() / n;
    let sd = |i: usize| {
        let mi = m(i);
        (zs.iter().map(|z| (z[i] - mi).powi(2)).sum::<f64>() / n).sqrt()
    };
    let (m0, m1) = (m(0), m(1));
    let cov = zs.iter().map(|z| (z[0] - m0) * (z[1] - m1)).sum::<f64>() / n;
    Some(format!(
        "{}: z_speed mean {:+.2} sd {:.2}, z_displacement mean {:+.2} sd {:.2}, correlation {:+.2}",
        label,
        m0,
        sd(0),
        m1,
        sd(1),
        cov / (sd(0) * sd(1))
    ))
}

/// A healthy row's notes: the median, 99th percentile and largest of its chi-squares (the
/// parameters', the commissioning's, the servo check's, the model fit's) and sea index.
fn healthy_notes(label: &str, runs: &[RunOutcome], notes: &mut Vec<String>) {
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
                label
            ));
        }
    }
}

/// A healthy row's note on the estimate calibrated to the vessel: the 95th percentiles of
/// its distance to the speed log and to the declared displacement after commissioning (and
/// after a change of speed, where the row has one).
fn calibrated_note(label: &str, runs: &[RunOutcome]) -> Option<String> {
    let c = calibrated_fit(runs);
    if c.tests + c.missing == 0 {
        return None;
    }
    let after = if c.after_speed_change > 0 {
        format!(
            "; after the change of speed {:.3} m/s ({} tests)",
            c.after_speed_change_p95_mps, c.after_speed_change
        )
    } else {
        String::new()
    };
    let by_method: Vec<String> = ["CLFRT", "HBT"]
        .iter()
        .zip(c.by_method)
        .filter(|(_, (n, _, _))| *n > 0)
        .map(|(m, (n, u, d))| format!("{m} {u:.3} m/s, {:.2} % ({n} tests)", 100.0 * d))
        .collect();
    Some(format!(
        "{label}: calibrated estimate, 95th percentile of |u_cal - u_log| {:.3} m/s, of |D_cal / D_nom - 1| {:.2} % (by method: {}); its 95 % interval holds the log in {}, the declared D in {} ({} tests after commissioning, {} without a vessel reference){after}",
        c.speed_p95_mps,
        100.0 * c.displacement_p95,
        by_method.join("; "),
        pct(c.covered[0], c.tests),
        pct(c.covered[1], c.tests),
        c.tests,
        c.missing
    ))
}

/// One line of the classic table: the row's runs as `who` scores them (ours, or the
/// baseline's), its figures kept (ours only).
#[allow(clippy::too_many_arguments)]
fn classic_row(
    row: &Row,
    who: &str,
    baseline: bool,
    runs: &[RunOutcome],
    sea: SeaState,
    turns: usize,
    out: &mut String,
    figures: &mut Vec<RowFigures>,
) {
    let sc = row.scenario;
    let c2 = score(runs, sc.expected, 2 * turns, baseline);
    let c3 = score(runs, sc.expected, 3 * turns, baseline);
    let c4 = score(runs, sc.expected, 4 * turns, baseline);
    let nominal = sc.expected.is_none();
    if !baseline {
        figures.push(RowFigures {
            set: "classic".into(),
            sea: sea.name().into(),
            scenario: row.label.clone(),
            runs: c3.runs,
            healthy: nominal,
            tests: c3.tests,
            false_alarm_tests: if nominal { c3.fault_tests } else { 0 },
            detected: c3.detected,
            named: Some(c3.isolated_within),
            alerts: if nominal { super::alerts(runs) } else { [0, 0] },
            inconsistent: None,
        });
    }
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
    let [det2, det3, delay, det4, iso, iso2, iso3, iso4] =
        detection_cells(nominal, [&c2, &c3, &c4]);
    let _ = writeln!(
        out,
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

/// A faulty row's detection and isolation cells, from its figures within 2, 3 and 4 tests of
/// each method (dashes for a healthy row).
fn detection_cells(nominal: bool, [c2, c3, c4]: [&Cell; 3]) -> [String; 8] {
    if nominal {
        std::array::from_fn(|_| "-".to_string())
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
    }
}

/// The envelope scenarios' table: false alarms over the tests after commissioning without
/// the fault, detection and isolation within each scenario's window of tests of the ship
/// from the onset; notes on the operating point the reports saw.
pub(super) fn envelope_table(
    rows: &[Row],
    sea: SeaState,
    methods: &[Method],
    o: &FdiEvalOptions,
    estimator: &Arc<Estimator>,
    sink: &mut Sink,
) {
    let Sink {
        outcomes,
        text: out,
        figures,
    } = sink;
    let _ = writeln!(
        out,
        "### Envelope: the speed and/or the declared loading change when commissioning ends (not a fault)");
    out.push('\n');
    let _ = writeln!(
        out,
        "False alarms: `fault` decisions over the tests after commissioning without the fault. Detection: the first `fault` within the window's tests of the ship from the onset (the first test with the fault is 1).");
    out.push('\n');
    let _ = writeln!(
        out,
        "| scenario | runs | tests without the fault | false alarms (tests / runs) | window (tests of the ship) | detected | mean delay | isolated within | isolated (last test) | aborted |");
    let _ = writeln!(out, "|---|---|---|---|---|---|---|---|---|---|");
    let mut notes = Vec::new();
    for row in rows {
        let sc = row.scenario;
        let runs = runs_of(row, sea, methods, o, estimator);
        if let Some(w) = outcomes.as_mut() {
            write_outcomes(w, &row.label, sea, &runs);
        }
        let window = sc.window_tests.unwrap_or(0);
        let c = score_envelope(&runs, sc.expected, window);
        let fa = format!(
            "{} / {} ({})",
            c.fault_tests,
            c.fault_runs,
            pct(c.fault_tests, c.tests)
        );
        let [win, det, delay, iso_w, iso] = if sc.expected.is_none() {
            std::array::from_fn(|_| "-".to_string())
        } else {
            [
                window.to_string(),
                pct(c.detected, c.runs),
                if c.detected > 0 {
                    format!("{:.2}", c.delay_sum as f64 / c.detected as f64)
                } else {
                    "-".into()
                },
                pct(c.isolated_within, c.runs),
                pct(c.isolated, c.runs),
            ]
        };
        let _ = writeln!(
            out,
            "| {} | {} | {} | {fa} | {win} | {det} | {delay} | {iso_w} | {iso} | {}{} |",
            row.label,
            c.runs,
            c.tests,
            c.aborted,
            broken(c.broken)
        );
        figures.push(RowFigures {
            set: "envelope".into(),
            sea: sea.name().into(),
            scenario: row.label.clone(),
            runs: c.runs,
            healthy: sc.expected.is_none(),
            tests: c.tests,
            false_alarm_tests: c.fault_tests,
            detected: c.detected,
            named: Some(c.isolated_within),
            alerts: if sc.expected.is_none() {
                super::alerts(&runs)
            } else {
                [0, 0]
            },
            inconsistent: None,
        });
        let p = operating_point(&runs);
        let declared = if p.declared_tests > 0 {
            format!(
                "; the declared D in force in {} of {} tests",
                p.declared_seen, p.declared_tests
            )
        } else {
            String::new()
        };
        notes.push(format!(
            "{}: speed log within {:.3} m/s of the scheduled speed ({} tests after commissioning){declared}",
            row.label, p.speed_error_max_mps, p.tests
        ));
        if sc.expected.is_none() {
            notes.extend(calibrated_note(&row.label, &runs));
        }
    }
    out.push('\n');
    for n in notes {
        let _ = writeln!(out, "- {n}");
    }
}

/// The commissioning scenarios' table: runs flagged from the onset (a healthy run: from its
/// first test) through the confirmation after commissioning (as many tests of the ship as
/// commissioning's).
pub(super) fn commissioning_table(
    rows: &[Row],
    sea: SeaState,
    methods: &[Method],
    o: &FdiEvalOptions,
    estimator: &Arc<Estimator>,
    sink: &mut Sink,
) {
    let Sink {
        outcomes,
        text: out,
        figures,
    } = sink;
    let _ = writeln!(
        out,
        "### Commissioning: faults arising before commissioning test k of the ship"
    );
    out.push('\n');
    let _ = writeln!(
        out,
        "Flagged: a report from the onset through the confirmation (as many tests of the ship after commissioning as commissioning had) with `residuals.decision.state` alert or alarm, or decision `fault` (the healthy row: from the first test, false flags). Inconsistent: a report says \"commissioning inconsistent\".");
    out.push('\n');
    let _ = writeln!(
        out,
        "| scenario | runs | tests in the window | onset k (mean) | flagged | flagged during commissioning | decision fault | commissioning inconsistent | aborted |");
    let _ = writeln!(out, "|---|---|---|---|---|---|---|---|---|");
    for row in rows {
        let sc = row.scenario;
        let runs = runs_of(row, sea, methods, o, estimator);
        if let Some(w) = outcomes.as_mut() {
            write_outcomes(w, &row.label, sea, &runs);
        }
        let healthy = sc.expected.is_none();
        let c = score_commissioning(&runs, healthy);
        figures.push(RowFigures {
            set: "commissioning".into(),
            sea: sea.name().into(),
            scenario: row.label.clone(),
            runs: c.runs,
            healthy,
            tests: c.tests,
            false_alarm_tests: if healthy { c.flagged } else { 0 },
            detected: if healthy { 0 } else { c.flagged },
            named: None,
            alerts: if healthy {
                super::alerts(&runs)
            } else {
                [0, 0]
            },
            inconsistent: (!healthy).then_some(c.inconsistent),
        });
        let onset = if healthy || c.runs == 0 {
            "-".to_string()
        } else {
            format!("{:.2}", c.onset_sum as f64 / c.runs as f64)
        };
        let _ = writeln!(
            out,
            "| {} | {} | {} | {onset} | {} | {} | {} | {} | {}{} |",
            row.label,
            c.runs,
            c.tests,
            pct(c.flagged, c.runs),
            pct(c.flagged_in_commissioning, c.runs),
            pct(c.fault_runs, c.runs),
            pct(c.inconsistent, c.runs),
            c.aborted,
            broken(c.broken)
        );
    }
}

fn broken(n: usize) -> String {
    if n > 0 {
        format!(" ({n} runs broken)")
    } else {
        String::new()
    }
}
