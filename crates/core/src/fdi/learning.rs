//! When a test is learned into its method's reference (docs/fdi.md, "Learning"): once the
//! decision has seen all it can of it, so that a reference never holds the evidence it judges.
//!
//! - While commissioning every completed test joins the sample at once
//!   (`reference::MethodReference::add`); a completed sample goes to the change-point test.
//! - After commissioning every completed test measured against the vessel's reference is
//!   eligible (a method found inconsistent learns nothing). A test over the single-test alarm
//!   limit raises the alarm, which drops it.
//! - An eligible test is learned at once when the decision after it is quiet (every look under
//!   its alert limit, no alarm holding).
//! - Otherwise it is held ([`Pending`]) and learned as it leaves the window, `N` tests later.
//!   An alarm drops every held test; one held under an older reference of its method is
//!   dropped as it leaves.
//! - After each learned test the confirmation runs (`changepoint::confirm`). The window's
//!   tests are measured again against their method's newest reference
//!   ([`Learner::remeasure_window`]); one learned at once stays as it was measured.
//!
//! With `fdi.enabled = false` nothing is learned.

use super::ablation::{self, Mechanism};
use super::changepoint;
use super::decision::{Sequential, Step};
use super::limits::DecisionLimits;
use super::measured::Basis;
use super::raw::Raw;
use super::reference::MethodReference;
use super::reference::{self, Added, Settings};
use super::window::measure_entry;
use super::window::method_index;
use super::window::Entry;
use crate::wire::residuals::TrackState;
use serde::{Deserialize, Serialize};
use std::collections::VecDeque;

/// One held test.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Held {
    /// Its method's index (0 CLFRT, 1 HBT).
    pub method: usize,
    /// The method's reference generation it was measured against.
    pub generation: u32,
    /// Its raw residuals.
    pub raw: Raw,
}

/// The tests in the decision's window that wait to be learned, oldest first: one slot per
/// test of the ship (`None`: not to be learned).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct Pending {
    slots: VecDeque<Option<Held>>,
}

/// What the decision said after a test.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum After {
    /// Every look under its alert limit: nothing is building up.
    Quiet,
    /// An alert: evidence is building, no alarm.
    Alert,
    /// An alarm raised or holding.
    Alarm,
}

impl From<TrackState> for After {
    fn from(s: TrackState) -> Self {
        match s {
            TrackState::Normal => After::Quiet,
            TrackState::Alert => After::Alert,
            TrackState::Alarm => After::Alarm,
        }
    }
}

impl Pending {
    /// Takes the test just decided (`held`: it is eligible) with what the decision said
    /// after it; returns the tests to learn now: the test itself when the decision was
    /// quiet, and the test that leaves a window of `window` tests.
    pub fn push(&mut self, held: Option<Held>, after: After, window: usize) -> [Option<Held>; 2] {
        let (now, slot) = match after {
            After::Alarm => {
                self.slots.clear();
                return [None, None];
            }
            After::Quiet => (held, None),
            After::Alert => (None, held),
        };
        self.slots.push_back(slot);
        let leaving = if self.slots.len() > window {
            self.slots.pop_front().flatten()
        } else {
            None
        };
        [leaving, now]
    }

    /// Tests waiting.
    #[cfg(test)]
    fn waiting(&self) -> usize {
        self.slots.iter().flatten().count()
    }
}

/// After the decision on a test (`seq` updated with it): the tests to learn now, `held` the
/// test itself if eligible. A test learned at once stays in the window as it was measured.
pub fn after_decision(
    pending: &mut Pending,
    seq: &mut Sequential,
    held: Option<Held>,
    window: usize,
) -> [Option<Held>; 2] {
    let after = After::from(seq.state);
    if after == After::Quiet && held.is_some() {
        if let Some(e) = seq.window.back_mut() {
            e.source = None;
        }
    }
    pending.push(held, after, window)
}

/// What learning reads and changes of the vessel's FDI: the references, their generations,
/// the tests held for learning and the decision's window.
pub struct Learner<'a> {
    /// Per method, the commissioning and the vessel's own reference.
    pub commissioning: &'a mut [MethodReference; 2],
    /// Per method, how many references it has had.
    pub generation: &'a mut [u32; 2],
    /// The tests in the window waiting to be learned.
    pub pending: &'a mut Pending,
    /// The vessel's sequential test.
    pub sequential: &'a mut Sequential,
    /// The decision's limits.
    pub limits: &'a DecisionLimits,
    /// `fdi.enabled`: nothing is learned without decisions.
    pub enabled: bool,
}

