//! A test under way: each heading sample's step (safety, then the method's), the end of a
//! test (the report, the estimate and the decision, the analysis record), the outputs it
//! queues, and the driver's shutdown. Part of [`Monitor`]'s state machine (`mod.rs` starts a
//! test; this file runs and ends it).

use super::*;
use crate::fdi::Assessment;
use crate::wire::Estimate;

/// How a test ended, for its report: the outcome, the abort's reason, the features, the
/// message, and for a completed test the estimate and the FDI's assessment.
struct Ending {
    outcome: Outcome,
    reason: Option<String>,
    features: Features,
    message: String,
    estimate: Option<Estimate>,
    assessment: Option<Assessment>,
}

impl Monitor {
    /// One heading sample of a running test: safety, then the method's step.
    pub(super) fn step_run(
        &mut self,
        t: f64,
        heading_rad: f64,
        continuous_rad: f64,
        prev_heading_t: Option<f64>,
    ) {
        if let Err(reason) = self.safety_check(t, heading_rad, prev_heading_t) {
            self.finish(t, Err(reason));
            return;
        }
        let Some(run) = &mut self.run else { return };
        let error_rad = wrap_pi(run.target_rad - heading_rad);
        let step = match &mut run.kind {
            RunKind::Hbt(h) => h.on_heading(t, continuous_rad, error_rad),
            RunKind::Clfrt(c) => c.on_heading(t, continuous_rad, error_rad),
        };
        let (center, test) = match &run.kind {
            RunKind::Hbt(h) => (h.trim_rad(), run.id.clone()),
            RunKind::Clfrt(_) => (0.0, run.id.clone()),
        };
        if let Some(phase) = step.phase {
            if phase != run.phase {
                run.phase = phase;
                self.emit_status(t, phase, None);
            }
        }
        match step.done {
            Some(result) => self.finish(t, result),
            None => self.emit_gated(t, step.mode, step.value, center, Some(test)),
        }
    }

    /// Ends the test in progress at `t`: `Ok(features)` completed, `Err(reason)` aborted.
    /// Queues, in order: the excitation `none` for this sample (when `t` is a heading sample
    /// time), the report, and the idle status.
    pub(super) fn finish(&mut self, t: f64, result: Result<Measured, AbortReason>) {
        let Some(run) = self.run.take() else { return };
        self.last_test_end = Some(t);
        let most = self.cfg.scheduler.commissioning_interval_s;
        self.commissioning_gap_s = Some(self.work.test_ended(t - run.t_start, most));
        self.update_heading_guard(&run, &result);
        let ending = match result {
            Ok(f) => self.completed(&run, f),
            Err(reason) => self.aborted(&run, reason),
        };
        let Ending {
            outcome,
            reason,
            features,
            message,
            estimate,
            assessment,
        } = ending;
        // Stop the excitation first: at a heading sample, its excitation is `none`.
        if self.last_heading_t() == Some(t) && !self.excitation_sent_at(t) {
            self.emit_excitation(t, ExcitationMode::None, 0.0);
        }
        if self.analysis_output && outcome == Outcome::Completed {
            if let Some(a) = analysis_record(&run) {
                self.outputs.push_back(Output::Analysis(Box::new(a)));
            }
        }
        let report = Report {
            test: run.id.clone(),
            method: run.method,
            t_start: run.t_start,
            t_end: t,
            outcome,
            reason: reason.clone(),
            features,
            estimate,
            calibrated_estimate: assessment.as_ref().and_then(|a| a.calibrated_estimate),
            residuals: assessment
                .as_ref()
                .map_or_else(Default::default, |a| a.residuals.clone()),
            decision: assessment
                .as_ref()
                .map_or(Decision::Inconclusive, |a| a.decision),
            isolation: assessment
                .as_ref()
                .map_or_else(Vec::new, |a| a.isolation.clone()),
            message,
        };
        self.outputs.push_back(Output::Report(Box::new(report)));
        if let Some(n) = assessment.and_then(|a| a.notification) {
            tracing::warn!(vessel = %self.vessel, state = ?n.state, "{}", n.message);
            self.outputs.push_back(Output::Notification(n));
        }
        let status_reason = match outcome {
            Outcome::Completed => Some("completed".to_string()),
            Outcome::Aborted => reason.map(|r| format!("aborted: {r}")),
        };
        self.emit_status_for(t, MonitorState::Idle, None, None, status_reason);
    }

