//! `eval --passive`: what normal operation tells about the ship, against one active test
//! (docs/passive.md).
//!
//! Three tables, at the configuration's nominal ship in each sea:
//!
//! 1. The Cramer-Rao bound of the loop model ([`helmwatch_core::passive`]) from `T` minutes
//!    of normal operation, `T` = 10, 30, 60, 120, and from one CLFRT test's measured windows
//!    (its tones, and the same record without them), the autopilot, servo and sea unknown;
//!    beside it the bound with the autopilot and servo known.
//! 2. The shortest record that resolves a 10 % displacement step and a 0.5 m/s speed-log bias
//!    at the decision's budget: with `alpha = fdi.false-alarms-per-year T / year` per
//!    decision, the bound must be below `change / (z(alpha / 2) + z(0.05))` (a two-sided test
//!    of that false-alarm rate detecting the change 95 % of the time).
//! 3. The Monte Carlo of Whittle's estimator on the simulated ship (the full simulator: rate
//!    limit, sampling, the hull's own discretisation), `--runs` records per cell, its spread
//!    of `ln a` and `ln b` against the bound.

use crate::config::Config;
use crate::tools::training::database::par_map;
use helmwatch_core::fdi::stats::normal_isf;
use helmwatch_core::model::SeaState;
use helmwatch_core::passive::{
    course_step_information, information, ship_information, speed_displacement_bounds,
    tone_information, whittle, LoopModel, N_PARAMS,
};
use helmwatch_core::sim::{Scenario, Ship};
use helmwatch_core::wire::Input;
use std::fmt::Write as _;

/// Records of normal operation the bound is given for [min].
pub const RECORD_MIN: [f64; 4] = [10.0, 30.0, 60.0, 120.0];
/// Records the Monte Carlo runs [min].
pub const MONTE_CARLO_MIN: [f64; 2] = [30.0, 120.0];
/// The course change of opportunity [deg]: small enough that the autopilot's command
/// (`Kp` times it, about 8 deg on the design's ship) stays inside the servo's linear range.
pub const COURSE_STEP_DEG: f64 = 2.0;
/// The displacement step to resolve (fraction).
pub const DISPLACEMENT_STEP: f64 = 0.10;
/// The speed-log bias to resolve [m/s].
pub const LOG_BIAS_MPS: f64 = 0.5;
/// Probability of detecting it.
pub const DETECTION: f64 = 0.95;

/// What the evaluation needs besides the configuration.
#[derive(Debug, Clone)]
pub struct PassiveOptions {
    /// Records per Monte Carlo cell.
    pub runs: usize,
    /// The first seed.
    pub seed: u64,
    /// Worker threads.
    pub threads: usize,
}

/// The loop model of the configuration's nominal ship in `sea`: its Nomoto `a`, `b`, the
/// autopilot's pole-placement gains, the servo, the sea's levels and the sensors' noise.
pub fn loop_model(cfg: &Config, sea: SeaState) -> LoopModel {
    let ship = &cfg.ship;
    let (a, b) = ship.nomoto(ship.nominal_speed_mps, ship.nominal_displacement_t);
    let g = cfg.autopilot.gains(ship);
    let levels = cfg.sea.levels(sea);
    LoopModel {
        a,
        b,
        kp: g.kp,
        td_s: g.td_s,
        ti_s: g.ti_s,
        wf_rad_s: cfg.autopilot.wave_filter_rad_s,
        servo_s: cfg.servo.time_constant_s,
        bias_rad: levels.bias_deg.to_radians(),
        bias_s: cfg.sea.bias_time_constant_s,
        wave_rad: levels.wave_yaw_deg.to_radians(),
        wave_w0_rad_s: cfg.sea.wave_frequency_rad_s,
        wave_damping: cfg.sea.wave_damping,
        heading_noise_rad: cfg.sensors.heading_noise_deg.to_radians(),
        rudder_noise_rad: cfg.sensors.rudder_noise_deg.to_radians(),
    }
}

