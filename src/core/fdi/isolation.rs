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
//! Whitened with the test's covariance, `v~ = L^-1 v`. Each cause is a model of the look's
//! n tests: the cause began within them and moved each test's whitened residual along its
//! direction, by a size the look fits. The part of the summed residuals the fitted model
//! leaves is the cause's cost (the free shift's statistic less the cause's look,
//! `crate::core::fdi::decision`):
//!
//! ```text
//! J_log = sum_m |s_m|^2 / k_m - (sum_k v_k . z_k)^2 / sum_m ((1 - c_m) sum_k |v_k|^2 + c_m |sum_k v_k|^2)
//! J_D   = sum_m |s_m - (u_mD . s_m) u_mD|^2 / k_m,       k_m = n_m (1 + (n_m - 1) c_m)
//! ```
//!
//! (`s_m` the sum of method m's whitened residuals in the look, `u_mD` the unit mean of its
//! displacement directions). A speed-log bias is one number for the vessel: it moves both
//! methods' residuals by `beta v_k` with directions that are exact per m/s, so its model has
//! one size (`decision::COMMON_SIZE`), and how much each method moved is evidence for or
//! against it. A displacement's direction is read through a model of the features that a
//! hull unlike the training model can bend: a size per method. Under the true cause its cost
//! is chi-square with the look's components less the sizes it fitted (`d_log = sum_m p_m - 1`,
//! `d_D = sum_m p_m - M`); the cause whose cost is the likelier, `P(chi2_d > J_c)`, is named
//! (on a tie, the cause with fewer sizes: a model that fits as well with less freedom). So a
//! look with more freedom does not win the name by it, and a log bias seen by both methods
//! in the ratio it predicts is named the log even where each method alone cannot tell the
//! two apart (the second-order hulls, where a test's two directions are a few degrees apart).
//! The name is taken over the raising look's window, whichever look raised the alarm. The
//! servo channel names `steering_actuator` by itself (`crate::core::fdi::decision`): one
//! fault at a time, and a slow servo also moves the parameter residuals (its lag changes the
//! loop the networks learned), which the servo check measures directly.

use super::decision::{method_sums, Entry};
use super::stats::{chi2_sf, dot, P};
use crate::core::wire::Cause;
use std::collections::VecDeque;

/// The parameter causes in the order of [`Entry::directions`].
pub const PARAMETER_CAUSES: [Cause; 2] =
    [Cause::SpeedLog, Cause::DisplacementOrRudderEffectiveness];

/// What the window says of the parameter causes (`isolation::PARAMETER_CAUSES`' order).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Costs {
    /// `J_c`: the part of the look's evidence each cause's model leaves.
    pub j: [f64; 2],
    /// Its degrees of freedom: the look's components less the sizes the model fitted.
    pub dof: [f64; 2],
}

/// The per-cause costs of the newest `n` entries (module doc).
pub fn costs(window: &VecDeque<Entry>, n: usize) -> Costs {
    let per = method_sums(window, n);
    let (mut free, mut dof) = (0.0, 0.0);
    let (mut j_d, mut proj, mut var) = (0.0, 0.0, 0.0);
    for p in &per {
        let (s, scale, c) = (p.sum, p.scale(), p.offset_var);
        free += dot(s, s) / scale;
        dof += p.dim as f64;
        let along = p.along(1);
        j_d += (dot(s, s) - along * along).max(0.0) / scale;
        let w = p.along_sum[0];
        proj += p.projection[0];
        var += (1.0 - c) * p.norm2[0] + c * dot(w, w);
    }
    let j_log = if var > 0.0 {
        (free - proj * proj / var).max(0.0)
    } else {
        free
    };
    Costs {
        j: [j_log, j_d],
        dof: [dof - 1.0, dof - per.len() as f64],
    }
}

/// The parameter cause the costs of a window name: the one whose cost is the likelier at its
/// own degrees of freedom, `P(chi2_d > J_c)`; where both tails are equal (both 1, or both
/// under the smallest double), the one nearer its chi-square's bulk by the Wilson-Hilferty
/// normal score, and then the one with more degrees of freedom (fewer sizes fitted).
pub fn name(costs: Costs) -> Vec<Cause> {
    let Costs { j, dof } = costs;
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

/// `v / |v|` (0 stays 0).
pub fn unit(v: [f64; P]) -> [f64; P] {
    let n = dot(v, v).sqrt();
    if n > 0.0 && n.is_finite() {
        v.map(|x| x / n)
    } else {
        [0.0; P]
    }
}
