//! HBT's relay sized to the loop it finds (see "HBT: the relay" in the module doc of
//! `super`, `crate::monitor::sizing`).
use crate::baseline::{self, BaselineConfig, BaselineError};
use crate::dsp::relay::limit_cycle_describing_function;
use crate::dsp::spectrum::{band_rms, Spectrum};
use crate::dsp::DspError;
use crate::model::{ServoConfig, ShipConfig};
use crate::monitor::config::CoreConfig;
use crate::monitor::AbortReason;
use std::f64::consts::PI;

/// What the relay sizing predicted from the start of the relay's record.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RelayPrediction {
    /// The ship's yaw damping `a` [1/s] and rudder gain `b` [1/s^2] fitted on the record.
    pub a_per_s: f64,
    /// See `a_per_s`.
    pub b_per_s2: f64,
    /// Wave yaw on the record's heading [rad] (none when it could not be computed).
    pub wave_yaw_rad: Option<f64>,
    /// The describing function's cycle at the relay as designed: frequency [rad/s],
    /// first-harmonic heading amplitude [rad] and the heading error's peak [rad].
    pub omega_rad_s: f64,
    /// See `omega_rad_s`.
    pub amplitude_rad: f64,
    /// See `omega_rad_s`.
    pub peak_rad: f64,
    /// The scale chosen (1: the relay as designed).
    pub scale: f64,
    /// The describing function's cycle at that scale: frequency [rad/s], first-harmonic
    /// amplitude [rad] and peak heading error [rad] (the designed relay's at scale 1).
    pub scaled_omega_rad_s: f64,
    /// See `scaled_omega_rad_s`.
    pub scaled_amplitude_rad: f64,
    /// See `scaled_omega_rad_s`.
    pub scaled_peak_rad: f64,
}

impl RelayPrediction {
    /// The describing function's ratios of the played relay's cycle to the designed one's,
    /// `(w(s) / w(1), A(s) / A(1))`: `(1, s)` where the servo's rate limit does not act
    /// (homogeneity), a higher frequency and a smaller amplitude where it does (a smaller
    /// step slews for less of the period: less lag).
    pub fn ratios(&self) -> (f64, f64) {
        (
            self.scaled_omega_rad_s / self.omega_rad_s,
            self.scaled_amplitude_rad / self.amplitude_rad,
        )
    }
}

/// The relay sizing's verdict at its look.
#[derive(Debug, Clone, PartialEq)]
pub enum RelayDecision {
    /// Play the relay scaled by `prediction.scale` (1: unchanged).
    Play(RelayPrediction),
    /// No relay the hysteresis floor allows stays inside the heading limit.
    Abort(AbortReason),
}

/// Why the relay sizing could not predict (the relay then plays as it is).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum RelaySizingError {
    /// The records are too short or of different lengths for the fit.
    #[error("fit: {heading} heading and {rudder} rudder samples")]
    FitSamples {
        /// Heading samples.
        heading: usize,
        /// Rudder samples.
        rudder: usize,
    },
    /// The fit (its filter, or the baseline's least squares) failed.
    #[error("fit: {0}")]
    Fit(BaselineError),
    /// The rudder did not move enough to fit its gain.
    #[error("fit: no rudder excitation")]
    NoRudderExcitation,
    /// The fitted ship is not a ship (`a < 0` or `b <= 0`).
    #[error("fitted a = {a:.3e} 1/s, b = {b:.3e} 1/s^2")]
    NotAShip {
        /// Fitted yaw damping [1/s].
        a: f64,
        /// Fitted rudder gain [1/s^2].
        b: f64,
    },
    /// The describing function found no limit cycle.
    #[error("describing function: {0}")]
    DescribingFunction(DspError),
}

