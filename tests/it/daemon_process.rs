//! The real binaries as processes: `helmwatch run` killed mid-test (the ship's autopilot
//! reverts within `hold_s`), and `helmwatch run` + `helmwatch ship` with SIGTERM (exit 0
//! after `mode: none` and a final status).

use crate::common::{endpoint, Observer};
use helmwatch::config::Config;
use helmwatch::shells::net::loopback_peer;
use helmwatch::shells::shipnode::{ShipNode, ShipNodeOptions};
use helmwatch_core::sim::{CommandSource, Scenario};
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::{Arc, Mutex};
use std::time::Duration;
use tokio_util::sync::CancellationToken;

const LIMIT: Duration = Duration::from_secs(120);

fn temp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("helmwatch-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Starts `helmwatch --config <file> <args>`, standard error to `<dir>/<name>.log`.
fn spawn(dir: &Path, name: &str, toml: &str, args: &[&str]) -> Child {
    let cfg = dir.join(format!("{name}.toml"));
    std::fs::write(&cfg, toml).unwrap();
    let log = std::fs::File::create(dir.join(format!("{name}.log"))).unwrap();
    Command::new(env!("CARGO_BIN_EXE_helmwatch"))
        .arg("--config")
        .arg(&cfg)
        .args(args)
        .env("RUST_LOG", "info")
        .stdout(Stdio::null())
        .stderr(log)
        .spawn()
        .unwrap()
}

fn log(dir: &Path, name: &str) -> String {
    std::fs::read_to_string(dir.join(format!("{name}.log"))).unwrap_or_default()
}

fn signal(child: &Child, sig: &str) {
    let ok = Command::new("kill")
        .args([sig, &child.id().to_string()])
        .status()
        .unwrap()
        .success();
    assert!(ok, "kill {sig}");
}

/// Waits (bounded) for a child to exit.
async fn wait_exit(child: &mut Child) -> std::process::ExitStatus {
    for _ in 0..(LIMIT.as_millis() / 20) {
        if let Some(s) = child.try_wait().unwrap() {
            return s;
        }
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
    let _ = child.kill();
    panic!("the process did not exit");
}

fn daemon_toml(ep: &str, scheduler: bool) -> String {
    format!(
        "[daemon]\nvessels = [\"self\"]\ntick-s = 0.1\n\n[zenoh]\nmode = \"peer\"\nlisten = [\"{ep}\"]\nconnect = []\nmulticast-scouting = false\n\n[scheduler]\nenabled = {scheduler}\n"
    )
}

#[tokio::test(flavor = "multi_thread")]
async fn daemon_killed_mid_test_the_autopilot_reverts_within_hold() {
    let dir = temp_dir("killed");
    let ep = endpoint();
    let mut daemon = spawn(&dir, "daemon", &daemon_toml(&ep, false), &["run"]);

    // The ship in this process, so every tick's command source can be observed.
    let cfg = Config::default();
    let mut opts = ShipNodeOptions::from_config(&cfg.ship_peer, &cfg.simulation.vessel);
    opts.lockstep = true;
    opts.excitation_timeout = Duration::from_millis(200);
    opts.speed_up = 20.0;
    let ticks: Arc<Mutex<Vec<(f64, CommandSource)>>> = Arc::default();
    let t2 = ticks.clone();
    let node = ShipNode::new(&cfg.sim(), &Scenario::nominal(&cfg.sim(), 9), opts)
        .unwrap()
        .observe(move |t, truth| t2.lock().unwrap().push((t, truth.command_source)));
    let stop = CancellationToken::new();
    let s = stop.clone();
    let ship = tokio::spawn(node.run(
        loopback_peer(&[], std::slice::from_ref(&ep)).unwrap(),
        async move { s.cancelled().await },
    ));
    let obs = Observer::new(&ep, "self", false).await;
    obs.trigger("hbt").await;

    // Wait until the relay steers the ship (replace), then kill the daemon outright.
    let replaced = || {
        ticks
            .lock()
            .unwrap()
            .iter()
            .filter(|x| x.1 == CommandSource::Replaced)
            .count()
    };
    for _ in 0..(LIMIT.as_millis() / 20) {
        if replaced() >= 50 {
            break;
        }
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
    assert!(
        replaced() >= 50,
        "the relay never steered; daemon log:\n{}",
        log(&dir, "daemon")
    );
    daemon.kill().unwrap();
    daemon.wait().unwrap();

    // The ship steps on; find the last relay tick and the first own-command tick after it.
    let hold_s = cfg.safety.hold_s;
    let dt = cfg.sensors.dt_s();
    let (t_relay, t_own) = loop {
        let v = ticks.lock().unwrap().clone();
        let last_relay = v
            .iter()
            .rposition(|x| x.1 == CommandSource::Replaced)
            .unwrap();
        let t_relay = v[last_relay].0;
        let after = &v[last_relay + 1..];
        if after.len() as f64 * dt > hold_s + 2.0 {
            let own = after
                .iter()
                .find(|x| x.1 == CommandSource::Own)
                .expect("the autopilot reverted to its own command");
            assert!(
                after
                    .iter()
                    .filter(|x| x.0 >= own.0)
                    .all(|x| x.1 == CommandSource::Own),
                "nothing but the own command after the revert"
            );
            break (t_relay, own.0);
        }
        tokio::time::sleep(Duration::from_millis(20)).await;
    };
    // The last excitation was valid from its t <= t_relay to t + hold_s: the revert comes at
    // the first tick past that.
    assert!(
        t_own - t_relay <= hold_s + dt + 1e-9,
        "reverted at {t_own} s, last relay tick {t_relay} s, hold {hold_s} s"
    );

    stop.cancel();
    let summary = ship.await.unwrap().unwrap();
    assert!(summary.excitation_timeouts >= 1, "{summary:?}");
    obs.close().await;
    let _ = std::fs::remove_dir_all(&dir);
}

#[tokio::test(flavor = "multi_thread")]
async fn sigterm_exits_0_after_mode_none_and_a_final_status() {
    let dir = temp_dir("sigterm");
    let ep = endpoint();
    // The scheduler starts a CLFRT test by itself after two minutes of steady course.
    let mut daemon = spawn(&dir, "daemon", &daemon_toml(&ep, true), &["run"]);
    let obs = Observer::new(&ep, "self", true).await;
    let ship_toml = format!(
        "[ship-peer]\nlockstep = true\nmode = \"peer\"\nlisten = []\nconnect = [\"{ep}\"]\nmulticast-scouting = false\n"
    );
    let mut ship = spawn(&dir, "ship", &ship_toml, &["ship"]);

    // A test is under way when the excitation adds the multisine.
    obs.wait_for("steering/autopilot/excitation", LIMIT, |e| {
        e["mode"] == "add"
    })
    .await;
    signal(&daemon, "-TERM");
    let status = wait_exit(&mut daemon).await;
    assert_eq!(
        status.code(),
        Some(0),
        "daemon log:\n{}",
        log(&dir, "daemon")
    );

    // After the exit, what the daemon sent last: the aborted report, the idle status, and
    // (first, on its own real-time queue) mode none.
    let report = obs
        .wait_for("fdi/report", LIMIT, |r| r["outcome"] == "aborted")
        .await;
    assert_eq!(report["reason"], "daemon stopping", "{report}");
    let final_status = obs
        .wait_for("fdi/status", LIMIT, |s| {
            s["reason"]
                .as_str()
                .is_some_and(|r| r.contains("daemon stopping"))
        })
        .await;
    assert_eq!(final_status["state"], "idle", "{final_status}");
    assert_eq!(
        obs.on("fdi/status").last(),
        Some(&final_status),
        "the final status is the last one"
    );
    let mut last = Value::Null;
    for _ in 0..(LIMIT.as_millis() / 20) {
        last = obs
            .on("steering/autopilot/excitation")
            .last()
            .cloned()
            .unwrap_or_default();
        if last["mode"] == "none" {
            break;
        }
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
    assert_eq!(
        last["mode"], "none",
        "the last excitation stops the test: {last}"
    );
    assert!(last["test"].is_null() && last["value"] == 0.0, "{last}");

    // The ship peer stops cleanly on SIGTERM too.
    signal(&ship, "-TERM");
    let status = wait_exit(&mut ship).await;
    assert_eq!(status.code(), Some(0), "ship log:\n{}", log(&dir, "ship"));
    obs.close().await;
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn bad_zenoh_settings_exit_78_or_64_naming_what() {
    let dir = temp_dir("badzenoh");
    let cfg = dir.join("bad.toml");
    std::fs::write(
        &cfg,
        "[zenoh]\nconfig-file = \"/nonexistent/zenoh.json5\"\n",
    )
    .unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_helmwatch"))
        .arg("--config")
        .arg(&cfg)
        .arg("run")
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(78));
    assert!(String::from_utf8_lossy(&out.stderr).contains("/nonexistent/zenoh.json5"));
    std::fs::write(&cfg, "[zenoh]\nlisten = [\"nonsense\"]\n").unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_helmwatch"))
        .arg("--config")
        .arg(&cfg)
        .arg("run")
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(78));
    assert!(String::from_utf8_lossy(&out.stderr).contains("zenoh.listen[0]"));
    let out = Command::new(env!("CARGO_BIN_EXE_helmwatch"))
        .args(["run", "--connect", "nonsense"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(64));
    let _ = std::fs::remove_dir_all(&dir);
}
