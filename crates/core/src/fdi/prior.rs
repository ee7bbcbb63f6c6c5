//! The class's prior for a vessel's healthy scatter (docs/fdi.md, "The class's prior").
//!
//! A method's residual in design-spread units, `z = e / s` per component (`e_u`, `e_D`, `e_b`),
//! scatters on a healthy vessel about its learned offset with covariance `Sigma_v`. Over the
//! hulls and operating points of the models' class, each of its variances `sigma_j^2` is
//! drawn from a scaled inverse chi-square of `w_j` dof about `Psi_jj(sea)`
//! (`calibration.json`'s `healthy-scatter`, measured by `helmwatch train` on the class: seeded
//! repeats at fixed operating points). The conjugate update of the vessel's shape `S~` (`nu`
//! dof, `envelope`), component by component, its correlations the vessel's own:
//!
//! ```text
//! v_j = (w_j Psi_jj + nu S~_jj) / (w_j + nu),    nu_j = w_j + nu
//! S_post = V^1/2 R~ V^1/2                        (R~ the shape's correlations)
//! ```
//!
//! (the offset keeps its flat prior: the envelope's regression). A statistic is read with
//! Hotelling's tail at the dof of its direction: the components' `nu_j`, weighted by their
//! shares of the learned part of the statistic (`along`). So after a few tests the limits are
//! the class's rather than Hotelling-wide, as far as the class knows each component.
//!
//! `w_j` is measured: each of the class's points gives the variance `v_ij` of component `j`
//! over `R` repeats; beyond the repeats' own sampling (`Var ln v = 2 / (R - 1) + kappa_j / R`,
//! `kappa_j` the excess kurtosis of the tests about their point), the variance `tau_j^2` of
//! `ln v_ij` over the points is how far the class's scatter moves between operating points
//! (and hulls, trained on a family). A scaled inverse chi-square of `w` dof moves a
//! variance's log by about `2 / w`: `w_j = 2 / tau_j^2`, at most the dof the prior was
//! measured from ([`ClassScatter::weight`]).
//!
//! **The scatter test.** The prior must not hide a vessel outside the class. Under the prior
//! a component's variance ratio `S~_jj / Psi_jj` of the vessel's shape is the ratio of two
//! scaled chi-squares, `F(nu, w_j)`. Outside the two-sided `SCATTER_ALPHA / P` interval of
//! any component (Bonferroni over the three) the vessel is noisier or quieter than its class:
//! its own scatter decides alone (no prior; commissioning then runs until its own tests
//! resolve, `reference`), and status says so.

use super::envelope::Shape;
use super::point::Sample;
use super::stats::{Cov, P};

/// The scatter test's two-sided level: the share of the class's own vessels that read their
/// own scatter alone (a longer commissioning, never a false alarm).
pub const SCATTER_ALPHA: f64 = 0.05;

/// The fewest dof of the vessel's own shape the scatter test is read on (below it the test
/// cannot tell a vessel 3x noisier from its class).
pub const MIN_TEST_DOF: f64 = 3.0;

pub use super::config::{ClassScatter, ScatterPrior};

impl ScatterPrior {
    /// Method `i`'s (0 CLFRT, 1 HBT).
    pub fn of(&self, i: usize) -> ClassScatter {
        if i == 0 {
            self.clfrt
        } else {
            self.hbt
        }
    }
}

/// What the scatter test found.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Verdict {
    /// The vessel's variance over the class's in the component farthest from it (1: as the
    /// class).
    pub ratio: f64,
    /// That component's two-sided tail probability under the prior, times `P`.
    pub tail: f64,
    /// The prior is used.
    pub used: bool,
}

/// One class point's variance of a component: `(v, dof, n)` over `n` repeats.
pub type PointVariance = (f64, f64, f64);

impl ClassScatter {
    /// `Psi` at sea fraction `frac` (0 calm, 1 moderate; clamped to the two).
    pub fn at(&self, frac: f64) -> Cov {
        let f = if frac.is_finite() {
            frac.clamp(0.0, 1.0)
        } else {
            1.0
        };
        Cov(self.calm)
            .times(1.0 - f)
            .plus(Cov(self.moderate).times(f))
    }

