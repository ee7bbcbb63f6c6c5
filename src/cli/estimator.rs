//! The `helmwatch train` and `helmwatch eval` subcommands: thin drivers around
//! [`crate::tools::training::database`], [`crate::tools::training::build`] and
//! [`crate::tools::eval::estimator`] that print what they do.
//!
//! `train` simulates the training database (both methods at every point, calm and moderate
//! seas), trains the four networks with Levenberg-Marquardt (the shipped models, written to
//! `--out`) and with the paper's Fletcher-Reeves conjugate gradient at 100 epochs (written to
//! `--out/traincgf/`, for the comparison), and prints the records and the wall-clock time
//! (printed only: nothing time-dependent enters a file). `eval` simulates a held-out database
//! on other random streams and prints the accuracy tables, the test durations, the
//! accuracy against test length and, with `--drift`, the effect of a 1 deg/min heading drift.

use crate::cli::Failure;
use crate::config::Config;
use crate::tools::eval::estimator::{accuracy, durations, find, fmt_unit, table, target_mse, Cell};
use crate::tools::training::build::{build_models, BuildSettings};
use crate::tools::training::database::{
    default_threads, design, simulate, Database, DatabaseSpec, Purpose,
};
use helmwatch_core::estimator::model::{Model, Target};
use helmwatch_core::estimator::trainer::{CgfOptions, LmOptions, Trainer};
use helmwatch_core::estimator::{Estimator, SLOTS};
use helmwatch_core::model::SeaState;
use helmwatch_core::sim::Fault;
use helmwatch_core::wire::Method;
use std::path::PathBuf;
use std::time::Instant;

/// Latin-hypercube points per sea state of the training database (default of `--points`).
pub const DEFAULT_TRAIN_POINTS: usize = 1200;
/// Restarts per network and trainer (default of `--restarts`).
pub const DEFAULT_RESTARTS: usize = 3;
/// Held-out points per sea state for `eval` (default of `--points`).
pub const DEFAULT_EVAL_POINTS: usize = 300;
/// Sea states of the databases.
pub const SEAS: [SeaState; 2] = [SeaState::Calm, SeaState::Moderate];
/// The limit on a test's duration, settling included [s].
pub const MAX_TEST_S: f64 = 1800.0;

/// The shipped trainer: Levenberg-Marquardt.
pub fn lm_trainer() -> Trainer {
    Trainer::Lm(LmOptions {
        max_epochs: 300,
        ..LmOptions::default()
    })
}

/// The paper's trainer: Fletcher-Reeves conjugate gradient, 100 epochs.
pub fn cgf_trainer() -> Trainer {
    Trainer::Cgf(CgfOptions::default())
}

/// Options of `helmwatch train`.
#[derive(Debug, Clone)]
pub struct TrainOptions {
    /// Database and training seed.
    pub seed: u64,
    /// Output directory.
    pub out: PathBuf,
    /// Points per sea state.
    pub points: usize,
    /// Restarts per network and trainer.
    pub restarts: usize,
    /// Worker threads (None: every core).
    pub threads: Option<usize>,
    /// Draw every point's ship from the family of real ships.
    pub family: bool,
    /// Measure only the calibration of the networks in `out`.
    pub calibrate: bool,
}

/// Options of `helmwatch eval`.
#[derive(Debug, Clone)]
pub struct EvalOptions {
    /// Held-out database seed.
    pub seed: u64,
    /// Model directory.
    pub models: PathBuf,
    /// Points per sea state.
    pub points: usize,
    /// Compare with a 1 deg/min heading drift on every test.
    pub drift: bool,
    /// Print the accuracy against test length.
    pub lengths: bool,
    /// Print the accuracy on each member of the family of real ships.
    pub family: bool,
    /// Worker threads (None: every core).
    pub threads: Option<usize>,
}

