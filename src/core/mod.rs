//! The pure core: everything that decides, and nothing that touches the world.
//!
//! No clock, no thread, no network, no file but the model files the estimator may be asked to
//! read: time comes with the samples, randomness from seeds. It compiles without tokio, zenoh,
//! clap or sd-notify (`cargo check --lib --no-default-features`). Its folders, from the bottom
//! up (each imports only from those above it in this list):
//!
//! | module | what it is |
//! |---|---|
//! | [`angle`] | angle wrapping and unit conversions |
//! | [`config`] | the configuration error (exit 78), range checks, vessel names |
//! | [`wire`] | the Zenoh keys and JSON payloads of the contract |
//! | [`nmea`] | NMEA 0183 / IEC 61162-450 sentences to the contract's input samples (the bridge's decoder) |
//! | [`model`] | the ship model both ways, its particulars, servo, sensors, sea states |
//! | [`design`] | the HBT and CLFRT test designs (model files record them) |
//! | [`dsp`] | spectra, multisine design, tone analysis, relay limit-cycle theory |
//! | [`baseline`] | equation-error least squares of the Nomoto a and b |
//! | [`estimator`] | the neural estimator's inference and model files |
//! | [`fdi`] | parity-space residuals, decision rule, alarm state, isolation |
//! | [`monitor`] | the monitor: a state machine fed timestamped samples; [`CoreConfig`] |
//! | [`ownership`] | which daemon drives a vessel: candidates, holder, takeover (a state machine fed liveliness events) |

pub mod angle;
pub mod baseline;
pub mod config;
pub mod design;
pub mod dsp;
pub mod estimator;
pub mod fdi;
pub mod model;
pub mod monitor;
pub mod nmea;
pub mod ownership;
pub mod wire;

pub use monitor::config::CoreConfig;
pub use monitor::{Monitor, Output};
