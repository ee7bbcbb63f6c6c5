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
pub mod config;
pub mod fault;
pub mod mariner;
pub mod mmg;
mod record;
pub mod sea;
pub mod servo;
pub mod ship;

pub use autopilot::{Autopilot, CommandSource};
pub use fault::{Fault, FaultKind, FaultParseError};
pub use record::record;

use crate::angle::{deg, wrap_2pi};
use crate::config::ConfigError;
use crate::model::{SeaState, ShipConfig};
use crate::sim::config::SimConfig;
use crate::wire::{Excitation, Input, Scalar, StateValue};
use fault::Effects;
use mariner::Manoeuvring;
use mmg::MmgInput;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use sea::{MarkovBias, WaveYaw};
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

/// What is simulated: the true speed and displacement, the sea, the faults, the seed.
#[derive(Debug, Clone, PartialEq)]
pub struct Scenario {
    /// True speed through water u [m/s] (> 0).
    pub speed_mps: f64,
    /// True displacement D [t] (> 0), before any displacement fault.
    pub displacement_t: f64,
    /// Sea state (disturbance levels from `SeaConfig::levels`).
    pub sea: SeaState,
    /// Faults, each with its onset.
    pub faults: Vec<Fault>,
    /// Seed of the only random generator.
    pub seed: u64,
}

impl Scenario {
    /// The nominal ship of `cfg` in its configured sea state, no fault.
    pub fn nominal(cfg: &SimConfig, seed: u64) -> Self {
        Self {
            speed_mps: cfg.ship.nominal_speed_mps,
            displacement_t: cfg.ship.nominal_displacement_t,
            sea: cfg.sea.state,
            faults: Vec::new(),
            seed,
        }
    }

    fn check(&self) -> Result<(), SimError> {
        let positive = |field, value: f64| {
            if value.is_finite() && value > 0.0 {
                Ok(())
            } else {
                Err(SimError::Scenario {
                    field,
                    value,
                    allowed: "finite and > 0",
                })
            }
        };
        positive("speed_mps", self.speed_mps)?;
        positive("displacement_t", self.displacement_t)?;
        for f in &self.faults {
            f.check()?;
        }
        Ok(())
    }
}

/// Switches for tests: run without sensor noise, without sea disturbances, or both.
///
/// Switching off scales the random draws by zero; the draws still happen, so the rest of the
/// realisation is unchanged.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SimOptions {
    /// White noise on heading, rudder and speed measurements.
    pub noise: bool,
    /// Rudder-equivalent bias and wave yaw.
    pub disturbances: bool,
}

impl Default for SimOptions {
    fn default() -> Self {
        Self {
            noise: true,
            disturbances: true,
        }
    }
}

impl SimOptions {
    /// No noise, no disturbance: the deterministic ship.
    pub const CLEAN: SimOptions = SimOptions {
        noise: false,
        disturbances: false,
    };
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

/// The tick's measurements, drawn once.
#[derive(Debug, Clone, Copy)]
struct Measurement {
    heading_rad: f64,
    rudder_rad: f64,
    speed_mps: f64,
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
    /// A ship for `scenario` with noise and disturbances on. Checks `cfg` and the scenario.
    pub fn new(cfg: &SimConfig, scenario: &Scenario) -> Result<Ship, SimError> {
        Ship::with_options(cfg, scenario, SimOptions::default())
    }

