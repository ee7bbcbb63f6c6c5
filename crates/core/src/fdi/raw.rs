//! A completed test's raw residuals against the design: the networks' estimate minus the
//! speed log and the declared displacement, with the design spreads at the test's sea
//! (interpolated between the model files' calm and moderate figures by the sea index), and
//! the servo check (docs/fdi.md, "Residuals").
//!
//! **The displacement's direction**: how `(e_u [m/s], e_D [fraction], e_b [ln])` move when the
//! ship's true displacement does, the declared one fixed. On the Nomoto class `D` enters `b`
//! alone (`b ~ 1 / D`), so the test's own features with `b` 1 % smaller, read through the
//! networks, give it at the test's point. On a hull whose yaw inertia and damping move with
//! `D` (an MMG hull: a lighter ship also has a larger `a`), that is not what a change of `D`
//! does: `train` measures the class's direction instead (the same seeded test at `D`
//! `+-10 %`, common random numbers, through the networks; per method and sea) and writes it
//! into `calibration.json`; where it is, it is used, interpolated by the sea index between
//! its calm and moderate figures, and a declared loading's slope follows it. The rudder's
//! effectiveness is not a separate cause: on every hull it scales `b` alone.
//!
//! **The speed's slope**: how they move per m/s when the ship itself goes faster. The
//! similarity law (`sensitivity::scale_speed`: every time constant scales with `l / u`) read
//! through the networks gives it at the test's point; exact on the Nomoto class. On an MMG
//! hull the law does not hold, and the class's own networks read the class's speed changes
//! near unbiased whatever the law says: `train` measures, per component, the class's slope
//! (the same seeded test at the point's speed `+-1 m/s`) and its scatter over the class's
//! points about each of the two centres, and keeps the class's slope where its scatter is
//! smaller than the law's by more than twice its standard error (`calibration.json`'s
//! `speed-slope`, interpolated by the sea index like the
//! displacement's). The scatter about the centre kept is the prior sd of the offset's slope
//! in speed (`slope-speed`, `slope-speed-gain`; `envelope`).

use super::ablation::{self, Mechanism};
use super::fit::CI90_TO_SIGMA;
use super::sensitivity;
use super::stats::{Cov, P};
use crate::estimator::model::{Target, Uncertainty};
use crate::estimator::{Estimator, EstimatorScratch};
use crate::wire::residuals::ServoCheck;
use crate::wire::{Estimate, Features, Method};
use serde::{Deserialize, Serialize};

/// Speed step of the central difference for `dD/du_log` [m/s].
const DU_MPS: f64 = 0.05;

/// Relative step of `b` for the displacement's direction (`sensitivity`).
const DB_REL: f64 = 0.01;

/// Speed step of the similarity law's central difference for the offset's slope [m/s].
const DU_SIMILAR_MPS: f64 = 0.25;

/// Step in `ln D` of the declared loading's central difference for the offset's slope.
const DL_SIMILAR: f64 = 0.05;

/// The central difference `(hi - lo) / step` of a residual, per component 0 where either end
/// is missing or it is not finite.
fn central(hi: Option<[f64; P]>, lo: Option<[f64; P]>, step: f64) -> [f64; P] {
    match (hi, lo) {
        (Some(hi), Some(lo)) => std::array::from_fn(|j| {
            let v = (hi[j] - lo[j]) / step;
            if v.is_finite() {
                v
            } else {
                0.0
            }
        }),
        _ => [0.0; P],
    }
}

/// `e_b` of `features`, NaN without.
fn gain_of(features: &Features) -> f64 {
    sensitivity::ln_gain(features).unwrap_or(f64::NAN)
}

/// The sea index of a test's features: its wave yaw [deg], if it has one.
pub fn sea_index(features: &Features) -> Option<f64> {
    features
        .wave_yaw_rad()
        .map(f64::to_degrees)
        .filter(|x| x.is_finite() && *x >= 0.0)
}

/// Where `index` sits between the calm (0) and moderate (1) anchors, clamped to [0, 3].
pub(super) fn sea_fraction(anchors: [f64; 2], index: Option<f64>) -> f64 {
    match index {
        None => 1.0,
        Some(i) => ((i - anchors[0]) / (anchors[1] - anchors[0])).clamp(0.0, 3.0),
    }
}

