//! The parity reference of one method (docs/fdi.md, "The vessel's normal"): the design's,
//! the design's with wide limits while commissioning, or the vessel's own over its operating
//! envelope (`envelope`). [`MethodReference::measure`] returns the basis and the residual
//! `(e_u [m/s], e_D [fraction of D_nom], e_b [ln])` with a healthy ship's covariance:
//!
//! - commissioning off: the design spreads, `(e_u, e_D)` only, offset share 0;
//! - commissioning or inconsistent (or no prediction possible): the design spreads widened to
//!   `calibration.commissioning-spread-*`, `(e_u, e_D)` only, no offset share (wide limits);
//! - commissioned: `r = e - mu(x)`, its covariance the local shape pooled with an
//!   inverse-Wishart prior of [`PRIOR_DOF`] dof and carried by the design spreads, then with
//!   the class's prior where the vessel's scatter is the class's (`prior`), plus `Omega(x)`,
//!   the floors and a CLFRT test's own excess error (`noise`). At a loading, excitation or
//!   sea over a bandwidth from every learned test the dof are at most the kernel weight
//!   there less one.
//!
//! [`MethodReference::add`] takes only finite tests with positive spreads and displacement, none
//! with commissioning off, and keeps at most [`MEMORY_TESTS`] (`envelope::forget`). The sample
//! ends at `K = fdi.commissioning-tests`, or from `min(K, MIN_TESTS)` tests once it resolves
//! `reference.resolve-*` (`resolve`) or the vessel's other method, commissioned, resolves
//! them ([`complete_on_other`]).
//!
//! A completed sample goes to the change-point test (`changepoint`).

use super::ablation::{self, Mechanism};
use super::config::{Calibration, FdiConfig, ReferenceConfig};
use super::envelope::{self, Shape};
use super::limits::DecisionLimits;
use super::measured::{kappa, Basis, Measured};
use super::noise;
use super::point::{self, Sample};
use super::prior::{ClassScatter, Verdict};
use super::raw::Raw;
use super::stats::{Cov, P};
use serde::{Deserialize, Serialize};

/// Learned tests kept per method (the fullest soft bin forgets first): enough for every
/// point of a vessel's operating envelope, each a few times over.
pub const MEMORY_TESTS: usize = 200;

/// The degrees of freedom of the prior the local shape is pooled with (an inverse Wishart
/// about the vessel's learned variances, uncorrelated): `P + 2`, the weakest whose mean
/// exists. The calibration keeps the shape's own dof: the prior's centre is the sample's
/// variances.
pub const PRIOR_DOF: f64 = P as f64 + 2.0;

/// Where one method's reference stands.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", tag = "phase")]
pub enum Phase {
    /// Gathering the commissioning sample.
    #[default]
    Commissioning,
    /// The sample held a change at test `at`: no reference until commissioned again.
    Inconsistent {
        /// The first test after the change (1-based).
        at: u32,
        /// The change-point test's combined tail probability (`changepoint::Change`).
        statistic: f64,
    },
    /// Commissioned; learning its healthy tests.
    Learning,
}

/// What the reference needs, from `[fdi]`, `[reference]` and the decision's limits (see
/// `crate::fdi::reference`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Settings {
    /// K: at most this many tests per method (0: the design reference for good).
    pub tests: u32,
    /// Speed spread floor while commissioning [m/s].
    pub wide_speed_mps: f64,
    /// Displacement spread floor while commissioning [fraction of D_nom].
    pub wide_displacement: f64,
    /// Physical floor of the speed residual's standard deviation [m/s].
    pub floor_speed_mps: f64,
    /// Physical floor of the displacement residual's standard deviation [fraction].
    pub floor_displacement: f64,
    /// The regression over the operating envelope.
    pub envelope: point::Regression,
    /// Learn healthy tests after commissioning.
    pub learn: bool,
    /// At most this many learned tests per method.
    pub memory: usize,
    /// The speed-log fault commissioning must resolve [m/s].
    pub resolve_speed_mps: f64,
    /// The displacement fault commissioning must resolve [fraction].
    pub resolve_displacement: f64,
    /// `h_1`: the decision's single-test limit.
    pub single_limit: f64,
    /// The change-point test's tail probability per (evaluation, moment) at commissioning's
    /// end.
    pub change_alpha: f64,
    /// Its tail probability per (evaluation, moment) in the confirmation after it.
    pub confirm_alpha: f64,
    /// Read a CLFRT test with its own measurement error beyond the vessel's typical.
    pub own_noise: bool,
    /// Per method (CLFRT, HBT), the class's prior for the scatter (`prior`).
    pub priors: [Option<ClassScatter>; 2],
    /// The method's whose reference these settings are for ([`Settings::method`]).
    pub prior: Option<ClassScatter>,
    /// The sea index's calm and moderate anchors [deg].
    pub sea_anchors: [f64; 2],
}

