//! Time-domain baseline: equation-error least squares of the Nomoto parameters.
//!
//! A conventional identification to compare the frequency-domain tests with: the approach the
//! source paper argues against. It reads the same heading and rudder records as the test's
//! own analysis and estimates `a` and `b` directly.
//!
//! ## Model
//!
//! ```text
//! psi'' = -a psi' + b delta + c             heading psi [rad], rudder delta [rad]
//! c     = b beta + a k                      [rad/s^2]
//! ```
//!
//! `a` [1/s] and `b` [1/s^2] are the ship's (`a = a0 u / l`, `b = 0.5 (u/l)^2 A l / V`);
//! `beta` [rad] is the sea's rudder-equivalent bias and the trim, taken as constant over the
//! record; `k` [rad/s] is a heading-sensor drift rate, taken as constant (a ramp on the
//! measured heading `psi_m = psi + k t` gives `psi_m'' = psi''` and `psi_m' = psi' + k`, so a
//! ramp only moves the intercept).
//!
//! ## Regression: state-variable filter (continuous-time equation error)
//!
//! The derivatives of a noisy heading cannot be formed directly, so both signals pass through
//! the same low-pass `F(s) = lambda^2 / (s + lambda)^2` (`baseline.filter-rad-s`), whose state
//! gives `F x`, `s F x` and `s^2 F x = lambda^2 (x - F x) - 2 lambda s F x` without any
//! differencing. Filtering the model (F is linear and commutes with s) gives, per sample n,
//!
//! ```text
//! s^2 F psi = -a (s F psi) + b (F delta) + c        (after F's start-up transient)
//! ```
//!
//! linear in `theta = (a, b, c)`, solved by ordinary least squares. The filter is discretised
//! exactly for an input linear between samples (first-order hold: the records' own linear
//! interpolation), from the matrix exponential of the augmented system. The first
//! `baseline.transient-s` of filtered samples are discarded (the filter starts at rest on the
//! first sample, a step in the derivative that decays as `(lambda t) e^{-lambda t}`).
//!
//! The least-squares problem is solved as it streams, by Givens rotations into a 4 x 4
//! triangular factor of `[X y]` (orthogonal, so no normal equations: the columns differ by
//! four orders of magnitude), then the 3 x 3 system by SVD after column scaling, which also
//! gives the condition number. No sample buffer: the fit allocates nothing and its cost is
//! O(n).
//!
//! `lambda` (default 0.15 rad/s) sits at the top of the ship's band (0.01 .. 0.2 rad/s: the
//! CLFRT tones, the relay's limit cycle) and well below the wave band (0.8 rad/s). Higher, the
//! wave yaw on the heading leaks into `s F psi` (an error in the regressor: `a` biased towards
//! zero) and the gyro noise reaches `s^2 F psi` with gain `lambda^2`; lower, the upper tones
//! are cut while the slow bias passes whole. `tests/it/baseline.rs` (`calibration_table`)
//! prints the trade-off for another lambda.
//!
//! ## What it does with drift and the sea's bias
//!
//! - The intercept `c` takes the mean rudder-equivalent bias and trim (`b beta`), and a
//!   constant heading drift rate (`a k`): without it no time-domain fit works on a ship with a
//!   trim. An established drift is therefore invisible to `a` and `b`.
//! - The slowly varying part of the bias (first-order Markov, T_b = 300 s) is not modelled: it
//!   stays in the equation error, and in closed loop (the autopilot answers the bias with
//!   rudder) it correlates with `F delta`, which biases `b` (and `a`) where the excitation is
//!   weak against it. The wave yaw on the heading enters `s F psi` attenuated by `F`.
//! - The covariance is the ordinary one, `sigma^2 (X^T X)^-1` with `sigma^2 = RSS / (n - 3)`:
//!   the equation errors are filtered, hence correlated, so it is optimistic (see
//!   `docs/baseline.md` for the measured spread).
//!
//! Units: time [s], angles [rad], `a` [1/s], `b` and `c` [1/s^2] (rad/s^2), speed [m/s],
//! displacement [t].

pub mod config;

use crate::model::{displacement_from_b, speed_from_a, ShipConfig};
use crate::wire::features::BaselineFeatures;
pub use config::BaselineConfig;
use nalgebra::Matrix3;

