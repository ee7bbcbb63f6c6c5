//! The vessel's one decision (docs/fdi.md, "Decision"; its statistics and limits in "The
//! window GLR and its limits"): a window GLR over the last `N = fdi.window-tests` tests of both
//! methods, a parameter channel and a servo channel.
//!
//! [`Sequential::update`] takes a test's [`Entry`] and returns its [`Step`]:
//!
//! - The window keeps at most `N` entries and one reference per method: the test's method's
//!   entries of an older epoch leave. Looks cover the newest `n = 1..N` entries.
//! - An entry on wide design limits (`offset_var` `None`) enters only its own look, the free
//!   shift's at `n = 1`: it alerts, never alarms; while it is the newest no other parameter
//!   look is taken.
//! - Parameter looks: the free shift `T_n` (each method's components summed, 1 to `2 P` dof)
//!   and one per cause of `limits::PARAMETER_CAUSES` ([`param_statistics`]; [`COMMON_SIZE`]
//!   says which cause has one size for both methods). The servo look `S_n` is taken only when
//!   the newest test has a servo check.
//! - A look over its limit (`limits::DecisionLimits`) raises the alarm and empties the window; the
//!   alarm clears after `N` tests in a row under every alert limit. A look over an alert limit
//!   with no alarm is an alert; otherwise the state is normal.
//! - The name: `steering_actuator` when the servo look is at least as near its limit as the
//!   parameter look, else isolation's over the parameter look's window (`isolation`). An
//!   alarm keeps its name until a later look over the alarm limit renames it; normal names
//!   nothing.
//!
//! A [`Step`]'s looks are each channel's nearest its limit (largest `T / h`), `None` when the
//! window holds nothing for that channel.

use super::isolation;
use super::limits::{self, DecisionLimits};
use super::stats::{dot, P};
use super::window::{method_sums, Entry};
use crate::wire::residuals::{Look, TrackState};
use crate::wire::Cause;
use serde::{Deserialize, Serialize};
use std::collections::VecDeque;

/// Which tests of the window a look covers, and its statistic.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Scored {
    /// The look.
    pub look: Look,
    /// How many of the newest entries it covers.
    pub n: usize,
}

/// The vessel's decision state.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct Sequential {
    /// The last tests, newest last (at most N).
    pub window: VecDeque<Entry>,
    /// The state after the last test.
    pub state: TrackState,
    /// Tests in a row under the alert limits while in alarm.
    pub quiet_run: u32,
    /// The causes named when the alarm was raised (or last confirmed), kept while it holds.
    pub named: Vec<Cause>,
    /// The other parameter causes that evidence had not ruled out
    /// (`isolation::not_ruled_out`), kept with the name.
    pub open: Vec<Cause>,
    /// The speed log's reading at the ship's last test that had one [m/s].
    pub last_log_mps: Option<f64>,
    /// While an alarm holds, the log's reading before the look that raised it: the later
    /// looks' step is taken from it (`isolation::costs`).
    pub onset_log_mps: Option<f64>,
}

/// What one test did to the decision.
#[derive(Debug, Clone, PartialEq)]
pub struct Step {
    /// The state after it.
    pub state: TrackState,
    /// The parameter look nearest its limit (largest `T / h`).
    pub param: Option<Scored>,
    /// The servo look nearest its limit.
    pub servo: Option<Scored>,
    /// The look that raised the alarm at this test: the parameter channel's (`false`) or the
    /// servo's (`true`); `None`: no alarm raised here.
    pub raised_by_servo: Option<bool>,
    /// The suspected causes after it (empty when normal).
    pub isolation: Vec<Cause>,
    /// The other parameter causes the evidence behind `isolation` does not rule out.
    pub open: Vec<Cause>,
    /// The parameter causes' costs `J_c` over the parameter look's window (speed log,
    /// displacement; `isolation`), before an alarm spends it.
    pub costs: Option<[f64; 2]>,
    /// The speed log's step those costs took (`isolation::costs`) [m/s].
    pub log_step_mps: Option<f64>,
}

impl Sequential {
    /// Measures the window's tests again where `f` gives a new entry (a newer reference of
    /// their method, which never contains them: `crate::fdi::learning`), so each look
    /// is taken against the best reference there is for its tests.
    pub fn remeasure(&mut self, mut f: impl FnMut(&Entry) -> Option<Entry>) {
        for e in self.window.iter_mut() {
            if let Some(n) = f(e) {
                *e = n;
            }
        }
    }

