//! The reference's local fit and shape: by hand at one point and away from it, and across
//! two points whose offsets differ.

use super::*;

/// The settings of the unit tests here and in `changepoint`.
pub(in crate::fdi) fn st() -> Regression {
    Regression {
        bandwidth: [1.0, 0.1, 0.1, 0.5],
        slope_speed: [0.5, 0.03],
        slope_speed_gain: 0.03,
        slope_loading: [4.0, 0.3],
        slope_excitation: [3.0, 0.3],
        slope_sea: [0.3, 0.03],
        sea_calm_deg: 0.05,
    }
}

/// A test whose `e_b` moves against its `e_D` (as `b` with `1 / D`).
fn smp(e: [f64; 2], u: f64, d: f64) -> Sample {
    Sample {
        e: [e[0], e[1], -5.0 - 0.8 * e[1]],
        s: [0.1, 0.01, 0.01],
        speed_mps: u,
        displacement_t: d,
        excitation_scale: 1.0,
        sea_index: None,
        speed_slope: [0.0; 3],
        loading_slope: [0.0; 3],
        order: 0,
        meas: None,
        log_slope: 0.0,
    }
}

/// Five tests' `(e_u, e_D)` at one point, anti-correlated.
const FIVE: [(f64, f64); 5] = [
    (1.0, -0.20),
    (1.2, -0.22),
    (0.8, -0.18),
    (1.1, -0.20),
    (0.9, -0.21),
];

fn at(u: f64, d: f64) -> Point {
    Point {
        speed_mps: u,
        displacement_t: d,
        excitation_scale: 1.0,
        sea_index: None,
    }
}

#[test]
fn at_one_point_the_fit_is_the_sample_mean_and_the_shape_its_covariance() {
    let data = [
        (1.0, -0.20),
        (1.2, -0.22),
        (0.8, -0.18),
        (1.1, -0.20),
        (0.9, -0.21),
    ];
    let samples: Vec<Sample> = data
        .iter()
        .map(|&(a, b)| smp([a, b], 7.0, 7000.0))
        .collect();
    let sh = shape(&samples, &st()).unwrap();
    // Independent two-pass moments (n - 1), in design-spread units.
    let n = 5.0;
    let mu = data
        .iter()
        .fold((0.0, 0.0), |a, x| (a.0 + x.0 / n, a.1 + x.1 / n));
    let sxx = data.iter().map(|x| (x.0 - mu.0).powi(2)).sum::<f64>() / 4.0 / 0.01;
    let sxy = data
        .iter()
        .map(|x| (x.0 - mu.0) * (x.1 - mu.1))
        .sum::<f64>()
        / 4.0
        / 0.001;
    let syy = data.iter().map(|x| (x.1 - mu.1).powi(2)).sum::<f64>() / 4.0 / 1e-4;
    assert!((sh.dof - 4.0).abs() < 1e-9, "{}", sh.dof);
    assert!((sh.cov.at(0, 0) - sxx).abs() < 1e-9 * sxx);
    assert!((sh.cov.at(0, 1) - sxy).abs() < 1e-9 * sxy.abs());
    assert!((sh.cov.at(1, 1) - syy).abs() < 1e-9 * syy);
    let p = predict(&samples, &st(), &sh, &at(7.0, 7000.0)).unwrap();
    assert!((p.offset[0] - mu.0).abs() < 1e-12);
    assert!((p.offset[1] - mu.1).abs() < 1e-12);
    // The mean's variance: S / n in physical units.
    assert!((p.cov.at(0, 0) - sxx * 0.01 / n).abs() < 1e-9 * p.cov.at(0, 0));
    assert!((p.cov.at(1, 1) - syy * 1e-4 / n).abs() < 1e-9 * p.cov.at(1, 1));
    assert!((p.support - 5.0).abs() < 1e-12 && p.nearest == 0.0);
}

