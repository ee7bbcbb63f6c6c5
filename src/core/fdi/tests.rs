use super::*;
use crate::core::monitor::config::CoreConfig;
use crate::core::wire::features::{sample, ClfrtFeatures, ServoRateFeatures};

fn cfg() -> FdiConfig {
    FdiConfig::default()
}

/// Residuals with unit spreads: z = (speed, disp), g = dD/du.
fn p(speed: f64, disp: f64, g: f64) -> ParamResiduals {
    ParamResiduals {
        speed_mps: speed,
        speed_sigma_mps: 1.0,
        displacement_t: disp,
        displacement_sigma_t: 1.0,
        dd_du_t_per_mps: g,
    }
}

#[test]
fn one_overwhelming_test_is_an_alarm_by_itself() {
    let c = cfg();
    assert_eq!(
        (c.chi2_single_threshold, c.actuator_single_threshold),
        (60.0, 25.0)
    );
    // q = 59: over 13.82, under 60: an alert only.
    let mut t = Track::default();
    let o = t.update(&c, Some(&p(0.0, 59f64.sqrt(), 0.0)), None);
    assert_eq!(o.state, TrackState::Alert);
    // q = 61: an alarm at the first test.
    let mut t = Track::default();
    let o = t.update(&c, Some(&p(5.0, 6.0, 0.0)), None);
    assert_eq!((o.state, o.decision), (TrackState::Alarm, Decision::Fault));
    // The servo check: z_rate^2 = 24 alerts, 26 alarms (named the actuator).
    let mut t = Track::default();
    let o = t.update(&c, None, Some([24f64.sqrt(), 0.0]));
    assert_eq!(o.state, TrackState::Alert);
    let mut t = Track::default();
    let o = t.update(&c, None, Some([26f64.sqrt(), 0.0]));
    assert_eq!(o.state, TrackState::Alarm);
    assert_eq!(o.isolation, vec![Cause::SteeringActuator]);
    // Other rules are not touched: the CUSUM and GLR have limits of their own.
    let glr = FdiConfig {
        rule: DecisionRule::Glr,
        ..cfg()
    };
    let mut t = Track::default();
    let o = t.update(&glr, Some(&p(5.0, 6.0, 0.0)), None);
    assert_eq!(
        o.state,
        TrackState::Alarm,
        "61 is over the GLR's own 60 too"
    );
    let mut t = Track::default();
    let o = t.update(&glr, Some(&p(0.0, 7.0, 0.0)), None);
    assert_eq!(o.state, TrackState::Alert);
}

#[test]
fn chi_square_alarm_needs_persistence_and_clears_after_nominal_tests() {
    let c = cfg();
    let mut t = Track::default();
    // q = 9 + 4 = 13 < 13.82: nominal.
    let o = t.update(&c, Some(&p(3.0, 2.0, 0.0)), None);
    assert_eq!(
        (o.state, o.decision),
        (TrackState::Normal, Decision::Nominal)
    );
    assert!((o.q_param - 13.0).abs() < 1e-12);
    // q = 16 + 0 > 13.82: alert (1 of 2), inconclusive.
    let o = t.update(&c, Some(&p(0.0, 4.0, 0.0)), None);
    assert_eq!(
        (o.state, o.decision),
        (TrackState::Alert, Decision::Inconclusive)
    );
    // A nominal test clears an alert at once.
    let o = t.update(&c, Some(&p(0.0, 1.0, 0.0)), None);
    assert_eq!(o.state, TrackState::Normal);
    assert!(o.isolation.is_empty());
    // Two in a row: alarm.
    t.update(&c, Some(&p(0.0, 5.0, 0.0)), None);
    let o = t.update(&c, Some(&p(0.0, 5.0, 0.0)), None);
    assert_eq!((o.state, o.decision), (TrackState::Alarm, Decision::Fault));
    assert_eq!(o.isolation, vec![Cause::DisplacementOrRudderEffectiveness]);
    // The alarm holds for clear-after - 1 nominal tests, then clears.
    for _ in 1..c.clear_after {
        let o = t.update(&c, Some(&p(0.0, 0.0, 0.0)), None);
        assert_eq!(o.state, TrackState::Alarm);
    }
    let o = t.update(&c, Some(&p(0.0, 0.0, 0.0)), None);
    assert_eq!(
        (o.state, o.decision),
        (TrackState::Normal, Decision::Nominal)
    );
}

#[test]
fn no_residuals_change_nothing() {
    let c = cfg();
    let mut t = Track::default();
    t.update(&c, Some(&p(0.0, 5.0, 0.0)), None);
    let before = t.clone();
    let o = t.update(&c, None, None);
    assert_eq!(o.decision, Decision::Inconclusive);
    assert_eq!(t, before);
    // NaN residuals count as none.
    let o = t.update(&c, Some(&p(f64::NAN, 1.0, 0.0)), None);
    assert_eq!(o.decision, Decision::Inconclusive);
    assert_eq!(t, before);
}

