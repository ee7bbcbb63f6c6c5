//! Input validation, rejection counters and the latest value of every stream.
//!
//! Every sample is checked before it touches any state: `t` finite and not older than the
//! stream's last accepted sample (equal `t` is a duplicate), the value finite and physically
//! plausible (heading and target in [0, 2 pi), |rudder| below `input.max-rudder-deg`, speed in
//! [-5, `input.max-speed-mps`], design displacement in (0, 1e9] kg). A rejected sample is counted by stream and reason, logged once
//! per burst (the first, then at every power of two), and otherwise ignored: it never reaches
//! a test record or the FFT.
//!
//! Memory is fixed: counters are arrays indexed by stream and reason; the latest value of each
//! stream is one slot.

use crate::core::wire::{Input, Stream};
use std::f64::consts::PI;

/// Largest plausible design displacement [kg] (1e9 kg = 1 million t, above any ship afloat).
pub const MAX_DESIGN_DISPLACEMENT_KG: f64 = 1e9;

/// Why a sample was rejected.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum RejectReason {
    /// The payload did not decode (counted by the driver through `Monitor::count_malformed`).
    Malformed,
    /// `t` or the value is NaN or infinite.
    NotFinite,
    /// The value is outside its physical range (e.g. a heading of 9 rad).
    OutOfRange,
    /// `t` is older than the stream's last accepted sample.
    OutOfOrder,
    /// `t` equals the stream's last accepted sample.
    Duplicate,
}

impl RejectReason {
    /// Every reason, in counter order.
    pub const ALL: [RejectReason; 5] = [
        RejectReason::Malformed,
        RejectReason::NotFinite,
        RejectReason::OutOfRange,
        RejectReason::OutOfOrder,
        RejectReason::Duplicate,
    ];
    /// Name for logs and the stats output.
    pub fn name(self) -> &'static str {
        match self {
            RejectReason::Malformed => "malformed",
            RejectReason::NotFinite => "not_finite",
            RejectReason::OutOfRange => "out_of_range",
            RejectReason::OutOfOrder => "out_of_order",
            RejectReason::Duplicate => "duplicate",
        }
    }
    fn index(self) -> usize {
        match self {
            RejectReason::Malformed => 0,
            RejectReason::NotFinite => 1,
            RejectReason::OutOfRange => 2,
            RejectReason::OutOfOrder => 3,
            RejectReason::Duplicate => 4,
        }
    }
}

/// A rejected sample: which stream, why, and a human-readable detail.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{stream:?} sample rejected ({reason:?}): {detail}")]
pub struct Rejection {
    /// The stream.
    pub stream: Stream,
    /// The reason.
    pub reason: RejectReason,
    /// Detail for the log.
    pub detail: String,
}

/// Accepted and rejected sample counts, by stream and reason. Fixed size.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Counters {
    accepted: [u64; 6],
    rejected: [[u64; 5]; 6],
}

impl Counters {
    /// Samples accepted on `stream`.
    pub fn accepted(&self, stream: Stream) -> u64 {
        self.accepted[stream.index()]
    }
    /// Samples rejected on `stream` for `reason`.
    pub fn rejected(&self, stream: Stream, reason: RejectReason) -> u64 {
        self.rejected[stream.index()][reason.index()]
    }
    /// All rejections, every stream and reason.
    pub fn rejected_total(&self) -> u64 {
        self.rejected.iter().flatten().sum()
    }
    /// Counts one rejection; returns whether it starts or doubles a burst (log it then).
    pub(crate) fn count_rejection(&mut self, stream: Stream, reason: RejectReason) -> bool {
        let c = &mut self.rejected[stream.index()][reason.index()];
        *c += 1;
        c.is_power_of_two()
    }
    pub(crate) fn count_accepted(&mut self, stream: Stream) {
        self.accepted[stream.index()] += 1;
    }
    /// As a JSON object `{stream: {"accepted": n, reason: n, ...}}` for stats and reports.
    pub fn to_json(&self) -> serde_json::Value {
        let mut m = serde_json::Map::new();
        for s in Stream::ALL {
            let mut o = serde_json::Map::new();
            o.insert("accepted".into(), self.accepted(s).into());
            for r in RejectReason::ALL {
                o.insert(r.name().into(), self.rejected(s, r).into());
            }
            m.insert(s.name().into(), serde_json::Value::Object(o));
        }
        serde_json::Value::Object(m)
    }
}

/// The latest accepted sample of each stream.
#[derive(Debug, Clone, Default)]
pub struct Latest {
    /// `(t, heading rad)`.
    pub heading: Option<(f64, f64)>,
    /// `(t, rudder rad)`.
    pub rudder: Option<(f64, f64)>,
    /// `(t, speed m/s)`.
    pub speed: Option<(f64, f64)>,
    /// `(t, engaged in "auto")`.
    pub auto: Option<(f64, bool)>,
    /// `(t, target heading rad)`.
    pub target: Option<(f64, f64)>,
    /// `(t, design displacement kg)`.
    pub design_displacement: Option<(f64, f64)>,
}

impl Latest {
    /// Time of the last accepted sample of `stream`.
    pub fn t(&self, stream: Stream) -> Option<f64> {
        match stream {
            Stream::Heading => self.heading.map(|x| x.0),
            Stream::Rudder => self.rudder.map(|x| x.0),
            Stream::Speed => self.speed.map(|x| x.0),
            Stream::AutopilotState => self.auto.map(|x| x.0),
            Stream::TargetHeading => self.target.map(|x| x.0),
            Stream::DesignDisplacement => self.design_displacement.map(|x| x.0),
        }
    }
}

