//! The suite's figures side by side: before and after a change (`eval --fdi --compare DIR`),
//! and with each mechanism of the decision switched off (`eval --fdi --ablate`).
//!
//! A row's figure is a count out of a number of trials (false alarms out of healthy tests,
//! detections or namings out of runs). Two counts differ *beyond Monte Carlo noise* when the
//! two-proportion z statistic, pooled, exceeds 2 in size (about 95 % two-sided under equal
//! rates; with zero on both sides they never differ).

use super::{FdiEvalOptions, RowFigures};
use std::fmt::Write;

/// The file name of a suite's results (`fdi-<set>[-family][-onset-after-N][-<method>][-<sea>]-seed<seed>`).
pub fn suite_name(o: &FdiEvalOptions) -> String {
    let mut name = format!("fdi-{}", o.scenarios.name());
    if o.family {
        name.push_str("-family");
    }
    if o.onset_after > 0 {
        let _ = write!(name, "-onset-after-{}", o.onset_after);
    }
    if o.methods.len() == 1 {
        let _ = write!(name, "-{}", o.methods[0].name());
    }
    if o.seas.len() == 1 {
        let _ = write!(name, "-{}", o.seas[0].name());
    }
    let _ = write!(name, "-seed{}", o.seed);
    name
}

/// A suite's totals: healthy tests and their false alarms, fault runs detected and named.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Totals {
    /// Healthy tests (the commissioning set's: its healthy runs, each judged whole).
    pub healthy_tests: usize,
    /// False alarms among them (the commissioning set's: runs flagged).
    pub false_alarms: usize,
    /// Commissioning set: fault runs the vessel's own sample found inconsistent (`None`:
    /// not counted, in figures written before the count existed).
    pub inconsistent: Option<usize>,
    /// Fault runs.
    pub fault_runs: usize,
    /// Fault runs detected within the row's window.
    pub detected: usize,
    /// Fault runs with a naming figure.
    pub nameable_runs: usize,
    /// Fault runs detected and named right within the window.
    pub named: usize,
    /// Healthy tests after commissioning in alert or alarm, and those tests.
    pub alerts: [usize; 2],
}

/// The totals of a set's rows (`set` None: every row).
pub fn totals(rows: &[RowFigures], set: Option<&str>) -> Totals {
    let mut t = Totals::default();
    for r in rows.iter().filter(|r| set.is_none_or(|s| r.set == s)) {
        if r.healthy {
            t.healthy_tests += r.healthy_units();
            t.false_alarms += r.false_alarm_tests;
            t.alerts[0] += r.alerts[0];
            t.alerts[1] += r.alerts[1];
        } else {
            t.fault_runs += r.runs;
            t.detected += r.detected;
            if let Some(k) = r.inconsistent {
                t.inconsistent = Some(t.inconsistent.unwrap_or(0) + k);
            }
            if let Some(n) = r.named {
                t.nameable_runs += r.runs;
                t.named += n;
            }
        }
    }
    t
}

/// The pooled two-proportion z statistic of `a / n` against `b / m` (0 when undefined).
pub fn two_proportion_z(a: usize, n: usize, b: usize, m: usize) -> f64 {
    if n == 0 || m == 0 {
        return 0.0;
    }
    let (p1, p2) = (a as f64 / n as f64, b as f64 / m as f64);
    let p = (a + b) as f64 / (n + m) as f64;
    let var = p * (1.0 - p) * (1.0 / n as f64 + 1.0 / m as f64);
    if var <= 0.0 {
        0.0
    } else {
        (p2 - p1) / var.sqrt()
    }
}

/// `k / n` and, past noise against `k0 / n0`, a mark.
fn cell(k: usize, n: usize, k0: usize, n0: usize) -> String {
    let z = two_proportion_z(k0, n0, k, n);
    let mark = if z.abs() > 2.0 { " **(differs)**" } else { "" };
    format!("{k} / {n}{mark}")
}

/// The row-by-row table of two runs of the same suite: for each row of `after` found in
/// `before` (same set, sea and scenario), the healthy rows' false alarms and the fault rows'
/// detection and naming, then the sets' totals.
pub fn compare_table(before: &[RowFigures], after: &[RowFigures]) -> String {
    let mut out = String::new();
    let _ = writeln!(
        out,
        "| set | sea | scenario | before: false alarms / tests (commissioning: runs flagged / runs), or detected / runs | after | before: named / runs | after |"
    );
    let _ = writeln!(out, "|---|---|---|---|---|---|---|");
    for a in after {
        let Some(b) = before
            .iter()
            .find(|b| b.set == a.set && b.sea == a.sea && b.scenario == a.scenario)
        else {
            continue;
        };
        let (k0, n0, k, n) = if a.healthy {
            let (n0, n) = (b.healthy_units(), a.healthy_units());
            (b.false_alarm_tests, n0, a.false_alarm_tests, n)
        } else {
            (b.detected, b.runs, a.detected, a.runs)
        };
        let named = match (b.named, a.named) {
            (Some(x), Some(y)) if !a.healthy => {
                [format!("{x} / {}", b.runs), cell(y, a.runs, x, b.runs)]
            }
            _ => ["-".to_string(), "-".to_string()],
        };
        let _ = writeln!(
            out,
            "| {} | {} | {} | {k0} / {n0} | {} | {} | {} |",
            a.set,
            a.sea,
            a.scenario,
            cell(k, n, k0, n0),
            named[0],
            named[1]
        );
    }
    out.push('\n');
    out.push_str(&totals_table(&[("before", before), ("after", after)]));
    out
}

