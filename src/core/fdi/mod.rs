//! Parity-space fault detection and isolation: residuals, decision, alarm state, isolation.
//!
//! ## Residuals (one completed test)
//!
//! ```text
//! r_speed = u_est(f) - u_log - m_u            [m/s]  z_speed = r_speed / s_u
//! r_disp  = D_est(f, u_log) - D_nom - m_D     [t]    z_disp  = r_disp  / s_D
//! ```
//!
//! `f` are the test's features, `u_log` the mean speed-log reading over the test, `D_nom` the
//! nominal displacement (`ship.nominal-displacement-t`, or the latest `design/displacement` the
//! ship published). `m` and `s` are the estimator's own bias and spread on its validation set
//! (recorded per sea state in the model files; for the displacement, by default, relative to
//! the truth and scaled by `D_nom`: `fdi.relative-spread-*`), chosen by how disturbed the sea
//! is: the *sea index* is the test's wave yaw (`features.wave_yaw_rad`, the heading's rms in
//! `fdi.wave-band-rad-s`, in deg), optionally remembered as a decaying maximum over the
//! method's tests (`fdi.sea-memory`, default 0), and it interpolates linearly between the calm
//! and the moderate spread, anchored at `fdi.sea-wave-yaw-deg` (above the moderate anchor the
//! spread keeps growing, up to 3 times the moderate one; a test without a wave yaw gets the
//! moderate spread).
//!
//! These are the residuals against the *design* reference. After commissioning (the first
//! `fdi.commissioning-tests` healthy tests of each method) each is measured against the
//! vessel's own reference instead: offset removed, spread the larger of the design's and the
//! vessel's own scatter; while commissioning, the design's with wide spreads
//! (`reference`, docs/fdi.md). A CLFRT model fit far above any first-order model's
//! (`fdi.model-mismatch-chi2`) adds a `model_mismatch` warning, never a decision.
//!
//! Both methods carry a *servo check* (actuator residual): the rudder's measured rate against
//! the healthy servo's, `rho`, gives the one-sided `z_rate = max(0, 1 - rho) /
//! fdi.actuator-rate-sigma`: a rate-limited servo cannot follow. CLFRT reads the rudder's
//! 95th-percentile rate during its servo-check burst; HBT the median over the measured periods
//! of each period's peak rate, which the relay's steps drive to the rate limit
//! (`features.servo_rate`; 1.01 healthy, 0.52 with a 2 deg/s servo, in either sea).
//!
//! CLFRT adds a second parity check:
//! - the *model fit*: the three measured G(jw_k) = psi/delta against the Nomoto model
//!   b / (jw (jw + a)) fitted by weighted least squares (weights from the tones' own 90 %
//!   intervals, floored by `fdi.model-fit-floor-*`): six numbers, two unknowns, a chi-square
//!   with four degrees of freedom over the four directions no (u, D) explains. It is reported;
//!   it enters the decision only with `fdi.model-fit-decides = true` (see docs/fdi.md).
//!
//! ## Decision (per method, tests of the same method in sequence)
//!
//! Chi-square rule: `q = z_speed^2 + z_disp^2` (m = 2) and `q_act = z_rate^2`
//! (compared with the same limit: conservative for one degree of freedom); a test *exceeds* when either is above `fdi.chi2-threshold` (13.82:
//! 0.1 % for m = 2); a test whose `q` exceeds `fdi.chi2-single-threshold` (60) or whose `q_act`
//! exceeds `fdi.actuator-single-threshold` (25) is an alarm by itself (overwhelming evidence);
//! so is the mean of the method's last `fdi.mean-window` (3) tests' z (each clipped to
//! `fdi.glr-clip`, all against one reference, never on wide design limits) when its
//! statistic `T_n` (the GLR rule's, below, for that one n) exceeds `fdi.mean-threshold` (20):
//! a small shift that persists; so is the vessel's window (`vessel`), the sum of the ship's
//! last `fdi.vessel-window` (3) tests' `q` of both methods, against `fdi.vessel-threshold`
//! (30): the methods' evidence added. CUSUM rule: a two-sided CUSUM per normalised residual,
//! `S+ = max(0, S+ + z - k)`, `S- = max(0, S- - z - k)`; a test exceeds when any sum is above
//! `h`. GLR rule: the mean of the last n tests' z (n = 1 to `fdi.glr-window`), squared and
//! scaled to its variance, `T_n = |z_mean|^2 (1 + c) / (1/n + c)` (`c = 1/K` once
//! commissioned with K tests: the reference offset's error is shared by the window), against
//! `fdi.glr-threshold`; a test exceeds when a `T_n` or its own chi-square is over its limit.
//! State machine: `normal -> alert` at the first exceeding test, `-> alarm` after
//! `fdi.persistence` exceeding tests in a row (1 for CUSUM, which integrates by itself; for
//! the GLR rule, when a `T_n` is over its limit);
//! an alert clears at the next test that does not exceed, an alarm after `fdi.clear-after` of
//! them. The report's decision follows the state after the test: normal `nominal`, alert
//! `inconclusive`, alarm `fault`. Aborted tests and tests without an estimate change nothing.
//!
//! ## Isolation (directional residuals, a GLR over the episode)
//!
//! In normalised coordinates each cause moves `z = (z_speed, z_disp)` along its own direction:
//! a speed-log bias `beta` gives `r_speed = -beta` and `r_disp = g beta` with `g = dD_est/du_log`
//! (the displacement network's own sensitivity, by a central difference at this test), so
//! `v_log = (-1/s_u, g/s_D)`; a displacement change, or a rudder effectiveness loss (both lower
//! `b`; nothing in the features tells them apart), gives `v_D = (0, 1)`; an actuator that adds
//! lag to the loop moves the speed estimate alone, `v_act = (1, 0)` (what the HBT period
//! showed with a slow servo; the servo checks now carry it in both methods). The cost of a cause over the tests of the episode (since it left `normal`) is the
//! sum of each test's squared distance to the cause's line, `J = sum_k (|z_k|^2 - (v_k.z_k)^2 /
//! |v_k|^2)` (each test its own magnitude: a fault's size and the estimator's error vary from
//! test to test); the cause with the lowest cost is named, and others within
//! `fdi.isolation-margin` of it too. A servo check that exceeded in the episode names
//! `steering_actuator`. A heading-sensor drift moves none of these residuals: the features are
//! drift-free by construction (docs/fdi.md).
//!
//! The vessel's naming (`fdi.isolation-across-methods`, default on): while both methods are
//! out of `normal`, the report and the notification name the parameter cause from CLFRT's
//! episode (when its parameter residuals exceeded in it), and the steering actuator when a
//! servo check of either method exceeded. CLFRT's tones sit at fixed frequencies: a change of
//! `b` moves their gains, not their phases, whatever the hull's structure. HBT's cycle
//! frequency moves with `b`, and on a hull with more lag than the first-order model the phase
//! it reads speed from moves with it: its displacement change leans to the speed log's line
//! (measured on the second-order hull: a 10 % heavier ship lowers HBT's speed estimate by
//! 0.2-0.7 m/s). The method's own naming stays in `residuals.isolation_across_methods`.
//!
//! The same rule runs on the equation-error baseline's estimate (`crate::core::baseline`, reported
//! under `residuals.baseline`) for comparison; only the method's own decision drives the
//! alarm.