    /// The scatter test of a vessel's shape `cov` of `dof` dof against `psi` (module doc);
    /// `None` below [`MIN_TEST_DOF`] or where `psi` has a variance that is not positive.
    pub fn test(&self, psi: Cov, cov: Cov, dof: f64) -> Option<Verdict> {
        if dof < MIN_TEST_DOF {
            return None;
        }
        let (v, p) = (cov.variances(), psi.variances());
        let mut worst: Option<Verdict> = None;
        for j in 0..P {
            let ratio = v[j] / p[j];
            if !(ratio.is_finite() && p[j] > 0.0) {
                return None;
            }
            if self.dof[j] <= 0.0 {
                continue;
            }
            let upper = f_sf(ratio, dof, self.dof[j]);
            let tail = (2.0 * P as f64 * upper.min(1.0 - upper)).min(1.0);
            if worst.is_none_or(|w| tail < w.tail) {
                worst = Some(Verdict {
                    ratio,
                    tail,
                    used: tail >= SCATTER_ALPHA,
                });
            }
        }
        worst
    }

    /// The conjugate update (module doc) of `cov` with `dof` dof at `psi`: the pooled
    /// covariance and each component's dof.
    pub fn pool(&self, psi: Cov, cov: Cov, dof: f64) -> (Cov, [f64; P]) {
        let (pv, v) = (psi.variances(), cov.variances());
        let n: [f64; P] = std::array::from_fn(|j| self.dof[j].max(0.0) + dof);
        let post: [f64; P] =
            std::array::from_fn(|j| (self.dof[j].max(0.0) * pv[j] + dof * v[j]) / n[j]);
        let mut c = [[0.0; P]; P];
        for (i, row) in c.iter_mut().enumerate() {
            for (j, x) in row.iter_mut().enumerate() {
                *x = if i == j {
                    post[i]
                } else {
                    cov.correlation(i, j) * (post[i] * post[j]).sqrt()
                };
            }
        }
        (Cov(c), n)
    }

    /// `w_j` from the class's points (module doc): per component, each point's variance, its
    /// dof and repeats, and the component's excess kurtosis about the points; the prior
    /// measured from `total_dof` dof in all.
    pub fn weight(components: &[(Vec<PointVariance>, f64); P], total_dof: f64) -> [f64; P] {
        components.each_ref().map(|(points, kurtosis)| {
            let n = points.len() as f64;
            let logs: Vec<f64> = points.iter().map(|p| p.0.ln()).collect();
            if n < 2.0 || logs.iter().any(|x| !x.is_finite()) {
                return 0.0;
            }
            let mean = logs.iter().sum::<f64>() / n;
            let var = logs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0);
            let own = points
                .iter()
                .map(|p| 2.0 / p.1 + kurtosis.max(0.0) / p.2)
                .sum::<f64>()
                / n;
            let tau2 = var - own;
            if tau2 <= 0.0 {
                total_dof
            } else {
                (2.0 / tau2).min(total_dof)
            }
        })
    }
}

/// The scatter test (module doc) of a vessel's `shape` from `samples` against `prior` at
/// their mean sea; `None` without a prior or a shape, or with too few tests.
pub fn verdict(
    prior: Option<ClassScatter>,
    shape: Option<Shape>,
    samples: &[Sample],
    anchors: [f64; 2],
) -> Option<Verdict> {
    let (prior, sh) = (prior?, shape?);
    prior.test(
        prior.at(mean_sea_fraction(samples, anchors)),
        sh.cov,
        sh.dof,
    )
}

/// `shape` pooled with `prior` at sea fraction `frac`, and each component's dof, where the
/// scatter test's `verdict` keeps the prior; as it is otherwise (`None`).
pub fn with_class(
    prior: Option<ClassScatter>,
    verdict: Option<Verdict>,
    shape: Shape,
    frac: f64,
) -> (Shape, Option<[f64; P]>) {
    match (prior, verdict) {
        (Some(prior), Some(v)) if v.used => {
            let (cov, dofs) = prior.pool(prior.at(frac), shape.cov, shape.dof);
            (Shape { cov, ..shape }, Some(dofs))
        }
        _ => (shape, None),
    }
}

