//! The neural estimator: test features to ship parameters (speed, displacement).
//!
//! ## Model
//!
//! As in the paper (eq. 14), one small feedforward network per estimated parameter and per
//! test method, two hidden layers of 10 tanh units and a linear output, inputs and output
//! scaled to [-1, 1] ([`nn`]). Four networks:
//!
//! ```text
//! u_est = NN_speed,m(f_m)               [m/s]   f_m: features of test m (CLFRT or HBT)
//! D_est = NN_displacement,m(f_m, u_log) [t]     u_log: mean speed-log reading over the test
//! ```
//!
//! The speed network reads the test's features only, the displacement network the features
//! and the measured speed ([`features`]): the parity test compares `u_est` with the log and
//! `D_est` with the nominal displacement.
//!
//! ## Pieces
//!
//! | module | role |
//! |---|---|
//! | [`nn`] | the network: forward pass, Jacobian rows, min-max scaling; inference allocates nothing |
//! | [`train`] | Levenberg-Marquardt and Fletcher-Reeves conjugate gradient, early stopping, seeded restarts |
//! | [`features`] | input vectors from a report's `features`, by stable names |
//! | [`model`] | model files (`models/<method>_<target>.json`): format and validating loader |
//! | [`database`] | the training database: Latin hypercube over (u, D), sea states, probes on every core |
//! | [`build`] | database to trained model files (split, scaling, restarts in parallel, records) |
//! | [`eval`] | accuracy on a held-out database: per method, sea state and parameter |
//! | [`cli`] | the `helmwatch train` and `helmwatch eval` subcommands |
//!
//! [`Estimator`] holds the four validated models for one configuration; the monitor core
//! calls [`Estimator::estimate`] when a test completes. The default models are embedded in the
//! binary ([`Estimator::embedded`]) so that it runs without the repository.

pub mod config;
pub mod features;
pub mod model;
pub mod nn;
pub mod trainer;

use crate::fdi::config::Calibration;
use crate::monitor::config::CoreConfig;
use crate::wire::{Estimate, Features, Method};
use features::{Feature, FeatureError};
use model::{Model, ModelError, Target};
use nn::Scratch;
use std::path::Path;
use std::sync::Arc;

/// The calibration's file in a models directory (`crate::fdi::config::Calibration`).
pub const CALIBRATION_FILE: &str = "calibration.json";

/// The shipped models, embedded at build time: `(file name, text)`.
pub const EMBEDDED_MODELS: [(&str, &str); 4] = [
    (
        "clfrt_speed.json",
        include_str!(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../models/clfrt_speed.json"
        )),
    ),
    (
        "clfrt_displacement.json",
        include_str!(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../models/clfrt_displacement.json"
        )),
    ),
    (
        "hbt_speed.json",
        include_str!(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../models/hbt_speed.json"
        )),
    ),
    (
        "hbt_displacement.json",
        include_str!(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../models/hbt_displacement.json"
        )),
    ),
];

/// The slots in their fixed order.
pub const SLOTS: [(Method, Target); 4] = [
    (Method::Clfrt, Target::Speed),
    (Method::Clfrt, Target::Displacement),
    (Method::Hbt, Target::Speed),
    (Method::Hbt, Target::Displacement),
];

/// Index of a slot in [`SLOTS`].
pub fn slot_index(method: Method, target: Target) -> usize {
    match (method, target) {
        (Method::Clfrt, Target::Speed) => 0,
        (Method::Clfrt, Target::Displacement) => 1,
        (Method::Hbt, Target::Speed) => 2,
        (Method::Hbt, Target::Displacement) => 3,
    }
}

/// The four validated models for one configuration.
#[derive(Debug, Clone, PartialEq)]
pub struct Estimator {
    /// Models in [`SLOTS`] order.
    models: [Model; 4],
    /// CRC-32 of each model file's content, in [`SLOTS`] order, then the calibration's (see
    /// [`Estimator::fingerprint`]).
    fingerprint: String,
    /// The models' calibration on their class of hull (`calibration.json`).
    calibration: Calibration,
}

