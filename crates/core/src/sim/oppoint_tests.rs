//! Operating-point changes during a run: a ship whose speed or loading changes behaves as a
//! ship built at the new point (its Nomoto parameters against the model's closed form and
//! against a fresh ship), its speed log reads the new speed, and the declared displacement
//! goes out with the status.

#![allow(clippy::unwrap_used)]

use super::*;
use crate::model::SeaState;
use crate::sim::config::SimConfig;
use crate::wire::Input;
use approx::assert_relative_eq;

fn scenario(u: f64, d: f64, faults: &[&str]) -> Scenario {
    Scenario {
        speed_mps: u,
        displacement_t: d,
        sea: SeaState::Calm,
        faults: faults.iter().map(|f| f.parse().unwrap()).collect(),
        seed: 3,
    }
}

fn clean(cfg: &SimConfig, u: f64, d: f64, faults: &[&str]) -> Ship {
    Ship::with_options(cfg, &scenario(u, d, faults), SimOptions::CLEAN).unwrap()
}

fn mmg_config() -> SimConfig {
    let mut cfg = SimConfig::default();
    let member = config::family()
        .into_iter()
        .find(|m| m.structure.hull == config::HullModel::Kvlcc2Mmg)
        .unwrap();
    member.apply(&mut cfg.structure, &mut cfg.autopilot);
    cfg
}

fn speed_log(ship: &mut Ship) -> f64 {
    let mut out = Vec::new();
    ship.publish(&mut out);
    out.iter()
        .find_map(|i| match i {
            Input::Speed(s) => Some(s.value),
            _ => None,
        })
        .unwrap()
}

/// The first-order ship at 7 m/s set to 8.5 m/s: a = a0 u / l and b = 0.5 (u/l)^2 A l / V at
/// 8.5 m/s (the domain's closed form, computed here), the same as a ship built at 8.5 m/s;
/// the clean speed log reads 8.5 from the next tick; on a fixed rudder its turn rate is the
/// fresh ship's and settles at (b/a) delta.
#[test]
fn a_speed_change_gives_the_ship_of_the_new_speed() {
    let cfg = SimConfig::default();
    let (u1, d) = (8.5, 6500.0);
    let mut ship = clean(&cfg, 7.0, d, &[]);
    for _ in 0..100 {
        ship.step();
    }
    ship.set_speed_mps(u1).unwrap();
    ship.step();
    let s = &cfg.ship;
    let a = s.yaw_damping_a0 * u1 / s.length_m;
    let b = 0.5 * (u1 / s.length_m).powi(2) * s.rudder_area_m2 * s.length_m
        / (d / s.water_density_t_m3);
    let t = ship.truth();
    assert_relative_eq!(t.a_per_s, a, max_relative = 1e-12);
    assert_relative_eq!(t.b_per_s2, b, max_relative = 1e-12);
    let fresh = clean(&cfg, u1, d, &[]).truth();
    assert_relative_eq!(t.a_per_s, fresh.a_per_s, max_relative = 1e-12);
    assert_relative_eq!(t.b_per_s2, fresh.b_per_s2, max_relative = 1e-12);
    assert_relative_eq!(t.speed_mps, u1, max_relative = 1e-12);
    // No noise: the speed log reads the speed exactly.
    assert_relative_eq!(speed_log(&mut ship), u1, max_relative = 1e-12);
    // Open loop on a 2 deg rudder: the turn rate of the fresh ship at every tick, and the
    // steady (b/a) delta.
    let delta = 2.0f64.to_radians();
    let mut fresh = clean(&cfg, u1, d, &[]);
    ship.set_command_override(Some(delta));
    fresh.set_command_override(Some(delta));
    for _ in 0..6000 {
        ship.step();
        fresh.step();
        let (r, r_fresh) = (ship.truth().r_rad_s, fresh.truth().r_rad_s);
        assert!(
            (r - r_fresh).abs() <= 1e-12 * r_fresh.abs().max(1e-6),
            "{r} {r_fresh}"
        );
    }
    assert_relative_eq!(ship.truth().r_rad_s, b / a * delta, max_relative = 0.01);
    assert!(ship.set_speed_mps(0.0).is_err());
    assert!(ship.set_speed_mps(f64::NAN).is_err());
}

