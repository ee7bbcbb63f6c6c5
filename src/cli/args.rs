//! The command line's schema: every subcommand and its arguments (clap derive). The bodies
//! are in [`super::offline`], [`super::service`] and [`super::estimator`].

use crate::cli::estimator::{DEFAULT_EVAL_POINTS, DEFAULT_RESTARTS, DEFAULT_TRAIN_POINTS};
use clap::{Args, Parser, Subcommand};
use helmwatch_core::model::SeaState;
use helmwatch_core::wire::Method;
use std::path::PathBuf;

#[derive(Debug, Parser)]
#[command(
    name = "helmwatch",
    version,
    about = "Steering fault detection for ships: closed-loop frequency tests over Zenoh"
)]
pub(crate) struct Cli {
    /// Configuration file (TOML); without it the embedded defaults are used.
    #[arg(long, global = true, value_name = "FILE")]
    pub(crate) config: Option<PathBuf>,
    #[command(subcommand)]
    pub(crate) command: Command,
}

#[derive(Debug, Subcommand)]
pub(crate) enum Command {
    /// Record what a simulated ship publishes, as JSON lines {"key": .., "payload": ..}.
    Simulate(SimulateArgs),
    /// Run one test (HBT or CLFRT) on a simulated ship in virtual time and print its report.
    Probe(ProbeArgs),
    /// Check a configuration file and print it with every default filled in.
    CheckConfig,
    /// The daemon: monitor the configured vessels over Zenoh until SIGTERM or SIGINT.
    Run(RunArgs),
    /// The simulated ship as a Zenoh peer (lockstep with the daemon, or real time).
    Ship(ShipPeerArgs),
    /// Daemon and simulated ship in one process over Zenoh on loopback, accelerated time:
    /// a few nominal tests, then a displacement fault; prints each decision as it arrives.
    Demo(DemoArgs),
    /// Run the monitor core over a recording (JSON lines, as `simulate` writes, or the
    /// daemon's MCAP recordings) and print its reports.
    Replay(ReplayArgs),
    /// Print the daemon's benchmark figures (lockstep speed, vessels kept up with, memory);
    /// with --time-to-alarm, time to alarm and rudder travel per scheduler interval.
    Bench(BenchArgs),
    /// Regenerate the training database and every estimator model (bit for bit per seed).
    Train(TrainArgs),
    /// Evaluate the models on a held-out database: accuracy tables, durations, drift.
    Eval(EvalArgs),
    /// Client: is a vessel's daemon alive, its alarm state and its last decisions.
    Status(ClientArgs),
    /// Client: ask a vessel's daemon for a test now.
    Trigger(TriggerArgs),
    /// Client: a vessel's report history (`fdi/history`).
    History(HistoryArgs),
    /// Client: a vessel's commissioning (`fdi/commission`); with --start, begin it again.
    Commission(CommissionArgs),
    /// Draw a report (Bode pair or Nyquist), a report history or a recording as SVG.
    Plot(PlotArgs),
    /// Client: every vessel whose daemon is alive, its state, alarm and last decision, live.
    Fleet(FleetArgs),
    /// A bridge from a ship's own instruments to the contract's keys (`bridge nmea`).
    #[command(subcommand)]
    Bridge(BridgeCommand),
}

#[derive(Debug, Subcommand)]
pub(crate) enum BridgeCommand {
    /// NMEA 0183 / IEC 61162-450 in (UDP unicast or multicast, TCP, a serial device), one
    /// vessel's heading, rudder, speed and autopilot out over Zenoh, per `[bridge]`.
    Nmea(NmeaBridgeArgs),
}