/// The training database of a seed.
pub fn training_spec(seed: u64, points: usize) -> DatabaseSpec {
    DatabaseSpec {
        seed,
        purpose: Purpose::Training,
        points_per_sea: points,
        seas: SEAS.to_vec(),
        methods: vec![Method::Clfrt, Method::Hbt],
        faults: Vec::new(),
        family: false,
    }
}

/// The held-out database of a seed.
pub fn evaluation_spec(seed: u64, points: usize) -> DatabaseSpec {
    DatabaseSpec {
        purpose: Purpose::Evaluation,
        ..training_spec(seed, points)
    }
}

/// A progress printer for stderr: one line per tenth.
fn progress(label: &'static str) -> impl Fn(usize, usize) + Sync {
    move |done, total| {
        if total >= 10 && done % (total / 10) == 0 || done == total {
            eprintln!("  {label}: {done}/{total} tests");
        }
    }
}

fn print_failures(db: &Database) {
    for &m in &db.spec.methods {
        let f = db.failures(m);
        let n = db.runs_of(m).len();
        println!(
            "  {}: {} of {n} tests completed, {} failed",
            m.name(),
            n - f.len(),
            f.len()
        );
        for (i, reason) in f.iter().take(3) {
            let p = &db.points[*i];
            println!(
                "    e.g. u {:.2} m/s, D {:.0} t, {}: {reason}",
                p.speed_mps,
                p.displacement_t,
                p.sea.name()
            );
        }
    }
}

/// `helmwatch train`.
pub(crate) fn train(cfg: &Config, o: &TrainOptions) -> Result<(), Failure> {
    let t0 = Instant::now();
    let threads = o.threads.unwrap_or_else(default_threads).max(1);
    if o.calibrate {
        return recalibrate(cfg, o, threads);
    }
    let spec = DatabaseSpec {
        family: o.family,
        ..training_spec(o.seed, o.points)
    };
    println!(
        "helmwatch train: seed {}, {} Latin-hypercube points per sea state ({}), CLFRT and HBT at each, {threads} threads",
        o.seed,
        o.points,
        SEAS.map(|s| s.name()).join(", ")
    );
    let db = simulate(cfg, &spec, threads, &progress("database"));
    let t_db = t0.elapsed().as_secs_f64();
    println!(
        "database: {} tests simulated in {t_db:.1} s",
        db.points.len() * db.spec.methods.len()
    );
    print_failures(&db);
    let t1 = Instant::now();
    let trainers = [lm_trainer(), cgf_trainer()];
    let settings = BuildSettings::new(o.seed, o.restarts, threads);
    let built = build_models(cfg, &db, &settings, &trainers).map_err(Failure::software)?;
    let t_train = t1.elapsed().as_secs_f64();
    let dirs = [o.out.clone(), o.out.join("traincgf")];
    for (models, dir) in built.iter().zip(&dirs) {
        std::fs::create_dir_all(dir).map_err(|e| Failure::io(dir, e))?;
        for m in models {
            m.save(dir).map_err(|e| Failure::Write(e.into()))?;
        }
    }
    // The calibration beside the networks (measured where the database can, the rest
    // carried from the shipped models'): tools::training::calibrate.
    let calibration = crate::tools::training::calibrate::calibrate(&db, &cfg.core().calibration);
    write_calibration(&dirs, &calibration)?;
    println!(
        "calibration: sea index anchors {:.4} / {:.4} deg (the median wave yaw in a calm / moderate sea)",
        calibration.sea_wave_yaw_deg[0], calibration.sea_wave_yaw_deg[1]
    );
    // The healthy scatter through the networks just written (`--calibrate` alone redoes it).
    recalibrate(cfg, o, threads)?;
    println!();
    println!("| model | trainer | inputs | epochs (kept) | stop | MSE train | MSE validation | MSE test | RMSE test | residual std calm / moderate | file |");
    println!("|---|---|---:|---:|---|---:|---:|---:|---:|---|---|");
    for (models, dir) in built.iter().zip(&dirs) {
        for m in models {
            let r = &m.file.training;
            let spread: Vec<String> = m
                .file
                .uncertainty
                .by_sea
                .iter()
                .map(|s| fmt_unit(s.residual_std, m.file.target))
                .collect();
            println!(
                "| {} {} | {} | {} | {} ({}) | {:?} | {:.5} | {:.5} | {:.5} | {} | {} | {} |",
                m.file.method.name(),
                m.file.target.name(),
                r.trainer.name(),
                m.inputs.len(),
                r.epochs,
                r.best_epoch,
                r.stop,
                r.mse_train,
                r.mse_validation,
                r.mse_test,
                fmt_unit(r.rmse_test, m.file.target),
                spread.join(" / "),
                dir.join(m.file_name()).display()
            );
        }
    }
    let total = t0.elapsed().as_secs_f64();
    println!();
    println!(
        "time: database {t_db:.1} s, training {t_train:.1} s, total {total:.1} s on {threads} threads (budget 600 s)"
    );
    Ok(())
}

