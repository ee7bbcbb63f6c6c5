//! The Levenberg-Marquardt trainer (the default, MATLAB `trainlm`), on a [`LeastSquares`]
//! problem with early stopping (the problem and the record: `train`).
//!
//! Per epoch, with `H = J^T J` and `g = J^T e` at the current weights:
//!
//! ```text
//! (H + mu I) dtheta = -g      (Cholesky; a failed factorisation counts as a rejected step)
//! ```
//!
//! A step that lowers `L` is taken and `mu <- mu * mu_dec`; otherwise `mu <- mu * mu_inc` and
//! the step is solved again, until `mu > mu_max` (stop). MATLAB's defaults: `mu = 1e-3`,
//! `mu_dec = 0.1`, `mu_inc = 10`, `mu_max = 1e10`.

use super::train::{mean_square, EarlyStop, Fit, LeastSquares};
use helmwatch_core::estimator::trainer::{LmOptions, StopReason};
use nalgebra::{DMatrix, DVector};

/// Levenberg-Marquardt from `theta0`. See the module documentation.
pub fn levenberg_marquardt<P: LeastSquares, V: LeastSquares>(
    problem: &mut P,
    validation: Option<&mut V>,
    theta0: &[f64],
    opts: &LmOptions,
) -> Fit {
    let p = problem.n_params();
    let n = problem.n_residuals();
    let mut theta = theta0.to_vec();
    let mut trial = theta.clone();
    let mut e = vec![0.0; n];
    let mut jt = DMatrix::zeros(p, n);
    let mut h = DMatrix::zeros(p, p);
    let mut a = DMatrix::zeros(p, p);
    let mut g = DVector::zeros(p);
    problem.residuals(&theta, &mut e);
    let mut loss = mean_square(&e);
    let mut early = EarlyStop::new(validation, &theta, loss, opts.max_fail);
    let mut mu = opts.mu;
    let mut epoch = 0;
    let stop = loop {
        if epoch >= opts.max_epochs {
            break StopReason::MaxEpochs;
        }
        problem.jacobian_t(&theta, &mut e, &mut jt);
        let ev = DVector::from_column_slice(&e);
        g.gemv(1.0, &jt, &ev, 0.0);
        if 2.0 * g.norm() / n.max(1) as f64 <= opts.min_grad {
            break StopReason::MinGradient;
        }
        h.gemm(1.0, &jt, &jt.transpose(), 0.0);
        let mut accepted = false;
        while mu <= opts.mu_max {
            a.copy_from(&h);
            for i in 0..p {
                a[(i, i)] += mu;
            }
            let step = nalgebra::Cholesky::new(a.clone()).map(|c| c.solve(&g));
            if let Some(step) = step {
                for i in 0..p {
                    trial[i] = theta[i] - step[i];
                }
                problem.residuals(&trial, &mut e);
                let l = mean_square(&e);
                if l.is_finite() && l < loss {
                    theta.copy_from_slice(&trial);
                    loss = l;
                    mu *= opts.mu_dec;
                    accepted = true;
                    break;
                }
            }
            mu *= opts.mu_inc;
        }
        if !accepted {
            break StopReason::MaxMu;
        }
        epoch += 1;
        if early.update(epoch, &theta, loss) {
            break StopReason::ValidationStop;
        }
    };
    early.finish(epoch, stop)
}
