//! Offline tools: the estimator's training database and trainers ([`training`]), the
//! evaluation suites ([`eval`]), the demo ([`demo`]), the daemon benchmark ([`bench`]) and
//! the SVG pictures of `helmwatch plot` ([`plot`]), the live fleet table of `helmwatch fleet`
//! ([`fleet`]), and the time to alarm and rudder travel per scheduler interval of `helmwatch
//! bench --time-to-alarm` ([`time_to_alarm`]); the error of the demo and the benchmark
//! ([`loopback`]).
//! Nothing here runs in the daemon.

pub mod bench;
pub mod demo;
pub mod eval;
pub mod fleet;
pub mod loopback;
pub mod plot;
pub mod results;
pub mod time_to_alarm;
pub mod training;
