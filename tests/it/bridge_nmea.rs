//! A simulated ship that speaks NMEA only: each tick one IEC 61162-450 datagram over UDP on
//! loopback to `helmwatch bridge nmea` (in-process: `shells::bridge`), which publishes the
//! contract's keys to the daemon over Zenoh; the ship hears the daemon's excitation over
//! Zenoh and keeps lockstep through the tag block's time. Hostile sentences are injected
//! beside the ship's and must be counted by reason on `bridge/stats`, never published. A
//! silent rudder indicator and a bridge restart must abort the running test on the daemon's
//! silence check, with no decision. No timing is asserted: every wait is bounded and polls.

use crate::common::{daemon_config, endpoint, ran_to_analysis, start_daemon, Observer};
use helmwatch::config::Config;
use helmwatch::shells::bridge::{Bridge, BridgeConfig, BridgeError};
use helmwatch::shells::net::loopback_peer;
use helmwatch::shells::shipnode::{ShipNode, ShipNodeError, ShipNodeOptions, ShipSummary};
use helmwatch_core::nmea::{DecodeStats, HeadingSentence, TimeSource};
use helmwatch_core::sim::Scenario;
use std::net::SocketAddr;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Duration;
use tokio::task::JoinHandle;
use tokio_util::sync::CancellationToken;

const LIMIT: Duration = Duration::from_secs(300);
const HDT: HeadingSentence = HeadingSentence::Hdt;

type Task<T, E> = (CancellationToken, JoinHandle<Result<T, E>>);

fn bridge_config(udp: SocketAddr, heading: HeadingSentence) -> BridgeConfig {
    let b = BridgeConfig {
        udp_listen: udp.to_string(),
        heading,
        time_source: TimeSource::TagBlockMs,
        talkers: vec!["AG".into(), "VW".into(), "HE".into()],
        stats_period_s: 0.2,
        ..BridgeConfig::default()
    };
    b.check().unwrap();
    b
}

/// A bridge on `udp` (port 0: a free one) publishing to the daemon at `ep`, listening on
/// `own` (peers do not route for each other: a watcher of `bridge/stats` connects there).
async fn start_bridge(
    ep: &str,
    own: &str,
    udp: SocketAddr,
    heading: HeadingSentence,
) -> (SocketAddr, Task<DecodeStats, BridgeError>) {
    let bridge = Bridge::start(
        &bridge_config(udp, heading),
        loopback_peer(&[own.to_string()], &[ep.to_string()]).unwrap(),
    )
    .await
    .unwrap();
    let addr = bridge.udp_addr().unwrap();
    let stop = CancellationToken::new();
    let s = stop.clone();
    let task = tokio::spawn(bridge.run(async move { s.cancelled().await }));
    (addr, (stop, task))
}

/// A lockstep ship whose instruments send NMEA datagrams to `nmea`; excitation over `ep`.
fn spawn_nmea_ship(
    cfg: &Config,
    seed: u64,
    ep: &str,
    nmea: SocketAddr,
    heading: HeadingSentence,
) -> Task<ShipSummary, ShipNodeError> {
    let mut opts = ShipNodeOptions::from_config(&cfg.ship_peer, &cfg.simulation.vessel);
    opts.lockstep = true;
    let node = ShipNode::new(&cfg.sim(), &Scenario::nominal(&cfg.sim(), seed), opts)
        .unwrap()
        .nmea_to(nmea)
        .nmea_heading(heading);
    let stop = CancellationToken::new();
    let s = stop.clone();
    let zcfg = loopback_peer(&[], &[ep.to_string()]).unwrap();
    (
        stop.clone(),
        tokio::spawn(node.run(zcfg, async move { s.cancelled().await })),
    )
}

/// A session on the bridge's endpoint `own` that adds `vessels/self/bridge/stats` to what
/// `obs` collects (as `bridge/stats`).
async fn watch_bridge_stats(
    obs: &Observer,
    own: &str,
) -> (zenoh::Session, zenoh::pubsub::Subscriber<()>) {
    let session = zenoh::open(loopback_peer(&[], &[own.to_string()]).unwrap())
        .await
        .unwrap();
    let seen = obs.seen.clone();
    let sub = session
        .declare_subscriber("vessels/self/bridge/stats")
        .callback(move |sample| {
            if let Ok(v) = serde_json::from_slice(&sample.payload().to_bytes()) {
                seen.lock().unwrap().push(("bridge/stats".to_string(), v));
            }
        })
        .await
        .unwrap();
    (session, sub)
}

