//! The ship's sensors: the tick's measurements, drawn once, and their publication in
//! lockstep order on the sensors' clock.

use super::fault::Effects;
use super::{normal, FaultKind, Ship};
use crate::angle::wrap_2pi;
use crate::wire::{Input, Scalar, StateValue};

/// The tick's measurements, drawn once.
#[derive(Debug, Clone, Copy)]
pub(super) struct Measurement {
    pub(super) heading_rad: f64,
    pub(super) rudder_rad: f64,
    pub(super) speed_mps: f64,
}

impl Ship {
    /// The tick's measurements, drawing them on first use.
    pub(super) fn measure(&mut self) -> Measurement {
        if let Some(m) = self.meas {
            return m;
        }
        let t = self.time_s();
        let fx = Effects::at(&self.faults, t);
        let n_rudder = normal(&mut self.rng);
        let n_speed = normal(&mut self.rng);
        let n_heading = normal(&mut self.rng);
        let m = Measurement {
            rudder_rad: self.rudder_rad() + self.rudder_noise_rad * n_rudder,
            speed_mps: self.true_speed_mps() * fx.speed_log_scale
                + fx.speed_log_bias_mps
                + self.speed_noise_mps * n_speed,
            heading_rad: wrap_2pi(
                self.hull.psi_rad
                    + self.wave.value_rad()
                    + fx.heading_drift_rad
                    + self.heading_noise_rad * n_heading,
            ),
        };
        self.meas = Some(m);
        m
    }

    /// Measurements at the current tick, drawn exactly once per tick, in lockstep order:
    /// rudder, speed, (autopilot state, target heading when due), heading LAST. Appends to `out`.
    ///
    /// The state and target are due every `sensors.status-period-s` from the start, and at the
    /// first tick after either changes; the declared displacement (after
    /// [`Ship::set_loading_t`], in kg) goes out with them, after the target. Only the state's
    /// string is allocated (once per status period); reuse `out` between calls.
    pub fn publish(&mut self, out: &mut Vec<Input>) {
        let m = self.measure();
        let t = self.clock_s() + self.outlier_s();
        out.push(Input::Rudder(Scalar {
            t,
            value: m.rudder_rad,
        }));
        out.push(Input::Speed(Scalar {
            t,
            value: m.speed_mps,
        }));
        // Publications are due by ship time; only their stamps carry the sensors' clock.
        let now = self.time_s();
        let next_due = self.start_s + self.status_count as f64 * self.status_period_s;
        if self.status_dirty || now >= next_due - 1e-9 {
            out.push(Input::AutopilotState(StateValue {
                t,
                value: self.autopilot.state_name().to_string(),
            }));
            out.push(Input::TargetHeading(Scalar {
                t,
                value: self.autopilot.target_rad(),
            }));
            if let Some(d) = self.declared_displacement_t {
                out.push(Input::DesignDisplacement(Scalar {
                    t,
                    value: d * 1000.0,
                }));
            }
            self.status_dirty = false;
            while self.start_s + self.status_count as f64 * self.status_period_s <= now + 1e-9 {
                self.status_count += 1;
            }
        }
        out.push(Input::Heading(Scalar {
            t,
            value: m.heading_rad,
        }));
    }

    /// The sensors' clock: ship time plus any stepped clock ([`FaultKind::ClockStepS`]) [s].
    pub fn clock_s(&self) -> f64 {
        let t = self.time_s();
        t + Effects::at(&self.faults, t).clock_offset_s
    }

    /// The wild-timestamp offset of this tick ([`FaultKind::ClockOutlierS`]: the one tick at
    /// or just after its onset) [s].
    fn outlier_s(&self) -> f64 {
        let t = self.time_s();
        let dt = 1.0 / self.rate_hz;
        self.faults
            .iter()
            .filter(|f| f.kind == FaultKind::ClockOutlierS)
            .filter(|f| t >= f.onset_s - 1e-9 && t < f.onset_s + dt - 1e-9)
            .map(|f| f.value)
            .sum()
    }
}
