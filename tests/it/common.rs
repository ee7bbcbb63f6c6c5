//! Helpers of the integration tests: free loopback ports, an observer session that
//! collects what the daemon publishes, triggers, bounded waits, a worker pool.

use helmwatch::config::Config;
use helmwatch::shells::net::{free_loopback_port, loopback_peer};
use helmwatch_core::wire::{Keys, TriggerReply};
use serde_json::Value;
use std::sync::{Arc, Mutex};
use std::time::Duration;

/// The daemon of `cfg` (its core configuration, one core per vessel), listening on `ep`.
pub async fn start_daemon(cfg: &Config, ep: &str) -> helmwatch::shells::daemon::Daemon {
    helmwatch::shells::daemon::Daemon::start(
        &cfg.core(),
        &cfg.daemon,
        loopback_peer(&[ep.to_string()], &[]).unwrap(),
    )
    .await
    .unwrap()
}

/// A free endpoint `tcp/127.0.0.1:<port>`.
pub fn endpoint() -> String {
    format!("tcp/127.0.0.1:{}", free_loopback_port().unwrap())
}

/// A fresh directory under the system's temporary directory, named for the test and the
/// process (emptied if a previous run left it).
pub fn temp_dir(name: &str) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("helmwatch-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// The daemon configuration of the tests: the defaults (real test lengths: lockstep makes
/// them cheap), a fast silence check and statistics.
pub fn daemon_config() -> Config {
    let mut cfg = Config::default();
    cfg.daemon.tick_s = 0.1;
    cfg.daemon.stats_period_s = 0.2;
    cfg
}

/// Everything published on a vessel's daemon keys, in arrival order: `(key suffix, payload)`.
pub struct Observer {
    pub session: zenoh::Session,
    pub seen: Arc<Mutex<Vec<(String, Value)>>>,
    subs: Vec<zenoh::pubsub::Subscriber<()>>,
    pub vessel: String,
}

impl Observer {
    /// Connects to `endpoint` and subscribes to status, report, notification, stats, and the
    /// excitation when `excitation` (it is 10 samples per ship second).
    pub async fn new(endpoint: &str, vessel: &str, excitation: bool) -> Observer {
        Self::with(
            loopback_peer(&[], &[endpoint.to_string()]).unwrap(),
            vessel,
            excitation,
        )
        .await
    }

    /// As [`Observer::new`], listening on `endpoint` for the daemon to connect (a daemon
    /// that restarts connects again by itself).
    pub async fn listening(endpoint: &str, vessel: &str, excitation: bool) -> Observer {
        Self::with(
            loopback_peer(&[endpoint.to_string()], &[]).unwrap(),
            vessel,
            excitation,
        )
        .await
    }

    async fn with(zcfg: zenoh::Config, vessel: &str, excitation: bool) -> Observer {
        let session = zenoh::open(zcfg).await.unwrap();
        let keys = Keys::new(vessel);
        let seen: Arc<Mutex<Vec<(String, Value)>>> = Arc::default();
        let mut names = vec![
            "fdi/status",
            "fdi/report",
            "notifications/steering/fdi",
            "fdi/stats",
        ];
        if excitation {
            names.push("steering/autopilot/excitation");
        }
        let mut subs = Vec::new();
        for name in names {
            let s = seen.clone();
            let n = name.to_string();
            let sub = session
                .declare_subscriber(format!("{}/{}", keys.prefix, name))
                .callback(move |sample| {
                    if let Ok(v) = serde_json::from_slice::<Value>(&sample.payload().to_bytes()) {
                        s.lock().unwrap().push((n.clone(), v));
                    }
                })
                .await
                .unwrap();
            subs.push(sub);
        }
        Observer {
            session,
            seen,
            subs,
            vessel: vessel.to_string(),
        }
    }

    /// Payloads seen on `name` so far.
    pub fn on(&self, name: &str) -> Vec<Value> {
        self.seen
            .lock()
            .unwrap()
            .iter()
            .filter(|(k, _)| k == name)
            .map(|(_, v)| v.clone())
            .collect()
    }

    /// Waits (bounded) until a payload on `name` satisfies `pred`; returns it.
    pub async fn wait_for(
        &self,
        name: &str,
        limit: Duration,
        pred: impl Fn(&Value) -> bool,
    ) -> Value {
        let deadline = tokio::time::Instant::now() + limit;
        loop {
            if let Some(v) = self.on(name).into_iter().find(|v| pred(v)) {
                return v;
            }
            assert!(
                tokio::time::Instant::now() < deadline,
                "nothing on {name} matched within {limit:?}; seen: {:?}",
                self.seen
                    .lock()
                    .unwrap()
                    .iter()
                    .rev()
                    .take(10)
                    .collect::<Vec<_>>()
            );
            tokio::time::sleep(Duration::from_millis(20)).await;
        }
    }

    /// Asks for a test once.
    pub async fn trigger_once(&self, method: &str) -> Result<TriggerReply, String> {
        let key = format!("vessels/{}/fdi/trigger?method={method}", self.vessel);
        let replies = self.session.get(key).await.map_err(|e| e.to_string())?;
        let reply = replies.recv_async().await.map_err(|e| e.to_string())?;
        let sample = reply.into_result().map_err(|e| format!("{e:?}"))?;
        serde_json::from_slice(&sample.payload().to_bytes()).map_err(|e| e.to_string())
    }

    /// Asks the vessel's `fdi/commission` queryable once (`params`: e.g. `start;method=hbt`).
    pub async fn commission(&self, params: &str) -> Value {
        let mut key = format!("vessels/{}/fdi/commission", self.vessel);
        if !params.is_empty() {
            key = format!("{key}?{params}");
        }
        for _ in 0..100 {
            if let Ok(replies) = self.session.get(&key).await {
                if let Ok(reply) = replies.recv_async().await {
                    if let Ok(sample) = reply.into_result() {
                        return serde_json::from_slice(&sample.payload().to_bytes()).unwrap();
                    }
                }
            }
            tokio::time::sleep(Duration::from_millis(50)).await;
        }
        panic!("{key}: no answer");
    }

    /// Asks for a test until it is accepted (the monitor refuses until every stream arrived).
    pub async fn trigger(&self, method: &str) -> TriggerReply {
        for _ in 0..600 {
            if let Ok(Ok(r)) =
                tokio::time::timeout(Duration::from_secs(5), self.trigger_once(method)).await
            {
                if r.accepted {
                    return r;
                }
            }
            tokio::time::sleep(Duration::from_millis(50)).await;
        }
        panic!("the trigger was never accepted");
    }

    pub async fn close(self) {
        for s in self.subs {
            s.undeclare().await.unwrap();
        }
        self.session.close().await.unwrap();
    }
}

/// A report that ran to its analysis: completed, or (until the feature analysis merges)
/// stopped by the analysis placeholder. Never a safety abort.
pub fn ran_to_analysis(report: &Value) -> bool {
    match report["outcome"].as_str() {
        Some("completed") => report["features"]
            .as_object()
            .is_some_and(|f| !f.is_empty()),
        Some("aborted") => report["reason"]
            .as_str()
            .is_some_and(|r| r.starts_with("analysis:")),
        _ => false,
    }
}

/// The text of a metrics endpoint's `GET /metrics` (the HTTP response, headers included).
pub async fn scrape_metrics(addr: std::net::SocketAddr) -> String {
    use tokio::io::{AsyncReadExt, AsyncWriteExt};
    let mut c = tokio::net::TcpStream::connect(addr).await.unwrap();
    c.write_all(b"GET /metrics HTTP/1.1\r\nHost: helmwatch\r\nConnection: close\r\n\r\n")
        .await
        .unwrap();
    let mut body = String::new();
    c.read_to_string(&mut body).await.unwrap();
    body
}

/// Runs `jobs` on both cores, keeping their order (the library's worker pool).
pub fn par_map<T: Clone + Sync, R: Send>(jobs: Vec<T>, f: impl Fn(T) -> R + Sync) -> Vec<R> {
    helmwatch::tools::training::database::par_map(jobs.len(), 2, |i| f(jobs[i].clone()))
}
