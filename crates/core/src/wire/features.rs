//! A report's `features`: what a completed test measured, typed.
//!
//! The monitor builds them ([`crate::monitor`]), the estimator reads its inputs from
//! them ([`crate::estimator::features`]), the FDI its sea index, servo rate, tones and
//! baseline ([`crate::fdi`]), and tools and tests read them by field, never by string.
//! On the wire they are the JSON object docs/contract.md documents: the keys of every object
//! come out in alphabetical order (the order the project has always published), fields marked
//! "absent" below are left out when unknown, fields marked "null" are `null`.
//!
//! Units are in the names: rad, s, rad/s, m/s, t; gains are heading over rudder [rad/rad].

use serde::{Deserialize, Serialize};

/// The `features` of a report, by method; an aborted test has none (`{}`).
#[derive(Debug, Clone, PartialEq, Default)]
pub enum Features {
    /// A multisine test's.
    Clfrt(ClfrtFeatures),
    /// A relay test's.
    Hbt(HbtFeatures),
    /// An aborted test's: `{}`.
    #[default]
    None,
}

impl Serialize for Features {
    /// Through a JSON value, whose maps keep their keys sorted: the bytes the contract's
    /// readers have always seen.
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let v = match self {
            Features::Clfrt(f) => serde_json::to_value(f),
            Features::Hbt(f) => serde_json::to_value(f),
            Features::None => Ok(serde_json::Value::Object(Default::default())),
        }
        .map_err(serde::ser::Error::custom)?;
        v.serialize(s)
    }
}

impl<'de> Deserialize<'de> for Features {
    /// `{}` is an aborted test's; an object with `tones` a CLFRT test's; one with
    /// `period_s` an HBT test's.
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        use serde::de::Error;
        let v = serde_json::Value::deserialize(d)?;
        let obj = v
            .as_object()
            .ok_or_else(|| D::Error::custom("features must be an object"))?;
        if obj.is_empty() {
            Ok(Features::None)
        } else if obj.contains_key("tones") {
            serde_json::from_value(v)
                .map(Features::Clfrt)
                .map_err(D::Error::custom)
        } else if obj.contains_key("period_s") {
            serde_json::from_value(v)
                .map(Features::Hbt)
                .map_err(D::Error::custom)
        } else {
            Err(D::Error::custom(
                "features hold neither `tones` (CLFRT) nor `period_s` (HBT)",
            ))
        }
    }
}

impl Features {
    /// The CLFRT features, if these are.
    pub fn clfrt(&self) -> Option<&ClfrtFeatures> {
        match self {
            Features::Clfrt(f) => Some(f),
            _ => None,
        }
    }

    /// The HBT features, if these are.
    pub fn hbt(&self) -> Option<&HbtFeatures> {
        match self {
            Features::Hbt(f) => Some(f),
            _ => None,
        }
    }

    /// The excitation's scale against its design: HBT's relay scale, the geometric mean of
    /// CLFRT's tone scales; 1 when the test played as designed (or was aborted).
    pub fn excitation_scale(&self) -> f64 {
        let s = match self {
            Features::Hbt(f) => f.relay_scale.unwrap_or(1.0),
            Features::Clfrt(f) => f.amplitude_scales.as_ref().map_or(1.0, |v| {
                let logs: Vec<f64> = v.iter().filter(|x| **x > 0.0).map(|x| x.ln()).collect();
                if logs.is_empty() {
                    1.0
                } else {
                    (logs.iter().sum::<f64>() / logs.len() as f64).exp()
                }
            }),
            Features::None => 1.0,
        };
        if s.is_finite() && s > 0.0 {
            s
        } else {
            1.0
        }
    }

    /// Mean speed-log reading over the test [m/s] (none for an aborted test or without a
    /// speed log).
    pub fn speed_log_mps(&self) -> Option<f64> {
        match self {
            Features::Clfrt(f) => f.speed_log_mps,
            Features::Hbt(f) => f.speed_log_mps,
            Features::None => None,
        }
    }

    /// Sets the mean speed-log reading over the test [m/s] (no effect on an aborted test).
    pub fn set_speed_log_mps(&mut self, speed_mps: Option<f64>) {
        match self {
            Features::Clfrt(f) => f.speed_log_mps = speed_mps,
            Features::Hbt(f) => f.speed_log_mps = speed_mps,
            Features::None => {}
        }
    }

