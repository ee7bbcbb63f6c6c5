//! Accuracy of trained models on a held-out database, against the paper and the targets.
//!
//! For a method `m`, a sea state and a parameter `y` (speed or displacement) with range
//! `[y_min, y_max]`, over the completed tests of a held-out database (drawn on its own random
//! streams, independent of the training database):
//!
//! ```text
//! MSE  = mean( ((y_est - y) / h)^2 ),   h = (y_max - y_min) / 2     the [-1, 1] scale
//! RMSE = sqrt(mean((y_est - y)^2))                                   [m/s] or [t]
//! bias = mean(y_est - y)
//! ```
//!
//! The paper's Table I gives one MSE per method after 100 epochs of `traincgf` (units
//! unstated; we compare on the [-1, 1] scale): 0.0989 for CLFRT, 0.1209 for HBT. The issue's
//! targets ([`target_mse`]) are per method, sea state and parameter. Failed tests (aborted,
//! refused) are counted and left out.

use crate::tools::training::database::Database;
use helmwatch_core::estimator::model::{Model, Target};
use helmwatch_core::estimator::nn::Scratch;
use helmwatch_core::model::SeaState;
use helmwatch_core::wire::Method;
use std::fmt::Write as _;

/// The paper's Table I MSE for `method` (traincgf, 100 epochs).
pub fn paper_mse(method: Method) -> f64 {
    match method {
        Method::Clfrt => 0.0989,
        Method::Hbt => 0.1209,
    }
}

/// The acceptance target on the [-1, 1] MSE (issue 4), where one is set.
pub fn target_mse(method: Method, sea: SeaState, target: Target) -> Option<f64> {
    use SeaState::*;
    use Target::*;
    match (method, sea, target) {
        (Method::Clfrt, Calm, Speed) => Some(0.002),
        (Method::Clfrt, Calm, Displacement) => Some(0.001),
        (Method::Clfrt, Moderate, Speed) => Some(0.015),
        (Method::Clfrt, Moderate, Displacement) => Some(0.002),
        (Method::Hbt, Calm, Speed) => Some(0.008),
        (Method::Hbt, Calm, Displacement) => Some(0.0015),
        (Method::Hbt, Moderate, Speed) => Some(0.025),
        (Method::Hbt, Moderate, Displacement) => Some(0.006),
        _ => None,
    }
}

/// Accuracy of one model on one sea state's tests.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cell {
    /// Method.
    pub method: Method,
    /// Sea state.
    pub sea: SeaState,
    /// Estimated parameter.
    pub target: Target,
    /// Completed tests used.
    pub n: usize,
    /// Tests that did not complete or lacked a feature.
    pub failed: usize,
    /// MSE on the [-1, 1] scale.
    pub mse: f64,
    /// RMSE in m/s or t.
    pub rmse: f64,
    /// Mean error in m/s or t.
    pub bias: f64,
}

/// Accuracy of each model on every sea state of `db`, in the order (model, sea state of the
/// database).
pub fn accuracy(models: &[Model], db: &Database) -> Vec<Cell> {
    let mut cells = Vec::new();
    let mut x = Vec::new();
    for model in models {
        let (method, target) = (model.file.method, model.file.target);
        let mut s = Scratch::new(model.inputs.len());
        let (y_min, y_max) = (model.scaling.y_min, model.scaling.y_max);
        let h = 0.5 * (y_max - y_min);
        for &sea in &db.spec.seas {
            let mut errs = Vec::new();
            let mut failed = 0;
            for (i, run) in db.runs_of(method).iter().enumerate() {
                let p = &db.points[i];
                if p.sea != sea {
                    continue;
                }
                let truth = match target {
                    Target::Speed => p.speed_mps,
                    Target::Displacement => p.displacement_t,
                };
                match run
                    .features
                    .as_ref()
                    .ok()
                    .and_then(|f| model.predict_features(f, &mut x, &mut s).ok())
                {
                    Some(est) => errs.push(est - truth),
                    None => failed += 1,
                }
            }
            let n = errs.len();
            let nf = n.max(1) as f64;
            let ms = errs.iter().map(|e| e * e).sum::<f64>() / nf;
            cells.push(Cell {
                method,
                sea,
                target,
                n,
                failed,
                mse: if n > 0 { ms / (h * h) } else { f64::NAN },
                rmse: if n > 0 { ms.sqrt() } else { f64::NAN },
                bias: if n > 0 {
                    errs.iter().sum::<f64>() / nf
                } else {
                    f64::NAN
                },
            });
        }
    }
    cells
}

