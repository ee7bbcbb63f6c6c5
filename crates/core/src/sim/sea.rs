//! Sea disturbances: a slowly varying yaw moment and first-order wave yaw.
//!
//! **Rudder-equivalent bias** beta [rad]: a first-order Gauss-Markov process
//!
//! ```text
//! beta' = -beta / T_b + w,     stationary std sigma_b  (T_b = 300 s, sigma_b = bias_deg)
//! ```
//!
//! discretised exactly over a step dt: `beta <- phi beta + sqrt(1 - phi^2) sigma_b n`,
//! `phi = exp(-dt / T_b)`, n ~ N(0, 1). Its autocorrelation is `exp(-|tau| / T_b)` whatever dt.
//! It enters the ship's yaw equation as a rudder angle (see `ship.rs`).
//!
//! **Wave yaw** y [rad], on the heading *measurement* only (the ship does not turn with it):
//! Fossen's wave filter `y = K_w s / (s^2 + 2 lambda w0 s + w0^2) w`, w unit-intensity white
//! noise. In state space, with unit input gain and the output scaled,
//!
//! ```text
//! x1' = x2
//! x2' = -w0^2 x1 - 2 lambda w0 x2 + w          y = K_w x2
//! ```
//!
//! The stationary covariance is diagonal, `P = diag(1 / (4 lambda w0^3), 1 / (4 lambda w0))`,
//! so var(y) = K_w^2 / (4 lambda w0) and `K_w = sigma_y sqrt(4 lambda w0)` gives the sea
//! state's `wave_yaw_deg`. Discretisation is exact: `x <- Phi x + L n`, `Phi = exp(A dt)`,
//! `L L^T = Qd = int_0^dt exp(A s) G G^T exp(A^T s) ds` computed by Van Loan's method
//! (`exp([[-A, G G^T], [0, A^T]] dt) = [[., Phi^-1 Qd], [0, Phi^T]]`), so the statistics do not
//! depend on dt. Both processes start from their stationary distributions.

use nalgebra::{Matrix2, Matrix4, Vector2};

/// First-order Gauss-Markov rudder-equivalent bias [rad], exact discretisation.
#[derive(Debug, Clone)]
pub struct MarkovBias {
    /// exp(-dt / T_b).
    phi: f64,
    /// sqrt(1 - phi^2) sigma [rad].
    drive_rad: f64,
    /// Stationary standard deviation [rad].
    sigma_rad: f64,
    /// Current value [rad].
    value_rad: f64,
}

impl MarkovBias {
    /// A process with time constant `time_constant_s` and stationary std `sigma_rad`, stepped
    /// every `dt_s`; starts at zero until [`MarkovBias::start`].
    pub fn new(time_constant_s: f64, sigma_rad: f64, dt_s: f64) -> Self {
        let phi = (-dt_s / time_constant_s).exp();
        Self {
            phi,
            drive_rad: (1.0 - phi * phi).max(0.0).sqrt() * sigma_rad,
            sigma_rad,
            value_rad: 0.0,
        }
    }
    /// Draws the initial value from the stationary distribution, `n ~ N(0, 1)`.
    pub fn start(&mut self, n: f64) {
        self.value_rad = self.sigma_rad * n;
    }
    /// One step of dt, `n ~ N(0, 1)`.
    pub fn step(&mut self, n: f64) {
        self.value_rad = self.phi * self.value_rad + self.drive_rad * n;
    }
    /// Current value [rad].
    pub fn value_rad(&self) -> f64 {
        self.value_rad
    }
    /// The sea changes: the stationary std times `factor` (>= 0), the value with it, so the
    /// process stays stationary at its new level and continuous in shape.
    pub fn rescale(&mut self, factor: f64) {
        self.sigma_rad *= factor;
        self.drive_rad *= factor;
        self.value_rad *= factor;
    }
}

/// Why the wave filter could not be discretised.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("wave filter: process noise covariance is not positive definite (w0 = {w0_rad_s}, lambda = {damping}, dt = {dt_s})")]
pub struct WaveDiscretisationError {
    /// w0 [rad/s].
    pub w0_rad_s: f64,
    /// lambda.
    pub damping: f64,
    /// Step [s].
    pub dt_s: f64,
}

