use super::*;
use crate::fdi::changepoint;
use crate::fdi::config::{Calibration, FdiConfig, ReferenceConfig};
use crate::fdi::limits::DecisionLimits;
use crate::fdi::measured::calibration;
use crate::fdi::stats::dot;

fn settings(k: u32) -> Settings {
    let fdi = FdiConfig {
        commissioning_tests: k,
        floor_speed_mps: 0.0,
        floor_displacement: 0.0,
        ..FdiConfig::default()
    };
    let limits = DecisionLimits::new(fdi.false_alarms_per_year, 3720.0, fdi.window_tests);
    // The slope priors these tests' numbers are drawn for, not the shipped models' measured
    // ones: a vessel whose offset of e_u may move by half a change of speed.
    let cal = Calibration {
        commissioning_spread_speed_mps: 1.0,
        commissioning_spread_displacement: 0.1,
        slope_speed: [0.5, 0.03],
        slope_speed_gain: 0.017,
        ..Calibration::default()
    };
    Settings::new(&fdi, &ReferenceConfig::default(), &cal, &limits)
}

/// `c` with its correlations times `k`, the variances kept (the prior at one point, by hand).
fn shrunk(c: Cov, k: f64) -> Cov {
    Cov(std::array::from_fn(|i| {
        std::array::from_fn(|j| if i == j { c.at(i, j) } else { k * c.at(i, j) })
    }))
}

fn raw_at(e_u: f64, e_d: f64, u: f64, d: f64) -> Raw {
    Raw {
        speed_mps: e_u,
        displacement: e_d,
        speed_sigma_mps: 0.05,
        displacement_sigma: 0.002,
        speed_log_mps: u,
        displacement_declared_t: d,
        excitation_scale: 1.0,
        sea_index: None,
        // A gain whose scatter is its own (not a linear function of the others'), about the
        // displacement's size.
        ln_gain: Some(-5.0 + 0.002 * (37.0 * e_u + 91.0 * e_d).sin()),
        ln_damping: None,
        speed_slope: [0.0; 3],
        loading_slope: [0.0; 3],
        meas: None,
        log_slope: 0.0,
    }
}

fn raw(e_u: f64, e_d: f64) -> Raw {
    raw_at(e_u, e_d, 7.0, 7000.0)
}

const SAMPLE: [(f64, f64); 5] = [
    (1.0, -0.20),
    (1.2, -0.22),
    (0.8, -0.18),
    (1.1, -0.20),
    (0.9, -0.21),
];

fn commissioned(s: &Settings) -> MethodReference {
    let mut c = MethodReference::default();
    for (u, d) in SAMPLE {
        c.add(s, &raw(u, d), 0);
    }
    assert_eq!(c.phase, Phase::Learning);
    c
}

#[test]
fn the_reference_is_the_sample_mean_and_covariance() {
    let s = settings(5);
    let mut c = MethodReference::default();
    for (i, (u, d)) in SAMPLE.iter().enumerate() {
        let (b, _) = c.measure(&s, &raw(*u, *d));
        assert!(matches!(b, Basis::Commissioning { done, of: 5 } if done == i as u32));
        let want = if i == 4 {
            Added::Completed
        } else {
            Added::Sample
        };
        assert_eq!(c.add(&s, &raw(*u, *d), 0), want);
    }
    let r = c.reference.unwrap();
    // Two-pass sample moments (n - 1), computed here independently.
    let n = SAMPLE.len() as f64;
    let mu = SAMPLE
        .iter()
        .fold((0.0, 0.0), |a, x| (a.0 + x.0 / n, a.1 + x.1 / n));
    let cov = |f: &dyn Fn(&(f64, f64)) -> f64| SAMPLE.iter().map(f).sum::<f64>() / (n - 1.0);
    let sxx = cov(&|x| (x.0 - mu.0).powi(2));
    let sxy = cov(&|x| (x.0 - mu.0) * (x.1 - mu.1));
    let syy = cov(&|x| (x.1 - mu.1).powi(2));
    assert!((r.speed_offset_mps - mu.0).abs() < 1e-12);
    assert!((r.displacement_offset - mu.1).abs() < 1e-12);
    assert!((r.covariance.at(0, 0) - sxx).abs() < 1e-9 * sxx);
    assert!((r.covariance.at(0, 1) - sxy).abs() < 1e-9 * sxy.abs());
    assert!((r.covariance.at(1, 1) - syy).abs() < 1e-9 * syy);
    assert!((r.dof - 4.0).abs() < 1e-9);
    assert!(
        r.covariance.correlation(0, 1) < -0.5,
        "the sample is anti-correlated"
    );
    assert_eq!(
        c.describe(&s),
        "commissioned (5 tests, 5 learned, 7.0-7.0 m/s)"
    );
}