    /// Takes one completed test; `limits` from the budget.
    pub fn update(&mut self, limits: &DecisionLimits, mut entry: Entry) -> Step {
        // The reading before this test is the last test's (`isolation::LogReading`).
        if let Some(log) = entry.log.as_mut() {
            log.before_mps = self.last_log_mps;
            self.last_log_mps = Some(log.now_mps);
        }
        // One reference per method in the window.
        self.window
            .retain(|e| e.method != entry.method || e.epoch == entry.epoch);
        self.window.push_back(entry);
        while self.window.len() > limits.window {
            self.window.pop_front();
        }
        let param = self.param_look(limits);
        let servo = self.servo_look(limits);
        let over = |s: Option<Scored>| s.is_some_and(|s| s.look.statistic > s.look.threshold);
        let alert =
            |s: Option<Scored>| s.is_some_and(|s| s.look.statistic > s.look.alert_threshold);
        // On wide design limits the parameter look alerts, never alarms (module doc).
        let wide = self.window.back().is_some_and(|e| e.offset_var.is_none());
        let before = self.state;
        let (p_over, s_over) = (over(param) && !wide, over(servo));
        let onset = self.onset_log_mps.filter(|_| before == TrackState::Alarm);
        let window_costs = param.map(|p| isolation::costs(&self.window, p.n, onset));
        let costs = window_costs.map(|c| c.j);
        let log_step_mps = window_costs.and_then(|c| c.log_step_mps);
        let mut raised_by_servo = None;
        // The cause the current evidence names: the channel nearest (or furthest over) its
        // limit; the parameter causes from the same tests as the parameter look.
        let current = if servo.is_some() && ratio(servo) >= ratio(param) {
            vec![Cause::SteeringActuator]
        } else {
            window_costs.map(isolation::name).unwrap_or_default()
        };
        let current_open = match (window_costs, current.first()) {
            (Some(c), Some(&named)) => isolation::not_ruled_out(c, named),
            _ => Vec::new(),
        };
        if p_over || s_over {
            if before != TrackState::Alarm {
                raised_by_servo = Some((s_over && !p_over) || ratio(servo) > ratio(param));
                self.onset_log_mps = isolation::reading_before(&self.window);
            }
            self.named = current.clone();
            self.open = current_open.clone();
            self.state = TrackState::Alarm;
            self.quiet_run = 0;
            // The evidence is spent on this alarm: it holds, or clears, on tests to come.
            self.window.clear();
        } else if alert(param) || alert(servo) {
            self.quiet_run = 0;
            if before != TrackState::Alarm {
                self.state = TrackState::Alert;
            }
        } else {
            self.quiet_run += 1;
            if before != TrackState::Alarm || self.quiet_run >= limits.window as u32 {
                self.state = TrackState::Normal;
            }
        }
        let (isolation, open) = match self.state {
            TrackState::Normal => {
                self.named.clear();
                self.open.clear();
                self.onset_log_mps = None;
                (Vec::new(), Vec::new())
            }
            TrackState::Alert => (current, current_open),
            TrackState::Alarm => (self.named.clone(), self.open.clone()),
        };
        Step {
            state: self.state,
            param,
            servo,
            raised_by_servo,
            isolation,
            open,
            costs,
            log_step_mps,
        }
    }

    /// The parameter look nearest its limit: over every window length, the free shift's
    /// and each cause's.
    fn param_look(&self, limits: &DecisionLimits) -> Option<Scored> {
        let newest = self.window.back()?;
        // A newest test on wide limits has only its own look, the free shift's.
        let wide = newest.offset_var.is_none();
        let longest = if wide { 1 } else { self.window.len() };
        let mut best: Option<Scored> = None;
        for n in 1..=longest {
            let Some(t) = param_statistics(&self.window, n) else {
                continue;
            };
            let dof = t.dof.clamp(1, 2 * P);
            let free = Scored {
                look: Look {
                    statistic: t.free,
                    window: n,
                    dof,
                    threshold: limits.param[dof],
                    alert_threshold: limits.param_alert[dof],
                    cause: None,
                },
                n,
            };
            let causes = limits::PARAMETER_CAUSES
                .iter()
                .zip(t.along.into_iter().zip(t.along_dof))
                .filter(|_| !wide)
                .map(|(c, (along, dof))| {
                    let i = dof.clamp(1, 2) - 1;
                    Scored {
                        look: Look {
                            statistic: along,
                            window: n,
                            dof,
                            threshold: limits.cause[i],
                            alert_threshold: limits.cause_alert[i],
                            cause: Some(*c),
                        },
                        n,
                    }
                });
            for s in std::iter::once(free).chain(causes) {
                if best.is_none_or(|b| ratio(Some(s)) > ratio(Some(b))) {
                    best = Some(s);
                }
            }
        }
        best
    }

