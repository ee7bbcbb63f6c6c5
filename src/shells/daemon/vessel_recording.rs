//! One vessel's side of the MCAP recording: its channels' names, what it wrote on each, and
//! the writing of its inputs, rejected samples and analyses into the shared recorder.

use super::vessel::VesselTask;
use crate::shells::recording;
use helmwatch_core::wire::{self, Keys};
use std::collections::BTreeMap;
use std::time::Instant;

/// One vessel's side of the recording: its channels' names and its counts.
#[derive(Debug, Default)]
pub(super) struct Recording {
    /// The input streams' keys, by [`wire::Stream::index`].
    pub(super) inputs: Vec<String>,
    pub(super) excitation: String,
    pub(super) status: String,
    pub(super) report: String,
    pub(super) notification: String,
    pub(super) analysis: String,
    /// `fdi/rejected`.
    pub(super) rejected: String,
    /// Per input stream (by index), the rejected records' budget.
    pub(super) rejected_budgets: Vec<recording::rejected::RejectedBudget>,
    /// Rejected samples left out of the recording (over the budget).
    pub(super) rejected_suppressed: u64,
    /// Ship time of the last accepted input sample (a rejected one is recorded at it) [s].
    pub(super) last_input_t: f64,
    /// Messages written, per channel.
    pub(super) counts: BTreeMap<String, u64>,
    /// Messages that could not be written.
    pub(super) errors: u64,
}

impl Recording {
    pub(super) fn new(keys: &Keys) -> Self {
        Self {
            inputs: wire::Stream::BY_INDEX
                .iter()
                .map(|&s| keys.stream(s))
                .collect(),
            excitation: keys.excitation(),
            status: keys.status(),
            report: keys.report(),
            notification: keys.notification(),
            analysis: recording::message::analysis_key(keys),
            rejected: recording::rejected::rejected_key(keys),
            rejected_budgets: vec![
                recording::rejected::RejectedBudget::default();
                wire::Stream::BY_INDEX.len()
            ],
            rejected_suppressed: 0,
            last_input_t: 0.0,
            counts: BTreeMap::new(),
            errors: 0,
        }
    }
}
impl VesselTask {
    /// Writes one message into the recording (when recording) and counts it.
    pub(super) fn record_message(
        &mut self,
        topic: &str,
        kind: recording::message::Kind,
        t: f64,
        payload: &[u8],
    ) {
        let Some(rec) = &self.recorder else { return };
        // A poisoned lock only means another vessel's task panicked while writing: the
        // recorder itself is still consistent (a failed write abandons its segment).
        let mut r = rec
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        match r.write(topic, kind, t, payload) {
            Ok(()) => match self.recording.counts.get_mut(topic) {
                Some(n) => *n += 1,
                None => {
                    self.recording.counts.insert(topic.to_string(), 1);
                }
            },
            Err(e) => {
                self.recording.errors += 1;
                if self.recording.errors.is_power_of_two() {
                    tracing::error!(vessel = %self.name, count = self.recording.errors, "recording: {e}");
                }
            }
        }
    }

    /// Records a rejected sample as its reason, length and head, within the stream's budget
    /// (`recording::rejected::RejectedBudget`); the rest are counted.
    pub(super) fn record_rejected(
        &mut self,
        stream: wire::Stream,
        reason: &str,
        len: usize,
        payload: &[u8],
    ) {
        if self.recorder.is_none() {
            return;
        }
        let budget = &mut self.recording.rejected_budgets[stream.index()];
        if !budget.take(Instant::now()) {
            self.recording.rejected_suppressed += 1;
            return;
        }
        let suppressed = std::mem::take(&mut budget.suppressed);
        let b = recording::rejected::rejected_record(stream, reason, len, payload, suppressed);
        let topic = self.recording.rejected.clone();
        let t = self.recording.last_input_t;
        self.record_message(&topic, recording::message::Kind::Rejected, t, &b);
    }

    /// Records a completed test's analysis: one message per grid point.
    pub(super) fn record_analysis(&mut self, a: &helmwatch_core::monitor::AnalysisRecord) {
        let topic = self.recording.analysis.clone();
        for i in 0..a.len() {
            let t = a.t0_s + i as f64 * a.dt_s;
            let point = serde_json::json!({
                "test": a.test,
                "method": a.method,
                "t": t,
                "heading": a.heading_rad[i],
                "rudder": a.rudder_rad[i],
                "excitation": a.excitation_rad[i],
            });
            if let Ok(b) = serde_json::to_vec(&point) {
                self.record_message(&topic, recording::message::Kind::Analysis, t, &b);
            }
        }
    }
}