#[test]
fn the_test_covariance_carries_the_sea_the_offset_error_the_k_factor_and_the_floors() {
    let s = Settings {
        floor_speed_mps: 0.05,
        floor_displacement: 0.004,
        ..settings(5)
    };
    let c = commissioned(&s);
    let r = c.reference.unwrap();
    let (b, m) = c.measure(&s, &raw(1.3, -0.2));
    // The correlations under the prior: nu / (nu + P + 2) = 4 / 9 of the sample's.
    let k = 4.0 / 9.0;
    assert_eq!(b.name(), "commissioned");
    assert!((m.r[0] - (1.3 - r.speed_offset_mps)).abs() < 1e-12);
    // The mean's error S / 5 on top of S, and the floors; Hotelling's tail with nu = 4 is
    // the calibration's business (`Measured::whitened`), kappa only sizes commissioning.
    assert_eq!(kappa(5.0), 5.0);
    assert_eq!(kappa(8.0), 2.0);
    let want = |v: f64, f: f64| v * 1.2 + f * f;
    let rc = |i, j| r.covariance.at(i, j);
    assert!((m.cov.at(0, 0) - want(rc(0, 0), 0.05)).abs() < 1e-9 * m.cov.at(0, 0));
    assert!((m.cov.at(0, 1) - 1.2 * k * rc(0, 1)).abs() < 1e-9 * m.cov.at(0, 1).abs());
    assert!((m.cov.at(1, 1) - want(rc(1, 1), 0.004)).abs() < 1e-9 * m.cov.at(1, 1));
    assert!((m.cov.at(2, 2) - want(rc(2, 2), 0.004)).abs() < 1e-9 * m.cov.at(2, 2));
    // The floors add degrees of freedom along the residual: nu / (the learned share).
    let learned = shrunk(r.covariance.times(1.2), k);
    // The calibration's dof: the shape's own 4 (the prior adds none).
    assert_eq!((m.dof, m.dim), (4.0, 3));
    for (a, b) in m.learned.0.iter().flatten().zip(learned.0.iter().flatten()) {
        assert!((a - b).abs() < 1e-12 * b.abs(), "{a} vs {b}");
    }
    // By the explicit inverse (nalgebra's LU).
    let inv = nalgebra::Matrix3::from_fn(|i, j| m.cov.at(i, j))
        .try_inverse()
        .unwrap();
    let y: [f64; 3] = (inv * nalgebra::Vector3::from(m.r)).into();
    let t = dot(m.r, y);
    let ya = learned.form(y, y);
    // The learned share at its 95 % upper bound (nu = 4 taken as 4.5): m = 4.5 / chi2_4.5
    // at 5 % (from below), share = m a / (T + (m - 1) a).
    assert!(m.bounded);
    let mb = 4.5 / crate::fdi::stats::chi2_isf(0.95, 4.5);
    assert!(mb > 3.5 && mb < 5.5, "{mb}");
    let want_dof = (4.0 * (t + (mb - 1.0) * ya) / (mb * ya)).max(4.0);
    assert!((m.effective_dof() - want_dof).abs() < 1e-9 * want_dof);
    assert!(m.effective_dof() < 4.0 * t / ya);
    // The shared share: the mean's error over the whole, largest where the floors weigh
    // least; without floors it is 1 / (K + 1) in every direction.
    let c0 = commissioned(&settings(5));
    let (_, m0) = c0.measure(&settings(5), &raw(1.3, -0.2));
    assert!(
        (m0.offset_var.unwrap() - 1.0 / 6.0).abs() < 1e-7,
        "{:?}",
        m0.offset_var
    );
    assert!(m.offset_var.unwrap() < 1.0 / 6.0 && m.offset_var.unwrap() > 0.0);
    // A sea with three times the design spread of the speed: its variance x9, the
    // covariance x3, the displacement's untouched.
    let mut rough = raw(1.3, -0.2);
    rough.speed_sigma_mps = 0.15;
    let (_, m3) = c0.measure(&settings(5), &rough);
    let r0 = c0.reference.unwrap();
    // The scatter is carried (x9, x3), the offset's error is not (it is the sample's).
    let (a, b, c) = (m3.cov, m0.cov, shrunk(r0.covariance, k));
    assert!((a.at(0, 0) - b.at(0, 0) - 8.0 * c.at(0, 0)).abs() < 1e-9 * a.at(0, 0));
    assert!((a.at(0, 1) - b.at(0, 1) - 2.0 * c.at(0, 1)).abs() < 1e-9 * a.at(0, 1).abs());
    assert!((a.at(1, 1) - b.at(1, 1)).abs() < 1e-12 * b.at(1, 1));
}

