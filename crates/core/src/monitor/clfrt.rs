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
//!   periods; see [`servo_check`] (`clfrt_servo_check.rs`).
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

use super::record::{Record, RecordError};
use super::sizing::{ToneSizing, MAX_TONES};
use super::{AbortReason, Measured, Step};
use crate::baseline::config::BaselineConfig;
use crate::baseline::{self, BaselineError, BaselineEstimate};
use crate::dsp::multisine::Multisine;
use crate::dsp::spectrum::{band_rms, Spectrum};
use crate::dsp::tones::{analyse_tones, ToneAnalyser, ToneEstimate};
use crate::model::ShipConfig;
use crate::monitor::config::CoreConfig;
use crate::wire::features::ClfrtFeatures;
use crate::wire::{ExcitationMode, MonitorState};
use servo_check::{ServoCheck, ServoCheckRun};
use std::f64::consts::PI;

#[path = "clfrt_servo_check.rs"]
mod servo_check;

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
        let check = ServoCheckRun::new(cfg, t_start_s);
        let multisine_start_s = check.as_ref().map_or(0.0, ServoCheckRun::duration_s);
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
        if let Some(c) = &mut self.check {
            c.push_rudder(t, rudder_rad, self.dt_s);
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
            if tr < c.duration_s() {
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
        if let Some(c) = &mut self.check {
            let [d, h, e] = &mut self.scratch;
            c.update(t, t0, dt, max_gap_s, [d, h, e]);
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
            c.push_heading(t, continuous_rad, self.dt_s);
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
            servo_check: self.check.as_ref().map(ServoCheckRun::report),
            baseline,
            wave_yaw_rad,
            amplitude_scales: self
                .sizing
                .resized()
                .then(|| scales[..self.harmonics.len().min(MAX_TONES)].to_vec()),
        }))
    }
}
