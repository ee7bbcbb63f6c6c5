//! A vessel task's role: taking over (a fresh core restored from the holder's state or the
//! state directory, the restored alarm published again), yielding, standing by (the
//! holder's states checked and kept, queries left to the holder), and the replicated state
//! published for the standbys. See the parent module's doc.

use super::*;

impl VesselTask {
    /// Publishes the restored alarm notification again, if any, as soon as someone listens
    /// or after `wait` (a restart: the listeners may still be connecting; a takeover: they
    /// are there).
    pub(super) async fn publish_restored(&mut self, wait: Duration) {
        if let Some(n) = self.restored.take() {
            // An alarm stays an alarm across a restart and a takeover.
            crate::shells::net::wait_matching(&self.pubs.notification, wait).await;
            tracing::warn!(vessel = %self.name, state = ?n.state, "restored notification: {}", n.message);
            match serde_json::to_vec(&n) {
                Ok(b) => {
                    if let Err(e) = self.pubs.notification.put(b).await {
                        tracing::warn!(vessel = %self.name, "publishing the restored notification: {e}");
                    }
                }
                Err(e) => {
                    tracing::warn!(vessel = %self.name, "encoding the restored notification: {e}")
                }
            }
        }
    }

    /// Takes a change of role: take over, yield, or note the other drivers.
    pub(super) async fn on_role(&mut self) {
        let view = self.role_rx.borrow_and_update().clone();
        let drives = view.role.drives();
        if drives && !self.driving {
            self.take_over().await;
        } else if !drives && self.driving {
            self.driving = false;
            let mut dropped = 0;
            while self.monitor.poll_output().is_some() {
                dropped += 1;
            }
            self.last_heading = None;
            self.pending_heading = None;
            tracing::warn!(vessel = %self.name, dropped_outputs = dropped, state = ?self.monitor.state(), "stopped driving ({}): the test under way is left to expire", view.describe());
        }
        if view.role != Role::Claiming {
            self.signal_settled();
        }
    }

    /// Tells the daemon this vessel has taken up its role (once).
    pub(super) fn signal_settled(&mut self) {
        if let Some(tx) = self.settled.take() {
            let _ = tx.send(());
        }
    }

    /// Starts driving: a fresh core restored from the holder's replicated state (else from
    /// the state directory), its alarm published again, its state published for the others.
    pub(super) async fn take_over(&mut self) {
        let f = &self.fresh;
        let mut m = Monitor::with_parts(
            &f.core,
            &self.name,
            f.multisine.clone(),
            f.estimator.clone(),
        );
        m.set_analysis_output(f.analysis);
        let from_replica = match self.replica.take() {
            Some(s) => {
                let seq = s.test_seq;
                match m.restore(s) {
                    Ok(discarded) => {
                        if let Some(why) = discarded {
                            tracing::warn!(vessel = %self.name, "{why}");
                        }
                        tracing::info!(vessel = %self.name, alarm = ?m.alarm_state(), tests = seq, commissioning = %m.commissioning_text(), "state taken over from the holder's publication");
                        true
                    }
                    Err(e) => {
                        tracing::error!(vessel = %self.name, "replicated state refused: {e}");
                        false
                    }
                }
            }
            None => false,
        };
        let restored = if from_replica {
            m.last_notification().cloned()
        } else {
            self.state
                .as_ref()
                .and_then(|dir| restore(dir, &self.name, &mut m))
        };
        self.monitor = m;
        if from_replica {
            if let Some(n) = &restored {
                // The holder's alarm is in this daemon's history too, at the end of the test
                // that raised it: `status` and `fdi/history` show it from the first moment
                // this daemon answers for the vessel.
                let t = self.monitor.saved_state().last_test_end.unwrap_or(f64::NAN);
                self.record(Kind::Notification, t, n);
                self.last_report_t = t;
            }
        }
        self.seen_aborts = self.monitor.stats().aborts.clone();
        self.shared.metrics.alarm(self.monitor.alarm_state());
        self.last_heading = None;
        self.pending_heading = None;
        self.concurrent_since = self.role_rx.borrow().seq;
        self.driving = true;
        self.restored = restored;
        tracing::info!(vessel = %self.name, daemon = %self.daemon_id, "driving the vessel");
        // Ready: the state is taken up. The restored alarm waits (briefly) for a listener.
        self.signal_settled();
        let wait = match from_replica {
            true => Duration::from_millis(500),
            false => Duration::from_secs(2),
        };
        self.publish_restored(wait).await;
        self.save_state();
        self.publish_state().await;
    }

