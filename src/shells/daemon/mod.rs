//! The daemon: a thin Zenoh driver around one [`Monitor`] core per vessel.
//!
//! ## Tasks (all on one tokio runtime)
//!
//! | task | owns | does |
//! |---|---|---|
//! | Zenoh subscriber callbacks (one per vessel and input stream) | nothing | copy the payload, `try_send` it to the vessel's queue; a full queue drops and counts (`dropped.flood`) |
//! | one vessel task per vessel | its `Monitor`, its publishers | decodes, feeds the core, drains every output at once (the excitation first, so a lockstep ship is answered promptly), checks silence every `daemon.tick-s`, publishes statistics |
//! | the trigger task | the queries | parses `method=hbt\|clfrt`, asks the vessel task, replies with its [`TriggerReply`] |
//!
//! The core has a single owner and no lock. Every queue is bounded (`daemon.queue-capacity`
//! samples per vessel, 64 queries), so a flood or a slow consumer never grows memory: the
//! callbacks never block Zenoh's threads, they drop. Decisions are never dropped: status,
//! report and notification are published by the owning task, reliably, with blocking
//! congestion control. The excitation is published express at real-time priority, also with
//! blocking congestion control: in lockstep the ship waits for exactly one excitation per
//! heading, and a dropped one would stall it for `ship-peer.excitation-timeout-s`; a real
//! autopilot reverts by itself when `hold_s` runs out, so a late excitation is harmless.
//!
//! ## Lifecycle
//!
//! [`Daemon::start`] opens the session and declares everything (publishers, vessel tasks,
//! subscribers, the control queryables `fdi/trigger` and `fdi/commission`, the history
//! queryable, and last the liveliness tokens `fdi/alive`): when it
//! returns, the daemon is ready. [`Daemon::run`] waits for the `shutdown` future (any future:
//! a signal in `main`, a token in tests), then stops intake, lets every vessel task publish
//! `mode: none` at its last heading `t` and a final status (a test under way is reported as
//! aborted), undeclares the tokens and closes the session.

pub mod config;
mod fleet;
mod owner;
mod publishers;
mod start;
mod vessel;
mod vessel_recording;

use crate::shells::metrics::{Metrics, VesselMetrics};
use crate::shells::recording::Recorder;
use crate::shells::state::StateDir;
use config::DaemonConfig;
use fleet::Fleet;
use helmwatch_core::config::ConfigError;
use helmwatch_core::monitor::config::CoreConfig;
use helmwatch_core::wire::Method;
use helmwatch_core::wire::{Keys, Stream, TriggerReply};
use std::future::Future;
use std::sync::atomic::Ordering;
use std::sync::Arc;
use std::sync::Mutex;
use std::time::{Duration, Instant};
use tokio::sync::oneshot;
use tokio_util::sync::CancellationToken;
use zenoh::pubsub::Subscriber;
use zenoh::query::Queryable;

