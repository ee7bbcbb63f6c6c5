//! HBT run: the relay test (harmonic balance), as a step function of heading samples.
//!
//! The relay replaces the autopilot: `rudder command = delta0 + h sign(e)` with hysteresis:
//! the sign changes only when the heading error `e = target - heading` passes `+eps` (to
//! `+h`, starboard) or `-eps` (to `-h`). `delta0` is the trim rudder, the mean rudder over
//! `hbt.trim-window-s` of autopilot steering before the relay starts. The hysteresis must
//! exceed the wave yaw on the heading, or the relay chatters at wave frequency.
//!
//! An ideal relay on `b / (s (s + a))` has no finite-frequency limit cycle; the hysteresis and
//! the servo's lag and rate limit give one, of period P_u and heading amplitude a_u
//! (describing function: `N(A) = 4h / (pi A) exp(-i asin(eps / A))`). The period is measured
//! from the relay's switching instants (interpolated crossings of `+eps`; the zero crossings
//! of a noisy heading would be useless), the amplitude as the first-harmonic Fourier integral
//! of the detrended heading over the measured whole periods ([`crate::dsp::relay`]).
//!
//! Settling: `hbt.settle-periods` periods after the first switch to `+h`; measuring: the
//! next `hbt.measure-periods` periods. No limit cycle within `hbt.timeout-s`: abort.
//!
//! Sizing (`hbt.resize-*`, [`super::sizing::RelaySizing`]): at the relay's
//! `hbt.resize-at-switch`-th switch, a Nomoto fit of the record so far and the describing
//! function predict the cycle's peak heading error; past `hbt.resize-heading-fraction` of
//! `safety.max-heading-error-deg`, h and eps are scaled by the same `s < 1` from that switch
//! on (same period, amplitude times `s`) and the settling starts again; past the limit
//! itself even at the smallest hysteresis the wave yaw allows, the test aborts
//! (`relay_too_large`). Before the relay starts, h and eps are scaled up by `s > 1` where the
//! sea's wave yaw (the vessel's last completed test's) needs a larger hysteresis, within
//! `safety.max-excitation-deg`. The report carries `relay_scale` and the relay as played.
//!
//! Relay-centre adaptation (`hbt.bias-adaptation`): at each switch to `+h` the centre moves
//! towards the mean rudder of the period just ended, `delta0 += g h (t+ - t-) / P`. When the
//! heading reading drifts, the relay can only keep its error bounded by making the ship turn
//! with the drift, which needs a mean rudder off delta0: a fixed centre buys it with an
//! asymmetric duty cycle that changes the period and amplitude; an adapted centre supplies it
//! and the cycle, by superposition on the linear ship, is the drift-free one.
//!
//! Response: over the same measured periods, the first harmonics at `omega_u` of the heading
//! and of the measured rudder ([`crate::dsp::relay::first_harmonic`]) give the ship's
//! `G(i omega_u)` (`response_gain`, `response_phase_rad`), servo and relay excluded. The
//! rudder stream may end a sample before the last switch: its last value is held for at most
//! `safety.stream-timeout-s` (the gap the records interpolate across); without a rudder
//! record over the periods the response is left out (and the estimator, which reads it,
//! gives no estimate).
//!
//! Baseline: the rudder is recorded from the relay's start too, and the heading and rudder on
//! the analysis grid (the measured periods) feed the time-domain baseline
//! ([`crate::baseline`]) over the span both records cover; its failure is reported, never an
//! abort.
//!
//! Chatter (two switches closer than `hbt.min-switch-interval-s`: heading noise above the
//! hysteresis) aborts at once; a cycle not larger than the hysteresis is refused.
//!
//! Hand-back (`hbt.handback-lead-s` = tau): handing the rudder back to the autopilot mid-cycle
//! lets its PD term `Kp (e + Td de/dt)` see the full cycle: 24 deg of rudder at 7 m/s and the
//! 30 deg limit at 4 m/s (Kp 12.9) were measured. The measured cycle predicts when
//! `e + tau de/dt = 0` after the last switch to `+h` (`e = A sin(phi)`, through `+eps` at the
//! switch: `phi = pi - atan(tau w)`); the relay runs on to that instant, within the test's
//! duration budget, and hands back there. With tau = 30 s (the simulated autopilot's Td) the
//! swing after hand-back measured 7.7 deg at 7 m/s and 9-16 deg at 4 m/s (calm, moderate).

