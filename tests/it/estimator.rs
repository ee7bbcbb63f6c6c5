//! The estimator end to end: the shipped models against fresh simulated tests, the report's
//! `estimate` and `speed_log_mps`, and bit-for-bit reproducible training.
//!
//! Independent answers: the true speed and displacement of each simulated ship, and the
//! shipped files' own recorded test MSE (measured by `helmwatch train` on other tests).

use helmwatch::cli::estimator::{cgf_trainer, lm_trainer};
use helmwatch::config::Config;
use helmwatch::tools::eval::estimator::accuracy;
use helmwatch::tools::training::build::{build_models, BuildSettings};
use helmwatch::tools::training::database::{simulate, DatabaseSpec, Purpose};
use helmwatch_core::drivers::probe::{run_probe, ProbeOptions};
use helmwatch_core::estimator::model::{Model, Target};
use helmwatch_core::estimator::{Estimator, SLOTS};
use helmwatch_core::model::SeaState;
use helmwatch_core::sim::{Fault, Scenario};
use helmwatch_core::wire::Method;
use helmwatch_core::wire::Outcome;
use std::path::Path;
use std::sync::Arc;

fn models_dir() -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("models")
}

/// The shipped models: the files in `models/` load, validate for the default configuration,
/// and are the ones embedded in the binary.
#[test]
fn shipped_models_load_and_are_the_embedded_ones() {
    let cfg = Config::default();
    let from_dir = Estimator::load_dir(&models_dir(), &cfg.core()).unwrap();
    let embedded = Estimator::embedded(&cfg.core()).unwrap();
    assert_eq!(from_dir, embedded);
    for (m, t) in SLOTS {
        let model = from_dir.model(m, t);
        assert_eq!(model.file.training.trainer.name(), "lm");
        assert!(model.file.uncertainty.residual_std > 0.0);
    }
    // The Fletcher-Reeves models for the comparison load too.
    Estimator::load_dir(&models_dir().join("traincgf"), &cfg.core()).unwrap();
}

/// Each shipped model, on a fresh sample of probes drawn on other random streams than its
/// database (calm and moderate seas, as in training), reproduces its recorded test MSE
/// within sampling error: the ratio of the two lies in [0.4, 2.5]. (A model fed the wrong
/// inputs, or a different test design, is off by orders of magnitude.)
#[test]
fn shipped_models_reproduce_their_recorded_test_mse_on_fresh_probes() {
    let cfg = Config::default();
    let est = Estimator::load_dir(&models_dir(), &cfg.core()).unwrap();
    let models: Vec<Model> = SLOTS
        .iter()
        .map(|&(m, t)| est.model(m, t).clone())
        .collect();
    let spec = DatabaseSpec {
        seed: 20_261_121,
        purpose: Purpose::Evaluation,
        points_per_sea: 40,
        seas: vec![SeaState::Calm, SeaState::Moderate],
        methods: vec![Method::Clfrt, Method::Hbt],
        faults: vec![],
        family: false,
    };
    let db = simulate(&cfg, &spec, 2, &|_, _| {});
    // One sea-state mixture per model, as recorded: pool the two sea states.
    let mut pooled = db.clone();
    for p in &mut pooled.points {
        p.sea = SeaState::Calm;
    }
    pooled.spec.seas = vec![SeaState::Calm];
    let cells = accuracy(&models, &pooled);
    for (model, cell) in models.iter().zip(&cells) {
        let recorded = model.file.training.mse_test;
        let ratio = cell.mse / recorded;
        println!(
            "{} {}: fresh MSE {:.5} on {} tests ({} failed), recorded {:.5}, ratio {ratio:.2}",
            model.file.method.name(),
            model.file.target.name(),
            cell.mse,
            cell.n,
            cell.failed,
            recorded
        );
        assert!(cell.n >= 76, "{} completed tests", cell.n);
        assert!(
            (0.4..=2.5).contains(&ratio),
            "{} {}: fresh MSE {} vs recorded {}",
            model.file.method.name(),
            model.file.target.name(),
            cell.mse,
            recorded
        );
    }
}

