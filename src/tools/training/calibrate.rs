//! The calibration `train` writes beside the networks (`calibration.json`,
//! `helmwatch_core::fdi::config::Calibration`): the numbers that describe the estimator on the
//! class of hull the database was drawn from.
//!
//! Measured on the database: the sea index's anchors, the median wave yaw of the completed
//! tests in a calm and in a moderate sea [deg] (the heading's rms in the wave band: how the
//! class's hulls answer the seas the networks were trained in). Measured on seeded tests at
//! the class's fixed points ([`scatter_points`]): the healthy scatter, the displacement's
//! direction, and the speed's slope with its prior sd (`super::speed_slope`). The others are
//! carried from the calibration in force (the shipped models' unless a models directory is
//! given): they describe hulls and servos beyond the simulated class (the commissioning
//! spreads, the servo's spread, the other slope priors), which one class's simulations
//! cannot measure.

use super::database::{design, par_map, Database, DatabaseSpec, Point, Purpose};
use crate::config::Config;
use helmwatch_core::drivers::probe::{run_probe, ProbeOptions};
use helmwatch_core::estimator::Estimator;
use helmwatch_core::fdi::config::Calibration;
use helmwatch_core::fdi::config::DisplacementDirection;
use helmwatch_core::fdi::prior::{ClassScatter, PointVariance, ScatterPrior};
use helmwatch_core::fdi::sensitivity::ln_gain;
use helmwatch_core::fdi::stats::{median, Cov, P};
use helmwatch_core::model::SeaState;
use helmwatch_core::monitor::Monitor;
use helmwatch_core::sim::fault::{Fault, FaultKind};
use helmwatch_core::sim::Scenario;
use helmwatch_core::wire::{Method, Outcome, Report};
use std::sync::Arc;

/// Operating points per sea the healthy scatter is measured at.
pub const SCATTER_POINTS: usize = 60;
/// Seeded repeats at each: the scatter of one vessel at one point.
pub const SCATTER_REPEATS: usize = 10;

/// The probe options of the calibration's seeded tests: `method`, read by the class's
/// `estimator`, with the multisine designed once (not per test).
pub(super) fn calibration_probe(
    cfg: &Config,
    method: Method,
    estimator: &Arc<Estimator>,
) -> ProbeOptions {
    let core = cfg.core();
    let mut opts = ProbeOptions::new(&core, method);
    opts.estimator = Some(estimator.clone());
    opts.multisine = Monitor::design_multisine(&core).ok();
    opts
}

/// The median wave yaw [deg] of the completed tests of `db` in `sea`, both methods.
pub fn wave_yaw_deg(db: &Database, sea: SeaState) -> f64 {
    let mut v = db
        .spec
        .methods
        .iter()
        .flat_map(|&m| db.completed(m))
        .filter(|(i, _)| db.points[*i].sea == sea)
        .filter_map(|(_, f)| f.wave_yaw_rad())
        .filter(|w| w.is_finite())
        .map(f64::to_degrees)
        .collect::<Vec<_>>();
    median(&mut v)
}

/// `base` with what `db` measures (the module doc); a sea the database lacks keeps its
/// anchor, and anchors that would not increase keep both.
pub fn calibrate(db: &Database, base: &Calibration) -> Calibration {
    let anchors = [
        wave_yaw_deg(db, SeaState::Calm),
        wave_yaw_deg(db, SeaState::Moderate),
    ];
    let mut c = base.clone();
    let measured = [
        if anchors[0].is_finite() && anchors[0] > 0.0 {
            anchors[0]
        } else {
            base.sea_wave_yaw_deg[0]
        },
        if anchors[1].is_finite() {
            anchors[1]
        } else {
            base.sea_wave_yaw_deg[1]
        },
    ];
    if measured[1] > measured[0] {
        c.sea_wave_yaw_deg = measured;
    }
    c
}

/// One completed test at `point` with `faults` from its start (`None`: not completed).
pub(super) fn completed(
    cfg: &Config,
    point: &Point,
    seed: u64,
    faults: Vec<Fault>,
    opts: &ProbeOptions,
) -> Option<Report> {
    let sc = Scenario {
        speed_mps: point.speed_mps,
        displacement_t: point.displacement_t,
        sea: point.sea,
        faults,
        seed,
    };
    let mut sim = cfg.sim();
    if let Some(m) = &point.ship {
        m.apply(&mut sim.structure, &mut sim.autopilot);
    }
    let r = run_probe(&cfg.core(), &sim, &sc, opts).ok()?.report;
    (r.outcome == Outcome::Completed).then_some(r)
}