impl Settings {
    /// What the reference needs, from `[fdi]`, `[reference]` and the decision's `limits`.
    pub fn new(
        fdi: &FdiConfig,
        r: &ReferenceConfig,
        cal: &Calibration,
        limits: &DecisionLimits,
    ) -> Self {
        // One ship-day of the alarm budget per commissioning, half at its end, half in the
        // confirmation after it (`changepoint`).
        let budget = fdi.false_alarms_per_year / 365.25 / 2.0;
        let looks = looks(fdi.commissioning_tests) as f64;
        let confirm = confirmation_looks(fdi.commissioning_tests) as f64;
        Self {
            tests: fdi.commissioning_tests,
            wide_speed_mps: cal.commissioning_spread_speed_mps,
            wide_displacement: cal.commissioning_spread_displacement,
            floor_speed_mps: fdi.floor_speed_mps,
            floor_displacement: fdi.floor_displacement,
            envelope: point::Regression::of(cal),
            learn: !super::ablation::off(super::ablation::Mechanism::Learning),
            memory: MEMORY_TESTS,
            own_noise: !super::ablation::off(super::ablation::Mechanism::OwnNoise),
            resolve_speed_mps: r.resolve_speed_mps,
            resolve_displacement: r.resolve_displacement,
            single_limit: limits.param[P],
            change_alpha: budget / looks,
            confirm_alpha: budget / confirm,
            priors: std::array::from_fn(|i| {
                let off = super::ablation::off(super::ablation::Mechanism::ClassPrior);
                cal.healthy_scatter.filter(|_| !off).map(|h| h.of(i))
            }),
            prior: None,
            sea_anchors: cal.sea_wave_yaw_deg,
        }
    }

    /// The settings for method `i`'s reference (0 CLFRT, 1 HBT): its class prior.
    pub fn method(&self, i: usize) -> Self {
        Self {
            prior: self.priors.get(i).copied().flatten(),
            ..*self
        }
    }

    /// The floors of `(e_u, e_D, e_b)`'s standard deviations: error sources the learned
    /// tests cannot see (`e_b`'s the displacement's: `b` scales with `1 / D`).
    pub fn floors(&self) -> [f64; P] {
        [
            self.floor_speed_mps,
            self.floor_displacement,
            self.floor_displacement,
        ]
    }
}

/// One method's reference for the vessel's whole life: its commissioning sample, then the
/// healthy tests learned after it (the phase says which holds).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct MethodReference {
    /// Tests in the commissioning sample.
    pub tests: u32,
    /// Where it stands.
    pub phase: Phase,
    /// The learned tests (the commissioning sample, then healthy tests), oldest first.
    pub samples: Vec<Sample>,
    /// Tests learned after commissioning.
    pub learned: u32,
    /// The scatter's shape over the learned tests.
    pub shape: Option<Shape>,
    /// A summary of the vessel's reference, once commissioned.
    pub reference: Option<Reference>,
}

pub use super::summary::Reference;

/// What adding a test did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Added {
    /// Nothing (not gathering, or not a finite test).
    Nothing,
    /// Joined the commissioning sample.
    Sample,
    /// Completed commissioning.
    Completed,
    /// The vessel's change-point test found a change in a commissioning sample (each
    /// method's test of it in its `Phase::Inconsistent`).
    Inconsistent,
    /// Learned after commissioning.
    Learned,
}