use super::record::{Record, RecordError};
use super::sizing::{RelayDecision, RelayPrediction, RelaySizing};
use super::{AbortReason, Measured, Step};
use crate::baseline::config::BaselineConfig;
use crate::baseline::{self, BaselineError, BaselineEstimate};
use crate::dsp::relay::{analyse_limit_cycle, first_harmonic, LimitCycle};
use crate::dsp::spectrum::{band_rms, Spectrum};
use crate::model::{ServoConfig, ShipConfig};
use crate::monitor::config::CoreConfig;
use crate::wire::features::{HbtFeatures, ServoRateFeatures};
use crate::wire::{ExcitationMode, MonitorState};
use rustfft::num_complex::Complex64;

/// Features of a completed relay test (the report's `features`).
#[derive(Debug, Clone, PartialEq)]
pub struct HbtReport {
    /// Period, frequency and amplitude of the limit cycle.
    pub cycle: LimitCycle,
    /// Ultimate gain with hysteresis, `K_u = 4 h / (pi sqrt(a^2 - eps^2))` [1/rad * rad].
    pub ultimate_gain: f64,
    /// Relay height h [rad].
    pub relay_height_rad: f64,
    /// Hysteresis eps [rad].
    pub hysteresis_rad: f64,
    /// Relay centre at the end of the test (adapted) [rad].
    pub trim_rad: f64,
    /// Trim rudder delta0 measured before the relay started [rad].
    pub initial_trim_rad: f64,
    /// Shortest time between two consecutive relay switches [s] (chatter check).
    pub min_switch_interval_s: f64,
    /// Relay switches in the whole test.
    pub switches: usize,
    /// The time-domain baseline on the measured periods, or why it failed.
    pub baseline: Result<BaselineEstimate, BaselineError>,
    /// Wave yaw: rms of the heading in `calibration.wave-band-rad-s` over the measured periods [rad]
    /// ([`crate::dsp::band_rms`]; none when it could not be computed).
    pub wave_yaw_rad: Option<f64>,
    /// First harmonics at `omega_u` over the measured periods of the heading and of the
    /// measured rudder [rad] (none when the rudder record does not cover them): their ratio
    /// is the ship's own response `G(i omega_u)`, servo and relay excluded.
    pub response: Option<(Complex64, Complex64)>,
    /// The servo's slew rate: the median over the measured periods of each period's largest
    /// rudder rate, and the healthy servo's rate limit [rad/s] (none when not measurable).
    pub servo_rate: Option<(f64, f64)>,
    /// The scale of h and eps against the design when the sizing changed the relay (none as
    /// designed): below 1 sized to the loop, above 1 to the sea.
    pub relay_scale: Option<f64>,
    /// What the sizing predicted at its look (none when it did not look or could not
    /// predict).
    pub prediction: Option<RelayPrediction>,
}

impl HbtReport {
    /// The report's `features` (without `speed_log_mps`, which the monitor adds).
    pub fn to_features(&self) -> HbtFeatures {
        let (baseline, baseline_error) = baseline::to_features(&self.baseline);
        let response = self.response.map(|(x1, d1)| {
            let g = x1 / d1;
            // Phase in (-2 pi, 0] (the dsp convention: no wrap near -180 deg).
            let mut phase = g.arg();
            if phase > 0.0 {
                phase -= 2.0 * std::f64::consts::PI;
            }
            (d1.norm(), g.norm(), phase)
        });
        HbtFeatures {
            period_s: self.cycle.period_s,
            omega_u_rad_s: self.cycle.omega_u_rad_s,
            amplitude_rad: self.cycle.amplitude_rad,
            periods: self.cycle.periods,
            period_std_s: self.cycle.period_std_s,
            ultimate_gain: self.ultimate_gain,
            relay_height_rad: self.relay_height_rad,
            hysteresis_rad: self.hysteresis_rad,
            trim_rad: self.trim_rad,
            initial_trim_rad: self.initial_trim_rad,
            min_switch_interval_s: self.min_switch_interval_s,
            switches: self.switches,
            wave_yaw_rad: self.wave_yaw_rad,
            rudder_amplitude_rad: response.map(|r| r.0),
            response_gain: response.map(|r| r.1),
            response_phase_rad: response.map(|r| r.2),
            servo_rate: self.servo_rate.map(|(peak, nominal)| ServoRateFeatures {
                rudder_rate_peak_rad_s: peak,
                rudder_rate_nominal_rad_s: nominal,
            }),
            relay_scale: self.relay_scale,
            relay_omega_ratio: self.relay_scale.and(self.prediction).map(|p| p.ratios().0),
            relay_amplitude_ratio: self.relay_scale.and(self.prediction).map(|p| p.ratios().1),
            speed_log_mps: None,
            baseline,
            baseline_error,
        }
    }
}

