//! Passive identification: what a ship's normal closed-loop operation tells about its steering.
//!
//! Between two tests the daemon receives the measured rudder and heading of a ship steered by
//! its own autopilot in a seaway. This module states that record's statistical model, its
//! Fisher information for the ship's Nomoto `a` and `b` (the Cramer-Rao bound of any
//! unbiased estimator from `T` seconds of it), and the estimator that reaches it (Whittle's
//! frequency-domain maximum likelihood, [`whittle`]). docs/passive.md derives it and reports
//! the bound (`helmwatch eval --passive`).
//!
//! ## Model (continuous time; radians, seconds; `s = j w`)
//!
//! ```text
//! ship       psi = G (delta + beta),        G = b / (s (s + a))
//! heading    y   = psi + w + n_psi          (measured, about the autopilot's course)
//! autopilot  delta = -L y,                  L = K Sr
//!            K  = Kp F (1 + Td s + 1 / (Ti s)),   F = wf^2 / (s + wf)^2   (wave filter)
//!            Sr = 1 / (Tr s + 1)                                            (servo, linear)
//! rudder     delta_m = delta + n_delta      (measured)
//! ```
//!
//! Sources, independent, each with its two-sided spectral density [rad^2 s / rad]
//! (`integral over w of Phi = variance`):
//!
//! ```text
//! beta     rudder-equivalent Markov bias   Phi_b = sb^2 (1/Tb) / (pi (w^2 + 1/Tb^2))
//! w        wave yaw (Fossen)               Phi_w = sw^2 (2 l w0 / pi) w^2 / ((w0^2 - w^2)^2 + (2 l w0 w)^2)
//! n_psi    gyro noise, white at dt         Phi_n = sp^2 dt / (2 pi)
//! n_delta  rudder indicator noise          Phi_d = sd^2 dt / (2 pi)
//! ```
//!
//! With the loop's sensitivity `S = 1 / (1 + G L)`, the record `z = (y, delta_m)` is
//!
//! ```text
//! z = m_b beta + m_v (w + n_psi) + m_d n_delta,
//! m_b = (S G, -L S G),   m_v = (S, -L S),   m_d = (0, 1)
//! Phi_z = Phi_b m_b m_b^H + (Phi_w + Phi_n) m_v m_v^H + Phi_d m_d m_d^H      (2 x 2)
//! ```
//!
//! The servo's rate limit, the autopilot's angle limit and the sampling are left out: the
//! record follows this linear model while the rudder stays off its rate limit (a steady
//! course in a moderate sea, most of the time) and in the band below [`BAND_TOP_RAD_S`].
//!
//! ## Information (Whittle)
//!
//! The Fourier coefficients of a record of `T` s at `w_k = 2 pi k / T` are independent
//! complex Gaussian with covariance proportional to `Phi_z(w_k)`, so for parameters `theta`
//! (here the logarithms of the 14 numbers of [`LoopModel`]: relative bounds)
//!
//! ```text
//! I_ij = sum_k tr(Phi^-1 dPhi/dtheta_i Phi^-1 dPhi/dtheta_j),   0 < w_k <= BAND_TOP_RAD_S
//! ```
//!
//! The autopilot, the servo and the sea are unknown to the estimator: their 12 parameters are
//! nuisance, removed by the Schur complement, `I_eff = I_ss - I_sn I_nn^-1 I_ns` for the ship
//! `s = (ln a, ln b)`. A known tone `r` added to the rudder command (CLFRT) adds its mean:
//! the response `c = r Sr S (G, 1)` of amplitude vector `c` over `T` s carries
//! `(T / (4 pi)) Re(dc^H Phi^-1 dc)` ([`tone_information`]).

pub mod whittle;

use rustfft::num_complex::Complex64;
use std::f64::consts::PI;

/// Top of the band the bound and the estimator use [rad/s]: above it the record is the
/// sensors' white noise (the wave's peak is 0.8 rad/s by default, the servo's corner 1 rad/s).
pub const BAND_TOP_RAD_S: f64 = 5.0;

/// Number of parameters of [`LoopModel`].
pub const N_PARAMS: usize = 14;

/// Names of the parameters, in [`LoopModel::to_logs`]'s order.
pub const PARAM_NAMES: [&str; N_PARAMS] = [
    "a", "b", "Kp", "Td", "Ti", "wf", "Tr", "sb", "Tb", "sw", "w0", "lambda", "sp", "sd",
];