impl MethodReference {
    /// Whether the sample is still being gathered (and commissioning is configured).
    pub fn in_progress(&self, s: &Settings) -> bool {
        s.tests > 0 && self.phase == Phase::Commissioning
    }

    /// The basis and residual of `raw`.
    pub fn measure(&self, s: &Settings, raw: &Raw) -> (Basis, Measured) {
        // Design and wide limits know nothing of `e_b` (a hull's gain is its own): the
        // first two components only.
        let e2 = [raw.speed_mps, raw.displacement, 0.0];
        let wide = Measured {
            r: e2,
            cov: Cov::diag([
                raw.speed_sigma_mps.max(s.wide_speed_mps),
                raw.displacement_sigma.max(s.wide_displacement),
                1.0,
            ]),
            offset_var: None,
            dof: f64::INFINITY,
            learned: Cov::default(),
            dim: 2,
            bounded: false,
            noise_ratio: 1.0,
        };
        if s.tests == 0 {
            let m = Measured {
                r: e2,
                cov: Cov::diag([raw.speed_sigma_mps, raw.displacement_sigma, 1.0]),
                offset_var: Some(0.0),
                dof: f64::INFINITY,
                learned: Cov::default(),
                dim: 2,
                bounded: false,
                noise_ratio: 1.0,
            };
            return (Basis::Design, m);
        }
        let commissioning = Basis::Commissioning {
            done: self.tests,
            of: s.tests,
        };
        match self.phase {
            Phase::Commissioning => (commissioning, wide),
            Phase::Inconsistent { at, .. } => (Basis::Inconsistent { at }, wide),
            Phase::Learning => {
                let Some(shape) = self.shape else {
                    return (commissioning, wide);
                };
                let own = Sample::from(raw);
                let at = own.point();
                // The scatter as the tests near this point show it (the shape learned
                // elsewhere where there are none).
                let local = envelope::local_shape(&self.samples, &s.envelope, &shape, &at);
                // Pooled with the prior: the vessel's variances everywhere, uncorrelated.
                let k = local.dof / (local.dof + PRIOR_DOF);
                let prior = Cov::diag(shape.cov.variances().map(f64::sqrt));
                let shape = envelope::Shape {
                    cov: local.cov.times(k).plus(prior.times(1.0 - k)),
                    ..local
                };
                // With the class's prior where the vessel's scatter is the class's (`prior`).
                let frac = super::raw::sea_fraction(s.sea_anchors, raw.sea_index);
                let (shape, class_dofs) = self.with_class(s, shape, frac);
                let Some(p) =
                    envelope::predict_for(&self.samples, &s.envelope, &shape, &at, &own.slopes())
                else {
                    return (commissioning, wide);
                };
                // The scatter and the offset's error rest on the learned tests, except the
                // offset error's part that is the slope prior's: a stated model of how far the
                // similarity law may miss away from the learned points, known like the floors.
                let scatter = shape.cov.scaled(raw.s());
                let d = p.prior_share.map(|x| (1.0 - x).clamp(0.0, 1.0).sqrt());
                let dim = raw.dim();
                let learned = scatter.plus(p.cov.scaled(d)).leading(dim, 0.0);
                let floors = Cov::diag(s.floors());
                let known = scatter.plus(p.cov).plus(floors).leading(dim, 1.0);
                // A test whose own tones are noisier than the vessel's typical at its sea is
                // read with its own interval (`noise`): the excess is known, like the floors.
                let typical = s
                    .own_noise
                    .then(|| {
                        let w = at.x(&s.envelope)[3];
                        noise::typical(&self.samples, &s.envelope, w, raw.s())
                    })
                    .flatten();
                let excess = noise::excess(raw.meas, typical).leading(dim, 0.0);
                let cov = known.plus(excess);
                let e = raw.e();
                let r = std::array::from_fn(|j| if j < dim { e[j] - p.offset[j] } else { 0.0 });
                // A learned loading, excitation and sea (a visited point is at one:
                // `nearest_conditions <= nearest`).
                let known_conditions = p.nearest_conditions <= 1.0;
                let m = Measured {
                    r,
                    cov,
                    offset_var: Some(p.cov.leading(dim, 0.0).max_ratio(cov)),
                    // At a declared loading, an excitation or a sea not yet visited the
                    // prediction is known only as well as the tests near it vouch for it
                    // (module doc); at a new speed only the offset is new, in `p.cov`.
                    dof: {
                        // With the class's prior, the dof along this residual (`prior::along`).
                        let dof = match (class_dofs, cov.solve(r)) {
                            (Some(d), Some(y)) => super::prior::along(d, learned, y),
                            _ => shape.dof,
                        };
                        if known_conditions {
                            dof
                        } else {
                            dof.min(p.support - 1.0)
                        }
                    },
                    learned,
                    dim,
                    bounded: known_conditions,
                    noise_ratio: 1.0 + excess.max_ratio(known),
                };
                (Basis::Vessel(p), m)
            }
        }
    }