/// One healthy test's residual `e` and design spreads `s` (`None`: not completed, or a
/// component missing).
fn residual(
    cfg: &Config,
    point: &Point,
    seed: u64,
    opts: &ProbeOptions,
) -> Option<([f64; P], [f64; P])> {
    let raw = completed(cfg, point, seed, Vec::new(), opts)?
        .residuals
        .raw?;
    let e = [raw.speed_mps, raw.displacement, raw.ln_gain?];
    let s = [
        raw.speed_sigma_mps,
        raw.displacement_sigma,
        raw.displacement_sigma,
    ];
    e.iter().chain(&s).all(|v| v.is_finite()).then_some((e, s))
}

/// A point's tests in design-spread units: each residual over the point's median spread
/// (the spreads follow each test's measured sea; the scatter at one point is that of `e`).
fn normalised(tests: &[([f64; P], [f64; P])]) -> Vec<[f64; P]> {
    let s: [f64; P] = std::array::from_fn(|j| {
        let mut v: Vec<f64> = tests.iter().map(|t| t.1[j]).collect();
        median(&mut v)
    });
    tests
        .iter()
        .map(|(e, _)| std::array::from_fn(|j| e[j] / s[j]))
        .collect()
}

/// The scatter matrix about their mean and its dof of one point's repeats.
fn scatter(zs: &[[f64; P]]) -> Option<(Cov, f64)> {
    let n = zs.len();
    if n < 3 {
        return None;
    }
    let mean: [f64; P] = std::array::from_fn(|j| zs.iter().map(|z| z[j]).sum::<f64>() / n as f64);
    let mut a = [[0.0; P]; P];
    for z in zs {
        for (i, row) in a.iter_mut().enumerate() {
            for (j, v) in row.iter_mut().enumerate() {
                *v += (z[i] - mean[i]) * (z[j] - mean[j]);
            }
        }
    }
    Some((Cov(a), (n - 1) as f64))
}

/// The class prior of one method and sea from each point's repeats (`fdi::prior`): `Psi`,
/// the pooled within-point covariance, and its weight (`ClassScatter::weight`).
fn pooled(points: &[Vec<[f64; P]>]) -> Option<(Cov, [f64; P])> {
    let per: Vec<(&Vec<[f64; P]>, Cov, f64)> = points
        .iter()
        .filter_map(|z| scatter(z).map(|(a, d)| (z, a, d)))
        .collect();
    let total: f64 = per.iter().map(|p| p.2).sum();
    if per.len() < 2 {
        return None;
    }
    let psi = per
        .iter()
        .fold(Cov::default(), |acc, p| acc.plus(p.1))
        .times(1.0 / total);
    let components: [(Vec<PointVariance>, f64); P] = std::array::from_fn(|j| {
        let vars: Vec<PointVariance> = per
            .iter()
            .map(|(z, a, d)| (a.at(j, j) / d, *d, z.len() as f64))
            .collect();
        // The excess kurtosis of the tests about their point, each in its point's own
        // units (the points' scales differ).
        let (mut m4, mut m2) = (0.0, 0.0);
        for (z, a, d) in &per {
            let v = a.at(j, j) / d;
            let mean = z.iter().map(|x| x[j]).sum::<f64>() / z.len() as f64;
            for x in z.iter() {
                let u = (x[j] - mean).powi(2) / v;
                m2 += u;
                m4 += u * u;
            }
        }
        // Less the normal's own at that many repeats (`3 (R - 1) / (R + 1)`: a point's
        // kurtosis in its own units is biased low).
        let n = per.iter().map(|p| p.0.len()).sum::<usize>() as f64;
        let r = n / per.len() as f64;
        (
            vars,
            (m4 / n) / (m2 / n).powi(2) - 3.0 * (r - 1.0) / (r + 1.0),
        )
    });
    Some((psi, ClassScatter::weight(&components, total)))
}

