//! A ship built from a configuration and a scenario: the sea at its stationary start, the
//! hull, and the servo and autopilot trimmed against the initial bias.

use super::autopilot::{Autopilot, CommandSource, PidGains};
use super::config::{SeaLevels, SimConfig, StructureConfig};
use super::mariner::Manoeuvring;
use super::sea::{MarkovBias, WaveYaw};
use super::servo::{Backlash, Servo};
use super::ship::{GeneralHull, Hull, HullStep, Structure};
use super::{normal, Scenario, Ship, SimError, SimOptions};
use crate::angle::{deg, wrap_2pi};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

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
        let (bias, wave) = start_sea(cfg, &levels, dist, dt, &mut rng)?;

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
        let general = general_hull(st, mmg.as_ref(), a, b, &hull, trim + bias.value_rad());
        let backlash = (st.rudder_backlash_deg > 0.0)
            .then(|| Backlash::new(deg(st.rudder_backlash_deg), trim));
        let gains = autopilot_gains(cfg, scenario, mmg.as_ref(), hull.psi_rad)?;
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
}

/// The sea's bias and wave yaw at their stationary starts, from the first three draws of
/// `rng` (beta, wave x1, wave x2), scaled by `dist` (0 with the disturbances off).
fn start_sea(
    cfg: &SimConfig,
    levels: &SeaLevels,
    dist: f64,
    dt: f64,
    rng: &mut ChaCha8Rng,
) -> Result<(MarkovBias, WaveYaw), SimError> {
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
    bias.start(normal(rng));
    let (n1, n2) = (normal(rng), normal(rng));
    wave.start(n1, n2);
    Ok((bias, wave))
}

/// The hull's structure beyond the first order, in steady state at the rudder-equivalent
/// angle `steady_rad` (None: the exact first-order hull, or the MMG hull).
fn general_hull(
    st: &StructureConfig,
    mmg: Option<&Manoeuvring>,
    a: f64,
    b: f64,
    hull: &Hull,
    steady_rad: f64,
) -> Option<(StructureConfig, GeneralHull)> {
    (!st.first_order_hull() && mmg.is_none()).then(|| {
        let s = Structure::new(
            a,
            b,
            st.nomoto_t2_ratio,
            st.nomoto_t3_ratio,
            st.norrbin_n3_s2,
        );
        (*st, GeneralHull::steady(&s, hull, steady_rad))
    })
}

/// The autopilot's gains for the scenario's ship. On the MMG hull the autopilot is tuned by
/// the same pole placement on that hull's own linearised first-order model (at the nominal
/// displacement; at the nominal speed too when it has fixed gains), as it would be
/// commissioned on its ship.
fn autopilot_gains(
    cfg: &SimConfig,
    scenario: &Scenario,
    mmg: Option<&Manoeuvring>,
    psi_rad: f64,
) -> Result<PidGains, SimError> {
    let st = &cfg.structure;
    Ok(match mmg {
        Some(m) => {
            let tuned = match cfg.autopilot.speed_scheduling {
                true => m.clone(),
                false => Manoeuvring::new(
                    st.hull,
                    st.mmg_length_m,
                    cfg.ship.nominal_speed_mps,
                    psi_rad,
                )?
                .unwrap_or_else(|| m.clone()),
            };
            let (k, t) = tuned.linear(1.0, 1.0).first_order();
            cfg.autopilot.gains_for_first_order(k, t)
        }
        None => cfg.autopilot.gains_at(&cfg.ship, scenario.speed_mps),
    })
}