    /// Adds a healthy test (the caller has judged it so), the vessel's test number `order`:
    /// to the commissioning sample, or to what the vessel has learned. A change inside the
    /// sample is the vessel's to find, over both methods (`changepoint::check`).
    pub fn add(&mut self, s: &Settings, raw: &Raw, order: u64) -> Added {
        let smp = Sample {
            order,
            ..Sample::from(raw)
        };
        let finite = smp.e.iter().chain(&smp.s).all(|v| v.is_finite())
            && smp.s.iter().all(|v| *v > 0.0)
            && smp.speed_mps.is_finite()
            && smp.displacement_t.is_finite()
            && smp.displacement_t > 0.0;
        if !finite || s.tests == 0 {
            return Added::Nothing;
        }
        match self.phase {
            Phase::Commissioning => {
                self.samples.push(smp);
                self.tests += 1;
                self.shape = envelope::shape(&self.samples, &s.envelope);
                let least = s.tests.min(MIN_TESTS as u32);
                if self.tests >= s.tests || (self.tests >= least && self.resolved(s)) {
                    self.phase = Phase::Learning;
                    self.summarize(s);
                    Added::Completed
                } else {
                    Added::Sample
                }
            }
            Phase::Learning if s.learn => {
                self.samples.push(smp);
                self.learned += 1;
                envelope::forget(&mut self.samples, &s.envelope, s.memory.max(MIN_TESTS));
                if let Some(sh) = envelope::shape(&self.samples, &s.envelope) {
                    self.shape = Some(sh);
                }
                self.summarize(s);
                Added::Learned
            }
            _ => Added::Nothing,
        }
    }

    /// A reference commissioned on `raws` as they are: no change-point test, no early end
    /// (the decision's Monte Carlo, tools); `None` with fewer than 5 finite tests.
    pub fn commissioned_on(s: &Settings, raws: &[Raw]) -> Option<Self> {
        let samples: Vec<Sample> = raws.iter().map(Sample::from).collect();
        let shape = envelope::shape(&samples, &s.envelope)?;
        let mut c = Self {
            tests: samples.len() as u32,
            phase: Phase::Learning,
            samples,
            learned: 0,
            shape: Some(shape),
            reference: None,
        };
        (c.tests >= 5).then(|| {
            c.summarize(s);
            c
        })
    }

    /// The scatter test of the vessel's shape against its class's prior (`prior::verdict`).
    pub fn class_verdict(&self, s: &Settings) -> Option<Verdict> {
        super::prior::verdict(s.prior, self.shape, &self.samples, s.sea_anchors)
    }

    /// `shape` with the class's prior at sea fraction `frac`, and each component's dof, where
    /// the scatter test keeps it (`prior::with_class`).
    pub fn with_class(&self, s: &Settings, shape: Shape, frac: f64) -> (Shape, Option<[f64; P]>) {
        super::prior::with_class(s.prior, self.class_verdict(s), shape, frac)
    }

