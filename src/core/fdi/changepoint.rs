//! A change inside the commissioning sample: the two-segment mean-shift test.
//!
//! A fault present from the first commissioning test is indistinguishable from the ship's
//! own normal (only the wide design limits can see it); one that arises *during*
//! commissioning splits the sample in two. For every split `k` (the first `k` tests, the
//! other `n - k`), the difference of the segments' mean residuals `d = mean_B - mean_A` is
//! compared with its healthy covariance
//!
//! ```text
//! C_k = (S_p / nu + F) (1/k + 1/(n - k)) + Psi       nu = n - 2
//! T_k = d' C_k^-1 d
//! ```
//!
//! - `S_p` the within-segment scatter matrix (sum of squares about each segment's mean),
//!   `F = diag(floors^2)` the physical floors (`fdi.floor-*`);
//! - `Psi` the operating point's share: when the segments' mean speed or declared loading
//!   differ by `(du, dl)`, the offset may move by the slope prior's `(tau_u du, tau_l dl)`
//!   (`crate::core::fdi::envelope`) about the physical move: `d` is taken less the sample's
//!   mean similarity slope times `du` and its mean loading slope times `dl`
//!   (`Sample::speed_slope`, `Sample::loading_slope`, the slope priors' means): a change of
//!   operating point is no change of health.
//!
//! Two looks per split, each with half the budget: the networks' pair `(e_u, e_D)` (`p = 2`)
//! and the gain `e_b` alone (`p = 1`: at the few tests of a commissioning, Hotelling's tail in
//! three dimensions, `nu (nu - 2)^-1 3 F(3, nu - 2)`, is so heavy at `nu = 4` that it would
//! cost the gain's evidence more than the third dimension adds). Without floors and `Psi`,
//! each `T_k` is Hotelling's two-sample statistic `T^2 (p, nu)` (`stats::hotelling_isf`),
//! heavy at small `nu` (a scatter matrix from 4 dof is sometimes far too small). The floors
//! and `Psi` are known variance: the less of the statistic the scatter carries, the nearer
//! its tail is the chi-square's. Each look's limit is Hotelling's at the dof the learned
//! share leaves, `nu / share` with the share `y' (S_p / nu) y (1/k + 1/(n-k)) / T_k` (`y =
//! C_k^-1 d`) taken at its 99 % upper confidence bound (`measured::effective_dof`, the rule
//! the decision's calibration uses at 95 %). The bound is what keeps the tail: with the share
//! as estimated (Satterthwaite's plug-in), a scatter small by chance makes its own share
//! small and its limit the chi-square's; the exact size of a one-dof look (integrated over
//! the scatter's chi-square, docs/fdi.md) at `nu = 4` is then 24 times its budget where the
//! known part is 7 % of the scatter's; at the 95 % bound at most 2.1 times, at the 99 %
//! bound at most 0.97 at every `nu` from 4 and every known share (the unit test
//! `a_one_dof_look_keeps_its_budget_whatever_the_known_share`). Student's limit at `nu`,
//! whatever the floors (as before this rule), holds the budget too but pays for it: a 0.5 m/s
//! speed-log bias arising in a moderate sea moves `e_b` by `-2 beta / u` (0.1-0.25, 5-25
//! standard deviations of the difference) and met a limit of 203 (`t = 14`) at `nu = 6`.
//!
//! The sample is declared inconsistent at the split whose look is furthest over its limit.
//! Budget: one ship-day of the alarm budget per commissioning, `alpha_c = F / 365.25`
//! (`fdi.false-alarms-per-year` = 0.1: 2.7e-4), spent evenly over the (look, split) pairs a
//! commissioning can make (Bonferroni: `alpha_c / L`). Needs `n >= 6` (`nu = 4`).
use super::envelope::{Sample, Settings as Envelope};
use super::measured::{bound_factor, effective_dof};
use super::stats::{dot, hotelling_isf, Cov, P};

/// The confidence level of the upper bound on the scatter's share of a look
/// (`measured::effective_dof`): at 99 % a one-dof look's exact size stays within its budget
/// at every `nu >= 4` and every share (module doc).
const BOUND: f64 = 0.99;

/// The fewest tests the test runs on.
pub const MIN_TESTS: usize = 6;

/// The number of (look, split) pairs a commissioning of up to `k_max` tests can make.
pub fn looks(k_max: u32) -> usize {
    (MIN_TESTS..=k_max.max(MIN_TESTS as u32) as usize)
        .map(|n| n - 1)
        .sum::<usize>()
        .max(1)
}

