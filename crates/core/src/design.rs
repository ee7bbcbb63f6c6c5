//! The test designs: the HBT relay and the CLFRT multisine with its servo check. Model
//! files record the design they were trained for, so these sections sit below the
//! estimator and the monitor.

use crate::config::{check_count, check_range, check_range_open_low, fail, ConfigError, DEG};
use serde::{Deserialize, Serialize};

/// Relay feedback test (HBT, the harmonic balance test).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(default, deny_unknown_fields, rename_all = "kebab-case")]
pub struct HbtConfig {
    /// Relay height h around the trim rudder [deg].
    pub relay_height_deg: f64,
    /// Relay hysteresis eps on the heading error [deg]; must exceed the wave yaw.
    pub hysteresis_deg: f64,
    /// Time over which the trim rudder delta0 is measured before the relay starts [s].
    pub trim_window_s: f64,
    /// Limit-cycle periods to let settle before measuring.
    pub settle_periods: u32,
    /// Limit-cycle periods measured.
    pub measure_periods: u32,
    /// Abort when the measurement is not complete after this long [s] (no limit cycle formed).
    pub timeout_s: f64,
    /// Relay-centre adaptation per period, in [0, 1]: after each full period the centre moves
    /// this fraction of the way to the period's mean rudder, which makes the cycle symmetric.
    /// A heading-sensor drift or a slow yaw moment then leaves the cycle unchanged (the ship
    /// turns with the drift at the mean rudder; superposition). 0 keeps delta0 fixed; 1 is a
    /// full Newton step, at the edge of a period-2 oscillation of the centre; 0.5 is damped.
    pub bias_adaptation: f64,
    /// Hand-back lead tau [s]: after the last measured period the relay keeps running until
    /// the instant the cycle predicts for `e + tau de/dt = 0`, where the autopilot's PD term
    /// `Kp (e + Td de/dt)` is zero when tau matches its derivative time Td, so taking back
    /// control starts from the trim instead of a full-scale rudder. 0 hands back at once.
    /// Capped by `safety.max-test-duration-s`.
    pub handback_lead_s: f64,
    /// Abort when two relay switches come closer than this [s]: the relay chatters (waves
    /// above the hysteresis), which only wears the steering gear.
    pub min_switch_interval_s: f64,
    /// Relay sizing: at this relay switch (1-based, within the settling: at most
    /// `2 settle-periods`) the record so far predicts the limit cycle (a Nomoto fit and the
    /// describing function); 0 disables the sizing.
    pub resize_at_switch: u32,
    /// Relay sizing: when the predicted peak heading error exceeds this fraction of
    /// `safety.max-heading-error-deg`, h and eps are scaled down to bring it there.
    pub resize_heading_fraction: f64,
    /// Relay sizing: the hysteresis is never scaled below this [deg].
    pub resize_min_hysteresis_deg: f64,
    /// Relay sizing: nor below this many times the wave yaw measured on the record (rms in
    /// `calibration.wave-band-rad-s`): the hysteresis must exceed the wave yaw. Before the relay
    /// starts, h and eps are scaled up to this many times the last completed test's wave yaw
    /// where the designed hysteresis is under it (within `safety.max-excitation-deg`).
    pub resize_wave_factor: f64,
}

impl Default for HbtConfig {
    fn default() -> Self {
        Self {
            relay_height_deg: 8.0,
            hysteresis_deg: 1.0,
            trim_window_s: 60.0,
            settle_periods: 1,
            measure_periods: 4,
            timeout_s: 1740.0,
            bias_adaptation: 0.5,
            handback_lead_s: 30.0,
            min_switch_interval_s: 10.0,
            resize_at_switch: 2,
            resize_heading_fraction: 0.7,
            resize_min_hysteresis_deg: 0.5,
            resize_wave_factor: 3.0,
        }
    }
}

