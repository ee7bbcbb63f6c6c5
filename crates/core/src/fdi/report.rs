//! What the FDI tells people: the report's message, the notification, the baseline's
//! comparison, the model-mismatch warning, and the fingerprint a reference was made under.

use super::fit::ModelFit;
use super::limits::DecisionLimits;
use super::measured::Measured;
use super::raw::lerp;
use super::stats::{dot, normal_isf, P};
use crate::baseline::config::BaselineConfig;
use crate::model::ShipConfig;
use crate::monitor::config::CoreConfig;
use crate::wire::residuals::{
    BaselineReport, ModelMismatch, ParameterResiduals, ReferenceKind, Residuals, TrackState,
};
use crate::wire::{
    AlarmState, CalibratedEstimate, Cause, Decision, Features, Method, Notification,
};
use serde::{Deserialize, Serialize};
use serde_json::Value;

/// What a `model_mismatch` warning tells the operator.
pub const MISMATCH_ADVICE: &str = "the ship's response is not the trained model's (a higher-order hull, a dead band or an autopilot of its own): this is no fault of the ship; decisions rest on the vessel's commissioned reference, so commission it on a healthy ship (`helmwatch commission`), and train models for this class (`helmwatch train --family`) if it persists";

/// The version of the decision's model: a reference made under another is discarded (its
/// covariance means something else; 4: the excitation's scale is a coordinate of the
/// operating point, unknown in older samples; 5: each learned test carries its physical
/// slopes in speed and loading, the slope priors' means).
const DECISION_MODEL: u32 = 6;

/// The `model_mismatch` warning of a fit, if its chi-square is over `threshold`.
pub fn mismatch(fit: &ModelFit, threshold: f64) -> Option<ModelMismatch> {
    (fit.chi2.is_finite() && fit.chi2 > threshold).then(|| ModelMismatch {
        chi2: fit.chi2,
        threshold,
        advice: MISMATCH_ADVICE.to_string(),
    })
}

/// The equation-error baseline's residuals against the design and its one-test decision
/// at the sequential test's single-test limit (comparison only).
pub fn baseline(
    cfg: &BaselineConfig,
    ship: &ShipConfig,
    limits: &DecisionLimits,
    method: Method,
    features: &Features,
    d_nom_t: f64,
    frac: f64,
) -> BaselineReport {
    let parameters = (|| {
        let u_log = features.speed_log_mps().filter(|u| u.is_finite())?;
        let bl = features.baseline()?;
        let (a, b) = (bl.a_per_s, bl.b_per_s2);
        if !(a > 0.0 && b > 0.0 && u_log > 0.0) {
            return None;
        }
        let u_est = crate::model::speed_from_a(a, ship);
        let d_est = crate::model::displacement_from_b(b, u_log, ship);
        let (su, sd) = cfg.sigmas(method);
        let (su, sd) = (lerp(su, frac).max(su[0]), lerp(sd, frac).max(sd[0]));
        let (ru, rd) = (u_est - u_log, d_est - d_nom_t);
        let p = ParameterResiduals {
            speed_mps: ru,
            speed_sigma_mps: su,
            z_speed: ru / su,
            displacement_t: rd,
            displacement_sigma_t: sd,
            z_displacement: rd / sd,
            ln_gain: None,
            ln_gain_sigma: None,
            z_ln_gain: None,
            correlation: 0.0,
            chi2: (ru / su).powi(2) + (rd / sd).powi(2),
            dof: 2,
            noise_ratio: None,
        };
        // The log's direction: D from b grows as u_log^2.
        let g = 2.0 * d_est / u_log;
        p.chi2.is_finite().then_some((p, g))
    })();
    let Some((p, g)) = parameters else {
        return BaselineReport {
            parameters: None,
            outcome: Decision::Inconclusive,
            isolation: Vec::new(),
        };
    };
    let fault = p.chi2 > limits.param[2];
    let isolation = if fault {
        // Distance of z to each cause's line, as `isolation` does for one test.
        let z = [p.z_speed, p.z_displacement];
        let off = |v: [f64; 2]| {
            let n2 = v[0] * v[0] + v[1] * v[1];
            let along = v[0] * z[0] + v[1] * z[1];
            p.chi2 - along * along / n2
        };
        let log = off([-1.0 / p.speed_sigma_mps, g / p.displacement_sigma_t]);
        let disp = off([0.0, 1.0]);
        vec![if log < disp {
            Cause::SpeedLog
        } else {
            Cause::DisplacementOrRudderEffectiveness
        }]
    } else {
        Vec::new()
    };
    BaselineReport {
        parameters: Some(p),
        outcome: if fault {
            Decision::Fault
        } else {
            Decision::Nominal
        },
        isolation,
    }
}

