//! Shells: the core meets the world. The Zenoh session settings ([`net`]), the daemon
//! ([`daemon`]) and its state directory ([`state`]), the simulated ship as a Zenoh peer
//! ([`shipnode`]) and the service manager ([`systemd`]).

pub mod daemon;
pub mod net;
pub mod shipnode;
pub mod state;
pub mod systemd;
