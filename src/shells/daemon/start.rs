//! The steps of [`Daemon::start_fleet`](super::Daemon::start_fleet), in the order it takes
//! them: the vessels' shared parts, the stores, the vessel tasks, the subscribers, the control
//! and history queryables, the wait for every role, the metrics endpoint.

use super::config::DaemonConfig;
use super::fleet::{serve_controls, Control, Fleet};
use super::publishers::Publishers;
use super::vessel::{self, VesselTask};
use super::vessel_recording::Recording;
use super::{owner, DaemonError, Msg, Parts, Shared, VesselSummary};
use crate::shells::history::History;
use crate::shells::metrics::Metrics;
use crate::shells::recording::Recorder;
use crate::shells::state::StateDir;
use helmwatch_core::monitor::config::CoreConfig;
use helmwatch_core::monitor::Monitor;
use helmwatch_core::wire::{Keys, Stream};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;
use tokio::sync::{mpsc, oneshot, watch};
use tokio_util::sync::CancellationToken;
use zenoh::key_expr::KeyExpr;
use zenoh::pubsub::Subscriber;
use zenoh::query::{Query, Queryable};

/// Checks each distinct core configuration once and builds its parts (the estimator, the
/// multisine); returns the parts and, per vessel, the index of its parts.
pub(super) fn design_parts(
    vessels: &[(String, CoreConfig)],
    cfg: &DaemonConfig,
) -> Result<(Vec<Parts>, Vec<usize>), DaemonError> {
    let mut cores: Vec<(&CoreConfig, Parts)> = Vec::new();
    let mut part_of = Vec::with_capacity(vessels.len());
    for (_, core) in vessels {
        let i = match cores.iter().position(|(c, _)| *c == core) {
            Some(i) => i,
            None => {
                core.check()?;
                if cfg.takeover_s <= core.safety.hold_s {
                    return Err(helmwatch_core::config::fail(
                        "daemon.takeover-s",
                        cfg.takeover_s,
                        &format!(
                            "greater than safety.hold-s ({} s): the old driver's last excitation expires first",
                            core.safety.hold_s
                        ),
                    )
                    .into());
                }
                let estimator = helmwatch_core::estimator::Estimator::from_config(core)?;
                let multisine = Monitor::design_multisine(core).ok();
                cores.push((core, (multisine, estimator)));
                cores.len() - 1
            }
        };
        part_of.push(i);
    }
    Ok((cores.into_iter().map(|(_, p)| p).collect(), part_of))
}

/// The report history in the state directory, when there is one.
pub(super) fn open_history(cfg: &DaemonConfig) -> Result<Option<Arc<History>>, DaemonError> {
    Ok(match &cfg.state_dir {
        Some(dir) => {
            let (h, note) = History::open(
                std::path::Path::new(dir),
                cfg.history_days,
                cfg.history_max_records,
            )?;
            if let Some(n) = note {
                tracing::error!("{n}");
            }
            Some(Arc::new(h))
        }
        None => None,
    })
}

/// The MCAP recorder in `<state-dir>/recordings`, when `daemon.record`.
pub(super) fn open_recorder(
    cfg: &DaemonConfig,
) -> Result<Option<Arc<Mutex<Recorder>>>, DaemonError> {
    Ok(match (cfg.record, &cfg.state_dir) {
        (false, _) => None,
        (true, None) => {
            return Err(helmwatch_core::config::fail(
                "daemon.record",
                "true",
                "false without a state directory (daemon.state-dir or run --state-dir)",
            )
            .into())
        }
        (true, Some(dir)) => {
            let dir = std::path::Path::new(dir).join("recordings");
            let r = Recorder::open(&dir, cfg.recording_limits())?;
            tracing::info!(dir = %dir.display(), "recording into MCAP files");
            Some(Arc::new(Mutex::new(r)))
        }
    })
}

