//! Parity-space fault detection and isolation of one vessel. The model is stated once, in
//! docs/fdi.md, "The model"; the keys and the models' calibration in "Keys and calibration".
//!
//! [`Fdi::assess`] takes a completed test through four steps, the evidence flowing one way:
//!
//! 1. `residual`: the raw residuals `(e_u, e_D, e_b)` against the design and the servo check
//!    (`raw`), HBT's displacement direction read through the vessel's loop (`shape`).
//! 2. `normal`: the residual measured against the method's reference, whitened and
//!    calibrated into the window's entry (`window`, `reference`, `envelope`, `measured`,
//!    `noise`), with the log's wander (`isolation`).
//! 3. `decide`: the vessel's window GLR and the cause it names (`decision`, `limits`,
//!    `isolation`), then what the reference learns (`learning`, `reference`, `changepoint`).
//! 4. `report`: the report's `residuals`, decision and summary, and a notification when the
//!    vessel's alarm state changed (`report`, `fit`, the equation-error baseline).
//!
//! Invariants: with `fdi.enabled = false` the residuals are reported, the reference learns
//! nothing and the decision is `inconclusive`; so is a test with neither a parameter residual
//! nor a servo check. An inconsistent commissioning holds the vessel at alert at least. The
//! saved [`FdiState`] restores an alarm as an alarm; a part in an older format comes back
//! empty, and a reference made under another ship configuration or other models is
//! discarded (docs/fdi.md, "Saved state and restarts").

pub mod ablation;
pub mod budget;
pub mod changepoint;
pub mod config;
pub mod decision;
pub mod envelope;
mod fit;
pub mod isolation;
pub mod learning;
pub mod limits;
pub mod measured;
pub mod noise;
pub mod point;
pub mod raw;
pub mod reference;
mod report;
pub mod sensitivity;
pub mod shape;
pub mod stats;
pub mod window;

use crate::baseline::config::BaselineConfig;
use crate::estimator::{Estimator, EstimatorScratch};
use crate::fdi::config::{Calibration, FdiConfig, ReferenceConfig};
use crate::model::ShipConfig;
use crate::monitor::config::CoreConfig;
use crate::wire::residuals::{
    CauseCosts, DecisionReport, RawResiduals, ReferenceKind, ReferenceReport, Residuals, TrackState,
};
use crate::wire::{AlarmState, Cause, Decision, Estimate, Features, Method, Notification};
use ablation::Mechanism;
use decision::Sequential;
use learning::Pending;
use limits::DecisionLimits;
use measured::Basis;
use raw::sea_fraction;
use raw::sea_index;
use reference::{Added, MethodReference, Phase};
use report::Fingerprint;
use serde::{Deserialize, Serialize};
use shape::LoopShape;
use window::measure_entry;
use window::{method_index, Entry, Source};

/// A test's residuals against the design: what the networks read, and the servo check.
#[derive(Debug, Clone, Copy)]
struct Residual {
    method: Method,
    /// The nominal displacement in force [t].
    d_nom_t: f64,
    /// The test's sea index (its wave yaw) [deg].
    sea_index: Option<f64>,
    /// Where the sea index falls between the calm and moderate anchors.
    sea_fraction: f64,
    /// The raw residuals, `dD_est / du_log` and the displacement's direction.
    raw: Option<(raw::Raw, f64, [f64; stats::P])>,
    servo: Option<crate::wire::residuals::ServoCheck>,
}

/// A test's evidence: its residual measured against the method's reference, whitened, and
/// the decision's entry made of it.
struct Evidence {
    residual: Residual,
    basis: Option<Basis>,
    /// The residual against the reference and its whitened, calibrated form.
    measured: Option<(measured::Measured, [f64; stats::P])>,
    entry: Entry,
}

/// What the FDI adds to a completed test's report.
#[derive(Debug, Clone, PartialEq)]
pub struct Assessment {
    /// The report's `residuals`.
    pub residuals: Residuals,
    /// The report's `decision`.
    pub decision: Decision,
    /// The report's `isolation`.
    pub isolation: Vec<Cause>,
    /// A sentence for the report's message.
    pub summary: String,
    /// The notification to publish, when the vessel's alarm state changed.
    pub notification: Option<Notification>,
}

