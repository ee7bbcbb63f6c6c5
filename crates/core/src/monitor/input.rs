//! Input validation, rejection counters and the latest value of every stream.
//!
//! Every sample is checked before it touches any state: `t` finite and in order on its stream
//! ([`order`]), the value finite and physically
//! plausible (heading and target in [0, 2 pi), |rudder| below `input.max-rudder-deg`, speed in
//! [-5, `input.max-speed-mps`], design displacement in (0, 1e9] kg). A rejected sample is counted by stream and reason, logged once
//! per burst (the first, then at every power of two), and otherwise ignored: it never reaches
//! a test record or the FFT.
//!
//! Memory is fixed: counters are arrays indexed by stream and reason; the latest value of each
//! stream is one slot.
//!
//! ## Clock steps
//!
//! Each stream's time is checked by [`crate::timeline::Clocks`] (duplicates, time going
//! backwards, jumps ahead beyond `input.time-jump-s`, re-synchronisation after
//! `input.resync-samples` consistent samples); [`order`] turns its verdict into a counted
//! rejection.
//!
//! The monitor aborts a test under way on a re-synchronisation ("clock step") and moves its
//! time-based state (scheduler interval, steady course) to the new timeline.

use crate::timeline::{Clocks, Jump, Order};
use crate::wire::{Input, Stream};
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
    /// `t` is ahead of the stream's last accepted sample by more than `input.time-jump-s`.
    TimeJump,
}

impl RejectReason {
    /// Every reason, in counter order.
    pub const ALL: [RejectReason; 6] = [
        RejectReason::Malformed,
        RejectReason::NotFinite,
        RejectReason::OutOfRange,
        RejectReason::OutOfOrder,
        RejectReason::Duplicate,
        RejectReason::TimeJump,
    ];
    /// Name for logs and the stats output.
    pub fn name(self) -> &'static str {
        match self {
            RejectReason::Malformed => "malformed",
            RejectReason::NotFinite => "not_finite",
            RejectReason::OutOfRange => "out_of_range",
            RejectReason::OutOfOrder => "out_of_order",
            RejectReason::Duplicate => "duplicate",
            RejectReason::TimeJump => "time_jump",
        }
    }
    fn index(self) -> usize {
        match self {
            RejectReason::Malformed => 0,
            RejectReason::NotFinite => 1,
            RejectReason::OutOfRange => 2,
            RejectReason::OutOfOrder => 3,
            RejectReason::Duplicate => 4,
            RejectReason::TimeJump => 5,
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
    rejected: [[u64; 6]; 6],
    resyncs: [u64; 6],
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
    /// Re-synchronisations of `stream` on a new timeline (clock steps).
    pub fn resyncs(&self, stream: Stream) -> u64 {
        self.resyncs[stream.index()]
    }
    pub(crate) fn count_resync(&mut self, stream: Stream) {
        self.resyncs[stream.index()] += 1;
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
            o.insert("resyncs".into(), self.resyncs(s).into());
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
    let _ = latest; // the order in time is the clocks' ([`order`])
    Ok(())
}

/// The place of a sample of `stream` at `t` after the stream's last accepted `last`
/// ([`Clocks::check`], with `input.time-jump-s` and `input.resync-samples`), or its rejection.
pub fn order(
    clocks: &mut Clocks,
    stream: Stream,
    t: f64,
    last: Option<f64>,
    jump_s: f64,
    resync: u32,
) -> Result<Order, Rejection> {
    let (reason, detail) = match clocks.check(stream, t, last, jump_s, resync) {
        Ok(o) => return Ok(o),
        Err(Jump::Duplicate) => (RejectReason::Duplicate, format!("t = {t} seen already")),
        Err(Jump::Backwards { last, samples }) => (
            RejectReason::OutOfOrder,
            format!("t = {t} before last accepted {last} ({samples} of {resync} to re-synchronise)"),
        ),
        Err(Jump::Ahead { last, samples }) => (
            RejectReason::TimeJump,
            format!("t = {t} is {:.1} s after last accepted {last} ({samples} of {resync} to re-synchronise)", t - last),
        ),
    };
    Err(Rejection {
        stream,
        reason,
        detail,
    })
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
    use crate::wire::{Scalar, StateValue};

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
        assert_eq!(r(&h(1.0, std::f64::consts::TAU - 0.003)), Ok(()));
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