pub mod config;
mod fit;
pub mod reference;
pub mod vessel;

use crate::core::estimator::model::{Target, Uncertainty};
use crate::core::estimator::{Estimator, EstimatorScratch};
use crate::core::fdi::config::{DecisionRule, FdiConfig};
use crate::core::model::ShipConfig;
pub use crate::core::model::{displacement_from_b, speed_from_a};
use crate::core::monitor::config::CoreConfig;
use crate::core::wire::Method;
use crate::core::wire::{AlarmState, Cause, Decision, Estimate, Features, Notification};
use reference::{Basis, Commissioning, Raw};
use serde_json::{json, Value};
use std::collections::VecDeque;
use vessel::VesselWindow;

/// Speed step of the central difference for `dD/du_log` [m/s].
const DU_MPS: f64 = 0.05;

/// Parameter residuals of one test (ours or the baseline's).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ParamResiduals {
    /// `u_est - u_log - bias` [m/s].
    pub speed_mps: f64,
    /// Its spread [m/s].
    pub speed_sigma_mps: f64,
    /// `D_est(f, u_log) - D_nom - bias` [t].
    pub displacement_t: f64,
    /// Its spread [t].
    pub displacement_sigma_t: f64,
    /// `dD_est / du_log` at this test [t per m/s]: the speed-log fault's direction.
    pub dd_du_t_per_mps: f64,
}

impl ParamResiduals {
    /// Normalised residual vector `(z_speed, z_disp)`.
    pub fn z(&self) -> [f64; 2] {
        [
            self.speed_mps / self.speed_sigma_mps,
            self.displacement_t / self.displacement_sigma_t,
        ]
    }

    /// Directions of the parameter causes in normalised coordinates: speed log,
    /// displacement (or rudder effectiveness), and the actuator's signature (the speed
    /// estimate alone moves: a slower servo adds lag to the loop, which the features read as
    /// another speed, while the log and the displacement agree with each other).
    /// In [`Cause::ALL`]'s order.
    fn directions(&self) -> [[f64; 2]; 3] {
        [
            [
                -1.0 / self.speed_sigma_mps,
                self.dd_du_t_per_mps / self.displacement_sigma_t,
            ],
            [0.0, 1.0],
            [1.0, 0.0],
        ]
    }

    fn to_json(self) -> Value {
        let z = self.z();
        json!({
            "speed_mps": self.speed_mps,
            "speed_sigma_mps": self.speed_sigma_mps,
            "z_speed": z[0],
            "displacement_t": self.displacement_t,
            "displacement_sigma_t": self.displacement_sigma_t,
            "z_displacement": z[1],
            "dd_du_t_per_mps": self.dd_du_t_per_mps,
        })
    }
}

/// Alarm state of one track.
#[derive(
    Debug,
    Clone,
    Copy,
    PartialEq,
    Eq,
    PartialOrd,
    Ord,
    Default,
    serde::Serialize,
    serde::Deserialize,
)]
#[serde(rename_all = "lowercase")]
pub enum TrackState {
    /// Nothing exceeded lately.
    #[default]
    Normal,
    /// Exceeded, not yet persistently.
    Alert,
    /// Exceeded persistently: a fault.
    Alarm,
}

impl TrackState {
    /// The Signal K notification state.
    pub fn alarm_state(self) -> AlarmState {
        match self {
            TrackState::Normal => AlarmState::Normal,
            TrackState::Alert => AlarmState::Alert,
            TrackState::Alarm => AlarmState::Alarm,
        }
    }
    /// The report's decision.
    pub fn decision(self) -> Decision {
        match self {
            TrackState::Normal => Decision::Nominal,
            TrackState::Alert => Decision::Inconclusive,
            TrackState::Alarm => Decision::Fault,
        }
    }
}

/// Sums over the tests of an episode (O(1) memory).
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize, serde::Deserialize)]
struct Episode {
    tests: u32,
    /// Per parameter cause (speed log, displacement, actuator): the sum over the episode's
    /// tests of the squared distance of z to the cause's line.
    cost: [f64; 3],
    /// Sum of |z|^2 of the parameter residuals.
    zz: f64,
    param_exceeded: u32,
    actuator_exceeded: u32,
    /// Sum of the actuator chi-square over the episode (orders the causes).
    q_act: f64,
    q_param: f64,
}

/// What one test did to a track.
#[derive(Debug, Clone, PartialEq)]
pub struct TrackOutcome {
    /// State after the test.
    pub state: TrackState,
    /// The test's decision (from the state).
    pub decision: Decision,
    /// Suspected causes, most likely first (empty when normal).
    pub isolation: Vec<Cause>,
    /// This test's parameter chi-square (NaN without parameter residuals).
    pub q_param: f64,
    /// This test's actuator chi-square, if there was a servo check.
    pub q_actuator: Option<f64>,
    /// Whether this test exceeded.
    pub exceeded: bool,
    /// Exceeding tests in a row.
    pub exceed_run: u32,
    /// GLR rule: the largest window statistic and its window length [tests]; chi-square
    /// rule: the mean of the last `fdi.mean-window` tests (reported as `mean`).
    pub glr: Option<GlrLook>,
}

impl TrackOutcome {
    fn to_json(&self, cfg: &FdiConfig) -> Value {
        let mut v = json!({
            "chi2": finite_or_null(self.q_param),
            "chi2_actuator": self.q_actuator,
            "threshold": cfg.chi2_threshold,
            "exceeded": self.exceeded,
            "exceed_run": self.exceed_run,
            "state": self.state,
        });
        if let (Some(g), Some(o)) = (self.glr, v.as_object_mut()) {
            let key = match cfg.rule {
                DecisionRule::Glr => "glr",
                _ => "mean",
            };
            o.insert(
                key.into(),
                json!({ "statistic": g.statistic, "window": g.window, "threshold": g.threshold }),
            );
        }
        v
    }
}

fn finite_or_null(x: f64) -> Value {
    if x.is_finite() {
        json!(x)
    } else {
        Value::Null
    }
}

/// The decision state of one residual stream: one method, ours or the baseline's.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Track {
    state: TrackState,
    exceed_run: u32,
    nominal_run: u32,
    /// CUSUM sums `[S+, S-]` of z_speed, z_disp, z_gain, z_phase.
    cusum: [[f64; 2]; 4],
    episode: Episode,
    /// The remembered sea index (decaying maximum over this track's tests).
    sea_memory: Option<f64>,
    /// GLR rule: the last `fdi.glr-window` tests' normalised parameter residuals, newest
    /// last, all measured against one reference.
    #[serde(default)]
    glr_param: VecDeque<[f64; 2]>,
    /// GLR rule: the last tests' actuator residuals `z_rate`, newest last.
    #[serde(default)]
    glr_actuator: VecDeque<[f64; 1]>,
    /// The reference the window was taken under: the relative variance of its offset (1/K
    /// once commissioned with K tests, 0 for the design's), `None` on wide design limits
    /// (no averaging); another empties the window.
    #[serde(default)]
    glr_reference: Option<f64>,
}

