//! The training (and evaluation) database: simulated tests over a space-filling design.
//!
//! ## Design
//!
//! For each sea state, a Latin hypercube of `n` points over `(u, D)` in the configured ranges
//! (`ship.speed-range-mps`, `ship.displacement-range-t`): each range is cut into `n` equal
//! strata, each stratum is used exactly once per dimension (a random permutation per
//! dimension), and the point is drawn uniformly inside its cell:
//!
//! ```text
//! u_i = u_min + (u_max - u_min) (pi_u(i) + U_i) / n,   D_i likewise,   U ~ U[0, 1)
//! ```
//!
//! Each point also draws the seed of its simulation (sensor noise and sea). Every draw comes
//! from one `ChaCha8Rng` seeded with the database seed, on a stream per purpose (training or
//! evaluation) and sea state, so a training and an evaluation database of the same seed are
//! independent draws, and adding a sea state changes no other sea state's points.
//!
//! ## Runs
//!
//! At every point each requested method runs once through [`helmwatch_core::drivers::probe::run_probe`] (the
//! same monitor core as the daemon: the features and the speed-log mean are exactly what the
//! daemon would report), the same ship seed for both methods. Runs are spread over worker
//! threads (`std::thread::scope`) that take the next job from a shared counter; each result is
//! stored at its job's index, so the database does not depend on the number of threads or on
//! scheduling. A test that does not complete (abort, refusal, timeout) is kept as a failure
//! with its reason and left out of training.

use crate::config::Config;
use helmwatch_core::drivers::probe::{run_probe, ProbeOptions};
use helmwatch_core::dsp::multisine::Multisine;
use helmwatch_core::model::SeaState;
use helmwatch_core::monitor::Monitor;
use helmwatch_core::sim::{Fault, Scenario};
use helmwatch_core::wire::Method;
use helmwatch_core::wire::{Features, Outcome};
use rand::seq::SliceRandom;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

/// What a database is for; each purpose draws from its own random streams.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Purpose {
    /// The training database (split into training, validation and test parts).
    Training,
    /// A held-out evaluation database, independent of the training one.
    Evaluation,
    /// The points the estimator's healthy scatter is measured at (`calibrate`).
    Scatter,
}

impl Purpose {
    fn stream(self, sea: SeaState) -> u64 {
        let p = match self {
            Purpose::Training => 1,
            Purpose::Evaluation => 2,
            Purpose::Scatter => 3,
        };
        let s = match sea {
            SeaState::Calm => 1,
            SeaState::Moderate => 2,
            SeaState::Rough => 3,
        };
        (p << 8) | s
    }
}

/// What to simulate.
#[derive(Debug, Clone, PartialEq)]
pub struct DatabaseSpec {
    /// Seed of the design and of the simulations.
    pub seed: u64,
    /// Training or evaluation (selects the random streams).
    pub purpose: Purpose,
    /// Latin-hypercube points per sea state.
    pub points_per_sea: usize,
    /// Sea states, in order.
    pub seas: Vec<SeaState>,
    /// Methods run at every point, in order.
    pub methods: Vec<Method>,
    /// Faults added to every scenario (e.g. a heading drift for the drift check).
    pub faults: Vec<Fault>,
    /// Draw each point's ship from the family of real ships
    /// ([`helmwatch_core::sim::config::draw_family_member`], on a random stream of its own: the points,
    /// seeds and every other draw are those of the database without it).
    pub family: bool,
}

/// One design point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Point {
    /// Sea state.
    pub sea: SeaState,
    /// True speed [m/s].
    pub speed_mps: f64,
    /// True displacement [t].
    pub displacement_t: f64,
    /// Seed of the simulation.
    pub seed: u64,
    /// The ship's structure and autopilot, when drawn from the family (else the
    /// configuration's).
    pub ship: Option<helmwatch_core::sim::config::FamilyMember>,
}

/// The outcome of one test at one point.
#[derive(Debug, Clone, PartialEq)]
pub struct TestRun {
    /// The report's `features` (with `speed_log_mps`) when the test completed, else the
    /// reason it did not.
    pub features: Result<Features, String>,
    /// Test duration, trigger to report [s of ship time] (NaN when no report came).
    pub duration_s: f64,
}

/// A simulated database: the points and, per method, one run per point.
#[derive(Debug, Clone, PartialEq)]
pub struct Database {
    /// What was simulated.
    pub spec: DatabaseSpec,
    /// The design, sea state by sea state.
    pub points: Vec<Point>,
    /// `runs[m][i]`: method `spec.methods[m]` at point `i`.
    pub runs: Vec<Vec<TestRun>>,
}

