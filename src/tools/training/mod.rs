//! The estimator's training: the database of simulated tests ([`database`]), the training
//! of the network ([`train`]) with its trainers (Levenberg-Marquardt, [`lm`]; Fletcher-Reeves,
//! [`cg`], and its [`line_search`]), the model build ([`build`]) and the calibration the
//! models carry ([`calibrate`], [`speed_slope`]).

pub mod build;
pub mod calibrate;
pub mod cg;
pub mod database;
pub mod line_search;
pub mod lm;
pub mod speed_slope;
pub mod train;