/// Status text: ", scatter 0.90x the class's", and why the prior is not used.
pub fn describe(ratio: Option<f64>, used: bool) -> String {
    match (ratio, used) {
        (Some(q), true) => format!(", scatter {q:.2}x the class's"),
        (Some(q), false) => {
            format!(", scatter {q:.2}x the class's: outside its class, its own tests alone")
        }
        (None, _) => String::new(),
    }
}

/// The mean sea fraction of `samples` (`raw::sea_fraction` between the `anchors`).
pub fn mean_sea_fraction(samples: &[Sample], anchors: [f64; 2]) -> f64 {
    let n = samples.len().max(1) as f64;
    samples
        .iter()
        .map(|x| super::raw::sea_fraction(anchors, x.sea_index))
        .sum::<f64>()
        / n
}

/// The dof of a statistic whose learned covariance `learned` rests on components of `dofs`
/// dof, along `y = Sigma^-1 r`: the harmonic mean of the `dofs` weighted by each component's
/// share `|y_j (A y)_j|` of the learned part `y' A y` (Satterthwaite's conservative root,
/// as `measured::effective_dof`). The least of them where the shares are all 0.
pub fn along(dofs: [f64; P], learned: Cov, y: [f64; P]) -> f64 {
    let ay: [f64; P] = std::array::from_fn(|i| (0..P).map(|j| learned.0[i][j] * y[j]).sum());
    let share: [f64; P] = std::array::from_fn(|j| (y[j] * ay[j]).abs());
    let total: f64 = share.iter().sum();
    let inv: f64 = (0..P).map(|j| share[j] / dofs[j]).sum();
    if total > 0.0 && inv > 0.0 && (total / inv).is_finite() {
        total / inv
    } else {
        dofs.iter().copied().fold(f64::INFINITY, f64::min)
    }
}