/// The split with the largest statistic over its limit: `(k, T_k)` (the change at test
/// `k + 1`), or `None`. `alpha` is each (look, split)'s tail probability.
pub fn change_point(
    samples: &[Sample],
    env: &Envelope,
    floors: [f64; P],
    alpha: f64,
) -> Option<(usize, f64)> {
    let n = samples.len();
    if n < MIN_TESTS {
        return None;
    }
    let nu = (n - 2) as f64;
    let m = bound_factor(nu, BOUND);
    // Prefix sums of e, e e' and the operating point: every split in O(1).
    let mut pre = vec![Sums::default(); n + 1];
    for (i, s) in samples.iter().enumerate() {
        pre[i + 1] = pre[i].plus(s);
    }
    let total = pre[n];
    let mut best: Option<(usize, f64, f64)> = None;
    for (k, &a) in pre.iter().enumerate().take(n).skip(1) {
        let b = total.minus(&a);
        let (ma, xa) = a.means();
        let (mb, xb) = b.means();
        let sp = a.scatter().plus(b.scatter());
        let f = 1.0 / k as f64 + 1.0 / (n - k) as f64;
        let (du, dl, dg) = (xb[0] - xa[0], xb[1] - xa[1], xb[2] - xa[2]);
        // The physical move between the segments' points (the slope priors' means): the
        // similarity law's in speed, `b` scaling by `1 / D` in declared loading.
        let slope = total.slope.map(|v| v / total.n.max(1.0));
        let lslope = total.lslope.map(|v| v / total.n.max(1.0));
        let d: [f64; P] = std::array::from_fn(|j| mb[j] - ma[j] - slope[j] * du - lslope[j] * dl);
        let psi = |j: usize| {
            let i = j.min(1);
            (env.slope_speed[i] * du).powi(2)
                + (env.slope_loading[i] * dl).powi(2)
                + (env.slope_excitation[i] * dg).powi(2)
        };
        let per = sp.times(1.0 / nu);
        // The learned part (the scatter, estimated with `nu` dof) and the known ones (the
        // floors, the slope prior's share).
        let learned = per.times(f);
        let c = learned
            .plus(Cov::diag(floors).times(f))
            .plus(Cov::diag(std::array::from_fn(|j| psi(j).sqrt())));
        // Two looks, half the budget each: the networks' pair (e_u, e_D), and the gain e_b
        // alone (one dof: at the few tests of a commissioning, Hotelling's tail in three
        // dimensions would cost the gain's evidence more than it adds). Each at the dof its
        // learned share leaves (`measured::effective_dof`, the share at its upper bound).
        let pair = {
            let (c2, l2) = (c.leading(2, 1.0), learned.leading(2, 0.0));
            let d2 = [d[0], d[1], 0.0];
            c2.solve(d2).map(|y| {
                let t = dot(d2, y);
                let dof = effective_dof(t, l2.form(y, y), nu, m);
                (t, hotelling_isf(0.5 * alpha, 2, dof))
            })
        };
        let cb = c.at(2, 2);
        let gain = (cb > 0.0 && d[2].is_finite()).then(|| {
            let t = d[2] * d[2] / cb;
            let a = learned.at(2, 2) * t / cb;
            let dof = effective_dof(t, a, nu, m);
            (t, hotelling_isf(0.5 * alpha, 1, dof))
        });
        for (t, limit) in [pair, gain].into_iter().flatten() {
            let ratio = t / limit;
            if t.is_finite() && t > limit && best.is_none_or(|(_, _, br)| ratio > br) {
                best = Some((k, t, ratio));
            }
        }
    }
    best.map(|(k, t, _)| (k, t))
}

/// Sums over a run of samples: count, `e`, `e e'`, `(u, ln D, ln s)`, the similarity
/// slopes (a component that is not finite counting as 0).
#[derive(Debug, Clone, Copy, Default)]
struct Sums {
    n: f64,
    e: [f64; P],
    ee: [[f64; P]; P],
    x: [f64; 3],
    slope: [f64; P],
    lslope: [f64; P],
}