    /// The servo look nearest its limit.
    fn servo_look(&self, limits: &DecisionLimits) -> Option<Scored> {
        self.window.back()?.z_rate?;
        let mut best: Option<Scored> = None;
        let (mut sum, mut count) = (0.0, 0usize);
        for (i, e) in self.window.iter().rev().enumerate() {
            if let Some(z) = e.z_rate {
                sum += z;
                count += 1;
            }
            if count == 0 {
                continue;
            }
            let s = Scored {
                look: Look {
                    statistic: sum / (count as f64).sqrt(),
                    window: i + 1,
                    dof: 1,
                    threshold: limits.servo,
                    alert_threshold: limits.servo_alert,
                    cause: None,
                },
                n: i + 1,
            };
            if best.is_none_or(|b| ratio(Some(s)) > ratio(Some(b))) {
                best = Some(s);
            }
        }
        best
    }
}

/// `T / h` of a look (0 without one).
fn ratio(s: Option<Scored>) -> f64 {
    s.map_or(0.0, |s| s.look.statistic / s.look.threshold)
}

/// Per cause of `limits::PARAMETER_CAUSES`, whether its size is one for every method. A
/// speed-log bias is: the log enters both methods' residuals the same way, `e_u` by `-beta`
/// exactly and `e_D` through each displacement network's own `dD/du_log`, so the whitened
/// directions per m/s are exact and one size `beta` moves both (1 dof). A displacement's
/// direction is read through each method's networks from a model of how `b` moves the
/// features (`sensitivity`), which a hull unlike the training model can bend, even turn:
/// a size of its own per method (1 dof per method).
pub const COMMON_SIZE: [bool; 2] = [true, false];

/// The parameter statistics of the newest `n` entries.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ParamStatistics {
    /// `T_n`, the free shift's.
    pub free: f64,
    /// Its degrees of freedom: each method's components (`P`, or 2 without `e_b`).
    pub dof: usize,
    /// `T_n,c` per cause of `limits::PARAMETER_CAUSES`: the evidence along the cause's
    /// directions (see `COMMON_SIZE`).
    pub along: [f64; 2],
    /// Their degrees of freedom: 1 for a cause of one size, else 1 per method.
    pub along_dof: [usize; 2],
    /// Methods among the entries.
    pub methods: usize,
}

/// The parameter statistics of the newest `n` entries (`None`: no parameter residual among
/// them).
pub fn param_statistics(window: &VecDeque<Entry>, n: usize) -> Option<ParamStatistics> {
    let sums = method_sums(window, n);
    if sums.is_empty() {
        return None;
    }
    let (mut free, mut along, mut dof) = (0.0, [0.0; 2], 0);
    // A cause of one size: `sum_k v_k . z_k` and its variance over every method.
    let (mut proj, mut var) = ([0.0; 2], [0.0; 2]);
    for m in &sums {
        let (s, c, scale) = (m.sum, m.offset_var, m.scale());
        free += dot(s, s) / scale;
        dof += m.dim;
        for j in 0..2 {
            if COMMON_SIZE[j] {
                let w = m.along_sum[j];
                proj[j] += m.projection[j];
                var[j] += (1.0 - c) * m.norm2[j] + c * dot(w, w);
            } else {
                along[j] += m.along(j).powi(2) / scale;
            }
        }
    }
    let mut along_dof = [sums.len(); 2];
    for j in (0..2).filter(|&j| COMMON_SIZE[j]) {
        along[j] = if var[j] > 0.0 {
            proj[j] * proj[j] / var[j]
        } else {
            0.0
        };
        along_dof[j] = 1;
    }
    (free.is_finite() && along.iter().all(|a| a.is_finite())).then_some(ParamStatistics {
        free,
        dof,
        along,
        along_dof,
        methods: sums.len(),
    })
}

#[cfg(test)]
#[path = "decision_tests.rs"]
pub(crate) mod tests;
