//! Closed-loop frequency response at the excited tones (CLFRT features), with calibrated
//! 90 % intervals.
//!
//! # Inputs
//!
//! Three aligned records, uniformly sampled every `dt_s`, of `N = M W` samples (`M >= 1`
//! whole windows of `W` samples): the heading `psi` (rad, unwrapped, raw), the measured rudder
//! `delta` (rad) and the injected multisine `r` (rad). Tone `i` is harmonic `k_i` of the
//! window, so it sits exactly on bin `b_i = k_i M` of the N-point DFT (convention of
//! [`crate::dsp::spectrum`]: RustFFT, unnormalised), at `omega_i = 2 pi k_i / (W dt)`.
//!
//! # Estimator
//!
//! Heading and rudder are detrended by [`detrend_linear_keep_bins`]: the line is fitted
//! jointly with the tones and only the line is removed, so a heading-sensor drift (a ramp) is
//! removed exactly and the tones are left untouched (a plain line fit would move the lowest
//! tone by up to ~2 %). Then, at each tone bin `b` (with `Psi(b)`, `Delta(b)` corrected for
//! transients as below),
//!
//! ```text
//! G^(b) = S_psi,r(b) / S_delta,r(b) = Psi(b) R*(b) / (Delta(b) R*(b))
//! ```
//!
//! In a closed loop the noise feeds back into the rudder, so a least-squares `Psi / Delta`
//! over noisy bins would be biased towards the inverse controller. The reference is the
//! instrument: the ratio is formed only where `r` has power, and the noise, uncorrelated
//! with `r`, averages out of it.
//!
//! **One long FFT, not per-window averaging.** Because `r` is periodic in the window, its
//! spectrum is the same in every window, and the ratio of the window-averaged cross spectra
//! equals `Psi(b) / Delta(b)` of the long record: both give the same `G^`. The long FFT
//! also resolves the `M - 1` unexcited bins between window harmonics, which gives many more
//! noise bins right next to each tone (resolution `2 pi / (N dt)`), while per-window
//! averaging would leave `M - 1` degrees of freedom for the noise (one, for the default
//! `M = 2`).
//!
//! # Neighbour bins, transient removal, uncertainty
//!
//! Exactly, `G^ - G = V(b) / Delta(b)` with `V = Psi - G Delta`, the part of the heading not
//! explained by the rudder through `G` (disturbance through the ship, sensor noise, the
//! feedback of both, transients, leakage). At unexcited bins the same combination holds
//! nothing else, so neighbouring bins measure it.
//!
//! *Neighbours.* `L = 2 P` bins in `P` pairs `b - d, b + d` symmetric about the tone
//! (d = 1, 2, ...), skipping any pair that touches bin 0 or another tone, stopping at bin 0
//! or Nyquist. Symmetric pairs cancel a linear slope of the noise spectrum, which is steep at
//! the lowest tone (the slow bias has its power at low frequency). When no symmetric pair
//! exists (a tone on bin 1) the `2 P` bins above are used. Default `P = 3`.
//!
//! *Transient removal* (the local polynomial method of Pintelon and Schoukens for periodic
//! excitation, degree 1). A record of a non-periodic process (the heading's slow wander, the
//! start of the record) leaks into every bin as a term that is smooth in frequency and has a
//! fixed phase, common to the tone and its neighbours; it is not noise that averages out. A
//! straight line `c0 + c1 (j - b)` is fitted by least squares to `Psi` and to `Delta` over
//! the neighbours and its value at the tone (weights `w_j`, the mean for symmetric pairs) is
//! subtracted from the tone bin before the ratio:
//!
//! ```text
//! Psi_c = Psi(b) - sum_j w_j Psi(j),   Delta_c = Delta(b) - sum_j w_j Delta(j),
//! G^ = Psi_c R*(b) / (Delta_c R*(b))
//! ```
//!
//! *Noise.* Output-error residuals at the neighbours, minus their own local line,
//!
//! ```text
//! e(j) = Psi(j) - G^ Delta(j),   s^2 = sum_j |e(j) - line(j)|^2 / (L - 2)
//! ```
//!
//! estimate the noise power per bin. To first order the relative error `eps = (G^ - G) / G`
//! is `(V(b) - sum_j w_j V(j)) / Psi_c`, circular with `E|eps|^2 = s^2 (1 + sum w_j^2) /
//! |Psi_c|^2`; its real part is the relative gain error and its imaginary part the phase
//! error (rad), each with half that variance. `s^2` has `2 (L - 2)` real degrees of freedom,
//! so each component over its estimated standard deviation is Student-t with `nu = 2 (L -
//! 2)` (8 by default):
//!
//! ```text
//! gain_ci90_rel = phase_ci90_rad = t_{0.95, nu} s sqrt((1 + sum w_j^2) / 2) / |Psi_c|
//! ```
//!
//! (phase capped at pi). The true gain lies in `gain (1 +- gain_ci90_rel)` and the true
//! phase in `phase_rad +- phase_ci90_rad` with probability ~90 %: the calibration test below
//! measures it in a closed-loop simulation. The transient removal matters most at the 17th
//! harmonic, whose fixed-phase leakage would otherwise bias the coverage of its gain and
//! phase in opposite directions.
//!
//! Signal-to-noise of the heading at the tone: `snr = |Psi_c|^2 / s^2 - 1` (the tone bin
//! holds signal plus noise), `snr_db = 10 log10 snr` clamped to [-120, 300] dB, and
//! `coherence = snr / (1 + snr) = S / (S + noise)`, in [0, 1].
//!
//! # Phase convention
//!
//! `phase_rad` is `arg G^` in (-2 pi, 0]: the principal value, minus 2 pi when positive. The
//! ship `b / (j w (j w + a))` lies between -90 and -180 degrees, so a noisy estimate near -180
//! degrees stays continuous (-181 degrees, not +179).

