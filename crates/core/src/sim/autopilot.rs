//! The simulated heading autopilot: wave filter, PID with anti-windup, and the autopilot side
//! of the excitation contract.
//!
//! Every tick (dt = 1 / sensor rate), from the measured heading psi_m [rad]:
//!
//! ```text
//! e   = wrap_pi(target - psi_m)                                    heading error [rad]
//! x1' = x2,  x2' = wf^2 (e - x1) - 2 wf x2                         critically damped low-pass
//! own = Kp (x1 + Td x2 + I / Ti),   I = integral of x1 dt          PID [rad]
//! ```
//!
//! The filter (wf = 0.25 rad/s) is discretised exactly for an error held over a tick, the
//! double pole giving
//!
//! ```text
//! Phi   = e^{-wf dt} [[1 + wf dt, dt], [-wf^2 dt, 1 - wf dt]]
//! Gamma = [1 - e^{-wf dt} (1 + wf dt), wf^2 dt e^{-wf dt}]
//! ```
//!
//! and the tick's sample is taken as held over the interval that ends at it, so the command
//! of a tick depends on that tick's heading. The integral is a forward rectangle, added after
//! the command is formed. Gains Kp, Td, Ti come from `AutopilotConfig::gains` (pole placement
//! on the nominal ship).
//!
//! Excitation (CONTRACT "Daemon -> autopilot"): the autopilot keeps the latest message it
//! received. If it is valid now (`t <= now <= t + hold_s`): `add` gives `own + value`,
//! `replace` gives `value` (the integral is frozen), `none` gives `own`. Nothing valid: `own`.
//!
//! Anti-windup: the integral is frozen while the final command is at or beyond the servo's
//! angle limit and the filtered error would drive it further.
//!
//! States: `auto` (the above) and `standby`, where the autopilot holds its last rudder
//! command, ignores excitation and freezes its integral; the filter keeps running, so
//! re-engaging is smooth. A test override of the command (open loop) also freezes the
//! integral.

use crate::angle::{wrap_2pi, wrap_pi};
use crate::model::ShipConfig;
use crate::sim::config::AutopilotConfig;
use crate::wire::{Excitation, ExcitationMode};

/// Where the rudder command of a tick came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CommandSource {
    /// The autopilot's own PID.
    Own,
    /// PID plus a valid `add` excitation.
    Added,
    /// A valid `replace` excitation.
    Replaced,
    /// Standby: the last command, held.
    Standby,
    /// The test override of [`super::Ship::set_command_override`].
    Override,
}

/// The heading autopilot.
#[derive(Debug, Clone)]
pub struct Autopilot {
    gains: PidGains,
    /// Filter transition matrix, row major.
    phi: [f64; 4],
    /// Filter input gain.
    gamma: [f64; 2],
    /// Filtered error x1 [rad] and its derivative x2 [rad/s].
    x: [f64; 2],
    /// Integral of x1 [rad s].
    integral_rad_s: f64,
    /// Target heading [rad], in [0, 2 pi).
    target_rad: f64,
    /// Auto (true) or standby.
    engaged: bool,
    /// Last command issued (after the angle limit) [rad].
    last_command_rad: f64,
    /// Latest excitation message received.
    excitation: Option<Excitation>,
    /// Servo angle limit [rad].
    max_angle_rad: f64,
    /// Tick [s].
    dt_s: f64,
}

impl Autopilot {
    /// An engaged autopilot on course `target_rad`, ticking every `dt_s`, with its integral
    /// set so that its first command (at zero error) is `trim_rad`.
    pub fn new(
        gains: PidGains,
        wave_filter_rad_s: f64,
        max_angle_rad: f64,
        target_rad: f64,
        trim_rad: f64,
        dt_s: f64,
    ) -> Self {
        let w = wave_filter_rad_s;
        let ex = (-w * dt_s).exp();
        Self {
            gains,
            phi: [
                ex * (1.0 + w * dt_s),
                ex * dt_s,
                -ex * w * w * dt_s,
                ex * (1.0 - w * dt_s),
            ],
            gamma: [1.0 - ex * (1.0 + w * dt_s), w * w * dt_s * ex],
            x: [0.0, 0.0],
            integral_rad_s: trim_rad * gains.ti_s / gains.kp,
            target_rad: wrap_2pi(target_rad),
            engaged: true,
            last_command_rad: trim_rad,
            excitation: None,
            max_angle_rad,
            dt_s,
        }
    }

