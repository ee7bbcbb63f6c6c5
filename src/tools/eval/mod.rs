//! Evaluation suites: the estimator's accuracy on a held-out database ([`estimator`]) and the
//! fault-decision scenario suite ([`fdi`], `helmwatch eval --fdi`).

pub mod estimator;
pub mod fdi;
