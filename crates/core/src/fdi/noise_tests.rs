use super::*;
use crate::estimator::Estimator;
use crate::fdi::config::{Calibration, FdiConfig, ReferenceConfig};
use crate::fdi::limits::DecisionLimits;
use crate::fdi::raw::measurement_cov;
use crate::fdi::raw::Raw;
use crate::fdi::reference::{MethodReference, Settings as RefSettings};
use crate::monitor::config::CoreConfig;
use crate::testing::sample;
use crate::wire::features::ClfrtFeatures;
use crate::wire::{Features, Method};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;

/// The default multisine's tones (harmonics 3, 7, 17 of a 590 s window) on the first-order
/// ship at 7 m/s and 7000 t, exact, with intervals `ci` (relative gain) and `ci` rad.
fn ship_tones(ci: f64) -> ClfrtFeatures {
    let cfg = CoreConfig::default();
    let (a, b) = cfg.ship.nomoto(7.0, 7000.0);
    let mut c = sample::clfrt(
        [3.0, 7.0, 17.0]
            .iter()
            .map(|k| {
                let w = 2.0 * std::f64::consts::PI * k / 590.0;
                let mut t = sample::tone(
                    w,
                    b / (w * (w * w + a * a).sqrt()),
                    -std::f64::consts::FRAC_PI_2 - (w / a).atan(),
                );
                t.gain_ci90_rel = ci;
                t.phase_ci90_rad = ci;
                t
            })
            .collect(),
    );
    c.speed_log_mps = Some(7.0);
    c
}

/// The linear propagation against a Monte Carlo of the same tone errors (an independent
/// answer: the networks run on perturbed tones, no derivative taken), in the small-error
/// regime where the first order holds: variances within 15 % both ways.
#[test]
fn the_propagated_covariance_is_the_spread_of_perturbed_tones() {
    let cfg = CoreConfig::default();
    let est = Estimator::embedded(&cfg).unwrap();
    let mut scratch = est.scratch();
    let c = ship_tones(0.005);
    let f = Features::Clfrt(c.clone());
    let cov = measurement_cov(Method::Clfrt, &f, &est, &mut scratch, 7000.0).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let n = 4000;
    let sd = 0.005 / 1.645;
    let mut draws = Vec::with_capacity(n);
    for _ in 0..n {
        let mut p = c.clone();
        for t in &mut p.tones {
            let (g, q): (f64, f64) = (rng.sample(StandardNormal), rng.sample(StandardNormal));
            t.gain *= (sd * g).exp();
            t.phase_rad += sd * q;
        }
        let r = crate::fdi::raw::read_residual(
            Method::Clfrt,
            &Features::Clfrt(p),
            &est,
            &mut scratch,
            7.0,
            7000.0,
        )
        .unwrap();
        draws.push(r);
    }
    let var = cov.variances();
    for j in 0..P {
        let m = draws.iter().map(|r| r[j]).sum::<f64>() / n as f64;
        let v = draws.iter().map(|r| (r[j] - m).powi(2)).sum::<f64>() / (n - 1) as f64;
        let ratio = var[j] / v;
        assert!(
            (0.85..1.15).contains(&ratio),
            "component {j}: propagated {} vs Monte Carlo {v}",
            var[j]
        );
    }
    // Wider intervals, a wider covariance (quadratically, to first order).
    let wide = measurement_cov(
        Method::Clfrt,
        &Features::Clfrt(ship_tones(0.01)),
        &est,
        &mut scratch,
        7000.0,
    )
    .unwrap();
    for (j, (w, v)) in wide.variances().iter().zip(var).enumerate() {
        let k = w / v;
        assert!((3.5..4.5).contains(&k), "component {j}: {k}");
    }
    // HBT carries no intervals of its own.
    assert!(measurement_cov(
        Method::Hbt,
        &Features::Hbt(sample::hbt()),
        &est,
        &mut scratch,
        7000.0
    )
    .is_none());
}

fn settings() -> RefSettings {
    let fdi = FdiConfig {
        commissioning_tests: 6,
        floor_speed_mps: 0.0,
        floor_displacement: 0.0,
        ..FdiConfig::default()
    };
    let limits = DecisionLimits::new(fdi.false_alarms_per_year, 3720.0, fdi.window_tests);
    RefSettings::new(
        &fdi,
        &ReferenceConfig::default(),
        &Calibration::default(),
        &limits,
    )
}

