//! Detrending and the discrete Fourier transform of real records.
//!
//! # Convention
//!
//! RustFFT does not normalise. For a real record `x[0..N]`,
//!
//! ```text
//! X[k] = sum_{n=0}^{N-1} x[n] e^{-2 pi i k n / N},      k = 0 .. N-1
//! ```
//!
//! so a tone `A cos(2 pi k n / N + phi)` on bin `k` (0 < k < N/2) gives `X[k] = (N A / 2)
//! e^{i phi}`, and `A sin(2 pi k n / N + phi)` gives `(N A / 2) e^{i (phi - pi / 2)}`. The
//! record's sample spacing does not enter: bin `k` is the frequency `2 pi k / (N dt)` rad/s.
//! Units of `X` are those of `x` (e.g. rad) times samples.
//!
//! # Detrending
//!
//! [`detrend_linear`] removes the least-squares line `c0 + c1 tau[n]`, `tau[n] = n - (N-1)/2`:
//! `c0 = mean(x)`, `c1 = sum tau x / sum tau^2`, `sum tau^2 = N (N^2 - 1) / 12`.
//!
//! A plain line fit is biased by any tone in the record: a sine with whole periods in the
//! record still correlates with a ramp (`sum tau sin(2 pi k n / N) = -(N/2) cot(pi k / N)`),
//! so the removed line takes a piece of the tone with it and changes `X[k]` by up to ~2 % at
//! the lowest CLFRT tone. [`detrend_linear_keep_bins`] fits the line jointly with a cosine
//! and a sine on each given bin and removes only the line: the tones are left exactly
//! untouched and a ramp is still removed exactly. Because the bin sinusoids are orthogonal
//! to each other and to the constant, the joint fit reduces (Frisch-Waugh) to a regression
//! on the ramp made orthogonal to the bins,
//!
//! ```text
//! tau~ = tau + sum_k (cos_k + cot(pi k / N) sin_k)
//! c1   = <tau~, x> / <tau~, tau~>,   <tau~, tau~> = N (N^2 - 1) / 12 - sum_k N / (2 sin^2(pi k / N))
//! ```
//!
//! with `cos_k[n] = cos(2 pi k n / N)`, `sin_k[n] = sin(2 pi k n / N)`.

use super::{check_finite, DspError};
use rustfft::num_complex::Complex64;
use rustfft::{Fft, FftPlanner};
use std::f64::consts::PI;
use std::sync::Arc;

/// Removes the least-squares straight line from `x` in place (sample index as abscissa).
///
/// A record of one sample becomes zero; an empty record is left alone. Non-finite input
/// gives non-finite output (use [`detrend_linear_keep_bins`] for a checked version).
pub fn detrend_linear(x: &mut [f64]) {
    let n = x.len();
    if n == 0 {
        return;
    }
    let nf = n as f64;
    let centre = (nf - 1.0) / 2.0;
    let mean = x.iter().sum::<f64>() / nf;
    let stt = nf * (nf * nf - 1.0) / 12.0;
    let slope = if stt > 0.0 {
        x.iter()
            .enumerate()
            .map(|(i, v)| (i as f64 - centre) * v)
            .sum::<f64>()
            / stt
    } else {
        0.0
    };
    for (i, v) in x.iter_mut().enumerate() {
        *v -= mean + slope * (i as f64 - centre);
    }
}

