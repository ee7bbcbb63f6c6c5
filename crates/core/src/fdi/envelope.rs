//! The vessel's healthy offset `mu(x)`, its error `Omega(x)` and the scatter's shape `S~` over
//! the operating envelope (docs/fdi.md, "How the normal is learned", "The reference follows
//! the ship"): a kernel-weighted local linear regression with a Gaussian prior on its slopes.
//!
//! At `x* = (u, ln D, ln s, w)` (`point::Point::x`) each component `j` is fitted by weighted
//! least squares, each learned test weighted `1 / (1 + d^2)` over its noise `s_ij^2 S~_jj`:
//!
//! ```text
//! e_j = a_0 + a_u du + a_l dl + a_g dg + a_w sea_step(dw)
//! d^2 = (du / b_u)^2 + (dl / b_l)^2 + (dg / b_g)^2 + (dw / b_w)^2
//! ```
//!
//! `b` the widths `calibration.bandwidth-*` (a test without a sea index adds no distance in
//! it). `a_0` has a flat prior, the slopes sd `calibration.slope-*` about 0, but in speed and
//! loading about the physical slopes: for a test ([`predict_for`]) the trapezoid of the
//! learned tests' kernel-weighted slope and its own, with a quarter of the learned slopes'
//! scatter added to the prior's variance. A [`Prediction`] holds `a_0` in physical units, its
//! covariance (growing away from the learned tests), the kernel support, the nearest learned
//! test's distances in bandwidths and the slope prior's share of each variance; `None` when
//! the normal equations are singular or not finite.
//!
//! [`shape`]: the scatter about the fits at the tests' own points in design-spread units, over
//! `nu = n - sum h_ii` (at least 1), the fits weighted by the raw scatter and with the slopes
//! all but free, so that an offset moved between points is not read as scatter; `None` under two
//! tests. [`local_shape`]: the tests in the point's sea, pooled with the global shape as a
//! prior worth [`CARRIED_DOF`] where other seas were learned too.

use super::point::{PhysicalSlopes, Point, Regression, Sample, X};
use super::raw::Raw;
use super::stats::{Cov, P};
use nalgebra::{Matrix5, Vector5};
use serde::{Deserialize, Serialize};

/// Smallest noise variance in design-spread units (a sample with no scatter at all).
const MIN_SHAPE_VAR: f64 = 1e-8;

/// The degrees of freedom the shape carried to another sea by the design spreads is worth
/// there: an inverse-Wishart prior about it, `P + 2`, the weakest whose mean exists.
pub const CARRIED_DOF: f64 = P as f64 + 2.0;

/// How much wider the slope prior is in the shape's fits.
const LOOSE: f64 = 1000.0;

/// The shape of the healthy scatter, in units of the design spreads.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Shape {
    /// `S~`.
    pub cov: Cov,
    /// Its effective degrees of freedom `nu`.
    pub dof: f64,
}

/// The predicted healthy offset at one operating point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Prediction {
    /// `m(x*)`: `(e_u [m/s], e_D [fraction], e_b [ln])`.
    pub offset: [f64; P],
    /// Its error's covariance (physical units; the shape taken as known).
    pub cov: Cov,
    /// The kernel weight the learned tests lend this point (tests' worth).
    pub support: f64,
    /// Distance to the nearest learned test, in bandwidths.
    pub nearest: f64,
    /// Distance in declared loading, excitation and sea alone (speed left out) to the
    /// nearest learned test, in bandwidths.
    pub nearest_conditions: f64,
    /// The slope prior's share of each component's variance in `cov` (0 where the tests
    /// span the point).
    pub prior_share: [f64; P],
}

/// The difference `a - b` per coordinate, 0 where either is NaN (a test at every sea).
fn delta(a: X, b: X) -> X {
    std::array::from_fn(|i| {
        let d = a[i] - b[i];
        if d.is_nan() {
            0.0
        } else {
            d
        }
    })
}

/// Whether two operating points are the same (a NaN sea the same as a NaN sea).
fn same(a: &X, b: &X) -> bool {
    a.iter()
        .zip(b)
        .all(|(p, q)| p == q || (p.is_nan() && q.is_nan()))
}

