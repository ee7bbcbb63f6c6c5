//! A recording's time trace for `helmwatch plot`: one vessel's heading, rudder and
//! excitation against the ship's time.
//!
//! [`Trace::collect`] takes any iterator of [`RecordLine`] results, so the format a recording
//! is stored in is the reader's business: [`json_lines`] reads the JSON lines of `helmwatch
//! simulate` and `ship --record`; a reader of another format (MCAP) yields the same lines.
//! Lines on other keys or vessels are skipped; a payload that does not decode is counted in
//! [`Trace::skipped`].

use super::{data, PlotError};
use helmwatch_core::angle::wrap_pi;
use helmwatch_core::wire::{
    vessel_key, Excitation, ExcitationMode, Keys, RecordLine, Scalar, Stream,
};

/// Most points a series keeps: longer series are reduced to the minimum and maximum of
/// equal time buckets (the shape survives, the SVG stays small).
pub const MAX_POINTS: usize = 4000;

/// One vessel's streams from a recording, times in s, angles in rad.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Trace {
    /// The vessel.
    pub vessel: String,
    /// Heading, unwrapped from its first sample (continuous across north) [rad].
    pub heading: Vec<(f64, f64)>,
    /// Rudder angle [rad].
    pub rudder: Vec<(f64, f64)>,
    /// Excitation value [rad] (0 when its mode is `none`).
    pub excitation: Vec<(f64, f64)>,
    /// Lines of the vessel whose payload did not decode.
    pub skipped: u64,
}

/// The lines of a JSON-lines recording; an unreadable line is an error naming it.
pub fn json_lines(text: &str) -> impl Iterator<Item = Result<RecordLine, PlotError>> + '_ {
    text.lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty())
        .map(|(i, l)| {
            serde_json::from_str::<RecordLine>(l).map_err(|e| {
                data(format!(
                    "line {}: not a {{\"key\", \"payload\"}}: {e}",
                    i + 1
                ))
            })
        })
}

/// The messages of an MCAP recording (the daemon's, `daemon.record`) as recording lines; a
/// message whose payload is not JSON, or a damaged file, is an error naming it.
pub fn mcap_lines(bytes: &[u8]) -> impl Iterator<Item = Result<RecordLine, PlotError>> + '_ {
    mcap::io::MessageReader::new(bytes)
        .enumerate()
        .map(|(i, m)| {
            let m = m.map_err(|e| data(format!("MCAP message {}: {e}", i + 1)))?;
            let payload = serde_json::from_slice(&m.data).map_err(|e| {
                data(format!(
                    "MCAP message {} on {}: not JSON: {e}",
                    i + 1,
                    m.channel.topic
                ))
            })?;
            Ok(RecordLine {
                key: m.channel.topic.clone(),
                payload,
            })
        })
}

impl Trace {
    /// The trace of `vessel` (default: the vessel of the first `vessels/<v>/...` key).
    /// Errors: a line the source could not read, or no heading of the vessel.
    pub fn collect(
        lines: impl IntoIterator<Item = Result<RecordLine, PlotError>>,
        vessel: Option<&str>,
    ) -> Result<Trace, PlotError> {
        let mut trace = Trace::default();
        let mut keys: Option<Keys> = vessel.map(Keys::new);
        if let Some(v) = vessel {
            trace.vessel = v.to_string();
        }
        for line in lines {
            let line = line?;
            if keys.is_none() {
                if let Some(k) = vessel_key::split(&line.key) {
                    trace.vessel = k.vessel.to_string();
                    keys = Some(Keys::new(k.vessel));
                }
            }
            let Some(k) = keys.as_ref() else { continue };
            if line.key == k.excitation() {
                match serde_json::from_value::<Excitation>(line.payload) {
                    Ok(e) => trace.excitation.push((
                        e.t,
                        if e.mode == ExcitationMode::None {
                            0.0
                        } else {
                            e.value
                        },
                    )),
                    Err(_) => trace.skipped += 1,
                }
                continue;
            }
            let stream = k.stream_of(&line.key);
            if !matches!(stream, Some(Stream::Heading | Stream::Rudder)) {
                continue;
            }
            let Ok(s) = serde_json::from_value::<Scalar>(line.payload) else {
                trace.skipped += 1;
                continue;
            };
            if !(s.t.is_finite() && s.value.is_finite()) {
                trace.skipped += 1;
                continue;
            }
            if stream == Some(Stream::Heading) {
                let v = match trace.heading.last() {
                    Some(&(_, prev)) => prev + wrap_pi(s.value - prev),
                    None => s.value,
                };
                trace.heading.push((s.t, v));
            } else {
                trace.rudder.push((s.t, s.value));
            }
        }
        if trace.heading.is_empty() {
            return Err(data(format!(
                "no heading of vessel {:?} in the recording",
                trace.vessel
            )));
        }
        Ok(trace)
    }
}

