//! The commissioning's change-point test: a change found where it is, a healthy sample left
//! alone, the two methods' evidence combined, and the tails the combination rests on.
use super::*;
use crate::fdi::measured::effective_dof;
use crate::fdi::reference::{confirmation_looks, looks};
use crate::fdi::stats::{chi2_sf, hotelling_isf};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

use crate::fdi::envelope::tests::st as env;

const FLOORS: [f64; 3] = [0.05, 0.004, 0.004];

/// Every split counts: both samples are commissioning tests.
const ALL: [usize; 2] = [usize::MAX; 2];

/// The per-moment budget of a commissioning of up to 8 tests of each method (half of one
/// ship-day's 2.7e-4).
fn alpha() -> f64 {
    2.7e-4 / 2.0 / looks(8) as f64
}

/// The per-moment budget of its confirmation (the other half).
fn confirm_alpha() -> f64 {
    2.7e-4 / 2.0 / confirmation_looks(8) as f64
}

fn gauss(r: &mut ChaCha8Rng) -> f64 {
    StandardNormal.sample(r)
}

/// A test of a second-order-like hull: `e_b` with the displacement's scatter `sd`, a
/// displacement change `x` moving `e_D` by `x` and `e_b` by `-x`.
fn sample(rng: &mut ChaCha8Rng, shift: [f64; 2], u: f64, sd: f64, order: u64) -> Sample {
    Sample {
        e: [
            0.8 + 0.08 * gauss(rng) + shift[0],
            -0.1 + sd * gauss(rng) + shift[1],
            -5.0 + sd * gauss(rng) - shift[1],
        ],
        s: [0.05, 0.002, 0.002],
        speed_mps: u,
        displacement_t: 7000.0,
        excitation_scale: 1.0,
        sea_index: None,
        speed_slope: [0.0; 3],
        loading_slope: [0.0; 3],
        order,
        meas: None,
        log_slope: 0.0,
    }
}

/// One method's sample alone: the split found, if any.
fn alone(samples: &[Sample]) -> Option<usize> {
    joint_change_point([samples, &[]], ALL, &env(), FLOORS, alpha()).map(|c| {
        assert_eq!(c.splits[1], None);
        c.splits[0].unwrap()
    })
}

#[test]
fn a_shift_in_the_middle_is_found_at_its_test_and_a_healthy_sample_is_not() {
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    // A +12 % displacement from the fourth test on (k = 3).
    let shifted: Vec<Sample> = (0..8)
        .map(|i| {
            let x = if i >= 3 { 0.12 } else { 0.0 };
            sample(&mut rng, [0.0, x], 7.0, 0.004, i)
        })
        .collect();
    assert_eq!(alone(&shifted), Some(3));
    // A healthy sample, and the same at a change of speed of 1.5 m/s mid-sample with
    // an offset moving as the slope prior allows (0.5 m/s per m/s: 1 sd).
    let mut flagged = 0;
    for _ in 0..2000 {
        let ok: Vec<Sample> = (0..8)
            .map(|i| sample(&mut rng, [0.0; 2], 7.0, 0.004, i))
            .collect();
        flagged += usize::from(alone(&ok).is_some());
    }
    assert_eq!(flagged, 0);
    let moved: Vec<Sample> = (0..8)
        .map(|i| {
            let (u, de) = if i >= 4 { (5.5, 0.75) } else { (7.0, 0.0) };
            sample(&mut rng, [de, 0.0], u, 0.004, i)
        })
        .collect();
    assert_eq!(alone(&moved), None);
    // Too few tests: no verdict.
    assert_eq!(alone(&shifted[..5]), None);
    assert_eq!(looks(8), 30);
}

