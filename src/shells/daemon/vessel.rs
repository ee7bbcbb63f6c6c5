//! One vessel's task: the only owner of its [`Monitor`] core. While this daemon drives the
//! vessel (its role, from the ownership driver, is holder) it decodes the samples its queue
//! brings, feeds the core, publishes every output at once and in order (saving the state and
//! the history first, when they are kept, and publishing the state on `fdi/state` for the
//! standbys), checks silence and publishes statistics.
//!
//! While it stands by it publishes nothing for the vessel: samples are dropped unread, a
//! trigger or commission query is left to the holder (answered only when no holder is alive,
//! with the refusal "standby, ..."), and every state the holder publishes is checked (format,
//! vessel, and the fingerprint of the ship configuration and models it was made under: a
//! state made under others is refused, with the reason) and kept, in memory and in the state
//! directory. When it takes over it starts from a fresh core restored from that state (else
//! from its state directory), publishes the restored alarm again and drives; a test the old
//! holder was running is not continued (the new core has none). When it yields (another
//! holder with a lower id: a healed partition) it stops at once, dropping what the core still
//! had to say. Reports made while another daemon also drove are marked with
//! `"concurrent_drivers": [ids]`.

use super::owner::RoleView;
use super::publishers::Publishers;
use super::vessel_recording::Recording;
use super::{Msg, Shared, VesselSummary};
use crate::shells::history::{History, Kind};
use crate::shells::recording::{self, Recorder};
use crate::shells::state::{Loaded, StateDir};
use helmwatch_core::monitor::abort::AbortCounts;
use helmwatch_core::monitor::input::RejectReason;
use helmwatch_core::monitor::VesselState;
use helmwatch_core::monitor::{Monitor, Output};
use helmwatch_core::ownership::Role;
use helmwatch_core::wire::{self, Input};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};
use tokio::sync::{mpsc, watch};
use tokio_util::sync::CancellationToken;

/// The task that owns one vessel's monitor core.
pub(super) struct VesselTask {
    pub(super) monitor: Monitor,
    pub(super) name: String,
    /// Where the vessel's state is saved after every decision.
    pub(super) state: Option<StateDir>,
    /// The report history, written before a report or notification is published.
    pub(super) history: Option<Arc<History>>,
    /// Ship time of the last report (a notification's time in the history) [s].
    pub(super) last_report_t: f64,
    /// The alarm notification restored from the state directory, published at start.
    pub(super) restored: Option<helmwatch_core::wire::Notification>,
    pub(super) rx: mpsc::Receiver<Msg>,
    pub(super) pubs: Publishers,
    pub(super) shared: Arc<Shared>,
    /// Last accepted heading: its ship time and when it arrived (silence check).
    pub(super) last_heading: Option<(f64, Instant)>,
    pub(super) tick: Duration,
    pub(super) stats_period: Option<Duration>,
    pub(super) shutdown_timeout: Duration,
    /// Failed publications (logged once per burst).
    pub(super) publish_errors: u64,
    /// The abort counts already in the metrics (a report's abort reason code is the one
    /// whose count moved).
    pub(super) seen_aborts: AbortCounts,
    /// The last accepted heading's `t` and arrival, until its excitation is published.
    pub(super) pending_heading: Option<(f64, Instant)>,
    /// The daemon's recorder (shared by the vessels), when `daemon.record`.
    pub(super) recorder: Option<Arc<Mutex<Recorder>>>,
    /// What this vessel recorded: the channels' names and the messages written on each.
    pub(super) recording: Recording,
    /// How to build a fresh core at a takeover.
    pub(super) fresh: Fresh,
    /// This daemon's id (`daemon.id`).
    pub(super) daemon_id: String,
    /// The role, from the ownership driver.
    pub(super) role_rx: watch::Receiver<RoleView>,
    /// Whether this daemon drives the vessel now.
    pub(super) driving: bool,
    /// The last state the holder published, checked (taken up at a takeover).
    pub(super) replica: Option<VesselState>,
    /// Replicated states refused (another format, vessel or fingerprint).
    pub(super) refused_states: u64,
    /// The role view's number when the test under way started: the daemons that drove the
    /// vessel with this one since then mark its report ([`RoleView::drove_since`]).
    pub(super) concurrent_since: u64,
    /// Told once the first role after the claim window is taken up (the daemon is ready
    /// then).
    pub(super) settled: Option<tokio::sync::oneshot::Sender<()>>,
}

