//! The daemon's MCAP recording (`[daemon] record`): a daemon with a fresh state directory
//! records while a lockstep simulated ship runs over Zenoh on loopback until the scheduler has
//! completed two tests; after a clean stop the file is read back with the `mcap` crate's
//! reader: every channel present with its schema, the message counts those the daemon says it
//! wrote and those of the file's summary statistics, the reports those heard live over Zenoh;
//! and a replay of the file through the monitor core gives the live reports again.

use crate::common::{daemon_config, endpoint, start_daemon, temp_dir, Observer};
use helmwatch::shells::net::loopback_peer;
use helmwatch::shells::shipnode::{ShipNode, ShipNodeOptions};
use helmwatch_core::monitor::Output;
use helmwatch_core::sim::Scenario;
use serde_json::Value;
use std::collections::BTreeMap;
use std::time::Duration;
use tokio_util::sync::CancellationToken;

const LIMIT: Duration = Duration::from_secs(300);

#[tokio::test(flavor = "multi_thread")]
async fn the_recording_holds_what_the_daemon_saw_and_replays_to_the_same_reports() {
    let dir = temp_dir("mcap");
    let ep = endpoint();
    let mut cfg = daemon_config();
    // Scheduled tests only (a trigger is not in the recording: replay could not repeat it).
    cfg.scheduler.enabled = true;
    cfg.scheduler.interval_s = 60.0;
    cfg.scheduler.steady_time_s = 60.0;
    cfg.daemon.state_dir = Some(dir.join("state").display().to_string());
    cfg.daemon.record = true;
    // One segment holds the whole run (rotation is unit-tested in shells::recording).
    cfg.daemon.recordings_segment_mb = 1024;

    let daemon = start_daemon(&cfg, &ep).await;
    let obs = Observer::new(&ep, "self", false).await;
    // The ship's clock is UNIX time, as in service.
    let t0 = 1.7e9;
    let mut sim = cfg.sim();
    sim.simulation.start_time_s = t0;
    let mut opts = ShipNodeOptions::from_config(&cfg.ship_peer, &cfg.simulation.vessel);
    opts.lockstep = true;
    let node = ShipNode::new(&sim, &Scenario::nominal(&sim, 7), opts).unwrap();
    let stop_ship = CancellationToken::new();
    let s = stop_ship.clone();
    let zcfg = loopback_peer(&[], std::slice::from_ref(&ep)).unwrap();
    let ship = tokio::spawn(node.run(zcfg, async move { s.cancelled().await }));

    // Two completed tests, heard over Zenoh.
    let deadline = tokio::time::Instant::now() + LIMIT;
    while obs
        .on("fdi/report")
        .iter()
        .filter(|r| r["outcome"] == "completed")
        .count()
        < 2
    {
        assert!(
            tokio::time::Instant::now() < deadline,
            "no two completed tests: {:?}",
            obs.on("fdi/report")
        );
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
    // Stop the daemon while the ship still publishes (no silence abort), then the ship.
    let summaries = daemon.stop().await;
    stop_ship.cancel();
    ship.await.unwrap().unwrap();
    // The final idle status (published last at shutdown) has arrived: nothing more is coming.
    obs.wait_for("fdi/status", LIMIT, |s| {
        s["reason"]
            .as_str()
            .is_some_and(|r| r.contains("daemon stopping"))
    })
    .await;
    let live: Vec<Value> = obs.on("fdi/report");
    obs.close().await;
    assert!(live.len() >= 2, "{live:?}");

    // What the daemon says it recorded.
    assert_eq!(summaries.len(), 1);
    let recorded = &summaries[0].stats["recorded"];
    assert_eq!(recorded["errors"], 0, "{recorded}");
    let said: BTreeMap<String, u64> = recorded["messages"]
        .as_object()
        .unwrap()
        .iter()
        .map(|(k, v)| (k.clone(), v.as_u64().unwrap()))
        .collect();

    // The files: finished (no `.part`), read with the mcap crate.
    let rec_dir = dir.join("state").join("recordings");
    let mut files: Vec<_> = std::fs::read_dir(&rec_dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    files.sort();
    assert_eq!(files.len(), 1, "{files:?}");
    assert!(
        files
            .iter()
            .all(|f| f.extension().is_some_and(|e| e == "mcap")),
        "{files:?}"
    );
    let mut summary_counts: BTreeMap<String, u64> = BTreeMap::new();
    let mut read_counts: BTreeMap<String, u64> = BTreeMap::new();
    let mut file_reports = Vec::new();
    let mut schemas: BTreeMap<String, (String, String, String)> = BTreeMap::new();
    let mut heading_times = Vec::new();
    let mut analysis_points = 0u64;
    // Raw series `(t, value)` from the recorded messages, to check the analysis records.
    let mut raw: BTreeMap<&str, Vec<(f64, f64)>> = BTreeMap::new();
    let mut analysis = Vec::new();
    for f in &files {
        let bytes = std::fs::read(f).unwrap();
        let summary = mcap::read::Summary::read(&bytes)
            .unwrap()
            .expect("a summary");
        let stats = summary.stats.clone().unwrap();
        for (id, n) in &stats.channel_message_counts {
            let topic = summary.channels[id].topic.clone();
            *summary_counts.entry(topic).or_default() += n;
        }
        for m in mcap::io::MessageReader::new(std::io::Cursor::new(&bytes)) {
            let m = m.unwrap();
            let topic = m.channel.topic.clone();
            *read_counts.entry(topic.clone()).or_default() += 1;
            let schema = m.channel.schema.as_ref().expect("a schema per channel");
            schemas.insert(
                topic.clone(),
                (
                    m.channel.message_encoding.clone(),
                    schema.encoding.clone(),
                    String::from_utf8(schema.data.to_vec()).unwrap(),
                ),
            );
            assert_eq!(m.log_time, m.publish_time);
            let v: Value = serde_json::from_slice(&m.data).unwrap();
            if topic.ends_with("fdi/report") {
                assert_eq!(
                    m.log_time,
                    (v["t_end"].as_f64().unwrap() * 1e9).round() as u64
                );
                file_reports.push(v.clone());
            } else if topic.ends_with("navigation/headingTrue") {
                let t = v["t"].as_f64().unwrap();
                assert_eq!(m.log_time, (t * 1e9).round() as u64);
                heading_times.push(t);
            } else if topic.ends_with("fdi/analysis") {
                analysis_points += 1;
                assert_eq!(m.log_time, (v["t"].as_f64().unwrap() * 1e9).round() as u64);
                analysis.push(v.clone());
            }
            for (end, name) in [
                ("navigation/headingTrue", "heading"),
                ("steering/rudderAngle", "rudder"),
                ("autopilot/excitation", "excitation"),
            ] {
                if topic.ends_with(end) {
                    let p = (v["t"].as_f64().unwrap(), v["value"].as_f64().unwrap());
                    raw.entry(name).or_default().push(p);
                }
            }
        }
    }
    // Every channel: the five required input streams, the outputs, the analysis records.
    let expected = [
        "vessels/self/navigation/headingTrue",
        "vessels/self/steering/rudderAngle",
        "vessels/self/navigation/speedThroughWater",
        "vessels/self/steering/autopilot/state",
        "vessels/self/steering/autopilot/target/headingTrue",
        "vessels/self/steering/autopilot/excitation",
        "vessels/self/fdi/status",
        "vessels/self/fdi/report",
        "vessels/self/fdi/analysis",
    ];
    for topic in expected {
        assert!(
            said.get(topic).is_some_and(|&n| n > 0),
            "{topic} missing: {said:?}"
        );
        let (enc, schema_enc, schema) = &schemas[topic];
        assert_eq!(enc, "json");
        assert_eq!(schema_enc, "jsonschema");
        let s: Value = serde_json::from_str(schema).unwrap();
        assert_eq!(s["type"], "object", "{topic}: {s}");
        assert!(s["properties"].as_object().is_some_and(|p| !p.is_empty()));
    }
    assert!(schemas["vessels/self/navigation/headingTrue"]
        .2
        .contains("\"value\""));
    // The counts three ways: the daemon's, the summary statistics', the messages read.
    assert_eq!(said, summary_counts);
    assert_eq!(said, read_counts);
    // One excitation per heading (lockstep), heading times in order and in the ship's clock.
    assert_eq!(
        said["vessels/self/steering/autopilot/excitation"],
        said["vessels/self/navigation/headingTrue"] + 1, // + the `none` at shutdown
    );
    assert!(heading_times.windows(2).all(|w| w[0] < w[1]));
    let bytes: u64 = files
        .iter()
        .map(|f| std::fs::metadata(f).unwrap().len())
        .sum();
    let hours = (heading_times[heading_times.len() - 1] - heading_times[0]) / 3600.0;
    println!(
        "recorded {bytes} bytes over {hours:.2} ship hours: {:.1} MiB per hour",
        bytes as f64 / hours / (1 << 20) as f64
    );
    assert!(heading_times[0] >= t0 && heading_times[0] < t0 + 60.0);
    // The analysis records: one grid point per 0.1 s of each completed test's analysis
    // (CLFRT: 2 windows of 600 s, 12000 points; HBT: a few relay periods).
    let completed: Vec<&Value> = live
        .iter()
        .filter(|r| r["outcome"] == "completed")
        .collect();
    let clfrt = completed.iter().filter(|r| r["method"] == "clfrt").count() as u64;
    assert!(analysis_points >= clfrt * 12_000 + 100, "{analysis_points}");
    assert!(
        analysis_points <= completed.len() as u64 * 12_000,
        "{analysis_points}"
    );

    // Each analysis point against the raw samples recorded around its time: heading and
    // rudder linearly interpolated here (the heading across 0 / 2 pi by its wrapped step;
    // past the last sample, its value held); the excitation the one published at or just
    // before it (HBT: held relay) or within a rate-limited step of it (CLFRT: the multisine).
    let wrap = |x: f64| {
        (x + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU) - std::f64::consts::PI
    };
    let interp = |name: &str, t: f64, angle: bool| -> f64 {
        let s = &raw[name];
        let i = s.partition_point(|p| p.0 <= t + 1e-9);
        let a = s[i - 1];
        match s.get(i) {
            Some(&b) => {
                let step = if angle { wrap(b.1 - a.1) } else { b.1 - a.1 };
                a.1 + (t - a.0) / (b.0 - a.0) * step
            }
            None => a.1,
        }
    };
    for v in &analysis {
        let t = v["t"].as_f64().unwrap();
        let dh = wrap(v["heading"].as_f64().unwrap() - interp("heading", t, true));
        assert!(dh.abs() < 1e-6, "heading off by {dh}: {v}");
        let dd = v["rudder"].as_f64().unwrap() - interp("rudder", t, false);
        assert!(dd.abs() < 1e-6, "rudder off by {dd}: {v}");
        let e = v["excitation"].as_f64().unwrap();
        let s = &raw["excitation"];
        let held = s[s.partition_point(|p| p.0 <= t + 1e-6) - 1].1;
        let tol = if v["method"] == "hbt" { 1e-12 } else { 5e-3 };
        assert!((e - held).abs() <= tol, "excitation {e} vs {held}: {v}");
    }

    // The reports in the file are the reports heard live.
    assert_eq!(file_reports, live);

    // Replay of the recording: the same reports (those the shutdown did not cut short).
    let cfgc = cfg.core();
    let mut replayed = Vec::new();
    for f in &files {
        let reader = std::io::BufReader::new(std::fs::File::open(f).unwrap());
        helmwatch::shells::recording::replay::replay_mcap(&cfgc, &[], reader, |_, out| {
            if let Output::Report(r) = out {
                replayed.push(serde_json::to_value(r).unwrap());
            }
        })
        .unwrap();
    }
    let expected: Vec<Value> = live
        .iter()
        .filter(|r| {
            !r["reason"]
                .as_str()
                .is_some_and(|x| x.contains("daemon stopping"))
        })
        .cloned()
        .collect();
    assert!(expected.len() >= 2);
    assert_eq!(replayed, expected);
    std::fs::remove_dir_all(&dir).unwrap();
}
