//! The simulated ship (owned by the sim work; see docs/architecture.md).
