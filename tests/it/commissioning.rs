//! Commissioning over Zenoh, with the daemon's state directory: the first tests of each method
//! set the vessel's own reference (`fdi/commission` reports it); the reference survives a
//! restart of the daemon; a fault that appears after commissioning raises the alarm; a change
//! of the ship's configuration discards the reference; `helmwatch commission --start` begins
//! it again.

use crate::common::{daemon_config, endpoint, start_daemon, temp_dir, Observer};
use helmwatch::config::Config;
use helmwatch::shells::net::loopback_peer;
use helmwatch::shells::shipnode::{ShipNode, ShipNodeOptions};
use helmwatch_core::sim::Scenario;
use serde_json::Value;
use std::time::Duration;
use tokio_util::sync::CancellationToken;

const LIMIT: Duration = Duration::from_secs(120);

/// Runs `methods` one after the other on a lockstep ship of `scenario` (its clock from
/// `start_s`); returns the reports.
async fn run_tests(
    cfg: &Config,
    scenario: &Scenario,
    start_s: f64,
    ep: &str,
    obs: &Observer,
    methods: &[&str],
) -> Vec<Value> {
    let mut sim = cfg.sim();
    sim.simulation.start_time_s = start_s;
    let mut opts = ShipNodeOptions::from_config(&cfg.ship_peer, &cfg.simulation.vessel);
    opts.lockstep = true;
    let node = ShipNode::new(&sim, scenario, opts).unwrap();
    let stop = CancellationToken::new();
    let s = stop.clone();
    let zcfg = loopback_peer(&[], &[ep.to_string()]).unwrap();
    let ship = tokio::spawn(node.run(zcfg, async move { s.cancelled().await }));
    let mut reports = Vec::new();
    for m in methods {
        let id = obs.trigger(m).await.test.unwrap();
        let r = obs
            .wait_for("fdi/report", LIMIT, |r| r["test"] == id.as_str())
            .await;
        assert_eq!(r["outcome"], "completed", "{r}");
        reports.push(r);
    }
    stop.cancel();
    ship.await.unwrap().unwrap();
    reports
}

