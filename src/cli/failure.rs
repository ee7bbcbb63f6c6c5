//! Why a subcommand failed, and the one mapping from that to the process's exit code.
//!
//! Every subcommand returns `Result<(), Failure>`. A `Failure` is typed by its sysexits class,
//! and [`Failure::exit_code`] is the only place a class becomes a number. The libraries'
//! errors (thiserror enums) become failures through the `From` impls below, which say, variant
//! by variant, which class each is; a subcommand then uses `?`. Where the class depends on
//! where an error came from, not on its type (a range check of a command-line flag is a usage
//! error, the same check of a file's key a configuration error; a file the command was asked
//! to read or write is an I/O error), the subcommand names the variant.
//!
//! | code | class | |
//! |---|---|---|
//! | 64 | [`Failure::Usage`] | a flag or argument of the command line |
//! | 65 | [`Failure::Data`] | a malformed input file (a recording, a report) |
//! | 69 | [`Failure::Unavailable`] | the Zenoh session, a daemon that does not answer |
//! | 70 | [`Failure::Software`] | an internal error |
//! | 71 | [`Failure::Os`] | the operating system (runtime, sockets, processes) |
//! | 73 | [`Failure::CantCreate`] | the state directory, its database or recordings |
//! | 74 | [`Failure::Io`], [`Failure::Write`] | reading or writing a file named on the command line, the output |
//! | 78 | [`Failure::Config`] | the configuration (file, models, Zenoh settings) |

use crate::shells::bridge::BridgeError;
use crate::shells::daemon::DaemonError;
use crate::shells::net::NetError;
use crate::tools::fleet::FleetError;
use crate::tools::plot::PlotError;
use helmwatch_core::config::ConfigError;
use helmwatch_core::estimator::model::ModelError;
use helmwatch_core::sim::FaultParseError;
use std::path::{Path, PathBuf};

/// Why a subcommand failed, by sysexits class (the module's table).
#[derive(Debug, thiserror::Error)]
pub(crate) enum Failure {
    /// 64: a flag or argument of the command line.
    #[error("{0:#}")]
    Usage(anyhow::Error),
    /// 65: a malformed input file.
    #[error("{0:#}")]
    Data(anyhow::Error),
    /// 69: the Zenoh session, or a daemon that does not answer.
    #[error("{0:#}")]
    Unavailable(anyhow::Error),
    /// 70: an internal error.
    #[error("{0:#}")]
    Software(anyhow::Error),
    /// 71: the operating system.
    #[error("{0:#}")]
    Os(anyhow::Error),
    /// 73: the state directory cannot be created or written.
    #[error("{0:#}")]
    CantCreate(anyhow::Error),
    /// 74: a file named on the command line cannot be read or written.
    #[error("{}: {reason:#}", path.display())]
    Io {
        /// The file (or directory).
        path: PathBuf,
        /// Why.
        reason: anyhow::Error,
    },
    /// 74: writing the command's output (standard output, a recording, a model file: the
    /// error names what).
    #[error("{0:#}")]
    Write(anyhow::Error),
    /// 78: the configuration.
    #[error("{0:#}")]
    Config(anyhow::Error),
}

impl Failure {
    /// The process's exit code for this failure (sysexits.h).
    pub(crate) fn exit_code(&self) -> i32 {
        match self {
            Failure::Usage(_) => 64,
            Failure::Data(_) => 65,
            Failure::Unavailable(_) => 69,
            Failure::Software(_) => 70,
            Failure::Os(_) => 71,
            Failure::CantCreate(_) => 73,
            Failure::Io { .. } | Failure::Write(_) => 74,
            Failure::Config(_) => ConfigError::EXIT_CODE,
        }
    }

    /// A usage failure: `e` came from checking a flag or an argument.
    pub(crate) fn usage(e: impl Into<anyhow::Error>) -> Self {
        Failure::Usage(e.into())
    }

    /// An internal failure.
    pub(crate) fn software(e: impl Into<anyhow::Error>) -> Self {
        Failure::Software(e.into())
    }

    /// A plot of `input` that failed: an input that is not what its kind needs is bad data
    /// (named by its file), a drawing that fails an internal error.
    pub(crate) fn plot(input: &Path, e: PlotError) -> Self {
        match e {
            PlotError::Data(_) => Failure::Data(anyhow::anyhow!("{}: {e}", input.display())),
            PlotError::Draw(_) => Failure::Software(e.into()),
        }
    }

    /// An I/O failure on `path`.
    pub(crate) fn io(path: &Path, e: impl Into<anyhow::Error>) -> Self {
        Failure::Io {
            path: path.to_path_buf(),
            reason: e.into(),
        }
    }
}

/// A configuration error of the file (a flag's is [`Failure::usage`]).
impl From<ConfigError> for Failure {
    fn from(e: ConfigError) -> Self {
        Failure::Config(e.into())
    }
}

/// The Zenoh settings (`[zenoh]`, its JSON5 file) are configuration.
impl From<NetError> for Failure {
    fn from(e: NetError) -> Self {
        Failure::Config(e.into())
    }
}

/// A model file that does not load (the models directory is configuration).
impl From<ModelError> for Failure {
    fn from(e: ModelError) -> Self {
        Failure::Config(e.into())
    }
}

/// A fault of the file's `[ship-peer] faults` (a `--fault` flag's is [`Failure::usage`]).
impl From<FaultParseError> for Failure {
    fn from(e: FaultParseError) -> Self {
        Failure::Config(e.into())
    }
}

impl From<DaemonError> for Failure {
    fn from(e: DaemonError) -> Self {
        match e {
            DaemonError::Config(_) | DaemonError::Estimator(_) => Failure::Config(e.into()),
            DaemonError::Open(_) | DaemonError::Metrics(_) => Failure::Unavailable(e.into()),
            DaemonError::Declare { .. } => Failure::Software(e.into()),
            DaemonError::State(_) | DaemonError::History(_) | DaemonError::Recording(_) => {
                Failure::CantCreate(e.into())
            }
        }
    }
}

impl From<BridgeError> for Failure {
    fn from(e: BridgeError) -> Self {
        match e {
            BridgeError::Zenoh(_) => Failure::Unavailable(e.into()),
            BridgeError::Udp { .. } | BridgeError::Metrics(_) => Failure::Os(e.into()),
        }
    }
}

impl From<FleetError> for Failure {
    fn from(e: FleetError) -> Self {
        match e {
            FleetError::Session(_) | FleetError::Subscribe { .. } => Failure::Unavailable(e.into()),
        }
    }
}
