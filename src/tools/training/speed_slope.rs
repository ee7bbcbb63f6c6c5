//! How a test's residual moves with the ship's own speed on the class (the module doc of
//! `helmwatch_core::fdi::raw`, "The speed's slope"), measured for `calibration.json`'s
//! `speed-slope`, `slope-speed` and `slope-speed-gain` at the class's fixed points
//! (`calibrate::scatter_points`).

use super::calibrate::{calibration_probe, completed, reading, SCATTER_REPEATS};
use super::database::{par_map, Point};
use crate::config::Config;
use helmwatch_core::estimator::Estimator;
use helmwatch_core::fdi::config::SpeedSlope;
use helmwatch_core::fdi::stats::P;
use helmwatch_core::model::SeaState;
use helmwatch_core::wire::Method;
use std::sync::Arc;

/// The true speed's step each side of a point for [`speed_slope`] [m/s]: the larger
/// changes of speed the watch follows (up to 2 m/s), over which the slope is read.
pub const SPEED_STEP_MPS: f64 = 1.0;

/// One pair's reading at a point: the true slope of `(e_u, e_D, e_b)` per m/s and the
/// similarity law's (the mean of the two tests' own `speed_slope`).
type SlopePair = ([f64; P], [f64; P]);

/// One sea's component: the class's mean slope, and `(m, se)` ([`mean_product`]) about the
/// law and about that mean.
type Centres = (f64, (f64, f64), (f64, f64));

/// The estimate of `E[d^2]` from two independent readings `y1 = d + n1`, `y2 = d + n2` at
/// each point: `(m, se)`, `m` the mean of `y1 y2` (the noise out) and `se` its standard
/// error.
fn mean_product(products: &[f64]) -> (f64, f64) {
    let n = products.len() as f64;
    let m = products.iter().sum::<f64>() / n;
    let var = products.iter().map(|p| (p - m).powi(2)).sum::<f64>() / (n - 1.0);
    (m, (var / n).sqrt())
}

/// The prior variance from [`mean_product`]'s `(m, se)`: `max(m, 0) + se`, the upper one-sigma (a class
/// that follows its centre exactly keeps a prior of its measurement's resolution).
fn prior_variance((m, se): (f64, f64)) -> f64 {
    m.max(0.0) + se
}

