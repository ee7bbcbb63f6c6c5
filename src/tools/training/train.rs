//! Training the network: the least-squares problem the trainers minimise, their record and
//! early stopping on a validation set, the initial weights, and seeded restarts keeping the
//! best on validation. The trainers: Levenberg-Marquardt (the default, MATLAB `trainlm`;
//! `lm`) and Fletcher-Reeves conjugate gradient with a line search and restarts (the paper's
//! `traincgf`; `cg`, its line search in `line_search`).
//!
//! ## The problem
//!
//! Both minimise the mean squared error on the training set, in the scaled units of
//! [`helmwatch_core::estimator::nn`]:
//!
//! ```text
//! L(theta) = (1/N) sum_i e_i^2,   e_i = y(x_i; theta) - t_i,   grad L = (2/N) J^T e
//! ```
//!
//! where `J` (N x P) holds `de_i / dtheta`. Any model exposing residuals and `J^T` through
//! [`LeastSquares`] can be trained: the network ([`NetProblem`]) and, in the tests, a linear
//! least-squares problem whose answer is known in closed form.
//!
//! ## Early stopping, restarts
//!
//! After each epoch the validation MSE is computed; the weights with the lowest validation
//! MSE are kept, and training stops after `max_fail` epochs in a row without improvement
//! (MATLAB: 6). Initial weights follow Nguyen-Widrow (MATLAB `initnw`) from a seeded
//! `ChaCha8Rng`; [`train`] runs several restarts and keeps the best on validation (the lowest
//! restart index on a tie). Everything is a deterministic function of the data and the seed:
//! sums run in a fixed order, and no clock is read.

use super::cg::conjugate_gradient_fr;
use super::lm::levenberg_marquardt;
use helmwatch_core::estimator::nn::{n_params, Mlp, Scratch, HIDDEN};
use helmwatch_core::estimator::trainer::{StopReason, Trainer};
use nalgebra::{DMatrix, DVector};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Why training could not run.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TrainError {
    /// The data set has no sample.
    #[error("the {0} set is empty")]
    Empty(&'static str),
    /// Rows of different lengths, or targets not matching the rows.
    #[error("{0}")]
    Shape(String),
    /// A value of the data is NaN or infinite.
    #[error("the {set} set holds a non-finite value at sample {sample}")]
    NotFinite {
        /// Which set.
        set: &'static str,
        /// Index of the sample.
        sample: usize,
    },
    /// No restart was asked for.
    #[error("at least one restart is needed")]
    NoRestart,
}

/// Scaled inputs and targets, one sample per row (row-major).
#[derive(Debug, Clone, PartialEq)]
pub struct Dataset {
    n_in: usize,
    x: Vec<f64>,
    y: Vec<f64>,
}

impl Dataset {
    /// A data set from rows of scaled inputs and scaled targets.
    pub fn new(set: &'static str, rows: &[Vec<f64>], targets: &[f64]) -> Result<Self, TrainError> {
        let Some(first) = rows.first() else {
            return Err(TrainError::Empty(set));
        };
        let n_in = first.len();
        if n_in == 0 {
            return Err(TrainError::Shape(format!("{set}: rows have no input")));
        }
        if targets.len() != rows.len() {
            return Err(TrainError::Shape(format!(
                "{set}: {} rows but {} targets",
                rows.len(),
                targets.len()
            )));
        }
        let mut x = Vec::with_capacity(rows.len() * n_in);
        for (i, r) in rows.iter().enumerate() {
            if r.len() != n_in {
                return Err(TrainError::Shape(format!(
                    "{set}: row {i} has {} inputs, row 0 has {n_in}",
                    r.len()
                )));
            }
            if !r.iter().all(|v| v.is_finite()) || !targets[i].is_finite() {
                return Err(TrainError::NotFinite { set, sample: i });
            }
            x.extend_from_slice(r);
        }
        Ok(Self {
            n_in,
            x,
            y: targets.to_vec(),
        })
    }

    /// Number of inputs per sample.
    pub fn n_in(&self) -> usize {
        self.n_in
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.y.len()
    }

    /// Whether the set is empty (never, once built).
    pub fn is_empty(&self) -> bool {
        self.y.is_empty()
    }

    /// Scaled inputs of sample `i`.
    pub fn row(&self, i: usize) -> &[f64] {
        &self.x[i * self.n_in..(i + 1) * self.n_in]
    }

    /// Scaled target of sample `i`.
    pub fn target(&self, i: usize) -> f64 {
        self.y[i]
    }
}

/// A model with residuals `e_i(theta)` and their Jacobian, for the trainers.
pub trait LeastSquares {
    /// Number of parameters P.
    fn n_params(&self) -> usize;
    /// Number of residuals N.
    fn n_residuals(&self) -> usize;
    /// Fills `e` (length N) with the residuals at `theta`.
    fn residuals(&mut self, theta: &[f64], e: &mut [f64]);
    /// Fills `e` and `jt` (P x N, column i = de_i/dtheta) at `theta`.
    fn jacobian_t(&mut self, theta: &[f64], e: &mut [f64], jt: &mut DMatrix<f64>);
}

/// Mean of the squares, summed in index order.
pub fn mean_square(e: &[f64]) -> f64 {
    if e.is_empty() {
        return 0.0;
    }
    e.iter().map(|v| v * v).sum::<f64>() / e.len() as f64
}

/// The network on a data set, as a least-squares problem.
#[derive(Debug)]
pub struct NetProblem<'a> {
    data: &'a Dataset,
    net: Mlp,
    scratch: Scratch,
    row: Vec<f64>,
}

