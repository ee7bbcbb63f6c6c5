//! Per-stream clock-step detection: is a sample's `t` the next one of its stream, a duplicate,
//! time going backwards, or a jump ahead, and when has a stream moved to a new timeline?
//!
//! Ship sensors step their clocks (a GNSS time fix, a reboot to the epoch), and a single
//! sample can carry a wild time. Per stream, against its last accepted `t`:
//! - `t` equal: a duplicate, rejected.
//! - `t` later by at most the jump bound: in order, accepted.
//! - `t` later by more (a jump ahead) or earlier (time going backwards): rejected
//!   (`time_jump` or `out_of_order`) and remembered as the start of a candidate timeline.
//!   Samples that continue that candidate (increasing, each within the jump bound of the
//!   previous one) extend it; the `resync`-th is accepted and the stream
//!   *re-synchronises* on the new timeline. A lone outlier never gets there: the next
//!   in-order sample drops the candidate.
//!
//! One rule for both its users: the monitor's input validation (`input.time-jump-s`,
//! `input.resync-samples`) and the NMEA bridge's check of tag-block times
//! (`bridge.time-jump-s`, `bridge.resync-samples`).

use crate::wire::Stream;

/// Why [`Clocks::check`] did not let a sample in.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Jump {
    /// `t` equal to the last accepted.
    Duplicate,
    /// `t` before the last accepted (`last`); `samples` of a candidate timeline so far.
    Backwards {
        /// The stream's last accepted `t` [s].
        last: f64,
        /// Samples of the candidate timeline, this one included.
        samples: u32,
    },
    /// `t` later than the last accepted (`last`) by more than the bound.
    Ahead {
        /// The stream's last accepted `t` [s].
        last: f64,
        /// Samples of the candidate timeline, this one included.
        samples: u32,
    },
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

/// Per-stream clock-step detection (module documentation). Fixed size: one candidate per
/// stream.
#[derive(Debug, Clone, Default)]
pub struct Clocks {
    candidates: [Option<Candidate>; Stream::ALL.len()],
}

impl Clocks {
    /// Places a sample of `stream` at `t` (finite) after the stream's last accepted `last`:
    /// within `jump_s` after it is in order; otherwise the sample starts or extends a
    /// candidate timeline, whose `resync`-th sample is accepted as a re-synchronisation.
    pub fn check(
        &mut self,
        stream: Stream,
        t: f64,
        last: Option<f64>,
        jump_s: f64,
        resync: u32,
    ) -> Result<Order, Jump> {
        let slot = &mut self.candidates[stream.index()];
        let Some(last) = last else {
            *slot = None;
            return Ok(Order::Next);
        };
        if t == last {
            return Err(Jump::Duplicate);
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
        Err(match t < last {
            true => Jump::Backwards { last, samples },
            false => Jump::Ahead { last, samples },
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Debug, PartialEq)]
    enum Kind {
        Duplicate,
        OutOfOrder,
        TimeJump,
    }

    fn kind(j: Jump) -> Kind {
        match j {
            Jump::Duplicate => Kind::Duplicate,
            Jump::Backwards { .. } => Kind::OutOfOrder,
            Jump::Ahead { .. } => Kind::TimeJump,
        }
    }

    /// Feeds `ts` to one stream's clock as a driver would (storing what is accepted) and
    /// returns each verdict: `Ok(true)` a resync, `Ok(false)` in order, `Err(reason)`.
    fn feed(ts: &[f64]) -> Vec<Result<bool, Kind>> {
        let mut c = Clocks::default();
        let mut last = None;
        ts.iter()
            .map(|&t| match c.check(Stream::Heading, t, last, 60.0, 3) {
                Ok(o) => {
                    last = Some(t);
                    Ok(matches!(o, Order::Resync { .. }))
                }
                Err(j) => Err(kind(j)),
            })
            .collect()
    }

    #[test]
    fn rejects_time_going_backwards_and_duplicates() {
        use Kind::*;
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
        use Kind::*;
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
        use Kind::*;
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
}