/// One row of the bound: relative sd of `a` and `b` (every other parameter unknown), the
/// speed's sd [m/s] (D unknown) and the displacement's relative sd (u given), unknown and
/// known autopilot.
#[derive(Debug, Clone, Copy)]
pub struct BoundRow {
    /// sd(ln a), sd(ln b).
    pub ab: [f64; 2],
    /// sd(u) [m/s], sd(ln D): the autopilot, servo and sea unknown.
    pub unknown: [f64; 2],
    /// The same with the autopilot and the servo known (the sea unknown).
    pub known: [f64; 2],
}

/// The bound from an information matrix about the logarithms.
pub fn bound_row(info: &[f64], speed_mps: f64) -> Option<BoundRow> {
    let n = N_PARAMS;
    let m = nalgebra::DMatrix::from_row_slice(n, n, info);
    let inv = m.clone().try_inverse()?;
    let uk = speed_displacement_bounds(&ship_information(info)?)?;
    // The autopilot's and the servo's rows (2..=6) taken as known: dropped before the Schur.
    let keep: Vec<usize> = (0..n).filter(|i| !(2..=6).contains(i)).collect();
    let mut sub = vec![0.0; n * n];
    for (r, &i) in keep.iter().enumerate() {
        for (c, &j) in keep.iter().enumerate() {
            sub[r * n + c] = info[i * n + j];
        }
    }
    // Pad the dropped rows with an identity (no coupling): their inverse does not enter.
    for k in keep.len()..n {
        sub[k * n + k] = 1.0;
    }
    let kn = speed_displacement_bounds(&ship_information(&sub)?)?;
    Some(BoundRow {
        ab: [inv[(0, 0)].sqrt(), inv[(1, 1)].sqrt()],
        unknown: [uk.0 * speed_mps, uk.1],
        known: [kn.0 * speed_mps, kn.1],
    })
}

/// The information of one CLFRT test's measured windows: its record and its tones.
fn clfrt_information(cfg: &Config, t: &[f64; N_PARAMS], dt_s: f64) -> (f64, Vec<f64>) {
    let c = &cfg.clfrt;
    let record_s = c.window_s * f64::from(c.measure_windows);
    let mut info = information(t, record_s, dt_s);
    for &h in &c.harmonics {
        let w = 2.0 * std::f64::consts::PI * f64::from(h) / c.window_s;
        let tone = tone_information(t, w, c.amplitude_deg.to_radians(), record_s, dt_s);
        for (x, y) in info.iter_mut().zip(tone) {
            *x += y;
        }
    }
    (record_s, info)
}

fn fmt_row(out: &mut String, sea: SeaState, what: &str, r: Option<BoundRow>) {
    let _ = match r {
        Some(r) => writeln!(
            out,
            "| {} | {what} | {:.1} | {:.1} | {:.3} | {:.2} | {:.3} | {:.2} |",
            sea.name(),
            100.0 * r.ab[0],
            100.0 * r.ab[1],
            r.unknown[0],
            100.0 * r.unknown[1],
            r.known[0],
            100.0 * r.known[1]
        ),
        None => writeln!(out, "| {} | {what} | singular | | | | | |", sea.name()),
    };
}

const SEAS: [SeaState; 3] = [SeaState::Calm, SeaState::Moderate, SeaState::Rough];

