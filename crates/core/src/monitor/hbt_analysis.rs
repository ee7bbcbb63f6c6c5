//! What a relay test measured: the analysis of its records over the measured periods (the
//! limit cycle, the wave yaw, the ship's response at `omega_u`, the servo's slew, the
//! baseline), the hand-back instant, and the typed features ([`HbtReport`]). Part of
//! [`super::HbtRun`]; the method is described in `hbt.rs`.

use super::HbtRun;
use crate::baseline::{self, BaselineError, BaselineEstimate};
use crate::dsp::relay::{analyse_limit_cycle, first_harmonic, LimitCycle};
use crate::dsp::spectrum::band_rms;
use crate::model::ServoConfig;
use crate::monitor::sizing::RelayPrediction;
use crate::monitor::{AbortReason, Measured};
use crate::wire::features::{HbtFeatures, ServoRateFeatures};
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

impl HbtRun {
    /// The analysis at ship time `t_now` over the measured periods, the relay centred on
    /// `trim` at the end.
    pub(super) fn analyse(&mut self, t_now: f64, trim: f64) -> Result<Measured, AbortReason> {
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
pub(super) fn nominal_slew_rad_s(servo: &ServoConfig, rate_hz: f64, h_rad: f64) -> Option<f64> {
    let r = servo.max_rate_rad_s();
    let ramp_s = (2.0 * h_rad - r * servo.time_constant_s) / r;
    let window_s = 2.0 * crate::dsp::RATE_HALF_WIDTH as f64 / rate_hz;
    (ramp_s >= 1.5 * window_s).then_some(r)
}

/// The median over the measured periods (`switches[k] .. switches[k + 1]`) of each period's
/// largest rudder rate ([`crate::dsp::abs_slopes`] on `d`, sampled from `t0` every `dt`): each
/// period holds two full slews of the servo, so a healthy one reads its rate limit, a slower
/// one less. `None` without a whole period inside the record.
pub(super) fn slew_peak(
    d: &[f64],
    t0: f64,
    dt: f64,
    switches: &[f64],
    slopes: &mut Vec<f64>,
) -> Option<f64> {
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
pub(super) fn handback_instant(
    t_up_s: f64,
    period_s: f64,
    amp_rad: f64,
    eps_rad: f64,
    tau_s: f64,
) -> f64 {
    let w = 2.0 * std::f64::consts::PI / period_s;
    let phi0 = (eps_rad / amp_rad).clamp(-1.0, 1.0).asin();
    let phi = std::f64::consts::PI - (tau_s * w).atan();
    t_up_s + (phi - phi0).max(0.0) / w
}