/// The Latin-hypercube design of `spec` over the ranges of `cfg`.
pub fn design(cfg: &Config, spec: &DatabaseSpec) -> Vec<Point> {
    let [u_lo, u_hi] = cfg.ship.speed_range_mps;
    let [d_lo, d_hi] = cfg.ship.displacement_range_t;
    let n = spec.points_per_sea;
    let mut points = Vec::with_capacity(n * spec.seas.len());
    for &sea in &spec.seas {
        let mut rng = ChaCha8Rng::seed_from_u64(spec.seed);
        rng.set_stream(spec.purpose.stream(sea));
        let mut family = ChaCha8Rng::seed_from_u64(spec.seed);
        family.set_stream(spec.purpose.stream(sea) | 1 << 16);
        let mut pu: Vec<usize> = (0..n).collect();
        let mut pd: Vec<usize> = (0..n).collect();
        pu.shuffle(&mut rng);
        pd.shuffle(&mut rng);
        for i in 0..n {
            let fu: f64 = rng.gen();
            let fd: f64 = rng.gen();
            let seed: u64 = rng.gen();
            points.push(Point {
                sea,
                speed_mps: u_lo + (u_hi - u_lo) * (pu[i] as f64 + fu) / n as f64,
                displacement_t: d_lo + (d_hi - d_lo) * (pd[i] as f64 + fd) / n as f64,
                seed,
                ship: spec
                    .family
                    .then(|| helmwatch_core::sim::config::draw_family_member(&mut family)),
            });
        }
    }
    points
}

/// Runs `f(i)` for `i in 0..n` on `threads` worker threads; results in index order.
pub fn par_map<R: Send>(n: usize, threads: usize, f: impl Fn(usize) -> R + Sync) -> Vec<R> {
    let next = AtomicUsize::new(0);
    let slots: Vec<Mutex<Option<R>>> = (0..n).map(|_| Mutex::new(None)).collect();
    let threads = threads.clamp(1, n.max(1));
    std::thread::scope(|s| {
        for _ in 0..threads {
            s.spawn(|| loop {
                let i = next.fetch_add(1, Ordering::Relaxed);
                if i >= n {
                    break;
                }
                let r = f(i);
                if let Ok(mut slot) = slots[i].lock() {
                    *slot = Some(r);
                }
            });
        }
    });
    slots
        .into_iter()
        .filter_map(|m| m.into_inner().ok().flatten())
        .collect()
}

/// Number of worker threads: every core the machine offers.
pub fn default_threads() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get())
}

/// One test at one point, through the probe (no estimator: features only). `multisine`:
/// the configuration's designed multisine, to skip its design ([`Monitor::design_multisine`]).
pub fn run_point(
    cfg: &Config,
    point: &Point,
    method: Method,
    faults: &[Fault],
    multisine: Option<&Multisine>,
) -> TestRun {
    let sc = Scenario {
        speed_mps: point.speed_mps,
        displacement_t: point.displacement_t,
        sea: point.sea,
        faults: faults.to_vec(),
        seed: point.seed,
    };
    let mut opts = ProbeOptions::new(&cfg.core(), method);
    opts.multisine = multisine.cloned();
    let mut sim = cfg.sim();
    if let Some(m) = &point.ship {
        m.apply(&mut sim.structure, &mut sim.autopilot);
    }
    match run_probe(&cfg.core(), &sim, &sc, &opts) {
        Ok(res) => {
            let r = res.report;
            let duration_s = r.t_end - r.t_start;
            let features = match r.outcome {
                Outcome::Completed => Ok(r.features),
                Outcome::Aborted => Err(r.reason.unwrap_or_else(|| "aborted".into())),
            };
            TestRun {
                features,
                duration_s,
            }
        }
        Err(e) => TestRun {
            features: Err(e.to_string()),
            duration_s: f64::NAN,
        },
    }
}