/// The bound table, the shortest records and the Monte Carlo, as markdown.
pub fn passive_table(cfg: &Config, o: &PassiveOptions) -> String {
    let dt = cfg.sensors.dt_s();
    let u = cfg.ship.nominal_speed_mps;
    let mut out = String::new();
    let _ = writeln!(
        out,
        "# The passive watch's bound\n\nShip at {u} m/s and {} t under its own autopilot, \
         sampled every {dt} s, the band up to {} rad/s. Bounds are one standard deviation; \
         \"unknown\": the autopilot (Kp, Td, Ti, wave filter), the servo and the sea are \
         estimated with the ship; \"known\": the autopilot and the servo given.\n",
        cfg.ship.nominal_displacement_t,
        helmwatch_core::passive::BAND_TOP_RAD_S
    );
    let _ = writeln!(
        out,
        "| sea | record | a [%] | b [%] | u [m/s] | D [%] | u, autopilot known [m/s] | D, autopilot known [%] |\n|---|---|---|---|---|---|---|---|"
    );
    for sea in SEAS {
        let t = loop_model(cfg, sea).to_logs();
        for m in RECORD_MIN {
            let r = bound_row(&information(&t, m * 60.0, dt), u);
            fmt_row(&mut out, sea, &format!("{m} min of normal operation"), r);
        }
        let (record_s, info) = clfrt_information(cfg, &t, dt);
        fmt_row(
            &mut out,
            sea,
            &format!("{record_s} s without tones"),
            bound_row(&information(&t, record_s, dt), u),
        );
        fmt_row(
            &mut out,
            sea,
            &format!("one CLFRT test ({record_s} s, its tones)"),
            bound_row(&info, u),
        );
        let mut step = information(&t, 3600.0, dt);
        let course = course_step_information(&t, COURSE_STEP_DEG.to_radians(), dt);
        for (x, y) in step.iter_mut().zip(course) {
            *x += y;
        }
        fmt_row(
            &mut out,
            sea,
            &format!("60 min with one {COURSE_STEP_DEG} deg course change"),
            bound_row(&step, u),
        );
    }
    shortest_records(cfg, &mut out);
    monte_carlo(cfg, o, &mut out);
    out
}

/// The bound on `(u [m/s], ln D)` from `minutes` of normal operation, the autopilot unknown.
fn passive_bound(cfg: &Config, sea: SeaState, minutes: f64) -> Option<[f64; 2]> {
    let t = loop_model(cfg, sea).to_logs();
    let info = information(&t, minutes * 60.0, cfg.sensors.dt_s());
    bound_row(&info, cfg.ship.nominal_speed_mps).map(|r| r.unknown)
}

/// Table 2: the shortest record of normal operation that resolves each change.
fn shortest_records(cfg: &Config, out: &mut String) {
    let year_min = 365.25 * 1440.0;
    let per_year = cfg.fdi.false_alarms_per_year;
    let need = |minutes: f64| {
        let alpha = (per_year * minutes / year_min).min(0.5);
        normal_isf(alpha / 2.0) + normal_isf(1.0 - DETECTION)
    };
    let grid = [
        10.0, 15.0, 20.0, 30.0, 45.0, 60.0, 90.0, 120.0, 180.0, 240.0, 360.0, 480.0, 720.0, 1440.0,
        2880.0, 5760.0,
    ];
    let _ = writeln!(
        out,
        "\n## The shortest record that resolves a change at the budget\n\n\
         {per_year} false alarms a year, one decision per record; the change detected {:.0} % \
         of the time. The first record of {grid:?} min whose bound is below the change over \
         z(alpha / 2) + z({:.2}).\n\n\
         | sea | D +{:.0} % | speed log +{LOG_BIAS_MPS} m/s |\n|---|---|---|",
        100.0 * DETECTION,
        1.0 - DETECTION,
        100.0 * DISPLACEMENT_STEP
    );
    for sea in SEAS {
        let first = |which: usize, change: f64| {
            grid.iter()
                .find(|&&m| {
                    passive_bound(cfg, sea, m).is_some_and(|b| b[which] * need(m) <= change)
                })
                .map_or("over 4 days".to_string(), |m| format!("{m} min"))
        };
        let _ = writeln!(
            out,
            "| {} | {} | {} |",
            sea.name(),
            first(1, (1.0 + DISPLACEMENT_STEP).ln()),
            first(0, LOG_BIAS_MPS)
        );
    }
}