#[test]
fn isolation_follows_the_fault_directions() {
    let c = cfg();
    // A speed-log bias of beta: r_speed = -beta, r_disp = g beta (g = 2 here).
    let mut t = Track::default();
    for _ in 0..2 {
        t.update(&c, Some(&p(-3.0, 6.0, 2.0)), None);
    }
    let o = t.update(&c, Some(&p(-3.0, 6.0, 2.0)), None);
    assert_eq!(o.isolation, vec![Cause::SpeedLog]);
    // The same r_disp with r_speed = 0 is a displacement change.
    let mut t = Track::default();
    t.update(&c, Some(&p(0.0, 6.0, 2.0)), None);
    let o = t.update(&c, Some(&p(0.0, 6.0, 2.0)), None);
    assert_eq!(o.isolation, vec![Cause::DisplacementOrRudderEffectiveness]);
    // Half-way between the two: with a margin both are named, the nearer first.
    let wide = FdiConfig {
        isolation_margin: 100.0,
        ..cfg()
    };
    let mut t = Track::default();
    t.update(&wide, Some(&p(-1.0, 6.0, 2.0)), None);
    let o = t.update(&wide, Some(&p(-1.0, 6.0, 2.0)), None);
    assert!(o.isolation.len() >= 2, "{:?}", o.isolation);
}

/// With both methods out of `normal` the vessel names the parameter cause from CLFRT's
/// episode (structure-robust) and the actuator from either servo check; a method back to
/// normal, or the option off, leaves each method to name from its own tests.
#[test]
fn the_vessel_names_the_parameter_cause_from_clfrt() {
    let full = CoreConfig::default();
    let c = full.fdi.clone();
    let (ci, hi) = (method_index(Method::Clfrt), method_index(Method::Hbt));
    let mut fdi = Fdi::new(&full);
    // HBT: three tests near the speed-log line (g = 2: v_log = (-1, 2)), which is what a
    // displacement change looks like to HBT on a hull with more lag than its model.
    for _ in 0..3 {
        fdi.tracks[hi].update(&c, Some(&p(-1.5, 4.0, 2.0)), None);
    }
    assert_eq!(fdi.tracks[hi].isolation(&c), vec![Cause::SpeedLog]);
    assert!(fdi.vessel_isolation().is_none(), "CLFRT is normal");
    // CLFRT: two tests on the displacement line.
    for _ in 0..2 {
        fdi.tracks[ci].update(&c, Some(&p(-0.2, 8.0, 2.0)), None);
    }
    let d = vec![Cause::DisplacementOrRudderEffectiveness];
    assert_eq!(fdi.tracks[ci].isolation(&c), d);
    assert_eq!(fdi.vessel_isolation(), Some(d.clone()));
    // Off: each method names alone.
    let mut off = fdi.clone();
    off.cfg.isolation_across_methods = false;
    assert!(off.vessel_isolation().is_none());
    // A servo check over its limit in HBT names the actuator alone (one fault at a time).
    let mut servo = fdi.clone();
    servo.tracks[hi].update(&c, Some(&p(-1.5, 4.0, 2.0)), Some([6.0, 0.0]));
    assert_eq!(
        servo.vessel_isolation(),
        Some(vec![Cause::SteeringActuator])
    );
    // CLFRT back to normal (three nominal tests clear its alarm): HBT names alone again.
    for _ in 0..3 {
        fdi.tracks[ci].update(&c, Some(&p(0.0, 0.0, 2.0)), None);
    }
    assert_eq!(fdi.tracks[ci].state, TrackState::Normal);
    assert!(fdi.vessel_isolation().is_none());
    // CLFRT out of normal on its servo check alone: the parameter cause is HBT's.
    let mut slow = Fdi::new(&full);
    for _ in 0..2 {
        slow.tracks[hi].update(&c, Some(&p(-1.5, 4.0, 2.0)), None);
    }
    slow.tracks[ci].update(&c, Some(&p(0.0, 0.0, 2.0)), Some([4.0, 0.0]));
    assert_eq!(slow.tracks[ci].episode.param_exceeded, 0);
    let named = slow.vessel_isolation().unwrap_or_default();
    assert_eq!(named, vec![Cause::SteeringActuator], "single fault");
    let mut both = slow.clone();
    both.cfg.single_fault = false;
    let named = both.vessel_isolation().unwrap_or_default();
    assert!(named.contains(&Cause::SpeedLog), "{named:?}");
    assert!(named.contains(&Cause::SteeringActuator), "{named:?}");
}

#[test]
fn the_isolation_costs_match_a_direct_least_squares() {
    // Independent answer: the cost of a direction v is the sum over the tests of
    // min over theta_k of |z_k - theta_k v_k|^2, found here by a dense scan of each theta_k.
    let tests = [p(-0.8, 5.0, 3.0), p(-1.6, 7.0, 2.5), p(0.3, 6.0, 2.8)];
    let c = cfg();
    let mut t = Track::default();
    for x in &tests {
        t.update(&c, Some(x), None);
    }
    let e = t.episode;
    for i in 0..3 {
        let mut total = 0.0;
        for x in &tests {
            let (z, v) = (x.z(), x.directions()[i]);
            let mut best = f64::INFINITY;
            for k in 0..400_001 {
                let theta = -20.0 + k as f64 * 1e-4;
                let cost = (z[0] - theta * v[0]).powi(2) + (z[1] - theta * v[1]).powi(2);
                best = best.min(cost);
            }
            total += best;
        }
        approx::assert_relative_eq!(e.cost[i], total, max_relative = 1e-6, epsilon = 1e-9);
    }
}

