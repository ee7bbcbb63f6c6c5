//! The `helmwatch` command line: thin drivers around the library.
//!
//! clap parses the whole command line first ([`args`]); logging starts next, with a default
//! filter chosen by the subcommand, before the configuration is loaded, so configuration
//! errors are logged. Exit codes follow sysexits: 0 success, else the class of the
//! [`failure::Failure`] a subcommand returns (64 usage, 65 bad input data, 69 Zenoh session
//! unavailable, 70 internal error, 71 OS error, 73 the state directory cannot be created, 74
//! I/O error, 78 configuration error), mapped in that one module.
//!
//! | file | subcommands |
//! |---|---|
//! | [`args`] | the schema of every subcommand |
//! | [`offline`] | `simulate`, `probe`, `replay`, `check-config`, `eval --fdi`, `plot` |
//! | [`service`] | `run`, `ship`, `demo`, `bench`, `bridge nmea` |
//! | [`estimator`] | `train`, `eval` |
//! | [`client`] | `status`, `trigger`, `history`, `commission`, `fleet`: clients over Zenoh |
//! | [`print`] | reports on a terminal |
//! | [`logging`] | the journal under systemd, standard error otherwise |
//! | [`failure`] | why a subcommand failed, and its exit code |

mod args;
mod client;
pub mod estimator;
mod failure;
mod logging;
mod offline;
mod print;
mod service;

use crate::cli::estimator::{EvalOptions, TrainOptions};
use crate::config::Config;
use args::{Cli, Command, EvalArgs, TrainArgs};
use clap::Parser;
use failure::Failure;
use helmwatch_core::config::ConfigError;

/// Runs the command line; returns the process exit code.
pub fn main() -> i32 {
    let cli = match Cli::try_parse() {
        Ok(c) => c,
        Err(e) => {
            let _ = e.print();
            return match e.use_stderr() {
                true => Failure::usage(e).exit_code(),
                false => 0,
            };
        }
    };
    init_logging(&cli.command);
    let cfg = match load_config(cli.config.as_deref()) {
        Ok(c) => c,
        Err(e) => {
            let failure = Failure::from(e);
            tracing::error!("{failure}");
            eprintln!("helmwatch: {failure}");
            return failure.exit_code();
        }
    };
    let result = match cli.command {
        Command::Simulate(a) => offline::simulate(&cfg, a),
        Command::Probe(a) => match vessel_config(&cfg, a.vessel.as_deref()) {
            Ok(c) => offline::probe(&c, a),
            Err(e) => Err(e),
        },
        Command::CheckConfig => offline::check_config(&cfg),
        Command::Replay(a) => offline::replay(&cfg, a),
        Command::Eval(a) if a.fdi => offline::eval_fdi(&cfg, &a),
        Command::Eval(a) if a.budget => offline::eval_budget(&a),
        Command::Eval(a) if a.crb => offline::eval_crb(&cfg, &a),
        Command::Eval(a) if a.passive => offline::eval_passive(&cfg, &a),
        Command::Run(a) => service::run_daemon(&cfg, a),
        Command::Ship(a) => service::ship(&cfg, a),
        Command::Demo(a) => service::demo(&cfg, a),
        Command::Bench(a) => service::bench(&cfg, cli.config.as_deref(), a),
        Command::Status(a) => client::status(&cfg, a),
        Command::Trigger(a) => client::trigger(&cfg, a),
        Command::History(a) => client::history(&cfg, a),
        Command::Commission(a) => client::commission(&cfg, a),
        Command::Plot(a) => offline::plot(&cfg, a),
        Command::Fleet(a) => client::fleet(a),
        Command::Bridge(args::BridgeCommand::Nmea(a)) => service::bridge_nmea(&cfg, a),
        Command::Train(a) => match vessel_config(&cfg, a.vessel.as_deref()) {
            Ok(c) => estimator::train(&c, &a.into()),
            Err(e) => Err(e),
        },
        Command::Eval(mut a) => {
            a.models = Some(a.models_dir(&cfg));
            estimator::eval(&cfg, &a.into())
        }
    };
    match result {
        Ok(()) => 0,
        Err(e) => {
            eprintln!("helmwatch: {e}");
            e.exit_code()
        }
    }
}

/// The effective configuration of `vessel` (`--vessel`): its `[vessel.<name>]` table over
/// the file's top level; the file itself without one.
fn vessel_config(cfg: &Config, vessel: Option<&str>) -> Result<Config, Failure> {
    let Some(v) = vessel else {
        return Ok(cfg.clone());
    };
    helmwatch_core::config::check_vessel_name("--vessel", v).map_err(Failure::usage)?;
    Ok(cfg.for_vessel(v)?)
}

/// Logging to the journal under systemd, else to standard error ([`logging`]); `RUST_LOG`
/// overrides the default filter of `command`.
fn init_logging(command: &Command) {
    // The demo prints to standard output; its default log level keeps standard error quiet.
    // `train`, `eval` and `bench --time-to-alarm` run thousands of tests: the core's per-test
    // lines would drown their tables.
    let default = match command {
        Command::Demo(_)
        | Command::Status(_)
        | Command::Trigger(_)
        | Command::History(_)
        | Command::Fleet(_) => "error",
        Command::Train(_) | Command::Eval(_) => "warn,helmwatch_core::monitor=error",
        Command::Bench(b) if b.time_to_alarm => "warn,helmwatch_core::monitor=error",
        _ => "info,zenoh=warn",
    };
    let filter = tracing_subscriber::EnvFilter::try_from_default_env()
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new(default));
    logging::init(filter);
}

fn load_config(path: Option<&std::path::Path>) -> Result<Config, ConfigError> {
    match path {
        Some(p) => Config::from_file(p),
        None => {
            let cfg = Config::default();
            cfg.check()?;
            Ok(cfg)
        }
    }
}

impl From<TrainArgs> for TrainOptions {
    fn from(a: TrainArgs) -> Self {
        Self {
            seed: a.seed,
            out: a.out,
            points: a.points,
            restarts: a.restarts,
            threads: a.threads,
            family: a.family,
            calibrate: a.calibrate,
        }
    }
}

impl From<EvalArgs> for EvalOptions {
    fn from(a: EvalArgs) -> Self {
        Self {
            seed: a.seed,
            models: a.models.unwrap_or_else(|| "models".into()),
            points: a.points,
            drift: a.drift,
            lengths: !a.no_lengths,
            family: a.family,
            threads: a.threads,
        }
    }
}