/// One record of normal operation from the simulator: (heading about the course, measured
/// rudder), `minutes` long after a settling hour.
pub fn record(
    cfg: &Config,
    sea: SeaState,
    minutes: f64,
    seed: u64,
) -> Option<(Vec<f64>, Vec<f64>)> {
    let sim = cfg.sim();
    let mut scenario = Scenario::nominal(&sim, seed);
    scenario.sea = sea;
    let mut ship = Ship::new(&sim, &scenario).ok()?;
    let course = sim.simulation.initial_course_deg.to_radians();
    let dt = ship.dt_s();
    let settle = (3600.0 / dt).round() as usize;
    let n = (minutes * 60.0 / dt).round() as usize;
    let (mut y, mut d) = (Vec::with_capacity(n), Vec::with_capacity(n));
    let mut inputs = Vec::new();
    for k in 0..settle + n {
        inputs.clear();
        ship.publish(&mut inputs);
        if k >= settle {
            let (mut hy, mut hd) = (None, None);
            for i in &inputs {
                match i {
                    Input::Heading(s) => {
                        hy = Some(helmwatch_core::angle::wrap_pi(s.value - course))
                    }
                    Input::Rudder(s) => hd = Some(s.value),
                    _ => {}
                }
            }
            y.push(hy?);
            d.push(hd?);
        }
        ship.step();
    }
    Some((y, d))
}

/// Table 3: Whittle's estimator on the simulator against the bound.
fn monte_carlo(cfg: &Config, o: &PassiveOptions, out: &mut String) {
    let dt = cfg.sensors.dt_s();
    let _ = writeln!(
        out,
        "\n## Whittle's estimator on the simulated ship\n\n{} records per cell from seed {}, \
         each after an hour of settling; the fit starts at the configured loop. Spread: \
         the standard deviation of ln a^ and ln b^ over the converged fits; ratio: spread over \
         the bound (1: efficient).\n\n\
         | sea | record [min] | converged | bias ln a [%] | spread a [%] | bound a [%] | ratio a | bias ln b [%] | spread b [%] | bound b [%] | ratio b |\n|---|---|---|---|---|---|---|---|---|---|---|",
        o.runs, o.seed
    );
    for sea in SEAS {
        let truth = loop_model(cfg, sea);
        let t = truth.to_logs();
        for m in MONTE_CARLO_MIN {
            let Some(bound) = bound_row(&information(&t, m * 60.0, dt), 1.0) else {
                continue;
            };
            let fits = par_map(o.runs, o.threads, |i| {
                let (y, d) = record(cfg, sea, m, o.seed.wrapping_add(i as u64))?;
                let pg = whittle::periodogram(&y, &d, dt)?;
                let f = whittle::fit(&truth, &pg, dt)?;
                f.converged
                    .then(|| [(f.model.a / truth.a).ln(), (f.model.b / truth.b).ln()])
            });
            let ok: Vec<[f64; 2]> = fits.into_iter().flatten().collect();
            let stat = |k: usize| {
                let n = ok.len() as f64;
                let mean = ok.iter().map(|x| x[k]).sum::<f64>() / n;
                let var = ok.iter().map(|x| (x[k] - mean).powi(2)).sum::<f64>() / (n - 1.0);
                (mean, var.sqrt())
            };
            let ((ma, sa), (mb, sb)) = (stat(0), stat(1));
            let _ = writeln!(
                out,
                "| {} | {m} | {} of {} | {:.1} | {:.1} | {:.1} | {:.2} | {:.1} | {:.1} | {:.1} | {:.2} |",
                sea.name(),
                ok.len(),
                o.runs,
                100.0 * ma,
                100.0 * sa,
                100.0 * bound.ab[0],
                sa / bound.ab[0],
                100.0 * mb,
                100.0 * sb,
                100.0 * bound.ab[1],
                sb / bound.ab[1]
            );
        }
    }
}