/// Removes from `x` the straight line fitted jointly with a sinusoid on each DFT bin of
/// `bins`; the sinusoids themselves stay in `x`. Returns `(offset, slope per sample)` of the
/// removed line `offset + slope (n - (N-1)/2)`.
///
/// With `bins` empty this is [`detrend_linear`]. Each bin must satisfy `0 < k < N/2`, bins must
/// be distinct, and `x` must be finite and have at least 3 samples.
pub fn detrend_linear_keep_bins(x: &mut [f64], bins: &[usize]) -> Result<(f64, f64), DspError> {
    let n = x.len();
    if n < 3 {
        return Err(DspError::TooShort {
            what: "x",
            got: n,
            need: 3,
        });
    }
    check_finite("x", x)?;
    for (i, &k) in bins.iter().enumerate() {
        // 0 < k < N/2, written without overflow for any k.
        if k == 0 || k > (n - 1) / 2 {
            return Err(DspError::InvalidParameter {
                name: "bins",
                value: k as f64,
                reason: "each bin must satisfy 0 < k < N/2",
            });
        }
        if bins[..i].contains(&k) {
            return Err(DspError::InvalidParameter {
                name: "bins",
                value: k as f64,
                reason: "bins must be distinct",
            });
        }
    }
    let nf = n as f64;
    let centre = (nf - 1.0) / 2.0;
    let mean = x.iter().sum::<f64>() / nf;
    let mut num = x
        .iter()
        .enumerate()
        .map(|(i, v)| (i as f64 - centre) * v)
        .sum::<f64>();
    let mut den = nf * (nf * nf - 1.0) / 12.0;
    for &k in bins {
        let half = PI * k as f64 / nf;
        let cot = half.cos() / half.sin();
        let (c, s) = bin_projection(x, k);
        num += c + cot * s;
        den -= nf / (2.0 * half.sin() * half.sin());
    }
    // The ramp must keep a part orthogonal to the sinusoids, or the slope is not identifiable.
    if den <= 1e-9 * nf * (nf * nf - 1.0) / 12.0 {
        return Err(DspError::Degenerate(
            "ramp not separable from the kept bins (record too short)",
        ));
    }
    let slope = num / den;
    for (i, v) in x.iter_mut().enumerate() {
        *v -= mean + slope * (i as f64 - centre);
    }
    Ok((mean, slope))
}

/// `(sum x[n] cos(2 pi k n / N), sum x[n] sin(2 pi k n / N))` with exact angle reduction.
fn bin_projection(x: &[f64], k: usize) -> (f64, f64) {
    let n = x.len();
    let step = 2.0 * PI / n as f64;
    let k = k % n.max(1);
    let mut m = 0usize; // (k * i) mod n
    let mut c = 0.0;
    let mut s = 0.0;
    for &v in x {
        let (sn, cs) = (step * m as f64).sin_cos();
        c += v * cs;
        s += v * sn;
        m += k;
        if m >= n {
            m -= n;
        }
    }
    (c, s)
}

/// Bin `k` of the DFT of `x`, computed term by term: the test oracle for [`Spectrum`].
///
/// `X[k] = sum_n x[n] e^{-2 pi i k n / N}`; the angle `k n mod N` is reduced exactly in
/// integers, so large `k n` lose no precision. An empty record gives 0.
pub fn naive_dft(x: &[f64], k: usize) -> Complex64 {
    let (c, s) = bin_projection(x, k);
    Complex64::new(c, -s)
}

/// A reusable DFT of real records (RustFFT, complex transform of the real input).
///
/// Holds the planner, the current plan and the buffers: repeated calls with the same length
/// allocate nothing. The output follows the convention of the module documentation (not
/// normalised).
pub struct Spectrum {
    /// Caches plans across lengths.
    planner: FftPlanner<f64>,
    /// Plan for the current length, if any.
    fft: Option<Arc<dyn Fft<f64>>>,
    /// The transform of the last record (length N).
    buf: Vec<Complex64>,
    /// RustFFT scratch space for the current plan.
    scratch: Vec<Complex64>,
}

impl std::fmt::Debug for Spectrum {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Spectrum")
            .field("len", &self.buf.len())
            .finish_non_exhaustive()
    }
}

/// A clone keeps the current plan and buffers; the planner's cache of other lengths starts
/// empty (a planner cannot be cloned; it plans the same transform again when asked).
impl Clone for Spectrum {
    fn clone(&self) -> Self {
        Self {
            planner: FftPlanner::new(),
            fft: self.fft.clone(),
            buf: self.buf.clone(),
            scratch: self.scratch.clone(),
        }
    }
}

