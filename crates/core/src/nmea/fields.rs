//! The fields of the sentences the `nmea` crate does not parse (HDG, HTD), plain numbers,
//! and a sentence's value before its time is known.

use super::Reject;
use crate::angle::{deg, wrap_2pi};
use crate::wire::{Input, Scalar, StateValue, Stream};

/// A sentence's value before its time is known.
pub(super) enum Value {
    Heading(f64),
    Rudder(f64),
    Speed(f64),
    Autopilot(&'static str, Option<f64>),
}

impl Value {
    /// The stream whose time this value's line carries (an HTD's state and target share it).
    pub(super) fn stream(&self) -> Stream {
        match self {
            Value::Heading(_) => Stream::Heading,
            Value::Rudder(_) => Stream::Rudder,
            Value::Speed(_) => Stream::Speed,
            Value::Autopilot(..) => Stream::AutopilotState,
        }
    }

    /// The samples of this value at `t`, appended to `out`.
    pub(super) fn push(self, t: f64, out: &mut Vec<Input>) {
        let sc = |value: f64| Scalar { t, value };
        match self {
            Value::Heading(v) => out.push(Input::Heading(sc(v))),
            Value::Rudder(v) => out.push(Input::Rudder(sc(v))),
            Value::Speed(v) => out.push(Input::Speed(sc(v))),
            Value::Autopilot(state, target) => {
                out.push(Input::AutopilotState(StateValue {
                    t,
                    value: state.to_string(),
                }));
                if let Some(v) = target {
                    out.push(Input::TargetHeading(sc(v)));
                }
            }
        }
    }
}

/// A heading in [0, 360] degrees to [0, 2 pi) radians (360 is north).
pub(super) fn heading_rad(d: f64) -> Result<f64, Reject> {
    if d.is_finite() && (0.0..=360.0).contains(&d) {
        Ok(wrap_2pi(deg(d)))
    } else {
        Err(Reject::OutOfRange)
    }
}

/// HDT: heading true [deg], `T`; read in double precision (the `nmea` crate's is single).
pub(super) fn hdt(data: &str) -> Result<f64, Reject> {
    let f: Vec<&str> = data.split(',').collect();
    if f.len() < 2 || !f[1].starts_with('T') {
        return Err(Reject::BadField);
    }
    heading_rad(number(f[0])?.ok_or(Reject::NoValue)?)
}

/// THS: heading true [deg], mode indicator. Only `A` (autonomous: measured) is a heading;
/// `E` (estimated, dead reckoning), `M` (manual input), `S` (simulator) and `V` (not valid)
/// are rejected as a status, an empty or unknown mode as a bad field.
pub(super) fn ths(data: &str) -> Result<f64, Reject> {
    let f: Vec<&str> = data.split(',').collect();
    match f.get(1).copied() {
        Some("A") => {}
        Some("E" | "M" | "S" | "V") => return Err(Reject::Status),
        _ => return Err(Reject::BadField),
    }
    heading_rad(number(f[0])?.ok_or(Reject::NoValue)?)
}

/// A numeric field: empty is `None`; anything but a plain decimal (digits, one point, a
/// leading sign) is a bad field (Rust's parser would take `inf`, `NaN`, `1e3`).
pub(super) fn number(s: &str) -> Result<Option<f64>, Reject> {
    if s.is_empty() {
        return Ok(None);
    }
    let digits = s.strip_prefix(['-', '+']).unwrap_or(s);
    let ok = !digits.is_empty()
        && digits.bytes().all(|b| b.is_ascii_digit() || b == b'.')
        && digits.bytes().filter(|b| *b == b'.').count() <= 1
        && digits.bytes().any(|b| b.is_ascii_digit());
    if !ok {
        return Err(Reject::BadField);
    }
    s.parse::<f64>().map(Some).map_err(|_| Reject::BadField)
}

/// Each field of `data` at `idx` (when present) is empty or a plain decimal.
pub(super) fn plain_numbers(data: &str, idx: &[usize]) -> Result<(), Reject> {
    let f: Vec<&str> = data.split(',').collect();
    for i in idx {
        if let Some(x) = f.get(*i) {
            number(x)?;
        }
    }
    Ok(())
}

/// An east/west-signed angle: value and `E` (+) or `W` (-); an empty pair is `None`.
fn east_west(v: &str, dir: &str) -> Result<Option<f64>, Reject> {
    match (number(v)?, dir) {
        (None, "") => Ok(None),
        (None, _) => Err(Reject::BadField),
        (Some(x), _) if !(0.0..=180.0).contains(&x) => Err(Reject::OutOfRange),
        (Some(x), "E") => Ok(Some(x)),
        (Some(x), "W") => Ok(Some(-x)),
        (Some(_), _) => Err(Reject::BadField),
    }
}

/// HDG: magnetic sensor heading, deviation, E/W, variation, E/W. True heading = sensor +
/// deviation + variation (east positive). No deviation: 0 (a compensated compass); no
/// variation: no true heading.
pub(super) fn hdg(data: &str) -> Result<f64, Reject> {
    let f: Vec<&str> = data.split(',').collect();
    if f.len() < 5 {
        return Err(Reject::BadField);
    }
    let sensor = number(f[0])?.ok_or(Reject::NoValue)?;
    if !(0.0..=360.0).contains(&sensor) {
        return Err(Reject::OutOfRange);
    }
    let deviation = east_west(f[1], f[2])?.unwrap_or(0.0);
    let variation = east_west(f[3], f[4])?.ok_or(Reject::NoValue)?;
    Ok(wrap_2pi(deg(sensor + deviation + variation)))
}

/// HTD (heading/track control data, IEC 61162-1): the autopilot's state and its
/// heading-to-steer (true) when given. Fields (0-based): 0 override (A in use), 3 steering
/// mode, 9 commanded heading-to-steer [deg], 12 heading reference (T/M).
pub(super) fn htd(data: &str) -> Result<(&'static str, Option<f64>), Reject> {
    let f: Vec<&str> = data.split(',').collect();
    if f.len() < 13 {
        return Err(Reject::BadField);
    }
    let mode = match f[3] {
        "" => return Err(Reject::NoValue),
        "S" | "H" => "auto",
        "T" => "route",
        "M" => "standby",
        "R" => "directControl",
        _ => return Err(Reject::BadField),
    };
    let state = match f[0] {
        "A" => "standby",
        "V" | "" => mode,
        _ => return Err(Reject::BadField),
    };
    let target = match number(f[9])? {
        None => None,
        Some(d) => {
            if f[12] != "T" {
                // A magnetic heading-to-steer cannot be made true here.
                return Err(Reject::BadField);
            }
            Some(heading_rad(d)?)
        }
    };
    Ok((state, target))
}
