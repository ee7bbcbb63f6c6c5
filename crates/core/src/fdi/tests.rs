use super::decision::tests::entry;
use super::measured::Basis;
use super::raw::spread;
use super::reference::{Added, MethodReference};
use super::*;
use crate::estimator::model::Uncertainty;
use crate::fdi::config::Calibration;
use crate::fdi::raw::servo_check;
use crate::testing::sample;
use crate::wire::features::{ClfrtFeatures, ServoRateFeatures};
use crate::wire::Features;

/// Relative spreads scale with the reference; absolute ones (or files without relative
/// figures) do not; between the anchors both interpolate, above moderate the spread grows.
#[test]
fn spreads_relative_and_absolute() {
    use crate::estimator::model::SeaSpread;
    use crate::model::SeaState;
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
    let c = Calibration::default();
    let ship = CoreConfig::default().ship;
    let (a, b) = (0.0146, 5.98e-4);
    let ws = [0.032, 0.0745, 0.181];
    let f = fit::model_fit(&Features::Clfrt(nomoto_tones(a, b, &ws)), &ship, &c).unwrap();
    approx::assert_relative_eq!(f.a_per_s, a, max_relative = 1e-6);
    approx::assert_relative_eq!(f.b_per_s2, b, max_relative = 1e-6);
    assert!(f.chi2 < 1e-12, "{}", f.chi2);
    assert_eq!(f.dof, 4);
    // Its (u, D) from the model's formulas (docs/architecture.md): a = 0.0146 is u = 7 m/s;
    // b = 5.98e-4 is D = 7000 t.
    let j = f.report(&ship);
    approx::assert_relative_eq!(j.speed_mps, 7.008, max_relative = 1e-3);
    let d = j.displacement_t;
    assert!((d - 7000.0).abs() < 30.0, "{d}");
    // Add a lag of 10 deg at the top tone (an unmodelled actuator lag): no (a, b) explains it.
    let mut bad = nomoto_tones(a, b, &ws);
    bad.tones[2].phase_rad -= 10f64.to_radians();
    let f = fit::model_fit(&Features::Clfrt(bad), &ship, &c).unwrap();
    assert!(f.chi2 > 100.0, "{}", f.chi2);
}

/// The servo check reads each method's own field: CLFRT the burst's p95 rate, HBT the relay
/// slews' peak rate; one-sided, and `(1 - rho) / sigma` by hand.
#[test]
fn the_servo_check_reads_each_methods_servo_field() {
    let fdi = Fdi::new(&CoreConfig::default());
    let sigma = Calibration::default().actuator_rate_sigma;
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
    let z = servo_check(&hbt(0.035), fdi.cal.actuator_rate_sigma).unwrap();
    approx::assert_relative_eq!(z.z_rate, 0.5 / sigma, max_relative = 1e-12);
    approx::assert_relative_eq!(z.rate_ratio, 0.5, max_relative = 1e-12);
    assert_eq!(
        servo_check(&hbt(0.0707), fdi.cal.actuator_rate_sigma)
            .unwrap()
            .z_rate,
        0.0
    );
    let z = servo_check(&clfrt(0.063), fdi.cal.actuator_rate_sigma).unwrap();
    approx::assert_relative_eq!(z.z_rate, 0.1 / sigma, max_relative = 1e-9);
    // No servo field, or a failed check: no actuator residual.
    assert!(servo_check(&Features::Hbt(sample::hbt()), fdi.cal.actuator_rate_sigma).is_none());
    assert!(servo_check(&Features::None, fdi.cal.actuator_rate_sigma).is_none());
    let mut failed = sample::servo_check(0.0, 0.07);
    failed.rudder_rate_p95_rad_s = None;
    failed.failed = Some("no rudder".into());
    let mut c = sample::clfrt(vec![]);
    c.servo_check = Some(failed);
    assert!(servo_check(&Features::Clfrt(c), fdi.cal.actuator_rate_sigma).is_none());
}

/// A test's raw residual at 7 m/s and 7000 t with speed residual `e_u` [m/s].
fn raw_7(e_u: f64) -> super::raw::Raw {
    super::raw::Raw {
        speed_mps: e_u,
        displacement: -0.2,
        speed_sigma_mps: 0.06,
        displacement_sigma: 0.002,
        speed_log_mps: 7.0,
        displacement_declared_t: 7000.0,
        excitation_scale: 1.0,
        sea_index: None,
        ln_gain: Some(-5.0),
        ln_damping: None,
        speed_slope: [0.0; 3],
        loading_slope: [0.0; 3],
        meas: None,
        log_slope: 0.0,
    }
}