fn models_of(e: &Estimator) -> Vec<Model> {
    SLOTS.iter().map(|&(m, t)| e.model(m, t).clone()).collect()
}

/// The durations table of a database.
fn print_durations(db: &Database) {
    println!("| method | sea | completed | mean duration | longest | limit |");
    println!("|---|---|---:|---:|---:|---:|");
    for &m in &db.spec.methods {
        for &sea in &db.spec.seas {
            let (n, mean, max) = durations(db, m, sea);
            println!(
                "| {} | {} | {n} | {:.0} s ({:.1} min) | {:.0} s ({:.1} min){} | {:.0} s |",
                m.name().to_uppercase(),
                sea.name(),
                mean,
                mean / 60.0,
                max,
                max / 60.0,
                if max > MAX_TEST_S { " OVER" } else { "" },
                MAX_TEST_S
            );
        }
    }
}

/// `helmwatch eval`.
pub(crate) fn eval(cfg: &Config, o: &EvalOptions) -> Result<(), Failure> {
    let t0 = Instant::now();
    let threads = o.threads.unwrap_or_else(default_threads).max(1);
    let lm = Estimator::load_dir(&o.models, &cfg.core())?;
    let cgf_dir = o.models.join("traincgf");
    let cgf = match Estimator::load_dir(&cgf_dir, &cfg.core()) {
        Ok(e) => Some(e),
        Err(e) => {
            eprintln!("helmwatch: no Fletcher-Reeves models: {e}");
            None
        }
    };
    let lm_models = models_of(&lm);
    let cgf_models = cgf.as_ref().map(models_of);
    let rec = &lm_models[0].file.training;
    let spec = evaluation_spec(o.seed, o.points);
    // Independence: the held-out design shares no simulation seed with the training one.
    let train_pts = design(
        cfg,
        &training_spec(rec.database_seed, rec.design_points_per_sea),
    );
    let eval_pts = design(cfg, &spec);
    let train_seeds: std::collections::HashSet<u64> = train_pts.iter().map(|p| p.seed).collect();
    let shared = eval_pts
        .iter()
        .filter(|p| train_seeds.contains(&p.seed))
        .count();
    println!(
        "helmwatch eval: held-out seed {} ({} points per sea state, evaluation streams), models trained on seed {} ({} points per sea state); simulation seeds shared with training: {shared}",
        o.seed, o.points, rec.database_seed, rec.design_points_per_sea
    );
    let db = simulate(cfg, &spec, threads, &progress("held-out"));
    print_failures(&db);
    let cells_lm = accuracy(&lm_models, &db);
    let cells_cgf = cgf_models.as_ref().map(|m| accuracy(m, &db));
    print_accuracy(&cells_lm, cells_cgf.as_deref(), &db);
    println!();
    println!("## Test durations (trigger to report, settling and ramp-down included)");
    println!();
    print_durations(&db);

    if o.family {
        print_family(cfg, &lm_models, &spec, threads);
    }

    if o.drift {
        print_drift(cfg, &lm_models, &cells_lm, &spec, threads)?;
    }
    if o.lengths {
        print_lengths(cfg, &lm_models, o, threads);
    }
    println!();
    println!("eval time: {:.1} s", t0.elapsed().as_secs_f64());
    Ok(())
}