/// A CLFRT test's raw residual at 7 m/s, 7000 t in sea index `sea` with its own measurement
/// standard deviations `m` (diagonal).
fn raw(e: [f64; P], sea: f64, m: [f64; P]) -> Raw {
    Raw {
        speed_mps: e[0],
        displacement: e[1],
        speed_sigma_mps: 0.1,
        displacement_sigma: 0.01,
        speed_log_mps: 7.0,
        displacement_declared_t: 7000.0,
        excitation_scale: 1.0,
        sea_index: Some(sea),
        ln_gain: Some(e[2]),
        ln_damping: None,
        speed_slope: [0.0; P],
        loading_slope: [0.0; P],
        meas: Some(Cov::diag(m)),
        log_slope: 0.0,
    }
}

/// Six commissioning tests in a calm sea (index 0.2) whose own measurement error is `m`
/// times (1, 0.01, 0.01), scattering by half that.
fn commissioned(s: &RefSettings, m: &[f64]) -> MethodReference {
    let mut c = MethodReference::default();
    for (i, k) in m.iter().enumerate() {
        let w = (i as f64 * 1.7).sin();
        let e = [0.05 * w, 0.005 * (i as f64 * 2.3).cos(), -5.0 + 0.005 * w];
        c.add(
            s,
            &raw(e, 0.2, [k * 1.0, k * 0.01, k * 0.01].map(|v| v * 0.1)),
            i as u64,
        );
    }
    c
}

#[test]
fn the_typical_is_the_median_of_the_sea_and_the_excess_its_overshoot() {
    let s = settings();
    let c = commissioned(&s, &[1.0, 1.0, 2.0, 1.0, 30.0, 1.0]);
    let w = |sea: f64| c.samples[0].x(&s.envelope)[3] + (sea / 0.2f64).ln();
    // The median of six: 1 x, whatever the one spoiled test's 30 x.
    let t = typical(&c.samples, &s.envelope, w(0.2), [0.1, 0.01, 0.01]).unwrap();
    assert!(t.local);
    let want = [0.1, 0.001, 0.001];
    for (j, (v, w)) in t.var.iter().zip(want).enumerate() {
        assert!((v / (w * w) - 1.0).abs() < 1e-9, "{j}: {:?}", t.var);
    }
    // Carried to a rough sea (no learned test there) by its design spreads, not local.
    let rough = typical(&c.samples, &s.envelope, w(2.0), [0.3, 0.03, 0.03]).unwrap();
    assert!(!rough.local);
    assert!((rough.var[0] / 0.3f64.powi(2) - 1.0).abs() < 1e-9);
    // The excess: per component, what the test's own variance has beyond the typical.
    let e = excess(Some(Cov::diag([0.5, 0.0005, 0.001])), Some(t));
    assert!((e.at(0, 0) - (0.25 - 0.01)).abs() < 1e-12);
    assert!((e.at(1, 1) - 0.0).abs() < 1e-15);
    assert!((e.at(2, 2) - 0.0).abs() < 1e-15);
    assert_eq!(e.at(0, 1), 0.0);
    assert_eq!(excess(None, Some(t)), Cov::default());
    assert_eq!(excess(Some(Cov::diag([1.0; P])), None), Cov::default());
}

/// Against the vessel's reference a test whose tones a wave spoiled is read with its own
/// interval: a speed residual far out, its own error 20 times the typical,
/// is an ordinary test; the same residual from a clean test is far out. Switched off
/// (own noise off), the spoiled one is far out too.
#[test]
fn a_spoiled_test_is_read_with_its_own_interval() {
    let s = settings();
    let c = commissioned(&s, &[1.0; 6]);
    let clean = raw([1.5, 0.0, -5.0], 0.2, [0.1, 0.001, 0.001]);
    let spoiled = Raw {
        meas: Some(Cov::diag([2.0, 0.001, 0.001])),
        log_slope: 0.0,
        ..clean
    };
    let chi2 = |s: &RefSettings, r: &Raw| {
        let (b, m) = c.measure(s, r);
        assert!(matches!(b, crate::fdi::measured::Basis::Vessel(_)));
        let z = m.whitened().unwrap();
        (z.iter().map(|v| v * v).sum::<f64>(), m.noise_ratio)
    };
    let (q_clean, n_clean) = chi2(&s, &clean);
    let (q_spoiled, n_spoiled) = chi2(&s, &spoiled);
    // Over the alert limit (15.4 at 3 dof, six tests' Hotelling tail taken), and under 1.
    assert!(q_clean > 18.0, "{q_clean}");
    assert!(q_spoiled < 1.0, "{q_spoiled}");
    assert_eq!(n_clean, 1.0);
    assert!(n_spoiled > 2.0, "{n_spoiled}");
    let off = RefSettings {
        own_noise: false,
        ..s
    };
    let (q_off, n_off) = chi2(&off, &spoiled);
    assert!((q_off - q_clean).abs() < 1e-9 * q_clean && n_off == 1.0);
}
