//! # helmwatch: steering fault detection for ships (the service)
//!
//! helmwatch watches a ship's steering for faults by running short closed-loop excitation
//! tests while the ship holds a steady course, measuring frequency features of the heading
//! response, estimating the ship's speed and displacement from them, and comparing those with
//! their nominal values in a parity space. Heading-sensor drift has no power at the excited
//! frequencies, so a drifting gyro never raises an alarm.
//!
//! ## Crates and floors
//!
//! Two crates. `helmwatch-core` (crates/core) is the pure core, the simulated ship and the
//! offline drivers: no tokio, zenoh, clap, rusqlite or mcap in its dependency tree, so the
//! compiler keeps the world out of every decision. This crate, the service, is built on it;
//! its folders are floors, each importing only from the floors below it and from the core
//! (checked by `tests/it/layers.rs`; the drawing is docs/architecture.md):
//!
//! | floor | folder | what it is | I/O |
//! |---|---|---|---|
//! | 1 | `shells` | Zenoh session settings, the daemon, the simulated ship as a Zenoh peer, the NMEA bridge, systemd | Zenoh, signals, UDP/TCP/serial NMEA in |
//! | 2 | `config` | the configuration file as a whole (each section lives beside its owner) | reads a file |
//! | 3 | `tools` | training database and trainers, evaluation suites, demo, bench | files, stdout, Zenoh |
//! | 4 | `cli` | the `helmwatch` command line: thin drivers | everything |
//!
//! The data flow, from a ship sample to a decision, is told in `helmwatch_core`'s crate doc.

pub mod cli;
pub mod config;
pub mod shells;
pub mod tools;