/// What a fresh core is made of.
pub(super) struct Fresh {
    pub core: helmwatch_core::monitor::config::CoreConfig,
    pub multisine: Option<helmwatch_core::dsp::multisine::Multisine>,
    pub estimator: Option<Arc<helmwatch_core::estimator::Estimator>>,
    /// The core's analysis records are wanted (recording).
    pub analysis: bool,
}

/// `fdi/state`: the vessel's state and the daemon that published it.
#[derive(Debug, serde::Serialize, serde::Deserialize)]
struct Replicated {
    daemon: String,
    state: VesselState,
}

impl VesselTask {
    pub(super) async fn run(mut self, cancel: CancellationToken) -> VesselSummary {
        let mut roles_open = true;
        let mut tick = tokio::time::interval(self.tick);
        tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
        let mut stats = self.stats_period.map(|p| {
            let mut i = tokio::time::interval_at(tokio::time::Instant::now() + p, p);
            i.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
            i
        });
        loop {
            tokio::select! {
                biased;
                _ = cancel.cancelled() => break,
                changed = self.role_rx.changed(), if roles_open => match changed {
                    Ok(()) => self.on_role().await,
                    Err(_) => roles_open = false,
                },
                _ = tick.tick(), if self.driving => {
                    if let Some((t, at)) = self.last_heading {
                        self.monitor.handle_timeout(t + at.elapsed().as_secs_f64());
                        self.publish_outputs().await;
                    }
                }
                _ = next_tick(stats.as_mut()) => self.publish_stats().await,
                msg = self.rx.recv() => match msg {
                    Some(m) => self.handle(m).await,
                    None => break,
                },
            }
        }
        self.rx.close();
        if self.driving {
            self.monitor.shutdown("daemon stopping");
            let limit = self.shutdown_timeout;
            if tokio::time::timeout(limit, self.publish_outputs())
                .await
                .is_err()
            {
                tracing::warn!(vessel = %self.name, "final publications timed out");
            }
        }
        let stats = self.stats_json();
        tracing::info!(vessel = %self.name, stats = %stats, "vessel statistics");
        VesselSummary {
            vessel: self.name,
            stats,
        }
    }

    async fn handle(&mut self, msg: Msg) {
        if !self.driving {
            return self.handle_standby(msg);
        }
        match msg {
            Msg::State { .. } => {}
            Msg::CandidateJoined => self.publish_state().await,
            Msg::StateQuery { reply } => {
                let _ = reply.send(self.state_payload());
            }
            Msg::Sample {
                stream,
                payload,
                len,
                arrived,
            } => self.handle_sample(stream, payload, len, arrived).await,
            Msg::Trigger { method, reply } => {
                let r = self.monitor.trigger(method);
                tracing::info!(vessel = %self.name, method = method.name(), accepted = r.accepted, test = ?r.test, reason = ?r.reason, "trigger");
                let _ = reply.send(Some(r));
                self.publish_outputs().await;
            }
            Msg::Commission {
                start,
                method,
                reply,
            } => {
                if start {
                    self.monitor.commission(method);
                    tracing::info!(vessel = %self.name, method = ?method.map(helmwatch_core::wire::Method::name), "commissioning started on request: {}", self.monitor.commissioning_text());
                    self.save_state();
                }
                let mut r = self.monitor.commissioning_status();
                if let Some(o) = r.as_object_mut() {
                    o.insert("vessel".into(), self.name.clone().into());
                    o.insert("started".into(), start.into());
                }
                let _ = reply.send(Some(r));
                if start {
                    self.publish_state().await;
                }
            }
        }
    }