/// One method's commissioning, as the `fdi/commission` queryable replies.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MethodCommissioning {
    /// `off`, `commissioning` or `commissioned`.
    pub state: &'static str,
    /// Tests in the sample.
    pub tests: u32,
    /// Tests it takes.
    pub of: u32,
    /// E.g. `commissioning 3 of 8`.
    pub text: String,
    /// The reference, once set.
    pub reference: Option<reference::Reference>,
}

/// Both methods' commissioning.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CommissioningStatus {
    /// CLFRT's.
    pub clfrt: MethodCommissioning,
    /// HBT's.
    pub hbt: MethodCommissioning,
}

/// What a vessel's FDI remembers between tests: saved after every decision and restored
/// after a restart, so an alarm stays an alarm. The parts whose format an upgrade changes (the
/// window, the references, the held tests) come back empty when they cannot be read: they
/// are learned again, and the alarm state published beside them is kept (`Fdi::restore`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FdiState {
    /// The vessel's sequential test (its window, state and the causes named).
    #[serde(default, deserialize_with = "or_default")]
    pub sequential: Sequential,
    /// The vessel's alarm state as last published.
    pub published: AlarmState,
    /// The last notification published.
    pub last_notification: Option<Notification>,
    /// Per method (CLFRT, HBT), the commissioning and the vessel's own reference.
    #[serde(default, deserialize_with = "or_default")]
    pub commissioning: [MethodReference; 2],
    /// Per method, how many references it has had (a new one drops its older tests from
    /// the window).
    #[serde(default)]
    pub generation: [u32; 2],
    /// What the reference was made under.
    #[serde(default)]
    pub fingerprint: Fingerprint,
    /// The tests in the decision's window waiting to be learned.
    #[serde(default, deserialize_with = "or_default")]
    pub pending: Pending,
    /// The vessel's loop shape from its last CLFRT tests (HBT's displacement direction).
    #[serde(default, deserialize_with = "or_default")]
    pub loop_shape: LoopShape,
}

/// A part of a saved state as it stands, or its default when it is in an older version's
/// format (see [`FdiState`]).
fn or_default<'de, D, T>(d: D) -> Result<T, D::Error>
where
    D: serde::Deserializer<'de>,
    T: serde::de::DeserializeOwned + Default,
{
    let v = serde_json::Value::deserialize(d)?;
    Ok(T::deserialize(v).unwrap_or_default())
}

/// The FDI of one vessel.
#[derive(Debug, Clone)]
pub struct Fdi {
    cfg: FdiConfig,
    reference_cfg: ReferenceConfig,
    /// The models' calibration on the class of hull.
    cal: Calibration,
    baseline_cfg: BaselineConfig,
    ship: ShipConfig,
    servo_time_constant_s: f64,
    limits: DecisionLimits,
    sequential: Sequential,
    published: AlarmState,
    last_notification: Option<Notification>,
    commissioning: [MethodReference; 2],
    generation: [u32; 2],
    fingerprint: Fingerprint,
    pending: Pending,
    loop_shape: LoopShape,
}

