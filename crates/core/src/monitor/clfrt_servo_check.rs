//! The servo check of a CLFRT test: the sinusoid played before the multisine, its rudder and
//! heading records, and what they measure (or why not). Part of [`super::ClfrtRun`].
//!
//! The multisine's tones are heading / rudder ratios: the servo sits outside them, and the
//! multisine commands ~1.1 deg/s at most, so a servo whose rate limit fell from 4 to 2 deg/s
//! leaves them unchanged. The check plays one faster tone, `w_s` = 0.6 rad/s at `A_s` = 5 deg:
//! a command rate `A_s w_s` = 3.0 deg/s, and a rudder rate `A_s w_s / |1 + j w_s T_r|` = 2.6 deg/s
//! with the nominal servo (`T_r` = 1 s): linear below its 4 deg/s, rate-limited with 2 deg/s.
//!
//! Measured: `T = Delta(w_s) / E(w_s)`, the bin `k = periods` of the `N`-sample DFT of the
//! rudder (resampled on the grid `t_s + n dt` of the full-amplitude periods, line removed
//! jointly with the bin, [`crate::dsp::detrend_linear_keep_bins`]) over that of the excitation
//! sent, known analytically on the same grid. `w_s` is adjusted (< 0.05 %) so that the `N`
//! samples hold exactly `periods` periods: no leakage from the tone itself.
//!
//! What `T` is: with servo `S(s)`, autopilot `C(s)` (PID behind its 0.25 rad/s wave low-pass)
//! and ship `G(s) = b / (s (s + a))`, the rudder answers the added excitation as
//! `T = S H / (1 + S C G)`, `H = e^{-j w dt / 2}` the half-sample delay of a value held over
//! one sample period. At `w_s` the loop term is small: `|G| ~ b / w^2 ~ 1.7e-3`, the low-pass
//! gives 0.15 and `|C G S| ~ 0.02` on the nominal ship (it moves `T` by ~0.3 % in gain and
//! ~1 deg in phase). So `T` is the servo's response. The reported errors are taken against the
//! nominal servo, linear, with the hold: `T_0 = e^{-j w dt / 2} / (1 + j w T_r)` (`T_r` =
//! `servo.time-constant-s`, `dt` = 1 / `sensors.rate-hz`): `ln_gain_error = ln |T| - ln |T_0|`,
//! `phase_error_rad = arg T - arg T_0` (wrapped to (-pi, pi]).
//!
//! A rate-limited servo turns the sinusoid into a near-triangle wave: by the describing
//! function of a rate limiter the first harmonic loses gain and gains lag (at 2 deg/s,
//! `ln_gain_error` ~ -0.2 and several degrees of extra lag), and the odd harmonics grow
//! (`harmonic3_ratio`, `|Delta(3 w_s)| / |Delta(w_s)|`, 1/9 for a pure triangle).
//! `residual_rms_rad` is the rudder's rms left after the line and the tone: sensor noise, the
//! autopilot's own wave-induced rudder, the harmonics.
//!
//! The check is part of the features and never aborts the test: if the rudder record of its
//! periods has a gap (or overflows), `features.servo_check` carries `failed` (the reason)
//! instead of the measured numbers, and the multisine test goes on.

use crate::dsp::spectrum::{detrend_linear_keep_bins, naive_dft};
use crate::dsp::DspError;
use crate::monitor::config::CoreConfig;
use crate::monitor::record::{Record, RecordError};
use crate::wire::features::ServoCheckFeatures;
use rustfft::num_complex::Complex64;
use std::f64::consts::PI;

/// The servo check of a multisine test (the features' `servo_check`).
#[derive(Debug, Clone, PartialEq)]
pub struct ServoCheck {
    /// Frequency played w_s [rad/s].
    pub omega_rad_s: f64,
    /// Amplitude A_s [rad].
    pub amplitude_rad: f64,
    /// Full-amplitude periods measured.
    pub periods: u32,
    /// The measured response, or why it could not be measured.
    pub result: Result<ServoCheckMeasurement, ServoCheckError>,
}