/// The closed loop of a ship under its autopilot in a seaway, as the passive record sees it.
/// Every field > 0.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LoopModel {
    /// Nomoto yaw damping a [1/s].
    pub a: f64,
    /// Nomoto rudder gain b [1/s^2].
    pub b: f64,
    /// Autopilot proportional gain [rad/rad].
    pub kp: f64,
    /// Derivative time [s].
    pub td_s: f64,
    /// Integral time [s].
    pub ti_s: f64,
    /// Wave filter's corner [rad/s].
    pub wf_rad_s: f64,
    /// Servo time constant [s].
    pub servo_s: f64,
    /// Rudder-equivalent bias sd [rad].
    pub bias_rad: f64,
    /// Its time constant [s].
    pub bias_s: f64,
    /// Wave yaw sd on the heading [rad].
    pub wave_rad: f64,
    /// Wave peak frequency [rad/s].
    pub wave_w0_rad_s: f64,
    /// Wave filter damping.
    pub wave_damping: f64,
    /// Gyro noise sd [rad].
    pub heading_noise_rad: f64,
    /// Rudder indicator noise sd [rad].
    pub rudder_noise_rad: f64,
}

/// A 2 x 2 complex matrix, row major.
pub type M2 = [[Complex64; 2]; 2];

impl LoopModel {
    /// The parameters' natural logarithms, in [`PARAM_NAMES`]' order.
    pub fn to_logs(&self) -> [f64; N_PARAMS] {
        [
            self.a,
            self.b,
            self.kp,
            self.td_s,
            self.ti_s,
            self.wf_rad_s,
            self.servo_s,
            self.bias_rad,
            self.bias_s,
            self.wave_rad,
            self.wave_w0_rad_s,
            self.wave_damping,
            self.heading_noise_rad,
            self.rudder_noise_rad,
        ]
        .map(f64::ln)
    }

    /// The model whose logarithms are `t`.
    pub fn from_logs(t: &[f64; N_PARAMS]) -> Self {
        let p = t.map(f64::exp);
        Self {
            a: p[0],
            b: p[1],
            kp: p[2],
            td_s: p[3],
            ti_s: p[4],
            wf_rad_s: p[5],
            servo_s: p[6],
            bias_rad: p[7],
            bias_s: p[8],
            wave_rad: p[9],
            wave_w0_rad_s: p[10],
            wave_damping: p[11],
            heading_noise_rad: p[12],
            rudder_noise_rad: p[13],
        }
    }

    /// The loop's transfer functions at `w` [rad/s]: (G, L, S, Sr).
    fn transfers(&self, w: f64) -> (Complex64, Complex64, Complex64, Complex64) {
        let s = Complex64::new(0.0, w);
        let one = Complex64::new(1.0, 0.0);
        let g = self.b / (s * (s + self.a));
        let f = self.wf_rad_s * self.wf_rad_s / ((s + self.wf_rad_s) * (s + self.wf_rad_s));
        let k = f * self.kp * (one + s * self.td_s + one / (s * self.ti_s));
        let sr = one / (s * self.servo_s + one);
        let l = k * sr;
        (g, l, one / (one + g * l), sr)
    }

    /// The sources' spectral densities at `w` [rad/s] for samples every `dt_s`: bias, wave
    /// plus gyro noise, rudder noise.
    pub fn sources(&self, w: f64, dt_s: f64) -> [f64; 3] {
        let ib = 1.0 / self.bias_s;
        let phi_b = self.bias_rad * self.bias_rad * ib / (PI * (w * w + ib * ib));
        let (w0, l) = (self.wave_w0_rad_s, self.wave_damping);
        let den = (w0 * w0 - w * w).powi(2) + (2.0 * l * w0 * w).powi(2);
        let phi_w = self.wave_rad * self.wave_rad * (2.0 * l * w0 / PI) * w * w / den;
        let white = |sd: f64| sd * sd * dt_s / (2.0 * PI);
        [
            phi_b,
            phi_w + white(self.heading_noise_rad),
            white(self.rudder_noise_rad),
        ]
    }

    /// The record's spectral matrix `Phi_z(w)` of (heading, rudder), samples every `dt_s`.
    pub fn spectrum(&self, w: f64, dt_s: f64) -> M2 {
        let (g, l, sens, _) = self.transfers(w);
        let [pb, pv, pd] = self.sources(w, dt_s);
        let mb = [sens * g, -l * sens * g];
        let mv = [sens, -l * sens];
        let mut m = [[Complex64::new(0.0, 0.0); 2]; 2];
        for (i, row) in m.iter_mut().enumerate() {
            for (j, x) in row.iter_mut().enumerate() {
                *x = mb[i] * mb[j].conj() * pb + mv[i] * mv[j].conj() * pv;
            }
        }
        m[1][1] += pd;
        m
    }

    /// The response (heading, rudder) to a unit change of the autopilot's course at `w`
    /// (`delta = L (course - y)`).
    pub fn course_response(&self, w: f64) -> [Complex64; 2] {
        let (g, l, sens, _) = self.transfers(w);
        [sens * g * l, sens * l]
    }

