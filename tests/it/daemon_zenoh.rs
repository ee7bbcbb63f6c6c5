//! The daemon and the simulated ship as separate Zenoh sessions on loopback (in one process),
//! in lockstep: nominal runs, a ship that disconnects, hostile samples in the streams, clock
//! steps (a fault after commissioning: tests/it/commissioning.rs).
//! No timing is asserted: every wait is bounded and polls for an event.

use crate::common::{daemon_config, endpoint, ran_to_analysis, start_daemon, Observer};
use helmwatch::config::Config;
use helmwatch::shells::net::loopback_peer;
use helmwatch::shells::shipnode::{ShipNode, ShipNodeOptions, ShipSummary};
use helmwatch_core::sim::Scenario;
use std::time::Duration;
use tokio::task::JoinHandle;
use tokio_util::sync::CancellationToken;

const LIMIT: Duration = Duration::from_secs(120);

/// A lockstep ship connected to `ep`, running until the returned token is cancelled.
fn spawn_ship(
    cfg: &Config,
    scenario: &Scenario,
    ep: &str,
) -> (
    CancellationToken,
    JoinHandle<Result<ShipSummary, helmwatch::shells::shipnode::ShipNodeError>>,
) {
    let mut opts = ShipNodeOptions::from_config(&cfg.ship_peer, &cfg.simulation.vessel);
    opts.lockstep = true;
    let node = ShipNode::new(&cfg.sim(), scenario, opts).unwrap();
    let stop = CancellationToken::new();
    let s = stop.clone();
    let zcfg = loopback_peer(&[], &[ep.to_string()]).unwrap();
    let task = tokio::spawn(node.run(zcfg, async move { s.cancelled().await }));
    (stop, task)
}

