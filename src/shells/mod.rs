//! Shells: the core meets the world. The Zenoh session settings ([`net`]), the daemon
//! ([`daemon`]) with its state directory ([`state`]), report history ([`history`]) and MCAP recordings ([`recording`]), the simulated ship as a Zenoh peer
//! ([`shipnode`]), the service manager ([`systemd`]) and the daemon's metrics endpoint
//! ([`metrics`]), and the NMEA bridge ([`bridge`]: a ship's NMEA 0183 / IEC 61162-450 sentences
//! in, the contract's keys out).

pub mod bridge;
pub mod daemon;
pub mod history;
pub mod metrics;
pub mod net;
pub mod recording;
pub mod shipnode;
pub mod state;
pub mod systemd;