    /// New gains (a speed-scheduled autopilot at a new speed), without a bump: the integral
    /// is rescaled so that its share of the command, Kp I / Ti, is unchanged.
    pub fn set_gains(&mut self, gains: PidGains) {
        let share = self.gains.kp * self.integral_rad_s / self.gains.ti_s;
        self.integral_rad_s = share * gains.ti_s / gains.kp;
        self.gains = gains;
    }

    /// Target heading [rad] in [0, 2 pi).
    pub fn target_rad(&self) -> f64 {
        self.target_rad
    }

    /// Sets the target heading [rad] (wrapped to [0, 2 pi)).
    pub fn set_target_rad(&mut self, course_rad: f64) {
        self.target_rad = wrap_2pi(course_rad);
    }

    /// Whether the autopilot is in `auto`.
    pub fn engaged(&self) -> bool {
        self.engaged
    }

    /// `auto` (true) or `standby` (false).
    pub fn set_engaged(&mut self, engaged: bool) {
        self.engaged = engaged;
    }

    /// Signal K state name: `auto` or `standby`.
    pub fn state_name(&self) -> &'static str {
        if self.engaged {
            "auto"
        } else {
            "standby"
        }
    }

    /// Stores the latest excitation message.
    pub fn receive(&mut self, e: &Excitation) {
        match &mut self.excitation {
            // Reuse the stored message's allocation for the test id.
            Some(stored) => stored.clone_from(e),
            None => self.excitation = Some(e.clone()),
        }
    }

    /// Last command issued [rad].
    pub fn last_command_rad(&self) -> f64 {
        self.last_command_rad
    }

    /// Filtered heading error x1 [rad] and its rate x2 [rad/s].
    pub fn filtered_error(&self) -> (f64, f64) {
        (self.x[0], self.x[1])
    }

    /// The rudder command of the tick at `now_s` given its measured heading; `override_rad`
    /// replaces everything (tests). Returns the command, limited to the servo angle, and its
    /// source.
    pub fn command(
        &mut self,
        now_s: f64,
        heading_meas_rad: f64,
        override_rad: Option<f64>,
    ) -> (f64, CommandSource) {
        let e = wrap_pi(self.target_rad - heading_meas_rad);
        let [p11, p12, p21, p22] = self.phi;
        let x1 = p11 * self.x[0] + p12 * self.x[1] + self.gamma[0] * e;
        let x2 = p21 * self.x[0] + p22 * self.x[1] + self.gamma[1] * e;
        self.x = [x1, x2];
        let g = self.gains;
        let own = g.kp * (x1 + g.td_s * x2 + self.integral_rad_s / g.ti_s);

        let (raw, source) = if let Some(c) = override_rad {
            (c, CommandSource::Override)
        } else if !self.engaged {
            (self.last_command_rad, CommandSource::Standby)
        } else {
            match self.excitation.as_ref().filter(|m| m.valid_at(now_s)) {
                Some(m) if m.mode == ExcitationMode::Add => (own + m.value, CommandSource::Added),
                Some(m) if m.mode == ExcitationMode::Replace => (m.value, CommandSource::Replaced),
                _ => (own, CommandSource::Own),
            }
        };
        let cmd = raw.clamp(-self.max_angle_rad, self.max_angle_rad);

        if matches!(source, CommandSource::Own | CommandSource::Added) {
            let winding_up = raw.abs() >= self.max_angle_rad && x1 * raw > 0.0;
            if !winding_up {
                self.integral_rad_s += x1 * self.dt_s;
            }
        }
        self.last_command_rad = cmd;
        (cmd, source)
    }
}

// ---------------------------------------------------------------------------------------------
// Pole placement (Fossen): the gains of the simulated autopilot

/// PID gains resolved from [`AutopilotConfig`] and the nominal ship.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PidGains {
    /// Proportional gain [rad/rad].
    pub kp: f64,
    /// Derivative time [s].
    pub td_s: f64,
    /// Integral time [s].
    pub ti_s: f64,
}

impl AutopilotConfig {
    /// Gains by pole placement for the nominal ship of `ship`, with overrides applied.
    pub fn gains(&self, ship: &ShipConfig) -> PidGains {
        self.gains_for(ship, ship.nominal_speed_mps)
    }

    /// Gains for a ship sailing at `speed_mps`: pole placement at that speed and the nominal
    /// displacement when `speed-scheduling` is on, else the nominal ship's gains.
    pub fn gains_at(&self, ship: &ShipConfig, speed_mps: f64) -> PidGains {
        if self.speed_scheduling {
            self.gains_for(ship, speed_mps)
        } else {
            self.gains(ship)
        }
    }

    fn gains_for(&self, ship: &ShipConfig, speed_mps: f64) -> PidGains {
        let (a, b) = ship.nomoto(speed_mps, ship.nominal_displacement_t);
        self.gains_for_first_order(b / a, 1.0 / a)
    }