#[tokio::test(flavor = "multi_thread")]
async fn nominal_run_reports_arrive_with_features_and_no_alarm() {
    let ep = endpoint();
    let cfg = daemon_config();
    let daemon = start_daemon(&cfg, &ep).await;
    let obs = Observer::new(&ep, "self", false).await;
    let (stop, ship) = spawn_ship(&cfg, &Scenario::nominal(&cfg.sim(), 7), &ep);

    // The scheduler starts the first test (CLFRT) on the steady ship by itself.
    let r1 = obs.wait_for("fdi/report", LIMIT, |_| true).await;
    assert_eq!(r1["method"], "clfrt", "{r1}");
    assert!(ran_to_analysis(&r1), "{r1}");
    assert_ne!(r1["decision"], "fault", "{r1}");

    // A bad trigger is refused with a reason; a good one starts an HBT test.
    let bad = obs.trigger_once("zigzag").await.unwrap();
    assert!(!bad.accepted && bad.reason.is_some(), "{bad:?}");
    let reply = obs.trigger("hbt").await;
    let id = reply.test.clone().unwrap();
    let r2 = obs
        .wait_for("fdi/report", LIMIT, |r| r["test"] == id.as_str())
        .await;
    assert_eq!(r2["method"], "hbt");
    assert!(ran_to_analysis(&r2), "{r2}");
    assert_ne!(r2["decision"], "fault", "{r2}");

    // Status went through settling and back to idle for each test (the idle status follows
    // the report: wait for the second one).
    let idle = |s: &serde_json::Value| s["state"] == "idle";
    for _ in 0..600 {
        if obs.on("fdi/status").iter().filter(|s| idle(s)).count() >= 2 {
            break;
        }
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
    let states: Vec<String> = obs
        .on("fdi/status")
        .iter()
        .filter_map(|s| s["state"].as_str().map(String::from))
        .collect();
    assert!(
        states.iter().filter(|s| *s == "settling").count() >= 2,
        "{states:?}"
    );
    assert_eq!(
        states.last().map(String::as_str),
        Some("idle"),
        "{states:?}"
    );
    // No alarm on the nominal ship.
    for n in obs.on("notifications/steering/fdi") {
        assert!(
            n["state"] == "normal",
            "no alarm on the nominal ship, got {n}"
        );
    }

    stop.cancel();
    let summary = ship.await.unwrap().unwrap();
    assert_eq!(summary.excitation_timeouts, 0, "{summary:?}");
    assert!(summary.excitations >= summary.ticks, "{summary:?}");
    daemon.stop().await;
    obs.close().await;
}

#[tokio::test(flavor = "multi_thread")]
async fn ship_disconnecting_mid_test_aborts_the_test_with_a_report() {
    let ep = endpoint();
    let mut cfg = daemon_config();
    cfg.scheduler.enabled = false;
    let daemon = start_daemon(&cfg, &ep).await;
    let obs = Observer::new(&ep, "self", false).await;
    let (stop, ship) = spawn_ship(&cfg, &Scenario::nominal(&cfg.sim(), 3), &ep);

    let id = obs.trigger("clfrt").await.test.unwrap();
    obs.wait_for("fdi/status", LIMIT, |s| s["test"] == id.as_str())
        .await;
    // The ship goes away in the middle of the test.
    stop.cancel();
    ship.await.unwrap().unwrap();

    let r = obs
        .wait_for("fdi/report", LIMIT, |r| r["test"] == id.as_str())
        .await;
    assert_eq!(r["outcome"], "aborted", "{r}");
    let reason = r["reason"].as_str().unwrap();
    assert!(reason.contains("silent"), "{reason}");
    assert!(r["estimate"].is_null(), "{r}");
    let idle = obs
        .wait_for("fdi/status", LIMIT, |s| {
            s["state"] == "idle" && s["reason"].as_str().is_some_and(|x| x.contains("silent"))
        })
        .await;
    assert!(idle["test"].is_null(), "{idle}");
    daemon.stop().await;
    obs.close().await;
}

#[tokio::test(flavor = "multi_thread")]
async fn malformed_nan_and_out_of_order_samples_are_counted_and_the_next_test_completes() {
    let ep = endpoint();
    let mut cfg = daemon_config();
    cfg.scheduler.enabled = false;
    let daemon = start_daemon(&cfg, &ep).await;
    let obs = Observer::new(&ep, "self", false).await;
    let (stop, ship) = spawn_ship(&cfg, &Scenario::nominal(&cfg.sim(), 5), &ep);

    let id1 = obs.trigger("hbt").await.test.unwrap();
    // Hostile samples from a third session while the test runs: not JSON, NaN (not valid
    // JSON either), a missing field, and samples older than the streams' last ones.
    let injector = zenoh::open(loopback_peer(&[], std::slice::from_ref(&ep)).unwrap())
        .await
        .unwrap();
    let heading = injector
        .declare_publisher("vessels/self/navigation/headingTrue")
        .await
        .unwrap();
    let rudder = injector
        .declare_publisher("vessels/self/steering/rudderAngle")
        .await
        .unwrap();
    assert!(helmwatch::shells::net::wait_matching(&heading, LIMIT).await);
    assert!(helmwatch::shells::net::wait_matching(&rudder, LIMIT).await);
    let malformed: [&[u8]; 4] = [
        b"not json",
        br#"{"t": NaN, "value": 1.0}"#,
        br#"{"t": 5.0, "value": NaN}"#,
        br#"{"t": 5.0}"#,
    ];
    for _ in 0..5 {
        for m in malformed {
            heading.put(m.to_vec()).await.unwrap();
        }
        heading
            .put(br#"{"t": 0.5, "value": 1.0}"#.to_vec())
            .await
            .unwrap();
        rudder
            .put(br#"{"t": 0.5, "value": 0.01}"#.to_vec())
            .await
            .unwrap();
    }
    let stats = obs
        .wait_for("fdi/stats", LIMIT, |s| {
            s["inputs"]["heading"]["malformed"] == 20
                && s["inputs"]["heading"]["out_of_order"] == 5
                && s["inputs"]["rudder"]["out_of_order"] == 5
        })
        .await;
    assert_eq!(stats["dropped"]["flood"], 0, "{stats}");

    let r1 = obs
        .wait_for("fdi/report", LIMIT, |r| r["test"] == id1.as_str())
        .await;
    assert!(ran_to_analysis(&r1), "{r1}");
    // The next test runs to its end as well. It starts once the autopilot has taken the ship
    // back (300 s of ship time, as the scheduler's steady-course wait would): right after a
    // relay test the autopilot's answer to the limit cycle swings the rudder towards its
    // limit, and a test started then aborts on rudder saturation.
    let t_back = r1["t_end"].as_f64().unwrap() + 300.0;
    obs.wait_for("fdi/stats", LIMIT, |s| {
        s["t"].as_f64().is_some_and(|t| t >= t_back)
    })
    .await;
    let id2 = obs.trigger("hbt").await.test.unwrap();
    let r2 = obs
        .wait_for("fdi/report", LIMIT, |r| r["test"] == id2.as_str())
        .await;
    assert!(ran_to_analysis(&r2), "{r2}");

    heading.undeclare().await.unwrap();
    rudder.undeclare().await.unwrap();
    injector.close().await.unwrap();
    stop.cancel();
    ship.await.unwrap().unwrap();
    let summaries = daemon.stop().await;
    assert_eq!(
        summaries[0].stats["inputs"]["heading"]["malformed"], 20,
        "{:?}",
        summaries[0].stats
    );
    obs.close().await;
}

#[tokio::test(flavor = "multi_thread")]
async fn a_fleet_daemon_answers_each_vessel_on_its_own_keys() {
    let ep = endpoint();
    let mut cfg = daemon_config();
    cfg.scheduler.enabled = false;
    cfg.daemon.vessels = vec!["alpha".into(), "bravo".into()];
    let daemon = start_daemon(&cfg, &ep).await;
    let obs = Observer::new(&ep, "bravo", false).await;
    let mut ship_cfg = cfg.clone();
    ship_cfg.simulation.vessel = "bravo".into();
    let (stop, ship) = spawn_ship(&ship_cfg, &Scenario::nominal(&cfg.sim(), 2), &ep);
    let reply = obs.trigger("hbt").await;
    assert!(reply.test.unwrap().starts_with("bravo-hbt-"));
    // alpha has no ship: its monitor refuses.
    let r = obs
        .session
        .get("vessels/alpha/fdi/trigger?method=hbt")
        .await
        .unwrap()
        .recv_async()
        .await
        .unwrap()
        .into_result()
        .unwrap();
    let alpha: helmwatch_core::wire::TriggerReply =
        serde_json::from_slice(&r.payload().to_bytes()).unwrap();
    assert!(!alpha.accepted, "{alpha:?}");
    assert_eq!(r.key_expr().as_str(), "vessels/alpha/fdi/trigger");
    stop.cancel();
    ship.await.unwrap().unwrap();
    daemon.stop().await;
    obs.close().await;
}

/// The sensors' clock over Zenoh: one tick of every stream stamped 1e6 s in the future, later
/// the clock stepping back an hour on every stream (a GNSS time fix). The daemon answers the
/// headings again at once after the wild tick and within 10 s of ship time after the step,
/// counts one re-synchronisation per stream, and completes a test on the new timeline.
#[tokio::test(flavor = "multi_thread")]
async fn a_wild_timestamp_and_a_clock_stepped_back_an_hour_never_stop_the_daemon() {
    const OUTLIER_S: f64 = 300.0;
    const STEP_S: f64 = 600.0;
    let ep = endpoint();
    let mut cfg = daemon_config();
    cfg.scheduler.enabled = false;
    let daemon = start_daemon(&cfg, &ep).await;
    let obs = Observer::new(&ep, "self", true).await;
    let mut scenario = Scenario::nominal(&cfg.sim(), 5);
    scenario.faults = vec![
        format!("clock_outlier_s:1e6@{OUTLIER_S}").parse().unwrap(),
        format!("clock_step_s:-3600@{STEP_S}").parse().unwrap(),
    ];
    let (stop, ship) = spawn_ship(&cfg, &scenario, &ep);
    let exc_t = |v: &serde_json::Value| v["t"].as_f64().unwrap_or(f64::NAN);

    // The first excitation on the new timeline (ship time after the step, the clock an hour
    // behind) comes within 10 s of the step.
    let first_new = obs
        .wait_for("steering/autopilot/excitation", LIMIT, |e| {
            exc_t(e) < STEP_S - 3600.0 + 1000.0
        })
        .await;
    let late = exc_t(&first_new) - (STEP_S - 3600.0);
    assert!(
        (0.0..10.0).contains(&late),
        "headings answered again {late} s of ship time after the step"
    );
    let excitations = obs.on("steering/autopilot/excitation");
    // The wild tick was never answered; the tick after it was, on the old timeline.
    assert!(
        excitations.iter().all(|e| exc_t(e) < 1e5),
        "a wild tick answered"
    );
    let after_outlier = excitations
        .iter()
        .map(exc_t)
        .filter(|t| *t > OUTLIER_S)
        .fold(f64::INFINITY, f64::min);
    assert!(
        after_outlier < OUTLIER_S + 0.25,
        "first heading answered after the wild tick: t = {after_outlier}"
    );

    // Every stream the test reads is on the new timeline before the trigger: the slower
    // autopilot_state stream steps back a moment after the headings, and a stream stepping
    // back during a test aborts that test (what `tests/it/clock_steps.rs` checks).
    let streams = ["heading", "rudder", "speed", "autopilot_state"];
    let stats = obs
        .wait_for("fdi/stats", LIMIT, |s| {
            streams
                .iter()
                .all(|k| s["inputs"][*k]["resyncs"].as_u64() == Some(1))
        })
        .await;
    // A test completes on the new timeline.
    let id = obs.trigger("hbt").await.test.unwrap();
    let r = obs
        .wait_for("fdi/report", LIMIT, |r| r["test"] == id.as_str())
        .await;
    assert_eq!(r["outcome"], "completed", "{r}");
    assert!(r["t_start"].as_f64().unwrap() < 0.0, "{r}");
    // Counted: one re-synchronisation per stream, one wild sample rejected per stream.
    for stream in ["heading", "rudder", "speed"] {
        let s = &stats["inputs"][stream];
        assert_eq!(s["resyncs"], 1, "{stream}: {s}");
        assert_eq!(s["time_jump"], 1, "{stream}: {s}");
    }

    stop.cancel();
    ship.await.unwrap().unwrap();
    daemon.stop().await;
    obs.close().await;
}