/// Why the servo check measured nothing (the features' `servo_check.failed` gives this text).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ServoCheckError {
    /// The rudder record of the check's periods overflowed or has a gap.
    #[error("rudder: {0}")]
    Rudder(RecordError),
    /// The heading record of the check's periods overflowed or has a gap.
    #[error("heading: {0}")]
    Heading(RecordError),
    /// The rudder's line could not be removed.
    #[error("rudder: {0}")]
    RudderDetrend(DspError),
    /// The heading's line could not be removed.
    #[error("heading: {0}")]
    HeadingDetrend(DspError),
    /// The excitation or the rudder has nothing at the check's bin.
    #[error("no rudder response at the check frequency")]
    NoResponse,
    /// The autopilot's own rudder could not be fitted at the neighbouring bins.
    #[error("autopilot rudder fit is singular")]
    SingularFit,
    /// The multisine's analysis came before the check's records covered its periods.
    #[error("not measured before the analysis")]
    NotMeasured,
}

/// What the servo check measured: `T = Delta(w_s) / E(w_s)` and its deviation from the
/// nominal servo's linear response (see the module documentation).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ServoCheckMeasurement {
    /// `ln |T|`.
    pub ln_gain: f64,
    /// `arg T` [rad], in (-pi, pi].
    pub phase_rad: f64,
    /// `ln |T| - ln |T_0|`, `T_0` the nominal servo with the half-sample hold.
    pub ln_gain_error: f64,
    /// `arg T - arg T_0` [rad], wrapped to (-pi, pi].
    pub phase_error_rad: f64,
    /// `|Delta(3 w_s)| / |Delta(w_s)|` (none when `3 w_s` is not below Nyquist).
    pub harmonic3_ratio: Option<f64>,
    /// Rms of the rudder after removing the line and the tone at `w_s` [rad].
    pub residual_rms_rad: f64,
    /// 95th percentile of `|d delta / dt|` over the measured periods, the slope of a line
    /// fitted over `2 RATE_HALF_WIDTH + 1` samples around each sample [rad/s].
    pub rudder_rate_p95_rad_s: f64,
    /// What `rudder_rate_p95_rad_s` is for the nominal servo, linear, with no disturbance:
    /// `A_s |T_0| w_s f cos(pi / 40)`, `f` the line fit's factor on a sinusoid [rad/s].
    pub rudder_rate_nominal_rad_s: f64,
    /// `ln |Delta(w_s) / E(w_s)|`, the plain ratio (closed loop, autopilot's rudder included).
    pub ratio_ln_gain: f64,
    /// `arg (Delta(w_s) / E(w_s))` [rad].
    pub ratio_phase_rad: f64,
}

impl ServoCheck {
    /// The report's `features.servo_check`.
    pub(super) fn to_features(&self) -> ServoCheckFeatures {
        let m = self.result.as_ref().ok();
        ServoCheckFeatures {
            omega_rad_s: self.omega_rad_s,
            amplitude_rad: self.amplitude_rad,
            periods: self.periods,
            ln_gain: m.map(|m| m.ln_gain),
            phase_rad: m.map(|m| m.phase_rad),
            ln_gain_error: m.map(|m| m.ln_gain_error),
            phase_error_rad: m.map(|m| m.phase_error_rad),
            harmonic3_ratio: m.and_then(|m| m.harmonic3_ratio),
            residual_rms_rad: m.map(|m| m.residual_rms_rad),
            rudder_rate_p95_rad_s: m.map(|m| m.rudder_rate_p95_rad_s),
            rudder_rate_nominal_rad_s: m.map(|m| m.rudder_rate_nominal_rad_s),
            ratio_ln_gain: m.map(|m| m.ratio_ln_gain),
            ratio_phase_rad: m.map(|m| m.ratio_phase_rad),
            failed: self.result.as_ref().err().map(ToString::to_string),
        }
    }
}

