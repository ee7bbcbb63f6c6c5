//! What a commissioning sample must resolve before it ends (`reference`, docs/fdi.md
//! "Commissioning"): a speed-log bias of `reference.resolve-speed-mps` and a displacement
//! change of `reference.resolve-displacement`.
//!
//! Each fault is read along its own direction `d` in `(e_u [m/s], e_D [fraction], e_b [ln])`:
//! a log bias moves `e_u` by -1 and `e_D` by the networks' slope in the log
//! (`Raw::log_slope`) per m/s; an undeclared displacement change moves the residual as a
//! declared one does (`Raw::loading_slope`: the class's displacement direction, or `b ~ 1 /
//! D`) but for the declaration itself, `e_D` by 1 more per unit. It must reach, with 95 %
//! power over [`RESOLVE_TESTS`] tests, the statistic whose calibrated value crosses the
//! single-test limit `h_1`. `Sigma` is the pooled
//! shape at the mean design spreads with its mean's error and the floors, `A` its learned
//! part, `nu_d` the dof along `d` (`prior::along`), the floors' share adding dof:
//!
//! ```text
//! sqrt(RESOLVE_TESTS delta^2 d' Sigma^-1 d) >= sqrt(t) + RESOLVE_POWER_Z
//! t = nu (exp(h_1 / (nu - 1)) - 1),   nu = nu_d / share,   share = y' A y / y' Sigma y,
//! y = Sigma^-1 d
//! ```
//!
//! (`t`: the statistic whose Hotelling tail at `nu` dof is the chi-square's at `h_1`, to the
//! order the tail's exponent holds.)

use super::point::Sample;
use super::stats::{Cov, P};

/// The tests a fault is resolved over (the window's, at most): the detection the decision
/// promises is within 3 tests.
pub const RESOLVE_TESTS: f64 = 3.0;

/// The one-sided normal quantile of the power commissioning resolves its faults with (95 %).
pub const RESOLVE_POWER_Z: f64 = 1.645;

/// The faults to resolve, and what reads them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Faults {
    /// The speed-log bias [m/s].
    pub speed_mps: f64,
    /// The displacement change [fraction].
    pub displacement: f64,
    /// The floors of `(e_u, e_D, e_b)`'s standard deviations.
    pub floors: [f64; P],
    /// `h_1`: the decision's single-test limit.
    pub single_limit: f64,
}

impl Faults {
    /// Whether `samples`, their scatter `shape` (design-spread units) known to `dofs` dof per
    /// component, resolve both faults (the module doc).
    pub fn resolved(&self, samples: &[Sample], shape: Cov, dofs: [f64; P]) -> bool {
        let n = samples.len() as f64;
        if n < 2.0 {
            return false;
        }
        let mean = |f: &dyn Fn(&Sample) -> f64| samples.iter().map(f).sum::<f64>() / n;
        let mean_s: [f64; P] = std::array::from_fn(|j| mean(&|x| x.s[j]));
        let learned = shape.scaled(mean_s).times(1.0 + 1.0 / n);
        let total = learned.plus(Cov::diag(self.floors));
        let resolves = |delta: f64, d: [f64; P]| -> bool {
            let Some(y) = total.solve(d) else {
                return false;
            };
            let lambda = delta * delta * total.form(y, y);
            let share = learned.form(y, y) / total.form(y, y);
            let nu = super::prior::along(dofs, learned, y) / share.max(f64::MIN_POSITIVE);
            let h = self.single_limit;
            let t = if nu.is_finite() {
                nu * (h / (nu - 1.0).max(f64::MIN_POSITIVE)).exp_m1()
            } else {
                h
            };
            (RESOLVE_TESTS * lambda).sqrt() >= t.sqrt() + RESOLVE_POWER_Z
        };
        let load: [f64; P] = std::array::from_fn(|j| mean(&|x| x.loading_slope[j]));
        resolves(self.speed_mps, [-1.0, mean(&|x| x.log_slope), 0.0])
            && resolves(self.displacement, [load[0], load[1] + 1.0, load[2]])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample(e: [f64; P]) -> Sample {
        Sample {
            e,
            s: [0.05, 0.002, 0.002],
            speed_mps: 7.0,
            displacement_t: 7000.0,
            excitation_scale: 1.0,
            speed_slope: [0.0; P],
            loading_slope: [0.0, 0.0, -1.0],
            sea_index: None,
            order: 0,
            meas: None,
            log_slope: 0.0,
        }
    }

    /// Against the formula by hand on a diagonal scatter with no floors, all learned: the
    /// log bias along `(-1, 0, 0)` resolves when `sqrt(3) delta / sd_u >= sqrt(t) + 1.645`,
    /// just above and not just below; a log slope in `e_D` makes a smaller bias resolvable.
    #[test]
    fn a_log_bias_resolves_where_the_formula_says() {
        let samples: Vec<Sample> = (0..6).map(|_| sample([0.0; P])).collect();
        let shape = Cov::diag([2.0, 1.0, 1.0]);
        let dofs = [20.0; P];
        let h = 30.0;
        let t: f64 = 20.0 * (h / 19.0f64).exp_m1();
        // sd_u = 2 * 0.05 * sqrt(7/6).
        let sd_u = 0.1 * (7.0f64 / 6.0).sqrt();
        let edge = (t.sqrt() + RESOLVE_POWER_Z) * sd_u / 3.0f64.sqrt();
        let faults = |speed: f64| Faults {
            speed_mps: speed,
            displacement: 1.0,
            floors: [0.0; P],
            single_limit: h,
        };
        assert!(faults(edge * 1.001).resolved(&samples, shape, dofs));
        assert!(!faults(edge * 0.999).resolved(&samples, shape, dofs));
        let sloped: Vec<Sample> = samples
            .iter()
            .map(|x| Sample {
                log_slope: 0.3,
                ..*x
            })
            .collect();
        assert!(faults(edge * 0.9).resolved(&sloped, shape, dofs));
    }
}