impl Fdi {
    /// What learning reads and changes.
    fn learner(&mut self) -> learning::Learner<'_> {
        learning::Learner {
            commissioning: &mut self.commissioning,
            generation: &mut self.generation,
            pending: &mut self.pending,
            sequential: &mut self.sequential,
            limits: &self.limits,
            enabled: self.cfg.enabled,
        }
    }

    /// The FDI of a vessel with configuration `cfg`.
    pub fn new(cfg: &CoreConfig) -> Self {
        Self {
            cfg: cfg.fdi.clone(),
            reference_cfg: cfg.reference.clone(),
            cal: cfg.calibration.clone(),
            baseline_cfg: cfg.baseline.clone(),
            ship: cfg.ship.clone(),
            servo_time_constant_s: cfg.servo.time_constant_s,
            limits: DecisionLimits::new(
                cfg.fdi.false_alarms_per_year,
                cfg.scheduler.interval_s + cfg.scheduler.steady_time_s,
                cfg.fdi.window_tests,
            ),
            sequential: Sequential::default(),
            published: AlarmState::Normal,
            last_notification: None,
            commissioning: Default::default(),
            generation: [0; 2],
            fingerprint: Fingerprint::of(cfg),
            pending: Pending::default(),
            loop_shape: LoopShape::default(),
        }
    }

    /// The decision's limits.
    pub fn limits(&self) -> &DecisionLimits {
        &self.limits
    }

    /// What the reference needs (`[fdi]`, `[reference]` and the limits).
    pub fn settings(&self) -> reference::Settings {
        reference::Settings::new(&self.cfg, &self.reference_cfg, &self.cal, &self.limits)
    }

    /// Per method (CLFRT, HBT), what the vessel has learned.
    pub fn learned(&self) -> &[MethodReference; 2] {
        &self.commissioning
    }

    /// A sentence when a method's commissioning sample held a change (an alert until
    /// commissioned again).
    fn inconsistent(&self) -> Option<String> {
        let s = self.settings();
        let texts: Vec<String> = [Method::Clfrt, Method::Hbt]
            .iter()
            .filter(|&&m| {
                matches!(
                    self.commissioning[method_index(m)].phase,
                    Phase::Inconsistent { .. }
                )
            })
            .map(|&m| {
                format!(
                    "{} {}",
                    m.name().to_uppercase(),
                    self.commissioning[method_index(m)].describe(&s)
                )
            })
            .collect();
        (!texts.is_empty()).then(|| texts.join("; "))
    }

    /// Records which models estimate (their checksums, [`Estimator::fingerprint`]).
    pub fn set_models(&mut self, fingerprint: Option<String>) {
        self.fingerprint.models = fingerprint;
    }

    /// Starts commissioning again for `method`, or for both. The loop shape is CLFRT's
    /// tones (after a repair or new gear, another loop): it goes with CLFRT's reference.
    pub fn commission(&mut self, method: Option<Method>) {
        for m in [Method::Clfrt, Method::Hbt] {
            if method.is_none_or(|x| x == m) {
                self.commissioning[method_index(m)].restart();
                self.generation[method_index(m)] += 1;
            }
        }
        if method.is_none_or(|x| x == Method::Clfrt) {
            self.loop_shape = LoopShape::default();
        }
    }

    /// Per method, the commissioning's progress and reference.
    pub fn commissioning_status(&self) -> CommissioningStatus {
        let s = self.settings();
        let per = |m: Method| {
            let c = &self.commissioning[method_index(m)];
            MethodCommissioning {
                state: c.state(&s),
                tests: c.tests,
                of: s.tests,
                text: c.describe(&s),
                reference: c.reference,
            }
        };
        CommissioningStatus {
            clfrt: per(Method::Clfrt),
            hbt: per(Method::Hbt),
        }
    }

    /// Every method has its own reference, or commissioning is off.
    pub fn commissioned(&self) -> bool {
        [Method::Clfrt, Method::Hbt]
            .iter()
            .all(|&m| self.method_commissioned(m))
    }

    /// `method` has its own reference, or commissioning is off.
    pub fn method_commissioned(&self, method: Method) -> bool {
        self.cfg.commissioning_tests == 0
            || self.commissioning[method_index(method)].phase == Phase::Learning
    }

    /// One line per method: "CLFRT commissioning 2 of 5, HBT commissioned (...)".
    pub fn commissioning_text(&self) -> String {
        let s = self.settings();
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
            sequential: self.sequential.clone(),
            published: self.published,
            last_notification: self.last_notification.clone(),
            commissioning: self.commissioning.clone(),
            generation: self.generation,
            fingerprint: self.fingerprint.clone(),
            pending: self.pending.clone(),
            loop_shape: self.loop_shape.clone(),
        }
    }

    /// Takes up a saved state. A commissioning reference made under another ship
    /// configuration or other models is discarded: the returned message says why.
    pub fn restore(&mut self, s: FdiState) -> Option<String> {
        self.sequential = s.sequential;
        // A window in an older format came back empty: the alarm published holds (it clears
        // after N quiet tests, as any alarm).
        if self.sequential == Sequential::default() && s.published == AlarmState::Alarm {
            self.sequential.state = TrackState::Alarm;
        }
        self.published = s.published;
        self.last_notification = s.last_notification;
        self.generation = s.generation;
        self.pending = s.pending;
        self.loop_shape = s.loop_shape;
        let had = s.commissioning.iter().any(|c| c.tests > 0);
        match self.fingerprint.difference(&s.fingerprint) {
            Some(why) if had => {
                self.commissioning = Default::default();
                self.sequential.window.clear();
                self.pending = Pending::default();
                self.loop_shape = LoopShape::default();
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

    /// The vessel's alarm state.
    pub fn alarm_state(&self) -> AlarmState {
        match self.sequential.state {
            TrackState::Normal if self.inconsistent().is_some() => AlarmState::Alert,
            TrackState::Normal => AlarmState::Normal,
            TrackState::Alert => AlarmState::Alert,
            TrackState::Alarm => AlarmState::Alarm,
        }
    }

    /// Assesses a completed test. `estimate` is the networks' estimate (with the estimator
    /// that made it), `d_nom_t` the nominal displacement in force. The evidence flows one
    /// way: the residuals against the design ([`Fdi::residual`]), measured against the
    /// vessel's normal ([`Fdi::normal`]), the decision and learning ([`Fdi::decide`]), the
    /// report ([`Fdi::report`]).
    pub fn assess(
        &mut self,
        method: Method,
        features: &Features,
        estimate: Option<(&Estimate, &Estimator, &mut EstimatorScratch)>,
        d_nom_t: f64,
    ) -> Assessment {
        let residual = self.residual(method, features, estimate, d_nom_t);
        let settings = self.settings();
        let evidence = self.normal(method, residual, &settings);
        let (step, added) = self.decide(&evidence, &settings);
        self.report(features, &evidence, step, added, &settings)
    }

    /// The test's residuals against the design and its servo check; the loop shape learns
    /// a CLFRT test's response.
    fn residual(
        &mut self,
        method: Method,
        features: &Features,
        estimate: Option<(&Estimate, &Estimator, &mut EstimatorScratch)>,
        d_nom_t: f64,
    ) -> Residual {
        let index = sea_index(features);
        let frac = if ablation::off(Mechanism::SeaInterpolation) {
            1.0
        } else {
            sea_fraction(self.cal.sea_wave_yaw_deg, index)
        };
        let slopes = if ablation::off(Mechanism::LoopShape) {
            None
        } else {
            self.loop_shape.slopes_at(features)
        };
        let raw = estimate.and_then(|(e, est, scratch)| {
            raw::nn_raw(method, features, e, d_nom_t, est, scratch, frac, slopes)
        });
        self.loop_shape.learn(features);
        Residual {
            method,
            d_nom_t,
            sea_index: index,
            sea_fraction: frac,
            raw,
            servo: raw::servo_check(features, self.cal.actuator_rate_sigma),
        }
    }

    /// The residual measured against the method's reference (the vessel's normal, or the
    /// design's), whitened, as the decision's entry.
    fn normal(
        &self,
        method: Method,
        residual: Residual,
        settings: &reference::Settings,
    ) -> Evidence {
        let i = method_index(method);
        let d_nom_t = residual.d_nom_t;
        let source = residual.raw.map(|(r, g, d_dir)| Source {
            raw: r,
            directions: [[-1.0, g / d_nom_t, 0.0], d_dir],
        });
        let z_rate = residual
            .servo
            .map(|s| s.z_rate)
            .filter(|_| !ablation::off(Mechanism::ServoChannel));
        let epoch = self.generation[i];
        let measured_basis = source
            .map(|src| measure_entry(&self.commissioning[i], settings, method, src, epoch, z_rate));
        let basis = measured_basis.map(|(b, _, _)| b);
        let measured = measured_basis.map(|(_, m, _)| m);
        let z = measured.and_then(|m| m.whitened());
        // The log's reading, and its wander over the vessel's learned tests.
        let samples = self.commissioning.iter().flat_map(|c| &c.samples);
        let sigma_mps = isolation::log_wander(samples, self.cfg.floor_speed_mps);
        let log = residual.raw.map(|(r, _, _)| window::LogReading {
            now_mps: r.speed_log_mps,
            before_mps: None,
            sigma_mps,
            learned_point: basis.as_ref().is_some_and(Basis::at_learned_point),
        });
        let entry = measured_basis
            .map(|(_, _, e)| Entry { log, ..e })
            .unwrap_or(Entry {
                method,
                z: None,
                dim: 2,
                offset_var: None,
                epoch,
                directions: [[0.0; stats::P]; 2],
                z_rate,
                source: None,
                log: None,
            });
        Evidence {
            residual,
            basis,
            measured: measured.zip(z),
            entry,
        }
    }

    /// The sequential test on the test's entry (unless `fdi.enabled` is off), then what the
    /// reference learns from it.
    fn decide(
        &mut self,
        evidence: &Evidence,
        settings: &reference::Settings,
    ) -> (Option<decision::Step>, Added) {
        let step = self.cfg.enabled.then(|| {
            self.learner().remeasure_window(settings);
            self.sequential.update(&self.limits, evidence.entry)
        });
        let added = self.learner().learn(
            method_index(evidence.residual.method),
            evidence.residual.raw.map(|(r, _, _)| r),
            evidence.basis.as_ref(),
            step.as_ref(),
            settings,
        );
        (step, added)
    }

    /// The report's residuals, decision and summary, and the notification when the vessel's
    /// alarm state changed.
    fn report(
        &mut self,
        features: &Features,
        evidence: &Evidence,
        step: Option<decision::Step>,
        added: Added,
        settings: &reference::Settings,
    ) -> Assessment {
        let Residual {
            method,
            d_nom_t,
            sea_index: index,
            sea_fraction: frac,
            raw,
            servo,
        } = evidence.residual;
        let i = method_index(method);
        let basis = evidence.basis;
        let parameters = evidence
            .measured
            .map(|(m, z)| report::parameter_report(&m, z, d_nom_t));
        let fit = match method {
            Method::Clfrt => fit::model_fit(features, &self.ship, &self.cal),
            Method::Hbt => None,
        };
        let baseline = report::baseline(
            &self.baseline_cfg,
            &self.ship,
            &self.limits,
            method,
            features,
            d_nom_t,
            frac,
        );
        let (mut state, isolation) = match &step {
            Some(s) => (s.state, s.isolation.clone()),
            None => (self.sequential.state, Vec::new()),
        };
        let inconsistent = self.inconsistent();
        if inconsistent.is_some() && state == TrackState::Normal {
            state = TrackState::Alert;
        }
        let decision = match (&step, &parameters, &servo) {
            (Some(_), None, None) | (None, _, _) => Decision::Inconclusive,
            _ => match state {
                TrackState::Normal => Decision::Nominal,
                TrackState::Alert => Decision::Inconclusive,
                TrackState::Alarm => Decision::Fault,
            },
        };
        let residuals = Residuals {
            sea_index: index,
            sea_fraction: Some(frac),
            displacement_nominal_t: Some(d_nom_t),
            raw: raw.map(|(r, g, _)| RawResiduals {
                speed_mps: r.speed_mps,
                displacement: r.displacement,
                speed_sigma_mps: r.speed_sigma_mps,
                displacement_sigma: r.displacement_sigma,
                speed_log_mps: r.speed_log_mps,
                dd_du_t_per_mps: g,
                ln_gain: r.ln_gain,
                ln_damping: r.ln_damping,
                speed_slope: r.speed_slope,
                loading_slope: r.loading_slope,
            }),
            parameters,
            servo_check: servo,
            model_fit: fit.map(|f| f.report(&self.ship)),
            model_mismatch: fit.and_then(|f| report::mismatch(&f, self.cal.model_mismatch_chi2)),
            reference: basis.map(|b| self.reference_report(i, &b, d_nom_t)),
            decision: step.as_ref().map(|s| DecisionReport {
                // The vessel's: an inconsistent commissioning holds it at alert.
                state,
                parameters: s.param.map(|p| p.look),
                servo: s.servo.map(|p| p.look),
                false_alarm_per_test: self.limits.alpha_test,
                cause_costs: s.costs.map(|[l, d]| CauseCosts {
                    speed_log: l,
                    displacement_or_rudder_effectiveness: d,
                }),
                log_step_mps: s.log_step_mps,
                not_ruled_out: s.open.clone(),
            }),
            baseline: Some(baseline),
            servo_time_constant_s: Some(self.servo_time_constant_s),
        };
        let commissioning_text = self.reference_sentence(
            i,
            &evidence.residual,
            basis.as_ref(),
            added,
            step.as_ref(),
            inconsistent,
            settings,
        );
        let summary = report::summary(
            self.cfg.enabled,
            &residuals,
            state,
            &isolation,
            commissioning_text,
        );
        let now = self.alarm_state();
        let notification = (now != self.published).then(|| {
            self.published = now;
            report::notification(now, method, &summary)
        });
        if let Some(n) = &notification {
            self.last_notification = Some(n.clone());
        }
        Assessment {
            residuals,
            decision,
            isolation,
            summary,
            notification,
        }
    }

    /// The sentence on the method's reference: commissioning's progress or end, an
    /// inconsistent sample, an operating point not yet learned.
    #[allow(clippy::too_many_arguments)]
    fn reference_sentence(
        &self,
        i: usize,
        residual: &Residual,
        basis: Option<&Basis>,
        added: Added,
        step: Option<&decision::Step>,
        inconsistent: Option<String>,
        settings: &reference::Settings,
    ) -> Option<String> {
        match (basis, added) {
            (_, Added::Inconsistent) | (Some(Basis::Inconsistent { .. }), _) => inconsistent,
            (Some(Basis::Commissioning { .. }), Added::Completed) => Some(format!(
                "commissioning complete: {}",
                self.commissioning[i].describe(settings)
            )),
            (Some(Basis::Commissioning { .. }), _) => Some(format!(
                "{} (wide design limits{})",
                self.commissioning[i].describe(settings),
                // Beyond them: an alert, never an alarm (`decision`).
                match step.and_then(|s| s.param) {
                    Some(p) if p.look.statistic > p.look.threshold => {
                        "; beyond them: the models do not fit this vessel here, or its declared displacement is wrong; learned as its normal"
                    }
                    _ => "",
                }
            )),
            (Some(Basis::Vessel(p)), _) if p.nearest > 1.0 => Some(format!(
                "operating point {:.1} m/s, {:.0} t not yet learned: reference predicted from {:.1} tests' worth",
                residual.raw.map_or(f64::NAN, |r| r.0.speed_log_mps),
                residual.d_nom_t,
                p.support
            )),
            _ => inconsistent,
        }
    }

    /// The report's `reference` for method index `i` under `basis`.
    fn reference_report(&self, i: usize, basis: &Basis, d_nom_t: f64) -> ReferenceReport {
        let s = self.settings();
        let c = &self.commissioning[i];
        let kind = match basis {
            Basis::Design => ReferenceKind::Design,
            Basis::Commissioning { .. } => ReferenceKind::Commissioning,
            Basis::Inconsistent { .. } => ReferenceKind::CommissioningInconsistent,
            b if b.at_learned_point() => ReferenceKind::Commissioned,
            Basis::Vessel(_) => ReferenceKind::Predicted,
        };
        let r = c.reference;
        let p = match basis {
            Basis::Vessel(p) => Some(*p),
            _ => None,
        };
        ReferenceReport {
            kind,
            text: c.describe(&s),
            tests: c.tests,
            of: s.tests,
            learned: r.map(|r| r.learned),
            speed_offset_mps: p.map(|p| p.offset[0]),
            displacement_offset_t: p.map(|p| p.offset[1] * d_nom_t),
            ln_gain_offset: p.map(|p| p.offset[2]),
            offset_speed_sigma_mps: p.map(|p| p.cov.at(0, 0).sqrt()),
            offset_displacement_sigma_t: p.map(|p| p.cov.at(1, 1).sqrt() * d_nom_t),
            offset_ln_gain_sigma: p.map(|p| p.cov.at(2, 2).sqrt()),
            support: p.map(|p| p.support),
            correlation: r.map(|r| r.covariance.correlation(0, 1)),
            speed_log_mps: r.map(|r| r.speed_log_mps),
        }
    }
}

#[cfg(test)]
mod tests;