/// The cell of (`method`, `sea`, `target`).
pub fn find(cells: &[Cell], method: Method, sea: SeaState, target: Target) -> Option<&Cell> {
    cells
        .iter()
        .find(|c| c.method == method && c.sea == sea && c.target == target)
}

/// Test durations of a method in a sea state: (completed, mean, max) [s].
pub fn durations(db: &Database, method: Method, sea: SeaState) -> (usize, f64, f64) {
    let d: Vec<f64> = db
        .runs_of(method)
        .iter()
        .zip(&db.points)
        .filter(|(r, p)| p.sea == sea && r.features.is_ok() && r.duration_s.is_finite())
        .map(|(r, _)| r.duration_s)
        .collect();
    let n = d.len();
    let mean = d.iter().sum::<f64>() / n.max(1) as f64;
    let max = d.iter().copied().fold(f64::NAN, f64::max);
    (n, mean, max)
}

/// The accuracy table: one row per method, sea state and parameter, with the paper's MSE,
/// the target, and one MSE / RMSE column pair per trainer (`labelled` = (label, cells)).
pub fn table(labelled: &[(&str, &[Cell])], seas: &[SeaState]) -> String {
    let mut out = String::new();
    let _ = write!(
        out,
        "| method | sea | parameter | n | paper Table I | target |"
    );
    for (label, _) in labelled {
        let _ = write!(out, " {label} MSE | {label} RMSE |");
    }
    out.push('\n');
    let _ = write!(out, "|---|---|---|---:|---:|---:|");
    for _ in labelled {
        out.push_str("---:|---:|");
    }
    out.push('\n');
    for method in [Method::Clfrt, Method::Hbt] {
        for &sea in seas {
            for target in Target::ALL {
                let n = labelled
                    .first()
                    .and_then(|(_, c)| find(c, method, sea, target))
                    .map_or(0, |c| c.n);
                let tgt =
                    target_mse(method, sea, target).map_or("-".to_string(), |t| format!("<= {t}"));
                let _ = write!(
                    out,
                    "| {} | {} | {} | {n} | {:.4} | {tgt} |",
                    method.name().to_uppercase(),
                    sea.name(),
                    target.name(),
                    paper_mse(method),
                );
                for (_, cells) in labelled {
                    match find(cells, method, sea, target) {
                        Some(c) => {
                            let ok = match target_mse(method, sea, target) {
                                Some(t) if c.mse <= t => " ok",
                                Some(_) => " MISS",
                                None => "",
                            };
                            let _ =
                                write!(out, " {:.5}{ok} | {} |", c.mse, fmt_unit(c.rmse, target));
                        }
                        None => out.push_str(" - | - |"),
                    }
                }
                out.push('\n');
            }
        }
    }
    out
}

/// A value in the target's unit, with the unit.
pub fn fmt_unit(v: f64, target: Target) -> String {
    match target {
        Target::Speed => format!("{v:.3} m/s"),
        Target::Displacement => format!("{v:.0} t"),
    }
}