    /// The response (heading, rudder) to a unit tone added to the rudder command at `w`.
    pub fn tone_response(&self, w: f64) -> [Complex64; 2] {
        let (g, _, sens, sr) = self.transfers(w);
        [sr * sens * g, sr * sens]
    }
}

/// The inverse of a 2 x 2 matrix (`None` when singular).
pub fn inv2(m: &M2) -> Option<M2> {
    let det = m[0][0] * m[1][1] - m[0][1] * m[1][0];
    if !det.norm().is_finite() || det.norm() <= 0.0 {
        return None;
    }
    Some([
        [m[1][1] / det, -m[0][1] / det],
        [-m[1][0] / det, m[0][0] / det],
    ])
}

/// The product of two 2 x 2 matrices.
pub fn mul2(x: &M2, y: &M2) -> M2 {
    let mut m = [[Complex64::new(0.0, 0.0); 2]; 2];
    for (i, row) in m.iter_mut().enumerate() {
        for (j, v) in row.iter_mut().enumerate() {
            *v = x[i][0] * y[0][j] + x[i][1] * y[1][j];
        }
    }
    m
}

/// Step of the central differences in the parameters' logarithms.
const LOG_STEP: f64 = 1.0e-4;

/// At `w`: `Phi^-1` and `Phi^-1 dPhi/dtheta_i` for every parameter (central differences in
/// the logarithms). `None` when `Phi` is singular.
pub fn whitened_slopes(t: &[f64; N_PARAMS], w: f64, dt_s: f64) -> Option<(M2, Vec<M2>)> {
    let phi = LoopModel::from_logs(t).spectrum(w, dt_s);
    let pinv = inv2(&phi)?;
    let mut out = Vec::with_capacity(N_PARAMS);
    for i in 0..N_PARAMS {
        let (mut up, mut dn) = (*t, *t);
        up[i] += LOG_STEP;
        dn[i] -= LOG_STEP;
        let (pu, pm) = (
            LoopModel::from_logs(&up).spectrum(w, dt_s),
            LoopModel::from_logs(&dn).spectrum(w, dt_s),
        );
        let mut d = [[Complex64::new(0.0, 0.0); 2]; 2];
        for r in 0..2 {
            for c in 0..2 {
                d[r][c] = (pu[r][c] - pm[r][c]) / (2.0 * LOG_STEP);
            }
        }
        out.push(mul2(&pinv, &d));
    }
    Some((pinv, out))
}

/// The Fourier frequencies of a record of `record_s` seconds inside the band [rad/s].
pub fn fourier_frequencies(record_s: f64) -> impl Iterator<Item = f64> {
    let step = 2.0 * PI / record_s;
    (1..)
        .map(move |k| k as f64 * step)
        .take_while(|w| *w <= BAND_TOP_RAD_S)
}

/// Fisher information (row major, `N_PARAMS`^2) of a record of `record_s` s about the
/// logarithms `t`, samples every `dt_s`.
pub fn information(t: &[f64; N_PARAMS], record_s: f64, dt_s: f64) -> Vec<f64> {
    let mut info = vec![0.0; N_PARAMS * N_PARAMS];
    for w in fourier_frequencies(record_s) {
        let Some((_, d)) = whitened_slopes(t, w, dt_s) else {
            continue;
        };
        accumulate_record(&mut info, &d);
    }
    info
}

/// `info_ij += tr(D_i D_j)` for one frequency's whitened slopes `D_i = Phi^-1 dPhi/dtheta_i`.
pub fn accumulate_record(info: &mut [f64], d: &[M2]) {
    for i in 0..N_PARAMS {
        for j in i..N_PARAMS {
            let p = mul2(&d[i], &d[j]);
            let v = (p[0][0] + p[1][1]).re;
            info[i * N_PARAMS + j] += v;
            if i != j {
                info[j * N_PARAMS + i] += v;
            }
        }
    }
}

/// Fisher information about the logarithms `t` of a tone of amplitude `amp_rad` added to the
/// rudder command at `w`, over `record_s` s (the mean's share; the record's own noise adds
/// [`information`]).
pub fn tone_information(
    t: &[f64; N_PARAMS],
    w: f64,
    amp_rad: f64,
    record_s: f64,
    dt_s: f64,
) -> Vec<f64> {
    let mut info = vec![0.0; N_PARAMS * N_PARAMS];
    let Some(pinv) = inv2(&LoopModel::from_logs(t).spectrum(w, dt_s)) else {
        return info;
    };
    let dc = mean_slopes(t, Complex64::new(amp_rad, 0.0), |m| m.tone_response(w));
    accumulate_mean(&mut info, &dc, &pinv, record_s / (4.0 * PI));
    info
}

