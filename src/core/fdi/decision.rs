//! One decision for the vessel: a window GLR over its last tests, both methods, whose limits
//! follow from one number, `fdi.false-alarms-per-year`.
//!
//! ## Model
//!
//! Each completed test k of method m gives a whitened parameter residual `z_k = L_k^-1 r_k`
//! (`L_k L_k' = Sigma_k`, the covariance of its residual against the reference it was
//! measured against, the reference's own error included: `crate::core::fdi::reference`) and,
//! when it had a servo check, the servo's one-sided score `z_rate,k >= 0`. For a healthy ship
//! (H0): the `z_k` are standard normal 2-vectors; the part of each that is the reference
//! offset's error, at most a share `c_m` of its variance in any direction, is shared by every
//! test of a method (0 for the design's reference; `1 / (K + 1)` for K tests at one point;
//! near 1 at an operating point the vessel has not been tested at); the rest is independent
//! from test to test; `z_rate` is a normal score clipped at 0. A fault that began `n` tests ago (H1(n)) shifts every later
//! `z_k` of method m by a constant `d_m` (each method sees the fault its own way: the two are
//! free) and the servo score by a constant `d_s > 0`.
//!
//! ## Statistics
//!
//! The generalised likelihood ratio of H1(n) against H0, the `d`'s at their maximum
//! likelihood, is, per channel,
//!
//! ```text
//! T_n     = sum_m |s_m|^2 / (n_m (1 + (n_m - 1) c_m))           chi2, 2 M_n dof
//! T_n,D   = sum_m (u_mD . s_m)^2 / (n_m (1 + (n_m - 1) c_m))    chi2, M_n dof
//! T_n,log = (sum_k v_k . z_k)^2 / sum_m ((1 - c_m) sum_k |v_k|^2 + c_m |sum_k v_k|^2)
//!                                                               chi2, 1 dof
//! S_n     = sum_{k in last n} z_rate,k / sqrt(n_s)              N(0, 1) or below
//! ```
//!
//! (`s_m = sum_{k in last n, method m} z_k`.) The cause looks are the ratio under narrower
//! H1s: the shift lies along the direction in which the cause moves each test's whitened
//! residual (`isolation`): for a displacement or rudder-effectiveness change along `u_mD`,
//! the unit mean of the method's displacement directions, with a size per method; for a
//! speed-log bias `beta` by exactly `beta v_k` (`v_k` the whitened log direction per m/s),
//! one size for both methods (`COMMON_SIZE`). The alarm is named by isolation over the
//! raising look's window, whichever look raised it.
//!
//! (`n_m` of the last n tests are of method m, `M_n` methods among them; the sum's covariance
//! is at most `n_m (1 + (n_m - 1) c_m) I`, so `T_n` errs low where the share is below `c_m`:
//! conservative; the servo's clip at 0 makes `S_n` stochastically smaller than a normal
//! score: conservative too). A test measured on
//! wide design limits (commissioning, or after a commissioning sample held a change) enters
//! only its own look, `n = 1`: its residual is the model's bias on this ship, the same at
//! every test, and no average shrinks it. Over its limit it raises an **alert, never an
//! alarm**: the wide limits bound how far the networks may misread a ship of the family they
//! were trained for, and a test beyond them (its displacement read about 1.3 D_nom off, or
//! its speed about 11 m/s: no loading, rudder or log fault does that) says the ship is unlike
//! that family at this operating point, or was declared wrong, steadily from its first test. A fault and a
//! model that does not fit cannot be told apart before the vessel has a reference of its
//! own; the test joins the commissioning sample (`crate::core::fdi::learning`), whose
//! change-point test catches a change inside it, and the vessel's own reference judges the
//! tests after it. (Measured: the Mariner hull with models trained on its own linearised
//! particulars read HBT's displacement at +1.3 D steadily at its fast and light corner, and
//! each of that run's tests alarmed.)
//!
//! ## Limits from the budget
//!
//! With `F = fdi.false-alarms-per-year` and the scheduler's test rate `N_y = 365.25 x 86400 /
//! (scheduler.interval-s + scheduler.steady-time-s)` tests a year (at most: a test's own
//! duration is left out, so the rate is over-counted and the limits err high), each test may
//! raise a false alarm with probability `alpha = F / N_y`, split evenly over the four families
//! of looks (the servo's, the free shift's, one per parameter cause; Bonferroni: a cause's
//! look is part of the free one's evidence, so the true rate is below it) and over the `N =
//! fdi.window-tests` window lengths counted as the `M_eff` independent looks they are worth
//! (`effective_lengths`: Li and Ji's count from the eigenvalues of the nested windows'
//! correlations `sqrt(n / m)`; 2 for N = 2 to 4, where Bonferroni would count N):
//!
//! ```text
//! alpha_n = alpha / (4 M_eff)
//! T_n > h_n = chi2_{2 M_n}^-1(1 - alpha_n)     T_n,c > k_n = chi2_{M_n}^-1(1 - alpha_n)
//! S_n > g = Phi^-1(1 - alpha_n)
//! ```
//!
//! Defaults (F = 0.1, 3720 s, N = 4, `M_eff` = 2): `alpha = 1.18e-5`, `alpha_n = 1.47e-6`,
//! `h = 26.9` (one method, 2 components) / 29.9 (3) / 32.6 (both, 2 each) / 37.4 (both, 3
//! each), `k = 23.2` / 26.9, `g = 4.67`. A look over its limit raises the alarm at once;
//! the evidence is spent (the window empties), so the alarm holds on new tests or clears
//! after N tests in a row under the alert limits, which are the same statistics at a
//! thousand times the per-look probability (`alpha_n x 1000`: `h = 13.0` / 15.4 / 17.6 /
//! 21.5, `k = 10.1` / 13.0, `g = 2.97`): an alert says evidence is building.
//!
//! What the arithmetic does not cover: residuals that are not Gaussian (heavy tails of a hull
//! unlike the training model), a covariance learned from few tests (the K-sample factor
//! makes it right on average, not for every vessel), and serial correlation of the sea.
//! The family suite counts false alarms on simulated ships directly; a Monte Carlo on the
//! model itself checks the arithmetic (`decision_tests.rs`, docs/fdi.md "What the
//! arithmetic covers").

use super::isolation;
use super::limits::{self, Limits};
use super::stats::{dot, P};
use super::window::{method_sums, Entry};
use crate::core::wire::residuals::{Look, TrackState};
use crate::core::wire::Cause;
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
    /// their method, which never contains them: `crate::core::fdi::learning`), so each look
    /// is taken against the best reference there is for its tests.
    pub fn remeasure(&mut self, mut f: impl FnMut(&Entry) -> Option<Entry>) {
        for e in self.window.iter_mut() {
            if let Some(n) = f(e) {
                *e = n;
            }
        }
    }

    /// Takes one completed test; `limits` from the budget.
    pub fn update(&mut self, limits: &Limits, mut entry: Entry) -> Step {
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
    fn param_look(&self, limits: &Limits) -> Option<Scored> {
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
    fn servo_look(&self, limits: &Limits) -> Option<Scored> {
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