#[test]
fn actuator_residuals_alone_name_the_steering_actuator() {
    let c = cfg();
    let mut t = Track::default();
    t.update(&c, Some(&p(0.5, -0.5, 2.0)), Some([-6.0, -3.0]));
    let o = t.update(&c, Some(&p(0.2, 0.4, 2.0)), Some([-5.5, -2.0]));
    assert_eq!(o.decision, Decision::Fault);
    assert_eq!(o.isolation, vec![Cause::SteeringActuator]);
}

#[test]
fn cusum_integrates_small_persistent_shifts() {
    let c = FdiConfig {
        rule: DecisionRule::Cusum,
        ..cfg()
    };
    // z = 1.5 per test: S+ grows by 1 per test, over h = 5 at the sixth test; the chi-square
    // rule (q = 2.25) never fires.
    let mut t = Track::default();
    let mut chi = Track::default();
    for k in 1..=8 {
        let o = t.update(&c, Some(&p(0.0, 1.5, 0.0)), None);
        let oc = chi.update(&cfg(), Some(&p(0.0, 1.5, 0.0)), None);
        assert_eq!(oc.decision, Decision::Nominal);
        let expect = if k >= 6 {
            Decision::Fault
        } else {
            Decision::Nominal
        };
        assert_eq!(o.decision, expect, "test {k}");
    }
    // Zero-mean residuals within +-k never accumulate.
    let mut t = Track::default();
    for k in 0..1000 {
        let z = if k % 2 == 0 { 0.45 } else { -0.45 };
        assert_eq!(
            t.update(&c, Some(&p(z, z, 0.0)), None).decision,
            Decision::Nominal
        );
    }
}

#[test]
fn sea_fraction_interpolates_and_clamps() {
    assert_eq!(sea_fraction([0.02, 0.06], Some(0.02)), 0.0);
    assert_eq!(sea_fraction([0.02, 0.06], Some(0.01)), 0.0);
    assert!((sea_fraction([0.02, 0.06], Some(0.04)) - 0.5).abs() < 1e-12);
    assert_eq!(sea_fraction([0.02, 0.06], Some(1.0)), 3.0);
    assert_eq!(sea_fraction([0.02, 0.06], None), 1.0);
}

#[test]
fn sea_index_reads_the_wave_yaw_in_degrees() {
    let with = |w: Option<f64>| {
        let mut h = sample::hbt();
        h.wave_yaw_rad = w;
        Features::Hbt(h)
    };
    assert!((sea_index(&with(Some(0.2f64.to_radians()))).unwrap() - 0.2).abs() < 1e-12);
    assert_eq!(sea_index(&with(None)), None);
    assert_eq!(sea_index(&with(Some(-1.0))), None);
    assert_eq!(sea_index(&with(Some(f64::NAN))), None);
    assert_eq!(sea_index(&Features::None), None);
}

/// Relative spreads scale with the reference; absolute ones (or files without relative
/// figures) do not; between the anchors both interpolate, above moderate the spread grows.
#[test]
fn spreads_relative_and_absolute() {
    use crate::core::estimator::model::SeaSpread;
    use crate::core::model::SeaState;
    let sea = |sea, m, sd, rel: Option<(f64, f64)>| SeaSpread {
        sea,
        n: 100,
        residual_mean: m,
        residual_std: sd,
        relative_mean: rel.map(|r| r.0),
        relative_std: rel.map(|r| r.1),
    };
    let u = |rel: bool| Uncertainty {
        residual_mean: 0.0,
        residual_std: 100.0,
        by_sea: vec![
            sea(SeaState::Calm, 2.0, 30.0, rel.then_some((0.001, 0.005))),
            sea(
                SeaState::Moderate,
                10.0,
                130.0,
                rel.then_some((0.002, 0.02)),
            ),
        ],
    };
    let close = |a: (f64, f64), b: (f64, f64)| {
        assert!(
            (a.0 - b.0).abs() < 1e-9 && (a.1 - b.1).abs() < 1e-9,
            "{a:?} vs {b:?}"
        )
    };
    close(spread(&u(true), 0.0, Some(4000.0)), (4.0, 20.0));
    close(spread(&u(true), 1.0, Some(10000.0)), (20.0, 200.0));
    close(spread(&u(true), 0.5, Some(8000.0)), (12.0, 0.0125 * 8000.0));
    // Twice the moderate fraction: the spread extrapolates, the bias stays at moderate's.
    close(spread(&u(true), 2.0, Some(1000.0)), (2.0, 35.0));
    close(spread(&u(true), 0.0, None), (2.0, 30.0));
    close(spread(&u(false), 1.0, Some(4000.0)), (10.0, 130.0));
}