/// Fisher information about the logarithms `t` of the autopilot's own step of `step_rad` on
/// its course, seen in full (the record outlasts the transient), samples every `dt_s`:
///
/// ```text
/// I = (1 / (2 pi^2)) integral_0^top Re(dM^H Phi^-1 dM) dw,   M(w) = step course_response(w) / (j w)
/// ```
///
/// (a deterministic mean in stationary Gaussian noise; for a tone it gives
/// [`tone_information`]'s `T / (4 pi)`). Linear: a step whose command `Kp step` saturates the
/// servo's rate or angle limit leaves the model.
pub fn course_step_information(t: &[f64; N_PARAMS], step_rad: f64, dt_s: f64) -> Vec<f64> {
    let mut info = vec![0.0; N_PARAMS * N_PARAMS];
    let (lo, hi, n) = (1.0e-6_f64.ln(), BAND_TOP_RAD_S.ln(), 6000);
    let h = (hi - lo) / n as f64;
    for k in 0..=n {
        let w = (lo + k as f64 * h).exp();
        let weight = if k == 0 || k == n { 0.5 } else { 1.0 } * h * w / (2.0 * PI * PI);
        let Some(pinv) = inv2(&LoopModel::from_logs(t).spectrum(w, dt_s)) else {
            continue;
        };
        let scale = Complex64::new(0.0, -step_rad / w);
        let dm = mean_slopes(t, scale, |m| m.course_response(w));
        accumulate_mean(&mut info, &dm, &pinv, weight);
    }
    info
}

/// The slopes in the logarithms `t` of a known mean `scale response(model)` (central
/// differences).
fn mean_slopes(
    t: &[f64; N_PARAMS],
    scale: Complex64,
    response: impl Fn(&LoopModel) -> [Complex64; 2],
) -> Vec<[Complex64; 2]> {
    (0..N_PARAMS)
        .map(|i| {
            let (mut up, mut dn) = (*t, *t);
            up[i] += LOG_STEP;
            dn[i] -= LOG_STEP;
            let (mu, md) = (
                response(&LoopModel::from_logs(&up)),
                response(&LoopModel::from_logs(&dn)),
            );
            [0, 1].map(|r| (mu[r] - md[r]) * scale / (2.0 * LOG_STEP))
        })
        .collect()
}

/// `info_ij += weight Re(dm_i^H pinv dm_j)`.
fn accumulate_mean(info: &mut [f64], dm: &[[Complex64; 2]], pinv: &M2, weight: f64) {
    for i in 0..N_PARAMS {
        for j in 0..N_PARAMS {
            let mut v = Complex64::new(0.0, 0.0);
            for r in 0..2 {
                for c in 0..2 {
                    v += dm[i][r].conj() * pinv[r][c] * dm[j][c];
                }
            }
            info[i * N_PARAMS + j] += weight * v.re;
        }
    }
}

/// The ship block's effective information (Schur complement of the nuisance), 2 x 2 row
/// major, for the logarithms of `(a, b)`; `None` when the nuisance block is singular.
pub fn ship_information(info: &[f64]) -> Option<[f64; 4]> {
    let n = N_PARAMS;
    let q = n - 2;
    let nn = nalgebra::DMatrix::from_fn(q, q, |i, j| info[(i + 2) * n + j + 2]);
    let sn = nalgebra::DMatrix::from_fn(2, q, |i, j| info[i * n + j + 2]);
    let ss = nalgebra::DMatrix::from_fn(2, 2, |i, j| info[i * n + j]);
    let chol = nalgebra::Cholesky::new(nn)?;
    let eff = ss - &sn * chol.solve(&sn.transpose());
    Some([eff[(0, 0)], eff[(0, 1)], eff[(1, 0)], eff[(1, 1)]])
}

/// Relative Cramer-Rao bounds of the speed u (displacement unknown) and of the displacement D
/// (speed given, the log) from the ship block's information about `(ln a, ln b)`, for the
/// first-order ship: `ln a = ln u + c`, `ln b = 2 ln u - ln D + c'`.
pub fn speed_displacement_bounds(ship: &[f64; 4]) -> Option<(f64, f64)> {
    // (ln a, ln b) = J (ln u, ln D), J = [[1, 0], [2, -1]]: I_ud = J' I_ab J.
    let (i11, i12, i22) = (ship[0], ship[1], ship[3]);
    let iuu = i11 + 4.0 * i12 + 4.0 * i22;
    let iud = -i12 - 2.0 * i22;
    let idd = i22;
    let det = iuu * idd - iud * iud;
    if det.is_nan() || idd.is_nan() || det <= 0.0 || idd <= 0.0 {
        return None;
    }
    Some(((idd / det).sqrt(), 1.0 / idd.sqrt()))
}

#[cfg(test)]
mod tests;
