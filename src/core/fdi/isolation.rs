//! Isolation: which cause explains the window's evidence best.
//!
//! Each parameter cause moves a method's raw residual `(e_u [m/s], e_D [fraction])` along a
//! direction of its own:
//!
//! - a speed-log bias `beta`: `e_u` by `-beta` (the log is the speed residual's reference) and
//!   `e_D` by `g beta / D_nom` (the displacement network reads the log; `g = dD_est/du_log`,
//!   through the network at this test): `v_log = (-1, g / D_nom)`;
//! - a displacement change or a rudder effectiveness loss (both lower `b`; nothing in the
//!   features tells them apart): `v_D = (0, 1)`.
//!
//! Whitened with the test's covariance, `v~ = L^-1 v`. Under "cause c began within the
//! look's n tests, with a size of its own for each method", the log-likelihood ratio against
//! the unconstrained shift is the part of each method's summed residual off the cause's
//! line:
//!
//! ```text
//! J_c = sum_m |s_m - (u_mc . s_m) u_mc|^2 / (n_m (1 + n_m c_m)),   u_mc = unit(mean of v~)
//! ```
//!
//! (`s_m` the sum of method m's whitened residuals in the look, as in the decision: the free
//! shift's statistic less the part along the cause, `crate::core::fdi::decision`). The cause
//! with the smallest `J_c` over the raising look's window is named, whichever look (the free
//! shift's or a cause's) raised the alarm: the sizes per method here, so that a look with
//! fewer degrees of freedom does not win the name by them. The servo channel names `steering_actuator` by
//! itself (`crate::core::fdi::decision`): one fault at a time, and a slow servo also moves
//! the parameter residuals (its lag changes the loop the networks learned), which the servo
//! check measures directly.

use super::decision::{method_sums, Entry};
use super::stats::{dot, P};
use crate::core::wire::Cause;
use std::collections::VecDeque;

/// The parameter causes in the order of [`Entry::directions`].
pub const PARAMETER_CAUSES: [Cause; 2] =
    [Cause::SpeedLog, Cause::DisplacementOrRudderEffectiveness];

/// The per-cause costs `J_c` of the newest `n` entries.
pub fn costs(window: &VecDeque<Entry>, n: usize) -> [f64; 2] {
    let per = method_sums(window, n);
    let mut j = [0.0; 2];
    for p in per {
        let (s, scale) = (p.sum, p.scale());
        for (c, cost) in j.iter_mut().enumerate() {
            let along = p.along(c);
            let off = (dot(s, s) - along * along).max(0.0);
            *cost += off / scale;
        }
    }
    j
}

/// The parameter cause the costs `j` of a window (`costs`) name: the cheapest.
pub fn name(j: [f64; 2]) -> Vec<Cause> {
    if !(j[0].is_finite() && j[1].is_finite()) {
        return Vec::new();
    }
    let best = if j[0] < j[1] { 0 } else { 1 };
    vec![PARAMETER_CAUSES[best]]
}

/// `v / |v|` (0 stays 0).
pub fn unit(v: [f64; P]) -> [f64; P] {
    let n = dot(v, v).sqrt();
    if n > 0.0 && n.is_finite() {
        v.map(|x| x / n)
    } else {
        [0.0; P]
    }
}
