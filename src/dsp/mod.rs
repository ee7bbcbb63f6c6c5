//! Signal processing for the tests. PLACEHOLDER until the dsp branch merges.
#![allow(missing_docs)]
pub mod multisine;
pub mod relay;
pub mod tones;
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum DspError {
    #[error("not implemented")]
    NotImplemented,
}