/// The servo check in progress: its timeline, its rudder record, its result once measured.
#[derive(Debug, Clone)]
pub(super) struct ServoCheckRun {
    /// Frequency w_s [rad/s] (on the sample grid of the measured periods).
    omega_rad_s: f64,
    /// Amplitude A_s [rad].
    amplitude_rad: f64,
    /// Full-amplitude periods (the DFT bin of the measurement).
    periods: u32,
    /// Fade-in and fade-out time [s].
    fade_s: f64,
    /// Whole check, fades included [s].
    duration_s: f64,
    /// First grid time of the measurement, `t0 + fade_s` [s].
    measure_start_s: f64,
    /// Grid samples N (exactly `periods` periods).
    samples: usize,
    /// Nominal response `T_0` (servo with the half-sample hold).
    nominal: Complex64,
    /// `rudder_rate_p95_rad_s` of the nominal linear servo [rad/s].
    rate_nominal_rad_s: f64,
    rudder: Record,
    heading: Record,
    /// Once measured (or failed).
    result: Option<Result<ServoCheckMeasurement, ServoCheckError>>,
}

impl ServoCheckRun {
    /// The check `cfg` asks for in a test starting at `t_start_s` (none when disabled).
    pub(super) fn new(cfg: &CoreConfig, t_start_s: f64) -> Option<Self> {
        let c = &cfg.clfrt;
        if !c.servo_check_enabled() {
            return None;
        }
        let rate = cfg.sensors.rate_hz;
        let w = c.servo_check_omega_rad_s(rate);
        let period_s = 2.0 * PI / w;
        let fade_s = c.servo_check_fade_periods as f64 * period_s;
        let samples = c.servo_check_samples(rate);
        let dt = 1.0 / rate;
        let nominal = Complex64::from_polar(1.0, -w * dt / 2.0)
            / Complex64::new(1.0, w * cfg.servo.time_constant_s);
        let h = RATE_HALF_WIDTH as f64;
        let (num, den) = (1..=RATE_HALF_WIDTH).fold((0.0, 0.0), |(a, b), i| {
            let x = i as f64;
            (a + x * (w * x * dt).sin(), b + x * x * w * dt)
        });
        let fit = if h > 0.0 { num / den } else { 1.0 };
        // 95 % of a sinusoid's |cos| lies below cos(pi / 40).
        let rate_nominal_rad_s =
            c.servo_check_amplitude_rad() * nominal.norm() * w * fit * (PI / 40.0).cos();
        // The measured periods plus a margin, at up to twice the nominal rate.
        let capacity = ((samples as f64 * dt + 10.0) * rate * 2.0).ceil() as usize;
        Some(Self {
            omega_rad_s: w,
            amplitude_rad: c.servo_check_amplitude_rad(),
            periods: c.servo_check_periods,
            fade_s,
            duration_s: c.servo_check_duration_s(rate),
            measure_start_s: t_start_s + fade_s,
            samples,
            nominal,
            rate_nominal_rad_s,
            rudder: Record::with_capacity(capacity),
            heading: Record::with_capacity(capacity),
            result: None,
        })
    }

    /// Whole check, fades included [s].
    pub(super) fn duration_s(&self) -> f64 {
        self.duration_s
    }

    /// The excitation at `tr` seconds from the test start [rad] (0 outside the check).
    pub(super) fn value(&self, tr: f64) -> f64 {
        if !(0.0..self.duration_s).contains(&tr) {
            return 0.0;
        }
        let raised = |x: f64| 0.5 * (1.0 - (PI * x.clamp(0.0, 1.0)).cos());
        let env = if self.fade_s > 0.0 {
            raised(tr / self.fade_s).min(raised((self.duration_s - tr) / self.fade_s))
        } else {
            1.0
        };
        env * self.amplitude_rad * (self.omega_rad_s * tr).sin()
    }

