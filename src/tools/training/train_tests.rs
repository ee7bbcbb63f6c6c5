//! Tests of [`super`] (`train.rs`) and of its trainers (`lm.rs`, `cg.rs`, `line_search.rs`),
//! kept beside it so that the module reads in one screenful of code; they check them against
//! independent answers.

use super::*;
use crate::tools::training::cg::conjugate_gradient_fr;
use crate::tools::training::line_search::line_search;
use crate::tools::training::lm::levenberg_marquardt;
use helmwatch_core::estimator::trainer::{CgfOptions, LmOptions};
use nalgebra::DMatrix;

/// Linear least squares: e = A theta - y.
struct Linear {
    a: DMatrix<f64>,
    y: DVector<f64>,
}

impl LeastSquares for Linear {
    fn n_params(&self) -> usize {
        self.a.ncols()
    }
    fn n_residuals(&self) -> usize {
        self.a.nrows()
    }
    fn residuals(&mut self, theta: &[f64], e: &mut [f64]) {
        let r = &self.a * DVector::from_column_slice(theta) - &self.y;
        e.copy_from_slice(r.as_slice());
    }
    fn jacobian_t(&mut self, theta: &[f64], e: &mut [f64], jt: &mut DMatrix<f64>) {
        self.residuals(theta, e);
        jt.copy_from(&self.a.transpose());
    }
}

fn linear_problem() -> (Linear, DVector<f64>) {
    let mut rng = ChaCha8Rng::seed_from_u64(9);
    let (n, p) = (40, 5);
    let a = DMatrix::from_fn(n, p, |_, _| rng.gen_range(-1.0..1.0));
    let y = DVector::from_fn(n, |_, _| rng.gen_range(-1.0..1.0));
    // Closed form: the normal equations (A^T A) theta = A^T y.
    let ata = a.transpose() * &a;
    let aty = a.transpose() * &y;
    let theta = ata.cholesky().unwrap().solve(&aty);
    (Linear { a, y }, theta)
}

#[test]
fn lm_solves_linear_least_squares_in_closed_form() {
    let (mut prob, answer) = linear_problem();
    let opts = LmOptions {
        max_epochs: 50,
        ..LmOptions::default()
    };
    let fit = levenberg_marquardt::<_, Linear>(&mut prob, None, &[0.0; 5], &opts);
    for (t, a) in fit.theta.iter().zip(answer.iter()) {
        approx::assert_relative_eq!(*t, *a, max_relative = 1e-8, epsilon = 1e-10);
    }
    // With mu = 1e-3 the first step is already within ~mu of Gauss-Newton: few epochs.
    assert!(fit.epochs <= 10, "{} epochs", fit.epochs);
}

#[test]
fn cgf_solves_linear_least_squares_within_p_iterations_per_restart() {
    let (mut prob, answer) = linear_problem();
    let opts = CgfOptions {
        max_epochs: 60,
        line_tol: 1e-8,
        ..CgfOptions::default()
    };
    let fit = conjugate_gradient_fr::<_, Linear>(&mut prob, None, &[0.0; 5], &opts);
    for (t, a) in fit.theta.iter().zip(answer.iter()) {
        approx::assert_relative_eq!(*t, *a, max_relative = 1e-5, epsilon = 1e-7);
    }
    // 5 epochs of exact-line-search CG do not reach it from far, 60 do: a check that
    // the iteration count matters (the test can fail).
    let short = CgfOptions {
        max_epochs: 2,
        ..opts
    };
    let (mut prob2, _) = linear_problem();
    let fit2 = conjugate_gradient_fr::<_, Linear>(&mut prob2, None, &[0.0; 5], &short);
    let err: f64 = fit2
        .theta
        .iter()
        .zip(answer.iter())
        .map(|(t, a)| (t - a).abs())
        .fold(0.0, f64::max);
    assert!(err > 1e-4, "2 epochs already at {err}");
}

#[test]
fn line_search_finds_the_minimum_of_a_parabola() {
    // phi(a) = (a - 3)^2 + 1, from a first trial far too short and far too long.
    for alpha0 in [1e-4, 0.5, 100.0] {
        let (a, f) = line_search(|a| (a - 3.0).powi(2) + 1.0, 10.0, alpha0, 1e-6, 80);
        approx::assert_relative_eq!(a, 3.0, max_relative = 1e-4);
        approx::assert_relative_eq!(f, 1.0, max_relative = 1e-6);
    }
    // Climbing everywhere: no step.
    let (a, f) = line_search(|a| a * a, 0.0, 1.0, 1e-6, 80);
    assert_eq!((a, f), (0.0, 0.0));
}

fn smooth_fn(x: &[f64]) -> f64 {
    (std::f64::consts::PI * x[0]).sin() * (0.5 * std::f64::consts::PI * x[1]).cos()
}