impl HbtConfig {
    /// Checks the section's limits; the error names the key and its allowed range.
    pub fn check(&self) -> Result<(), ConfigError> {
        check_range_open_low("hbt.relay-height-deg", self.relay_height_deg, 0.0, 15.0)?;
        check_range_open_low("hbt.hysteresis-deg", self.hysteresis_deg, 0.0, 10.0)?;
        check_range_open_low("hbt.trim-window-s", self.trim_window_s, 0.0, 600.0)?;
        check_count("hbt.settle-periods", self.settle_periods, 1, 20)?;
        check_count("hbt.measure-periods", self.measure_periods, 1, 50)?;
        check_range_open_low("hbt.timeout-s", self.timeout_s, 0.0, 86400.0)?;
        check_range("hbt.bias-adaptation", self.bias_adaptation, 0.0, 1.0)?;
        check_range("hbt.handback-lead-s", self.handback_lead_s, 0.0, 300.0)?;
        check_range(
            "hbt.min-switch-interval-s",
            self.min_switch_interval_s,
            0.0,
            600.0,
        )?;
        if self.resize_at_switch > 2 * self.settle_periods {
            return Err(fail(
                "hbt.resize-at-switch",
                self.resize_at_switch.to_string(),
                &format!(
                    "integer in [0, {}] (2 hbt.settle-periods: within the settling)",
                    2 * self.settle_periods
                ),
            ));
        }
        check_range_open_low(
            "hbt.resize-heading-fraction",
            self.resize_heading_fraction,
            0.0,
            1.0,
        )?;
        check_range_open_low(
            "hbt.resize-min-hysteresis-deg",
            self.resize_min_hysteresis_deg,
            0.0,
            10.0,
        )?;
        check_range("hbt.resize-wave-factor", self.resize_wave_factor, 0.0, 20.0)?;
        Ok(())
    }
    /// Relay height [rad].
    pub fn relay_height_rad(&self) -> f64 {
        self.relay_height_deg * DEG
    }
    /// Hysteresis [rad].
    pub fn hysteresis_rad(&self) -> f64 {
        self.hysteresis_deg * DEG
    }
}

/// Multisine test (CLFRT, the closed-loop frequency response test).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(default, deny_unknown_fields, rename_all = "kebab-case")]
pub struct ClfrtConfig {
    /// Analysis window T_w [s]; every tone has a whole number of periods in it.
    pub window_s: f64,
    /// Tone harmonics k of the window (omega_k = 2 pi k / T_w).
    pub harmonics: Vec<u32>,
    /// Amplitude of each tone [deg].
    pub amplitude_deg: f64,
    /// Windows to let settle before measuring.
    pub settle_windows: u32,
    /// Windows measured (averaged).
    pub measure_windows: u32,
    /// Fade-in time of the multisine [s] (within the settle window, after the servo check).
    pub fade_s: f64,
    /// Seed of the crest-factor phase optimisation (the design is deterministic).
    pub phase_seed: u64,
    /// Servo check: frequency of the sinusoid played at the start of the settle window, before
    /// the multisine fades in [rad/s]. Adjusted by < 0.1 % so that the measured periods span a
    /// whole number of samples ([`ClfrtConfig::servo_check_omega_rad_s`]).
    pub servo_check_frequency_rad_s: f64,
    /// Servo check: amplitude of the sinusoid [deg] (0 disables the check).
    pub servo_check_amplitude_deg: f64,
    /// Servo check: periods at full amplitude, all measured, 3 .. 100 (0 disables the check).
    pub servo_check_periods: u32,
    /// Servo check: periods of raised-cosine fade-in, and again of fade-out, around them.
    pub servo_check_fade_periods: u32,
    /// Excitation sizing: a tone whose rudder amplitude exceeds this many times its own is
    /// lowered (the loop amplifies it).
    pub resize_gain: f64,
    /// Excitation sizing: a tone's gain is judged this many standard errors below its
    /// estimate.
    pub resize_confidence: f64,
    /// Excitation sizing: correlation time of the rudder's own motion in the fit [s] (the
    /// standard error counts one sample per this).
    pub resize_correlation_s: f64,
    /// Excitation sizing: the factor each resize applies to such a tone, (0, 0.95].
    pub resize_factor: f64,
    /// Excitation sizing: time between looks at the tones' rudder amplitudes [s].
    pub resize_wait_s: f64,
    /// Excitation sizing: resizes at most per test (0 disables the sizing).
    pub resize_max: u32,
    /// Excitation sizing: no resize within this time of the measurement's start [s], so
    /// the loop settles at the new amplitude before it is measured.
    pub resize_settle_s: f64,
    /// Excitation sizing: raised-cosine ramp of a resize [s].
    pub resize_ramp_s: f64,
    /// Excitation sizing: every tone is lowered when the heading error exceeds this fraction
    /// of `safety.max-heading-error-deg` heading for it (a ship more responsive than the
    /// tones were sized for), (0, 1]. Armed on a vessel after a CLFRT test of it ended on
    /// the heading limit, while the armed tests need it; 1 leaves it to the safety check.
    pub resize_heading_fraction: f64,
    /// Excitation sizing: the factor that lowering applies to every tone, (0, 0.95].
    pub resize_heading_factor: f64,
}