/// `$body*hh`, checksum computed here.
fn line(body: &str) -> String {
    let cs = body.bytes().fold(0u8, |c, b| c ^ b);
    format!("${body}*{cs:02X}")
}

fn tag(params: &str) -> String {
    let cs = params.bytes().fold(0u8, |c, b| c ^ b);
    format!("\\{params}*{cs:02X}\\")
}

/// A daemon (scheduler off) on `ep`, an observer, a bridge reading `heading` that publishes to
/// the daemon, and a watcher of the bridge's stats (on the bridge's own endpoint).
struct Rig {
    ep: String,
    cfg: Config,
    daemon: helmwatch::shells::daemon::Daemon,
    obs: Observer,
    udp: SocketAddr,
    bridge: Task<DecodeStats, BridgeError>,
    watcher: (zenoh::Session, zenoh::pubsub::Subscriber<()>),
}

impl Rig {
    async fn start(heading: HeadingSentence) -> Self {
        let ep = endpoint();
        let mut cfg = daemon_config();
        cfg.scheduler.enabled = false;
        let daemon = start_daemon(&cfg, &ep).await;
        let obs = Observer::new(&ep, "self", false).await;
        let own = endpoint();
        let (udp, bridge) = start_bridge(&ep, &own, "127.0.0.1:0".parse().unwrap(), heading).await;
        let watcher = watch_bridge_stats(&obs, &own).await;
        Self {
            ep,
            cfg,
            daemon,
            obs,
            udp,
            bridge,
            watcher,
        }
    }
}