/// Interpolates a `[calm, moderate]` pair at `frac`.
pub(super) fn lerp(pair: [f64; 2], frac: f64) -> f64 {
    pair[0] + frac * (pair[1] - pair[0])
}

/// `(bias, spread)` of a model's residuals at sea fraction `frac`; relative to `reference`
/// when given and the model file records relative spreads.
pub(super) fn spread(u: &Uncertainty, frac: f64, reference: Option<f64>) -> (f64, f64) {
    use crate::model::SeaState;
    let of = |s: SeaState| u.by_sea.iter().find(|b| b.sea == s);
    let pick =
        |mean: [f64; 2], sd: [f64; 2]| (lerp(mean, frac.min(1.0)), lerp(sd, frac).max(sd[0]));
    match (of(SeaState::Calm), of(SeaState::Moderate)) {
        (Some(c), Some(m)) => match (reference, c.relative_std, m.relative_std) {
            (Some(y), Some(rc), Some(rm)) => {
                let means = [
                    c.relative_mean.unwrap_or(0.0),
                    m.relative_mean.unwrap_or(0.0),
                ];
                let (bm, bs) = pick(means, [rc, rm]);
                (bm * y, bs * y)
            }
            _ => pick(
                [c.residual_mean, m.residual_mean],
                [c.residual_std, m.residual_std],
            ),
        },
        _ => (u.residual_mean, u.residual_std),
    }
}

// A test's own measurement error. Model: each CLFRT tone's `ln |G|` and `arg G` carry an
// error of standard deviation `gain_ci90_rel / 1.645` and `phase_ci90_rad / 1.645` (their
// 90 % intervals, `crate::dsp::tones`), independent between tones and between gain and
// phase. The residual `(e_u [m/s], e_D [fraction of D_nom], e_b [ln])` is a smooth function
// of them (the networks and `sensitivity::ln_gain`), so to first order its covariance from
// the test's own tones is `sum_i d_i d_i^T`, `d_i` the residual's central difference over
// `+- 1 sd` of input `i`. An HBT test carries no per-test interval of its cycle's amplitude
// or response: `None`.

/// The residual of `features` as the networks read it (`e_u` against `u_log`).
pub(super) fn read_residual(
    method: Method,
    features: &Features,
    est: &Estimator,
    scratch: &mut EstimatorScratch,
    u_log: f64,
    d_nom_t: f64,
) -> Option<[f64; P]> {
    let e = est.estimate(method, features, scratch).ok()?;
    let g = sensitivity::ln_gain(features).unwrap_or(0.0);
    let r = [e.speed_mps - u_log, e.displacement_t / d_nom_t, g];
    r.iter().all(|x| x.is_finite()).then_some(r)
}

/// The residual's covariance from the test's own tone intervals (see the module doc);
/// `None` for an HBT test or where the features do not say.
pub fn measurement_cov(
    method: Method,
    features: &Features,
    est: &Estimator,
    scratch: &mut EstimatorScratch,
    d_nom_t: f64,
) -> Option<Cov> {
    let c = features.clfrt()?;
    let u_log = features.speed_log_mps().filter(|u| u.is_finite())?;
    let mut cov = [[0.0; P]; P];
    for (k, t) in c.tones.iter().enumerate() {
        let sg = t.gain_ci90_rel * CI90_TO_SIGMA;
        let sp = t.phase_ci90_rad * CI90_TO_SIGMA;
        if !(sg.is_finite() && sp.is_finite() && sg >= 0.0 && sp >= 0.0) {
            return None;
        }
        for (which, s) in [(0, sg), (1, sp)] {
            if s == 0.0 {
                continue;
            }
            let mut at = |sign: f64| -> Option<[f64; P]> {
                let mut f = c.clone();
                let tk = &mut f.tones[k];
                if which == 0 {
                    tk.gain *= (sign * s).exp();
                } else {
                    tk.phase_rad += sign * s;
                }
                read_residual(method, &Features::Clfrt(f), est, scratch, u_log, d_nom_t)
            };
            let (hi, lo) = (at(1.0)?, at(-1.0)?);
            let d: [f64; P] = std::array::from_fn(|j| 0.5 * (hi[j] - lo[j]));
            for (i, row) in cov.iter_mut().enumerate() {
                for (j, v) in row.iter_mut().enumerate() {
                    *v += d[i] * d[j];
                }
            }
        }
    }
    Some(Cov(cov)).filter(Cov::is_finite)
}

