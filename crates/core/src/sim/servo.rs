//! Rudder servo: angle-limited command, first-order lag, rate limit, angle limit.
//!
//! ```text
//! c       = clamp(cmd, -max, +max)                                [rad]
//! delta'  = clamp((c - delta) / T_r, -R, +R)                      [rad/s]
//! delta   in [-max, +max]                                         [rad]
//! ```
//!
//! with max = 30 deg, R = 4 deg/s, T_r = 1 s by default. For a command held over a sub-step
//! the solution is exact and piecewise analytic: while |c - delta| > R T_r the rudder ramps at
//! the rate limit (a straight line), which takes `(|c - delta| - R T_r) / R`; after that the
//! error decays exponentially, `c - delta(t) = (c - delta_1) exp(-t / T_r)`. So one sub-step
//! is at most two [`Piece`]s: a ramp then an exponential. The rudder moves monotonically
//! towards c, which lies inside the angle limits, so it never leaves them.
//!
//! Two steering-gear nuisances of real ships (`[structure]`, off by default):
//!
//! - a dead band db: a command error |c - delta| <= db/2 leaves the servo at rest; a larger
//!   one drives it to the band's near edge, c - sign(c - delta) db/2 (the valve closes there);
//! - a backlash (play) p between the servo and the rudder blade: the blade stays put until the
//!   servo has taken up the play, then is dragged at its side,
//!   `blade = clamp(blade, delta - p/2, delta + p/2)` ([`Backlash`]); the rudder-angle sensor
//!   reads the blade.

/// One stretch of the rudder trajectory over (part of) a sub-step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Piece {
    /// Length [s].
    pub duration_s: f64,
    /// Rudder at the start [rad].
    pub delta0_rad: f64,
    /// Rudder at the end [rad].
    pub delta1_rad: f64,
    /// Ramp at the rate limit (exactly linear) rather than the exponential phase.
    pub ramp: bool,
}

/// The pieces of one sub-step: a ramp, an exponential, or a ramp then an exponential.
#[derive(Debug, Clone, Copy)]
pub struct Pieces {
    items: [Piece; 2],
    len: usize,
}

impl Pieces {
    /// The pieces in time order.
    pub fn as_slice(&self) -> &[Piece] {
        &self.items[..self.len]
    }
}

/// The rudder servo state and parameters.
#[derive(Debug, Clone)]
pub struct Servo {
    /// Rudder angle [rad].
    delta_rad: f64,
    /// Angle limit [rad].
    max_angle_rad: f64,
    /// Rate limit R [rad/s].
    rate_rad_s: f64,
    /// Time constant T_r [s].
    time_constant_s: f64,
    /// Sub-step length h [s] whose decay factor is cached.
    cached_h_s: f64,
    /// exp(-h / T_r).
    cached_decay: f64,
    /// Dead band on the command error (total width) [rad]; 0: none.
    dead_band_rad: f64,
}

/// The play between the servo and the rudder blade (see the module documentation).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Backlash {
    /// Half the play [rad].
    half_rad: f64,
    /// Blade angle [rad].
    blade_rad: f64,
}

impl Backlash {
    /// A play of `play_rad` (total) with the blade at `blade_rad`.
    pub fn new(play_rad: f64, blade_rad: f64) -> Self {
        Self {
            half_rad: 0.5 * play_rad,
            blade_rad,
        }
    }

    /// The blade after the servo moved to `servo_rad`.
    pub fn follow(&mut self, servo_rad: f64) -> f64 {
        self.blade_rad = self
            .blade_rad
            .clamp(servo_rad - self.half_rad, servo_rad + self.half_rad);
        self.blade_rad
    }

    /// Blade angle [rad].
    pub fn blade_rad(&self) -> f64 {
        self.blade_rad
    }
}

