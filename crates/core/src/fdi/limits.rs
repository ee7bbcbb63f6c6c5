//! The decision's limits, from one number: `fdi.false-alarms-per-year` at the scheduler's
//! test rate, shared over the families of looks and the window's effective lengths
//! (docs/fdi.md, "The window GLR and its limits").

use super::ablation::{self, Mechanism};
use super::stats::{chi2_isf, normal_isf, P};
use crate::wire::Cause;

/// The parameter causes in the order of a test's directions (`window::Entry::directions`).
pub const PARAMETER_CAUSES: [Cause; 2] =
    [Cause::SpeedLog, Cause::DisplacementOrRudderEffectiveness];

/// Seconds in a year (365.25 days).
pub const YEAR_S: f64 = 365.25 * 86400.0;

/// The alert limits' per-look probability over the alarm's.
pub const ALERT_FACTOR: f64 = 1000.0;

/// The families of looks that share a test's false-alarm probability, each over the N
/// window lengths: the servo's, the parameters' free shift, and one per parameter cause
/// ([`PARAMETER_CAUSES`]).
pub const LOOK_FAMILIES: usize = 2 + PARAMETER_CAUSES.len();

/// The limits of the sequential test, from the budget.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DecisionLimits {
    /// N: the longest window [tests].
    pub window: usize,
    /// `alpha_n`: each look's false-alarm probability.
    pub alpha_look: f64,
    /// `h_n` by the look's degrees of freedom (index; 0 unused): `P` per method in the
    /// window, 2 for a test measured without `e_b`.
    pub param: [f64; 2 * P + 1],
    /// The alert limits, likewise.
    pub param_alert: [f64; 2 * P + 1],
    /// `k_n` for one named cause, one method in the window, both (1 dof per method).
    pub cause: [f64; 2],
    /// The alert limits, likewise.
    pub cause_alert: [f64; 2],
    /// `g`.
    pub servo: f64,
    /// The servo's alert limit.
    pub servo_alert: f64,
    /// `alpha`: per test, both channels.
    pub alpha_test: f64,
}

impl DecisionLimits {
    /// The limits for `false_alarms_per_year` at one test every `test_period_s` seconds
    /// over windows of up to `window` tests.
    pub fn new(false_alarms_per_year: f64, test_period_s: f64, window: u32) -> Self {
        let tests_per_year = YEAR_S / test_period_s.max(1.0);
        let alpha_test = (false_alarms_per_year / tests_per_year).min(0.5);
        let n = window.max(1) as usize;
        let alpha_look = alpha_test / (LOOK_FAMILIES as f64 * effective_lengths(n));
        let factor = if ablation::off(Mechanism::AlertLevel) {
            1.0
        } else {
            ALERT_FACTOR
        };
        let alert = (alpha_look * factor).min(0.5);
        // chi2 with 1 dof: the square of a two-sided normal score.
        let chi2_1 = |p: f64| normal_isf(p / 2.0).powi(2);
        Self {
            window: n,
            alpha_look,
            param: std::array::from_fn(|d| chi2_isf(alpha_look, d.max(1) as f64)),
            param_alert: std::array::from_fn(|d| chi2_isf(alert, d.max(1) as f64)),
            cause: [chi2_1(alpha_look), chi2_isf(alpha_look, 2.0)],
            cause_alert: [chi2_1(alert), chi2_isf(alert, 2.0)],
            servo: normal_isf(alpha_look),
            servo_alert: normal_isf(alert),
            alpha_test,
        }
    }
}

/// The effective number of independent window lengths among `1..=n` (Li and Ji, 2005):
/// the looks over nested windows ending at the same test share their newest tests, the sums
/// over `i` and `j` tests correlating `sqrt(min / max)` (independent tests of equal
/// variance); with `l_k` the eigenvalues of that correlation matrix, `M_eff = sum_k [l_k >=
/// 1] + (l_k - floor(l_k))`. Between 1 (one length) and `n` (independent looks): 2 for
/// `n = 2` to 4, 4 for 8.
pub fn effective_lengths(n: usize) -> f64 {
    let n = n.max(1);
    let r = nalgebra::DMatrix::from_fn(n, n, |i, j| {
        let (a, b) = ((i.min(j) + 1) as f64, (i.max(j) + 1) as f64);
        (a / b).sqrt()
    });
    let m: f64 = r
        .symmetric_eigenvalues()
        .iter()
        .map(|&l| {
            let l = l.max(0.0);
            let whole = if l >= 1.0 { 1.0 } else { 0.0 };
            whole + (l - l.floor())
        })
        .sum();
    m.clamp(1.0, n as f64)
}
