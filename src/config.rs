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
//!
//! ## One daemon, ships of different classes
//!
//! A `[vessel.<name>]` table overrides, for that vessel only, any key of the sections a ship
//! owns: its particulars and nominal values (`[vessel.<name>.ship]`), servo, sensors,
//! autopilot, sea and structure (simulated ships), the tests, scheduler, safety limits, input checks,
//! the estimator's models directory, the FDI and the baseline. Keys left out keep the file's
//! top-level value. The daemon-wide sections (`daemon`, `zenoh`, `ship-peer`, `bridge`) cannot be
//! overridden. [`Config::for_vessel`] gives a vessel's effective configuration: the
//! top-level file with the vessel's table merged in, checked like the file itself (an error
//! names `vessel.<name>.<section>.<key>`).

use crate::shells::bridge::BridgeConfig;
use crate::shells::daemon::config::DaemonConfig;
use crate::shells::net::ZenohConfig;
use crate::shells::shipnode::ShipPeerConfig;
use helmwatch_core::baseline::config::BaselineConfig;
use helmwatch_core::config::ConfigError;
use helmwatch_core::design::{ClfrtConfig, HbtConfig};
use helmwatch_core::estimator::config::EstimatorConfig;
use helmwatch_core::fdi::config::{FdiConfig, ReferenceConfig};
use helmwatch_core::model::{SensorConfig, ServoConfig, ShipConfig};
use helmwatch_core::monitor::config::{CoreConfig, InputConfig, SafetyConfig, SchedulerConfig};
use helmwatch_core::sim::config::{
    AutopilotConfig, SeaConfig, SimConfig, SimulationConfig, StructureConfig,
};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::Path;

/// Sections a `[vessel.<name>]` table may override (the rest are daemon-wide).
pub const VESSEL_SECTIONS: [&str; 16] = [
    "ship",
    "servo",
    "autopilot",
    "sensors",
    "sea",
    "simulation",
    "structure",
    "scheduler",
    "hbt",
    "clfrt",
    "safety",
    "input",
    "estimator",
    "fdi",
    "reference",
    "baseline",
];

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
    /// The simulated ship's structure beyond the first-order model (second-order Nomoto,
    /// cubic damping, steering dead band and backlash); off by default.
    pub structure: StructureConfig,
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
    /// The NMEA bridge (`helmwatch bridge nmea`): a ship's NMEA 0183 / IEC 61162-450 in.
    pub bridge: BridgeConfig,
    /// The neural estimator's models (speed and displacement from the features).
    pub estimator: EstimatorConfig,
    /// Fault detection and isolation: residual spreads, decision rule, alarm state.
    pub fdi: FdiConfig,
    /// The vessel's own reference over its operating envelope.
    pub reference: ReferenceConfig,
    /// The time-domain baseline (equation-error least squares of a and b).
    pub baseline: BaselineConfig,
    /// Per-vessel overrides (`[vessel.<name>.<section>]`), see the module documentation.
    /// Kept as TOML tables: a key left out keeps the top-level value.
    pub vessel: BTreeMap<String, toml::Table>,
}

