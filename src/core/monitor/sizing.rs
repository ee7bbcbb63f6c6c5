//! Excitation sized to the loop the test finds: the test plays its designed excitation,
//! measures what the loop makes of it early in the test's settling, and lowers it (never
//! raises it) when the loop would carry the ship past a limit; the measurement then sees one
//! size, and the report says which.
//!
//! ## CLFRT: the tones ([`ToneSizing`])
//!
//! The autopilot is a black box, and where its sensitivity peaks (gains tuned for another
//! ship: at the fast and light corner a fixed-gain autopilot amplifies the fastest tone
//! ~13-fold, `|1 / (1 + L(jw))|` at 0.18 rad/s) the tones drive the rudder to its limit. From
//! the multisine's start to `clfrt.resize-settle-s` before the measurement, every
//! `clfrt.resize-wait-s` the rudder over each tone's latest period is fitted (least squares)
//! on that tone and the faster ones as played, with a quadratic trend: the gain
//! `g_i = |Delta_i| / |E_i|` and its standard error `se_i` (the residual's variance counted
//! once per `clfrt.resize-correlation-s`). A tone with `(g_i - c se_i) s_i >
//! clfrt.resize-gain` (`c` = `clfrt.resize-confidence`, `s_i` its scale) is lowered by
//! `clfrt.resize-factor` over a raised-cosine ramp of `clfrt.resize-ramp-s`, at most
//! `clfrt.resize-max` times; the record starts again after the ramp. The measured windows see
//! one amplitude per tone. Each tone's gain and phase are ratios of heading to rudder,
//! independent of its amplitude for a linear ship, and the lowered tone is the one the loop
//! amplifies, so its rudder (the signal the ratio rests on) stays large. The report's
//! `amplitude_scales` gives each tone's scale.
//!

use crate::core::dsp::multisine::Multisine;
use crate::core::monitor::config::CoreConfig;
use std::collections::VecDeque;
use std::f64::consts::PI;

/// Tones a multisine may have (`clfrt.harmonics`: 1 to 8).
pub(super) const MAX_TONES: usize = 8;

/// The tones' sizes while the test settles (see "CLFRT" in the module doc).
#[derive(Debug, Clone, PartialEq)]
pub(super) struct ToneSizing {
    /// Whether the sizing is on.
    on: bool,
    /// A tone whose rudder amplitude over its excitation exceeds this is lowered.
    gain_limit: f64,
    /// Factor of one resize of a tone.
    factor: f64,
    /// Resizes allowed.
    max: u32,
    /// Ramp of one resize [s].
    ramp_s: f64,
    /// Time between looks at the tones [s].
    wait_s: f64,
    /// Standard errors below its estimate at which a tone's gain is judged, the rudder
    /// residual's correlation time [s] and the sample period [s].
    confidence: f64,
    correlation_s: f64,
    dt_s: f64,
    /// The latest look [s].
    look_s: f64,
    /// Ship times between which a resize may start [s].
    window: (f64, f64),
    /// Tone frequencies [rad/s] (the multisine's) and its amplitude [rad].
    omegas: Vec<f64>,
    amplitude_rad: f64,
    /// Per tone: the scale before the latest resize, and after it; the resize's start [s].
    from: Vec<f64>,
    to: Vec<f64>,
    at_s: f64,
    /// Resizes so far.
    resizes: u32,
    /// Since the latest resize's ramp, over at most the lowest tone's period: `(t, rudder,
    /// fade envelope)` [s, rad, -].
    rudder: VecDeque<(f64, f64, f64)>,
    /// Tone phases [rad] and the multisine's phase origin [s].
    phases: Vec<f64>,
    t0_s: f64,
    /// Span of `rudder` [s] and its capacity [samples].
    span_s: f64,
    capacity: usize,
}