fn grid(n: usize, offset: f64) -> (Vec<Vec<f64>>, Vec<f64>) {
    let mut rows = Vec::new();
    let mut ys = Vec::new();
    for i in 0..n {
        for j in 0..n {
            let x = vec![
                -1.0 + 2.0 * (i as f64 + offset) / n as f64,
                -1.0 + 2.0 * (j as f64 + offset) / n as f64,
            ];
            ys.push(0.8 * smooth_fn(&x));
            rows.push(x);
        }
    }
    (rows, ys)
}

fn sets() -> (Dataset, Dataset, Dataset) {
    let (r, y) = grid(20, 0.5);
    let (rv, yv) = grid(7, 0.25);
    let (rt, yt) = grid(9, 0.37);
    (
        Dataset::new("training", &r, &y).unwrap(),
        Dataset::new("validation", &rv, &yv).unwrap(),
        Dataset::new("test", &rt, &yt).unwrap(),
    )
}

#[test]
fn lm_network_fits_a_known_smooth_function() {
    let (tr, va, te) = sets();
    let var = {
        let mut p = NetProblem::new(&te);
        // Output of an all-zero network is 0: this is the mean square of the target.
        p.mse(&vec![0.0; n_params(2)])
    };
    let trainer = Trainer::Lm(LmOptions {
        max_epochs: 200,
        ..LmOptions::default()
    });
    let best = train(&tr, &va, &trainer, 1, 2).unwrap();
    let mse = NetProblem::new(&te).mse(&best.net.params());
    println!(
        "LM: test MSE {mse:.2e} (target mean square {var:.3}), {} epochs, stop {:?}",
        best.fit.epochs, best.fit.stop
    );
    // Measured ~2e-8; a network that merely learnt the trend stays above 1e-3.
    assert!(mse < 1e-6, "test MSE {mse}");
    assert!(var > 0.1, "target mean square {var}");
}

#[test]
fn cgf_network_learns_a_known_smooth_function_more_slowly() {
    let (tr, va, te) = sets();
    let lm = train(&tr, &va, &Trainer::Lm(LmOptions::default()), 1, 1).unwrap();
    let cg = train(&tr, &va, &Trainer::Cgf(CgfOptions::default()), 1, 1).unwrap();
    let init = {
        let mut rng = ChaCha8Rng::seed_from_u64(restart_seed(1, 0));
        nguyen_widrow(2, &mut rng).params()
    };
    let m0 = NetProblem::new(&te).mse(&init);
    let m_cg = NetProblem::new(&te).mse(&cg.net.params());
    let m_lm = NetProblem::new(&te).mse(&lm.net.params());
    println!("initial {m0:.2e}, CGF 100 epochs {m_cg:.2e}, LM {m_lm:.2e}");
    // CG at 100 epochs learns most of the function, LM gets much further.
    assert!(m_cg < 0.05 * m0, "CG {m_cg} vs initial {m0}");
    assert!(m_cg < 0.02, "CG {m_cg}");
    assert!(m_lm < 0.2 * m_cg, "LM {m_lm} vs CG {m_cg}");
}

#[test]
fn training_is_deterministic_and_seed_dependent() {
    let (tr, va, _) = sets();
    let t = Trainer::Lm(LmOptions {
        max_epochs: 20,
        ..LmOptions::default()
    });
    let a = train(&tr, &va, &t, 5, 2).unwrap();
    let b = train(&tr, &va, &t, 5, 2).unwrap();
    let c = train(&tr, &va, &t, 6, 2).unwrap();
    let bits = |n: &TrainedNet| {
        n.net
            .params()
            .iter()
            .map(|v| v.to_bits())
            .collect::<Vec<_>>()
    };
    assert_eq!(bits(&a), bits(&b));
    assert_ne!(bits(&a), bits(&c));
}

#[test]
fn early_stopping_keeps_the_best_validation_weights() {
    // Few noisy training points and a clean validation set: the validation error must
    // be that of the kept weights, recomputed independently.
    let (tr, va, _) = sets();
    let best = train_restart(&tr, &va, &Trainer::Lm(LmOptions::default()), 3, 0).unwrap();
    let recomputed = NetProblem::new(&va).mse(&best.net.params());
    approx::assert_relative_eq!(recomputed, best.fit.mse_validation, max_relative = 1e-12);
    assert!(best.fit.best_epoch <= best.fit.epochs);
}

#[test]
fn bad_data_is_refused() {
    assert!(matches!(
        Dataset::new("training", &[], &[]),
        Err(TrainError::Empty("training"))
    ));
    assert!(matches!(
        Dataset::new("training", &[vec![1.0, 2.0], vec![1.0]], &[0.0, 0.0]),
        Err(TrainError::Shape(_))
    ));
    assert!(matches!(
        Dataset::new("training", &[vec![f64::NAN]], &[0.0]),
        Err(TrainError::NotFinite { sample: 0, .. })
    ));
}