/// Simulates the database of `spec` on `threads` threads. `progress(done, total)` is called
/// from the workers as runs finish (for display only: results do not depend on it).
pub fn simulate(
    cfg: &Config,
    spec: &DatabaseSpec,
    threads: usize,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Database {
    let points = design(cfg, spec);
    let n_points = points.len();
    let n_methods = spec.methods.len();
    let total = n_points * n_methods;
    let done = AtomicUsize::new(0);
    let multisine = Monitor::design_multisine(&cfg.core()).ok();
    // Job j: point j / n_methods, method j % n_methods (both methods of a point together).
    let flat = par_map(total, threads, |j| {
        let run = run_point(
            cfg,
            &points[j / n_methods],
            spec.methods[j % n_methods],
            &spec.faults,
            multisine.as_ref(),
        );
        let d = done.fetch_add(1, Ordering::Relaxed) + 1;
        progress(d, total);
        run
    });
    let mut runs: Vec<Vec<TestRun>> = (0..n_methods)
        .map(|_| Vec::with_capacity(n_points))
        .collect();
    for (j, r) in flat.into_iter().enumerate() {
        runs[j % n_methods].push(r);
    }
    Database {
        spec: spec.clone(),
        points,
        runs,
    }
}

impl Database {
    /// Runs of `method` (empty when it was not simulated).
    pub fn runs_of(&self, method: Method) -> &[TestRun] {
        match self.spec.methods.iter().position(|&m| m == method) {
            Some(k) => &self.runs[k],
            None => &[],
        }
    }

    /// Completed runs of `method`: `(point index, features)`, in point order.
    pub fn completed(&self, method: Method) -> Vec<(usize, &Features)> {
        self.runs_of(method)
            .iter()
            .enumerate()
            .filter_map(|(i, r)| r.features.as_ref().ok().map(|f| (i, f)))
            .collect()
    }

    /// Failed runs of `method`: `(point index, reason)`.
    pub fn failures(&self, method: Method) -> Vec<(usize, &str)> {
        self.runs_of(method)
            .iter()
            .enumerate()
            .filter_map(|(i, r)| r.features.as_ref().err().map(|e| (i, e.as_str())))
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spec(purpose: Purpose, n: usize) -> DatabaseSpec {
        DatabaseSpec {
            seed: 7,
            purpose,
            points_per_sea: n,
            seas: vec![SeaState::Calm, SeaState::Moderate],
            methods: vec![Method::Clfrt, Method::Hbt],
            faults: vec![],
            family: false,
        }
    }

    /// The family's draws come from a stream of their own: the points and seeds are those of
    /// the plain database; every nuisance is drawn inside its documented range, present in
    /// about half the ships and absent in the others.
    #[test]
    fn family_draws_leave_the_design_alone_and_stay_in_range() {
        let cfg = Config::default();
        let plain = design(&cfg, &spec(Purpose::Training, 200));
        let fam = design(
            &cfg,
            &DatabaseSpec {
                family: true,
                ..spec(Purpose::Training, 200)
            },
        );
        assert_eq!(plain.len(), fam.len());
        let mut with_t2 = 0;
        let mut fixed = 0;
        for (p, f) in plain.iter().zip(&fam) {
            assert_eq!(
                (p.sea, p.speed_mps, p.displacement_t, p.seed),
                (f.sea, f.speed_mps, f.displacement_t, f.seed)
            );
            assert!(p.ship.is_none());
            let m = f.ship.unwrap();
            let s = m.structure;
            s.check().unwrap();
            assert!(s.nomoto_t2_ratio <= 0.1 && s.nomoto_t3_ratio <= 0.25);
            assert!(s.norrbin_n3_s2 <= 30000.0);
            assert!(s.rudder_dead_band_deg <= 1.0 && s.rudder_backlash_deg <= 1.0);
            with_t2 += usize::from(s.nomoto_t2_ratio > 0.0);
            fixed += usize::from(m.fixed_gain_autopilot);
        }
        // 400 ships, each half present: 200 +- 3 sigma (30).
        assert!((170..=230).contains(&with_t2), "{with_t2}");
        assert!((170..=230).contains(&fixed), "{fixed}");
    }

    #[test]
    fn latin_hypercube_uses_every_stratum_once_per_dimension() {
        let cfg = Config::default();
        let n = 50;
        let pts = design(&cfg, &spec(Purpose::Training, n));
        assert_eq!(pts.len(), 2 * n);
        for sea_pts in pts.chunks(n) {
            let mut su = vec![0; n];
            let mut sd = vec![0; n];
            for p in sea_pts {
                assert!((4.0..10.0).contains(&p.speed_mps));
                assert!((4000.0..10000.0).contains(&p.displacement_t));
                su[((p.speed_mps - 4.0) / 6.0 * n as f64) as usize] += 1;
                sd[((p.displacement_t - 4000.0) / 6000.0 * n as f64) as usize] += 1;
            }
            assert!(su.iter().all(|&c| c == 1), "{su:?}");
            assert!(sd.iter().all(|&c| c == 1), "{sd:?}");
        }
        assert_eq!(pts[0].sea, SeaState::Calm);
        assert_eq!(pts[n].sea, SeaState::Moderate);
    }

    #[test]
    fn design_is_seeded_and_purposes_are_independent() {
        let cfg = Config::default();
        let a = design(&cfg, &spec(Purpose::Training, 20));
        let b = design(&cfg, &spec(Purpose::Training, 20));
        let c = design(&cfg, &spec(Purpose::Evaluation, 20));
        assert_eq!(a, b);
        assert!(a
            .iter()
            .zip(&c)
            .all(|(x, y)| x.speed_mps != y.speed_mps && x.seed != y.seed));
        // A sea state's points do not depend on the others.
        let mut only_moderate = spec(Purpose::Training, 20);
        only_moderate.seas = vec![SeaState::Moderate];
        assert_eq!(design(&cfg, &only_moderate), a[20..].to_vec());
    }

    #[test]
    fn par_map_keeps_order_whatever_the_threads() {
        let f = |i: usize| (i * i) % 17;
        let one = par_map(100, 1, f);
        let three = par_map(100, 3, f);
        assert_eq!(one, (0..100).map(f).collect::<Vec<_>>());
        assert_eq!(one, three);
        assert!(par_map(0, 2, f).is_empty());
    }
}