/// `eval`'s accuracy table (LM models, and FR-CG's when present) and the LM targets met.
fn print_accuracy(cells_lm: &[Cell], cells_cgf: Option<&[Cell]>, db: &Database) {
    let mut labelled: Vec<(&str, &[Cell])> = vec![("LM", cells_lm)];
    if let Some(c) = cells_cgf {
        labelled.push(("FR-CG 100 ep.", c));
    }
    println!();
    println!("## Accuracy on the held-out set (MSE on the [-1, 1] scale; RMSE in m/s and t)");
    println!();
    print!("{}", table(&labelled, &db.spec.seas));
    let misses: Vec<String> = cells_lm
        .iter()
        .filter(|c| target_mse(c.method, c.sea, c.target).is_some_and(|t| c.mse > t))
        .map(|c| format!("{} {} {}", c.method.name(), c.sea.name(), c.target.name()))
        .collect();
    println!(
        "LM targets met: {} of {}{}",
        8 - misses.len(),
        8,
        if misses.is_empty() {
            String::new()
        } else {
            format!(" (missed: {})", misses.join(", "))
        }
    );
}

/// `eval --drift`: the held-out set again with a 1 deg/min heading drift on every test.
fn print_drift(
    cfg: &Config,
    lm_models: &[Model],
    cells_lm: &[Cell],
    spec: &DatabaseSpec,
    threads: usize,
) -> Result<(), Failure> {
    let drift: Fault = "heading_drift_deg_per_min:1@0"
        .parse()
        .map_err(|e| Failure::Software(anyhow::anyhow!("{e}")))?;
    let mut dspec = spec.clone();
    dspec.faults = vec![drift];
    let ddb = simulate(cfg, &dspec, threads, &progress("held-out with drift"));
    let cells_d = accuracy(lm_models, &ddb);
    println!();
    println!("## Heading drift 1 deg/min on every test (same points and seeds), LM models");
    println!();
    println!("| method | sea | parameter | MSE | MSE with drift | growth | limit |");
    println!("|---|---|---|---:|---:|---:|---|");
    for c in cells_lm {
        if let Some(d) = find(&cells_d, c.method, c.sea, c.target) {
            let g = 100.0 * (d.mse / c.mse - 1.0);
            println!(
                "| {} | {} | {} | {:.5} | {:.5} | {g:+.1} % | {} |",
                c.method.name().to_uppercase(),
                c.sea.name(),
                c.target.name(),
                c.mse,
                d.mse,
                if g <= 10.0 {
                    "<= +10 % ok"
                } else {
                    "> +10 % MISS"
                }
            );
        }
    }
    print_failures(&ddb);
    Ok(())
}

