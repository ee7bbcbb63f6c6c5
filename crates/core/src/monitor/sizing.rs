//! Excitation sized to the loop the test finds: each method plays its designed excitation,
//! measures what the loop makes of it early in the test's settling, and lowers it (the look
//! never raises it) when the loop would carry the ship past a limit; the measurement then
//! sees one size, the report says which, and the features the estimator reads do not depend
//! on it. HBT's relay is also sized up for the sea before it starts, where the designed
//! hysteresis is under the wave yaw (below).
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
//! The heading is the other limit: on a ship more responsive than the tones were sized for
//! (the heading per tone, `|G S| E_i`, grows as `b / w^2`) the tones carry the heading error
//! to `safety.max-heading-error-deg`. In the same window, when the error is past
//! `clfrt.resize-heading-fraction` of that limit and heading for it, the tones' summed
//! heading is lowered by `clfrt.resize-heading-factor` `f` and the fastest tone keeps its
//! size ([`ToneSizing::on_heading`], [`spare_the_fastest`]): each tone's heading is its share
//! `x_i = s_i g_i |G(jw_i)|` (its scale, the loop's gain from excitation to rudder as the
//! rudder's fit reads it, 1 until it does, and the first-order ship's
//! `1 / (w sqrt(w^2 + a^2))`, `a = a0 u / l` from the speed log at the test's start), and the
//! other tones are lowered alike by `k = (f X - x_fast) / (X - x_fast)` (`X` the sum), so that
//! the sum falls by `f`, as a cut of every tone would lower it; where the fastest alone
//! carries more than `f X`, every tone is lowered by `f`. On a ship that responsive the
//! slower tones carry the heading (`|G|` falls as `1 / w^2`: the design's tones an octave and
//! more apart, the slowest's heading is 5-30 times the fastest tone's), so `k` is close to
//! `f` and no tone sinks far below where the even cut would leave it, while the fastest,
//! which reads the ship's gain `b` (`e_b`, `crate::fdi::sensitivity::ln_gain`) and most
//! of what the networks read, keeps its size and its signal-to-noise. The guard is armed per
//! vessel by what its tests find: after a CLFRT test that ended on the heading limit, and for as
//! long as each armed test needs it (the guard lowered its tones); a test it did not act in
//! disarms it. A hull whose peaks come near the limit and turn (KVLCC2's 7-9 deg in a
//! moderate sea) keeps its tones: lowered there for nothing, they cost detection.
//!
//! ## HBT: the relay ([`RelaySizing`])
//!
//! The relay `h sign(e)` with hysteresis `eps` on the linear ship `G(s) = b / (s (s + a))`
//! behind the servo `S` oscillates where `S G` meets `-1/N(A)`,
//! `N(A) = 4h / (pi A) exp(-i asin(eps / A))`: `N` depends on `h / A` and `eps / A` only, so
//! scaling `h` and `eps` by `s` scales the cycle's amplitude by `s` at the same frequency
//! (homogeneity). The servo's rate limit breaks this only while it saturates, and then in the
//! safe direction: a smaller step slews for less of the period, so the lag and the cycle
//! shrink a little more than `s`. The cycle's heading amplitude grows with `b / w^2`, so it is
//! largest where the ship is most responsive (fast and light), and there it can exceed the
//! heading limit (`safety.max-heading-error-deg`).
//!
//! At the relay's `hbt.resize-at-switch`-th switch (in the settling, before the cycle has
//! grown: from rest, a relay cycle grows over several half-periods), the ship is identified
//! on the heading and rudder recorded since the relay started: `a = a0 u / l` from the speed
//! log at the test's start (the speed is known on a ship, and a record of a fraction of a
//! period tells `a` poorly), and `b` by the baseline's equation-error least squares with
//! that `a` (the relay's steps tell `b` within a few %; the record starts on a steady course,
//! at rest, so no start-up transient is left out). Without a speed log, `a` and `b` are both
//! fitted ([`crate::baseline::fit`]). The describing function
//! ([`crate::dsp::relay::limit_cycle_describing_function`], the servo included) gives
//! the cycle's frequency `w` and first-harmonic amplitude `A`; the heading error's peak is
//! `k A`, `k` the peak over the first harmonic of the ship's steady response to a square
//! wave at `w` ([`square_wave_peak_factor`]: `pi^3 / 32` = 0.97 for `w >> a`, `pi^2 / 8` =
//! 1.23 for `w << a`). When `k A` exceeds `hbt.resize-heading-fraction` of the heading limit,
//! `h` and `eps` are scaled by `s = fraction limit / (k A)`, but never `eps` below
//! `max(hbt.resize-min-hysteresis-deg, hbt.resize-wave-factor x wave yaw)` (the hysteresis
//! must exceed the wave yaw or the relay chatters; the wave yaw: the vessel's sea as its last
//! completed test measured it, or, with none yet, the rms in `calibration.wave-band-rad-s` of the
//! heading on the same record less the fitted ship's answer to the recorded rudder: the
//! heading as it is would count the relay's own swing, the band's lower edge being the
//! short record's second or third bin). When even that smallest relay is predicted past the heading
//! limit itself, the test aborts (`relay_too_large`) before the ship gets there; when it is
//! predicted between the fraction and the limit, the smallest relay plays.
//!
//! **Sized for the sea.** A relay whose hysteresis the wave yaw on the heading crosses
//! chatters (switches closer than `hbt.min-switch-interval-s`: the test aborts): in the
//! simulator's rough sea (0.5 deg of wave yaw on the designed 1 deg) about half the relay
//! tests did. Before the relay starts ([`RelaySizing::for_sea`]), with the sea's wave yaw as
//! the vessel's last completed test measured it (over its whole record: a 60 s trim window of
//! a sea whose wave yaw lives in a band of ~0.2 rad/s holds two or three independent
//! components, too few to judge it), `h` and `eps` are scaled by `s = hbt.resize-wave-factor
//! x wave yaw / eps` where that is over 1, no further than `safety.max-excitation-deg / h`;
//! the look at the `hbt.resize-at-switch`-th switch may lower it again (never below the
//! wave floor). By the same homogeneity the cycle is the designed relay's at `s` times its
//! amplitude, read through the same ratios; with the sea in the picture, the relay `(s h, s
//! eps)` in a wave `w` is the designed relay in the wave `w / s`, scaled by `s`. Unknown sea
//! (no completed test yet) or the sizing off (`hbt.resize-at-switch` 0): as designed.
//!
//! After a resize the settling starts again (`hbt.settle-periods` from the next switch to
//! `+h`). The report's `relay_height_rad` and `hysteresis_rad` are the relay as played,
//! `relay_scale` its scale. The estimator reads the designed relay's cycle: `w_u / r_w` and
//! `a_u / r_A`, `(r_w, r_A)` the describing function's ratios `(w(s) / w(1), A(s) / A(1))`
//! on the fitted ship (`relay_omega_ratio`, `relay_amplitude_ratio`;
//! [`RelayPrediction::ratios`]). By homogeneity they are `(1, s)`; the servo's rate limit
//! moves them where the relay's slew takes a noticeable part of the period (default servo,
//! 4 deg/s, h 8 -> 4 deg: `w` +4 % and `A / s` -7 % at 7 m/s, 7000 t; +7 % and -13 % at
//! 10 m/s, 4000 t). The response `G(j w_u)` (a ratio) and the period spread need nothing.

