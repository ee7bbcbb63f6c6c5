//! Benchmark figures of the daemon over real Zenoh sessions on loopback (`helmwatch bench`,
//! `cargo bench --bench daemon`). Each figure is measured in one run and printed; none is
//! asserted in a test, because machines are shared and noisy.
//!
//! - [`lockstep`]: one vessel, the daemon and the simulated ship as two sessions in lockstep:
//!   ship seconds per wall second (target >= 500 at 10 Hz in release).
//! - [`fleet`]: one daemon monitoring `n` vessels fed at 10 Hz of wall time by a feeder
//!   session (rudder, speed, heading every 0.1 s; autopilot state and target every 1 s). The
//!   daemon keeps up when it answers at least 99 % of the headings of the measurement window
//!   with their excitation, the 99th percentile of the answer's delay (from the start of the
//!   feeder's burst) is below one sample period, and no sample was dropped from a full queue.
//!   Memory is the process's resident set (daemon and feeder together, so an upper bound).

use crate::config::Config;
use crate::shells::daemon::Daemon;
use crate::shells::net::{free_loopback_port, loopback_peer};
use crate::shells::shipnode::{ShipNode, ShipNodeOptions};
use crate::tools::loopback::LoopbackError;
use helmwatch_core::sim::Scenario;
use helmwatch_core::wire::{Excitation, Keys, Scalar, StateValue, Stream};
use std::io::Write;
use std::path::Path;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// One vessel in lockstep over Zenoh.
#[derive(Debug, Clone, PartialEq)]
pub struct LockstepFigure {
    /// Ship time simulated [s].
    pub ship_s: f64,
    /// Wall time [s].
    pub wall_s: f64,
    /// Ship seconds per wall second.
    pub ratio: f64,
    /// Lockstep waits that ran out (should be 0).
    pub excitation_timeouts: u64,
}

/// Runs the daemon and a lockstep ship for `ship_s` seconds of ship time.
pub async fn lockstep(cfg: &Config, ship_s: f64) -> Result<LockstepFigure, LoopbackError> {
    let port = free_loopback_port().map_err(|e| LoopbackError::Other(e.to_string()))?;
    let ep = format!("tcp/127.0.0.1:{port}");
    let mut dcfg = cfg.clone();
    dcfg.daemon.vessels = vec![cfg.simulation.vessel.clone()];
    let daemon = Daemon::start(
        &dcfg.core(),
        &dcfg.daemon,
        loopback_peer(std::slice::from_ref(&ep), &[])?,
    )
    .await?;
    let mut opts = ShipNodeOptions::from_config(&cfg.ship_peer, &cfg.simulation.vessel);
    opts.lockstep = true;
    opts.duration_s = Some(ship_s);
    let ship = ShipNode::new(&cfg.sim(), &Scenario::nominal(&cfg.sim(), 1), opts)?;
    // The ship ticks on the timer until it sees the daemon's token; wait for it first.
    let started = Instant::now();
    let summary = ship
        .run(loopback_peer(&[], &[ep])?, std::future::pending())
        .await?;
    let wall_s = started.elapsed().as_secs_f64();
    daemon.stop().await;
    Ok(LockstepFigure {
        ship_s,
        wall_s,
        ratio: ship_s / wall_s.max(1e-9),
        excitation_timeouts: summary.excitation_timeouts,
    })
}

/// One daemon, `vessels` vessels at 10 Hz of wall time.
#[derive(Debug, Clone, PartialEq)]
pub struct FleetFigure {
    /// Vessels monitored.
    pub vessels: usize,
    /// Headings published during the measurement window.
    pub headings: u64,
    /// Their excitations received.
    pub excitations: u64,
    /// Median delay from the burst's start to an excitation [ms].
    pub p50_ms: f64,
    /// 99th percentile of that delay [ms].
    pub p99_ms: f64,
    /// Samples the daemon dropped from full queues.
    pub flood_drops: u64,
    /// Resident memory of the whole process at the end of the window [MiB].
    pub rss_mib: f64,
    /// The criterion of the module documentation.
    pub kept_up: bool,
}

/// Resident set size of this process [MiB], from `/proc/self/status`.
pub fn rss_mib() -> f64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("VmRSS:"))
                .and_then(|l| l.split_whitespace().nth(1))
                .and_then(|kb| kb.parse::<f64>().ok())
        })
        .map(|kb| kb / 1024.0)
        .unwrap_or(f64::NAN)
}

/// Send time of each tick (by tick number), shared with the excitation subscribers.
type SentAt = Arc<Mutex<Vec<Option<Instant>>>>;

/// Period of the feeder's ticks [s].
const FEED_DT: f64 = 0.1;

/// Ticks of warm-up before the measurement window.
const WARMUP_TICKS: usize = 10;