/// What every vessel task shares: the stores, the daemon's settings.
pub(super) struct Common<'a> {
    pub(super) cfg: &'a DaemonConfig,
    pub(super) daemon_id: &'a str,
    pub(super) state: Option<StateDir>,
    pub(super) history: Option<Arc<History>>,
    pub(super) recorder: Option<Arc<Mutex<Recorder>>>,
    pub(super) cancel: &'a CancellationToken,
}

/// The vessel tasks spawned and what the rest of the start needs of them.
pub(super) struct Spawned {
    pub(super) fleet: Arc<Fleet>,
    /// Each vessel's role, for the ownership driver.
    pub(super) roles: Vec<watch::Sender<owner::RoleView>>,
    pub(super) vessel_tasks: Vec<tokio::task::JoinHandle<VesselSummary>>,
    /// Told when each vessel task has taken up its first role.
    pub(super) settled: Vec<oneshot::Receiver<()>>,
}

/// Declares each vessel's publishers and spawns its task; registers the queues' metrics.
pub(super) async fn spawn_vessels(
    session: &zenoh::Session,
    vessels: &[(String, CoreConfig)],
    parts: &[Parts],
    part_of: &[usize],
    common: &Common<'_>,
    metrics: &mut Metrics,
) -> Result<Spawned, DaemonError> {
    let cfg = common.cfg;
    let names: Vec<String> = vessels.iter().map(|(n, _)| n.clone()).collect();
    let capacity = cfg.queue_capacity as usize;
    let mut senders = Vec::with_capacity(names.len());
    let mut shared = Vec::with_capacity(names.len());
    let mut trigger_keys = Vec::with_capacity(names.len());
    let mut commission_keys = Vec::with_capacity(names.len());
    let mut state_keys = Vec::with_capacity(names.len());
    let mut roles = Vec::with_capacity(names.len());
    let mut vessel_tasks = Vec::with_capacity(names.len());
    let mut settled = Vec::with_capacity(names.len());
    for (v, (name, core)) in vessels.iter().enumerate() {
        let keys = Keys::new(name);
        let pubs = Publishers::declare(session, &keys, cfg.publish_stats).await?;
        let (tx, rx) = mpsc::channel(capacity);
        let sh = Arc::new(Shared {
            metrics: metrics.vessel(name),
        });
        let trigger_key =
            KeyExpr::try_from(keys.trigger()).map_err(DaemonError::declare("trigger key", name))?;
        let commission_key = KeyExpr::try_from(keys.commission())
            .map_err(DaemonError::declare("commission key", name))?;
        let state_key =
            KeyExpr::try_from(keys.state()).map_err(DaemonError::declare("state key", name))?;
        let (role_tx, role_rx) = watch::channel(owner::RoleView::claiming());
        roles.push(role_tx);
        let (settled_tx, settled_rx) = oneshot::channel();
        settled.push(settled_rx);
        let task = vessel_task(
            name,
            core,
            &parts[part_of[v]],
            common,
            VesselWiring {
                keys: &keys,
                rx,
                pubs,
                shared: sh.clone(),
                role_rx,
                settled: settled_tx,
            },
        );
        vessel_tasks.push(tokio::spawn(task.run(common.cancel.clone())));
        senders.push(tx);
        shared.push(sh);
        trigger_keys.push(trigger_key);
        commission_keys.push(commission_key);
        state_keys.push(state_key);
    }
    metrics.register_queues(
        names
            .iter()
            .cloned()
            .zip(senders.iter().map(mpsc::Sender::downgrade))
            .collect(),
    );
    let fleet = Arc::new(Fleet {
        index: names
            .iter()
            .enumerate()
            .map(|(i, n)| (n.clone(), i))
            .collect(),
        names: names.clone(),
        senders,
        shared,
        trigger_keys,
        commission_keys,
        state_keys,
        roles: roles.iter().map(watch::Sender::subscribe).collect(),
        unknown: AtomicU64::new(0),
        queries_dropped: AtomicU64::new(0),
    });
    Ok(Spawned {
        fleet,
        roles,
        vessel_tasks,
        settled,
    })
}

