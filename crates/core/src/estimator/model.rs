//! Model files: one JSON file per method and estimated parameter, `models/<method>_<target>.json`
//! (`clfrt_speed.json`, `clfrt_displacement.json`, `hbt_speed.json`, `hbt_displacement.json`).
//!
//! ## Format (version 1)
//!
//! ```text
//! format        "helmwatch-estimator-model"
//! version       1
//! method        "clfrt" | "hbt"
//! target        "speed" (m/s) | "displacement" (t)
//! unit          "m/s" | "t"
//! inputs        feature names, in input order (see estimator::features)
//! architecture  { layers: [n_in, 10, 10, 1], activations: ["tanh", "tanh", "linear"] }
//! scaling       { input_min[n_in], input_max[n_in], output_min, output_max }: each maps to [-1, 1]
//! weights       { w1[10][n_in], b1[10], w2[10][10], b2[10], w3[10], b3 }  (rows = units)
//! design        the ship, servo and test design the network was trained for
//! uncertainty   validation residuals (estimate - truth) in the target's unit: mean, std,
//!               and per sea state; the parity test normalises its residuals by them
//! training      database seed and size, trainer and its settings, restarts, epochs,
//!               train / validation / test MSE on the [-1, 1] scale, test RMSE in the unit
//! ```
//!
//! Numbers are written by serde_json with the shortest representation that reads back to the
//! same `f64`, so a file is a bit-exact image of the trained network. The loader
//! ([`Model::from_json`]) refuses a file whose format or version is unknown, whose feature
//! names are unknown or belong to the other method, whose speed network reads the speed log,
//! whose shapes disagree with `n_in`, or that holds a non-finite number; the error names the
//! file and the problem.

use super::features::{self, Feature, FeatureError};
use super::nn::{Mlp, NnError, Scaling, Scratch, HIDDEN};
use crate::model::ShipConfig;
use crate::monitor::config::CoreConfig;
use crate::wire::Features;
use crate::wire::Method;
use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};

#[path = "model_file.rs"]
mod file;
pub use file::{
    Architecture, ClfrtDesign, Design, HbtDesign, Metadata, ModelFile, ScalingFile, SeaSpread,
    Split, TrainingRecord, Uncertainty, Weights,
};

/// The `format` string of a model file.
pub const FORMAT: &str = "helmwatch-estimator-model";
/// The `version` this build reads and writes.
pub const VERSION: u32 = 1;

/// What a network estimates.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Target {
    /// Speed through water [m/s].
    Speed,
    /// Displacement [t].
    Displacement,
}

impl Target {
    /// Both targets, speed first.
    pub const ALL: [Target; 2] = [Target::Speed, Target::Displacement];

    /// Name in file names and files.
    pub fn name(self) -> &'static str {
        match self {
            Target::Speed => "speed",
            Target::Displacement => "displacement",
        }
    }

    /// Unit of the estimate.
    pub fn unit(self) -> &'static str {
        match self {
            Target::Speed => "m/s",
            Target::Displacement => "t",
        }
    }

    /// The configured range of the target, mapped to [-1, 1].
    pub fn range(self, ship: &ShipConfig) -> (f64, f64) {
        match self {
            Target::Speed => (ship.speed_range_mps[0], ship.speed_range_mps[1]),
            Target::Displacement => (ship.displacement_range_t[0], ship.displacement_range_t[1]),
        }
    }

    /// The file name of the model of `method` and this target.
    pub fn file_name(self, method: Method) -> String {
        format!("{}_{}.json", method.name(), self.name())
    }
}

/// A model file that cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum ModelError {
    /// The file cannot be read.
    #[error("model file {path}: {source}")]
    Io {
        /// Path of the file.
        path: String,
        /// The I/O error.
        source: std::io::Error,
    },
    /// The JSON does not parse into the schema (including `null` for a non-finite number).
    #[error("model file {path}: does not parse: {message}")]
    Parse {
        /// Path (or name) of the file.
        path: String,
        /// serde's message.
        message: String,
    },
    /// The file parses but breaks a rule of the format.
    #[error("model file {path}: {message}")]
    Invalid {
        /// Path (or name) of the file.
        path: String,
        /// What is wrong.
        message: String,
    },
    /// The file is valid but not for this configuration or slot.
    #[error("model file {path}: {message}; run `helmwatch train` for this configuration")]
    Mismatch {
        /// Path (or name) of the file.
        path: String,
        /// What differs.
        message: String,
    },
    /// Writing a model file failed.
    #[error("writing model file {path}: {message}")]
    Write {
        /// Path of the file.
        path: String,
        /// What failed.
        message: String,
    },
}