#[derive(Debug, Args)]
pub(crate) struct NmeaBridgeArgs {
    /// Vessel name in the keys (default: `bridge.vessel`).
    #[arg(long)]
    pub(crate) vessel: Option<String>,
    /// Read UDP datagrams on this address (sets `bridge.input = "udp"`, replaces
    /// `bridge.udp-listen`).
    #[arg(long, value_name = "IP:PORT", conflicts_with_all = ["tcp", "serial"])]
    pub(crate) udp: Option<String>,
    /// Read a TCP stream from this server (sets `bridge.input = "tcp"`).
    #[arg(long, value_name = "HOST:PORT", conflicts_with = "serial")]
    pub(crate) tcp: Option<String>,
    /// Read this serial device (sets `bridge.input = "serial"`).
    #[arg(long, value_name = "PATH")]
    pub(crate) serial: Option<PathBuf>,
    /// Endpoint to listen on (repeatable; replaces `bridge.listen`).
    #[arg(long, value_name = "ENDPOINT")]
    pub(crate) listen: Vec<String>,
    /// Endpoint to connect to (repeatable; replaces `bridge.connect`).
    #[arg(long, value_name = "ENDPOINT")]
    pub(crate) connect: Vec<String>,
}

#[derive(Debug, Args)]
pub(crate) struct FleetArgs {
    /// Endpoint of a daemon or of a router that reaches the fleet (repeatable).
    #[arg(long, value_name = "ENDPOINT", default_value = "tcp/127.0.0.1:7447")]
    pub(crate) connect: Vec<String>,
    /// Print one JSON object per change instead of a table.
    #[arg(long)]
    pub(crate) json: bool,
    /// Stop after this many seconds (default: until Ctrl-C).
    #[arg(long)]
    pub(crate) duration_s: Option<f64>,
}

#[derive(Debug, Args)]
pub(crate) struct PlotArgs {
    /// A report (`probe --json`), a report history (`history --json`, or one report per
    /// line) or a recording (JSON lines {"key", "payload"}); `-` for standard input.
    pub(crate) input: PathBuf,
    /// The SVG file to write.
    #[arg(long, value_name = "FILE.svg")]
    pub(crate) out: PathBuf,
    /// What the input is: report, history or recording (default: detected).
    #[arg(long)]
    pub(crate) kind: Option<crate::tools::plot::InputKind>,
    /// A recording's vessel (default: the first in it).
    #[arg(long)]
    pub(crate) vessel: Option<String>,
    /// Width of the picture [px].
    #[arg(long, default_value_t = 1000)]
    pub(crate) width: u32,
    /// Height of the picture [px].
    #[arg(long, default_value_t = 760)]
    pub(crate) height: u32,
}

/// How a client reaches a daemon.
#[derive(Debug, Args)]
pub(crate) struct ClientArgs {
    /// Endpoint of the daemon or of a router that reaches it (repeatable).
    #[arg(long, value_name = "ENDPOINT", default_value = "tcp/127.0.0.1:7447")]
    pub(crate) connect: Vec<String>,
    /// The vessel (default: the first of `daemon.vessels`).
    #[arg(long)]
    pub(crate) vessel: Option<String>,
    /// Print JSON (the payloads as published) instead of tables.
    #[arg(long)]
    pub(crate) json: bool,
    /// Longest wait for the daemon's answer [s].
    #[arg(long, default_value_t = 10.0)]
    pub(crate) timeout_s: f64,
}

#[derive(Debug, Args)]
pub(crate) struct TriggerArgs {
    #[command(flatten)]
    pub(crate) client: ClientArgs,
    /// Test method.
    #[arg(long, default_value = "hbt")]
    pub(crate) method: Method,
}

#[derive(Debug, Args)]
pub(crate) struct CommissionArgs {
    #[command(flatten)]
    pub(crate) client: ClientArgs,
    /// Begin commissioning again: the vessel's reference is set anew from its next healthy
    /// tests (run it on a healthy ship, after a repair or a change of autopilot).
    #[arg(long)]
    pub(crate) start: bool,
    /// With --start: only this method (default both).
    #[arg(long)]
    pub(crate) method: Option<Method>,
}

#[derive(Debug, Args)]
pub(crate) struct HistoryArgs {
    #[command(flatten)]
    pub(crate) client: ClientArgs,
    /// From this ship time [s].
    #[arg(long)]
    pub(crate) from: Option<f64>,
    /// Up to this ship time [s].
    #[arg(long)]
    pub(crate) to: Option<f64>,
    /// The latest this many records.
    #[arg(long, default_value_t = 20)]
    pub(crate) limit: usize,
}

