//! CLFRT run: the closed-loop multisine test, as a step function of heading samples.
//!
//! A multisine `r(t) = sum_i A sin(w_i t + phi_i)` (paper eq. 8-9), tones on the FFT grid of
//! the window T_w (`w_i = 2 pi k_i / T_w`), is added to the autopilot's rudder command
//! (`mode: add`). Its phase origin is the test start `t0`.
//!
//! - Servo check (first part of the settle window, before the multisine): a sinusoid
//!   `e(t) = A_s env(t) sin(w_s (t - t0))`, `env` a raised-cosine fade-in over
//!   `clfrt.servo-check-fade-periods` periods, one during `clfrt.servo-check-periods` periods
//!   and a raised-cosine fade-out, then nothing. The rudder is recorded over the full-amplitude
//!   periods; see "Servo check" below.
//! - Settling: `clfrt.settle-windows` windows; after the servo check the multisine's amplitude
//!   fades in over `clfrt.fade-s` with a raised cosine (ArduPilot SystemID style) so the rudder
//!   sees no step.
//! - Sizing (while settling, from the multisine's start to `clfrt.resize-settle-s` before
//!   the measurement): a tone the autopilot loop amplifies past `clfrt.resize-gain` on the
//!   rudder is lowered, and every tone when the heading error heads for its limit
//!   ([`super::sizing::ToneSizing`], the `clfrt.resize-*` keys; see "CLFRT" in
//!   [`super::sizing`]). The measured windows see one amplitude per tone; the
//!   report's `amplitude_scales` gives each tone's scale.
//! - Exciting: `clfrt.measure-windows` windows at full amplitude; heading and rudder recorded.
//! - Analysing: heading and rudder are resampled onto the uniform grid of the measurement
//!   (alignment by `t`), the reference is the multisine itself on that grid, and the gain and
//!   phase of heading/rudder at each tone are estimated against the reference
//!   ([`crate::dsp::tones`]). The same grids feed the time-domain baseline
//!   ([`crate::baseline`]), whose failure is reported, never an abort. Meanwhile the excitation ramps to zero at the safety rate limit;
//!   the report follows when it reaches zero.
//!
//! ## Servo check
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

use super::record::{Record, RecordError};
use super::sizing::{ToneSizing, MAX_TONES};
use super::{AbortReason, Measured, Step};
use crate::baseline::config::BaselineConfig;
use crate::baseline::{self, BaselineError, BaselineEstimate};
use crate::dsp::multisine::Multisine;
use crate::dsp::spectrum::{band_rms, detrend_linear_keep_bins, naive_dft, Spectrum};
use crate::dsp::tones::{analyse_tones, ToneAnalyser, ToneEstimate};
use crate::model::ShipConfig;
use crate::monitor::config::CoreConfig;
use crate::wire::features::{ClfrtFeatures, ServoCheckFeatures};
use crate::wire::{ExcitationMode, MonitorState};
use rustfft::num_complex::Complex64;
use std::f64::consts::PI;

/// Features of a completed multisine test (the report's `features`).
#[derive(Debug, Clone, PartialEq)]
pub struct ClfrtReport {
    /// One estimate per tone, lowest first.
    pub tones: Vec<ToneEstimate>,
    /// Window length T_w [s].
    pub window_s: f64,
    /// Windows measured.
    pub windows: u32,
    /// Tone amplitude [rad].
    pub amplitude_rad: f64,
    /// Crest factor of the multisine.
    pub crest_factor: f64,
    /// The servo check (none when disabled).
    pub servo_check: Option<ServoCheck>,
    /// The time-domain baseline on the measured windows, or why it failed.
    pub baseline: Result<BaselineEstimate, BaselineError>,
    /// Wave yaw: rms of the heading in `calibration.wave-band-rad-s` over the measured windows [rad]
    /// ([`crate::dsp::band_rms`]; none when it could not be computed).
    pub wave_yaw_rad: Option<f64>,
    /// Per tone, its scale against the design when the sizing lowered any (none at full
    /// size).
    pub amplitude_scales: Option<Vec<f64>>,
}

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
    pub result: Result<ServoCheckMeasurement, String>,
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
    fn to_features(&self) -> ServoCheckFeatures {
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
            failed: self.result.as_ref().err().cloned(),
        }
    }
}