    /// The tones' heading guard: armed after a CLFRT test that ended on the heading limit,
    /// kept while the armed tests need it (`crate::monitor::sizing`).
    fn update_heading_guard(&mut self, run: &Run, result: &Result<Measured, AbortReason>) {
        if let RunKind::Clfrt(c) = &run.kind {
            self.clfrt_heading_guard = self.cfg.clfrt.resize_heading_fraction < 1.0
                && match result {
                    Ok(_) => c.heading_guarded(),
                    Err(AbortReason::HeadingError { .. }) => true,
                    Err(_) => self.clfrt_heading_guard,
                };
        }
    }

    /// A completed test: its features with the speed log's mean, the estimate and the FDI's
    /// assessment, the sea the next relay is sized for, and the report's message.
    fn completed(&mut self, run: &Run, f: Measured) -> Ending {
        self.stats.tests_completed += 1;
        let mut features = f.to_features();
        if run.speed_n > 0 {
            features.set_speed_log_mps(Some(run.speed_sum_mps / run.speed_n as f64));
        }
        let name = run.method.name().to_uppercase();
        let (est_text, estimate, a) = self.estimate_and_assess(run.method, &features);
        if let Some(w) = features
            .wave_yaw_rad()
            .filter(|w| w.is_finite() && *w >= 0.0)
        {
            self.sea_wave_yaw_rad = Some(w);
        }
        let mut msg = format!("{name} test completed; {est_text}; {}", a.summary);
        if let Some(scales) = features.clfrt().and_then(|c| c.amplitude_scales.as_ref()) {
            let pct: Vec<String> = scales
                .iter()
                .map(|s| format!("{:.0} %", 100.0 * s))
                .collect();
            msg.push_str(&format!(
                "; tones sized to the loop: {} of the design amplitude",
                pct.join(", ")
            ));
        }
        if let Some(scale) = features.hbt().and_then(|h| h.relay_scale) {
            let to = if scale > 1.0 { "sea" } else { "loop" };
            msg.push_str(&format!(
                "; relay sized to the {to}: {:.0} % of the design",
                100.0 * scale
            ));
        }
        Ending {
            outcome: Outcome::Completed,
            reason: None,
            features,
            message: msg,
            estimate,
            assessment: Some(a),
        }
    }

    /// The networks' estimate from a completed test's `features` (when an estimator is
    /// loaded and it reads them) and the FDI's assessment; with the message's sentence on the
    /// estimate.
    fn estimate_and_assess(
        &mut self,
        method: Method,
        features: &Features,
    ) -> (String, Option<Estimate>, Assessment) {
        let d_nom_t = self.nominal_displacement_t();
        match &mut self.estimator {
            None => (
                "no estimator loaded".to_string(),
                None,
                self.fdi.assess(method, features, None, d_nom_t),
            ),
            Some((est, scratch)) => match est.estimate(method, features, scratch) {
                Ok(e) => {
                    let a = self.fdi.assess(
                        method,
                        features,
                        Some((&e, est.as_ref(), scratch)),
                        d_nom_t,
                    );
                    let raw = format!(
                        "networks' estimate {:.2} m/s, {:.0} t",
                        e.speed_mps, e.displacement_t
                    );
                    let text = match &a.calibrated_estimate {
                        Some(c) => format!("{raw}, {}", c.sentence()),
                        None => format!("{raw} (raw: no vessel reference)"),
                    };
                    (text, Some(e), a)
                }
                Err(e) => (
                    format!("no estimate: {e}"),
                    None,
                    self.fdi.assess(method, features, None, d_nom_t),
                ),
            },
        }
    }

    /// An aborted test: counted by reason, logged, and the report's message.
    fn aborted(&mut self, run: &Run, reason: AbortReason) -> Ending {
        self.stats.tests_aborted += 1;
        self.stats.aborts.add(&reason);
        let reason = reason.to_string();
        tracing::warn!(vessel = %self.vessel, test = %run.id, "test aborted: {reason}");
        let msg = format!(
            "{} test aborted: {reason}",
            run.method.name().to_uppercase()
        );
        Ending {
            outcome: Outcome::Aborted,
            reason: Some(reason),
            features: Features::None,
            message: msg,
            estimate: None,
            assessment: None,
        }
    }