impl<'a> NetProblem<'a> {
    /// The network of `data`'s input size over `data`.
    pub fn new(data: &'a Dataset) -> Self {
        let n_in = data.n_in();
        Self {
            data,
            net: Mlp::zeros(n_in),
            scratch: Scratch::new(n_in),
            row: vec![0.0; n_params(n_in)],
        }
    }

    /// MSE of the network with parameters `theta` on the data.
    pub fn mse(&mut self, theta: &[f64]) -> f64 {
        self.net.set_params(theta);
        let mut sum = 0.0;
        for i in 0..self.data.len() {
            let e = self.net.forward(self.data.row(i), &mut self.scratch) - self.data.target(i);
            sum += e * e;
        }
        sum / self.data.len().max(1) as f64
    }
}

impl LeastSquares for NetProblem<'_> {
    fn n_params(&self) -> usize {
        n_params(self.data.n_in())
    }
    fn n_residuals(&self) -> usize {
        self.data.len()
    }
    fn residuals(&mut self, theta: &[f64], e: &mut [f64]) {
        self.net.set_params(theta);
        for (i, ei) in e.iter_mut().enumerate().take(self.data.len()) {
            *ei = self.net.forward(self.data.row(i), &mut self.scratch) - self.data.target(i);
        }
    }
    fn jacobian_t(&mut self, theta: &[f64], e: &mut [f64], jt: &mut DMatrix<f64>) {
        self.net.set_params(theta);
        for (i, ei) in e.iter_mut().enumerate().take(self.data.len()) {
            let y = self
                .net
                .jacobian_row(self.data.row(i), &mut self.scratch, &mut self.row);
            *ei = y - self.data.target(i);
            jt.column_mut(i).copy_from_slice(&self.row);
        }
    }
}

/// What one optimisation produced.
#[derive(Debug, Clone, PartialEq)]
pub struct Fit {
    /// The parameters with the lowest validation error (or the last, without validation).
    pub theta: Vec<f64>,
    /// Epochs run.
    pub epochs: usize,
    /// Epoch of the kept parameters (0: the initial ones).
    pub best_epoch: usize,
    /// Training MSE of the kept parameters.
    pub mse_train: f64,
    /// Validation MSE of the kept parameters (NaN without validation).
    pub mse_validation: f64,
    /// Why it stopped.
    pub stop: StopReason,
}

/// Tracks the best validation error for early stopping.
pub(super) struct EarlyStop<'v, V: LeastSquares> {
    validation: Option<&'v mut V>,
    e: Vec<f64>,
    best: f64,
    best_theta: Vec<f64>,
    best_epoch: usize,
    best_train: f64,
    fails: usize,
    max_fail: usize,
}

impl<'v, V: LeastSquares> EarlyStop<'v, V> {
    pub(super) fn new(
        validation: Option<&'v mut V>,
        theta: &[f64],
        train_mse: f64,
        max_fail: usize,
    ) -> Self {
        let n = validation.as_ref().map_or(0, |v| v.n_residuals());
        let mut s = Self {
            validation,
            e: vec![0.0; n],
            best: f64::INFINITY,
            best_theta: theta.to_vec(),
            best_epoch: 0,
            best_train: train_mse,
            fails: 0,
            max_fail,
        };
        s.best = s.loss(theta, train_mse);
        s
    }

    /// Validation MSE, or the training MSE without validation.
    fn loss(&mut self, theta: &[f64], train_mse: f64) -> f64 {
        match self.validation.as_deref_mut() {
            Some(v) => {
                v.residuals(theta, &mut self.e);
                mean_square(&self.e)
            }
            None => train_mse,
        }
    }

    /// Records epoch `epoch`; returns true when training must stop.
    pub(super) fn update(&mut self, epoch: usize, theta: &[f64], train_mse: f64) -> bool {
        let l = self.loss(theta, train_mse);
        if l < self.best {
            self.best = l;
            self.best_theta.copy_from_slice(theta);
            self.best_epoch = epoch;
            self.best_train = train_mse;
            self.fails = 0;
            false
        } else {
            self.fails += 1;
            self.validation.is_some() && self.fails >= self.max_fail
        }
    }

