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
        }
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
        let c = self.clamp_command(cmd_rad);
        let d0 = self.delta_rad;
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