/// The class's measured displacement direction at sea fraction `frac` (clamped to the
/// measured seas, calm to moderate), per unit of `ln D` (module doc); `None` where the model
/// files carry none, or with the mechanism off.
fn class_direction(est: &Estimator, method: Method, frac: f64) -> Option<[f64; P]> {
    let pair = est
        .calibration()
        .displacement_direction
        .filter(|_| !ablation::off(Mechanism::ClassDirection))?
        .of(method);
    let at = frac.clamp(0.0, 1.0);
    Some(std::array::from_fn(|j| lerp([pair[0][j], pair[1][j]], at)))
}

/// The class's measured slope per m/s of the ship's speed at sea fraction `frac`, per
/// component where the model files carry one (else `None`: the similarity law's), none with
/// the mechanism off.
fn class_speed_slope(est: &Estimator, method: Method, frac: f64) -> [Option<f64>; P] {
    let Some(s) = est
        .calibration()
        .speed_slope
        .filter(|_| !ablation::off(Mechanism::ClassDirection))
    else {
        return [None; P];
    };
    let at = frac.clamp(0.0, 1.0);
    s.of(method).map(|pair| pair.map(|p| lerp(p, at)))
}

/// The neural estimator's raw residuals against the design for a completed test, with
/// `dD_est / du_log` and the displacement's and the rudder's directions ([`NnRaw`]).
#[allow(clippy::too_many_arguments)]
pub fn nn_raw(
    method: Method,
    features: &Features,
    estimate: &Estimate,
    d_nom_t: f64,
    est: &Estimator,
    scratch: &mut EstimatorScratch,
    frac: f64,
    slopes: Option<sensitivity::ResponseSlopes>,
) -> Option<NnRaw> {
    let u_log = features.speed_log_mps().filter(|u| u.is_finite())?;
    let (mu, su) = spread(
        &est.model(method, Target::Speed).file.uncertainty,
        frac,
        None,
    );
    let (md, sd) = spread(
        &est.model(method, Target::Displacement).file.uncertainty,
        frac,
        Some(d_nom_t),
    );
    let mut at = |u: f64| -> Option<f64> {
        est.predict_at_speed_log(method, Target::Displacement, features, u, scratch)
            .ok()
    };
    let no_slopes = ablation::off(Mechanism::NetworkSlopes);
    let g = if no_slopes {
        0.0
    } else {
        (at(u_log + DU_MPS)? - at(u_log - DU_MPS)?) / (2.0 * DU_MPS)
    };
    let ln_gain = sensitivity::ln_gain(features).filter(|_| !ablation::off(Mechanism::GainChannel));
    // The displacement's direction (module doc): the class's, measured; else through the
    // networks and the gain, the same test on a ship with b 1 % smaller (`sensitivity`);
    // (0, 1, 0.01) when the features cannot say.
    let mut b_dir = || {
        sensitivity::scale_b_at(features, 1.0 - DB_REL, slopes)
            .filter(|_| !no_slopes)
            .and_then(|f| Some((est.estimate(method, &f, scratch).ok()?, gain_of(&f))))
            .map(|(e, g)| {
                let gain = g - ln_gain.unwrap_or(f64::NAN);
                [
                    e.speed_mps - estimate.speed_mps,
                    (e.displacement_t - estimate.displacement_t) / d_nom_t,
                    if gain.is_finite() { gain } else { 0.0 },
                ]
            })
            .filter(|v| v[..2].iter().all(|x| x.is_finite()) && v[1].abs() > 0.0)
    };
    // With the class's, the `b` scaling's is the rudder effectiveness's (the isolation's
    // other model of the same cause).
    let class = class_direction(est, method, frac);
    let (d_dir, rudder_dir) = match class {
        Some(d) => (d.map(|x| DB_REL * x), b_dir()),
        None => (b_dir().unwrap_or([0.0, 1.0, DB_REL]), None),
    };
    // How the residual moves when the ship itself goes faster (`sensitivity::scale_speed`),
    // per m/s: the networks read the same ship's features at the other speed.
    let mut similar = |u: f64| -> Option<[f64; P]> {
        let f = sensitivity::scale_speed(features, u)?;
        let e = est.estimate(method, &f, scratch).ok()?;
        Some([e.speed_mps - u, e.displacement_t / d_nom_t, gain_of(&f)])
    };
    let (u_hi, u_lo) = (
        u_log + DU_SIMILAR_MPS,
        (u_log - DU_SIMILAR_MPS).max(0.5 * u_log),
    );
    let speed_slope = if no_slopes {
        [0.0; P]
    } else {
        let law = central(similar(u_hi), similar(u_lo), u_hi - u_lo);
        let class = class_speed_slope(est, method, frac);
        std::array::from_fn(|j| class[j].unwrap_or(law[j]))
    };
    // How it moves per unit of ln D when the ship is declared and is `D` heavier: as the
    // true displacement's direction, the residual taken against the new declared
    // displacement (`e_D` less `D_est / D_nom`); without the class's, `b` scales by `1 / D`
    // (`sensitivity::scale_b`).
    let mut loaded = |dl: f64| -> Option<[f64; P]> {
        let f = sensitivity::scale_b_at(features, (-dl).exp(), slopes)?;
        let e = est.estimate(method, &f, scratch).ok()?;
        Some([
            e.speed_mps,
            e.displacement_t / (d_nom_t * dl.exp()),
            gain_of(&f),
        ])
    };
    let loading_slope = match class {
        _ if no_slopes => [0.0; P],
        Some(c) => [c[0], c[1] - estimate.displacement_t / d_nom_t, c[2]],
        None => central(loaded(DL_SIMILAR), loaded(-DL_SIMILAR), 2.0 * DL_SIMILAR),
    };
    let raw = Raw {
        speed_slope,
        loading_slope,
        speed_mps: estimate.speed_mps - u_log - mu,
        displacement: (estimate.displacement_t - d_nom_t - md) / d_nom_t,
        speed_sigma_mps: su,
        displacement_sigma: sd / d_nom_t,
        speed_log_mps: u_log,
        displacement_declared_t: d_nom_t,
        excitation_scale: features.excitation_scale(),
        sea_index: sea_index(features),
        ln_gain,
        ln_damping: sensitivity::ln_damping(features).map(|a| a - u_log.ln()),
        meas: measurement_cov(method, features, est, scratch, d_nom_t),
        log_slope: g / d_nom_t,
    };
    let ok = [raw.speed_mps, raw.displacement, g]
        .iter()
        .all(|x| x.is_finite())
        && raw.speed_sigma_mps > 0.0
        && raw.displacement_sigma > 0.0;
    ok.then_some(NnRaw {
        raw,
        log_slope_t: g,
        displacement_dir: d_dir,
        rudder_dir,
    })
}

