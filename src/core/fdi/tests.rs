use super::decision::{Entry, Limits, Sequential, Source, YEAR_S};
use super::learning::{after_decision, Held};
use super::raw::spread;
use super::reference::{Basis, Commissioning, Raw};
use super::*;
use crate::core::estimator::model::Uncertainty;
use crate::core::wire::features::{sample, ClfrtFeatures, ServoRateFeatures};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;

fn entry(method: Method, z: [f64; 2], c: Option<f64>) -> Entry {
    Entry {
        method,
        z: Some(z),
        offset_var: c,
        epoch: 0,
        directions: [[-1.0, 0.3], [0.0, 1.0]],
        z_rate: None,
        source: None,
    }
}

#[test]
fn the_limits_follow_from_the_budget_by_hand() {
    let l = Limits::new(0.1, 3720.0, 4);
    let tests = YEAR_S / 3720.0;
    assert!((l.alpha_test - 0.1 / tests).abs() < 1e-18);
    let a = 0.1 / tests / 8.0;
    assert!((l.alpha_look - a).abs() < 1e-18);
    // chi2 with 2 dof is exponential: h = -2 ln(alpha).
    assert!(
        (l.param[0] - (-2.0 * a.ln())).abs() < 1e-9,
        "{}",
        l.param[0]
    );
    // chi2 with 4 dof: e^{-h/2} (1 + h/2) = alpha.
    let h4 = l.param[1];
    assert!(((-h4 / 2.0).exp() * (1.0 + h4 / 2.0) / a - 1.0).abs() < 1e-9);
    // The figures the docs quote.
    assert!(
        (l.param[0] - 26.9).abs() < 0.05 && (l.param[1] - 32.6).abs() < 0.05,
        "{l:?}"
    );
    assert!((l.servo - 4.67).abs() < 0.01, "{}", l.servo);
    assert!(
        (l.param_alert[0] - 13.0).abs() < 0.05,
        "{}",
        l.param_alert[0]
    );
    // A bigger budget lowers every limit.
    let loose = Limits::new(10.0, 3720.0, 4);
    assert!(loose.param[0] < l.param[0] && loose.servo < l.servo);
}

#[test]
fn a_persistent_shift_adds_up_over_the_window_as_the_glr_says() {
    let l = Limits::new(0.1, 3720.0, 4);
    let mut s = Sequential::default();
    // K = 8 tests at one point: the offset's error is a share 1 / (K + 1) of each test's
    // variance, shared by all.
    let c = Some(1.0 / 9.0);
    // |z| = 2.8 on every CLFRT test: chi2 7.84 each, under the alert limit alone.
    let z = [0.0, 2.8];
    let first = s.update(&l, entry(Method::Clfrt, z, c));
    assert_eq!(first.state, TrackState::Normal);
    let second = s.update(&l, entry(Method::Clfrt, z, c));
    // T_2 = |5.6|^2 / (2 (1 + 1/9)) = 14.11: over the alert limit (13.0), not the alarm's.
    let p = second.param.unwrap();
    assert_eq!(p.n, 2);
    assert!(
        (p.look.statistic - 31.36 / (2.0 * 10.0 / 9.0)).abs() < 1e-12,
        "{p:?}"
    );
    assert_eq!(second.state, TrackState::Alert);
    let third = s.update(&l, entry(Method::Clfrt, z, c));
    // T_3 = 70.56 / (3 (1 + 2/9)) = 19.2; T_4 at the fourth: 125.44 / (4 (1 + 3/9)) = 23.5;
    // still under 26.9: with K = 8 the shared offset error limits what a window can show.
    let t3 = 70.56 / (3.0 * 11.0 / 9.0);
    assert!((third.param.unwrap().look.statistic - t3).abs() < 1e-12);
    let fourth = s.update(&l, entry(Method::Clfrt, z, c));
    assert!((fourth.param.unwrap().look.statistic - 23.52).abs() < 1e-12);
    assert_eq!(fourth.state, TrackState::Alert);
    // Against the design reference (c = 0) the same shift alarms at the third test:
    // T_3 = 81 / 3 = 27 > 26.9.
    let mut d = Sequential::default();
    let z = [0.0, 3.0];
    for _ in 0..2 {
        assert_ne!(
            d.update(&l, entry(Method::Clfrt, z, Some(0.0))).state,
            TrackState::Alarm
        );
    }
    let last = d.update(&l, entry(Method::Clfrt, z, Some(0.0)));
    assert!((last.param.unwrap().look.statistic - 27.0).abs() < 1e-12);
    assert_eq!(last.state, TrackState::Alarm);
    assert_eq!(
        last.isolation,
        vec![Cause::DisplacementOrRudderEffectiveness]
    );
    // The evidence is spent: the window is empty after the alarm.
    assert!(d.window.is_empty());
}

