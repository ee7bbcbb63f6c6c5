//! Recording: what a simulated ship publishes, as JSON lines, without a daemon.
//!
//! One line per publication, `{"key": "vessels/<vessel>/<path>", "payload": {...}}`
//! ([`crate::wire::RecordLine`]), in lockstep order within a tick (heading last). No excitation
//! is received, so the autopilot steers on its own command throughout. The output depends only
//! on the configuration and the scenario (seed included): same inputs, same bytes.

use super::{Scenario, Ship, SimError};
use crate::config::check_vessel_name;
use crate::sim::config::SimConfig;
use crate::wire::{Input, Keys, RecordLine, Stream};
use std::io::Write;

/// Longest recording accepted [s] (a year of ship time).
const MAX_DURATION_S: f64 = 366.0 * 86400.0;

/// Writes `duration_s` of what the ship publishes as JSON lines {"key": .., "payload": ..}
/// (wire::RecordLine, keys from wire::Keys::new(vessel)), no daemon (excitation none). Returns lines written.
///
/// The ticks recorded are those at `start + k dt` for `k < round(duration_s / dt)`.
pub fn record<W: Write>(
    cfg: &SimConfig,
    scenario: &Scenario,
    duration_s: f64,
    vessel: &str,
    out: W,
) -> Result<u64, SimError> {
    check_vessel_name("vessel", vessel)?;
    if !(duration_s.is_finite() && (0.0..=MAX_DURATION_S).contains(&duration_s)) {
        return Err(SimError::Scenario {
            field: "duration_s",
            value: duration_s,
            allowed: "[0, 31622400] s",
        });
    }
    let mut ship = Ship::new(cfg, scenario)?;
    let keys = Keys::new(vessel);
    let mut key_of = [const { String::new() }; 6];
    for s in Stream::ALL {
        key_of[s.index()] = keys.stream(s);
    }
    let ticks = (duration_s * cfg.sensors.rate_hz).round() as u64;
    let mut w = std::io::BufWriter::new(out);
    let mut buf: Vec<Input> = Vec::with_capacity(8);
    let mut lines = 0u64;
    for _ in 0..ticks {
        buf.clear();
        ship.publish(&mut buf);
        for input in &buf {
            let line = RecordLine {
                key: key_of[input.stream().index()].clone(),
                payload: input.payload(),
            };
            serde_json::to_writer(&mut w, &line)?;
            w.write_all(b"\n")?;
            lines += 1;
        }
        ship.step();
    }
    w.flush()?;
    Ok(lines)
}