#[test]
fn a_second_point_is_fitted_at_its_own_offset_when_the_offset_moved_far() {
    // Eight tests at 10 m/s and two at 9 m/s, the displacement offset 0.23 lower there
    // (23 design spreads, 200 times the scatter: a hull whose estimate does not follow
    // the ship), the scatter about 0.001 at both. The fit at 9 m/s is the two tests' own mean (the data fix the
    // slope far better than its prior), and the shape is the scatter's, not the move's.
    let jitter = [0.0, 0.8, -0.6, 0.3, -1.0, 0.5, -0.2, 0.9];
    let mut samples: Vec<Sample> = jitter
        .iter()
        .map(|j| smp([-3.1 + 0.01 * j, 0.368 + 0.001 * j], 10.0, 7000.0))
        .collect();
    samples.push(smp([-2.13, 0.1375], 9.0, 7000.0));
    samples.push(smp([-2.12, 0.1355], 9.0, 7000.0));
    let sh = shape(&samples, &st()).unwrap();
    let p = predict(&samples, &st(), &sh, &at(9.0, 7000.0)).unwrap();
    assert!((p.offset[1] - 0.1365).abs() < 0.001, "{:?}", p.offset);
    // The shape in design units (s_D = 0.01): the scatter's (0.1)^2 order, not the
    // move's (23^2).
    assert!(sh.cov.at(1, 1) < 0.1, "{:?}", sh.cov);
}

#[test]
fn away_from_the_learned_point_the_interval_grows_by_the_kernel_and_the_slope_prior() {
    let samples: Vec<Sample> = FIVE
        .iter()
        .map(|&(a, b)| smp([a, b], 7.0, 7000.0))
        .collect();
    let sh = shape(&samples, &st()).unwrap();
    let du = 1.5;
    let p = predict(&samples, &st(), &sh, &at(7.0 + du, 7000.0)).unwrap();
    // By hand: all data at one distance d = 1.5 bandwidths, weight w = 1 / (1 + d^2);
    // intercept variance = 1 / W + du^2 tau^2 with W = n w / sigma^2.
    let w = 1.0 / (1.0 + du * du);
    for (j, (var, tau)) in [
        (sh.cov.at(0, 0) * 0.01, 0.5),
        (sh.cov.at(1, 1) * 1e-4, 0.03),
    ]
    .iter()
    .enumerate()
    {
        let want = var / (5.0 * w) + du * du * tau * tau;
        let got = [p.cov.at(0, 0), p.cov.at(1, 1)][j];
        assert!((got - want).abs() < 1e-9 * want, "{j}: {got} vs {want}");
    }
    // The offset is still the sample's (the prior slope is 0).
    assert!((p.offset[0] - 1.0).abs() < 1e-12);
    assert!((p.nearest - 1.5).abs() < 1e-12);
}