/// The relay's size (see "HBT" in the module doc): one look, at a given switch.
#[derive(Debug, Clone)]
pub struct RelaySizing {
    /// The relay switch (1-based) at which the sizing looks; 0: off.
    at_switch: usize,
    /// Heading error's peak allowed: `hbt.resize-heading-fraction` of the limit [rad].
    target_rad: f64,
    /// The safety limit on the heading error [rad].
    limit_rad: f64,
    /// Hysteresis floor, absolute [rad], and per rad of wave yaw.
    min_eps_rad: f64,
    wave_factor: f64,
    /// The servo the describing function includes.
    servo: ServoConfig,
    /// The fit's filter, with no start-up transient left out.
    fit: BaselineConfig,
    /// The ship's particulars (`a = a0 u / l` from the speed log).
    ship: ShipConfig,
    /// Wave-yaw band [rad/s], its transform and scratch.
    wave: ((f64, f64), Spectrum, Vec<f64>),
}

impl RelaySizing {
    /// The sizing `cfg` asks for.
    pub fn new(cfg: &CoreConfig) -> Self {
        let h = &cfg.hbt;
        let limit_rad = cfg.safety.max_heading_error_deg.to_radians();
        Self {
            at_switch: h.resize_at_switch as usize,
            target_rad: h.resize_heading_fraction * limit_rad,
            limit_rad,
            min_eps_rad: h.resize_min_hysteresis_deg.to_radians(),
            wave_factor: h.resize_wave_factor,
            servo: cfg.servo.clone(),
            fit: BaselineConfig {
                transient_s: 0.0,
                ..cfg.baseline.clone()
            },
            ship: cfg.ship.clone(),
            wave: (
                (
                    cfg.calibration.wave_band_rad_s[0],
                    cfg.calibration.wave_band_rad_s[1],
                ),
                Spectrum::new(),
                Vec::new(),
            ),
        }
    }

    /// Whether the sizing looks at the `switches`-th relay switch.
    pub fn looks_at(&self, switches: usize) -> bool {
        self.at_switch > 0 && switches == self.at_switch
    }

    /// The relay's scale for the sea, before it starts (see "HBT" in the module doc): with
    /// the sea's wave yaw on the heading (the vessel's last completed test's, measured over
    /// its whole record), `s = hbt.resize-wave-factor x wave yaw / eps` where that is over 1
    /// (the designed hysteresis is under the wave floor: the relay would chatter), no larger
    /// than lets `s h` stay within `max_h_rad` (`safety.max-excitation-deg`); else 1 (also
    /// with the sizing off or no wave yaw known).
    pub fn for_sea(
        &self,
        wave_yaw_rad: Option<f64>,
        (h_rad, eps_rad): (f64, f64),
        max_h_rad: f64,
    ) -> f64 {
        let wanted = match wave_yaw_rad {
            Some(w) if self.at_switch > 0 => self.wave_factor * w / eps_rad,
            _ => return 1.0,
        };
        let most = (max_h_rad / h_rad).max(1.0);
        if wanted.is_finite() {
            wanted.clamp(1.0, most)
        } else {
            1.0
        }
    }

