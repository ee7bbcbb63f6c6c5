//! When a test may start and when it must stop: the preconditions of a trigger, the steady
//! course the scheduler waits for, the safety checks at every heading sample of a test, and
//! the safety gate on every excitation value (docs/contract.md, "Daemon -> autopilot:
//! excitation"). Part of [`Monitor`], in its own file so that the rules read together.

use super::{AbortReason, Monitor};
use crate::angle::wrap_pi;
use crate::wire::{ExcitationMode, Stream};

/// A precondition of a test that does not hold (the trigger's reply gives this text).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub(super) enum Precondition {
    /// A required stream has sent nothing yet.
    #[error("no {} received yet", .0.name())]
    NotReceived(Stream),
    /// A required stream has been silent longer than `safety.stream-timeout-s`.
    #[error("{} stream silent for {silent_s:.1} s", .stream.name())]
    Silent {
        /// The stream.
        stream: Stream,
        /// For how long [s].
        silent_s: f64,
    },
    /// The autopilot is not in `auto`.
    #[error("autopilot is not in auto")]
    NotAuto,
    /// |heading error| is over `safety.max-heading-error-deg`.
    #[error("heading error {error_deg:.1} deg over the limit")]
    HeadingError {
        /// |heading error| [deg].
        error_deg: f64,
    },
}

impl Monitor {
    /// Conditions for starting any test at `t`: fresh streams, autopilot in auto, a target,
    /// a heading error within the abort limit.
    pub(super) fn preconditions(&self, t: f64) -> Result<(), Precondition> {
        let timeout = self.cfg.safety.stream_timeout_s;
        for s in Stream::REQUIRED {
            match self.latest.t(s) {
                None => return Err(Precondition::NotReceived(s)),
                Some(ts) if t - ts > timeout => {
                    return Err(Precondition::Silent {
                        stream: s,
                        silent_s: t - ts,
                    })
                }
                _ => {}
            }
        }
        if !matches!(self.latest.auto, Some((_, true))) {
            return Err(Precondition::NotAuto);
        }
        if let (Some((_, h)), Some((_, target))) = (self.latest.heading, self.latest.target) {
            let e = self.heading_error(target, h).abs();
            if e > self.cfg.safety.max_heading_error_deg.to_radians() {
                return Err(Precondition::HeadingError {
                    error_deg: e.to_degrees(),
                });
            }
        }
        Ok(())
    }

    pub(super) fn update_steady(&mut self, t: f64, heading_rad: f64) {
        let sc = &self.cfg.scheduler;
        let ok = self.preconditions(t).is_ok()
            && self.latest.target.is_some_and(|(_, target)| {
                self.heading_error(target, heading_rad).abs()
                    < sc.steady_heading_error_deg.to_radians()
            });
        let (Some((_, rudder)), Some((speed, _))) = (self.latest.rudder, self.speed_smooth) else {
            self.steady.since = None;
            return;
        };
        if !ok {
            self.steady.since = None;
            return;
        }
        let st = &mut self.steady;
        match st.since {
            None => {
                st.since = Some(t);
                st.rudder = (rudder, rudder);
                st.speed = (speed, speed);
            }
            Some(_) => {
                st.rudder = (st.rudder.0.min(rudder), st.rudder.1.max(rudder));
                st.speed = (st.speed.0.min(speed), st.speed.1.max(speed));
                if st.rudder.1 - st.rudder.0 > 2.0 * sc.steady_rudder_deg.to_radians()
                    || st.speed.1 - st.speed.0 > 2.0 * sc.steady_speed_mps
                {
                    st.since = Some(t);
                    st.rudder = (rudder, rudder);
                    st.speed = (speed, speed);
                }
            }
        }
    }

    pub(super) fn scheduled_start_due(&self, t: f64) -> bool {
        let sc = &self.cfg.scheduler;
        sc.enabled
            && self
                .steady
                .since
                .is_some_and(|since| t - since >= sc.steady_time_s)
            && self
                .last_test_end
                .is_none_or(|end| t - end >= self.scheduled_interval_s())
    }

