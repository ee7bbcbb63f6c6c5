//! The networks' input vectors, read from a report's typed [`Features`] and named by stable
//! names (model files list their inputs by these names).
//!
//! ## Names and meaning
//!
//! | name | value | unit | method |
//! |---|---|---|---|
//! | `ln_gain_<k>` | `ln |G(j w_k)|`, tone k (1 = lowest) | ln(rad/rad) | CLFRT |
//! | `phase_<k>_rad` | `arg G(j w_k)`, in (-2 pi, 0] (dsp convention: no wrap near -180 deg) | rad | CLFRT |
//! | `ln_omega_u` | `ln (w_u / r_w)`, limit-cycle frequency of the designed relay (`r_w` = `relay_omega_ratio`, 1 when absent) | ln(rad/s) | HBT |
//! | `ln_amplitude` | `ln (a_u / r_A)`, first-harmonic heading amplitude of the designed relay (`r_A` = `relay_amplitude_ratio`, else `relay_scale`, else 1) | ln(rad) | HBT |
//! | `period_cv` | `period_std_s / period_s`, relative spread of the measured periods | 1 | HBT |
//! | `ln_response_gain` | `ln |G(j w_u)|`, heading over measured rudder, first harmonics | ln(rad/rad) | HBT |
//! | `response_phase_rad` | `arg G(j w_u)`, in (-2 pi, 0] | rad | HBT |
//! | `speed_log_mps` | mean speed-log reading over the test (report field `speed_log_mps`) | m/s | both |
//!
//! Why these (the ship `G(s) = b / (s (s + a))`, `a = a0 u / l`, `b = 0.5 (u/l)^2 A l / V`,
//! docs/architecture.md "The model and its units"): the phase `-pi/2 - atan(w/a)` carries
//! `a`, hence speed, most where `w ~ a` (0.008 .. 0.021 rad/s); the gain
//! `b / (w sqrt(w^2 + a^2))` tends to `b / w^2` at the upper tones, and `b` given the speed
//! carries displacement. Logarithms turn the power laws into sums, which a small tanh
//! network fits with less curvature. For HBT the period follows `a` (speed) and the
//! amplitude `b / a^2` (displacement); but the sea moves the relay's switching instants,
//! which shifts the period and the amplitude (a calm-sea test read by a network that cannot
//! tell the sea state was 0.14 m/s slow on average), and spreads the periods: `period_cv`
//! tells the network how rough the test was (calm-sea speed MSE 0.0045 -> 0.0025 with it).
//! The response `G(j w_u)`, heading over the measured rudder at the limit-cycle frequency,
//! reads the ship itself, whatever the switching did: its phase `-pi/2 - atan(w_u/a)`
//! carries `a` and its gain `b`. With it the HBT speed error in a moderate sea halves
//! (docs/estimator.md).
//!
//! A relay sized down by `s` (h and eps both, [`crate::monitor`]'s sizing) gives the
//! same cycle at the same frequency with its amplitude times `s` (the describing function
//! depends on `h / A` and `eps / A` only), except where the servo's rate limit acts: a
//! smaller step slews for less of the period, so the cycle is a little faster and smaller.
//! The report carries the describing function's ratios of the two cycles on the fitted ship
//! (`relay_omega_ratio`, `relay_amplitude_ratio`, `(1, s)` by homogeneity) and the inputs
//! read the designed relay's cycle through them, so the networks trained on the designed
//! relay read a sized test alike. `period_cv` and the response `G(j w_u)` (a ratio) are
//! read as measured.
//!
//! The speed network sees the test's features only; the displacement network sees them and
//! the measured speed (`speed_log_mps`): speed from the features alone is poorly conditioned,
//! displacement given speed is well conditioned (the gain gives `b`, which fixes `V` only
//! once `u` is known; docs/estimator.md, "Features").

use crate::wire::{Features, Method};
use std::fmt;