    /// Gains by pole placement for a ship whose first-order Nomoto model is K = `k_per_s`,
    /// T = `t_s` (how the simulator tunes the autopilot on a hull that is no Nomoto ship,
    /// from that hull's own linearised model), with overrides applied.
    pub fn gains_for_first_order(&self, k_per_s: f64, t_s: f64) -> PidGains {
        let (k, t) = (k_per_s, t_s);
        let wn = self.natural_frequency_rad_s;
        let kp = self.kp.unwrap_or(t / k * wn * wn);
        let td_s = self
            .td_s
            .unwrap_or((t / (k * kp) * (2.0 * self.damping * wn - 1.0 / t)).max(0.0));
        let ti_s = self.ti_s.unwrap_or(self.integral_time_factor / wn);
        PidGains { kp, td_s, ti_s }
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use nalgebra::{Matrix3, Vector2};

    /// The closed-form filter discretisation against nalgebra's matrix exponential of the
    /// augmented system [[A, B], [0, 0]] dt.
    #[test]
    fn filter_discretisation_matches_matrix_exponential() {
        let (w, dt) = (0.25, 0.1);
        let gains = PidGains {
            kp: 1.0,
            td_s: 0.0,
            ti_s: 1.0,
        };
        let ap = Autopilot::new(gains, w, 0.5, 0.0, 0.0, dt);
        let m = Matrix3::new(0.0, 1.0, 0.0, -w * w, -2.0 * w, w * w, 0.0, 0.0, 0.0) * dt;
        let f = m.exp();
        let phi = [f[(0, 0)], f[(0, 1)], f[(1, 0)], f[(1, 1)]];
        for (x, y) in phi.iter().zip(ap.phi.iter()) {
            assert!((x - y).abs() < 1e-14, "{phi:?} {:?}", ap.phi);
        }
        let gamma = Vector2::new(f[(0, 2)], f[(1, 2)]);
        assert!((gamma.x - ap.gamma[0]).abs() < 1e-14);
        assert!((gamma.y - ap.gamma[1]).abs() < 1e-14);
    }

    /// A constant error: x1 tends to it, the integral grows, excitation modes and standby.
    #[test]
    fn modes_follow_the_contract() {
        let gains = PidGains {
            kp: 2.0,
            td_s: 10.0,
            ti_s: 100.0,
        };
        let max = 30f64.to_radians();
        let mut ap = Autopilot::new(gains, 0.25, max, 0.1, 0.0, 0.1);
        // Heading 0.09 rad: error 0.01 rad, held 200 s.
        let mut cmd = 0.0;
        for k in 0..2000 {
            cmd = ap.command(k as f64 * 0.1, 0.09, None).0;
        }
        let (x1, x2) = ap.filtered_error();
        assert!((x1 - 0.01).abs() < 1e-9 && x2.abs() < 1e-9);
        // Integral of x1 over 200 s is a bit less than 2 rad s (filter lag 2 / wf = 8 s).
        let i = (cmd / gains.kp - x1) * gains.ti_s;
        assert!((i - 0.01 * 192.0).abs() < 0.01 * 0.5, "integral {i}");

        let t = 200.0;
        let mut ex = Excitation::none(t, 1.0);
        ex.mode = ExcitationMode::Add;
        ex.value = 0.05;
        ap.receive(&ex);
        let (c_add, s) = ap.command(t, 0.09, None);
        assert_eq!(s, CommandSource::Added);
        assert!((c_add - (cmd + 0.05)).abs() < 1e-3);
        ex.mode = ExcitationMode::Replace;
        ex.value = -0.07;
        ap.receive(&ex);
        assert_eq!(
            ap.command(t + 0.5, 0.09, None),
            (-0.07, CommandSource::Replaced)
        );
        // Expired (hold 1 s): back to the own command.
        assert_eq!(ap.command(t + 1.1, 0.09, None).1, CommandSource::Own);
        // Replace beyond the limit is clamped.
        ex.t = t + 2.0;
        ex.value = 1.0;
        ap.receive(&ex);
        assert_eq!(ap.command(t + 2.0, 0.09, None).0, max);
        // Standby holds the last command and ignores excitation.
        ap.set_engaged(false);
        assert_eq!(ap.state_name(), "standby");
        assert_eq!(
            ap.command(t + 2.1, 0.0, None),
            (max, CommandSource::Standby)
        );
        ap.set_engaged(true);
        assert_eq!(ap.command(t + 2.2, 0.09, None).1, CommandSource::Replaced);
    }
}