/// A test's raw residuals and its cause directions, before whitening ([`nn_raw`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NnRaw {
    /// The raw residuals.
    pub raw: Raw,
    /// `dD_est / du_log` [t per m/s].
    pub log_slope_t: f64,
    /// How they move per 1 % of the true displacement (module doc).
    pub displacement_dir: [f64; P],
    /// How they move per 1 % less `b` (the rudder's effectiveness) where that differs from
    /// the displacement's (the class's measured one in force); `None`: the same.
    pub rudder_dir: Option<[f64; P]>,
}

impl NnRaw {
    /// How the residuals move per m/s of speed-log bias: `[-1, dD_est/du_log / D_nom, 0]`
    /// (`e_u` is the estimate less the log, and the displacement's network reads the log).
    pub fn log_direction(&self, d_nom_t: f64) -> [f64; P] {
        [-1.0, self.log_slope_t / d_nom_t, 0.0]
    }

    /// How the residuals move per m/s of speed-log bias and per unit fraction of the true
    /// displacement: [`Self::log_direction`] and the displacement's direction over its 1 %
    /// step.
    pub fn cause_directions(&self, d_nom_t: f64) -> [[f64; P]; 2] {
        [
            self.log_direction(d_nom_t),
            self.displacement_dir.map(|x| x / DB_REL),
        ]
    }
}

