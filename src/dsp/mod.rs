//! Signal processing for the tests (owned by the dsp work; see docs/architecture.md).
