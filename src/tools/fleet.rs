//! `helmwatch fleet`: every vessel whose daemon is alive, its state, alarm and last decision,
//! kept up to date from what the daemons publish.
//!
//! Sources (docs/contract.md): the liveliness tokens `vessels/*/fdi/alive` through a
//! liveliness subscriber with history (vessels already alive when the view starts appear at
//! once; a token that goes away marks its vessel gone), the ownership tokens
//! `vessels/*/fdi/holder/*` and `vessels/*/fdi/candidate/*` the same way (which daemon drives
//! each vessel, which stand by), `vessels/*/fdi/status`,
//! `vessels/*/notifications/steering/fdi` and `vessels/*/fdi/report`. [`FleetView`] is the
//! table, updated by [`Event`]s without I/O; [`watch`] is the Zenoh driver around it. A
//! vessel's state and alarm are known from the first message after the view started (the
//! daemon publishes them on change); until then they show as `-`.

use helmwatch_core::wire::{
    vessel_key, AlarmState, Decision, Method, MonitorState, Notification, Status,
};
use serde::Serialize;
use std::collections::BTreeMap;
use std::future::Future;

/// Whether a vessel's daemon holds its token.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum Presence {
    /// Heard from, token not (yet) seen.
    #[default]
    Unknown,
    /// The daemon holds `fdi/alive`.
    Alive,
    /// The token went away (the daemon stopped or is unreachable).
    Gone,
}

/// One vessel's line of the table.
#[derive(Debug, Clone, PartialEq, Serialize, Default)]
pub struct VesselRow {
    /// The daemon's token.
    pub presence: Presence,
    /// Monitor state from the last `fdi/status`.
    pub state: Option<MonitorState>,
    /// The running test (last status).
    pub test: Option<String>,
    /// Its method.
    pub method: Option<Method>,
    /// Ship time of the last status [s].
    pub status_t: Option<f64>,
    /// Alarm state from the last notification.
    pub alarm: Option<AlarmState>,
    /// Its message.
    pub alarm_message: Option<String>,
    /// The last report's test id.
    pub last_test: Option<String>,
    /// The last report's decision.
    pub last_decision: Option<Decision>,
    /// The last report's `t_end` [s].
    pub last_t_end: Option<f64>,
    /// The last report's message.
    pub last_message: Option<String>,
    /// The daemons holding the vessel (`fdi/holder/<id>`; two only while a healed partition
    /// settles).
    pub holders: Vec<String>,
    /// The daemons standing by (`fdi/candidate/<id>` without a holder token).
    pub standbys: Vec<String>,
    /// Every candidate seen alive (not shown: `standbys` is derived from it).
    #[serde(skip)]
    pub candidates: Vec<String>,
}

/// What happened to one vessel.
#[derive(Debug, Clone, PartialEq)]
pub enum Event {
    /// Its token appeared.
    Alive(String),
    /// Its token went away.
    Gone(String),
    /// A status.
    Status(String, Status),
    /// A notification.
    Notification(String, Notification),
    /// A report (only `test`, `decision`, `t_end`, `message` are read).
    Report(String, serde_json::Value),
    /// A daemon's token `fdi/holder/<id>` (true) or `fdi/candidate/<id>` (false) appeared
    /// (`up`) or went away.
    Owner {
        /// The vessel.
        vessel: String,
        /// The daemon.
        daemon: String,
        /// A holder token (else a candidate token).
        holder: bool,
        /// Appeared (else went away).
        up: bool,
    },
}

impl Event {
    /// The vessel it concerns.
    pub fn vessel(&self) -> &str {
        match self {
            Event::Alive(v) | Event::Gone(v) => v,
            Event::Status(v, _) | Event::Notification(v, _) | Event::Report(v, _) => v,
            Event::Owner { vessel, .. } => vessel,
        }
    }
    /// Its name in `--json` output.
    pub fn name(&self) -> &'static str {
        match self {
            Event::Alive(_) => "alive",
            Event::Gone(_) => "gone",
            Event::Status(..) => "status",
            Event::Notification(..) => "alarm",
            Event::Report(..) => "report",
            Event::Owner { .. } => "ownership",
        }
    }
}

