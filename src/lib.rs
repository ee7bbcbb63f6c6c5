//! # helmwatch: steering fault detection for ships
//!
//! helmwatch watches a ship's steering for faults by running short closed-loop excitation
//! tests while the ship holds a steady course, measuring frequency features of the heading
//! response, estimating the ship's speed and displacement from them, and comparing those with
//! their nominal values in a parity space. Heading-sensor drift has no power at the excited
//! frequencies, so a drifting gyro never raises an alarm.
//!
//! ## Module map
//!
//! | module | what it is | I/O? |
//! |---|---|---|
//! | [`config`] | every number of the domain, with units, defaults and checked ranges | reads a file |
//! | [`wire`] | the Zenoh keys and JSON payloads of the contract, decode and encode | no |
//! | [`angle`] | angle wrapping and unit conversions | no |
//! | [`sim`] | the simulated ship: Nomoto model, servo, autopilot, sea, sensors, faults | no |
//! | [`dsp`] | spectra, detrending, multisine design, tone analysis, relay limit-cycle theory | no |
//! | [`monitor`] | the monitor core: a pure state machine fed timestamped samples | no |
//! | [`estimator`] | the neural estimator: features to speed and displacement; training, model files, evaluation | reads model files |
//! | [`fdi`] | parity-space residuals, decision rule, alarm state, isolation; the `eval --fdi` suite | no |
//! | [`baseline`] | time-domain baseline: equation-error least squares of the Nomoto a and b (state-variable filter) | no |
//! | [`probe`] | virtual-time driver: simulated ship + monitor core in lockstep | no |
//! | [`replay`] | the monitor core over a recording (JSON lines) | reads a file |
//! | [`net`] | Zenoh session configuration shared by the drivers below | no |
//! | [`daemon`] | the Zenoh daemon: one task per vessel owning its core, trigger queryable, liveliness | Zenoh |
//! | [`shipnode`] | the simulated ship as a Zenoh peer (lockstep or real time) | Zenoh |
//! | [`demo`] | daemon and simulated ship in one process over Zenoh on loopback | Zenoh, stdout |
//! | [`bench`] | benchmark figures of the daemon over Zenoh (`helmwatch bench`) | Zenoh, stdout |
//! | [`cli`] | the `helmwatch` command line (subcommands are thin drivers) | yes |
//!
//! ## Data flow
//!
//! A ship sample (Zenoh or a recording line) is decoded by [`wire::decode`] into a
//! [`wire::Input`], handed to [`monitor::Monitor::handle_input`], which validates it (counted
//! rejections), aligns it with the other streams by `t`, and on every accepted heading sample
//! queues exactly one [`wire::Excitation`]. Drivers drain [`monitor::Monitor::poll_output`]
//! and publish what comes out (excitation, status, report, notification). The core never reads
//! a clock or a global random generator: time comes with the samples, randomness from seeds.

pub mod angle;
pub mod baseline;
pub mod bench;
pub mod cli;
pub mod config;
pub mod daemon;
pub mod demo;
pub mod dsp;
pub mod estimator;
pub mod fdi;
pub mod monitor;
pub mod net;
pub mod probe;
pub mod replay;
pub mod shipnode;
pub mod sim;
pub mod wire;