/// Exact Nomoto tones for (a, b), with 90 % intervals of 3 % and 0.02 rad.
fn nomoto_tones(a: f64, b: f64, ws: &[f64]) -> ClfrtFeatures {
    sample::clfrt(
        ws.iter()
            .map(|&w| {
                let gain = b / (w * (w * w + a * a).sqrt());
                let phase = -std::f64::consts::FRAC_PI_2 - (w / a).atan();
                sample::tone(w, gain, phase)
            })
            .collect(),
    )
}

#[test]
fn model_fit_recovers_exact_nomoto_tones_and_flags_a_foreign_one() {
    let c = cfg();
    let ship = CoreConfig::default().ship;
    let (a, b) = (0.0146, 5.98e-4);
    let ws = [0.032, 0.0745, 0.181];
    let f = fit::model_fit(&Features::Clfrt(nomoto_tones(a, b, &ws)), &ship, &c).unwrap();
    approx::assert_relative_eq!(f.a_per_s, a, max_relative = 1e-6);
    approx::assert_relative_eq!(f.b_per_s2, b, max_relative = 1e-6);
    assert!(f.chi2 < 1e-12, "{}", f.chi2);
    assert_eq!(f.dof, 4);
    // Its (u, D) from DOMAIN's formulas: a = 0.0146 is u = 7 m/s; b = 5.98e-4 is D = 7000 t.
    let j = f.to_json(&ship);
    approx::assert_relative_eq!(j["speed_mps"].as_f64().unwrap(), 7.008, max_relative = 1e-3);
    let d = j["displacement_t"].as_f64().unwrap();
    assert!((d - 7000.0).abs() < 30.0, "{d}");
    // Add a lag of 10 deg at the top tone (an unmodelled actuator lag): no (a, b) explains it.
    let mut bad = nomoto_tones(a, b, &ws);
    bad.tones[2].phase_rad -= 10f64.to_radians();
    let f = fit::model_fit(&Features::Clfrt(bad), &ship, &c).unwrap();
    assert!(f.chi2 > 100.0, "{}", f.chi2);
}

#[test]
fn notifications_follow_the_vessel_alarm_state() {
    let mut full = CoreConfig::default();
    full.fdi.persistence = 2;
    let mut fdi = Fdi::new(&full);
    let mut h = sample::hbt();
    h.speed_log_mps = Some(7.0);
    let features = Features::Hbt(h);
    // Without an estimate nothing happens and nothing is published.
    let a = fdi.assess(Method::Hbt, &features, None, 7000.0);
    assert_eq!(a.decision, Decision::Inconclusive);
    assert!(a.notification.is_none());
    // Drive the HBT track by hand through its states; the vessel state is the worst track.
    let c = full.fdi.clone();
    fdi.tracks[1].update(&c, Some(&p(0.0, 7.0, 0.0)), None);
    assert_eq!(fdi.alarm_state(), AlarmState::Alert);
    fdi.tracks[1].update(&c, Some(&p(0.0, 7.0, 0.0)), None);
    assert_eq!(fdi.alarm_state(), AlarmState::Alarm);
}

/// A saved state, through JSON and back into a fresh FDI, is the same state: the alarm, the
/// runs and sums that decide the next test, the last notification.
#[test]
fn the_state_survives_a_round_trip_through_json() {
    let mut full = CoreConfig::default();
    full.fdi.persistence = 2;
    let mut fdi = Fdi::new(&full);
    let c = full.fdi.clone();
    fdi.tracks[1].update(&c, Some(&p(0.3, 9.0, 0.0)), None);
    fdi.tracks[1].update(&c, Some(&p(0.1, 8.0, 0.0)), None);
    fdi.tracks[0].sea_index(Some(0.17), 0.5);
    fdi.vessel.look(&c, Method::Clfrt, Some(7.5), true);
    fdi.vessel.look(&c, Method::Hbt, Some(3.0), true);
    fdi.last_notification = Some(Notification {
        state: AlarmState::Alarm,
        method: vec!["visual".into(), "sound".into()],
        message: "Steering FDI (HBT): fault".into(),
    });
    let saved = fdi.state();
    let text = serde_json::to_string(&saved).unwrap();
    let mut fresh = Fdi::new(&full);
    assert_eq!(fresh.alarm_state(), AlarmState::Normal);
    fresh.restore(serde_json::from_str(&text).unwrap());
    assert_eq!(fresh.state(), saved);
    assert_eq!(fresh.alarm_state(), AlarmState::Alarm);
    assert_eq!(
        fresh.last_notification().map(|n| n.state),
        Some(AlarmState::Alarm)
    );
    // The next test moves both the same way.
    let a = fdi.tracks[1].update(&c, Some(&p(0.0, 0.5, 0.0)), None);
    let b = fresh.tracks[1].update(&c, Some(&p(0.0, 0.5, 0.0)), None);
    assert_eq!(a, b);
    assert_eq!(fdi.state(), fresh.state());
    // The vessel's window too: the third test completes it the same way.
    let va = fdi.vessel.look(&c, Method::Clfrt, Some(1.0), true);
    let vb = fresh.vessel.look(&c, Method::Clfrt, Some(1.0), true);
    assert_eq!(va, vb);
    assert!(va.is_some_and(|v| (v.statistic - 11.5).abs() < 1e-12));
}