impl Servo {
    /// A servo at rudder `delta_rad` (clamped to the angle limit).
    pub fn new(
        max_angle_rad: f64,
        rate_rad_s: f64,
        time_constant_s: f64,
        delta_rad: f64,
        substep_s: f64,
    ) -> Self {
        Self {
            delta_rad: delta_rad.clamp(-max_angle_rad, max_angle_rad),
            max_angle_rad,
            rate_rad_s,
            time_constant_s,
            cached_h_s: substep_s,
            cached_decay: (-substep_s / time_constant_s).exp(),
            dead_band_rad: 0.0,
        }
    }

    /// The servo with a dead band of `dead_band_rad` (total width) on the command error.
    pub fn with_dead_band(mut self, dead_band_rad: f64) -> Self {
        self.dead_band_rad = dead_band_rad;
        self
    }

    /// Rudder angle [rad].
    pub fn delta_rad(&self) -> f64 {
        self.delta_rad
    }

    /// Angle limit [rad].
    pub fn max_angle_rad(&self) -> f64 {
        self.max_angle_rad
    }

    /// Current rate limit [rad/s].
    pub fn rate_rad_s(&self) -> f64 {
        self.rate_rad_s
    }

    /// Changes the rate limit (a servo fault) [rad/s].
    pub fn set_rate_rad_s(&mut self, rate_rad_s: f64) {
        self.rate_rad_s = rate_rad_s;
    }

    /// The command as the servo takes it: clamped to the angle limit.
    pub fn clamp_command(&self, cmd_rad: f64) -> f64 {
        cmd_rad.clamp(-self.max_angle_rad, self.max_angle_rad)
    }

    fn decay(&self, t_s: f64) -> f64 {
        if t_s == self.cached_h_s {
            self.cached_decay
        } else {
            (-t_s / self.time_constant_s).exp()
        }
    }

