//! The simulator's sections: the autopilot, the sea, the simulation set-up, and
//! [`SimConfig`], everything one simulated ship needs.

use crate::config::check_vessel_name;
use crate::config::{check_count, check_range, check_range_open_low, ConfigError};
use crate::model::{SeaState, SensorConfig, ServoConfig, ShipConfig};
use serde::{Deserialize, Serialize};

// ---------------------------------------------------------------------------------------------
// Autopilot

/// Simulated heading autopilot: PID on the wave-filtered heading error, pole placement defaults.
///
/// Fossen: Kp = (T/K) wn^2, Td = T/(K Kp) (2 zeta wn - 1/T), Ti = factor / wn, computed for
/// the nominal ship unless overridden.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(default, deny_unknown_fields, rename_all = "kebab-case")]
pub struct AutopilotConfig {
    /// Closed-loop natural frequency wn for pole placement [rad/s].
    pub natural_frequency_rad_s: f64,
    /// Closed-loop damping ratio zeta.
    pub damping: f64,
    /// Ti = integral-time-factor / wn.
    pub integral_time_factor: f64,
    /// Cut-off of the critically damped 2nd-order low-pass on the heading error [rad/s].
    pub wave_filter_rad_s: f64,
    /// Override of the proportional gain Kp [rad rudder / rad error].
    pub kp: Option<f64>,
    /// Override of the derivative time Td [s].
    pub td_s: Option<f64>,
    /// Override of the integral time Ti [s].
    pub ti_s: Option<f64>,
    /// Gain scheduling on speed, as commercial autopilots do with their speed input: the
    /// pole placement uses the ship at its speed (and nominal displacement). Off: the gains
    /// are those of the nominal ship at every speed (the loop then loses its margins on a
    /// fast, light ship: |S| peaks near 13 at 10 m/s, 4000 t).
    pub speed_scheduling: bool,
}

impl Default for AutopilotConfig {
    fn default() -> Self {
        Self {
            natural_frequency_rad_s: 0.05,
            damping: 0.9,
            integral_time_factor: 10.0,
            wave_filter_rad_s: 0.25,
            kp: None,
            td_s: None,
            ti_s: None,
            speed_scheduling: true,
        }
    }
}

impl AutopilotConfig {
    /// Checks the section's limits; the error names the key and its allowed range.
    pub fn check(&self) -> Result<(), ConfigError> {
        check_range_open_low(
            "autopilot.natural-frequency-rad-s",
            self.natural_frequency_rad_s,
            0.0,
            1.0,
        )?;
        check_range_open_low("autopilot.damping", self.damping, 0.0, 5.0)?;
        check_range_open_low(
            "autopilot.integral-time-factor",
            self.integral_time_factor,
            0.0,
            1000.0,
        )?;
        check_range_open_low(
            "autopilot.wave-filter-rad-s",
            self.wave_filter_rad_s,
            0.0,
            10.0,
        )?;
        if let Some(kp) = self.kp {
            check_range_open_low("autopilot.kp", kp, 0.0, 100.0)?;
        }
        if let Some(td) = self.td_s {
            check_range("autopilot.td-s", td, 0.0, 1000.0)?;
        }
        if let Some(ti) = self.ti_s {
            check_range_open_low("autopilot.ti-s", ti, 0.0, 1.0e5)?;
        }
        Ok(())
    }
}

// ---------------------------------------------------------------------------------------------
// Sea

/// Disturbance levels of one sea state (standard deviations).
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, rename_all = "kebab-case")]
pub struct SeaLevels {
    /// First-order wave yaw on the heading measurement [deg].
    pub wave_yaw_deg: f64,
    /// Rudder-equivalent slowly varying yaw moment (Markov bias) [deg].
    pub bias_deg: f64,
}

