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
pub use relay::{analyse_limit_cycle, limit_cycle_describing_function, LimitCycle};
pub use spectrum::{band_rms, detrend_linear, detrend_linear_keep_bins, naive_dft, Spectrum};
pub use tones::{analyse_tones, ToneAnalyser, ToneEstimate};

/// Half-width of the line fitted for a rate [samples] ([`abs_slopes`]): 2.1 s at 10 Hz.
pub const RATE_HALF_WIDTH: usize = 10;

/// `|slope|` of the least-squares line over `2 RATE_HALF_WIDTH + 1` samples of `x` (step
/// `dt`), centred on each sample where the window fits: `out[j]` is centred on sample
/// `j + RATE_HALF_WIDTH` (cleared first; empty for a record shorter than the window). A ramp
/// of slope `r` gives `r` exactly; white noise of sd `s` gives a slope of sd
/// `s / (dt sqrt(sum_i 2 i^2))`, 0.04 deg/s for 0.1 deg at 10 Hz.
pub fn abs_slopes(x: &[f64], dt: f64, out: &mut Vec<f64>) {
    let h = RATE_HALF_WIDTH;
    out.clear();
    if x.len() < 2 * h + 1 {
        return;
    }
    let sii = (1..=h).map(|i| 2.0 * (i * i) as f64).sum::<f64>() * dt;
    out.extend(x.windows(2 * h + 1).map(|w| {
        let num: f64 = w
            .iter()
            .enumerate()
            .map(|(i, v)| (i as f64 - h as f64) * v)
            .sum();
        (num / sii).abs()
    }));
}

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
