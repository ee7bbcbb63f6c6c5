//! Offline tools: the estimator's training database and trainers ([`training`]), the
//! evaluation suites ([`eval`]), the demo ([`demo`]) and the daemon benchmark ([`bench`]).
//! Nothing here runs in the daemon.

pub mod bench;
pub mod demo;
pub mod eval;
pub mod training;
