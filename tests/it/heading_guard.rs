//! The CLFRT tones' heading guard is armed per vessel by what its tests find
//! (`helmwatch_core::monitor::sizing`): a vessel's first CLFRT test on a ship more responsive
//! than the tones were sized for ends on the heading limit; the next, armed, completes with
//! the tones that carry the heading lowered (the slower ones alike, the fastest kept), and
//! the guard stays armed across a restart (the vessel's saved state).
//! On a ship whose tones keep clear of the limit an armed guard does not act, and the next
//! test goes unarmed. The core runs as in the daemon (lockstep), consecutive tests on one
//! vessel.

use helmwatch::config::Config;
use helmwatch_core::drivers::probe::{Lockstep, ProbeOptions};
use helmwatch_core::model::SeaState;
use helmwatch_core::sim::Scenario;
use helmwatch_core::wire::{Method, Outcome, Report};

/// The family's ship made as responsive as the Mariner cargo ship scaled to 120 m
/// (`yaw-damping-a0` 0.1945, `rudder-area-m2` 85.4: 4.3 times the family's rudder gain), or
/// the family's own, at the fast and light corner in a calm sea; the guard's `fraction`.
fn vessel(responsive: bool, fraction: f64) -> (Config, Lockstep) {
    let mut cfg = Config::default();
    cfg.clfrt.resize_heading_fraction = fraction;
    if responsive {
        cfg.ship.yaw_damping_a0 = 0.1945;
        cfg.ship.rudder_area_m2 = 85.4;
    }
    cfg.scheduler.enabled = false;
    let sc = Scenario {
        speed_mps: 10.0,
        displacement_t: 4000.0,
        sea: SeaState::Calm,
        faults: vec![],
        seed: 3,
    };
    let ls = Lockstep::new(&cfg.core(), &cfg.sim(), &sc).unwrap();
    (cfg, ls)
}

fn clfrt(cfg: &Config, ls: &mut Lockstep) -> Report {
    let opts = ProbeOptions::new(&cfg.core(), Method::Clfrt);
    ls.run_test(&opts).unwrap().report
}

fn scales(r: &Report) -> Option<Vec<f64>> {
    r.features.clfrt().and_then(|c| c.amplitude_scales.clone())
}

#[test]
fn the_guard_arms_after_a_test_on_the_heading_limit_and_disarms_where_not_needed() {
    let fraction = Config::default().clfrt.resize_heading_fraction;
    assert!(fraction < 1.0, "the guard is on by default");
    let (cfg, mut ls) = vessel(true, fraction);
    assert!(!ls.monitor.saved_state().clfrt_heading_guard);
    let first = clfrt(&cfg, &mut ls);
    assert_eq!(first.outcome, Outcome::Aborted);
    assert!(
        first
            .reason
            .as_deref()
            .unwrap_or("")
            .contains("heading error"),
        "{:?}",
        first.reason
    );
    let saved = ls.monitor.saved_state();
    assert!(saved.clfrt_heading_guard);
    // A restart between the tests: the guard is in the vessel's state.
    let json = serde_json::to_string(&saved).unwrap();
    let (_, mut restarted) = vessel(true, fraction);
    restarted
        .monitor
        .restore(serde_json::from_str(&json).unwrap())
        .unwrap();
    let second = clfrt(&cfg, &mut restarted);
    assert_eq!(second.outcome, Outcome::Completed, "{:?}", second.reason);
    let s = scales(&second).expect("the tones were lowered");
    let factor = cfg.clfrt.resize_heading_factor;
    assert!(s[0] < factor && s[0] > 0.5 * factor * factor, "{s:?}");
    assert_eq!(s[0], s[1], "{s:?}");
    assert_eq!(s[s.len() - 1], 1.0, "{s:?}");
    assert!(restarted.monitor.saved_state().clfrt_heading_guard);

    // The family's own ship, armed: its tones keep clear of the limit, the guard does not
    // act, and the next test goes unarmed.
    let (cfg, mut ls) = vessel(false, fraction);
    let mut state = ls.monitor.saved_state();
    state.clfrt_heading_guard = true;
    ls.monitor.restore(state).unwrap();
    let r = clfrt(&cfg, &mut ls);
    assert_eq!(r.outcome, Outcome::Completed, "{:?}", r.reason);
    assert!(!ls.monitor.saved_state().clfrt_heading_guard);

    // Off (fraction 1): never armed.
    let (cfg, mut ls) = vessel(true, 1.0);
    let r = clfrt(&cfg, &mut ls);
    assert_eq!(r.outcome, Outcome::Aborted);
    assert!(!ls.monitor.saved_state().clfrt_heading_guard);
}