    /// The interval before the next scheduled test: while a scheduled method's reference is
    /// being established (commissioning, then its confirmation), the gap the last test asked
    /// for under the added-travel budget (`cadence`), at most `commissioning-interval-s`,
    /// and at most `interval-s` (commissioning is never slower than the watch); else
    /// `interval-s`.
    pub(super) fn scheduled_interval_s(&self) -> f64 {
        let sc = &self.cfg.scheduler;
        if self.establishing() {
            let most = sc.commissioning_interval_s;
            self.commissioning_gap_s
                .map_or(most, |g| g.min(most))
                .min(sc.interval_s)
        } else {
            sc.interval_s
        }
    }

    /// The safety checks of a running test at heading sample `t`. `Err(reason)` aborts.
    pub(super) fn safety_check(
        &self,
        t: f64,
        heading_rad: f64,
        prev_heading_t: Option<f64>,
    ) -> Result<(), AbortReason> {
        let Some(run) = &self.run else { return Ok(()) };
        let s = &self.cfg.safety;
        if !matches!(self.latest.auto, Some((_, true))) {
            return Err(AbortReason::AutopilotLeftAuto);
        }
        let e = self.heading_error(run.target_rad, heading_rad);
        if e.abs() > s.max_heading_error_deg.to_radians() {
            return Err(AbortReason::HeadingError {
                error_deg: e.to_degrees(),
                limit_deg: s.max_heading_error_deg,
            });
        }
        if let Some((_, rudder)) = self.latest.rudder {
            if rudder.abs() >= s.rudder_saturation_deg.to_radians() {
                return Err(AbortReason::RudderSaturated {
                    rudder_deg: rudder.to_degrees(),
                });
            }
        }
        if let Some((_, target)) = self.latest.target {
            if wrap_pi(target - run.target_rad).abs() > 1e-6 {
                return Err(AbortReason::CourseChanged);
            }
        }
        for stream in Stream::REQUIRED {
            let last = if stream == Stream::Heading {
                prev_heading_t
            } else {
                self.latest.t(stream)
            };
            if let Some(ts) = last {
                if t - ts > s.stream_timeout_s {
                    return Err(AbortReason::StreamSilent {
                        stream,
                        silent_s: t - ts,
                    });
                }
            }
        }
        if let Some((speed, _)) = self.speed_smooth {
            if (speed - run.speed_start_mps).abs() > s.max_speed_change_mps {
                return Err(AbortReason::SpeedChanged {
                    from_mps: run.speed_start_mps,
                    to_mps: speed,
                });
            }
        }
        if t - run.t_start > s.max_test_duration_s {
            return Err(AbortReason::TooLong {
                limit_s: s.max_test_duration_s,
            });
        }
        Ok(())
    }

    /// Publishes the excitation of a running test after the safety gate: the value is bounded
    /// to `center +- max-excitation` and the servo's angle limit; in `add` mode its change from
    /// the previous `add` value is bounded by the rate limit.
    pub(super) fn emit_gated(
        &mut self,
        t: f64,
        mode: ExcitationMode,
        value: f64,
        center: f64,
        test: Option<String>,
    ) {
        let s = &self.cfg.safety;
        let max_exc = s.max_excitation_deg.to_radians();
        let servo_max = self.cfg.servo.max_angle_rad();
        let mut v = if value.is_finite() { value } else { 0.0 };
        let (lo, hi) = match mode {
            ExcitationMode::None => (0.0, 0.0),
            ExcitationMode::Add => (-max_exc, max_exc),
            ExcitationMode::Replace => (
                (center - max_exc).max(-servo_max),
                (center + max_exc).min(servo_max),
            ),
        };
        v = v.clamp(lo, hi);
        if mode == ExcitationMode::Add {
            let (prev_v, dt) = match self.last_excitation {
                Some((tp, ExcitationMode::Add, vp)) => (vp, t - tp),
                Some((tp, _, _)) => (0.0, t - tp),
                None => (0.0, 1.0 / self.cfg.sensors.rate_hz),
            };
            let dmax = s.max_excitation_rate_deg_s.to_radians() * dt.max(0.0);
            v = v.clamp(prev_v - dmax, prev_v + dmax);
        }
        if v != value {
            self.stats.excitation_clamped += 1;
            if self.stats.excitation_clamped.is_power_of_two() {
                tracing::warn!(vessel = %self.vessel, asked = value, sent = v, "excitation bounded by the safety gate");
            }
        }
        self.push_excitation(t, mode, v, test);
    }
}