    /// The verdict for the designed relay `(h, eps)` [rad] played at `scale` (1, or the
    /// sea's [`RelaySizing::for_sea`]) from the heading and rudder recorded since it started
    /// (`dt` apart, same length, starting on a steady course), the speed log at the test's
    /// start (none: unknown) and the sea's wave yaw as the vessel's last completed test
    /// measured it (none: not known). The scale it gives is never above `scale` (the look
    /// only lowers) nor below the wave floor: `hbt.resize-wave-factor` x the vessel's sea
    /// where it is known, else the record's, read from the heading the fitted ship does not
    /// explain ([`unexplained_heading`]: on a record of a few tens of seconds the wave band's
    /// lower edge is its second or third bin, inside the window's main lobe of the relay's own
    /// swing, and the heading as it is read up to 0.4 deg of "wave yaw" in a calm sea).
    /// `Err`: no prediction (the fit or the describing function failed, or the fitted ship
    /// is not a ship); the relay then plays as it is and the safety limits still hold.
    #[allow(clippy::too_many_arguments)]
    pub fn decide(
        &mut self,
        heading_rad: &[f64],
        rudder_rad: &[f64],
        dt_s: f64,
        speed_mps: Option<f64>,
        (h_rad, eps_rad): (f64, f64),
        scale: f64,
        sea_wave_yaw_rad: Option<f64>,
    ) -> Result<RelayDecision, RelaySizingError> {
        let (a, (b, c)) = match speed_mps.filter(|u| u.is_finite() && *u > 0.0) {
            Some(u) => {
                let a = self.ship.yaw_damping_a0 * u / self.ship.length_m;
                (a, fit_b(heading_rad, rudder_rad, dt_s, a, &self.fit)?)
            }
            None => {
                let fit = baseline::fit(heading_rad, rudder_rad, dt_s, &self.fit)
                    .map_err(RelaySizingError::Fit)?;
                (fit.a_per_s, (fit.b_per_s2, 0.0))
            }
        };
        if !(a >= 0.0 && b > 0.0) {
            return Err(RelaySizingError::NotAShip { a, b });
        }
        // The sea on this record: what the fitted ship does not explain (the relay's own
        // swing dominates the heading, and on a record of a few tens of seconds the wave
        // band starts inside the window's main lobe of it).
        let unexplained = unexplained_heading(heading_rad, rudder_rad, dt_s, a, b, c);
        let (band, spectrum, scratch) = &mut self.wave;
        let wave_yaw_rad = band_rms(&unexplained, dt_s, *band, spectrum, scratch).ok();
        let peak = |s: f64| -> Result<(f64, f64, f64), RelaySizingError> {
            let (w, amp) =
                limit_cycle_describing_function(a, b, s * h_rad, s * eps_rad, &self.servo)
                    .map_err(RelaySizingError::DescribingFunction)?;
            Ok((w, amp, square_wave_peak_factor(w, a) * amp))
        };
        let (omega_rad_s, amplitude_rad, peak_rad) = peak(1.0)?;
        let playing = if scale == 1.0 {
            (omega_rad_s, amplitude_rad, peak_rad)
        } else {
            peak(scale)?
        };
        let mut prediction = RelayPrediction {
            a_per_s: a,
            b_per_s2: b,
            wave_yaw_rad,
            omega_rad_s,
            amplitude_rad,
            peak_rad,
            scale,
            scaled_omega_rad_s: playing.0,
            scaled_amplitude_rad: playing.1,
            scaled_peak_rad: playing.2,
        };
        if playing.2 <= self.target_rad {
            return Ok(RelayDecision::Play(prediction));
        }
        let sea = sea_wave_yaw_rad
            .filter(|w| w.is_finite() && *w >= 0.0)
            .or(wave_yaw_rad);
        let floor_rad = self.min_eps_rad.max(self.wave_factor * sea.unwrap_or(0.0));
        let lower = (self.target_rad / peak_rad)
            .max(floor_rad / eps_rad)
            .min(scale);
        let (scaled_omega_rad_s, scaled_amplitude_rad, scaled_peak_rad) =
            if lower < scale { peak(lower)? } else { playing };
        if scaled_peak_rad > self.limit_rad {
            return Ok(RelayDecision::Abort(AbortReason::RelayTooLarge {
                predicted_deg: scaled_peak_rad.to_degrees(),
                limit_deg: self.limit_rad.to_degrees(),
                hysteresis_deg: (lower * eps_rad).to_degrees(),
            }));
        }
        prediction.scale = lower;
        prediction.scaled_omega_rad_s = scaled_omega_rad_s;
        prediction.scaled_amplitude_rad = scaled_amplitude_rad;
        prediction.scaled_peak_rad = scaled_peak_rad;
        Ok(RelayDecision::Play(prediction))
    }
}