/// The largest window statistic of a GLR window: `(T, n)`, with `T_n = |mean of the last n
/// z|^2 * (1 + c) / (1/n + c)`, for `n = 1..=len`. Each z has unit variance, of which `c /
/// (1 + c)` is the reference offset's error shared by every test of the window (it does not
/// average out), so the mean of n tests has variance `(1/n + c) / (1 + c)` per component and
/// `T_n` is chi-square with the components' count of degrees of freedom for a healthy ship.
///
/// Two guards against the residuals' heavy tails (a healthy second-order hull gave single HBT
/// tests at chi2 27 and 44 in 5755): the newest test alone (n = 1) is an alarm only over
/// `fdi.glr-single-threshold`, and in the longer windows each test counts with its z clipped
/// to the norm `fdi.glr-clip`, so no one test carries a window. The look returned is the one
/// nearest its limit (largest `T / h`).
fn glr_statistic<const M: usize>(
    window: &VecDeque<[f64; M]>,
    c: f64,
    cfg: &FdiConfig,
) -> Option<GlrLook> {
    let last = window.back()?;
    let single = GlrLook {
        statistic: last.iter().map(|v| v * v).sum(),
        window: 1,
        threshold: cfg.glr_single_threshold,
    };
    let clipped: VecDeque<[f64; M]> = window.iter().map(|z| clip(*z, cfg.glr_clip)).collect();
    (2..=window.len())
        .map(|n| GlrLook {
            statistic: glr_window_statistic(&clipped, n, c),
            window: n,
            threshold: cfg.glr_threshold,
        })
        .chain(std::iter::once(single))
        .max_by(|a, b| (a.statistic / a.threshold).total_cmp(&(b.statistic / b.threshold)))
}

/// `z` scaled down to the norm `limit` when it is longer.
fn clip<const M: usize>(z: [f64; M], limit: f64) -> [f64; M] {
    let norm = z.iter().map(|v| v * v).sum::<f64>().sqrt();
    let k = if norm > limit { limit / norm } else { 1.0 };
    z.map(|v| v * k)
}

/// The GLR rule's look nearest its limit at one test.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GlrLook {
    /// `T_n`.
    pub statistic: f64,
    /// `n` [tests].
    pub window: usize,
    /// Its limit: `fdi.glr-single-threshold` for one test, `fdi.glr-threshold` for more.
    pub threshold: f64,
}

impl GlrLook {
    fn over(self) -> bool {
        self.statistic > self.threshold
    }
}

/// `T_n` of the last `n` entries of `window` (see [`glr_statistic`]).
fn glr_window_statistic<const M: usize>(window: &VecDeque<[f64; M]>, n: usize, c: f64) -> f64 {
    let mut sum = [0.0; M];
    for z in window.iter().rev().take(n) {
        for (s, v) in sum.iter_mut().zip(z) {
            *s += v;
        }
    }
    let n = n as f64;
    let sq: f64 = sum.iter().map(|s| (s / n) * (s / n)).sum();
    sq * (1.0 + c) / (1.0 / n + c)
}

fn push_window<T>(w: &mut VecDeque<T>, v: T, cap: usize) {
    w.push_back(v);
    while w.len() > cap {
        w.pop_front();
    }
}

impl Track {
    /// Keeps the windows to tests of one reference: another reference empties them.
    fn window_under(&mut self, reference: Option<f64>) {
        if self.glr_reference.map(f64::to_bits) != reference.map(f64::to_bits) {
            self.glr_param.clear();
            self.glr_actuator.clear();
            self.glr_reference = reference;
        }
    }

    /// Chi-square rule: the look at the mean of the last `fdi.mean-window` tests' parameter
    /// residuals, once that many were measured against one reference (the window empties
    /// when it changes; on wide design limits, `reference = None`, there is no window: the
    /// residual there is the model's own bias on this ship, which a mean does not shrink).
    /// Each test counts with its z clipped to `fdi.glr-clip`; the statistic is the GLR
    /// rule's `T_n` for `n = fdi.mean-window` (see [`glr_statistic`]).
    fn mean_look(
        &mut self,
        cfg: &FdiConfig,
        zp: Option<[f64; 2]>,
        reference: Option<f64>,
    ) -> Option<GlrLook> {
        self.window_under(reference);
        let z = zp?;
        let c = reference?;
        let n = cfg.mean_window as usize;
        push_window(&mut self.glr_param, z, n);
        if self.glr_param.len() < n {
            return None;
        }
        let clipped: VecDeque<[f64; 2]> = self
            .glr_param
            .iter()
            .map(|z| clip(*z, cfg.glr_clip))
            .collect();
        let statistic = glr_window_statistic(&clipped, n, c);
        statistic.is_finite().then_some(GlrLook {
            statistic,
            window: n,
            threshold: cfg.mean_threshold,
        })
    }

    /// The current state.
    pub fn state(&self) -> TrackState {
        self.state
    }

    /// The sea index in force for a test measuring `index`: the larger of it and the
    /// remembered index times `decay` (the sea state outlasts a test; a single test can look
    /// calm in a moderate sea). Remembers the result.
    pub fn sea_index(&mut self, index: Option<f64>, decay: f64) -> Option<f64> {
        let remembered = self.sea_memory.map(|m| m * decay);
        let eff = match (index, remembered) {
            (Some(i), Some(m)) => Some(i.max(m)),
            (i, m) => i.or(m),
        };
        self.sea_memory = eff;
        eff
    }

    /// Feeds one test's residuals; `None` for both changes nothing (inconclusive).
    pub fn update(
        &mut self,
        cfg: &FdiConfig,
        param: Option<&ParamResiduals>,
        actuator_z: Option<[f64; 2]>,
    ) -> TrackOutcome {
        self.update_against(cfg, param, actuator_z, Some(0.0))
    }

    /// [`Track::update`] for residuals measured against a given reference (the GLR rule's
    /// window depends on it): `Some(c)` when their errors are test-to-test scatter about a
    /// reference whose offset has relative variance `c` (1/K for one commissioned with K
    /// tests, 0 for the design's); `None` on wide design limits (while commissioning, or
    /// outside the commissioned speed band), whose error is the model's own bias on this
    /// ship, the same at every test: a mean of tests would not shrink it, so the window is
    /// one test.
    pub fn update_against(
        &mut self,
        cfg: &FdiConfig,
        param: Option<&ParamResiduals>,
        actuator_z: Option<[f64; 2]>,
        reference: Option<f64>,
    ) -> TrackOutcome {
        self.update_with(cfg, param, actuator_z, reference, false)
    }