impl Learner<'_> {
    /// Learns what the test just decided lets the vessel learn (see the module doc): while
    /// commissioning every completed test at once; after, by `Pending`.
    pub fn learn(
        &mut self,
        i: usize,
        raw: Option<Raw>,
        basis: Option<&Basis>,
        step: Option<&Step>,
        settings: &Settings,
    ) -> Added {
        let mut added = Added::Nothing;
        let mut held = None;
        if let (true, Some(r), Some(b)) = (self.enabled, raw, basis) {
            match b {
                // Every completed test joins the sample, one beyond the wide limits too
                // (`decision`: there a misfit model reads the ship so, from its first test).
                Basis::Commissioning { .. } => {
                    let order = reference::next_order(self.commissioning);
                    added = self.commissioning[i].add(&settings.method(i), &r, order);
                    if added == Added::Sample
                        && reference::complete_on_other(self.commissioning, i, settings)
                    {
                        added = Added::Completed;
                    }
                    if added == Added::Completed {
                        self.generation[i] += 1;
                        if !ablation::off(Mechanism::CommissioningCheck)
                            && changepoint::check(self.commissioning, i, settings).is_some()
                        {
                            added = Added::Inconsistent;
                        }
                    }
                }
                Basis::Vessel(_) => {
                    held = Some(Held {
                        method: i,
                        generation: self.generation[i],
                        raw: r,
                    });
                }
                _ => {}
            }
        }
        if step.is_some() {
            for h in after_decision(self.pending, self.sequential, held, self.limits.window)
                .into_iter()
                .flatten()
            {
                if h.generation == self.generation[h.method] {
                    let order = reference::next_order(self.commissioning);
                    self.commissioning[h.method].add(&settings.method(h.method), &h.raw, order);
                    if !ablation::off(Mechanism::CommissioningCheck)
                        && changepoint::confirm(self.commissioning, h.method, settings).is_some()
                    {
                        added = Added::Inconsistent;
                    }
                }
            }
        }
        added
    }

    /// Measures the window's held tests again against their methods' references as they are
    /// now (a test measured on wide limits, or under an older reference, stays as it was).
    pub fn remeasure_window(&mut self, settings: &Settings) {
        let (generation, commissioning) = (*self.generation, &*self.commissioning);
        self.sequential.remeasure(|e| {
            let (src, _) = (e.source?, e.offset_var?);
            let m = method_index(e.method);
            (e.epoch == generation[m])
                .then(|| {
                    measure_entry(
                        &commissioning[m],
                        settings,
                        e.method,
                        src,
                        e.epoch,
                        e.z_rate,
                    )
                })
                .filter(|(b, _, _)| matches!(b, Basis::Vessel(_)))
                .map(|(_, _, n)| Entry { log: e.log, ..n })
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn held(i: u32) -> Held {
        Held {
            method: (i % 2) as usize,
            generation: i,
            raw: Raw {
                speed_mps: 0.0,
                displacement: 0.0,
                speed_sigma_mps: 0.1,
                displacement_sigma: 0.01,
                speed_log_mps: 7.0,
                displacement_declared_t: 7000.0,
                excitation_scale: 1.0,
                sea_index: None,
                ln_gain: Some(-5.0),
                ln_damping: None,
                speed_slope: [0.0; 3],
                loading_slope: [0.0; 3],
                meas: None,
                log_slope: 0.0,
            },
        }
    }

    /// A quiet decision learns the test at once; one under an alert is held until it leaves
    /// the window.
    #[test]
    fn a_quiet_test_is_learned_at_once_an_alerted_one_at_the_window_end() {
        use crate::fdi::limits::DecisionLimits;
        use crate::fdi::window::Entry;
        use crate::wire::Method;
        let limits = DecisionLimits::new(0.1, 3720.0, 4);
        let entry = |zb: f64| Entry {
            method: Method::Clfrt,
            z: Some([0.0, 0.0, zb]),
            dim: 3,
            offset_var: Some(0.1),
            epoch: 0,
            directions: [[-1.0, 0.0, 0.0], [0.0, 1.0, -1.0]],
            rudder: None,
            z_rate: None,
            source: None,
            log: None,
        };
        let mut seq = Sequential::default();
        let mut pending = Pending::default();
        seq.update(&limits, entry(1.0));
        assert_eq!(seq.state, TrackState::Normal);
        assert_eq!(
            after_decision(&mut pending, &mut seq, Some(held(1)), 4),
            [None, Some(held(1))]
        );
        // Over the single test's alert limit, under its alarm limit: held.
        let z_alert = (limits.param_alert[3] * 1.01).sqrt();
        assert!(z_alert * z_alert < limits.param[3]);
        seq.update(&limits, entry(z_alert));
        assert_eq!(seq.state, TrackState::Alert);
        assert_eq!(
            after_decision(&mut pending, &mut seq, Some(held(2)), 4),
            [None, None]
        );
    }

    /// A quiet test is learned at once; one under an alert leaves N tests later; a test
    /// not eligible leaves nothing; an alarm drops every held test and the one that raised it.
    #[test]
    fn held_for_the_window_dropped_by_an_alarm() {
        use After::*;
        let mut p = Pending::default();
        assert_eq!(p.push(Some(held(0)), Quiet, 4), [None, Some(held(0))]);
        for i in 1..4 {
            assert_eq!(p.push(Some(held(i)), Alert, 4), [None, None]);
        }
        assert_eq!(p.waiting(), 3);
        assert_eq!(p.push(None, Alert, 4), [None, None]);
        assert_eq!(
            p.push(Some(held(5)), Quiet, 4),
            [Some(held(1)), Some(held(5))]
        );
        assert_eq!(p.push(Some(held(6)), Alarm, 4), [None, None]);
        assert_eq!(p.waiting(), 0);
        for i in 7..11 {
            assert_eq!(p.push(Some(held(i)), Alert, 4), [None, None]);
        }
        assert_eq!(p.push(None, Quiet, 4), [Some(held(7)), None]);
        // A window of one: learned at the next test.
        let mut q = Pending::default();
        assert_eq!(q.push(Some(held(1)), Alert, 1), [None, None]);
        assert_eq!(q.push(Some(held(2)), Alert, 1), [Some(held(1)), None]);
    }
}