/// Why the daemon could not start.
#[derive(Debug, thiserror::Error)]
pub enum DaemonError {
    /// The configuration breaks a limit.
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// The state directory cannot be used.
    #[error(transparent)]
    State(#[from] crate::shells::state::StateError),
    /// The metrics endpoint cannot listen (`daemon.metrics-listen`: port in use...).
    #[error(transparent)]
    Metrics(#[from] crate::shells::metrics::http::MetricsError),
    /// The history database cannot be opened, even afresh.
    #[error(transparent)]
    History(#[from] crate::shells::history::HistoryError),
    /// The recordings directory cannot be used.
    #[error(transparent)]
    Recording(#[from] crate::shells::recording::RecordingError),
    /// The estimator's model files are missing, invalid, or not for this configuration.
    #[error(transparent)]
    Estimator(#[from] helmwatch_core::estimator::model::ModelError),
    /// The Zenoh session could not be opened (bad endpoint, port in use...).
    #[error("cannot open the Zenoh session: {0}")]
    Open(String),
    /// A publisher, subscriber, queryable or token could not be declared.
    #[error("cannot declare the {what} on {key}: {reason}")]
    Declare {
        /// What was declared.
        what: &'static str,
        /// On which key expression.
        key: String,
        /// Zenoh's message.
        reason: String,
    },
}

impl DaemonError {
    fn declare(what: &'static str, key: &str) -> impl FnOnce(zenoh::Error) -> DaemonError {
        let key = key.to_string();
        move |e| DaemonError::Declare {
            what,
            key,
            reason: e.to_string(),
        }
    }
}

/// What a vessel task receives.
#[derive(Debug)]
enum Msg {
    /// A payload on an input stream, as received (only its head when it is longer than
    /// [`MAX_SAMPLE_BYTES`]: `len` is its length), and when (the excitation latency).
    Sample {
        stream: Stream,
        payload: Vec<u8>,
        len: usize,
        arrived: Instant,
    },
    /// A trigger request; the reply goes back on the oneshot (`None`: a standby stays
    /// silent, the holder answers).
    Trigger {
        method: Method,
        reply: oneshot::Sender<Option<TriggerReply>>,
    },
    /// The vessel's state as its holder published it (`fdi/state`), or as it answered a
    /// standby's query.
    State { payload: Vec<u8> },
    /// Another daemon became a candidate for the vessel: the holder publishes its state for
    /// it (a standby that came late has seen none), a standby ignores it.
    CandidateJoined,
    /// A query for the vessel's state: the holder answers with it, a standby stays silent.
    StateQuery {
        reply: oneshot::Sender<Option<Vec<u8>>>,
    },
    /// A commissioning request: begin again (`start`, for `method` or both), then reply
    /// with the progress.
    Commission {
        start: bool,
        method: Option<Method>,
        reply: oneshot::Sender<Option<serde_json::Value>>,
    },
}

/// An input sample longer than this is rejected as oversized without being read: only its
/// head is queued (a sample of the contract is under 100 bytes) [bytes].
pub const MAX_SAMPLE_BYTES: usize = 4096;

/// What vessels of one configuration share: the designed multisine and the estimator.
type Parts = (
    Option<helmwatch_core::dsp::multisine::Multisine>,
    Option<Arc<helmwatch_core::estimator::Estimator>>,
);

/// Counters the Zenoh callbacks update without touching the core.
#[derive(Debug)]
struct Shared {
    /// The vessel's metrics: the callbacks count samples dropped because the vessel's queue
    /// was full (`queue_dropped`, `dropped.flood` in the stats) and control requests refused
    /// for the same reason (`control_dropped`, `dropped.triggers`).
    metrics: VesselMetrics,
}

/// The final statistics of one vessel.
#[derive(Debug, Clone)]
pub struct VesselSummary {
    /// The vessel.
    pub vessel: String,
    /// The statistics object (as published on `fdi/stats`).
    pub stats: serde_json::Value,
}

/// A running daemon: the session and everything declared on it.
pub struct Daemon {
    session: zenoh::Session,
    cfg: DaemonConfig,
    fleet: Arc<Fleet>,
    cancel: CancellationToken,
    vessel_tasks: Vec<tokio::task::JoinHandle<VesselSummary>>,
    trigger_task: tokio::task::JoinHandle<()>,
    /// The history queryable and its task, when a history is kept.
    history_queryable: Option<(Queryable<()>, tokio::task::JoinHandle<()>)>,
    subscribers: Vec<Subscriber<()>>,
    queryables: Vec<Queryable<()>>,
    /// The ownership driver (candidate and holder tokens, `fdi/alive`).
    owner: owner::OwnerDriver,
    /// Stops the ownership driver (after the vessel tasks: the tokens go last).
    owner_cancel: CancellationToken,
    /// The metrics endpoint's bound address and its task, when `daemon.metrics-listen` is set.
    metrics: Option<(std::net::SocketAddr, tokio::task::JoinHandle<()>)>,
    /// The MCAP recorder, when `daemon.record`: its segment is finished at stop.
    recorder: Option<Arc<Mutex<Recorder>>>,
}

impl std::fmt::Debug for Daemon {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Daemon")
            .field("vessels", &self.fleet.names.len())
            .finish_non_exhaustive()
    }
}

/// Starts the daemon on `zcfg` and runs it until `shutdown` completes.
pub async fn run(
    core: &CoreConfig,
    cfg: &DaemonConfig,
    zcfg: zenoh::Config,
    shutdown: impl Future<Output = ()>,
) -> Result<Vec<VesselSummary>, DaemonError> {
    let daemon = Daemon::start(core, cfg, zcfg).await?;
    Ok(daemon.run(shutdown).await)
}

impl Daemon {
    /// Opens the session and declares everything; the daemon is ready when this returns.
    /// Every vessel of `cfg.vessels` is configured by `core` (one ship class).
    pub async fn start(
        core: &CoreConfig,
        cfg: &DaemonConfig,
        zcfg: zenoh::Config,
    ) -> Result<Daemon, DaemonError> {
        let fleet: Vec<(String, CoreConfig)> = cfg
            .vessels
            .iter()
            .map(|v| (v.clone(), core.clone()))
            .collect();
        Self::start_fleet(&fleet, cfg, zcfg).await
    }

    /// Opens the session and declares everything; the daemon is ready when this returns.
    /// Each vessel has its own core configuration (ships of different classes: see
    /// `Config::fleet`); `cfg.vessels` is not read. The estimator's models are loaded and
    /// the multisine designed once per distinct configuration, not per vessel.
    pub async fn start_fleet(
        vessels: &[(String, CoreConfig)],
        cfg: &DaemonConfig,
        zcfg: zenoh::Config,
    ) -> Result<Daemon, DaemonError> {
        cfg.check()?;
        let (parts, part_of) = start::design_parts(vessels, cfg)?;
        // The metrics listener first: a port in use stops the start before anything is open.
        let metrics_listener = if cfg.metrics_listen.is_empty() {
            None
        } else {
            Some(
                crate::shells::metrics::http::bind("daemon.metrics-listen", &cfg.metrics_listen)
                    .await?,
            )
        };
        let mut metrics = Metrics::new();
        let state = match &cfg.state_dir {
            Some(dir) => Some(StateDir::open(std::path::Path::new(dir))?),
            None => None,
        };
        let history = start::open_history(cfg)?;
        let recorder = start::open_recorder(cfg)?;
        let session = zenoh::open(zcfg)
            .await
            .map_err(|e| DaemonError::Open(e.to_string()))?;
        let cancel = CancellationToken::new();
        let daemon_id = cfg.daemon_id();
        let common = start::Common {
            cfg,
            daemon_id: &daemon_id,
            state,
            history: history.clone(),
            recorder: recorder.clone(),
            cancel: &cancel,
        };
        let start::Spawned {
            fleet,
            roles,
            vessel_tasks,
            settled,
        } = start::spawn_vessels(&session, vessels, &parts, &part_of, &common, &mut metrics)
            .await?;
        let names = &fleet.names;
        let single = (names.len() == 1).then(|| Keys::new(&names[0]));
        let subscribers = start::declare_subscribers(&session, &fleet, single.as_ref()).await?;
        let (queryables, trigger_task) =
            start::declare_controls(&session, &fleet, single.as_ref(), &cancel).await?;
        let history_queryable =
            start::declare_history(&session, &fleet, history.as_ref(), single.as_ref(), &cancel)
                .await?;
        // Ownership last: the candidate tokens, then each vessel driven (`fdi/alive`, which
        // tells the world the vessel is monitored) or stood by, once the claim window ended.
        let owner_cancel = CancellationToken::new();
        let owner = owner::OwnerDriver::start(
            &session,
            &daemon_id,
            names,
            roles,
            fleet.senders.clone(),
            cfg.claim_s,
            cfg.takeover_s,
            owner_cancel.clone(),
        )
        .await?;
        // Ready once every vessel task has taken up its role.
        start::await_settled(settled).await;
        let metrics = start::serve_metrics(metrics_listener, metrics, cfg)?;
        tracing::info!(
            vessels = names.len(),
            zid = %session.zid(),
            daemon = %daemon_id,
            "daemon ready"
        );
        Ok(Daemon {
            session,
            cfg: cfg.clone(),
            fleet,
            cancel,
            vessel_tasks,
            trigger_task,
            subscribers,
            queryables,
            history_queryable,
            owner,
            owner_cancel,
            metrics,
            recorder,
        })
    }

    /// The vessels monitored.
    pub fn vessels(&self) -> &[String] {
        &self.fleet.names
    }

    /// Samples dropped so far because a vessel's queue was full, all vessels.
    pub fn flood_drops(&self) -> u64 {
        self.fleet
            .shared
            .iter()
            .map(|s| s.metrics.queue_dropped_count())
            .sum()
    }

    /// The address the metrics endpoint listens on (`daemon.metrics-listen`, its port
    /// chosen by the system when 0), or `None` when metrics are off.
    pub fn metrics_addr(&self) -> Option<std::net::SocketAddr> {
        self.metrics.as_ref().map(|(a, _)| *a)
    }

    /// The daemon's Zenoh session (for in-process tools: the demo, benchmarks).
    pub fn session(&self) -> &zenoh::Session {
        &self.session
    }

    /// Runs until `shutdown` completes, then stops cleanly (see the module documentation).
    /// Returns each vessel's final statistics.
    pub async fn run(self, shutdown: impl Future<Output = ()>) -> Vec<VesselSummary> {
        shutdown.await;
        self.stop().await
    }

    /// Stops now: intake first, then `mode: none` and a final status per vessel, then the
    /// tokens and the session.
    pub async fn stop(self) -> Vec<VesselSummary> {
        tracing::info!("daemon stopping");
        for sub in self.subscribers {
            if let Err(e) = sub.undeclare().await {
                tracing::warn!("undeclaring a subscriber: {e}");
            }
        }
        for q in self.queryables {
            if let Err(e) = q.undeclare().await {
                tracing::warn!("undeclaring a control queryable: {e}");
            }
        }
        let history_task = match self.history_queryable {
            Some((q, task)) => {
                if let Err(e) = q.undeclare().await {
                    tracing::warn!("undeclaring the history queryable: {e}");
                }
                Some(task)
            }
            None => None,
        };
        self.cancel.cancel();
        let limit = Duration::from_secs_f64(self.cfg.shutdown_timeout_s + 1.0);
        let mut summaries = Vec::with_capacity(self.vessel_tasks.len());
        for (i, task) in self.vessel_tasks.into_iter().enumerate() {
            match tokio::time::timeout(limit, task).await {
                Ok(Ok(s)) => summaries.push(s),
                Ok(Err(e)) => {
                    tracing::error!(vessel = %self.fleet.names[i], "vessel task failed: {e}")
                }
                Err(_) => {
                    tracing::error!(vessel = %self.fleet.names[i], "vessel task did not stop in time")
                }
            }
        }
        let _ = tokio::time::timeout(limit, self.trigger_task).await;
        if let Some(rec) = &self.recorder {
            // Every vessel task has written its last messages: finish the file.
            let mut r = rec
                .lock()
                .unwrap_or_else(std::sync::PoisonError::into_inner);
            match tokio::task::block_in_place(|| r.rotate()) {
                Ok(()) => {
                    let s = r.stats();
                    tracing::info!(
                        files = s.finished.len(),
                        deleted = s.deleted,
                        errors = s.errors,
                        messages = s.messages.values().sum::<u64>(),
                        "recording finished"
                    );
                }
                Err(e) => tracing::error!("finishing the recording: {e}"),
            }
        }
        if let Some(task) = history_task {
            let _ = tokio::time::timeout(limit, task).await;
        }
        self.owner_cancel.cancel();
        self.owner.stop().await;
        let unknown = self.fleet.unknown.load(Ordering::Relaxed);
        let queries = self.fleet.queries_dropped.load(Ordering::Relaxed);
        if unknown > 0 || queries > 0 {
            tracing::info!(
                unknown_vessel_samples = unknown,
                queries_dropped = queries,
                "daemon-wide counters"
            );
        }
        if let Err(e) = self.session.close().await {
            tracing::warn!("closing the Zenoh session: {e}");
        }
        if let Some((_, task)) = self.metrics {
            // Dropping the server task closes its listener and every connection.
            task.abort();
            let _ = task.await;
        }
        tracing::info!("daemon stopped");
        summaries
    }
}