impl Default for ClfrtConfig {
    fn default() -> Self {
        Self {
            window_s: 590.0,
            harmonics: vec![3, 7, 17],
            amplitude_deg: 4.0,
            settle_windows: 1,
            measure_windows: 2,
            fade_s: 30.0,
            phase_seed: 1,
            servo_check_frequency_rad_s: 0.6,
            servo_check_amplitude_deg: 5.0,
            servo_check_periods: 10,
            servo_check_fade_periods: 1,
            resize_gain: 2.5,
            resize_confidence: 2.0,
            resize_correlation_s: 5.0,
            resize_factor: 0.25,
            resize_wait_s: 10.0,
            resize_max: 2,
            resize_settle_s: 240.0,
            resize_ramp_s: 10.0,
            resize_heading_fraction: 0.7,
            resize_heading_factor: 0.5,
        }
    }
}

impl ClfrtConfig {
    /// Checks the section's limits; the error names the key and its allowed range.
    pub fn check(&self, rate_hz: f64) -> Result<(), ConfigError> {
        check_range("clfrt.window-s", self.window_s, 60.0, 7200.0)?;
        if self.harmonics.is_empty() || self.harmonics.len() > 8 {
            return Err(fail(
                "clfrt.harmonics",
                format!("{:?}", self.harmonics),
                "1 to 8 distinct harmonics, increasing, each >= 1 and below the Nyquist bin",
            ));
        }
        let nyquist_bin = (self.window_s * rate_hz / 2.0).floor() as u32;
        let mut prev = 0;
        for &k in &self.harmonics {
            if k <= prev || k >= nyquist_bin {
                return Err(fail(
                    "clfrt.harmonics",
                    format!("{:?}", self.harmonics),
                    &format!(
                        "increasing harmonics in [1, {}) (the Nyquist bin)",
                        nyquist_bin
                    ),
                ));
            }
            prev = k;
        }
        check_range_open_low("clfrt.amplitude-deg", self.amplitude_deg, 0.0, 10.0)?;
        check_count("clfrt.settle-windows", self.settle_windows, 0, 10)?;
        check_count("clfrt.measure-windows", self.measure_windows, 1, 20)?;
        check_range("clfrt.fade-s", self.fade_s, 0.0, self.window_s)?;
        // At least 4 samples per period: the check's bin stays far below Nyquist.
        let w_max = (std::f64::consts::PI * rate_hz / 4.0).min(5.0);
        check_range_open_low(
            "clfrt.servo-check-frequency-rad-s",
            self.servo_check_frequency_rad_s,
            0.0,
            w_max,
        )?;
        check_range(
            "clfrt.servo-check-amplitude-deg",
            self.servo_check_amplitude_deg,
            0.0,
            10.0,
        )?;
        if self.servo_check_periods != 0 {
            // The tone's bin needs neighbours on both sides (the autopilot's rudder fit).
            check_count(
                "clfrt.servo-check-periods",
                self.servo_check_periods,
                3,
                100,
            )?;
        }
        check_count(
            "clfrt.servo-check-fade-periods",
            self.servo_check_fade_periods,
            0,
            10,
        )?;
        check_range_open_low("clfrt.resize-gain", self.resize_gain, 0.0, 100.0)?;
        check_range("clfrt.resize-confidence", self.resize_confidence, 0.0, 10.0)?;
        check_range_open_low(
            "clfrt.resize-correlation-s",
            self.resize_correlation_s,
            0.0,
            600.0,
        )?;
        check_range_open_low("clfrt.resize-factor", self.resize_factor, 0.0, 0.95)?;
        check_range("clfrt.resize-wait-s", self.resize_wait_s, 0.0, 3600.0)?;
        check_count("clfrt.resize-max", self.resize_max, 0, 10)?;
        check_range("clfrt.resize-ramp-s", self.resize_ramp_s, 0.0, 600.0)?;
        check_range_open_low(
            "clfrt.resize-heading-fraction",
            self.resize_heading_fraction,
            0.0,
            1.0,
        )?;
        check_range_open_low(
            "clfrt.resize-heading-factor",
            self.resize_heading_factor,
            0.0,
            0.95,
        )?;
        // Beyond the settle windows it only means no sizing.
        check_range(
            "clfrt.resize-settle-s",
            self.resize_settle_s,
            self.resize_ramp_s,
            72000.0,
        )?;
        if self.servo_check_enabled() {
            let settle_s = self.settle_windows as f64 * self.window_s;
            let burst_s = self.servo_check_duration_s(rate_hz);
            if burst_s + self.fade_s > settle_s {
                return Err(fail(
                    "clfrt.servo-check-periods",
                    self.servo_check_periods,
                    &format!(
                        "a servo check of (periods + 2 fade-periods) x 2 pi / frequency = \
                         {burst_s:.1} s plus fade-s within the settle windows \
                         ({settle_s:.1} s); or 0 to disable the check"
                    ),
                ));
            }
        }
        Ok(())
    }

