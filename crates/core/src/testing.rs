//! Samples for tests, this crate's and the service's: complete features whose fields a test
//! then sets, and a valid model file. Compiled for this crate's tests and with the feature
//! `test-support` (the service's dev-dependency on this crate), never into the binary.
#![allow(clippy::unwrap_used)]

use crate::estimator::features;
use crate::estimator::model::*;
use crate::estimator::nn::{Mlp, Scaling};
use crate::estimator::trainer::{LmOptions, StopReason, Trainer};
use crate::model::SeaState;
use crate::monitor::config::CoreConfig;
use crate::wire::Method;

/// Features to build on.
pub mod sample {
    use crate::wire::features::*;

    /// A tone with 90 % intervals of 3 % in gain and 0.02 rad in phase.
    pub fn tone(omega_rad_s: f64, gain: f64, phase_rad: f64) -> ToneFeatures {
        ToneFeatures {
            omega_rad_s,
            gain,
            phase_rad,
            coherence: 1.0,
            snr_db: 40.0,
            gain_ci90_rel: 0.03,
            phase_ci90_rad: 0.02,
        }
    }

    /// CLFRT features with these tones, no servo check, no baseline, no speed log.
    pub fn clfrt(tones: Vec<ToneFeatures>) -> ClfrtFeatures {
        ClfrtFeatures {
            tones,
            window_s: 590.0,
            windows: 2,
            amplitude_rad: 0.07,
            crest_factor: 1.8,
            servo_check: None,
            wave_yaw_rad: None,
            amplitude_scales: None,
            speed_log_mps: None,
            baseline: None,
            baseline_error: None,
        }
    }

    /// HBT features of a 150 s limit cycle, no response, no servo rate, no baseline.
    pub fn hbt() -> HbtFeatures {
        HbtFeatures {
            period_s: 150.0,
            omega_u_rad_s: 2.0 * std::f64::consts::PI / 150.0,
            amplitude_rad: 0.05,
            periods: 4,
            period_std_s: 3.0,
            ultimate_gain: 3.0,
            relay_height_rad: 0.14,
            hysteresis_rad: 0.017,
            trim_rad: 0.0,
            initial_trim_rad: 0.001,
            min_switch_interval_s: 60.0,
            switches: 11,
            wave_yaw_rad: None,
            rudder_amplitude_rad: None,
            response_gain: None,
            response_phase_rad: None,
            servo_rate: None,
            relay_scale: None,
            relay_omega_ratio: None,
            relay_amplitude_ratio: None,
            speed_log_mps: None,
            baseline: None,
            baseline_error: None,
        }
    }

    /// A servo check that measured a rate `p95` against the nominal `nominal` [rad/s].
    pub fn servo_check(p95: f64, nominal: f64) -> ServoCheckFeatures {
        ServoCheckFeatures {
            omega_rad_s: 0.6,
            amplitude_rad: 0.087,
            periods: 10,
            ln_gain: Some(0.0),
            phase_rad: Some(-0.5),
            ln_gain_error: Some(0.0),
            phase_error_rad: Some(0.0),
            harmonic3_ratio: None,
            residual_rms_rad: Some(0.01),
            rudder_rate_p95_rad_s: Some(p95),
            rudder_rate_nominal_rad_s: Some(nominal),
            ratio_ln_gain: Some(0.0),
            ratio_phase_rad: Some(-0.6),
            failed: None,
        }
    }
}

/// A valid displacement model for the default CLFRT design (weights arbitrary).
pub fn sample_model() -> Model {
    let cfg = CoreConfig::default();
    let inputs = features::displacement_inputs(Method::Clfrt, cfg.clfrt.harmonics.len());
    let n_in = inputs.len();
    let theta: Vec<f64> = (0..crate::estimator::nn::n_params(n_in))
        .map(|k| ((k as f64) * 0.37).sin() * 0.5)
        .collect();
    let net = Mlp::from_params(n_in, &theta).unwrap();
    let scaling = Scaling::new(
        (0..n_in).map(|i| -(i as f64) - 1.0).collect(),
        (0..n_in).map(|i| i as f64 + 1.0).collect(),
        4000.0,
        10000.0,
    )
    .unwrap();
    Model::new(
        Method::Clfrt,
        Target::Displacement,
        &inputs,
        &net,
        &scaling,
        Metadata {
            design: Design::from_config(&cfg, Method::Clfrt),
            uncertainty: Uncertainty {
                residual_mean: 1.0,
                residual_std: 80.0,
                by_sea: vec![SeaSpread {
                    sea: SeaState::Calm,
                    n: 10,
                    residual_mean: 0.5,
                    residual_std: 60.0,
                    relative_mean: Some(1e-4),
                    relative_std: Some(0.008),
                }],
            },
            training: TrainingRecord {
                database_seed: 1,
                design_points_per_sea: 10,
                sea_states: vec![SeaState::Calm],
                family: false,
                database_size: 10,
                database_failed: 0,
                split: Split {
                    train: 6,
                    validation: 2,
                    test: 2,
                },
                trainer: Trainer::Lm(LmOptions::default()),
                restarts: 1,
                best_restart: 0,
                epochs: 3,
                best_epoch: 3,
                stop: StopReason::MaxEpochs,
                mse_train: 0.1,
                mse_validation: 0.2,
                mse_test: 0.3,
                rmse_test: 100.0,
            },
        },
    )
    .unwrap()
}
