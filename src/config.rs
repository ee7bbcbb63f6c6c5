//! Configuration: every number of the domain, with its default, its unit and its allowed range.
//!
//! The file format is TOML with kebab-case keys; unknown keys are rejected
//! (`deny_unknown_fields`). Units are part of the key names (`_deg`, `_s`, `_mps`, `_t`). Angles
//! are configured in degrees, which people read, and converted to radians, which the code uses,
//! by the accessor methods (`*_rad()`).
//!
//! Loading is two steps, as in ntpd-rs: serde parses the shape ([`Config::from_toml_str`]),
//! then [`Config::check`] enforces the semantic limits and names the offending key and its
//! allowed range in a [`ConfigError`]. The binary maps any such error to exit code 78
//! (`EX_CONFIG`).
//!
//! The defaults are the numbers of the domain brief (the ship, the servo, the autopilot, the
//! sensors and sea states, HBT, CLFRT and the safety limits).
//!
//! Each section is defined beside the code that owns it; this is the file as a whole. The
//! floors below take only their part: [`Config::core`] for a monitor core, [`Config::sim`]
//! for a simulated ship, and the shells their own sections.

use crate::core::baseline::config::BaselineConfig;
pub use crate::core::config::ConfigError;
use crate::core::design::{ClfrtConfig, HbtConfig};
use crate::core::estimator::config::EstimatorConfig;
use crate::core::fdi::config::FdiConfig;
use crate::core::model::{SensorConfig, ServoConfig, ShipConfig};
use crate::core::monitor::config::{CoreConfig, InputConfig, SafetyConfig, SchedulerConfig};
use crate::shells::daemon::config::DaemonConfig;
use crate::shells::net::ZenohConfig;
use crate::shells::shipnode::ShipPeerConfig;
use crate::sim::config::{AutopilotConfig, SeaConfig, SimConfig, SimulationConfig};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// The whole configuration file.
#[derive(Debug, Clone, Default, Serialize, Deserialize, PartialEq)]
#[serde(default, deny_unknown_fields, rename_all = "kebab-case")]
pub struct Config {
    /// The ship model and its nominal parameters.
    pub ship: ShipConfig,
    /// The rudder servo.
    pub servo: ServoConfig,
    /// The simulated heading autopilot (PID with wave filter).
    pub autopilot: AutopilotConfig,
    /// Sensor rates and noise.
    pub sensors: SensorConfig,
    /// Environmental disturbances per sea state.
    pub sea: SeaConfig,
    /// Simulation set-up (initial course, integration).
    pub simulation: SimulationConfig,
    /// When tests run.
    pub scheduler: SchedulerConfig,
    /// Harmonic balance (relay) test.
    pub hbt: HbtConfig,
    /// Closed-loop frequency response (multisine) test.
    pub clfrt: ClfrtConfig,
    /// Safety limits on excitation and abort conditions.
    pub safety: SafetyConfig,
    /// Input validation (plausibility limits on incoming samples).
    pub input: InputConfig,
    /// The daemon (`helmwatch run`): vessels, queues, timers.
    pub daemon: DaemonConfig,
    /// The daemon's Zenoh session.
    pub zenoh: ZenohConfig,
    /// The simulated ship as a Zenoh peer (`helmwatch ship`).
    pub ship_peer: ShipPeerConfig,
    /// The neural estimator's models (speed and displacement from the features).
    pub estimator: EstimatorConfig,
    /// Fault detection and isolation: residual spreads, decision rule, alarm state.
    pub fdi: FdiConfig,
    /// The time-domain baseline (equation-error least squares of a and b).
    pub baseline: BaselineConfig,
}

impl Config {
    /// Parses TOML text and checks every limit.
    pub fn from_toml_str(text: &str) -> Result<Self, ConfigError> {
        let cfg: Config = toml::from_str(text).map_err(|e| ConfigError::Parse(e.to_string()))?;
        cfg.check()?;
        Ok(cfg)
    }