#[test]
fn both_methods_add_their_evidence_with_two_more_degrees_of_freedom() {
    let l = Limits::new(0.1, 3720.0, 4);
    let mut s = Sequential::default();
    // CLFRT and HBT see the fault in different directions: (0, 4) and (3, 2.6).
    s.update(&l, entry(Method::Clfrt, [0.0, 4.0], Some(0.0)));
    let st = s.update(&l, entry(Method::Hbt, [3.0, 2.6], Some(0.0)));
    let p = st.param.unwrap();
    // T_2 = 16 + 15.76 = 31.76 with 4 dof against 32.6: an alert.
    assert_eq!((p.n, p.look.dof), (2, 4));
    assert!((p.look.statistic - 31.76).abs() < 1e-9);
    assert_eq!(st.state, TrackState::Alert);
    let st = s.update(&l, entry(Method::Clfrt, [0.0, 4.0], Some(0.0)));
    // T_3 = |(0, 8)|^2 / 2 + 15.76 = 47.76 > 32.6.
    assert_eq!(st.state, TrackState::Alarm);
    assert_eq!(st.raised_by_servo, Some(false));
}

#[test]
fn a_test_on_wide_limits_counts_alone_and_is_left_out_of_longer_windows() {
    let l = Limits::new(0.1, 3720.0, 4);
    let mut s = Sequential::default();
    for _ in 0..3 {
        let st = s.update(&l, entry(Method::Hbt, [0.0, 3.0], None));
        let p = st.param.unwrap();
        assert_eq!((p.n, p.look.statistic), (1, 9.0));
    }
    // A commissioned test after them: the wide ones are left out of its windows.
    let st = s.update(&l, entry(Method::Clfrt, [0.0, 1.0], Some(0.125)));
    assert!(st.param.unwrap().look.statistic <= 1.0 + 1e-12);
    // A gross fault on wide limits still alarms at once.
    let st = s.update(&l, entry(Method::Hbt, [0.0, 6.0], None));
    assert_eq!(st.state, TrackState::Alarm);
}

#[test]
fn the_servo_channel_alarms_and_names_the_actuator_alone() {
    let l = Limits::new(0.1, 3720.0, 4);
    let mut s = Sequential::default();
    let mut e = entry(Method::Clfrt, [2.0, 1.0], Some(0.125));
    e.z_rate = Some(5.8);
    let st = s.update(&l, e);
    assert_eq!(st.state, TrackState::Alarm);
    assert_eq!(st.raised_by_servo, Some(true));
    assert_eq!(st.isolation, vec![Cause::SteeringActuator]);
    // The alarm holds while the servo stays slow, and clears after 4 quiet tests.
    let mut quiet = entry(Method::Hbt, [0.1, 0.2], Some(0.125));
    quiet.z_rate = Some(0.0);
    for k in 1..=4 {
        let st = s.update(&l, quiet);
        let want = if k < 4 {
            TrackState::Alarm
        } else {
            TrackState::Normal
        };
        assert_eq!(st.state, want, "quiet test {k}");
        if k < 4 {
            assert_eq!(st.isolation, vec![Cause::SteeringActuator]);
        } else {
            assert!(st.isolation.is_empty());
        }
    }
}

#[test]
fn isolation_tells_the_speed_log_from_the_displacement_by_direction() {
    let l = Limits::new(0.1, 3720.0, 4);
    // A speed-log bias: every method's residual along its own log direction.
    let mut s = Sequential::default();
    let mut e = entry(Method::Clfrt, [-5.0, 1.5], Some(0.0));
    e.directions = [[-1.0, 0.3], [0.0, 1.0]];
    let st = s.update(&l, e);
    assert_eq!(st.state, TrackState::Alarm);
    assert_eq!(st.isolation, vec![Cause::SpeedLog]);
    // A displacement change: along (0, 1).
    let mut s = Sequential::default();
    let st = s.update(&l, entry(Method::Hbt, [0.4, 6.0], Some(0.0)));
    assert_eq!(st.isolation, vec![Cause::DisplacementOrRudderEffectiveness]);
    // The cost by hand: off the log line (-1, 0.3) of (0.4, 6): |z|^2 - (u.z)^2.
    let w: std::collections::VecDeque<Entry> = [entry(Method::Hbt, [0.4, 6.0], Some(0.0))].into();
    let j = isolation::costs(&w, 1);
    let u = [-1.0 / 1.09f64.sqrt(), 0.3 / 1.09f64.sqrt()];
    let along = u[0] * 0.4 + u[1] * 6.0;
    assert!((j[0] - (36.16 - along * along)).abs() < 1e-9);
    assert!((j[1] - 0.16).abs() < 1e-12);
}