/// A speed change of 1.5 m/s mid-sample whose offset moves 0.75 of D, 17 slope-prior sds
/// of `e_D` (0.5 per m/s; a smaller move stays under the limit of 8 tests whose speed
/// residual's scatter is barely over its floor): a change when the tests' similarity
/// slope is 0, none when it says the ship moves so.
#[test]
fn a_speed_change_along_the_similarity_slope_is_no_change_of_health() {
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let run = |rng: &mut ChaCha8Rng, slope: f64| -> Vec<Sample> {
        (0..8)
            .map(|i| {
                let (u, de) = if i >= 4 { (8.5, 0.75) } else { (7.0, 0.0) };
                Sample {
                    speed_slope: [0.0, slope, -slope],
                    ..sample(rng, [0.0, de], u, 0.004, i)
                }
            })
            .collect()
    };
    assert_eq!(alone(&run(&mut rng, 0.0)), Some(4));
    assert_eq!(alone(&run(&mut rng, 0.5)), None);
}

/// The law bends: a ship whose gain follows `2 ln u` exactly (each test's slope `2 / u`)
/// speeds up from 4 to 5.5 m/s after the second of 16 tests. The segments' move is 0.637 in
/// `e_b`; the sample's mean slope, weighted by the longer segment's end (0.38), would predict
/// 0.57, 2.6 of the gain prior's standard deviations over 1.5 m/s (0.017 per m/s); the
/// trapezoid of the segments' (0.432) predicts 0.648: no change of health. A +12 %
/// displacement arising with the change (`e_b` -0.12 more) is still found at its test.
#[test]
fn a_speed_change_along_the_bending_law_is_no_change_of_health() {
    let mut rng = ChaCha8Rng::seed_from_u64(17);
    let mut gain = env();
    gain.slope_speed_gain = 0.017;
    let run = |rng: &mut ChaCha8Rng, x: f64| -> Vec<Sample> {
        (0..16)
            .map(|i| {
                let u = if i >= 2 { 5.5 } else { 4.0 };
                let mut s = sample(rng, [0.0, 0.0], u, 0.002, i);
                s.e[2] += 2.0 * (u / 4.0f64).ln() - if i >= 2 { x } else { 0.0 };
                s.e[1] += if i >= 2 { x } else { 0.0 };
                s.speed_slope = [0.0, 0.0, 2.0 / u];
                s
            })
            .collect()
    };
    let found = |s: &[Sample]| {
        joint_change_point([s, &[]], ALL, &gain, FLOORS, alpha()).and_then(|c| c.splits[0])
    };
    for _ in 0..20 {
        assert_eq!(found(&run(&mut rng, 0.0)), None);
    }
    assert_eq!(found(&run(&mut rng, 0.12)), Some(2));
}

/// CLFRT's tones resized in every other test (the excitation at 1 and 0.63, ln s 0 and
/// -0.46), the offset moving with it by a slope of one prior sd (0.3 per unit ln s in `e_D`
/// and `e_b`): a +12 % displacement from the sample's second test (k = 1) is found at its
/// test when the segments' own spread of excitations tells the slope, though the prior alone
/// allows the move between the segments' mean excitations to hide it; healthy with the same
/// slope, no change.
#[test]
fn a_slope_the_sample_itself_shows_is_taken_from_it() {
    let mut rng = ChaCha8Rng::seed_from_u64(13);
    let run = |rng: &mut ChaCha8Rng, x: f64| -> Vec<Sample> {
        (0..16u64)
            .map(|i| {
                let scale = if i % 2 == 0 { 0.63 } else { 1.0 };
                let g = f64::ln(scale);
                let shift = if i >= 1 { x } else { 0.0 };
                let mut t = sample(rng, [0.0, shift], 7.0, 0.005, i);
                t.excitation_scale = scale;
                t.e[1] += 0.3 * g;
                t.e[2] += 0.3 * g;
                t
            })
            .collect()
    };
    let found = |v: &[Sample]| {
        joint_change_point([v, &[]], ALL, &env(), FLOORS, confirm_alpha()).map(|c| c.splits[0])
    };
    assert_eq!(found(&run(&mut rng, 0.12)), Some(Some(1)));
    let flagged = (0..1000)
        .filter(|_| found(&run(&mut rng, 0.0)).is_some())
        .count();
    assert_eq!(flagged, 0);
    // The prior alone (one spread-free point per segment: the excitations of the two
    // segments as they were, each test moved to its segment's mean) cannot tell.
    let mut flat = run(&mut rng, 0.12);
    let mean_rest = flat[1..]
        .iter()
        .map(|t| t.excitation_scale.ln())
        .sum::<f64>()
        / 15.0;
    for t in &mut flat[1..] {
        let g = t.excitation_scale.ln();
        t.e[1] += 0.3 * (mean_rest - g);
        t.e[2] += 0.3 * (mean_rest - g);
        t.excitation_scale = mean_rest.exp();
    }
    assert_eq!(found(&flat), None);
}