    /// Reads, parses and checks a TOML file.
    pub fn from_file(path: &Path) -> Result<Self, ConfigError> {
        let text = std::fs::read_to_string(path).map_err(|source| ConfigError::Io {
            path: path.display().to_string(),
            source,
        })?;
        Self::from_toml_str(&text)
    }

    /// Checks every semantic limit; the first violation is returned, naming its key.
    pub fn check(&self) -> Result<(), ConfigError> {
        self.core().check()?;
        self.sim().check()?;
        self.daemon.check()?;
        self.zenoh.check("zenoh")?;
        self.ship_peer.check()?;
        Ok(())
    }

    /// What one monitor core needs: the ship's particulars and streams, the test designs,
    /// the scheduler, the safety limits, input validation, the estimator, the FDI and the
    /// baseline.
    pub fn core(&self) -> CoreConfig {
        CoreConfig {
            ship: self.ship.clone(),
            servo: self.servo.clone(),
            sensors: self.sensors.clone(),
            scheduler: self.scheduler.clone(),
            hbt: self.hbt.clone(),
            clfrt: self.clfrt.clone(),
            safety: self.safety.clone(),
            input: self.input.clone(),
            estimator: self.estimator.clone(),
            fdi: self.fdi.clone(),
            baseline: self.baseline.clone(),
        }
    }

