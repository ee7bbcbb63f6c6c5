//! Input validation, rejection counters and the latest value of every stream.
//!
//! Every sample is checked before it touches any state: `t` finite and in order on its stream
//! ([`Clocks`]), the value finite and physically
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
//! Ship sensors step their clocks (a GNSS time fix, a reboot to the epoch), and a single
//! sample can carry a wild time. Per stream, against its last accepted `t`:
//! - `t` equal: a duplicate, rejected.
//! - `t` later by at most `input.time-jump-s`: in order, accepted.
//! - `t` later by more (a jump ahead) or earlier (time going backwards): rejected
//!   (`time_jump` or `out_of_order`) and remembered as the start of a candidate timeline.
//!   Samples that continue that candidate (increasing, each within `input.time-jump-s` of the
//!   previous one) extend it; the `input.resync-samples`-th is accepted and the stream
//!   *re-synchronises* on the new timeline (counted in `resyncs`). A lone outlier never gets
//!   there: the next in-order sample drops the candidate.
//!
//! The monitor aborts a test under way on a re-synchronisation ("clock step") and moves its
//! time-based state (scheduler interval, steady course) to the new timeline.

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
    let _ = latest; // the order in time is the clocks' ([`Clocks::check`])
    Ok(())
}

/// A sample's place in its stream's time, when [`Clocks::check`] lets it in.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Order {
    /// In order after the stream's last accepted sample (or the stream's first).
    Next,
    /// The stream re-synchronised on a new timeline: its last accepted sample was at `from_t`.
    Resync {
        /// The last accepted `t` of the old timeline [s].
        from_t: f64,
    },
}

/// A candidate timeline: samples rejected as out of order or ahead that follow each other.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Candidate {
    last_t: f64,
    samples: u32,
}

/// Per-stream clock-step detection (module documentation). Fixed size.
#[derive(Debug, Clone, Default)]
pub struct Clocks {
    candidates: [Option<Candidate>; 6],
}

impl Clocks {
    /// Places a sample of `stream` at `t` (finite) after the stream's last accepted `last`:
    /// `jump_s` is `input.time-jump-s`, `resync` is `input.resync-samples`.
    pub fn check(
        &mut self,
        stream: Stream,
        t: f64,
        last: Option<f64>,
        jump_s: f64,
        resync: u32,
    ) -> Result<Order, Rejection> {
        let slot = &mut self.candidates[stream.index()];
        let Some(last) = last else {
            *slot = None;
            return Ok(Order::Next);
        };
        if t == last {
            return Err(Rejection {
                stream,
                reason: RejectReason::Duplicate,
                detail: format!("t = {t} seen already"),
            });
        }
        if t > last && t - last <= jump_s {
            *slot = None;
            return Ok(Order::Next);
        }
        let continues = slot.is_some_and(|c| t > c.last_t && t - c.last_t <= jump_s);
        let samples = if continues {
            slot.map_or(1, |c| c.samples + 1)
        } else {
            1
        };
        if samples >= resync {
            *slot = None;
            return Ok(Order::Resync { from_t: last });
        }
        *slot = Some(Candidate { last_t: t, samples });
        let (reason, detail) = if t < last {
            (
                RejectReason::OutOfOrder,
                format!(
                    "t = {t} before last accepted {last} ({samples} of {resync} to re-synchronise)"
                ),
            )
        } else {
            (
                RejectReason::TimeJump,
                format!("t = {t} is {:.1} s after last accepted {last} ({samples} of {resync} to re-synchronise)", t - last),
            )
        };
        Err(Rejection {
            stream,
            reason,
            detail,
        })
    }
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

    /// Feeds `ts` to one stream's clock as a driver would (storing what is accepted) and
    /// returns each verdict: `Ok(true)` a resync, `Ok(false)` in order, `Err(reason)`.
    fn feed(ts: &[f64]) -> Vec<Result<bool, RejectReason>> {
        let mut c = Clocks::default();
        let mut last = None;
        ts.iter()
            .map(|&t| match c.check(Stream::Heading, t, last, 60.0, 3) {
                Ok(o) => {
                    last = Some(t);
                    Ok(matches!(o, Order::Resync { .. }))
                }
                Err(r) => Err(r.reason),
            })
            .collect()
    }

    #[test]
    fn rejects_time_going_backwards_and_duplicates() {
        use RejectReason::*;
        assert_eq!(
            feed(&[10.0, 9.9, 10.0, 10.1]),
            vec![Ok(false), Err(OutOfOrder), Err(Duplicate), Ok(false)]
        );
        // Other streams keep their own clocks.
        let mut c = Clocks::default();
        assert!(c.check(Stream::Heading, 10.0, Some(9.0), 60.0, 3).is_ok());
        assert!(c.check(Stream::Rudder, 5.0, Some(4.9), 60.0, 3).is_ok());
    }

    #[test]
    fn a_lone_future_sample_is_rejected_and_forgotten() {
        use RejectReason::*;
        assert_eq!(
            feed(&[10.0, 1e9, 10.1, 1e9 + 0.1, 10.2, 10.3]),
            vec![
                Ok(false),
                Err(TimeJump),
                Ok(false),
                Err(TimeJump),
                Ok(false),
                Ok(false)
            ]
        );
    }

    #[test]
    fn a_clock_step_resynchronises_after_a_consistent_run() {
        use RejectReason::*;
        // An hour back: two rejected, the third of the new timeline accepted as a resync.
        assert_eq!(
            feed(&[3600.0, 3600.1, 0.2, 0.3, 0.4, 0.5]),
            vec![
                Ok(false),
                Ok(false),
                Err(OutOfOrder),
                Err(OutOfOrder),
                Ok(true),
                Ok(false)
            ]
        );
        // An hour ahead, the same.
        assert_eq!(
            feed(&[0.0, 3600.0, 3600.1, 3600.2, 3600.3]),
            vec![Ok(false), Err(TimeJump), Err(TimeJump), Ok(true), Ok(false)]
        );
        // A run broken by an in-order sample starts again.
        assert_eq!(
            feed(&[0.0, 3600.0, 3600.1, 0.1, 3600.2, 3600.3, 3600.4]),
            vec![
                Ok(false),
                Err(TimeJump),
                Err(TimeJump),
                Ok(false),
                Err(TimeJump),
                Err(TimeJump),
                Ok(true)
            ]
        );
        // A gap within the limit is no jump.
        assert_eq!(feed(&[0.0, 59.0]), vec![Ok(false), Ok(false)]);
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
