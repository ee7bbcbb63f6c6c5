//! A completed test's assessment, the four steps of [`Fdi::assess`] (see the module
//! documentation of `super`): the residual against the design, measured against the
//! vessel's normal, the decision and what the reference learns, the report.

use super::ablation::{self, Mechanism};
use super::measured::{self, Basis};
use super::raw::{self, sea_fraction, sea_index};
use super::reference::{self, Added};
use super::window::{self, measure_entry, method_index, Entry, Source};
use super::{decision, fit, isolation, report, stats, Assessment, Fdi};
use crate::estimator::{Estimator, EstimatorScratch};
use crate::wire::residuals::{
    CauseCosts, DecisionReport, RawResiduals, ReferenceKind, ReferenceReport, Residuals, TrackState,
};
use crate::wire::{Decision, Estimate, Features, Method};

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
    raw: Option<raw::NnRaw>,
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

impl Fdi {
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
        let source = residual.raw.map(|n| Source {
            raw: n.raw,
            directions: [n.log_direction(d_nom_t), n.displacement_dir],
            rudder: n.rudder_dir,
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
        let log = residual.raw.map(|n| window::LogReading {
            now_mps: n.raw.speed_log_mps,
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
                rudder: None,
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
            evidence.residual.raw.map(|n| n.raw),
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
            raw: raw.map(|n| raw_residuals(&n.raw, n.log_slope_t)),
            parameters,
            servo_check: servo,
            model_fit: fit.map(|f| f.report(&self.ship)),
            model_mismatch: fit.and_then(|f| report::mismatch(&f, self.cal.model_mismatch_chi2)),
            reference: basis.map(|b| self.reference_report(i, &b, d_nom_t)),
            decision: step.as_ref().map(|s| self.decision_report(s, state)),
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
        // The test read as its two causes, along the directions the isolation weighs them by.
        let reading = (evidence.measured.as_ref().zip(raw.as_ref()))
            .and_then(|((m, _), n)| report::cause_reading(m, n.cause_directions(d_nom_t)));
        Assessment {
            calibrated_estimate: report::calibrated_estimate(&residuals, reading),
            residuals,
            decision,
            isolation,
            summary,
            notification,
        }
    }

    /// The report's `decision` of the sequential test's `step`, in the vessel's `state` (an
    /// inconsistent commissioning holds it at alert).
    fn decision_report(&self, s: &decision::Step, state: TrackState) -> DecisionReport {
        DecisionReport {
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
                residual.raw.map_or(f64::NAN, |n| n.raw.speed_log_mps),
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

/// The report's `raw` residuals: `r` against the design, `g` = `dD_est / du_log` [t/(m/s)].
fn raw_residuals(r: &raw::Raw, g: f64) -> RawResiduals {
    RawResiduals {
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
    }
}