/// State of one relay test.
#[derive(Debug, Clone)]
pub(crate) struct HbtRun {
    /// Relay height [rad].
    h_rad: f64,
    /// Hysteresis [rad].
    eps_rad: f64,
    settle_periods: usize,
    measure_periods: usize,
    timeout_s: f64,
    /// Chatter limit [s].
    min_switch_interval_s: f64,
    /// Relay-centre adaptation gain per period.
    bias_adaptation: f64,
    /// Hand-back lead tau [s] (0: hand back at once).
    handback_lead_s: f64,
    /// The last moment the relay may run (test-duration budget) [s].
    deadline_s: f64,
    /// Once measured: the features (or why not) and the hand-back instant [s].
    result: Option<(Result<Measured, AbortReason>, f64)>,
    /// Instant of the last switch to `-h` [s].
    last_down_s: Option<f64>,
    /// The trim measured before the relay started [rad].
    initial_trim_rad: f64,
    /// Grid step for the analysis [s].
    dt_s: f64,
    /// Largest gap interpolated across [s].
    max_gap_s: f64,
    /// End of the trim measurement [s].
    trim_end_s: f64,
    /// Sum and count of rudder samples in the trim window.
    trim_sum: f64,
    trim_n: u64,
    /// delta0 once measured [rad].
    trim_rad: Option<f64>,
    /// Start of the relay [s].
    relay_start_s: Option<f64>,
    /// Current relay side, +1 or -1.
    sign: f64,
    /// Previous heading error sample `(t, e)`.
    prev: Option<(f64, f64)>,
    /// Interpolated instants of the switches to `+h` [s].
    up_switches: Vec<f64>,
    /// Instant of the last switch, either direction [s].
    last_switch_s: Option<f64>,
    /// Shortest interval between two switches so far [s].
    shortest_switch_s: f64,
    switches: usize,
    /// Continuous heading from the relay start [rad].
    heading: Record,
    /// Rudder from the relay start [rad] (for the baseline).
    rudder: Record,
    /// Resampled heading and rudder.
    scratch: [Vec<f64>; 2],
    /// First time of the analysis grid, once analysed [s] (the grid of `scratch`).
    grid_t0_s: Option<f64>,
    /// Wave-yaw band [rad/s], its transform and scratch.
    wave: ((f64, f64), Spectrum, Vec<f64>),
    /// The baseline's filter and the ship that turns its a and b into speed and displacement.
    baseline: (BaselineConfig, ShipConfig),
    /// The healthy servo's slew rate [rad/s], when the relay's step saturates it for longer
    /// than the rate fit's window; and the slopes' scratch.
    servo_rate: (Option<f64>, Vec<f64>),
    /// The relay's sizing, the scale it chose (1: as designed) and its prediction.
    sizing: RelaySizing,
    scale: f64,
    prediction: Option<RelayPrediction>,
    /// The relay as designed `(h, eps)` [rad], and the largest `h` the excitation's safety
    /// limit allows [rad].
    design: (f64, f64),
    max_h_rad: f64,
    /// The sea's wave yaw on the heading as the vessel's last completed test measured it
    /// [rad] (none: not known), for the relay's size.
    sea_wave_yaw_rad: Option<f64>,
    /// The servo, for the healthy slew rate after a resize.
    servo_cfg: (ServoConfig, f64),
    /// The speed log at the test's start [m/s] (none without one), for the sizing.
    speed_mps: Option<f64>,
}