/// A feature name that is unknown, or a report that lacks a feature.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FeatureError {
    /// The name is not one of the documented feature names.
    #[error("unknown feature name `{0}`")]
    UnknownName(String),
    /// The feature does not belong to this method's reports.
    #[error("feature `{name}` is not a {method} feature")]
    WrongMethod {
        /// The feature name.
        name: String,
        /// The method asked for.
        method: &'static str,
    },
    /// The report has no such value (missing field, missing tone).
    #[error("report features lack `{0}`")]
    Missing(String),
    /// The value is NaN, infinite, or not positive where a logarithm is taken.
    #[error("report feature `{name}` = {value} is not usable")]
    Unusable {
        /// The feature name.
        name: String,
        /// The offending value.
        value: f64,
    },
}

/// One input of a network.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Feature {
    /// `ln_gain_<k>`: log gain of tone k (1-based, lowest first).
    LnGain(usize),
    /// `phase_<k>_rad`: phase of tone k [rad].
    Phase(usize),
    /// `ln_omega_u`: log limit-cycle frequency.
    LnOmegaU,
    /// `ln_amplitude`: log limit-cycle amplitude.
    LnAmplitude,
    /// `speed_log_mps`: mean speed-log reading over the test [m/s].
    SpeedLog,
    /// `period_cv`: relative spread of the limit-cycle periods, `period_std_s / period_s`.
    PeriodCv,
    /// `ln_response_gain`: log gain of heading over the measured rudder at `w_u`.
    LnResponseGain,
    /// `response_phase_rad`: phase of heading over the measured rudder at `w_u` [rad].
    ResponsePhase,
}

impl fmt::Display for Feature {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Feature::LnGain(k) => write!(f, "ln_gain_{k}"),
            Feature::Phase(k) => write!(f, "phase_{k}_rad"),
            Feature::LnOmegaU => f.write_str("ln_omega_u"),
            Feature::LnAmplitude => f.write_str("ln_amplitude"),
            Feature::SpeedLog => f.write_str("speed_log_mps"),
            Feature::PeriodCv => f.write_str("period_cv"),
            Feature::LnResponseGain => f.write_str("ln_response_gain"),
            Feature::ResponsePhase => f.write_str("response_phase_rad"),
        }
    }
}

impl std::str::FromStr for Feature {
    type Err = FeatureError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let tone = |t: &str| t.parse::<usize>().ok().filter(|&k| (1..=64).contains(&k));
        let unknown = || FeatureError::UnknownName(s.to_string());
        match s {
            "ln_omega_u" => Ok(Feature::LnOmegaU),
            "ln_amplitude" => Ok(Feature::LnAmplitude),
            "speed_log_mps" => Ok(Feature::SpeedLog),
            "period_cv" => Ok(Feature::PeriodCv),
            "ln_response_gain" => Ok(Feature::LnResponseGain),
            "response_phase_rad" => Ok(Feature::ResponsePhase),
            _ => {
                if let Some(k) = s.strip_prefix("ln_gain_") {
                    tone(k).map(Feature::LnGain).ok_or_else(unknown)
                } else if let Some(k) = s
                    .strip_prefix("phase_")
                    .and_then(|r| r.strip_suffix("_rad"))
                {
                    tone(k).map(Feature::Phase).ok_or_else(unknown)
                } else {
                    Err(unknown())
                }
            }
        }
    }
}

/// The report field holding the mean speed-log reading over the test [m/s].
pub const SPEED_LOG_FIELD: &str = "speed_log_mps";

impl Feature {
    /// Whether the feature exists in reports of `method`.
    pub fn belongs_to(&self, method: Method) -> bool {
        match self {
            Feature::LnGain(_) | Feature::Phase(_) => method == Method::Clfrt,
            Feature::LnOmegaU
            | Feature::LnAmplitude
            | Feature::PeriodCv
            | Feature::LnResponseGain
            | Feature::ResponsePhase => method == Method::Hbt,
            Feature::SpeedLog => true,
        }
    }