/// The servo check reads each method's own field: CLFRT the burst's p95 rate, HBT the relay
/// slews' peak rate; one-sided, and `(1 - rho) / sigma` by hand.
#[test]
fn actuator_z_reads_each_methods_servo_field() {
    let fdi = Fdi::new(&CoreConfig::default());
    let sigma = FdiConfig::default().actuator_rate_sigma;
    let hbt = |peak: f64| {
        let mut h = sample::hbt();
        h.servo_rate = Some(ServoRateFeatures {
            rudder_rate_peak_rad_s: peak,
            rudder_rate_nominal_rad_s: 0.07,
        });
        Features::Hbt(h)
    };
    let clfrt = |p95: f64| {
        let mut c = sample::clfrt(vec![]);
        c.servo_check = Some(sample::servo_check(p95, 0.07));
        Features::Clfrt(c)
    };
    let z = fdi.actuator_z(&hbt(0.035)).unwrap();
    approx::assert_relative_eq!(z[0], 0.5 / sigma, max_relative = 1e-12);
    assert_eq!(fdi.actuator_z(&hbt(0.0707)).unwrap()[0], 0.0);
    let z = fdi.actuator_z(&clfrt(0.063)).unwrap();
    approx::assert_relative_eq!(z[0], 0.1 / sigma, max_relative = 1e-9);
    // No servo field, or a failed check: no actuator residual.
    assert!(fdi.actuator_z(&Features::Hbt(sample::hbt())).is_none());
    assert!(fdi.actuator_z(&Features::None).is_none());
    let mut failed = sample::servo_check(0.0, 0.07);
    failed.rudder_rate_p95_rad_s = None;
    failed.failed = Some("no rudder".into());
    let mut c = sample::clfrt(vec![]);
    c.servo_check = Some(failed);
    assert!(fdi.actuator_z(&Features::Clfrt(c)).is_none());
}

/// A commissioning reference is kept across a restore under the same configuration and
/// models, and discarded, with a message naming what changed, under others; a state file
/// of a version without commissioning still loads.
#[test]
fn a_reference_is_kept_only_for_its_configuration_and_models() {
    let cfg = CoreConfig::default();
    let mut fdi = Fdi::new(&cfg);
    fdi.set_models(Some("aaaa".into()));
    let s = cfg.fdi.commissioning();
    let raw = super::reference::Raw {
        speed_mps: 1.0,
        displacement: -0.2,
        speed_sigma_mps: 0.06,
        displacement_sigma: 0.002,
        speed_log_mps: 7.0,
    };
    for _ in 0..s.tests {
        fdi.commissioning[1].add(&s, &raw);
    }
    assert!(fdi.commissioning[1].reference.is_some());
    let saved = fdi.state();

    let mut same = Fdi::new(&cfg);
    same.set_models(Some("aaaa".into()));
    assert_eq!(same.restore(saved.clone()), None);
    assert_eq!(same.state(), saved);
    assert!(same
        .commissioning_text()
        .contains("HBT commissioned (8 tests at 7.0 m/s)"));

    let mut other_models = Fdi::new(&cfg);
    other_models.set_models(Some("bbbb".into()));
    let why = other_models.restore(saved.clone()).unwrap();
    assert!(why.contains("models changed (aaaa -> bbbb)"), "{why}");
    assert_eq!(other_models.commissioning, <[Commissioning; 2]>::default());

    let mut longer = cfg.clone();
    longer.ship.length_m = 130.0;
    // The nominal values are no part of it: a new loading keeps the reference.
    longer.ship.nominal_displacement_t = 8000.0;
    let mut other_ship = Fdi::new(&longer);
    other_ship.set_models(Some("aaaa".into()));
    let why = other_ship.restore(saved.clone()).unwrap();
    assert!(why.contains("ship.length-m 120.0 -> 130.0"), "{why}");
    assert!(!why.contains("nominal"), "{why}");

    let mut loaded = cfg.clone();
    loaded.ship.nominal_displacement_t = 8000.0;
    let mut new_load = Fdi::new(&loaded);
    new_load.set_models(Some("aaaa".into()));
    assert_eq!(new_load.restore(saved.clone()), None);

    // An older file: no commissioning, no fingerprint.
    let mut v = serde_json::to_value(&saved).unwrap();
    let o = v.as_object_mut().unwrap();
    o.remove("commissioning");
    o.remove("fingerprint");
    let old: FdiState = serde_json::from_value(v).unwrap();
    let mut fresh = Fdi::new(&cfg);
    assert_eq!(fresh.restore(old), None);
    assert!(fresh
        .commissioning_text()
        .starts_with("CLFRT commissioning 0 of 8"));
}

fn glr_cfg() -> FdiConfig {
    FdiConfig {
        rule: DecisionRule::Glr,
        ..FdiConfig::default()
    }
}