#[derive(Debug, Args)]
pub(crate) struct TrainArgs {
    /// Seed of the database (design, simulations, split) and of the training restarts.
    #[arg(long, default_value_t = 1)]
    pub(crate) seed: u64,
    /// Directory for the model files (Levenberg-Marquardt; Fletcher-Reeves in `traincgf/`).
    #[arg(long, default_value = "models")]
    pub(crate) out: PathBuf,
    /// Latin-hypercube points per sea state.
    #[arg(long, default_value_t = DEFAULT_TRAIN_POINTS)]
    pub(crate) points: usize,
    /// Seeded restarts per network and trainer.
    #[arg(long, default_value_t = DEFAULT_RESTARTS)]
    pub(crate) restarts: usize,
    /// Worker threads (default: every core).
    #[arg(long)]
    pub(crate) threads: Option<usize>,
    /// Train for this vessel's class: its `[vessel.<name>]` table over the file's top level.
    #[arg(long, value_name = "NAME")]
    pub(crate) vessel: Option<String>,
    /// Draw every point's ship from the family of real ships (second-order Nomoto, Norrbin
    /// damping, dead band, backlash, fixed-gain autopilot; docs/estimator.md).
    #[arg(long)]
    pub(crate) family: bool,
    /// Keep the networks in `--out`: measure only their calibration's healthy scatter,
    /// displacement direction and slope in speed on the class (seeded tests at fixed points;
    /// docs/fdi.md, "The class's prior", "Residuals") and rewrite its `calibration.json`.
    #[arg(long)]
    pub(crate) calibrate: bool,
}