    /// Reads the feature from a report's `features`. A value the report lacks, or that is not
    /// finite (the wire would carry it as `null`), is missing; a logarithm of a value that is
    /// not positive is unusable.
    pub fn value(&self, features: &Features) -> Result<f64, FeatureError> {
        let missing = || FeatureError::Missing(self.to_string());
        let known = |x: Option<f64>| x.filter(|v| v.is_finite()).ok_or_else(missing);
        let tone = |k: usize| {
            features
                .clfrt()
                .and_then(|c| c.tones.get(k.wrapping_sub(1)))
        };
        let hbt = features.hbt();
        let (raw, log) = match *self {
            Feature::LnGain(k) => (known(tone(k).map(|t| t.gain))?, true),
            Feature::Phase(k) => (known(tone(k).map(|t| t.phase_rad))?, false),
            Feature::LnOmegaU => (
                known(hbt.map(|h| h.omega_u_rad_s / h.relay_omega_ratio.unwrap_or(1.0)))?,
                true,
            ),
            Feature::LnAmplitude => (
                known(hbt.map(|h| {
                    let r = h.relay_amplitude_ratio.or(h.relay_scale).unwrap_or(1.0);
                    h.amplitude_rad / r
                }))?,
                true,
            ),
            Feature::SpeedLog => (known(features.speed_log_mps())?, false),
            Feature::LnResponseGain => (known(hbt.and_then(|h| h.response_gain))?, true),
            Feature::ResponsePhase => (known(hbt.and_then(|h| h.response_phase_rad))?, false),
            Feature::PeriodCv => {
                let p = known(hbt.map(|h| h.period_s))?;
                let sd = known(hbt.map(|h| h.period_std_s))?;
                (sd / p, false)
            }
        };
        let v = if log {
            if raw > 0.0 {
                raw.ln()
            } else {
                f64::NAN
            }
        } else {
            raw
        };
        if v.is_finite() {
            Ok(v)
        } else {
            Err(FeatureError::Unusable {
                name: self.to_string(),
                value: raw,
            })
        }
    }
}

/// Parses names, checking each belongs to `method`.
pub fn parse_names(method: Method, names: &[String]) -> Result<Vec<Feature>, FeatureError> {
    names
        .iter()
        .map(|n| {
            let f: Feature = n.parse()?;
            if f.belongs_to(method) {
                Ok(f)
            } else {
                Err(FeatureError::WrongMethod {
                    name: n.clone(),
                    method: method.name(),
                })
            }
        })
        .collect()
}

/// The inputs of the speed network of `method`, for a CLFRT design with `n_tones` tones:
/// CLFRT `ln_gain_k, phase_k_rad` for each tone; HBT `ln_omega_u, ln_amplitude, period_cv,
/// ln_response_gain, response_phase_rad`.
pub fn speed_inputs(method: Method, n_tones: usize) -> Vec<Feature> {
    match method {
        Method::Clfrt => (1..=n_tones)
            .flat_map(|k| [Feature::LnGain(k), Feature::Phase(k)])
            .collect(),
        Method::Hbt => vec![
            Feature::LnOmegaU,
            Feature::LnAmplitude,
            Feature::PeriodCv,
            Feature::LnResponseGain,
            Feature::ResponsePhase,
        ],
    }
}

/// The inputs of the displacement network: the speed network's, then `speed_log_mps`.
pub fn displacement_inputs(method: Method, n_tones: usize) -> Vec<Feature> {
    let mut v = speed_inputs(method, n_tones);
    v.push(Feature::SpeedLog);
    v
}

