//! The integration tests, one crate: each module is the behaviour of one part of helmwatch
//! seen from outside (the simulator, the monitor core through its drivers, the daemon and its
//! clients over Zenoh on loopback, the binary's commands, the shipped files). One crate links
//! zenoh and tokio once; tests run on the harness's threads side by side, so each one binds its
//! own free loopback port and its own temporary directory.
//!
//! Tiers: `cargo test --profile ci` runs the fast tier; the tests marked
//! `#[ignore = "slow tier: ..."]` (full-size Monte Carlos and soaks) run with
//! `cargo test --profile ci -- --ignored`. CI runs both.
// A test crate: an unwrap, expect or panic here is the test failing, with its message
// (clippy.toml allows them in `#[test]` functions; the helpers are test code too).
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

mod common;

mod baseline;
mod bridge_nmea;
mod class_models;
mod clock_steps;
mod commissioning;
mod config_example;
mod daemon_process;
mod daemon_restart;
mod daemon_zenoh;
mod demo;
mod deploy_files;
mod estimator;
mod features;
mod fleet_classes;
mod fleet_view;
mod flood_recording;
mod golden;
mod heading_guard;
mod layers;
mod mariner;
mod mcap_recording;
mod metrics;
mod mmg;
mod monitor_safety;
mod nmea_in;
mod plot;
mod relay_sea;
mod residual_docs;
mod router_acl;
mod servo_check;
mod sim;
mod sizes;
mod source;
mod standby;
