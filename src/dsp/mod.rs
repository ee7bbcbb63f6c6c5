//! Signal processing for the two excitation tests (HBT and CLFRT).
//!
//! Everything here is pure computation on slices: no I/O, no clock, no global random
//! generator (the multisine design is seeded). Angles are in radians, times in seconds,
//! frequencies in rad/s unless a name says otherwise (`_bin`, `_hz`).
//!
//! | file | computes |
//! |---|---|
//! | [`spectrum`] | linear detrending, the DFT (RustFFT, unnormalised) and its naive oracle |
//! | [`multisine`] | the CLFRT excitation, eq. (8)-(9) of the paper, with a low crest factor |
//! | [`tones`] | closed-loop frequency response G = S_psi,r / S_delta,r at the tones, with calibrated 90 % intervals |
//! | [`relay`] | HBT limit-cycle features (period, first-harmonic amplitude) and the describing-function prediction |
//!
//! DFT convention throughout (RustFFT's, which does not normalise):
//! `X[k] = sum_{n=0}^{N-1} x[n] e^{-2 pi i k n / N}`. A real tone `A cos(2 pi k n / N + phi)`
//! on bin `k` (0 < k < N/2) gives `X[k] = (N A / 2) e^{i phi}`.
//!
//! Functions never panic on bad input: they return a [`DspError`].

pub mod multisine;
pub mod relay;
pub mod spectrum;
pub mod tones;

pub use multisine::Multisine;
pub use relay::{analyse_limit_cycle, limit_cycle_describing_function, HbtFeatures};
pub use spectrum::{band_rms, detrend_linear, detrend_linear_keep_bins, naive_dft, Spectrum};
pub use tones::{analyse_tones, ToneAnalyser, ToneEstimate};

/// Why a signal-processing function refused its input or could not produce a result.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum DspError {
    /// An input slice is empty or too short for the computation.
    #[error("input `{what}` too short: {got} samples, need at least {need}")]
    TooShort {
        /// Name of the input.
        what: &'static str,
        /// Length given.
        got: usize,
        /// Smallest length accepted.
        need: usize,
    },
    /// Two inputs that must have the same length do not.
    #[error("length mismatch: `{what}` has {got} samples, expected {expected}")]
    LengthMismatch {
        /// Name of the offending input.
        what: &'static str,
        /// Length expected.
        expected: usize,
        /// Length given.
        got: usize,
    },
    /// An input holds NaN or an infinity.
    #[error("non-finite value in `{0}`")]
    NonFinite(&'static str),
    /// A scalar parameter is outside its domain.
    #[error("invalid `{name}` = {value}: {reason}")]
    InvalidParameter {
        /// Name of the parameter.
        name: &'static str,
        /// The value given (lengths and counts are converted to f64).
        value: f64,
        /// What is allowed.
        reason: &'static str,
    },
    /// The data are valid but carry no usable information (e.g. no rudder power at a tone).
    #[error("degenerate data: {0}")]
    Degenerate(&'static str),
    /// An equation has no solution in the searched range.
    #[error("no solution: {0}")]
    NoSolution(&'static str),
}

/// Returns `Err(NonFinite(what))` if any element of `x` is NaN or infinite.
pub(crate) fn check_finite(what: &'static str, x: &[f64]) -> Result<(), DspError> {
    if x.iter().all(|v| v.is_finite()) {
        Ok(())
    } else {
        Err(DspError::NonFinite(what))
    }
}

/// Returns `Err(InvalidParameter)` unless `v` is finite and strictly positive.
pub(crate) fn check_positive(name: &'static str, v: f64) -> Result<(), DspError> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(DspError::InvalidParameter {
            name,
            value: v,
            reason: "must be finite and > 0",
        })
    }
}
