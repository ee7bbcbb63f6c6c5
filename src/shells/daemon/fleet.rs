//! The daemon's side of the vessels' queues: where each key's vessel is ([`Fleet`]: the
//! subscriber callbacks hand samples to it, dropping and counting on a full queue), and the
//! control queryables' server (`fdi/trigger`, `fdi/commission`, `fdi/state`), which asks the
//! vessel task that owns the core and replies with its answer.

use super::{owner, Msg, Shared, MAX_SAMPLE_BYTES};
use helmwatch_core::wire::{vessel_key, Method, Stream, TriggerReply};
use std::collections::HashMap;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};
use tokio::sync::{mpsc, oneshot, watch};
use tokio_util::sync::CancellationToken;
use zenoh::bytes::Encoding;
use zenoh::key_expr::KeyExpr;
use zenoh::query::Query;

/// The control queryables the vessels answer (see [`serve_controls`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Control {
    /// `fdi/trigger`.
    Trigger,
    /// `fdi/commission`.
    Commission,
    /// `fdi/state`.
    State,
}

/// Where a key's vessel queue is.
#[derive(Debug)]
pub(super) struct Fleet {
    /// Vessel name -> index.
    pub(super) index: HashMap<String, usize>,
    /// Vessel names, in configuration order.
    pub(super) names: Vec<String>,
    /// Each vessel's queue.
    pub(super) senders: Vec<mpsc::Sender<Msg>>,
    /// Each vessel's drop counters.
    pub(super) shared: Vec<Arc<Shared>>,
    /// Each vessel's trigger key (to match wildcard queries).
    pub(super) trigger_keys: Vec<KeyExpr<'static>>,
    /// Each vessel's commission key.
    pub(super) commission_keys: Vec<KeyExpr<'static>>,
    /// Each vessel's state key.
    pub(super) state_keys: Vec<KeyExpr<'static>>,
    /// Each vessel's role (a standby leaves the history queries to the holder).
    pub(super) roles: Vec<watch::Receiver<owner::RoleView>>,
    /// Samples on a stream key of a vessel that is not configured (wildcard subscriptions).
    pub(super) unknown: AtomicU64,
    /// Queries dropped because the trigger queue was full.
    pub(super) queries_dropped: AtomicU64,
}

impl Fleet {
    /// Whether this daemon stands by for the vessel of `key` while another holds it (it
    /// then leaves the vessel's queries to the holder: a second reply would race its answer).
    pub(super) fn leaves_to_holder(&self, key: &str) -> bool {
        self.vessel_of(key).is_some_and(|i| {
            matches!(
                self.roles[i].borrow().role,
                helmwatch_core::ownership::Role::Standby { holder: Some(_) }
            )
        })
    }

    /// The vessel of `vessels/<vessel>/...`, if configured.
    pub(super) fn vessel_of(&self, key: &str) -> Option<usize> {
        let k = vessel_key::split(key)?;
        self.index.get(k.vessel).copied()
    }

    /// Hands a sample to its vessel's queue (its head only when oversized); drops and counts
    /// when the queue is full.
    pub(super) fn dispatch(&self, stream: Stream, key: &str, payload: &[u8]) {
        let Some(i) = self.vessel_of(key) else {
            self.unknown.fetch_add(1, Ordering::Relaxed);
            return;
        };
        let len = payload.len();
        let kept = if len > MAX_SAMPLE_BYTES {
            &payload[..crate::shells::recording::rejected::REJECTED_HEAD_BYTES]
        } else {
            payload
        };
        let msg = Msg::Sample {
            stream,
            payload: kept.to_vec(),
            len,
            arrived: Instant::now(),
        };
        if let Err(mpsc::error::TrySendError::Full(_)) = self.senders[i].try_send(msg) {
            let n = self.shared[i].metrics.queue_dropped();
            if n.is_power_of_two() {
                tracing::warn!(
                    vessel = %self.names[i],
                    dropped = n,
                    "input queue full: samples dropped (flood or slow core)"
                );
            }
        }
    }
}

/// Answers the control queries: `fdi/trigger` (parameter `method=hbt|clfrt`) and
/// `fdi/commission` (parameters `start` to begin commissioning again, `method=hbt|clfrt` to
/// restrict it to one method); each vessel whose key the query matches replies.
pub(super) async fn serve_controls(
    fleet: Arc<Fleet>,
    mut rx: mpsc::Receiver<(Control, Query)>,
    cancel: CancellationToken,
) {
    loop {
        let (control, query) = tokio::select! {
            biased;
            _ = cancel.cancelled() => return,
            q = rx.recv() => match q { Some(q) => q, None => return },
        };
        let params = query.parameters();
        let method = params.get("method").map(|m| m.parse::<Method>());
        let start = params.get("start").is_some();
        let keys = match control {
            Control::Trigger => &fleet.trigger_keys,
            Control::Commission => &fleet.commission_keys,
            Control::State => &fleet.state_keys,
        };
        let qke = query.key_expr().clone();
        let targets: Vec<usize> = match fleet.vessel_of(qke.as_str()) {
            Some(i) if keys[i].intersects(&qke) => vec![i],
            _ => (0..fleet.names.len())
                .filter(|&i| keys[i].intersects(&qke))
                .collect(),
        };
        for i in targets {
            // `None`: the vessel's standby stays silent (its holder answers).
            let bytes = match (control, &method) {
                (Control::State, _) => ask_state(&fleet, i).await,
                (Control::Trigger, None) => Some(to_json(&refusal(
                    "missing parameter method=hbt|clfrt".into(),
                ))),
                (Control::Trigger, Some(Err(reason))) => {
                    Some(to_json(&refusal(reason.to_string())))
                }
                (Control::Commission, Some(Err(reason))) => {
                    Some(to_json(&serde_json::json!({ "error": reason.to_string() })))
                }
                (Control::Trigger, Some(Ok(m))) => {
                    ask_vessel(&fleet, i, *m).await.map(|r| to_json(&r))
                }
                (Control::Commission, m) => {
                    let m = m.as_ref().and_then(|m| m.as_ref().ok().copied());
                    ask_commission(&fleet, i, start, m)
                        .await
                        .map(|r| to_json(&r))
                }
            };
            let Some(bytes) = bytes else { continue };
            if let Err(e) = query
                .reply(keys[i].clone(), bytes)
                .encoding(Encoding::APPLICATION_JSON)
                .await
            {
                tracing::warn!(vessel = %fleet.names[i], "control reply failed: {e}");
            }
        }
    }
}

