//! Evaluation suites: the estimator's accuracy on a held-out database ([`estimator`]) and the
//! fault-decision scenario suite ([`fdi`], `helmwatch eval --fdi`) and the decision on its own
//! model against the budget ([`budget`], `helmwatch eval --budget`).

pub mod budget;
pub mod crb;
pub mod estimator;
pub mod fdi;
pub mod passive;