#[test]
fn the_glr_statistic_is_the_windowed_mean_worked_by_hand() {
    let w: VecDeque<[f64; 2]> = [[1.0, 0.0], [3.0, 0.0], [2.0, 2.0]].into_iter().collect();
    // n = 1: |(2, 2)|^2 = 8; n = 2: mean (2.5, 1), 2 * 7.25 = 14.5; n = 3: mean (2, 2/3),
    // 3 * (4 + 4/9) = 13.33.
    assert!((glr_window_statistic(&w, 1, 0.0) - 8.0).abs() < 1e-12);
    assert!((glr_window_statistic(&w, 2, 0.0) - 14.5).abs() < 1e-12);
    assert!((glr_window_statistic(&w, 3, 0.0) - 40.0 / 3.0).abs() < 1e-12);
    // The look nearest its limit: n = 2 (14.5 / 25) before n = 3 (13.3 / 25) and the newest
    // test alone (8 / 60).
    let g = glr_statistic(&w, 0.0, &cfg()).unwrap();
    assert_eq!((g.window, g.threshold), (2, 25.0));
    assert!((g.statistic - 14.5).abs() < 1e-12);
    // Clipped to |z| <= 2: (3, 0) counts as (2, 0), (2, 2) as (1.41, 1.41); n = 2: mean
    // (1.71, 0.71), 2 * 3.41 = 6.83; n = 3: mean (1.47, 0.47), 3 * 2.39 = 7.16, the larger.
    let clip = FdiConfig {
        glr_clip: 2.0,
        ..cfg()
    };
    let g = glr_statistic(&w, 0.0, &clip).unwrap();
    let h = 2f64.sqrt();
    let want = 3.0 * (((3.0 + h) / 3.0).powi(2) + (h / 3.0).powi(2));
    assert_eq!(g.window, 3);
    assert!((g.statistic - want).abs() < 1e-12, "{} {want}", g.statistic);
    // With a shared offset error of relative variance 1/8, three tests' mean has variance
    // (1/3 + 1/8) / (1 + 1/8) per component: 13.33 * 1.125 / 0.4583 / 3 = 10.91.
    let t3 = glr_window_statistic(&w, 3, 0.125);
    assert!((t3 - (4.0 + 4.0 / 9.0) * 1.125 / (1.0 / 3.0 + 0.125)).abs() < 1e-12);
    assert!(t3 > 10.8 && t3 < 11.0, "{t3}");
}

/// A healthy vessel's residuals, commissioned with K = 8 tests: each test's z is its own
/// noise plus the reference offset's error, shared by the run, scaled to unit variance as
/// `Commissioning::measure` does. The three-test statistic must exceed the chi-square(2)
/// 99 % point (9.21) 1 % of the time, and would twice as often without the offset term.
#[test]
fn the_glr_window_is_calibrated_for_a_commissioned_reference() {
    use rand::SeedableRng;
    use rand_distr::{Distribution, StandardNormal};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
    let c: f64 = 1.0 / 8.0;
    let runs = 100_000;
    let (mut over, mut over_naive) = (0, 0);
    for _ in 0..runs {
        let mut g = || -> f64 { StandardNormal.sample(&mut rng) };
        let o = [g() * c.sqrt(), g() * c.sqrt()];
        let w: VecDeque<[f64; 2]> = (0..3)
            .map(|_| {
                let s = (1.0 + c).sqrt();
                [(o[0] + g()) / s, (o[1] + g()) / s]
            })
            .collect();
        over += usize::from(glr_window_statistic(&w, 3, c) > 9.21);
        over_naive += usize::from(glr_window_statistic(&w, 3, 0.0) > 9.21);
    }
    let rate = over as f64 / runs as f64;
    let naive = over_naive as f64 / runs as f64;
    assert!(rate > 0.0085 && rate < 0.0115, "{rate}");
    assert!(naive > 0.017, "{naive}");
}

#[test]
fn glr_alarms_on_one_overwhelming_test_or_a_persistent_small_shift() {
    let c = glr_cfg();
    // One test with q = 72 > 60: alarm at once.
    let mut t = Track::default();
    let o = t.update(&c, Some(&p(0.0, 8.5, 0.0)), None);
    assert_eq!(o.state, TrackState::Alarm);
    assert_eq!(o.glr.map(|g| g.window), Some(1));
    // z = (0, 3.2) every test: q = 10.24 < 13.82 and T_2 = 20.5 < 25 stay normal; the third
    // test's T_3 = 30.7 raises the alarm (the chi-square rule with persistence alone never
    // would; its mean of three tests, limit 20, does at the same test).
    let mut t = Track::default();
    for _ in 0..2 {
        let o = t.update(&c, Some(&p(0.0, 3.2, 0.0)), None);
        assert_eq!(o.state, TrackState::Normal);
    }
    let o = t.update(&c, Some(&p(0.0, 3.2, 0.0)), None);
    assert_eq!(o.state, TrackState::Alarm);
    assert_eq!(o.glr.map(|g| g.window), Some(3));
    assert_eq!(o.isolation, vec![Cause::DisplacementOrRudderEffectiveness]);
    let persistence_alone = FdiConfig {
        mean_window: 0,
        ..cfg()
    };
    let (mut chi, mut with_mean) = (Track::default(), Track::default());
    for k in 1..=3 {
        assert_eq!(
            chi.update(&persistence_alone, Some(&p(0.0, 3.2, 0.0)), None)
                .state,
            TrackState::Normal
        );
        let want = if k < 3 {
            TrackState::Normal
        } else {
            TrackState::Alarm
        };
        assert_eq!(
            with_mean
                .update(&cfg(), Some(&p(0.0, 3.2, 0.0)), None)
                .state,
            want
        );
    }
    // A healthy scatter stays normal; a single test over 13.82 but under 25 is an alert.
    let mut t = Track::default();
    for z in [1.0, -1.5, 0.5, 2.0, -0.3] {
        assert_eq!(
            t.update(&c, Some(&p(z, -z, 0.0)), None).state,
            TrackState::Normal
        );
    }
    let o = t.update(&c, Some(&p(0.0, 4.0, 0.0)), None);
    assert_eq!(o.state, TrackState::Alert);
}