mod svf;
pub use svf::{StateVariableFilter, SvfOutput};

/// Filtered samples needed after the transient: far more than the three parameters, so the
/// residual standard deviation means something.
pub const MIN_FIT_SAMPLES: usize = 100;

/// Largest condition number of the column-scaled regression accepted.
pub const MAX_CONDITION: f64 = 1.0e8;

/// Why the baseline could not be fitted.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum BaselineError {
    /// Fewer samples than the filter's transient plus [`MIN_FIT_SAMPLES`].
    #[error("too few samples: {n} after the {transient_s:.0} s transient, at least {min} needed")]
    TooFewSamples {
        /// Samples left after the transient.
        n: usize,
        /// Samples needed.
        min: usize,
        /// Transient discarded [s].
        transient_s: f64,
    },
    /// Heading and rudder records of different lengths.
    #[error("heading has {heading} samples, rudder {rudder}")]
    LengthMismatch {
        /// Heading samples.
        heading: usize,
        /// Rudder samples.
        rudder: usize,
    },
    /// A NaN or infinite input sample, or a non-finite result.
    #[error("non-finite {what} at sample {index}")]
    NonFinite {
        /// Which signal or result.
        what: &'static str,
        /// Sample index (0 for results).
        index: usize,
    },
    /// The regressors are (nearly) linearly dependent: no excitation.
    #[error("singular regression (condition number {condition:.3e}): not enough excitation")]
    Singular {
        /// Condition number of the column-scaled regressor matrix (infinite when rank-deficient).
        condition: f64,
    },
    /// The records could not be put on the analysis grid (a gap, or no samples).
    #[error("record: {0}")]
    Record(String),
    /// The sample period or the filter bandwidth is not a positive finite number.
    #[error("invalid {what} = {value}")]
    InvalidArgument {
        /// `dt_s` or `filter_rad_s`.
        what: &'static str,
        /// The value given.
        value: f64,
    },
}

/// Least squares by Givens rotations, one row at a time, into the triangular factor of `[X y]`.
#[derive(Debug, Clone)]
struct StreamingQr {
    /// Upper-triangular 4 x 4 factor of `[x1 x2 x3 y]`; `r[3][3]^2` is the residual sum of squares.
    r: [[f64; 4]; 4],
    n: usize,
}

impl StreamingQr {
    fn new() -> Self {
        Self {
            r: [[0.0; 4]; 4],
            n: 0,
        }
    }

    fn push(&mut self, mut row: [f64; 4]) {
        for i in 0..4 {
            if row[i] == 0.0 {
                continue;
            }
            let rho = self.r[i][i].hypot(row[i]);
            let (c, s) = (self.r[i][i] / rho, row[i] / rho);
            for (rij, vj) in self.r[i][i..].iter_mut().zip(&mut row[i..]) {
                (*rij, *vj) = (c * *rij + s * *vj, c * *vj - s * *rij);
            }
        }
        self.n += 1;
    }
}

/// The fitted model `s^2 F psi = -a s F psi + b F delta + c` and its uncertainty.
#[derive(Debug, Clone, PartialEq)]
pub struct NomotoFit {
    /// Yaw damping a [1/s].
    pub a_per_s: f64,
    /// Rudder gain b [1/s^2].
    pub b_per_s2: f64,
    /// Intercept c: mean rudder-equivalent bias and trim times b, plus a times a heading
    /// drift rate [rad/s^2].
    pub c_rad_s2: f64,
    /// Standard deviation of the equation error [rad/s^2].
    pub residual_std_rad_s2: f64,
    /// Ordinary least-squares covariance of `(a, b, c)`, row major, `sigma^2 (X^T X)^-1`
    /// (optimistic: the filtered equation errors are correlated).
    pub covariance: [[f64; 3]; 3],
    /// Condition number of the column-scaled regressor matrix.
    pub condition: f64,
    /// Samples used (after the transient).
    pub n: usize,
}