/// Two methods in turn (the vessel's even tests one, odd the other), 8 tests each, a
/// displacement change of 5 scatter sds from the vessel's 7th test: the joint test names
/// the moment in both samples where, in most runs, neither sample alone shows it; healthy,
/// neither.
#[test]
fn the_methods_add_up_their_evidence_at_the_same_moment() {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let (sd, runs) = (0.02, 200);
    let (mut joint, mut single, mut right) = (0, 0, 0);
    for _ in 0..runs {
        let pair: [Vec<Sample>; 2] = std::array::from_fn(|m| {
            (0..8u64)
                .map(|i| {
                    let order = 2 * i + m as u64;
                    let x = if order >= 6 { 5.0 * sd } else { 0.0 };
                    sample(&mut rng, [0.0, x], 7.0, sd, order)
                })
                .collect()
        });
        single += usize::from(alone(&pair[0]).is_some() || alone(&pair[1]).is_some());
        if let Some(c) = joint_change_point([&pair[0], &pair[1]], ALL, &env(), FLOORS, alpha()) {
            joint += 1;
            right += usize::from(c.splits == [Some(3), Some(3)]);
        }
    }
    assert!(joint >= single + runs / 4, "joint {joint}, single {single}");
    assert!(right * 10 >= joint * 7, "{right} of {joint} at the moment");
    let mut flagged = 0;
    for _ in 0..1000 {
        let pair: [Vec<Sample>; 2] = std::array::from_fn(|m| {
            (0..8u64)
                .map(|i| sample(&mut rng, [0.0; 2], 7.0, sd, 2 * i + m as u64))
                .collect()
        });
        flagged += usize::from(
            joint_change_point([&pair[0], &pair[1]], ALL, &env(), FLOORS, alpha()).is_some(),
        );
    }
    assert_eq!(flagged, 0);
}

/// A one-dof look's tail `p = P(T^2(1, nu_eff(t)) > t)` as a p-value (Fisher's rule needs
/// it at every level): its exact size `P(p < alpha)`, integrated over the scatter's
/// chi-square: `v = sigma^2 w`, `w ~ chi2_nu / nu`, the known part `kappa` (in units of the
/// scatter's `sigma^2 (1/k + 1/(n-k))`); healthy, `d^2 ~ (1 + kappa) chi2_1`, and `p < alpha`
/// when `d^2 / (w + kappa) > L(w)`, `L` Hotelling's at the dof `effective_dof` gives. At the
/// 99 % bound within `alpha` at every `nu`, known share and level; with the share as
/// estimated (no bound), many times over it.
#[test]
fn a_one_dof_look_keeps_its_budget_whatever_the_known_share() {
    let size = |nu: f64, kappa: f64, level: Option<f64>, alpha: f64| -> f64 {
        let m = level.map_or(1.0, |l| bound_factor(nu, l));
        let ln_norm = 0.5 * nu * 2f64.ln() + statrs::function::gamma::ln_gamma(0.5 * nu);
        // Trapezoid over ln x, x the chi-square variate.
        let (lo, hi, n) = ((1e-6f64).ln(), (40.0 * nu).ln(), 1500);
        let h = (hi - lo) / n as f64;
        (0..=n)
            .map(|i| {
                let x = (lo + h * i as f64).exp();
                let w = x / nu;
                let t = 1.0 / (w + kappa);
                let dof = effective_dof(t, w * t / (w + kappa), nu, m);
                let limit = hotelling_isf(alpha, 1, dof);
                let tail = chi2_sf(limit * (w + kappa) / (1.0 + kappa), 1.0);
                let pdf_x = ((0.5 * nu - 1.0) * x.ln() - 0.5 * x - ln_norm).exp() * x;
                let edge = if i == 0 || i == n { 0.5 } else { 1.0 };
                edge * h * tail * pdf_x
            })
            .sum()
    };
    for alpha in [0.05, 1e-3, 7.5e-6] {
        for nu in [4.0, 6.0, 10.0] {
            for kappa in [0.0, 0.003, 0.04, 0.1, 1.0, 10.0] {
                let r = size(nu, kappa, Some(BOUND), alpha) / alpha;
                assert!(r < 1.05, "alpha {alpha} nu {nu} kappa {kappa}: {r}");
            }
            // Without known variance the look is Student's, exactly at its budget.
            let r = size(nu, 0.0, Some(BOUND), alpha) / alpha;
            assert!((r - 1.0).abs() < 0.03, "alpha {alpha} nu {nu}: {r}");
        }
    }
    // The plug-in share: a scatter small by chance takes the chi-square's limit.
    assert!(size(4.0, 0.1, None, 7.5e-6) / 7.5e-6 > 5.0);
}

