//! One vessel, one driver: two `helmwatch run` processes configured for the same vessel on one
//! Zenoh network (an in-process router on loopback, multicast off, the daemons its clients).
//!
//! - Started together, they settle on the lowest id: over more than a ship hour of a lockstep
//!   ship with scheduled tests and triggers, every heading is answered exactly once (no `t`
//!   twice among the excitations) and every test started has exactly one report.
//! - The holder killed with SIGKILL during an alarm: the standby takes over with the state the
//!   holder published (the alarm is published again, headings are answered, the next report
//!   is against the commissioned reference); the first daemon, restarted, stands by, and takes
//!   over the same way when the second is killed.
//! - A partition (two routers, a third joins them later): of the two holders the higher id
//!   yields, no heading is answered twice, and a report made while both held is marked (also
//!   when the yielder's holder token never reached the holder: its `fdi/yielded` token does).
//! - A state made under another ship configuration is refused; a standby with no holder
//!   alive answers a trigger with its refusal.
//!
//! Waits are bounded and poll for events; the wall-clock figures are printed (and bounded
//! generously), not asserted tightly.

use crate::common::{endpoint, temp_dir, Observer};
use helmwatch::config::Config;
use helmwatch::shells::net::{loopback, ZenohMode};
use helmwatch::shells::shipnode::{ShipNode, ShipNodeOptions, ShipSummary};
use helmwatch_core::sim::Scenario;
use serde_json::Value;
use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};
use tokio_util::sync::CancellationToken;

const LIMIT: Duration = Duration::from_secs(240);

/// A child process killed when dropped (a failing test leaves no daemon behind).
struct Proc(Child);

impl std::ops::Deref for Proc {
    type Target = Child;
    fn deref(&self) -> &Child {
        &self.0
    }
}

impl std::ops::DerefMut for Proc {
    fn deref_mut(&mut self) -> &mut Child {
        &mut self.0
    }
}

impl Drop for Proc {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// `helmwatch --config <dir>/<name>.toml run`, standard error appended to `<dir>/<name>.log`.
fn spawn_daemon(dir: &Path, name: &str, toml: &str) -> Proc {
    let cfg = dir.join(format!("{name}.toml"));
    std::fs::write(&cfg, toml).unwrap();
    let log = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(dir.join(format!("{name}.log")))
        .unwrap();
    Command::new(env!("CARGO_BIN_EXE_helmwatch"))
        .arg("--config")
        .arg(&cfg)
        .arg("run")
        .env("RUST_LOG", "info,zenoh=warn")
        .env_remove("NOTIFY_SOCKET")
        .stdout(Stdio::null())
        .stderr(log)
        .spawn()
        .map(Proc)
        .unwrap()
}

fn log(dir: &Path, name: &str) -> String {
    std::fs::read_to_string(dir.join(format!("{name}.log"))).unwrap_or_default()
}

/// A daemon `id` for vessel `self`, a client of `router`, with its own state directory
/// (`daemon.takeover-s` its default, 2 s).
fn daemon_toml(dir: &Path, id: &str, router: &str, extra: &str) -> String {
    let state = dir.join(format!("state-{id}"));
    format!(
        "[daemon]\nvessels = [\"self\"]\nid = \"{id}\"\ntick-s = 0.1\nstate-dir = \"{}\"\n\n[zenoh]\nmode = \"client\"\nlisten = []\nconnect = [\"{router}\"]\nmulticast-scouting = false\n\n{extra}",
        state.display()
    )
}

fn client(router: &str) -> zenoh::Config {
    loopback(ZenohMode::Client, &[], &[router.to_string()]).unwrap()
}

/// Every `fdi/ownership` message, in arrival order.
struct Ownership {
    seen: Arc<Mutex<Vec<Value>>>,
    _sub: zenoh::pubsub::Subscriber<()>,
}

impl Ownership {
    async fn new(s: &zenoh::Session) -> Self {
        let seen: Arc<Mutex<Vec<Value>>> = Arc::default();
        let s2 = seen.clone();
        let sub = s
            .declare_subscriber("vessels/self/fdi/ownership")
            .callback(move |sample| {
                if let Ok(v) = serde_json::from_slice::<Value>(&sample.payload().to_bytes()) {
                    s2.lock().unwrap().push(v);
                }
            })
            .await
            .unwrap();
        Self { seen, _sub: sub }
    }

