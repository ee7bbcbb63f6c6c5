//! A test's own measurement error, carried through the networks (docs/fdi.md, "A test's
//! own measurement error").
//!
//! Model: each CLFRT tone's `ln |G|` and `arg G` carry an error of standard deviation
//! `gain_ci90_rel / 1.645` and `phase_ci90_rad / 1.645` (their 90 % intervals,
//! `crate::core::dsp::tones`), independent between tones and between gain and phase. The
//! residual `(e_u [m/s], e_D [fraction of D_nom], e_b [ln])` is a smooth function of them
//! (the networks and `sensitivity::ln_gain`), so to first order its covariance from the
//! test's own tones is `sum_i d_i d_i^T`, `d_i` the residual's central difference over
//! `+- 1 sd` of input `i`. An HBT test carries no per-test interval of its cycle's amplitude
//! or response: `None`.

use super::envelope::{self, Sample, Settings};
use super::fit::CI90_TO_SIGMA;
use super::sensitivity;
use super::stats::{Cov, P};
use crate::core::estimator::{Estimator, EstimatorScratch};
use crate::core::wire::{Features, Method};

/// The residual of `features` as the networks read it (`e_u` against `u_log`).
fn residual(
    method: Method,
    features: &Features,
    est: &Estimator,
    scratch: &mut EstimatorScratch,
    u_log: f64,
    d_nom_t: f64,
) -> Option<[f64; P]> {
    let e = est.estimate(method, features, scratch).ok()?;
    let g = sensitivity::ln_gain(features).unwrap_or(0.0);
    let r = [e.speed_mps - u_log, e.displacement_t / d_nom_t, g];
    r.iter().all(|x| x.is_finite()).then_some(r)
}

/// The residual's covariance from the test's own tone intervals (see the module doc);
/// `None` for an HBT test or where the features do not say.
pub fn measurement_cov(
    method: Method,
    features: &Features,
    est: &Estimator,
    scratch: &mut EstimatorScratch,
    d_nom_t: f64,
) -> Option<Cov> {
    let c = features.clfrt()?;
    let u_log = features.speed_log_mps().filter(|u| u.is_finite())?;
    let mut cov = [[0.0; P]; P];
    for (k, t) in c.tones.iter().enumerate() {
        let sg = t.gain_ci90_rel * CI90_TO_SIGMA;
        let sp = t.phase_ci90_rad * CI90_TO_SIGMA;
        if !(sg.is_finite() && sp.is_finite() && sg >= 0.0 && sp >= 0.0) {
            return None;
        }
        for (which, s) in [(0, sg), (1, sp)] {
            if s == 0.0 {
                continue;
            }
            let mut at = |sign: f64| -> Option<[f64; P]> {
                let mut f = c.clone();
                let tk = &mut f.tones[k];
                if which == 0 {
                    tk.gain *= (sign * s).exp();
                } else {
                    tk.phase_rad += sign * s;
                }
                residual(method, &Features::Clfrt(f), est, scratch, u_log, d_nom_t)
            };
            let (hi, lo) = (at(1.0)?, at(-1.0)?);
            let d: [f64; P] = std::array::from_fn(|j| 0.5 * (hi[j] - lo[j]));
            for (i, row) in cov.iter_mut().enumerate() {
                for (j, v) in row.iter_mut().enumerate() {
                    *v += d[i] * d[j];
                }
            }
        }
    }
    Some(Cov(cov)).filter(Cov::is_finite)
}

/// Fewest learned tests in the test's own sea whose measurement error stands for the
/// vessel's typical there; with fewer, every learned test's, carried by the design spreads.
pub const MIN_TYPICAL: usize = 3;

/// The median of `v` (not empty).
fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// The vessel's typical measurement variances at a test of design spreads `s` in the sea `w`
/// (`envelope` coordinates): per component, the median, in design-spread units, of the
/// learned tests' own (`Sample::meas`) in that sea (within one `reference.bandwidth-sea`;
/// every learned test's where fewer than `MIN_TYPICAL` are there), carried to the test by
/// `s`. A median, because the tests it stands for are the typical ones, not the few whose
/// tones a wave spoiled. `None` where no learned test carries its own.
pub fn typical(samples: &[Sample], st: &Settings, w: f64, s: [f64; P]) -> Option<Typical> {
    let units = |x: &Sample| -> Option<[f64; P]> {
        let v = x.meas?.variances();
        let u: [f64; P] = std::array::from_fn(|j| v[j] / (x.s[j] * x.s[j]));
        u.iter().all(|x| x.is_finite()).then_some(u)
    };
    let here: Vec<[f64; P]> = samples
        .iter()
        .filter(|x| envelope::same_sea(st, x.x(st)[3], w))
        .filter_map(units)
        .collect();
    let local = here.len() >= MIN_TYPICAL;
    let pool = if local {
        here
    } else {
        samples.iter().filter_map(units).collect()
    };
    if pool.is_empty() {
        return None;
    }
    let mut v = Vec::with_capacity(pool.len());
    let var = std::array::from_fn(|j| {
        v.clear();
        v.extend(pool.iter().map(|c| c[j]));
        median(&mut v) * s[j] * s[j]
    });
    Some(Typical { var, local })
}

/// The vessel's typical measurement variances at a test (`typical`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Typical {
    /// Per component `(e_u [m/s], e_D [fraction], e_b [ln])`, squared.
    pub var: [f64; P],
    /// Learned in the test's own sea (else carried from the others by the design spreads).
    pub local: bool,
}

/// A test's measurement error beyond the vessel's typical at its sea, per component:
/// `diag(max(0, meas_jj - typical_j))` (0 without either). Added to the test's covariance:
/// the scatter learned from the vessel's tests already holds the typical test's own error,
/// and a test whose tones a wave spoiled is read with its own, wider, interval. Per
/// component, as the outliers show themselves (docs/fdi.md): the error's direction from one
/// test to the next is not the typical's.
pub fn excess(meas: Option<Cov>, typical: Option<Typical>) -> Cov {
    match (meas, typical) {
        (Some(m), Some(t)) => {
            let v = m.variances();
            Cov::diag(std::array::from_fn(|j| {
                let x = v[j] - t.var[j];
                if x.is_finite() && x > 0.0 {
                    x.sqrt()
                } else {
                    0.0
                }
            }))
        }
        _ => Cov::default(),
    }
}

#[cfg(test)]
#[path = "noise_tests.rs"]
mod tests;
