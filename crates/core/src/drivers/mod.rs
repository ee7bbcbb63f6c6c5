//! Drivers without I/O of their own: the monitor core in virtual time beside the simulated
//! ship ([`probe`], lockstep), and over a recording ([`replay`]).

pub mod probe;
pub mod replay;
