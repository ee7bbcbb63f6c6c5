//! Isolation (docs/fdi.md, "Isolation", under "The model" and under "Decision"): which
//! parameter cause explains the window's evidence best, and which other it does not rule out.
//!
//! Each cause is a model of a look's tests: a shift along the cause's whitened directions
//! (`window::Entry::directions`), the speed log by one size for both methods, the displacement
//! by one per method (`decision::COMMON_SIZE`). Its cost `J_c` ([`costs`]) is what the model
//! leaves of the free shift's statistic, its dof the look's components less the sizes:
//!
//! ```text
//! J_log = T_n - T_n,log,    J_D = min over d in {D, b} of sum_m (|s_m|^2 - (u_md . s_m)^2) / k_m
//! ```
//!
//! The displacement's cause has two models, one size per method each: the true
//! displacement's direction and the rudder effectiveness's, `b` alone. They are one on the
//! Nomoto class (`D` enters `b` alone) and two where the class's measured displacement
//! direction is in force (`crate::fdi::raw`, module doc); the cost is the better fit's, at
//! the same dof (the choice of two is a small look-elsewhere the rule-out's 95 % absorbs).
//!
//! - **The log's step.** Where every test of the look was at a point the vessel has learned,
//!   each model also explains the step `s` of the log's reading from before the fault, spread
//!   `sigma sqrt(1 + 1/n)`, `sigma` the steady ship's wander ([`log_wander`]: at least
//!   `fdi.floor-speed-mps` and 1 mm/s). The displacement's model adds `step_cost(s)`, the
//!   log's `step_cost(s - beta)`, its size `beta` fitted to residuals and step together; one
//!   dof more each. [`step_cost`] is 0 for no step and bounded by the prior of a speed change
//!   ([`SPEED_CHANGE_PRIOR`]).
//! - **The name** ([`name`]): the cause with the larger tail `P(chi2_dof > J_c)`, each cost at
//!   its own dof (the displacement's model fits a size per method, the log's one: comparing
//!   the costs alone would favour the model with more sizes); on a tie the one nearer its
//!   chi-square's bulk, then the one with fewer sizes. Nothing is named when a cost or dof is
//!   not finite, or a dof is not positive.
//! - **Not ruled out** ([`not_ruled_out`]): a cause whose cost exceeds the named one's by at
//!   most `chi2_q^-1(RULE_OUT_CONFIDENCE)`, `q` the named model's sizes: under the true cause
//!   the difference exceeds that with probability at most 5 %.

use super::limits::PARAMETER_CAUSES;
use super::point::Sample;
use super::stats::{chi2_isf, chi2_sf, dot};
use super::window::{method_sums, Entry};
use crate::wire::Cause;
use std::collections::VecDeque;

/// What the window says of the parameter causes (`limits::PARAMETER_CAUSES`' order).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Costs {
    /// `J_c`: the part of the look's evidence each cause's model leaves.
    pub j: [f64; 2],
    /// Its degrees of freedom: the look's components less the sizes the model fitted.
    pub dof: [f64; 2],
    /// The log's step the costs took in [m/s] (`None`: none known).
    pub log_step_mps: Option<f64>,
}

/// The prior probability that the ship changed its speed between two of its tests: once in
/// ten tests, one or two changes of passage speed a day at the default schedule.
pub const SPEED_CHANGE_PRIOR: f64 = 0.1;

/// The range over which such a change is equally likely, any size [m/s]: a merchant ship's
/// speeds span about 6 m/s, so a change lies within +-6 m/s. Flat, so that a change of speed
/// favours no size of log bias over another (a Gaussian would make a log bias that "explains"
/// part of a large change look likelier than the change alone).
pub const SPEED_CHANGE_RANGE_MPS: f64 = 12.0;

/// The fewest steps between consecutive learned tests that [`log_wander`] reads a scale from.
const MIN_STEPS: usize = 8;

/// A test's mean speed log's wander on a ship at steady speed [m/s]: the robust scale of the
/// reading's steps between the vessel's consecutive learned tests (`order` one apart, both
/// methods), `1.4826 MAD / sqrt 2` (a change of speed among them is an outlier the median
/// does not see), at least `floor` (the log's noise, `fdi.floor-speed-mps`) and 1 mm/s.
pub fn log_wander<'a>(samples: impl Iterator<Item = &'a Sample>, floor: f64) -> f64 {
    let mut by_order: Vec<(u64, f64)> = samples
        .filter(|s| s.order > 0 && s.speed_mps.is_finite())
        .map(|s| (s.order, s.speed_mps))
        .collect();
    by_order.sort_by_key(|x| x.0);
    let mut steps: Vec<f64> = by_order
        .windows(2)
        .filter(|w| w[1].0 == w[0].0 + 1)
        .map(|w| (w[1].1 - w[0].1).abs())
        .collect();
    let learned = if steps.len() >= MIN_STEPS {
        steps.sort_by(f64::total_cmp);
        1.4826 * steps[steps.len() / 2] / std::f64::consts::SQRT_2
    } else {
        0.0
    };
    learned.max(floor).max(1e-3)
}