#[derive(Debug, Args)]
pub(crate) struct EvalArgs {
    /// Seed of the held-out database (drawn on other random streams than training's).
    #[arg(long, default_value_t = 1)]
    pub(crate) seed: u64,
    /// Directory of the model files (Levenberg-Marquardt; Fletcher-Reeves in `traincgf/`);
    /// default: the configuration's `estimator.models-dir`, else `models`.
    #[arg(long)]
    pub(crate) models: Option<PathBuf>,
    /// Held-out points per sea state.
    #[arg(long, default_value_t = DEFAULT_EVAL_POINTS)]
    pub(crate) points: usize,
    /// Also run every held-out test with a heading drift of 1 deg/min and compare.
    #[arg(long)]
    pub(crate) drift: bool,
    /// Run the fault-decision scenario suite instead (docs/fdi.md): false alarms, detection,
    /// isolation, delay, per method and sea state, beside the equation-error baseline.
    #[arg(long)]
    pub(crate) fdi: bool,
    /// Run the decision on its own model instead (Monte Carlo vessels whose residuals are
    /// exactly what it assumes): false alarms against `fdi.false-alarms-per-year` over the
    /// commissioning sample size, the floors and learning; with --results DIR, written to
    /// DIR/budget-seed<SEED>.md.
    #[arg(long, conflicts_with = "fdi")]
    pub(crate) budget: bool,
    /// Compute one test's Cramer-Rao bound on (u, D) from its features instead, per method
    /// and sea at the nominal point, beside the networks' spread (`--runs` seeded tests per
    /// point, from `--seed`); with --results DIR, written to
    /// DIR/crb-seed<SEED>[-<member>][-models-<dir>].md.
    #[arg(long, conflicts_with_all = ["fdi", "budget"])]
    pub(crate) crb: bool,
    /// Compute the passive watch's bound instead (docs/passive.md): the Cramer-Rao bound of
    /// the ship's Nomoto a and b from 10 to 120 minutes of normal operation under the
    /// autopilot, per sea, beside one CLFRT test's; the shortest record that resolves a 10 %
    /// displacement step and a 0.5 m/s log bias at the budget; and Whittle's estimator on the
    /// simulated ship against it (`--runs` records per cell); with --results DIR, written to
    /// DIR/passive-seed<SEED>.md.
    #[arg(long, conflicts_with_all = ["fdi", "budget", "crb"])]
    pub(crate) passive: bool,
    /// With --fdi: runs per fault scenario; with --crb: seeded tests per point; with
    /// --passive: records per Monte Carlo cell.
    #[arg(long, default_value_t = 60)]
    pub(crate) runs: usize,
    /// With --fdi: runs per nominal scenario (each of `--tests` tests).
    #[arg(long, default_value_t = 60)]
    pub(crate) nominal_runs: usize,
    /// With --fdi: tests per run (of each method with --in-turn) after commissioning;
    /// --scenarios envelope: after the change, and after a later fault's onset.
    #[arg(long, default_value_t = 4)]
    pub(crate) tests: usize,
    /// With --fdi: only this method (default both).
    #[arg(long)]
    pub(crate) method: Option<Method>,
    /// With --fdi: only this sea state (default calm and moderate).
    #[arg(long)]
    pub(crate) sea: Option<SeaState>,
    /// Skip the accuracy-against-test-length table.
    #[arg(long)]
    pub(crate) no_lengths: bool,
    /// Also evaluate on the family of real ships (second-order Nomoto, Norrbin damping, dead
    /// band, backlash, a fixed-gain autopilot, and the KVLCC2 and Mariner surge-sway-yaw
    /// hulls; `sim::config::family`). With --fdi: the
    /// scenario suite on every member of the family (healthy with drift, then faults after
    /// commissioning; half the runs at the corners of the speed and displacement box).
    #[arg(long)]
    pub(crate) family: bool,
    /// With --fdi --family or --crb --family: only members whose name contains this.
    #[arg(long, value_name = "TEXT")]
    pub(crate) member: Option<String>,
    /// Worker threads (default: every core).
    #[arg(long)]
    pub(crate) threads: Option<usize>,
    /// With --fdi: also write every test's outcome (decision, residuals, the raw residuals
    /// against the design) to this file as JSON lines.
    #[arg(long, value_name = "FILE")]
    pub(crate) outcomes: Option<std::path::PathBuf>,
    /// With --fdi: the methods take turns on each ship, as the daemon runs them (`--tests`
    /// tests of each; the windows count tests of each method), instead of one method per run.
    #[arg(long)]
    pub(crate) in_turn: bool,
    /// With --fdi: which scenario sets run: `classic` (faults from commissioning's end at one
    /// operating point), `envelope` (the speed and/or the declared loading change after
    /// commissioning; displacement faults after a speed change), `commissioning` (faults
    /// arising during commissioning), or `all` (docs/fdi.md, "What is measured").
    #[arg(long, value_name = "SET", default_value = "classic")]
    pub(crate) scenarios: crate::tools::eval::fdi::ScenarioSet,
    /// With --fdi, classic and envelope scenarios: the fault (envelope: the change of
    /// operating point or sea, and its fault with or after it) arises N tests of the ship
    /// after commissioning ends, the vessel learning its healthy tests meanwhile (detection
    /// counts from the onset; false alarms are the healthy rows'), not at its end.
    #[arg(long, value_name = "N", default_value_t = 0)]
    pub(crate) onset_after: usize,
    /// With --fdi: also write the tables to DIR/<suite>.md under the command, the commit and
    /// the seed, and the rows' figures to DIR/<suite>.json (docs/results/).
    #[arg(long, value_name = "DIR")]
    pub(crate) results: Option<PathBuf>,
    /// With --fdi: put the rows' figures beside those of the same suite in DIR (a
    /// `<suite>.json` an earlier `--results DIR` wrote): the before-and-after table.
    #[arg(long, value_name = "DIR")]
    pub(crate) compare: Option<PathBuf>,
    /// With --fdi: run the suite again with each mechanism of the decision off in turn and
    /// add what each buys (false alarms, the alert tail, detection, naming); with a list
    /// (comma-separated names), only those; `a+b` switches a and b off together.
    #[arg(long, value_name = "MECHANISMS", num_args = 0..=1, default_missing_value = "all")]
    pub(crate) ablate: Option<String>,
}

#[derive(Debug, Args)]
pub(crate) struct RunArgs {
    /// Endpoint to listen on, e.g. tcp/127.0.0.1:7447 (repeatable; replaces `zenoh.listen`).
    #[arg(long, value_name = "ENDPOINT")]
    pub(crate) listen: Vec<String>,
    /// Endpoint to connect to (repeatable; replaces `zenoh.connect`).
    #[arg(long, value_name = "ENDPOINT")]
    pub(crate) connect: Vec<String>,
    /// State directory: alarm tracks and scheduler saved after every decision, restored at
    /// start (replaces `daemon.state-dir`; systemd: /var/lib/helmwatch).
    #[arg(long, value_name = "DIR")]
    pub(crate) state_dir: Option<PathBuf>,
}