/// The distance between two operating points in their conditions alone (declared loading,
/// excitation and sea; speed left out), in bandwidths.
fn condition_distance(st: &Regression, a: X, b: X) -> f64 {
    let d = delta(a, b);
    (1..4)
        .map(|i| (d[i] / st.bandwidth[i]).powi(2))
        .sum::<f64>()
        .sqrt()
}

/// Whether two tests' `w` are one sea: within one `calibration.bandwidth-sea` (a NaN `w`, a
/// test at every sea, is in any).
pub fn same_sea(st: &Regression, w: f64, at: f64) -> bool {
    let d = w - at;
    d.is_nan() || (d / st.bandwidth[3]).abs() <= 1.0
}

/// The sea's regressor for a difference `dw` in `w`: the part beyond half a bandwidth. One
/// test's sea index is its wave yaw over that test, which scatters within one sea; a slope
/// fitted to that scatter is noise, and the next sea would be predicted along it. Within half
/// a bandwidth the offset is one sea's.
pub(super) fn sea_step(st: &Regression, dw: f64) -> f64 {
    let dead = 0.5 * st.bandwidth[3];
    dw.signum() * (dw.abs() - dead).max(0.0)
}

/// The kernel weight and squared distance between two operating points.
fn kernel(st: &Regression, a: X, b: X) -> (f64, f64) {
    let d = delta(a, b);
    let d2 = (0..4)
        .map(|i| (d[i] / st.bandwidth[i]).powi(2))
        .sum::<f64>();
    (1.0 / (1.0 + d2), d2)
}

/// The prior mean of one physical slope over a move from the learned tests to the point, and
/// the variance its own error adds: the trapezoid of the learned tests' kernel-weighted mean
/// slope `m` (their scatter about it `v`) and the point's own `own`, whose error is one
/// test's, `v`, a quarter of it in the mean; without `own`, `m` and nothing.
fn trapezoid(m: f64, v: f64, own: Option<f64>) -> (f64, f64) {
    match own.filter(|s| s.is_finite()) {
        Some(s) => (0.5 * (m + s), 0.25 * v.max(0.0)),
        None => (m, 0.0),
    }
}

/// One component's local fit at `at`: `(intercept, its variance, the slope prior's part of
/// that variance)`. With `own`, the fit is for a test whose own physical slopes those are
/// (the module doc's trapezoid).
fn fit_component(
    samples: &[Sample],
    st: &Regression,
    at: X,
    j: usize,
    noise: f64,
    own: Option<&PhysicalSlopes>,
) -> Option<(f64, f64, f64)> {
    // The slopes' prior means in speed and loading: the physical slopes (the similarity law,
    // `b` scaling by `1 / D`) of the tests near `at`, and their scatter about them.
    let (mut sw, mut ss, mut sl, mut ss2, mut sl2) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for smp in samples {
        let (w, _) = kernel(st, smp.x(st), at);
        let (u, l) = (smp.speed_slope[j], smp.loading_slope[j]);
        if u.is_finite() && l.is_finite() {
            sw += w;
            ss += w * u;
            sl += w * l;
            ss2 += w * u * u;
            sl2 += w * l * l;
        }
    }
    let (mut mean_u, mut mean_l, mut var_u, mut var_l) = (0.0, 0.0, 0.0, 0.0);
    if sw > 0.0 {
        (mean_u, var_u) = trapezoid(
            ss / sw,
            ss2 / sw - (ss / sw).powi(2),
            own.map(|o| o.speed[j]),
        );
        (mean_l, var_l) = trapezoid(
            sl / sw,
            sl2 / sw - (sl / sw).powi(2),
            own.map(|o| o.loading[j]),
        );
    }
    let prior = |sd: f64, extra: f64| 1.0 / (sd.max(1e-12).powi(2) + extra);
    let p0 = Matrix5::from_diagonal(&Vector5::new(
        0.0,
        prior(st.speed_sd(j), var_u),
        prior(st.slope_loading[j.min(1)], var_l),
        prior(st.slope_excitation[j.min(1)], 0.0),
        prior(st.slope_sea[j.min(1)], 0.0),
    ));
    let mut a = p0;
    let mut b = Vector5::zeros();
    b[1] = a[(1, 1)] * mean_u;
    b[2] = a[(2, 2)] * mean_l;
    for smp in samples {
        let x = smp.x(st);
        let (w, _) = kernel(st, x, at);
        let var = smp.s[j] * smp.s[j] * noise.max(MIN_SHAPE_VAR);
        if var.is_nan() || var <= 0.0 {
            continue;
        }
        let d = delta(x, at);
        let phi = if super::ablation::off(super::ablation::Mechanism::EnvelopeSlopes) {
            Vector5::new(1.0, 0.0, 0.0, 0.0, 0.0)
        } else {
            Vector5::new(1.0, d[0], d[1], d[2], sea_step(st, d[3]))
        };
        a += phi * phi.transpose() * (w / var);
        b += phi * (w * smp.e[j] / var);
    }
    let inv = a.try_inverse()?;
    let coef = inv * b;
    let v = inv[(0, 0)];
    // inv = inv (P0 + X'WX) inv: the intercept's variance splits into the prior's part and
    // the tests'.
    let vp = (inv * p0 * inv)[(0, 0)].clamp(0.0, v.max(0.0));
    (coef[0].is_finite() && v.is_finite() && v >= 0.0).then_some((coef[0], v, vp))
}

