//! The vessel's healthy residual over its operating envelope: a local linear regression with
//! a prior on its slopes, and the prediction interval it gives at a new operating point.
//!
//! ## Model
//!
//! A healthy test of one method at the operating point `x = (u, l, g, w)` (`u` the speed
//! log [m/s], `l = ln D_decl` the declared displacement's logarithm, `g = ln s` the logarithm
//! of the excitation's scale against its design: HBT's relay scale, CLFRT's tones' geometric
//! mean, 0 when the test played as designed; `w = ln(max(i, i_calm) / i_calm)` of the test's
//! sea index `i`, its measured wave yaw [deg], `i_calm` the calm anchor
//! `calibration.sea-wave-yaw-deg[0]`: 0 in a calm sea, 1.3 in a moderate one, 2.3 in a rough one at
//! the defaults) has the raw residual
//! (`crate::core::fdi::reference`) `e = m(x) + eps`, with
//!
//! - `m(x)` the networks' structural bias on this ship: smooth in `x`, unknown, learned.
//!   The excitation's scale is part of the point because a test sized down to the loop it
//!   found (`crate::core::monitor::sizing`) is read back to the design by the describing
//!   function of a linear ship: on a nonlinear hull the read-back is biased, by as much as
//!   0.4 m/s of HBT's speed for a relay at 0.83 of its design (KVLCC2, 9.5 m/s), and a
//!   ship near the sizing's threshold plays one scale or the other from test to test. The
//!   sea is part of it because the wave-induced yaw biases what a test reads (the relay
//!   switches early on a wave, the tones' gains gather the waves' power at their
//!   frequencies), and the networks' bias per sea (the model files' calm and moderate
//!   means) is the training ship's, not this hull's: measured on the family, a matured
//!   reference met a sea one state rougher with HBT's `e_u` moved by 0.1-1.5 m/s per unit
//!   of `w` and `e_D` by up to 0.1;
//! - `eps ~ N(0, S_sea S~ S_sea)`: the test-to-test scatter, its *shape* `S~` (a 3 x 3
//!   covariance in units of the design spreads) carried to a test's sea by that test's
//!   design spreads `S_sea = diag(s_u, s_D, s_D)` (`e_b`, the ln of the test's own
//!   high-frequency gain, is a relative quantity like `e_D`). The shape is the same over
//!   the envelope but for the sea: in another sea only the tests there vouch for it
//!   (`local_shape`), the design spreads carrying it there as a prior worth `CARRIED_DOF`.
//!
//! Near a point `x*`, `m(x) ~ a_0 + a_u (u - u*) + a_l (l - l*) + a_g (g - g*) + a_w
//! step(w - w*)` per component (`step` the part beyond half the sea's bandwidth: one sea's
//! own scatter of the sea index is no change of sea, `sea_step`). Each
//! component is fitted by weighted least squares over the learned tests, each test weighted
//! by its noise (`1 / (s_ij^2 S~_jj)`) and by a kernel of its distance from `x*`,
//!
//! ```text
//! w = 1 / (1 + d^2),
//! d^2 = ((u - u*) / b_u)^2 + ((l - l*) / b_l)^2 + ((g - g*) / b_g)^2 + ((w - w*) / b_w)^2
//! ```
//!
//! (`calibration.bandwidth-speed-mps`, `-loading`, `-excitation`, `-sea`; a test that does not
//! know its sea adds no distance in it): a soft bin, the method
//! of bins of wind-turbine power curves (IEC 61400-12) made continuous, and ISO 19030's
//! reference conditions made local. The slopes carry a Gaussian prior with standard
//! deviations `calibration.slope-speed`, `-loading`, `-excitation` and `-sea` (per component,
//! `e_b` taking the displacement's: both are fractions of the ship's own value; in speed
//! its own, `calibration.slope-speed-gain`): how
//! fast a network's bias on a ship unlike its training model may change across the
//! envelope beyond what physics predicts. The prior's mean is 0 (in the sea: the model
//! files' per-sea bias is already removed), except in declared loading,
//! where it is the learned tests' own slope of `b` scaling by `1 / D` (`Sample::loading_slope`,
//! `crate::core::fdi::sensitivity::scale_b`), and in speed: there it is the **similarity
//! law's slope**, the kernel-weighted mean of the learned tests' own
//! (`Sample::speed_slope`, `crate::core::fdi::sensitivity::scale_speed`): each test's
//! features moved to a neighbouring speed as the same ship would play them there, read by
//! the networks. On the first-order ship the networks were trained on it is near 0; on a
//! hull unlike it, it is how the networks misread that hull at another speed (measured on
//! the family: `e_D` of CLFRT on the T2/T1 0.1 hull -0.107 for 0.5 m/s slower, predicted
//! -0.104; on the upper-strength hull -0.316 for 2 m/s, predicted -0.308). For a test
//! (`predict_for`) the mean in speed and in loading is the **trapezoid** of the learned
//! tests' slope and the test's own, `(beta_learned + beta_test) / 2`: the law bends (the
//! gain moves as `2 ln u`, its slope `2 / u`), and the learned slope carried straight from 4
//! to 5.5 m/s over-predicts the gain's move by 0.11, the trapezoid by 0.011 (its error is
//! third order in the move). The test's slope is one test's reading: a quarter of the
//! learned slopes' scatter near `x*` joins the prior's variance. `e_b`'s prior in speed is
//! its own (`calibration.slope-speed-gain`: the spread of the law's error over a population
//! of hulls, docs/fdi.md). The intercept has a flat prior. The fit's intercept is the
//! predicted offset at `x*`; its posterior variance `(A^-1)_00` is the prediction's own:
//! small where the ship has been tested, growing with the distance from what was learned
//! (the kernel and the slope prior), never the design's wide limits.
//!
//! The shape `S~` is the scatter of the learned tests about the fit at their own points,
//! normalised by their design spreads, over the effective degrees of freedom `nu = n -
//! sum_i h_ii` (`h_ii` the leverage of test i at its own point): `n - 1` when every test was
//! at one point, the sample covariance. It is computed in passes to its fixed point (at most
//! `SHAPE_PASSES`): the first with the raw scatter about the sample's mean as the noise
//! weights and the slopes all but free (the prior `LOOSE` times wider), then with the
//! previous pass's shape and the prior. At one operating point the first pass is the fixed
//! point (the fit is the sample's mean whatever the weights). Across points the raw scatter
//! counts the offset's move between them as noise, many times the real scatter; a fit
//! weighted with that noise leans on the slope prior, is pulled towards the other points'
//! offset and leaves the move in the residuals, which keeps the noise large: a fixed point
//! of its own, which two passes from the raw scatter stayed near (a second point's offset
//! fitted halfway to the first's, the unit test
//! `a_second_point_is_fitted_at_its_own_offset_when_the_offset_moved_far`).