impl Sums {
    fn plus(self, s: &Sample) -> Self {
        let finite = |x: f64| if x.is_finite() { x } else { 0.0 };
        let x = s.point().x();
        Self {
            n: self.n + 1.0,
            e: std::array::from_fn(|i| self.e[i] + s.e[i]),
            ee: std::array::from_fn(|i| std::array::from_fn(|j| self.ee[i][j] + s.e[i] * s.e[j])),
            x: std::array::from_fn(|i| self.x[i] + x[i]),
            slope: std::array::from_fn(|i| self.slope[i] + finite(s.speed_slope[i])),
            lslope: std::array::from_fn(|i| self.lslope[i] + finite(s.loading_slope[i])),
        }
    }

    fn minus(self, o: &Self) -> Self {
        Self {
            n: self.n - o.n,
            e: std::array::from_fn(|i| self.e[i] - o.e[i]),
            ee: std::array::from_fn(|i| std::array::from_fn(|j| self.ee[i][j] - o.ee[i][j])),
            x: std::array::from_fn(|i| self.x[i] - o.x[i]),
            slope: std::array::from_fn(|i| self.slope[i] - o.slope[i]),
            lslope: std::array::from_fn(|i| self.lslope[i] - o.lslope[i]),
        }
    }

    /// Mean residual and mean operating point.
    fn means(&self) -> ([f64; P], [f64; 3]) {
        let n = self.n.max(1.0);
        (self.e.map(|v| v / n), self.x.map(|v| v / n))
    }

