//! Why a tool that runs the daemon over Zenoh on loopback failed: the demo and the benchmark.

use crate::shells::daemon::DaemonError;
use crate::shells::net::NetError;
use crate::shells::shipnode::ShipNodeError;

/// Why the demo or a benchmark failed.
#[derive(Debug, thiserror::Error)]
pub enum LoopbackError {
    /// Setting up Zenoh.
    #[error(transparent)]
    Net(#[from] NetError),
    /// The daemon.
    #[error(transparent)]
    Daemon(#[from] DaemonError),
    /// The ship.
    #[error(transparent)]
    Ship(#[from] ShipNodeError),
    /// Anything else: a session, a port, the output.
    #[error("{0}")]
    Other(String),
}