/// A validated model, ready for inference.
#[derive(Debug, Clone, PartialEq)]
pub struct Model {
    /// The file it came from (metadata).
    pub file: ModelFile,
    /// Its inputs, parsed.
    pub inputs: Vec<Feature>,
    /// The network.
    pub net: Mlp,
    /// Its scaling.
    pub scaling: Scaling,
}

fn nn_invalid(path: &str) -> impl Fn(NnError) -> ModelError + '_ {
    move |e| ModelError::Invalid {
        path: path.to_string(),
        message: e.to_string(),
    }
}

fn feature_invalid(path: &str) -> impl Fn(FeatureError) -> ModelError + '_ {
    move |e| ModelError::Invalid {
        path: path.to_string(),
        message: e.to_string(),
    }
}

fn invalid(path: &str) -> impl Fn(String) -> ModelError + '_ {
    move |message| ModelError::Invalid {
        path: path.to_string(),
        message,
    }
}

/// The file's format, version and unit are this build's.
fn check_header(file: &ModelFile, path: &str) -> Result<(), ModelError> {
    let invalid = invalid(path);
    if file.format != FORMAT {
        return Err(invalid(format!(
            "format `{}`, expected `{FORMAT}`",
            file.format
        )));
    }
    if file.version != VERSION {
        return Err(invalid(format!(
            "version {}, this build reads version {VERSION}",
            file.version
        )));
    }
    if file.unit != file.target.unit() {
        return Err(invalid(format!(
            "unit `{}` for target {}, expected `{}`",
            file.unit,
            file.target.name(),
            file.target.unit()
        )));
    }
    Ok(())
}

/// The file's inputs, parsed: known names of its method, at least one, none twice, and the
/// speed log read by the displacement network only.
fn check_inputs(file: &ModelFile, path: &str) -> Result<Vec<Feature>, ModelError> {
    let invalid = invalid(path);
    let inputs = features::parse_names(file.method, &file.inputs).map_err(feature_invalid(path))?;
    let n_in = inputs.len();
    if n_in == 0 {
        return Err(invalid("no inputs".into()));
    }
    let mut seen = std::collections::HashSet::new();
    if let Some(dup) = inputs.iter().find(|f| !seen.insert(**f)) {
        return Err(invalid(format!("input `{dup}` appears twice")));
    }
    let has_log = inputs.contains(&Feature::SpeedLog);
    if file.target == Target::Speed && has_log {
        return Err(invalid(
            "the speed network must not read the speed log (it estimates what the log measures)"
                .into(),
        ));
    }
    if file.target == Target::Displacement && !has_log {
        return Err(invalid(
            "the displacement network must read the speed log (`speed_log_mps`)".into(),
        ));
    }
    Ok(inputs)
}

/// The file's scaling for `n_in` inputs.
fn scaling_of(s: &ScalingFile, n_in: usize, path: &str) -> Result<Scaling, ModelError> {
    if s.input_min.len() != n_in || s.input_max.len() != n_in {
        return Err(invalid(path)(format!(
            "scaling has {} / {} input ranges for {n_in} inputs",
            s.input_min.len(),
            s.input_max.len()
        )));
    }
    Scaling::new(
        s.input_min.clone(),
        s.input_max.clone(),
        s.output_min,
        s.output_max,
    )
    .map_err(nn_invalid(path))
}

