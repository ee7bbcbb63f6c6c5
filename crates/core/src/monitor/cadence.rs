//! Commissioning's cadence: the gap after a test while the vessel's reference is established,
//! from the rudder travel the tests add, measured.
//!
//! **The steering gear's work** is the rudder's travel, `sum |d delta|` [rad], of the measured
//! rudder through a play of half-width `h = 3 sigma` (`sensors.rudder-noise-deg`): the
//! indicator's white noise seldom leaves the play and adds next to nothing (about `50 sigma`
//! an hour at 10 Hz: 5 deg/h for 0.1 deg, against the autopilot's hundreds), a rudder that
//! swings `A > h` adds `4 (A - h)` a period (and up to `2.5 sigma` more at each turning
//! point, where the play follows the noise's extreme).
//!
//! **The autopilot's own work** `r` [rad/s] is measured between tests: travel over time, each
//! weighted by `exp(-age / AUTOPILOT_MEMORY_S)` (an hour: the sea changes over hours). A
//! test of duration `T` and travel `W` adds `A = W - r T`.
//!
//! **The budget.** While the reference is established the tests may add at most the
//! autopilot's own work over the same time (they at most double the steering gear's work
//! while commissioning and its confirmation last). A cycle (the gap, with the steady wait in
//! it, and the test) then lasts `C >= A / r`: the gap after the test is `A / r - T`, at least
//! 0. It is at most `scheduler.commissioning-interval-s` (the fixed cadence that keeps the
//! budget on the design's ship in a calm sea, `config::COMMISSIONING_INTERVAL_S`, over the
//! two methods' mean test): in a calm sea a long CLFRT test has spent most of its budget in
//! its own length and the gap after it is short, the HBT's is the most; in a seaway, where the relay or the tones take over work the
//! autopilot does anyway, `A <= 0` and the tests follow each other after the steady wait.
//! The most wins over the budget: with an autopilot quieter than the design's in a calm sea
//! the tests add more than its own, and commissioning still takes hours, not days.
//! Without a measured `r` (no autopilot-alone stretch yet, or a rudder that never leaves the
//! play) the gap is `commissioning-interval-s`.

/// The forgetting time of the autopilot's measured work [s].
pub const AUTOPILOT_MEMORY_S: f64 = 3600.0;

/// The play's half-width in the indicator's noise sd.
pub const PLAY_SIGMAS: f64 = 3.0;

/// The longest step between two rudder samples that counts [s]: over a longer gap the play
/// starts again at the new sample (nothing is known of the travel in between).
pub const MAX_STEP_S: f64 = 5.0;

/// The measured rudder's travel, the autopilot's own rate and the running test's travel.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Work {
    /// The play's output [rad] and the time of its last sample [s].
    play: Option<(f64, f64)>,
    /// Autopilot-alone travel [rad] and time [s], both weighted by their age.
    own: (f64, f64),
    /// The running test's travel [rad] (`None` between tests).
    test: Option<f64>,
}

impl Work {
    /// A rudder sample `delta` [rad] at `t` [s], the play's half-width `h` [rad].
    pub fn rudder(&mut self, t: f64, delta: f64, h: f64) {
        let Some((y, t0)) = self.play else {
            self.play = Some((delta, t));
            return;
        };
        let dt = t - t0;
        if !(0.0..=MAX_STEP_S).contains(&dt) {
            self.play = Some((delta, t));
            return;
        }
        let out = y.clamp(delta - h, delta + h);
        let travel = (out - y).abs();
        self.play = Some((out, t));
        match &mut self.test {
            Some(w) => *w += travel,
            None => {
                let keep = (-dt / AUTOPILOT_MEMORY_S).exp();
                self.own = (self.own.0 * keep + travel, self.own.1 * keep + dt);
            }
        }
    }

    /// A test starts: its travel counts apart.
    pub fn test_started(&mut self) {
        self.test = Some(0.0);
    }

    /// The autopilot's own rate [rad/s], once it has been measured over a minute.
    pub fn own_rate(&self) -> Option<f64> {
        (self.own.1 >= 60.0 && self.own.0 > 0.0).then(|| self.own.0 / self.own.1)
    }

