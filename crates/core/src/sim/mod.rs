//! The simulated ship: Nomoto hull, rudder servo, heading autopilot, sea, sensors and faults.
//!
//! One [`Ship`] is a pure, seeded state machine in ship time; it never reads a clock. A driver
//! calls, once per tick (dt = 1 / `sensors.rate-hz`, 0.1 s by default):
//!
//! 1. [`Ship::publish`]: the tick's measurements, in lockstep order (rudder, speed, autopilot
//!    state and target heading when due, heading last);
//! 2. [`Ship::receive_excitation`] with what the daemon answered (optional);
//! 3. [`Ship::step`]: the autopilot forms its command from this tick's measured heading and
//!    the excitation valid now, and the ship integrates to the next tick.
//!
//! ## Model (SI units, radians; see `docs/sim.md`)
//!
//! ```text
//! psi' = r                      heading [rad] (unwrapped internally)
//! r'   = -a r + b (e delta + beta)                   turn rate [rad/s]
//! delta' = clamp((c - delta) / T_r, -R, R)          rudder [rad], c = clamp(cmd, +-max)
//! (a, b) = ShipConfig::nomoto(u, D)                  u true speed, D true displacement
//! ```
//!
//! e is the rudder effectiveness (1 nominal), beta the sea's rudder-equivalent bias
//! ([`sea`]). With `structure.hull = "kvlcc2-mmg"` the hull is instead the surge-sway-yaw MMG
//! model of KVLCC2 ([`mmg`]), with `"mariner"` the Mariner cargo ship's ([`mariner`]): the
//! rudder delta drives it, e scales its rudder force, beta acts as the straight-running
//! rudder force and moment of that angle, D / D_nom scales its mass and yaw inertia, the speed log reads its surge speed, and the autopilot is tuned
//! by the same pole placement on its own linearised first-order model. Sensors at each tick,
//! with white noise n_* of the configured std:
//!
//! ```text
//! heading = wrap_2pi(psi + wave + drift + n_h)       [rad, 0 .. 2 pi)
//! rudder  = delta + n_r                               [rad]
//! speed   = u scale + bias + n_u                      [m/s]  (scale 1, bias 0 unless faulted)
//! ```
//!
//! ## Operating point
//!
//! The speed and the loading may change during a run, as on a passage; neither is a fault.
//! [`Ship::set_speed_mps`] sets u (the MMG hull: its propeller revolutions for that steady
//! speed and its surge speed; a speed-scheduled autopilot re-tunes without a bump), and the
//! speed log reads it from the next tick. [`Ship::set_loading_t`] sets the true displacement
//! and declares it: from the next tick the ship publishes `design/displacement` (in kg) with
//! its status, every `sensors.status-period-s`. Displacement faults act on the displacement in
//! force (a `displacement_pct` fault stays relative to it).
//!
//! ## Integration
//!
//! The autopilot's command is held over the tick (zero-order hold). The tick is cut into
//! `simulation.substeps` sub-steps (5, h = 0.02 s). In each, the servo is solved exactly
//! (a rate-limited ramp then an exponential, [`servo`]), and the hull exactly for a rudder
//! linear within each piece ([`ship`]): exact on ramps, a first-order hold between end points
//! in the exponential phase. beta is held over the tick and then stepped (exact Markov
//! discretisation); the wave state is stepped exactly once per tick.
//!
//! ## Randomness
//!
//! One `ChaCha8Rng` seeded from [`Scenario::seed`]. Draw order: at construction beta, wave
//! x1, wave x2 (stationary starts); per tick, the measurement noises (rudder, speed, heading)
//! exactly once, then in `step` beta, wave x1, wave x2. Draws happen whatever the
//! [`SimOptions`], which only scale them by zero, so switching noise off leaves the sea's
//! realisation unchanged, and the sequence never depends on whether `publish` was called.