/// The network of the file's weights for `n_in` inputs: the paper's shapes, finite values.
fn net_of(w: &Weights, n_in: usize, path: &str) -> Result<Mlp, ModelError> {
    let invalid = invalid(path);
    let matrix = |name: &str, rows: &Vec<Vec<f64>>, ncols: usize| {
        if rows.len() != HIDDEN || rows.iter().any(|r| r.len() != ncols) {
            return Err(invalid(format!(
                "weights.{name} must be {HIDDEN} rows of {ncols}"
            )));
        }
        let m = DMatrix::from_fn(HIDDEN, ncols, |j, i| rows[j][i]);
        if m.iter().all(|v| v.is_finite()) {
            Ok(m)
        } else {
            Err(invalid(format!("weights.{name} holds a non-finite value")))
        }
    };
    let vector = |name: &str, v: &Vec<f64>| {
        if v.len() != HIDDEN {
            return Err(invalid(format!(
                "weights.{name} must have {HIDDEN} values, has {}",
                v.len()
            )));
        }
        if v.iter().all(|x| x.is_finite()) {
            Ok(DVector::from_column_slice(v))
        } else {
            Err(invalid(format!("weights.{name} holds a non-finite value")))
        }
    };
    Ok(Mlp {
        w1: matrix("w1", &w.w1, n_in)?,
        b1: vector("b1", &w.b1)?,
        w2: matrix("w2", &w.w2, HIDDEN)?,
        b2: vector("b2", &w.b2)?,
        w3: vector("w3", &w.w3)?,
        b3: if w.b3.is_finite() {
            w.b3
        } else {
            return Err(invalid("weights.b3 is not finite".into()));
        },
    })
}

/// The residual means are finite and the spreads finite and positive (the relative ones
/// given both or neither).
fn check_uncertainty(u: &Uncertainty, path: &str) -> Result<(), ModelError> {
    let spread_ok = |m: f64, s: f64| m.is_finite() && s.is_finite() && s > 0.0;
    if !spread_ok(u.residual_mean, u.residual_std)
        || !u.by_sea.iter().all(|x| {
            spread_ok(x.residual_mean, x.residual_std)
                && match (x.relative_mean, x.relative_std) {
                    (None, None) => true,
                    (Some(m), Some(s)) => spread_ok(m, s),
                    _ => false,
                }
        })
    {
        return Err(invalid(path)(
            "uncertainty: residual means must be finite and spreads finite and > 0 (relative ones given both or neither)".into(),
        ));
    }
    Ok(())
}

impl Model {
    /// Builds the file of a trained network.
    pub fn new(
        method: Method,
        target: Target,
        inputs: &[Feature],
        net: &Mlp,
        scaling: &Scaling,
        meta: Metadata,
    ) -> Result<Self, ModelError> {
        let Metadata {
            design,
            uncertainty,
            training,
        } = meta;
        let rows = |m: &DMatrix<f64>| -> Vec<Vec<f64>> {
            (0..m.nrows())
                .map(|j| m.row(j).iter().copied().collect())
                .collect()
        };
        let file = ModelFile {
            format: FORMAT.to_string(),
            version: VERSION,
            method,
            target,
            unit: target.unit().to_string(),
            inputs: inputs.iter().map(|f| f.to_string()).collect(),
            architecture: Architecture::paper(inputs.len()),
            scaling: ScalingFile {
                input_min: scaling.x_min.clone(),
                input_max: scaling.x_max.clone(),
                output_min: scaling.y_min,
                output_max: scaling.y_max,
            },
            weights: Weights {
                w1: rows(&net.w1),
                b1: net.b1.iter().copied().collect(),
                w2: rows(&net.w2),
                b2: net.b2.iter().copied().collect(),
                w3: net.w3.iter().copied().collect(),
                b3: net.b3,
            },
            design,
            uncertainty,
            training,
        };
        Self::from_file(file, "(new model)")
    }

    /// Parses and validates a model file's text; `path` names it in errors.
    pub fn from_json(text: &str, path: &str) -> Result<Self, ModelError> {
        let file: ModelFile = serde_json::from_str(text).map_err(|e| ModelError::Parse {
            path: path.to_string(),
            message: e.to_string(),
        })?;
        Self::from_file(file, path)
    }