/// `-2 ln` of the density of a step `x` [m/s] of the log's reading that the ship's own speed
/// made, less its value at 0: a steady ship's wander `N(0, sigma^2)` or, with the prior
/// [`SPEED_CHANGE_PRIOR`], a change of speed of any size (flat over
/// [`SPEED_CHANGE_RANGE_MPS`]). 0 for no step; a step no steady ship makes costs `2 ln(1 +
/// (1 - pi) W / (pi sigma sqrt(2 pi)))` whatever its size (12.8 at sigma 0.071): the evidence
/// is bounded by the prior of a change.
pub fn step_cost(x: f64, sigma: f64) -> f64 {
    let pi = SPEED_CHANGE_PRIOR;
    let flat = (pi / SPEED_CHANGE_RANGE_MPS).ln();
    let ln_density = |x: f64| {
        let a = (1.0 - pi).ln()
            - (sigma * (2.0 * std::f64::consts::PI).sqrt()).ln()
            - 0.5 * (x / sigma).powi(2);
        a.max(flat) + (-(a - flat).abs()).exp().ln_1p()
    };
    (2.0 * (ln_density(0.0) - ln_density(x))).max(0.0)
}

/// The entries of the newest `n` that a look takes, newest first.
fn taken(window: &VecDeque<Entry>, n: usize) -> Vec<&Entry> {
    window
        .iter()
        .rev()
        .take(n)
        .filter(|e| e.in_look(n))
        .collect()
}

/// The log's reading before the window's oldest test that has one: before any fault that
/// arose within the window (the look nearest its limit may be shorter than the fault's age:
/// a test that alerted, then one that alarmed).
pub fn reading_before(window: &VecDeque<Entry>) -> Option<f64> {
    window.iter().find_map(|e| e.log?.before_mps)
}

/// The look's step of the log's reading: the mean reading over the look's tests less the
/// reading before the fault (`onset`: while an alarm holds, the reading before the window
/// that raised it, the window since emptied; else [`reading_before`]), with its spread
/// `sigma sqrt(1 + 1/n)` (`None`: a test of the look without a reading, or none before, or
/// one measured at a point the vessel has not learned).
///
/// At a point not yet learned the reference is a prediction whose error is most of the
/// test's covariance: a log bias the size of the jump is then as cheap to the residual as the
/// prediction's error, and the step would name the log for every change of speed. Whether
/// the ship stayed where it was is only said by a residual against a learned point.
fn look_step(window: &VecDeque<Entry>, n: usize, onset: Option<f64>) -> Option<(f64, f64)> {
    let taken = taken(window, n);
    let oldest = taken.last()?.log?;
    let before = onset.or_else(|| reading_before(window))?;
    let mut sum = 0.0;
    for e in &taken {
        let log = e.log.filter(|l| l.learned_point)?;
        sum += log.now_mps;
    }
    let k = taken.len() as f64;
    let sigma = oldest.sigma_mps * (1.0 + 1.0 / k).sqrt();
    Some((sum / k - before, sigma))
}

/// `min_beta var (beta - beta_hat)^2 + step_cost(s - beta, sigma)`: the log model's size
/// fitted to the residuals and to the step together. The minimum lies between `beta_hat`
/// (the residuals' fit) and `s` (the step's); a grid over that interval, refined about its
/// best point by golden section (the step's cost is not convex: two local minima, one near
/// each end).
fn fit_log_size(var: f64, beta_hat: f64, s: f64, sigma: f64) -> f64 {
    let f = |b: f64| var * (b - beta_hat).powi(2) + step_cost(s - b, sigma);
    let (lo, hi) = (beta_hat.min(s), beta_hat.max(s));
    const GRID: usize = 256;
    let h = (hi - lo) / GRID as f64;
    let mut best = (f(lo), lo);
    for i in 1..=GRID {
        let b = lo + h * i as f64;
        let v = f(b);
        if v < best.0 {
            best = (v, b);
        }
    }
    let (mut a, mut c) = ((best.1 - h).max(lo), (best.1 + h).min(hi));
    let g = (5f64.sqrt() - 1.0) / 2.0;
    for _ in 0..40 {
        let (x1, x2) = (c - g * (c - a), a + g * (c - a));
        if f(x1) < f(x2) {
            c = x2;
        } else {
            a = x1;
        }
    }
    f(0.5 * (a + c)).min(best.0)
}