use crate::dsp::multisine::Multisine;
use crate::monitor::config::CoreConfig;
use std::collections::VecDeque;
use std::f64::consts::PI;

/// Tones a multisine may have (`clfrt.harmonics`: 1 to 8).
pub(super) const MAX_TONES: usize = 8;

/// Time constant of the low-pass on the heading error's rate in the tones' heading guard
/// [s]: the wave's heading rate (0.8 rad/s) falls to an eighth, a tone's (0.03-0.2 rad/s)
/// passes.
const RATE_FILTER_S: f64 = 10.0;

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
    /// The heading limit [rad], the fraction of it beyond which every tone may be lowered,
    /// and by what factor; the heading error's growth rate, low-passed: `(t, e, rate)` [s,
    /// rad, rad/s] at the latest sample.
    heading_limit_rad: f64,
    heading_fraction: f64,
    heading_factor: f64,
    /// Whether the heading guard is armed for this test (the vessel's last CLFRT test hit
    /// the heading limit, or needed the guard), and whether it lowered the tones.
    heading_armed: bool,
    heading_cut: bool,
    heading_rate: Option<(f64, f64, f64)>,
    /// The first-order ship's yaw damping at the test's speed, `a0 u / l` [1/s]: the tones'
    /// heading shares.
    a_per_s: f64,
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
    pub(super) fn new(
        cfg: &CoreConfig,
        multisine: &Multisine,
        t0_s: f64,
        window: (f64, f64),
        heading_armed: bool,
        speed_mps: Option<f64>,
    ) -> Self {
        let c = &cfg.clfrt;
        let ship = &cfg.ship;
        let u = speed_mps
            .filter(|u| u.is_finite() && *u > 0.0)
            .unwrap_or(ship.nominal_speed_mps);
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
            heading_limit_rad: cfg.safety.max_heading_error_deg.to_radians(),
            heading_fraction: c.resize_heading_fraction,
            heading_factor: c.resize_heading_factor,
            heading_armed: heading_armed && c.resize_heading_fraction < 1.0,
            heading_cut: false,
            heading_rate: None,
            a_per_s: ship.yaw_damping_a0 * u / ship.length_m,
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

    /// Whether the heading guard lowered the tones in this test.
    pub(super) fn heading_guarded(&self) -> bool {
        self.heading_cut
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

    /// A heading sample, `error_rad` the heading error against the test's course. When the
    /// guard is armed (module doc), inside the window the tones' summed heading is lowered by
    /// `clfrt.resize-heading-factor`, the fastest tone kept ([`Self::heading_cut_scales`]),
    /// when the error is beyond `clfrt.resize-heading-fraction` `f` of the heading limit and
    /// heading for it:
    /// its growth rate (low-passed over [`RATE_FILTER_S`]) would carry it past the limit
    /// within the time a cut takes to act (`resize-ramp-s + resize-wait-s`), or it is past
    /// `(1 + f) / 2` of the limit whatever its rate. A peak that turns short of the limit
    /// keeps the tones (on a hull as sensitive as KVLCC2's, moderate-sea peaks of 7-9 deg
    /// are common, and a cut there costs the test signal it did not need to lose). Not
    /// again until `resize-wait-s` after the cut's ramp (the heading answers late); one
    /// resize of the test's `max`. The tones' heading adds up (a multisine's peak is at
    /// most the sum of its tones'), and on a ship more responsive than the design the
    /// slowest tone's share, `|G S|` times its amplitude, grows as `b / w^2`: the test would
    /// otherwise end on the heading limit; the fastest tone, whose share is small, keeps its
    /// size and its signal-to-noise.
    pub(super) fn on_heading(&mut self, t: f64, error_rad: f64) {
        let (start, end) = self.window;
        if !self.on || !self.heading_armed || !error_rad.is_finite() || t < start || t >= end {
            return;
        }
        // The error's rate, low-passed over RATE_FILTER_S (the wave's heading rate, at
        // 0.8 rad/s, falls to an eighth).
        let rate = match self.heading_rate {
            Some((tp, ep, r)) if t > tp => {
                let raw = (error_rad - ep) / (t - tp);
                let w = ((t - tp) / RATE_FILTER_S).min(1.0);
                r + w * (raw - r)
            }
            Some((_, _, r)) => r,
            None => 0.0,
        };
        self.heading_rate = Some((t, error_rad, rate));
        let size = error_rad.abs();
        let growth = rate * error_rad.signum();
        let horizon_s = self.ramp_s + self.wait_s;
        let limit = self.heading_limit_rad;
        let heading_for_the_limit = size > self.heading_fraction * limit
            && (size + growth.max(0.0) * horizon_s > limit
                || size > 0.5 * (1.0 + self.heading_fraction) * limit);
        if !heading_for_the_limit
            || t < self.at_s + self.ramp_s + self.wait_s
            || self.resizes >= self.max
        {
            return;
        }
        let now = self.scales(t);
        let cut = self.heading_cut_scales(&now);
        self.rudder.clear();
        for ((f, to), (n, c)) in self
            .from
            .iter_mut()
            .zip(self.to.iter_mut())
            .zip(now.iter().zip(cut))
        {
            *f = *n;
            *to = c;
        }
        self.at_s = t;
        self.look_s = t;
        self.resizes += 1;
        self.heading_cut = true;
    }

    /// The scales a heading cut leaves from the scales `now`: the fastest tone kept and the
    /// others lowered alike so that the summed heading share
    /// `s_i g_i / (w_i sqrt(w_i^2 + a^2))` (module doc) falls by `heading_factor`
    /// ([`spare_the_fastest`]). Shares that cannot be computed: every tone by the factor.
    fn heading_cut_scales(&self, now: &[f64; MAX_TONES]) -> Vec<f64> {
        let n = self.omegas.len().min(MAX_TONES);
        let gains = self.tone_gains();
        let a = self.a_per_s;
        let shares: Vec<f64> = (0..n)
            .map(|i| {
                let w = self.omegas[i];
                let g = gains[i].map_or(1.0, |(g, _)| g);
                now[i] * g / (w * (w * w + a * a).sqrt())
            })
            .collect();
        let fastest = (0..n).max_by(|&i, &j| self.omegas[i].total_cmp(&self.omegas[j]));
        let factors = fastest
            .filter(|_| shares.iter().all(|x| x.is_finite() && *x >= 0.0))
            .and_then(|j| spare_the_fastest(&shares, j, self.heading_factor));
        match factors {
            Some(k) => (0..n).map(|i| now[i] * k[i]).collect(),
            None => now[..n].iter().map(|s| s * self.heading_factor).collect(),
        }
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

/// The factors that lower the sum of `shares` (non-negative) by `factor` (in (0, 1)) while the
/// share at `keep` keeps its size: the others' factor `k = (factor X - x_keep) / (X -
/// x_keep)`, `X` the sum, 1 at `keep`. `None` when that cannot be done (the kept share alone
/// is at least `factor X`, or every other share is 0): the caller lowers every share alike.
pub(super) fn spare_the_fastest(shares: &[f64], keep: usize, factor: f64) -> Option<Vec<f64>> {
    let total: f64 = shares.iter().sum();
    let kept = *shares.get(keep)?;
    let rest = total - kept;
    let k = (factor * total - kept) / rest;
    if !(rest > 0.0 && k > 0.0 && k < 1.0 && k.is_finite()) {
        return None;
    }
    Some(
        (0..shares.len())
            .map(|i| if i == keep { 1.0 } else { k })
            .collect(),
    )
}

#[path = "sizing_relay.rs"]
mod relay;
pub use relay::{square_wave_peak_factor, RelayDecision, RelayPrediction, RelaySizing};

#[cfg(test)]
#[path = "sizing_tests.rs"]
mod tests;
