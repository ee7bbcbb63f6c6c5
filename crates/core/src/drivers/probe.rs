//! Virtual-time driver: the simulated ship and the monitor core in lockstep, in one process.
//!
//! One tick follows the contract's lockstep order: the ship publishes its samples (rudder,
//! speed, autopilot state and target when due, heading last), the monitor consumes them and
//! answers the heading with exactly one excitation of the same `t`, the ship's autopilot takes
//! that excitation, and the ship advances one sample period. No clock and no thread: a
//! simulated hour costs milliseconds and the same seed gives the same result bit for bit.
//!
//! [`Lockstep`] is the building block (the offline probe, tests, the training database and
//! benchmarks all use it); [`run_probe`] runs one test after a warm-up and returns its report.

use crate::dsp::multisine::Multisine;
use crate::estimator::Estimator;
use crate::monitor::config::CoreConfig;
use crate::monitor::{Monitor, Output};
use crate::sim::config::SimConfig;
use crate::sim::{Scenario, Ship, SimError};
use crate::wire::Method;
use crate::wire::{Input, Report, Status, TriggerReply};
use std::sync::Arc;

/// Errors of the virtual-time drivers.
#[derive(Debug, thiserror::Error)]
pub enum ProbeError {
    /// The scenario is not valid.
    #[error(transparent)]
    Sim(#[from] SimError),
    /// The monitor refused to start the test for longer than the warm-up allows.
    #[error("the monitor refused the test: {0}")]
    Refused(String),
    /// No report within the time limit.
    #[error("no report within {0:.0} s of ship time")]
    Timeout(f64),
}

/// A simulated ship and a monitor, driven tick by tick. A clone goes on from the same state
/// (a run branched at a fault's onset).
#[derive(Debug, Clone)]
pub struct Lockstep {
    /// The ship (tests reach in to change course, disengage the autopilot, ...).
    pub ship: Ship,
    /// The monitor core.
    pub monitor: Monitor,
    /// Samples of the current tick (reused).
    inputs: Vec<Input>,
    /// Samples the monitor rejected so far.
    pub rejected: u64,
}

impl Lockstep {
    /// A ship for `scenario` (configured by `sim`) and a monitor (configured by `core`) for
    /// vessel `sim.simulation.vessel`.
    pub fn new(core: &CoreConfig, sim: &SimConfig, scenario: &Scenario) -> Result<Self, SimError> {
        Self::with_parts(core, sim, scenario, None, None)
    }

    /// As [`Lockstep::new`], the monitor built by [`Monitor::with_parts`] from a designed
    /// multisine and an estimator when given.
    pub fn with_parts(
        core: &CoreConfig,
        sim: &SimConfig,
        scenario: &Scenario,
        multisine: Option<Multisine>,
        estimator: Option<Arc<Estimator>>,
    ) -> Result<Self, SimError> {
        let vessel = &sim.simulation.vessel;
        Ok(Self {
            ship: Ship::new(sim, scenario)?,
            monitor: Monitor::with_parts(core, vessel, multisine, estimator),
            inputs: Vec::with_capacity(8),
            rejected: 0,
        })
    }

    /// Ship time of the next tick [s].
    pub fn time_s(&self) -> f64 {
        self.ship.time_s()
    }

    /// One tick. Outputs other than excitations are appended to `out`; excitations go to the
    /// ship's autopilot (and are appended too when `keep_excitation`).
    pub fn tick(&mut self, out: &mut Vec<Output>, keep_excitation: bool) {
        self.inputs.clear();
        self.ship.publish(&mut self.inputs);
        for input in self.inputs.drain(..) {
            if self.monitor.handle_input(input).is_err() {
                self.rejected += 1;
            }
            while let Some(o) = self.monitor.poll_output() {
                if let Output::Excitation(e) = &o {
                    self.ship.receive_excitation(e);
                    if !keep_excitation {
                        continue;
                    }
                }
                out.push(o);
            }
        }
        self.ship.step();
    }

    /// Runs ticks until ship time `t_end_s`, collecting outputs (excitations excluded).
    pub fn run_until(&mut self, t_end_s: f64, out: &mut Vec<Output>) {
        while self.ship.time_s() < t_end_s {
            self.tick(out, false);
        }
    }

    /// One test of `opts.method` on this ship as it is: `opts.warmup_s` of ship time, then
    /// the trigger (retried each second while the monitor refuses, for up to the warm-up
    /// time again), then its report within `opts.max_test_s` (consecutive tests on one
    /// vessel: each keeps what the previous ones left in the monitor).
    pub fn run_test(&mut self, opts: &ProbeOptions) -> Result<ProbeResult, ProbeError> {
        let mut out = Vec::new();
        let t0 = self.time_s();
        self.run_until(t0 + opts.warmup_s, &mut out);
        let t_trigger = loop {
            let reply = self.trigger(opts.method);
            if reply.accepted {
                break self.time_s();
            }
            if self.time_s() > t0 + 2.0 * opts.warmup_s {
                return Err(ProbeError::Refused(reply.reason.unwrap_or_default()));
            }
            let t = self.time_s();
            self.run_until(t + 1.0, &mut out);
        };
        out.clear();
        let mut statuses = Vec::new();
        match self.next_report(t_trigger + opts.max_test_s, |o| {
            if let Output::Status(s) = o {
                statuses.push(s);
            }
        }) {
            Some(report) => Ok(ProbeResult { report, statuses }),
            None => Err(ProbeError::Timeout(opts.max_test_s)),
        }
    }