impl Default for Spectrum {
    fn default() -> Self {
        Self::new()
    }
}

impl Spectrum {
    /// An empty analyser; the first [`Spectrum::compute`] plans for its length.
    pub fn new() -> Self {
        Self {
            planner: FftPlanner::new(),
            fft: None,
            buf: Vec::new(),
            scratch: Vec::new(),
        }
    }

    /// Computes the DFT of the real record `x` (all N bins) and returns it.
    ///
    /// Errors on an empty or non-finite record. Re-plans only when the length changes.
    pub fn compute(&mut self, x: &[f64]) -> Result<&[Complex64], DspError> {
        if x.is_empty() {
            return Err(DspError::TooShort {
                what: "x",
                got: 0,
                need: 1,
            });
        }
        check_finite("x", x)?;
        let fft = match &self.fft {
            Some(f) if f.len() == x.len() => Arc::clone(f),
            _ => {
                let f = self.planner.plan_fft_forward(x.len());
                self.scratch
                    .resize(f.get_inplace_scratch_len(), Complex64::new(0.0, 0.0));
                self.fft = Some(Arc::clone(&f));
                f
            }
        };
        self.buf.clear();
        self.buf.extend(x.iter().map(|&v| Complex64::new(v, 0.0)));
        fft.process_with_scratch(&mut self.buf, &mut self.scratch);
        Ok(&self.buf)
    }

    /// The transform of the last record (empty before the first [`Spectrum::compute`]).
    pub fn bins(&self) -> &[Complex64] {
        &self.buf
    }

    /// Length of the last record.
    pub fn len(&self) -> usize {
        self.buf.len()
    }

    /// True before the first [`Spectrum::compute`].
    pub fn is_empty(&self) -> bool {
        self.buf.is_empty()
    }
}