#[tokio::test(flavor = "multi_thread")]
async fn commissioning_survives_a_restart_then_a_fault_raises_the_alarm() {
    let dir = temp_dir("commissioning");
    let ep = endpoint();
    let mut cfg = daemon_config();
    cfg.scheduler.enabled = false;
    // The fewest the covariance's K-sample factor allows.
    cfg.fdi.commissioning_tests = 5;
    cfg.daemon.state_dir = Some(dir.join("state").display().to_string());

    // 1. A healthy ship commissions both methods, five tests each.
    let daemon = start_daemon(&cfg, &ep).await;
    let obs = Observer::new(&ep, "self", false).await;
    let c = obs.commission("").await;
    assert_eq!(c["clfrt"]["state"], "commissioning", "{c}");
    assert_eq!(c["clfrt"]["text"], "commissioning 0 of at most 5", "{c}");
    let healthy = Scenario::nominal(&cfg.sim(), 11);
    let methods: Vec<&str> = ["clfrt", "hbt"].repeat(5);
    let reports = run_tests(&cfg, &healthy, 0.0, &ep, &obs, &methods).await;
    for (i, r) in reports.iter().enumerate() {
        assert_eq!(r["residuals"]["reference"]["kind"], "commissioning", "{r}");
        // No vessel reference yet: no calibrated estimate, and the message says the
        // networks' estimate is raw.
        assert!(r["calibrated_estimate"].is_null(), "{r}");
        assert!(
            r["message"]
                .as_str()
                .unwrap()
                .contains("(raw: no vessel reference)"),
            "{r}"
        );
        assert_ne!(r["decision"], "fault", "{r}");
        let complete = r["message"]
            .as_str()
            .unwrap()
            .contains("commissioning complete");
        assert_eq!(complete, i >= 8, "test {i}: {r}");
    }
    let before = obs.commission("").await;
    for m in ["clfrt", "hbt"] {
        assert_eq!(before[m]["state"], "commissioned", "{before}");
        assert_eq!(before[m]["reference"]["tests"], 5, "{before}");
    }
    daemon.stop().await;
    obs.close().await;

    // 2. Restarted on the same state directory: the same reference, to the bit.
    let daemon = start_daemon(&cfg, &ep).await;
    let obs = Observer::new(&ep, "self", false).await;
    let after = obs.commission("").await;
    for m in ["clfrt", "hbt"] {
        assert_eq!(after[m]["reference"], before[m]["reference"], "{after}");
    }
    // A displacement 30 % up appears after commissioning (a new ship clock, later).
    let mut faulty = Scenario::nominal(&cfg.sim(), 12);
    faulty.faults = vec!["displacement_pct:+30@0".parse().unwrap()];
    let reports = run_tests(&cfg, &faulty, 20_000.0, &ep, &obs, &["clfrt", "clfrt"]).await;
    assert_eq!(
        reports[0]["residuals"]["reference"]["kind"], "commissioned",
        "{}",
        reports[0]
    );
    // The commissioned residual is the raw one (against the design, `residuals.raw`) less
    // the reference's offset.
    let res = &reports[0]["residuals"];
    let f = |v: &Value| v.as_f64().unwrap();
    let d_nom = f(&res["displacement_nominal_t"]);
    let want_u = f(&res["raw"]["speed_mps"]) - f(&res["reference"]["speed_offset_mps"]);
    let want_d =
        f(&res["raw"]["displacement"]) * d_nom - f(&res["reference"]["displacement_offset_t"]);
    assert!(
        (f(&res["parameters"]["speed_mps"]) - want_u).abs() < 1e-9,
        "{res}"
    );
    assert!(
        (f(&res["parameters"]["displacement_t"]) - want_d).abs() < 1e-6,
        "{res}"
    );
    // The estimate calibrated to the vessel: the residual against the reference's offset
    // read as a log bias and a displacement change at once (the unit tests of
    // `fdi::report::cause_reading` check the arithmetic). It reads the displacement the ship
    // now has (30 % over the declared) and the log's speed.
    let cal = &reports[0]["calibrated_estimate"];
    let u_log = f(&res["raw"]["speed_log_mps"]);
    assert_eq!(cal["reference"], "commissioned", "{cal}");
    assert!(
        (f(&cal["speed_mps"]) - u_log).abs() < 0.5,
        "{cal}: log {u_log}"
    );
    let ratio = f(&cal["displacement_t"]) / (1.3 * d_nom);
    assert!(
        (0.9..1.1).contains(&ratio),
        "{cal}: {ratio} of the true 1.3 D_nom"
    );
    for (lo_hi, v) in [
        ("speed_interval_mps", "speed_mps"),
        ("displacement_interval_t", "displacement_t"),
    ] {
        let [lo, hi] = [f(&cal[lo_hi][0]), f(&cal[lo_hi][1])];
        assert!(lo < f(&cal[v]) && f(&cal[v]) < hi, "{cal}");
    }
    let message = reports[0]["message"].as_str().unwrap();
    assert!(
        message.contains("networks' estimate") && message.contains("calibrated to the vessel"),
        "{message}"
    );
    let last = &reports[1];
    assert_eq!(last["decision"], "fault", "{last}");
    // Two CLFRT tests against a five-test reference cannot yet tell a loading change from a
    // speed-log bias: in CLFRT's whitened residuals the two causes' directions are a few
    // degrees apart (its speed estimate is the noisy one), their costs near-tie (0.05-0.4
    // each, the order changing with the tick the trigger lands on), and the report keeps the
    // other in `not_ruled_out`. The displacement must be among the suspects: named, or not
    // ruled out beside the name.
    let suspects: Vec<&Value> = last["isolation"]
        .as_array()
        .unwrap()
        .iter()
        .chain(
            last["residuals"]["decision"]["not_ruled_out"]
                .as_array()
                .into_iter()
                .flatten(),
        )
        .collect();
    assert!(
        suspects
            .iter()
            .any(|c| *c == "displacement_or_rudder_effectiveness"),
        "{last}"
    );
    let n = obs
        .wait_for("notifications/steering/fdi", LIMIT, |n| {
            n["state"] == "alarm"
        })
        .await;
    assert_eq!(n["method"], serde_json::json!(["visual", "sound"]), "{n}");

    // 3. `helmwatch commission --start --method hbt`, the client: HBT begins again, CLFRT keeps
    //    its reference.
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_helmwatch"))
        .args(["commission", "--start", "--method", "hbt", "--connect", &ep])
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{text} {}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(text.contains("self: commissioning started"), "{text}");
    assert!(
        text.lines()
            .any(|l| l.starts_with("hbt") && l.contains("commissioning")),
        "{text}"
    );
    assert!(
        text.lines()
            .any(|l| l.starts_with("clfrt") && l.contains("commissioned")),
        "{text}"
    );
    daemon.stop().await;
    obs.close().await;

    // 4. HBT measuring another number of periods: the saved reference is discarded on
    //    restart (the models still fit).
    let mut changed = cfg.clone();
    changed.hbt.measure_periods += 1;
    let daemon = start_daemon(&changed, &ep).await;
    let obs = Observer::new(&ep, "self", false).await;
    let c = obs.commission("").await;
    for m in ["clfrt", "hbt"] {
        assert_eq!(c[m]["state"], "commissioning", "{c}");
        assert_eq!(c[m]["tests"], 0, "{c}");
    }
    // The alarm itself is kept: an alarm stays an alarm across a restart.
    let n = obs
        .wait_for("notifications/steering/fdi", LIMIT, |n| {
            n["state"] == "alarm"
        })
        .await;
    assert!(n["message"].is_string());
    daemon.stop().await;
    obs.close().await;
    let _ = std::fs::remove_dir_all(&dir);
}