/// One vessel task's own ends: its queue, publishers, counters and role.
struct VesselWiring<'a> {
    keys: &'a Keys,
    rx: mpsc::Receiver<Msg>,
    pubs: Publishers,
    shared: Arc<Shared>,
    role_rx: watch::Receiver<owner::RoleView>,
    settled: oneshot::Sender<()>,
}

/// The task of vessel `name`, its core fresh (the state is taken up when the vessel is taken
/// over: from the holder's publication, else from the state directory).
fn vessel_task(
    name: &str,
    core: &CoreConfig,
    (multisine, estimator): &Parts,
    common: &Common<'_>,
    w: VesselWiring<'_>,
) -> VesselTask {
    let cfg = common.cfg;
    let recorder = &common.recorder;
    let mut monitor = Monitor::with_parts(core, name, multisine.clone(), estimator.clone());
    monitor.set_analysis_output(recorder.is_some());
    let restored = None;
    w.shared.metrics.alarm(monitor.alarm_state());
    let seen_aborts = monitor.stats().aborts.clone();
    VesselTask {
        seen_aborts,
        pending_heading: None,
        monitor,
        name: name.to_string(),
        state: common.state.clone(),
        history: common.history.clone(),
        last_report_t: f64::NAN,
        restored,
        rx: w.rx,
        pubs: w.pubs,
        shared: w.shared,
        last_heading: None,
        tick: Duration::from_secs_f64(cfg.tick_s),
        stats_period: (cfg.stats_period_s > 0.0)
            .then(|| Duration::from_secs_f64(cfg.stats_period_s)),
        shutdown_timeout: Duration::from_secs_f64(cfg.shutdown_timeout_s),
        publish_errors: 0,
        recorder: recorder.clone(),
        recording: Recording::new(w.keys),
        fresh: vessel::Fresh {
            core: core.clone(),
            multisine: multisine.clone(),
            estimator: estimator.clone(),
            analysis: recorder.is_some(),
        },
        daemon_id: common.daemon_id.to_string(),
        role_rx: w.role_rx,
        driving: false,
        replica: None,
        refused_states: 0,
        concurrent_since: 0,
        settled: Some(w.settled),
    }
}

/// The subscribers: one per vessel and input stream, on exact keys, and the vessels'
/// replicated state.
pub(super) async fn declare_subscribers(
    session: &zenoh::Session,
    fleet: &Arc<Fleet>,
    single: Option<&Keys>,
) -> Result<Vec<Subscriber<()>>, DaemonError> {
    // (A wildcard subscription per stream would be fewer declarations, but Zenoh then
    // computes the route of every sample: a fleet daemon kept up with a third as many
    // vessels in the benchmark.)
    let names = &fleet.names;
    let mut sub_keys = Vec::with_capacity(Stream::ALL.len() * names.len());
    for n in names {
        let keys = Keys::new(n);
        for stream in Stream::ALL {
            sub_keys.push((stream, keys.stream(stream)));
        }
    }
    let mut subscribers = Vec::with_capacity(sub_keys.len());
    for (stream, key) in sub_keys {
        let f = fleet.clone();
        let sub = session
            .declare_subscriber(key.clone())
            .callback(move |sample| {
                let payload = sample.payload().to_bytes();
                f.dispatch(stream, sample.key_expr().as_str(), &payload);
            })
            .await
            .map_err(DaemonError::declare("subscriber", &key))?;
        subscribers.push(sub);
    }
    // The vessels' replicated state, from whichever daemon holds them (a standby keeps
    // it; the holder ignores it).
    let state_sub_key = single.map_or("vessels/*/fdi/state".into(), Keys::state);
    let f = fleet.clone();
    let sub = session
        .declare_subscriber(state_sub_key.clone())
        .callback(move |sample| {
            if let Some(i) = f.vessel_of(sample.key_expr().as_str()) {
                let payload = sample.payload().to_bytes().into_owned();
                if f.senders[i].try_send(Msg::State { payload }).is_err() {
                    f.shared[i].metrics.control_dropped();
                }
            }
        })
        .await
        .map_err(DaemonError::declare("subscriber", &state_sub_key))?;
    subscribers.push(sub);
    Ok(subscribers)
}