/// Disturbance model: Markov rudder-equivalent bias and Fossen's wave filter on the heading.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(default, deny_unknown_fields, rename_all = "kebab-case")]
pub struct SeaConfig {
    /// Sea state used when none is given on the command line.
    pub state: SeaState,
    /// Time constant T_b of the first-order Markov bias [s].
    pub bias_time_constant_s: f64,
    /// Wave filter peak frequency w0 [rad/s].
    pub wave_frequency_rad_s: f64,
    /// Wave filter damping lambda.
    pub wave_damping: f64,
    /// Levels in a calm sea.
    pub calm: SeaLevels,
    /// Levels in a moderate sea.
    pub moderate: SeaLevels,
    /// Levels in a rough sea.
    pub rough: SeaLevels,
}

impl Default for SeaConfig {
    fn default() -> Self {
        Self {
            state: SeaState::Moderate,
            bias_time_constant_s: 300.0,
            wave_frequency_rad_s: 0.8,
            wave_damping: 0.1,
            calm: SeaLevels {
                wave_yaw_deg: 0.05,
                bias_deg: 0.1,
            },
            moderate: SeaLevels {
                wave_yaw_deg: 0.2,
                bias_deg: 0.5,
            },
            rough: SeaLevels {
                wave_yaw_deg: 0.5,
                bias_deg: 1.0,
            },
        }
    }
}