/// The per-cause costs of the newest `n` entries (module doc); `onset` the log's reading
/// before the fault, while an alarm holds ([`look_step`]).
pub fn costs(window: &VecDeque<Entry>, n: usize, onset: Option<f64>) -> Costs {
    let per = method_sums(window, n);
    let (mut free, mut dof) = (0.0, 0.0);
    let (mut j_d, mut j_r, mut proj, mut var) = (0.0, 0.0, 0.0, 0.0);
    for p in &per {
        let (s, scale, c) = (p.sum, p.scale(), p.offset_var);
        free += dot(s, s) / scale;
        dof += p.dim as f64;
        let (along, rudder) = (p.along(1), p.along_rudder());
        j_d += (dot(s, s) - along * along).max(0.0) / scale;
        j_r += (dot(s, s) - rudder * rudder).max(0.0) / scale;
        let w = p.along_sum[0];
        proj += p.projection[0];
        var += (1.0 - c) * p.norm2[0] + c * dot(w, w);
    }
    let j_log_min = if var > 0.0 {
        (free - proj * proj / var).max(0.0)
    } else {
        free
    };
    let mut out = Costs {
        j: [j_log_min, j_d.min(j_r)],
        dof: [dof - 1.0, dof - per.len() as f64],
        log_step_mps: None,
    };
    // The log's reading: one more component in each model (module doc, "The log's step").
    let step = look_step(window, n, onset)
        .filter(|_| !super::ablation::off(super::ablation::Mechanism::LogStep));
    if let Some((step, sigma)) = step {
        let beta_hat = if var > 0.0 { proj / var } else { step };
        out.j[0] = j_log_min + fit_log_size(var, beta_hat, step, sigma);
        out.j[1] += step_cost(step, sigma);
        out.dof = out.dof.map(|d| d + 1.0);
        out.log_step_mps = Some(step);
    }
    out
}

/// The parameter cause the costs of a window name: the one whose cost is the likelier at its
/// own degrees of freedom, `P(chi2_d > J_c)`; where both tails are equal (both 1, or both
/// under the smallest double), the one nearer its chi-square's bulk by the Wilson-Hilferty
/// normal score, and then the one with more degrees of freedom (fewer sizes fitted).
pub fn name(costs: Costs) -> Vec<Cause> {
    let Costs { j, dof, .. } = costs;
    if !(j.iter().chain(&dof).all(|x| x.is_finite()) && dof.iter().all(|d| *d > 0.0)) {
        return Vec::new();
    }
    let tail = |c: usize| chi2_sf(j[c], dof[c]);
    let score = |c: usize| {
        let v = 2.0 / (9.0 * dof[c]);
        ((j[c] / dof[c]).cbrt() - (1.0 - v)) / v.sqrt()
    };
    let order = tail(0)
        .total_cmp(&tail(1))
        .then_with(|| score(1).total_cmp(&score(0)))
        .then_with(|| dof[0].total_cmp(&dof[1]));
    let best = if order == std::cmp::Ordering::Greater {
        0
    } else {
        1
    };
    vec![PARAMETER_CAUSES[best]]
}

/// The confidence at which a cause's cost rules it out against the named one's
/// ([`not_ruled_out`]).
pub const RULE_OUT_CONFIDENCE: f64 = 0.95;

/// The parameter causes other than `named` that the costs do not rule out (module doc): `J_c
/// - J_named <= chi2_{p_named}(RULE_OUT_CONFIDENCE)`, `p_named` the sizes its model fitted
/// (the log 1, the displacement one per method: `dof_log - dof_D + 1`).
pub fn not_ruled_out(costs: Costs, named: Cause) -> Vec<Cause> {
    let Costs { j, dof, .. } = costs;
    let Some(k) = PARAMETER_CAUSES.iter().position(|c| *c == named) else {
        return Vec::new();
    };
    let sizes = [1.0, (dof[0] - dof[1] + 1.0).max(1.0)];
    let q = chi2_isf(1.0 - RULE_OUT_CONFIDENCE, sizes[k]);
    (0..PARAMETER_CAUSES.len())
        .filter(|&c| c != k && j[c].is_finite() && j[k].is_finite() && j[c] - j[k] <= q)
        .map(|c| PARAMETER_CAUSES[c])
        .collect()
}

#[cfg(test)]
#[path = "isolation_tests.rs"]
mod tests;
