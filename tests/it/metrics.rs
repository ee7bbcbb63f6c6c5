//! The daemon's metrics endpoint over HTTP, with a lockstep simulated ship over Zenoh: the
//! counters move between two scrapes, and the tests, decisions and aborts counted match the
//! reports observed over Zenoh; the inputs and the excitation latencies match what the ship
//! sent and received. A port in use is a start-up error naming the key.

use crate::common::{daemon_config, endpoint, start_daemon, Observer};
use helmwatch::shells::net::loopback_peer;
use helmwatch::shells::shipnode::{ShipNode, ShipNodeOptions};
use helmwatch_core::sim::Scenario;
use std::collections::HashMap;
use std::io::{Read, Write};
use std::net::SocketAddr;
use std::time::Duration;
use tokio_util::sync::CancellationToken;

const LIMIT: Duration = Duration::from_secs(120);

/// One HTTP/1.1 GET of `path` on `addr`: (status code, content type, body).
async fn get(addr: SocketAddr, path: &str) -> (u16, String, String) {
    let path = path.to_string();
    tokio::task::spawn_blocking(move || {
        let mut s = std::net::TcpStream::connect(addr).unwrap();
        s.set_read_timeout(Some(Duration::from_secs(30))).unwrap();
        write!(
            s,
            "GET {path} HTTP/1.1\r\nHost: {addr}\r\nConnection: close\r\n\r\n"
        )
        .unwrap();
        let mut raw = String::new();
        s.read_to_string(&mut raw).unwrap();
        let (head, body) = raw.split_once("\r\n\r\n").unwrap();
        let mut lines = head.lines();
        let status: u16 = lines
            .next()
            .unwrap()
            .split(' ')
            .nth(1)
            .unwrap()
            .parse()
            .unwrap();
        let ctype = lines
            .filter_map(|l| l.split_once(':'))
            .find(|(k, _)| k.eq_ignore_ascii_case("content-type"))
            .map(|(_, v)| v.trim().to_string())
            .unwrap_or_default();
        (status, ctype, body.to_string())
    })
    .await
    .unwrap()
}

/// The exposition's samples: `name{labels}` -> value; checks every line's syntax.
fn parse(text: &str) -> HashMap<String, f64> {
    assert!(text.ends_with("# EOF\n"), "{text}");
    let mut m = HashMap::new();
    for line in text.lines() {
        if let Some(rest) = line.strip_prefix("# ") {
            let kind = rest.split(' ').next().unwrap();
            assert!(["HELP", "TYPE", "UNIT", "EOF"].contains(&kind), "{line}");
            continue;
        }
        let (series, value) = line.rsplit_once(' ').unwrap();
        let name = series.split('{').next().unwrap();
        assert!(
            name.starts_with("helmwatch_")
                && name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_'),
            "{line}"
        );
        let v: f64 = value.parse().unwrap_or_else(|_| panic!("{line}"));
        assert!(m.insert(series.to_string(), v).is_none(), "twice: {line}");
    }
    m
}

async fn scrape(addr: SocketAddr) -> HashMap<String, f64> {
    let (status, ctype, body) = get(addr, "/metrics").await;
    assert_eq!(status, 200, "{body}");
    assert!(ctype.starts_with("application/openmetrics-text"), "{ctype}");
    parse(&body)
}

fn value(m: &HashMap<String, f64>, series: &str) -> f64 {
    *m.get(series)
        .unwrap_or_else(|| panic!("no {series} in {:#?}", m.keys().collect::<Vec<_>>()))
}

const HEADING: &str = r#"helmwatch_inputs_accepted_total{vessel="self",stream="heading"}"#;
const LATENCY_COUNT: &str = r#"helmwatch_excitation_latency_seconds_count{vessel="self"}"#;