    /// A ship with noise and disturbances switched by `options`.
    pub fn with_options(
        cfg: &SimConfig,
        scenario: &Scenario,
        options: SimOptions,
    ) -> Result<Ship, SimError> {
        cfg.check()?;
        scenario.check()?;
        let dt = cfg.sensors.dt_s();
        let substeps = cfg.simulation.substeps;
        let h_s = dt / f64::from(substeps);
        let levels = cfg.sea.levels(scenario.sea);
        let on = |b: bool| if b { 1.0 } else { 0.0 };
        let dist = on(options.disturbances);
        let noise = on(options.noise);

        let mut rng = ChaCha8Rng::seed_from_u64(scenario.seed);
        let mut bias = MarkovBias::new(
            cfg.sea.bias_time_constant_s,
            dist * deg(levels.bias_deg),
            dt,
        );
        let mut wave = WaveYaw::new(
            cfg.sea.wave_frequency_rad_s,
            cfg.sea.wave_damping,
            dist * deg(levels.wave_yaw_deg),
            dt,
        )?;
        bias.start(normal(&mut rng));
        let (n1, n2) = (normal(&mut rng), normal(&mut rng));
        wave.start(n1, n2);

        // Start trimmed: rudder and autopilot integral balance the initial bias.
        let max = cfg.servo.max_angle_rad();
        let trim = (-bias.value_rad()).clamp(-max, max);
        let course = deg(cfg.simulation.initial_course_deg);
        let (a, b) = cfg.ship.nomoto(scenario.speed_mps, scenario.displacement_t);
        let st = &cfg.structure;
        let hull = Hull {
            psi_rad: wrap_2pi(course),
            r_rad_s: 0.0,
        };
        let mmg = Manoeuvring::new(st.hull, st.mmg_length_m, scenario.speed_mps, hull.psi_rad)?;
        let general = (!st.first_order_hull() && mmg.is_none()).then(|| {
            let s = Structure::new(
                a,
                b,
                st.nomoto_t2_ratio,
                st.nomoto_t3_ratio,
                st.norrbin_n3_s2,
            );
            (*st, GeneralHull::steady(&s, &hull, trim + bias.value_rad()))
        });
        let backlash = (st.rudder_backlash_deg > 0.0)
            .then(|| Backlash::new(deg(st.rudder_backlash_deg), trim));
        // On the MMG hull the autopilot is tuned by the same pole placement on that hull's own
        // linearised first-order model (at the nominal displacement; at the nominal speed too
        // when it has fixed gains), as it would be commissioned on its ship.
        let gains = match &mmg {
            Some(m) => {
                let tuned = match cfg.autopilot.speed_scheduling {
                    true => m.clone(),
                    false => Manoeuvring::new(
                        st.hull,
                        st.mmg_length_m,
                        cfg.ship.nominal_speed_mps,
                        hull.psi_rad,
                    )?
                    .unwrap_or_else(|| m.clone()),
                };
                let (k, t) = tuned.linear(1.0, 1.0).first_order();
                cfg.autopilot.gains_for_first_order(k, t)
            }
            None => cfg.autopilot.gains_at(&cfg.ship, scenario.speed_mps),
        };
        let autopilot = Autopilot::new(
            gains,
            cfg.autopilot.wave_filter_rad_s,
            max,
            course,
            trim,
            dt,
        );
        Ok(Ship {
            ship_cfg: cfg.ship.clone(),
            speed_mps: scenario.speed_mps,
            displacement_t: scenario.displacement_t,
            faults: scenario.faults.clone(),
            servo_rate_rad_s: cfg.servo.max_rate_rad_s(),
            tick: 0,
            start_s: cfg.simulation.start_time_s,
            rate_hz: cfg.sensors.rate_hz,
            substeps,
            h_s,
            full: HullStep::new(a, h_s),
            a_per_s: a,
            hull,
            general,
            autopilot_cfg: cfg.autopilot.clone(),
            declared_displacement_t: None,
            mmg,
            nominal_displacement_t: cfg.ship.nominal_displacement_t,
            servo: Servo::new(
                max,
                cfg.servo.max_rate_rad_s(),
                cfg.servo.time_constant_s,
                trim,
                h_s,
            )
            .with_dead_band(deg(st.rudder_dead_band_deg)),
            backlash,
            autopilot,
            bias,
            wave,
            sea_levels: levels,
            rng,
            heading_noise_rad: noise * deg(cfg.sensors.heading_noise_deg),
            rudder_noise_rad: noise * deg(cfg.sensors.rudder_noise_deg),
            speed_noise_mps: noise * cfg.sensors.speed_noise_mps,
            meas: None,
            status_period_s: cfg.sensors.status_period_s,
            status_count: 0,
            status_dirty: true,
            override_rad: None,
            last_command_rad: trim,
            last_source: CommandSource::Own,
            rate_limited: false,
        })
    }

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

    /// The tick's measurements, drawing them on first use.
    fn measure(&mut self) -> Measurement {
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
    pub fn set_sea(&mut self, levels: config::SeaLevels) -> Result<(), SimError> {
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