    /// What one simulated ship needs: the ship, its servo, sensors and autopilot, the sea
    /// and the simulation set-up.
    pub fn sim(&self) -> SimConfig {
        SimConfig {
            ship: self.ship.clone(),
            servo: self.servo.clone(),
            sensors: self.sensors.clone(),
            autopilot: self.autopilot.clone(),
            sea: self.sea.clone(),
            simulation: self.simulation.clone(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_pass_check() {
        Config::default().check().unwrap();
    }

    #[test]
    fn nominal_ship_matches_domain_brief() {
        let s = ShipConfig::default();
        let (a, b) = s.nomoto(7.0, 7000.0);
        approx::assert_relative_eq!(a, 0.014583, max_relative = 1e-3);
        approx::assert_relative_eq!(b, 5.98e-4, max_relative = 2e-3);
        approx::assert_relative_eq!(b / a, 0.041, max_relative = 1e-2);
    }

    #[test]
    fn pole_placement_gains_match_domain_brief() {
        let g = AutopilotConfig::default().gains(&ShipConfig::default());
        assert!((g.kp - 4.2).abs() < 0.1, "kp {}", g.kp);
        assert!((g.td_s - 30.0).abs() < 1.5, "td {}", g.td_s);
        approx::assert_relative_eq!(g.ti_s, 200.0, max_relative = 1e-12);
    }

    #[test]
    fn unknown_key_is_rejected() {
        let e = Config::from_toml_str("[servo]\nmax-rate-deg-s = 4\nbogus = 1\n").unwrap_err();
        assert!(
            matches!(e, ConfigError::Parse(ref m) if m.contains("bogus")),
            "{e}"
        );
    }

    #[test]
    fn out_of_range_names_key_and_range() {
        let e = Config::from_toml_str("[servo]\nmax-rate-deg-s = -1\n").unwrap_err();
        let m = e.to_string();
        assert!(
            m.contains("servo.max-rate-deg-s") && m.contains("(0, 20]"),
            "{m}"
        );
    }

    #[test]
    fn daemon_and_zenoh_keys_are_checked() {
        let e = Config::from_toml_str("[daemon]\nvessels = [\"a\", \"a\"]\n").unwrap_err();
        assert!(e.to_string().contains("daemon.vessels[1]"), "{e}");
        let e = Config::from_toml_str("[daemon]\nvessels = [\"a/b\"]\n").unwrap_err();
        assert!(e.to_string().contains("daemon.vessels[0]"), "{e}");
        let e = Config::from_toml_str("[zenoh]\nlisten = [\"nonsense\"]\n").unwrap_err();
        assert!(e.to_string().contains("zenoh.listen[0]"), "{e}");
        let e = Config::from_toml_str("[ship-peer]\nfaults = [\"bogus:1@0\"]\n").unwrap_err();
        assert!(e.to_string().contains("ship-peer.faults[0]"), "{e}");
        let e = Config::from_toml_str("[daemon]\ntick-s = 0\n").unwrap_err();
        assert!(e.to_string().contains("daemon.tick-s"), "{e}");
    }

    #[test]
    fn servo_check_keys_are_checked() {
        let e = Config::from_toml_str("[clfrt]\nservo-check-periods = 2\n").unwrap_err();
        assert!(e.to_string().contains("clfrt.servo-check-periods"), "{e}");
        // 60 periods of 10.5 s do not fit in the 590 s settle window.
        let e = Config::from_toml_str("[clfrt]\nservo-check-periods = 60\n").unwrap_err();
        assert!(e.to_string().contains("clfrt.servo-check-periods"), "{e}");
        let e = Config::from_toml_str("[clfrt]\nservo-check-frequency-rad-s = 0\n").unwrap_err();
        assert!(e.to_string().contains("(0, 5]"), "{e}");
        // 8 deg at 0.6 rad/s is 4.8 deg/s, over the gate's 3.5 deg/s.
        let e = Config::from_toml_str("[clfrt]\nservo-check-amplitude-deg = 8\n").unwrap_err();
        assert!(
            e.to_string().contains("clfrt.servo-check-amplitude-deg")
                && e.to_string().contains("safety.max-excitation-rate-deg-s"),
            "{e}"
        );
        // Disabled: no settle window needed for it.
        let cfg =
            Config::from_toml_str("[clfrt]\nservo-check-amplitude-deg = 0\nsettle-windows = 0\n")
                .unwrap();
        assert_eq!(cfg.clfrt.servo_check_duration_s(cfg.sensors.rate_hz), 0.0);
        // Defaults: 10 periods on 1047 samples, 12 periods in all.
        let c = Config::default();
        assert_eq!(c.clfrt.servo_check_samples(10.0), 1047);
        let w = c.clfrt.servo_check_omega_rad_s(10.0);
        assert!((w / 0.6 - 1.0).abs() < 5e-4, "{w}");
        let d = c.clfrt.servo_check_duration_s(10.0);
        assert!((d - 12.0 * 104.7 / 10.0).abs() < 1e-9, "{d}");
    }

    #[test]
    fn sea_keys_are_checked() {
        let e = Config::from_toml_str("[fdi]\nsea-wave-yaw-deg = [0.2, 0.05]\n").unwrap_err();
        assert!(e.to_string().contains("fdi.sea-wave-yaw-deg"), "{e}");
        let e = Config::from_toml_str("[fdi]\nwave-band-rad-s = [2.0, 0.4]\n").unwrap_err();
        assert!(e.to_string().contains("fdi.wave-band-rad-s"), "{e}");
        // 8 rad/s is above the Nyquist frequency of 2 Hz sensors (6.28 rad/s).
        let e =
            Config::from_toml_str("[sensors]\nrate-hz = 2\n[fdi]\nwave-band-rad-s = [0.4, 8.0]\n")
                .unwrap_err();
        assert!(e.to_string().contains("fdi.wave-band-rad-s"), "{e}");
    }

    #[test]
    fn baseline_keys_are_checked() {
        let e = Config::from_toml_str("[baseline]\nfilter-rad-s = 0\n").unwrap_err();
        assert!(e.to_string().contains("baseline.filter-rad-s"), "{e}");
        // 5 / lambda = 50 s at 0.1 rad/s.
        let e = Config::from_toml_str("[baseline]\nfilter-rad-s = 0.1\ntransient-s = 40\n")
            .unwrap_err();
        assert!(e.to_string().contains("baseline.transient-s"), "{e}");
        Config::from_toml_str("[baseline]\nfilter-rad-s = 0.1\ntransient-s = 60\n").unwrap();
        let e = Config::from_toml_str("[baseline]\nlambda = 0.1\n").unwrap_err();
        assert!(e.to_string().contains("lambda"), "{e}");
    }

    #[test]
    fn harmonics_must_increase() {
        let e = Config::from_toml_str("[clfrt]\nharmonics = [7, 3]\n").unwrap_err();
        assert!(e.to_string().contains("clfrt.harmonics"));
    }
}
