//! The estimator's training: the database of simulated tests ([`database`]), the training
//! of the network ([`train`]) with its trainers (Levenberg-Marquardt, [`lm`]; Fletcher-Reeves,
//! [`cg`], and its [`line_search`]) and the model build ([`build`]).

pub mod build;
pub mod calibrate;
pub mod cg;
pub mod database;
pub mod line_search;
pub mod lm;
pub mod train;