/// The operating points the class's scatter and direction are measured at:
/// [`SCATTER_POINTS`] per sea of their own Latin hypercube (each its own ship of the family
/// with `family`).
pub fn scatter_points(cfg: &Config, family: bool, seed: u64) -> Vec<Point> {
    let spec = DatabaseSpec {
        seed,
        purpose: Purpose::Scatter,
        points_per_sea: SCATTER_POINTS,
        seas: vec![SeaState::Calm, SeaState::Moderate],
        methods: vec![Method::Clfrt, Method::Hbt],
        faults: Vec::new(),
        family,
    };
    design(cfg, &spec)
}

/// The estimator's healthy scatter on the class (`helmwatch_core::fdi::prior`): per sea,
/// [`SCATTER_POINTS`] operating points of their own Latin hypercube (each its own ship of
/// the family with `family`), [`SCATTER_REPEATS`] seeded tests of each method at each;
/// `Psi` the pooled within-point covariance of `z = e / s`, `nu_0` from how the points'
/// scale moves (`ClassScatter::weight`), the smaller of the two seas'.
pub fn healthy_scatter(
    cfg: &Config,
    estimator: Arc<Estimator>,
    family: bool,
    seed: u64,
    threads: usize,
) -> Option<ScatterPrior> {
    let points = scatter_points(cfg, family, seed);
    let per_method = |method: Method| -> Option<ClassScatter> {
        let opts = calibration_probe(cfg, method, &estimator);
        let jobs = points.len() * SCATTER_REPEATS;
        let z = par_map(jobs, threads, |j| {
            let p = &points[j / SCATTER_REPEATS];
            let k = (j % SCATTER_REPEATS) as u64;
            residual(cfg, p, p.seed.wrapping_add(k), &opts)
        });
        let sea = |s: SeaState| -> Option<(Cov, [f64; P])> {
            let groups: Vec<Vec<[f64; P]>> = (0..points.len())
                .filter(|&i| points[i].sea == s)
                .map(|i| {
                    let tests: Vec<([f64; P], [f64; P])> = z
                        [i * SCATTER_REPEATS..(i + 1) * SCATTER_REPEATS]
                        .iter()
                        .flatten()
                        .copied()
                        .collect();
                    normalised(&tests)
                })
                .collect();
            pooled(&groups)
        };
        let (calm, moderate) = (sea(SeaState::Calm)?, sea(SeaState::Moderate)?);
        Some(ClassScatter {
            calm: calm.0 .0,
            moderate: moderate.0 .0,
            dof: std::array::from_fn(|j| calm.1[j].min(moderate.1[j])),
        })
    };
    Some(ScatterPrior {
        clfrt: per_method(Method::Clfrt)?,
        hbt: per_method(Method::Hbt)?,
    })
}

/// The true displacement's step each side of the declared one for
/// [`displacement_direction`] [%]: the size of the smallest fault the decision must find.
pub const DIRECTION_STEP_PCT: f64 = 10.0;

/// `(e_u [m/s], e_D [fraction of the declared], e_b [ln])` as the networks read `r`.
pub(super) fn reading(r: &Report, declared_t: f64) -> Option<[f64; P]> {
    let e = r.estimate.as_ref()?;
    let v = [
        e.speed_mps,
        e.displacement_t / declared_t,
        ln_gain(&r.features)?,
    ];
    v.iter().all(|x| x.is_finite()).then_some(v)
}