impl SeaConfig {
    /// Checks the section's limits; the error names the key and its allowed range.
    pub fn check(&self) -> Result<(), ConfigError> {
        check_range_open_low(
            "sea.bias-time-constant-s",
            self.bias_time_constant_s,
            0.0,
            1.0e5,
        )?;
        check_range_open_low(
            "sea.wave-frequency-rad-s",
            self.wave_frequency_rad_s,
            0.0,
            10.0,
        )?;
        check_range_open_low("sea.wave-damping", self.wave_damping, 0.0, 2.0)?;
        for (name, l) in [
            ("calm", &self.calm),
            ("moderate", &self.moderate),
            ("rough", &self.rough),
        ] {
            check_range(
                &format!("sea.{name}.wave-yaw-deg"),
                l.wave_yaw_deg,
                0.0,
                10.0,
            )?;
            check_range(&format!("sea.{name}.bias-deg"), l.bias_deg, 0.0, 10.0)?;
        }
        Ok(())
    }
    /// Levels of a sea state.
    pub fn levels(&self, state: SeaState) -> SeaLevels {
        match state {
            SeaState::Calm => self.calm,
            SeaState::Moderate => self.moderate,
            SeaState::Rough => self.rough,
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Simulation

/// Simulation set-up.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(default, deny_unknown_fields, rename_all = "kebab-case")]
pub struct SimulationConfig {
    /// Course set on the autopilot at the start [deg, 0..360].
    pub initial_course_deg: f64,
    /// Integration sub-steps per sensor sample.
    pub substeps: u32,
    /// Time of the first sample [s] (any origin in simulation).
    pub start_time_s: f64,
    /// Vessel name used in the keys (`vessels/<vessel>/...`).
    pub vessel: String,
}

impl Default for SimulationConfig {
    fn default() -> Self {
        Self {
            initial_course_deg: 45.0,
            substeps: 5,
            start_time_s: 0.0,
            vessel: "self".to_string(),
        }
    }
}

impl SimulationConfig {
    /// Checks the section's limits; the error names the key and its allowed range.
    pub fn check(&self) -> Result<(), ConfigError> {
        check_range(
            "simulation.initial-course-deg",
            self.initial_course_deg,
            0.0,
            360.0,
        )?;
        check_count("simulation.substeps", self.substeps, 1, 1000)?;
        check_range(
            "simulation.start-time-s",
            self.start_time_s,
            -1.0e12,
            1.0e12,
        )?;
        check_vessel_name("simulation.vessel", &self.vessel)?;
        Ok(())
    }
}

// ---------------------------------------------------------------------------------------------
// Structure

/// How the simulated ship differs in structure from the first-order Nomoto model the method
/// is designed on (the nuisances of a real ship; all off by default).
///
/// ```text
/// hull:     T1 T2 r'' + (T1 + T2) r' + H(r) = K (v + T3 v'),   H(r) = r + n3 r^3
///           T1 = T / (1 + T2/T1 - T3/T1), so T1 + T2 - T3 = T = 1/a and K = b/a:
///           the ship's first-order (Nomoto) approximation is the nominal model
/// steering: the servo ignores command errors inside the dead band (it stops at its edge);
///           the rudder blade follows the servo through a backlash (mechanical play)
/// ```
///
/// With every value zero the hull is integrated exactly (`sim::ship`) and the simulator is
/// the first-order ship bit for bit; otherwise by fourth-order Runge-Kutta on the sub-steps.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq)]
#[serde(default, deny_unknown_fields, rename_all = "kebab-case")]
pub struct StructureConfig {
    /// Second-order Nomoto: T2 / T1, 0 (first order) or [0.005, 0.5].
    pub nomoto_t2_ratio: f64,
    /// Second-order Nomoto: the zero's T3 / T1, [0, 0.5] and below 1 + T2/T1.
    pub nomoto_t3_ratio: f64,
    /// Norrbin cubic yaw damping n3 in H(r) = r + n3 r^3 [s^2/rad^2], [0, 1e6]. At 1000 s^2
    /// the cubic term is 30 % of the linear one at r = 1 deg/s.
    pub norrbin_n3_s2: f64,
    /// Steering-gear dead band: command errors smaller than half of it leave the servo at
    /// rest [deg], [0, 5].
    pub rudder_dead_band_deg: f64,
    /// Backlash between the servo and the rudder blade (total play) [deg], [0, 5]. The
    /// rudder-angle sensor reads the blade.
    pub rudder_backlash_deg: f64,
    /// The hull model: `nomoto` (the equation above), `kvlcc2-mmg`, the surge-sway-yaw MMG
    /// model of the KVLCC2 tanker ([`crate::sim::mmg`]), or `mariner`, the Mariner-class cargo
    /// ship's surge-sway-yaw model from captive tests ([`crate::sim::mariner`]); the last two
    /// replace the Nomoto hull (its T2, T3 and n3 must then be 0; dead band and backlash still
    /// apply).
    pub hull: HullModel,
    /// Length the MMG or Mariner hull is scaled to by Froude similarity [m], [10, 400].
    pub mmg_length_m: f64,
}

/// Which hull the simulator integrates.
#[derive(Debug, Clone, Copy, Default, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "kebab-case")]
pub enum HullModel {
    /// Nomoto's yaw equation (first or second order, Norrbin damping).
    #[default]
    Nomoto,
    /// The MMG standard model of KVLCC2 (Yasukawa & Yoshimura 2015), Froude-scaled.
    Kvlcc2Mmg,
    /// The Mariner-class cargo ship's model (Chislett & Strøm-Tejsen 1965, Fossen's
    /// `mariner.m`), Froude-scaled.
    Mariner,
}

impl Default for StructureConfig {
    fn default() -> Self {
        Self {
            nomoto_t2_ratio: 0.0,
            nomoto_t3_ratio: 0.0,
            norrbin_n3_s2: 0.0,
            rudder_dead_band_deg: 0.0,
            rudder_backlash_deg: 0.0,
            hull: HullModel::Nomoto,
            mmg_length_m: 120.0,
        }
    }
}

impl StructureConfig {
    /// Checks the section's limits; the error names the key and its allowed range.
    pub fn check(&self) -> Result<(), ConfigError> {
        let r2 = self.nomoto_t2_ratio;
        if r2 != 0.0 {
            check_range("structure.nomoto-t2-ratio", r2, 0.005, 0.5).map_err(|_| {
                crate::config::fail(
                    "structure.nomoto-t2-ratio",
                    r2,
                    "0 (first order) or [0.005, 0.5]",
                )
            })?;
        }
        check_range("structure.nomoto-t3-ratio", self.nomoto_t3_ratio, 0.0, 0.5)?;
        check_range("structure.norrbin-n3-s2", self.norrbin_n3_s2, 0.0, 1.0e6)?;
        check_range(
            "structure.rudder-dead-band-deg",
            self.rudder_dead_band_deg,
            0.0,
            5.0,
        )?;
        check_range(
            "structure.rudder-backlash-deg",
            self.rudder_backlash_deg,
            0.0,
            5.0,
        )?;
        check_range("structure.mmg-length-m", self.mmg_length_m, 10.0, 400.0)?;
        if let Some(name) = match self.hull {
            HullModel::Nomoto => None,
            HullModel::Kvlcc2Mmg => Some("\"kvlcc2-mmg\""),
            HullModel::Mariner => Some("\"mariner\""),
        } {
            for (key, value) in [
                ("structure.nomoto-t2-ratio", self.nomoto_t2_ratio),
                ("structure.nomoto-t3-ratio", self.nomoto_t3_ratio),
                ("structure.norrbin-n3-s2", self.norrbin_n3_s2),
            ] {
                if value != 0.0 {
                    return Err(crate::config::fail(
                        key,
                        value,
                        &format!(
                            "0 with structure.hull = {name} (that hull replaces the Nomoto one)"
                        ),
                    ));
                }
            }
        }
        Ok(())
    }

    /// Whether the hull is the exact first-order model (the Nomoto hull without T2, T3 or
    /// cubic damping).
    pub fn first_order_hull(&self) -> bool {
        self.hull == HullModel::Nomoto
            && self.nomoto_t2_ratio == 0.0
            && self.nomoto_t3_ratio == 0.0
            && self.norrbin_n3_s2 == 0.0
    }
}

/// One member of the family of real ships the method must serve: a structure and whether the
/// autopilot keeps gains of its own tuned at the nominal ship (no speed scheduling).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FamilyMember {
    /// Name in tables.
    pub name: &'static str,
    /// Hull and steering structure.
    pub structure: StructureConfig,
    /// The autopilot's gains are fixed at those of the nominal ship.
    pub fixed_gain_autopilot: bool,
}

impl FamilyMember {
    /// Sets this member's structure and autopilot in a configuration's sections.
    pub fn apply(&self, structure: &mut StructureConfig, autopilot: &mut AutopilotConfig) {
        *structure = self.structure;
        if self.fixed_gain_autopilot {
            autopilot.speed_scheduling = false;
        }
    }
}

/// The family of ships of the real-ships issue, each nuisance alone at two strengths (the
/// upper one the acceptance bound: T2/T1 0.1, T3/T1 0.25, dead band 1 deg), then all at once,
/// then hulls that are no Nomoto equation at all: KVLCC2's surge-sway-yaw MMG model and the
/// Mariner cargo ship's captive-test model, both scaled to the family's 120 m (the Mariner
/// last: a row's seeds follow its member's place in the list). The first member is the first-order ship the estimator was designed on.
pub fn family() -> Vec<FamilyMember> {
    let s = |t2, t3, n3, db, bl| StructureConfig {
        nomoto_t2_ratio: t2,
        nomoto_t3_ratio: t3,
        norrbin_n3_s2: n3,
        rudder_dead_band_deg: db,
        rudder_backlash_deg: bl,
        ..StructureConfig::default()
    };
    let m = |name, structure, fixed_gain_autopilot| FamilyMember {
        name,
        structure,
        fixed_gain_autopilot,
    };
    vec![
        m("first order", s(0.0, 0.0, 0.0, 0.0, 0.0), false),
        m(
            "nomoto2 T2/T1 0.05 T3/T1 0.12",
            s(0.05, 0.12, 0.0, 0.0, 0.0),
            false,
        ),
        m(
            "nomoto2 T2/T1 0.1 T3/T1 0.25",
            s(0.1, 0.25, 0.0, 0.0, 0.0),
            false,
        ),
        m("norrbin n3 3000 s^2", s(0.0, 0.0, 3000.0, 0.0, 0.0), false),
        m(
            "norrbin n3 30000 s^2",
            s(0.0, 0.0, 30000.0, 0.0, 0.0),
            false,
        ),
        m("dead band 0.5 deg", s(0.0, 0.0, 0.0, 0.5, 0.0), false),
        m("dead band 1 deg", s(0.0, 0.0, 0.0, 1.0, 0.0), false),
        m("backlash 0.5 deg", s(0.0, 0.0, 0.0, 0.0, 0.5), false),
        m("backlash 1 deg", s(0.0, 0.0, 0.0, 0.0, 1.0), false),
        m("fixed-gain autopilot", s(0.0, 0.0, 0.0, 0.0, 0.0), true),
        m(
            "all at the upper strength",
            s(0.1, 0.25, 30000.0, 1.0, 1.0),
            true,
        ),
        m(
            "KVLCC2 MMG 120 m",
            StructureConfig {
                hull: HullModel::Kvlcc2Mmg,
                mmg_length_m: 120.0,
                ..StructureConfig::default()
            },
            false,
        ),
        m(
            "Mariner 120 m",
            StructureConfig {
                hull: HullModel::Mariner,
                mmg_length_m: 120.0,
                ..StructureConfig::default()
            },
            false,
        ),
    ]
}

/// A ship drawn from the family's documented ranges (uniform): T2/T1 in [0, 0.1], T3/T1 in
/// [0, 0.25], n3 in [0, 30000] s^2, dead band and backlash in [0, 1] deg, and an autopilot
/// with fixed gains one time in two. Each nuisance is present (drawn) with probability 1/2,
/// so the first-order ship and every one alone stay in the draw.
pub fn draw_family_member(rng: &mut impl rand::Rng) -> FamilyMember {
    let mut draw = |hi: f64| -> f64 {
        let on: bool = rng.gen();
        let x: f64 = rng.gen();
        if on {
            hi * x
        } else {
            0.0
        }
    };
    let t2 = draw(0.1);
    let t2 = if t2 > 0.0 { t2.max(0.005) } else { 0.0 };
    let structure = StructureConfig {
        nomoto_t2_ratio: t2,
        nomoto_t3_ratio: draw(0.25),
        norrbin_n3_s2: draw(30000.0),
        rudder_dead_band_deg: draw(1.0),
        rudder_backlash_deg: draw(1.0),
        ..StructureConfig::default()
    };
    FamilyMember {
        name: "drawn",
        structure,
        fixed_gain_autopilot: rng.gen(),
    }
}

/// Everything one simulated ship needs: the ship (its true particulars default to the
/// nominal ones), its servo, sensors and autopilot, the sea and the simulation set-up. Cloned
/// from [`crate::config::Config::sim`] or built by hand in tests.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SimConfig {
    /// The ship model and its nominal parameters.
    pub ship: ShipConfig,
    /// The rudder servo.
    pub servo: ServoConfig,
    /// Sensor rates and noise.
    pub sensors: SensorConfig,
    /// The simulated heading autopilot.
    pub autopilot: AutopilotConfig,
    /// Environmental disturbances per sea state.
    pub sea: SeaConfig,
    /// Simulation set-up.
    pub simulation: SimulationConfig,
    /// The ship's structure beyond the first-order model (a scenario may override it).
    pub structure: StructureConfig,
}

impl SimConfig {
    /// Checks every section the simulator reads.
    pub fn check(&self) -> Result<(), ConfigError> {
        self.ship.check()?;
        self.servo.check()?;
        self.sensors.check()?;
        self.autopilot.check()?;
        self.sea.check()?;
        self.simulation.check()?;
        self.structure.check()?;
        Ok(())
    }
}
