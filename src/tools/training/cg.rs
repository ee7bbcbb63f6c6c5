//! The Fletcher-Reeves conjugate gradient trainer (the paper's `traincgf`), on a
//! [`LeastSquares`] problem with early stopping (the problem and the record: `train`).
//!
//! ```text
//! d_0 = -g_0;   theta_{k+1} = theta_k + alpha_k d_k,   alpha_k = argmin_alpha L(theta_k + alpha d_k)
//! beta_k = |g_{k+1}|^2 / |g_k|^2,   d_{k+1} = -g_{k+1} + beta_k d_k
//! ```
//!
//! restarted (`d = -g`) every `P` iterations and whenever `d` is not a descent direction
//! (`g . d >= 0`). The line search (`line_search`) never returns a step that raises `L`.
//! One epoch is one CG iteration, as in `traincgf`.

use super::line_search::line_search;
use super::train::{mean_square, EarlyStop, Fit, LeastSquares};
use helmwatch_core::estimator::trainer::{CgfOptions, StopReason};
use nalgebra::{DMatrix, DVector};

/// Fletcher-Reeves conjugate gradient from `theta0`. See the module documentation.
pub fn conjugate_gradient_fr<P: LeastSquares, V: LeastSquares>(
    problem: &mut P,
    validation: Option<&mut V>,
    theta0: &[f64],
    opts: &CgfOptions,
) -> Fit {
    let p = problem.n_params();
    let n = problem.n_residuals();
    let scale = 2.0 / n.max(1) as f64;
    let mut theta = theta0.to_vec();
    let mut trial = theta.clone();
    let mut e = vec![0.0; n];
    let mut jt = DMatrix::zeros(p, n);
    let mut g = DVector::zeros(p);
    // Loss and gradient of the MSE at theta.
    let mut grad = |problem: &mut P, theta: &[f64], g: &mut DVector<f64>, e: &mut [f64]| {
        problem.jacobian_t(theta, e, &mut jt);
        let ev = DVector::from_column_slice(e);
        g.gemv(scale, &jt, &ev, 0.0);
        mean_square(e)
    };
    let mut loss = grad(problem, &theta, &mut g, &mut e);
    let mut early = EarlyStop::new(validation, &theta, loss, opts.max_fail);
    let mut d = -&g;
    let mut gg = g.norm_squared();
    let mut alpha_prev = 1e-2 / d.amax().max(1e-12);
    let mut since_restart = 0usize;
    let mut epoch = 0;
    let stop = loop {
        if epoch >= opts.max_epochs {
            break StopReason::MaxEpochs;
        }
        if gg.sqrt() <= opts.min_grad {
            break StopReason::MinGradient;
        }
        if g.dot(&d) >= 0.0 {
            // Not a descent direction: restart on steepest descent.
            d = -&g;
            since_restart = 0;
        }
        let (alpha, _) = line_search(
            |a| {
                for i in 0..p {
                    trial[i] = theta[i] + a * d[i];
                }
                problem.residuals(&trial, &mut e);
                mean_square(&e)
            },
            loss,
            alpha_prev,
            opts.line_tol,
            opts.line_max_evals,
        );
        if alpha == 0.0 {
            if since_restart == 0 {
                break StopReason::NoProgress;
            }
            // Lost descent along the conjugate direction: restart on steepest descent.
            d = -&g;
            since_restart = 0;
            continue;
        }
        let d_norm = d.norm();
        for i in 0..p {
            theta[i] += alpha * d[i];
        }
        loss = grad(problem, &theta, &mut g, &mut e);
        let gg_new = g.norm_squared();
        since_restart += 1;
        if since_restart >= p {
            d = -&g;
            since_restart = 0;
        } else {
            let beta = gg_new / gg;
            d *= beta;
            d -= &g;
        }
        gg = gg_new;
        // Next first trial: the same step length along the new direction.
        alpha_prev = alpha * d_norm / d.norm().max(1e-300);
        epoch += 1;
        if early.update(epoch, &theta, loss) {
            break StopReason::ValidationStop;
        }
    };
    early.finish(epoch, stop)
}