use super::spectrum::{detrend_linear_keep_bins, Spectrum};
use super::{check_finite, check_positive, DspError};
use rustfft::num_complex::Complex64;
use std::f64::consts::PI;

/// Default number of symmetric neighbour pairs used for the noise estimate.
pub const DEFAULT_NEIGHBOUR_PAIRS: usize = 3;

/// The frequency response at one tone, with its uncertainty: the wire's tone features, so
/// a report carries the analysis's result as it is.
pub type ToneEstimate = crate::wire::features::ToneFeatures;

/// Reusable state for [`analyse_tones`]: FFT plans and buffers (no allocation per call once
/// the record length is fixed, apart from the returned vector).
#[derive(Debug, Clone)]
pub struct ToneAnalyser {
    /// FFT plan cache and its output buffer.
    spectrum: Spectrum,
    /// Detrending scratch (length N).
    work: Vec<f64>,
    /// DFT of the detrended heading.
    psi: Vec<Complex64>,
    /// DFT of the detrended rudder.
    delta: Vec<Complex64>,
    /// DFT of the reference.
    reference: Vec<Complex64>,
    /// Tone bins of the current record (k_i M).
    tone_bins: Vec<usize>,
    /// Neighbour bins of the current tone.
    neighbours: Vec<usize>,
    /// Symmetric neighbour pairs per tone for the noise estimate.
    neighbour_pairs: usize,
    /// Prediction weights of the local fit at the tone bin.
    weights: Vec<f64>,
    /// Residuals at the neighbour bins.
    residuals: Vec<Complex64>,
}

impl Default for ToneAnalyser {
    fn default() -> Self {
        Self::new()
    }
}

impl ToneAnalyser {
    /// An analyser with [`DEFAULT_NEIGHBOUR_PAIRS`] neighbour pairs.
    pub fn new() -> Self {
        Self {
            spectrum: Spectrum::new(),
            work: Vec::new(),
            psi: Vec::new(),
            delta: Vec::new(),
            reference: Vec::new(),
            tone_bins: Vec::new(),
            neighbours: Vec::new(),
            neighbour_pairs: DEFAULT_NEIGHBOUR_PAIRS,
            weights: Vec::new(),
            residuals: Vec::new(),
        }
    }

    /// An analyser using `pairs` (1 to 64) symmetric neighbour pairs per tone.
    pub fn with_neighbour_pairs(pairs: usize) -> Result<Self, DspError> {
        if !(1..=64).contains(&pairs) {
            return Err(DspError::InvalidParameter {
                name: "neighbour_pairs",
                value: pairs as f64,
                reason: "must be in [1, 64]",
            });
        }
        Ok(Self {
            neighbour_pairs: pairs,
            ..Self::new()
        })
    }

    /// Symmetric neighbour pairs per tone used for the noise estimate.
    pub fn neighbour_pairs(&self) -> usize {
        self.neighbour_pairs
    }

    /// Detrends `x` (keeping the tone bins) and stores its DFT in `out`.
    fn transform(&mut self, x: &[f64], detrend: bool, which: Which) -> Result<(), DspError> {
        self.work.clear();
        self.work.extend_from_slice(x);
        if detrend {
            detrend_linear_keep_bins(&mut self.work, &self.tone_bins)?;
        }
        let bins = self.spectrum.compute(&self.work)?;
        let out = match which {
            Which::Psi => &mut self.psi,
            Which::Delta => &mut self.delta,
            Which::Reference => &mut self.reference,
        };
        out.clear();
        out.extend_from_slice(bins);
        Ok(())
    }