impl Config {
    /// Parses TOML text and checks every limit.
    pub fn from_toml_str(text: &str) -> Result<Self, ConfigError> {
        let table: toml::Table =
            toml::from_str(text).map_err(|e| ConfigError::Parse(e.to_string()))?;
        let cfg: Config = table
            .try_into()
            .map_err(|e: toml::de::Error| ConfigError::Parse(e.to_string()))?;
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
    /// Every `[vessel.<name>]` table is checked too, merged into the top level.
    pub fn check(&self) -> Result<(), ConfigError> {
        self.check_sections()?;
        self.daemon.check()?;
        if self.daemon.takeover_s <= self.safety.hold_s {
            return Err(helmwatch_core::config::fail(
                "daemon.takeover-s",
                self.daemon.takeover_s,
                &format!(
                    "(0, 600] and greater than safety.hold-s ({} s)",
                    self.safety.hold_s
                ),
            ));
        }
        self.zenoh.check("zenoh")?;
        self.ship_peer.check()?;
        self.bridge.check()?;
        for name in self.vessel.keys() {
            let key = format!("vessel.{name}");
            helmwatch_core::config::check_vessel_name(&key, name)?;
            if !self.daemon.vessels.iter().any(|v| v == name) {
                return Err(helmwatch_core::config::fail(
                    &key,
                    format!("{name:?}"),
                    "a vessel listed in daemon.vessels",
                ));
            }
            self.for_vessel(name)?;
        }
        Ok(())
    }

    /// The limits of the sections a vessel can override.
    fn check_sections(&self) -> Result<(), ConfigError> {
        self.core().check()?;
        self.sim().check()
    }

    /// The effective configuration of `vessel`: the top level with its `[vessel.<name>]`
    /// table merged in (itself when it has none), checked; errors name the vessel's key.
    /// The result has no vessel tables of its own.
    pub fn for_vessel(&self, vessel: &str) -> Result<Config, ConfigError> {
        let Some(over) = self.vessel.get(vessel) else {
            let mut c = self.clone();
            c.vessel.clear();
            return Ok(c);
        };
        let prefix = format!("vessel.{vessel}");
        for (section, value) in over {
            if !VESSEL_SECTIONS.contains(&section.as_str()) {
                return Err(helmwatch_core::config::fail(
                    &format!("{prefix}.{section}"),
                    "a table",
                    &format!("one of the sections {}", VESSEL_SECTIONS.join(", ")),
                ));
            }
            if !value.is_table() {
                return Err(ConfigError::Parse(format!(
                    "`{prefix}.{section}` must be a table of keys"
                )));
            }
        }
        let mut base = self.clone();
        base.vessel.clear();
        let mut table = toml::Table::try_from(&base)
            .map_err(|e| ConfigError::Parse(format!("{prefix}: {e}")))?;
        merge(&mut table, over);
        let merged: Config = table.try_into().map_err(|e: toml::de::Error| {
            ConfigError::Parse(format!("{prefix}: {}", e.message()))
        })?;
        merged.check_sections().map_err(|e| match e {
            ConfigError::OutOfRange {
                key,
                value,
                allowed,
            } => ConfigError::OutOfRange {
                key: format!("{prefix}.{key}"),
                value,
                allowed,
            },
            other => other,
        })?;
        Ok(merged)
    }

    /// Each vessel of `daemon.vessels` with its monitor core's configuration, in order.
    pub fn fleet(&self) -> Result<Vec<(String, CoreConfig)>, ConfigError> {
        let root = self.core();
        self.daemon
            .vessels
            .iter()
            .map(|v| {
                let core = match self.vessel.contains_key(v) {
                    true => self.for_vessel(v)?.core(),
                    false => root.clone(),
                };
                Ok((v.clone(), core))
            })
            .collect()
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
            reference: self.reference.clone(),
            calibration: Default::default(),
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
            structure: self.structure,
        }
    }
}