fn tests(method: &str, outcome: &str) -> String {
    format!(r#"helmwatch_tests_total{{vessel="self",method="{method}",outcome="{outcome}"}}"#)
}

fn decisions(method: &str, decision: &str) -> String {
    format!(r#"helmwatch_decisions_total{{vessel="self",method="{method}",decision="{decision}"}}"#)
}

#[tokio::test(flavor = "multi_thread")]
async fn counters_move_and_match_the_reports_over_zenoh() {
    let ep = endpoint();
    let mut cfg = daemon_config();
    cfg.scheduler.enabled = false;
    cfg.daemon.metrics_listen = "127.0.0.1:0".into();
    // HBT ends within 1200 s (about 900 s); CLFRT (about 1770 s) is aborted as too long.
    cfg.safety.max_test_duration_s = 1200.0;
    let daemon = start_daemon(&cfg, &ep).await;
    let addr = daemon.metrics_addr().unwrap();
    assert!(addr.ip().is_loopback() && addr.port() != 0, "{addr}");
    let obs = Observer::new(&ep, "self", false).await;

    // Before any ship: every series at 0, the alarm normal, the queue empty.
    let m0 = scrape(addr).await;
    assert_eq!(value(&m0, HEADING), 0.0);
    assert_eq!(value(&m0, &tests("hbt", "completed")), 0.0);
    assert_eq!(value(&m0, r#"helmwatch_alarm_state{vessel="self"}"#), 0.0);
    assert_eq!(value(&m0, r#"helmwatch_queue_depth{vessel="self"}"#), 0.0);
    assert_eq!(
        value(&m0, r#"helmwatch_queue_capacity{vessel="self"}"#),
        f64::from(cfg.daemon.queue_capacity)
    );
    // Other paths and methods.
    assert_eq!(get(addr, "/").await.0, 404);

    let mut opts = ShipNodeOptions::from_config(&cfg.ship_peer, &cfg.simulation.vessel);
    opts.lockstep = true;
    let node = ShipNode::new(&cfg.sim(), &Scenario::nominal(&cfg.sim(), 5), opts).unwrap();
    let stop = CancellationToken::new();
    let s = stop.clone();
    let zcfg = loopback_peer(&[], &[ep.to_string()]).unwrap();
    let ship = tokio::spawn(node.run(zcfg, async move { s.cancelled().await }));

    // The trigger is accepted once every stream arrived: headings have been counted.
    let hbt = obs.trigger("hbt").await.test.unwrap();
    // The start is counted before its status is published.
    obs.wait_for("fdi/status", LIMIT, |s| {
        s["test"] == hbt.as_str() && s["state"] == "settling"
    })
    .await;
    let m1 = scrape(addr).await;
    let h1 = value(&m1, HEADING);
    assert!(h1 >= 1.0, "{h1}");
    assert_eq!(
        value(
            &m1,
            r#"helmwatch_tests_started_total{vessel="self",method="hbt"}"#
        ),
        1.0
    );
    let r_hbt = obs
        .wait_for("fdi/report", LIMIT, |r| r["test"] == hbt.as_str())
        .await;
    assert_eq!(r_hbt["outcome"], "completed", "{r_hbt}");

    let clfrt = obs.trigger("clfrt").await.test.unwrap();
    let r_clfrt = obs
        .wait_for("fdi/report", LIMIT, |r| r["test"] == clfrt.as_str())
        .await;
    assert_eq!(r_clfrt["outcome"], "aborted", "{r_clfrt}");
    let m2 = scrape(addr).await;
    stop.cancel();
    let summary = ship.await.unwrap().unwrap();

    // The heading counter moved: HBT alone is about 9000 headings at 10 Hz.
    let h2 = value(&m2, HEADING);
    assert!(h2 > h1 + 5000.0, "{h1} -> {h2}");
    // The tests and decisions counted are the reports seen over Zenoh.
    let reports = obs.on("fdi/report");
    assert_eq!(reports.len(), 2, "{reports:?}");
    assert_eq!(value(&m2, &tests("hbt", "completed")), 1.0);
    assert_eq!(value(&m2, &tests("hbt", "aborted")), 0.0);
    assert_eq!(value(&m2, &tests("clfrt", "aborted")), 1.0);
    assert_eq!(value(&m2, &tests("clfrt", "completed")), 0.0);
    for (r, method) in [(&r_hbt, "hbt"), (&r_clfrt, "clfrt")] {
        let decided = r["decision"].as_str().unwrap();
        for d in ["nominal", "fault", "inconclusive"] {
            let want = if d == decided { 1.0 } else { 0.0 };
            assert_eq!(value(&m2, &decisions(method, d)), want, "{method} {d}: {r}");
        }
    }
    assert_eq!(r_clfrt["decision"], "inconclusive");
    assert!(
        r_clfrt["reason"].as_str().unwrap().contains("1200"),
        "{r_clfrt}"
    );
    assert_eq!(
        value(
            &m2,
            r#"helmwatch_test_aborts_total{vessel="self",method="clfrt",reason="too_long"}"#
        ),
        1.0
    );
    assert!(!m2.keys().any(|k| k.contains("method=\"hbt\",reason=")));
    // Lockstep, healthy inputs: nothing rejected, nothing dropped.
    assert!(!m2
        .keys()
        .any(|k| k.starts_with("helmwatch_inputs_rejected_total")));
    assert_eq!(
        value(&m2, r#"helmwatch_queue_dropped_total{vessel="self"}"#),
        0.0
    );

    // After the ship stopped: every heading it sent was accepted, and each of the ship's
    // excitations is one latency observation (the last heading may be one ahead of the
    // ship's count: sent as it stopped).
    let m3 = scrape(addr).await;
    let h3 = value(&m3, HEADING);
    let n = summary.excitations as f64;
    assert!(n > 10_000.0, "{n}");
    assert!(h3 >= n && h3 <= n + 1.0, "{h3} headings, {n} excitations");
    let lat = value(&m3, LATENCY_COUNT);
    assert!(lat >= n && lat <= h3, "{lat} latencies, {n} excitations");
    let sum = value(
        &m3,
        r#"helmwatch_excitation_latency_seconds_sum{vessel="self"}"#,
    );
    assert!(sum > 0.0 && sum / lat < 1.0, "mean latency {} s", sum / lat);
    assert_eq!(
        value(
            &m3,
            r#"helmwatch_excitation_latency_seconds_bucket{le="+Inf",vessel="self"}"#
        ),
        lat
    );

    daemon.stop().await;
    obs.close().await;
}

#[tokio::test(flavor = "multi_thread")]
async fn a_port_in_use_names_the_key_and_off_means_no_listener() {
    let taken = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let mut cfg = daemon_config();
    cfg.daemon.metrics_listen = taken.local_addr().unwrap().to_string();
    let err = helmwatch::shells::daemon::Daemon::start(
        &cfg.core(),
        &cfg.daemon,
        loopback_peer(&[endpoint()], &[]).unwrap(),
    )
    .await
    .unwrap_err();
    assert!(
        matches!(err, helmwatch::shells::daemon::DaemonError::Metrics(_)),
        "{err}"
    );
    let text = err.to_string();
    assert!(text.contains("daemon.metrics-listen"), "{text}");
    assert!(text.contains(&cfg.daemon.metrics_listen), "{text}");

    // The default: off.
    let cfg = daemon_config();
    assert!(cfg.daemon.metrics_listen.is_empty());
    let daemon = start_daemon(&cfg, &endpoint()).await;
    assert_eq!(daemon.metrics_addr(), None);
    daemon.stop().await;
}
