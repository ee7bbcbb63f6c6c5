//! The outcomes file (`--outcomes`): one JSON line per test, for analysis of the residuals.

use super::run::RunOutcome;
use helmwatch_core::model::SeaState;

/// Writes one JSON line per test of `runs` (commissioning and after it): the row, the run,
/// its drawn operating point and the one after the change, the test's phase (`commissioning`,
/// `test` for a classic scenario after commissioning, else `before change`, `after change`,
/// `after fault`), whether the fault was present, the operating point the report saw (mean
/// speed log, HBT's relay scale, nominal displacement in force), the reference's kind, and its decision and
/// residuals.
pub(super) fn write_outcomes(
    w: &mut impl std::io::Write,
    label: &str,
    sea: SeaState,
    runs: &[RunOutcome],
) {
    let nan_null = |x: f64| x.is_finite().then_some(x);
    for (k, r) in runs.iter().enumerate() {
        for tests in [&r.commissioning, &r.tests] {
            for (i, t) in tests.iter().enumerate() {
                let line = serde_json::json!({
                    "row": label,
                    "method": t.method.name(),
                    "sea": sea.name(),
                    "run": k,
                    "speed_mps": nan_null(r.speed_mps),
                    "displacement_t": nan_null(r.displacement_t),
                    "speed_after_mps": nan_null(r.speed_after_mps),
                    "declared_after_t": nan_null(r.declared_after_t),
                    "phase": t.phase.name(),
                    "fault_present": t.fault_present,
                    "test": i,
                    "completed": t.completed,
                    "reason": t.abort_reason,
                    "speed_log_mps": nan_null(t.speed_log_mps),
                    "relay_scale": nan_null(t.relay_scale),
                    "displacement_nominal_t": nan_null(t.displacement_nominal_t),
                    "decision": t.decision,
                    "state": t.state,
                    "reference": t.reference_kind,
                    "inconsistent": t.inconsistent,
                    "isolation": t.isolation,
                    "chi2": nan_null(t.q_param),
                    "chi2_actuator": nan_null(t.q_actuator),
                    "sea_index": nan_null(t.sea_index),
                    "fit_chi2": nan_null(t.fit_chi2),
                    "tone_ci90": t.tone_ci90.map(nan_null),
                    "meas_sd": t.meas_sd.map(nan_null),
                    "noise_ratio": nan_null(t.noise_ratio),
                    "z": t.z.map(nan_null),
                    "cause_costs": t.cause_costs.map(nan_null),
                    "raw": t.raw.map(nan_null),
                    "sigma": t.sigma.map(nan_null),
                    "offset_sigma": t.offset_sigma.map(nan_null),
                    "calibrated": t.calibrated.map(nan_null),
                });
                if let Err(e) = writeln!(w, "{line}") {
                    eprintln!("outcomes not written: {e}");
                    return;
                }
            }
        }
    }
}