impl ToneSizing {
    pub(super) fn new(cfg: &CoreConfig, multisine: &Multisine, t0_s: f64, window: (f64, f64)) -> Self {
        let c = &cfg.clfrt;
        let omegas = multisine.omegas().to_vec();
        let n = omegas.len();
        // The slowest tone's period, and a second to spare.
        let span_s = omegas
            .iter()
            .fold(0.0f64, |m, w| m.max(2.0 * PI / w.max(1e-9)))
            + 1.0;
        let capacity = (span_s * cfg.sensors.rate_hz * 2.0).ceil() as usize + 8;
        Self {
            on: c.resize_max > 0,
            gain_limit: c.resize_gain,
            factor: c.resize_factor,
            max: c.resize_max,
            ramp_s: c.resize_ramp_s,
            wait_s: c.resize_wait_s,
            confidence: c.resize_confidence,
            correlation_s: c.resize_correlation_s,
            dt_s: 1.0 / cfg.sensors.rate_hz,
            window,
            omegas,
            phases: multisine.phases().to_vec(),
            t0_s,
            amplitude_rad: multisine.amplitude_rad(),
            from: vec![1.0; n],
            to: vec![1.0; n],
            at_s: f64::NEG_INFINITY,
            look_s: window.0,
            resizes: 0,
            rudder: VecDeque::new(),
            span_s,
            capacity,
        }
    }

    /// The tones' scales at ship time `t` (tones beyond the multisine's count 1).
    pub(super) fn scales(&self, t: f64) -> [f64; MAX_TONES] {
        let x = if self.ramp_s > 0.0 {
            ((t - self.at_s) / self.ramp_s).clamp(0.0, 1.0)
        } else {
            1.0
        };
        let w = 0.5 * (1.0 - (PI * x).cos());
        let mut out = [1.0; MAX_TONES];
        for (o, (f, to)) in out.iter_mut().zip(self.from.iter().zip(&self.to)) {
            *o = f + (to - f) * w;
        }
        out
    }

    /// Whether any tone was lowered.
    pub(super) fn resized(&self) -> bool {
        self.to.iter().any(|&s| s < 1.0)
    }

    /// The loop's gain from excitation to rudder at each tone, `|Delta(w_i)| / |E(w_i)|`, and
    /// its standard error, over
    /// the latest whole period of the tone (the loop may still be building up: the latest
    /// period is the nearest to what the measurement will see): a least-squares fit of the
    /// kept rudder on the sine and cosine as played (fade envelope and scale included) of this
    /// tone and every faster one, jointly (over a period they are not orthogonal), with a
    /// quadratic trend for the slower ones. None until the record holds a period of the tone,
    /// or when the fit is singular.
    fn tone_gains(&self) -> [Option<(f64, f64)>; MAX_TONES] {
        let mut out = [None; MAX_TONES];
        let Some(&(t_last, _, _)) = self.rudder.back() else {
            return out;
        };
        let n = self.omegas.len().min(MAX_TONES);
        for (i, slot) in out.iter_mut().enumerate().take(n) {
            let period = 2.0 * PI / self.omegas[i];
            let from = t_last - period;
            if self.rudder.front().is_none_or(|&(t0, _, _)| t0 > from) {
                continue;
            }
            let fitted: Vec<usize> = (0..n)
                .filter(|&j| 2.0 * PI / self.omegas[j] <= period)
                .collect();
            *slot = self.fit_gain(from, t_last, &fitted, i);
        }
        out
    }

