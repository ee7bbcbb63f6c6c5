//! # helmwatch-core: everything that decides, and nothing that touches the world
//!
//! The monitor core of helmwatch, the simulated ship and the drivers that run the core in
//! virtual time. No clock, no thread, no network, no database, no command line: time comes
//! with the samples, randomness from seeds, and the only files read are the estimator's model
//! files and a recording handed to `replay`. `cargo tree -p helmwatch-core -e normal` shows
//! no tokio, zenoh, clap, rusqlite or mcap; the service crate (`helmwatch`: the daemon's
//! shells, the tools, the command line) is built on top.
//!
//! ## Data flow
//!
//! A ship sample (Zenoh or a recording line) is decoded by [`wire::decode`] into a
//! [`wire::Input`], handed to [`monitor::Monitor::handle_input`], which validates it (counted
//! rejections), aligns it with the other streams by `t`, and on every accepted heading sample
//! queues exactly one [`wire::Excitation`]. Drivers drain [`monitor::Monitor::poll_output`]
//! and publish what comes out (excitation, status, report, notification).
//!
//! ## Modules
//!
//! From the bottom up, each imports only from those above it in this list (checked by the
//! service crate's `tests/it/layers.rs`):
//!
//! | module | what it is |
//! |---|---|
//! | [`angle`] | angle wrapping and unit conversions |
//! | [`config`] | the configuration error (exit 78), range checks, vessel names |
//! | [`wire`] | the Zenoh keys and JSON payloads of the contract |
//! | [`timeline`] | per-stream clock-step detection (duplicates, time backwards, jumps, re-synchronisation) |
//! | [`nmea`] | NMEA 0183 / IEC 61162-450 sentences to the contract's input samples (the bridge's decoder) |
//! | [`model`] | the ship model both ways, its particulars, servo, sensors, sea states |
//! | [`design`] | the HBT and CLFRT test designs (model files record them) |
//! | [`dsp`] | spectra, multisine design, tone analysis, relay limit-cycle theory |
//! | [`baseline`] | equation-error least squares of the Nomoto a and b |
//! | [`passive`] | the closed loop's spectral model under the autopilot, its Fisher information and Whittle's estimator (the passive watch's bound) |
//! | [`estimator`] | the neural estimator's inference and model files |
//! | [`fdi`] | parity-space residuals, decision rule, alarm state, isolation |
//! | [`monitor`] | the monitor: a state machine fed timestamped samples; [`monitor::config::CoreConfig`] |
//! | [`ownership`] | which daemon drives a vessel: candidates, holder, takeover (a state machine fed liveliness events) |
//! | [`sim`] | the simulated ship: Nomoto hull, servo, autopilot, sea, sensors, faults |
//! | [`drivers`] | the core in virtual time beside the simulator (`probe`, lockstep) and over a recording (`replay`) |

pub mod angle;
pub mod baseline;
pub mod config;
pub mod design;
pub mod drivers;
pub mod dsp;
pub mod estimator;
pub mod fdi;
pub mod model;
pub mod monitor;
pub mod nmea;
pub mod ownership;
pub mod passive;
pub mod sim;
#[cfg(any(test, feature = "test-support"))]
pub mod testing;
pub mod timeline;
pub mod wire;