    /// An input sample: decoded (unless oversized), fed to the core, counted, recorded (a
    /// rejected one as its reason), then every output published.
    async fn handle_sample(
        &mut self,
        stream: wire::Stream,
        payload: Vec<u8>,
        len: usize,
        arrived: Instant,
    ) {
        // An oversized sample is not read (only its head was queued).
        let decoded = if len > payload.len() {
            Err(format!(
                "{} sample of {len} bytes, over {} bytes: not read",
                stream.name(),
                super::MAX_SAMPLE_BYTES
            ))
        } else {
            wire::decode(stream, &payload).map_err(|e| e.to_string())
        };
        let reason = match decoded {
            Err(e) => {
                self.shared
                    .metrics
                    .rejected(stream, RejectReason::Malformed);
                if self.monitor.count_malformed(stream) {
                    let n = self
                        .monitor
                        .counters()
                        .rejected(stream, RejectReason::Malformed);
                    tracing::warn!(vessel = %self.name, stream = stream.name(), count = n, "{e}");
                }
                Some(if len > payload.len() {
                    "oversized"
                } else {
                    RejectReason::Malformed.name()
                })
            }
            Ok(input) => {
                let t = input.t();
                let heading_t = match &input {
                    Input::Heading(s) => Some(s.t),
                    _ => None,
                };
                match self.monitor.handle_input(input) {
                    Ok(()) => {
                        self.shared.metrics.accepted(stream);
                        if let Some(t) = heading_t {
                            self.last_heading = Some((t, Instant::now()));
                            self.pending_heading = Some((t, arrived));
                        }
                        // Recorded before its outputs, in the order it was handled.
                        if self.recorder.is_some() {
                            self.recording.last_input_t = t;
                            let topic = self.recording.inputs[stream.index()].clone();
                            self.record_message(
                                &topic,
                                recording::message::Kind::Input(stream),
                                t,
                                &payload,
                            );
                        }
                        None
                    }
                    Err(r) => {
                        self.shared.metrics.rejected(r.stream, r.reason);
                        Some(r.reason.name())
                    }
                }
            }
        };
        if let Some(reason) = reason {
            self.record_rejected(stream, reason, len, &payload);
        }
        self.publish_outputs().await;
    }

    /// Adds a report or notification to the history, if kept (durable when this returns).
    pub(super) fn record(&self, kind: Kind, t: f64, payload: &impl serde::Serialize) {
        if let Some(h) = &self.history {
            if let Err(e) = tokio::task::block_in_place(|| h.add(&self.name, kind, t, payload)) {
                tracing::error!(vessel = %self.name, "history: {e}");
            }
        }
    }

    /// Saves the vessel's state (atomically) when there is a state directory.
    fn save_state(&self) {
        if let Some(dir) = &self.state {
            let s = self.monitor.saved_state();
            if let Err(e) = tokio::task::block_in_place(|| dir.save(&s)) {
                tracing::error!(vessel = %self.name, "saving the state: {e}");
            }
        }
    }