    /// Waits (bounded) for a message of daemon `id` in `role` (with `holder`, `"null"`: none).
    async fn wait(&self, id: &str, role: &str, holder: &str) -> Value {
        let deadline = Instant::now() + LIMIT;
        loop {
            if let Some(v) = self.seen.lock().unwrap().iter().find(|v| {
                v["daemon"] == id
                    && v["role"] == role
                    && v["holder"].as_str().unwrap_or("null") == holder
            }) {
                return v.clone();
            }
            assert!(
                Instant::now() < deadline,
                "no ownership message {id} {role} {holder}; seen {:?}",
                self.seen.lock().unwrap()
            );
            tokio::time::sleep(Duration::from_millis(20)).await;
        }
    }
}

/// A router on a free loopback port, an observer of vessel `self` on it (excitation too), the
/// ownership messages, and daemons `a` (holder) then `b` (its standby), each with `extra` in
/// its configuration.
struct HolderAndStandby {
    router_ep: String,
    router: zenoh::Session,
    obs: Observer,
    owners: Ownership,
    a: Proc,
    b: Proc,
}

impl HolderAndStandby {
    async fn start(dir: &Path, extra: &str) -> Self {
        let router_ep = endpoint();
        let router = zenoh::open(
            loopback(ZenohMode::Router, std::slice::from_ref(&router_ep), &[]).unwrap(),
        )
        .await
        .unwrap();
        let obs = Observer::new(&router_ep, "self", true).await;
        let owners = Ownership::new(&obs.session).await;
        let a = spawn_daemon(dir, "a", &daemon_toml(dir, "a", &router_ep, extra));
        owners.wait("a", "holder", "a").await;
        let b = spawn_daemon(dir, "b", &daemon_toml(dir, "b", &router_ep, extra));
        owners.wait("b", "standby", "a").await;
        Self {
            router_ep,
            router,
            obs,
            owners,
            a,
            b,
        }
    }
}

/// A lockstep ship of `scenario` from ship time `start_s` (for `duration_s` when given), a
/// client of `router`.
fn ship(
    cfg: &Config,
    scenario: &Scenario,
    start_s: f64,
    duration_s: Option<f64>,
    router: &str,
) -> (
    CancellationToken,
    tokio::task::JoinHandle<Result<ShipSummary, helmwatch::shells::shipnode::ShipNodeError>>,
) {
    let mut sim = cfg.sim();
    sim.simulation.start_time_s = start_s;
    let mut opts = ShipNodeOptions::from_config(&cfg.ship_peer, "self");
    opts.lockstep = true;
    opts.duration_s = duration_s;
    let node = ShipNode::new(&sim, scenario, opts).unwrap();
    let stop = CancellationToken::new();
    let s = stop.clone();
    let task = tokio::spawn(node.run(client(router), async move { s.cancelled().await }));
    (stop, task)
}

/// Excitation `t`s seen more than once.
fn duplicates(obs: &Observer) -> Vec<(f64, usize)> {
    let mut count: BTreeMap<u64, usize> = BTreeMap::new();
    for e in obs.on("steering/autopilot/excitation") {
        *count.entry(e["t"].as_f64().unwrap().to_bits()).or_default() += 1;
    }
    count
        .into_iter()
        .filter(|(_, n)| *n > 1)
        .map(|(t, n)| (f64::from_bits(t), n))
        .collect()
}

#[tokio::test(flavor = "multi_thread")]
async fn two_daemons_one_vessel_every_heading_answered_once_one_report_per_test() {
    let dir = temp_dir("standby-two");
    let router_ep = endpoint();
    let router =
        zenoh::open(loopback(ZenohMode::Router, std::slice::from_ref(&router_ep), &[]).unwrap())
            .await
            .unwrap();
    let obs = Observer::new(&router_ep, "self", true).await;
    let owners = Ownership::new(&obs.session).await;
    // Scheduled tests every 10 minutes of steady course, both methods in turn.
    let extra = "[scheduler]\ninterval-s = 600.0\n";
    let mut b = spawn_daemon(&dir, "b", &daemon_toml(&dir, "b", &router_ep, extra));
    let mut a = spawn_daemon(&dir, "a", &daemon_toml(&dir, "a", &router_ep, extra));
    owners.wait("a", "holder", "a").await;
    owners.wait("b", "standby", "a").await;

    let cfg = Config::default();
    let hour_s = 3700.0;
    let (stop, ship) = ship(
        &cfg,
        &Scenario::nominal(&cfg.sim(), 21),
        0.0,
        Some(hour_s),
        &router_ep,
    );
    // Two triggers on top of the schedule; only the holder answers.
    for m in ["hbt", "clfrt"] {
        let r = obs.trigger(m).await;
        assert!(r.accepted, "{r:?}");
        let id = r.test.unwrap();
        obs.wait_for("fdi/report", LIMIT, |r| r["test"] == id.as_str())
            .await;
    }
    let summary = tokio::time::timeout(LIMIT * 4, ship)
        .await
        .expect("the ship hour ends")
        .unwrap()
        .unwrap();
    stop.cancel();
    assert!(
        summary.t_end_s >= 3600.0,
        "at least a ship hour: {summary:?}"
    );
    // The last excitations and reports arrive.
    tokio::time::sleep(Duration::from_millis(500)).await;

    let dups = duplicates(&obs);
    let excitations = obs.on("steering/autopilot/excitation").len();
    println!(
        "ship {:.0} s, {} ticks, {} excitations seen, {} duplicated t, ship excitation timeouts {}",
        summary.t_end_s,
        summary.ticks,
        excitations,
        dups.len(),
        summary.excitation_timeouts
    );
    assert!(
        dups.is_empty(),
        "{} headings answered twice, first {:?}",
        dups.len(),
        &dups[..dups.len().min(5)]
    );
    assert!(
        excitations as f64 >= 0.95 * summary.ticks as f64,
        "{excitations} excitations for {} ticks",
        summary.ticks
    );
    // Every test started has exactly one report.
    let started: BTreeSet<String> = obs
        .on("fdi/status")
        .iter()
        .filter_map(|s| s["test"].as_str().map(String::from))
        .collect();
    // A test the ship's end cut short is reported aborted once the heading is silent.
    for t in &started {
        obs.wait_for("fdi/report", LIMIT, |r| r["test"] == t.as_str())
            .await;
    }
    let reports = obs.on("fdi/report");
    let mut per_test: BTreeMap<String, usize> = BTreeMap::new();
    for r in &reports {
        *per_test
            .entry(r["test"].as_str().unwrap().to_string())
            .or_default() += 1;
    }
    assert!(
        started.len() >= 3,
        "scheduled tests and triggers: {started:?}"
    );
    for t in &started {
        assert_eq!(per_test.get(t), Some(&1), "test {t}: {per_test:?}");
    }
    assert_eq!(per_test.len(), started.len(), "{per_test:?}");
    // The standby published nothing for the vessel.
    // helmwatch status and helmwatch fleet show the holder and the standby.
    let cli = |args: &[&str]| {
        let out = Command::new(env!("CARGO_BIN_EXE_helmwatch"))
            .args(args)
            .args(["--connect", &router_ep])
            .output()
            .unwrap();
        (
            out.status.code(),
            String::from_utf8_lossy(&out.stdout).to_string(),
        )
    };
    let (code, out) = cli(&["status", "--vessel", "self", "--json"]);
    assert_eq!(code, Some(0), "{out}");
    let st: Value = serde_json::from_str(&out).unwrap();
    assert_eq!(st["holders"], serde_json::json!(["a"]), "{st}");
    assert_eq!(st["standbys"], serde_json::json!(["b"]), "{st}");
    let (code, out) = cli(&["fleet", "--json", "--duration-s", "3"]);
    assert_eq!(code, Some(0), "{out}");
    let last = out
        .lines()
        .filter_map(|l| serde_json::from_str::<Value>(l).ok())
        .rfind(|l| l["vessel"] == "self")
        .unwrap_or_else(|| panic!("no fleet line: {out}"));
    assert_eq!(last["holders"], serde_json::json!(["a"]), "{out}");
    assert_eq!(last["standbys"], serde_json::json!(["b"]), "{out}");
    let b_log = log(&dir, "b");
    assert!(
        !b_log.contains(": status ") && !b_log.contains(": report "),
        "{b_log}"
    );

    for c in [&mut a, &mut b] {
        let _ = c.kill();
        let _ = c.wait();
    }
    obs.close().await;
    router.close().await.unwrap();
    let _ = std::fs::remove_dir_all(&dir);
}

/// Triggers `method` until accepted, then waits for its report; again when the test was
/// aborted (a test started on the last samples of a ship that stopped is silent).
async fn one_test(obs: &Observer, method: &str) -> Value {
    for _ in 0..3 {
        let id = obs.trigger(method).await.test.unwrap();
        let r = obs
            .wait_for("fdi/report", LIMIT, |r| r["test"] == id.as_str())
            .await;
        if r["outcome"] == "completed" {
            return r;
        }
    }
    panic!("three {method} tests aborted in a row");
}

/// `helmwatch status --vessel self --json` run every 0.25 s on a thread of its own: what it
/// answered, with the time since `from` at which each call started.
struct StatusPoll {
    stop: Arc<std::sync::atomic::AtomicBool>,
    thread: std::thread::JoinHandle<Vec<(Duration, Value)>>,
}

impl StatusPoll {
    fn start(router: &str, from: Instant) -> Self {
        let stop = Arc::new(std::sync::atomic::AtomicBool::new(false));
        let (s, router) = (stop.clone(), router.to_string());
        let thread = std::thread::spawn(move || {
            let mut seen = Vec::new();
            while !s.load(std::sync::atomic::Ordering::Relaxed) {
                let at = from.elapsed();
                let out = Command::new(env!("CARGO_BIN_EXE_helmwatch"))
                    .args(["status", "--vessel", "self", "--json", "--timeout-s", "1"])
                    .args(["--connect", &router])
                    .output()
                    .unwrap();
                if let Ok(v) = serde_json::from_slice::<Value>(&out.stdout) {
                    seen.push((at, v));
                }
                std::thread::sleep(Duration::from_millis(250));
            }
            seen
        });
        Self { stop, thread }
    }