/// A local fit: per component, `(intercept, its variance, the slope prior's part)`.
type Fit = [(f64, f64, f64); P];

/// Every component's local fit at `at`, with the noise variances `noise` (`S~_jj`), for a
/// test whose own physical slopes are `own` when given.
fn fit(
    samples: &[Sample],
    st: &Regression,
    at: X,
    noise: [f64; P],
    own: Option<&PhysicalSlopes>,
) -> Option<Fit> {
    let mut out = [(0.0, 0.0, 0.0); P];
    for (j, o) in out.iter_mut().enumerate() {
        *o = fit_component(samples, st, at, j, noise[j], own)?;
    }
    Some(out)
}

/// A test's residual about a fit, in design-spread units, and its mean leverage on it.
fn normalised(s: &Sample, f: &Fit, noise: [f64; P]) -> ([f64; P], f64) {
    let r = std::array::from_fn(|j| (s.e[j] - f[j].0) / s.s[j]);
    let h = (0..P)
        .map(|j| f[j].1 / (s.s[j] * s.s[j] * noise[j].max(MIN_SHAPE_VAR)))
        .sum::<f64>()
        / P as f64;
    (r, h)
}

/// `sum w r r'` accumulated.
fn add_outer(acc: &mut [[f64; P]; P], r: [f64; P], w: f64) {
    for i in 0..P {
        for j in 0..P {
            acc[i][j] += w * r[i] * r[j];
        }
    }
}

/// The shape of the scatter of `samples` (at least 2 of them) about their local fit.
pub fn shape(samples: &[Sample], st: &Regression) -> Option<Shape> {
    let n = samples.len();
    if n < 2 {
        return None;
    }
    // The raw normalised scatter about its mean (an over-estimate when the offset moves over
    // the samples) as the noise weights.
    let norm: Vec<[f64; P]> = samples
        .iter()
        .map(|s| std::array::from_fn(|j| s.e[j] / s.s[j]))
        .collect();
    let mut noise = [0.0; P];
    for (j, v) in noise.iter_mut().enumerate() {
        let m = norm.iter().map(|x| x[j]).sum::<f64>() / n as f64;
        *v = norm.iter().map(|x| (x[j] - m).powi(2)).sum::<f64>() / (n - 1) as f64;
    }
    // The fit at each distinct operating point, once (a commissioning sample is often at
    // one point: one fit for all).
    let mut points: Vec<X> = Vec::new();
    let index: Vec<usize> = samples
        .iter()
        .map(|s| {
            let x = s.x(st);
            points.iter().position(|p| same(p, &x)).unwrap_or_else(|| {
                points.push(x);
                points.len() - 1
            })
        })
        .collect();
    // The fits with the slopes all but free (the module doc says why).
    let loose = Regression {
        slope_speed: st.slope_speed.map(|v| v * LOOSE),
        slope_loading: st.slope_loading.map(|v| v * LOOSE),
        slope_excitation: st.slope_excitation.map(|v| v * LOOSE),
        slope_sea: st.slope_sea.map(|v| v * LOOSE),
        slope_speed_gain: st.slope_speed_gain * LOOSE,
        ..*st
    };
    let fits: Vec<Fit> = points
        .iter()
        .map(|&x| fit(samples, &loose, x, noise, None))
        .collect::<Option<_>>()?;
    let (mut acc, mut lev) = ([[0.0; P]; P], 0.0);
    for (s, &i) in samples.iter().zip(&index) {
        // The leverage of the test on its own fit, the components' mean.
        let (r, h) = normalised(s, &fits[i], noise);
        add_outer(&mut acc, r, 1.0);
        lev += h;
    }
    let dof = (n as f64 - lev).max(1.0);
    let cov = Cov(acc).times(1.0 / dof);
    cov.is_finite().then_some(Shape { cov, dof })
}