    /// Wave yaw: rms of the heading in `calibration.wave-band-rad-s` over the measurement [rad].
    pub fn wave_yaw_rad(&self) -> Option<f64> {
        match self {
            Features::Clfrt(f) => f.wave_yaw_rad,
            Features::Hbt(f) => f.wave_yaw_rad,
            Features::None => None,
        }
    }

    /// The time-domain baseline, when it could be fitted.
    pub fn baseline(&self) -> Option<&BaselineFeatures> {
        match self {
            Features::Clfrt(f) => f.baseline.as_ref(),
            Features::Hbt(f) => f.baseline.as_ref(),
            Features::None => None,
        }
    }

    /// The servo's measured rudder rate against the healthy servo's `(measured, nominal)`
    /// [rad/s]: CLFRT the servo check's 95th percentile, HBT the median of the periods' peaks.
    pub fn servo_rate_rad_s(&self) -> Option<(f64, f64)> {
        match self {
            Features::Clfrt(f) => {
                let sc = f.servo_check.as_ref()?;
                Some((sc.rudder_rate_p95_rad_s?, sc.rudder_rate_nominal_rad_s?))
            }
            Features::Hbt(f) => f
                .servo_rate
                .as_ref()
                .map(|s| (s.rudder_rate_peak_rad_s, s.rudder_rate_nominal_rad_s)),
            Features::None => None,
        }
    }
}

/// The time-domain baseline (`features.baseline`, docs/baseline.md): equation-error least
/// squares of `s^2 F psi = -a s F psi + b F delta + c` and the ship it reads.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BaselineFeatures {
    /// Yaw damping a [1/s].
    pub a_per_s: f64,
    /// Rudder gain b [1/s^2].
    pub b_per_s2: f64,
    /// Intercept c (a constant yaw moment or a drifting gyro's rate) [rad/s^2].
    pub c_rad_s2: f64,
    /// Standard deviation of a [1/s].
    pub a_std_per_s: f64,
    /// Standard deviation of b [1/s^2].
    pub b_std_per_s2: f64,
    /// Correlation of the a and b estimates.
    pub ab_correlation: f64,
    /// Residual standard deviation [rad/s^2].
    pub residual_std_rad_s2: f64,
    /// Condition number of the normal equations.
    pub condition: f64,
    /// Samples fitted.
    pub n: usize,
    /// Filter bandwidth lambda [rad/s].
    pub filter_rad_s: f64,
    /// Speed read from a [m/s].
    pub speed_mps: f64,
    /// Displacement read from b at that speed [t].
    pub displacement_t: f64,
}

/// One excited tone of a CLFRT test (`features.tones[k]`, lowest first): the frequency
/// response at the tone with its uncertainty, as the tone analysis
/// (`crate::dsp::tones`) estimates it.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ToneFeatures {
    /// Tone frequency [rad/s].
    pub omega_rad_s: f64,
    /// |G| heading over rudder [rad/rad].
    pub gain: f64,
    /// arg G [rad], in (-2 pi, 0].
    pub phase_rad: f64,
    /// Signal / (signal + noise) of the heading at the tone, in [0, 1].
    pub coherence: f64,
    /// Signal-to-noise ratio of the heading at the tone [dB], clamped to [-120, 300].
    pub snr_db: f64,
    /// Half-width of the 90 % interval of the gain, relative to `gain`.
    pub gain_ci90_rel: f64,
    /// Half-width of the 90 % interval of the phase [rad], at most pi.
    pub phase_ci90_rad: f64,
}

/// The CLFRT servo check (`features.servo_check`): a sinusoid played before the multisine
/// and the rudder's response to it. The measured fields are absent when it failed, and
/// `failed` says why.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ServoCheckFeatures {
    /// Frequency played [rad/s].
    pub omega_rad_s: f64,
    /// Amplitude played [rad].
    pub amplitude_rad: f64,
    /// Full-amplitude periods measured.
    pub periods: u32,
    /// `ln |T|`, T the rudder over the excitation at the check's frequency.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ln_gain: Option<f64>,
    /// `arg T` [rad].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub phase_rad: Option<f64>,
    /// `ln |T| - ln |T_0|`, T_0 the nominal servo.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ln_gain_error: Option<f64>,
    /// `arg T - arg T_0` [rad].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub phase_error_rad: Option<f64>,
    /// Third harmonic of the rudder over its first (absent above Nyquist).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub harmonic3_ratio: Option<f64>,
    /// Rms of the rudder after removing the line and the tone [rad].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub residual_rms_rad: Option<f64>,
    /// 95th percentile of the rudder rate over the measured periods [rad/s].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rudder_rate_p95_rad_s: Option<f64>,
    /// The same for the nominal servo, linear, undisturbed [rad/s].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rudder_rate_nominal_rad_s: Option<f64>,
    /// `ln |Delta / E|`, the plain closed-loop ratio.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ratio_ln_gain: Option<f64>,
    /// `arg (Delta / E)` [rad].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ratio_phase_rad: Option<f64>,
    /// Why the check could not be measured (absent when it was).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub failed: Option<String>,
}