#[test]
fn the_glr_window_restarts_with_another_reference() {
    let c = glr_cfg();
    let mut t = Track::default();
    t.update_against(&c, Some(&p(0.0, 3.2, 0.0)), None, Some(0.0));
    t.update_against(&c, Some(&p(0.0, 3.2, 0.0)), None, Some(0.0));
    // Commissioned now: the window holds this test alone, T = 10.24.
    let o = t.update_against(&c, Some(&p(0.0, 3.2, 0.0)), None, Some(0.125));
    assert_eq!(o.state, TrackState::Normal);
    assert_eq!(o.glr.map(|g| g.window), Some(1));
}

/// A healthy ship's outlier (the second-order hull gave HBT tests at chi2 44): an alert, not
/// an alarm; without the clip the next ordinary test would carry the pair over the limit.
#[test]
fn one_outlier_does_not_carry_a_glr_window() {
    let run = |glr_clip: f64| {
        let c = FdiConfig {
            glr_clip,
            ..glr_cfg()
        };
        let mut t = Track::default();
        t.update(&c, Some(&p(0.2, -0.3, 0.0)), None);
        let o = t.update(&c, Some(&p(0.0, 6.63, 0.0)), None);
        assert_eq!(o.state, TrackState::Alert);
        t.update(&c, Some(&p(0.0, 0.5, 0.0)), None).state
    };
    assert_eq!(run(4.0), TrackState::Normal);
    assert_eq!(run(100.0), TrackState::Alarm);
}

/// On wide design limits (commissioning) the residual is the model's bias on this ship, the
/// same at every test: no averaging. Three tests at q = 9 (the second-order hull's
/// commissioning tests measured 4-9) would give T_3 = 27 > 25 if averaged.
#[test]
fn the_glr_does_not_average_a_bias_on_wide_design_limits() {
    let c = glr_cfg();
    let mut t = Track::default();
    for _ in 0..6 {
        let o = t.update_against(&c, Some(&p(2.1, 2.1, 0.0)), None, None);
        assert_eq!(o.state, TrackState::Normal);
        assert_eq!(o.glr.map(|g| g.window), Some(1));
    }
    let mut t = Track::default();
    let states: Vec<TrackState> = (0..3)
        .map(|_| t.update(&c, Some(&p(2.1, 2.1, 0.0)), None).state)
        .collect();
    assert_eq!(states[2], TrackState::Alarm);
}

/// A slow servo that also pushes the parameter residuals over the limit (HBT in a calm sea):
/// with one fault at a time the servo check names the cause alone; without, a parameter
/// cause is named beside it.
#[test]
fn a_servo_check_over_its_limit_names_the_actuator_alone_under_one_fault() {
    let run = |single_fault: bool| {
        let c = FdiConfig {
            single_fault,
            ..cfg()
        };
        let mut t = Track::default();
        t.update(&c, Some(&p(0.5, 5.0, 2.0)), Some([6.0, 0.0]));
        t.update(&c, Some(&p(0.4, 5.5, 2.0)), Some([6.5, 0.0]))
    };
    let one = run(true);
    assert_eq!(one.decision, Decision::Fault);
    assert_eq!(one.isolation, vec![Cause::SteeringActuator]);
    let both = run(false);
    assert_eq!(both.isolation.len(), 2, "{:?}", both.isolation);
    assert!(both
        .isolation
        .contains(&Cause::DisplacementOrRudderEffectiveness));
}