    /// [`Track::update_against`], with `vessel_over`: the vessel's window (both methods'
    /// tests, `vessel::VesselWindow`) is over its limit at this test, which the chi-square
    /// rule takes as it takes its mean: an exceeding test and the alarm at once.
    pub fn update_with(
        &mut self,
        cfg: &FdiConfig,
        param: Option<&ParamResiduals>,
        actuator_z: Option<[f64; 2]>,
        reference: Option<f64>,
        vessel_over: bool,
    ) -> TrackOutcome {
        let zp = param
            .map(|p| p.z())
            .filter(|z| z.iter().all(|v| v.is_finite()));
        let za = actuator_z.filter(|z| z.iter().all(|v| v.is_finite()));
        let q_param = zp.map_or(f64::NAN, |z| z[0] * z[0] + z[1] * z[1]);
        let q_act = za.map(|z| z[0] * z[0] + z[1] * z[1]);
        if zp.is_none() && za.is_none() {
            return TrackOutcome {
                state: self.state,
                decision: Decision::Inconclusive,
                isolation: self.isolation(cfg),
                q_param,
                q_actuator: q_act,
                exceeded: false,
                exceed_run: self.exceed_run,
                glr: None,
            };
        }
        let mut glr = None;
        // Chi-square rule: one test of overwhelming evidence is an alarm by itself.
        let overwhelming = cfg.rule == DecisionRule::ChiSquare
            && (q_param > cfg.chi2_single_threshold
                || q_act.is_some_and(|q| q > cfg.actuator_single_threshold));
        // Chi-square rule: the mean of the last `fdi.mean-window` tests (one reference).
        let mut mean_over = false;
        let (param_exceeds, act_exceeds, persistence) = match cfg.rule {
            DecisionRule::ChiSquare => {
                if cfg.mean_window >= 2 {
                    glr = self.mean_look(cfg, zp, reference);
                    mean_over = glr.is_some_and(GlrLook::over);
                }
                mean_over |= vessel_over && zp.is_some();
                (
                    q_param > cfg.chi2_threshold || mean_over,
                    q_act.is_some_and(|q| q > cfg.chi2_threshold),
                    cfg.persistence,
                )
            }
            DecisionRule::Cusum => {
                let over = |sums: &mut [[f64; 2]], z: &[f64]| {
                    let mut over = false;
                    for (s, &z) in sums.iter_mut().zip(z) {
                        s[0] = (s[0] + z - cfg.cusum_k).max(0.0);
                        s[1] = (s[1] - z - cfg.cusum_k).max(0.0);
                        over |= s[0] > cfg.cusum_h || s[1] > cfg.cusum_h;
                    }
                    over
                };
                let (p_sums, a_sums) = self.cusum.split_at_mut(2);
                let p = zp.is_some_and(|z| over(p_sums, &z));
                let a = za.is_some_and(|z| over(a_sums, &z));
                (p, a, 1)
            }
            DecisionRule::Glr => {
                self.window_under(reference);
                let cap = cfg.glr_window as usize;
                let offset_var = reference.unwrap_or(0.0);
                if let Some(z) = zp {
                    push_window(
                        &mut self.glr_param,
                        z,
                        if reference.is_some() { cap } else { 1 },
                    );
                }
                if let Some(z) = za {
                    // One-sided: only a slower servo counts (z_rate >= 0 by construction).
                    push_window(&mut self.glr_actuator, [z[0]], cap);
                }
                let p = zp
                    .and_then(|_| glr_statistic(&self.glr_param, offset_var, cfg))
                    .filter(|t| t.statistic.is_finite());
                let a = za
                    .and_then(|_| glr_statistic(&self.glr_actuator, 0.0, cfg))
                    .filter(|t| t.statistic.is_finite());
                glr = [p, a].into_iter().flatten().max_by(|x, y| {
                    (x.statistic / x.threshold).total_cmp(&(y.statistic / y.threshold))
                });
                let over = |t: Option<GlrLook>| t.is_some_and(GlrLook::over);
                (
                    over(p) || q_param > cfg.chi2_threshold,
                    over(a) || q_act.is_some_and(|q| q > cfg.chi2_threshold),
                    1,
                )
            }
        };
        // Under the GLR rule a single test over the chi-square limit is an alert; the alarm
        // needs a window over the GLR limit.
        let glr_over = glr.is_some_and(GlrLook::over);
        let exceeded = param_exceeds || act_exceeds;
        if exceeded {
            self.exceed_run += 1;
            self.nominal_run = 0;
        } else {
            self.exceed_run = 0;
            self.nominal_run += 1;
        }
        let before = self.state;
        self.state = match (before, exceeded) {
            (_, true) if cfg.rule == DecisionRule::Glr && glr_over => TrackState::Alarm,
            (_, true)
                if cfg.rule != DecisionRule::Glr
                    && (self.exceed_run >= persistence || overwhelming || mean_over) =>
            {
                TrackState::Alarm
            }
            (TrackState::Alarm, _) => {
                if !exceeded && self.nominal_run >= cfg.clear_after {
                    TrackState::Normal
                } else {
                    TrackState::Alarm
                }
            }
            (_, true) => TrackState::Alert,
            (_, false) => TrackState::Normal,
        };
        if before == TrackState::Normal && self.state != TrackState::Normal {
            self.episode = Episode::default();
        }
        if cfg.rule == DecisionRule::ChiSquare
            && before != TrackState::Alarm
            && self.state == TrackState::Alarm
        {
            // The mean's evidence is spent on this alarm: the alarm holds, or clears, on
            // tests to come, not on the ones that raised it.
            self.glr_param.clear();
        }
        if self.state == TrackState::Normal {
            self.episode = Episode::default();
            if before == TrackState::Alarm {
                self.cusum = Default::default();
                self.glr_param.clear();
                self.glr_actuator.clear();
            }
        } else {
            let e = &mut self.episode;
            e.tests += 1;
            if let (Some(z), Some(p)) = (zp, param) {
                let zz = z[0] * z[0] + z[1] * z[1];
                e.zz += zz;
                for (i, v) in p.directions().iter().enumerate() {
                    let vz = v[0] * z[0] + v[1] * z[1];
                    let vv = v[0] * v[0] + v[1] * v[1];
                    e.cost[i] += if vv > 0.0 { zz - vz * vz / vv } else { zz };
                }
                e.q_param += q_param;
            }
            if let Some(q) = q_act {
                e.q_act += q;
            }
            e.param_exceeded += u32::from(param_exceeds);
            e.actuator_exceeded += u32::from(act_exceeds);
        }
        TrackOutcome {
            state: self.state,
            decision: self.state.decision(),
            isolation: self.isolation(cfg),
            q_param,
            q_actuator: q_act,
            exceeded,
            exceed_run: self.exceed_run,
            glr,
        }
    }

    /// Suspected causes of the current episode, most likely first.
    fn isolation(&self, cfg: &FdiConfig) -> Vec<Cause> {
        if self.state == TrackState::Normal {
            return Vec::new();
        }
        self.episode.isolation(cfg)
    }

    /// The episode under way, if the track is out of `normal`.
    fn open_episode(&self) -> Option<&Episode> {
        (self.state != TrackState::Normal && self.episode.tests > 0).then_some(&self.episode)
    }
}

impl Episode {
    /// This episode's parameter sums with the actuator sums of `all` added up (the servo
    /// checks of every method in the vessel's episode).
    fn with_actuator_of(&self, all: [&Episode; 2]) -> Episode {
        Episode {
            actuator_exceeded: all.iter().map(|e| e.actuator_exceeded).sum(),
            q_act: all.iter().map(|e| e.q_act).sum(),
            ..*self
        }
    }