impl HbtRun {
    /// A relay test starting at `t_start_s`, the speed log reading `speed_mps` (none: no
    /// speed log), in a sea whose wave yaw on the heading the vessel's last completed test
    /// measured as `sea_wave_yaw_rad` (none: not known; the relay starts as designed).
    pub(crate) fn new(
        cfg: &CoreConfig,
        t_start_s: f64,
        speed_mps: Option<f64>,
        sea_wave_yaw_rad: Option<f64>,
    ) -> Self {
        let h = &cfg.hbt;
        let rate = cfg.sensors.rate_hz;
        let capacity = ((h.timeout_s + 60.0) * rate * 2.0).ceil() as usize;
        Self {
            h_rad: h.relay_height_rad(),
            eps_rad: h.hysteresis_rad(),
            settle_periods: h.settle_periods as usize,
            measure_periods: h.measure_periods as usize,
            timeout_s: h.timeout_s,
            min_switch_interval_s: h.min_switch_interval_s,
            bias_adaptation: h.bias_adaptation,
            handback_lead_s: h.handback_lead_s,
            deadline_s: t_start_s + cfg.safety.max_test_duration_s - 2.0 / rate,
            result: None,
            last_down_s: None,
            initial_trim_rad: 0.0,
            dt_s: 1.0 / rate,
            max_gap_s: cfg.safety.stream_timeout_s,
            trim_end_s: t_start_s + h.trim_window_s,
            trim_sum: 0.0,
            trim_n: 0,
            trim_rad: None,
            relay_start_s: None,
            sign: 1.0,
            prev: None,
            up_switches: Vec::with_capacity((h.settle_periods + h.measure_periods + 2) as usize),
            last_switch_s: None,
            shortest_switch_s: f64::INFINITY,
            switches: 0,
            heading: Record::with_capacity(capacity),
            rudder: Record::with_capacity(capacity),
            scratch: [Vec::new(), Vec::new()],
            grid_t0_s: None,
            wave: (
                (
                    cfg.calibration.wave_band_rad_s[0],
                    cfg.calibration.wave_band_rad_s[1],
                ),
                Spectrum::new(),
                Vec::new(),
            ),
            baseline: (cfg.baseline.clone(), cfg.ship.clone()),
            servo_rate: (
                nominal_slew_rad_s(&cfg.servo, cfg.sensors.rate_hz, h.relay_height_rad()),
                Vec::new(),
            ),
            sizing: RelaySizing::new(cfg),
            scale: 1.0,
            prediction: None,
            design: (h.relay_height_rad(), h.hysteresis_rad()),
            max_h_rad: cfg.safety.max_excitation_deg.to_radians(),
            sea_wave_yaw_rad,
            servo_cfg: (cfg.servo.clone(), cfg.sensors.rate_hz),
            speed_mps,
        }
    }

    /// After the analysis: its grid `(t0, dt)` and the resampled continuous heading and rudder
    /// it used (the rudder may be shorter: the span both records cover).
    pub(crate) fn analysis_series(&self) -> Option<(f64, f64, &[f64], &[f64])> {
        let t0 = self.grid_t0_s?;
        let [h, d] = &self.scratch;
        Some((t0, self.dt_s, h, d))
    }

    /// The trim the relay is centred on (0 before it is measured) [rad].
    pub(crate) fn trim_rad(&self) -> f64 {
        self.trim_rad.unwrap_or(0.0)
    }

    /// A rudder sample: accumulates the trim during the trim window, then is recorded (with
    /// two samples of margin before the relay starts) until the analysis.
    pub(crate) fn push_rudder(&mut self, t: f64, rudder_rad: f64) -> Result<(), RecordError> {
        if t < self.trim_end_s {
            self.trim_sum += rudder_rad;
            self.trim_n += 1;
        }
        if self.result.is_none() && t >= self.trim_end_s - 2.0 * self.dt_s {
            self.rudder.push(t, rudder_rad)?;
        }
        Ok(())
    }

