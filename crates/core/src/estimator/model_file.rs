//! The model file as written on disk (version 1, the format in `model.rs`): the network's
//! architecture, scaling and weights, the design it was trained for, its uncertainty and its
//! training record.

use super::Target;
use crate::estimator::nn::HIDDEN;
use crate::estimator::trainer::{StopReason, Trainer};
use crate::model::{SeaState, ServoConfig, ShipConfig};
use crate::monitor::config::CoreConfig;
use crate::wire::Method;
use serde::{Deserialize, Serialize};

/// `architecture` of a model file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Architecture {
    /// Layer sizes `[n_in, 10, 10, 1]`.
    pub layers: Vec<usize>,
    /// Activations of the three layers: `["tanh", "tanh", "linear"]`.
    pub activations: Vec<String>,
}

impl Architecture {
    /// The paper's architecture for `n_in` inputs.
    pub fn paper(n_in: usize) -> Self {
        Self {
            layers: vec![n_in, HIDDEN, HIDDEN, 1],
            activations: vec!["tanh".into(), "tanh".into(), "linear".into()],
        }
    }
}

/// `scaling` of a model file: min-max maps to [-1, 1].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ScalingFile {
    /// Raw value of each input mapped to -1.
    pub input_min: Vec<f64>,
    /// Raw value of each input mapped to +1.
    pub input_max: Vec<f64>,
    /// Target value mapped to -1 [unit].
    pub output_min: f64,
    /// Target value mapped to +1 [unit].
    pub output_max: f64,
}

/// `weights` of a model file (rows are units, columns their inputs).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Weights {
    /// First layer, 10 rows of n_in.
    pub w1: Vec<Vec<f64>>,
    /// First layer biases (10).
    pub b1: Vec<f64>,
    /// Second layer, 10 rows of 10.
    pub w2: Vec<Vec<f64>>,
    /// Second layer biases (10).
    pub b2: Vec<f64>,
    /// Output weights (10).
    pub w3: Vec<f64>,
    /// Output bias.
    pub b3: f64,
}

/// CLFRT design a model was trained for.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ClfrtDesign {
    /// Window T_w [s].
    pub window_s: f64,
    /// Tone harmonics of the window.
    pub harmonics: Vec<u32>,
    /// Tone amplitude [deg].
    pub amplitude_deg: f64,
}

/// HBT design a model was trained for.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HbtDesign {
    /// Relay height [deg].
    pub relay_height_deg: f64,
    /// Hysteresis [deg].
    pub hysteresis_deg: f64,
}

/// The ship, servo and test design behind the features: a network only maps features to
/// parameters for these. Measurement lengths (windows, periods) are not part of it: they
/// change the noise of the features, not their expected values.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Design {
    /// The ship model (and the parameter ranges of the training database).
    pub ship: ShipConfig,
    /// The rudder servo.
    pub servo: ServoConfig,
    /// The CLFRT design (CLFRT models).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub clfrt: Option<ClfrtDesign>,
    /// The HBT design (HBT models).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub hbt: Option<HbtDesign>,
}

impl Design {
    /// The design of `method` in `cfg`.
    pub fn from_config(cfg: &CoreConfig, method: Method) -> Self {
        Self {
            ship: cfg.ship.clone(),
            servo: cfg.servo.clone(),
            clfrt: (method == Method::Clfrt).then(|| ClfrtDesign {
                window_s: cfg.clfrt.window_s,
                harmonics: cfg.clfrt.harmonics.clone(),
                amplitude_deg: cfg.clfrt.amplitude_deg,
            }),
            hbt: (method == Method::Hbt).then_some(HbtDesign {
                relay_height_deg: cfg.hbt.relay_height_deg,
                hysteresis_deg: cfg.hbt.hysteresis_deg,
            }),
        }
    }
}

/// Residual spread of one sea state on the validation set.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SeaSpread {
    /// Sea state.
    pub sea: SeaState,
    /// Validation samples of this sea state.
    pub n: usize,
    /// Mean of (estimate - truth) [unit].
    pub residual_mean: f64,
    /// Standard deviation of (estimate - truth) [unit].
    pub residual_std: f64,
    /// Mean of (estimate - truth) / truth (absent in older files).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub relative_mean: Option<f64>,
    /// Standard deviation of (estimate - truth) / truth (absent in older files).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub relative_std: Option<f64>,
}

/// `uncertainty`: the spread of the estimator's residuals on the validation set.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Uncertainty {
    /// Mean of (estimate - truth) over the validation set [unit].
    pub residual_mean: f64,
    /// Standard deviation of (estimate - truth) over the validation set [unit].
    pub residual_std: f64,
    /// The same per sea state.
    pub by_sea: Vec<SeaSpread>,
}

/// Sizes of the three parts of the database.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Split {
    /// Training samples.
    pub train: usize,
    /// Validation samples (early stopping, restart choice, uncertainty).
    pub validation: usize,
    /// Test samples (never seen by training).
    pub test: usize,
}

/// `training`: how the network was obtained.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TrainingRecord {
    /// Seed of the database (design, probe seeds, split) and of the restarts.
    pub database_seed: u64,
    /// Design points (u, D) per sea state (Latin hypercube).
    pub design_points_per_sea: usize,
    /// Sea states of the database.
    pub sea_states: Vec<SeaState>,
    /// Each point's ship was drawn from the family of real ships (`train --family`); absent
    /// in files trained on the configured ship alone.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub family: bool,
    /// Completed tests in the database for this method.
    pub database_size: usize,
    /// Tests of this method that did not complete (excluded).
    pub database_failed: usize,
    /// How the completed tests were split.
    pub split: Split,
    /// Trainer and its settings.
    pub trainer: Trainer,
    /// Seeded restarts run.
    pub restarts: usize,
    /// The restart kept (lowest validation MSE).
    pub best_restart: usize,
    /// Epochs run by the kept restart.
    pub epochs: usize,
    /// Epoch of the kept weights.
    pub best_epoch: usize,
    /// Why the kept restart stopped.
    pub stop: StopReason,
    /// Training MSE on the [-1, 1] scale.
    pub mse_train: f64,
    /// Validation MSE on the [-1, 1] scale.
    pub mse_validation: f64,
    /// Test MSE on the [-1, 1] scale.
    pub mse_test: f64,
    /// Test RMSE in the target's unit.
    pub rmse_test: f64,
}

/// What a model file records besides the network: design, uncertainty, training record.
#[derive(Debug, Clone, PartialEq)]
pub struct Metadata {
    /// Ship, servo and test design.
    pub design: Design,
    /// Validation residual spread.
    pub uncertainty: Uncertainty,
    /// Training record.
    pub training: TrainingRecord,
}

/// A model file, as written on disk.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ModelFile {
    /// Always [`super::FORMAT`].
    pub format: String,
    /// Always [`super::VERSION`].
    pub version: u32,
    /// The test method whose features the network reads.
    pub method: Method,
    /// What it estimates.
    pub target: Target,
    /// Unit of the estimate.
    pub unit: String,
    /// Feature names, in input order.
    pub inputs: Vec<String>,
    /// Layer sizes and activations.
    pub architecture: Architecture,
    /// Input and output scaling.
    pub scaling: ScalingFile,
    /// The weights.
    pub weights: Weights,
    /// Ship, servo and test design the network was trained for.
    pub design: Design,
    /// Validation residual spread.
    pub uncertainty: Uncertainty,
    /// Training record.
    pub training: TrainingRecord,
}