/// A relay sized down is another point: predicted from the designed relay's tests with
/// the slope prior's interval in `ln s`; once learned, each scale keeps its own offset.
#[test]
fn an_excitation_sized_down_is_another_operating_point() {
    let wob = [0.01, -0.01, 0.005, -0.005, 0.0];
    let mut samples: Vec<Sample> = wob
        .iter()
        .map(|w| smp([2.0 + w, -0.70 + w / 10.0], 9.5, 7000.0))
        .collect();
    let sh = shape(&samples, &st()).unwrap();
    let scaled = Point {
        excitation_scale: 0.83,
        sea_index: None,
        ..at(9.5, 7000.0)
    };
    let p = predict(&samples, &st(), &sh, &scaled).unwrap();
    // By hand: every test at g = ln 0.83 from the point, d = |g| / b_g.
    let g = 0.83f64.ln();
    let w = 1.0 / (1.0 + (g / 0.1).powi(2));
    let want = sh.cov.at(0, 0) * 0.01 / (5.0 * w) + (g * 3.0).powi(2);
    assert!(
        (p.cov.at(0, 0) - want).abs() < 1e-9 * want,
        "{} vs {want}",
        p.cov.at(0, 0)
    );
    assert!((p.offset[0] - 2.0).abs() < 1e-9, "{:?}", p.offset);
    // Tests at 0.83 read 0.4 m/s lower (the read-back's bias on a nonlinear hull).
    for w in wob {
        let mut t = smp([1.6 + w, -0.68 + w / 10.0], 9.5, 7000.0);
        t.excitation_scale = 0.83;
        samples.push(t);
    }
    let sh = shape(&samples, &st()).unwrap();
    // The shape is the scatter about each scale's offset, not the gap between them.
    assert!(sh.cov.at(0, 0) < 0.2, "{:?}", sh.cov);
    let lo = predict(&samples, &st(), &sh, &scaled).unwrap();
    let hi = predict(&samples, &st(), &sh, &at(9.5, 7000.0)).unwrap();
    assert!((lo.offset[0] - 1.6).abs() < 0.02, "{:?}", lo.offset);
    assert!((hi.offset[0] - 2.0).abs() < 0.02, "{:?}", hi.offset);
    assert!(lo.cov.at(0, 0).sqrt() < 0.02, "{}", lo.cov.at(0, 0).sqrt());
}

/// The local shape: the global one where every test is; where a second point scatters
/// ten times more, its own tests speak for it there, and hardly at the first point.
#[test]
fn the_local_shape_is_the_scatter_of_the_tests_near_the_point() {
    let wob = [0.01, -0.01, 0.005, -0.005, 0.0, 0.008, -0.008, 0.0];
    let mut samples: Vec<Sample> = wob
        .iter()
        .map(|w| smp([1.0 + w, -0.2 + w / 10.0], 7.0, 7000.0))
        .collect();
    let sh = shape(&samples, &st()).unwrap();
    let here = local_shape(&samples, &st(), &sh, &at(7.0, 7000.0));
    assert!(
        (here.cov.at(0, 0) / sh.cov.at(0, 0) - 1.0).abs() < 1e-9,
        "{here:?} vs {sh:?}"
    );
    assert!((here.cov.at(1, 1) / sh.cov.at(1, 1) - 1.0).abs() < 1e-9);
    assert!(
        (here.dof - sh.dof).abs() < 1e-9,
        "{} vs {}",
        here.dof,
        sh.dof
    );
    // Far away, with nothing near, the same shape (every weight alike).
    let far = local_shape(&samples, &st(), &sh, &at(12.0, 7000.0));
    assert!((far.cov.at(0, 0) / sh.cov.at(0, 0) - 1.0).abs() < 1e-9);
    // Eight tests at 4 m/s (3 bandwidths away) with ten times the scatter.
    for w in wob {
        samples.push(smp([0.5 + 10.0 * w, -0.1 + w], 4.0, 7000.0));
    }
    let sh = shape(&samples, &st()).unwrap();
    let there = local_shape(&samples, &st(), &sh, &at(4.0, 7000.0));
    let here = local_shape(&samples, &st(), &sh, &at(7.0, 7000.0));
    // By hand: kernel 1 at its own point, 1 / (1 + 9) = 0.1 from the other; the
    // residuals are each point's own about its mean (0.01 x 0.1 kernel mixes in).
    let var = |k: f64| wob.iter().map(|w| (k * w).powi(2)).sum::<f64>() / 0.01;
    let want_there = (var(10.0) + 0.1 * var(1.0)) / (1.1 * 7.0);
    let want_here = (var(1.0) + 0.1 * var(10.0)) / (1.1 * 7.0);
    assert!(
        (there.cov.at(0, 0) / want_there - 1.0).abs() < 0.05,
        "{there:?} vs {want_there}"
    );
    assert!(
        (here.cov.at(0, 0) / want_here - 1.0).abs() < 0.05,
        "{here:?} vs {want_here}"
    );
    // Each point keeps most of its own scatter (9 times apart, by the sums above).
    assert!(
        there.cov.at(0, 0) > 5.0 * here.cov.at(0, 0),
        "{there:?} {here:?}"
    );
}