    /// Whether the sample resolves the faults commissioning must (`resolve`).
    fn resolved(&self, s: &Settings) -> bool {
        let Some(sh) = self.shape else { return false };
        let (sh, class_dofs) = self.with_class(
            s,
            sh,
            super::prior::mean_sea_fraction(&self.samples, s.sea_anchors),
        );
        let need = super::resolve::Faults {
            speed_mps: s.resolve_speed_mps,
            displacement: s.resolve_displacement,
            floors: s.floors(),
            single_limit: s.single_limit,
        };
        need.resolved(&self.samples, sh.cov, class_dofs.unwrap_or([sh.dof; P]))
    }

    /// Updates the summary from the learned tests.
    fn summarize(&mut self, s: &Settings) {
        let (Some(sh), false) = (self.shape, self.samples.is_empty()) else {
            return;
        };
        let n = self.samples.len() as f64;
        let mean = |f: &dyn Fn(&Sample) -> f64| self.samples.iter().map(f).sum::<f64>() / n;
        let range = |f: &dyn Fn(&Sample) -> f64| {
            self.samples
                .iter()
                .map(f)
                .fold([f64::INFINITY, f64::NEG_INFINITY], |r, v| {
                    [r[0].min(v), r[1].max(v)]
                })
        };
        let verdict = self.class_verdict(s);
        let (sh, _) = super::prior::with_class(
            s.prior,
            verdict,
            sh,
            super::prior::mean_sea_fraction(&self.samples, s.sea_anchors),
        );
        let s_u = mean(&|x| x.s[0]);
        let s_d = mean(&|x| x.s[1]);
        let s_b = mean(&|x| x.s[2]);
        let u = mean(&|x| x.speed_mps);
        let at = point::Point {
            speed_mps: u,
            displacement_t: mean(&|x| x.displacement_t.ln()).exp(),
            excitation_scale: mean(&|x| x.excitation_scale.ln()).exp(),
            sea_index: super::point::log_mean(self.samples.iter().filter_map(|x| x.sea_index)),
        };
        let off = envelope::predict(&self.samples, &s.envelope, &sh, &at).map_or(
            [mean(&|x| x.e[0]), mean(&|x| x.e[1]), mean(&|x| x.e[2])],
            |p| p.offset,
        );
        self.reference = Some(Reference {
            tests: self.tests,
            learned: self.samples.len() as u32,
            speed_offset_mps: off[0],
            displacement_offset: off[1],
            ln_gain: off[2],
            covariance: sh.cov.scaled([s_u, s_d, s_b]),
            dof: sh.dof,
            speed_design_sigma_mps: s_u,
            displacement_design_sigma: s_d,
            speed_log_mps: u,
            speed_range_mps: range(&|x| x.speed_mps),
            displacement_range_t: range(&|x| x.displacement_t),
            class_scatter_ratio: verdict.map(|v| v.ratio),
            class_prior: verdict.is_some_and(|v| v.used),
        });
    }

    /// The reference over speed at the declared displacement `d_t`, the excitation as
    /// designed: per speed, the
    /// predicted offset `(e_u, e_D)` and its standard deviations (the prediction's, the
    /// shape's at the learned tests' mean design spreads and the floors). For plots.
    pub fn curve(&self, s: &Settings, speeds: &[f64], d_t: f64) -> Vec<(f64, [f64; 2], [f64; 2])> {
        let (Some(sh), Some(r)) = (self.shape, self.reference) else {
            return Vec::new();
        };
        let k = kappa(sh.dof);
        speeds
            .iter()
            .filter_map(|&u| {
                let at = point::Point {
                    speed_mps: u,
                    displacement_t: d_t,
                    excitation_scale: 1.0,
                    sea_index: None,
                };
                let p = envelope::predict(&self.samples, &s.envelope, &sh, &at)?;
                let sd = |var: f64, pv: f64, floor: f64| (k * (var + pv) + floor * floor).sqrt();
                let (v, pv) = (r.covariance.variances(), p.cov.variances());
                Some((
                    u,
                    [p.offset[0], p.offset[1]],
                    [
                        sd(v[0], pv[0], s.floor_speed_mps),
                        sd(v[1], pv[1], s.floor_displacement),
                    ],
                ))
            })
            .collect()
    }

    /// Starts again: the sample, what was learned and the reference are dropped.
    pub fn restart(&mut self) {
        *self = Self::default();
    }