/// The servo check of a test: `rho` and `z_rate` with `sigma` the healthy rate ratio's
/// spread (`calibration.actuator-rate-sigma`).
pub fn servo_check(features: &Features, sigma: f64) -> Option<ServoCheck> {
    let (rate, nominal) = features.servo_rate_rad_s()?;
    if !rate.is_finite() || !nominal.is_finite() || nominal <= 0.0 {
        return None;
    }
    let rho = rate / nominal;
    Some(ServoCheck {
        rate_ratio: rho,
        z_rate: ((1.0 - rho) / sigma).max(0.0),
    })
}

/// One test's raw residuals against the design (see the module doc).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Raw {
    /// `e_u` [m/s].
    pub speed_mps: f64,
    /// `e_D` [fraction of D_nom].
    pub displacement: f64,
    /// Design spread of the speed at this test's sea [m/s].
    pub speed_sigma_mps: f64,
    /// Design spread of the displacement [fraction].
    pub displacement_sigma: f64,
    /// Speed log over the test [m/s].
    pub speed_log_mps: f64,
    /// The declared (nominal) displacement in force [t].
    pub displacement_declared_t: f64,
    /// The excitation's scale against its design (`Features::excitation_scale`).
    pub excitation_scale: f64,
    /// The test's sea index [deg] (`sea_index`; `None`: the features do not say).
    #[serde(default)]
    pub sea_index: Option<f64>,
    /// `e_b`: the ln of the test's own high-frequency gain
    /// (`crate::fdi::sensitivity::ln_gain`; `None`: the features do not say).
    #[serde(default)]
    pub ln_gain: Option<f64>,
    /// `e_a = ln(a^ / u_log)`: the test's own yaw damping over the speed log
    /// (`crate::fdi::sensitivity::ln_damping`; `None`: the features do not say)
    /// [ln 1/m]. The similarity law makes it the same at every speed; a speed-log bias
    /// `beta` moves it by `-beta / u`. Reported, not decided on (docs/fdi.md, "Residuals").
    #[serde(default)]
    pub ln_damping: Option<f64>,
    /// How `(e_u, e_D, e_b)` move per m/s of the ship's own speed by the similarity law
    /// (`crate::fdi::sensitivity::scale_speed`) [(m/s, fraction, ln) per m/s].
    pub speed_slope: [f64; P],
    /// How they move per unit of `ln D` of a declared change of loading: the class's
    /// displacement direction less the declaration, or without it `b` scaling by `1 / D`
    /// (`crate::fdi::sensitivity::scale_b`) [(m/s, fraction, ln) per unit ln D].
    pub loading_slope: [f64; P],
    /// The residual's covariance from the test's own tone intervals
    /// (`crate::fdi::raw::measurement_cov`, physical units; `None`: HBT, or the
    /// features do not say).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub meas: Option<Cov>,
    /// How `e_D` moves per m/s of a speed-log bias: `dD_est / du_log / D_nom` [fraction per
    /// m/s] (0 in a state saved before it was kept).
    #[serde(default)]
    pub log_slope: f64,
}

impl Raw {
    /// `(e_u, e_D, e_b)`, `e_b` NaN when the test has none.
    pub fn e(&self) -> [f64; P] {
        [
            self.speed_mps,
            self.displacement,
            self.ln_gain.unwrap_or(f64::NAN),
        ]
    }

    /// The design spreads: `e_b`'s is the displacement's (`b` scales with `1 / D`: the
    /// same relative units; the shape learns the ratio).
    pub fn s(&self) -> [f64; P] {
        [
            self.speed_sigma_mps,
            self.displacement_sigma,
            self.displacement_sigma,
        ]
    }

    /// The residual's dimension: 3 with `e_b`, else 2.
    pub fn dim(&self) -> usize {
        if self.ln_gain.is_some_and(f64::is_finite) {
            P
        } else {
            2
        }
    }
}