/// The shape of the scatter near `at`: the residuals about the fit at their own points (with
/// `global`'s noise weights) of the learned tests in `at`'s sea (within one bandwidth in `w`:
/// the shape carried to another sea by the design spreads is a guess, which the tests there
/// must vouch for), each weighted by the kernel from `at`,
///
/// ```text
/// S~(x*) = sum w_i r_i r_i' / sum w_i (1 - h_i),   nu(x*) = (sum a_i)^2 / sum a_i^2,
/// a_i = w_i (1 - h_i)
/// ```
///
/// (Satterthwaite's dof of a weighted variance, at most `global`'s), pooled, where some
/// learned tests are in other seas, with `global` as a prior worth `CARRIED_DOF`
/// (`global` itself, at that dof, where no test is in this sea or none has a residual of
/// its own yet). Where every test is near `at` it is `global`; where the ship has been tested a few times at a point whose
/// scatter is not the commissioning point's (an estimator pressed against its training
/// box's edge scatters less there than inside it), the tests at that point speak for it,
/// with the few dof they are worth.
pub fn local_shape(samples: &[Sample], st: &Regression, global: &Shape, at: &Point) -> Shape {
    let noise = global.cov.variances();
    let at = at.x(st);
    let mut fits: Vec<(X, Fit)> = Vec::new();
    let (mut acc, mut den, mut den2) = ([[0.0; P]; P], 0.0, 0.0);
    let mut here = 0;
    for s in samples {
        let x = s.x(st);
        // Only the tests in the point's sea vouch for its scatter.
        if !same_sea(st, x[3], at[3]) {
            continue;
        }
        here += 1;
        let f = match fits.iter().find(|(p, _)| same(p, &x)) {
            Some((_, f)) => *f,
            None => {
                let Some(f) = fit(samples, st, x, noise, None) else {
                    return *global;
                };
                fits.push((x, f));
                f
            }
        };
        let (r, h) = normalised(s, &f, noise);
        let keep = (1.0 - h).clamp(0.0, 1.0);
        let (w, _) = kernel(st, x, at);
        add_outer(&mut acc, r, w);
        den += w * keep;
        den2 += (w * keep).powi(2);
    }
    let own = (den > 0.0 && den2 > 0.0)
        .then(|| Cov(acc).times(1.0 / den))
        .filter(|c| c.is_finite() && c.variances().iter().all(|v| *v > 0.0))
        .map(|cov| Shape {
            cov,
            dof: (den * den / den2).min(global.dof),
        });
    if here == samples.len() {
        // Every learned test is in this sea: the scatter is theirs.
        return own.unwrap_or(*global);
    }
    // Elsewhere, the tests here pooled with the shape carried from the others by the design
    // spreads, an inverse-Wishart prior worth `CARRIED_DOF`.
    let carried = global.dof.min(CARRIED_DOF);
    match own {
        None => Shape {
            dof: carried,
            ..*global
        },
        Some(o) => {
            let k = o.dof / (o.dof + carried);
            Shape {
                cov: o.cov.times(k).plus(global.cov.times(1.0 - k)),
                dof: (o.dof + carried).min(global.dof),
            }
        }
    }
}