/// The control queryables (trigger, commission, state) and the task that serves them.
pub(super) async fn declare_controls(
    session: &zenoh::Session,
    fleet: &Arc<Fleet>,
    single: Option<&Keys>,
    cancel: &CancellationToken,
) -> Result<(Vec<Queryable<()>>, tokio::task::JoinHandle<()>), DaemonError> {
    let (qtx, qrx) = mpsc::channel::<(Control, Query)>(64);
    let mut queryables = Vec::with_capacity(2);
    for (control, key) in [
        (
            Control::Trigger,
            single.map_or("vessels/*/fdi/trigger".into(), Keys::trigger),
        ),
        (
            Control::Commission,
            single.map_or("vessels/*/fdi/commission".into(), Keys::commission),
        ),
        (
            Control::State,
            single.map_or("vessels/*/fdi/state".into(), Keys::state),
        ),
    ] {
        let f = fleet.clone();
        let tx = qtx.clone();
        let q = session
            .declare_queryable(key.clone())
            .callback(move |query| {
                if tx.try_send((control, query)).is_err() {
                    f.queries_dropped.fetch_add(1, Ordering::Relaxed);
                }
            })
            .await
            .map_err(DaemonError::declare("queryable", &key))?;
        queryables.push(q);
    }
    drop(qtx);
    let trigger_task = tokio::spawn(serve_controls(fleet.clone(), qrx, cancel.clone()));
    Ok((queryables, trigger_task))
}

/// The history queryable and its task, when a history is kept.
pub(super) async fn declare_history(
    session: &zenoh::Session,
    fleet: &Arc<Fleet>,
    history: Option<&Arc<History>>,
    single: Option<&Keys>,
    cancel: &CancellationToken,
) -> Result<Option<(Queryable<()>, tokio::task::JoinHandle<()>)>, DaemonError> {
    let Some(h) = history else { return Ok(None) };
    let key = match single {
        Some(k) => k.history(),
        None => "vessels/*/fdi/history".to_string(),
    };
    let (htx, hrx) = mpsc::channel::<Query>(64);
    let f = fleet.clone();
    let q = session
        .declare_queryable(key.clone())
        .callback(move |query| {
            if f.leaves_to_holder(query.key_expr().as_str()) {
                return;
            }
            if htx.try_send(query).is_err() {
                f.queries_dropped.fetch_add(1, Ordering::Relaxed);
            }
        })
        .await
        .map_err(DaemonError::declare("queryable", &key))?;
    let served = crate::shells::history::serve(h.clone(), fleet.names.clone(), hrx, cancel.clone());
    Ok(Some((q, tokio::spawn(served))))
}

/// Waits until every vessel task has taken up its role: a held vessel's state restored (and
/// its alarm published again), a standby standing by.
pub(super) async fn await_settled(settled: Vec<oneshot::Receiver<()>>) {
    for rx in settled {
        if tokio::time::timeout(Duration::from_secs(5), rx)
            .await
            .is_err()
        {
            tracing::warn!("a vessel task did not take up its role within 5 s");
        }
    }
}

/// Serves the metrics on the listener bound first, when `daemon.metrics-listen` is set.
pub(super) fn serve_metrics(
    listener: Option<tokio::net::TcpListener>,
    metrics: Metrics,
    cfg: &DaemonConfig,
) -> Result<Option<(std::net::SocketAddr, tokio::task::JoinHandle<()>)>, DaemonError> {
    let Some(listener) = listener else {
        return Ok(None);
    };
    let addr = listener
        .local_addr()
        .map_err(|e| crate::shells::metrics::http::MetricsError {
            key: "daemon.metrics-listen",
            addr: cfg.metrics_listen.clone(),
            reason: e.to_string(),
        })?;
    let registry = Arc::new(metrics.into_registry());
    let task = tokio::spawn(crate::shells::metrics::http::serve(listener, registry));
    tracing::info!(%addr, "metrics on http://{addr}/metrics");
    Ok(Some((addr, task)))
}