/// Per-caller buffers for [`Estimator::estimate`] (no allocation per estimate).
#[derive(Debug, Clone)]
pub struct EstimatorScratch {
    nets: [Scratch; 4],
    x: Vec<f64>,
}

impl Estimator {
    /// Validates four models (in any order) against `cfg`: each slot filled once, the same
    /// ship, servo and test design as the configuration, the expected inputs. Each model comes
    /// with the name (path) that errors cite.
    pub fn from_models(
        models: Vec<(String, Model)>,
        calibration: Calibration,
        cfg: &CoreConfig,
    ) -> Result<Self, ModelError> {
        let mut slots: [Option<Model>; 4] = [None, None, None, None];
        for (name, m) in models {
            let i = slot_index(m.file.method, m.file.target);
            let (method, target) = SLOTS[i];
            m.check_for(cfg, method, target, &name)?;
            if slots[i].is_some() {
                return Err(ModelError::Invalid {
                    path: name,
                    message: format!("a second {} {} model", method.name(), target.name()),
                });
            }
            slots[i] = Some(m);
        }
        let [a, b, c, d] = slots;
        let missing = |i: usize| ModelError::Invalid {
            path: SLOTS[i].1.file_name(SLOTS[i].0),
            message: "missing".into(),
        };
        let models = [
            a.ok_or_else(|| missing(0))?,
            b.ok_or_else(|| missing(1))?,
            c.ok_or_else(|| missing(2))?,
            d.ok_or_else(|| missing(3))?,
        ];
        let nyquist = std::f64::consts::PI * cfg.sensors.rate_hz;
        if calibration.wave_band_rad_s[1] > nyquist {
            return Err(ModelError::Invalid {
                path: CALIBRATION_FILE.into(),
                message: format!(
                    "wave-band-rad-s {:?}: above pi sensors.rate-hz = {nyquist:.3}",
                    calibration.wave_band_rad_s
                ),
            });
        }
        let crc = |bytes: Vec<u8>| format!("{:08x}", crc32fast::hash(&bytes));
        let fingerprint = models
            .iter()
            .map(|m| crc(serde_json::to_vec(&m.file).unwrap_or_default()))
            .chain(std::iter::once(crc(
                serde_json::to_vec(&calibration).unwrap_or_default()
            )))
            .collect::<Vec<_>>()
            .join("-");
        Ok(Self {
            models,
            fingerprint,
            calibration,
        })
    }

    /// Loads `<dir>/{clfrt,hbt}_{speed,displacement}.json` and validates them against `cfg`.
    pub fn load_dir(dir: &Path, cfg: &CoreConfig) -> Result<Self, ModelError> {
        let models = SLOTS
            .iter()
            .map(|&(m, t)| {
                let path = dir.join(t.file_name(m));
                Model::load(&path).map(|model| (path.display().to_string(), model))
            })
            .collect::<Result<Vec<_>, _>>()?;
        let path = dir.join(CALIBRATION_FILE);
        let name = path.display().to_string();
        let text = std::fs::read_to_string(&path).map_err(|source| ModelError::Io {
            path: name.clone(),
            source,
        })?;
        let calibration = Calibration::from_json(&text).map_err(|e| ModelError::Invalid {
            path: name,
            message: e.to_string(),
        })?;
        Self::from_models(models, calibration, cfg)
    }

    /// The models embedded in the binary ([`EMBEDDED_MODELS`]), validated against `cfg`.
    pub fn embedded(cfg: &CoreConfig) -> Result<Self, ModelError> {
        let models = EMBEDDED_MODELS
            .iter()
            .map(|(name, text)| {
                let name = format!("(embedded) models/{name}");
                Model::from_json(text, &name).map(|m| (name, m))
            })
            .collect::<Result<Vec<_>, _>>()?;
        Self::from_models(models, Calibration::default(), cfg)
    }