/// The report's sentence.
pub fn summary(
    enabled: bool,
    r: &Residuals,
    state: TrackState,
    isolation: &[Cause],
    commissioning: Option<String>,
) -> String {
    if !enabled {
        return "FDI disabled, no decision".into();
    }
    let mut parts = Vec::new();
    if let Some(p) = &r.parameters {
        parts.push(format!(
            "chi2 {:.1} (speed {:+.2} m/s, displacement {:+.0} t against the reference)",
            p.chi2, p.speed_mps, p.displacement_t
        ));
    }
    if let Some(s) = &r.servo_check {
        parts.push(format!("servo check z {:.1}", s.z_rate));
    }
    if parts.is_empty() {
        return "no residuals (no estimate, speed log or servo check), no decision".into();
    }
    let look = r.decision.as_ref().and_then(|d| {
        let best = [d.parameters, d.servo]
            .into_iter()
            .flatten()
            .max_by(|a, b| (a.statistic / a.threshold).total_cmp(&(b.statistic / b.threshold)))?;
        Some(format!(
            "window of {} test(s): {:.1} against {:.1}",
            best.window, best.statistic, best.threshold
        ))
    });
    let causes = if isolation.is_empty() {
        String::new()
    } else {
        let names: Vec<&str> = isolation.iter().map(|c| c.name()).collect();
        let open: Vec<&str> = r
            .decision
            .as_ref()
            .map(|d| d.not_ruled_out.iter().map(|c| c.name()).collect())
            .unwrap_or_default();
        if open.is_empty() {
            format!("; suspected: {}", names.join(", "))
        } else {
            format!(
                "; suspected: {} ({} not yet ruled out)",
                names.join(", "),
                open.join(", ")
            )
        }
    };
    let head = match state {
        TrackState::Normal => "nominal",
        TrackState::Alert => "alert",
        TrackState::Alarm => "FAULT",
    };
    let mut out = format!("{head}, {}", parts.join(", "));
    if let Some(l) = look {
        out.push_str(&format!("; {l}"));
    }
    out.push_str(&causes);
    if let Some(c) = commissioning {
        out.push_str(&format!("; {c}"));
    }
    if let Some(m) = &r.model_mismatch {
        out.push_str(&format!(
            "; model_mismatch: model-fit chi2 {:.0} > {:.0}: {}",
            m.chi2, m.threshold, m.advice
        ));
    }
    out
}

/// The Signal K notification for a new alarm state.
pub fn notification(now: AlarmState, method: Method, summary: &str) -> Notification {
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
}

/// What a commissioning reference was made under: the ship's particulars, servo and test
/// designs (relay, periods measured, multisine; the nominal values excluded: a reference
/// survives a new loading), the decision model's version, and the models' checksums. A
/// saved reference made under another is discarded on restore.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Fingerprint {
    /// `{ship, servo, hbt, clfrt, fdi}` as configured.
    pub config: Value,
    /// The models' checksums (`None`: no estimator).
    pub models: Option<String>,
}

/// The configuration a reference depends on.
#[derive(Serialize)]
struct Designs<'a> {
    ship: Value,
    servo: &'a crate::model::ServoConfig,
    hbt: HbtDesign,
    clfrt: ClfrtDesign<'a>,
    fdi: FdiModel,
}

#[derive(Serialize)]
#[serde(rename_all = "kebab-case")]
struct HbtDesign {
    relay_height_deg: f64,
    hysteresis_deg: f64,
    measure_periods: u32,
}