/// `eval`'s table of accuracy against the test length.
fn print_lengths(cfg: &Config, lm_models: &[Model], o: &EvalOptions, threads: usize) {
    println!();
    println!("## Accuracy against test length (LM models; the same design, shorter or longer measurement)");
    println!();
    println!("| method | measurement | mean duration | longest | calm speed | calm displacement | moderate speed | moderate displacement |");
    println!("|---|---|---:|---:|---:|---:|---:|---:|");
    for (label, variant) in length_variants(cfg) {
        let lspec = DatabaseSpec {
            methods: vec![variant.0],
            ..evaluation_spec(o.seed, o.points)
        };
        let vdb = simulate(&variant.1, &lspec, threads, &|_, _| {});
        let cells = accuracy(lm_models, &vdb);
        let (n_c, mean_c, max_c) = durations(&vdb, variant.0, SeaState::Calm);
        let (n_m, mean_m, max_m) = durations(&vdb, variant.0, SeaState::Moderate);
        let failed = vdb.failures(variant.0).len();
        let mut row = format!(
            "| {} | {label} | {:.0} s | {:.0} s |",
            variant.0.name().to_uppercase(),
            (mean_c * n_c as f64 + mean_m * n_m as f64) / (n_c + n_m).max(1) as f64,
            max_c.max(max_m)
        );
        for sea in SEAS {
            for t in Target::ALL {
                match find(&cells, variant.0, sea, t) {
                    Some(c) if c.n > 0 => {
                        row.push_str(&format!(" {:.5} ({}) |", c.mse, fmt_unit(c.rmse, t)))
                    }
                    _ => row.push_str(" - |"),
                }
            }
        }
        if failed > 0 {
            row.push_str(&format!(" {failed} failed"));
        }
        println!("{row}");
    }
}

/// Configurations that change only the measurement length of one method (the default one
/// included), with a label. The duration limits (`safety.max-test-duration-s`,
/// `hbt.timeout-s`) are lifted to two hours so that the longer variants can complete.
pub fn length_variants(cfg: &Config) -> Vec<(String, (Method, Config))> {
    let mut v = Vec::new();
    let mut cfg = cfg.clone();
    cfg.safety.max_test_duration_s = cfg.safety.max_test_duration_s.max(7200.0);
    cfg.hbt.timeout_s = cfg.hbt.timeout_s.max(7200.0);
    let cfg = &cfg;
    let c = &cfg.clfrt;
    for m in 1..=c.measure_windows + 1 {
        let mut x = cfg.clone();
        x.clfrt.measure_windows = m;
        let default = if m == c.measure_windows {
            " (default)"
        } else {
            ""
        };
        v.push((
            format!("{m} x {:.0} s windows{default}", c.window_s),
            (Method::Clfrt, x),
        ));
    }
    let h = &cfg.hbt;
    for p in 1..=h.measure_periods + 2 {
        let mut x = cfg.clone();
        x.hbt.measure_periods = p;
        let default = if p == h.measure_periods {
            " (default)"
        } else {
            ""
        };
        v.push((format!("{p} periods{default}"), (Method::Hbt, x)));
    }
    v
}

/// `eval --family`: the shipped (LM) models on ships of other structures, bias and RMSE per
/// method, sea and parameter, and the share of tests that completed.
fn print_family(
    cfg: &Config,
    models: &[helmwatch_core::estimator::model::Model],
    spec: &crate::tools::training::database::DatabaseSpec,
    threads: usize,
) {
    let rows = crate::tools::eval::estimator::family_accuracy(cfg, models, spec, threads);
    println!();
    println!("## The family of real ships (same held-out points and seeds, LM models)");
    println!();
    println!("Error = estimate - truth; bias is its mean, RMSE its root mean square.");
    println!();
    println!("| ship | method | sea | speed bias | speed RMSE | displacement bias | displacement RMSE | completed |");
    println!("|---|---|---|---:|---:|---:|---:|---:|");
    for (name, cells, rate) in &rows {
        for method in [Method::Clfrt, Method::Hbt] {
            for &sea in &spec.seas {
                let (Some(u), Some(d)) = (
                    find(cells, method, sea, Target::Speed),
                    find(cells, method, sea, Target::Displacement),
                ) else {
                    continue;
                };
                println!(
                    "| {name} | {} | {} | {:+.2} m/s | {:.2} m/s | {:+.0} t | {:.0} t | {:.0} % |",
                    method.name().to_uppercase(),
                    sea.name(),
                    u.bias,
                    u.rmse,
                    d.bias,
                    d.rmse,
                    100.0 * rate
                );
            }
        }
    }
}

