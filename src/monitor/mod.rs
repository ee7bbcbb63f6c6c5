//! The monitor core (see docs/architecture.md).