use super::point::{Point, Sample, Settings, Slopes, X};
use super::raw::Raw;
use super::stats::{Cov, P};
use nalgebra::{Matrix5, Vector5};
use serde::{Deserialize, Serialize};

/// Smallest noise variance in design-spread units (a sample with no scatter at all).
const MIN_SHAPE_VAR: f64 = 1e-8;

/// The most passes of the shape's estimate (the fits weighted by the noise, the noise from
/// the residuals about the fits), stopping early at its fixed point.
const SHAPE_PASSES: usize = 12;

/// The degrees of freedom the shape carried to another sea by the design spreads is worth
/// there: an inverse-Wishart prior about
/// it, `P + 2`, the weakest whose mean exists. Measured on the family (`eval --fdi --family
/// --scenarios envelope`, the seas' commissioning samples), the scatter in design-spread
/// units moves between a calm and a moderate sea by up to 3 times in standard deviation,
/// which this prior's 1 % tail (9 times the variance) covers.
pub const CARRIED_DOF: f64 = P as f64 + 2.0;

/// How much wider the slope prior is in the shape's first pass.
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
fn condition_distance(st: &Settings, a: X, b: X) -> f64 {
    let d = delta(a, b);
    (1..4)
        .map(|i| (d[i] / st.bandwidth[i]).powi(2))
        .sum::<f64>()
        .sqrt()
}