#[derive(Serialize)]
#[serde(rename_all = "kebab-case")]
struct ClfrtDesign<'a> {
    window_s: f64,
    harmonics: &'a [u32],
    amplitude_deg: f64,
}

#[derive(Serialize)]
#[serde(rename_all = "kebab-case")]
struct FdiModel {
    decision_model: u32,
}

impl Fingerprint {
    /// The configuration part for `cfg`.
    pub fn of(cfg: &CoreConfig) -> Self {
        let mut ship = serde_json::to_value(&cfg.ship).unwrap_or(Value::Null);
        if let Some(o) = ship.as_object_mut() {
            o.remove("nominal-speed-mps");
            o.remove("nominal-displacement-t");
        }
        let designs = Designs {
            ship,
            servo: &cfg.servo,
            hbt: HbtDesign {
                relay_height_deg: cfg.hbt.relay_height_deg,
                hysteresis_deg: cfg.hbt.hysteresis_deg,
                measure_periods: cfg.hbt.measure_periods,
            },
            clfrt: ClfrtDesign {
                window_s: cfg.clfrt.window_s,
                harmonics: &cfg.clfrt.harmonics,
                amplitude_deg: cfg.clfrt.amplitude_deg,
            },
            fdi: FdiModel {
                decision_model: DECISION_MODEL,
            },
        };
        Self {
            config: serde_json::to_value(designs).unwrap_or(Value::Null),
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

/// The report's parameter residuals of a measured test (`z` its whitened residual).
pub(super) fn parameter_report(m: &Measured, z: [f64; P], d_nom_t: f64) -> ParameterResiduals {
    let sd = m.cov.variances().map(f64::sqrt);
    let with_gain = m.dim > 2;
    ParameterResiduals {
        speed_mps: m.r[0],
        speed_sigma_mps: sd[0],
        z_speed: m.r[0] / sd[0],
        displacement_t: m.r[1] * d_nom_t,
        displacement_sigma_t: sd[1] * d_nom_t,
        z_displacement: m.r[1] / sd[1],
        ln_gain: with_gain.then_some(m.r[2]),
        ln_gain_sigma: with_gain.then_some(sd[2]),
        z_ln_gain: with_gain.then_some(m.r[2] / sd[2]),
        correlation: m.cov.correlation(0, 1),
        chi2: dot(z, z),
        dof: m.dim,
        noise_ratio: (m.noise_ratio > 1.0).then_some(m.noise_ratio),
    }
}

/// A test's residual read as its two parameter causes ([`cause_reading`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct CauseReading {
    /// `(b, g)`: the speed-log bias [m/s] and the displacement change [fraction of `D_nom`].
    pub value: [f64; 2],
    /// Their covariance.
    pub cov: [[f64; 2]; 2],
}

/// A measured residual `m` read as its two parameter causes at once
/// (`crate::wire::CalibratedEstimate` states the model): a speed-log bias [m/s] along
/// `directions[0]` and a displacement change [fraction of `D_nom`] along `directions[1]`
/// (`NnRaw::cause_directions`), by generalised least squares over the measured components:
///
/// ```text
/// V = [v_log v_D]  (their first `dim` components),  cov = (V' Sigma^-1 V)^-1,
/// value = cov V' Sigma^-1 r
/// ```
///
/// `None` where `Sigma` is not positive definite or the two directions cannot be told apart.
pub(super) fn cause_reading(m: &Measured, directions: [[f64; P]; 2]) -> Option<CauseReading> {
    let keep =
        |v: [f64; P]| -> [f64; P] { std::array::from_fn(|j| if j < m.dim { v[j] } else { 0.0 }) };
    let v = directions.map(keep);
    let r = keep(m.r);
    let w = [m.cov.solve(v[0])?, m.cov.solve(v[1])?];
    let a = [
        [dot(v[0], w[0]), dot(v[0], w[1])],
        [dot(v[1], w[0]), dot(v[1], w[1])],
    ];
    let det = a[0][0] * a[1][1] - a[0][1] * a[1][0];
    // Told apart: the two directions' whitened angle is not within about 0.1 deg.
    if !(det.is_finite() && det > 1e-6 * a[0][0] * a[1][1]) {
        return None;
    }
    let cov = [
        [a[1][1] / det, -a[0][1] / det],
        [-a[1][0] / det, a[0][0] / det],
    ];
    let y = [dot(w[0], r), dot(w[1], r)];
    let value = [
        cov[0][0] * y[0] + cov[0][1] * y[1],
        cov[1][0] * y[0] + cov[1][1] * y[1],
    ];
    (value
        .iter()
        .chain(cov.iter().flatten())
        .all(|x| x.is_finite()))
    .then_some(CauseReading { value, cov })
}

/// The report's `calibrated_estimate` from its `residuals` and the test's `reading` of its
/// two causes (`crate::wire::CalibratedEstimate` states the model): the speed from the
/// reading (without one, the speed component alone), the displacement from its component,
/// which is the displacement network's reading given the log. `None` without a speed log,
/// parameter residuals or the vessel's own reference.
pub(super) fn calibrated_estimate(
    r: &Residuals,
    reading: Option<CauseReading>,
) -> Option<CalibratedEstimate> {
    let reference = r.reference.as_ref()?.kind;
    if !matches!(
        reference,
        ReferenceKind::Commissioned | ReferenceKind::Predicted
    ) {
        return None;
    }
    let p = r.parameters.as_ref()?;
    let u_log = r.raw.as_ref()?.speed_log_mps;
    let d_nom = r.displacement_nominal_t?;
    let (u, su) = match reading {
        Some(c) => (u_log - c.value[0], c.cov[0][0].sqrt()),
        None => (u_log + p.speed_mps, p.speed_sigma_mps),
    };
    let (d, sd) = (d_nom + p.displacement_t, p.displacement_sigma_t);
    let z = normal_isf(0.025);
    let interval = |x: f64, sd: f64| [x - z * sd, x + z * sd];
    let c = CalibratedEstimate {
        speed_mps: u,
        speed_interval_mps: interval(u, su),
        displacement_t: d,
        displacement_interval_t: interval(d, sd),
        reference,
    };
    (c.speed_interval_mps.iter())
        .chain(&c.displacement_interval_t)
        .all(|x| x.is_finite())
        .then_some(c)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fdi::stats::Cov;
    use nalgebra::{Matrix2, Matrix3, Matrix3x2, Vector2, Vector3};
    use rand::SeedableRng;
    use rand_distr::{Distribution, StandardNormal};

    /// A residual of covariance `cov` (correlated, as a vessel's are), all three measured.
    fn measured(r: [f64; P], cov: [[f64; P]; P], dim: usize) -> Measured {
        Measured {
            r,
            cov: Cov(cov),
            offset_var: Some(0.0),
            dof: f64::INFINITY,
            learned: Cov(cov),
            dim,
            bounded: false,
            noise_ratio: 1.0,
        }
    }

    const SIGMA: [[f64; P]; P] = [
        [0.04, 0.002, -0.001],
        [0.002, 0.0004, -0.0002],
        [-0.001, -0.0002, 0.0009],
    ];
    /// A log bias moves `e_u` by -1 and `e_D` by the networks' slope; a displacement change
    /// moves `e_D` by about 1 and the gain by about -1 (`b ~ 1 / D`).
    const DIRS: [[f64; P]; 2] = [[-1.0, 0.08, 0.0], [-0.02, 0.97, -1.05]];

    /// The generalised least squares of nalgebra's own inverse: `(V' S^-1 V)^-1 V' S^-1 r`.
    fn by_nalgebra(r: [f64; P]) -> (Vector2<f64>, Matrix2<f64>) {
        let s = Matrix3::from_fn(|i, j| SIGMA[i][j]);
        let v = Matrix3x2::from_fn(|i, j| DIRS[j][i]);
        let si = s.try_inverse().unwrap();
        let cov = (v.transpose() * si * v).try_inverse().unwrap();
        (cov * v.transpose() * si * Vector3::from(r), cov)
    }

    /// Against an independent answer: a residual made of the two causes alone is read back
    /// exactly, any residual as nalgebra's inverse reads it, with its covariance.
    #[test]
    fn the_cause_reading_is_the_generalised_least_squares() {
        let (b, g) = (0.4, -0.12);
        let pure: [f64; P] = std::array::from_fn(|j| b * DIRS[0][j] + g * DIRS[1][j]);
        let c = cause_reading(&measured(pure, SIGMA, 3), DIRS).unwrap();
        assert!(
            (c.value[0] - b).abs() < 1e-12 && (c.value[1] - g).abs() < 1e-12,
            "{c:?}"
        );
        let r = [0.3, -0.05, 0.02];
        let c = cause_reading(&measured(r, SIGMA, 3), DIRS).unwrap();
        let (value, cov) = by_nalgebra(r);
        for i in 0..2 {
            assert!(
                (c.value[i] - value[i]).abs() < 1e-12 * value[i].abs().max(1.0),
                "{c:?}"
            );
            for j in 0..2 {
                assert!(
                    (c.cov[i][j] - cov[(i, j)]).abs() < 1e-9 * cov[(i, i)],
                    "{c:?} {cov}"
                );
            }
        }
    }

    /// With two components measured the third is not read, whatever it holds; two
    /// directions that are one cannot be told apart.
    #[test]
    fn the_cause_reading_reads_the_measured_components_only() {
        let r = [0.3, -0.05, 0.0];
        let two = cause_reading(&measured(r, SIGMA, 2), DIRS).unwrap();
        let junk = cause_reading(&measured([0.3, -0.05, 7.0], SIGMA, 2), DIRS).unwrap();
        assert_eq!(two, junk);
        // Two equations in two unknowns: the exact solution of the 2 x 2 system.
        let m = Matrix2::new(DIRS[0][0], DIRS[1][0], DIRS[0][1], DIRS[1][1]);
        let want = m.try_inverse().unwrap() * Vector2::new(r[0], r[1]);
        assert!((two.value[0] - want[0]).abs() < 1e-12 && (two.value[1] - want[1]).abs() < 1e-12);
        let same = [DIRS[0], DIRS[0].map(|x| 2.0 * x)];
        assert_eq!(cause_reading(&measured(r, SIGMA, 3), same), None);
    }

    /// Monte Carlo of healthy residuals: the reading is unbiased, its spread is the stated
    /// covariance, and its speed is read closer than the speed component alone (`e_u`'s
    /// sd), which ignores what `e_D` and the gain say. 20 000 draws: a variance's relative
    /// standard error is sqrt(2 / 20 000) = 1 %, so +-5 % is five of them.
    #[test]
    fn the_cause_reading_has_its_stated_spread_and_beats_one_component() {
        let l = Matrix3::from_fn(|i, j| SIGMA[i][j]).cholesky().unwrap().l();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let n = 20_000;
        let (mut sum, mut sq) = ([0.0; 2], [0.0; 2]);
        let mut stated = [[0.0; 2]; 2];
        for _ in 0..n {
            let e = Vector3::from_fn(|_, _| StandardNormal.sample(&mut rng));
            let r: [f64; P] = (l * e).into();
            let c = cause_reading(&measured(r, SIGMA, 3), DIRS).unwrap();
            stated = c.cov;
            for i in 0..2 {
                sum[i] += c.value[i];
                sq[i] += c.value[i] * c.value[i];
            }
        }
        for i in 0..2 {
            let mean = sum[i] / n as f64;
            let var = sq[i] / n as f64 - mean * mean;
            assert!(
                mean.abs() < 4.0 * (stated[i][i] / n as f64).sqrt(),
                "{i}: mean {mean}"
            );
            let ratio = var / stated[i][i];
            assert!(
                (0.95..1.05).contains(&ratio),
                "{i}: {var} against {}",
                stated[i][i]
            );
        }
        assert!(stated[0][0] < SIGMA[0][0], "{stated:?}");
    }
}
