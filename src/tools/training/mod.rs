//! The estimator's training: the database of simulated tests ([`database`]), the trainers
//! ([`train`]: Levenberg-Marquardt and Fletcher-Reeves) and the model build ([`build`]).

pub mod build;
pub mod calibrate;
pub mod database;
pub mod train;