/// A CLFRT test's features.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ClfrtFeatures {
    /// The tones, lowest first.
    pub tones: Vec<ToneFeatures>,
    /// Window length T_w [s].
    pub window_s: f64,
    /// Windows measured.
    pub windows: u32,
    /// Tone amplitude [rad].
    pub amplitude_rad: f64,
    /// Crest factor of the multisine.
    pub crest_factor: f64,
    /// The servo check (absent when disabled).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub servo_check: Option<ServoCheckFeatures>,
    /// Wave yaw over the measured windows [rad] (null when it could not be computed).
    pub wave_yaw_rad: Option<f64>,
    /// Per tone (lowest first), the scale of its amplitude against `amplitude_rad` when the
    /// test lowered tones the loop amplified, to keep the rudder off its limit (absent when
    /// every tone played at the design amplitude).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub amplitude_scales: Option<Vec<f64>>,
    /// Mean speed-log reading over the test [m/s] (absent without speed samples).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub speed_log_mps: Option<f64>,
    /// The time-domain baseline (null when it failed).
    pub baseline: Option<BaselineFeatures>,
    /// Why the baseline failed (absent when it did not).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub baseline_error: Option<String>,
}

/// The HBT servo slew check (`features.servo_rate`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ServoRateFeatures {
    /// Median over the measured periods of each period's largest rudder rate [rad/s].
    pub rudder_rate_peak_rad_s: f64,
    /// The healthy servo's rate limit [rad/s].
    pub rudder_rate_nominal_rad_s: f64,
}