/// A commissioning reference is kept across a restore under the same configuration and
/// models, and discarded, with a message naming what changed, under others; a state file
/// of a version without commissioning still loads.
#[test]
fn a_reference_is_kept_only_for_its_configuration_and_models() {
    let cfg = CoreConfig::default();
    let mut fdi = Fdi::new(&cfg);
    fdi.set_models(Some("aaaa".into()));
    let s = fdi.settings();
    let raw = raw_7(1.0);
    // No scatter: the floors alone resolve the faults, so commissioning ends at 6 tests.
    while fdi.commissioning[1].in_progress(&s) {
        fdi.commissioning[1].add(&s, &raw, 0);
    }
    assert!(fdi.commissioning[1].reference.is_some());
    // A CLFRT test's tones in the loop shape.
    let tones = [0.032, 0.075, 0.18]
        .iter()
        .map(|&w| sample::tone(w, 1e-3 / (w * w), -2.5))
        .collect();
    let mut c = sample::clfrt(tones);
    c.speed_log_mps = Some(7.0);
    fdi.loop_shape.learn(&Features::Clfrt(c));
    assert_ne!(fdi.loop_shape, LoopShape::default());
    let saved = fdi.state();

    let mut same = Fdi::new(&cfg);
    same.set_models(Some("aaaa".into()));
    assert_eq!(same.restore(saved.clone()), None);
    assert_eq!(same.state(), saved);
    assert!(same
        .commissioning_text()
        .contains("HBT commissioned (6 tests, 6 learned, 7.0-7.0 m/s)"));

    let mut other_models = Fdi::new(&cfg);
    other_models.set_models(Some("bbbb".into()));
    let why = other_models.restore(saved.clone()).unwrap();
    assert!(why.contains("models changed (aaaa -> bbbb)"), "{why}");
    assert_eq!(
        other_models.commissioning,
        <[MethodReference; 2]>::default()
    );
    assert_eq!(other_models.loop_shape, LoopShape::default());

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

    // An older file: no commissioning, no fingerprint, no sequential test, no loop shape.
    let mut v = serde_json::to_value(&saved).unwrap();
    let o = v.as_object_mut().unwrap();
    o.remove("loop_shape");
    o.remove("commissioning");
    o.remove("fingerprint");
    o.remove("sequential");
    let old: FdiState = serde_json::from_value(v).unwrap();
    let mut fresh = Fdi::new(&cfg);
    assert_eq!(fresh.restore(old), None);
    assert!(fresh
        .commissioning_text()
        .starts_with("CLFRT commissioning 0 of at most 16"));

    // Commissioning HBT again keeps CLFRT's loop shape; commissioning CLFRT again drops it.
    same.commission(Some(Method::Hbt));
    assert_eq!(same.loop_shape, saved.loop_shape);
    same.commission(Some(Method::Clfrt));
    assert_eq!(same.loop_shape, LoopShape::default());
}

/// A saved state, through JSON and back into a fresh FDI, is the same state, and the next
/// test moves both the same way: an alarm stays an alarm across a restart.
#[test]
fn the_state_survives_a_round_trip_through_json() {
    let cfg = CoreConfig::default();
    let mut fdi = Fdi::new(&cfg);
    let l = *fdi.limits();
    fdi.sequential
        .update(&l, entry(Method::Clfrt, [0.0, 3.0], Some(0.125)));
    fdi.sequential
        .update(&l, entry(Method::Hbt, [9.0, 2.0], Some(0.125)));
    assert_eq!(fdi.alarm_state(), AlarmState::Alarm);
    fdi.sequential
        .update(&l, entry(Method::Clfrt, [0.0, 2.0], Some(0.125)));
    fdi.last_notification = Some(Notification {
        state: AlarmState::Alarm,
        method: vec!["visual".into(), "sound".into()],
        message: "Steering FDI (HBT): fault".into(),
    });
    fdi.published = AlarmState::Alarm;
    let saved = fdi.state();
    let text = serde_json::to_string(&saved).unwrap();
    let mut fresh = Fdi::new(&cfg);
    assert_eq!(fresh.alarm_state(), AlarmState::Normal);
    assert_eq!(fresh.restore(serde_json::from_str(&text).unwrap()), None);
    assert_eq!(fresh.state(), saved);
    assert_eq!(fresh.alarm_state(), AlarmState::Alarm);
    let a = fdi
        .sequential
        .update(&l, entry(Method::Hbt, [0.0, 2.5], Some(0.125)));
    let b = fresh
        .sequential
        .update(&l, entry(Method::Hbt, [0.0, 2.5], Some(0.125)));
    assert_eq!(a, b);
    assert_eq!(fdi.state(), fresh.state());
    // A file of an older version, whose window and references are in another format (two
    // residual components): read, those parts empty, the alarm kept.
    let mut v = serde_json::to_value(&saved).unwrap();
    v["sequential"]["window"] = serde_json::from_str(
        r#"[{"method": "clfrt", "z": [1.0, 2.0], "offset_var": 0.1, "epoch": 0,
            "directions": [[-1.0, 0.0], [0.0, 1.0]]}]"#,
    )
    .unwrap();
    v["commissioning"][0]["samples"] = serde_json::from_str(
        r#"[{"e": [1.0, 2.0], "s": [1.0, 1.0], "speed_mps": 7.0, "displacement_t": 7000.0}]"#,
    )
    .unwrap();
    let old: FdiState = serde_json::from_value(v).unwrap();
    assert_eq!(old.sequential, Sequential::default());
    assert_eq!(old.commissioning, <[MethodReference; 2]>::default());
    let mut upgraded = Fdi::new(&cfg);
    upgraded.restore(old);
    assert_eq!(upgraded.alarm_state(), AlarmState::Alarm);
    assert_eq!(
        upgraded.last_notification(),
        saved.last_notification.as_ref()
    );
}