    pub(super) fn emit_excitation(&mut self, t: f64, mode: ExcitationMode, value: f64) {
        self.push_excitation(t, mode, value, None);
    }

    pub(super) fn push_excitation(
        &mut self,
        t: f64,
        mode: ExcitationMode,
        value: f64,
        test: Option<String>,
    ) {
        self.last_excitation = Some((t, mode, value));
        if self.analysis_output && test.is_some() {
            let cap = self.sent_capacity();
            if let Some(run) = &mut self.run {
                if run.sent.len() < cap {
                    run.sent.push((t, value));
                }
            }
        }
        self.outputs.push_back(Output::Excitation(Excitation {
            t,
            mode,
            value,
            hold_s: self.cfg.safety.hold_s,
            test,
        }));
    }

    pub(super) fn emit_status(&mut self, t: f64, state: MonitorState, reason: Option<String>) {
        let (test, method) = match &self.run {
            Some(r) => (Some(r.id.clone()), Some(r.method)),
            None => (None, None),
        };
        self.emit_status_for(t, state, test, method, reason);
    }

    pub(super) fn emit_status_for(
        &mut self,
        t: f64,
        state: MonitorState,
        test: Option<String>,
        method: Option<Method>,
        reason: Option<String>,
    ) {
        self.status = state;
        self.outputs.push_back(Output::Status(Status {
            t,
            state,
            test,
            method,
            reason,
        }));
    }
}

/// The analysis record of a run whose analysis completed.
fn analysis_record(run: &Run) -> Option<AnalysisRecord> {
    let (t0, dt, h, d, e) = match &run.kind {
        RunKind::Hbt(k) => {
            let (t0, dt, h, d) = k.analysis_series()?;
            let e = hold_on_grid(&run.sent, t0, dt, h.len());
            (t0, dt, h.to_vec(), d.to_vec(), e)
        }
        RunKind::Clfrt(k) => {
            let (t0, dt, [h, d, r]) = k.analysis_series()?;
            (t0, dt, h.to_vec(), d.to_vec(), r.to_vec())
        }
    };
    Some(AnalysisRecord {
        test: run.id.clone(),
        method: run.method,
        t0_s: t0,
        dt_s: dt,
        heading_rad: h,
        rudder_rad: d,
        excitation_rad: e,
    })
}

impl Monitor {
    /// The driver is stopping (daemon shutdown): stops any excitation and closes the books.
    ///
    /// Queues, in order: an excitation `none` at the last accepted heading's `t` (it supersedes
    /// what the autopilot holds, so it reverts at once instead of after `hold_s`); then, if a
    /// test is under way, its report (aborted with `reason`) and the idle status; otherwise an
    /// idle status with `reason`. Call it once, drain [`Monitor::poll_output`], publish.
    pub fn shutdown(&mut self, reason: &str) {
        let t_heading = self.last_heading_t();
        if let Some(t) = t_heading {
            self.push_excitation(t, ExcitationMode::None, 0.0, None);
        }
        let t = t_heading
            .or_else(|| {
                Stream::ALL
                    .into_iter()
                    .filter_map(|s| self.latest.t(s))
                    .reduce(f64::max)
            })
            .unwrap_or(0.0);
        if self.run.is_some() {
            self.finish(t, Err(AbortReason::Shutdown(reason.to_string())));
        } else {
            self.emit_status_for(t, MonitorState::Idle, None, None, Some(reason.to_string()));
        }
    }
}

/// The value held at each grid time `t0 + i dt` (`i < n`) from `(t, value)` steps in
/// increasing `t` (the first value before the first step; empty without steps).
fn hold_on_grid(steps: &[(f64, f64)], t0: f64, dt: f64, n: usize) -> Vec<f64> {
    if steps.is_empty() {
        return Vec::new();
    }
    let mut j = 0usize;
    (0..n)
        .map(|i| {
            let tg = t0 + i as f64 * dt;
            while j + 1 < steps.len() && steps[j + 1].0 <= tg + 1e-9 {
                j += 1;
            }
            steps[j].1
        })
        .collect()
}
