//! What changes during a run without being a fault: the speed, the loading, the sea, the
//! course, the autopilot's engagement, an open-loop rudder command.

use super::config::SeaLevels;
use super::ship::HullStep;
use super::{Ship, SimError};

impl Ship {
    /// The ship's speed through water becomes `speed_mps` from the next tick (not a fault):
    /// the Nomoto hull's a, the MMG hull's propeller revolutions (set for a steady straight
    /// course at that speed) and its surge speed, and a speed-scheduled autopilot's gains
    /// (re-tuned without a bump in its command). Refuses a speed that is not finite and > 0.
    pub fn set_speed_mps(&mut self, speed_mps: f64) -> Result<(), SimError> {
        if !(speed_mps.is_finite() && speed_mps > 0.0) {
            return Err(SimError::Scenario {
                field: "speed_mps",
                value: speed_mps,
                allowed: "finite and > 0",
            });
        }
        let (a, _) = self.ship_cfg.nomoto(speed_mps, self.displacement_t);
        let gains = match &mut self.mmg {
            Some(m) => {
                m.set_speed_mps(speed_mps)?;
                let (k, t) = m.linear(1.0, 1.0).first_order();
                self.autopilot_cfg
                    .speed_scheduling
                    .then(|| self.autopilot_cfg.gains_for_first_order(k, t))
            }
            None => self
                .autopilot_cfg
                .speed_scheduling
                .then(|| self.autopilot_cfg.gains_at(&self.ship_cfg, speed_mps)),
        };
        if let Some(g) = gains {
            self.autopilot.set_gains(g);
        }
        self.speed_mps = speed_mps;
        self.a_per_s = a;
        self.full = HullStep::new(a, self.h_s);
        Ok(())
    }

    /// The ship is loaded to `displacement_t` (its true displacement from the next tick, not
    /// a fault) and declares it: `design/displacement` (kg) goes out with the status at the
    /// next tick and every status period after. Refuses a value that is not finite and > 0.
    pub fn set_loading_t(&mut self, displacement_t: f64) -> Result<(), SimError> {
        if !(displacement_t.is_finite() && displacement_t > 0.0) {
            return Err(SimError::Scenario {
                field: "displacement_t",
                value: displacement_t,
                allowed: "finite and > 0",
            });
        }
        self.displacement_t = displacement_t;
        self.declared_displacement_t = Some(displacement_t);
        self.status_dirty = true;
        Ok(())
    }

    /// The sea becomes `levels` from the next tick (the weather, not a fault): the
    /// rudder-equivalent bias and the wave yaw keep their state, rescaled to the new
    /// standard deviations (both stay stationary; no random draw, so the run's other draws
    /// are those of the same seed). A level that was zero stays zero. Refuses levels that
    /// are not finite and >= 0.
    pub fn set_sea(&mut self, levels: SeaLevels) -> Result<(), SimError> {
        for (field, value) in [
            ("sea.wave_yaw_deg", levels.wave_yaw_deg),
            ("sea.bias_deg", levels.bias_deg),
        ] {
            if !(value.is_finite() && value >= 0.0) {
                return Err(SimError::Scenario {
                    field,
                    value,
                    allowed: "finite and >= 0",
                });
            }
        }
        let ratio = |new: f64, old: f64| if old > 0.0 { new / old } else { 0.0 };
        self.wave
            .rescale(ratio(levels.wave_yaw_deg, self.sea_levels.wave_yaw_deg));
        self.bias
            .rescale(ratio(levels.bias_deg, self.sea_levels.bias_deg));
        self.sea_levels = levels;
        Ok(())
    }

    /// The displacement the ship declares [t] (None until [`Ship::set_loading_t`]).
    pub fn declared_displacement_t(&self) -> Option<f64> {
        self.declared_displacement_t
    }

    /// Sets the autopilot's target course [rad] (published at the next tick).
    pub fn set_course(&mut self, course_rad: f64) {
        self.autopilot.set_target_rad(course_rad);
        self.status_dirty = true;
    }

    /// `true` = "auto", `false` = "standby" (holds the last command, ignores excitation).
    pub fn set_autopilot_engaged(&mut self, engaged: bool) {
        if engaged != self.autopilot.engaged() {
            self.status_dirty = true;
        }
        self.autopilot.set_engaged(engaged);
    }

    /// Whether the autopilot is in `auto` (else `standby`).
    pub fn autopilot_engaged(&self) -> bool {
        self.autopilot.engaged()
    }

    /// Open-loop mode for tests: the rudder command is `cmd_rad` (bypasses the autopilot and excitation); None restores.
    pub fn set_command_override(&mut self, cmd_rad: Option<f64>) {
        self.override_rad = cmd_rad;
    }
}