/// Without an estimate a test has no parameter residuals; with a servo check it is still
/// decided on that channel (a gross servo fault alarms and is named, notified once).
#[test]
fn a_test_without_an_estimate_is_decided_on_its_servo_check_alone() {
    let mut fdi = Fdi::new(&CoreConfig::default());
    let mut h = sample::hbt();
    h.speed_log_mps = Some(7.0);
    let a = fdi.assess(Method::Hbt, &Features::Hbt(h.clone()), None, 7000.0);
    assert_eq!(a.decision, Decision::Inconclusive);
    assert!(a.notification.is_none());
    assert!(a.residuals.parameters.is_none());
    // A 2 deg/s servo: the relay slews peak at half the healthy rate, z_rate = 16.7.
    h.servo_rate = Some(ServoRateFeatures {
        rudder_rate_peak_rad_s: 0.035,
        rudder_rate_nominal_rad_s: 0.07,
    });
    let a = fdi.assess(Method::Hbt, &Features::Hbt(h), None, 7000.0);
    assert_eq!(a.decision, Decision::Fault);
    assert_eq!(a.isolation, vec![Cause::SteeringActuator]);
    assert_eq!(a.notification.map(|n| n.state), Some(AlarmState::Alarm));
    let d = a.residuals.decision.unwrap();
    assert!(d.servo.unwrap().statistic > d.servo.unwrap().threshold);
}

/// A commissioning test beyond the wide limits (HBT reading the displacement 1.3 D_nom high,
/// as models trained on the Mariner's own particulars do at its fast and light corner) joins
/// the sample: a misfit model reads the ship so from its first test, and the vessel's own
/// reference is what judges it (`decision`: on wide limits it alerts, never alarms).
#[test]
fn a_commissioning_test_beyond_the_wide_limits_joins_the_sample() {
    let cfg = CoreConfig::default();
    let mut fdi = Fdi::new(&cfg);
    let s = fdi.settings();
    let raw = super::raw::Raw {
        speed_mps: -0.2,
        displacement: 1.3,
        speed_sigma_mps: 0.3,
        displacement_sigma: 0.03,
        speed_log_mps: 10.0,
        displacement_declared_t: 4000.0,
        excitation_scale: 0.5,
        sea_index: None,
        ln_gain: Some(-5.0),
        ln_damping: None,
        speed_slope: [0.0; 3],
        loading_slope: [0.0; 3],
        meas: None,
        log_slope: 0.0,
    };
    let (basis, m) = fdi.commissioning[1].measure(&s, &raw);
    assert!(
        matches!(basis, Basis::Commissioning { done: 0, .. }),
        "{basis:?}"
    );
    let z = m.whitened().unwrap();
    let q = stats::dot(z, z);
    assert!(
        q > fdi.limits.param[m.dim],
        "{q} under the single-test limit"
    );
    let added = fdi.learner().learn(1, Some(raw), Some(&basis), None, &s);
    assert_eq!(added, Added::Sample);
    assert_eq!(fdi.commissioning[1].tests, 1);
}

/// The embedded networks under `calibration`.
fn embedded_with(calibration: Calibration) -> crate::estimator::Estimator {
    use crate::estimator::model::Model;
    use crate::estimator::{Estimator, EMBEDDED_MODELS};
    let models = EMBEDDED_MODELS
        .iter()
        .map(|(n, t)| (n.to_string(), Model::from_json(t, n).unwrap()))
        .collect::<Vec<_>>();
    Estimator::from_models(models, calibration, &CoreConfig::default()).unwrap()
}

/// A CLFRT test of the design's Nomoto ship with its log at 7 m/s.
fn clfrt_at_7_mps() -> Features {
    let mut c = nomoto_tones(0.0146, 5.98e-4, &[0.032, 0.0745, 0.181]);
    c.speed_log_mps = Some(7.0);
    Features::Clfrt(c)
}