/// The predicted offset at the operating point `at`, the learned tests moved there along
/// their own physical slopes (for a test at `at`, `predict_for`).
pub fn predict(
    samples: &[Sample],
    st: &Regression,
    shape: &Shape,
    at: &Point,
) -> Option<Prediction> {
    predict_with(samples, st, shape, at, None)
}

/// The predicted offset for a test at `at` whose own physical slopes are `own`: the learned
/// tests moved there along the trapezoid of their slopes and the test's (module doc).
pub fn predict_for(
    samples: &[Sample],
    st: &Regression,
    shape: &Shape,
    at: &Point,
    own: &PhysicalSlopes,
) -> Option<Prediction> {
    predict_with(samples, st, shape, at, Some(own))
}

fn predict_with(
    samples: &[Sample],
    st: &Regression,
    shape: &Shape,
    at: &Point,
    own: Option<&PhysicalSlopes>,
) -> Option<Prediction> {
    let at = at.x(st);
    let f = fit(samples, st, at, shape.cov.variances(), own)?;
    let (support, nearest, nearest_conditions) =
        samples
            .iter()
            .fold((0.0, f64::INFINITY, f64::INFINITY), |(w, d, l), s| {
                let x = s.x(st);
                let (wi, d2) = kernel(st, x, at);
                (
                    w + wi,
                    d.min(d2.sqrt()),
                    l.min(condition_distance(st, x, at)),
                )
            });
    // The components' errors: the tests' part correlates as their scatter does; the slope
    // prior's part is each component's own (the priors are independent).
    let data = f.map(|c| (c.1 - c.2).max(0.0));
    let cov = Cov(std::array::from_fn(|i| {
        std::array::from_fn(|j| {
            if i == j {
                f[i].1
            } else {
                shape.cov.correlation(i, j) * (data[i] * data[j]).sqrt()
            }
        })
    }));
    Some(Prediction {
        offset: f.map(|c| c.0),
        cov,
        support,
        nearest,
        nearest_conditions,
        prior_share: f.map(|c| if c.1 > 0.0 { c.2 / c.1 } else { 0.0 }),
    })
}

/// Keeps at most `memory` tests: the oldest of the most populated soft bin (a bandwidth of
/// speed by one of declared loading by one of sea) goes.
pub fn forget(samples: &mut Vec<Sample>, st: &Regression, memory: usize) {
    while samples.len() > memory {
        let bin = |x: &Sample| {
            let w = x.x(st)[3];
            (
                (x.speed_mps / st.bandwidth[0]).round() as i64,
                (x.displacement_t.max(1e-9).ln() / st.bandwidth[1]).round() as i64,
                if w.is_nan() {
                    -1
                } else {
                    (w / st.bandwidth[3]).round() as i64
                },
            )
        };
        let mut counts: Vec<((i64, i64, i64), usize)> = Vec::new();
        for x in samples.iter() {
            let b = bin(x);
            match counts.iter_mut().find(|(k, _)| *k == b) {
                Some((_, c)) => *c += 1,
                None => counts.push((b, 1)),
            }
        }
        let Some(&(fullest, _)) = counts.iter().max_by_key(|(_, c)| *c) else {
            return;
        };
        if let Some(i) = samples.iter().position(|x| bin(x) == fullest) {
            samples.remove(i);
        }
    }
}

impl From<&Raw> for Sample {
    /// A test's raw residual as a sample of the regression (its order set when learned).
    fn from(r: &Raw) -> Self {
        Sample {
            e: r.e(),
            s: r.s(),
            speed_mps: r.speed_log_mps,
            displacement_t: r.displacement_declared_t,
            excitation_scale: r.excitation_scale,
            sea_index: r.sea_index,
            speed_slope: r.speed_slope,
            loading_slope: r.loading_slope,
            order: 0,
            meas: r.meas,
            log_slope: r.log_slope,
        }
    }
}

#[cfg(test)]
#[path = "envelope_tests.rs"]
pub(super) mod tests;
