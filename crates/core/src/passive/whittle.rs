//! Whittle's maximum likelihood: the loop's parameters from a passive record.
//!
//! From the heading about the course `y[n]` and the measured rudder `delta_m[n]`, `N`
//! samples every `dt`, the Fourier coefficients `Z_k = dt sum_n z[n] e^{-j w_k n dt}` at the
//! Fourier frequencies of the band ([`super::fourier_frequencies`]) give the periodogram
//! `P_k = Z_k Z_k^H / (2 pi T)`, `T = N dt`, whose mean is `Phi_z(w_k)`. The estimate
//! maximises
//!
//! ```text
//! l(theta) = -sum_k [ ln det Phi_k(theta) + tr(Phi_k(theta)^-1 P_k) ]
//! ```
//!
//! by Fisher scoring, `theta += I^-1 s`, `s_i = sum_k tr(D_i Phi^-1 (P - Phi))`,
//! `D_i = Phi^-1 dPhi/dtheta_i`, `I` of [`super::information`]; a step that lowers `l` is
//! halved, and no logarithm moves by more than [`MAX_LOG_STEP`] a step. Asymptotically this
//! is efficient: its spread reaches the Cramer-Rao bound of [`super::information`].

use super::{
    accumulate_record, fourier_frequencies, inv2, mul2, whitened_slopes, LoopModel, M2, N_PARAMS,
};
use rustfft::num_complex::Complex64;
use rustfft::FftPlanner;
use std::f64::consts::PI;

/// Largest change of one logarithm in one scoring step.
pub const MAX_LOG_STEP: f64 = 0.5;
/// Scoring steps at most.
pub const MAX_ITERATIONS: usize = 60;
/// Converged when no logarithm moves by more than this in a step.
pub const TOLERANCE: f64 = 1.0e-5;

/// The estimate: the model, its log-likelihood, the steps taken, whether it converged.
#[derive(Debug, Clone)]
pub struct Fit {
    /// The loop's parameters at the maximum.
    pub model: LoopModel,
    /// Whittle log-likelihood there.
    pub log_likelihood: f64,
    /// Scoring steps.
    pub iterations: usize,
    /// Whether the last step moved every logarithm by less than [`TOLERANCE`].
    pub converged: bool,
}

/// The periodogram of (heading, rudder) at the band's Fourier frequencies: `(w_k, P_k)`.
/// `None` for records of different lengths, fewer than 16 samples, or a non-finite sample.
pub fn periodogram(heading: &[f64], rudder: &[f64], dt_s: f64) -> Option<Vec<(f64, M2)>> {
    let n = heading.len();
    if n != rudder.len() || n < 16 || !heading.iter().chain(rudder).all(|x| x.is_finite()) {
        return None;
    }
    let record_s = n as f64 * dt_s;
    let fft = FftPlanner::new().plan_fft_forward(n);
    let spectrum = |x: &[f64]| {
        let mean = x.iter().sum::<f64>() / n as f64;
        let mut buf: Vec<Complex64> = x.iter().map(|v| Complex64::new(v - mean, 0.0)).collect();
        fft.process(&mut buf);
        buf
    };
    let (zy, zd) = (spectrum(heading), spectrum(rudder));
    let scale = dt_s * dt_s / (2.0 * PI * record_s);
    Some(
        fourier_frequencies(record_s)
            .enumerate()
            .take_while(|(k, _)| k + 1 < n / 2)
            .map(|(k, w)| {
                let z = [zy[k + 1], zd[k + 1]];
                let p = [0, 1].map(|r| [0, 1].map(|c| z[r] * z[c].conj() * scale));
                (w, p)
            })
            .collect(),
    )
}

/// Whittle log-likelihood of `t` (logarithms) given the periodogram; `None` where a spectral
/// matrix is singular.
pub fn log_likelihood(t: &[f64; N_PARAMS], pg: &[(f64, M2)], dt_s: f64) -> Option<f64> {
    let model = LoopModel::from_logs(t);
    let mut l = 0.0;
    for (w, p) in pg {
        let phi = model.spectrum(*w, dt_s);
        let det = (phi[0][0] * phi[1][1] - phi[0][1] * phi[1][0]).re;
        let pinv = inv2(&phi)?;
        let q = mul2(&pinv, p);
        if det.is_nan() || det <= 0.0 {
            return None;
        }
        l -= det.ln() + (q[0][0] + q[1][1]).re;
    }
    l.is_finite().then_some(l)
}

/// The score and the Fisher information at `t` (row major).
fn score_information(
    t: &[f64; N_PARAMS],
    pg: &[(f64, M2)],
    dt_s: f64,
) -> Option<([f64; N_PARAMS], Vec<f64>)> {
    let mut s = [0.0; N_PARAMS];
    let mut info = vec![0.0; N_PARAMS * N_PARAMS];
    for (w, p) in pg {
        let (pinv, d) = whitened_slopes(t, *w, dt_s)?;
        let q = mul2(&pinv, p);
        for (si, di) in s.iter_mut().zip(&d) {
            let dq = mul2(di, &q);
            *si += (dq[0][0] + dq[1][1] - di[0][0] - di[1][1]).re;
        }
        accumulate_record(&mut info, &d);
    }
    Some((s, info))
}

/// Maximises the Whittle likelihood from `start`; `None` when the likelihood cannot be
/// evaluated there.
pub fn fit(start: &LoopModel, pg: &[(f64, M2)], dt_s: f64) -> Option<Fit> {
    let mut t = start.to_logs();
    let mut l = log_likelihood(&t, pg, dt_s)?;
    let mut converged = false;
    let mut iterations = 0;
    while iterations < MAX_ITERATIONS && !converged {
        iterations += 1;
        let Some((s, info)) = score_information(&t, pg, dt_s) else {
            break;
        };
        let m = nalgebra::DMatrix::from_row_slice(N_PARAMS, N_PARAMS, &info);
        let Some(chol) = nalgebra::Cholesky::new(m) else {
            break;
        };
        let step = chol.solve(&nalgebra::DVector::from_column_slice(&s));
        let biggest = step.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
        let mut factor = if biggest > MAX_LOG_STEP {
            MAX_LOG_STEP / biggest
        } else {
            1.0
        };
        let mut moved = false;
        for _ in 0..20 {
            let mut trial = t;
            for (x, d) in trial.iter_mut().zip(step.iter()) {
                *x += factor * d;
            }
            match log_likelihood(&trial, pg, dt_s) {
                Some(lt) if lt >= l => {
                    t = trial;
                    l = lt;
                    moved = true;
                    break;
                }
                _ => factor *= 0.5,
            }
        }
        converged = !moved || biggest * factor < TOLERANCE;
    }
    Some(Fit {
        model: LoopModel::from_logs(&t),
        log_likelihood: l,
        iterations,
        converged,
    })
}