/// A vessel per the decision's own model: K healthy commissioning tests per method, whose
/// mean and covariance set the reference (through `Commissioning`), then tests in turn,
/// each whitened and fed to the sequential test, and learned (`learn`) as the daemon learns
/// them. Returns (alarms raised, tests decided).
fn monte_carlo(
    budget: f64,
    k: u32,
    floors: [f64; 2],
    vessels: usize,
    tests: usize,
    seed: u64,
    learn: bool,
) -> (usize, usize) {
    let l = Limits::new(budget, 3720.0, 4);
    let fdi = FdiConfig {
        commissioning_tests: k,
        floor_speed_mps: floors[0],
        floor_displacement: floors[1],
        ..FdiConfig::default()
    };
    let reference = ReferenceConfig {
        learn,
        // The whole sample: a known covariance needs all K tests.
        resolve_speed_mps: 1e-9,
        resolve_displacement: 1e-9,
        ..ReferenceConfig::default()
    };
    let settings = reference::Settings::new(&fdi, &reference, &l);
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let (mut alarms, mut decided) = (0, 0);
    // True scatter: correlated -0.9, as on a second-order hull.
    let (su, sd, rho) = (0.2, 0.01, -0.9);
    let draw = |rng: &mut ChaCha8Rng| {
        let a: f64 = rng.sample(StandardNormal);
        let b: f64 = rng.sample(StandardNormal);
        let u = su * a;
        let d = sd * (rho * a + (1.0f64 - rho * rho).sqrt() * b);
        Raw {
            speed_mps: 1.0 + u,
            displacement: -0.2 + d,
            speed_sigma_mps: 0.05,
            displacement_sigma: 0.002,
            speed_log_mps: 7.0,
            displacement_declared_t: 7000.0,
            excitation_scale: 1.0,
        }
    };
    for _ in 0..vessels {
        let mut sample = || {
            let raws: Vec<Raw> = (0..k).map(|_| draw(&mut rng)).collect();
            Commissioning::commissioned_on(&settings, &raws).unwrap()
        };
        let mut c = [sample(), sample()];
        let mut s = Sequential::default();
        let mut pending = Pending::default();
        for k in 0..tests {
            let m = k % 2;
            let method = [Method::Clfrt, Method::Hbt][m];
            let raw = draw(&mut rng);
            // The window against the references as they are now, as the daemon does.
            s.remeasure(|e| {
                let src = e.source?;
                let j = [Method::Clfrt, Method::Hbt]
                    .iter()
                    .position(|x| *x == e.method)?;
                let (_, n) = c[j].measure(&settings, &src.raw);
                Some(Entry {
                    z: n.whitened(),
                    offset_var: n.offset_var,
                    ..*e
                })
            });
            let (basis, meas) = c[m].measure(&settings, &raw);
            assert!(
                matches!(basis, Basis::Vessel(_)),
                "{basis:?} {:?}",
                c[m].phase
            );
            let z = meas.whitened();
            let before = s.state;
            let st = s.update(
                &l,
                Entry {
                    method,
                    z,
                    offset_var: meas.offset_var,
                    epoch: 0,
                    directions: [[-1.0, 0.0], [0.0, 1.0]],
                    z_rate: Some(rng.sample::<f64, _>(StandardNormal).max(0.0)),
                    source: Some(Source {
                        raw,
                        directions: [[-1.0, 0.0], [0.0, 1.0]],
                    }),
                },
            );
            decided += 1;
            if before != TrackState::Alarm && st.state == TrackState::Alarm {
                alarms += 1;
            }
            // Learned as the daemon learns (`learning`): under the single-test limit, at once
            // when the decision is quiet, else once it leaves the window with no alarm.
            let q = z.map_or(f64::INFINITY, |z| z[0] * z[0] + z[1] * z[1]);
            let held = (learn && q <= l.param[0]).then_some(Held {
                method: m,
                generation: 0,
                raw,
            });
            for h in after_decision(&mut pending, &mut s, held, l.window)
                .into_iter()
                .flatten()
            {
                c[h.method].add(&settings, &h.raw);
            }
        }
    }
    (alarms, decided)
}