/// Feeds `vessels` vessels at 10 Hz for a second of warm-up and `window` of measurement.
pub async fn fleet(
    cfg: &Config,
    vessels: usize,
    window: Duration,
) -> Result<FleetFigure, LoopbackError> {
    let other = |e: zenoh::Error| LoopbackError::Other(e.to_string());
    let port = free_loopback_port().map_err(|e| LoopbackError::Other(e.to_string()))?;
    let ep = format!("tcp/127.0.0.1:{port}");
    let names: Vec<String> = (0..vessels).map(|i| format!("v{i:05}")).collect();
    let mut dcfg = cfg.clone();
    dcfg.daemon.vessels = names.clone();
    dcfg.daemon.stats_period_s = 0.0;
    dcfg.scheduler.enabled = false;
    let daemon = Daemon::start(
        &dcfg.core(),
        &dcfg.daemon,
        loopback_peer(std::slice::from_ref(&ep), &[])?,
    )
    .await?;

    let feeder = zenoh::open(loopback_peer(&[], &[ep])?)
        .await
        .map_err(other)?;
    let dt = FEED_DT;
    // Send time of each tick, and the delays of the excitations of measured ticks.
    let sent: SentAt = Arc::new(Mutex::new(Vec::new()));
    let delays: Arc<Mutex<Vec<f64>>> = Arc::new(Mutex::new(Vec::new()));
    let ticks = WARMUP_TICKS + (window.as_secs_f64() / dt).round() as usize;
    let subs = excitation_subscribers(&feeder, &names, &sent, &delays).await?;
    let pubs = stream_publishers(&feeder, &names).await?;
    if let Some(p) = pubs.last() {
        crate::shells::net::wait_matching(p, Duration::from_secs(10)).await;
    }
    let headings = feed(&pubs, names.len(), ticks, &sent).await;
    tokio::time::sleep(Duration::from_millis(500)).await;
    let rss = rss_mib();
    let flood_drops = daemon.flood_drops();
    for sub in subs {
        let _ = sub.undeclare().await;
    }
    let _ = feeder.close().await;
    daemon.stop().await;
    let mut d = delays.lock().map(|d| d.clone()).unwrap_or_default();
    d.sort_by(f64::total_cmp);
    let pct = |p: f64| {
        if d.is_empty() {
            f64::NAN
        } else {
            d[((d.len() - 1) as f64 * p).round() as usize]
        }
    };
    let excitations = d.len() as u64;
    let p99_ms = pct(0.99);
    Ok(FleetFigure {
        vessels,
        headings,
        excitations,
        p50_ms: pct(0.5),
        p99_ms,
        flood_drops,
        rss_mib: rss,
        kept_up: excitations as f64 >= 0.99 * headings as f64
            && p99_ms < dt * 1e3
            && flood_drops == 0,
    })
}

/// One excitation subscriber per vessel, as each ship has its own: each pushes the delay of an
/// excitation of a measured tick (from the tick's send time) to `delays` [ms].
async fn excitation_subscribers(
    feeder: &zenoh::Session,
    names: &[String],
    sent: &SentAt,
    delays: &Arc<Mutex<Vec<f64>>>,
) -> Result<Vec<zenoh::pubsub::Subscriber<()>>, LoopbackError> {
    let other = |e: zenoh::Error| LoopbackError::Other(e.to_string());
    let dt = FEED_DT;
    let warmup_ticks = WARMUP_TICKS;
    let mut subs = Vec::with_capacity(names.len());
    for n in names {
        let (s2, d2) = (sent.clone(), delays.clone());
        let sub = feeder
            .declare_subscriber(Keys::new(n).excitation())
            .callback(move |sample| {
                let now = Instant::now();
                let Ok(e) = serde_json::from_slice::<Excitation>(&sample.payload().to_bytes())
                else {
                    return;
                };
                let k = (e.t / dt).round() as usize;
                if k < warmup_ticks {
                    return;
                }
                let at = s2.lock().ok().and_then(|s| s.get(k).copied().flatten());
                if let (Some(at), Ok(mut d)) = (at, d2.lock()) {
                    d.push(now.duration_since(at).as_secs_f64() * 1e3);
                }
            })
            .await
            .map_err(other)?;
        subs.push(sub);
    }
    Ok(subs)
}