#[test]
fn two_learned_speeds_give_the_slope_between_them() {
    // e_u = 1 - (u - 7) exactly (the estimate does not follow the speed), e_D flat,
    // with a small scatter.
    let mut samples = Vec::new();
    for (k, u) in [7.0, 7.0, 7.0, 7.0, 5.5, 5.5, 5.5, 5.5].iter().enumerate() {
        let wob = [0.01, -0.01, 0.005, -0.005][k % 4];
        samples.push(smp([1.0 - (u - 7.0) + wob, -0.2 + wob / 10.0], *u, 7000.0));
    }
    let sh = shape(&samples, &st()).unwrap();
    let p = predict(&samples, &st(), &sh, &at(6.25, 7000.0)).unwrap();
    assert!((p.offset[0] - 1.75).abs() < 0.01, "{:?}", p.offset);
    assert!((p.offset[1] + 0.2).abs() < 0.002);
    // Between two learned points the interval is far narrower than the prior's alone
    // (0.75 m/s x 0.5 = 0.375 m/s).
    assert!(p.cov.at(0, 0).sqrt() < 0.05, "{}", p.cov.at(0, 0).sqrt());
}

/// The slope prior's mean is the similarity law's slope of the tests near the point: a ship
/// commissioned at 7 m/s whose tests say `e_D` moves by +0.2 per m/s of its own speed is
/// predicted 0.2 higher at 8 m/s (by hand: the intercept moves by the slope's prior mean times
/// the distance, the tests at one point saying nothing of the slope), and, with no slope,
/// where it was.
#[test]
fn a_new_speed_is_predicted_along_the_similarity_slope() {
    let wob = [0.0, 0.01, -0.01, 0.02, -0.02, 0.005, -0.005, 0.0];
    let with = |slope: [f64; 3]| -> Vec<Sample> {
        wob.iter()
            .map(|w| Sample {
                speed_slope: slope,
                ..smp([0.3 + w, -0.1 + w / 10.0], 7.0, 7000.0)
            })
            .collect()
    };
    let mean_d = -0.1 + wob.iter().sum::<f64>() / 80.0;
    let mean_u = 0.3 + wob.iter().sum::<f64>() / 8.0;
    for (slope, want_u, want_d) in [
        ([0.0, 0.0, 0.0], mean_u, mean_d),
        ([-0.9, 0.2, 0.0], mean_u - 0.9, mean_d + 0.2),
    ] {
        let samples = with(slope);
        let sh = shape(&samples, &st()).unwrap();
        let p = predict(&samples, &st(), &sh, &at(8.0, 7000.0)).unwrap();
        assert!(
            (p.offset[0] - want_u).abs() < 1e-6,
            "{:?} {want_u}",
            p.offset
        );
        assert!(
            (p.offset[1] - want_d).abs() < 1e-6,
            "{:?} {want_d}",
            p.offset
        );
        // The interval is the prior's whatever its mean: 1 m/s of a 0.03 per m/s slope sd,
        // beside which the mean's error (a scatter of 0.0013 over 8 tests) is nothing.
        assert!(
            p.cov.at(1, 1) > 0.03f64.powi(2) && p.cov.at(1, 1) < 1.01 * 0.03f64.powi(2),
            "{}",
            p.cov.at(1, 1)
        );
        // That interval is nearly all the slope prior's (known: `reference`), and none of it
        // at the learned point itself.
        assert!(
            p.prior_share[1] > 0.99 && p.prior_share[1] <= 1.0,
            "{:?}",
            p.prior_share
        );
        let home = predict(&samples, &st(), &sh, &at(7.0, 7000.0)).unwrap();
        assert!(home.prior_share[1] < 1e-9, "{:?}", home.prior_share);
    }
}