#[test]
fn commissioning_is_wide_and_ends_as_soon_as_the_sample_resolves_its_faults() {
    let s = Settings {
        floor_speed_mps: 0.05,
        floor_displacement: 0.004,
        ..settings(8)
    };
    let mut c = MethodReference::default();
    let (_, m) = c.measure(&s, &raw(1.0, -0.2));
    assert_eq!(
        (m.cov, m.offset_var, m.dim),
        (Cov::diag([1.0, 0.1, 1.0]), None, 2)
    );
    // A scatter of 0.015 m/s and 0.1 %, well under the floors: six tests resolve 0.5 m/s
    // and 10 % (the least the change-point test needs).
    let tight = [0.0, 0.02, -0.02, 0.01, -0.01, 0.0, 0.015, -0.015];
    for (i, w) in tight.iter().enumerate() {
        let a = c.add(&s, &raw(1.0 + w, -0.2 + w / 20.0), 0);
        if i == 5 {
            assert_eq!(a, Added::Completed);
            break;
        }
        assert_eq!(a, Added::Sample);
    }
    assert_eq!(c.tests, 6);
    // A scatter of 0.3 m/s: the speed-log bias of 0.5 m/s is not resolved: all 8 tests.
    let mut wide = MethodReference::default();
    for (i, w) in tight.iter().enumerate() {
        let a = wide.add(&s, &raw(1.0 + 15.0 * w, -0.2 + w / 20.0), 0);
        assert_eq!(a == Added::Completed, i == 7, "{i}: {a:?}");
    }
}

/// A method whose own tests do not resolve the faults ends its commissioning at six tests
/// once the vessel's other method is commissioned and resolves them; not before six, not
/// while the other gathers, not when the other ended at K unresolved.
#[test]
fn a_method_ends_commissioning_on_the_other_that_resolves_the_faults() {
    let s = Settings {
        floor_speed_mps: 0.05,
        floor_displacement: 0.004,
        ..settings(8)
    };
    let tight = [0.0, 0.02, -0.02, 0.01, -0.01, 0.0, 0.015, -0.015];
    let sample = |k: f64| tight.map(|w| raw(1.0 + k * w, -0.2 + w / 20.0));
    let (quiet, noisy) = (sample(1.0), sample(15.0));
    let mut c = [MethodReference::default(), MethodReference::default()];
    for t in &noisy[..5] {
        c[1].add(&s, t, 0);
    }
    for t in &quiet[..6] {
        c[0].add(&s, t, 0);
    }
    assert_eq!(c[0].phase, Phase::Learning);
    assert!(!complete_on_other(&mut c, 1, &s), "five tests");
    assert_eq!(c[1].add(&s, &noisy[5], 0), Added::Sample);
    assert!(complete_on_other(&mut c, 1, &s));
    assert_eq!((c[1].phase, c[1].tests), (Phase::Learning, 6));
    assert!(c[1].reference.is_some());
    // The other still gathering, or ended at K unresolved: no early end.
    let mut d = [MethodReference::default(), MethodReference::default()];
    for t in &noisy[..6] {
        d[1].add(&s, t, 0);
    }
    assert!(!complete_on_other(&mut d, 1, &s), "the other gathering");
    for t in &noisy {
        d[0].add(&s, t, 0);
    }
    assert_eq!((d[0].phase, d[0].tests), (Phase::Learning, 8));
    assert!(!complete_on_other(&mut d, 1, &s), "the other unresolved");
    assert_eq!(d[1].phase, Phase::Commissioning);
}