    /// Asks the monitor for a test now.
    pub fn trigger(&mut self, method: Method) -> TriggerReply {
        self.monitor.trigger(method)
    }

    /// Runs ticks until the monitor's next report or ship time `until_s`, whichever comes
    /// first; the outputs before the report go to `other` (excitations excluded), those after
    /// it in the same tick are dropped. `None`: no report by then.
    pub fn next_report(&mut self, until_s: f64, mut other: impl FnMut(Output)) -> Option<Report> {
        let mut out = Vec::new();
        while self.time_s() < until_s {
            self.tick(&mut out, false);
            for o in out.drain(..) {
                match o {
                    Output::Report(r) => return Some(*r),
                    o => other(o),
                }
            }
        }
        None
    }
}

/// Options of one probe run.
#[derive(Debug, Clone)]
pub struct ProbeOptions {
    /// The test to run.
    pub method: Method,
    /// Ship time before the test is triggered, so the autopilot and the sea settle [s].
    pub warmup_s: f64,
    /// Give up when no report arrived after this much ship time from the trigger [s].
    pub max_test_s: f64,
    /// Networks for the report's `estimate` (none: features only).
    pub estimator: Option<Arc<Estimator>>,
    /// The CLFRT multisine from [`Monitor::design_multisine`] for this configuration, to
    /// skip its design (~0.1 s) when running many probes (none: designed per run).
    pub multisine: Option<Multisine>,
    /// The vessel's CLFRT heading guard armed, as after a CLFRT test of it that ended on the
    /// heading limit (`crate::monitor::sizing`); a fresh monitor's is not.
    pub clfrt_heading_guard: bool,
}

impl ProbeOptions {
    /// Defaults: 600 s warm-up, and the safety limit on test duration plus a margin.
    pub fn new(cfg: &CoreConfig, method: Method) -> Self {
        Self {
            method,
            warmup_s: 600.0,
            max_test_s: cfg.safety.max_test_duration_s + 120.0,
            estimator: None,
            multisine: None,
            clfrt_heading_guard: false,
        }
    }
}

/// What a probe run produced.
#[derive(Debug, Clone)]
pub struct ProbeResult {
    /// The report of the test.
    pub report: Report,
    /// Every status change, in order.
    pub statuses: Vec<Status>,
}

/// Runs one test on a simulated ship in virtual time and returns its report (with an
/// `estimate` when `opts.estimator` is set). The scheduler
/// is switched off: the test starts on trigger after the warm-up (retried each second while
/// the monitor refuses, for up to the warm-up time again).
pub fn run_probe(
    core: &CoreConfig,
    sim: &SimConfig,
    scenario: &Scenario,
    opts: &ProbeOptions,
) -> Result<ProbeResult, ProbeError> {
    let mut core = core.clone();
    core.scheduler.enabled = false;
    let mut ls = Lockstep::with_parts(
        &core,
        sim,
        scenario,
        opts.multisine.clone(),
        opts.estimator.clone(),
    )?;
    if opts.clfrt_heading_guard {
        let mut state = ls.monitor.saved_state();
        state.clfrt_heading_guard = true;
        ls.monitor
            .restore(state)
            .map_err(|e| ProbeError::Refused(e.to_string()))?;
    }
    ls.run_test(opts)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A clone taken in the middle of a test (its multisine analyser, relay and records
    /// under way) goes on exactly as the original: the same outputs, bit for bit.
    #[test]
    fn a_clone_goes_on_as_the_original() {
        let mut core = CoreConfig::default();
        core.scheduler.interval_s = 60.0;
        let sim = SimConfig::default();
        let sc = Scenario::nominal(&sim, 3);
        let mut a = Lockstep::new(&core, &sim, &sc).unwrap();
        let mut out = Vec::new();
        // Into the first test (CLFRT), then clone.
        a.run_until(a.time_s() + 600.0, &mut out);
        assert!(a.monitor.state() != crate::wire::MonitorState::Idle);
        let mut b = a.clone();
        let (mut oa, mut ob) = (Vec::new(), Vec::new());
        let t_end = a.time_s() + 3.0 * 3600.0;
        a.run_until(t_end, &mut oa);
        b.run_until(t_end, &mut ob);
        let reports = oa.iter().filter(|o| matches!(o, Output::Report(_))).count();
        assert!(reports >= 3, "{reports} reports");
        assert_eq!(oa, ob);
    }
}
