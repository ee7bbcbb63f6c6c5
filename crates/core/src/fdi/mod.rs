//! Parity-space fault detection and isolation of one vessel. The model is stated once, in
//! docs/fdi.md, "The model"; the keys and the models' calibration in "Keys and calibration".
//!
//! [`Fdi::assess`] (`assess.rs`) takes a completed test through four steps, the evidence flowing
//! one way:
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
mod assess;
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
pub mod prior;
pub mod raw;
pub mod reference;
mod report;
pub mod resolve;
pub mod sensitivity;
pub mod shape;
pub mod stats;
pub mod summary;
pub mod window;

use crate::baseline::config::BaselineConfig;
use crate::fdi::config::{Calibration, FdiConfig, ReferenceConfig};
use crate::model::ShipConfig;
use crate::monitor::config::CoreConfig;
use crate::wire::residuals::{Residuals, TrackState};
use crate::wire::{AlarmState, Cause, Decision, Method, Notification};
use decision::Sequential;
use learning::Pending;
use limits::DecisionLimits;
use reference::{MethodReference, Phase};
use report::Fingerprint;
use serde::{Deserialize, Serialize};
use shape::LoopShape;
use window::method_index;

/// What the FDI adds to a completed test's report.
#[derive(Debug, Clone, PartialEq)]
pub struct Assessment {
    /// The report's `residuals`.
    pub residuals: Residuals,
    /// The report's `decision`.
    pub decision: Decision,
    /// The report's `isolation`.
    pub isolation: Vec<Cause>,
    /// The report's `calibrated_estimate`: the estimate corrected by the vessel's learned
    /// offset (`None` before the vessel's own reference).
    pub calibrated_estimate: Option<crate::wire::CalibratedEstimate>,
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

    /// Records which models estimate (their checksums, [`crate::estimator::Estimator::fingerprint`]).
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

    /// `method`'s reference is being established: commissioning, or commissioned and its
    /// confirmation still running (`changepoint::confirming`). Not when commissioning is off
    /// or inconsistent (no reference until commissioned again).
    pub fn establishing(&self, method: Method) -> bool {
        let c = &self.commissioning[method_index(method)];
        self.cfg.commissioning_tests > 0
            && (c.phase == Phase::Commissioning || changepoint::confirming(c))
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
}

#[cfg(test)]
mod tests;