/// Whether two tests' `w` are one sea: within one `calibration.bandwidth-sea` (a NaN `w`, a
/// test at every sea, is in any). A sea state apart is about 1 (calm to moderate 1.3,
/// moderate to rough 0.9 at the default anchors); one sea's own tests scatter by about 0.1.
pub fn same_sea(st: &Settings, w: f64, at: f64) -> bool {
    let d = w - at;
    d.is_nan() || (d / st.bandwidth[3]).abs() <= 1.0
}

/// The sea's regressor for a difference `dw` in `w`: the part beyond half a bandwidth. One
/// test's sea index is its wave yaw over that test, which scatters by about 0.1 in `w`
/// within one sea (measured on the family: calm 0.02 +- 0.05, moderate 1.34 +- 0.1, rough
/// 2.27 +- 0.1); a slope fitted to that scatter is noise, and the next sea would be
/// predicted along it. Within half a bandwidth the offset is one sea's.
pub(super) fn sea_step(st: &Settings, dw: f64) -> f64 {
    let dead = 0.5 * st.bandwidth[3];
    dw.signum() * (dw.abs() - dead).max(0.0)
}

/// The kernel weight and squared distance between two operating points.
fn kernel(st: &Settings, a: X, b: X) -> (f64, f64) {
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
    st: &Settings,
    at: X,
    j: usize,
    noise: f64,
    own: Option<&Slopes>,
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
    st: &Settings,
    at: X,
    noise: [f64; P],
    own: Option<&Slopes>,
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
pub fn shape(samples: &[Sample], st: &Settings) -> Option<Shape> {
    let n = samples.len();
    if n < 2 {
        return None;
    }
    // Pass 0: the raw normalised scatter about its mean (an over-estimate when the offset
    // moves over the samples) as the noise weights.
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
    // Pass 0 fits with the slopes all but free (the module doc says why).
    let loose = Settings {
        slope_speed: st.slope_speed.map(|v| v * LOOSE),
        slope_loading: st.slope_loading.map(|v| v * LOOSE),
        slope_excitation: st.slope_excitation.map(|v| v * LOOSE),
        slope_sea: st.slope_sea.map(|v| v * LOOSE),
        slope_speed_gain: st.slope_speed_gain * LOOSE,
        ..*st
    };
    let mut out: Option<Shape> = None;
    let passes = if super::ablation::off(super::ablation::Mechanism::ShapeFixedPoint) {
        1
    } else {
        SHAPE_PASSES
    };
    for pass in 0..passes {
        let prior = if pass == 0 { &loose } else { st };
        let fits: Vec<Fit> = points
            .iter()
            .map(|&x| fit(samples, prior, x, noise, None))
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
        if !cov.is_finite() {
            return None;
        }
        let settled = out.is_some_and(|o: Shape| {
            let close = |a: f64, b: f64| (a - b).abs() <= 1e-9 * a.abs().max(b.abs());
            o.cov
                .0
                .iter()
                .flatten()
                .zip(cov.0.iter().flatten())
                .all(|(a, b)| close(*a, *b))
        });
        noise = cov.variances();
        out = Some(Shape { cov, dof });
        if settled {
            break;
        }
    }
    out
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
pub fn local_shape(samples: &[Sample], st: &Settings, global: &Shape, at: &Point) -> Shape {
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
pub fn predict(samples: &[Sample], st: &Settings, shape: &Shape, at: &Point) -> Option<Prediction> {
    predict_with(samples, st, shape, at, None)
}

/// The predicted offset for a test at `at` whose own physical slopes are `own`: the learned
/// tests moved there along the trapezoid of their slopes and the test's (module doc).
pub fn predict_for(
    samples: &[Sample],
    st: &Settings,
    shape: &Shape,
    at: &Point,
    own: &Slopes,
) -> Option<Prediction> {
    predict_with(samples, st, shape, at, Some(own))
}

fn predict_with(
    samples: &[Sample],
    st: &Settings,
    shape: &Shape,
    at: &Point,
    own: Option<&Slopes>,
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
pub fn forget(samples: &mut Vec<Sample>, st: &Settings, memory: usize) {
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
        }
    }
}

#[cfg(test)]
#[path = "envelope_tests.rs"]
pub(super) mod tests;