    /// Suspected causes from the episode's sums, most likely first.
    fn isolation(&self, cfg: &FdiConfig) -> Vec<Cause> {
        let e = self;
        if e.tests == 0 {
            return Vec::new();
        }
        if cfg.single_fault && e.actuator_exceeded > 0 {
            return vec![Cause::SteeringActuator];
        }
        let mut causes: Vec<(f64, Cause)> = Vec::new();
        if e.param_exceeded > 0 {
            // `Episode::cost` is indexed in `Cause::ALL`'s order.
            let mut costs: Vec<(f64, Cause)> = (0..3).map(|i| (e.cost[i], Cause::ALL[i])).collect();
            costs.sort_by(|a, b| a.0.total_cmp(&b.0));
            let best = costs[0].0;
            for (j, name) in costs {
                if j == best || j - best < cfg.isolation_margin {
                    // Evidence for ordering: the energy the cause explains.
                    causes.push((e.zz - j, name));
                }
            }
        }
        if e.actuator_exceeded > 0 && !causes.iter().any(|c| c.1 == Cause::SteeringActuator) {
            causes.push((e.q_act, Cause::SteeringActuator));
        }
        // Stable order by evidence, strongest first (the parameter pair keeps its order).
        causes.sort_by(|a, b| b.0.total_cmp(&a.0));
        causes.into_iter().map(|c| c.1).collect()
    }
}

/// What the FDI adds to a completed test's report.
#[derive(Debug, Clone, PartialEq)]
pub struct Assessment {
    /// The report's `residuals`.
    pub residuals: Value,
    /// The report's `decision`.
    pub decision: Decision,
    /// The report's `isolation`.
    pub isolation: Vec<Cause>,
    /// A sentence for the report's message.
    pub summary: String,
    /// The notification to publish, when the vessel's alarm state changed.
    pub notification: Option<Notification>,
}

/// What a `model_mismatch` warning tells the operator.
pub const MISMATCH_ADVICE: &str = "the ship's response is not the trained model's (a higher-order hull, a dead band or an autopilot of its own): this is no fault of the ship; decisions rest on the vessel's commissioned reference, so commission it on a healthy ship (`helmwatch commission`), and train models for this class (`helmwatch train --family`) if it persists";

/// The FDI of one vessel: the tracks of both methods and of the baseline, the alarm state.
#[derive(Debug, Clone)]
pub struct Fdi {
    cfg: FdiConfig,
    ship: ShipConfig,
    servo_time_constant_s: f64,
    /// Per method (index: CLFRT 0, HBT 1): ours, then the baseline's.
    tracks: [Track; 2],
    baseline: [Track; 2],
    /// The vessel's alarm state as last published.
    published: AlarmState,
    /// The last notification published (republished after a restart).
    last_notification: Option<Notification>,
    /// Per method, the commissioning and the vessel's own reference.
    commissioning: [Commissioning; 2],
    /// What the reference is valid for: the ship configuration and the models.
    fingerprint: Fingerprint,
    /// The last tests of the ship, both methods (`vessel::VesselWindow`).
    vessel: VesselWindow,
}

/// What a commissioning reference was made under: the ship's particulars, servo and test
/// designs (relay, periods measured, multisine; the nominal values excluded: a reference
/// survives a new loading), and the models' checksums. A saved reference made under another
/// is discarded on restore.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Fingerprint {
    /// `{ship, servo, hbt, clfrt}` as configured.
    pub config: Value,
    /// [`Estimator::fingerprint`] of the models in use (`None`: no estimator).
    pub models: Option<String>,
}

impl Fingerprint {
    /// The configuration part for `cfg`.
    fn of(cfg: &CoreConfig) -> Self {
        let mut ship = serde_json::to_value(&cfg.ship).unwrap_or(Value::Null);
        if let Some(o) = ship.as_object_mut() {
            o.remove("nominal-speed-mps");
            o.remove("nominal-displacement-t");
        }
        // What the features depend on: the ship, the servo and the tests' designs (not
        // their timeouts or safety limits).
        Self {
            config: json!({
                "ship": ship,
                "servo": cfg.servo,
                "hbt": {
                    "relay-height-deg": cfg.hbt.relay_height_deg,
                    "hysteresis-deg": cfg.hbt.hysteresis_deg,
                    "measure-periods": cfg.hbt.measure_periods,
                },
                "clfrt": {
                    "window-s": cfg.clfrt.window_s,
                    "harmonics": cfg.clfrt.harmonics,
                    "amplitude-deg": cfg.clfrt.amplitude_deg,
                },
            }),
            models: None,
        }
    }

    /// Why `saved` differs from `self`, in words (`None`: it does not).
    pub fn difference(&self, saved: &Fingerprint) -> Option<String> {
        let mut why = Vec::new();
        if self.config != saved.config {
            let mut keys = Vec::new();
            if let (Some(now), Some(then)) = (self.config.as_object(), saved.config.as_object()) {
                for (section, v) in now {
                    let old = then.get(section);
                    match (v.as_object(), old.and_then(Value::as_object)) {
                        (Some(a), Some(b)) => {
                            for (k, x) in a {
                                if b.get(k) != Some(x) {
                                    let was = b.get(k).map_or("absent".into(), Value::to_string);
                                    keys.push(format!("{section}.{k} {was} -> {x}"));
                                }
                            }
                        }
                        _ if old != Some(v) => keys.push(format!("{section} changed")),
                        _ => {}
                    }
                }
            }
            why.push(if keys.is_empty() {
                "ship configuration changed".to_string()
            } else {
                format!("ship configuration changed ({})", keys.join(", "))
            });
        }
        if self.models != saved.models {
            why.push(format!(
                "models changed ({} -> {})",
                saved.models.as_deref().unwrap_or("none"),
                self.models.as_deref().unwrap_or("none")
            ));
        }
        (!why.is_empty()).then(|| why.join("; "))
    }
}

/// What a vessel's FDI remembers between tests (its tracks: states, runs, CUSUM sums,
/// episodes, sea memory; the alarm state published and its notification): saved after every
/// decision and restored after a restart, so an alarm stays an alarm.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct FdiState {
    /// Per method (CLFRT, HBT), ours.
    pub tracks: [Track; 2],
    /// Per method, the baseline's.
    pub baseline: [Track; 2],
    /// The vessel's alarm state as last published.
    pub published: AlarmState,
    /// The last notification published.
    pub last_notification: Option<Notification>,
    /// Per method, the commissioning and the vessel's own reference (absent in files of
    /// versions without commissioning: commissioning starts afresh).
    #[serde(default)]
    pub commissioning: [Commissioning; 2],
    /// What the reference was made under.
    #[serde(default)]
    pub fingerprint: Fingerprint,
    /// The vessel's window (absent in files of earlier versions: it starts empty).
    #[serde(default)]
    pub vessel: VesselWindow,
}

fn method_index(m: Method) -> usize {
    match m {
        Method::Clfrt => 0,
        Method::Hbt => 1,
    }
}