impl NomotoFit {
    /// Standard deviation of `a` from [`NomotoFit::covariance`] [1/s].
    pub fn a_std_per_s(&self) -> f64 {
        self.covariance[0][0].sqrt()
    }
    /// Standard deviation of `b` from [`NomotoFit::covariance`] [1/s^2].
    pub fn b_std_per_s2(&self) -> f64 {
        self.covariance[1][1].sqrt()
    }
    /// Correlation of the `a` and `b` estimates.
    pub fn ab_correlation(&self) -> f64 {
        self.covariance[0][1] / (self.a_std_per_s() * self.b_std_per_s2())
    }
}

/// Fits `a`, `b`, `c` to a heading and a rudder record on one uniform grid.
///
/// `heading_rad`: continuous (unwrapped) heading [rad]; `rudder_rad`: rudder angle [rad];
/// both `dt_s` apart, same length. `cfg.filter_rad_s` is the filter's lambda, the first
/// `cfg.transient_s` of filtered samples are left out.
pub fn fit(
    heading_rad: &[f64],
    rudder_rad: &[f64],
    dt_s: f64,
    cfg: &BaselineConfig,
) -> Result<NomotoFit, BaselineError> {
    if heading_rad.len() != rudder_rad.len() {
        return Err(BaselineError::LengthMismatch {
            heading: heading_rad.len(),
            rudder: rudder_rad.len(),
        });
    }
    let mut fh = StateVariableFilter::new(cfg.filter_rad_s, dt_s)?;
    let mut fd = StateVariableFilter::new(cfg.filter_rad_s, dt_s)?;
    let skip = (cfg.transient_s.max(0.0) / dt_s).ceil() as usize;
    let n_fit = heading_rad.len().saturating_sub(skip);
    if n_fit < MIN_FIT_SAMPLES {
        return Err(BaselineError::TooFewSamples {
            n: n_fit,
            min: MIN_FIT_SAMPLES,
            transient_s: cfg.transient_s,
        });
    }
    for (what, s) in [("heading", heading_rad), ("rudder", rudder_rad)] {
        if let Some(index) = s.iter().position(|v| !v.is_finite()) {
            return Err(BaselineError::NonFinite { what, index });
        }
    }
    // The heading relative to its first sample (only its derivatives enter the regression).
    let psi0 = heading_rad[0];
    let mut qr = StreamingQr::new();
    for (k, (&psi, &delta)) in heading_rad.iter().zip(rudder_rad).enumerate() {
        let (h, d) = if k == 0 {
            (fh.reset(0.0), fd.reset(delta))
        } else {
            (fh.step(psi - psi0), fd.step(delta))
        };
        if k >= skip {
            qr.push([-h.sf, d.f, 1.0, h.ssf]);
        }
    }
    solve(&qr)
}

fn solve(qr: &StreamingQr) -> Result<NomotoFit, BaselineError> {
    let r = &qr.r;
    let r3 = Matrix3::new(
        r[0][0], r[0][1], r[0][2], 0.0, r[1][1], r[1][2], 0.0, 0.0, r[2][2],
    );
    let z = nalgebra::Vector3::new(r[0][3], r[1][3], r[2][3]);
    // Column scaling: the norms of X's columns are those of R's.
    let scale = nalgebra::Vector3::from_fn(|j, _| r3.column(j).norm());
    if scale.iter().any(|&s| s.is_nan() || s == 0.0) {
        return Err(BaselineError::Singular {
            condition: f64::INFINITY,
        });
    }
    let rs = Matrix3::from_fn(|i, j| r3[(i, j)] / scale[j]);
    let svd = rs.svd(true, true);
    let (smax, smin) = (svd.singular_values.max(), svd.singular_values.min());
    let condition = if smin > 0.0 {
        smax / smin
    } else {
        f64::INFINITY
    };
    if condition.is_nan() || condition > MAX_CONDITION {
        return Err(BaselineError::Singular { condition });
    }
    let (Some(u), Some(v_t)) = (svd.u, svd.v_t) else {
        return Err(BaselineError::Singular { condition });
    };
    let s_inv = Matrix3::from_diagonal(&svd.singular_values.map(|s| 1.0 / s));
    // rs = U S V^T: theta_scaled = V S^-1 U^T z; (rs^T rs)^-1 = V S^-2 V^T.
    let theta_s = v_t.transpose() * s_inv * u.transpose() * z;
    let inv_s = v_t.transpose() * s_inv * s_inv * v_t;
    let dof = qr.n.saturating_sub(3).max(1) as f64;
    let rss = r[3][3] * r[3][3];
    let sigma2 = rss / dof;
    let theta = theta_s.component_div(&scale);
    let mut covariance = [[0.0; 3]; 3];
    for (i, row) in covariance.iter_mut().enumerate() {
        for (j, c) in row.iter_mut().enumerate() {
            *c = sigma2 * inv_s[(i, j)] / (scale[i] * scale[j]);
        }
    }
    let fit = NomotoFit {
        a_per_s: theta[0],
        b_per_s2: theta[1],
        c_rad_s2: theta[2],
        residual_std_rad_s2: sigma2.sqrt(),
        covariance,
        condition,
        n: qr.n,
    };
    let finite = [fit.a_per_s, fit.b_per_s2, fit.c_rad_s2, sigma2]
        .iter()
        .chain(covariance.iter().flatten())
        .all(|v| v.is_finite());
    if !finite {
        return Err(BaselineError::NonFinite {
            what: "estimate",
            index: 0,
        });
    }
    Ok(fit)
}

