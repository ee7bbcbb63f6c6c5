//! The decision on its own model: Monte Carlo vessels whose residuals are exactly what H0
//! assumes (docs/fdi.md, "The model"), to check that the limits keep
//! `fdi.false-alarms-per-year`.
//!
//! A vessel is commissioned on K Gaussian tests per method (the reference's mean and shape
//! estimated from them, as `reference::MethodReference` does), then decides `tests` tests in
//! turn: each measured against its method's reference, whitened, fed to the window GLR and
//! learned as the daemon learns (`learning::after_decision`). The true scatter is correlated
//! (speed and displacement -0.9, as on a second-order hull; the gain half with the
//! displacement), so the shape the reference estimates matters. An alarm is a rise into the
//! alarm state; the rate per decided test is compared with the budget's per-test share
//! `alpha_test`. Vessel `v` draws from its own ChaCha stream `v` of the seed, so a cell's
//! count is the same on any number of threads.

use super::config::{Calibration, FdiConfig, ReferenceConfig};
use super::decision::Sequential;
use super::learning::{after_decision, Held, Pending};
use super::limits::DecisionLimits;
use super::prior::{ClassScatter, ScatterPrior};
use super::raw::Raw;
use super::reference::{self, MethodReference};
use super::stats::{dot, Cov};
use super::window::{Entry, Source};
use crate::wire::residuals::TrackState;
use crate::wire::Method;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;

/// The test period the budget is spread over [s] (CLFRT and HBT in turn, one an hour and
/// two minutes apart: the default schedule).
pub const TEST_PERIOD_S: f64 = 3720.0;

/// One cell of the Monte Carlo.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cell {
    /// Commissioning tests per method (K).
    pub commissioning_tests: u32,
    /// `fdi.floor-speed-mps` and `fdi.floor-displacement`.
    pub floors: [f64; 2],
    /// Whether healthy tests are learned after commissioning.
    pub learn: bool,
    /// `fdi.false-alarms-per-year`.
    pub budget_per_year: f64,
    /// Vessels.
    pub vessels: usize,
    /// Tests each vessel decides after commissioning.
    pub tests: usize,
    /// The class's prior for the scatter, and the vessels against it.
    pub prior: PriorCase,
}

/// How the cell's vessels stand to the class's prior for their scatter (`prior`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum PriorCase {
    /// No prior: the vessel's own tests alone (every vessel the same scatter).
    Off,
    /// The prior of [`PRIOR_WEIGHT`] dof about the scatter, each vessel's variances drawn
    /// from it (the model the prior states).
    Class,
    /// The same prior; every vessel this many times noisier (variance) than its centre.
    Noisier(f64),
}

/// The prior's weight per component in the Monte Carlo: about the shipped models' class
/// (`calibration.json`'s `healthy-scatter`, 3 to 6 dof).
pub const PRIOR_WEIGHT: [f64; 3] = [5.0, 3.0, 5.0];

/// The prior cells `eval --budget` runs: every K from the smallest allowed to the default,
/// vessels from the prior, then 3x noisier than it, at 30 a year.
pub const PRIOR_SCAN: [Cell; 8] = [
    with_prior(cell(5, [0.0, 0.0], true, 30.0, 600), PriorCase::Class),
    with_prior(cell(6, [0.0, 0.0], true, 30.0, 600), PriorCase::Class),
    with_prior(cell(8, [0.0, 0.0], true, 30.0, 600), PriorCase::Class),
    with_prior(cell(12, [0.0, 0.0], true, 30.0, 600), PriorCase::Class),
    with_prior(cell(16, [0.0, 0.0], true, 30.0, 600), PriorCase::Class),
    with_prior(
        cell(5, [0.0, 0.0], true, 30.0, 600),
        PriorCase::Noisier(3.0),
    ),
    with_prior(
        cell(8, [0.0, 0.0], true, 30.0, 600),
        PriorCase::Noisier(3.0),
    ),
    with_prior(
        cell(16, [0.0, 0.0], true, 30.0, 600),
        PriorCase::Noisier(3.0),
    ),
];

