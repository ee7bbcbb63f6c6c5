//! `eval --budget`: the decision on its own model against `fdi.false-alarms-per-year`
//! (`core::fdi::budget`), over the commissioning sample size, the floors and learning, and
//! with the mechanisms that keep the budget at a small sample switched off in turn. Each
//! cell is sized for about a hundred alarms at its budget (a tenth's relative spread).

use crate::core::fdi::ablation::{switch_off, Mechanism};
use crate::core::fdi::budget::{run, Cell};
use std::fmt::Write;

/// The cells: (K, floors, learning, budget a year, vessels), 100 tests each after
/// commissioning.
const CELLS: [(u32, [f64; 2], bool, f64, usize); 13] = [
    (8, [0.0, 0.0], false, 30.0, 300),
    (8, [0.0, 0.0], false, 8.0, 1000),
    (8, [0.0, 0.0], true, 30.0, 300),
    (8, [0.0, 0.0], true, 8.0, 1000),
    (16, [0.0, 0.0], true, 30.0, 300),
    (16, [0.0, 0.0], true, 8.0, 1000),
    (8, [0.2, 0.01], false, 30.0, 300),
    (8, [0.2, 0.01], false, 8.0, 1000),
    (30, [0.0, 0.0], false, 30.0, 300),
    (30, [0.0, 0.0], false, 8.0, 1000),
    (200, [0.0, 0.0], false, 30.0, 300),
    (200, [0.0, 0.0], false, 8.0, 1000),
    (16, [0.0, 0.0], true, 2.0, 20_000),
];

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
        for (k, floors, learn, budget, vessels) in CELLS {
            if small_only && !(k == 8 && floors == [0.0, 0.0]) {
                continue;
            }
            let cell = Cell {
                commissioning_tests: k,
                floors,
                learn,
                budget_per_year: budget,
                vessels,
                tests: 100,
            };
            let line = match run(&cell, seed, threads) {
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
            };
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
    out
}