/// New gains without a bump: an autopilot on course (zero error) holding a trim of 1.5 deg
/// in its integral commands that trim before and after its gains change to those of another
/// speed (Kp x0.68).
#[test]
fn new_gains_keep_the_trim() {
    let cfg = SimConfig::default();
    let g0 = cfg.autopilot.gains_at(&cfg.ship, 7.0);
    let g1 = cfg.autopilot.gains_at(&cfg.ship, 8.5);
    assert!((g1.kp / g0.kp - (7.0f64 / 8.5).powi(2)).abs() < 1e-12);
    let trim = 1.5f64.to_radians();
    let target = 1.0;
    let mut ap = Autopilot::new(g0, 0.25, 0.5, target, trim, 0.1);
    let (c0, _) = ap.command(0.0, target, None);
    assert_relative_eq!(c0, trim, max_relative = 1e-12);
    ap.set_gains(g1);
    let (c1, _) = ap.command(0.1, target, None);
    assert_relative_eq!(c1, trim, max_relative = 1e-12);
}

/// The KVLCC2 MMG hull at 7 m/s set to 5.5 m/s: its linearised (a, b) equal a hull built at
/// 5.5 m/s, and after ten minutes under its autopilot its surge speed and the speed log are
/// within 0.05 m/s of 5.5 (its propeller turns for that speed).
#[test]
fn a_speed_change_on_the_mmg_hull_holds_the_new_speed() {
    let cfg = mmg_config();
    let (u1, d) = (5.5, 7000.0);
    let mut ship = clean(&cfg, 7.0, d, &[]);
    for _ in 0..100 {
        ship.step();
    }
    ship.set_speed_mps(u1).unwrap();
    let fresh = clean(&cfg, u1, d, &[]).truth();
    let t = ship.truth();
    assert_relative_eq!(t.a_per_s, fresh.a_per_s, max_relative = 1e-9);
    assert_relative_eq!(t.b_per_s2, fresh.b_per_s2, max_relative = 1e-9);
    for _ in 0..6000 {
        ship.step();
    }
    let u = ship.truth().speed_mps;
    assert!((u - u1).abs() < 0.05, "surge speed {u} m/s");
    let log = speed_log(&mut ship);
    assert!((log - u1).abs() < 0.05, "speed log {log} m/s");
}

/// A loading of 8200 t: the true displacement and b follow it (and a +10 % displacement fault
/// stays relative to it); the ship publishes `design/displacement` = 8.2e6 kg at the next
/// tick, not at the ticks before the next status period, and again at it.
#[test]
fn a_loading_is_in_force_and_declared_with_the_status() {
    let cfg = SimConfig::default();
    let (u, d0, d1) = (7.0, 6000.0, 8200.0);
    let mut ship = clean(&cfg, u, d0, &["displacement_pct:10@0"]);
    let declared = |ship: &mut Ship| {
        let mut out = Vec::new();
        ship.publish(&mut out);
        let last_is_heading = matches!(out.last(), Some(Input::Heading(_)));
        assert!(last_is_heading, "{out:?}");
        out.iter()
            .filter_map(|i| match i {
                Input::DesignDisplacement(s) => Some(s.value),
                _ => None,
            })
            .collect::<Vec<_>>()
    };
    // Nothing declared before a loading.
    let period = (cfg.sensors.status_period_s * cfg.sensors.rate_hz).round() as usize;
    for _ in 0..2 * period {
        assert!(declared(&mut ship).is_empty());
        ship.step();
    }
    // Mid-period: the change is published at once.
    for _ in 0..period / 2 {
        declared(&mut ship);
        ship.step();
    }
    ship.set_loading_t(d1).unwrap();
    assert_eq!(ship.declared_displacement_t(), Some(d1));
    let first = declared(&mut ship);
    assert_eq!(first.len(), 1);
    assert_relative_eq!(first[0], d1 * 1000.0, max_relative = 1e-12);
    ship.step();
    let mut seen = 0;
    for _ in 0..2 * period {
        let v = declared(&mut ship);
        for x in &v {
            assert_relative_eq!(*x, d1 * 1000.0, max_relative = 1e-12);
        }
        seen += v.len();
        ship.step();
    }
    assert_eq!(seen, 2, "one declaration per status period");
    let t = ship.truth();
    assert_relative_eq!(t.displacement_t, 1.1 * d1, max_relative = 1e-12);
    let s = &cfg.ship;
    let b = 0.5 * (u / s.length_m).powi(2) * s.rudder_area_m2 * s.length_m
        / (1.1 * d1 / s.water_density_t_m3);
    assert_relative_eq!(t.b_per_s2, b, max_relative = 1e-12);
    assert!(ship.set_loading_t(-1.0).is_err());
    assert!(ship.set_loading_t(f64::INFINITY).is_err());
}