/// The event of a sample on `key` (a liveliness sample: `delete` when the token went away);
/// `None` for a key or payload that is not one (ignored).
pub fn event_of(key: &str, delete: bool, payload: &[u8]) -> Option<Event> {
    let k = vessel_key::split(key)?;
    let v = k.vessel.to_string();
    match k.rest {
        "fdi/alive" if delete => Some(Event::Gone(v)),
        "fdi/alive" => Some(Event::Alive(v)),
        "fdi/status" => serde_json::from_slice(payload)
            .ok()
            .map(|s| Event::Status(v, s)),
        "notifications/steering/fdi" => serde_json::from_slice(payload)
            .ok()
            .map(|n| Event::Notification(v, n)),
        "fdi/report" => serde_json::from_slice::<serde_json::Value>(payload)
            .ok()
            .filter(serde_json::Value::is_object)
            .map(|r| Event::Report(v, r)),
        _ => {
            let (what, daemon) = k.fdi_token()?;
            let holder = match what {
                "holder" => true,
                "candidate" => false,
                _ => return None,
            };
            (!daemon.is_empty() && !daemon.contains('/')).then(|| Event::Owner {
                vessel: v,
                daemon: daemon.to_string(),
                holder,
                up: !delete,
            })
        }
    }
}

/// Most vessels the view keeps (a flood of made-up names cannot exhaust memory).
pub const MAX_VESSELS: usize = 10_000;

/// The fleet table.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct FleetView {
    vessels: BTreeMap<String, VesselRow>,
}

impl FleetView {
    /// Applies `e`; returns whether the table changed.
    pub fn apply(&mut self, e: &Event) -> bool {
        if !self.vessels.contains_key(e.vessel()) && self.vessels.len() >= MAX_VESSELS {
            return false;
        }
        let row = self.vessels.entry(e.vessel().to_string()).or_default();
        let before = row.clone();
        match e {
            Event::Alive(_) => row.presence = Presence::Alive,
            Event::Gone(_) => row.presence = Presence::Gone,
            Event::Status(_, s) => {
                row.state = Some(s.state);
                row.test = s.test.clone();
                row.method = s.method;
                row.status_t = Some(s.t);
            }
            Event::Notification(_, n) => {
                row.alarm = Some(n.state);
                row.alarm_message = Some(n.message.clone());
            }
            Event::Report(_, r) => {
                row.last_test = r["test"].as_str().map(String::from);
                row.last_decision = serde_json::from_value(r["decision"].clone()).ok();
                row.last_t_end = r["t_end"].as_f64();
                row.last_message = r["message"].as_str().map(String::from);
            }
            Event::Owner {
                daemon, holder, up, ..
            } => {
                let list = if *holder {
                    &mut row.holders
                } else {
                    &mut row.candidates
                };
                list.retain(|d| d != daemon);
                if *up && list.len() < 64 {
                    list.push(daemon.clone());
                    list.sort();
                }
                row.standbys = row
                    .candidates
                    .iter()
                    .filter(|c| !row.holders.contains(c))
                    .cloned()
                    .collect();
            }
        }
        *row != before
    }

    /// The rows, by vessel name.
    pub fn rows(&self) -> &BTreeMap<String, VesselRow> {
        &self.vessels
    }

    /// The `--json` line of a change: `{"change", "vessel", ...the vessel's row}`.
    pub fn change_json(&self, e: &Event) -> serde_json::Value {
        let mut v = serde_json::json!({"change": e.name(), "vessel": e.vessel()});
        if let (Some(obj), Some(row)) = (
            v.as_object_mut(),
            self.vessels
                .get(e.vessel())
                .and_then(|r| serde_json::to_value(r).ok()),
        ) {
            if let Some(fields) = row.as_object() {
                obj.extend(fields.clone());
            }
        }
        v
    }

