//! The CLFRT model-fit parity check: the Nomoto model fitted to the measured tones.
//!
//! Model: `G(jw) = b / (jw (jw + a))`, so `ln|G| = ln b - ln w - ln|jw + a|` and
//! `arg G = -pi/2 - atan(w / a)`. Unknowns `x = (ln a, ln b)`; per tone two residuals
//! (`ln` gain and phase) weighted by the tone's own 90 % interval (`ci / 1.645`, floored by
//! `calibration.model-fit-floor-ln-gain` and `calibration.model-fit-floor-phase-deg`). Gauss-Newton from the
//! phase-only estimate of `a`; `chi2 = sum (e / s)^2` with `2 n - 2` degrees of freedom.

use crate::angle::wrap_pi;
use crate::fdi::config::Calibration;
use crate::model::ShipConfig;
use crate::wire::residuals::ModelFitReport;
use crate::wire::Features;
use std::f64::consts::FRAC_PI_2;

/// Two-sided 90 % interval to one standard deviation.
pub(super) const CI90_TO_SIGMA: f64 = 1.0 / 1.645;

/// The fitted model and how well it explains the tones.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ModelFit {
    /// Fitted a [1/s].
    pub a_per_s: f64,
    /// Fitted b [1/s^2].
    pub b_per_s2: f64,
    /// Weighted residual sum of squares.
    pub chi2: f64,
    /// Degrees of freedom (2 per tone, minus 2).
    pub dof: usize,
}

impl ModelFit {
    /// The report's `residuals.model_fit`, with the (u, D) the fit implies.
    pub fn report(self, ship: &ShipConfig) -> ModelFitReport {
        let u = crate::model::speed_from_a(self.a_per_s, ship);
        ModelFitReport {
            chi2: self.chi2,
            dof: self.dof,
            a_per_s: self.a_per_s,
            b_per_s2: self.b_per_s2,
            speed_mps: u,
            displacement_t: crate::model::displacement_from_b(self.b_per_s2, u, ship),
        }
    }
}

struct Tone {
    w: f64,
    ln_g: f64,
    phase: f64,
    s_g: f64,
    s_p: f64,
}

fn tones(features: &Features, cfg: &Calibration) -> Option<Vec<Tone>> {
    let floor_p = cfg.model_fit_floor_phase_deg.to_radians();
    let finite = |x: f64| x.is_finite().then_some(x);
    features
        .clfrt()?
        .tones
        .iter()
        .map(|t| {
            let gain = finite(t.gain)?;
            (gain > 0.0).then_some(())?;
            Some(Tone {
                w: finite(t.omega_rad_s)?,
                ln_g: gain.ln(),
                phase: finite(t.phase_rad)?,
                s_g: (finite(t.gain_ci90_rel)? * CI90_TO_SIGMA).max(cfg.model_fit_floor_ln_gain),
                s_p: (finite(t.phase_ci90_rad)? * CI90_TO_SIGMA).max(floor_p),
            })
        })
        .collect()
}

/// Weighted residuals at `(ln a, ln b)` and their Jacobian rows.
fn residuals(t: &[Tone], x: [f64; 2], e: &mut Vec<f64>, j: &mut Vec<[f64; 2]>) {
    e.clear();
    j.clear();
    let a = x[0].exp();
    for k in t {
        let m2 = k.w * k.w + a * a;
        let model_g = x[1] - k.w.ln() - 0.5 * m2.ln();
        let model_p = -FRAC_PI_2 - (k.w / a).atan();
        e.push((k.ln_g - model_g) / k.s_g);
        // d(-model)/dx: the residual's derivative.
        j.push([(a * a / m2) / k.s_g, -1.0 / k.s_g]);
        e.push(wrap_pi(k.phase - model_p) / k.s_p);
        j.push([-(k.w * a / m2) / k.s_p, 0.0]);
    }
}

/// Fits the Nomoto model to the CLFRT tones of `features`; `None` without usable tones.
pub fn model_fit(features: &Features, _ship: &ShipConfig, cfg: &Calibration) -> Option<ModelFit> {
    let t = tones(features, cfg)?;
    if t.len() < 2 {
        return None;
    }
    // Start: a from the phases (arg G = -pi/2 - atan(w/a)), b from the gains given a.
    let mut a_sum = 0.0;
    let mut n = 0.0;
    for k in &t {
        let lag = -(k.phase + FRAC_PI_2);
        if lag > 0.0 && lag < FRAC_PI_2 {
            a_sum += (k.w / lag.tan()).ln();
            n += 1.0;
        }
    }
    let ln_a = if n > 0.0 { a_sum / n } else { (0.01f64).ln() };
    let a = ln_a.exp();
    let ln_b = t
        .iter()
        .map(|k| k.ln_g + k.w.ln() + 0.5 * (k.w * k.w + a * a).ln())
        .sum::<f64>()
        / t.len() as f64;
    let mut x = [ln_a, ln_b];
    let (mut e, mut j) = (Vec::new(), Vec::new());
    for _ in 0..30 {
        residuals(&t, x, &mut e, &mut j);
        // Normal equations of a 2-parameter problem: J^T J dx = -J^T e.
        let (mut h00, mut h01, mut h11, mut g0, mut g1) = (0.0, 0.0, 0.0, 0.0, 0.0);
        for (r, jr) in e.iter().zip(&j) {
            h00 += jr[0] * jr[0];
            h01 += jr[0] * jr[1];
            h11 += jr[1] * jr[1];
            g0 += jr[0] * r;
            g1 += jr[1] * r;
        }
        let det = h00 * h11 - h01 * h01;
        if det.abs() < 1e-300 || !det.is_finite() {
            return None;
        }
        let dx0 = -(h11 * g0 - h01 * g1) / det;
        let dx1 = -(-h01 * g0 + h00 * g1) / det;
        // Keep steps moderate (a must stay positive: ln a moves at most 0.5 per step).
        let s = (0.5 / dx0.abs().max(1e-300)).min(1.0);
        x = [x[0] + s * dx0, x[1] + s * dx1];
        if dx0.abs() < 1e-10 && dx1.abs() < 1e-10 {
            break;
        }
    }
    residuals(&t, x, &mut e, &mut j);
    let chi2: f64 = e.iter().map(|r| r * r).sum();
    chi2.is_finite().then_some(ModelFit {
        a_per_s: x[0].exp(),
        b_per_s2: x[1].exp(),
        chi2,
        dof: 2 * t.len() - 2,
    })
}
