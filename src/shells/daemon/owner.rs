//! The ownership driver: feeds one [`Ownership`] state machine per vessel with Zenoh
//! liveliness events and the wall clock, and carries out its decisions.
//!
//! Protocol (docs/contract.md "Ownership"): every daemon holds
//! `vessels/<v>/fdi/candidate/<id>` for each vessel it is configured for; the one that drives
//! a vessel also holds `vessels/<v>/fdi/holder/<id>` and `vessels/<v>/fdi/alive`. A liveliness
//! subscriber with history on `fdi/candidate/*` and `fdi/holder/*` shows each daemon every
//! other one (and, when they go, a crash, a stop or a lost link: Zenoh drops a session's
//! tokens with it). Decisions ([`helmwatch_core::ownership`]) are carried out in this order:
//!
//! - **to holder**: the vessel task is told first (it restores the replicated state and starts
//!   answering headings), then the tokens `fdi/holder/<id>` and `fdi/alive` are declared;
//! - **to standby**: the vessel task is told first (it stops answering at once: nothing more
//!   is published for the vessel), then the two tokens are undeclared;
//! - a holder that yields to another (two holders, a healed partition) declares
//!   `fdi/yielded/<id>` while it stands by: the holder it yielded to may never have seen its
//!   holder token (declared and undeclared before the routes across the healed link formed),
//!   and counts it, when this token appears, as having driven with it until then;
//! - every change is logged and published on `vessels/<v>/fdi/ownership`, and a standby that
//!   learns of a holder asks it for the vessel's state (`fdi/state`, a query); the holder
//!   also publishes it when another candidate appears.
//!
//! The vessel task reads its role from a `watch` channel (never lost, never blocks).

use super::DaemonError;
use helmwatch_core::ownership::{Event, Ownership, Role};
use helmwatch_core::wire::Keys;
use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::time::{Duration, Instant};
use tokio::sync::{mpsc, oneshot, watch};
use tokio_util::sync::CancellationToken;
use zenoh::bytes::Encoding;
use zenoh::liveliness::LivelinessToken;
use zenoh::pubsub::Subscriber;
use zenoh::sample::SampleKind;

/// What the vessel task needs to know of its role.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct RoleView {
    /// The role.
    pub role: Role,
    /// Other daemons driving the vessel at the same time (a healed partition, until they
    /// yield): reports made meanwhile are marked with them.
    pub others_holding: BTreeSet<String>,
    /// The number of this view: one more at every view sent.
    pub seq: u64,
    /// Every other daemon seen driving the vessel while this one drove, with the number of
    /// the last view at which it still did (the view that showed it gone, or the current
    /// one). The channel keeps only the latest view, so a holder that came and yielded
    /// between two reads of it is found here: it drove during a test started at view `s`
    /// when its number is above `s` (see [`RoleView::drove_since`]). One entry per daemon.
    pub last_held: BTreeMap<String, u64>,
}

impl RoleView {
    /// The role before the claim window ends.
    pub fn claiming() -> Self {
        Self {
            role: Role::Claiming,
            others_holding: BTreeSet::new(),
            seq: 0,
            last_held: BTreeMap::new(),
        }
    }

    /// The other daemons that drove the vessel with this one at any time since view `since`
    /// (taken when a test started): those driving now and those that stopped after it.
    pub fn drove_since(&self, since: u64) -> BTreeSet<String> {
        let mut ids = self.others_holding.clone();
        ids.extend(
            self.last_held
                .iter()
                .filter(|(_, &s)| s > since)
                .map(|(id, _)| id.clone()),
        );
        ids
    }

    /// The words of a refusal or a journal line: "standby, holder b".
    pub fn describe(&self) -> String {
        match &self.role {
            Role::Claiming => "standby, claiming the vessel's ownership".into(),
            Role::Holder => "holder".into(),
            Role::Standby { holder: Some(h) } => format!("standby, holder {h}"),
            Role::Standby { holder: None } => "standby, no holder: taking over".into(),
        }
    }
}

/// The `fdi/ownership` payload.
fn ownership_json(id: &str, o: &Ownership, view: &RoleView) -> serde_json::Value {
    let (role, holder) = match &view.role {
        Role::Claiming => ("claiming", None),
        Role::Holder => ("holder", Some(id.to_string())),
        Role::Standby { holder } => ("standby", holder.clone()),
    };
    serde_json::json!({
        "daemon": id,
        "role": role,
        "holder": holder,
        "candidates": o.other_candidates(),
        "other_holders": o.other_holders(),
        "reason": view.describe(),
    })
}

