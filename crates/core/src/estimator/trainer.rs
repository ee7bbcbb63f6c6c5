//! What a model file records of its training: the trainer, its settings, and why it
//! stopped. The trainers themselves are the service's tools (`tools::training::lm`, `cg`).

use serde::{Deserialize, Serialize};

/// Why an optimisation stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum StopReason {
    /// The epoch limit was reached.
    MaxEpochs,
    /// The validation error did not improve for `max_fail` epochs in a row.
    ValidationStop,
    /// The gradient norm fell below its limit.
    MinGradient,
    /// Levenberg-Marquardt: mu exceeded its maximum (no step lowers the error).
    MaxMu,
    /// Conjugate gradient: the line search found no lower point along steepest descent.
    NoProgress,
}

/// Levenberg-Marquardt settings (MATLAB `trainlm` defaults except `max_epochs`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct LmOptions {
    /// Epoch limit.
    pub max_epochs: usize,
    /// Initial damping.
    pub mu: f64,
    /// Factor on mu after a successful step.
    pub mu_dec: f64,
    /// Factor on mu after a failed step.
    pub mu_inc: f64,
    /// Stop when mu exceeds this.
    pub mu_max: f64,
    /// Validation failures in a row before stopping.
    pub max_fail: usize,
    /// Stop when the gradient norm of the MSE falls below this.
    pub min_grad: f64,
}

impl Default for LmOptions {
    fn default() -> Self {
        Self {
            max_epochs: 300,
            mu: 1e-3,
            mu_dec: 0.1,
            mu_inc: 10.0,
            mu_max: 1e10,
            max_fail: 6,
            min_grad: 1e-9,
        }
    }
}

/// Fletcher-Reeves conjugate-gradient settings (MATLAB `traincgf`, Brent line search).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct CgfOptions {
    /// Epoch limit (the paper: 100).
    pub max_epochs: usize,
    /// Validation failures in a row before stopping.
    pub max_fail: usize,
    /// Stop when the gradient norm of the MSE falls below this.
    pub min_grad: f64,
    /// Relative tolerance on the step of the line search.
    pub line_tol: f64,
    /// Loss evaluations allowed per line search.
    pub line_max_evals: usize,
}

impl Default for CgfOptions {
    fn default() -> Self {
        Self {
            max_epochs: 100,
            max_fail: 6,
            min_grad: 1e-10,
            line_tol: 1e-3,
            line_max_evals: 40,
        }
    }
}

/// A trainer and its settings.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "name", rename_all = "snake_case")]
pub enum Trainer {
    /// Levenberg-Marquardt (`trainlm`).
    Lm(LmOptions),
    /// Fletcher-Reeves conjugate gradient (`traincgf`).
    Cgf(CgfOptions),
}

impl Trainer {
    /// Short name: `lm` or `cgf`.
    pub fn name(&self) -> &'static str {
        match self {
            Trainer::Lm(_) => "lm",
            Trainer::Cgf(_) => "cgf",
        }
    }
}