    /// The scatter about the mean, `sum (e - m)(e - m)'`.
    fn scatter(&self) -> Cov {
        let (m, _) = self.means();
        Cov(std::array::from_fn(|i| {
            std::array::from_fn(|j| {
                let v = self.ee[i][j] - self.n * m[i] * m[j];
                if i == j {
                    v.max(0.0)
                } else {
                    v
                }
            })
        }))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::core::fdi::stats::chi2_sf;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;
    use rand_distr::{Distribution, StandardNormal};

    use crate::core::fdi::envelope::tests::st as env;

    const FLOORS: [f64; 3] = [0.05, 0.004, 0.004];

    /// A test of a second-order-like hull: `e_b` with the displacement's scatter, a
    /// displacement change `x` moving `e_D` by `x` and `e_b` by `-x`.
    fn sample(rng: &mut ChaCha8Rng, shift: [f64; 2], u: f64) -> Sample {
        let n = |r: &mut ChaCha8Rng| -> f64 { StandardNormal.sample(r) };
        Sample {
            e: [
                0.8 + 0.08 * n(rng) + shift[0],
                -0.1 + 0.004 * n(rng) + shift[1],
                -5.0 + 0.004 * n(rng) - shift[1],
            ],
            s: [0.05, 0.002, 0.002],
            speed_mps: u,
            displacement_t: 7000.0,
            excitation_scale: 1.0,
            speed_slope: [0.0; 3],
            loading_slope: [0.0; 3],
        }
    }

    #[test]
    fn a_shift_in_the_middle_is_found_at_its_test_and_a_healthy_sample_is_not() {
        let alpha = 2.7e-4 / looks(8) as f64;
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        // A +12 % displacement from the fourth test on (k = 3).
        let shifted: Vec<Sample> = (0..8)
            .map(|i| sample(&mut rng, if i >= 3 { [0.0, 0.12] } else { [0.0; 2] }, 7.0))
            .collect();
        let (k, t) = change_point(&shifted, &env(), FLOORS, alpha).unwrap();
        assert_eq!(k, 3);
        assert!(t > 300.0, "{t}");
        // A healthy sample, and the same at a change of speed of 1.5 m/s mid-sample with
        // an offset moving as the slope prior allows (0.5 m/s per m/s: 1 sd).
        let mut flagged = 0;
        for _ in 0..2000 {
            let ok: Vec<Sample> = (0..8).map(|_| sample(&mut rng, [0.0; 2], 7.0)).collect();
            flagged += usize::from(change_point(&ok, &env(), FLOORS, alpha).is_some());
        }
        assert_eq!(flagged, 0);
        let moved: Vec<Sample> = (0..8)
            .map(|i| {
                let (u, de) = if i >= 4 { (5.5, 0.75) } else { (7.0, 0.0) };
                sample(&mut rng, [de, 0.0], u)
            })
            .collect();
        assert!(change_point(&moved, &env(), FLOORS, alpha).is_none());
        // Too few tests: no verdict.
        assert!(change_point(&shifted[..5], &env(), FLOORS, alpha).is_none());
        assert_eq!(looks(8), 5 + 6 + 7);
    }

    /// A speed change of 1.5 m/s mid-sample whose offset moves 0.75 of D, 17 slope-prior sds
    /// of `e_D` (0.5 per m/s; a smaller move stays under the limit of 8 tests whose speed
    /// residual's scatter is barely over its floor): a change when the tests' similarity
    /// slope is 0, none when it says the ship moves so.
    #[test]
    fn a_speed_change_along_the_similarity_slope_is_no_change_of_health() {
        let alpha = 2.7e-4 / looks(8) as f64;
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let run = |rng: &mut ChaCha8Rng, slope: f64| -> Vec<Sample> {
            (0..8)
                .map(|i| {
                    let (u, de) = if i >= 4 { (8.5, 0.75) } else { (7.0, 0.0) };
                    Sample {
                        speed_slope: [0.0, slope, -slope],
                        ..sample(rng, [0.0, de], u)
                    }
                })
                .collect()
        };
        let flat = run(&mut rng, 0.0);
        let (k, _) = change_point(&flat, &env(), FLOORS, alpha).unwrap();
        assert_eq!(k, 4);
        let along = run(&mut rng, 0.5);
        assert!(change_point(&along, &env(), FLOORS, alpha).is_none());
    }

    /// The exact size of the gain's one-dof look, integrated over the scatter's chi-square:
    /// `v = sigma^2 w`, `w ~ chi2_nu / nu`, the known part `kappa` (in units of the
    /// scatter's `sigma^2 (1/k + 1/(n-k))`); healthy, `d^2 ~ (1 + kappa) chi2_1`, and the
    /// look exceeds when `d^2 / (w + kappa) > L(w)`, `L` Hotelling's at the dof
    /// `effective_dof` gives. At the 99 % bound within the look's budget at every `nu` and
    /// known share; with the share as estimated (no bound), many times over it.
    #[test]
    fn a_one_dof_look_keeps_its_budget_whatever_the_known_share() {
        let alpha = 7.5e-6;
        let size = |nu: f64, kappa: f64, level: Option<f64>| -> f64 {
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
        for nu in [4.0, 6.0, 10.0] {
            for kappa in [0.0, 0.003, 0.04, 0.1, 1.0, 10.0] {
                let r = size(nu, kappa, Some(BOUND)) / alpha;
                assert!(r < 1.05, "nu {nu} kappa {kappa}: {r}");
            }
            // Without known variance the look is Student's, exactly at its budget.
            let r = size(nu, 0.0, Some(BOUND)) / alpha;
            assert!((r - 1.0).abs() < 0.03, "nu {nu}: {r}");
        }
        // The plug-in share: a scatter small by chance takes the chi-square's limit.
        assert!(size(4.0, 0.1, None) / alpha > 5.0);
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

    /// False "inconsistent" on healthy samples by Monte Carlo: scatter at and above the
    /// floors, every look of a commissioning of up to 8 (`cargo test --profile ci --lib
    /// change_point_false_flags -- --ignored --nocapture`).
    #[test]
    #[ignore]
    fn change_point_false_flags() {
        let alpha = 2.7e-4 / looks(8) as f64;
        for (su, sd) in [
            (0.05, 0.004),
            (0.1, 0.004),
            (0.2, 0.02),
            (0.3, 0.01),
            (1.0, 0.03),
        ] {
            let mut rng = ChaCha8Rng::seed_from_u64(11);
            let runs = 200_000;
            let mut flagged = 0;
            for _ in 0..runs {
                let n = |r: &mut ChaCha8Rng| -> f64 { StandardNormal.sample(r) };
                let v: Vec<Sample> = (0..8)
                    .map(|_| {
                        let a = n(&mut rng);
                        let b = n(&mut rng);
                        let c = n(&mut rng);
                        Sample {
                            e: [
                                su * a,
                                sd * (-0.9 * a + 0.436 * b),
                                sd * (0.5 * b + 0.866 * c),
                            ],
                            s: [0.05, 0.002, 0.002],
                            speed_mps: 7.0,
                            displacement_t: 7000.0,
                            excitation_scale: 1.0,
                            speed_slope: [0.0; 3],
                            loading_slope: [0.0; 3],
                        }
                    })
                    .collect();
                let any =
                    (MIN_TESTS..=8).any(|m| change_point(&v[..m], &env(), FLOORS, alpha).is_some());
                flagged += usize::from(any);
            }
            println!(
                "scatter ({su}, {sd}): {flagged} of {runs} flagged: {:.2e} per commissioning (budget 2.7e-4)",
                flagged as f64 / runs as f64
            );
        }
    }
}