    /// Drains the core and publishes every output on its key, in order (recording each first,
    /// when recording).
    async fn publish_outputs(&mut self) {
        let mut state_changed = false;
        while let Some(out) = self.monitor.poll_output() {
            state_changed |= matches!(&out, Output::Report(_) | Output::Notification(_))
                || matches!(&out, Output::Status(s) if s.state == wire::MonitorState::Settling);
            let mut excitation_of: Option<Instant> = None;
            let (kind, t) = match &out {
                Output::Excitation(e) => (recording::message::Kind::Excitation, e.t),
                Output::Status(s) => (recording::message::Kind::Status, s.t),
                Output::Report(r) => (recording::message::Kind::Report, r.t_end),
                Output::Notification(_) => {
                    (recording::message::Kind::Notification, self.last_report_t)
                }
                Output::Analysis(a) => {
                    self.record_analysis(a);
                    continue;
                }
            };
            let bytes = match &out {
                Output::Analysis(_) => continue,
                Output::Excitation(e) => {
                    // The latency is measured to this put's return (below).
                    excitation_of = self
                        .pending_heading
                        .take_if(|(ht, _)| *ht == e.t)
                        .map(|(_, at)| at);
                    serde_json::to_vec(e)
                }
                Output::Status(s) => self.status_out(s),
                Output::Report(r) => self.report_out(r),
                Output::Notification(n) => {
                    self.record(Kind::Notification, self.last_report_t, n);
                    self.shared.metrics.alarm(n.state);
                    tracing::warn!(vessel = %self.name, state = ?n.state, "notification: {}", n.message);
                    serde_json::to_vec(n)
                }
            };
            if self.recorder.is_some() {
                if let Ok(b) = &bytes {
                    let topic = match kind {
                        recording::message::Kind::Excitation => &self.recording.excitation,
                        recording::message::Kind::Status => &self.recording.status,
                        recording::message::Kind::Report => &self.recording.report,
                        _ => &self.recording.notification,
                    }
                    .clone();
                    self.record_message(&topic, kind, t, b);
                }
            }
            self.put_output(kind, bytes, excitation_of).await;
        }
        if state_changed {
            self.publish_state().await;
        }
    }

    /// A status about to be published: a new test is noted (its id saved, its start
    /// counted) and the status logged; returns its payload.
    fn status_out(&mut self, s: &wire::Status) -> serde_json::Result<Vec<u8>> {
        if s.state == wire::MonitorState::Settling {
            // A new test: marked only if another daemon drives during it.
            self.concurrent_since = self.role_rx.borrow().seq;
            // A test started: its id is taken, even if the daemon dies before it ends.
            self.save_state();
            if let Some(m) = s.method {
                self.shared.metrics.test_started(m);
            }
        }
        tracing::info!(vessel = %self.name, t = s.t, state = ?s.state, test = ?s.test, reason = ?s.reason, "status");
        serde_json::to_vec(s)
    }

