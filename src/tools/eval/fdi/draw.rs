//! The draw of one run of a scenario: the ship's operating point, its faults and, for the
//! envelope and commissioning scenarios, the change of operating point and the fault's onset.

use super::scenarios::{Change, FdiScenario, Onset, ScenarioSet, SeaChange};
use crate::config::Config;
use helmwatch_core::model::SeaState;
use helmwatch_core::sim::{Fault, Scenario};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// The drawn change of operating point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DrawnChange {
    /// The new speed [m/s] (`None`: unchanged).
    pub speed_mps: Option<f64>,
    /// The new, declared displacement [t] (`None`: unchanged, nothing declared).
    pub displacement_t: Option<f64>,
    /// The new sea state (`None`: unchanged).
    pub sea: Option<SeaState>,
}

/// One run as drawn.
#[derive(Debug, Clone)]
pub struct Drawn {
    /// The simulated ship.
    pub scenario: Scenario,
    /// The configuration (its nominal displacement the drawn D, its scheduler off).
    pub cfg: Config,
    /// Faults that arise during the run (at the onset).
    pub late: Vec<Fault>,
    /// The change at commissioning's end.
    pub change: Option<DrawnChange>,
    /// Commissioning scenarios: the onset's test of the ship (1 is the first).
    pub onset_test: Option<usize>,
}

/// A scenario's range, stated on the family's box (4..10 m/s, 4000..10000 t: the default
/// `ship.*-range`, docs/architecture.md "The model and its units"), mapped linearly onto the
/// configured box (a vessel of another class, `train --vessel`); the same numbers when the
/// configured box is the family's.
fn on_box(range: [f64; 2], family: [f64; 2], configured: [f64; 2]) -> [f64; 2] {
    if configured == family {
        return range;
    }
    let k = (configured[1] - configured[0]) / (family[1] - family[0]);
    range.map(|x| configured[0] + (x - family[0]) * k)
}

/// Draws the run's ship and fault list. With `corner = Some(k)` the ship sits at corner
/// `k % 4` of the scenario's (u, D) box (low/high speed, low/high displacement) instead of a
/// random point. The classic draws (u, D, drift, the ship's seed) come first, so the classic
/// runs are the same whatever else a scenario draws after them.
pub fn draw(
    cfg: &Config,
    sc: &FdiScenario,
    sea: SeaState,
    seed: u64,
    corner: Option<usize>,
) -> Result<Drawn, String> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let family = helmwatch_core::model::ShipConfig::default();
    let [u_lo, u_hi] = sc.speed_mps.map_or(cfg.ship.speed_range_mps, |r| {
        on_box(r, family.speed_range_mps, cfg.ship.speed_range_mps)
    });
    let [d_lo, d_hi] = sc
        .displacement_t
        .map_or(cfg.ship.displacement_range_t, |r| {
            on_box(
                r,
                family.displacement_range_t,
                cfg.ship.displacement_range_t,
            )
        });
    let mut u = rng.gen_range(u_lo..=u_hi);
    let mut d = rng.gen_range(d_lo..=d_hi);
    if let Some(k) = corner {
        u = if k % 2 == 0 { u_lo } else { u_hi };
        d = if (k / 2) % 2 == 0 { d_lo } else { d_hi };
    }
    let mut faults = Vec::new();
    let mut late = Vec::new();
    if let Some(f) = sc.fault {
        let f = f.parse::<Fault>().map_err(|e| e.to_string())?;
        // With commissioning, the fault appears once the vessel is commissioned; the other
        // sets place it themselves.
        if cfg.fdi.commissioning_tests > 0 || sc.group != ScenarioSet::Classic {
            late.push(f);
        } else {
            faults.push(f);
        }
    }
    if sc.drift {
        let v = rng.gen_range(0.25..=1.0) * if rng.gen_bool(0.5) { 1.0 } else { -1.0 };
        let spec = format!("heading_drift_deg_per_min:{v}@0");
        faults.push(spec.parse::<Fault>().map_err(|e| e.to_string())?);
    }
    let mut cfg = cfg.clone();
    cfg.ship.nominal_displacement_t = d;
    cfg.scheduler.enabled = false;
    let scenario = Scenario {
        speed_mps: u,
        displacement_t: d,
        sea,
        faults,
        seed: rng.gen(),
    };
    let change = match sc.change {
        Some(c) => Some(draw_change(
            &mut rng,
            &c,
            u,
            d,
            cfg.ship.speed_range_mps,
            sea,
        )?),
        None => None,
    };
    let onset_test = match sc.onset {
        Onset::InCommissioning([lo, hi]) => Some(rng.gen_range(lo..=hi)),
        _ => None,
    };
    Ok(Drawn {
        scenario,
        cfg,
        late,
        change,
        onset_test,
    })
}

/// Draws a change from (u [m/s], D [t]): a magnitude of `c.speed_mps`, its sign among those
/// that keep the speed in `range`, a loading fraction in `c.loading`, and the sea one state
/// above or below `sea` when it rises or falls (no draw).
fn draw_change(
    rng: &mut ChaCha8Rng,
    c: &Change,
    u: f64,
    d: f64,
    [lo, hi]: [f64; 2],
    sea: SeaState,
) -> Result<DrawnChange, String> {
    let speed_mps = match c.speed_mps {
        [] => None,
        sizes => {
            let m = sizes[rng.gen_range(0..sizes.len())];
            let (up, down) = (u + m <= hi + 1e-9, u - m >= lo - 1e-9);
            let sign = match (up, down) {
                (true, true) => {
                    if rng.gen_bool(0.5) {
                        1.0
                    } else {
                        -1.0
                    }
                }
                (true, false) => 1.0,
                (false, true) => -1.0,
                (false, false) => {
                    return Err(format!(
                        "a speed change of {m} m/s from {u:.2} m/s leaves {lo}..{hi} m/s"
                    ))
                }
            };
            Some(u + sign * m)
        }
    };
    let displacement_t = c.loading.map(|[a, b]| d * (1.0 + rng.gen_range(a..=b)));
    let sea = match (c.sea, sea) {
        (SeaChange::Stays, _) => None,
        (SeaChange::Rises, SeaState::Calm) => Some(SeaState::Moderate),
        (SeaChange::Rises, SeaState::Moderate | SeaState::Rough) => Some(SeaState::Rough),
        (SeaChange::Falls, SeaState::Calm | SeaState::Moderate) => Some(SeaState::Calm),
        (SeaChange::Falls, SeaState::Rough) => Some(SeaState::Moderate),
    };
    Ok(DrawnChange {
        speed_mps,
        displacement_t,
        sea,
    })
}