fn to_json(v: &impl serde::Serialize) -> Vec<u8> {
    serde_json::to_vec(v).unwrap_or_default()
}

/// Asks vessel `i` to report (and with `start` to begin again) its commissioning.
async fn ask_commission(
    fleet: &Fleet,
    i: usize,
    start: bool,
    method: Option<Method>,
) -> Option<serde_json::Value> {
    let (tx, rx) = oneshot::channel();
    let msg = Msg::Commission {
        start,
        method,
        reply: tx,
    };
    if fleet.senders[i].try_send(msg).is_err() {
        fleet.shared[i].metrics.control_dropped();
        return Some(serde_json::json!({"error": "the vessel's input queue is full"}));
    }
    match tokio::time::timeout(Duration::from_secs(5), rx).await {
        Ok(Ok(r)) => r,
        _ => Some(serde_json::json!({"error": "the vessel's monitor did not answer"})),
    }
}

/// Asks vessel `i` for its state (`None`: not the holder, or no answer).
async fn ask_state(fleet: &Fleet, i: usize) -> Option<Vec<u8>> {
    let (tx, rx) = oneshot::channel();
    if fleet.senders[i]
        .try_send(Msg::StateQuery { reply: tx })
        .is_err()
    {
        fleet.shared[i].metrics.control_dropped();
        return None;
    }
    match tokio::time::timeout(Duration::from_secs(5), rx).await {
        Ok(Ok(r)) => r,
        _ => None,
    }
}

fn refusal(reason: String) -> TriggerReply {
    TriggerReply {
        accepted: false,
        test: None,
        reason: Some(reason),
    }
}

async fn ask_vessel(fleet: &Fleet, i: usize, method: Method) -> Option<TriggerReply> {
    let (tx, rx) = oneshot::channel();
    if fleet.senders[i]
        .try_send(Msg::Trigger { method, reply: tx })
        .is_err()
    {
        fleet.shared[i].metrics.control_dropped();
        return Some(refusal("the vessel's input queue is full".into()));
    }
    match tokio::time::timeout(Duration::from_secs(5), rx).await {
        Ok(Ok(r)) => r,
        _ => Some(refusal("the vessel's monitor did not answer".into())),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shells::metrics::Metrics;

    fn fleet(capacity: usize) -> (Fleet, mpsc::Receiver<Msg>) {
        let (tx, rx) = mpsc::channel(capacity);
        let fleet = Fleet {
            index: [("self".to_string(), 0)].into_iter().collect(),
            names: vec!["self".into()],
            senders: vec![tx],
            shared: vec![Arc::new(Shared {
                metrics: Metrics::new().vessel("self"),
            })],
            trigger_keys: vec![KeyExpr::try_from("vessels/self/fdi/trigger").unwrap()],
            commission_keys: vec![KeyExpr::try_from("vessels/self/fdi/commission").unwrap()],
            state_keys: vec![KeyExpr::try_from("vessels/self/fdi/state").unwrap()],
            roles: vec![watch::channel(owner::RoleView::claiming()).1],
            unknown: AtomicU64::new(0),
            queries_dropped: AtomicU64::new(0),
        };
        (fleet, rx)
    }

    #[test]
    fn a_flood_is_dropped_and_counted_never_queued() {
        let (fleet, mut rx) = fleet(16);
        for _ in 0..100 {
            fleet.dispatch(Stream::Rudder, "vessels/self/steering/rudderAngle", b"{}");
        }
        assert_eq!(fleet.shared[0].metrics.queue_dropped_count(), 84);
        let mut queued = 0;
        while rx.try_recv().is_ok() {
            queued += 1;
        }
        assert_eq!(queued, 16);
    }

    #[test]
    fn keys_of_other_vessels_are_counted_apart() {
        let (fleet, _rx) = fleet(16);
        fleet.dispatch(Stream::Heading, "vessels/other/navigation/headingTrue", &[]);
        fleet.dispatch(Stream::Heading, "elsewhere", &[]);
        assert_eq!(fleet.unknown.load(Ordering::Relaxed), 2);
        assert_eq!(fleet.vessel_of("vessels/self/fdi/trigger"), Some(0));
    }
}