/// The rudder gain `b` [1/s^2] of `psi'' = -a psi' + b delta + c` with `a` given: the
/// baseline's state-variable filter on both records ([`crate::baseline`]), then least
/// squares of `s^2 F psi + a s F psi = b F delta + c` (two unknowns, normal equations; the
/// record starts at rest, so no transient is left out). Returns `(b, c)`.
fn fit_b(
    heading_rad: &[f64],
    rudder_rad: &[f64],
    dt_s: f64,
    a: f64,
    cfg: &BaselineConfig,
) -> Result<(f64, f64), RelaySizingError> {
    if heading_rad.len() != rudder_rad.len() || heading_rad.len() < baseline::MIN_FIT_SAMPLES {
        return Err(RelaySizingError::FitSamples {
            heading: heading_rad.len(),
            rudder: rudder_rad.len(),
        });
    }
    let err = RelaySizingError::Fit;
    let mut fh = baseline::StateVariableFilter::new(cfg.filter_rad_s, dt_s).map_err(err)?;
    let mut fd = baseline::StateVariableFilter::new(cfg.filter_rad_s, dt_s).map_err(err)?;
    let psi0 = heading_rad[0];
    // Sums of x x' and x y over x = (F delta, 1), y = s^2 F psi + a s F psi.
    let (mut sdd, mut sd, mut n, mut sdy, mut sy) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for (k, (&psi, &delta)) in heading_rad.iter().zip(rudder_rad).enumerate() {
        let (h, d) = if k == 0 {
            (fh.reset(0.0), fd.reset(delta))
        } else {
            (fh.step(psi - psi0), fd.step(delta))
        };
        let y = h.ssf + a * h.sf;
        sdd += d.f * d.f;
        sd += d.f;
        n += 1.0;
        sdy += d.f * y;
        sy += y;
    }
    let det = sdd * n - sd * sd;
    let b = (n * sdy - sd * sy) / det;
    if det > 0.0 && b.is_finite() {
        Ok((b, (sy - b * sd) / n))
    } else {
        Err(RelaySizingError::NoRudderExcitation)
    }
}

/// The heading less the fitted ship's answer to the recorded rudder: `psi'' = -a psi' + b
/// delta + c` from the record's first heading at rest, the rudder held over each sample
/// (exact for `r`, trapezoidal for `psi`) [rad].
pub(super) fn unexplained_heading(
    heading_rad: &[f64],
    rudder_rad: &[f64],
    dt_s: f64,
    a: f64,
    b: f64,
    c: f64,
) -> Vec<f64> {
    let decay = (-a * dt_s).exp();
    let gain = if a > 0.0 { (1.0 - decay) / a } else { dt_s };
    let (mut psi, mut r) = (heading_rad.first().copied().unwrap_or(0.0), 0.0);
    heading_rad
        .iter()
        .zip(rudder_rad)
        .map(|(&h, &d)| {
            let out = h - psi;
            let next = decay * r + gain * (b * d + c);
            psi += 0.5 * dt_s * (r + next);
            r = next;
            out
        })
        .collect()
}

/// Harmonics summed by [`square_wave_peak_factor`] (their terms fall as `1 / n^2` and faster).
const PEAK_HARMONICS: usize = 63;

/// Peak over first-harmonic amplitude of the steady response of `b / (s (s + a))` to a
/// square wave of frequency `w` [rad/s]: the odd harmonics `n`, each `(1/n) |G(j n w)|` and
/// phase `arg G(j n w)` against the fundamental's, summed and maximised over a period (`b`
/// cancels). `pi^3 / 32` when `a = 0` (parabolic arcs), `pi^2 / 8` when `a >> w` (a
/// triangle).
pub fn square_wave_peak_factor(w: f64, a: f64) -> f64 {
    let g = |n: f64| {
        let x = n * w;
        (
            1.0 / (x * x.hypot(a)),
            -PI / 2.0 - (x / a.max(f64::MIN_POSITIVE)).atan(),
        )
    };
    let (g1, _) = g(1.0);
    let steps = 720;
    (0..steps)
        .map(|i| {
            let th = 2.0 * PI * i as f64 / steps as f64;
            (0..PEAK_HARMONICS)
                .map(|k| {
                    let n = (2 * k + 1) as f64;
                    let (gn, pn) = g(n);
                    gn / (n * g1) * (n * th + pn).sin()
                })
                .sum::<f64>()
                .abs()
        })
        .fold(0.0, f64::max)
}
