//! `eval --budget`: the decision on its own model against `fdi.false-alarms-per-year`
//! (`core::fdi::budget`), over the commissioning sample size, the floors and learning, and
//! with the mechanisms that keep the budget at a small sample switched off in turn
//! (`core::fdi::budget::SCAN`).

use helmwatch_core::fdi::ablation::{switch_off, Mechanism};
use helmwatch_core::fdi::budget::{run, PriorCase, PRIOR_SCAN, PRIOR_WEIGHT, SCAN};
use std::fmt::Write;

/// The mechanisms switched off for the small-sample cells (K = 8, no floors): the one that
/// exists for a small sample.
const ABLATED: [Mechanism; 1] = [Mechanism::HotellingCalibration];

/// Runs every cell and returns the markdown table.
pub fn budget_table(seed: u64, threads: usize) -> String {
    let mut out = String::new();
    let _ = writeln!(
        out,
        "# The decision on its own model: false alarms against the budget\n\n\
         Vessels commissioned on K Gaussian tests per method of a correlated scatter, then 100 \
         tests each in turn, learned as the daemon learns (`learning` no: the commissioning \
         sample alone). Ratio: alarms per test over the budget's share per test; 95 % \
         interval with the count taken as Poisson. The limits promise a ratio at most 1.\n"
    );
    let _ = writeln!(
        out,
        "| variant | K | floors (m/s, ln D) | learning | budget / year | tests | alarms | ratio | 95 % interval |"
    );
    let _ = writeln!(out, "|---|---|---|---|---|---|---|---|---|");
    let rows = |name: &str, off: &[Mechanism], small_only: bool, out: &mut String| {
        switch_off(off);
        for cell in SCAN {
            let (k, floors, learn, budget) = (
                cell.commissioning_tests,
                cell.floors,
                cell.learn,
                cell.budget_per_year,
            );
            if small_only && !(k == 8 && floors == [0.0, 0.0]) {
                continue;
            }
            let line = measured(&cell, seed, threads);
            let _ = writeln!(
                out,
                "| {name} | {k} | {} / {} | {} | {budget} | {line} |",
                floors[0],
                floors[1],
                if learn { "yes" } else { "no" }
            );
        }
        switch_off(&[]);
    };
    rows("as built", &[], false, &mut out);
    for m in ABLATED {
        rows(&format!("{} off", m.name()), &[m], true, &mut out);
    }
    prior_rows(seed, threads, &mut out);
    out
}

/// A cell's measured columns: tests, alarms, ratio and its interval.
fn measured(cell: &helmwatch_core::fdi::budget::Cell, seed: u64, threads: usize) -> String {
    match run(cell, seed, threads) {
        Some(o) => {
            let [lo, hi] = o.ratio_interval();
            format!(
                "{} | {} | {:.3} | {lo:.2} .. {hi:.2}",
                o.decided,
                o.alarms,
                o.ratio()
            )
        }
        None => "refused | - | - | -".into(),
    }
}

/// The cells with the class's prior for the scatter (`core::fdi::budget::PRIOR_SCAN`).
fn prior_rows(seed: u64, threads: usize, out: &mut String) {
    let _ = writeln!(
        out,
        "\n## With the class's prior for the scatter\n\n\
         The prior of {PRIOR_WEIGHT:?} dof per component (e_u, e_D, e_b) about the scatter \
         above. `from the prior`: each vessel's variances drawn from it (the model it \
         states); `3x noisier`: every vessel three times the prior's centre, which the \
         scatter test must find (prior dropped) or pay for in false alarms. Learning as the \
         daemon learns; no floors.\n"
    );
    let _ = writeln!(
        out,
        "| vessels | K | budget / year | tests | alarms | ratio | 95 % interval |"
    );
    let _ = writeln!(out, "|---|---|---|---|---|---|---|");
    for cell in PRIOR_SCAN {
        let kind = match cell.prior {
            PriorCase::Off => "no prior".to_string(),
            PriorCase::Class => "from the prior".to_string(),
            PriorCase::Noisier(k) => format!("{k}x noisier"),
        };
        let line = measured(&cell, seed, threads);
        let _ = writeln!(
            out,
            "| {kind} | {} | {} | {line} |",
            cell.commissioning_tests, cell.budget_per_year
        );
    }
}