    /// A report about to be published: the state saved and the report in the history first,
    /// marked when another daemon drove too, its end counted and logged; returns its payload.
    fn report_out(&mut self, r: &wire::Report) -> serde_json::Result<Vec<u8>> {
        // The decision is on disk before anyone hears of it.
        self.save_state();
        self.last_report_t = r.t_end;
        // Made while another daemon also drove the vessel: marked.
        let (concurrent, seq) = {
            let view = self.role_rx.borrow();
            (view.drove_since(self.concurrent_since), view.seq)
        };
        let marked = if concurrent.is_empty() {
            None
        } else {
            let mut v = serde_json::to_value(r).unwrap_or_default();
            if let Some(o) = v.as_object_mut() {
                o.insert("concurrent_drivers".into(), serde_json::json!(concurrent));
            }
            tracing::warn!(vessel = %self.name, test = %r.test, others = ?concurrent, "report made while another daemon drove too: marked");
            Some(v)
        };
        self.concurrent_since = seq;
        match &marked {
            Some(v) => self.record(Kind::Report, r.t_end, v),
            None => self.record(Kind::Report, r.t_end, r),
        }
        let aborts = self.monitor.stats().aborts.clone();
        let moved: Vec<(&'static str, u64)> = aborts
            .iter()
            .zip(self.seen_aborts.iter())
            .filter(|((_, now), (_, before))| now > before)
            .map(|((code, now), (_, before))| (code, now - before))
            .collect();
        self.seen_aborts = aborts;
        self.shared
            .metrics
            .test_ended(r.method, r.outcome, r.decision, moved);
        tracing::info!(
            vessel = %self.name,
            test = %r.test,
            outcome = ?r.outcome,
            decision = ?r.decision,
            reason = ?r.reason,
            "report"
        );
        match &marked {
            Some(v) => serde_json::to_vec(v),
            None => serde_json::to_vec(r),
        }
    }

    /// Puts one output's payload on its publisher; counts (and logs once per burst) a
    /// failure, measures the excitation latency of a heading (`excitation_of`: its arrival).
    async fn put_output(
        &mut self,
        kind: recording::message::Kind,
        bytes: serde_json::Result<Vec<u8>>,
        excitation_of: Option<Instant>,
    ) {
        let publisher = match kind {
            recording::message::Kind::Excitation => &self.pubs.excitation,
            recording::message::Kind::Status => &self.pubs.status,
            recording::message::Kind::Report => &self.pubs.report,
            _ => &self.pubs.notification,
        };
        let result = match bytes {
            Ok(b) => publisher.put(b).await.map_err(|e| e.to_string()),
            Err(e) => Err(e.to_string()),
        };
        if let (Ok(()), Some(at)) = (&result, excitation_of) {
            self.shared.metrics.excitation_latency(at.elapsed());
        }
        if let Err(e) = result {
            self.shared.metrics.publish_error();
            self.publish_errors += 1;
            if self.publish_errors.is_power_of_two() {
                tracing::warn!(vessel = %self.name, count = self.publish_errors, "publication failed: {e}");
            }
        }
    }

    fn stats_json(&self) -> serde_json::Value {
        let s = self.monitor.stats();
        serde_json::json!({
            "t": self.monitor.last_heading_t(),
            "state": self.monitor.state(),
            "inputs": self.monitor.counters().to_json(),
            "dropped": {
                "flood": self.shared.metrics.queue_dropped_count(),
                "triggers": self.shared.metrics.controls_dropped_count(),
            },
            "tests": {
                "started": s.tests_started,
                "completed": s.tests_completed,
                "aborted": s.tests_aborted,
                "aborted_by_reason": s.aborts.to_json(),
            },
            "excitation_clamped": s.excitation_clamped,
            "publish_errors": self.publish_errors,
            "role": self.role_rx.borrow().describe(),
            "replicated_states_refused": self.refused_states,
            "recorded": {
                "messages": self.recording.counts,
                "errors": self.recording.errors,
                "rejected_suppressed": self.recording.rejected_suppressed,
            },
        })
    }

    async fn publish_stats(&mut self) {
        let stats = self.stats_json();
        tracing::debug!(vessel = %self.name, stats = %stats, "vessel statistics");
        // A standby publishes nothing on the vessel's keys (its counters are in its log).
        if !self.driving {
            return;
        }
        if let Some(p) = &self.pubs.stats {
            if let Ok(b) = serde_json::to_vec(&stats) {
                if let Err(e) = p.put(b).await {
                    tracing::debug!(vessel = %self.name, "stats publication failed: {e}");
                }
            }
        }
    }
}

/// The next tick of `interval`, or never.
async fn next_tick(interval: Option<&mut tokio::time::Interval>) {
    match interval {
        Some(i) => {
            i.tick().await;
        }
        None => std::future::pending().await,
    }
}

/// Restores `vessel`'s saved state into `monitor`; returns the notification to publish again
/// (the vessel's alarm state as it was). A corrupt or foreign file is logged and set aside.
pub(super) fn restore(
    dir: &StateDir,
    vessel: &str,
    monitor: &mut Monitor,
) -> Option<helmwatch_core::wire::Notification> {
    match dir.load(vessel) {
        Loaded::Fresh => {
            tracing::info!(vessel, "no saved state: starting fresh");
            None
        }
        Loaded::State(s) => match monitor.restore(*s) {
            Ok(discarded) => {
                if let Some(why) = discarded {
                    tracing::warn!(vessel, file = %dir.vessel_file(vessel).display(), "{why}");
                }
                let n = monitor.last_notification().cloned();
                tracing::info!(
                    vessel,
                    alarm = ?monitor.alarm_state(),
                    file = %dir.vessel_file(vessel).display(),
                    "state restored"
                );
                n
            }
            Err(e) => {
                tracing::error!(vessel, file = %dir.vessel_file(vessel).display(), "saved state refused: {e}; starting fresh");
                None
            }
        },
        Loaded::Corrupt(msg) => {
            tracing::error!(vessel, "{msg}");
            None
        }
    }
}

#[path = "vessel_role.rs"]
mod role;