/// The accuracy of `models` on each member of the family of real ships
/// ([`helmwatch_core::sim::config::family`]): the held-out database of `spec` simulated on ships of
/// each structure (the monitor and the models unchanged), in family order.
pub fn family_accuracy(
    cfg: &crate::config::Config,
    models: &[Model],
    spec: &crate::tools::training::database::DatabaseSpec,
    threads: usize,
) -> Vec<(&'static str, Vec<Cell>, f64)> {
    helmwatch_core::sim::config::family()
        .into_iter()
        .map(|m| {
            let mut c = cfg.clone();
            m.apply(&mut c.structure, &mut c.autopilot);
            let db = crate::tools::training::database::simulate(&c, spec, threads, &|_, _| {});
            let runs: Vec<_> = db.runs.iter().flatten().collect();
            let completed = runs.iter().filter(|r| r.features.is_ok()).count();
            let rate = completed as f64 / runs.len().max(1) as f64;
            (m.name, accuracy(models, &db), rate)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tools::training::database::{DatabaseSpec, Point, Purpose, TestRun};
    use helmwatch_core::estimator::nn::Scratch;
    use helmwatch_core::testing::sample_model;

    #[test]
    fn accuracy_matches_a_hand_computation() {
        // One displacement model, three tests with known features: MSE and RMSE by hand.
        let model = sample_model();
        let mk = |g: f64, sp: f64| {
            use helmwatch_core::testing::sample;
            let mut c = sample::clfrt(vec![
                sample::tone(0.03, g, -2.0),
                sample::tone(0.07, g * 0.3, -2.5),
                sample::tone(0.18, g * 0.05, -2.9),
            ]);
            c.speed_log_mps = Some(sp);
            helmwatch_core::wire::Features::Clfrt(c)
        };
        let feats = [mk(2.0, 6.0), mk(1.0, 7.0), mk(0.5, 8.0)];
        let truths = [5000.0, 7000.0, 9000.0];
        let db = Database {
            spec: DatabaseSpec {
                seed: 1,
                purpose: Purpose::Evaluation,
                points_per_sea: 4,
                seas: vec![SeaState::Calm],
                methods: vec![Method::Clfrt],
                faults: vec![],
                family: false,
            },
            points: truths
                .iter()
                .chain([7000.0].iter())
                .map(|&d| Point {
                    sea: SeaState::Calm,
                    speed_mps: 7.0,
                    displacement_t: d,
                    seed: 0,
                    ship: None,
                })
                .collect(),
            runs: vec![feats
                .iter()
                .map(|f| TestRun {
                    features: Ok(f.clone()),
                    duration_s: 1700.0,
                })
                .chain([TestRun {
                    features: Err("aborted".into()),
                    duration_s: f64::NAN,
                }])
                .collect()],
        };
        let models = vec![model.clone()];
        let cells = accuracy(&models, &db);
        let c = find(&cells, Method::Clfrt, SeaState::Calm, Target::Displacement).unwrap();
        let mut x = Vec::new();
        let mut s = Scratch::new(model.inputs.len());
        let errs: Vec<f64> = feats
            .iter()
            .zip(truths)
            .map(|(f, t)| model.predict_features(f, &mut x, &mut s).unwrap() - t)
            .collect();
        let mse_raw = errs.iter().map(|e| e * e).sum::<f64>() / 3.0;
        assert_eq!(c.n, 3);
        assert_eq!(c.failed, 1);
        approx::assert_relative_eq!(c.rmse, mse_raw.sqrt(), max_relative = 1e-12);
        approx::assert_relative_eq!(c.mse, mse_raw / 3000.0f64.powi(2), max_relative = 1e-12);
        let (n, mean, max) = durations(&db, Method::Clfrt, SeaState::Calm);
        assert_eq!((n, mean, max), (3, 1700.0, 1700.0));
        let t = table(&[("LM", &cells)], &[SeaState::Calm]);
        assert!(
            t.contains("| CLFRT | calm | displacement | 3 | 0.0989 | <= 0.001 |"),
            "{t}"
        );
    }
}