const fn with_prior(c: Cell, prior: PriorCase) -> Cell {
    Cell { prior, ..c }
}

/// The scan `eval --budget` runs and the slow tier checks: K, the floors and learning, each
/// at 30 and 8 false alarms a year, the vessels sized for about a hundred alarms at the
/// budget (a tenth's relative spread); last, the default K at 2 a year, full size.
pub const SCAN: [Cell; 13] = [
    cell(8, [0.0, 0.0], false, 30.0, 300),
    cell(8, [0.0, 0.0], false, 8.0, 1000),
    cell(8, [0.0, 0.0], true, 30.0, 300),
    cell(8, [0.0, 0.0], true, 8.0, 1000),
    cell(16, [0.0, 0.0], true, 30.0, 300),
    cell(16, [0.0, 0.0], true, 8.0, 1000),
    cell(8, [0.2, 0.01], false, 30.0, 300),
    cell(8, [0.2, 0.01], false, 8.0, 1000),
    cell(30, [0.0, 0.0], false, 30.0, 300),
    cell(30, [0.0, 0.0], false, 8.0, 1000),
    cell(200, [0.0, 0.0], false, 30.0, 300),
    cell(200, [0.0, 0.0], false, 8.0, 1000),
    cell(16, [0.0, 0.0], true, 2.0, 20_000),
];

/// A cell of 100 tests a vessel.
const fn cell(k: u32, floors: [f64; 2], learn: bool, budget: f64, vessels: usize) -> Cell {
    Cell {
        commissioning_tests: k,
        floors,
        learn,
        budget_per_year: budget,
        vessels,
        tests: 100,
        prior: PriorCase::Off,
    }
}

/// What a cell measured.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Outcome {
    /// Alarms raised.
    pub alarms: usize,
    /// Tests decided.
    pub decided: usize,
    /// The budget's share per test.
    pub alpha_test: f64,
}

impl Outcome {
    /// The measured rate over the budget's.
    pub fn ratio(&self) -> f64 {
        self.alarms as f64 / self.decided.max(1) as f64 / self.alpha_test
    }

    /// The ratio's two-sided 95 % interval, the count taken as Poisson (the normal
    /// approximation on its square root, good from about ten alarms).
    pub fn ratio_interval(&self) -> [f64; 2] {
        let n = self.alarms as f64;
        let scale = self.decided.max(1) as f64 * self.alpha_test;
        let lo = (n.sqrt() - 0.98).max(0.0).powi(2);
        let hi = (n.sqrt() + 0.98).powi(2) + 1.0;
        [lo / scale, hi / scale]
    }
}

/// The decision's settings for `cell` (the whole commissioning sample resolved, so that a
/// reference's shape is estimated from all K tests).
fn settings(cell: &Cell) -> (DecisionLimits, reference::Settings) {
    let l = DecisionLimits::new(cell.budget_per_year, TEST_PERIOD_S, 4);
    let fdi = FdiConfig {
        commissioning_tests: cell.commissioning_tests,
        floor_speed_mps: cell.floors[0],
        floor_displacement: cell.floors[1],
        ..FdiConfig::default()
    };
    let reference = ReferenceConfig {
        resolve_speed_mps: 1e-9,
        resolve_displacement: 1e-9,
    };
    let class = ClassScatter {
        calm: psi().0,
        moderate: psi().0,
        dof: PRIOR_WEIGHT,
    };
    let cal = Calibration {
        healthy_scatter: (cell.prior != PriorCase::Off).then_some(ScatterPrior {
            clfrt: class,
            hbt: class,
        }),
        ..Calibration::default()
    };
    let s = reference::Settings {
        learn: cell.learn,
        ..reference::Settings::new(&fdi, &reference, &cal, &l)
    };
    (l, s)
}

/// The design spreads of the drawn tests `(s_u [m/s], s_D, s_D)`.
const SPREADS: [f64; 3] = [0.05, 0.002, 0.002];