/// The gain of a Nomoto hull moves as `2 ln u` between speeds (`b` scales with `u^2`), whose
/// slope `2 / u` falls as the ship speeds up. Commissioned at 4 m/s (slope 0.5) and tested at
/// 5.5 m/s (its own slope 0.364), the prediction moves the learned gain along the trapezoid of
/// the two: within the trapezoid rule's bound `du^3 / 12 max |d^2 (2 / u) / du^2|` = 0.0176 of
/// the analytic `2 ln(5.5 / 4)` (0.011 by hand), where the learned slope alone, carried
/// straight, misses by 0.113 (a 25 % loading on a hull whose added mass halves its effect on
/// `b` moves it by 0.1). Without the test's own slope the prediction is the learned slope's.
#[test]
fn a_new_speed_is_predicted_along_the_trapezoid_of_the_learned_and_the_tests_slopes() {
    let law = |u: f64| 2.0 * u.ln();
    let wob = [0.0, 0.001, -0.001, 0.002, -0.002, 0.0005, -0.0005, 0.0];
    let samples: Vec<Sample> = wob
        .iter()
        .map(|w| {
            let mut x = smp([0.3, -0.1], 4.0, 7000.0);
            x.e[2] = -6.0 + law(4.0) + w;
            x.speed_slope = [0.0, 0.0, 2.0 / 4.0];
            x
        })
        .collect();
    let sh = shape(&samples, &st()).unwrap();
    let level = samples.iter().map(|x| x.e[2]).sum::<f64>() / 8.0;
    let truth = level + law(5.5) - law(4.0);
    let own = PhysicalSlopes {
        speed: [0.0, 0.0, 2.0 / 5.5],
        loading: [0.0; 3],
    };
    let p = predict_for(&samples, &st(), &sh, &at(5.5, 7000.0), &own).unwrap();
    let err = p.offset[2] - truth;
    let bound = 1.5f64.powi(3) / 12.0 * 4.0 / 4.0f64.powi(3);
    assert!(err > 0.0 && err < bound, "{err} {bound}");
    assert!((err - 0.0108).abs() < 0.001, "{err}");
    let straight = predict(&samples, &st(), &sh, &at(5.5, 7000.0)).unwrap();
    let miss = straight.offset[2] - truth;
    assert!((miss - 0.1131).abs() < 0.001, "{miss}");
    // The test's own slope is one test's: its scatter among the learned tests (here none)
    // widens nothing, and the interval is the prior's over the move.
    let tau = st().speed_sd(2) * 1.5;
    assert!(
        p.cov.at(2, 2) > tau * tau && p.cov.at(2, 2) < 1.01 * tau * tau,
        "{} {}",
        p.cov.at(2, 2),
        tau * tau
    );
}

/// The test's own slope is one test's reading: where the learned tests' slopes scatter by
/// `sd`, a quarter of its variance joins the slope prior's in the trapezoid's mean, and the
/// interval over a move `du` is `(tau^2 + sd^2 / 4) du^2` (by hand: data at one point say
/// nothing of the slope).
#[test]
fn the_tests_own_slope_adds_its_scatter_to_the_prior() {
    let sl = [0.4, 0.6, 0.45, 0.55, 0.5, 0.5, 0.42, 0.58];
    let wob = [0.0, 0.001, -0.001, 0.002, -0.002, 0.0005, -0.0005, 0.0];
    let samples: Vec<Sample> = sl
        .iter()
        .zip(wob)
        .map(|(&s, w)| {
            let mut x = smp([0.3 + w, -0.1 + w], 4.0, 7000.0);
            x.e[2] = -5.0 + w;
            x.speed_slope = [0.0, 0.0, s];
            x
        })
        .collect();
    let level = samples.iter().map(|x| x.e[2]).sum::<f64>() / 8.0;
    let mean = sl.iter().sum::<f64>() / 8.0;
    let var = sl.iter().map(|s| (s - mean).powi(2)).sum::<f64>() / 8.0;
    let sh = shape(&samples, &st()).unwrap();
    let own = PhysicalSlopes {
        speed: [0.0, 0.0, 0.3],
        loading: [0.0; 3],
    };
    let du = 1.5;
    let p = predict_for(&samples, &st(), &sh, &at(4.0 + du, 7000.0), &own).unwrap();
    let want = (st().speed_sd(2).powi(2) + var / 4.0) * du * du;
    let got = p.cov.at(2, 2);
    assert!(got > want && got < 1.01 * want, "{got} {want}");
    let moved = p.offset[2] - level;
    assert!(
        (moved - 0.5 * (mean + 0.3) * du).abs() < 1e-6,
        "{moved} {}",
        0.5 * (mean + 0.3) * du
    );
}