/// The sea index of a test's features (see the module doc): its wave yaw [deg], if it has
/// one.
pub fn sea_index(features: &Features) -> Option<f64> {
    features
        .wave_yaw_rad()
        .map(f64::to_degrees)
        .filter(|x| x.is_finite() && *x >= 0.0)
}

/// Where `index` sits between the calm (0) and moderate (1) anchors, clamped to [0, 3].
fn sea_fraction(anchors: [f64; 2], index: Option<f64>) -> f64 {
    match index {
        // Unknown disturbance: assume the moderate sea (the wider spread).
        None => 1.0,
        Some(i) => ((i - anchors[0]) / (anchors[1] - anchors[0])).clamp(0.0, 3.0),
    }
}

/// Interpolates a `[calm, moderate]` pair at `frac`.
fn lerp(pair: [f64; 2], frac: f64) -> f64 {
    pair[0] + frac * (pair[1] - pair[0])
}

/// `(bias, spread)` of a model's residuals at sea fraction `frac`; relative to `reference`
/// (the value under no fault) when given and the model file records relative spreads.
fn spread(u: &Uncertainty, frac: f64, reference: Option<f64>) -> (f64, f64) {
    use crate::core::model::SeaState;
    let of = |s: SeaState| u.by_sea.iter().find(|b| b.sea == s);
    let pick =
        |mean: [f64; 2], sd: [f64; 2]| (lerp(mean, frac.min(1.0)), lerp(sd, frac).max(sd[0]));
    match (of(SeaState::Calm), of(SeaState::Moderate)) {
        (Some(c), Some(m)) => match (reference, c.relative_std, m.relative_std) {
            (Some(y), Some(rc), Some(rm)) => {
                let means = [
                    c.relative_mean.unwrap_or(0.0),
                    m.relative_mean.unwrap_or(0.0),
                ];
                let (bm, bs) = pick(means, [rc, rm]);
                (bm * y, bs * y)
            }
            _ => pick(
                [c.residual_mean, m.residual_mean],
                [c.residual_std, m.residual_std],
            ),
        },
        _ => (u.residual_mean, u.residual_std),
    }
}

impl Fdi {
    /// The FDI of a vessel with configuration `cfg`.
    pub fn new(cfg: &CoreConfig) -> Self {
        Self {
            cfg: cfg.fdi.clone(),
            ship: cfg.ship.clone(),
            servo_time_constant_s: cfg.servo.time_constant_s,
            tracks: Default::default(),
            baseline: Default::default(),
            published: AlarmState::Normal,
            last_notification: None,
            commissioning: Default::default(),
            fingerprint: Fingerprint::of(cfg),
            vessel: VesselWindow::default(),
        }
    }

    /// Records which models estimate (their checksums, [`Estimator::fingerprint`]).
    pub fn set_models(&mut self, fingerprint: Option<String>) {
        self.fingerprint.models = fingerprint;
    }

    /// Starts commissioning again for `method`, or for both: the vessel's reference is
    /// dropped and set again from the next `fdi.commissioning-tests` healthy tests.
    pub fn commission(&mut self, method: Option<Method>) {
        for m in [Method::Clfrt, Method::Hbt] {
            if method.is_none_or(|x| x == m) {
                self.commissioning[method_index(m)].restart();
            }
        }
    }

    /// Per method, the commissioning's progress and reference (the `fdi/commission` reply).
    pub fn commissioning_status(&self) -> Value {
        let s = self.cfg.commissioning();
        let per = |m: Method| {
            let c = &self.commissioning[method_index(m)];
            json!({
                "state": c.state(&s),
                "tests": c.tests,
                "of": s.tests,
                "text": c.describe(&s),
                "reference": c.reference,
            })
        };
        json!({ "clfrt": per(Method::Clfrt), "hbt": per(Method::Hbt) })
    }

    /// Every method has its own reference, or commissioning is off (`fdi.commissioning-tests`
    /// = 0): decisions from now on rest on what commissioning set.
    pub fn commissioned(&self) -> bool {
        let s = self.cfg.commissioning();
        self.commissioning
            .iter()
            .all(|c| s.tests == 0 || c.reference.is_some())
    }

    /// One line per method: "CLFRT commissioning 2 of 5, HBT commissioned (...)".
    pub fn commissioning_text(&self) -> String {
        let s = self.cfg.commissioning();
        [Method::Clfrt, Method::Hbt]
            .iter()
            .map(|&m| {
                format!(
                    "{} {}",
                    m.name().to_uppercase(),
                    self.commissioning[method_index(m)].describe(&s)
                )
            })
            .collect::<Vec<_>>()
            .join(", ")
    }

    /// What to save: see [`FdiState`].
    pub fn state(&self) -> FdiState {
        FdiState {
            tracks: self.tracks.clone(),
            baseline: self.baseline.clone(),
            published: self.published,
            last_notification: self.last_notification.clone(),
            commissioning: self.commissioning.clone(),
            fingerprint: self.fingerprint.clone(),
            vessel: self.vessel.clone(),
        }
    }

    /// Takes up a saved state. A commissioning reference made under another ship
    /// configuration or other models is discarded: the returned message says why.
    pub fn restore(&mut self, s: FdiState) -> Option<String> {
        self.tracks = s.tracks;
        self.baseline = s.baseline;
        self.published = s.published;
        self.last_notification = s.last_notification;
        self.vessel = s.vessel;
        let had = s.commissioning.iter().any(|c| c.tests > 0);
        match self.fingerprint.difference(&s.fingerprint) {
            Some(why) if had => {
                self.commissioning = Default::default();
                Some(format!(
                    "commissioning reference discarded, commissioning starts again: {why}"
                ))
            }
            _ => {
                self.commissioning = s.commissioning;
                None
            }
        }
    }

    /// The last notification published (after a restore: the one to publish again at once).
    pub fn last_notification(&self) -> Option<&Notification> {
        self.last_notification.as_ref()
    }

    /// The vessel's alarm state (the worst of the methods' tracks).
    pub fn alarm_state(&self) -> AlarmState {
        self.worst().alarm_state()
    }

    fn worst(&self) -> TrackState {
        self.tracks
            .iter()
            .map(Track::state)
            .max()
            .unwrap_or_default()
    }

    /// The neural estimator's raw residuals against the design (`reference::Raw`) for a
    /// completed test, and `dD_est / du_log` [t per m/s].
    #[allow(clippy::too_many_arguments)]
    fn nn_raw(
        &self,
        method: Method,
        features: &Features,
        estimate: &Estimate,
        d_nom_t: f64,
        est: &Estimator,
        scratch: &mut EstimatorScratch,
        frac: f64,
    ) -> Option<(Raw, f64)> {
        let u_log = features.speed_log_mps().filter(|u| u.is_finite())?;
        let rel = |on: bool, y: f64| on.then_some(y);
        let (mu, su) = spread(
            &est.model(method, Target::Speed).file.uncertainty,
            frac,
            rel(self.cfg.relative_spread_speed, u_log),
        );
        let (md, sd) = spread(
            &est.model(method, Target::Displacement).file.uncertainty,
            frac,
            rel(self.cfg.relative_spread_displacement, d_nom_t),
        );
        // dD/du_log by a central difference through the displacement network.
        let mut at = |u: f64| -> Option<f64> {
            est.predict_at_speed_log(method, Target::Displacement, features, u, scratch)
                .ok()
        };
        let g = (at(u_log + DU_MPS)? - at(u_log - DU_MPS)?) / (2.0 * DU_MPS);
        let raw = Raw {
            speed_mps: estimate.speed_mps - u_log - mu,
            displacement: (estimate.displacement_t - d_nom_t - md) / d_nom_t,
            speed_sigma_mps: su,
            displacement_sigma: sd / d_nom_t,
            speed_log_mps: u_log,
        };
        let ok = [raw.speed_mps, raw.displacement, g]
            .iter()
            .all(|x| x.is_finite())
            && raw.speed_sigma_mps > 0.0
            && raw.displacement_sigma > 0.0;
        ok.then_some((raw, g))
    }