    /// Advances the rudder by `h_s` under the held command `cmd_rad` (clamped here), exactly.
    pub fn advance(&mut self, cmd_rad: f64, h_s: f64) -> Pieces {
        let mut c = self.clamp_command(cmd_rad);
        let d0 = self.delta_rad;
        if self.dead_band_rad > 0.0 {
            let half = 0.5 * self.dead_band_rad;
            let e = c - d0;
            c = if e.abs() <= half {
                d0
            } else {
                c - e.signum() * half
            };
        }
        let err = c - d0;
        let knee = self.rate_rad_s * self.time_constant_s;
        let mut pieces = Pieces {
            items: [Piece {
                duration_s: 0.0,
                delta0_rad: d0,
                delta1_rad: d0,
                ramp: false,
            }; 2],
            len: 0,
        };
        let mut t_left = h_s;
        let mut d = d0;
        if err.abs() > knee {
            let t_ramp = (err.abs() - knee) / self.rate_rad_s;
            let t = t_ramp.min(h_s);
            let d1 = if t_ramp >= h_s {
                d0 + err.signum() * self.rate_rad_s * h_s
            } else {
                // Exactly on the knee, free of rounding in the ramp.
                c - err.signum() * knee
            };
            pieces.items[0] = Piece {
                duration_s: t,
                delta0_rad: d0,
                delta1_rad: d1,
                ramp: true,
            };
            pieces.len = 1;
            t_left = h_s - t;
            d = d1;
        }
        if t_left > 0.0 {
            let d1 = c - (c - d) * self.decay(t_left);
            pieces.items[pieces.len] = Piece {
                duration_s: t_left,
                delta0_rad: d,
                delta1_rad: d1,
                ramp: false,
            };
            pieces.len += 1;
            d = d1;
        }
        self.delta_rad = d.clamp(-self.max_angle_rad, self.max_angle_rad);
        pieces
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    const DEG: f64 = std::f64::consts::PI / 180.0;

    /// A large step: ramp at 4 deg/s until 4 deg from the command, then exp(-t / 1 s).
    #[test]
    fn large_step_ramps_then_decays() {
        let h = 0.02;
        let mut s = Servo::new(30.0 * DEG, 4.0 * DEG, 1.0, 0.0, h);
        let mut t = 0.0;
        let mut worst: f64 = 0.0;
        for _ in 0..1000 {
            let pieces = s.advance(20.0 * DEG, h);
            t += h;
            let total: f64 = pieces.as_slice().iter().map(|p| p.duration_s).sum();
            assert!((total - h).abs() < 1e-15);
            // Analytic: ramp to 16 deg by t = 4 s, then 20 - 4 exp(-(t - 4)).
            let expect = if t <= 4.0 {
                4.0 * t
            } else {
                20.0 - 4.0 * (-(t - 4.0)).exp()
            };
            worst = worst.max((s.delta_rad() / DEG - expect).abs());
        }
        assert!(worst < 1e-9, "worst deviation {worst} deg");
    }

    /// Dead band 1 deg: a command 0.4 deg away leaves the servo at rest; one 3 deg away
    /// brings it to 2.5 deg, the band's near edge (the lag's exponential towards it).
    #[test]
    fn a_dead_band_stops_the_servo_at_its_edge() {
        let h = 0.02;
        let mut s = Servo::new(30.0 * DEG, 4.0 * DEG, 1.0, 0.0, h).with_dead_band(1.0 * DEG);
        for _ in 0..500 {
            s.advance(0.4 * DEG, h);
        }
        assert_eq!(s.delta_rad(), 0.0);
        for _ in 0..1000 {
            s.advance(3.0 * DEG, h);
        }
        assert!(
            (s.delta_rad() / DEG - 2.5).abs() < 1e-6,
            "{}",
            s.delta_rad() / DEG
        );
        // Back by less than the band's half: it stays.
        for _ in 0..500 {
            s.advance(2.2 * DEG, h);
        }
        assert!((s.delta_rad() / DEG - 2.5).abs() < 1e-6);
    }

    /// Backlash 2 deg against a sine on the servo: the blade's peaks are those of the servo
    /// less half the play, and it rests for the servo's travel of the whole play after each
    /// reversal.
    #[test]
    fn backlash_takes_half_the_play_off_the_peaks() {
        let mut b = Backlash::new(2.0 * DEG, 0.0);
        let (amp, w, dt) = (5.0, 0.1, 0.01);
        let mut max: f64 = f64::MIN;
        let mut min: f64 = f64::MAX;
        let mut still = 0usize;
        let mut prev = 0.0;
        for i in 0..20_000 {
            let servo = amp * DEG * (w * i as f64 * dt).sin();
            let blade = b.follow(servo);
            if i > 5000 {
                max = max.max(blade);
                min = min.min(blade);
                still += usize::from(blade == prev);
            }
            prev = blade;
        }
        assert!((max / DEG - 4.0).abs() < 1e-3, "{}", max / DEG);
        assert!((min / DEG + 4.0).abs() < 1e-3, "{}", min / DEG);
        // After each reversal the servo travels 2 deg back from its 5 deg peak:
        // sin(phi) = 3/5, the blade rests (pi/2 - asin(0.6)) / w per half period.
        let rest_s = (std::f64::consts::FRAC_PI_2 - 0.6f64.asin()) / w;
        let halves = 15_000.0 * dt * w / std::f64::consts::PI;
        let expect = rest_s * halves / dt;
        assert!(
            (still as f64 / expect - 1.0).abs() < 0.05,
            "{still} samples at rest, expected {expect}"
        );
    }

    #[test]
    fn command_clamped_to_angle_limit() {
        let mut s = Servo::new(30.0 * DEG, 4.0 * DEG, 1.0, 0.0, 0.1);
        for _ in 0..2000 {
            s.advance(90.0 * DEG, 0.1);
        }
        assert!((s.delta_rad() - 30.0 * DEG).abs() < 1e-12);
        assert!(s.delta_rad() <= 30.0 * DEG);
    }
}