    /// Whether the servo check runs (non-zero amplitude and periods).
    pub fn servo_check_enabled(&self) -> bool {
        self.servo_check_amplitude_deg > 0.0 && self.servo_check_periods > 0
    }

    /// Servo check amplitude [rad].
    pub fn servo_check_amplitude_rad(&self) -> f64 {
        self.servo_check_amplitude_deg * DEG
    }

    /// Samples `N` of the measured (full-amplitude) part of the servo check at `rate_hz`: the
    /// configured periods rounded to a whole number of samples (at least 1).
    pub fn servo_check_samples(&self, rate_hz: f64) -> usize {
        let period_s = 2.0 * std::f64::consts::PI / self.servo_check_frequency_rad_s;
        ((self.servo_check_periods as f64 * period_s * rate_hz).round() as usize).max(1)
    }

    /// Frequency actually played by the servo check [rad/s]: `2 pi periods / (N dt)`, so that
    /// the measured periods fall exactly on bin `periods` of their `N`-sample DFT (within
    /// `pi / (periods N)` relative of the configured frequency, < 0.05 % by default).
    pub fn servo_check_omega_rad_s(&self, rate_hz: f64) -> f64 {
        if self.servo_check_periods == 0 {
            return self.servo_check_frequency_rad_s;
        }
        let n = self.servo_check_samples(rate_hz) as f64;
        2.0 * std::f64::consts::PI * self.servo_check_periods as f64 * rate_hz / n
    }

    /// Duration of the whole servo check, fades included [s] (0 when disabled).
    pub fn servo_check_duration_s(&self, rate_hz: f64) -> f64 {
        if !self.servo_check_enabled() {
            return 0.0;
        }
        let periods = (self.servo_check_periods + 2 * self.servo_check_fade_periods) as f64;
        periods * 2.0 * std::f64::consts::PI / self.servo_check_omega_rad_s(rate_hz)
    }

    /// Largest rate of the servo check's excitation [rad/s]: `A sqrt(w^2 + w_f^2)` with
    /// `w_f = pi / (2 T_f)` the largest rate of its raised-cosine envelope (fade time `T_f`),
    /// a bound of `|d/dt (env(t) A sin(w t))|`.
    pub fn servo_check_max_rate_rad_s(&self, rate_hz: f64) -> f64 {
        if !self.servo_check_enabled() {
            return 0.0;
        }
        let w = self.servo_check_omega_rad_s(rate_hz);
        let fade_s = self.servo_check_fade_periods as f64 * 2.0 * std::f64::consts::PI / w;
        let wf = if fade_s > 0.0 {
            std::f64::consts::PI / (2.0 * fade_s)
        } else {
            0.0
        };
        self.servo_check_amplitude_rad() * (w * w + wf * wf).sqrt()
    }

    /// The servo check against the safety gate: amplitude within `safety.max-excitation-deg`
    /// and rate within `safety.max-excitation-rate-deg-s` (the gate would otherwise distort it).
    pub fn check_servo_check_safety(
        &self,
        max_excitation_deg: f64,
        max_excitation_rate_deg_s: f64,
        rate_hz: f64,
    ) -> Result<(), ConfigError> {
        if !self.servo_check_enabled() {
            return Ok(());
        }
        check_range(
            "clfrt.servo-check-amplitude-deg",
            self.servo_check_amplitude_deg,
            0.0,
            max_excitation_deg,
        )?;
        let rate_per_deg_deg_s =
            self.servo_check_max_rate_rad_s(rate_hz) / self.servo_check_amplitude_rad();
        let max_amp_deg = max_excitation_rate_deg_s / rate_per_deg_deg_s;
        if self.servo_check_amplitude_deg > max_amp_deg {
            return Err(fail(
                "clfrt.servo-check-amplitude-deg",
                self.servo_check_amplitude_deg,
                &format!(
                    "[0, {max_amp_deg:.3}]: its rate (amplitude x {rate_per_deg_deg_s:.3} /s) \
                     within safety.max-excitation-rate-deg-s"
                ),
            ));
        }
        Ok(())
    }

    /// Tone amplitude [rad].
    pub fn amplitude_rad(&self) -> f64 {
        self.amplitude_deg * DEG
    }
    /// Tone frequencies [rad/s].
    pub fn tone_frequencies_rad_s(&self) -> Vec<f64> {
        self.harmonics
            .iter()
            .map(|&k| 2.0 * std::f64::consts::PI * k as f64 / self.window_s)
            .collect()
    }
}