/// Fossen's second-order wave yaw filter, exact discretisation (Van Loan).
#[derive(Debug, Clone)]
pub struct WaveYaw {
    /// Transition matrix exp(A dt).
    phi: Matrix2<f64>,
    /// Lower Cholesky factor of the discrete process noise covariance Qd.
    chol: Matrix2<f64>,
    /// Output gain K_w [rad s^-1/2 ...], sets the stationary std of y.
    gain: f64,
    /// Stationary std of x1 and x2 (unit-intensity input).
    stationary_std: Vector2<f64>,
    /// State (x1, x2), unit-intensity input.
    x: Vector2<f64>,
}

impl WaveYaw {
    /// The filter at peak frequency `w0_rad_s`, damping `damping`, stationary output std
    /// `sigma_rad`, stepped every `dt_s`. Starts at zero until [`WaveYaw::start`].
    pub fn new(
        w0_rad_s: f64,
        damping: f64,
        sigma_rad: f64,
        dt_s: f64,
    ) -> Result<Self, WaveDiscretisationError> {
        let (phi, qd) = Self::discretise(w0_rad_s, damping, dt_s);
        let err = WaveDiscretisationError {
            w0_rad_s,
            damping,
            dt_s,
        };
        let chol = qd.cholesky().ok_or(err.clone())?.l();
        if !chol.iter().all(|v| v.is_finite()) {
            return Err(err);
        }
        let lw = 4.0 * damping * w0_rad_s;
        Ok(Self {
            phi,
            chol,
            gain: sigma_rad * lw.sqrt(),
            stationary_std: Vector2::new(
                (1.0 / (lw * w0_rad_s * w0_rad_s)).sqrt(),
                (1.0 / lw).sqrt(),
            ),
            x: Vector2::zeros(),
        })
    }

    /// `(Phi, Qd)` for step `dt_s` by Van Loan's method.
    pub fn discretise(w0_rad_s: f64, damping: f64, dt_s: f64) -> (Matrix2<f64>, Matrix2<f64>) {
        let a = Matrix2::new(0.0, 1.0, -w0_rad_s * w0_rad_s, -2.0 * damping * w0_rad_s);
        let ggt = Matrix2::new(0.0, 0.0, 0.0, 1.0);
        let mut m = Matrix4::zeros();
        m.fixed_view_mut::<2, 2>(0, 0).copy_from(&(-a * dt_s));
        m.fixed_view_mut::<2, 2>(0, 2).copy_from(&(ggt * dt_s));
        m.fixed_view_mut::<2, 2>(2, 2)
            .copy_from(&(a.transpose() * dt_s));
        let f = m.exp();
        let phi: Matrix2<f64> = f.fixed_view::<2, 2>(2, 2).transpose();
        let q = phi * f.fixed_view::<2, 2>(0, 2);
        // Symmetric in exact arithmetic; remove the rounding asymmetry.
        let qd = (q + q.transpose()) * 0.5;
        (phi, qd)
    }

    /// Draws the initial state from the stationary distribution, `n1, n2 ~ N(0, 1)`.
    pub fn start(&mut self, n1: f64, n2: f64) {
        self.x = Vector2::new(self.stationary_std.x * n1, self.stationary_std.y * n2);
    }

    /// One step of dt, `n1, n2 ~ N(0, 1)`.
    pub fn step(&mut self, n1: f64, n2: f64) {
        self.x = self.phi * self.x + self.chol * Vector2::new(n1, n2);
    }

    /// Current wave yaw y [rad].
    pub fn value_rad(&self) -> f64 {
        self.gain * self.x.y
    }