    /// Last grid time of the measurement [s].
    fn grid_end_s(&self, dt: f64) -> f64 {
        self.measure_start_s + (self.samples as f64 - 1.0) * dt
    }

    /// Whether a sample at `t` is recorded: the check not yet measured, `t` on its grid or
    /// within two samples of it.
    fn records(&self, t: f64, dt: f64) -> bool {
        let span = self.measure_start_s - 2.0 * dt..=self.grid_end_s(dt) + 2.0 * dt;
        self.result.is_none() && span.contains(&t)
    }

    /// A rudder sample (`dt`: grid step); a record that fails fails the check.
    pub(super) fn push_rudder(&mut self, t: f64, rudder_rad: f64, dt: f64) {
        if self.records(t, dt) {
            if let Err(e) = self.rudder.push(t, rudder_rad) {
                self.result = Some(Err(ServoCheckError::Rudder(e)));
            }
        }
    }

    /// A heading sample (continuous); a record that fails fails the check.
    pub(super) fn push_heading(&mut self, t: f64, continuous_rad: f64, dt: f64) {
        if self.records(t, dt) {
            if let Err(e) = self.heading.push(t, continuous_rad) {
                self.result = Some(Err(ServoCheckError::Heading(e)));
            }
        }
    }

    /// Measures the check at ship time `t` once the rudder record covers its periods (or
    /// once it can no longer: a gap); `t0` the test start, `scratch` the rudder's, heading's
    /// and excitation's grids.
    pub(super) fn update(
        &mut self,
        t: f64,
        t0: f64,
        dt: f64,
        max_gap_s: f64,
        scratch: [&mut Vec<f64>; 3],
    ) {
        if self.result.is_some() {
            return;
        }
        let end = self.grid_end_s(dt);
        let covered = self.rudder.last_t().is_some_and(|tl| tl >= end);
        if covered || t > end + max_gap_s + dt {
            self.result = Some(self.measure(t0, dt, max_gap_s, scratch));
        }
    }

    /// The report's servo check: measured, or why not.
    pub(super) fn report(&self) -> ServoCheck {
        ServoCheck {
            omega_rad_s: self.omega_rad_s,
            amplitude_rad: self.amplitude_rad,
            periods: self.periods,
            result: self
                .result
                .clone()
                .unwrap_or(Err(ServoCheckError::NotMeasured)),
        }
    }