#[tokio::test(flavor = "multi_thread")]
async fn an_nmea_only_ship_runs_a_test_end_to_end_and_bad_sentences_are_counted() {
    let Rig {
        ep,
        cfg,
        daemon,
        obs,
        udp,
        bridge: (bridge_stop, bridge),
        watcher: (watcher, stats_sub),
    } = Rig::start(HDT).await;
    let (ship_stop, ship) = spawn_nmea_ship(&cfg, 7, &ep, udp, HDT);

    let id = obs.trigger("hbt").await.test.unwrap();
    // Hostile sentences from another instrument while the test runs, with the ship's own
    // tag-block time far in the past: none may reach the daemon.
    let c = tag("s:XX0001,c:1");
    let hostile: Vec<(String, &str)> = vec![
        (format!("{c}$HEHDT,100.0,T*00"), "checksum"),
        (format!("{c}{}", &line("HEHDT,100.0,T")[..9]), "framing"),
        (format!("{c}{}", line("GPHDT,100.0,T")), "talker"),
        (format!("{c}{}", line("AGRSA,5.0,V,,V")), "status"),
        (format!("{c}{}", line("HEHDT,400.0,T")), "out_of_range"),
        (format!("{c}{}", line("AGRSA,80.0,A,,V")), "out_of_range"),
        (format!("{c}{}", line("HEHDT,,T")), "no_value"),
        (line("HEHDT,100.0,T"), "no_time"),
        ("x".repeat(600), "too_long"),
    ];
    let injector = tokio::net::UdpSocket::bind("127.0.0.1:0").await.unwrap();
    let mut want = std::collections::BTreeMap::<&str, u64>::new();
    for (l, reason) in &hostile {
        let mut d = b"UdPbC\0".to_vec();
        d.extend_from_slice(l.as_bytes());
        d.extend_from_slice(b"\r\n");
        injector.send_to(&d, udp).await.unwrap();
        *want.entry(reason).or_default() += 1;
    }
    // 100 kB of garbage in datagrams of 10 kB (no header): each of its lines is rejected.
    let garbage: Vec<u8> = (0..100_000u32)
        .map(|i| (i.wrapping_mul(2_654_435_761) >> 24) as u8)
        .collect();
    for chunk in garbage.chunks(10_000) {
        injector.send_to(chunk, udp).await.unwrap();
    }
    let r = obs
        .wait_for("fdi/report", LIMIT, |r| r["test"] == id.as_str())
        .await;
    assert_eq!(r["outcome"], "completed", "{r}");
    assert!(ran_to_analysis(&r), "{r}");
    // The usual bounds (tests/it/fleet_classes.rs): speed within 1 m/s of the ship's 7 m/s,
    // displacement within 10 % of its 7000 t; no fault on the nominal ship.
    let u = r["estimate"]["speed_mps"].as_f64().unwrap();
    let d = r["estimate"]["displacement_t"].as_f64().unwrap();
    assert!((u - 7.0).abs() < 1.0, "speed {u}: {r}");
    assert!((d - 7000.0).abs() < 700.0, "displacement {d}: {r}");
    assert_ne!(r["decision"], "fault", "{r}");
    eprintln!(
        "estimate over NMEA: {u:.3} m/s, {d:.0} t, decision {}",
        r["decision"]
    );

    // Every hostile line counted by its reason; the garbage's lines under framing or
    // too_long; nothing else rejected (the ship's own sentences are all valid).
    let stats = obs
        .wait_for("bridge/stats", LIMIT, |s| {
            s["rejected"]["checksum"].as_u64() == Some(1)
                && s["rejected"]["no_time"].as_u64() == Some(1)
                && s["samples"]["heading"].as_u64() > Some(1000)
        })
        .await;
    let rej = &stats["rejected"];
    for (reason, n) in &want {
        if *reason != "framing" && *reason != "too_long" {
            assert_eq!(rej[*reason].as_u64(), Some(*n), "{reason}: {stats}");
        }
    }
    let garbage_lines = garbage
        .chunks(10_000)
        .flat_map(|c| c.split(|b| *b == b'\n'))
        .filter(|l| !l.is_empty() && *l != b"\r")
        .count() as u64;
    let framing_and_long = rej["framing"].as_u64().unwrap() + rej["too_long"].as_u64().unwrap();
    assert_eq!(framing_and_long, garbage_lines + 2, "{stats}");
    let total: u64 = rej
        .as_object()
        .unwrap()
        .values()
        .map(|v| v.as_u64().unwrap())
        .sum();
    assert_eq!(total, garbage_lines + hostile.len() as u64, "{stats}");
    assert!(
        stats["samples"]["heading"].as_u64().unwrap() > 1000,
        "{stats}"
    );
    eprintln!("bridge/stats: {stats}");

    // The daemon saw no malformed, out-of-range or out-of-order sample from the bridge.
    let dstats = obs.wait_for("fdi/stats", LIMIT, |_| true).await;
    for stream in [
        "heading",
        "rudder",
        "speed",
        "autopilot_state",
        "target_heading",
    ] {
        let s = &dstats["inputs"][stream];
        for reason in ["malformed", "not_finite", "out_of_range", "out_of_order"] {
            assert_eq!(
                s[reason].as_u64().unwrap_or(0),
                0,
                "{stream} {reason}: {dstats}"
            );
        }
    }

    ship_stop.cancel();
    let summary = ship.await.unwrap().unwrap();
    // Lockstep held all along (a timeout or two while the routes come up at the start).
    assert!(summary.excitation_timeouts <= 2, "{summary:?}");
    assert!(summary.excitations + 2 >= summary.ticks, "{summary:?}");
    bridge_stop.cancel();
    let b = bridge.await.unwrap().unwrap();
    assert_eq!(b.rejected_total(), total);
    stats_sub.undeclare().await.unwrap();
    watcher.close().await.unwrap();
    daemon.stop().await;
    obs.close().await;
}

/// Forwards the ship's datagrams to the bridge; while `drop_rudder` is set, without their
/// RSA lines (a rudder angle indicator gone silent).
fn spawn_relay(
    sock: tokio::net::UdpSocket,
    to: SocketAddr,
    drop_rudder: Arc<AtomicBool>,
) -> JoinHandle<()> {
    tokio::spawn(async move {
        let mut buf = vec![0u8; 65536];
        loop {
            let Ok(n) = sock.recv(&mut buf).await else {
                return;
            };
            let d = &buf[..n];
            let out: Vec<u8> = if drop_rudder.load(Ordering::Relaxed) {
                let mut o = d[..6].to_vec();
                for l in d[6..].split_inclusive(|b| *b == b'\n') {
                    if !l.windows(4).any(|w| w == b"RSA,") {
                        o.extend_from_slice(l);
                    }
                }
                o
            } else {
                d.to_vec()
            };
            let _ = sock.send_to(&out, to).await;
        }
    })
}