    fn stop(self) -> Vec<(Duration, Value)> {
        self.stop.store(true, std::sync::atomic::Ordering::Relaxed);
        self.thread.join().unwrap()
    }
}

/// Kills `holder` (SIGKILL) while the vessel is in alarm; waits until `standby` took over:
/// the alarm published again and a heading answered after the kill. Returns the wall time
/// from the kill to both, and checks the next report is against the commissioned reference.
async fn kill_and_take_over(
    dir: &Path,
    router: &str,
    obs: &Observer,
    owners: &Ownership,
    holder: &mut Child,
    standby: &str,
) -> Duration {
    let notes_before = obs.on("notifications/steering/fdi").len();
    let owners_before = owners.seen.lock().unwrap().len();
    let killed = Instant::now();
    holder.kill().unwrap();
    holder.wait().unwrap();
    let poll = StatusPoll::start(router, killed);
    let deadline = killed + LIMIT;
    // Excitations the dead holder sent may still arrive for a moment: those of the new holder
    // are counted from its announcement on.
    let (mut alarm_at, mut answer_at, mut exc_at_announce) = (None, None, None);
    while alarm_at.is_none() || answer_at.is_none() {
        if alarm_at.is_none()
            && obs.on("notifications/steering/fdi")[notes_before..]
                .iter()
                .any(|n| n["state"] == "alarm")
        {
            alarm_at = Some(killed.elapsed());
        }
        let n_exc = obs.on("steering/autopilot/excitation").len();
        match exc_at_announce {
            None => {
                if owners.seen.lock().unwrap()[owners_before..]
                    .iter()
                    .any(|v| v["daemon"] == standby && v["role"] == "holder")
                {
                    exc_at_announce = Some(n_exc);
                }
            }
            Some(n) if answer_at.is_none() && n_exc > n + 5 => answer_at = Some(killed.elapsed()),
            Some(_) => {}
        }
        assert!(
            Instant::now() < deadline,
            "{standby} did not take over; its log:\n{}",
            log(dir, standby)
        );
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
    let took = alarm_at.unwrap().max(answer_at.unwrap());
    println!(
        "{standby} took over: alarm again after {:?}, headings answered after {:?} (takeover-s 2, the default)",
        alarm_at.unwrap(),
        answer_at.unwrap()
    );
    // `helmwatch status --json`, polled every 0.25 s from the kill: once the standby answers
    // as the holder it shows the alarm, never `alarm: null`, and it does so within 4 s.
    tokio::time::sleep(Duration::from_secs(3)).await;
    let seen = poll.stop();
    let held: Vec<&(Duration, Value)> = seen
        .iter()
        .filter(|(_, s)| s["holders"] == serde_json::json!([standby]))
        .collect();
    assert!(
        !held.is_empty(),
        "status never showed {standby} holding: {seen:?}"
    );
    for (at, s) in &held {
        assert_eq!(s["alarm"], "alarm", "{at:?} after the kill: {s}");
    }
    println!(
        "status shows {standby} holding, in alarm, {:?} after the kill ({} polls)",
        held[0].0,
        seen.len()
    );
    assert!(held[0].0 <= Duration::from_secs(4), "{seen:?}");
    let r = one_test(obs, "hbt").await;
    assert_eq!(r["residuals"]["reference"]["kind"], "commissioned", "{r}");
    assert!(
        !r["message"]
            .as_str()
            .unwrap_or("")
            .contains("commissioning"),
        "no new commissioning: {r}"
    );
    took
}

/// The holder killed with SIGKILL on an uncommissioned vessel: the standby announces itself
/// holder, answers the headings, and the next test runs to its report; no heading is answered
/// twice. (The takeover of a commissioned vessel in alarm, both ways, is the slow tier's.)
#[tokio::test(flavor = "multi_thread")]
async fn the_standby_takes_over_after_sigkill_and_runs_the_next_test() {
    let dir = temp_dir("standby-takeover");
    let HolderAndStandby {
        router_ep,
        router,
        obs,
        owners,
        mut a,
        mut b,
    } = HolderAndStandby::start(&dir, "[scheduler]\nenabled = false\n").await;
    let cfg = Config::default();
    let (stop, ship_task) = ship(
        &cfg,
        &Scenario::nominal(&cfg.sim(), 31),
        0.0,
        None,
        &router_ep,
    );
    obs.wait_for("steering/autopilot/excitation", LIMIT, |_| true)
        .await;

    let killed = Instant::now();
    a.kill().unwrap();
    a.wait().unwrap();
    owners.wait("b", "holder", "b").await;
    let n = obs.on("steering/autopilot/excitation").len();
    let deadline = Instant::now() + LIMIT;
    while obs.on("steering/autopilot/excitation").len() < n + 10 {
        assert!(Instant::now() < deadline, "{}", log(&dir, "b"));
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
    println!(
        "b answers headings {:?} after the kill (takeover-s 2, the default)",
        killed.elapsed()
    );
    let r = one_test(&obs, "hbt").await;
    assert_eq!(r["outcome"], "completed", "{r}");
    assert!(duplicates(&obs).is_empty(), "{:?}", duplicates(&obs));

    stop.cancel();
    let _ = ship_task.await;
    let _ = b.kill();
    obs.close().await;
    router.close().await.unwrap();
    let _ = std::fs::remove_dir_all(&dir);
}

/// The holder killed with SIGKILL while the vessel is in alarm, after commissioning, both ways
/// (about 80 s of lockstep through a router: the slow tier).
#[tokio::test(flavor = "multi_thread")]
#[ignore = "slow tier: cargo test --profile ci -- --ignored"]
async fn the_standby_takes_over_an_alarm_with_the_state_after_sigkill_both_ways() {
    let dir = temp_dir("standby-kill");
    // The fewest commissioning tests the covariance's K-sample factor allows.
    let extra = "[scheduler]\nenabled = false\n\n[fdi]\ncommissioning-tests = 5\n";
    let HolderAndStandby {
        router_ep,
        router,
        obs,
        owners,
        mut a,
        mut b,
    } = HolderAndStandby::start(&dir, extra).await;
    let toml = |id: &str| daemon_toml(&dir, id, &router_ep, extra);

    // Commissioning on a healthy ship, five tests per method (about 13,600 s of ship time); a
    // displacement 30 % up from ONSET_S on, and from then HBT tests (the shorter) until the
    // alarm, the first of them started after the onset.
    const ONSET_S: f64 = 15_000.0;
    let mut cfg = Config::default();
    cfg.fdi.commissioning_tests = 5;
    let mut scenario = Scenario::nominal(&cfg.sim(), 11);
    scenario.faults = vec![format!("displacement_pct:+30@{ONSET_S}").parse().unwrap()];
    let (stop, ship_task) = ship(&cfg, &scenario, 0.0, None, &router_ep);
    for m in ["clfrt", "hbt"].repeat(5) {
        let r = one_test(&obs, m).await;
        assert_eq!(r["residuals"]["reference"]["kind"], "commissioning", "{r}");
        assert!(r["t_end"].as_f64().unwrap() < ONSET_S, "{r}");
    }
    obs.wait_for("steering/autopilot/excitation", LIMIT, |e| {
        e["t"].as_f64().is_some_and(|t| t > ONSET_S)
    })
    .await;
    for _ in 0..12 {
        let r = one_test(&obs, "hbt").await;
        assert_eq!(r["residuals"]["reference"]["kind"], "commissioned", "{r}");
        if obs
            .on("notifications/steering/fdi")
            .iter()
            .any(|n| n["state"] == "alarm")
        {
            break;
        }
    }
    obs.wait_for("notifications/steering/fdi", LIMIT, |n| {
        n["state"] == "alarm"
    })
    .await;

    // a is killed: b takes over.
    let first = kill_and_take_over(&dir, &router_ep, &obs, &owners, &mut a, "b").await;
    // a comes back and stands by; b is killed: a takes over.
    let mut a = spawn_daemon(&dir, "a", &toml("a"));
    let n_owner = owners.seen.lock().unwrap().len();
    let deadline = Instant::now() + LIMIT;
    while !owners.seen.lock().unwrap()[n_owner..]
        .iter()
        .any(|v| v["daemon"] == "a" && v["role"] == "standby" && v["holder"] == "b")
    {
        assert!(Instant::now() < deadline, "{}", log(&dir, "a"));
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
    // It keeps b's state (a publication or its answer to a's query).
    let deadline = Instant::now() + LIMIT;
    while !log(&dir, "a").contains("keeping the holder's state") {
        assert!(Instant::now() < deadline, "{}", log(&dir, "a"));
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
    let second = kill_and_take_over(&dir, &router_ep, &obs, &owners, &mut b, "a").await;
    assert!(
        first < Duration::from_secs(20) && second < Duration::from_secs(20),
        "takeovers took {first:?} and {second:?}"
    );
    assert!(duplicates(&obs).is_empty(), "{:?}", duplicates(&obs));

    stop.cancel();
    let _ = ship_task.await;
    let _ = a.kill();
    let _ = a.wait();
    obs.close().await;
    router.close().await.unwrap();
    let _ = std::fs::remove_dir_all(&dir);
}

/// A daemon of `cfg` with id `id`, a client of `router`, in this process.
async fn daemon_in_process(
    cfg: &Config,
    id: &str,
    router: &str,
) -> helmwatch::shells::daemon::Daemon {
    let mut cfg = cfg.clone();
    cfg.daemon.id = id.to_string();
    helmwatch::shells::daemon::Daemon::start(&cfg.core(), &cfg.daemon, client(router))
        .await
        .unwrap()
}

/// The value of one series on a daemon's metrics endpoint (0 when absent).
async fn counter(addr: std::net::SocketAddr, series: &str) -> u64 {
    crate::common::scrape_metrics(addr)
        .await
        .lines()
        .find_map(|l| l.strip_prefix(series))
        .and_then(|v| v.trim().parse::<f64>().ok())
        .map_or(0, |v| v as u64)
}

/// One side of a partition: a router on a free loopback endpoint, and that endpoint.
async fn partition() -> (String, zenoh::Session) {
    let ep = endpoint();
    let router = zenoh::open(loopback(ZenohMode::Router, std::slice::from_ref(&ep), &[]).unwrap())
        .await
        .unwrap();
    (ep, router)
}

/// A partition: two routers, daemon `a` behind one, daemon `b` and the lockstep ship behind
/// the other; both hold the vessel, `b` drives the ship. A third router joins the two (the
/// partition heals): `b` (the higher id) yields, `a` drives, and headings answered twice are
/// those of the moment both saw the ship and not yet each other.
#[tokio::test(flavor = "multi_thread")]
async fn a_healed_partition_leaves_one_driver() {
    let ((ep_a, router_a), (ep_b, router_b)) = (partition().await, partition().await);
    let mut cfg = crate::common::daemon_config();
    cfg.scheduler.enabled = false;
    let obs = Observer::new(&ep_b, "self", true).await;
    let owners = Ownership::new(&obs.session).await;
    let obs_a = Observer::new(&ep_a, "self", false).await;
    let owners_a = Ownership::new(&obs_a.session).await;
    let a = daemon_in_process(&cfg, "a", &ep_a).await;
    let b = daemon_in_process(&cfg, "b", &ep_b).await;
    owners_a.wait("a", "holder", "a").await;
    owners.wait("b", "holder", "b").await;
    let (stop, ship_task) = ship(
        &Config::default(),
        &Scenario::nominal(&cfg.sim(), 5),
        0.0,
        None,
        &ep_b,
    );
    // b drives the ship: a test runs.
    let r = obs.trigger("hbt").await;
    assert!(r.accepted, "{r:?}");
    obs.wait_for("steering/autopilot/excitation", LIMIT, |e| {
        e["mode"] == "replace"
    })
    .await;
    assert!(duplicates(&obs).is_empty());

    // The partition heals.
    let healed = Instant::now();
    let bridge =
        zenoh::open(loopback(ZenohMode::Router, &[], &[ep_a.clone(), ep_b.clone()]).unwrap())
            .await
            .unwrap();
    owners.wait("b", "standby", "a").await;
    let yielded = healed.elapsed();
    // a answers the ship from now on: headings answered after the yield come from a alone.
    let n = obs.on("steering/autopilot/excitation").len();
    obs.wait_for("steering/autopilot/excitation", LIMIT, |_| {
        obs.on("steering/autopilot/excitation").len() > n + 100
    })
    .await;
    let dups = duplicates(&obs);
    println!(
        "healed: b yielded {yielded:?} after the bridge opened; {} headings answered twice: {:?}",
        dups.len(),
        &dups[..dups.len().min(5)]
    );
    assert!(dups.len() <= 3, "{dups:?}");
    // The excitation of b's test is not continued by a.
    let after: Vec<Value> = obs.on("steering/autopilot/excitation")[n..].to_vec();
    assert!(
        after
            .iter()
            .all(|e| e["test"] != r.test.as_deref().unwrap()),
        "b's test is not continued"
    );
    stop.cancel();
    let _ = ship_task.await;
    b.stop().await;
    a.stop().await;
    obs.close().await;
    obs_a.close().await;
    bridge.close().await.unwrap();
    router_a.close().await.unwrap();
    router_b.close().await.unwrap();
}

/// A standby configured for another ship refuses the holder's state (its fingerprint), and a
/// standby with no holder alive answers a trigger with its refusal.
#[tokio::test(flavor = "multi_thread")]
async fn a_state_of_another_configuration_is_refused_and_a_lone_standby_refuses_triggers() {
    let router_ep = endpoint();
    let router =
        zenoh::open(loopback(ZenohMode::Router, std::slice::from_ref(&router_ep), &[]).unwrap())
            .await
            .unwrap();
    let obs = Observer::new(&router_ep, "self", false).await;
    let owners = Ownership::new(&obs.session).await;
    let mut cfg = crate::common::daemon_config();
    cfg.scheduler.enabled = false;
    cfg.daemon.takeover_s = 8.0;
    // No models: the fingerprint is the ship configuration alone.
    cfg.estimator.enabled = false;
    let a = daemon_in_process(&cfg, "a", &router_ep).await;
    owners.wait("a", "holder", "a").await;
    let mut other = cfg.clone();
    other.ship.length_m *= 1.5;
    other.daemon.metrics_listen = "127.0.0.1:0".into();
    let b = daemon_in_process(&other, "b", &router_ep).await;
    owners.wait("b", "standby", "a").await;
    // The holder's state reaches b (published for the new candidate, and asked for by b) and
    // is refused: seen on b's metrics before the holder goes.
    let refused = r#"helmwatch_replicated_states_refused_total{vessel="self"}"#;
    let metrics = b.metrics_addr().unwrap();
    let deadline = Instant::now() + LIMIT;
    while counter(metrics, refused).await < 1 {
        assert!(Instant::now() < deadline, "b refused no state of a");
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
    // The holder is gone: within takeover-s the standby answers, refusing.
    a.stop().await;
    owners.wait("b", "standby", "null").await;
    let r = obs.trigger_once("hbt").await.unwrap();
    assert!(!r.accepted, "{r:?}");
    assert!(
        r.reason.as_deref().unwrap_or("").starts_with("standby"),
        "{r:?}"
    );
    let summaries = b.stop().await;
    let refused = summaries[0].stats["replicated_states_refused"]
        .as_u64()
        .unwrap();
    assert!(refused >= 1, "{}", summaries[0].stats);
    obs.close().await;
    router.close().await.unwrap();
}

/// The report of a test that ran while another daemon also held the vessel (a partition
/// healing) is marked with that daemon: `a` drives the ship through a test when the partition
/// heals and `b` appears as a second holder (and yields).
/// Triggers an HBT test and waits for its relay: the test's id.
async fn hbt_under_way(obs: &Observer) -> String {
    let test = obs.trigger("hbt").await.test.unwrap();
    obs.wait_for("steering/autopilot/excitation", LIMIT, |e| {
        e["mode"] == "replace"
    })
    .await;
    test
}

/// The report of `test` is marked as made while `b` drove too; the next test's, with `b`
/// standing by, is not.
async fn marked_by_b_then_not(obs: &Observer, test: &str) {
    let report = obs
        .wait_for("fdi/report", LIMIT, |r| r["test"] == test)
        .await;
    assert_eq!(
        report["concurrent_drivers"],
        serde_json::json!(["b"]),
        "{report}"
    );
    let next = obs.trigger("hbt").await.test.unwrap();
    let report = obs
        .wait_for("fdi/report", LIMIT, |r| r["test"] == next.as_str())
        .await;
    assert!(report.get("concurrent_drivers").is_none(), "{report}");
}

#[tokio::test(flavor = "multi_thread")]
async fn a_report_made_while_two_held_the_vessel_is_marked() {
    let ((ep_a, router_a), (ep_b, router_b)) = (partition().await, partition().await);
    let mut cfg = crate::common::daemon_config();
    cfg.scheduler.enabled = false;
    let obs = Observer::new(&ep_a, "self", true).await;
    let owners = Ownership::new(&obs.session).await;
    // b's messages are watched on its own side (a publication made while the routes across
    // the healed partition are still forming may not cross it).
    let obs_b = Observer::new(&ep_b, "self", false).await;
    let owners_b = Ownership::new(&obs_b.session).await;
    let a = daemon_in_process(&cfg, "a", &ep_a).await;
    let b = daemon_in_process(&cfg, "b", &ep_b).await;
    owners.wait("a", "holder", "a").await;
    owners_b.wait("b", "holder", "b").await;
    let (stop, ship_task) = ship(
        &Config::default(),
        &Scenario::nominal(&cfg.sim(), 6),
        0.0,
        None,
        &ep_a,
    );
    let test = hbt_under_way(&obs).await;
    let bridge =
        zenoh::open(loopback(ZenohMode::Router, &[], &[ep_a.clone(), ep_b.clone()]).unwrap())
            .await
            .unwrap();
    owners_b.wait("b", "standby", "a").await;
    marked_by_b_then_not(&obs, &test).await;
    stop.cancel();
    let _ = ship_task.await;
    b.stop().await;
    a.stop().await;
    obs.close().await;
    obs_b.close().await;
    bridge.close().await.unwrap();
    router_a.close().await.unwrap();
    router_b.close().await.unwrap();
}

#[tokio::test(flavor = "multi_thread")]
async fn a_daemon_that_yielded_unseen_marks_the_report_of_the_test_it_overlapped() {
    // The race of a healed partition made certain: the other daemon's holder token never
    // reaches the holder (it yielded before the routes formed); only its `fdi/yielded` token
    // does, declared here by hand while a test runs.
    let (ep, router) = partition().await;
    let mut cfg = crate::common::daemon_config();
    cfg.scheduler.enabled = false;
    let obs = Observer::new(&ep, "self", true).await;
    let owners = Ownership::new(&obs.session).await;
    let a = daemon_in_process(&cfg, "a", &ep).await;
    owners.wait("a", "holder", "a").await;
    let (stop, ship_task) = ship(
        &Config::default(),
        &Scenario::nominal(&cfg.sim(), 6),
        0.0,
        None,
        &ep,
    );
    let test = hbt_under_way(&obs).await;
    let yielded = obs
        .session
        .liveliness()
        .declare_token("vessels/self/fdi/yielded/b")
        .await
        .unwrap();
    // The token still stands (b stands by): the next test is not marked.
    marked_by_b_then_not(&obs, &test).await;
    yielded.undeclare().await.unwrap();
    stop.cancel();
    let _ = ship_task.await;
    a.stop().await;
    obs.close().await;
    router.close().await.unwrap();
}