    /// The baseline's parameter residuals, from `features.baseline` (a, b).
    fn baseline_residuals(
        &self,
        method: Method,
        features: &Features,
        d_nom_t: f64,
        frac: f64,
    ) -> Option<ParamResiduals> {
        let u_log = features.speed_log_mps().filter(|u| u.is_finite())?;
        let bl = features.baseline()?;
        let (a, b) = (bl.a_per_s, bl.b_per_s2);
        if !(a > 0.0 && b > 0.0 && u_log > 0.0) {
            return None;
        }
        let u_est = speed_from_a(a, &self.ship);
        let d_est = displacement_from_b(b, u_log, &self.ship);
        let c = self.cfg.baseline_sigmas(method);
        let r = ParamResiduals {
            speed_mps: u_est - u_log,
            speed_sigma_mps: lerp(c.0, frac).max(c.0[0]),
            displacement_t: d_est - d_nom_t,
            displacement_sigma_t: lerp(c.1, frac).max(c.1[0]),
            dd_du_t_per_mps: 2.0 * d_est / u_log,
        };
        r.z().iter().all(|z| z.is_finite()).then_some(r)
    }

    /// The vessel's naming after a test, with `fdi.isolation-across-methods`
    /// and both methods' tracks out of `normal` (`None` otherwise: the method names from its
    /// own tests). The parameter cause is CLFRT's when its parameter residuals exceeded in its
    /// episode: its tones sit at fixed frequencies, so a change of `b` (displacement, rudder)
    /// moves their gains and not their phases whatever the hull's structure, while HBT's
    /// cycle moves with `b` and, on a hull with more lag than the model, its speed estimate
    /// with it (its displacement change then leans to the speed log's line). A servo check
    /// over its limit in either method names the steering actuator, one fault at a time.
    fn vessel_isolation(&self) -> Option<Vec<Cause>> {
        if !self.cfg.isolation_across_methods {
            return None;
        }
        let clfrt = self.tracks[method_index(Method::Clfrt)].open_episode()?;
        let hbt = self.tracks[method_index(Method::Hbt)].open_episode()?;
        let namer = if clfrt.param_exceeded > 0 { clfrt } else { hbt };
        Some(namer.with_actuator_of([clfrt, hbt]).isolation(&self.cfg))
    }

    /// The servo check's normalised residual: how far the rudder's 95th-percentile
    /// rate during the burst falls short of the healthy servo's, `z = (1 - rho) /
    /// fdi.actuator-rate-sigma`, one-sided (a rudder moving faster than the nominal servo's
    /// linear response, as the autopilot adds its own motion in a rougher sea, is no fault).
    ///
    /// HBT: the relay's steps slew the servo at its rate limit twice a period;
    /// `features.servo_rate` holds the median of the periods' peak rudder rates, read the
    /// same way against the rate limit.
    fn actuator_z(&self, features: &Features) -> Option<[f64; 2]> {
        let (p95, nominal) = features.servo_rate_rad_s()?;
        if !p95.is_finite() || !nominal.is_finite() || nominal <= 0.0 {
            return None;
        }
        let rho = p95 / nominal;
        Some([((1.0 - rho) / self.cfg.actuator_rate_sigma).max(0.0), 0.0])
    }

