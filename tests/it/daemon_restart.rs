//! A restart loses nothing: `helmwatch run --state-dir` killed with SIGKILL during an alarm
//! and started again on the same state directory publishes the alarm again within a second of
//! telling systemd it is ready (`READY=1`, received here on our own `NOTIFY_SOCKET`), its
//! test ids go on from where they were, and its history (`fdi/history`) holds every report a
//! subscriber saw, before and after the kill. A damaged state directory is named, moved
//! aside, and monitoring goes on with a fresh store.

use crate::common::{endpoint, temp_dir, Observer};
use std::os::unix::net::UnixDatagram;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

const LIMIT: Duration = Duration::from_secs(180);

/// `helmwatch --config <dir>/<name>.toml <args>`, standard error to `<dir>/<name>.log`,
/// `NOTIFY_SOCKET` pointed at `notify` when given.
fn spawn(dir: &Path, name: &str, toml: &str, args: &[&str], notify: Option<&Path>) -> Child {
    let cfg = dir.join(format!("{name}.toml"));
    std::fs::write(&cfg, toml).unwrap();
    let log = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(dir.join(format!("{name}.log")))
        .unwrap();
    let mut c = Command::new(env!("CARGO_BIN_EXE_helmwatch"));
    c.arg("--config")
        .arg(&cfg)
        .args(args)
        .env("RUST_LOG", "info,zenoh=warn")
        .env_remove("NOTIFY_SOCKET")
        .stdout(Stdio::null())
        .stderr(log);
    if let Some(n) = notify {
        c.env("NOTIFY_SOCKET", n);
    }
    c.spawn().unwrap()
}

fn log(dir: &Path, name: &str) -> String {
    std::fs::read_to_string(dir.join(format!("{name}.log"))).unwrap_or_default()
}

/// Waits (bounded) for `READY=1` on the notify socket; returns when it came.
async fn ready(sock: &UnixDatagram) -> Instant {
    let deadline = Instant::now() + LIMIT;
    let mut buf = [0u8; 4096];
    loop {
        match sock.recv(&mut buf) {
            Ok(n) if String::from_utf8_lossy(&buf[..n]).contains("READY=1") => {
                return Instant::now()
            }
            Ok(_) => {}
            Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => {
                assert!(Instant::now() < deadline, "no READY=1 within {LIMIT:?}");
                tokio::time::sleep(Duration::from_millis(5)).await;
            }
            Err(e) => panic!("notify socket: {e}"),
        }
    }
}

/// What both tests set up: endpoints, the daemon's and the ship's configuration (HBT tests
/// only, back to back; the design reference from the first test, no commissioning: the ship is
/// faulty from the start), our own `NOTIFY_SOCKET`, and an observer the daemon connects to.
struct Setup {
    dir: PathBuf,
    state: PathBuf,
    daemon_ep: String,
    daemon_toml: String,
    ship_toml: String,
    notify_path: PathBuf,
    notify: UnixDatagram,
    obs: Observer,
}

impl Setup {
    async fn new(name: &str) -> Setup {
        let dir = temp_dir(name);
        let state = dir.join("state");
        let obs_ep = endpoint();
        let daemon_ep = endpoint();
        let daemon_toml = format!(
            "[daemon]\nvessels = [\"self\"]\ntick-s = 0.1\n\n[zenoh]\nmode = \"peer\"\nlisten = [\"{daemon_ep}\"]\nconnect = [\"{obs_ep}\"]\nmulticast-scouting = false\n\n[scheduler]\nmethods = [\"hbt\"]\ninterval-s = 30.0\nsteady-time-s = 60.0\n\n[fdi]\ncommissioning-tests = 0\n"
        );
        let ship_toml = format!(
            "[ship-peer]\nlockstep = true\nmode = \"peer\"\nlisten = []\nconnect = [\"{daemon_ep}\"]\nmulticast-scouting = false\n"
        );
        let notify_path = dir.join("notify.sock");
        let notify = UnixDatagram::bind(&notify_path).unwrap();
        notify.set_nonblocking(true).unwrap();
        let obs = Observer::listening(&obs_ep, "self", false).await;
        Setup {
            dir,
            state,
            daemon_ep,
            daemon_toml,
            ship_toml,
            notify_path,
            notify,
            obs,
        }
    }
}

/// `helmwatch run --state-dir <state>` under our notify socket.
fn daemon(dir: &Path, toml: &str, state: &Path, notify: &Path) -> Child {
    spawn(
        dir,
        "daemon",
        toml,
        &["run", "--state-dir", state.to_str().unwrap()],
        Some(notify),
    )
}

