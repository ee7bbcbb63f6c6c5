//! Feeding the monitor: each decoded sample's way in (validation, clock steps, then its
//! stream's handler), a malformed payload's count, and the silence a driver reports. Part of
//! [`Monitor`]'s state machine (`mod.rs` holds it; a heading sample may start a test here,
//! `run.rs` steps it).

use super::*;

/// Smoothing time constant of the speed used for the speed-change abort [s].
const SPEED_SMOOTHING_S: f64 = 10.0;

impl Monitor {
    /// Counts a payload that did not decode on `stream`. Returns whether to log it (first of
    /// a burst).
    pub fn count_malformed(&mut self, stream: Stream) -> bool {
        self.counters
            .count_rejection(stream, RejectReason::Malformed)
    }

    /// Feeds one sample. A rejected sample is counted and returned as an error; it changes
    /// nothing else. An accepted heading sample queues exactly one excitation.
    pub fn handle_input(&mut self, input: Input) -> Result<(), Rejection> {
        let stream = input.stream();
        let order = input::validate(&input, &self.latest, &self.limits).and_then(|()| {
            let c = &self.cfg.input;
            input::order(
                &mut self.clocks,
                stream,
                input.t(),
                self.latest.t(stream),
                c.time_jump_s,
                c.resync_samples,
            )
        });
        let order = match order {
            Ok(o) => o,
            Err(r) => {
                if self.counters.count_rejection(r.stream, r.reason) {
                    tracing::warn!(
                        vessel = %self.vessel,
                        stream = r.stream.name(),
                        reason = r.reason.name(),
                        count = self.counters.rejected(r.stream, r.reason),
                        "{}",
                        r.detail
                    );
                }
                return Err(r);
            }
        };
        self.counters.count_accepted(stream);
        if let Order::Resync { from_t } = order {
            self.resync(stream, from_t, input.t());
        }
        let prev_heading_t = self.last_heading_t();
        input::store(&input, &mut self.latest);
        match input {
            Input::Heading(s) => self.on_heading(s.t, s.value, prev_heading_t),
            Input::Rudder(s) => self.on_rudder(s.t, s.value),
            Input::Speed(s) => self.on_speed(s.t, s.value),
            Input::AutopilotState(_) | Input::TargetHeading(_) | Input::DesignDisplacement(_) => {}
        }
        Ok(())
    }

    /// Lets the monitor notice silence: `now_s` is the driver's estimate of ship time. A test
    /// whose heading stream has been silent longer than `safety.stream-timeout-s` is aborted
    /// (status and report; the autopilot reverts by itself when `hold_s` runs out).
    pub fn handle_timeout(&mut self, now_s: f64) {
        if !now_s.is_finite() {
            return;
        }
        let Some(last) = self.last_heading_t() else {
            return;
        };
        let silent = now_s - last;
        if self.run.is_some() && silent > self.cfg.safety.stream_timeout_s {
            let reason = AbortReason::StreamSilent {
                stream: Stream::Heading,
                silent_s: silent,
            };
            self.finish(now_s, Err(reason));
        }
    }

    /// A stream re-synchronised on a new timeline (its clock stepped from `from_t` to `to_t`):
    /// the test under way, whose records no longer line up, is aborted ("clock step"), and
    /// state kept in ship time moves to the new timeline: the heading's (the scheduler's
    /// interval and steady course, the heading's own latest time) or the speed's smoothing.
    fn resync(&mut self, stream: Stream, from_t: f64, to_t: f64) {
        self.counters.count_resync(stream);
        tracing::warn!(
            vessel = %self.vessel,
            stream = stream.name(),
            from_t,
            to_t,
            "clock step: the stream re-synchronised on a new timeline"
        );
        match stream {
            Stream::Heading => {
                let shift = to_t - from_t;
                self.last_test_end = self.last_test_end.map(|e| e + shift);
                self.steady = Steady::default();
            }
            Stream::Speed => self.speed_smooth = None,
            _ => {}
        }
        if self.run.is_some() {
            // Reported at the new timeline's time when the heading stepped, else the heading's.
            let t = if stream == Stream::Heading {
                to_t
            } else {
                self.last_heading_t().unwrap_or(to_t)
            };
            self.finish(
                t,
                Err(AbortReason::ClockStep {
                    stream,
                    from_t,
                    to_t,
                }),
            );
        }
        if stream == Stream::Heading {
            // The heading's last sample belongs to the old timeline: forget it, so the next
            // step measures no interval across the jump.
            self.latest.heading = None;
        }
    }

    fn on_rudder(&mut self, t: f64, rudder_rad: f64) {
        let play = cadence::PLAY_SIGMAS * self.cfg.sensors.rudder_noise_deg.to_radians();
        self.work.rudder(t, rudder_rad, play);
        let full = match &mut self.run {
            Some(run) => match &mut run.kind {
                RunKind::Hbt(h) => h.push_rudder(t, rudder_rad).err(),
                RunKind::Clfrt(c) => c.push_rudder(t, rudder_rad).err(),
            },
            None => None,
        };
        if let Some(e) = full {
            self.finish(t, Err(AbortReason::Record(e)));
        }
    }

    fn on_speed(&mut self, t: f64, speed_mps: f64) {
        if let Some(run) = &mut self.run {
            run.speed_sum_mps += speed_mps;
            run.speed_n += 1;
        }
        self.speed_smooth = Some(match self.speed_smooth {
            None => (speed_mps, t),
            Some((s, t_prev)) => {
                let alpha = 1.0 - (-(t - t_prev).max(0.0) / SPEED_SMOOTHING_S).exp();
                (s + alpha * (speed_mps - s), t)
            }
        });
    }

    fn on_heading(&mut self, t: f64, heading_rad: f64, prev_heading_t: Option<f64>) {
        // Continuous heading for the records.
        let continuous = self.unwrap_heading(heading_rad);
        self.heading_unwrapped = Some(continuous);

        if self.run.is_some() {
            self.step_run(t, heading_rad, continuous, prev_heading_t);
        } else {
            self.update_steady(t, heading_rad);
            if self.scheduled_start_due(t) {
                let methods = &self.cfg.scheduler.methods;
                let method = methods[self.next_method % methods.len()];
                self.next_method = (self.next_method + 1) % methods.len();
                if self.start(t, method, "schedule").is_ok() {
                    self.step_run(t, heading_rad, continuous, prev_heading_t);
                } else {
                    self.last_test_end = Some(t);
                }
            }
        }
        // Exactly one excitation per accepted heading sample: idle, or a test that just ended.
        if !self.excitation_sent_at(t) {
            self.emit_excitation(t, ExcitationMode::None, 0.0);
        }
    }

    /// Unwraps the new heading against the previous continuous heading.
    fn unwrap_heading(&self, heading_rad: f64) -> f64 {
        match self.heading_unwrapped {
            None => heading_rad,
            Some(prev) => prev + wrap_pi(heading_rad - prev),
        }
    }
}