    /// Assesses a completed test. `estimate` is the networks' estimate (with the estimator
    /// that made it), `d_nom_t` the nominal displacement in force.
    pub fn assess(
        &mut self,
        method: Method,
        features: &Features,
        estimate: Option<(&Estimate, &Estimator, &mut EstimatorScratch)>,
        d_nom_t: f64,
    ) -> Assessment {
        let i = method_index(method);
        let measured = sea_index(features);
        let index = self.tracks[i].sea_index(measured, self.cfg.sea_memory);
        let frac = sea_fraction(self.cfg.sea_wave_yaw_deg, index);
        let raw = estimate.and_then(|(e, est, scratch)| {
            self.nn_raw(method, features, e, d_nom_t, est, scratch, frac)
        });
        let settings = self.cfg.commissioning();
        let basis = raw.map(|(r, _)| self.commissioning[i].basis(&settings, r.speed_log_mps));
        let param = match (raw, &basis) {
            (Some((r, g)), Some(b)) => {
                let (ru, su, rd, sd) = Commissioning::measure(b, &settings, &r);
                let p = ParamResiduals {
                    speed_mps: ru,
                    speed_sigma_mps: su,
                    displacement_t: rd * d_nom_t,
                    displacement_sigma_t: sd * d_nom_t,
                    dd_du_t_per_mps: g,
                };
                p.z().iter().all(|z| z.is_finite()).then_some(p)
            }
            _ => None,
        };
        let fit = match method {
            Method::Clfrt => fit::model_fit(features, &self.ship, &self.cfg),
            Method::Hbt => None,
        };
        let mut act = self.actuator_z(features);
        if self.cfg.model_fit_decides {
            // The fit's chi-square (4 dof) joins the actuator group, scaled to its threshold.
            if let Some(f) = &fit {
                let scaled = f.chi2 * self.cfg.chi2_threshold / self.cfg.model_fit_threshold;
                let a = act.unwrap_or([0.0, 0.0]);
                let q = a[0] * a[0] + a[1] * a[1];
                if scaled > q {
                    act = Some([scaled.sqrt(), 0.0]);
                }
            }
        }
        let reference = match &basis {
            Some(Basis::Commissioned(r)) => Some(1.0 / f64::from(r.tests.max(1))),
            Some(Basis::Commissioning { .. } | Basis::OutsideBand(_)) => None,
            Some(Basis::Design) | None => Some(0.0),
        };
        // The vessel's window: both methods' tests against their commissioned references.
        let vessel = if self.cfg.enabled {
            let q = param
                .as_ref()
                .map(|p| p.z().iter().map(|z| z * z).sum::<f64>());
            let on_reference = matches!(basis, Some(Basis::Commissioned(_)));
            self.vessel.look(&self.cfg, method, q, on_reference)
        } else {
            None
        };
        let vessel_over = vessel.is_some_and(GlrLook::over);
        let mut ours = if self.cfg.enabled {
            let before = self.tracks[i].state;
            let o =
                self.tracks[i].update_with(&self.cfg, param.as_ref(), act, reference, vessel_over);
            if vessel_over && before != TrackState::Alarm && o.state == TrackState::Alarm {
                // The window's evidence is spent on this alarm (as the mean's).
                self.vessel.clear();
            }
            o
        } else {
            self.tracks[i].update(&self.cfg, None, None)
        };
        // The vessel's naming, with both methods out of `normal` (see `vessel_isolation`).
        let own_isolation = self
            .vessel_isolation()
            .map(|joined| std::mem::replace(&mut ours.isolation, joined));
        // A healthy commissioning test joins the vessel's reference.
        let mut commissioned = false;
        if let (Some((r, _)), Some(Basis::Commissioning { .. })) = (raw, &basis) {
            if self.cfg.enabled && param.is_some() && !ours.exceeded {
                commissioned = self.commissioning[i].add(&settings, &r);
            }
        }
        let mismatch = fit
            .as_ref()
            .filter(|f| f.chi2.is_finite() && f.chi2 > self.cfg.model_mismatch_chi2)
            .map(|f| {
                json!({
                    "chi2": f.chi2,
                    "threshold": self.cfg.model_mismatch_chi2,
                    "advice": MISMATCH_ADVICE,
                })
            });
        let bl_param = self.baseline_residuals(method, features, d_nom_t, frac);
        let bl = self.baseline[i].update(&self.cfg, bl_param.as_ref(), None);

        let mut residuals = json!({
            "rule": self.cfg.rule.name(),
            "sea_index": index,
            "sea_index_measured": measured,
            "sea_fraction": frac,
            "displacement_nominal_t": d_nom_t,
            "decision": ours.to_json(&self.cfg),
        });
        if let Some(obj) = residuals.as_object_mut() {
            if let Some(p) = &param {
                obj.insert("parameters".into(), p.to_json());
            }
            if let Some((r, g)) = &raw {
                // Against the design, before any reference: what commissioning samples.
                obj.insert(
                    "raw".into(),
                    json!({
                        "speed_mps": r.speed_mps,
                        "displacement": r.displacement,
                        "speed_sigma_mps": r.speed_sigma_mps,
                        "displacement_sigma": r.displacement_sigma,
                        "speed_log_mps": r.speed_log_mps,
                        "dd_du_t_per_mps": g,
                    }),
                );
            }
            if let Some(z) = act {
                obj.insert(
                    "actuator".into(),
                    json!({ "z_gain": z[0], "z_phase": z[1] }),
                );
            }
            if let Some(f) = &fit {
                obj.insert("model_fit".into(), f.to_json(&self.ship));
            }
            if let Some(m) = &mismatch {
                obj.insert("model_mismatch".into(), m.clone());
            }
            if let Some(b) = &basis {
                let c = &self.commissioning[i];
                let mut r = json!({
                    "kind": b.name(),
                    "text": c.describe(&settings),
                    "tests": c.tests,
                    "of": settings.tests,
                });
                if let (Some(o), Some(rf)) = (r.as_object_mut(), &c.reference) {
                    o.insert("speed_offset_mps".into(), json!(rf.speed_offset_mps));
                    o.insert(
                        "displacement_offset_t".into(),
                        json!(rf.displacement_offset * d_nom_t),
                    );
                    o.insert("speed_log_mps".into(), json!(rf.speed_log_mps));
                }
                obj.insert("reference".into(), r);
            }
            obj.insert(
                "baseline".into(),
                json!({
                    "parameters": bl_param.map(ParamResiduals::to_json),
                    "decision": bl.to_json(&self.cfg),
                    "outcome": bl.decision,
                    "isolation": bl.isolation,
                }),
            );
            obj.insert(
                "servo_time_constant_s".into(),
                json!(self.servo_time_constant_s),
            );
            if let Some(v) = vessel {
                obj.insert(
                    "vessel".into(),
                    json!({ "statistic": v.statistic, "window": v.window, "threshold": v.threshold }),
                );
            }
            if let Some(own) = &own_isolation {
                // Named from both methods' episodes; what this method's tests alone name.
                obj.insert(
                    "isolation_across_methods".into(),
                    json!({
                        "tests": self.tracks[0].episode.tests + self.tracks[1].episode.tests,
                        "this_method": own,
                    }),
                );
            }
        }
        let mut summary = summary(&ours, param.as_ref(), self.cfg.enabled);
        match &basis {
            Some(Basis::Commissioning { .. }) if commissioned => summary.push_str(&format!(
                "; commissioning complete: {}",
                self.commissioning[i].describe(&settings)
            )),
            Some(Basis::Commissioning { .. }) => summary.push_str(&format!(
                "; {} (wide design limits)",
                self.commissioning[i].describe(&settings)
            )),
            Some(Basis::OutsideBand(r)) => summary.push_str(&format!(
                "; speed outside the commissioned {:.1} +- {:.1} m/s: wide design limits",
                r.speed_log_mps, settings.speed_band_mps
            )),
            _ => {}
        }
        if let Some(f) = fit.filter(|_| mismatch.is_some()) {
            summary.push_str(&format!(
                "; model_mismatch: model-fit chi2 {:.0} > {:.0}: {MISMATCH_ADVICE}",
                f.chi2, self.cfg.model_mismatch_chi2
            ));
        }
        let now = self.alarm_state();
        let notification = (now != self.published).then(|| {
            self.published = now;
            let method_list = match now {
                AlarmState::Alarm | AlarmState::Warn => vec!["visual".into(), "sound".into()],
                AlarmState::Alert => vec!["visual".into()],
                AlarmState::Normal => Vec::new(),
            };
            Notification {
                state: now,
                method: method_list,
                message: format!("Steering FDI ({}): {summary}", method.name().to_uppercase()),
            }
        });
        if let Some(n) = &notification {
            self.last_notification = Some(n.clone());
        }
        Assessment {
            residuals,
            decision: ours.decision,
            isolation: ours.isolation,
            summary,
            notification,
        }
    }
}

fn summary(o: &TrackOutcome, p: Option<&ParamResiduals>, enabled: bool) -> String {
    if !enabled {
        return "FDI disabled, no decision".into();
    }
    let stat = match o.q_actuator {
        Some(qa) if o.q_param.is_finite() => {
            format!("chi2 {:.1} (servo check {:.1})", o.q_param, qa)
        }
        Some(qa) => format!("servo check chi2 {qa:.1}"),
        None if o.q_param.is_finite() => format!("chi2 {:.1}", o.q_param),
        None => return "no residuals (no estimate or speed log), no decision".into(),
    };
    let causes = if o.isolation.is_empty() {
        String::new()
    } else {
        let names: Vec<&str> = o.isolation.iter().map(|c| c.name()).collect();
        format!("; suspected: {}", names.join(", "))
    };
    let detail = p.map_or(String::new(), |p| {
        format!(
            " (speed {:+.2} m/s, displacement {:+.0} t against the nominal)",
            p.speed_mps, p.displacement_t
        )
    });
    match o.state {
        TrackState::Normal => format!("nominal, {stat}{detail}"),
        TrackState::Alert => format!(
            "alert, {stat}{detail}, {} test(s) in a row over the limit{causes}",
            o.exceed_run
        ),
        TrackState::Alarm => format!("FAULT, {stat}{detail}{causes}"),
    }
}

#[cfg(test)]
mod tests;