#[tokio::test(flavor = "multi_thread")]
async fn an_alarm_survives_sigkill_and_is_published_within_a_second_of_ready() {
    let Setup {
        dir,
        state,
        daemon_ep,
        daemon_toml,
        ship_toml,
        notify_path,
        notify,
        obs,
    } = Setup::new("restart").await;
    let mut daemon = daemon(&dir, &daemon_toml, &state, &notify_path);
    ready(&notify).await;
    let mut ship = spawn(
        &dir,
        "ship",
        &ship_toml,
        &["ship", "--fault", "displacement_pct:30@0"],
        None,
    );
    let alarm = obs
        .wait_for("notifications/steering/fdi", LIMIT, |n| {
            n["state"] == "alarm"
        })
        .await;
    let file = state.join("vessels/self.json");
    assert!(
        file.exists(),
        "no state file; daemon log:\n{}",
        log(&dir, "daemon")
    );

    // SIGKILL: no shutdown, no final words.
    daemon.kill().unwrap();
    daemon.wait().unwrap();
    let n_before = obs.on("notifications/steering/fdi").len();
    let seq = |id: &str| id.rsplit('-').next().unwrap().parse::<u64>().unwrap();
    let seen_ids: Vec<String> = obs
        .on("fdi/status")
        .iter()
        .filter_map(|s| s["test"].as_str().map(String::from))
        .collect();
    let last_seq = seen_ids.iter().map(|id| seq(id)).max().unwrap();

    let mut daemon = self::daemon(&dir, &daemon_toml, &state, &notify_path);
    let t_ready = ready(&notify).await;
    let deadline = t_ready + Duration::from_secs(1);
    let republished = loop {
        let ns = obs.on("notifications/steering/fdi");
        if ns.len() > n_before {
            break (ns[n_before].clone(), Instant::now());
        }
        assert!(
            Instant::now() < deadline,
            "no notification within 1 s of READY; daemon log:\n{}",
            log(&dir, "daemon")
        );
        tokio::time::sleep(Duration::from_millis(5)).await;
    };
    assert_eq!(republished.0["state"], "alarm", "{}", republished.0);
    assert_eq!(
        republished.0, alarm,
        "the same notification as before the kill"
    );
    assert!(republished.1 <= deadline);

    // Test ids go on after the last one started before the kill: none repeats.
    let next = obs
        .wait_for("fdi/status", LIMIT, |s| {
            s["test"]
                .as_str()
                .is_some_and(|t| !seen_ids.iter().any(|x| x == t))
        })
        .await;
    assert!(
        seq(next["test"].as_str().unwrap()) > last_seq,
        "{next} after {last_seq}; daemon log:\n{}",
        log(&dir, "daemon")
    );

    // No report is lost: the history holds every report the subscriber saw, across the kill,
    // and the notifications.
    let seen: Vec<serde_json::Value> = obs.on("fdi/report");
    let replies = obs
        .session
        .get("vessels/self/fdi/history?limit=10000")
        .await
        .unwrap();
    let reply = replies.recv_async().await.unwrap();
    let body: serde_json::Value =
        serde_json::from_slice(&reply.result().unwrap().payload().to_bytes()).unwrap();
    assert_eq!(body["vessel"], "self");
    let records = body["records"].as_array().unwrap();
    let reports: Vec<&serde_json::Value> = records
        .iter()
        .filter(|r| r["kind"] == "report")
        .map(|r| &r["payload"])
        .collect();
    assert!(!seen.is_empty());
    for r in &seen {
        assert!(
            reports.contains(&r),
            "report {} seen by the subscriber is not in the history",
            r["test"]
        );
    }
    assert!(records
        .iter()
        .any(|r| r["kind"] == "notification" && r["payload"] == alarm));
    // A time range: only the records of the range, oldest first.
    let t_mid = reports[reports.len() / 2]["t_end"].as_f64().unwrap();
    let replies = obs
        .session
        .get(format!("vessels/self/fdi/history?from={t_mid}"))
        .await
        .unwrap();
    let reply = replies.recv_async().await.unwrap();
    let body: serde_json::Value =
        serde_json::from_slice(&reply.result().unwrap().payload().to_bytes()).unwrap();
    let ts: Vec<f64> = body["records"]
        .as_array()
        .unwrap()
        .iter()
        .map(|r| r["t"].as_f64().unwrap())
        .collect();
    assert!(!ts.is_empty() && ts.iter().all(|&t| t >= t_mid), "{ts:?}");
    assert!(ts.windows(2).all(|w| w[0] <= w[1]), "{ts:?}");
    // A bad parameter is an error reply naming it.
    let replies = obs
        .session
        .get("vessels/self/fdi/history?limit=0")
        .await
        .unwrap();
    let reply = replies.recv_async().await.unwrap();
    let err = reply.result().unwrap_err();
    assert!(
        String::from_utf8_lossy(&err.payload().to_bytes()).contains("limit"),
        "{err:?}"
    );

    // The same through the command-line clients.
    let client = |args: &[&str]| {
        let out = Command::new(env!("CARGO_BIN_EXE_helmwatch"))
            .args(args)
            .args(["--connect", &daemon_ep, "--vessel", "self"])
            .output()
            .unwrap();
        (
            out.status.code(),
            String::from_utf8_lossy(&out.stdout).to_string(),
        )
    };
    let (code, out) = client(&["status", "--json"]);
    assert_eq!(code, Some(0), "{out}");
    let st: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert_eq!(st["alive"], true, "{st}");
    assert_eq!(st["alarm"], "alarm", "{st}");
    // The history holds at least the faulty test's report and its alarm (one overwhelming
    // test is an alarm by itself): the limit keeps one.
    let (code, out) = client(&["history", "--limit", "1"]);
    assert_eq!(code, Some(0), "{out}");
    assert_eq!(out.lines().count(), 2, "a header and one record:\n{out}");
    let (code, out) = client(&["trigger", "--method", "clfrt"]);
    assert_eq!(code, Some(0), "{out}");
    assert!(out.starts_with("self: "), "{out}");
    let out = Command::new(env!("CARGO_BIN_EXE_helmwatch"))
        .args([
            "status",
            "--connect",
            &daemon_ep,
            "--vessel",
            "nobody",
            "--timeout-s",
            "1",
        ])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(69), "no daemon monitors `nobody`");

    let _ = ship.kill();
    let _ = ship.wait();
    let _ = daemon.kill();
    let _ = daemon.wait();
    obs.close().await;
    let _ = std::fs::remove_dir_all(&dir);
}