    /// The sea changes: the output's stationary std times `factor` (>= 0); the state (of a
    /// unit-intensity input) is kept, so the output stays stationary at its new level.
    pub fn rescale(&mut self, factor: f64) {
        self.gain *= factor;
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;
    use rand_distr::{Distribution, StandardNormal};

    fn n(rng: &mut ChaCha8Rng) -> f64 {
        StandardNormal.sample(rng)
    }

    /// Van Loan's Qd against the analytic stationary covariance: P = Phi P Phi^T + Qd.
    #[test]
    fn van_loan_keeps_the_analytic_stationary_covariance() {
        for (w0, lambda, dt) in [(0.8, 0.1, 0.1), (0.8, 0.1, 1.0), (0.5, 0.7, 0.01)] {
            let (phi, qd) = WaveYaw::discretise(w0, lambda, dt);
            let lw: f64 = 4.0 * lambda * w0;
            let p = Matrix2::new(1.0 / (lw * w0 * w0), 0.0, 0.0, 1.0 / lw);
            let back = phi * p * phi.transpose() + qd;
            for i in 0..4 {
                assert!((back[i] - p[i]).abs() < 1e-10 * p.max(), "{back} vs {p}");
            }
        }
    }

    /// The simulated wave yaw has the sea state's std, at two step sizes.
    #[test]
    fn wave_yaw_std_matches_sea_state() {
        let sigma = 0.2f64.to_radians();
        for dt in [0.1, 0.5] {
            let mut rng = ChaCha8Rng::seed_from_u64(7);
            let mut w = WaveYaw::new(0.8, 0.1, sigma, dt).unwrap();
            w.start(n(&mut rng), n(&mut rng));
            let steps = (400_000.0 / dt) as usize;
            let mut sum2 = 0.0;
            for _ in 0..steps {
                w.step(n(&mut rng), n(&mut rng));
                sum2 += w.value_rad().powi(2);
            }
            let std = (sum2 / steps as f64).sqrt();
            eprintln!("wave yaw dt = {dt}: std / target = {:.4}", std / sigma);
            // About 16000 correlation times (1 / (lambda w0) = 12.5 s): ~0.6 % standard error.
            approx::assert_relative_eq!(std, sigma, max_relative = 0.03);
        }
    }

    /// Bias std and autocorrelation time, stepping at a coarse dt (exact discretisation).
    #[test]
    fn bias_std_and_correlation_time() {
        let (tb, sigma, dt) = (300.0, 0.5f64.to_radians(), 30.0);
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let mut b = MarkovBias::new(tb, sigma, dt);
        b.start(n(&mut rng));
        let steps = 1_000_000;
        let lag = (tb / dt) as usize; // one time constant
        let mut hist = vec![0.0; steps];
        for h in hist.iter_mut() {
            b.step(n(&mut rng));
            *h = b.value_rad();
        }
        let var = hist.iter().map(|v| v * v).sum::<f64>() / steps as f64;
        let cov = hist.windows(lag + 1).map(|w| w[0] * w[lag]).sum::<f64>() / (steps - lag) as f64;
        eprintln!(
            "bias: std / target = {:.4}, rho(T_b) = {:.4}",
            var.sqrt() / sigma,
            cov / var
        );
        approx::assert_relative_eq!(var.sqrt(), sigma, max_relative = 0.02);
        // rho(T_b) = exp(-1) = 0.368.
        assert!(
            (cov / var - (-1f64).exp()).abs() < 0.02,
            "rho = {}",
            cov / var
        );
    }

    /// The sea rises: both processes rescaled from a calm sea's levels to a rough one's take
    /// the new standard deviations (stationary from the change on: the empirical std over
    /// the steps after it, against the new target, as the tests above).
    #[test]
    fn a_rescaled_sea_is_stationary_at_its_new_level() {
        let (calm, rough) = (0.05f64.to_radians(), 0.5f64.to_radians());
        let dt = 0.5;
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let mut w = WaveYaw::new(0.8, 0.1, calm, dt).unwrap();
        let mut b = MarkovBias::new(300.0, calm, 30.0);
        w.start(n(&mut rng), n(&mut rng));
        b.start(n(&mut rng));
        for _ in 0..1000 {
            w.step(n(&mut rng), n(&mut rng));
            b.step(n(&mut rng));
        }
        let before = w.value_rad();
        w.rescale(rough / calm);
        b.rescale(rough / calm);
        approx::assert_relative_eq!(w.value_rad(), before * 10.0, max_relative = 1e-12);
        let steps = 800_000;
        let (mut sw, mut sb) = (0.0, 0.0);
        for _ in 0..steps {
            w.step(n(&mut rng), n(&mut rng));
            b.step(n(&mut rng));
            sw += w.value_rad().powi(2);
            sb += b.value_rad().powi(2);
        }
        let (stdw, stdb) = ((sw / steps as f64).sqrt(), (sb / steps as f64).sqrt());
        approx::assert_relative_eq!(stdw, rough, max_relative = 0.03);
        approx::assert_relative_eq!(stdb, rough, max_relative = 0.03);
    }
}