    /// The estimator `cfg` asks for: none when `estimator.enabled` is false, else the models
    /// of `estimator.models-dir`, or the embedded ones when it is absent, validated for `cfg`.
    pub fn from_config(cfg: &CoreConfig) -> Result<Option<Arc<Self>>, ModelError> {
        if !cfg.estimator.enabled {
            return Ok(None);
        }
        let e = match &cfg.estimator.models_dir {
            Some(dir) => Self::load_dir(Path::new(dir), cfg)?,
            None => Self::embedded(cfg)?,
        };
        Ok(Some(Arc::new(e)))
    }

    /// Which models these are: the CRC-32 of each model file's content, in slot order. A
    /// vessel's commissioning reference is kept only for the models it was made with.
    pub fn fingerprint(&self) -> &str {
        &self.fingerprint
    }

    /// The models' calibration on their class of hull.
    pub fn calibration(&self) -> &Calibration {
        &self.calibration
    }

    /// The model of a slot.
    pub fn model(&self, method: Method, target: Target) -> &Model {
        &self.models[slot_index(method, target)]
    }

    /// Buffers for [`Estimator::estimate`].
    pub fn scratch(&self) -> EstimatorScratch {
        EstimatorScratch {
            nets: [0, 1, 2, 3].map(|i| Scratch::new(self.models[i].inputs.len())),
            x: Vec::with_capacity(32),
        }
    }

    /// One parameter from a report's `features` (with `speed_log_mps` for displacement).
    pub fn predict(
        &self,
        method: Method,
        target: Target,
        features: &Features,
        scratch: &mut EstimatorScratch,
    ) -> Result<f64, FeatureError> {
        let i = slot_index(method, target);
        self.models[i].predict_features(features, &mut scratch.x, &mut scratch.nets[i])
    }

    /// One parameter with the input `speed_log_mps` replaced by `speed_log_mps` (see
    /// [`Model::predict_at_speed_log`]).
    pub fn predict_at_speed_log(
        &self,
        method: Method,
        target: Target,
        features: &Features,
        speed_log_mps: f64,
        scratch: &mut EstimatorScratch,
    ) -> Result<f64, FeatureError> {
        let i = slot_index(method, target);
        self.models[i].predict_at_speed_log(
            features,
            speed_log_mps,
            &mut scratch.x,
            &mut scratch.nets[i],
        )
    }

    /// Speed and displacement from a completed test's `features` (which must hold
    /// `speed_log_mps`, the mean speed-log reading over the test).
    pub fn estimate(
        &self,
        method: Method,
        features: &Features,
        scratch: &mut EstimatorScratch,
    ) -> Result<Estimate, FeatureError> {
        Ok(Estimate {
            speed_mps: self.predict(method, Target::Speed, features, scratch)?,
            displacement_t: self.predict(method, Target::Displacement, features, scratch)?,
        })
    }

    /// Inputs of a slot, in order.
    pub fn inputs(&self, method: Method, target: Target) -> &[Feature] {
        &self.model(method, target).inputs
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slots_are_consistent() {
        for (i, &(m, t)) in SLOTS.iter().enumerate() {
            assert_eq!(slot_index(m, t), i);
            assert_eq!(EMBEDDED_MODELS[i].0, t.file_name(m));
        }
    }

    #[test]
    fn embedded_models_load_for_the_default_configuration() {
        let cfg = CoreConfig::default();
        let est = Estimator::embedded(&cfg).unwrap();
        for (m, t) in SLOTS {
            assert_eq!(est.model(m, t).file.method, m);
        }
        // Another test design must be refused.
        let mut other = cfg;
        other.hbt.relay_height_deg += 1.0;
        let e = Estimator::embedded(&other).unwrap_err().to_string();
        assert!(e.contains("hbt") && e.contains("another design"), "{e}");
    }
}