    /// `off`, `commissioning`, `inconsistent` or `commissioned`.
    pub fn state(&self, s: &Settings) -> &'static str {
        match (s.tests, self.phase) {
            (0, _) => "off",
            (_, Phase::Commissioning) => "commissioning",
            (_, Phase::Inconsistent { .. }) => "inconsistent",
            (_, Phase::Learning) => "commissioned",
        }
    }

    /// Status text: "commissioning k of at most K", "commissioned (...)", or why not.
    pub fn describe(&self, s: &Settings) -> String {
        match (s.tests, self.phase, &self.reference) {
            (0, _, _) => "design reference (commissioning off)".into(),
            (_, Phase::Commissioning, _) => {
                format!("commissioning {} of at most {}", self.tests, s.tests)
            }
            // A change after the commissioning tests: only from a state saved before the
            // confirmation kept to the moments inside them (`changepoint::confirm`).
            (_, Phase::Inconsistent { at, .. }, _) if at > self.tests => format!(
                "commissioning inconsistent: a change at test {at}, {} after its {} commissioning tests; commission again after repairs",
                at - self.tests,
                self.tests
            ),
            (_, Phase::Inconsistent { at, .. }, _) => format!(
                "commissioning inconsistent: a change at test {at} of {}; commission again after repairs",
                self.tests
            ),
            (_, Phase::Learning, Some(r)) => format!(
                "commissioned ({} tests, {} learned, {:.1}-{:.1} m/s{})",
                r.tests,
                r.learned,
                r.speed_range_mps[0],
                r.speed_range_mps[1],
                super::prior::describe(r.class_scatter_ratio, r.class_prior)
            ),
            (_, Phase::Learning, None) => "commissioned".into(),
        }
    }
}

/// The fewest tests the test runs on.
pub const MIN_TESTS: usize = 6;

/// The number of (evaluation, moment) pairs a commissioning of up to `k_max` tests of each
/// method can make: the joint test runs when a method completes its sample (twice), over
/// at most one moment between each two of the vessel's tests (at most `2 k_max` of them).
/// Bonferroni's count, a bound whatever the order of the methods' tests.
pub fn looks(k_max: u32) -> usize {
    2 * (2 * k_max.max(MIN_TESTS as u32) as usize - 1)
}

/// The number of (evaluation, moment) pairs the confirmation can make: one evaluation at
/// each of the `k_max` tests each method learns after its commissioning (its sample then
/// holds at most `2 k_max`), over at most `4 k_max - 1` moments (both methods' samples at
/// most `2 k_max` tests).
pub fn confirmation_looks(k_max: u32) -> usize {
    let k = k_max.max(MIN_TESTS as u32) as usize;
    2 * k * (4 * k - 1)
}

/// Ends method `i`'s commissioning on the vessel's other method (docs/fdi.md,
/// "Commissioning"): at `min(K, MIN_TESTS)` tests or more, when the other method is
/// commissioned and its sample resolves the faults. The vessel's decision weighs both
/// methods' tests, each at its own dof: the promised detection rests on the resolved one,
/// and `i`'s reference, Hotelling-wide at its few tests, keeps learning. Returns whether it
/// ended.
pub fn complete_on_other(c: &mut [MethodReference; 2], i: usize, s: &Settings) -> bool {
    let (x, other) = (&c[i], &c[1 - i]);
    let done = !ablation::off(Mechanism::OneResolved)
        && x.phase == Phase::Commissioning
        && x.tests >= s.tests.min(MIN_TESTS as u32)
        && other.phase == Phase::Learning
        && other.resolved(&s.method(1 - i));
    if done {
        c[i].phase = Phase::Learning;
        c[i].summarize(&s.method(i));
    }
    done
}

/// The vessel's number for its next test: one past the newest sample's of either method
/// (samples restored from a state without numbers count as 0).
pub fn next_order(c: &[MethodReference; 2]) -> u64 {
    c.iter()
        .flat_map(|x| x.samples.iter().map(|s| s.order))
        .max()
        .map_or(1, |o| o + 1)
}

#[cfg(test)]
#[path = "reference_tests.rs"]
mod tests;