/// With the class's prior (its centre this vessel's own scatter, 30 dof a component) six
/// tests resolve the faults eight do not resolve alone; a vessel three times as noisy (sd)
/// is outside its class: the scatter test drops the prior, and commissioning runs to K.
#[test]
fn the_class_prior_ends_commissioning_early_unless_the_vessel_is_outside_its_class() {
    let base = Settings {
        floor_speed_mps: 0.05,
        floor_displacement: 0.004,
        ..settings(8)
    };
    let unit = [0.0, 1.2, -1.2, 0.6, -0.6, 0.9, -0.9, 0.3];
    let other = [0.9, -0.3, 0.6, -1.2, 0.0, 1.0, -0.5, 0.2];
    let test = |k: f64, i: usize| raw(1.0 + k * 0.06 * unit[i], -0.2 + k * 0.004 * other[i]);
    let completes = |s: &Settings, k: f64| {
        let mut c = MethodReference::default();
        let at = (0..8).position(|i| c.add(s, &test(k, i), 0) == Added::Completed);
        (at, c)
    };
    let (alone, own) = completes(&base, 1.0);
    assert_eq!(alone, Some(7));
    let psi = own.shape.unwrap().cov;
    let class = crate::fdi::prior::ClassScatter {
        calm: psi.0,
        moderate: psi.0,
        dof: [30.0; 3],
    };
    let s = Settings {
        prior: Some(class),
        ..base
    };
    let (early, c) = completes(&s, 1.0);
    assert_eq!(early, Some(5));
    let r = c.reference.unwrap();
    assert!(r.class_prior, "{r:?}");
    assert!(
        (0.5..2.0).contains(&r.class_scatter_ratio.unwrap()),
        "{r:?}"
    );
    let (noisy_at, noisy) = completes(&s, 3.0);
    assert_eq!(noisy_at, Some(7));
    let r = noisy.reference.unwrap();
    assert!(
        !r.class_prior && r.class_scatter_ratio.unwrap() > 4.0,
        "{r:?}"
    );
    assert!(
        noisy.describe(&s).contains("outside its class"),
        "{}",
        noisy.describe(&s)
    );
}

#[test]
fn a_change_inside_the_commissioning_sample_sets_no_reference() {
    let s = settings(8);
    let mut c = MethodReference::default();
    let scatter = [0.0, 0.02, -0.02, 0.01, -0.01, 0.0];
    for (i, w) in scatter.iter().enumerate() {
        // +12 % displacement from the fourth test on.
        let shift = if i >= 3 { 0.12 } else { 0.0 };
        let a = c.add(&s, &raw(1.0 + 4.0 * w, -0.2 + w / 10.0 + shift), i as u64);
        assert_eq!(a, Added::Sample);
    }
    // The vessel's test (the other method has no sample) splits this one at its fourth.
    let mut both = [c, MethodReference::default()];
    let change = changepoint::check(&mut both, 0, &s).unwrap();
    assert_eq!(change.splits, [Some(3), None]);
    let [mut c, _] = both;
    assert!(c.reference.is_none());
    assert_eq!(c.state(&s), "inconsistent");
    assert!(c
        .describe(&s)
        .starts_with("commissioning inconsistent: a change at test 4"));
    let (b, m) = c.measure(&s, &raw(1.0, -0.2));
    assert_eq!(b.name(), "commissioning_inconsistent");
    assert_eq!(m.offset_var, None);
    // Nothing more is gathered until commissioning starts again.
    assert_eq!(c.add(&s, &raw(1.0, -0.2), 0), Added::Nothing);
    c.restart();
    assert!(c.in_progress(&s));
    assert_eq!(c.describe(&s), "commissioning 0 of at most 8");
}