    /// The table as text, one line per vessel.
    pub fn table(&self) -> String {
        fn name<T: Serialize>(x: &Option<T>) -> String {
            x.as_ref()
                .and_then(|v| serde_json::to_value(v).ok())
                .and_then(|v| v.as_str().map(String::from))
                .unwrap_or_else(|| "-".into())
        }
        let mut out = format!(
            "{:<16}  {:<7}  {:<16}  {:<16}  {:<9}  {:<26}  {:<6}  {:<12}  {:>9}  message\n",
            "vessel", "daemon", "holder", "standby", "state", "test", "alarm", "last", "t_end [s]"
        );
        let list = |l: &[String]| {
            if l.is_empty() {
                "-".to_string()
            } else {
                l.join(",")
            }
        };
        for (v, r) in &self.vessels {
            let presence = match r.presence {
                Presence::Alive => "alive",
                Presence::Gone => "GONE",
                Presence::Unknown => "?",
            };
            out.push_str(&format!(
                "{:<16}  {:<7}  {:<16}  {:<16}  {:<9}  {:<26}  {:<6}  {:<12}  {:>9}  {}\n",
                v,
                presence,
                list(&r.holders),
                list(&r.standbys),
                name(&r.state),
                r.test.as_deref().unwrap_or("-"),
                name(&r.alarm),
                name(&r.last_decision),
                r.last_t_end.map_or("-".into(), |t| format!("{t:.0}")),
                r.last_message.as_deref().unwrap_or("")
            ));
        }
        out
    }
}

/// Why the view could not run.
#[derive(Debug, thiserror::Error)]
pub enum FleetError {
    /// The session could not be opened.
    #[error("zenoh session: {0}")]
    Session(String),
    /// A subscriber could not be declared.
    #[error("subscribing to {key}: {reason}")]
    Subscribe {
        /// Its key expression.
        key: &'static str,
        /// Zenoh's reason.
        reason: String,
    },
}

/// Watches the fleet over a session opened with `zcfg` until `stop` completes, calling
/// `on_change(view, event)` after every event that changed the table. Returns the last table.
pub async fn watch(
    zcfg: zenoh::Config,
    stop: impl Future<Output = ()>,
    mut on_change: impl FnMut(&FleetView, &Event),
) -> Result<FleetView, FleetError> {
    let session = zenoh::open(zcfg)
        .await
        .map_err(|e| FleetError::Session(e.to_string()))?;
    let result = watch_on(&session, stop, &mut on_change).await;
    let _ = session.close().await;
    result
}