#[tokio::test(flavor = "multi_thread")]
async fn a_silent_rudder_indicator_and_a_bridge_restart_abort_the_test_without_a_decision() {
    let ep = endpoint();
    let mut cfg = daemon_config();
    cfg.scheduler.enabled = false;
    let daemon = start_daemon(&cfg, &ep).await;
    let obs = Observer::new(&ep, "self", false).await;
    let (udp, (bridge_stop, bridge)) =
        start_bridge(&ep, &endpoint(), "127.0.0.1:0".parse().unwrap(), HDT).await;
    let relay_sock = tokio::net::UdpSocket::bind("127.0.0.1:0").await.unwrap();
    let relay_addr = relay_sock.local_addr().unwrap();
    let drop_rudder = Arc::new(AtomicBool::new(false));
    let relay = spawn_relay(relay_sock, udp, drop_rudder.clone());
    let (ship_stop, ship) = spawn_nmea_ship(&cfg, 3, &ep, relay_addr, HDT);

    // 1. The rudder angle indicator falls silent in the middle of a test.
    let id1 = obs.trigger("clfrt").await.test.unwrap();
    obs.wait_for("fdi/status", LIMIT, |s| s["test"] == id1.as_str())
        .await;
    drop_rudder.store(true, Ordering::Relaxed);
    let r1 = obs
        .wait_for("fdi/report", LIMIT, |r| r["test"] == id1.as_str())
        .await;
    drop_rudder.store(false, Ordering::Relaxed);
    assert_eq!(r1["outcome"], "aborted", "{r1}");
    let reason = r1["reason"].as_str().unwrap();
    assert!(reason.contains("rudder stream silent"), "{reason}");
    assert!(r1["estimate"].is_null(), "{r1}");
    assert_ne!(r1["decision"], "fault", "{r1}");

    // 2. The bridge restarts in the middle of the next test (accepted once every stream is
    // fresh again).
    let id2 = obs.trigger("hbt").await.test.unwrap();
    obs.wait_for("fdi/status", LIMIT, |s| s["test"] == id2.as_str())
        .await;
    bridge_stop.cancel();
    let first = bridge.await.unwrap().unwrap();
    assert_eq!(first.rejected_total(), 0, "{first:?}");
    let r2 = obs
        .wait_for("fdi/report", LIMIT, |r| r["test"] == id2.as_str())
        .await;
    assert_eq!(r2["outcome"], "aborted", "{r2}");
    assert!(
        r2["reason"].as_str().unwrap().contains("stream silent"),
        "{r2}"
    );
    assert!(r2["estimate"].is_null(), "{r2}");
    eprintln!("aborted: {reason}; {}", r2["reason"]);
    assert_ne!(r2["decision"], "fault", "{r2}");
    // A new bridge on the same port: the samples flow again and the daemon answers them.
    let (udp2, (bridge_stop, bridge)) = start_bridge(&ep, &endpoint(), udp, HDT).await;
    assert_eq!(udp2, udp);
    let t_end = r2["t_end"].as_f64().unwrap();
    obs.wait_for("fdi/stats", LIMIT, |s| {
        s["t"].as_f64().is_some_and(|t| t > t_end + 30.0)
    })
    .await;
    for n in obs.on("notifications/steering/fdi") {
        assert_eq!(n["state"], "normal", "no alarm: {n}");
    }

    ship_stop.cancel();
    ship.await.unwrap().unwrap();
    relay.abort();
    bridge_stop.cancel();
    bridge.await.unwrap().unwrap();
    daemon.stop().await;
    obs.close().await;
}