/// Fisher's rule: one method's tail is its own; two tails of 1e-3 combine to
/// `P(chi2_4 > -2 ln 1e-6) = 1e-6 (1 + ln 1e3)` (the chi-square of 4 dof's closed form).
#[test]
fn fishers_rule_by_hand() {
    let one = chi2_sf(-2.0 * 1e-3f64.ln(), 2.0);
    assert!((one / 1e-3 - 1.0).abs() < 1e-9, "{one}");
    let x = -4.0 * 1e-3f64.ln();
    let two = chi2_sf(x, 4.0);
    let want = (-x / 2.0).exp() * (1.0 + x / 2.0);
    assert!((two / want - 1.0).abs() < 1e-9, "{two} {want}");
}

#[test]
fn the_hotelling_limit_matches_tables_and_tends_to_the_chi_square() {
    // T^2(2, nu) = 2 nu / (nu - 1) F(2, nu - 1); F(2, 5) at 5 % is 5.786 (tables):
    // nu = 6 gives 13.89.
    assert!((hotelling_isf(0.05, 2, 6.0) - 2.4 * 5.786).abs() < 0.01);
    // nu -> infinity: chi2_2 at 1e-4 = 2 ln 1e4 = 18.42.
    let chi2 = 2.0 * 1e4f64.ln();
    assert!((hotelling_isf(1e-4, 2, 1e7) - chi2).abs() < 1e-3);
    assert!(hotelling_isf(1e-4, 2, 50.0) > chi2 && hotelling_isf(1e-4, 2, 6.0) > 10.0 * chi2);
}