/// `points` reduced to at most about [`MAX_POINTS`]: the first and last sample of each of
/// `MAX_POINTS / 2` equal time buckets' minimum and maximum, in time order.
pub fn decimate(points: &[(f64, f64)]) -> Vec<(f64, f64)> {
    let buckets = MAX_POINTS / 2;
    if points.len() <= MAX_POINTS {
        return points.to_vec();
    }
    let per = points.len().div_ceil(buckets);
    let mut out = Vec::with_capacity(2 * buckets + 2);
    for chunk in points.chunks(per) {
        let (mut lo, mut hi) = (0, 0);
        for (i, p) in chunk.iter().enumerate() {
            if p.1 < chunk[lo].1 {
                lo = i;
            }
            if p.1 > chunk[hi].1 {
                hi = i;
            }
        }
        let (a, b) = if lo <= hi { (lo, hi) } else { (hi, lo) };
        out.push(chunk[a]);
        if b != a {
            out.push(chunk[b]);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn heading_is_unwrapped_and_other_vessels_skipped() {
        let text = [
            r#"{"key":"vessels/a/navigation/headingTrue","payload":{"t":0.0,"value":6.2}}"#,
            r#"{"key":"vessels/b/navigation/headingTrue","payload":{"t":0.0,"value":1.0}}"#,
            r#"{"key":"vessels/a/navigation/headingTrue","payload":{"t":0.1,"value":0.1}}"#,
            r#"{"key":"vessels/a/steering/rudderAngle","payload":{"t":0.1,"value":-0.05}}"#,
            r#"{"key":"vessels/a/steering/autopilot/excitation","payload":{"t":0.1,"mode":"replace","value":0.14,"hold_s":1.0,"test":"x"}}"#,
            r#"{"key":"vessels/a/steering/rudderAngle","payload":{"t":0.2,"value":"bad"}}"#,
        ]
        .join("\n");
        let tr = Trace::collect(json_lines(&text), None).unwrap();
        assert_eq!(tr.vessel, "a");
        assert_eq!(tr.heading.len(), 2);
        // 6.2 -> 0.1 crosses north: +0.183 rad, not -6.1.
        let step = tr.heading[1].1 - tr.heading[0].1;
        assert!((step - (0.1 + 2.0 * std::f64::consts::PI - 6.2)).abs() < 1e-12);
        assert_eq!(tr.rudder, vec![(0.1, -0.05)]);
        assert_eq!(tr.excitation, vec![(0.1, 0.14)]);
        assert_eq!(tr.skipped, 1);
        let b = Trace::collect(json_lines(&text), Some("b")).unwrap();
        assert_eq!(b.heading, vec![(0.0, 1.0)]);
        assert!(Trace::collect(json_lines(&text), Some("c")).is_err());
        assert!(Trace::collect(json_lines("{not json"), None).is_err());
    }

    #[test]
    fn decimation_keeps_the_extremes() {
        let pts: Vec<(f64, f64)> = (0..100_000)
            .map(|i| (i as f64, ((i * 7919) % 1000) as f64))
            .collect();
        let d = decimate(&pts);
        assert!(
            d.len() <= MAX_POINTS + 2 && d.len() > MAX_POINTS / 2,
            "{}",
            d.len()
        );
        assert!(d.windows(2).all(|w| w[0].0 < w[1].0));
        let max = d.iter().map(|p| p.1).fold(f64::MIN, f64::max);
        let min = d.iter().map(|p| p.1).fold(f64::MAX, f64::min);
        assert_eq!((min, max), (0.0, 999.0));
        assert_eq!(decimate(&pts[..10]), pts[..10].to_vec());
    }
}