/// The true scatter's loadings on three standard normals: `e_u` 0.2 m/s, `e_D` 0.01
/// correlated -0.9 with it, `e_b` 0.005 half with `e_D`'s own part.
fn loadings() -> [[f64; 3]; 3] {
    let (su, sd, rho) = (0.2, 0.01, -0.9);
    let q = (1.0f64 - rho * rho).sqrt();
    [
        [su, 0.0, 0.0],
        [sd * rho, sd * q, 0.0],
        [0.0, 0.005 * 0.5, 0.005 * 0.75f64.sqrt()],
    ]
}

/// The true scatter in design-spread units: the prior's centre.
fn psi() -> Cov {
    let m = loadings();
    Cov(std::array::from_fn(|i| {
        std::array::from_fn(|j| {
            (0..3).map(|k| m[i][k] * m[j][k]).sum::<f64>() / (SPREADS[i] * SPREADS[j])
        })
    }))
}

/// One healthy test's raw residuals, drawn from the true scatter, each component's
/// deviation scaled by `sqrt(scale_j)`.
fn draw(rng: &mut ChaCha8Rng, scale: [f64; 3]) -> Raw {
    let e: [f64; 3] = std::array::from_fn(|_| rng.sample(StandardNormal));
    let m = loadings();
    let dev: [f64; 3] =
        std::array::from_fn(|i| scale[i].sqrt() * (0..3).map(|k| m[i][k] * e[k]).sum::<f64>());
    Raw {
        ln_gain: Some(-5.0 + dev[2]),
        ln_damping: None,
        speed_mps: 1.0 + dev[0],
        displacement: -0.2 + dev[1],
        speed_sigma_mps: SPREADS[0],
        displacement_sigma: SPREADS[1],
        speed_log_mps: 7.0,
        displacement_declared_t: 7000.0,
        excitation_scale: 1.0,
        sea_index: None,
        speed_slope: [0.0; 3],
        loading_slope: [0.0; 3],
        meas: None,
        log_slope: 0.0,
    }
}

/// A vessel's scale of each component's variance against the prior's centre.
fn vessel_scale(cell: &Cell, rng: &mut ChaCha8Rng) -> [f64; 3] {
    match cell.prior {
        PriorCase::Off => [1.0; 3],
        PriorCase::Noisier(k) => [k; 3],
        // A scaled inverse chi-square of `w_j` dof: `w_j / chi2_w_j` (whole dof).
        PriorCase::Class => std::array::from_fn(|j| {
            let w = PRIOR_WEIGHT[j];
            let chi: f64 = (0..w as usize)
                .map(|_| rng.sample::<f64, _>(StandardNormal).powi(2))
                .sum();
            w / chi
        }),
    }
}

const DIRECTIONS: [[f64; 3]; 2] = [[-1.0, 0.0, 0.0], [0.0, 1.0, -1.0]];