/// Two methods in turn: the change is judged in both samples when the first completes (the
/// other's partial sample with it), and a method commissioned before the other began is
/// left alone.
#[test]
fn the_change_is_the_vessels_in_both_samples_that_overlap_in_time() {
    // Faults no sample resolves: every method's sample is all 8 tests.
    let s = Settings {
        resolve_speed_mps: 1e-9,
        resolve_displacement: 1e-9,
        ..settings(8)
    };
    let scatter = [0.0, 0.02, -0.02, 0.01, -0.01, 0.0, 0.015, -0.015];
    let run = |c: &mut MethodReference, m: u64, from: u64, shift_at: u64| -> Added {
        let mut last = Added::Nothing;
        for (i, w) in scatter.iter().enumerate() {
            let order = from + 2 * i as u64 + m;
            let shift = if order >= shift_at { 0.12 } else { 0.0 };
            last = c.add(&s, &raw(1.0 + 4.0 * w, -0.2 + w / 10.0 + shift), order);
        }
        last
    };
    // In turn from the vessel's test 0, +12 % from its test 6: method 0's fourth test,
    // method 1's fourth.
    let mut both: [MethodReference; 2] = Default::default();
    assert_eq!(run(&mut both[1], 1, 0, 6), Added::Completed);
    assert_eq!(run(&mut both[0], 0, 0, 6), Added::Completed);
    let change = changepoint::check(&mut both, 0, &s).unwrap();
    assert_eq!(change.splits, [Some(3), Some(3)]);
    assert!(both.iter().all(|c| c.state(&s) == "inconsistent"));
    // Method 0 commissioned healthy before method 1 began: only method 1 is judged.
    let mut both: [MethodReference; 2] = Default::default();
    assert_eq!(run(&mut both[0], 0, 0, u64::MAX), Added::Completed);
    assert_eq!(run(&mut both[1], 1, 100, 106), Added::Completed);
    let change = changepoint::check(&mut both, 1, &s).unwrap();
    assert_eq!(change.splits, [None, Some(3)]);
    assert_eq!(both[0].state(&s), "commissioned");
}