/// A probe with the estimator reports an estimate close to the simulated ship's truth, the
/// networks' output for the report's own features, and the mean speed-log reading.
#[test]
fn probe_reports_carry_the_estimate_and_the_speed_log() {
    let cfg = Config::default();
    let est = Arc::new(Estimator::embedded(&cfg.core()).unwrap());
    for method in [Method::Clfrt, Method::Hbt] {
        for (u, d) in [(5.0, 9000.0), (8.5, 5000.0)] {
            let sc = Scenario {
                speed_mps: u,
                displacement_t: d,
                sea: SeaState::Calm,
                faults: vec![],
                seed: 77,
            };
            let mut opts = ProbeOptions::new(&cfg.core(), method);
            opts.estimator = Some(est.clone());
            let r = run_probe(&cfg.core(), &cfg.sim(), &sc, &opts)
                .unwrap()
                .report;
            assert_eq!(r.outcome, Outcome::Completed, "{:?}", r.reason);
            let e = r.estimate.expect("an estimate");
            let log = r.features.speed_log_mps().unwrap();
            println!(
                "{} u {u} D {d}: estimate {:.2} m/s {:.0} t, speed log {log:.3}",
                method.name(),
                e.speed_mps,
                e.displacement_t
            );
            // The speed log: 0.05 m/s noise averaged over ~18 000 samples.
            assert!((log - u).abs() < 0.01, "speed log {log}");
            // Calm sea: within 4 validation spreads of the truth.
            let tol = |t: Target| 4.0 * est.model(method, t).file.uncertainty.residual_std;
            assert!((e.speed_mps - u).abs() < tol(Target::Speed), "{e:?}");
            assert!(
                (e.displacement_t - d).abs() < tol(Target::Displacement),
                "{e:?}"
            );
            let mut s = est.scratch();
            let again = est.estimate(method, &r.features, &mut s).unwrap();
            assert_eq!(again, e);
            assert!(r.message.contains("estimate"), "{}", r.message);
            // Without the estimator: the same features, no estimate.
            let bare = run_probe(
                &cfg.core(),
                &cfg.sim(),
                &sc,
                &ProbeOptions::new(&cfg.core(), method),
            )
            .unwrap()
            .report;
            assert_eq!(bare.features, r.features);
            assert!(bare.estimate.is_none());
        }
    }
}

/// The displacement network reads the speed log: a speed-log bias moves `speed_log_mps` by
/// the bias, leaves the speed estimate (features only) alone, and moves the displacement.
#[test]
fn a_speed_log_bias_reaches_only_the_displacement_network() {
    let cfg = Config::default();
    let est = Arc::new(Estimator::embedded(&cfg.core()).unwrap());
    let run = |faults: Vec<Fault>| {
        let sc = Scenario {
            speed_mps: 7.0,
            displacement_t: 7000.0,
            sea: SeaState::Calm,
            faults,
            seed: 3,
        };
        let mut opts = ProbeOptions::new(&cfg.core(), Method::Clfrt);
        opts.estimator = Some(est.clone());
        run_probe(&cfg.core(), &cfg.sim(), &sc, &opts)
            .unwrap()
            .report
    };
    let a = run(vec![]);
    let b = run(vec!["speed_log_bias_mps:0.5@0".parse().unwrap()]);
    let log = |r: &helmwatch_core::wire::Report| r.features.speed_log_mps().unwrap();
    assert!(
        (log(&b) - log(&a) - 0.5).abs() < 1e-3,
        "{} {}",
        log(&a),
        log(&b)
    );
    let (ea, eb) = (a.estimate.unwrap(), b.estimate.unwrap());
    assert_eq!(ea.speed_mps, eb.speed_mps);
    assert!(
        (eb.displacement_t - ea.displacement_t).abs() > 100.0,
        "{ea:?} {eb:?}"
    );
}

/// `helmwatch train`'s pipeline on a small database: the same seed gives the same model
/// files bit for bit, whatever the number of threads; another seed gives other files.
#[test]
fn training_is_reproducible_bit_for_bit() {
    let cfg = Config::default();
    let spec = |seed| DatabaseSpec {
        seed,
        purpose: Purpose::Training,
        points_per_sea: 40,
        seas: vec![SeaState::Calm],
        methods: vec![Method::Clfrt, Method::Hbt],
        faults: vec![],
        family: false,
    };
    let db1 = simulate(&cfg, &spec(5), 2, &|_, _| {});
    let db1_one_thread = simulate(&cfg, &spec(5), 1, &|_, _| {});
    assert_eq!(db1, db1_one_thread);
    let texts = |db, threads| -> Vec<String> {
        build_models(
            &cfg,
            db,
            &BuildSettings::new(db.spec.seed, 2, threads),
            &[lm_trainer(), cgf_trainer()],
        )
        .unwrap()
        .iter()
        .flatten()
        .map(|m| m.to_json().unwrap())
        .collect()
    };
    let a = texts(&db1, 2);
    let b = texts(&db1, 1);
    assert_eq!(a.len(), 8);
    assert_eq!(a, b);
    let db2 = simulate(&cfg, &spec(6), 2, &|_, _| {});
    let c = texts(&db2, 2);
    assert!(a.iter().zip(&c).all(|(x, y)| x != y));
}

/// Models for another test design are refused with a message that names the file and the
/// remedy.
#[test]
fn models_for_another_design_or_a_missing_file_are_refused() {
    let mut cfg = Config::default();
    cfg.clfrt.amplitude_deg = 2.0;
    let e = Estimator::load_dir(&models_dir(), &cfg.core())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("clfrt_speed.json") && e.contains("helmwatch train"),
        "{e}"
    );
    let e = Estimator::load_dir(Path::new("/nonexistent-models"), &Config::default().core())
        .unwrap_err()
        .to_string();
    assert!(e.contains("/nonexistent-models/clfrt_speed.json"), "{e}");
}