/// A state directory someone damaged (a truncated vessel file, garbage in place of the
/// history): the daemon starts, says which files it moved aside and why, and monitors with a
/// fresh store: its next report is published and kept in the new history.
#[tokio::test(flavor = "multi_thread")]
async fn a_corrupted_state_directory_is_named_moved_aside_and_monitoring_goes_on() {
    let Setup {
        dir,
        state,
        daemon_toml,
        ship_toml,
        notify_path,
        notify,
        obs,
        ..
    } = Setup::new("corrupt-state").await;
    std::fs::create_dir_all(state.join("vessels")).unwrap();
    let vessel_file = state.join("vessels/self.json");
    std::fs::write(&vessel_file, "{\"format\": \"helmwatch-state/1\", \"vess").unwrap();
    let history_file = state.join("history.sqlite");
    std::fs::write(&history_file, vec![0xA5u8; 5000]).unwrap();
    let mut daemon = daemon(&dir, &daemon_toml, &state, &notify_path);
    ready(&notify).await;
    let text = log(&dir, "daemon");
    for f in [&vessel_file, &history_file] {
        assert!(
            text.contains(&f.display().to_string()),
            "the log names {}:\n{text}",
            f.display()
        );
    }
    assert!(vessel_file.with_extension("json.corrupt").exists());
    assert!(state.join("history.sqlite.corrupt").exists());

    let mut ship = spawn(&dir, "ship", &ship_toml, &["ship"], None);
    let r = obs.wait_for("fdi/report", LIMIT, |_| true).await;
    assert_eq!(r["outcome"], "completed", "{r}");
    let replies = obs
        .session
        .get("vessels/self/fdi/history?limit=100")
        .await
        .unwrap();
    let reply = replies.recv_async().await.unwrap();
    let body: serde_json::Value =
        serde_json::from_slice(&reply.result().unwrap().payload().to_bytes()).unwrap();
    assert!(
        body["records"]
            .as_array()
            .unwrap()
            .iter()
            .any(|x| x["kind"] == "report" && x["payload"] == r),
        "{body}"
    );
    assert_eq!(daemon.try_wait().unwrap(), None, "the daemon is running");

    let _ = ship.kill();
    let _ = ship.wait();
    let _ = daemon.kill();
    let _ = daemon.wait();
    obs.close().await;
    let _ = std::fs::remove_dir_all(&dir);
}