#[test]
fn a_new_operating_point_is_predicted_wider_then_learned() {
    let s = settings(5);
    let mut c = commissioned(&s);
    let at_home = c.measure(&s, &raw(1.0, -0.2)).1;
    // 1.5 m/s faster, and the offset of e_u has moved by -0.75 m/s there (the estimate
    // follows half the speed change): predicted, within its wider interval.
    let (b, m) = c.measure(&s, &raw_at(0.25, -0.2, 8.5, 7000.0));
    assert_eq!(b.name(), "predicted");
    assert!(
        m.cov.at(0, 0) > 10.0 * at_home.cov.at(0, 0),
        "{} vs {}",
        m.cov.at(0, 0),
        at_home.cov.at(0, 0)
    );
    let z = m.cov.whiten(m.r).unwrap();
    assert!(dot(z, z) < 9.0, "{z:?}");
    assert!(m.offset_var.unwrap() > 0.9);
    // Only the offset is new at a new speed at the learned loading: the scatter's shape, and
    // the dof its calibration rests on, are the vessel's, as at home.
    assert_eq!((m.dof, m.bounded), (at_home.dof, at_home.bounded));
    assert!(at_home.bounded);
    // At a new declared loading the prediction rests on the slope priors: few dof (the
    // tests' kernel weight there less one), the share as estimated.
    let (b, lighter) = c.measure(&s, &raw_at(1.0, -0.2, 7.0, 5600.0));
    assert_eq!(b.name(), "predicted");
    assert!(!lighter.bounded);
    assert!(
        lighter.dof < 4.0 && lighter.dof < at_home.dof,
        "{}",
        lighter.dof
    );
    // Learned: four tests there and the point is the vessel's own.
    for w in [0.0, 0.02, -0.02, 0.01] {
        assert_eq!(
            c.add(&s, &raw_at(0.25 + w, -0.2, 8.5, 7000.0), 0),
            Added::Learned
        );
    }
    let (b, m) = c.measure(&s, &raw_at(0.25, -0.2, 8.5, 7000.0));
    assert_eq!(b.name(), "commissioned");
    assert!(m.r[0].abs() < 0.1, "{:?}", m.r);
    assert!(
        m.cov.at(0, 0) < 4.0 * at_home.cov.at(0, 0),
        "{} vs {}",
        m.cov.at(0, 0),
        at_home.cov.at(0, 0)
    );
    // A +12 % displacement there now crosses the displacement look's single-test limit (23.2)
    // on its own.
    let (_, f) = c.measure(&s, &raw_at(0.25, -0.08, 8.5, 7000.0));
    let z = f.cov.whiten(f.r).unwrap();
    assert!(dot(z, z) > 27.0, "{z:?}");
    // The declared loading is an operating point too: 20 % lighter is predicted.
    let (b, _) = c.measure(&s, &raw_at(0.25, -0.2, 8.5, 5600.0));
    assert_eq!(b.name(), "predicted");
}

#[test]
fn memory_keeps_the_newest_of_the_fullest_bin() {
    let s = Settings {
        memory: 8,
        ..settings(5)
    };
    let mut c = commissioned(&s);
    for k in 0..6 {
        c.add(&s, &raw_at(1.0, -0.2, 9.0, 7000.0 + k as f64), 0);
    }
    assert_eq!(c.samples.len(), 8);
    // The 7 m/s bin (5 tests) gave way until both held 4.
    let at = |u: f64| c.samples.iter().filter(|x| x.speed_mps == u).count();
    assert_eq!((at(7.0), at(9.0)), (4, 4));
    assert_eq!(c.samples.last().unwrap().displacement_t, 7005.0);
}

#[test]
fn without_commissioning_the_design_reference_serves() {
    let s = settings(0);
    let mut c = MethodReference::default();
    assert_eq!(c.add(&s, &raw(1.0, 0.0), 0), Added::Nothing);
    let (b, m) = c.measure(&s, &raw(1.0, -0.2));
    assert_eq!(b, Basis::Design);
    assert_eq!(
        (m.r, m.cov, m.offset_var),
        ([1.0, -0.2, 0.0], Cov::diag([0.05, 0.002, 1.0]), Some(0.0))
    );
}

#[test]
fn the_calibration_maps_hotellings_tail_onto_the_chi_squares() {
    // T^2(2, 6) at 5 % is 13.89 (2 x 6 / 5 x F(2, 5) = 2.4 x 5.786); chi2_2 at 5 % is 5.991.
    let t = 2.4 * 5.786;
    let k = calibration(t, 6.0, 2);
    assert!((k * k * t - 5.991).abs() < 0.01, "{}", k * k * t);
    // p = 3: T^2(3, 10) at 5 % is 3.75 x F(3, 8) = 3.75 x 4.0662; chi2_3 at 5 % is 7.8147.
    let t3 = 3.75 * 4.0662;
    let k3 = calibration(t3, 10.0, 3);
    assert!((k3 * k3 * t3 - 7.8147).abs() < 0.01, "{}", k3 * k3 * t3);
    // Known covariance: unchanged; many dof: nearly so.
    assert_eq!(calibration(30.0, f64::INFINITY, 3), 1.0);
    assert!((calibration(30.0, 1e6, 3) - 1.0).abs() < 1e-4);
    let m = Measured {
        r: [0.3, 0.0, 0.0],
        cov: Cov::diag([0.1, 0.01, 1.0]),
        offset_var: Some(0.0),
        dof: 6.0,
        learned: Cov::diag([0.1, 0.01, 0.0]),
        dim: 2,
        bounded: false,
        noise_ratio: 1.0,
    };
    let z = m.whitened().unwrap();
    assert!((z[0] * z[0] - 5.0 * (1.0 + 9.0 / 6.0f64).ln()).abs() < 1e-12);
}