async fn watch_on(
    session: &zenoh::Session,
    stop: impl Future<Output = ()>,
    on_change: &mut impl FnMut(&FleetView, &Event),
) -> Result<FleetView, FleetError> {
    const ALIVE: &str = "vessels/*/fdi/alive";
    const STATUS: &str = "vessels/*/fdi/status";
    const ALARM: &str = "vessels/*/notifications/steering/fdi";
    const REPORT: &str = "vessels/*/fdi/report";
    const HOLDER: &str = "vessels/*/fdi/holder/*";
    const CANDIDATE: &str = "vessels/*/fdi/candidate/*";
    let err = |key: &'static str| {
        move |e: zenoh::Error| FleetError::Subscribe {
            key,
            reason: e.to_string(),
        }
    };
    let status = session
        .declare_subscriber(STATUS)
        .await
        .map_err(err(STATUS))?;
    let alarm = session
        .declare_subscriber(ALARM)
        .await
        .map_err(err(ALARM))?;
    let report = session
        .declare_subscriber(REPORT)
        .await
        .map_err(err(REPORT))?;
    let alive = session
        .liveliness()
        .declare_subscriber(ALIVE)
        .history(true)
        .await
        .map_err(err(ALIVE))?;
    let holder = session
        .liveliness()
        .declare_subscriber(HOLDER)
        .history(true)
        .await
        .map_err(err(HOLDER))?;
    let candidate = session
        .liveliness()
        .declare_subscriber(CANDIDATE)
        .history(true)
        .await
        .map_err(err(CANDIDATE))?;
    let mut view = FleetView::default();
    tokio::pin!(stop);
    loop {
        let sample = tokio::select! {
            () = &mut stop => break,
            s = alive.recv_async() => s,
            s = status.recv_async() => s,
            s = alarm.recv_async() => s,
            s = report.recv_async() => s,
            s = holder.recv_async() => s,
            s = candidate.recv_async() => s,
        };
        let Ok(sample) = sample else { break };
        let delete = sample.kind() == zenoh::sample::SampleKind::Delete;
        let bytes = sample.payload().to_bytes();
        if let Some(e) = event_of(sample.key_expr().as_str(), delete, &bytes) {
            if view.apply(&e) {
                on_change(&view, &e);
            }
        }
    }
    let _ = alive.undeclare().await;
    let _ = status.undeclare().await;
    let _ = alarm.undeclare().await;
    let _ = report.undeclare().await;
    let _ = holder.undeclare().await;
    let _ = candidate.undeclare().await;
    Ok(view)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn events_update_the_table_and_report_changes() {
        let mut v = FleetView::default();
        let alive = event_of("vessels/a/fdi/alive", false, b"").unwrap();
        assert_eq!(alive, Event::Alive("a".into()));
        assert!(v.apply(&alive));
        assert!(!v.apply(&alive), "no change the second time");
        let st = event_of(
            "vessels/a/fdi/status",
            false,
            br#"{"t": 5.0, "state": "settling", "test": "a-hbt-5-1", "method": "hbt", "reason": null}"#,
        )
        .unwrap();
        assert!(v.apply(&st));
        let n = event_of(
            "vessels/a/notifications/steering/fdi",
            false,
            br#"{"state": "alarm", "method": ["visual"], "message": "displacement"}"#,
        )
        .unwrap();
        assert!(v.apply(&n));
        let r = event_of(
            "vessels/a/fdi/report",
            false,
            br#"{"test": "a-hbt-5-1", "decision": "fault", "t_end": 900.0, "message": "m"}"#,
        )
        .unwrap();
        assert!(v.apply(&r));
        let row = &v.rows()["a"];
        assert_eq!(row.presence, Presence::Alive);
        assert_eq!(row.state, Some(MonitorState::Settling));
        assert_eq!(row.alarm, Some(AlarmState::Alarm));
        assert_eq!(row.last_decision, Some(Decision::Fault));
        assert_eq!(row.last_t_end, Some(900.0));
        let gone = event_of("vessels/a/fdi/alive", true, b"").unwrap();
        assert!(v.apply(&gone));
        let j = v.change_json(&gone);
        assert_eq!(j["change"], "gone");
        assert_eq!(j["presence"], "gone");
        assert_eq!(j["state"], "settling");
        assert!(v.table().contains("GONE"), "{}", v.table());
        // Not ours, or not a payload: ignored.
        assert_eq!(event_of("vessels/a/fdi/stats", false, b"{}"), None);
        assert_eq!(event_of("vessels/a/fdi/status", false, b"nope"), None);
        assert_eq!(event_of("other/a/fdi/alive", false, b""), None);
    }

    #[test]
    fn holder_and_standby_per_vessel_from_the_ownership_tokens() {
        let mut v = FleetView::default();
        for (key, delete) in [
            ("vessels/a/fdi/candidate/bridge", false),
            ("vessels/a/fdi/candidate/engine", false),
            ("vessels/a/fdi/holder/bridge", false),
        ] {
            assert!(v.apply(&event_of(key, delete, b"").unwrap()), "{key}");
        }
        let row = &v.rows()["a"];
        assert_eq!(row.holders, ["bridge"]);
        assert_eq!(row.standbys, ["engine"]);
        assert!(v.table().contains("bridge"), "{}", v.table());
        // The holder dies; the standby takes over.
        for (key, delete) in [
            ("vessels/a/fdi/holder/bridge", true),
            ("vessels/a/fdi/candidate/bridge", true),
            ("vessels/a/fdi/holder/engine", false),
        ] {
            v.apply(&event_of(key, delete, b"").unwrap());
        }
        let row = &v.rows()["a"];
        assert_eq!(row.holders, ["engine"]);
        assert!(row.standbys.is_empty());
        let j = v.change_json(&Event::Alive("a".into()));
        assert_eq!(j["holders"], serde_json::json!(["engine"]));
        assert_eq!(event_of("vessels/a/fdi/holder/", false, b""), None);
        assert_eq!(event_of("vessels/a/fdi/owner/x", false, b""), None);
    }
}