/// How the residual moves with the ship's speed on the class (`helmwatch_core::fdi::raw`,
/// "The speed's slope"): at each of `points`, two pairs of seeded tests on independent
/// seeds, each pair one test at the point's speed [`SPEED_STEP_MPS`] faster and one as much
/// slower on one seed (common random numbers). Per method, sea and component, the scatter
/// of the true slope over the points about two centres, the similarity law at each point
/// and the class's mean slope ([`mean_product`]); per method and component the class's
/// slope is kept where its scatter, summed over the seas, is smaller than the law's by more
/// than twice the difference's standard error (physics unless the class shows otherwise:
/// a hull outside the class follows the law, not the class's networks). Returns
/// the slopes and the prior sd about the centre kept, the largest over methods and seas:
/// `(speed_slope, [e_u, e_D], e_b)`.
pub fn speed_slope(
    cfg: &Config,
    estimator: Arc<Estimator>,
    points: &[Point],
    threads: usize,
) -> Option<(SpeedSlope, [f64; 2], f64)> {
    let mut sd = [0.0f64; P];
    let mut per_method = |method: Method| -> Option<[Option<[f64; 2]>; P]> {
        let opts = calibration_probe(cfg, method, &estimator);
        let pair = |p: &Point, seed: u64| -> Option<SlopePair> {
            let at = |du: f64| {
                let q = Point {
                    speed_mps: p.speed_mps + du,
                    ..*p
                };
                let r = completed(cfg, &q, seed, Vec::new(), &opts)?;
                let raw = r.residuals.raw?;
                let mut e = reading(&r, p.displacement_t)?;
                e[0] -= raw.speed_log_mps;
                Some((e, raw.speed_slope, raw.speed_log_mps))
            };
            let du = SPEED_STEP_MPS.min(0.4 * p.speed_mps);
            let ((hi, s_hi, u_hi), (lo, s_lo, u_lo)) = (at(du)?, at(-du)?);
            let t: [f64; P] = std::array::from_fn(|j| (hi[j] - lo[j]) / (u_hi - u_lo));
            let law: [f64; P] = std::array::from_fn(|j| 0.5 * (s_hi[j] + s_lo[j]));
            t.iter()
                .chain(&law)
                .all(|x| x.is_finite())
                .then_some((t, law))
        };
        // Seeds the scatter's repeats and the displacement's direction do not use.
        let pairs = par_map(points.len(), threads, |i| {
            let p = &points[i];
            let first = pair(p, p.seed.wrapping_add(SCATTER_REPEATS as u64 + 1))?;
            Some((
                first,
                pair(p, p.seed.wrapping_add(SCATTER_REPEATS as u64 + 2))?,
            ))
        });
        // Per sea and component: the class's mean slope, and the two centres' variances.
        let mut by_sea = Vec::new();
        for sea in [SeaState::Calm, SeaState::Moderate] {
            let of: Vec<(SlopePair, SlopePair)> = (0..points.len())
                .filter(|&i| points[i].sea == sea)
                .filter_map(|i| pairs[i])
                .collect();
            if of.len() < 3 {
                return None;
            }
            let n = of.len() as f64;
            let per: [Centres; P] = std::array::from_fn(|j| {
                let mean = of.iter().map(|(a, b)| a.0[j] + b.0[j]).sum::<f64>() / (2.0 * n);
                let about = |c: &dyn Fn(&SlopePair) -> f64| -> (f64, f64) {
                    let products: Vec<f64> = of
                        .iter()
                        .map(|(a, b)| (a.0[j] - c(a)) * (b.0[j] - c(b)))
                        .collect();
                    mean_product(&products)
                };
                (mean, about(&|x| x.1[j]), about(&|_| mean))
            });
            by_sea.push(per);
        }
        Some(std::array::from_fn(|j| {
            // Over the seas: the law's excess over the class's, and its standard error.
            let excess: f64 = by_sea.iter().map(|s| s[j].1 .0 - s[j].2 .0).sum();
            let se = by_sea
                .iter()
                .map(|s| s[j].1 .1.powi(2) + s[j].2 .1.powi(2))
                .sum::<f64>()
                .sqrt();
            let keep = excess > 2.0 * se;
            for sea in &by_sea {
                sd[j] = sd[j].max(prior_variance(if keep { sea[j].2 } else { sea[j].1 }).sqrt());
            }
            keep.then(|| [by_sea[0][j].0, by_sea[1][j].0])
        }))
    };
    let slope = SpeedSlope {
        clfrt: per_method(Method::Clfrt)?,
        hbt: per_method(Method::Hbt)?,
    };
    Some((slope, [sd[0], sd[1]], sd[2]))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two readings of each point's deviation on independent noise, 8000 draws of 60
    /// points. With the noise three times the deviation's sd, [`mean_product`] takes it
    /// out (the mean of `m` within 5 % of `E[d^2]`, where the plain mean square is 10x it).
    /// With the noise the deviation's size (so that the standard error is below `E[d^2]`),
    /// `m` plus its standard error is at or above `E[d^2]` in about 84 % of draws (the upper
    /// one-sigma): two-sided within 6 points, for the products are skewed (a product of two
    /// normals) and the mean of 60 is not yet normal (8000 draws: the share's own sd 0.4
    /// points).
    #[test]
    fn the_two_seed_product_takes_the_noise_out_of_the_deviation() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        // Box and Muller's normal draw.
        let mut normal = |sd: f64| -> f64 {
            let (a, b): (f64, f64) = (rng.gen(), rng.gen());
            sd * (-2.0 * (1.0 - a).ln()).sqrt() * (std::f64::consts::TAU * b).cos()
        };
        let sd: f64 = 0.01;
        let truth = sd * sd;
        let (draws, points) = (8000, 60);
        // (the mean of m, the plain mean square, the share the upper one-sigma covers)
        let mut run = |noise: f64| -> (f64, f64, f64) {
            let (mut sum_m, mut sum_plain, mut covered) = (0.0, 0.0, 0);
            for _ in 0..draws {
                let pairs: Vec<(f64, f64)> = (0..points)
                    .map(|_| {
                        let x = normal(sd);
                        (x + normal(noise), x + normal(noise))
                    })
                    .collect();
                let products: Vec<f64> = pairs.iter().map(|(a, b)| a * b).collect();
                sum_m += products.iter().sum::<f64>() / points as f64;
                sum_plain += pairs.iter().map(|(a, _)| a * a).sum::<f64>() / points as f64;
                covered += usize::from(prior_variance(mean_product(&products)) >= truth);
            }
            let n = draws as f64;
            (sum_m / n, sum_plain / n, covered as f64 / n)
        };
        let (m, plain, _) = run(3.0 * sd);
        assert!(
            (m - truth).abs() <= 0.05 * truth,
            "mean product {m:e} against {truth:e}"
        );
        assert!(plain > 8.0 * truth, "the plain mean square {plain:e}");
        let (_, _, share) = run(sd);
        assert!(
            (0.78..=0.90).contains(&share),
            "upper one-sigma covers {share}"
        );
    }
}