    /// `|Delta(w_i)| / |E(w_i)|` from the fit over `[from, to]` on the tones `fitted` (which
    /// hold `i`), and its standard error (in a moderate sea at 4 m/s the autopilot's own
    /// rudder scatters a one-period gain by +-1).
    fn fit_gain(&self, from: f64, to: f64, fitted: &[usize], i: usize) -> Option<(f64, f64)> {
        let m = 3 + 2 * fitted.len();
        let mid = 0.5 * (from + to);
        let half = (0.5 * (to - from)).max(1e-9);
        let mut ata = nalgebra::DMatrix::<f64>::zeros(m, m);
        let mut atb = nalgebra::DVector::<f64>::zeros(m);
        let mut row = vec![0.0; m];
        let (mut count, mut sum_dd) = (0usize, 0.0);
        for &(t, d, env) in self.rudder.iter().filter(|(t, _, _)| *t >= from) {
            count += 1;
            sum_dd += d * d;
            let x = (t - mid) / half;
            row[0] = 1.0;
            row[1] = x;
            row[2] = x * x;
            for (j, &k) in fitted.iter().enumerate() {
                let a = self.amplitude_rad * self.to[k] * env;
                let arg = self.omegas[k] * (t - self.t0_s) + self.phases[k];
                row[3 + 2 * j] = a * arg.sin();
                row[4 + 2 * j] = a * arg.cos();
            }
            for r in 0..m {
                atb[r] += row[r] * d;
                for c in 0..m {
                    ata[(r, c)] += row[r] * row[c];
                }
            }
        }
        let ch = ata.cholesky()?;
        let sol = ch.solve(&atb);
        let j = fitted.iter().position(|&k| k == i)?;
        let gain = sol[3 + 2 * j].hypot(sol[4 + 2 * j]);
        // The fit's noise: residual variance over the effective samples (the rudder's
        // residual is correlated over `correlation_s`), its covariance sigma^2 (A'A)^-1.
        let samples = count as f64;
        let dof = samples - m as f64;
        if dof <= 0.0 {
            return None;
        }
        let rss = (sum_dd - sol.dot(&atb)).max(0.0);
        let inv = ch.inverse();
        let per_sample = (self.correlation_s / self.dt_s).max(1.0);
        let var = rss / dof * per_sample;
        let se = (0.5 * var * (inv[(3 + 2 * j, 3 + 2 * j)] + inv[(4 + 2 * j, 4 + 2 * j)])).sqrt();
        Some((gain, se))
    }