/// Headings published by a bridge that listens on `own`, collected by a session there.
async fn watch_headings(
    own: &str,
) -> (
    zenoh::Session,
    zenoh::pubsub::Subscriber<()>,
    Arc<std::sync::Mutex<Vec<f64>>>,
) {
    let session = zenoh::open(loopback_peer(&[], &[own.to_string()]).unwrap())
        .await
        .unwrap();
    let got: Arc<std::sync::Mutex<Vec<f64>>> = Arc::default();
    let g = got.clone();
    let sub = session
        .declare_subscriber("vessels/self/navigation/headingTrue")
        .callback(move |sample| {
            if let Ok(v) = serde_json::from_slice::<serde_json::Value>(&sample.payload().to_bytes())
            {
                g.lock().unwrap().push(v["value"].as_f64().unwrap());
            }
        })
        .await
        .unwrap();
    (session, sub, got)
}

/// The bytes a stream instrument sends in one burst: a sentence cut in two writes' worth, a
/// 2 kB line (dropped, counted), another sentence.
fn stream_burst() -> Vec<u8> {
    let mut b = format!("{}\r\n", line("HEHDT,123.4,T")).into_bytes();
    b.extend_from_slice(&[b'7'; 2048]);
    b.extend_from_slice(format!("\r\n{}\r\n", line("HEHDT,124.0,T")).as_bytes());
    b
}