/// The feeder's publishers: five per vessel, in the order rudder, speed, autopilot state,
/// target heading, heading.
async fn stream_publishers(
    feeder: &zenoh::Session,
    names: &[String],
) -> Result<Vec<zenoh::pubsub::Publisher<'static>>, LoopbackError> {
    let other = |e: zenoh::Error| LoopbackError::Other(e.to_string());
    let mut pubs = Vec::with_capacity(names.len() * 5);
    for n in names {
        let k = Keys::new(n);
        for s in [
            Stream::Rudder,
            Stream::Speed,
            Stream::AutopilotState,
            Stream::TargetHeading,
            Stream::Heading,
        ] {
            let ke = feeder.declare_keyexpr(k.stream(s)).await.map_err(other)?;
            pubs.push(
                feeder
                    .declare_publisher(ke)
                    .encoding(zenoh::bytes::Encoding::APPLICATION_JSON)
                    .await
                    .map_err(other)?,
            );
        }
    }
    Ok(pubs)
}

/// Publishes `ticks` ticks at 10 Hz to `vessels` vessels (rudder, speed, heading every tick;
/// autopilot state and target every tenth), noting each tick's send time in `sent`. Returns
/// the headings published after the warm-up.
async fn feed(
    pubs: &[zenoh::pubsub::Publisher<'static>],
    vessels: usize,
    ticks: usize,
    sent: &SentAt,
) -> u64 {
    let dt = FEED_DT;
    let target = 1.0;
    let mut interval = tokio::time::interval(Duration::from_secs_f64(dt));
    interval.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Burst);
    let mut headings = 0u64;
    for k in 0..ticks {
        interval.tick().await;
        if let Ok(mut s) = sent.lock() {
            s.push(Some(Instant::now()));
        }
        let t = k as f64 * dt;
        let js = |v: f64| serde_json::to_vec(&Scalar { t, value: v }).unwrap_or_default();
        let (rudder, speed, heading) = (js(0.01), js(7.0), js(target + 0.001 * (0.3 * t).sin()));
        let state = serde_json::to_vec(&StateValue {
            t,
            value: "auto".into(),
        })
        .unwrap_or_default();
        for i in 0..vessels {
            let _ = pubs[5 * i].put(rudder.clone()).await;
            let _ = pubs[5 * i + 1].put(speed.clone()).await;
            if k % 10 == 0 {
                let _ = pubs[5 * i + 2].put(state.clone()).await;
                let _ = pubs[5 * i + 3].put(js(target)).await;
            }
            let _ = pubs[5 * i + 4].put(heading.clone()).await;
            if k >= WARMUP_TICKS {
                headings += 1;
            }
        }
    }
    headings
}

/// A fleet figure as the one JSON line `helmwatch bench --one-fleet N` prints.
pub fn fleet_json(f: &FleetFigure) -> serde_json::Value {
    serde_json::json!({
        "vessels": f.vessels, "headings": f.headings, "excitations": f.excitations,
        "p50_ms": f.p50_ms, "p99_ms": f.p99_ms, "flood_drops": f.flood_drops,
        "rss_mib": f.rss_mib, "kept_up": f.kept_up,
    })
}

/// Measures each fleet size of `sizes` in turn, each in a fresh child process
/// `exe [--config CONFIG] bench --one-fleet N` so that its memory is its own, prints a line
/// per size to `out`, and stops at the first size not kept up with. Returns the largest size
/// kept up with (0 when none was).
pub fn fleet_sizes(
    exe: &Path,
    config: Option<&Path>,
    sizes: &[usize],
    window_s: f64,
    out: &mut impl Write,
) -> Result<usize, std::io::Error> {
    let mut best = 0usize;
    for &n in sizes {
        let mut cmd = std::process::Command::new(exe);
        if let Some(c) = config {
            cmd.arg("--config").arg(c);
        }
        let child = cmd
            .args([
                "bench",
                "--window-s",
                &window_s.to_string(),
                "--one-fleet",
                &n.to_string(),
            ])
            .env("RUST_LOG", "off")
            .stderr(std::process::Stdio::null())
            .output()?;
        let text = String::from_utf8_lossy(&child.stdout);
        let Some(v) = text
            .lines()
            .rev()
            .find_map(|l| serde_json::from_str::<serde_json::Value>(l).ok())
        else {
            writeln!(
                out,
                "fleet of {n}: the measurement failed ({})",
                child.status
            )?;
            break;
        };
        let g = |k: &str| v.get(k).and_then(|x| x.as_f64()).unwrap_or(f64::NAN);
        let kept = v.get("kept_up").and_then(|x| x.as_bool()).unwrap_or(false);
        writeln!(
            out,
            "fleet of {n} vessels at 10 Hz: {:.0}/{:.0} headings answered, delay p50 {:.1} ms p99 {:.1} ms, {:.0} flood drops, RSS {:.0} MiB: {}",
            g("excitations"), g("headings"), g("p50_ms"), g("p99_ms"), g("flood_drops"), g("rss_mib"),
            if kept { "kept up" } else { "NOT kept up" }
        )?;
        if !kept {
            break;
        }
        best = n;
    }
    Ok(best)
}