/// Fills `out` with the values of `inputs` read from `features` (cleared first; reuses its
/// allocation).
pub fn extract_into(
    inputs: &[Feature],
    features: &Features,
    out: &mut Vec<f64>,
) -> Result<(), FeatureError> {
    out.clear();
    for f in inputs {
        out.push(f.value(features)?);
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::sample;
    use crate::wire::features::HbtFeatures;

    fn clfrt() -> Features {
        let mut c = sample::clfrt(vec![
            sample::tone(0.02, 2.0, -2.0),
            sample::tone(0.05, 0.5, -2.8),
        ]);
        c.speed_log_mps = Some(7.01);
        Features::Clfrt(c)
    }

    #[test]
    fn names_round_trip() {
        for f in [
            Feature::LnGain(1),
            Feature::Phase(3),
            Feature::LnOmegaU,
            Feature::LnAmplitude,
            Feature::SpeedLog,
            Feature::PeriodCv,
            Feature::LnResponseGain,
            Feature::ResponsePhase,
        ] {
            assert_eq!(f.to_string().parse::<Feature>().unwrap(), f);
        }
        for bad in [
            "ln_gain_0",
            "ln_gain_x",
            "phase_2",
            "gain_1",
            "",
            "ln_gain_65",
        ] {
            assert!(bad.parse::<Feature>().is_err(), "{bad}");
        }
    }

    #[test]
    fn clfrt_values_are_read_by_name() {
        let inputs = displacement_inputs(Method::Clfrt, 2);
        let names: Vec<String> = inputs.iter().map(|f| f.to_string()).collect();
        assert_eq!(
            names,
            [
                "ln_gain_1",
                "phase_1_rad",
                "ln_gain_2",
                "phase_2_rad",
                "speed_log_mps"
            ]
        );
        let mut out = Vec::new();
        extract_into(&inputs, &clfrt(), &mut out).unwrap();
        assert_eq!(out, vec![2.0f64.ln(), -2.0, 0.5f64.ln(), -2.8, 7.01]);
    }

    #[test]
    fn hbt_values_are_read_by_name() {
        let mut h = sample::hbt();
        h.omega_u_rad_s = 0.035;
        h.amplitude_rad = 0.05;
        h.period_s = 180.0;
        h.period_std_s = 3.6;
        h.response_gain = Some(0.9);
        h.response_phase_rad = Some(-2.8);
        h.speed_log_mps = Some(7.0);
        let f = Features::Hbt(h);
        let mut out = Vec::new();
        extract_into(&displacement_inputs(Method::Hbt, 0), &f, &mut out).unwrap();
        assert_eq!(
            out,
            vec![
                0.035f64.ln(),
                0.05f64.ln(),
                3.6 / 180.0,
                0.9f64.ln(),
                -2.8,
                7.0
            ]
        );
    }

    /// A relay played at half size: the cycle is half as large at the same frequency, and
    /// the inputs are those of the designed relay's test.
    #[test]
    fn a_sized_relay_reads_as_the_designed_one() {
        let mut full = sample::hbt();
        full.response_gain = Some(0.9);
        full.response_phase_rad = Some(-2.8);
        let half = HbtFeatures {
            amplitude_rad: 0.5 * full.amplitude_rad,
            relay_height_rad: 0.5 * full.relay_height_rad,
            hysteresis_rad: 0.5 * full.hysteresis_rad,
            relay_scale: Some(0.5),
            ..full.clone()
        };
        // Where the rate limit acts: 4 % faster, 10 % smaller than homogeneity says.
        let fast = HbtFeatures {
            omega_u_rad_s: 1.04 * full.omega_u_rad_s,
            amplitude_rad: 0.45 * full.amplitude_rad,
            relay_omega_ratio: Some(1.04),
            relay_amplitude_ratio: Some(0.45),
            ..half.clone()
        };
        let inputs = speed_inputs(Method::Hbt, 0);
        let read = |f: HbtFeatures| {
            let mut v = Vec::new();
            extract_into(&inputs, &Features::Hbt(f), &mut v).unwrap();
            v
        };
        let a = read(full);
        assert_eq!(a, read(half));
        for (x, y) in a.iter().zip(read(fast)) {
            assert!((x - y).abs() < 1e-12, "{x} vs {y}");
        }
    }

    #[test]
    fn missing_or_unusable_values_are_errors() {
        let mut out = Vec::new();
        let e = extract_into(&speed_inputs(Method::Clfrt, 3), &clfrt(), &mut out).unwrap_err();
        assert_eq!(e, FeatureError::Missing("ln_gain_3".into()));
        let bad = Features::Clfrt(sample::clfrt(vec![sample::tone(0.02, 0.0, -2.0)]));
        assert!(matches!(
            Feature::LnGain(1).value(&bad),
            Err(FeatureError::Unusable { .. })
        ));
        let e = extract_into(&[Feature::SpeedLog], &Features::None, &mut out).unwrap_err();
        assert_eq!(e, FeatureError::Missing("speed_log_mps".into()));
    }

    #[test]
    fn method_membership_is_checked() {
        assert!(parse_names(Method::Hbt, &["ln_gain_1".to_string()]).is_err());
        assert!(parse_names(Method::Clfrt, &["ln_omega_u".to_string()]).is_err());
        assert_eq!(
            parse_names(Method::Hbt, &["speed_log_mps".to_string()]).unwrap(),
            vec![Feature::SpeedLog]
        );
    }
}