/// The totals of several variants of a suite, one line each, per set; a figure past Monte
/// Carlo noise against the first variant's is marked.
pub fn totals_table(variants: &[(&str, &[RowFigures])]) -> String {
    let mut out = String::new();
    let _ = writeln!(
        out,
        "| variant | set | false alarms / healthy tests (commissioning: runs flagged / runs) | alert or alarm / healthy tests after commissioning | detected / fault runs | named / runs | commissioning inconsistent / fault runs |"
    );
    let _ = writeln!(out, "|---|---|---|---|---|---|---|");
    let Some((_, first)) = variants.first() else {
        return out;
    };
    for set in ["classic", "envelope", "commissioning"] {
        let t0 = totals(first, Some(set));
        if t0.healthy_tests + t0.fault_runs == 0 {
            continue;
        }
        for (name, rows) in variants {
            let t = totals(rows, Some(set));
            let named = if t.nameable_runs > 0 {
                cell(t.named, t.nameable_runs, t0.named, t0.nameable_runs)
            } else {
                "-".into()
            };
            let inconsistent = match (set, t.inconsistent, t0.inconsistent) {
                ("commissioning", Some(k), Some(k0)) => cell(k, t.fault_runs, k0, t0.fault_runs),
                ("commissioning", Some(k), None) => format!("{k} / {}", t.fault_runs),
                _ => "-".into(),
            };
            let _ = writeln!(
                out,
                "| {name} | {set} | {} | {} | {} | {named} | {inconsistent} |",
                cell(
                    t.false_alarms,
                    t.healthy_tests,
                    t0.false_alarms,
                    t0.healthy_tests
                ),
                cell(t.alerts[0], t.alerts[1], t0.alerts[0], t0.alerts[1]),
                cell(t.detected, t.fault_runs, t0.detected, t0.fault_runs),
            );
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(healthy: bool, runs: usize, tests: usize, fa: usize, det: usize) -> RowFigures {
        RowFigures {
            set: "classic".into(),
            sea: "calm".into(),
            scenario: if healthy { "nominal" } else { "D +10 %" }.into(),
            runs,
            healthy,
            tests,
            false_alarm_tests: fa,
            detected: det,
            named: (!healthy).then_some(det),
            alerts: [0, tests],
            inconsistent: None,
        }
    }

    #[test]
    fn the_z_statistic_matches_a_hand_computed_case() {
        // 10 / 100 against 20 / 100: p = 0.15, var = 0.15 * 0.85 * 0.02 = 0.00255.
        let z = two_proportion_z(10, 100, 20, 100);
        assert!((z - 0.1 / 0.00255f64.sqrt()).abs() < 1e-12, "{z}");
        assert_eq!(two_proportion_z(0, 100, 0, 100), 0.0);
        assert_eq!(two_proportion_z(1, 0, 0, 100), 0.0);
    }

    #[test]
    fn a_count_the_earlier_figures_lack_is_shown_not_compared() {
        let mut before = row(false, 60, 240, 0, 58);
        before.set = "commissioning".into();
        let mut after = before.clone();
        after.inconsistent = Some(45);
        let t = compare_table(&[before.clone()], &[after.clone()]);
        assert!(t.contains("| 45 / 60 |"), "{t}");
        assert!(!t.contains("differs"), "{t}");
        before.inconsistent = Some(10);
        let t = compare_table(&[before], &[after]);
        assert!(t.contains("45 / 60 **(differs)**"), "{t}");
    }

    #[test]
    fn only_a_difference_beyond_noise_is_marked() {
        let before = [row(true, 10, 400, 0, 0), row(false, 60, 240, 0, 58)];
        let same = [row(true, 10, 400, 1, 0), row(false, 60, 240, 0, 57)];
        let worse = [row(true, 10, 400, 0, 0), row(false, 60, 240, 0, 30)];
        assert!(!compare_table(&before, &same).contains("differs"));
        let t = compare_table(&before, &worse);
        assert!(t.contains("30 / 60 **(differs)**"), "{t}");
        let tot = totals(&worse, None);
        assert_eq!(
            (tot.healthy_tests, tot.fault_runs, tot.detected),
            (400, 60, 30)
        );
    }
}
