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
use crate::dsp::spectrum::Spectrum;
use crate::model::{ServoConfig, ShipConfig};
use crate::monitor::config::CoreConfig;
use crate::wire::{ExcitationMode, MonitorState};
use analysis::{handback_instant, nominal_slew_rad_s};

#[path = "hbt_analysis.rs"]
pub(super) mod analysis;

/// No excitation from the relay at this sample (before it starts), with `phase`.
fn idle(phase: Option<MonitorState>) -> Step {
    Step {
        mode: ExcitationMode::None,
        value: 0.0,
        phase,
        done: None,
    }
}

/// The test ends at this sample, aborted for `reason`.
fn aborted(reason: AbortReason) -> Step {
    Step {
        done: Some(Err(reason)),
        ..idle(None)
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
        if t < self.trim_end_s {
            return idle(None);
        }
        let trim = match self.trim_rad {
            Some(x) => x,
            None => match self.start_relay(t, error_rad) {
                Some(x) => x,
                None => return aborted(AbortReason::NoTrimRudder),
            },
        };
        let relay_start = self.relay_start_s.unwrap_or(t);
        if let Err(e) = self.heading.push(t, continuous_rad) {
            return aborted(AbortReason::Record(e));
        }
        let mut phase = match self.switch_relay(t, error_rad, trim) {
            Ok(phase) => phase,
            Err(reason) => return aborted(reason),
        };
        self.prev = Some((t, error_rad));
        if self.analyse_once_covered(t) {
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
            return aborted(AbortReason::NoLimitCycle {
                timeout_s: self.timeout_s,
                up_switches: self.up_switches.len(),
            });
        }
        Step {
            mode: ExcitationMode::Replace,
            value: self.trim_rad() + self.sign * self.h_rad,
            phase,
            done: None,
        }
    }

    /// The end of the trim window at heading sample `t`: delta0 is the mean rudder over it,
    /// and the relay starts on the side of `error_rad`, scaled for the sea. Returns delta0;
    /// none without a rudder sample in the window.
    fn start_relay(&mut self, t: f64, error_rad: f64) -> Option<f64> {
        if self.trim_n == 0 {
            return None;
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
        Some(x)
    }

    /// The relay with hysteresis at heading sample `t`, centred on `trim`: a switch when the
    /// error passes the other side's threshold, its instant interpolated at the crossing;
    /// then the chatter check, the sizing's look and, at a switch to `+h`, the centre's
    /// adaptation. Returns the new phase (exciting once the settling periods are done), or
    /// why the test aborts.
    fn switch_relay(
        &mut self,
        t: f64,
        error_rad: f64,
        trim: f64,
    ) -> Result<Option<MonitorState>, AbortReason> {
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
                    return Err(AbortReason::RelayChatter {
                        interval_s: interval,
                        hysteresis_deg: self.eps_rad.to_degrees(),
                    });
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
                self.size(t)?;
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
        Ok(phase)
    }

    /// Analyses once the last measured switch lies two samples inside the record, so the
    /// uniform analysis grid (which ends at or before the latest sample) covers it; the
    /// hand-back instant follows from the measured cycle. Returns whether it analysed now.
    fn analyse_once_covered(&mut self, t: f64) -> bool {
        let needed = self.settle_periods + self.measure_periods + 1;
        let covered = self
            .up_switches
            .get(needed - 1)
            .is_some_and(|&ts| t >= ts + 2.0 * self.dt_s);
        if !(covered && self.result.is_none()) {
            return false;
        }
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
        true
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
}

#[cfg(test)]
#[path = "hbt_tests.rs"]
mod tests;