    /// Measures `T` from the rudder and heading records (`t0`: test start, `dt`: grid step).
    fn measure(
        &self,
        t0: f64,
        dt: f64,
        max_gap_s: f64,
        [d, h, e]: [&mut Vec<f64>; 3],
    ) -> Result<ServoCheckMeasurement, ServoCheckError> {
        let n = self.samples;
        let k = self.periods as usize;
        self.rudder
            .resample(self.measure_start_s, dt, n, max_gap_s, d)
            .map_err(ServoCheckError::Rudder)?;
        self.heading
            .resample(self.measure_start_s, dt, n, max_gap_s, h)
            .map_err(ServoCheckError::Heading)?;
        let rudder_rate_p95_rad_s = rate_quantile(d, dt, 0.95, e);
        e.clear();
        e.extend((0..n).map(|i| self.value(self.measure_start_s + i as f64 * dt - t0)));
        let p = NEIGHBOUR_PAIRS.min(k - 1);
        let bins: Vec<usize> = (k - p..=k + p).collect();
        detrend_linear_keep_bins(d, &bins).map_err(ServoCheckError::RudderDetrend)?;
        detrend_linear_keep_bins(h, &bins).map_err(ServoCheckError::HeadingDetrend)?;
        let dk = naive_dft(d, k);
        let ek = naive_dft(e, k);
        if ek.norm() == 0.0 || dk.norm() == 0.0 {
            return Err(ServoCheckError::NoResponse);
        }
        let ratio = dk / ek;
        // The autopilot's own rudder, L(j) Psi(j), fitted at the neighbours (no excitation
        // there) with L and a transient term each linear in j - k, removed at the tone.
        let rows: Vec<(f64, Complex64, Complex64)> = bins
            .iter()
            .filter(|&&j| j != k)
            .map(|&j| (j as f64 - k as f64, naive_dft(h, j), naive_dft(d, j)))
            .collect();
        let own = fit_own_rudder(&rows).ok_or(ServoCheckError::SingularFit)?;
        let hk = naive_dft(h, k);
        let t = (dk - own[0] * hk - own[2]) / ek;
        let phase_rad = t.arg();
        let ln_gain = t.norm().ln();
        let err = t / self.nominal;
        let harmonic3_ratio =
            (3 * k < n.div_ceil(2)).then(|| naive_dft(d, 3 * k).norm() / dk.norm());
        let nf = n as f64;
        let power = d.iter().map(|x| x * x).sum::<f64>();
        // Parseval: the tone on bin k holds 2 |X_k|^2 / N of the sum of squares.
        let residual = (power - 2.0 * dk.norm_sqr() / nf).max(0.0);
        Ok(ServoCheckMeasurement {
            ln_gain,
            phase_rad,
            ln_gain_error: err.norm().ln(),
            phase_error_rad: err.arg(),
            harmonic3_ratio,
            residual_rms_rad: (residual / nf).sqrt(),
            rudder_rate_p95_rad_s,
            rudder_rate_nominal_rad_s: self.rate_nominal_rad_s,
            ratio_ln_gain: ratio.norm().ln(),
            ratio_phase_rad: ratio.arg(),
        })
    }
}

/// Half-width of the line fitted for the rudder rate [samples]: 2.1 s at 10 Hz, the slope's
/// noise from the 0.1 deg angle indicator ~0.04 deg/s, and a sinusoid's rate at 0.6 rad/s
/// read ~4 % low.
const RATE_HALF_WIDTH: usize = crate::dsp::RATE_HALF_WIDTH;

/// The `q` quantile of `|slope|` of the least-squares line over `2 RATE_HALF_WIDTH + 1`
/// samples of `x` (step `dt`) centred on each sample where the window fits (`scratch` holds the
/// slopes). 0 for a record shorter than the window.
fn rate_quantile(x: &[f64], dt: f64, q: f64, scratch: &mut Vec<f64>) -> f64 {
    crate::dsp::abs_slopes(x, dt, scratch);
    if scratch.is_empty() {
        return 0.0;
    }
    scratch.sort_by(f64::total_cmp);
    let idx = ((scratch.len() - 1) as f64 * q).round() as usize;
    scratch[idx.min(scratch.len() - 1)]
}

/// Neighbour bin pairs `k +- 1 .. k +- P` on which the autopilot's own rudder is fitted.
const NEIGHBOUR_PAIRS: usize = 5;

/// Least squares `Delta(j) = (l0 + l1 x) Psi(j) + c0 + c1 x` over `rows` of
/// `(x = j - k, Psi(j), Delta(j))`: returns `[l0, l1, c0, c1]`, or `None` when singular.
fn fit_own_rudder(rows: &[(f64, Complex64, Complex64)]) -> Option<[Complex64; 4]> {
    let mut a = nalgebra::DMatrix::<Complex64>::zeros(rows.len(), 4);
    let mut b = nalgebra::DVector::<Complex64>::zeros(rows.len());
    for (i, &(x, psi, delta)) in rows.iter().enumerate() {
        a[(i, 0)] = psi;
        a[(i, 1)] = psi * x;
        a[(i, 2)] = Complex64::new(1.0, 0.0);
        a[(i, 3)] = Complex64::new(x, 0.0);
        b[i] = delta;
    }
    let sol = a.svd(true, true).solve(&b, 1e-12).ok()?;
    Some([sol[0], sol[1], sol[2], sol[3]])
}