/// One vessel's side of the driver.
struct Vessel {
    name: String,
    keys: Keys,
    machine: Ownership,
    role: watch::Sender<RoleView>,
    /// The last view sent on `role` (its number, the holders seen).
    view: RoleView,
    /// `fdi/holder/<id>` and `fdi/alive`, while this daemon drives.
    tokens: Vec<LivelinessToken>,
    /// `fdi/yielded/<id>`, while this daemon stands by after yielding to another holder.
    yielded: Option<LivelinessToken>,
    /// Where a replicated state fetched from the holder goes (the vessel's queue).
    state_in: mpsc::Sender<super::Msg>,
}

/// The running driver: its task and its subscribers.
pub(super) struct OwnerDriver {
    pub task: tokio::task::JoinHandle<()>,
    subs: Vec<Subscriber<()>>,
    candidate_tokens: Vec<LivelinessToken>,
}

impl OwnerDriver {
    /// Declares the candidate tokens and the liveliness subscribers, starts the task; returns
    /// once every vessel's claim window ended (each vessel drives or stands by).
    #[allow(clippy::too_many_arguments)]
    pub async fn start(
        session: &zenoh::Session,
        id: &str,
        names: &[String],
        roles: Vec<watch::Sender<RoleView>>,
        state_in: Vec<mpsc::Sender<super::Msg>>,
        claim_s: f64,
        takeover_s: f64,
        cancel: CancellationToken,
    ) -> Result<OwnerDriver, DaemonError> {
        let origin = Instant::now();
        let mut candidate_tokens = Vec::with_capacity(names.len());
        for name in names {
            let key = Keys::new(name).candidate(id);
            let t = session
                .liveliness()
                .declare_token(key.clone())
                .await
                .map_err(DaemonError::declare("liveliness token", &key))?;
            candidate_tokens.push(t);
        }
        let (tx, rx) = mpsc::unbounded_channel::<(String, Seen)>();
        let single = (names.len() == 1).then(|| Keys::new(&names[0]));
        let mut subs = Vec::with_capacity(3);
        for what in ["candidate", "holder", "yielded"] {
            let key = match &single {
                Some(k) => format!("{}/fdi/{what}/*", k.prefix),
                None => format!("vessels/*/fdi/{what}/*"),
            };
            let tx = tx.clone();
            let sub = session
                .liveliness()
                .declare_subscriber(key.clone())
                .history(true)
                .callback(move |sample| {
                    if let Some((vessel, ev)) = parse(sample.key_expr().as_str(), sample.kind()) {
                        let _ = tx.send((vessel, ev));
                    }
                })
                .await
                .map_err(DaemonError::declare("liveliness subscriber", &key))?;
            subs.push(sub);
        }
        drop(tx);
        let vessels: Vec<Vessel> = names
            .iter()
            .zip(roles)
            .zip(state_in)
            .map(|((name, role), state_in)| Vessel {
                name: name.clone(),
                keys: Keys::new(name),
                machine: Ownership::new(id, 0.0, claim_s, takeover_s),
                role,
                view: RoleView::claiming(),
                tokens: Vec::new(),
                yielded: None,
                state_in,
            })
            .collect();
        let (settled_tx, settled_rx) = oneshot::channel();
        let task = tokio::spawn(run(
            session.clone(),
            id.to_string(),
            vessels,
            rx,
            origin,
            cancel,
            settled_tx,
        ));
        // The claim window, and a margin for a slow start.
        let limit = Duration::from_secs_f64(claim_s + 5.0);
        if tokio::time::timeout(limit, settled_rx).await.is_err() {
            tracing::warn!("the vessels' ownership did not settle within {limit:?}");
        }
        Ok(OwnerDriver {
            task,
            subs,
            candidate_tokens,
        })
    }

    /// Undeclares the subscribers and the candidate tokens (the task has ended: it undeclared
    /// the holder tokens).
    pub async fn stop(self) {
        let _ = self.task.await;
        for s in self.subs {
            if let Err(e) = s.undeclare().await {
                tracing::warn!("undeclaring a liveliness subscriber: {e}");
            }
        }
        for t in self.candidate_tokens {
            if let Err(e) = t.undeclare().await {
                tracing::warn!("undeclaring a candidate token: {e}");
            }
        }
    }
}

/// A liveliness event the driver acts on.
#[derive(Debug, Clone, PartialEq)]
enum Seen {
    /// A candidate or holder token: the ownership machine's input.
    Machine(Event),
    /// `fdi/yielded/<id>` appeared: that daemon drove the vessel until it yielded.
    Yielded(String),
}