    /// Fills `self.neighbours` for the tone on bin `b` (see the module documentation).
    fn select_neighbours(&mut self, b: usize, n: usize) {
        self.neighbours.clear();
        let half = n.div_ceil(2); // bins < half are below Nyquist (exclusive when N even)
        let usable = |j: usize, tones: &[usize]| j > 0 && j < half && !tones.contains(&j);
        let mut d = 1;
        while self.neighbours.len() < 2 * self.neighbour_pairs && d < b {
            let (lo, hi) = (b - d, b + d);
            if hi >= half {
                break;
            }
            if usable(lo, &self.tone_bins) && usable(hi, &self.tone_bins) {
                self.neighbours.push(lo);
                self.neighbours.push(hi);
            }
            d += 1;
        }
        if self.neighbours.is_empty() {
            let mut j = b + 1;
            while self.neighbours.len() < 2 * self.neighbour_pairs && j < half {
                if usable(j, &self.tone_bins) {
                    self.neighbours.push(j);
                }
                j += 1;
            }
        }
    }
}

#[derive(Clone, Copy)]
enum Which {
    Psi,
    Delta,
    Reference,
}

/// Gain, phase and calibrated 90 % intervals of `G = psi / delta` at each tone (module
/// documentation: estimator, uncertainty, conventions).
///
/// `heading`, `rudder` and `reference` are aligned records of equal length `N`, a whole
/// number of windows of `window_samples` samples, spaced `dt_s` seconds; `harmonics` are the
/// tone harmonics of the window (distinct, each below the window's Nyquist bin). Returns one
/// estimate per harmonic, in the order given.
///
/// Errors: lengths differ or are not whole windows, non-finite samples, bad `dt_s`,
/// harmonics empty / zero / repeated / at or above Nyquist, no reference or rudder power at
/// a tone, or no unexcited bin left for the noise estimate.
pub fn analyse_tones(
    an: &mut ToneAnalyser,
    heading: &[f64],
    rudder: &[f64],
    reference: &[f64],
    dt_s: f64,
    window_samples: usize,
    harmonics: &[u32],
) -> Result<Vec<ToneEstimate>, DspError> {
    check_record(heading, rudder, reference, dt_s, window_samples, harmonics)?;
    let n = heading.len();
    an.set_tone_bins(harmonics, window_samples, n)?;

    an.transform(heading, true, Which::Psi)?;
    an.transform(rudder, true, Which::Delta)?;
    an.transform(reference, false, Which::Reference)?;
    let ref_energy: f64 = reference.iter().map(|v| v * v).sum::<f64>() * n as f64;

    let record_s = n as f64 * dt_s;
    let mut out = Vec::with_capacity(harmonics.len());
    for i in 0..harmonics.len() {
        let b = an.tone_bins[i];
        out.push(an.tone(b, n, ref_energy, record_s)?);
    }
    Ok(out)
}

/// The input checks of [`analyse_tones`] on the records, the step and the harmonics given.
fn check_record(
    heading: &[f64],
    rudder: &[f64],
    reference: &[f64],
    dt_s: f64,
    window_samples: usize,
    harmonics: &[u32],
) -> Result<(), DspError> {
    check_positive("dt_s", dt_s)?;
    let n = heading.len();
    if window_samples < 4 {
        return Err(DspError::InvalidParameter {
            name: "window_samples",
            value: window_samples as f64,
            reason: "must be >= 4",
        });
    }
    if n < window_samples {
        return Err(DspError::TooShort {
            what: "heading",
            got: n,
            need: window_samples,
        });
    }
    if n % window_samples != 0 {
        return Err(DspError::InvalidParameter {
            name: "heading length",
            value: n as f64,
            reason: "must be a whole number of windows",
        });
    }
    for (what, x) in [("rudder", rudder), ("reference", reference)] {
        if x.len() != n {
            return Err(DspError::LengthMismatch {
                what,
                expected: n,
                got: x.len(),
            });
        }
    }
    check_finite("heading", heading)?;
    check_finite("rudder", rudder)?;
    check_finite("reference", reference)?;
    if harmonics.is_empty() {
        return Err(DspError::TooShort {
            what: "harmonics",
            got: 0,
            need: 1,
        });
    }
    Ok(())
}