/// The figures of docs/fdi.md "What the arithmetic covers": `cargo test --profile ci --lib
/// monte_carlo_scan -- --ignored --nocapture`.
#[test]
#[ignore]
fn monte_carlo_scan() {
    for (k, floors, learn) in [
        (8, [0.0, 0.0], false),
        (8, [0.0, 0.0], true),
        (8, [0.2, 0.01], false),
        (30, [0.0, 0.0], false),
        (200, [0.0, 0.0], false),
    ] {
        for (budget, vessels) in [(30.0, 2000), (8.0, 6000), (2.0, 20000)] {
            let (alarms, decided) = monte_carlo(budget, k, floors, vessels, 100, 7, learn);
            let want = Limits::new(budget, 3720.0, 4).alpha_test;
            println!(
                "K {k} floors {floors:?} learn {learn} budget {budget}: {alarms} in {decided}: ratio {:.3}",
                alarms as f64 / decided as f64 / want
            );
        }
    }
}

/// A vessel commissioned on 8 tests, then learning its tests as the daemon does: the false
/// alarms counted on the model itself are within a factor of two of the budget (measured
/// 1.05; without learning 1.43, the calibration alone; K = 200, the covariance known: 0.79).
/// A budget of 2 a year (2.4e-4 per test) is small enough for the Gaussian tails to decouple
/// the overlapping looks and large enough to count 300 alarms in 2e6 tests.
#[test]
fn monte_carlo_false_alarm_rate_is_within_a_factor_two_of_the_budget() {
    let budget = 2.0;
    let (alarms, decided) = monte_carlo(budget, 8, [0.0, 0.0], 20_000, 100, 7, true);
    let per_test = alarms as f64 / decided as f64;
    let want = Limits::new(budget, 3720.0, 4).alpha_test;
    let ratio = per_test / want;
    eprintln!("{alarms} alarms in {decided} tests: ratio {ratio:.3}");
    assert!(
        (0.5..=2.0).contains(&ratio),
        "{alarms} alarms in {decided} tests: {per_test:.4} per test against {want:.4} ({ratio:.2})"
    );
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
    let c = FdiConfig::default();
    let ship = CoreConfig::default().ship;
    let (a, b) = (0.0146, 5.98e-4);
    let ws = [0.032, 0.0745, 0.181];
    let f = fit::model_fit(&Features::Clfrt(nomoto_tones(a, b, &ws)), &ship, &c).unwrap();
    approx::assert_relative_eq!(f.a_per_s, a, max_relative = 1e-6);
    approx::assert_relative_eq!(f.b_per_s2, b, max_relative = 1e-6);
    assert!(f.chi2 < 1e-12, "{}", f.chi2);
    assert_eq!(f.dof, 4);
    // Its (u, D) from DOMAIN's formulas: a = 0.0146 is u = 7 m/s; b = 5.98e-4 is D = 7000 t.
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
    let z = fdi.servo_check(&hbt(0.035)).unwrap();
    approx::assert_relative_eq!(z.z_rate, 0.5 / sigma, max_relative = 1e-12);
    approx::assert_relative_eq!(z.rate_ratio, 0.5, max_relative = 1e-12);
    assert_eq!(fdi.servo_check(&hbt(0.0707)).unwrap().z_rate, 0.0);
    let z = fdi.servo_check(&clfrt(0.063)).unwrap();
    approx::assert_relative_eq!(z.z_rate, 0.1 / sigma, max_relative = 1e-9);
    // No servo field, or a failed check: no actuator residual.
    assert!(fdi.servo_check(&Features::Hbt(sample::hbt())).is_none());
    assert!(fdi.servo_check(&Features::None).is_none());
    let mut failed = sample::servo_check(0.0, 0.07);
    failed.rudder_rate_p95_rad_s = None;
    failed.failed = Some("no rudder".into());
    let mut c = sample::clfrt(vec![]);
    c.servo_check = Some(failed);
    assert!(fdi.servo_check(&Features::Clfrt(c)).is_none());
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
    let raw = super::reference::Raw {
        speed_mps: 1.0,
        displacement: -0.2,
        speed_sigma_mps: 0.06,
        displacement_sigma: 0.002,
        speed_log_mps: 7.0,
        displacement_declared_t: 7000.0,
        excitation_scale: 1.0,
    };
    // No scatter: the floors alone resolve the faults, so commissioning ends at 6 tests.
    while fdi.commissioning[1].in_progress(&s) {
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
        .contains("HBT commissioned (6 tests, 6 learned, 7.0-7.0 m/s)"));

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

    // An older file: no commissioning, no fingerprint, no sequential test.
    let mut v = serde_json::to_value(&saved).unwrap();
    let o = v.as_object_mut().unwrap();
    o.remove("commissioning");
    o.remove("fingerprint");
    o.remove("sequential");
    let old: FdiState = serde_json::from_value(v).unwrap();
    let mut fresh = Fdi::new(&cfg);
    assert_eq!(fresh.restore(old), None);
    assert!(fresh
        .commissioning_text()
        .starts_with("CLFRT commissioning 0 of at most 8"));
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