    /// A heading sample: `continuous_rad` the unwrapped heading, `error_rad` target - heading.
    pub(crate) fn on_heading(&mut self, t: f64, continuous_rad: f64, error_rad: f64) -> Step {
        let idle = |phase| Step {
            mode: ExcitationMode::None,
            value: 0.0,
            phase,
            done: None,
        };
        if t < self.trim_end_s {
            return idle(None);
        }
        let trim = match self.trim_rad {
            Some(x) => x,
            None => {
                if self.trim_n == 0 {
                    return Step {
                        done: Some(Err(AbortReason::NoTrimRudder)),
                        ..idle(None)
                    };
                }
                let x = self.trim_sum / self.trim_n as f64;
                self.trim_rad = Some(x);
                self.initial_trim_rad = x;
                self.relay_start_s = Some(t);
                self.sign = if error_rad >= 0.0 { 1.0 } else { -1.0 };
                let scale = self
                    .sizing
                    .for_sea(self.sea_wave_yaw_rad, self.design, self.max_h_rad);
                if scale > 1.0 {
                    self.play_at(scale);
                }
                x
            }
        };
        let relay_start = self.relay_start_s.unwrap_or(t);
        if let Err(e) = self.heading.push(t, continuous_rad) {
            return Step {
                done: Some(Err(AbortReason::Record(e))),
                ..idle(None)
            };
        }

        // Relay with hysteresis; switching instants interpolated at the threshold crossing.
        let new_sign = if error_rad > self.eps_rad {
            1.0
        } else if error_rad < -self.eps_rad {
            -1.0
        } else {
            self.sign
        };
        let mut phase = None;
        if new_sign != self.sign {
            let threshold = new_sign * self.eps_rad;
            let t_switch = match self.prev {
                Some((tp, ep)) if error_rad != ep => {
                    let w = ((threshold - ep) / (error_rad - ep)).clamp(0.0, 1.0);
                    tp + w * (t - tp)
                }
                _ => t,
            };
            if let Some(last) = self.last_switch_s {
                let interval = t_switch - last;
                self.shortest_switch_s = self.shortest_switch_s.min(interval);
                if interval < self.min_switch_interval_s {
                    return Step {
                        done: Some(Err(AbortReason::RelayChatter {
                            interval_s: interval,
                            hysteresis_deg: self.eps_rad.to_degrees(),
                        })),
                        ..idle(None)
                    };
                }
            }
            self.last_switch_s = Some(t_switch);
            self.switches += 1;
            self.sign = new_sign;
            if new_sign < 0.0 {
                self.last_down_s = Some(t_switch);
            }
            if self.sizing.looks_at(self.switches) && self.up_switches.len() <= self.settle_periods
            {
                if let Err(reason) = self.size(t) {
                    return Step {
                        done: Some(Err(reason)),
                        ..idle(None)
                    };
                }
            }
            if new_sign > 0.0 {
                // A full period ended: centre the relay on its mean rudder.
                if let (Some(&up), Some(down)) = (self.up_switches.last(), self.last_down_s) {
                    let period = t_switch - up;
                    if down > up && period > 0.0 {
                        let t_plus = down - up;
                        let asym = (2.0 * t_plus - period) / period;
                        let centre = trim + self.bias_adaptation * self.h_rad * asym;
                        self.trim_rad = Some(centre);
                    }
                }
                self.up_switches.push(t_switch);
                if self.up_switches.len() == self.settle_periods + 1 {
                    phase = Some(MonitorState::Exciting);
                }
            }
        }
        self.prev = Some((t, error_rad));

        // Analyse once the last measured switch lies two samples inside the record, so the
        // uniform analysis grid (which ends at or before the latest sample) covers it.
        let needed = self.settle_periods + self.measure_periods + 1;
        let covered = self
            .up_switches
            .get(needed - 1)
            .is_some_and(|&ts| t >= ts + 2.0 * self.dt_s);
        if covered && self.result.is_none() {
            let features = self.analyse(t, self.trim_rad());
            let handback_s = match &features {
                Ok(Measured::Hbt(f)) if self.handback_lead_s > 0.0 => {
                    let last_up = self.up_switches[needed - 1];
                    handback_instant(
                        last_up,
                        f.cycle.period_s,
                        f.cycle.amplitude_rad,
                        self.eps_rad,
                        self.handback_lead_s,
                    )
                    .min(self.deadline_s)
                }
                _ => t,
            };
            self.result = Some((features, handback_s));
            phase = Some(MonitorState::Analysing);
        }
        if let Some((result, handback_s)) = &self.result {
            if t >= *handback_s {
                return Step {
                    mode: ExcitationMode::None,
                    value: 0.0,
                    phase,
                    done: Some(result.clone()),
                };
            }
        } else if t - relay_start > self.timeout_s {
            return Step {
                done: Some(Err(AbortReason::NoLimitCycle {
                    timeout_s: self.timeout_s,
                    up_switches: self.up_switches.len(),
                })),
                ..idle(None)
            };
        }
        Step {
            mode: ExcitationMode::Replace,
            value: self.trim_rad() + self.sign * self.h_rad,
            phase,
            done: None,
        }
    }