/// An HBT test's features.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct HbtFeatures {
    /// Limit-cycle period P_u [s].
    pub period_s: f64,
    /// omega_u = 2 pi / P_u [rad/s].
    pub omega_u_rad_s: f64,
    /// First-harmonic heading amplitude [rad].
    pub amplitude_rad: f64,
    /// Whole periods measured.
    pub periods: usize,
    /// Standard deviation of the periods [s].
    pub period_std_s: f64,
    /// Ultimate gain with hysteresis.
    pub ultimate_gain: f64,
    /// Relay height h [rad].
    pub relay_height_rad: f64,
    /// Hysteresis eps [rad].
    pub hysteresis_rad: f64,
    /// Relay centre at the end of the test [rad].
    pub trim_rad: f64,
    /// Trim rudder measured before the relay started [rad].
    pub initial_trim_rad: f64,
    /// Shortest interval between two relay switches [s].
    pub min_switch_interval_s: f64,
    /// Relay switches in the whole test.
    pub switches: usize,
    /// Wave yaw over the measured periods [rad] (null when it could not be computed).
    pub wave_yaw_rad: Option<f64>,
    /// First-harmonic amplitude of the measured rudder at omega_u [rad] (absent without a
    /// rudder record over the periods).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rudder_amplitude_rad: Option<f64>,
    /// |G(j omega_u)|, heading over measured rudder (absent as above).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub response_gain: Option<f64>,
    /// arg G(j omega_u) [rad], in (-2 pi, 0] (absent as above).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub response_phase_rad: Option<f64>,
    /// The servo slew check (absent when not measurable).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub servo_rate: Option<ServoRateFeatures>,
    /// The scale of the relay's height and hysteresis against the design when the test
    /// lowered them to keep the limit cycle inside the heading limit (absent when the relay
    /// played as designed): `relay_height_rad`, `hysteresis_rad` and `amplitude_rad` are as
    /// played; by homogeneity the cycle is the designed relay's at `relay_scale` times its
    /// amplitude, up to the servo's rate limit (`relay_omega_ratio`,
    /// `relay_amplitude_ratio`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub relay_scale: Option<f64>,
    /// With `relay_scale`: the describing function's ratio, on the ship fitted at the
    /// sizing's look, of the played relay's cycle frequency to the designed relay's (1 where
    /// the servo's rate limit does not act): `omega_u_rad_s / relay_omega_ratio` is the
    /// designed relay's.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub relay_omega_ratio: Option<f64>,
    /// With `relay_scale`: the same ratio of the cycle amplitudes (`relay_scale` where the
    /// rate limit does not act): `amplitude_rad / relay_amplitude_ratio` is the designed
    /// relay's.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub relay_amplitude_ratio: Option<f64>,
    /// Mean speed-log reading over the test [m/s] (absent without speed samples).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub speed_log_mps: Option<f64>,
    /// The time-domain baseline (null when it failed).
    pub baseline: Option<BaselineFeatures>,
    /// Why the baseline failed (absent when it did not).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub baseline_error: Option<String>,
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::sample;

    fn hbt() -> HbtFeatures {
        HbtFeatures {
            response_gain: Some(0.3),
            response_phase_rad: Some(-2.8),
            speed_log_mps: Some(7.0),
            baseline_error: Some("too short".into()),
            ..sample::hbt()
        }
    }

    /// Keys sorted, absent fields left out, null fields null; and back.
    #[test]
    fn hbt_features_serialize_as_the_contract_says_and_round_trip() {
        let f = Features::Hbt(hbt());
        let text = serde_json::to_string(&f).unwrap();
        assert!(text.starts_with("{\"amplitude_rad\":0.05,\"baseline\":null,\"baseline_error\":\"too short\",\"hysteresis_rad\""), "{text}");
        assert!(text.contains("\"wave_yaw_rad\":null"), "{text}");
        assert!(!text.contains("rudder_amplitude_rad"), "{text}");
        assert!(!text.contains("servo_rate"), "{text}");
        let back: Features = serde_json::from_str(&text).unwrap();
        assert_eq!(back, f);
        assert_eq!(back.speed_log_mps(), Some(7.0));
        assert!(back.clfrt().is_none());
    }

    #[test]
    fn an_aborted_test_has_empty_features() {
        assert_eq!(serde_json::to_string(&Features::None).unwrap(), "{}");
        assert_eq!(
            serde_json::from_str::<Features>("{}").unwrap(),
            Features::None
        );
    }

    #[test]
    fn clfrt_features_are_told_from_hbt_ones() {
        let c = ClfrtFeatures {
            tones: vec![ToneFeatures {
                omega_rad_s: 0.03,
                gain: 0.5,
                phase_rad: -2.7,
                coherence: 0.99,
                snr_db: 30.0,
                gain_ci90_rel: 0.04,
                phase_ci90_rad: 0.04,
            }],
            window_s: 590.0,
            windows: 2,
            amplitude_rad: 0.07,
            crest_factor: 1.77,
            servo_check: Some(ServoCheckFeatures {
                omega_rad_s: 0.6,
                amplitude_rad: 0.087,
                periods: 10,
                ln_gain: None,
                phase_rad: None,
                ln_gain_error: None,
                phase_error_rad: None,
                harmonic3_ratio: None,
                residual_rms_rad: None,
                rudder_rate_p95_rad_s: None,
                rudder_rate_nominal_rad_s: None,
                ratio_ln_gain: None,
                ratio_phase_rad: None,
                failed: Some("rudder record short".into()),
            }),
            wave_yaw_rad: Some(0.003),
            amplitude_scales: Some(vec![1.0, 0.25]),
            speed_log_mps: None,
            baseline: None,
            baseline_error: None,
        };
        let f = Features::Clfrt(c);
        let text = serde_json::to_string(&f).unwrap();
        assert!(text.contains("\"amplitude_scales\":[1.0,0.25]"), "{text}");
        assert!(text.contains("\"servo_check\":{\"amplitude_rad\":0.087,\"failed\":\"rudder record short\",\"omega_rad_s\":0.6,\"periods\":10}"), "{text}");
        let back: Features = serde_json::from_str(&text).unwrap();
        assert_eq!(back, f);
        assert_eq!(back.servo_rate_rad_s(), None);
        assert_eq!(back.wave_yaw_rad(), Some(0.003));
    }
}