/// `vessels/<v>/fdi/candidate/<id>`, `.../holder/<id>` or `.../yielded/<id>` as an event about
/// vessel `v` (a yielded token's going away says nothing).
fn parse(key: &str, kind: SampleKind) -> Option<(String, Seen)> {
    let k = helmwatch_core::wire::vessel_key::split(key)?;
    let (what, id) = k.fdi_token()?;
    let id = id.to_string();
    let up = kind == SampleKind::Put;
    let ev = match (what, up) {
        ("candidate", true) => Seen::Machine(Event::CandidateUp(id)),
        ("candidate", false) => Seen::Machine(Event::CandidateDown(id)),
        ("holder", true) => Seen::Machine(Event::HolderUp(id)),
        ("holder", false) => Seen::Machine(Event::HolderDown(id)),
        ("yielded", true) => Seen::Yielded(id),
        _ => return None,
    };
    Some((k.vessel.to_string(), ev))
}

async fn run(
    session: zenoh::Session,
    id: String,
    mut vessels: Vec<Vessel>,
    mut rx: mpsc::UnboundedReceiver<(String, Seen)>,
    origin: Instant,
    cancel: CancellationToken,
    settled: oneshot::Sender<()>,
) {
    let index: HashMap<String, usize> = vessels
        .iter()
        .enumerate()
        .map(|(i, v)| (v.name.clone(), i))
        .collect();
    let now = || origin.elapsed().as_secs_f64();
    let mut settled = Some(settled);
    loop {
        let next = vessels
            .iter()
            .filter_map(|v| v.machine.poll_timeout())
            .fold(f64::INFINITY, f64::min);
        let sleep = if next.is_finite() {
            let wait = (next - now()).max(0.0);
            tokio::time::sleep(Duration::from_secs_f64(wait))
        } else {
            tokio::time::sleep(Duration::from_secs(3600))
        };
        tokio::select! {
            biased;
            _ = cancel.cancelled() => break,
            ev = rx.recv() => match ev {
                Some((vessel, Seen::Yielded(other))) => {
                    if let Some(&i) = index.get(&vessel) {
                        if other != id {
                            yielded_to_me(&mut vessels[i], &other);
                        }
                    }
                }
                Some((vessel, Seen::Machine(ev))) => {
                    if let Some(&i) = index.get(&vessel) {
                        if matches!(&ev, Event::CandidateUp(c) if *c != id)
                            && vessels[i].machine.role().drives()
                        {
                            // A new standby: it gets the state now, not at the next decision.
                            let _ = vessels[i].state_in.try_send(super::Msg::CandidateJoined);
                        }
                        let t = now();
                        let before = vessels[i].machine.other_holders().clone();
                        let change = vessels[i].machine.handle(t, ev);
                        let v = &mut vessels[i];
                        apply(&session, &id, v, change, &before).await;
                    }
                }
                None => break,
            },
            _ = sleep => {
                let t = now();
                for v in vessels.iter_mut() {
                    if v.machine.poll_timeout().is_some_and(|d| d <= t) {
                        let before = v.machine.other_holders().clone();
                        let change = v.machine.handle_timeout(t);
                        apply(&session, &id, v, change, &before).await;
                    }
                }
            }
        }
        if settled.is_some() && vessels.iter().all(|v| *v.machine.role() != Role::Claiming) {
            if let Some(s) = settled.take() {
                let _ = s.send(());
            }
        }
    }
    for v in vessels {
        for t in v.tokens.into_iter().chain(v.yielded) {
            if let Err(e) = t.undeclare().await {
                tracing::warn!(vessel = %v.name, "undeclaring a holder token: {e}");
            }
        }
    }
}

/// Another daemon says it drove the vessel until it yielded: while this one drives, it is
/// counted as having driven with it until now (a test started before this moment is marked).
/// It may have yielded to this very daemon before its holder token was ever seen here.
fn yielded_to_me(v: &mut Vessel, other: &str) {
    if !v.machine.role().drives() {
        return;
    }
    let mut view = v.view.clone();
    view.seq += 1;
    view.last_held.insert(other.to_string(), view.seq);
    tracing::warn!(vessel = %v.name, other, "another daemon drove this vessel until it yielded (a healed partition): the report of the test under way is marked");
    v.view = view.clone();
    v.role.send_replace(view);
}