    /// The sizing's look at ship time `t` (a switch): on the heading and rudder since the
    /// relay started, it may scale h and eps (from this switch on; the settling starts
    /// again) or abort. A record or a prediction that fails leaves the relay as designed.
    fn size(&mut self, t: f64) -> Result<(), AbortReason> {
        let Some(t0) = self.relay_start_s else {
            return Ok(());
        };
        let n_rudder = match self.rudder.last_t() {
            Some(tl) if tl >= t0 => ((tl - t0) / self.dt_s).floor() as usize + 1,
            _ => 0,
        };
        let n = (((t - t0) / self.dt_s).floor() as usize + 1).min(n_rudder);
        let [h, d] = &mut self.scratch;
        let resampled = self
            .heading
            .resample(t0, self.dt_s, n, self.max_gap_s, h)
            .and_then(|()| self.rudder.resample(t0, self.dt_s, n, self.max_gap_s, d));
        if resampled.is_err() {
            return Ok(());
        }
        match self.sizing.decide(
            h,
            d,
            self.dt_s,
            self.speed_mps,
            self.design,
            self.scale,
            self.sea_wave_yaw_rad,
        ) {
            Ok(RelayDecision::Abort(reason)) => Err(reason),
            Ok(RelayDecision::Play(p)) => {
                self.prediction = Some(p);
                if p.scale < self.scale {
                    self.play_at(p.scale);
                    // The settling starts again: periods count from the next switch to +h.
                    self.up_switches.clear();
                    self.last_down_s = None;
                }
                Ok(())
            }
            Err(_) => Ok(()),
        }
    }

    /// Plays the designed relay at `scale`: `h` and `eps` both (homogeneity), and the servo
    /// check's healthy slew for the new step.
    fn play_at(&mut self, scale: f64) {
        self.scale = scale;
        self.h_rad = self.design.0 * scale;
        self.eps_rad = self.design.1 * scale;
        let (servo, rate) = &self.servo_cfg;
        self.servo_rate.0 = nominal_slew_rad_s(servo, *rate, self.h_rad);
    }

    fn analyse(&mut self, t_now: f64, trim: f64) -> Result<Measured, AbortReason> {
        let needed = self.settle_periods + self.measure_periods + 1;
        let measured = &self.up_switches[self.settle_periods..needed];
        let first = measured.first().copied().unwrap_or(t_now);
        let t0 = (first - 2.0 * self.dt_s).max(self.relay_start_s.unwrap_or(first));
        let n = ((t_now - t0) / self.dt_s).floor() as usize + 1;
        self.grid_t0_s = Some(t0);
        let [h, d] = &mut self.scratch;
        self.heading
            .resample(t0, self.dt_s, n, self.max_gap_s, h)
            .map_err(|e| AbortReason::Analysis(e.to_string()))?;
        let cycle = analyse_limit_cycle(t0, self.dt_s, h, measured)
            .map_err(|e| AbortReason::Analysis(e.to_string()))?;
        let (band, spectrum, wscratch) = &mut self.wave;
        let wave_yaw_rad = band_rms(h, self.dt_s, *band, spectrum, wscratch).ok();
        // The baseline over the span both records cover (the rudder may lag the heading).
        let n_rudder = match self.rudder.last_t() {
            Some(tl) if tl >= t0 => ((tl - t0) / self.dt_s).floor() as usize + 1,
            _ => 0,
        };
        let n_both = n.min(n_rudder);
        let (bcfg, ship) = &self.baseline;
        let resampled = self
            .rudder
            .resample(t0, self.dt_s, n_both, self.max_gap_s, d);
        let baseline = resampled
            .as_ref()
            .map_err(|e| BaselineError::Record(e.to_string()))
            .and_then(|()| baseline::estimate(&h[..n_both], d, self.dt_s, bcfg, ship));
        // The ship's response at omega_u: heading over rudder, first harmonics over the same
        // whole periods (the heading's from the cycle analysis). The rudder stream may end a sample or two before the last switch
        // (the streams arrive apart): its last value is held up to `max_gap_s`.
        let (s0, sn) = (first, measured.last().copied().unwrap_or(first));
        let response = resampled.ok().and_then(|()| {
            let last = *d.last()?;
            if (n - n_both) as f64 * self.dt_s > self.max_gap_s {
                return None;
            }
            d.resize(n, last);
            let d1 = first_harmonic(t0, self.dt_s, d, s0, sn, cycle.omega_u_rad_s).ok()?;
            (d1.norm() > 0.0).then_some((cycle.harmonic_rad, d1))
        });
        let servo_rate = match (&mut self.servo_rate, response.is_some()) {
            ((Some(nominal), slopes), true) => {
                slew_peak(d, t0, self.dt_s, measured, slopes).map(|p| (p, *nominal))
            }
            _ => None,
        };
        let a = cycle.amplitude_rad;
        if a <= self.eps_rad {
            // A limit cycle through the hysteresis band cannot be smaller than the band.
            return Err(AbortReason::ImplausibleLimitCycle {
                amplitude_deg: a.to_degrees(),
                hysteresis_deg: self.eps_rad.to_degrees(),
            });
        }
        let ultimate_gain = 4.0 * self.h_rad
            / (std::f64::consts::PI * (a * a - self.eps_rad * self.eps_rad).sqrt());
        Ok(Measured::Hbt(HbtReport {
            cycle,
            ultimate_gain,
            relay_height_rad: self.h_rad,
            hysteresis_rad: self.eps_rad,
            trim_rad: trim,
            initial_trim_rad: self.initial_trim_rad,
            min_switch_interval_s: self.shortest_switch_s,
            switches: self.switches,
            baseline,
            wave_yaw_rad,
            response,
            servo_rate,
            relay_scale: (self.scale != 1.0).then_some(self.scale),
            prediction: self.prediction,
        }))
    }
}