/// Vessel `v` of the cell: alarms raised and tests decided (`None`: a commissioning
/// sample the reference refused, which the tool counts as a defect).
fn vessel(
    cell: &Cell,
    l: &DecisionLimits,
    settings: &reference::Settings,
    seed: u64,
    v: u64,
) -> Option<(usize, usize)> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(v);
    let k = cell.commissioning_tests as usize;
    let scale = vessel_scale(cell, &mut rng);
    let sample = |rng: &mut ChaCha8Rng, m: usize| {
        let raws: Vec<Raw> = (0..k).map(|_| draw(rng, scale)).collect();
        MethodReference::commissioned_on(&settings.method(m), &raws)
    };
    let mut c = [sample(&mut rng, 0)?, sample(&mut rng, 1)?];
    let (mut s, mut pending) = (Sequential::default(), Pending::default());
    let mut alarms = 0;
    for t in 0..cell.tests {
        let m = t % 2;
        let method = [Method::Clfrt, Method::Hbt][m];
        let raw = draw(&mut rng, scale);
        // The window against the references as they are now, as the daemon does.
        s.remeasure(|e| {
            let src = e.source?;
            let j = usize::from(e.method == Method::Hbt);
            let (_, n) = c[j].measure(&settings.method(j), &src.raw);
            Some(Entry {
                z: n.whitened(),
                offset_var: n.offset_var,
                ..*e
            })
        });
        let (_, meas) = c[m].measure(&settings.method(m), &raw);
        let z = meas.whitened();
        let before = s.state;
        let st = s.update(
            l,
            Entry {
                method,
                z,
                dim: meas.dim,
                offset_var: meas.offset_var,
                epoch: 0,
                directions: DIRECTIONS,
                rudder: None,
                z_rate: Some(rng.sample::<f64, _>(StandardNormal).max(0.0)),
                source: Some(Source {
                    raw,
                    directions: DIRECTIONS,
                    rudder: None,
                }),
                log: None,
            },
        );
        if before != TrackState::Alarm && st.state == TrackState::Alarm {
            alarms += 1;
        }
        // Learned as the daemon learns: under the single-test limit, at once when the
        // decision is quiet, else once it leaves the window with no alarm.
        let q = z.map_or(f64::INFINITY, |z| dot(z, z));
        let held = (cell.learn && q <= l.param[meas.dim]).then_some(Held {
            method: m,
            generation: 0,
            raw,
        });
        for h in after_decision(&mut pending, &mut s, held, l.window)
            .into_iter()
            .flatten()
        {
            c[h.method].add(&settings.method(h.method), &h.raw, 0);
        }
    }
    Some((alarms, cell.tests))
}

/// Runs `cell` on `threads` threads; `None` if a vessel's commissioning was refused.
pub fn run(cell: &Cell, seed: u64, threads: usize) -> Option<Outcome> {
    let (l, settings) = settings(cell);
    let threads = threads.max(1);
    let counts: Vec<Option<(usize, usize)>> = std::thread::scope(|scope| {
        let handles: Vec<_> = (0..threads)
            .map(|t| {
                let (l, settings) = (&l, &settings);
                scope.spawn(move || {
                    (t..cell.vessels)
                        .step_by(threads)
                        .map(|v| vessel(cell, l, settings, seed, v as u64))
                        .try_fold((0, 0), |(a, d), r| r.map(|(x, y)| (a + x, d + y)))
                })
            })
            .collect();
        handles
            .into_iter()
            .map(|h| h.join().ok().flatten())
            .collect()
    });
    let (alarms, decided) = counts
        .into_iter()
        .try_fold((0, 0), |(a, d), r| r.map(|(x, y)| (a + x, d + y)))?;
    Some(Outcome {
        alarms,
        decided,
        alpha_test: l.alpha_test,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_cell_counts_the_same_on_any_number_of_threads() {
        let cell = Cell {
            commissioning_tests: 8,
            floors: [0.0, 0.0],
            learn: true,
            budget_per_year: 300.0,
            vessels: 6,
            tests: 20,
            prior: PriorCase::Off,
        };
        let one = run(&cell, 3, 1).unwrap();
        assert_eq!(run(&cell, 3, 4).unwrap(), one);
        assert_eq!(one.decided, 120);
    }

    #[test]
    fn the_interval_covers_the_ratio_and_narrows_with_the_count() {
        let o = |alarms, decided| Outcome {
            alarms,
            decided,
            alpha_test: 1e-3,
        };
        let small = o(10, 10_000);
        let big = o(1000, 1_000_000);
        for x in [small, big] {
            let [lo, hi] = x.ratio_interval();
            assert!(lo < x.ratio() && x.ratio() < hi, "{x:?}");
        }
        let width = |x: Outcome| x.ratio_interval()[1] - x.ratio_interval()[0];
        // 1 / sqrt(n): a hundred times the count, a tenth of the width.
        let r = width(big) / width(small);
        assert!((0.08..0.12).contains(&r), "{r}");
    }
}