/// The loading slope's prior mean is the tests' own (`b` scaling by `1 / D`): declared 10 %
/// heavier (0.0953 in ln D), a ship whose tests say `e_D` moves by -0.5 per unit ln D is
/// predicted 0.048 lower.
#[test]
fn a_declared_loading_is_predicted_along_the_loading_slope() {
    let wob = [0.0, 0.01, -0.01, 0.02, -0.02, 0.005, -0.005, 0.0];
    let samples: Vec<Sample> = wob
        .iter()
        .map(|w| Sample {
            loading_slope: [0.0, -0.5, 0.0],
            ..smp([0.3 + w, -0.1 + w / 10.0], 7.0, 7000.0)
        })
        .collect();
    let sh = shape(&samples, &st()).unwrap();
    let mean_d = -0.1 + wob.iter().sum::<f64>() / 80.0;
    let p = predict(&samples, &st(), &sh, &at(7.0, 7700.0)).unwrap();
    let want = mean_d - 0.5 * (1.1f64).ln();
    assert!((p.offset[1] - want).abs() < 1e-6, "{:?} {want}", p.offset);
}

/// The sea's coordinate: 0 in a calm sea or calmer, `ln(i / i_calm)` above it, NaN for a test
/// whose sea is not known.
#[test]
fn the_sea_coordinate_is_the_log_of_the_index_over_the_calm_one() {
    let st = st();
    let sea = |i: Option<f64>| {
        Point {
            sea_index: i,
            ..at(7.0, 7000.0)
        }
        .x(&st)[3]
    };
    assert_eq!(sea(Some(0.05)), 0.0);
    assert_eq!(sea(Some(0.01)), 0.0);
    assert!((sea(Some(0.18)) - (0.18f64 / 0.05).ln()).abs() < 1e-12);
    assert!(sea(None).is_nan() && sea(Some(f64::NAN)).is_nan());
}