    /// A rudder sample. Every `wait_s` inside the window, each tone whose rudder amplitude
    /// exceeds `gain_limit` times its designed amplitude (the loop amplifies it: its gain,
    /// `confidence` standard errors below the estimate, times its scale is over the limit) is
    /// lowered by `factor`; the others are not the rudder's trouble, and lowering them would
    /// only cost signal-to-noise.
    pub(super) fn on_rudder(&mut self, t: f64, rudder_rad: f64, envelope: f64) {
        let (start, end) = self.window;
        if !self.on
            || !rudder_rad.is_finite()
            || t < start
            || t >= end
            || t < self.at_s + self.ramp_s
        {
            return;
        }
        self.rudder.push_back((t, rudder_rad, envelope));
        while self.rudder.len() > self.capacity
            || self
                .rudder
                .front()
                .is_some_and(|(t0, _, _)| t - t0 > self.span_s)
        {
            self.rudder.pop_front();
        }
        if self.resizes >= self.max || t < self.look_s + self.wait_s {
            return;
        }
        self.look_s = t;
        let now = self.scales(t);
        let gains = self.tone_gains();
        // Lowered while its rudder amplitude, on clear evidence, exceeds `gain_limit` times
        // its designed amplitude.
        let cut: Vec<bool> = gains
            .iter()
            .zip(now)
            .map(|(g, scale)| {
                g.is_some_and(|(g, se)| (g - self.confidence * se) * scale > self.gain_limit)
            })
            .collect();
        if !cut.iter().any(|&c| c) {
            return;
        }
        // A fresh record after the ramp: the fit assumes one size per tone.
        self.rudder.clear();
        for (f, n) in self.from.iter_mut().zip(now) {
            *f = n;
        }
        for (to, c) in self.to.iter_mut().zip(&cut) {
            if *c {
                *to *= self.factor;
            }
        }
        self.at_s = t;
        self.resizes += 1;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::core::monitor::Monitor;

    /// A rudder that answers each tone `i` with gain `gains[i]` (a lag of 0.3 rad) plus a
    /// trim and a slow wander, sampled at 10 Hz from the multisine's start: what the sizing
    /// sees in a loop whose sensitivity at the tones is `gains`.
    fn run(gains: [f64; 3], noise_rad: f64) -> (ToneSizing, Multisine) {
        let cfg = CoreConfig::default();
        let ms = Monitor::design_multisine(&cfg).unwrap();
        let t0 = 1000.0;
        let mut sizing = ToneSizing::new(&cfg, &ms, t0, (t0, t0 + 400.0));
        let mut rng_state = 7u64;
        let mut noise = || {
            // xorshift, uniform in [-1, 1].
            rng_state ^= rng_state << 13;
            rng_state ^= rng_state >> 7;
            rng_state ^= rng_state << 17;
            (rng_state >> 11) as f64 / (1u64 << 52) as f64 - 1.0
        };
        for n in 0..4000 {
            let t = t0 + n as f64 * 0.1;
            let scales = sizing.scales(t);
            let rudder: f64 = (0..3)
                .map(|i| {
                    let arg = ms.omegas()[i] * (t - t0) + ms.phases()[i] - 0.3;
                    gains[i] * scales[i] * ms.amplitude_rad() * arg.sin()
                })
                .sum::<f64>()
                + 0.02
                + 0.01 * (0.01 * t).sin()
                + noise_rad * noise();
            sizing.on_rudder(t, rudder, 1.0);
        }
        (sizing, ms)
    }

    #[test]
    fn the_fit_reads_each_tones_gain() {
        // No tone over the limit: no resize, and the record's fit gives the gains back.
        let (sizing, _) = run([0.4, 1.5, 2.2], 0.0);
        assert!(!sizing.resized());
        let g = sizing.tone_gains();
        for (i, want) in [0.4, 1.5, 2.2].iter().enumerate() {
            let (got, se) = g[i].unwrap();
            // The slower tones leak a little into a faster one's one-period fit (the
            // quadratic trend takes most of it): within 5 %. The error bar is the noise's
            // alone, small without noise.
            assert!(
                (got - want).abs() < 0.05 * want,
                "tone {i}: {got} vs {want}"
            );
            assert!(se < 0.05 * want, "tone {i}: se {se}");
        }
    }

    #[test]
    fn only_the_amplified_tone_is_lowered() {
        let (sizing, _) = run([0.1, 0.4, 12.0], 0.001);
        let (once, _) = run([0.1, 0.4, 6.0], 0.001);
        // Gain 6: 6 x 0.25 = 1.5, under the limit after one resize.
        assert_eq!(once.scales(f64::INFINITY)[2], 0.25);
        assert!(sizing.resized());
        let s = sizing.scales(f64::INFINITY);
        assert_eq!(&s[..2], &[1.0, 1.0]);
        // Gain 12: 12 x 0.25 = 3 is still over 2.5, 12 x 0.0625 = 0.75 is not.
        assert_eq!(s[2], 0.0625, "{s:?}");
        assert_eq!(sizing.resizes, 2);
    }

    #[test]
    fn rudder_noise_does_not_lower_a_tone() {
        // Gains of 2 under a rudder noise of +-3 deg: one-period fits scatter, the lower
        // confidence bound stays under the limit.
        let (sizing, _) = run([1.6, 2.0, 2.0], 3f64.to_radians());
        assert!(!sizing.resized(), "{:?}", sizing.scales(f64::INFINITY));
    }

    #[test]
    fn sizing_off_leaves_the_tones() {
        let mut cfg = CoreConfig::default();
        cfg.clfrt.resize_max = 0;
        let ms = Monitor::design_multisine(&cfg).unwrap();
        let mut sizing = ToneSizing::new(&cfg, &ms, 0.0, (0.0, 400.0));
        for n in 0..4000 {
            let t = n as f64 * 0.1;
            sizing.on_rudder(t, 0.4 * (ms.omegas()[2] * t).sin(), 1.0);
        }
        assert!(!sizing.resized());
    }
}
