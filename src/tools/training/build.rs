//! From a simulated database to trained model files.
//!
//! For each method, the completed tests are split at random (seeded) into training (70 %),
//! validation (15 %) and test (15 %) parts, the same split for both targets (MATLAB
//! `dividerand`). Inputs are scaled by the minimum and maximum of the training part
//! (`minmax(p)`), targets by the configured parameter range, both to [-1, 1]. Each of the
//! four networks ([`helmwatch_core::estimator::SLOTS`]) is trained by each requested trainer from several seeded
//! restarts; the restart with the lowest validation MSE is kept. The jobs (trainer, slot,
//! restart) run on worker threads and are combined in their fixed order, so the models are
//! a function of the database and the seed only.
//!
//! Each model records its validation residual spread (estimate - truth, in m/s or t, overall
//! and per sea state: the estimator's uncertainty for the parity test) and its MSE on the
//! three parts on the [-1, 1] scale.

use super::database::{par_map, Database};
use super::train::{best_of, train_restart, Dataset, TrainError};
use crate::config::Config;
use helmwatch_core::estimator::features::{self, Feature};
use helmwatch_core::estimator::model::{
    Design, Metadata, Model, ModelError, SeaSpread, Split, Target, TrainingRecord, Uncertainty,
};
use helmwatch_core::estimator::nn::{Mlp, Scaling, Scratch};
use helmwatch_core::estimator::trainer::Trainer;
use helmwatch_core::estimator::SLOTS;
use helmwatch_core::model::SeaState;
use helmwatch_core::wire::Method;
use rand::seq::SliceRandom;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