/// `f`'s raw residuals through `est` at sea fraction `frac`, declared 7000 t.
fn clfrt_raw(est: &crate::estimator::Estimator, f: &Features, frac: f64) -> raw::NnRaw {
    use crate::wire::Method;
    let mut scratch = est.scratch();
    let e = est.estimate(Method::Clfrt, f, &mut scratch).unwrap();
    raw::nn_raw(Method::Clfrt, f, &e, 7000.0, est, &mut scratch, frac, None).unwrap()
}

/// With the class's displacement direction in the models' calibration, a test's
/// displacement direction is that direction at its sea (1 % of it, interpolated by hand
/// between calm and moderate, clamped to them) and the rudder's is the `b` scaling's the
/// same networks give without it; without it, the `b` scaling's is the displacement's and
/// the rudder has none of its own (`raw`, module doc). A declared loading's slope follows the
/// class's direction too.
#[test]
fn the_class_direction_is_the_displacements_and_the_b_scaling_the_rudders() {
    use crate::fdi::config::DisplacementDirection;
    use crate::wire::Method;
    let pair = [[0.01, 0.9, -0.4], [-0.03, 0.8, -0.6]];
    let design = embedded_with(Calibration::default());
    let class = embedded_with(Calibration {
        displacement_direction: Some(DisplacementDirection {
            clfrt: pair,
            hbt: pair,
        }),
        ..Calibration::default()
    });
    let f = clfrt_at_7_mps();
    let run = |est: &crate::estimator::Estimator, frac: f64| clfrt_raw(est, &f, frac);
    for (frac, at) in [(0.0, 0.0), (0.25, 0.25), (1.0, 1.0), (2.5, 1.0)] {
        let without = run(&design, frac);
        assert_eq!(without.rudder_dir, None);
        assert!(without.displacement_dir[1] > 0.0, "{without:?}");
        let with = run(&class, frac);
        for (got, (c, m)) in with
            .displacement_dir
            .iter()
            .zip(pair[0].iter().zip(pair[1]))
        {
            let want = 0.01 * (c + at * (m - c));
            approx::assert_relative_eq!(*got, want, max_relative = 1e-12);
        }
        assert_eq!(with.rudder_dir, Some(without.displacement_dir));
        // A declared loading moves it as the true displacement does, less the declaration.
        let e = design
            .estimate(Method::Clfrt, &f, &mut design.scratch())
            .unwrap();
        let want: [f64; 3] = std::array::from_fn(|j| {
            let c = pair[0][j] + at * (pair[1][j] - pair[0][j]);
            c - if j == 1 {
                e.displacement_t / 7000.0
            } else {
                0.0
            }
        });
        for (got, want) in with.raw.loading_slope.iter().zip(want) {
            approx::assert_relative_eq!(*got, want, max_relative = 1e-12);
        }
        assert_ne!(without.raw.loading_slope, with.raw.loading_slope);
        let same = super::raw::Raw {
            loading_slope: without.raw.loading_slope,
            ..with.raw
        };
        assert_eq!(same, without.raw);
    }
}

/// With the class's speed slope in the models' calibration, a test's `speed_slope` takes it
/// on the components it names (interpolated by hand between calm and moderate, clamped to
/// them) and keeps the similarity law's, as the same networks give it without, on the null
/// ones; nothing else moves (`raw`, module doc).
#[test]
fn the_class_speed_slope_replaces_the_law_where_it_is_given() {
    use crate::fdi::config::SpeedSlope;
    let e_d = [-0.01, -0.03];
    let law = embedded_with(Calibration::default());
    let class = embedded_with(Calibration {
        speed_slope: Some(SpeedSlope {
            clfrt: [None, Some(e_d), None],
            hbt: [None; 3],
        }),
        ..Calibration::default()
    });
    let f = clfrt_at_7_mps();
    let run = |est: &crate::estimator::Estimator, frac: f64| clfrt_raw(est, &f, frac);
    for (frac, at) in [(0.0, 0.0), (0.25, 0.25), (1.0, 1.0), (2.5, 1.0)] {
        let (without, with) = (run(&law, frac), run(&class, frac));
        // The law's slope is the networks' own: e_b's near 2 / u (b ~ u^2) on this ship.
        assert!(without.raw.speed_slope[2] > 0.0, "{without:?}");
        let want = e_d[0] + at * (e_d[1] - e_d[0]);
        approx::assert_relative_eq!(with.raw.speed_slope[1], want, max_relative = 1e-12);
        assert_ne!(without.raw.speed_slope[1], want);
        let same = super::raw::Raw {
            speed_slope: without.raw.speed_slope,
            ..with.raw
        };
        assert_eq!(same, without.raw);
        assert_eq!(with.raw.speed_slope[0], without.raw.speed_slope[0]);
        assert_eq!(with.raw.speed_slope[2], without.raw.speed_slope[2]);
    }
}