pub mod autopilot;
mod build;
pub mod config;
mod controls;
pub mod fault;
pub mod mariner;
pub mod mmg;
mod record;
mod scenario;
pub mod sea;
mod sensors;
pub mod servo;
pub mod ship;

pub use autopilot::{Autopilot, CommandSource};
pub use fault::{Fault, FaultKind, FaultParseError};
pub use record::record;
pub use scenario::{Scenario, SimOptions};

use crate::config::ConfigError;
use crate::model::ShipConfig;
use crate::wire::Excitation;
use fault::Effects;
use mariner::Manoeuvring;
use mmg::MmgInput;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use sea::{MarkovBias, WaveYaw};
use sensors::Measurement;
use servo::{Backlash, Servo};
use ship::{GeneralHull, Hull, HullStep, Structure};

/// Why a simulation could not be set up or run.
#[derive(Debug, thiserror::Error)]
pub enum SimError {
    /// The configuration breaks one of its limits.
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// A scenario value is out of range.
    #[error("scenario {field} = {value}: allowed {allowed}")]
    Scenario {
        /// Field name.
        field: &'static str,
        /// Offending value.
        value: f64,
        /// Allowed range.
        allowed: &'static str,
    },
    /// A fault of the scenario is invalid.
    #[error(transparent)]
    Fault(#[from] FaultParseError),
    /// The wave filter cannot be discretised at this step.
    #[error(transparent)]
    Wave(#[from] sea::WaveDiscretisationError),
    /// The surge-sway-yaw hull cannot be built for this scenario.
    #[error(transparent)]
    Mmg(#[from] mmg::MmgError),
    /// Writing a recording failed.
    #[error("writing the recording: {0}")]
    Io(#[from] std::io::Error),
    /// Serialising a recording line failed.
    #[error("serialising a recording line: {0}")]
    Json(#[from] serde_json::Error),
}

/// The true state of the ship at the current tick (what no sensor sees exactly).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Truth {
    /// Ship time [s].
    pub t_s: f64,
    /// True heading psi [rad], unwrapped (continuous through north).
    pub psi_rad: f64,
    /// Turn rate r [rad/s].
    pub r_rad_s: f64,
    /// Rudder angle delta [rad].
    pub delta_rad: f64,
    /// Rudder-equivalent sea bias beta [rad] (held over the coming tick).
    pub beta_rad: f64,
    /// Wave yaw on the heading measurement [rad].
    pub wave_rad: f64,
    /// Heading sensor drift on the measurement [rad].
    pub drift_rad: f64,
    /// Nomoto a [1/s] in force (the MMG hull: 1/T of its linearised first-order model,
    /// starboard side).
    pub a_per_s: f64,
    /// Nomoto b [1/s^2] in force (with the displacement fault, without the effectiveness;
    /// the MMG hull: K/T of its linearised first-order model, starboard side).
    pub b_per_s2: f64,
    /// Rudder effectiveness e in force (1 nominal).
    pub rudder_effectiveness: f64,
    /// Servo rate limit in force [rad/s].
    pub servo_rate_rad_s: f64,
    /// True speed through water [m/s] (the MMG hull: its surge speed u, which drops in a
    /// turn; else the scenario's).
    pub speed_mps: f64,
    /// True displacement in force [t].
    pub displacement_t: f64,
    /// Rudder command of the last step, after the angle limit [rad].
    pub command_rad: f64,
    /// Where that command came from.
    pub command_source: CommandSource,
    /// Whether the servo was at its rate limit at any time during the last step.
    pub rate_limited: bool,
    /// Target heading of the autopilot [rad].
    pub target_rad: f64,
}

/// The simulated ship (see the module documentation for the call order and the model).
#[derive(Debug, Clone)]
pub struct Ship {
    ship_cfg: ShipConfig,
    /// Scenario speed [m/s] and displacement [t].
    speed_mps: f64,
    displacement_t: f64,
    faults: Vec<Fault>,
    /// Nominal servo rate limit [rad/s].
    servo_rate_rad_s: f64,
    /// Tick count since the start; time = start + tick / rate.
    tick: u64,
    start_s: f64,
    rate_hz: f64,
    /// Sub-steps per tick and their length [s].
    substeps: u32,
    h_s: f64,
    /// Hull coefficients for a full sub-step (a depends only on the speed).
    full: HullStep,
    a_per_s: f64,
    hull: Hull,
    /// The hull's structure beyond the first order, and the state it adds (None: the exact
    /// first-order hull).
    general: Option<(config::StructureConfig, GeneralHull)>,
    /// The autopilot's tuning (re-tuned at a speed change when it is speed-scheduled).
    autopilot_cfg: config::AutopilotConfig,
    /// The displacement the ship declares as `design/displacement` [t] (None: none declared).
    declared_displacement_t: Option<f64>,
    /// The surge-sway-yaw hull, when `structure.hull` is `kvlcc2-mmg` or `mariner` (heading
    /// and turn rate are copied into `hull` after every piece), and the nominal displacement its mass refers to [t].
    mmg: Option<Manoeuvring>,
    nominal_displacement_t: f64,
    servo: Servo,
    /// Play between the servo and the blade (None: none).
    backlash: Option<Backlash>,
    autopilot: Autopilot,
    bias: MarkovBias,
    wave: WaveYaw,
    /// The sea's levels the bias and the wave yaw are at now.
    sea_levels: config::SeaLevels,
    rng: ChaCha8Rng,
    /// Noise std [rad, rad, m/s], zero when noise is off.
    heading_noise_rad: f64,
    rudder_noise_rad: f64,
    speed_noise_mps: f64,
    /// This tick's measurements, once drawn.
    meas: Option<Measurement>,
    /// Status (autopilot state, target) period [s], next due time index, forced by a change.
    status_period_s: f64,
    status_count: u64,
    status_dirty: bool,
    override_rad: Option<f64>,
    last_command_rad: f64,
    last_source: CommandSource,
    rate_limited: bool,
}

impl Ship {
    /// Adds `fault` from the next tick on (its onset set to now): a fault that appears
    /// during a run, after commissioning (the FDI suite).
    pub fn inject(&mut self, mut fault: Fault) {
        fault.onset_s = self.time_s();
        self.faults.push(fault);
    }

    /// Current tick time [s]; starts at `simulation.start_time_s`.
    pub fn time_s(&self) -> f64 {
        self.start_s + self.tick as f64 / self.rate_hz
    }

    /// Tick length [s].
    pub fn dt_s(&self) -> f64 {
        1.0 / self.rate_hz
    }

    /// The autopilot side of the contract: store the latest excitation message.
    pub fn receive_excitation(&mut self, e: &Excitation) {
        self.autopilot.receive(e);
    }

    /// Advance one tick: the autopilot computes its command from this tick's measured heading
    /// and the excitation valid now; the ship integrates to the next tick. If publish() was not
    /// called this tick, the measurements are drawn anyway (so the RNG sequence never depends on it).
    pub fn step(&mut self) {
        let m = self.measure();
        let t = self.time_s();
        let fx = Effects::at(&self.faults, t);
        let (_, b) = self
            .ship_cfg
            .nomoto(self.speed_mps, self.displacement_t * fx.displacement_factor);
        let e = fx.rudder_effectiveness;
        self.servo
            .set_rate_rad_s(fx.servo_rate_rad_s.unwrap_or(self.servo_rate_rad_s));
        // The autopilot lives on the sensors' clock: the excitation it holds carries that `t`.
        let now = t + fx.clock_offset_s;
        let (cmd, source) = self
            .autopilot
            .command(now, m.heading_rad, self.override_rad);
        let beta = self.bias.value_rad();

        let mut rate_limited = false;
        let mmg_input = MmgInput {
            rudder_effectiveness: e,
            sea_rad: beta,
            mass_factor: fx.displacement_factor * self.displacement_t / self.nominal_displacement_t,
        };
        let structure = self.general.as_ref().map(|(st, _)| {
            Structure::new(
                self.a_per_s,
                b,
                st.nomoto_t2_ratio,
                st.nomoto_t3_ratio,
                st.norrbin_n3_s2,
            )
        });
        for _ in 0..self.substeps {
            let pieces = self.servo.advance(cmd, self.h_s);
            for p in pieces.as_slice() {
                rate_limited |= p.ramp;
                // The blade: the servo's angle through the play, if any.
                let (d0, d1) = match &mut self.backlash {
                    Some(bl) => (bl.blade_rad(), bl.follow(p.delta1_rad)),
                    None => (p.delta0_rad, p.delta1_rad),
                };
                let v0 = e * d0 + beta;
                let v1 = e * d1 + beta;
                if let Some(m) = &mut self.mmg {
                    if p.duration_s > 0.0 {
                        m.advance(d0, d1, &mmg_input, p.duration_s);
                        self.hull.psi_rad = m.state().psi_rad;
                        self.hull.r_rad_s = m.state().r_rad_s;
                    }
                } else if let (Some(s), Some((_, g))) = (&structure, &mut self.general) {
                    if p.duration_s > 0.0 {
                        g.advance(s, &mut self.hull, v0, v1, p.duration_s);
                    }
                } else if p.duration_s == self.h_s {
                    self.hull.advance(&self.full, b, v0, v1);
                } else if p.duration_s > 0.0 {
                    let c = HullStep::new(self.a_per_s, p.duration_s);
                    self.hull.advance(&c, b, v0, v1);
                }
            }
        }

        let nb = normal(&mut self.rng);
        let (n1, n2) = (normal(&mut self.rng), normal(&mut self.rng));
        self.bias.step(nb);
        self.wave.step(n1, n2);
        self.last_command_rad = cmd;
        self.last_source = source;
        self.rate_limited = rate_limited;
        self.tick += 1;
        self.meas = None;
    }

    /// The true speed through water [m/s]: the MMG hull's surge speed, else the scenario's.
    fn true_speed_mps(&self) -> f64 {
        self.mmg
            .as_ref()
            .map_or(self.speed_mps, |m| m.state().u_mps)
    }

    /// The rudder blade's angle [rad]: the servo's, through the backlash if there is one.
    fn rudder_rad(&self) -> f64 {
        self.backlash
            .as_ref()
            .map_or(self.servo.delta_rad(), Backlash::blade_rad)
    }

    /// The true state at the current tick.
    pub fn truth(&self) -> Truth {
        let t = self.time_s();
        let fx = Effects::at(&self.faults, t);
        let displacement_t = self.displacement_t * fx.displacement_factor;
        let (a, b) = match &self.mmg {
            Some(m) => {
                let lin = m.linear(displacement_t / self.nominal_displacement_t, 1.0);
                let (k, t) = lin.first_order();
                (1.0 / t, k / t)
            }
            None => self.ship_cfg.nomoto(self.speed_mps, displacement_t),
        };
        Truth {
            t_s: t,
            psi_rad: self.hull.psi_rad,
            r_rad_s: self.hull.r_rad_s,
            delta_rad: self.rudder_rad(),
            beta_rad: self.bias.value_rad(),
            wave_rad: self.wave.value_rad(),
            drift_rad: fx.heading_drift_rad,
            a_per_s: a,
            b_per_s2: b,
            rudder_effectiveness: fx.rudder_effectiveness,
            servo_rate_rad_s: fx.servo_rate_rad_s.unwrap_or(self.servo_rate_rad_s),
            speed_mps: self.true_speed_mps(),
            displacement_t,
            command_rad: self.last_command_rad,
            command_source: self.last_source,
            rate_limited: self.rate_limited,
            target_rad: self.autopilot.target_rad(),
        }
    }
}

fn normal(rng: &mut ChaCha8Rng) -> f64 {
    StandardNormal.sample(rng)
}

#[cfg(test)]
mod oppoint_tests;