/// The local linear fit over a tone's neighbours (abscissa `j - b`): its degree, the
/// abscissa's mean and spread, and the leverage (the prediction weights, in
/// `ToneAnalyser::weights`, squared and summed).
struct LocalFit {
    degree: usize,
    rbar: f64,
    srr: f64,
    leverage: f64,
}

impl ToneAnalyser {
    /// Sets the tone bins `k_i M` of a record of `n` samples in windows of `window_samples`,
    /// refusing a zero, repeated or too high harmonic.
    fn set_tone_bins(
        &mut self,
        harmonics: &[u32],
        window_samples: usize,
        n: usize,
    ) -> Result<(), DspError> {
        let m = n / window_samples;
        self.tone_bins.clear();
        for (i, &k) in harmonics.iter().enumerate() {
            let k = k as usize;
            if k == 0 || 2 * k >= window_samples || harmonics[..i].contains(&harmonics[i]) {
                return Err(DspError::InvalidParameter {
                    name: "harmonics",
                    value: k as f64,
                    reason: "distinct, each in [1, window Nyquist bin)",
                });
            }
            self.tone_bins.push(k * m);
        }
        Ok(())
    }

    /// The estimate at the tone on bin `b` of the transformed records (module
    /// documentation: neighbours, transient removal, noise).
    fn tone(
        &mut self,
        b: usize,
        n: usize,
        ref_energy: f64,
        record_s: f64,
    ) -> Result<ToneEstimate, DspError> {
        let r = self.reference[b];
        if !above(r.norm_sqr(), 1e-9 * ref_energy) {
            return Err(DspError::Degenerate("reference has no power at a tone"));
        }
        self.select_neighbours(b, n);
        let fit = self.local_fit(b)?;
        // Transient / leakage at the tone bin, interpolated from the neighbours, removed.
        let mut tp = Complex64::new(0.0, 0.0);
        let mut td = Complex64::new(0.0, 0.0);
        for (&j, &w) in self.neighbours.iter().zip(&self.weights) {
            tp += self.psi[j] * w;
            td += self.delta[j] * w;
        }
        let (psi_b, delta_b) = (self.psi[b] - tp, self.delta[b] - td);
        let s_psi_r = psi_b * r.conj();
        let s_delta_r = delta_b * r.conj();
        if !above(s_delta_r.norm(), 0.0) {
            return Err(DspError::Degenerate("rudder has no power at a tone"));
        }
        let g = s_psi_r / s_delta_r;
        if !(g.re.is_finite() && g.im.is_finite()) {
            return Err(DspError::Degenerate("rudder has no power at a tone"));
        }
        let signal = psi_b.norm_sqr();
        if !above(signal, 0.0) {
            return Err(DspError::Degenerate("heading has no power at a tone"));
        }
        let (noise, dof) = self.noise_power(b, g, &fit);
        // The variance of each component of eps at the tone.
        let var_component = noise * (1.0 + fit.leverage) / (2.0 * signal);
        let t90 = student_t_quantile(0.95, 2 * dof as u32);
        let snr = if noise > 0.0 {
            signal / noise - 1.0
        } else {
            1e30
        };
        let coherence = (snr / (1.0 + snr)).clamp(0.0, 1.0);
        let mut phase = g.arg();
        if phase > 0.0 {
            phase -= 2.0 * PI;
        }
        Ok(ToneEstimate {
            omega_rad_s: 2.0 * PI * b as f64 / record_s,
            gain: g.norm(),
            phase_rad: phase,
            coherence: if coherence.is_finite() {
                coherence
            } else {
                1.0
            },
            snr_db: 10.0 * snr.clamp(1e-12, 1e30).log10(),
            gain_ci90_rel: t90 * var_component.sqrt(),
            phase_ci90_rad: (t90 * var_component.sqrt()).min(PI),
        })
    }

    /// The local fit over the neighbours of the tone on bin `b`; fills `self.weights`.
    fn local_fit(&mut self, b: usize) -> Result<LocalFit, DspError> {
        let l = self.neighbours.len();
        // Local linear fit over the neighbours (abscissa r = j - b): prediction weights at
        // r = 0 and its leverage sum w^2. Degree 1 with >= 3 bins, else degree 0.
        let degree = if l >= 3 { 1 } else { 0 };
        if l < degree + 2 {
            return Err(DspError::Degenerate(
                "too few unexcited bins next to a tone",
            ));
        }
        let rs = |j: usize| j as f64 - b as f64;
        let lf = l as f64;
        let rbar = self.neighbours.iter().map(|&j| rs(j)).sum::<f64>() / lf;
        let srr: f64 = self
            .neighbours
            .iter()
            .map(|&j| (rs(j) - rbar).powi(2))
            .sum();
        self.weights.clear();
        for &j in &self.neighbours {
            let w = if degree == 1 && srr > 0.0 {
                1.0 / lf - rbar * (rs(j) - rbar) / srr
            } else {
                1.0 / lf
            };
            self.weights.push(w);
        }
        let leverage: f64 = self.weights.iter().map(|w| w * w).sum();
        Ok(LocalFit {
            degree,
            rbar,
            srr,
            leverage,
        })
    }