/// Eight commissioning tests whose gain is exactly a linear function of their displacement
/// residual (a plane in three components, as a small sample can fall by chance): without the
/// prior on the correlations a test off that plane by one spread would stand thousands of
/// sigmas out; with it, a few.
#[test]
fn a_sample_on_a_plane_is_not_taken_for_a_law() {
    let s = settings(8);
    let pts = [
        (1.0, -0.20),
        (1.2, -0.22),
        (0.8, -0.18),
        (1.1, -0.20),
        (0.9, -0.21),
        (1.05, -0.19),
        (0.95, -0.215),
        (1.15, -0.185),
    ];
    let on_plane = |u: f64, d: f64| Raw {
        ln_gain: Some(-5.0 + (d + 0.2)),
        ln_damping: None,
        ..raw(u, d)
    };
    let mut c = MethodReference::default();
    for (u, d) in pts {
        c.add(&s, &on_plane(u, d), 0);
    }
    assert_eq!(c.phase, Phase::Learning);
    let sd = c.reference.unwrap().covariance.at(1, 1).sqrt();
    // One spread up in e_D, one down in e_b: two spreads off the plane.
    let off = Raw {
        ln_gain: Some(-5.0 - sd),
        ln_damping: None,
        ..raw(1.0, -0.2 + sd)
    };
    let (_, m) = c.measure(&s, &off);
    let t = dot(m.r, m.cov.solve(m.r).unwrap());
    // The same residual against the sample's own covariance (x 9 / 8, the mean's error), by
    // the explicit inverse: the plane taken for a law.
    let r = c.reference.unwrap().covariance.times(1.125);
    let raw_cov = nalgebra::Matrix3::from_fn(|i, j| r.at(i, j));
    let t_law = raw_cov
        .try_inverse()
        .map(|inv| {
            let v = nalgebra::Vector3::from(m.r);
            (v.transpose() * inv * v)[(0, 0)]
        })
        .unwrap_or(f64::INFINITY);
    assert!(t_law > 1e4, "{t_law}");
    assert!(t > 2.0 && t < 30.0, "{t}");
}

/// A change after each method's first commissioning test: one test against the others'
/// scatter from 6 dof is no proof at commissioning's end (Hotelling's tail is heavy there);
/// the confirmation proves it as each method learns tests after it, their dof added, and
/// the references set from the changed samples are dropped.
#[test]
fn a_change_commissioning_could_not_prove_is_proven_by_the_tests_after_it() {
    let s = settings(8);
    // The vessel's tests in turn (method `order % 2`), +6 % displacement from its third
    // test (each method's second) on: six standard deviations of each residual's scatter.
    let test = |order: u64| {
        let x = order as f64;
        let shift = if order >= 2 { 0.06 } else { 0.0 };
        raw(
            1.0 + 0.01 * (2.3 * x).sin(),
            -0.2 + 0.01 * (1.7 * x).cos() + shift,
        )
    };
    let mut both: [MethodReference; 2] = Default::default();
    let mut completed = Vec::new();
    let mut found = None;
    for order in 0..40u64 {
        let m = (order % 2) as usize;
        match both[m].add(&s, &test(order), order) {
            Added::Completed => {
                assert_eq!(changepoint::check(&mut both, m, &s), None, "{order}");
                completed.push(order);
            }
            Added::Learned => {
                if let Some(c) = changepoint::confirm(&mut both, m, &s) {
                    found = Some((order, c));
                    break;
                }
            }
            a => assert_eq!(a, Added::Sample, "{order}"),
        }
    }
    // Both commissioned on the changed samples, 8 tests each.
    assert_eq!(completed, [14, 15]);
    // Proven once each method has learned 7 tests more (the vessel's 30th test; the
    // confirmation runs until each holds 16).
    let (order, change) = found.expect("the confirmation finds the change");
    assert_eq!(order, 29);
    assert_eq!(change.splits, [Some(1), Some(1)]);
    for c in &both {
        assert_eq!(c.state(&s), "inconsistent");
        assert!(c
            .describe(&s)
            .starts_with("commissioning inconsistent: a change at test 2"));
    }
    // A healthy vessel's same tests: nothing, to the confirmation's end.
    let mut both: [MethodReference; 2] = Default::default();
    for order in 0..40u64 {
        let m = (order % 2) as usize;
        let mut t = test(order);
        t.displacement = -0.2 + 0.01 * (1.7 * order as f64).cos();
        match both[m].add(&s, &t, order) {
            Added::Completed => assert_eq!(changepoint::check(&mut both, m, &s), None),
            Added::Learned => assert_eq!(changepoint::confirm(&mut both, m, &s), None),
            _ => {}
        }
    }
    assert!(both.iter().all(|c| c.state(&s) == "commissioned"));
}