/// Waits until both headings of [`stream_burst`] were published, and nothing else.
async fn wait_both(got: &std::sync::Mutex<Vec<f64>>) {
    let want = [123.4_f64.to_radians(), 124.0_f64.to_radians()];
    let deadline = tokio::time::Instant::now() + LIMIT;
    loop {
        let g = got.lock().unwrap().clone();
        for v in &g {
            assert!(want.iter().any(|w| (v - w).abs() < 1e-6), "published {v}");
        }
        if want.iter().all(|w| g.iter().any(|v| (v - w).abs() < 1e-6)) {
            return;
        }
        assert!(tokio::time::Instant::now() < deadline, "{g:?}");
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
}

#[tokio::test(flavor = "multi_thread")]
async fn tcp_and_serial_streams_are_cut_into_lines_and_reopened() {
    // TCP: an NMEA server on loopback; the bridge reconnects after the server hangs up.
    let server = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
    let own = endpoint();
    let cfg = BridgeConfig {
        input: helmwatch::shells::bridge::BridgeInput::Tcp,
        tcp_connect: server.local_addr().unwrap().to_string(),
        reconnect_s: 0.05,
        metrics_listen: "127.0.0.1:0".into(),
        ..BridgeConfig::default()
    };
    cfg.check().unwrap();
    let bridge = Bridge::start(
        &cfg,
        loopback_peer(std::slice::from_ref(&own), &[]).unwrap(),
    )
    .await
    .unwrap();
    let metrics = bridge.metrics_addr().unwrap();
    let stop = CancellationToken::new();
    let s = stop.clone();
    let task = tokio::spawn(bridge.run(async move { s.cancelled().await }));
    let (session, sub, got) = watch_headings(&own).await;
    for _ in 0..2 {
        let (mut conn, _) = server.accept().await.unwrap();
        got.lock().unwrap().clear();
        let burst = stream_burst();
        let writer = async {
            use tokio::io::AsyncWriteExt;
            loop {
                // Two writes that cut the first sentence in the middle.
                conn.write_all(&burst[..10]).await.unwrap();
                conn.flush().await.unwrap();
                conn.write_all(&burst[10..]).await.unwrap();
                tokio::time::sleep(Duration::from_millis(50)).await;
            }
        };
        tokio::select! {
            _ = writer => {}
            _ = wait_both(&got) => {}
        }
        drop(conn);
    }
    // The counters on the metrics endpoint: both headings of both connections, the two
    // over-long lines at least.
    let text = crate::common::scrape_metrics(metrics).await;
    for family in helmwatch::shells::bridge::metrics::METRIC_FAMILIES {
        assert!(text.contains(family), "{family}: {text}");
    }
    let value = |series: &str| -> u64 {
        text.lines()
            .find_map(|l| l.strip_prefix(series))
            .and_then(|v| v.trim().parse().ok())
            .unwrap_or_else(|| panic!("{series}: {text}"))
    };
    assert!(value("helmwatch_bridge_samples_total{vessel=\"self\",stream=\"heading\"}") >= 4);
    assert!(value("helmwatch_bridge_rejected_total{vessel=\"self\",reason=\"too_long\"}") >= 2);
    assert_eq!(
        value("helmwatch_bridge_rejected_total{vessel=\"self\",reason=\"checksum\"}"),
        0
    );
    stop.cancel();
    let stats = task.await.unwrap().unwrap();
    assert!(
        stats.rejected(helmwatch_core::nmea::Reject::TooLong) >= 2,
        "{stats:?}"
    );
    assert_eq!(
        stats.rejected_total(),
        stats.rejected(helmwatch_core::nmea::Reject::TooLong),
        "{stats:?}"
    );
    sub.undeclare().await.unwrap();
    session.close().await.unwrap();

    // A serial device, here a named pipe read as the device path.
    let dir = crate::common::temp_dir("bridge-serial");
    let fifo = dir.join("ttyNMEA");
    assert!(std::process::Command::new("mkfifo")
        .arg(&fifo)
        .status()
        .unwrap()
        .success());
    let own = endpoint();
    let cfg = BridgeConfig {
        input: helmwatch::shells::bridge::BridgeInput::Serial,
        serial_path: fifo.clone(),
        reconnect_s: 0.05,
        ..BridgeConfig::default()
    };
    cfg.check().unwrap();
    let bridge = Bridge::start(
        &cfg,
        loopback_peer(std::slice::from_ref(&own), &[]).unwrap(),
    )
    .await
    .unwrap();
    let (session, sub, got) = watch_headings(&own).await;
    let stop = CancellationToken::new();
    let s = stop.clone();
    let task = tokio::spawn(bridge.run(async move { s.cancelled().await }));
    let done = Arc::new(AtomicBool::new(false));
    let d = done.clone();
    let f = fifo.clone();
    let writer = std::thread::spawn(move || {
        use std::io::Write;
        let mut w = std::fs::OpenOptions::new().write(true).open(&f).unwrap();
        let burst = stream_burst();
        while !d.load(Ordering::Relaxed) {
            if w.write_all(&burst).is_err() {
                return;
            }
            std::thread::sleep(Duration::from_millis(50));
        }
    });
    wait_both(&got).await;
    done.store(true, Ordering::Relaxed);
    writer.join().unwrap();
    stop.cancel();
    let stats = task.await.unwrap().unwrap();
    assert_eq!(
        stats.rejected_total(),
        stats.rejected(helmwatch_core::nmea::Reject::TooLong),
        "{stats:?}"
    );
    sub.undeclare().await.unwrap();
    session.close().await.unwrap();
    let _ = std::fs::remove_dir_all(&dir);
}

/// A gyro that sends THS and no HDT feeds the daemon through a bridge set to `ths`: a test
/// completes on its heading.
#[tokio::test(flavor = "multi_thread")]
async fn a_ths_only_gyro_feeds_a_test_that_completes() {
    let ths = HeadingSentence::Ths;
    let rig = Rig::start(ths).await;
    let (ship_stop, ship) = spawn_nmea_ship(&rig.cfg, 11, &rig.ep, rig.udp, ths);
    let obs = &rig.obs;
    let id = obs.trigger("clfrt").await.test.unwrap();
    let r = obs
        .wait_for("fdi/report", LIMIT, |r| r["test"] == id.as_str())
        .await;
    assert_eq!(r["outcome"], "completed", "{r}");
    assert!(ran_to_analysis(&r), "{r}");
    let stats = obs
        .wait_for("bridge/stats", LIMIT, |s| {
            s["samples"]["heading"].as_u64() > Some(1000)
        })
        .await;
    let rejected: u64 = stats["rejected"]
        .as_object()
        .unwrap()
        .values()
        .map(|v| v.as_u64().unwrap())
        .sum();
    assert_eq!(rejected, 0, "{stats}");
    ship_stop.cancel();
    ship.await.unwrap().unwrap();
    let (bridge_stop, bridge) = rig.bridge;
    bridge_stop.cancel();
    bridge.await.unwrap().unwrap();
    let (watcher, stats_sub) = rig.watcher;
    stats_sub.undeclare().await.unwrap();
    watcher.close().await.unwrap();
    rig.daemon.stop().await;
    rig.obs.close().await;
}