/// The displacement's direction on the class (`helmwatch_core::fdi::raw`, module doc): at
/// each of `points` (the healthy scatter's, [`scatter_points`]), one seeded test with the
/// true displacement [`DIRECTION_STEP_PCT`] above the declared and one the same below, the
/// same seed (common random numbers: the sea and the sensors' noise cancel), their
/// difference per unit of `ln D`; per method and sea the median of each component over the
/// points.
pub fn displacement_direction(
    cfg: &Config,
    estimator: Arc<Estimator>,
    points: &[Point],
    threads: usize,
) -> Option<DisplacementDirection> {
    let step = DIRECTION_STEP_PCT;
    let per_ln_d = ((1.0 + step / 100.0) / (1.0 - step / 100.0)).ln();
    let per_method = |method: Method| -> Option<[[f64; P]; 2]> {
        let opts = calibration_probe(cfg, method, &estimator);
        let slopes = par_map(points.len(), threads, |i| {
            let p = &points[i];
            // Both ends one seed, one the scatter's repeats do not use.
            let seed = p.seed.wrapping_add(SCATTER_REPEATS as u64);
            let at = |pct: f64| {
                let fault = Fault::new(FaultKind::DisplacementPct, pct, 0.0).ok()?;
                let r = completed(cfg, p, seed, vec![fault], &opts)?;
                reading(&r, p.displacement_t)
            };
            let (hi, lo) = (at(step)?, at(-step)?);
            Some(std::array::from_fn::<f64, P, _>(|j| {
                (hi[j] - lo[j]) / per_ln_d
            }))
        });
        let sea = |s: SeaState| -> Option<[f64; P]> {
            let of: Vec<[f64; P]> = (0..points.len())
                .filter(|&i| points[i].sea == s)
                .filter_map(|i| slopes[i])
                .collect();
            (!of.is_empty()).then(|| {
                std::array::from_fn(|j| {
                    let mut v: Vec<f64> = of.iter().map(|x| x[j]).collect();
                    median(&mut v)
                })
            })
        };
        Some([sea(SeaState::Calm)?, sea(SeaState::Moderate)?])
    };
    let d = DisplacementDirection {
        clfrt: per_method(Method::Clfrt)?,
        hbt: per_method(Method::Hbt)?,
    };
    let reads = |m: [[f64; P]; 2]| {
        m.iter()
            .all(|v| v.iter().all(|x| x.is_finite()) && v[1] > 0.0)
    };
    (reads(d.clfrt) && reads(d.hbt)).then_some(d)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A database of CLFRT tests whose wave yaw is known: the anchors are the medians of
    /// each sea's, a failed test and a rough sea's left out; a database without a moderate
    /// sea keeps that anchor.
    #[test]
    fn the_sea_anchors_are_the_medians_of_the_databases_wave_yaw() {
        use crate::tools::training::database::{DatabaseSpec, Point, Purpose, TestRun};
        use helmwatch_core::testing::sample;
        use helmwatch_core::wire::{Features, Method};
        let test = |deg: f64| TestRun {
            features: Ok(Features::Clfrt(
                helmwatch_core::wire::features::ClfrtFeatures {
                    wave_yaw_rad: Some(f64::to_radians(deg)),
                    ..sample::clfrt(vec![])
                },
            )),
            duration_s: 1200.0,
        };
        let point = |sea| Point {
            sea,
            speed_mps: 7.0,
            displacement_t: 7000.0,
            seed: 1,
            ship: None,
        };
        let seas = [
            (SeaState::Calm, 0.04),
            (SeaState::Calm, 0.06),
            (SeaState::Calm, 0.05),
            (SeaState::Moderate, 0.2),
            (SeaState::Moderate, 0.3),
            (SeaState::Rough, 0.9),
        ];
        let mut runs: Vec<TestRun> = seas.iter().map(|&(_, d)| test(d)).collect();
        runs.push(TestRun {
            features: Err("aborted".into()),
            duration_s: f64::NAN,
        });
        let mut points: Vec<Point> = seas.iter().map(|&(s, _)| point(s)).collect();
        points.push(point(SeaState::Calm));
        let db = Database {
            spec: DatabaseSpec {
                seed: 1,
                purpose: Purpose::Training,
                points_per_sea: 3,
                seas: vec![SeaState::Calm, SeaState::Moderate, SeaState::Rough],
                methods: vec![Method::Clfrt],
                faults: vec![],
                family: false,
            },
            points,
            runs: vec![runs],
        };
        let base = Calibration::default();
        let c = calibrate(&db, &base);
        approx::assert_relative_eq!(c.sea_wave_yaw_deg[0], 0.05, max_relative = 1e-12);
        approx::assert_relative_eq!(c.sea_wave_yaw_deg[1], 0.25, max_relative = 1e-12);
        assert_eq!(
            Calibration {
                sea_wave_yaw_deg: base.sea_wave_yaw_deg,
                ..c
            },
            base
        );
        let calm_only = Database {
            points: db.points[..3].to_vec(),
            runs: vec![db.runs[0][..3].to_vec()],
            ..db
        };
        let c = calibrate(&calm_only, &base);
        approx::assert_relative_eq!(c.sea_wave_yaw_deg[0], 0.05, max_relative = 1e-12);
        assert_eq!(c.sea_wave_yaw_deg[1], base.sea_wave_yaw_deg[1]);
    }

    /// On the design's Nomoto class `D` enters `b` alone, so the direction measured by
    /// changing the true displacement must be the one the features with `b` scaled give
    /// through the same networks (`sensitivity::scale_b`, analytic), at the same points and
    /// seeds. Compared in design spreads (the units the decision whitens them in): per
    /// method and sea, each component within 20 % of the `b` scaling's norm. The noise: a
    /// point's slope is two tests' difference over 0.2 in `ln D`, at most `sqrt 2 / 0.2 =
    /// 7` spreads where their noise does not cancel; the median of eight, about 3, against
    /// a norm over 30 (`e_D` alone moves about 1 / 0.03 spreads per unit `ln D`).
    #[test]
    fn on_the_nomoto_class_the_measured_direction_is_the_b_scalings() {
        use helmwatch_core::fdi::sensitivity::scale_b;
        let cfg = Config::default();
        let estimator = Arc::new(Estimator::embedded(&cfg.core()).unwrap());
        // Eight seeds at one point per sea: the medians' noise well under the tolerance.
        const SEEDS: u64 = 8;
        let points: Vec<Point> = [
            (SeaState::Calm, 6.0, 6000.0),
            (SeaState::Moderate, 8.0, 8000.0),
        ]
        .iter()
        .flat_map(|&(sea, speed_mps, displacement_t)| {
            (0..SEEDS).map(move |seed| Point {
                sea,
                speed_mps,
                displacement_t,
                seed: 11 + seed,
                ship: None,
            })
        })
        .collect();
        let measured = displacement_direction(&cfg, estimator.clone(), &points, 2).unwrap();
        for method in [Method::Clfrt, Method::Hbt] {
            let opts = calibration_probe(&cfg, method, &estimator);
            let b_scaling = |p: &Point| -> ([f64; P], [f64; P]) {
                let seed = p.seed.wrapping_add(SCATTER_REPEATS as u64);
                let r = completed(&cfg, p, seed, Vec::new(), &opts).unwrap();
                let base = reading(&r, p.displacement_t).unwrap();
                let step: f64 = 0.01;
                let f = scale_b(&r.features, (-step).exp()).unwrap();
                let e = estimator
                    .estimate(method, &f, &mut estimator.scratch())
                    .unwrap();
                let raw = r.residuals.raw.unwrap();
                let s = raw.displacement_sigma;
                let b = [
                    (e.speed_mps - base[0]) / step,
                    (e.displacement_t / p.displacement_t - base[1]) / step,
                    (ln_gain(&f).unwrap() - base[2]) / step,
                ];
                (b, [raw.speed_sigma_mps, s, s])
            };
            let mid = |v: &[([f64; P], [f64; P])], j: usize, which: usize| {
                median(&mut v.iter().map(|x| [x.0, x.1][which][j]).collect::<Vec<_>>())
            };
            for (k, sea) in points.chunks(SEEDS as usize).enumerate() {
                let each: Vec<([f64; P], [f64; P])> = sea.iter().map(b_scaling).collect();
                // In design spreads, the units the decision whitens them in.
                let z =
                    |v: [f64; P]| -> [f64; P] { std::array::from_fn(|j| v[j] / mid(&each, j, 1)) };
                let b = z(std::array::from_fn(|j| mid(&each, j, 0)));
                let m = z(measured.of(method)[k]);
                let norm = b.iter().map(|x| x * x).sum::<f64>().sqrt();
                for j in 0..P {
                    assert!(
                        (m[j] - b[j]).abs() <= 0.2 * norm,
                        "{method:?} {:?} component {j}: measured {m:?}, b scaling {b:?}",
                        sea[0].sea
                    );
                }
            }
        }
    }

    #[test]
    fn the_median_is_the_middle_value() {
        assert_eq!(median(&mut [3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(&mut [4.0, 1.0, 2.0, 3.0]), 2.5);
        assert!(median(&mut []).is_nan());
    }
}