#[derive(Debug, Args)]
pub(crate) struct ShipPeerArgs {
    #[command(flatten)]
    pub(crate) ship: ShipArgs,
    /// Vessel name in the keys (default: `simulation.vessel`).
    #[arg(long)]
    pub(crate) vessel: Option<String>,
    /// Tick on a timer instead of waiting for the daemon's excitation (lockstep).
    #[arg(long)]
    pub(crate) real_time: bool,
    /// Ship seconds per wall second on the timer (default: `ship-peer.speed-up`).
    #[arg(long)]
    pub(crate) speed_up: Option<f64>,
    /// Stop after this much ship time [s] (default: run until SIGTERM or SIGINT).
    #[arg(long)]
    pub(crate) duration_s: Option<f64>,
    /// Endpoint to listen on (repeatable; replaces `ship-peer.listen`).
    #[arg(long, value_name = "ENDPOINT")]
    pub(crate) listen: Vec<String>,
    /// Endpoint to connect to (repeatable; replaces `ship-peer.connect`).
    #[arg(long, value_name = "ENDPOINT")]
    pub(crate) connect: Vec<String>,
    /// Record every publication as JSON lines (the `simulate` format, input of `replay`).
    #[arg(long, value_name = "FILE")]
    pub(crate) record: Option<PathBuf>,
    /// The instruments speak NMEA only: send each tick as an IEC 61162-450 datagram to this
    /// UDP address (for `helmwatch bridge nmea` with `bridge.time-source = "tag-block-ms"`)
    /// instead of publishing the keys; the excitation still comes over Zenoh.
    #[arg(long, value_name = "IP:PORT")]
    pub(crate) nmea_udp: Option<std::net::SocketAddr>,
}

#[derive(Debug, Args)]
pub(crate) struct DemoArgs {
    /// Seed of the simulated ship.
    #[arg(long, default_value_t = 1)]
    pub(crate) seed: u64,
    /// The fault, KIND:VALUE@ONSET_S (after commissioning: with seed 1 the first two tests
    /// of each method end at 5954 s).
    #[arg(long, default_value = "displacement_pct:+25@14930")]
    pub(crate) fault: String,
    /// Reports of the faulty ship after which the demo stops if no alarm came.
    #[arg(long, default_value_t = 8)]
    pub(crate) fault_reports: usize,
}

#[derive(Debug, Args)]
pub(crate) struct ReplayArgs {
    /// The recording (JSON lines {"key": .., "payload": ..}, or an MCAP file of the daemon's,
    /// told by its magic bytes); `-` for standard input.
    pub(crate) file: PathBuf,
    /// Print each report as one JSON line (the `fdi/report` payload).
    #[arg(long)]
    pub(crate) json: bool,
}