/// A completed test's baseline: the fit, and speed and displacement read from it.
#[derive(Debug, Clone, PartialEq)]
pub struct BaselineEstimate {
    /// The regression.
    pub fit: NomotoFit,
    /// `speed_from_a(a)` [m/s].
    pub speed_mps: f64,
    /// `displacement_from_b(b, speed_mps)`: the baseline alone, without the speed log [t].
    pub displacement_t: f64,
    /// The filter bandwidth used [rad/s].
    pub filter_rad_s: f64,
}

/// The baseline of a test: [`fit`] with `cfg`, speed and displacement for `ship`.
pub fn estimate(
    heading_rad: &[f64],
    rudder_rad: &[f64],
    dt_s: f64,
    cfg: &BaselineConfig,
    ship: &ShipConfig,
) -> Result<BaselineEstimate, BaselineError> {
    let fit = fit(heading_rad, rudder_rad, dt_s, cfg)?;
    let speed_mps = speed_from_a(fit.a_per_s, ship);
    let displacement_t = displacement_from_b(fit.b_per_s2, speed_mps, ship);
    Ok(BaselineEstimate {
        fit,
        speed_mps,
        displacement_t,
        filter_rad_s: cfg.filter_rad_s,
    })
}

/// The report's `features.baseline` and `features.baseline_error`: the estimate, or none
/// and the reason.
pub fn to_features(
    baseline: &Result<BaselineEstimate, BaselineError>,
) -> (Option<BaselineFeatures>, Option<String>) {
    match baseline {
        Ok(e) => {
            let f = &e.fit;
            (
                Some(BaselineFeatures {
                    a_per_s: f.a_per_s,
                    b_per_s2: f.b_per_s2,
                    c_rad_s2: f.c_rad_s2,
                    a_std_per_s: f.a_std_per_s(),
                    b_std_per_s2: f.b_std_per_s2(),
                    ab_correlation: f.ab_correlation(),
                    residual_std_rad_s2: f.residual_std_rad_s2,
                    condition: f.condition,
                    n: f.n,
                    filter_rad_s: e.filter_rad_s,
                    speed_mps: e.speed_mps,
                    displacement_t: e.displacement_t,
                }),
                None,
            )
        }
        Err(err) => (None, Some(err.to_string())),
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;
    use rand_distr::{Distribution, StandardNormal};
    use std::f64::consts::PI;

    const DT: f64 = 0.1;

    fn cfg() -> BaselineConfig {
        BaselineConfig::default()
    }

    /// The exact response of `psi'' + a psi' = b (delta + beta)` to
    /// `delta = sum A_i sin(w_i t + p_i)` with constant `beta`: the steady-state sines through
    /// `G(jw) = b / (jw (jw + a))`, the ramp `b beta t / a`, and the homogeneous part
    /// `c1 + c2 e^{-a t}` (any initial condition).
    fn exact_record(a: f64, b: f64, beta: f64, n: usize) -> (Vec<f64>, Vec<f64>) {
        let tones = [
            (0.031, 4f64.to_radians(), 0.3),
            (0.073, 4f64.to_radians(), 2.1),
            (0.178, 4f64.to_radians(), 4.0),
        ];
        let (c1, c2) = (0.8, 0.05);
        let mut psi = Vec::with_capacity(n);
        let mut delta = Vec::with_capacity(n);
        for k in 0..n {
            let t = k as f64 * DT;
            let mut p = b * beta / a * t + c1 + c2 * (-a * t).exp();
            let mut d = 0.0;
            for &(w, amp, ph) in &tones {
                let g = b / (w * (w * w + a * a).sqrt());
                let arg = -PI / 2.0 - (w / a).atan();
                p += amp * g * (w * t + ph + arg).sin();
                d += amp * (w * t + ph).sin();
            }
            psi.push(p);
            delta.push(d);
        }
        (psi, delta)
    }

    /// Noise-free records of the exact model over the (u, D) range: a and b within 0.1 %,
    /// c = b beta.
    #[test]
    fn fit_recovers_a_and_b_from_the_exact_model() {
        let ship = ShipConfig::default();
        for (u, d) in [
            (4.0, 4000.0),
            (7.0, 7000.0),
            (10.0, 10000.0),
            (4.0, 10000.0),
        ] {
            let (a, b) = ship.nomoto(u, d);
            let beta = 1.5f64.to_radians();
            let (psi, delta) = exact_record(a, b, beta, 12_000);
            let f = fit(&psi, &delta, DT, &cfg()).unwrap();
            assert_relative_eq!(f.a_per_s, a, max_relative = 1e-3);
            assert_relative_eq!(f.b_per_s2, b, max_relative = 1e-3);
            assert_relative_eq!(f.c_rad_s2, b * beta, max_relative = 1e-2);
            assert_eq!(f.n, 12_000 - (cfg().transient_s / DT).ceil() as usize);
            assert_relative_eq!(speed_from_a(f.a_per_s, &ship), u, max_relative = 1e-3);
            let disp = displacement_from_b(f.b_per_s2, u, &ship);
            assert_relative_eq!(disp, d, max_relative = 1e-3);
        }
    }

    /// A heading ramp (sensor drift) moves only the intercept, by a k.
    #[test]
    fn heading_ramp_moves_only_the_intercept() {
        let (a, b) = ShipConfig::default().nomoto(7.0, 7000.0);
        let (psi, delta) = exact_record(a, b, 0.0, 12_000);
        let k = 1f64.to_radians() / 60.0;
        let drifted: Vec<f64> = psi
            .iter()
            .enumerate()
            .map(|(i, p)| p + k * i as f64 * DT)
            .collect();
        let f0 = fit(&psi, &delta, DT, &cfg()).unwrap();
        let f1 = fit(&drifted, &delta, DT, &cfg()).unwrap();
        assert_relative_eq!(f1.a_per_s, f0.a_per_s, max_relative = 1e-6);
        assert_relative_eq!(f1.b_per_s2, f0.b_per_s2, max_relative = 1e-6);
        assert_relative_eq!(f1.c_rad_s2 - f0.c_rad_s2, a * k, max_relative = 1e-3);
    }

    /// Sensor noise of the domain brief (0.05 deg heading, 0.1 deg rudder, white, 10 Hz), 16
    /// seeds per ship: every a within 4 % and b within 2 %, and their means within 1 % and
    /// 0.5 % (no bias: the noise only spreads them; the slowest, heaviest ship spreads most,
    /// ~1.1 % sd for a).
    #[test]
    fn fit_with_white_noise_stays_close() {
        let ship = ShipConfig::default();
        let seeds = 16;
        for (u, d) in [(4.0, 10000.0), (7.0, 7000.0), (10.0, 4000.0)] {
            let (a, b) = ship.nomoto(u, d);
            let (psi0, delta0) = exact_record(a, b, 0.5f64.to_radians(), 12_000);
            let (mut sum, mut worst) = ([0.0; 2], [0.0f64; 2]);
            for seed in 0..seeds {
                let mut rng = ChaCha8Rng::seed_from_u64(seed);
                let mut noisy = |x: &[f64], sd_deg: f64| -> Vec<f64> {
                    x.iter()
                        .map(|v| {
                            let n: f64 = StandardNormal.sample(&mut rng);
                            v + sd_deg.to_radians() * n
                        })
                        .collect()
                };
                let psi = noisy(&psi0, 0.05);
                let delta = noisy(&delta0, 0.1);
                let f = fit(&psi, &delta, DT, &cfg()).unwrap();
                let e = [f.a_per_s / a - 1.0, f.b_per_s2 / b - 1.0];
                for i in 0..2 {
                    sum[i] += e[i];
                    worst[i] = worst[i].max(e[i].abs());
                }
            }
            let mean = sum.map(|x| x / seeds as f64);
            println!(
                "u {u} D {d}: a mean {:+.3} % worst {:.3} %, b mean {:+.3} % worst {:.3} %",
                100.0 * mean[0],
                100.0 * worst[0],
                100.0 * mean[1],
                100.0 * worst[1]
            );
            assert!(worst[0] < 0.04 && worst[1] < 0.02, "u {u} D {d}: {worst:?}");
            assert!(
                mean[0].abs() < 0.01 && mean[1].abs() < 0.005,
                "u {u} D {d}: {mean:?}"
            );
        }
    }

    #[test]
    fn bad_input_is_a_typed_error() {
        let (a, b) = ShipConfig::default().nomoto(7.0, 7000.0);
        let (psi, delta) = exact_record(a, b, 0.0, 2000);
        assert!(matches!(
            fit(&psi[..300], &delta[..300], DT, &cfg()),
            Err(BaselineError::TooFewSamples { .. })
        ));
        assert!(matches!(
            fit(&psi, &delta[..1999], DT, &cfg()),
            Err(BaselineError::LengthMismatch { .. })
        ));
        let mut bad = delta.clone();
        bad[1234] = f64::NAN;
        assert_eq!(
            fit(&psi, &bad, DT, &cfg()),
            Err(BaselineError::NonFinite {
                what: "rudder",
                index: 1234
            })
        );
        // No rudder motion, no heading motion: nothing to identify.
        let flat = vec![0.1; 2000];
        assert!(matches!(
            fit(&flat, &flat, DT, &cfg()),
            Err(BaselineError::Singular { .. })
        ));
        assert!(matches!(
            fit(&psi, &delta, 0.0, &cfg()),
            Err(BaselineError::InvalidArgument { what: "dt_s", .. })
        ));
    }

    /// The inverse formulas against the forward ones of the configuration and the domain
    /// brief's nominal ship (a = 0.0146 1/s, b = 5.98e-4 1/s^2 at 7 m/s, 7000 t).
    #[test]
    fn speed_and_displacement_invert_the_ship_formulas() {
        let ship = ShipConfig::default();
        assert_relative_eq!(speed_from_a(0.0145833, &ship), 7.0, max_relative = 1e-5);
        assert_relative_eq!(
            displacement_from_b(5.98e-4, 7.0, &ship),
            7000.0,
            max_relative = 3e-3
        );
        for (u, d) in [(4.0, 4000.0), (10.0, 10000.0), (5.5, 8123.0)] {
            let (a, b) = ship.nomoto(u, d);
            assert_relative_eq!(speed_from_a(a, &ship), u, max_relative = 1e-12);
            assert_relative_eq!(displacement_from_b(b, u, &ship), d, max_relative = 1e-12);
        }
    }

    #[test]
    fn features_have_the_estimate_or_none_and_a_reason() {
        let (a, b) = ShipConfig::default().nomoto(7.0, 7000.0);
        let (psi, delta) = exact_record(a, b, 0.0, 3000);
        let ship = ShipConfig::default();
        let (f, err) = to_features(&estimate(&psi, &delta, DT, &cfg(), &ship));
        let f = f.unwrap();
        assert_relative_eq!(f.speed_mps, 7.0, max_relative = 1e-3);
        assert_relative_eq!(f.a_per_s, a, max_relative = 1e-3);
        assert!(f.n > 2000, "{}", f.n);
        assert!(err.is_none());
        let (f, err) = to_features(&estimate(&psi[..10], &delta[..10], DT, &cfg(), &ship));
        assert!(f.is_none());
        assert!(err.unwrap().contains("too few"));
    }
}