/// Root-mean-square of the part of `x` (step `dt` s) between `lo` and `hi` rad/s: the record
/// is detrended ([`detrend_linear`], into `scratch`), Hann-windowed and transformed, and
///
/// ```text
/// rms^2 = 2 sum_{k: lo <= w_k <= hi} |X[k]|^2 / (N sum_n w[n]^2),   w_k = 2 pi k / (N dt)
/// ```
///
/// which is unbiased for a stationary process (Parseval with the window's power), and for a
/// sinusoid of amplitude `A` well inside the band gives `A / sqrt 2` (the Hann main lobe,
/// two bins either side, is summed whole when the band holds it). The window's side lobes
/// fall as `1 / k^3`: a slow component (the limit cycle, a ramp left after detrending) leaks
/// `~1e-5` of its amplitude into a band 20 bins away.
///
/// Used for the wave yaw on the heading (the sea state's measure): first-order wave motion
/// sits well above a ship's steering band, so the band rms is wave yaw plus the sensor noise
/// falling in the band, whatever the test excites below it and whatever the heading drifts.
pub fn band_rms(
    x: &[f64],
    dt: f64,
    (lo, hi): (f64, f64),
    spectrum: &mut Spectrum,
    scratch: &mut Vec<f64>,
) -> Result<f64, DspError> {
    const MIN_SAMPLES: usize = 16;
    if x.len() < MIN_SAMPLES {
        return Err(DspError::TooShort {
            what: "x",
            got: x.len(),
            need: MIN_SAMPLES,
        });
    }
    if !(dt > 0.0 && dt.is_finite()) {
        return Err(DspError::InvalidParameter {
            name: "dt",
            value: dt,
            reason: "must be positive and finite",
        });
    }
    if !(lo >= 0.0 && hi > lo && hi.is_finite()) {
        return Err(DspError::InvalidParameter {
            name: "band",
            value: hi,
            reason: "need 0 <= lo < hi, finite",
        });
    }
    check_finite("x", x)?;
    let n = x.len();
    scratch.clear();
    scratch.extend_from_slice(x);
    detrend_linear(scratch);
    let nf = n as f64;
    let mut w2 = 0.0;
    for (i, v) in scratch.iter_mut().enumerate() {
        let w = 0.5 * (1.0 - (2.0 * PI * i as f64 / nf).cos());
        *v *= w;
        w2 += w * w;
    }
    let bins = spectrum.compute(scratch)?;
    let dw = 2.0 * PI / (nf * dt);
    let k_lo = (lo / dw).ceil().max(1.0) as usize;
    // Bins strictly below Nyquist (N/2 counted once would need a factor 1, not 2).
    let k_hi = ((hi / dw).floor() as usize).min((n - 1) / 2);
    let power: f64 = (k_lo..=k_hi).map(|k| bins[k].norm_sqr()).sum();
    Ok((2.0 * power / (nf * w2)).sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;
    use proptest::prelude::*;

    fn tone(n: usize, k: usize, amp: f64, phase: f64) -> Vec<f64> {
        (0..n)
            .map(|i| amp * (2.0 * PI * k as f64 * i as f64 / n as f64 + phase).cos())
            .collect()
    }

    #[test]
    fn tone_lands_in_its_bin_with_amplitude_and_phase() {
        let (n, k, amp, phase) = (1000, 37, 0.7, -1.1);
        let x = tone(n, k, amp, phase);
        let mut sp = Spectrum::new();
        let xs = sp.compute(&x).unwrap();
        let expected = Complex64::from_polar(n as f64 * amp / 2.0, phase);
        assert_relative_eq!(xs[k].re, expected.re, max_relative = 1e-12);
        assert_relative_eq!(xs[k].im, expected.im, max_relative = 1e-12);
        // Mirror bin holds the conjugate; every other bin is empty.
        assert_relative_eq!(xs[n - k].im, -expected.im, max_relative = 1e-12);
        for (j, v) in xs.iter().enumerate() {
            if j != k && j != n - k {
                assert!(v.norm() < 1e-9, "bin {j}: {v}");
            }
        }
        // A sine on the same bin lags the cosine by 90 degrees.
        let s: Vec<f64> = (0..n)
            .map(|i| amp * (2.0 * PI * k as f64 * i as f64 / n as f64).sin())
            .collect();
        let xs = sp.compute(&s).unwrap();
        assert_relative_eq!(xs[k].arg(), -PI / 2.0, epsilon = 1e-12);
        assert_relative_eq!(xs[k].norm(), n as f64 * amp / 2.0, max_relative = 1e-12);
    }

    /// A tone in the band reads A / sqrt 2 beside a limit cycle 20 times larger and a drift
    /// ramp; a tone outside reads nothing; white noise reads its share of the band.
    #[test]
    fn band_rms_against_independent_answers() {
        let (dt, n) = (0.1, 11800);
        let band = (0.4, 2.0);
        let (mut sp, mut scratch) = (Spectrum::new(), Vec::new());
        let t = |i: usize| i as f64 * dt;
        // 0.8137 rad/s: not on a bin. Limit cycle 2 deg at 0.04 rad/s, drift 1 deg/min.
        let (a, big) = (0.1f64.to_radians(), 2.0f64.to_radians());
        let drift = 1f64.to_radians() / 60.0;
        let x: Vec<f64> = (0..n)
            .map(|i| a * (0.8137 * t(i) + 0.3).sin() + big * (0.04 * t(i)).sin() + drift * t(i))
            .collect();
        let r = band_rms(&x, dt, band, &mut sp, &mut scratch).unwrap();
        assert!(
            (r / (a / 2f64.sqrt()) - 1.0).abs() < 0.01,
            "{r} vs {}",
            a / 2f64.sqrt()
        );
        // Only the out-of-band parts: the leakage is tiny.
        let y: Vec<f64> = (0..n)
            .map(|i| big * (0.04 * t(i)).sin() + drift * t(i) + a * (3.0 * t(i)).sin())
            .collect();
        let r = band_rms(&y, dt, band, &mut sp, &mut scratch).unwrap();
        assert!(r < 1e-3 * a, "{r}");
        // White noise of sd s: the band holds (hi - lo) / (pi / dt) of its power.
        use rand::SeedableRng;
        use rand_distr::{Distribution, StandardNormal};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let s = 0.05f64.to_radians();
        let z: Vec<f64> = (0..n)
            .map(|_| {
                let g: f64 = StandardNormal.sample(&mut rng);
                s * g
            })
            .collect();
        let expect = s * ((band.1 - band.0) / (PI / dt)).sqrt();
        let r = band_rms(&z, dt, band, &mut sp, &mut scratch).unwrap();
        assert!((r / expect - 1.0).abs() < 0.1, "{r} vs {expect}");
        // Bad input.
        assert!(band_rms(&x[..8], dt, band, &mut sp, &mut scratch).is_err());
        assert!(band_rms(&x, 0.0, band, &mut sp, &mut scratch).is_err());
        assert!(band_rms(&x, dt, (2.0, 0.4), &mut sp, &mut scratch).is_err());
        let mut bad = x.clone();
        bad[5] = f64::NAN;
        assert!(band_rms(&bad, dt, band, &mut sp, &mut scratch).is_err());
    }

    #[test]
    fn naive_dft_known_answers() {
        let x = [1.0, 2.0, 3.0, 4.0];
        // X[0] = 10, X[1] = -2 + 2i, X[2] = -2.
        let x0 = naive_dft(&x, 0);
        let x1 = naive_dft(&x, 1);
        let x2 = naive_dft(&x, 2);
        assert!((x0 - Complex64::new(10.0, 0.0)).norm() < 1e-12);
        assert!((x1 - Complex64::new(-2.0, 2.0)).norm() < 1e-12);
        assert!((x2 - Complex64::new(-2.0, 0.0)).norm() < 1e-12);
        assert_eq!(naive_dft(&[], 3), Complex64::new(0.0, 0.0));
    }

    #[test]
    fn spectrum_rejects_bad_input_and_replans() {
        let mut sp = Spectrum::new();
        assert!(sp.is_empty());
        assert!(matches!(sp.compute(&[]), Err(DspError::TooShort { .. })));
        assert_eq!(sp.compute(&[1.0, f64::NAN]), Err(DspError::NonFinite("x")));
        let a = sp.compute(&[1.0, 0.0, 0.0]).unwrap().to_vec();
        assert_eq!(a.len(), 3);
        let b = sp.compute(&[0.0, 1.0, 0.0, 0.0, 0.0]).unwrap().to_vec();
        assert_eq!(b.len(), 5);
        assert_relative_eq!(b[1].arg(), -2.0 * PI / 5.0, epsilon = 1e-12);
        assert_eq!(sp.len(), 5);
    }

    #[test]
    fn detrend_removes_a_line_exactly() {
        let mut x: Vec<f64> = (0..101).map(|i| 3.0 - 0.25 * i as f64).collect();
        detrend_linear(&mut x);
        assert!(x.iter().all(|v| v.abs() < 1e-12));
        let mut one = [5.0];
        detrend_linear(&mut one);
        assert_eq!(one, [0.0]);
        let mut empty: [f64; 0] = [];
        detrend_linear(&mut empty);
    }

    #[test]
    fn detrend_residual_is_orthogonal_to_constant_and_ramp() {
        let mut x: Vec<f64> = (0..50).map(|i| ((i * i) % 17) as f64).collect();
        detrend_linear(&mut x);
        let s0: f64 = x.iter().sum();
        let s1: f64 = x.iter().enumerate().map(|(i, v)| i as f64 * v).sum();
        assert!(s0.abs() < 1e-10 && s1.abs() < 1e-9, "{s0} {s1}");
    }

    #[test]
    fn plain_detrend_biases_a_low_tone_but_keep_bins_does_not() {
        let (n, k) = (6000, 3);
        let clean = tone(n, k, 1.0, 0.4);
        let ramp_plus_tone: Vec<f64> = clean
            .iter()
            .enumerate()
            .map(|(i, v)| v + 0.5 + 2e-4 * i as f64)
            .collect();
        // Plain detrending leaves a visible error at the tone bin (independent check of the
        // claim in the module doc: ~ 24 / (4 pi^2 k^2) of the amplitude, here > 1 %).
        let mut plain = ramp_plus_tone.clone();
        detrend_linear(&mut plain);
        let err_plain = (naive_dft(&plain, k) - naive_dft(&clean, k)).norm() / (n as f64 / 2.0);
        assert!(err_plain > 0.01 && err_plain < 0.1, "{err_plain}");
        // Joint fit: the ramp goes, the tone stays, to rounding.
        let mut kept = ramp_plus_tone;
        let (c0, c1) = detrend_linear_keep_bins(&mut kept, &[k, 11]).unwrap();
        assert_relative_eq!(c1, 2e-4, max_relative = 1e-9);
        assert_relative_eq!(c0, 0.5 + 2e-4 * (n as f64 - 1.0) / 2.0, max_relative = 1e-9);
        for (a, b) in kept.iter().zip(&clean) {
            assert!((a - b).abs() < 1e-9);
        }
    }

    #[test]
    fn keep_bins_with_no_bins_is_plain_detrend() {
        let x: Vec<f64> = (0..64).map(|i| ((i * 7) % 13) as f64 * 0.1).collect();
        let mut a = x.clone();
        let mut b = x;
        detrend_linear(&mut a);
        detrend_linear_keep_bins(&mut b, &[]).unwrap();
        for (p, q) in a.iter().zip(&b) {
            assert!((p - q).abs() < 1e-12);
        }
    }

    #[test]
    fn keep_bins_rejects_bad_input() {
        let mut x = vec![0.0; 10];
        assert!(detrend_linear_keep_bins(&mut x, &[0]).is_err());
        assert!(detrend_linear_keep_bins(&mut x, &[5]).is_err());
        assert!(detrend_linear_keep_bins(&mut x, &[2, 2]).is_err());
        assert!(detrend_linear_keep_bins(&mut x, &[usize::MAX]).is_err());
        assert!(detrend_linear_keep_bins(&mut x, &[4]).is_ok());
        let mut odd = vec![0.0; 9];
        assert!(detrend_linear_keep_bins(&mut odd, &[4]).is_ok());
        assert!(detrend_linear_keep_bins(&mut odd, &[5]).is_err());
        assert!(detrend_linear_keep_bins(&mut x[..2], &[]).is_err());
        x[3] = f64::INFINITY;
        assert_eq!(
            detrend_linear_keep_bins(&mut x, &[1]),
            Err(DspError::NonFinite("x"))
        );
        // Four bins in a record of nine span everything but the constant: the ramp is not
        // separable. (In a record of ten the Nyquist bin is left and the ramp is separable.)
        let mut y = vec![1.0; 9];
        assert!(detrend_linear_keep_bins(&mut y, &[1, 2, 3, 4]).is_err());
        let mut z = vec![1.0; 10];
        assert!(detrend_linear_keep_bins(&mut z, &[1, 2, 3, 4]).is_ok());
    }

    proptest! {
        #[test]
        fn fft_matches_naive_dft(x in proptest::collection::vec(-1.0e3..1.0e3f64, 1..300)) {
            let mut sp = Spectrum::new();
            let fast = sp.compute(&x).unwrap();
            let norm: f64 = x.iter().map(|v| v * v).sum::<f64>().sqrt() * (x.len() as f64).sqrt();
            let mut err2 = 0.0;
            let mut ref2 = 0.0;
            for (k, f) in fast.iter().enumerate() {
                let slow = naive_dft(&x, k);
                err2 += (f - slow).norm_sqr();
                ref2 += slow.norm_sqr();
                // Per bin, relative to the bin or (for near-empty bins) to the record's scale.
                prop_assert!((f - slow).norm() <= 1e-9 * slow.norm().max(1e-3 * norm) + 1e-12,
                    "bin {} fast {} slow {}", k, f, slow);
            }
            prop_assert!(err2.sqrt() <= 1e-9 * ref2.sqrt() + 1e-12);
        }
    }
}