/// `P(F(d1, d2) > x)`: the regularised incomplete beta `I_{d2 / (d2 + d1 x)}(d2 / 2, d1 / 2)`.
pub fn f_sf(x: f64, d1: f64, d2: f64) -> f64 {
    if x.is_nan() || x <= 0.0 {
        return 1.0;
    }
    if x.is_infinite() {
        return 0.0;
    }
    statrs::function::beta::beta_reg(0.5 * d2, 0.5 * d1, d2 / (d2 + d1 * x))
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;
    use rand_distr::StandardNormal;

    /// The F tail against tables (F(5, 10) 95 %: 3.326; F(10, 20) 99 %: 3.368) and its
    /// limit, the chi-square's over its dof.
    #[test]
    fn the_f_tail_matches_tables() {
        assert!((f_sf(3.326, 5.0, 10.0) - 0.05).abs() < 5e-4);
        assert!((f_sf(3.368, 10.0, 20.0) - 0.01).abs() < 2e-4);
        let chi = crate::fdi::stats::chi2_sf(8.0 * 1.5, 8.0);
        assert!((f_sf(1.5, 8.0, 1e7) - chi).abs() < 1e-4);
    }

    /// The pooled covariance is the dof-weighted mean, with the vessel's correlations.
    #[test]
    fn pooling_is_what_it_says() {
        let psi = Cov([[1.0, -0.5, 0.0], [-0.5, 2.0, 0.3], [0.0, 0.3, 0.5]]);
        let c = ClassScatter {
            calm: psi.0,
            moderate: psi.times(3.0).0,
            dof: [20.0, 20.0, 5.0],
        };
        let (p, n) = c.pool(psi, psi.times(4.0), 5.0);
        assert_eq!(n, [25.0, 25.0, 10.0]);
        assert!((p.at(1, 1) - 2.0 * (20.0 + 20.0) / 25.0).abs() < 1e-12);
        assert!((p.at(2, 2) - 0.5 * (5.0 + 20.0) / 10.0).abs() < 1e-12);
        // The correlations are the vessel's.
        assert!((p.correlation(0, 1) - psi.correlation(0, 1)).abs() < 1e-12);
        // Along a direction only component 2 learns, its dof; along none, the least.
        let y = [0.0, 0.0, 1.0];
        assert!((along(n, Cov::diag([1.0, 1.0, 1.0]), y) - 10.0).abs() < 1e-12);
        assert_eq!(along(n, Cov::default(), y), 10.0);
        assert!((c.at(0.5).at(0, 0) - 2.0).abs() < 1e-12);
        assert_eq!(c.at(7.0), Cov(c.moderate));
    }

    /// Vessels drawn from the prior's model (each component's variance
    /// `nu_0 / chi2(nu_0)`, tests Gaussian about it) pass the scatter test at
    /// `1 - SCATTER_ALPHA` or more (Bonferroni: at most it, within a third on 4000
    /// vessels), and a vessel 3x noisier (variance) than the class is found from 6 tests in
    /// most draws.
    #[test]
    fn the_scatter_test_keeps_its_level_and_finds_a_noisier_vessel() {
        let psi = Cov::diag([1.0, 1.0, 1.0]);
        let nu0 = 30;
        let c = ClassScatter {
            calm: psi.0,
            moderate: psi.0,
            dof: [nu0 as f64; P],
        };
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let vessels = 4000;
        let (mut rejected, mut found) = (0, 0);
        let chi = |rng: &mut ChaCha8Rng, k: usize| -> f64 {
            (0..k)
                .map(|_| rng.sample::<f64, _>(StandardNormal).powi(2))
                .sum()
        };
        for _ in 0..vessels {
            let scale: [f64; P] = std::array::from_fn(|_| nu0 as f64 / chi(&mut rng, nu0));
            let n = 6;
            for (k, hit) in [(scale, &mut rejected), ([3.0; P], &mut found)] {
                let draws: Vec<[f64; P]> = (0..n)
                    .map(|_| {
                        std::array::from_fn(|j| k[j].sqrt() * rng.sample::<f64, _>(StandardNormal))
                    })
                    .collect();
                let mean: [f64; P] =
                    std::array::from_fn(|j| draws.iter().map(|d| d[j]).sum::<f64>() / n as f64);
                let mut s = [[0.0; P]; P];
                for d in &draws {
                    for i in 0..P {
                        for j in 0..P {
                            s[i][j] += (d[i] - mean[i]) * (d[j] - mean[j]) / (n - 1) as f64;
                        }
                    }
                }
                let v = c.test(psi, Cov(s), (n - 1) as f64).unwrap();
                if !v.used {
                    *hit += 1;
                }
            }
        }
        let level = rejected as f64 / vessels as f64;
        assert!(
            (SCATTER_ALPHA * 0.5..SCATTER_ALPHA * 1.33).contains(&level),
            "{level}"
        );
        let power = found as f64 / vessels as f64;
        assert!(power > 0.6, "{power}");
    }

    /// With points all of one variance the weight is the dof measured; with variances that
    /// move it is what their excess variance says, the least over the components.
    #[test]
    fn the_weight_follows_the_points_excess_variance() {
        let flat = vec![(1.0, 1e9, 1e9), (1.0, 1e9, 1e9)];
        // ln v = -0.2, +0.2: var 0.08 beyond ~0 sampling: w = 2 / 0.08 = 25.
        let moving = vec![((-0.2f64).exp(), 1e12, 1e12), (0.2f64.exp(), 1e12, 1e12)];
        let w = ClassScatter::weight(
            &[(flat.clone(), 0.0), (moving.clone(), 0.0), (moving, 1.0)],
            500.0,
        );
        assert_eq!(w[0], 500.0);
        assert!((w[1] - 25.0).abs() < 1e-6, "{w:?}");
        // Sampling of 2 / 1e12 + 1 / 1e12: still 25 to 1e-6.
        assert!((w[2] - 25.0).abs() < 1e-6, "{w:?}");
    }
}
