//! # helmwatch: steering fault detection for ships
//!
//! helmwatch watches a ship's steering for faults by running short closed-loop excitation
//! tests while the ship holds a steady course, measuring frequency features of the heading
//! response, estimating the ship's speed and displacement from them, and comparing those with
//! their nominal values in a parity space. Heading-sensor drift has no power at the excited
//! frequencies, so a drifting gyro never raises an alarm.
//!
//! ## Floors
//!
//! The folders of `src/` are the layout's floors; each imports only from the floors below it
//! (checked by `tests/it/layers.rs`; the drawing is docs/architecture.md):
//!
//! | floor | folder | what it is | I/O |
//! |---|---|---|---|
//! | 1 | [`core`] | the pure core: wire types, the NMEA decoder, angles, the ship model both ways, config data, dsp, the monitor, the FDI, the estimator's inference, the baseline | none (the estimator may read model files) |
//! | 2 | [`sim`] | the simulated ship: Nomoto hull, servo, autopilot, sea, sensors, faults | none |
//! | 3 | [`drivers`] | the core in virtual time beside the simulator (`probe`, lockstep) and over a recording (`replay`) | reads a recording |
//! | 4 | `shells` | Zenoh session settings, the daemon, the simulated ship as a Zenoh peer, the NMEA bridge, systemd | Zenoh, signals, UDP/TCP/serial NMEA in |
//! | 5 | `config` | the configuration file as a whole (each section lives beside its owner) | reads a file |
//! | 6 | `tools` | training database and trainers, evaluation suites, demo, bench | files, stdout, Zenoh |
//! | 7 | `cli` | the `helmwatch` command line: thin drivers | everything |
//!
//! Floors 4 to 7 need the default feature `shell` (tokio, zenoh, clap, sd-notify, toml);
//! `cargo check --lib --no-default-features` builds floors 1 to 3 without them.
//!
//! ## Data flow
//!
//! A ship sample (Zenoh or a recording line) is decoded by [`core::wire::decode`] into a
//! [`core::wire::Input`], handed to [`core::monitor::Monitor::handle_input`], which validates
//! it (counted rejections), aligns it with the other streams by `t`, and on every accepted
//! heading sample queues exactly one [`core::wire::Excitation`]. Drivers drain
//! [`core::monitor::Monitor::poll_output`] and publish what comes out (excitation, status,
//! report, notification). The core never reads a clock or a global random generator: time
//! comes with the samples, randomness from seeds.

pub mod core;
pub mod drivers;
pub mod sim;

#[cfg(feature = "shell")]
pub mod cli;
#[cfg(feature = "shell")]
pub mod config;
#[cfg(feature = "shell")]
pub mod shells;
#[cfg(feature = "shell")]
pub mod tools;