    /// Noise power per bin at the tone on bin `b` and its degrees of freedom: the
    /// output-error residuals `e(j) = Psi(j) - G Delta(j)` at the neighbours, minus their
    /// local fit (left in `self.residuals`).
    fn noise_power(&mut self, b: usize, g: Complex64, fit: &LocalFit) -> (f64, usize) {
        let (degree, rbar, srr) = (fit.degree, fit.rbar, fit.srr);
        let rs = |j: usize| j as f64 - b as f64;
        let l = self.neighbours.len();
        let lf = l as f64;
        self.residuals.clear();
        for &j in &self.neighbours {
            self.residuals.push(self.psi[j] - g * self.delta[j]);
        }
        let dof = {
            let ebar = self.residuals.iter().sum::<Complex64>() / lf;
            let slope = if degree == 1 && srr > 0.0 {
                self.neighbours
                    .iter()
                    .zip(&self.residuals)
                    .map(|(&j, e)| (e - ebar) * (rs(j) - rbar))
                    .sum::<Complex64>()
                    / srr
            } else {
                Complex64::new(0.0, 0.0)
            };
            for (&j, e) in self.neighbours.iter().zip(self.residuals.iter_mut()) {
                *e -= ebar + slope * (rs(j) - rbar);
            }
            l - degree - 1
        };
        let noise = self.residuals.iter().map(|e| e.norm_sqr()).sum::<f64>() / dof as f64;
        (noise, dof)
    }
}

/// `a > b`, false when either is NaN.
fn above(a: f64, b: f64) -> bool {
    a > b
}

/// Upper quantile `t_p` of Student's t with `nu` degrees of freedom (`P(T <= t_p) = p`,
/// 0.5 <= p < 1), by bisection on the closed-form CDF (Abramowitz & Stegun 26.7.3-4).
///
/// `nu = 0` is treated as 1; `nu` above 10^5 uses 10^5 (within 1e-5 of the normal quantile).
pub fn student_t_quantile(p: f64, nu: u32) -> f64 {
    if !(0.5..1.0).contains(&p) {
        return f64::NAN;
    }
    let target = 2.0 * p - 1.0; // P(|T| <= t)
    let nu = nu.clamp(1, 100_000);
    let (mut lo, mut hi) = (0.0f64, 1.0f64);
    while student_t_central(hi, nu) < target && hi < 1e12 {
        hi *= 2.0;
    }
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if student_t_central(mid, nu) < target {
            lo = mid;
        } else {
            hi = mid;
        }
        if hi - lo <= 1e-13 * hi {
            break;
        }
    }
    0.5 * (lo + hi)
}

/// `A(t | nu) = P(|T| <= t)` for Student's t (Abramowitz & Stegun 26.7.3-4), t >= 0.
fn student_t_central(t: f64, nu: u32) -> f64 {
    let theta = (t / f64::from(nu).sqrt()).atan();
    let (s, c) = theta.sin_cos();
    let c2 = c * c;
    if nu % 2 == 0 {
        // sin(theta) [1 + 1/2 c^2 + 1.3/(2.4) c^4 + ... + 1.3..(nu-3)/(2.4..(nu-2)) c^(nu-2)]
        let mut term = 1.0;
        let mut sum = 1.0;
        let mut j = 2;
        while j < nu {
            term *= f64::from(j - 1) / f64::from(j) * c2;
            sum += term;
            j += 2;
        }
        s * sum
    } else if nu == 1 {
        2.0 * theta / PI
    } else {
        // (2/pi) [theta + sin cos (1 + 2/3 c^2 + ... + 2.4..(nu-3)/(1.3..(nu-2)) c^(nu-3))]
        let mut term = 1.0;
        let mut sum = 1.0;
        let mut j = 3;
        while j < nu {
            term *= f64::from(j - 1) / f64::from(j) * c2;
            sum += term;
            j += 2;
        }
        2.0 / PI * (theta + s * c * sum)
    }
}

#[cfg(test)]
#[path = "tones_tests.rs"]
mod tests;