    /// The test of `duration_s` ended: the gap it asks for under the budget (module doc),
    /// at most `most_s`.
    pub fn test_ended(&mut self, duration_s: f64, most_s: f64) -> f64 {
        let w = self.test.take().unwrap_or(0.0);
        match self.own_rate() {
            Some(r) if duration_s.is_finite() => {
                ((w - r * duration_s) / r - duration_s).max(0.0).min(most_s)
            }
            _ => most_s,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;
    use rand_distr::{Distribution, Normal};

    const RATE: f64 = 10.0;

    /// Feeds `secs` of `f(t)` plus white noise of `sigma` at 10 Hz from `t0`.
    fn feed(w: &mut Work, t0: f64, secs: f64, sigma: f64, f: impl Fn(f64) -> f64) -> f64 {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let n = Normal::new(0.0, sigma).unwrap();
        let steps = (secs * RATE) as usize;
        for k in 0..steps {
            let t = t0 + k as f64 / RATE;
            w.rudder(t, f(t) + n.sample(&mut rng), PLAY_SIGMAS * sigma);
        }
        t0 + steps as f64 / RATE
    }

    /// A sine of amplitude A through the play travels `4 (A - h)` a period, and up to
    /// `2.5 sd` more at each turning point, where the play follows the noise's extreme among
    /// the samples near the peak; noise alone travels about 50 sd an hour.
    #[test]
    fn the_play_measures_the_swing_and_not_the_noise() {
        let sigma = 0.1_f64.to_radians();
        let (a, period) = (2.0_f64.to_radians(), 20.0);
        let mut w = Work::default();
        feed(&mut w, 0.0, 3600.0, sigma, |t| {
            a * (std::f64::consts::TAU * t / period).sin()
        });
        let periods = 3600.0 / period;
        let least = 4.0 * (a - PLAY_SIGMAS * sigma) * periods;
        let most = 4.0 * (a - PLAY_SIGMAS * sigma + 2.5 * sigma) * periods;
        let r = w.own_rate().unwrap() * 3600.0;
        assert!(
            r > least && r < most,
            "{} deg/h outside ({}, {}) deg/h",
            r.to_degrees(),
            least.to_degrees(),
            most.to_degrees()
        );
        let mut quiet = Work::default();
        feed(&mut quiet, 0.0, 3600.0, sigma, |_| 0.0);
        let noise = quiet.own_rate().unwrap_or(0.0) * 3600.0;
        assert!(
            noise > 10.0 * sigma && noise < 100.0 * sigma,
            "{} deg/h",
            noise.to_degrees()
        );
    }

    /// The gap: `A / r - T` for a test that adds `A`; 0 when the test does the autopilot's
    /// work instead of adding to it; the most without a measured rate.
    #[test]
    fn the_gap_keeps_the_budget() {
        let sigma = 0.1_f64.to_radians();
        let (a, period) = (1.0_f64.to_radians(), 30.0);
        let autopilot = |t: f64| a * (std::f64::consts::TAU * t / period).sin();
        let mut w = Work::default();
        assert_eq!(w.test_ended(600.0, 780.0), 780.0);
        let t = feed(&mut w, 0.0, 1800.0, sigma, autopilot);
        let r = w.own_rate().unwrap();
        // A test that swings 3x the autopilot's amplitude at its period for 600 s.
        w.test_started();
        let t = feed(&mut w, t, 600.0, sigma, |t| 3.0 * autopilot(t));
        let added = 4.0 * 2.0 * a * 600.0 / period;
        let gap = w.test_ended(600.0, 1e9);
        let expected = added / r - 600.0;
        assert!(
            (gap - expected).abs() < 0.15 * expected,
            "{gap} s against {expected} s"
        );
        assert_eq!(
            w.own_rate(),
            Some(r),
            "the test's travel is not the autopilot's"
        );
        // A test that moves the rudder less than the autopilot did: no gap.
        w.test_started();
        feed(&mut w, t, 600.0, sigma, |t| 0.5 * autopilot(t));
        assert_eq!(w.test_ended(600.0, 780.0), 0.0);
    }
}