/// Merges `over` into `base`: tables key by key, anything else replaced.
fn merge(base: &mut toml::Table, over: &toml::Table) {
    for (k, v) in over {
        match (base.get_mut(k), v) {
            (Some(toml::Value::Table(b)), toml::Value::Table(o)) => merge(b, o),
            _ => {
                base.insert(k.clone(), v.clone());
            }
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
    fn an_unknown_bridge_key_is_named_with_every_key_allowed() {
        let e = Config::from_toml_str("[bridge]\nbogus = 1\n").unwrap_err();
        let m = e.to_string();
        let keys = toml::Value::try_from(crate::shells::bridge::BridgeConfig::default()).unwrap();
        let keys = keys.as_table().unwrap();
        assert!(keys.len() >= 20 && m.contains("bogus"), "{m}");
        for k in keys.keys() {
            assert!(m.contains(&format!("`{k}`")), "{k} missing from: {m}");
        }
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
        // The sizing's keys name themselves and their range.
        let e = Config::from_toml_str("[clfrt]\nresize-factor = 1.0\n").unwrap_err();
        assert!(
            e.to_string().contains("clfrt.resize-factor") && e.to_string().contains("(0, 0.95]"),
            "{e}"
        );
        let e = Config::from_toml_str("[clfrt]\nresize-settle-s = 5\n").unwrap_err();
        assert!(e.to_string().contains("clfrt.resize-settle-s"), "{e}");
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
    fn relay_sizing_keys_are_checked() {
        for (toml, key, range) in [
            ("resize-at-switch = 3", "hbt.resize-at-switch", "[0, 2]"),
            (
                "resize-heading-fraction = 0",
                "hbt.resize-heading-fraction",
                "(0, 1]",
            ),
            (
                "resize-heading-fraction = 1.2",
                "hbt.resize-heading-fraction",
                "(0, 1]",
            ),
            (
                "resize-min-hysteresis-deg = 0",
                "hbt.resize-min-hysteresis-deg",
                "(0, 10]",
            ),
            (
                "resize-wave-factor = -1",
                "hbt.resize-wave-factor",
                "[0, 20]",
            ),
        ] {
            let e = Config::from_toml_str(&format!("[hbt]\n{toml}\n")).unwrap_err();
            let m = e.to_string();
            assert!(m.contains(key) && m.contains(range), "{toml}: {m}");
        }
        // Two settle periods leave room for a look at the fourth switch; 0 is off.
        Config::from_toml_str("[hbt]\nsettle-periods = 2\nresize-at-switch = 4\n").unwrap();
        Config::from_toml_str("[hbt]\nresize-at-switch = 0\n").unwrap();
    }

    #[test]
    fn the_models_calibration_is_no_key_of_the_file() {
        for key in [
            "sea-wave-yaw-deg = [0.05, 0.18]",
            "wave-band-rad-s = [0.4, 2.0]",
        ] {
            let e = Config::from_toml_str(&format!("[fdi]\n{key}\n")).unwrap_err();
            assert!(e.to_string().contains(&key[..8]), "{e}");
        }
        let e = Config::from_toml_str("[reference]\nslope-speed-gain = 0.01\n").unwrap_err();
        assert!(e.to_string().contains("slope-speed-gain"), "{e}");
        // [fdi] and [reference]: eight keys together.
        let n = |t: toml::Table| t.len();
        let keys =
            n(toml::Table::try_from(helmwatch_core::fdi::config::FdiConfig::default()).unwrap())
                + n(
                    toml::Table::try_from(helmwatch_core::fdi::config::ReferenceConfig::default())
                        .unwrap(),
                );
        assert_eq!(keys, 8);
    }

    #[test]
    fn the_decision_keys_are_checked_and_unknown_ones_refused() {
        for (toml, key, range) in [
            (
                "false-alarms-per-year = 0",
                "fdi.false-alarms-per-year",
                "(0, 100]",
            ),
            ("window-tests = 0", "fdi.window-tests", "[1, 12]"),
            ("window-tests = 13", "fdi.window-tests", "[1, 12]"),
            (
                "commissioning-tests = 4",
                "fdi.commissioning-tests",
                "0 (the design reference) or [5, 50]",
            ),
            (
                "floor-displacement = 0.6",
                "fdi.floor-displacement",
                "[0, 0.5]",
            ),
            ("floor-speed-mps = -1", "fdi.floor-speed-mps", "[0, 5]"),
        ] {
            let e = Config::from_toml_str(&format!("[fdi]\n{toml}\n")).unwrap_err();
            let e = e.to_string();
            assert!(e.contains(key) && e.contains(range), "{toml}: {e}");
        }
        assert_eq!(
            Config::from_toml_str("[fdi]\ncommissioning-tests = 0\n")
                .unwrap()
                .fdi
                .commissioning_tests,
            0
        );
        // A key the section does not have is refused by name, at the top level and in a
        // vessel's table (no key of an earlier release is read as something else).
        let e = Config::from_toml_str("[fdi]\nchi2-threshold = 9\n").unwrap_err();
        assert!(e.to_string().contains("chi2-threshold"), "{e}");
        let e = Config::from_toml_str(
            "[daemon]\nvessels = [\"self\"]\n[vessel.self.fdi]\nchi2-threshold = 9\n",
        )
        .unwrap_err();
        assert!(e.to_string().contains("chi2-threshold"), "{e}");
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
    fn a_vessel_table_overrides_only_its_keys() {
        let text = "[daemon]\nvessels = [\"alpha\", \"bravo\"]\n\
                    [ship]\nlength-m = 130\n\
                    [vessel.bravo.ship]\nnominal-displacement-t = 9000\n\
                    [vessel.bravo.estimator]\nmodels-dir = \"/srv/bravo\"\n";
        let cfg = Config::from_toml_str(text).unwrap();
        let bravo = cfg.for_vessel("bravo").unwrap();
        assert_eq!(bravo.ship.nominal_displacement_t, 9000.0);
        // Left out: the file's top-level value, not the default.
        assert_eq!(bravo.ship.length_m, 130.0);
        assert_eq!(bravo.estimator.models_dir.as_deref(), Some("/srv/bravo"));
        assert!(bravo.vessel.is_empty());
        let alpha = cfg.for_vessel("alpha").unwrap();
        assert_eq!(alpha.ship, cfg.ship);
        let fleet = cfg.fleet().unwrap();
        assert_eq!(fleet.len(), 2);
        assert_eq!(fleet[0].1, cfg.core());
        assert_eq!(fleet[1].1, bravo.core());
        assert_ne!(fleet[0].1, fleet[1].1);
    }

    #[test]
    fn the_defaults_survive_the_merge_bit_for_bit() {
        let mut cfg = Config::default();
        cfg.vessel.insert("self".into(), toml::Table::new());
        assert_eq!(cfg.for_vessel("self").unwrap(), Config::default());
    }

    #[test]
    fn vessel_tables_are_checked_and_named() {
        let base = "[daemon]\nvessels = [\"alpha\"]\n";
        let e = Config::from_toml_str(&format!("{base}[vessel.alpha.ship]\nlength-m = -3\n"))
            .unwrap_err();
        assert!(e.to_string().contains("vessel.alpha.ship.length-m"), "{e}");
        let e =
            Config::from_toml_str(&format!("{base}[vessel.alpha.ship]\nbogus = 1\n")).unwrap_err();
        assert!(
            e.to_string().contains("vessel.alpha") && e.to_string().contains("bogus"),
            "{e}"
        );
        let e = Config::from_toml_str(&format!("{base}[vessel.alpha.daemon]\ntick-s = 1\n"))
            .unwrap_err();
        assert!(e.to_string().contains("vessel.alpha.daemon"), "{e}");
        let e = Config::from_toml_str(&format!("{base}[vessel.zulu.ship]\nlength-m = 100\n"))
            .unwrap_err();
        assert!(
            e.to_string().contains("vessel.zulu") && e.to_string().contains("daemon.vessels"),
            "{e}"
        );
        let e = Config::from_toml_str(&format!("{base}[vessel.alpha]\nship = 3\n")).unwrap_err();
        assert!(e.to_string().contains("vessel.alpha.ship"), "{e}");
    }

    #[test]
    fn harmonics_must_increase() {
        let e = Config::from_toml_str("[clfrt]\nharmonics = [7, 3]\n").unwrap_err();
        assert!(e.to_string().contains("clfrt.harmonics"));
    }
}