/// The chi-square rule's three-test mean: `T_3 = |mean z|^2 (1 + c) / (1/3 + c)`, worked by
/// hand: a shift of |z| = 3 on every test under a reference commissioned with K = 8 tests
/// (c = 1/8) gives T_3 = 9 x 1.125 / (1/3 + 1/8) = 22.09 > 20, while each test alone (chi2
/// 9) stays under 13.82: the alarm comes at the third test, not before; |z| = 2.8 gives
/// 19.24 and never alarms.
#[test]
fn the_chi_square_rule_adds_up_a_persistent_shift_over_three_tests() {
    let c = cfg();
    assert_eq!((c.mean_window, c.mean_threshold), (3, 20.0));
    let k8 = Some(1.0 / 8.0);
    let by_hand = |z: f64| z * z * 1.125 / (1.0 / 3.0 + 0.125);
    assert!((by_hand(3.0) - 22.090_909).abs() < 1e-5);
    let mut t = Track::default();
    let shift = p(0.0, 3.0, 0.0);
    for k in 1..=2 {
        let o = t.update_against(&c, Some(&shift), None, k8);
        assert_eq!(o.state, TrackState::Normal, "test {k}");
        assert!(o.glr.is_none(), "no mean before three tests");
    }
    let o = t.update_against(&c, Some(&shift), None, k8);
    assert_eq!((o.state, o.decision), (TrackState::Alarm, Decision::Fault));
    let look = o.glr.unwrap();
    assert_eq!(look.window, 3);
    assert!((look.statistic - by_hand(3.0)).abs() < 1e-9);
    assert_eq!(o.isolation, vec![Cause::DisplacementOrRudderEffectiveness]);
    let j = o.to_json(&c);
    assert_eq!(j["mean"]["window"], 3);
    // |z| = 2.8: T_3 = 19.24 under 20, for as long as it lasts.
    let mut t = Track::default();
    for _ in 0..10 {
        let o = t.update_against(&c, Some(&p(0.0, 2.8, 0.0)), None, k8);
        assert_eq!(o.state, TrackState::Normal);
        if let Some(g) = o.glr {
            assert!((g.statistic - by_hand(2.8)).abs() < 1e-9);
        }
    }
    // Off (`fdi.mean-window = 0`): |z| = 3 never alarms.
    let off = FdiConfig {
        mean_window: 0,
        ..cfg()
    };
    let mut t = Track::default();
    for _ in 0..10 {
        let o = t.update_against(&off, Some(&shift), None, k8);
        assert_eq!(o.state, TrackState::Normal);
        assert!(o.glr.is_none());
    }
}

/// The mean is taken under one reference only, never on wide design limits (there the
/// residual is the model's bias on this ship, the same at every test), and each test counts
/// with its z clipped to `fdi.glr-clip`.
#[test]
fn the_chi_square_mean_keeps_to_one_reference_and_clips_outliers() {
    let c = cfg();
    let shift = p(0.0, 3.0, 0.0);
    // Wide limits: no mean, however long the shift lasts.
    let mut t = Track::default();
    for _ in 0..6 {
        let o = t.update_against(&c, Some(&shift), None, None);
        assert_eq!(o.state, TrackState::Normal);
        assert!(o.glr.is_none());
    }
    // Two tests under the design, the third under the commissioned reference: the window
    // starts again at the change, so the alarm waits for three tests of the new reference.
    let mut t = Track::default();
    t.update_against(&c, Some(&shift), None, Some(0.0));
    t.update_against(&c, Some(&shift), None, Some(0.0));
    for _ in 0..2 {
        let o = t.update_against(&c, Some(&shift), None, Some(0.125));
        assert_eq!(o.state, TrackState::Normal);
    }
    let o = t.update_against(&c, Some(&shift), None, Some(0.125));
    assert_eq!(o.state, TrackState::Alarm);
    // One outlier (|z| = 7.5, chi2 56: an alert, under the one-test limit of 60) and two
    // ordinary tests: clipped to 4 the mean is (4 + 1 + 1) / 3 = 2, T_3 = 4 x 3 = 12 under
    // the design (c = 0); unclipped it would be 3.17^2 x 3 = 30 and alarm.
    let mut t = Track::default();
    let o = t.update(&c, Some(&p(0.0, 7.5, 0.0)), None);
    assert_eq!(o.state, TrackState::Alert);
    t.update(&c, Some(&p(0.0, 1.0, 0.0)), None);
    let o = t.update(&c, Some(&p(0.0, 1.0, 0.0)), None);
    assert_eq!(o.state, TrackState::Normal);
    assert!((o.glr.unwrap().statistic - 12.0).abs() < 1e-9);
}

/// The vessel's window over its limit raises the alarm of the test's method at once, as the
/// mean does, on a test no limit of its own would call; a test without parameter residuals
/// takes nothing from it.
#[test]
fn the_vessel_window_over_its_limit_is_an_alarm_at_once() {
    let c = cfg();
    let small = p(2.0, 2.0, 2.0); // chi2 8: under every limit of one method
    let mut t = Track::default();
    let o = t.update_with(&c, Some(&small), None, Some(0.125), false);
    assert_eq!((o.state, o.exceeded), (TrackState::Normal, false));
    let o = t.update_with(&c, Some(&small), None, Some(0.125), true);
    assert_eq!((o.state, o.exceeded), (TrackState::Alarm, true));
    assert_eq!(o.decision, Decision::Fault);
    assert_eq!(t.episode.param_exceeded, 1);
    // The alarm clears after `clear-after` nominal tests, as any alarm.
    for _ in 0..c.clear_after {
        t.update_with(&c, Some(&p(0.0, 0.0, 2.0)), None, Some(0.125), false);
    }
    assert_eq!(t.state, TrackState::Normal);
    // Only the servo check this test: the window is not the parameter residuals' evidence.
    let mut t = Track::default();
    let o = t.update_with(&c, None, Some([1.0, 0.0]), Some(0.125), true);
    assert_eq!(o.state, TrackState::Normal);
}