    /// The record: the kept parameters and why it stopped after `epochs` epochs.
    pub(super) fn finish(self, epochs: usize, stop: StopReason) -> Fit {
        let has_val = self.validation.is_some();
        Fit {
            theta: self.best_theta,
            epochs,
            best_epoch: self.best_epoch,
            mse_train: self.best_train,
            mse_validation: if has_val { self.best } else { f64::NAN },
            stop,
        }
    }
}

/// Nguyen-Widrow initial weights (MATLAB `initnw`) for inputs scaled to [-1, 1], from `rng`.
pub fn nguyen_widrow(n_in: usize, rng: &mut ChaCha8Rng) -> Mlp {
    let mut m = Mlp::zeros(n_in);
    let mut layer = |w: &mut DMatrix<f64>, b: &mut DVector<f64>, fan_in: usize| {
        let beta = 0.7 * (HIDDEN as f64).powf(1.0 / fan_in as f64);
        for j in 0..HIDDEN {
            let mut norm = 0.0;
            for i in 0..fan_in {
                let v: f64 = rng.gen_range(-1.0..1.0);
                w[(j, i)] = v;
                norm += v * v;
            }
            let norm = norm.sqrt().max(1e-12);
            for i in 0..fan_in {
                w[(j, i)] *= beta / norm;
            }
            b[j] = rng.gen_range(-beta..beta);
        }
    };
    layer(&mut m.w1, &mut m.b1, n_in);
    layer(&mut m.w2, &mut m.b2, HIDDEN);
    for j in 0..HIDDEN {
        m.w3[j] = rng.gen_range(-0.5..0.5);
    }
    m.b3 = 0.0;
    m
}

/// The seed of restart `restart` of a training whose seed is `seed`.
pub fn restart_seed(seed: u64, restart: usize) -> u64 {
    // SplitMix64 of the pair: distinct, well-mixed seeds per restart.
    let mut z = seed
        .wrapping_add(0x9E37_79B9_7F4A_7C15u64.wrapping_mul(restart as u64 + 1))
        .wrapping_add(0xD1B5_4A32_D192_ED03);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// One restart: a trained network and its record.
#[derive(Debug, Clone, PartialEq)]
pub struct TrainedNet {
    /// The network (best weights on validation).
    pub net: Mlp,
    /// The optimisation record.
    pub fit: Fit,
    /// Which restart produced it.
    pub restart: usize,
}

/// Trains one restart from Nguyen-Widrow weights drawn with [`restart_seed`]`(seed, restart)`.
pub fn train_restart(
    train: &Dataset,
    validation: &Dataset,
    trainer: &Trainer,
    seed: u64,
    restart: usize,
) -> Result<TrainedNet, TrainError> {
    if train.is_empty() {
        return Err(TrainError::Empty("training"));
    }
    if validation.is_empty() {
        return Err(TrainError::Empty("validation"));
    }
    if validation.n_in() != train.n_in() {
        return Err(TrainError::Shape(format!(
            "validation rows have {} inputs, training rows {}",
            validation.n_in(),
            train.n_in()
        )));
    }
    let mut rng = ChaCha8Rng::seed_from_u64(restart_seed(seed, restart));
    let theta0 = nguyen_widrow(train.n_in(), &mut rng).params();
    let mut problem = NetProblem::new(train);
    let mut val = NetProblem::new(validation);
    let fit = match trainer {
        Trainer::Lm(o) => levenberg_marquardt(&mut problem, Some(&mut val), &theta0, o),
        Trainer::Cgf(o) => conjugate_gradient_fr(&mut problem, Some(&mut val), &theta0, o),
    };
    let net =
        Mlp::from_params(train.n_in(), &fit.theta).map_err(|e| TrainError::Shape(e.to_string()))?;
    Ok(TrainedNet { net, fit, restart })
}

/// The best of several restarts on validation (the lowest index on a tie).
pub fn best_of(runs: Vec<TrainedNet>) -> Option<TrainedNet> {
    let mut best: Option<TrainedNet> = None;
    for r in runs {
        let better = match &best {
            None => true,
            Some(b) => r.fit.mse_validation < b.fit.mse_validation,
        };
        if better {
            best = Some(r);
        }
    }
    best
}

/// Trains `restarts` seeded restarts one after the other and keeps the best on validation.
pub fn train(
    train: &Dataset,
    validation: &Dataset,
    trainer: &Trainer,
    seed: u64,
    restarts: usize,
) -> Result<TrainedNet, TrainError> {
    let runs = (0..restarts)
        .map(|r| train_restart(train, validation, trainer, seed, r))
        .collect::<Result<Vec<_>, _>>()?;
    best_of(runs).ok_or(TrainError::NoRestart)
}

#[cfg(test)]
#[path = "train_tests.rs"]
mod tests;