    /// The vessel's state as published on `fdi/state`.
    pub(super) fn state_payload(&self) -> Option<Vec<u8>> {
        serde_json::to_vec(&Replicated {
            daemon: self.daemon_id.clone(),
            state: self.monitor.saved_state(),
        })
        .ok()
    }

    /// Publishes the vessel's state for the standbys (the holder only).
    pub(super) async fn publish_state(&mut self) {
        if !self.driving {
            return;
        }
        if let Some(b) = self.state_payload() {
            if let Err(e) = self.pubs.state.put(b).await {
                tracing::warn!(vessel = %self.name, "publishing the state: {e}");
            }
        }
    }

    /// Takes a state published by the holder: checked, then kept (memory and state directory).
    pub(super) fn on_state(&mut self, payload: &[u8]) {
        if self.driving {
            return;
        }
        let refuse = |me: &mut Self, from: &str, why: String| {
            me.refused_states += 1;
            me.shared.metrics.state_refused();
            if me.refused_states.is_power_of_two() {
                tracing::error!(vessel = %me.name, from, count = me.refused_states, "replicated state refused: {why}");
            }
        };
        let r: Replicated = match serde_json::from_slice(payload) {
            Ok(r) => r,
            Err(e) => return refuse(self, "?", format!("not a vessel state: {e}")),
        };
        if r.daemon == self.daemon_id {
            return;
        }
        if r.state.format != VesselState::FORMAT {
            let why = format!(
                "format `{}`, expected `{}`",
                r.state.format,
                VesselState::FORMAT
            );
            return refuse(self, &r.daemon, why);
        }
        if r.state.vessel != self.name {
            let why = format!("made for vessel `{}`", r.state.vessel);
            return refuse(self, &r.daemon, why);
        }
        let own = self.monitor.saved_state().fdi.fingerprint;
        if let Some(why) = own.difference(&r.state.fdi.fingerprint) {
            let why =
                format!("made under another configuration or models than this daemon's: {why}");
            return refuse(self, &r.daemon, why);
        }
        if self.replica.is_none() {
            tracing::info!(vessel = %self.name, from = %r.daemon, tests = r.state.test_seq, "keeping the holder's state");
        }
        if let Some(dir) = &self.state {
            if let Err(e) = tokio::task::block_in_place(|| dir.save(&r.state)) {
                tracing::error!(vessel = %self.name, "saving the replicated state: {e}");
            }
        }
        self.replica = Some(r.state);
    }

    /// A message while standing by: nothing is driven, nothing published.
    pub(super) fn handle_standby(&mut self, msg: Msg) {
        let view = self.role_rx.borrow().clone();
        // Left to the holder when one is alive (a second reply would race its answer).
        let holder_alive = matches!(view.role, Role::Standby { holder: Some(_) });
        match msg {
            Msg::Sample { .. } | Msg::CandidateJoined => {}
            Msg::State { payload } => self.on_state(&payload),
            Msg::StateQuery { reply } => {
                let _ = reply.send(None);
            }
            Msg::Trigger { reply, .. } => {
                let r = (!holder_alive).then(|| helmwatch_core::wire::TriggerReply {
                    accepted: false,
                    test: None,
                    reason: Some(view.describe()),
                });
                let _ = reply.send(r);
            }
            Msg::Commission { reply, .. } => {
                let r = (!holder_alive).then(|| serde_json::json!({"error": view.describe()}));
                let _ = reply.send(r);
            }
        }
    }
}
