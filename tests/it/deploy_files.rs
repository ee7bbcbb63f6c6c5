//! The deployment files stay loadable: the example `/etc/helmwatch/helmwatch.toml` passes the
//! configuration checks, the Zenoh router configurations parse, and the systemd unit names
//! the paths and the readiness protocol the daemon implements; so does the NMEA bridge's unit.
//! (`systemd-analyze verify` runs on both in `.ci/run`.)

use std::path::Path;

fn deploy(name: &str) -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("deploy")
        .join(name)
}

#[test]
fn example_etc_config_is_valid_and_stays_on_loopback() {
    let cfg = helmwatch::config::Config::from_file(&deploy("helmwatch.toml")).unwrap();
    assert!(!cfg.zenoh.multicast_scouting);
    for e in cfg.zenoh.listen.iter().chain(&cfg.zenoh.connect) {
        assert!(e.starts_with("tcp/127.0.0.1:"), "{e}");
    }
    assert!(
        cfg.daemon.metrics_listen.starts_with("127.0.0.1:"),
        "{}",
        cfg.daemon.metrics_listen
    );
    helmwatch::shells::net::zenoh_config(&cfg.zenoh, &[], &[]).unwrap();
}

#[test]
fn zenoh_router_configs_parse() {
    for name in ["zenoh-router.json5", "zenoh-shore.json5"] {
        let path = deploy(name);
        if let Err(e) = zenoh::Config::from_file(&path) {
            panic!("{name}: {e}");
        }
        let text = std::fs::read_to_string(&path).unwrap();
        assert!(text.contains("enable_mtls: true"), "{name}: mutual TLS");
        assert!(text.contains("multicast: { enabled: false }"), "{name}");
    }
}

#[test]
fn unit_is_notify_with_watchdog_and_config_dir() {
    let unit = std::fs::read_to_string(deploy("helmwatch.service")).unwrap();
    for line in [
        "Type=notify",
        "WatchdogSec=",
        "User=helmwatch",
        "ConfigurationDirectory=helmwatch",
        "RestartPreventExitStatus=78",
        "StateDirectory=helmwatch",
        "ExecStart=/usr/local/bin/helmwatch --config /etc/helmwatch/helmwatch.toml run --state-dir /var/lib/helmwatch",
    ] {
        assert!(unit.lines().any(|l| l.starts_with(line)), "missing {line}");
    }
}

#[test]
fn bridge_unit_is_notify_and_runs_the_bridge_from_the_same_config() {
    let unit = std::fs::read_to_string(deploy("helmwatch-bridge-nmea.service")).unwrap();
    for line in [
        "Type=notify",
        "WatchdogSec=",
        "User=helmwatch",
        "ConfigurationDirectory=helmwatch",
        "RestartPreventExitStatus=78",
        "ExecStart=/usr/local/bin/helmwatch --config /etc/helmwatch/helmwatch.toml bridge nmea",
    ] {
        assert!(unit.lines().any(|l| l.starts_with(line)), "missing {line}");
    }
    // The shipped configuration's [bridge] is valid and talks to Zenoh on loopback only.
    let cfg = helmwatch::config::Config::from_file(&deploy("helmwatch.toml")).unwrap();
    assert!(!cfg.bridge.multicast_scouting);
    for e in cfg.bridge.listen.iter().chain(&cfg.bridge.connect) {
        assert!(e.starts_with("tcp/127.0.0.1:"), "{e}");
    }
}

#[test]
fn standby_example_two_daemons_one_router() {
    let dir = deploy("standby");
    let bridge =
        helmwatch::config::Config::from_file(&dir.join("bridge.toml")).expect("bridge.toml");
    let engine = helmwatch::config::Config::from_file(&dir.join("engine-room.toml"))
        .expect("engine-room.toml");
    assert_eq!(bridge.daemon.vessels, engine.daemon.vessels, "one vessel");
    assert!(
        bridge.daemon.id < engine.daemon.id,
        "the bridge drives first"
    );
    for c in [&bridge, &engine] {
        assert!(!c.zenoh.multicast_scouting);
        assert_eq!(c.zenoh.connect.len(), 1);
        assert!(c.zenoh.listen.is_empty());
        assert!(c.daemon.takeover_s > c.safety.hold_s);
        helmwatch::shells::net::zenoh_config(&c.zenoh, &[], &[]).unwrap();
    }
    assert!(bridge.zenoh.connect[0].starts_with("tcp/127.0.0.1:"));
    let router = dir.join("zenoh-router.json5");
    zenoh::Config::from_file(&router).expect("the router's configuration");
    let text = std::fs::read_to_string(&router).unwrap();
    assert!(text.contains("multicast: { enabled: false }"));
    let port = engine.zenoh.connect[0]
        .rsplit(':')
        .next()
        .unwrap()
        .to_string();
    assert!(
        text.contains(&format!(":{port}\"")),
        "the standby reaches the router"
    );
}
