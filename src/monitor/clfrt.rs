//! CLFRT run: the closed-loop multisine test, as a step function of heading samples.
//!
//! A multisine `r(t) = sum_i A sin(w_i t + phi_i)` (paper eq. 8-9), tones on the FFT grid of
//! the window T_w (`w_i = 2 pi k_i / T_w`), is added to the autopilot's rudder command
//! (`mode: add`). Its phase origin is the test start `t0`.
//!
//! - Settling: `clfrt.settle-windows` windows; the amplitude fades in over `clfrt.fade-s` with
//!   a raised cosine (ArduPilot SystemID style) so the rudder sees no step.
//! - Exciting: `clfrt.measure-windows` windows at full amplitude; heading and rudder recorded.
//! - Analysing: heading and rudder are resampled onto the uniform grid of the measurement
//!   (alignment by `t`), the reference is the multisine itself on that grid, and the gain and
//!   phase of heading/rudder at each tone are estimated against the reference
//!   ([`crate::dsp::tones`]). The same grids feed the time-domain baseline
//!   ([`crate::baseline`]), whose failure is reported, never an abort. Meanwhile the excitation ramps to zero at the safety rate limit;
//!   the report follows when it reaches zero.

use super::record::{Record, RecordError};
use super::{Features, Step};
use crate::baseline::{self, BaselineError, BaselineEstimate};
use crate::config::{BaselineConfig, Config, ShipConfig};
use crate::dsp::multisine::Multisine;
use crate::dsp::tones::{analyse_tones, ToneAnalyser, ToneEstimate};
use crate::wire::{ExcitationMode, MonitorState};

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
    /// The time-domain baseline on the measured windows, or why it failed.
    pub baseline: Result<BaselineEstimate, BaselineError>,
}

impl ClfrtReport {
    /// JSON of the report's `features`.
    pub fn to_json(&self) -> serde_json::Value {
        let tones: Vec<serde_json::Value> = self
            .tones
            .iter()
            .map(|t| {
                serde_json::json!({
                    "omega_rad_s": t.omega_rad_s,
                    "gain": t.gain,
                    "phase_rad": t.phase_rad,
                    "coherence": t.coherence,
                    "snr_db": t.snr_db,
                    "gain_ci90_rel": t.gain_ci90_rel,
                    "phase_ci90_rad": t.phase_ci90_rad,
                })
            })
            .collect();
        let mut v = serde_json::json!({
            "tones": tones,
            "window_s": self.window_s,
            "windows": self.windows,
            "amplitude_rad": self.amplitude_rad,
            "crest_factor": self.crest_factor,
        });
        if let Some(obj) = v.as_object_mut() {
            baseline::insert_json(obj, &self.baseline);
        }
        v
    }
}

/// State of one multisine test.
#[derive(Debug)]
pub(crate) struct ClfrtRun {
    multisine: Multisine,
    harmonics: Vec<u32>,
    window_s: f64,
    windows: u32,
    amplitude_rad: f64,
    /// Phase origin of the multisine [s].
    t0_s: f64,
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
    result: Option<Result<Features, String>>,
    ramp: (f64, f64),
    analyser: ToneAnalyser,
    scratch: [Vec<f64>; 3],
    /// The baseline's filter and the ship that turns its a and b into speed and displacement.
    baseline: (BaselineConfig, ShipConfig),
}

impl ClfrtRun {
    /// A multisine test starting at `t_start_s` with the designed `multisine`.
    pub(crate) fn new(cfg: &Config, t_start_s: f64, multisine: Multisine) -> Self {
        let c = &cfg.clfrt;
        let rate = cfg.sensors.rate_hz;
        let measure_start_s = t_start_s + c.settle_windows as f64 * c.window_s;
        let measure_s = c.measure_windows as f64 * c.window_s;
        // Records hold the measurement plus a margin, at up to twice the nominal rate.
        let capacity = ((measure_s + 60.0) * rate * 2.0).ceil() as usize;
        Self {
            multisine,
            harmonics: c.harmonics.clone(),
            window_s: c.window_s,
            windows: c.measure_windows,
            amplitude_rad: c.amplitude_rad(),
            t0_s: t_start_s,
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
            baseline: (cfg.baseline.clone(), cfg.ship.clone()),
        }
    }

    /// Whether samples at `t` are needed for the analysis.
    fn recording(&self, t: f64) -> bool {
        self.result.is_none() && t >= self.measure_start_s - 2.0 * self.dt_s
    }

    /// A rudder sample.
    pub(crate) fn push_rudder(&mut self, t: f64, rudder_rad: f64) -> Result<(), RecordError> {
        if self.recording(t) {
            self.rudder.push(t, rudder_rad)?;
        }
        Ok(())
    }

    /// The multisine with its fade-in envelope at ship time `t` [rad].
    fn excitation(&self, t: f64) -> f64 {
        let tr = t - self.t0_s;
        let env = if self.fade_s > 0.0 && tr < self.fade_s {
            0.5 * (1.0 - (std::f64::consts::PI * tr.max(0.0) / self.fade_s).cos())
        } else {
            1.0
        };
        env * self.multisine.value(tr)
    }

    /// A heading sample (`continuous_rad`: unwrapped heading).
    pub(crate) fn on_heading(&mut self, t: f64, continuous_rad: f64) -> Step {
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
                    done: Some(Err(e.to_string())),
                };
            }
        }
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

    fn analyse(&mut self) -> Result<Features, String> {
        let n = self.window_samples * self.windows as usize;
        let [h, d, r] = &mut self.scratch;
        let t0 = self.measure_start_s;
        self.heading
            .resample(t0, self.dt_s, n, self.max_gap_s, h)
            .map_err(|e| format!("analysis: heading: {e}"))?;
        self.rudder
            .resample(t0, self.dt_s, n, self.max_gap_s, d)
            .map_err(|e| format!("analysis: rudder: {e}"))?;
        r.clear();
        r.extend((0..n).map(|i| self.multisine.value(t0 + i as f64 * self.dt_s - self.t0_s)));
        let tones = analyse_tones(
            &mut self.analyser,
            h,
            d,
            r,
            self.dt_s,
            self.window_samples,
            &self.harmonics,
        )
        .map_err(|e| format!("analysis: {e}"))?;
        let (bcfg, ship) = &self.baseline;
        let baseline = baseline::estimate(h, d, self.dt_s, bcfg, ship);
        Ok(Features::Clfrt(ClfrtReport {
            tones,
            window_s: self.window_s,
            windows: self.windows,
            amplitude_rad: self.amplitude_rad,
            crest_factor: self.multisine.crest_factor(),
            baseline,
        }))
    }
}