/// Learned in a calm sea, a test in a moderate one is predicted from the calm tests with
/// the slope prior's interval over the sea's distance (by hand, as in speed above); a test
/// that does not know its sea adds no distance.
#[test]
fn a_new_sea_is_predicted_with_the_slope_prior_over_its_distance() {
    let calm = |smp: Sample| Sample {
        sea_index: Some(0.05),
        ..smp
    };
    let samples: Vec<Sample> = FIVE
        .iter()
        .map(|&(a, b)| calm(smp([a, b], 7.0, 7000.0)))
        .collect();
    let sh = shape(&samples, &st()).unwrap();
    let moderate = Point {
        sea_index: Some(0.18),
        ..at(7.0, 7000.0)
    };
    let p = predict(&samples, &st(), &sh, &moderate).unwrap();
    let dw = (0.18f64 / 0.05).ln();
    let w = 1.0 / (1.0 + (dw / 0.5).powi(2));
    for (j, (var, tau)) in [
        (sh.cov.at(0, 0) * 0.01, 0.3),
        (sh.cov.at(1, 1) * 1e-4, 0.03),
    ]
    .iter()
    .enumerate()
    {
        // The sea's regressor is the part beyond half a bandwidth (0.25).
        let step = dw - 0.25;
        let want = var / (5.0 * w) + step * step * tau * tau;
        let got = [p.cov.at(0, 0), p.cov.at(1, 1)][j];
        assert!((got - want).abs() < 1e-9 * want, "{j}: {got} vs {want}");
        let share = step * step * tau * tau / want;
        assert!(
            (p.prior_share[j] - share).abs() < 1e-9,
            "{:?}",
            p.prior_share
        );
    }
    assert!((p.offset[0] - 1.0).abs() < 1e-12);
    assert!((p.nearest - dw / 0.5).abs() < 1e-12, "{}", p.nearest);
    // The sea is a condition (its scatter's shape is new there too), unlike speed.
    assert!((p.nearest_conditions - dw / 0.5).abs() < 1e-12);
    // Tests saved before the sea was kept are at every sea.
    let unknown: Vec<Sample> = samples
        .iter()
        .map(|s| Sample {
            sea_index: None,
            ..*s
        })
        .collect();
    let q = predict(&unknown, &st(), &sh, &moderate).unwrap();
    let home = predict(&samples, &st(), &sh, &at(7.0, 7000.0)).unwrap();
    assert_eq!(q.nearest, 0.0);
    assert!((q.cov.at(0, 0) - home.cov.at(0, 0)).abs() < 1e-15);
}

/// Learned in two seas whose offsets differ, each sea is predicted at its own offset, and a
/// sea between them between the two.
#[test]
fn each_learned_sea_keeps_its_own_offset() {
    let wob = [0.01, -0.01, 0.005, -0.005, 0.0, 0.002];
    let mut samples: Vec<Sample> = Vec::new();
    for (i, off) in [(0.05, 0.3), (0.18, 0.9)] {
        samples.extend(wob.iter().map(|w| Sample {
            sea_index: Some(i * (1.0 + w)),
            ..smp([off + w, -0.1 + w / 10.0], 7.0, 7000.0)
        }));
    }
    let sh = shape(&samples, &st()).unwrap();
    let sea = |i: f64| {
        predict(
            &samples,
            &st(),
            &sh,
            &Point {
                sea_index: Some(i),
                ..at(7.0, 7000.0)
            },
        )
        .unwrap()
    };
    let (c, m, mid) = (sea(0.05), sea(0.18), sea((0.05f64 * 0.18).sqrt()));
    assert!((c.offset[0] - 0.3).abs() < 0.02, "{:?}", c.offset);
    assert!((m.offset[0] - 0.9).abs() < 0.02, "{:?}", m.offset);
    assert!(
        mid.offset[0] > 0.45 && mid.offset[0] < 0.75,
        "{:?}",
        mid.offset
    );
    // The scatter is the tests' about their own sea's offset, not the move between seas.
    assert!(sh.cov.at(0, 0) < 0.1, "{:?}", sh.cov);
}