/// Two outliers at the end of a healthy method's confirmation (its last two learned tests
/// read the speed 0.5 m/s high, ten floors): no change inside its commissioning, so not
/// inconsistent; the same step from its fourth commissioning test is (at commissioning's
/// end).
#[test]
fn outliers_after_commissioning_are_no_change_inside_it() {
    let s = settings(8);
    let run = |from: u64, to: u64| {
        let mut both: [MethodReference; 2] = Default::default();
        let mut found = None;
        for order in 0..40u64 {
            let m = (order % 2) as usize;
            let x = order as f64;
            let step = if m == 0 && (from..=to).contains(&order) {
                0.5
            } else {
                0.0
            };
            let t = raw(
                1.0 + 0.01 * (2.3 * x).sin() + step,
                -0.2 + 0.01 * (1.7 * x).cos(),
            );
            match both[m].add(&s, &t, order) {
                Added::Completed => {
                    if let Some(c) = changepoint::check(&mut both, m, &s) {
                        found.get_or_insert(c);
                    }
                }
                Added::Learned => {
                    if let Some(c) = changepoint::confirm(&mut both, m, &s) {
                        found.get_or_insert(c);
                    }
                }
                _ => {}
            }
        }
        found
    };
    // Method 0's tests are the vessel's even ones: commissioned at 14, learning to 30.
    assert_eq!(run(28, 30), None);
    let c = run(6, 40).expect("a step from its fourth test is a change");
    assert_eq!(c.splits[0], Some(3));
}

/// The sea rising a state after commissioning, the offset moving with it by ten times the
/// scatter: another operating point, the reference's to learn, not a change inside the
/// commissioning (the confirmation takes the learned tests in the commissioning's sea).
#[test]
fn a_new_sea_after_commissioning_is_no_change_inside_it() {
    let s = settings(16);
    let calm = Calibration::default().sea_wave_yaw_deg[0];
    let mut both: [MethodReference; 2] = Default::default();
    for order in 0..80u64 {
        let m = (order % 2) as usize;
        let x = order as f64;
        let rough = both[m].phase == Phase::Learning;
        let mut t = raw(
            1.0 + 0.01 * (2.3 * x).sin() + if rough { 0.1 } else { 0.0 },
            -0.2 + 0.01 * (1.7 * x).cos(),
        );
        t.sea_index = Some(if rough { 4.0 * calm } else { calm });
        match both[m].add(&s, &t, order) {
            Added::Completed => assert_eq!(changepoint::check(&mut both, m, &s), None),
            Added::Learned => assert_eq!(changepoint::confirm(&mut both, m, &s), None, "{order}"),
            _ => {}
        }
    }
    assert!(both.iter().all(|c| c.state(&s) == "commissioned"));
}