/// Why models could not be built.
#[derive(Debug, thiserror::Error)]
pub enum BuildError {
    /// Too few completed tests of a method to split and train.
    #[error("{method}: only {n} completed tests, at least {min} are needed")]
    TooFewTests {
        /// The method.
        method: &'static str,
        /// Completed tests.
        n: usize,
        /// Needed.
        min: usize,
    },
    /// Training failed.
    #[error(transparent)]
    Train(#[from] TrainError),
    /// A model could not be assembled.
    #[error(transparent)]
    Model(#[from] ModelError),
    /// A scaling could not be formed.
    #[error("scaling: {0}")]
    Scaling(#[from] helmwatch_core::estimator::nn::NnError),
}

/// Settings of a build.
#[derive(Debug, Clone, PartialEq)]
pub struct BuildSettings {
    /// Seed of the split and of the restarts (the database seed).
    pub seed: u64,
    /// Restarts per network and trainer.
    pub restarts: usize,
    /// Fraction of the completed tests for training.
    pub train_fraction: f64,
    /// Fraction for validation (the rest is the test part).
    pub validation_fraction: f64,
    /// Worker threads.
    pub threads: usize,
}

impl BuildSettings {
    /// 70 / 15 / 15 split, `restarts` restarts.
    pub fn new(seed: u64, restarts: usize, threads: usize) -> Self {
        Self {
            seed,
            restarts,
            train_fraction: 0.70,
            validation_fraction: 0.15,
            threads,
        }
    }
}

/// The raw data of one network: inputs, targets, and which part each sample is in.
#[derive(Debug, Clone)]
struct SlotData {
    inputs: Vec<Feature>,
    scaling: Scaling,
    /// (raw inputs, raw target, sea) per part: 0 train, 1 validation, 2 test.
    parts: [Vec<(Vec<f64>, f64, SeaState)>; 3],
    sets: [Dataset; 3],
    failed: usize,
    size: usize,
}

/// Which part (0 train, 1 validation, 2 test) each of `n` samples falls in.
fn split(n: usize, seed: u64, method: Method, s: &BuildSettings) -> Vec<usize> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(match method {
        Method::Clfrt => 0x51,
        Method::Hbt => 0x52,
    });
    let mut order: Vec<usize> = (0..n).collect();
    order.shuffle(&mut rng);
    let n_train = ((n as f64) * s.train_fraction).round() as usize;
    let n_val = ((n as f64) * s.validation_fraction).round() as usize;
    let mut part = vec![2; n];
    for (rank, &i) in order.iter().enumerate() {
        part[i] = if rank < n_train {
            0
        } else if rank < n_train + n_val {
            1
        } else {
            2
        };
    }
    part
}

fn slot_data(
    cfg: &Config,
    db: &Database,
    method: Method,
    target: Target,
    s: &BuildSettings,
) -> Result<SlotData, BuildError> {
    let n_tones = cfg.clfrt.harmonics.len();
    let inputs = match target {
        Target::Speed => features::speed_inputs(method, n_tones),
        Target::Displacement => features::displacement_inputs(method, n_tones),
    };
    // Both targets use the samples where every input of the displacement network exists,
    // so that they share one split.
    let all = features::displacement_inputs(method, n_tones);
    let mut x = Vec::new();
    let mut samples = Vec::new();
    let completed = db.completed(method);
    for &(i, f) in &completed {
        let mut row = Vec::new();
        if features::extract_into(&all, f, &mut x).is_ok()
            && features::extract_into(&inputs, f, &mut row).is_ok()
        {
            let p = &db.points[i];
            let y = match target {
                Target::Speed => p.speed_mps,
                Target::Displacement => p.displacement_t,
            };
            samples.push((row, y, p.sea));
        }
    }
    let failed = db.runs_of(method).len() - samples.len();
    let min = 20;
    if samples.len() < min {
        return Err(BuildError::TooFewTests {
            method: method.name(),
            n: samples.len(),
            min,
        });
    }
    let part = split(samples.len(), s.seed, method, s);
    let mut parts: [Vec<(Vec<f64>, f64, SeaState)>; 3] = [Vec::new(), Vec::new(), Vec::new()];
    let size = samples.len();
    for (k, smp) in samples.into_iter().enumerate() {
        parts[part[k]].push(smp);
    }
    let (y_min, y_max) = target.range(&cfg.ship);
    let scaling = Scaling::from_data(parts[0].iter().map(|r| r.0.as_slice()), y_min, y_max)?;
    let scaled = |p: &Vec<(Vec<f64>, f64, SeaState)>, name: &'static str| {
        let rows: Vec<Vec<f64>> = p
            .iter()
            .map(|r| {
                r.0.iter()
                    .enumerate()
                    .map(|(i, &v)| scaling.scale_x(i, v))
                    .collect()
            })
            .collect();
        let ys: Vec<f64> = p.iter().map(|r| scaling.scale_y(r.1)).collect();
        Dataset::new(name, &rows, &ys)
    };
    let sets = [
        scaled(&parts[0], "training")?,
        scaled(&parts[1], "validation")?,
        scaled(&parts[2], "test")?,
    ];
    Ok(SlotData {
        inputs,
        scaling,
        parts,
        sets,
        failed,
        size,
    })
}

/// Residual statistics (estimate - truth, raw units) of `net` on raw samples.
fn residuals(net: &Mlp, scaling: &Scaling, samples: &[(Vec<f64>, f64, SeaState)]) -> Vec<f64> {
    let mut s = Scratch::new(scaling.n_in());
    samples
        .iter()
        .map(|(x, y, _)| net.predict(scaling, x, &mut s) - y)
        .collect()
}

fn mean_std(r: &[f64]) -> (f64, f64) {
    let n = r.len().max(1) as f64;
    let mean = r.iter().sum::<f64>() / n;
    let var = r.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>() / (n - 1.0).max(1.0);
    (mean, var.sqrt())
}

/// The seed of slot `slot`'s restarts.
fn slot_seed(seed: u64, slot: usize) -> u64 {
    seed ^ (0xA5A5_0000_0000_0000u64.wrapping_add(slot as u64 * 0x1_0001))
}

/// Trains every slot whose method the database holds, with every trainer. Returns, per
/// trainer (in order), the models in [`SLOTS`] order (all four for a database of both
/// methods).
pub fn build_models(
    cfg: &Config,
    db: &Database,
    settings: &BuildSettings,
    trainers: &[Trainer],
) -> Result<Vec<Vec<Model>>, BuildError> {
    let slots: Vec<(Method, Target)> = SLOTS
        .iter()
        .copied()
        .filter(|(m, _)| db.spec.methods.contains(m))
        .collect();
    let data: Vec<SlotData> = slots
        .iter()
        .map(|&(m, t)| slot_data(cfg, db, m, t, settings))
        .collect::<Result<_, _>>()?;
    let restarts = settings.restarts.max(1);
    // Jobs (trainer, slot, restart) in a fixed order; workers take the next free one.
    let jobs: Vec<(usize, usize, usize)> = (0..trainers.len())
        .flat_map(|k| (0..slots.len()).flat_map(move |s| (0..restarts).map(move |r| (k, s, r))))
        .collect();
    let results = par_map(jobs.len(), settings.threads, |j| {
        let (k, s, r) = jobs[j];
        let d = &data[s];
        train_restart(
            &d.sets[0],
            &d.sets[1],
            &trainers[k],
            slot_seed(
                settings.seed,
                helmwatch_core::estimator::slot_index(slots[s].0, slots[s].1),
            ),
            r,
        )
    });
    let mut results = results.into_iter();
    let mut out = Vec::with_capacity(trainers.len());
    for trainer in trainers {
        let mut models = Vec::with_capacity(slots.len());
        for (s, &(method, target)) in slots.iter().enumerate() {
            let runs = results
                .by_ref()
                .take(restarts)
                .collect::<Result<Vec<_>, _>>()?;
            let best = best_of(runs).ok_or(TrainError::NoRestart)?;
            let d = &data[s];
            let val = residuals(&best.net, &d.scaling, &d.parts[1]);
            let (residual_mean, residual_std) = mean_std(&val);
            let by_sea = db
                .spec
                .seas
                .iter()
                .filter_map(|&sea| {
                    let (r, rel): (Vec<f64>, Vec<f64>) = d.parts[1]
                        .iter()
                        .zip(&val)
                        .filter(|(p, _)| p.2 == sea)
                        .map(|(p, v)| (*v, *v / p.1))
                        .unzip();
                    (r.len() >= 2).then(|| {
                        let (m, sd) = mean_std(&r);
                        let (rm, rsd) = mean_std(&rel);
                        SeaSpread {
                            sea,
                            n: r.len(),
                            residual_mean: m,
                            residual_std: sd,
                            relative_mean: Some(rm),
                            relative_std: Some(rsd),
                        }
                    })
                })
                .collect();
            let test = residuals(&best.net, &d.scaling, &d.parts[2]);
            let half = 0.5 * (d.scaling.y_max - d.scaling.y_min);
            let mse_test_raw = test.iter().map(|v| v * v).sum::<f64>() / test.len().max(1) as f64;
            let meta = Metadata {
                design: Design::from_config(&cfg.core(), method),
                uncertainty: Uncertainty {
                    residual_mean,
                    residual_std,
                    by_sea,
                },
                training: TrainingRecord {
                    database_seed: db.spec.seed,
                    design_points_per_sea: db.spec.points_per_sea,
                    sea_states: db.spec.seas.clone(),
                    family: db.spec.family,
                    database_size: d.size,
                    database_failed: d.failed,
                    split: Split {
                        train: d.sets[0].len(),
                        validation: d.sets[1].len(),
                        test: d.sets[2].len(),
                    },
                    trainer: *trainer,
                    restarts,
                    best_restart: best.restart,
                    epochs: best.fit.epochs,
                    best_epoch: best.fit.best_epoch,
                    stop: best.fit.stop,
                    mse_train: best.fit.mse_train,
                    mse_validation: best.fit.mse_validation,
                    mse_test: mse_test_raw / (half * half),
                    rmse_test: mse_test_raw.sqrt(),
                },
            };
            models.push(Model::new(
                method, target, &d.inputs, &best.net, &d.scaling, meta,
            )?);
        }
        out.push(models);
    }
    Ok(out)
}