/// Carries out a change of role (or of the other holders seen while holding).
async fn apply(
    session: &zenoh::Session,
    id: &str,
    v: &mut Vessel,
    change: Option<Role>,
    holders_before: &BTreeSet<String>,
) {
    let others = v.machine.other_holders().clone();
    let drives = v.machine.role().drives();
    let changed = change.is_some() || (drives && others != *holders_before);
    if !changed {
        return;
    }
    // The next view: the holders that drove with this daemon until now, and those that do.
    let mut view = v.view.clone();
    view.seq += 1;
    if view.role.drives() {
        for id in holders_before {
            view.last_held.insert(id.clone(), view.seq);
        }
    }
    view.role = v.machine.role().clone();
    view.others_holding = if drives {
        others.clone()
    } else {
        BTreeSet::new()
    };
    for id in &view.others_holding {
        view.last_held.insert(id.clone(), view.seq);
    }
    v.view = view.clone();
    let Some(role) = change else {
        if !others.is_empty() {
            tracing::warn!(vessel = %v.name, others = ?others, "another daemon drives this vessel too (a healed partition): it yields, reports meanwhile are marked");
        }
        v.role.send_replace(view);
        return;
    };
    // The vessel task first: it stops (or starts) driving before the world is told.
    v.role.send_replace(view.clone());
    match &role {
        Role::Holder => {
            if let Some(t) = v.yielded.take() {
                if let Err(e) = t.undeclare().await {
                    tracing::warn!(vessel = %v.name, "undeclaring the yielded token: {e}");
                }
            }
            for key in [v.keys.holder(id), v.keys.alive()] {
                match session.liveliness().declare_token(key.clone()).await {
                    Ok(t) => v.tokens.push(t),
                    Err(e) => tracing::error!(vessel = %v.name, "declaring {key}: {e}"),
                }
            }
            tracing::info!(vessel = %v.name, daemon = id, standbys = ?v.machine.other_candidates(), "holding the vessel: driving it");
        }
        Role::Standby { holder } => {
            let was_holding = !v.tokens.is_empty();
            for t in v.tokens.drain(..) {
                if let Err(e) = t.undeclare().await {
                    tracing::warn!(vessel = %v.name, "undeclaring a holder token: {e}");
                }
            }
            if was_holding && v.yielded.is_none() {
                let key = v.keys.yielded(id);
                match session.liveliness().declare_token(key.clone()).await {
                    Ok(t) => v.yielded = Some(t),
                    Err(e) => tracing::error!(vessel = %v.name, "declaring {key}: {e}"),
                }
            }
            tracing::warn!(vessel = %v.name, daemon = id, holder = ?holder, "{}: no excitation, no tests, no reports", view.describe());
            if holder.is_some() {
                fetch_state(session, v);
            }
        }
        Role::Claiming => {}
    }
    let body = ownership_json(id, &v.machine, &view);
    if let Err(e) = session
        .put(v.keys.ownership(), body.to_string())
        .encoding(Encoding::APPLICATION_JSON)
        .await
    {
        tracing::warn!(vessel = %v.name, "publishing fdi/ownership: {e}");
    }
}

/// Asks the holder for the vessel's state (a standby that came late has seen no publication
/// of it); the answer goes to the vessel task like a publication.
fn fetch_state(session: &zenoh::Session, v: &Vessel) {
    let session = session.clone();
    let key = v.keys.state();
    let tx = v.state_in.clone();
    let vessel = v.name.clone();
    tokio::spawn(async move {
        let replies = match session.get(&key).timeout(Duration::from_secs(5)).await {
            Ok(r) => r,
            Err(e) => {
                tracing::warn!(%vessel, "asking for the vessel's state: {e}");
                return;
            }
        };
        while let Ok(reply) = replies.recv_async().await {
            if let Ok(sample) = reply.result() {
                let payload = sample.payload().to_bytes().into_owned();
                let _ = tx.send(super::Msg::State { payload }).await;
            }
        }
    });
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn token_keys_parse_into_events_of_their_vessel() {
        assert_eq!(
            parse("vessels/self/fdi/candidate/a-1", SampleKind::Put),
            Some((
                "self".into(),
                Seen::Machine(Event::CandidateUp("a-1".into()))
            ))
        );
        assert_eq!(
            parse("vessels/v2/fdi/holder/b", SampleKind::Delete),
            Some(("v2".into(), Seen::Machine(Event::HolderDown("b".into()))))
        );
        assert_eq!(
            parse("vessels/v2/fdi/yielded/b", SampleKind::Put),
            Some(("v2".into(), Seen::Yielded("b".into())))
        );
        assert_eq!(parse("vessels/v2/fdi/yielded/b", SampleKind::Delete), None);
        assert_eq!(parse("vessels/v2/fdi/alive", SampleKind::Put), None);
        assert_eq!(parse("elsewhere/fdi/holder/b", SampleKind::Put), None);
    }
}