/// Writes `calibration` into each of `dirs` (atomically).
fn write_calibration(
    dirs: &[PathBuf],
    calibration: &helmwatch_core::fdi::config::Calibration,
) -> Result<(), Failure> {
    let mut json = serde_json::to_string_pretty(calibration).map_err(Failure::software)?;
    json.push('\n');
    for dir in dirs {
        let path = dir.join(helmwatch_core::estimator::CALIBRATION_FILE);
        crate::tools::results::write_atomic(&path, json.as_bytes())
            .map_err(|e| Failure::io(&path, e))?;
    }
    Ok(())
}

/// `train --calibrate`: the healthy scatter, the displacement's direction and the speed's slope
/// of the networks in `o.out` on the class (`tools::training::calibrate`), into its `calibration.json`.
fn recalibrate(cfg: &Config, o: &TrainOptions, threads: usize) -> Result<(), Failure> {
    let t0 = Instant::now();
    let estimator = Estimator::load_dir(&o.out, &cfg.core())?;
    let mut calibration = estimator.calibration().clone();
    let estimator = std::sync::Arc::new(estimator);
    use crate::tools::training::calibrate::{
        displacement_direction, healthy_scatter, scatter_points,
    };
    use crate::tools::training::speed_slope::speed_slope;
    let too_few = |what: &str| {
        Failure::software(anyhow::anyhow!(
            "too few completed tests to measure the {what}"
        ))
    };
    let prior = healthy_scatter(cfg, estimator.clone(), o.family, o.seed, threads)
        .ok_or_else(|| too_few("healthy scatter"))?;
    let points = scatter_points(cfg, o.family, o.seed);
    let direction = displacement_direction(cfg, estimator.clone(), &points, threads)
        .ok_or_else(|| too_few("displacement's direction"))?;
    let (slope, slope_speed, slope_speed_gain) =
        speed_slope(cfg, estimator, &points, threads).ok_or_else(|| too_few("slope in speed"))?;
    calibration.speed_slope = Some(slope);
    calibration.slope_speed = slope_speed;
    calibration.slope_speed_gain = slope_speed_gain;
    calibration.healthy_scatter = Some(prior);
    calibration.displacement_direction = Some(direction);
    write_calibration(std::slice::from_ref(&o.out), &calibration)?;
    for (name, c) in [("clfrt", prior.clfrt), ("hbt", prior.hbt)] {
        let v = |p: [[f64; 3]; 3]| {
            (0..3)
                .map(|j| format!("{:.3}", p[j][j].sqrt()))
                .collect::<Vec<_>>()
        };
        println!(
            "healthy scatter {name}: sd in design spreads calm {:?}, moderate {:?}, weight {:?} dof",
            v(c.calm),
            v(c.moderate),
            c.dof.map(|w| format!("{w:.1}"))
        );
    }
    for (name, pair) in [("clfrt", direction.clfrt), ("hbt", direction.hbt)] {
        let v = |d: [f64; 3]| d.map(|x| format!("{x:+.3}"));
        println!(
            "displacement direction {name} per unit ln D (e_u m/s, e_D, e_b): calm {:?}, moderate {:?}",
            v(pair[0]),
            v(pair[1])
        );
    }
    let kept = |m: [Option<[f64; 2]>; 3]| {
        m.map(|c| {
            c.map_or("the law".to_string(), |p| {
                format!("{:+.4} / {:+.4}", p[0], p[1])
            })
        })
    };
    println!(
        "slope in speed per m/s (e_u, e_D, e_b), the class's calm / moderate or the similarity law: clfrt {:?}, hbt {:?}; prior sd about it: e_u {:.3} m/s, e_D {:.4}, e_b {:.4} ln",
        kept(slope.clfrt),
        kept(slope.hbt),
        slope_speed[0],
        slope_speed[1],
        slope_speed_gain
    );
    println!(
        "healthy scatter, displacement direction and slope in speed measured in {:.1} s",
        t0.elapsed().as_secs_f64()
    );
    Ok(())
}