impl ClfrtReport {
    /// The report's `features` (without `speed_log_mps`, which the monitor adds).
    pub fn to_features(&self) -> ClfrtFeatures {
        let (baseline, baseline_error) = baseline::to_features(&self.baseline);
        ClfrtFeatures {
            tones: self.tones.clone(),
            window_s: self.window_s,
            windows: self.windows,
            amplitude_rad: self.amplitude_rad,
            crest_factor: self.crest_factor,
            servo_check: self.servo_check.as_ref().map(ServoCheck::to_features),
            wave_yaw_rad: self.wave_yaw_rad,
            amplitude_scales: self.amplitude_scales.clone(),
            speed_log_mps: None,
            baseline,
            baseline_error,
        }
    }
}

/// The servo check in progress: its timeline, its rudder record, its result once measured.
#[derive(Debug, Clone)]
struct ServoCheckRun {
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
    result: Option<Result<ServoCheckMeasurement, String>>,
}

impl ServoCheckRun {
    fn new(cfg: &CoreConfig) -> Option<Self> {
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
            measure_start_s: 0.0,
            samples,
            nominal,
            rate_nominal_rad_s,
            rudder: Record::with_capacity(capacity),
            heading: Record::with_capacity(capacity),
            result: None,
        })
    }

    /// The excitation at `tr` seconds from the test start [rad] (0 outside the check).
    fn value(&self, tr: f64) -> f64 {
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

    /// Measures `T` from the rudder and heading records (`t0`: test start, `dt`: grid step).
    fn measure(
        &self,
        t0: f64,
        dt: f64,
        max_gap_s: f64,
        [d, h, e]: [&mut Vec<f64>; 3],
    ) -> Result<ServoCheckMeasurement, String> {
        let n = self.samples;
        let k = self.periods as usize;
        self.rudder
            .resample(self.measure_start_s, dt, n, max_gap_s, d)
            .map_err(|err| format!("rudder: {err}"))?;
        self.heading
            .resample(self.measure_start_s, dt, n, max_gap_s, h)
            .map_err(|err| format!("heading: {err}"))?;
        let rudder_rate_p95_rad_s = rate_quantile(d, dt, 0.95, e);
        e.clear();
        e.extend((0..n).map(|i| self.value(self.measure_start_s + i as f64 * dt - t0)));
        let p = NEIGHBOUR_PAIRS.min(k - 1);
        let bins: Vec<usize> = (k - p..=k + p).collect();
        detrend_linear_keep_bins(d, &bins).map_err(|err| format!("rudder: {err}"))?;
        detrend_linear_keep_bins(h, &bins).map_err(|err| format!("heading: {err}"))?;
        let dk = naive_dft(d, k);
        let ek = naive_dft(e, k);
        if ek.norm() == 0.0 || dk.norm() == 0.0 {
            return Err("no rudder response at the check frequency".into());
        }
        let ratio = dk / ek;
        // The autopilot's own rudder, L(j) Psi(j), fitted at the neighbours (no excitation
        // there) with L and a transient term each linear in j - k, removed at the tone.
        let rows: Vec<(f64, Complex64, Complex64)> = bins
            .iter()
            .filter(|&&j| j != k)
            .map(|&j| (j as f64 - k as f64, naive_dft(h, j), naive_dft(d, j)))
            .collect();
        let own = fit_own_rudder(&rows).ok_or("autopilot rudder fit is singular")?;
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

/// State of one multisine test.
#[derive(Debug, Clone)]
pub(crate) struct ClfrtRun {
    multisine: Multisine,
    harmonics: Vec<u32>,
    window_s: f64,
    windows: u32,
    amplitude_rad: f64,
    /// Phase origin of the multisine and start of the servo check [s].
    t0_s: f64,
    /// Start of the multisine's fade-in, after the servo check, relative to `t0_s` [s].
    multisine_start_s: f64,
    fade_s: f64,
    /// Start and end of the measurement [s].
    measure_start_s: f64,
    measure_end_s: f64,
    dt_s: f64,
    window_samples: usize,
    max_gap_s: f64,
    /// Rate limit of the ramp-down after the measurement [rad/s].
    ramp_rate_rad_s: f64,
    heading: Record,
    rudder: Record,
    /// Once measured: the features (or why not) and the excitation ramping to zero.
    result: Option<Result<Measured, AbortReason>>,
    ramp: (f64, f64),
    analyser: ToneAnalyser,
    scratch: [Vec<f64>; 3],
    /// Whether `scratch` holds the analysis's heading, rudder and reference.
    analysed: bool,
    /// Wave-yaw band [rad/s], its transform and scratch.
    wave: ((f64, f64), Spectrum, Vec<f64>),
    /// The servo check (none when disabled).
    check: Option<ServoCheckRun>,
    /// The baseline's filter and the ship that turns its a and b into speed and displacement.
    baseline: (BaselineConfig, ShipConfig),
    /// The tones' size.
    sizing: ToneSizing,
}

impl ClfrtRun {
    /// A multisine test starting at `t_start_s` with the designed `multisine`.
    /// `heading_guard`: the tones' heading guard armed (the vessel's last CLFRT test ended
    /// on the heading limit or needed the guard; [`ToneSizing::on_heading`]).
    pub(crate) fn new(
        cfg: &CoreConfig,
        t_start_s: f64,
        multisine: Multisine,
        heading_guard: bool,
        speed_mps: Option<f64>,
    ) -> Self {
        let c = &cfg.clfrt;
        let rate = cfg.sensors.rate_hz;
        let measure_start_s = t_start_s + c.settle_windows as f64 * c.window_s;
        let measure_s = c.measure_windows as f64 * c.window_s;
        // Records hold the measurement plus a margin, at up to twice the nominal rate.
        let capacity = ((measure_s + 60.0) * rate * 2.0).ceil() as usize;
        let check = ServoCheckRun::new(cfg).map(|mut c| {
            c.measure_start_s = t_start_s + c.fade_s;
            c
        });
        let multisine_start_s = check.as_ref().map_or(0.0, |c| c.duration_s);
        let sizing = ToneSizing::new(
            cfg,
            &multisine,
            t_start_s,
            (
                t_start_s + multisine_start_s,
                measure_start_s - c.resize_settle_s,
            ),
            heading_guard,
            speed_mps,
        );
        Self {
            multisine,
            harmonics: c.harmonics.clone(),
            window_s: c.window_s,
            windows: c.measure_windows,
            amplitude_rad: c.amplitude_rad(),
            t0_s: t_start_s,
            multisine_start_s,
            fade_s: if c.settle_windows > 0 { c.fade_s } else { 0.0 },
            measure_start_s,
            measure_end_s: measure_start_s + measure_s,
            dt_s: 1.0 / rate,
            window_samples: (c.window_s * rate).round() as usize,
            max_gap_s: cfg.safety.stream_timeout_s,
            ramp_rate_rad_s: cfg.safety.max_excitation_rate_deg_s.to_radians(),
            heading: Record::with_capacity(capacity),
            rudder: Record::with_capacity(capacity),
            result: None,
            ramp: (0.0, t_start_s),
            analyser: ToneAnalyser::new(),
            scratch: [Vec::new(), Vec::new(), Vec::new()],
            analysed: false,
            wave: (
                (
                    cfg.calibration.wave_band_rad_s[0],
                    cfg.calibration.wave_band_rad_s[1],
                ),
                Spectrum::new(),
                Vec::new(),
            ),
            check,
            baseline: (cfg.baseline.clone(), cfg.ship.clone()),
            sizing,
        }
    }

    /// Whether the heading guard lowered the tones in this test (the next test keeps it
    /// armed).
    pub(crate) fn heading_guarded(&self) -> bool {
        self.sizing.heading_guarded()
    }

    /// After the analysis: its grid `(t0, dt)` and the resampled continuous heading, rudder
    /// and the multisine reference on it (what the tone analysis used).
    pub(crate) fn analysis_series(&self) -> Option<(f64, f64, [&[f64]; 3])> {
        if !self.analysed {
            return None;
        }
        let [h, d, r] = &self.scratch;
        Some((self.measure_start_s, self.dt_s, [h, d, r]))
    }

    /// Whether samples at `t` are needed for the analysis.
    fn recording(&self, t: f64) -> bool {
        self.result.is_none() && t >= self.measure_start_s - 2.0 * self.dt_s
    }

    /// A rudder sample.
    pub(crate) fn push_rudder(&mut self, t: f64, rudder_rad: f64) -> Result<(), RecordError> {
        let dt = self.dt_s;
        if let Some(c) = &mut self.check {
            let span = c.measure_start_s - 2.0 * dt..=c.grid_end_s(dt) + 2.0 * dt;
            if c.result.is_none() && span.contains(&t) {
                if let Err(e) = c.rudder.push(t, rudder_rad) {
                    c.result = Some(Err(format!("rudder: {e}")));
                }
            }
        }
        let env = self.envelope(t);
        self.sizing.on_rudder(t, rudder_rad, env);
        if self.recording(t) {
            self.rudder.push(t, rudder_rad)?;
        }
        Ok(())
    }

    /// The excitation at ship time `t` [rad]: the servo check, then the multisine with its
    /// fade-in envelope.
    fn excitation(&self, t: f64) -> f64 {
        let tr = t - self.t0_s;
        if let Some(c) = &self.check {
            if tr < c.duration_s {
                return c.value(tr);
            }
        }
        self.envelope(t) * self.multisine.value_weighted(tr, &self.sizing.scales(t))
    }

    /// The multisine's fade-in envelope at ship time `t` (0 before it starts, 1 after).
    fn envelope(&self, t: f64) -> f64 {
        let tm = t - self.t0_s - self.multisine_start_s;
        if tm < 0.0 {
            0.0
        } else if self.fade_s > 0.0 && tm < self.fade_s {
            0.5 * (1.0 - (PI * tm / self.fade_s).cos())
        } else {
            1.0
        }
    }

    /// Measures the servo check once the rudder record covers its periods (or once it can no
    /// longer: a gap).
    fn update_check(&mut self, t: f64) {
        let (dt, t0, max_gap_s) = (self.dt_s, self.t0_s, self.max_gap_s);
        let Some(c) = &mut self.check else { return };
        if c.result.is_some() {
            return;
        }
        let end = c.grid_end_s(dt);
        let covered = c.rudder.last_t().is_some_and(|tl| tl >= end);
        if covered || t > end + max_gap_s + dt {
            let [d, h, e] = &mut self.scratch;
            c.result = Some(c.measure(t0, dt, max_gap_s, [d, h, e]));
        }
    }

    /// A heading sample (`continuous_rad`: unwrapped heading; `error_rad`: the heading error
    /// against the test's course, for the tones' size).
    pub(crate) fn on_heading(&mut self, t: f64, continuous_rad: f64, error_rad: f64) -> Step {
        if let Some(result) = &self.result {
            // Ramp the excitation down at the rate limit, then report.
            let (v, tp) = self.ramp;
            let dv = self.ramp_rate_rad_s * (t - tp).max(0.0);
            let v = if v.abs() <= dv {
                0.0
            } else {
                v - dv * v.signum()
            };
            self.ramp = (v, t);
            if v == 0.0 {
                return Step {
                    mode: ExcitationMode::None,
                    value: 0.0,
                    phase: None,
                    done: Some(result.clone()),
                };
            }
            return Step {
                mode: ExcitationMode::Add,
                value: v,
                phase: None,
                done: None,
            };
        }
        if self.recording(t) {
            if let Err(e) = self.heading.push(t, continuous_rad) {
                return Step {
                    mode: ExcitationMode::None,
                    value: 0.0,
                    phase: None,
                    done: Some(Err(AbortReason::Record(e))),
                };
            }
        }
        if let Some(c) = &mut self.check {
            let dt = self.dt_s;
            let span = c.measure_start_s - 2.0 * dt..=c.grid_end_s(dt) + 2.0 * dt;
            if c.result.is_none() && span.contains(&t) {
                if let Err(e) = c.heading.push(t, continuous_rad) {
                    c.result = Some(Err(format!("heading: {e}")));
                }
            }
        }
        self.update_check(t);
        self.sizing.on_heading(t, error_rad);
        let value = self.excitation(t);
        let mut phase = if t >= self.measure_start_s {
            Some(MonitorState::Exciting)
        } else {
            Some(MonitorState::Settling)
        };
        // Analyse once both records cover the measurement (the rudder may lag the heading).
        let covered = |r: &Record, end: f64| r.last_t().is_some_and(|tl| tl >= end);
        let grid_end = self.measure_end_s - self.dt_s;
        if t >= self.measure_end_s
            && covered(&self.heading, grid_end)
            && covered(&self.rudder, grid_end)
        {
            self.result = Some(self.analyse());
            self.ramp = (value, t);
            phase = Some(MonitorState::Analysing);
        }
        Step {
            mode: ExcitationMode::Add,
            value,
            phase,
            done: None,
        }
    }

    fn analyse(&mut self) -> Result<Measured, AbortReason> {
        let n = self.window_samples * self.windows as usize;
        self.analysed = true;
        let [h, d, r] = &mut self.scratch;
        let t0 = self.measure_start_s;
        self.heading
            .resample(t0, self.dt_s, n, self.max_gap_s, h)
            .map_err(|e| AbortReason::Analysis(format!("heading: {e}")))?;
        self.rudder
            .resample(t0, self.dt_s, n, self.max_gap_s, d)
            .map_err(|e| AbortReason::Analysis(format!("rudder: {e}")))?;
        // The sizing ends before the measurement: one size per tone over it.
        let scales = self.sizing.scales(t0);
        r.clear();
        r.extend((0..n).map(|i| {
            self.multisine
                .value_weighted(t0 + i as f64 * self.dt_s - self.t0_s, &scales)
        }));
        let (band, spectrum, wscratch) = &mut self.wave;
        let wave_yaw_rad = band_rms(h, self.dt_s, *band, spectrum, wscratch).ok();
        let tones = analyse_tones(
            &mut self.analyser,
            h,
            d,
            r,
            self.dt_s,
            self.window_samples,
            &self.harmonics,
        )
        .map_err(|e| AbortReason::Analysis(e.to_string()))?;
        let (bcfg, ship) = &self.baseline;
        let baseline = baseline::estimate(h, d, self.dt_s, bcfg, ship);
        Ok(Measured::Clfrt(ClfrtReport {
            tones,
            window_s: self.window_s,
            windows: self.windows,
            amplitude_rad: self.amplitude_rad,
            crest_factor: self.multisine.crest_factor(),
            servo_check: self.check.as_ref().map(|c| ServoCheck {
                omega_rad_s: c.omega_rad_s,
                amplitude_rad: c.amplitude_rad,
                periods: c.periods,
                result: c
                    .result
                    .clone()
                    .unwrap_or_else(|| Err("not measured before the analysis".into())),
            }),
            baseline,
            wave_yaw_rad,
            amplitude_scales: self
                .sizing
                .resized()
                .then(|| scales[..self.harmonics.len().min(MAX_TONES)].to_vec()),
        }))
    }
}