/// The healthy servo's slew rate as the rate fit reads it: the relay's step `2 h` (as played)
/// drives the servo at its rate limit `R` while `|cmd - delta| > R T_r`, a ramp of `(2 h - R T_r) / R`
/// seconds; when that ramp outlasts the fit's window the fit reads `R` exactly. `None`
/// otherwise (a relay too small to saturate the servo: no slew to measure).
fn nominal_slew_rad_s(servo: &ServoConfig, rate_hz: f64, h_rad: f64) -> Option<f64> {
    let r = servo.max_rate_rad_s();
    let ramp_s = (2.0 * h_rad - r * servo.time_constant_s) / r;
    let window_s = 2.0 * crate::dsp::RATE_HALF_WIDTH as f64 / rate_hz;
    (ramp_s >= 1.5 * window_s).then_some(r)
}

/// The median over the measured periods (`switches[k] .. switches[k + 1]`) of each period's
/// largest rudder rate ([`crate::dsp::abs_slopes`] on `d`, sampled from `t0` every `dt`): each
/// period holds two full slews of the servo, so a healthy one reads its rate limit, a slower
/// one less. `None` without a whole period inside the record.
fn slew_peak(d: &[f64], t0: f64, dt: f64, switches: &[f64], slopes: &mut Vec<f64>) -> Option<f64> {
    crate::dsp::abs_slopes(d, dt, slopes);
    let hw = crate::dsp::RATE_HALF_WIDTH as f64;
    let mut peaks: Vec<f64> = switches
        .windows(2)
        .filter_map(|w| {
            // Slopes centred in [w0, w1): slope j is centred on sample j + hw.
            let lo = ((w[0] - t0) / dt - hw).ceil().max(0.0) as usize;
            let hi = (((w[1] - t0) / dt - hw).ceil().max(0.0) as usize).min(slopes.len());
            slopes
                .get(lo..hi)
                .filter(|s| !s.is_empty())
                .map(|s| s.iter().copied().fold(0.0, f64::max))
        })
        .collect();
    if peaks.is_empty() {
        return None;
    }
    peaks.sort_by(f64::total_cmp);
    let m = peaks.len();
    Some(if m % 2 == 1 {
        peaks[m / 2]
    } else {
        0.5 * (peaks[m / 2 - 1] + peaks[m / 2])
    })
}

/// The instant after a switch to `+h` at `t_up_s` where the heading error of the cycle
/// (period `period_s`, amplitude `amp_rad`, through `+eps` rising at the switch) satisfies
/// `e + tau de/dt = 0` on its way down: with `e = A sin(phi)`, `phi = asin(eps / A)` at the
/// switch, the zero is at `phi = pi - atan(tau w)`.
fn handback_instant(t_up_s: f64, period_s: f64, amp_rad: f64, eps_rad: f64, tau_s: f64) -> f64 {
    let w = 2.0 * std::f64::consts::PI / period_s;
    let phi0 = (eps_rad / amp_rad).clamp(-1.0, 1.0).asin();
    let phi = std::f64::consts::PI - (tau_s * w).atan();
    t_up_s + (phi - phi0).max(0.0) / w
}

#[cfg(test)]
#[path = "hbt_tests.rs"]
mod tests;