/// The scatter at another sea is the tests' there, the calm sea's carried by the design
/// spreads only as a prior worth `CARRIED_DOF`: none there (or one, with no residual of its
/// own), that prior; one, that prior and its one dof; several, their own scatter pooled
/// with it.
#[test]
fn only_the_tests_at_a_sea_vouch_for_its_scatter() {
    let wob = [0.01, -0.01, 0.005, -0.005, 0.0, 0.008, -0.008, 0.0];
    let sea = |i: f64| {
        move |smp: Sample| Sample {
            sea_index: Some(i),
            ..smp
        }
    };
    let mut samples: Vec<Sample> = wob
        .iter()
        .map(|w| sea(0.05)(smp([1.0 + w, -0.2 + w / 10.0], 7.0, 7000.0)))
        .collect();
    let moderate = Point {
        sea_index: Some(0.18),
        ..at(7.0, 7000.0)
    };
    let sh = shape(&samples, &st()).unwrap();
    let none = local_shape(&samples, &st(), &sh, &moderate);
    assert_eq!(none.cov, sh.cov);
    assert_eq!(none.dof, CARRIED_DOF);
    assert!(
        predict(&samples, &st(), &sh, &moderate)
            .unwrap()
            .nearest_conditions
            > 1.0
    );
    samples.push(sea(0.18)(smp([1.3 + 0.03, -0.2 + 0.003], 7.0, 7000.0)));
    let sh = shape(&samples, &st()).unwrap();
    let one = local_shape(&samples, &st(), &sh, &moderate);
    assert!((one.dof - CARRIED_DOF - 1.0).abs() < 1e-9, "{one:?}");
    // Seven more there: three times the calm tests' deviations about their own offset.
    for w in &wob[1..] {
        samples.push(sea(0.18)(smp(
            [1.3 + 3.0 * w, -0.2 + 3.0 * w / 10.0],
            7.0,
            7000.0,
        )));
    }
    let sh = shape(&samples, &st()).unwrap();
    let there = local_shape(&samples, &st(), &sh, &moderate);
    let calm_point = Point {
        sea_index: Some(0.05),
        ..at(7.0, 7000.0)
    };
    let calm = local_shape(&samples, &st(), &sh, &calm_point);
    // Three times the scatter: nine times the variance, each sea's own (the slope in the
    // sea joins the two offsets, so each sea's residuals are about its own), pooled with
    // the shape of all sixteen (by hand: nu_own S_own + 5 S_global over nu_own + 5).
    let own = |c: &Shape| (c.dof - CARRIED_DOF, c.cov.at(0, 0));
    let (nu_t, _) = own(&there);
    let (nu_c, _) = own(&calm);
    assert!(
        nu_t > 6.0 && nu_t < 9.0 && nu_c > 6.0 && nu_c < 9.0,
        "{there:?} {calm:?}"
    );
    let unpool = |c: &Shape, nu: f64| (c.cov.at(0, 0) * (nu + 5.0) - 5.0 * sh.cov.at(0, 0)) / nu;
    let ratio = unpool(&there, nu_t) / unpool(&calm, nu_c);
    assert!(ratio > 8.5 && ratio < 9.5, "{ratio}: {there:?} vs {calm:?}");
    // Pooled, the sea's own still shows: more than twice the calm sea's variance.
    assert!(
        there.cov.at(0, 0) > 2.0 * calm.cov.at(0, 0),
        "{there:?} vs {calm:?}"
    );
}

/// One sea's scatter of the sea index (its wave yaw over each test) teaches next to no
/// slope: tests whose residual happens to follow that scatter are predicted in the next sea
/// near their mean, not along it (the fit at their own points reads the sea only beyond
/// half a bandwidth, so the scatter is noise to the shape, which outweighs it against the
/// slope prior).
#[test]
fn one_seas_scatter_of_the_sea_index_teaches_no_slope() {
    let jitter = [0.1, -0.1, 0.05, -0.05, 0.0, 0.08, -0.08, 0.02];
    let samples: Vec<Sample> = jitter
        .iter()
        .map(|j: &f64| Sample {
            sea_index: Some(0.18 * j.exp()),
            // 2 m/s per unit of w, exactly: a slope a free fit would carry to the next sea.
            ..smp([1.0 + 2.0 * j, -0.2], 7.0, 7000.0)
        })
        .collect();
    let sh = shape(&samples, &st()).unwrap();
    let rough = Point {
        sea_index: Some(0.18 * 1.0f64.exp()),
        ..at(7.0, 7000.0)
    };
    let mean = 1.0 + 2.0 * jitter.iter().sum::<f64>() / 8.0;
    let p = predict(&samples, &st(), &sh, &rough).unwrap();
    // Along the scatter's slope the next sea would be at 1 + 2 x (1 - 0.25) = 2.5.
    assert!((p.offset[0] - mean).abs() < 0.1, "{:?} vs {mean}", p.offset);
    assert!(p.offset[0] > mean, "{:?} vs {mean}", p.offset);
}
