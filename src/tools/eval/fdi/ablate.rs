//! `eval --fdi --ablate`: the suite once as built and once with each mechanism of the
//! decision off (`helmwatch_core::fdi::ablation`), the same seeds, ships and seas: what each
//! mechanism buys in false alarms, the healthy alert tail, detection and naming. A mechanism
//! whose removal changes none of them past Monte Carlo noise buys nothing the suite can see.

use super::compare::totals_table;
use super::{run_suite, FdiEvalOptions, RowFigures};
use crate::config::Config;
use helmwatch_core::estimator::Estimator;
use helmwatch_core::fdi::ablation::{switch_off, Mechanism};
use std::fmt::Write;
use std::sync::Arc;

/// The configuration that switches the mechanisms in `set` off where a key does it.
pub fn configured(cfg: &Config, set: &[Mechanism]) -> Config {
    let mut c = cfg.clone();
    for m in set {
        match m {
            Mechanism::VesselReference => c.fdi.commissioning_tests = 0,
            Mechanism::WindowGlr => c.fdi.window_tests = 1,
            _ => {}
        }
    }
    c
}

/// Runs the suite with each set of `mechanisms` off in turn (a set of two or more: to see
/// what mechanisms that stand in for each other buy together) and returns the table, `base` (the
/// suite as built, already run) first. Every switch is back on when it returns.
pub fn ablate(
    cfg: &Config,
    estimator: &Arc<Estimator>,
    o: &FdiEvalOptions,
    base: &[RowFigures],
    mechanisms: &[Vec<Mechanism>],
) -> String {
    let mut variants: Vec<(String, Vec<RowFigures>)> = vec![("as built".into(), base.to_vec())];
    for set in mechanisms {
        switch_off(set);
        let res = run_suite(&configured(cfg, set), estimator.clone(), o);
        switch_off(&[]);
        let names: Vec<&str> = set.iter().map(|m| m.name()).collect();
        variants.push((format!("{} off", names.join(" + ")), res.figures));
    }
    let refs: Vec<(&str, &[RowFigures])> = variants
        .iter()
        .map(|(n, f)| (n.as_str(), f.as_slice()))
        .collect();
    let mut out = String::new();
    let _ = writeln!(
        out,
        "\n## Ablation\n\nThe same suite with one mechanism (or one named set, `a + b`) off at a time. A count marked **(differs)** is past Monte Carlo noise against the suite as built (pooled two-proportion |z| > 2).\n"
    );
    out.push_str(&totals_table(&refs));
    out
}