/// Plausibility limits for [`validate`].
#[derive(Debug, Clone, Copy)]
pub struct Limits {
    /// Largest |rudder| [rad].
    pub max_rudder_rad: f64,
    /// Largest speed [m/s].
    pub max_speed_mps: f64,
}

/// Checks one sample against the stream's last accepted time and the physical ranges.
/// Returns the stream on success; never mutates.
pub fn validate(input: &Input, latest: &Latest, limits: &Limits) -> Result<(), Rejection> {
    let stream = input.stream();
    let reject = |reason, detail: String| {
        Err(Rejection {
            stream,
            reason,
            detail,
        })
    };
    let t = input.t();
    if !t.is_finite() {
        return reject(RejectReason::NotFinite, format!("t = {t}"));
    }
    let value = match input {
        Input::Heading(s)
        | Input::Rudder(s)
        | Input::Speed(s)
        | Input::TargetHeading(s)
        | Input::DesignDisplacement(s) => Some(s.value),
        Input::AutopilotState(_) => None,
    };
    if let Some(v) = value {
        if !v.is_finite() {
            return reject(RejectReason::NotFinite, format!("value = {v}"));
        }
        let ok = match stream {
            Stream::Heading | Stream::TargetHeading => (0.0..2.0 * PI).contains(&v),
            Stream::Rudder => v.abs() <= limits.max_rudder_rad,
            Stream::Speed => (-5.0..=limits.max_speed_mps).contains(&v),
            Stream::AutopilotState => true,
            Stream::DesignDisplacement => v > 0.0 && v <= MAX_DESIGN_DISPLACEMENT_KG,
        };
        if !ok {
            return reject(RejectReason::OutOfRange, format!("value = {v}"));
        }
    }
    if let Input::AutopilotState(s) = input {
        if s.value.is_empty() || s.value.len() > 64 {
            return reject(
                RejectReason::OutOfRange,
                "state must be 1 to 64 characters".into(),
            );
        }
    }
    if let Some(last) = latest.t(stream) {
        if t < last {
            return reject(
                RejectReason::OutOfOrder,
                format!("t = {t} before last accepted {last}"),
            );
        }
        if t == last {
            return reject(RejectReason::Duplicate, format!("t = {t} seen already"));
        }
    }
    Ok(())
}

/// Stores an accepted sample as the latest of its stream.
pub fn store(input: &Input, latest: &mut Latest) {
    match input {
        Input::Heading(s) => latest.heading = Some((s.t, s.value)),
        Input::Rudder(s) => latest.rudder = Some((s.t, s.value)),
        Input::Speed(s) => latest.speed = Some((s.t, s.value)),
        Input::AutopilotState(s) => latest.auto = Some((s.t, s.value == "auto")),
        Input::TargetHeading(s) => latest.target = Some((s.t, s.value)),
        Input::DesignDisplacement(s) => latest.design_displacement = Some((s.t, s.value)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::core::wire::{Scalar, StateValue};

    const LIM: Limits = Limits {
        max_rudder_rad: 0.8,
        max_speed_mps: 30.0,
    };

    fn h(t: f64, v: f64) -> Input {
        Input::Heading(Scalar { t, value: v })
    }

    #[test]
    fn rejects_bad_values_with_reasons() {
        let l = Latest::default();
        let r = |i: &Input| validate(i, &l, &LIM).map_err(|e| e.reason);
        assert_eq!(r(&h(1.0, 9.0)), Err(RejectReason::OutOfRange));
        assert_eq!(r(&h(1.0, -0.1)), Err(RejectReason::OutOfRange));
        assert_eq!(r(&h(1.0, 2.0 * PI)), Err(RejectReason::OutOfRange));
        assert_eq!(r(&h(f64::NAN, 1.0)), Err(RejectReason::NotFinite));
        assert_eq!(r(&h(1.0, f64::INFINITY)), Err(RejectReason::NotFinite));
        assert_eq!(r(&h(1.0, 6.28)), Ok(()));
        let rud = Input::Rudder(Scalar {
            t: 1.0,
            value: 0.81,
        });
        assert_eq!(r(&rud), Err(RejectReason::OutOfRange));
        let st = Input::AutopilotState(StateValue {
            t: 1.0,
            value: String::new(),
        });
        assert_eq!(r(&st), Err(RejectReason::OutOfRange));
    }

    #[test]
    fn rejects_time_going_backwards_and_duplicates() {
        let mut l = Latest::default();
        store(&h(10.0, 1.0), &mut l);
        let r = |i: &Input| validate(i, &l, &LIM).map_err(|e| e.reason);
        assert_eq!(r(&h(9.9, 1.0)), Err(RejectReason::OutOfOrder));
        assert_eq!(r(&h(10.0, 1.0)), Err(RejectReason::Duplicate));
        assert_eq!(r(&h(10.1, 1.0)), Ok(()));
        // Other streams keep their own clocks.
        assert_eq!(r(&Input::Rudder(Scalar { t: 5.0, value: 0.0 })), Ok(()));
    }

    #[test]
    fn bursts_log_at_powers_of_two() {
        let mut c = Counters::default();
        let logged: Vec<bool> = (0..9)
            .map(|_| c.count_rejection(Stream::Heading, RejectReason::NotFinite))
            .collect();
        assert_eq!(
            logged,
            vec![true, true, false, true, false, false, false, true, false]
        );
        assert_eq!(c.rejected(Stream::Heading, RejectReason::NotFinite), 9);
        assert_eq!(c.rejected_total(), 9);
    }
}