#[derive(Debug, Args)]
pub(crate) struct BenchArgs {
    /// Ship time of the lockstep figure [s].
    #[arg(long, default_value_t = 1800.0)]
    pub(crate) lockstep_s: f64,
    /// Fleet sizes tried, in order, until one is not kept up with.
    #[arg(long, value_delimiter = ',', default_values_t = vec![100, 250, 500, 1000, 2000])]
    pub(crate) fleet: Vec<usize>,
    /// Measurement window of each fleet size [s of wall time].
    #[arg(long, default_value_t = 5.0)]
    pub(crate) window_s: f64,
    /// Internal: measure one fleet size in this process and print it as JSON.
    #[arg(long, hide = true)]
    pub(crate) one_fleet: Option<usize>,
    /// Instead: time to alarm per fault and rudder travel added per hour, per scheduler
    /// interval, in virtual time (the monitor core in lockstep with the simulated ship, the
    /// scheduler on; docs/fdi.md).
    #[arg(long)]
    pub(crate) time_to_alarm: bool,
    /// With --time-to-alarm: seeded runs per interval.
    #[arg(long, default_value_t = 12)]
    pub(crate) runs: usize,
    /// With --time-to-alarm: seed of the runs.
    #[arg(long, default_value_t = 1)]
    pub(crate) seed: u64,
    /// With --time-to-alarm: sea state (default: the configuration's).
    #[arg(long)]
    pub(crate) sea: Option<SeaState>,
    /// With --time-to-alarm: scheduler intervals studied [s].
    #[arg(long, value_delimiter = ',', default_values_t = vec![1800.0, 3600.0, 7200.0])]
    pub(crate) intervals: Vec<f64>,
    /// With --time-to-alarm: ship hours after the onset within which an alarm counts.
    #[arg(long, default_value_t = 24.0)]
    pub(crate) cap_h: f64,
    /// With --time-to-alarm: worker threads (default: every core).
    #[arg(long)]
    pub(crate) threads: Option<usize>,
    /// With --time-to-alarm: also write the tables to DIR/time-to-alarm-<sea>-seed<seed>.md
    /// under the command, the commit and the seed (docs/results/).
    #[arg(long, value_name = "DIR")]
    pub(crate) results: Option<PathBuf>,
    /// With --time-to-alarm --results: add the same file of an earlier run in DIR below the
    /// tables (the before-and-after pair).
    #[arg(long, value_name = "DIR")]
    pub(crate) compare: Option<PathBuf>,
    /// With --time-to-alarm: switch these decision mechanisms off (`a+b`: both; the names
    /// of `eval --fdi --ablate`); the file is named `...-<names>-off`.
    #[arg(long, value_name = "MECHANISMS")]
    pub(crate) ablate: Option<String>,
    /// With --time-to-alarm: on the one member of the family of real ships (`eval --fdi
    /// --family`) whose name contains this, its structure and autopilot on the configured
    /// ship; the file is named `...-<member>`.
    #[arg(long, value_name = "TEXT")]
    pub(crate) member: Option<String>,
}

/// The simulated ship of one run.
#[derive(Debug, Args)]
pub(crate) struct ShipArgs {
    /// True speed through water [m/s] (default: the ship's nominal speed).
    #[arg(long)]
    pub(crate) speed_mps: Option<f64>,
    /// True displacement [t] (default: the ship's nominal displacement).
    #[arg(long)]
    pub(crate) displacement_t: Option<f64>,
    /// Seed of every random draw (sensor noise, sea).
    #[arg(long, default_value_t = 1)]
    pub(crate) seed: u64,
    /// A fault KIND:VALUE@ONSET_S, e.g. displacement_pct:+10@300 (repeatable). Kinds:
    /// displacement_pct, speed_log_bias_mps, speed_log_scale, servo_rate_deg_s,
    /// rudder_effectiveness, heading_drift_deg_per_min.
    #[arg(long = "fault", value_name = "KIND:VALUE@ONSET_S")]
    pub(crate) faults: Vec<String>,
    /// Sea state: calm, moderate or rough (default: the configuration's, moderate).
    #[arg(long)]
    pub(crate) sea: Option<SeaState>,
}

#[derive(Debug, Args)]
pub(crate) struct SimulateArgs {
    #[command(flatten)]
    pub(crate) ship: ShipArgs,
    /// Simulated duration [s].
    #[arg(long, default_value_t = 3600.0)]
    pub(crate) duration_s: f64,
    /// Vessel name in the keys.
    #[arg(long, default_value = "self")]
    pub(crate) vessel: String,
    /// Output file (JSON lines); `-` for standard output.
    #[arg(long)]
    pub(crate) out: PathBuf,
}

#[derive(Debug, Args)]
pub(crate) struct ProbeArgs {
    #[command(flatten)]
    pub(crate) ship: ShipArgs,
    /// Probe this vessel's class: its `[vessel.<name>]` table over the file's top level.
    #[arg(long, value_name = "NAME")]
    pub(crate) vessel: Option<String>,
    /// Directory of the estimator's model files (default: `estimator.models-dir`, else the
    /// models embedded in the binary).
    #[arg(long, value_name = "DIR")]
    pub(crate) models: Option<PathBuf>,
    /// Test method.
    #[arg(long, default_value = "clfrt")]
    pub(crate) method: Method,
    /// Print the report as JSON (the `fdi/report` payload).
    #[arg(long)]
    pub(crate) json: bool,
}
