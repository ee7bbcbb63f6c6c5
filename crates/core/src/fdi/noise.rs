//! A test's own measurement error against the vessel's typical (docs/fdi.md, "A test's own
//! measurement error"): the scatter already holds a typical test's error, so a CLFRT test
//! adds only its excess over the typical of the learned tests in its sea. The test's own
//! error covariance is `raw::measurement_cov`.

use super::envelope;
use super::point::{Regression, Sample};
use super::stats::{median, Cov, P};

/// Fewest learned tests in the test's own sea whose measurement error stands for the
/// vessel's typical there; with fewer, every learned test's, carried by the design spreads.
pub const MIN_TYPICAL: usize = 3;

/// The vessel's typical measurement variances at a test of design spreads `s` in the sea `w`
/// (`envelope` coordinates): per component, the median, in design-spread units, of the
/// learned tests' own (`Sample::meas`) in that sea (within one `calibration.bandwidth-sea`;
/// every learned test's where fewer than `MIN_TYPICAL` are there), carried to the test by
/// `s`. A median, because the tests it stands for are the typical ones, not the few whose
/// tones a wave spoiled. `None` where no learned test carries its own.
pub fn typical(samples: &[Sample], st: &Regression, w: f64, s: [f64; P]) -> Option<Typical> {
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