/// False "inconsistent" on healthy commissionings by Monte Carlo: both methods in turn,
/// scatter at and above the floors, both evaluations of a commissioning of the default
/// `fdi.commissioning-tests` K of each (at the vessel's `2K - 1`th and `2K`th tests) and the
/// `2K` of its confirmation (the vessel's `2K + 1`th to `4K`th), at the budget of that K
/// (slow tier: `cargo test --profile ci --lib change_point_false_flags -- --ignored
/// --nocapture`).
///
/// The budget is `alpha_c` = 2.7e-4 per commissioning with its confirmation. 500 runs at each
/// of the seven scatters, 3500 pooled, expect 0.95 flags at the budget; more than 4 has a
/// Poisson tail of 0.24 % there, so the assertion fails a commissioning that spends its
/// budget only by that chance, and a rate five times the budget about half the time.
#[test]
#[ignore = "slow tier: cargo test --profile ci -- --ignored"]
fn change_point_false_flags() {
    let k = crate::fdi::config::FdiConfig::default().commissioning_tests;
    let alpha = 2.7e-4 / 2.0 / looks(k) as f64;
    let confirm = 2.7e-4 / 2.0 / confirmation_looks(k) as f64;
    let k = u64::from(k);
    let runs = 500;
    let mut pooled = 0;
    // The last two: CLFRT's (the even tests') excitation alternating between 1 and 0.63,
    // its offset moving by one slope-prior sd (0.3 per unit ln s in e_D and e_b).
    for (su, sd, slope) in [
        (0.05, 0.004, 0.0),
        (0.1, 0.004, 0.0),
        (0.2, 0.02, 0.0),
        (0.3, 0.01, 0.0),
        (1.0, 0.03, 0.0),
        (0.05, 0.004, 0.3),
        (0.2, 0.02, 0.3),
    ] {
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let mut flagged = 0;
        for _ in 0..runs {
            let mut draw = |order: u64| {
                let (a, b, c) = (gauss(&mut rng), gauss(&mut rng), gauss(&mut rng));
                let scale = if slope > 0.0 && order % 4 == 0 {
                    0.63
                } else {
                    1.0
                };
                let g = slope * f64::ln(scale);
                Sample {
                    e: [
                        su * a,
                        sd * (-0.9 * a + 0.436 * b) + g,
                        sd * (0.5 * b + 0.866 * c) + g,
                    ],
                    excitation_scale: scale,
                    sea_index: None,
                    ..sample(&mut ChaCha8Rng::seed_from_u64(0), [0.0; 2], 7.0, sd, order)
                }
            };
            let v: Vec<Sample> = (0..4 * k).map(&mut draw).collect();
            let pair: [Vec<Sample>; 2] = std::array::from_fn(|m| {
                v.iter()
                    .filter(|s| s.order % 2 == m as u64)
                    .copied()
                    .collect()
            });
            let any = (2 * k - 1..=4 * k).any(|n| {
                let part = |m: usize| -> Vec<Sample> {
                    pair[m].iter().filter(|s| s.order < n).copied().collect()
                };
                let (clfrt, hbt) = (part(0), part(1));
                let (level, within) = if n <= 2 * k {
                    (alpha, ALL)
                } else {
                    (confirm, [k as usize; 2])
                };
                joint_change_point([&clfrt, &hbt], within, &env(), FLOORS, level).is_some()
            });
            flagged += usize::from(any);
        }
        println!(
            "K = {k}, scatter ({su}, {sd}), excitation slope {slope}: {flagged} of {runs} flagged: {:.2e} per commissioning and confirmation (budget 2.7e-4)",
            flagged as f64 / runs as f64
        );
        pooled += flagged;
    }
    assert!(
        pooled <= 4,
        "{pooled} of {} healthy commissionings flagged inconsistent (at most 4)",
        7 * runs
    );
}

/// One outlier at a sample's last test (the speed 20 scatter standard deviations off) is no
/// change: a single test's look is the decision's. The same shift in the last two tests is.
#[test]
fn one_test_after_the_moment_is_no_change_two_are() {
    let mut rng = ChaCha8Rng::seed_from_u64(21);
    let run = |rng: &mut ChaCha8Rng, from: u64| -> Vec<Sample> {
        (0..16u64)
            .map(|i| {
                let u = if i >= from { 1.6 } else { 0.0 };
                sample(rng, [u, 0.0], 7.0, 0.004, i)
            })
            .collect()
    };
    assert_eq!(alone(&run(&mut rng, 15)), None);
    assert_eq!(alone(&run(&mut rng, 14)), Some(14));
}

/// The sea falls a state after the sample's second test (moderate, `w` 1.39, to calm, 0):
/// the offset moves with it, `e_u` by 0.5 m/s (6 of its scatter's standard deviations, 1.5
/// of the sea prior's over the step) and `e_D` by 0.02, and that is no change of health; a
/// displacement change of 0.25 at the same moment (7 of the prior's standard deviations in
/// `e_D`) still is.
#[test]
fn a_change_of_sea_is_no_change_of_health() {
    let mut rng = ChaCha8Rng::seed_from_u64(8);
    let run = |rng: &mut ChaCha8Rng, fault: f64| -> Vec<Sample> {
        (0..16u64)
            .map(|i| {
                let (i_sea, shift) = if i < 2 {
                    (0.2, [0.5, 0.02])
                } else {
                    (0.05, [0.0, fault])
                };
                Sample {
                    sea_index: Some(i_sea),
                    ..sample(rng, shift, 7.0, 0.004, i)
                }
            })
            .collect()
    };
    for _ in 0..20 {
        assert_eq!(alone(&run(&mut rng, 0.0)), None);
    }
    assert_eq!(alone(&run(&mut rng, 0.25)), Some(2));
}