    /// Reads and validates a model file.
    pub fn load(path: &std::path::Path) -> Result<Self, ModelError> {
        let p = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|source| ModelError::Io {
            path: p.clone(),
            source,
        })?;
        Self::from_json(&text, &p)
    }

    /// The file's JSON text (pretty-printed, newline-terminated).
    pub fn to_json(&self) -> Result<String, ModelError> {
        serde_json::to_string_pretty(&self.file)
            .map(|s| s + "\n")
            .map_err(|e| ModelError::Write {
                path: self.file_name(),
                message: e.to_string(),
            })
    }

    /// Writes the file into `dir` under its standard name; returns the path.
    pub fn save(&self, dir: &std::path::Path) -> Result<std::path::PathBuf, ModelError> {
        let path = dir.join(self.file_name());
        let text = self.to_json()?;
        std::fs::write(&path, text).map_err(|e| ModelError::Write {
            path: path.display().to_string(),
            message: e.to_string(),
        })?;
        Ok(path)
    }

    /// The estimate for a report's `features` (raw units). `x` and `s` are reused buffers
    /// (`s` sized for this model's inputs); nothing is allocated once `x` has grown.
    pub fn predict_features(
        &self,
        features: &Features,
        x: &mut Vec<f64>,
        s: &mut Scratch,
    ) -> Result<f64, FeatureError> {
        features::extract_into(&self.inputs, features, x)?;
        Ok(self.net.predict(&self.scaling, x, s))
    }

    /// As [`Model::predict_features`], with the input `speed_log_mps` (when the model reads
    /// it) replaced by `speed_log_mps`: the displacement network along the speed log, as the
    /// FDI's sensitivity `dD/du_log` needs, without copying the features.
    pub fn predict_at_speed_log(
        &self,
        features: &Features,
        speed_log_mps: f64,
        x: &mut Vec<f64>,
        s: &mut Scratch,
    ) -> Result<f64, FeatureError> {
        x.clear();
        for f in &self.inputs {
            x.push(match f {
                Feature::SpeedLog => speed_log_mps,
                _ => f.value(features)?,
            });
        }
        Ok(self.net.predict(&self.scaling, x, s))
    }

    /// `<method>_<target>.json`.
    pub fn file_name(&self) -> String {
        self.file.target.file_name(self.file.method)
    }

    /// Validates a parsed file. See the module documentation for the rules.
    pub fn from_file(file: ModelFile, path: &str) -> Result<Self, ModelError> {
        check_header(&file, path)?;
        let inputs = check_inputs(&file, path)?;
        let n_in = inputs.len();
        if file.architecture != Architecture::paper(n_in) {
            return Err(invalid(path)(format!(
                "architecture {:?} {:?}, expected {:?} {:?}",
                file.architecture.layers,
                file.architecture.activations,
                Architecture::paper(n_in).layers,
                Architecture::paper(n_in).activations
            )));
        }
        let scaling = scaling_of(&file.scaling, n_in, path)?;
        let net = net_of(&file.weights, n_in, path)?;
        check_uncertainty(&file.uncertainty, path)?;
        Ok(Self {
            file,
            inputs,
            net,
            scaling,
        })
    }

    /// Checks that this model fits slot (`method`, `target`) and configuration `cfg`: same
    /// ship, servo and test design, and inputs that the configured test produces.
    pub fn check_for(
        &self,
        cfg: &CoreConfig,
        method: Method,
        target: Target,
        path: &str,
    ) -> Result<(), ModelError> {
        let mismatch = |message: String| ModelError::Mismatch {
            path: path.to_string(),
            message,
        };
        if self.file.method != method || self.file.target != target {
            return Err(mismatch(format!(
                "holds the {} {} model, expected {} {}",
                self.file.method.name(),
                self.file.target.name(),
                method.name(),
                target.name()
            )));
        }
        let mut want = Design::from_config(cfg, method);
        // The nominal speed and displacement are the parity test's reference, not part of
        // the design: a model serves any nominal inside its ranges.
        want.ship.nominal_speed_mps = self.file.design.ship.nominal_speed_mps;
        want.ship.nominal_displacement_t = self.file.design.ship.nominal_displacement_t;
        if self.file.design != want {
            return Err(mismatch(format!(
                "trained for another design: {}, configuration has {}",
                serde_json::to_string(&self.file.design).unwrap_or_default(),
                serde_json::to_string(&want).unwrap_or_default()
            )));
        }
        let n_tones = cfg.clfrt.harmonics.len();
        let expected = match target {
            Target::Speed => features::speed_inputs(method, n_tones),
            Target::Displacement => features::displacement_inputs(method, n_tones),
        };
        if self.inputs != expected {
            return Err(mismatch(format!(
                "inputs {:?}, this build feeds {:?}",
                self.file.inputs,
                expected.iter().map(|f| f.to_string()).collect::<Vec<_>>()
            )));
        }
        Ok(())
    }
}

#[cfg(test)]
#[path = "model_tests.rs"]
pub(crate) mod tests;
