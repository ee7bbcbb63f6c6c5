//! A flood cannot erase the record: a daemon recording with the default bounds serves a
//! lockstep ship for 10 ship hours, then every input key is flooded with 20 000 malformed,
//! oversized and out-of-range payloads each. Every recording file of the 10 hours is still
//! there afterwards, and what the flood wrote (the `fdi/rejected` channel) is within the bound
//! src/shells/recording.rs documents for the flood's wall time (its token bucket refills on
//! the wall clock). Waits are bounded; figures are printed. Slow tier (about a minute).
use crate::common::{daemon_config, endpoint, start_daemon, temp_dir};
use helmwatch::shells::net::loopback_peer;
use helmwatch::shells::recording::rejected::{
    REJECTED_BURST, REJECTED_PERIOD_S, REJECTED_RECORD_MAX_BYTES,
};
use helmwatch::shells::shipnode::{ShipNode, ShipNodeOptions};
use helmwatch_core::sim::Scenario;
use helmwatch_core::wire::{Keys, Stream};
use std::collections::BTreeSet;
use std::path::Path;
use std::time::{Duration, Instant};
use tokio_util::sync::CancellationToken;

/// The recording files' stems (a `.part` and its finished `.mcap` are one file) and sizes.
fn files(dir: &Path) -> Vec<(String, u64)> {
    let mut v: Vec<(String, u64)> = std::fs::read_dir(dir)
        .unwrap()
        .filter_map(|e| e.ok())
        .map(|e| {
            let name = e.file_name().to_string_lossy().to_string();
            let stem = name.split(".mcap").next().unwrap().to_string();
            (stem, e.metadata().map(|m| m.len()).unwrap_or(0))
        })
        .collect();
    v.sort();
    v
}

/// Payloads sent on each input key.
const FLOOD_PER_KEY: u64 = 20_000;

#[tokio::test(flavor = "multi_thread")]
#[ignore = "slow tier: cargo test --profile ci -- --ignored"]
async fn a_flood_after_ten_hours_erases_nothing_and_stays_within_its_bound() {
    let dir = temp_dir("flood");
    let ep = endpoint();
    let mut cfg = daemon_config();
    cfg.daemon.state_dir = Some(dir.display().to_string());
    cfg.daemon.record = true;
    let daemon = start_daemon(&cfg, &ep).await;

    // 10 ship hours of service.
    let hours_s = 36_000.0;
    let mut opts = ShipNodeOptions::from_config(&cfg.ship_peer, "self");
    opts.lockstep = true;
    opts.duration_s = Some(hours_s);
    let node = ShipNode::new(&cfg.sim(), &Scenario::nominal(&cfg.sim(), 3), opts).unwrap();
    let stop = CancellationToken::new();
    let s = stop.clone();
    let ship = tokio::spawn(node.run(
        loopback_peer(&[], std::slice::from_ref(&ep)).unwrap(),
        async move { s.cancelled().await },
    ));
    let summary = tokio::time::timeout(Duration::from_secs(1800), ship)
        .await
        .expect("10 ship hours within 30 min")
        .unwrap()
        .unwrap();
    assert!(summary.t_end_s >= hours_s - 1.0, "{summary:?}");
    let rec_dir = dir.join("recordings");
    let before = files(&rec_dir);
    let bytes_before: u64 = before.iter().map(|f| f.1).sum();
    assert!(!before.is_empty());

    // The flood: FLOOD_PER_KEY payloads on every input key.
    let flood = zenoh::open(loopback_peer(&[], std::slice::from_ref(&ep)).unwrap())
        .await
        .unwrap();
    let keys = Keys::new("self");
    let mut pubs = Vec::new();
    for s in Stream::ALL {
        pubs.push(
            flood
                .declare_publisher(keys.stream(s))
                .congestion_control(zenoh::qos::CongestionControl::Drop)
                .await
                .unwrap(),
        );
    }
    let oversized = vec![b'x'; 200_000];
    let started = Instant::now();
    let mut sent = 0u64;
    for _ in 0..FLOOD_PER_KEY {
        for p in &pubs {
            let payload: Vec<u8> = match sent % 4 {
                0 => b"not json {{{".to_vec(),
                1 => oversized.clone(),
                2 => br#"{"t": 1.0, "value": 99.0}"#.to_vec(),
                _ => vec![0x01; 600],
            };
            let _ = p.put(payload).await;
            sent += 1;
        }
        if sent % 600 == 0 {
            tokio::task::yield_now().await;
        }
    }
    for p in pubs {
        p.undeclare().await.unwrap();
    }
    flood.close().await.unwrap();
    let summaries = daemon.stop().await;
    // The bucket may refill until the daemon stopped.
    let flood_s = started.elapsed().as_secs_f64();
    stop.cancel();

    // Every file of the 10 hours is still there.
    let after = files(&rec_dir);
    let stems_after: BTreeSet<&String> = after.iter().map(|f| &f.0).collect();
    for (stem, _) in &before {
        assert!(
            stems_after.contains(stem),
            "{stem} was deleted; after: {after:?}"
        );
    }
    // What the flood wrote: the rejected channel, within its bound for a minute.
    let mut rejected_msgs = 0u64;
    let mut rejected_bytes = 0u64;
    let mut suppressed = 0u64;
    for e in std::fs::read_dir(&rec_dir).unwrap() {
        let path = e.unwrap().path();
        let data = std::fs::read(&path).unwrap();
        for m in mcap::io::MessageReader::new(std::io::Cursor::new(&data[..])).flatten() {
            if m.channel.topic.ends_with("fdi/rejected") {
                rejected_msgs += 1;
                rejected_bytes += m.data.len() as u64;
                let v: serde_json::Value = serde_json::from_slice(&m.data).unwrap();
                suppressed += v["suppressed"].as_u64().unwrap();
                assert!(v["head"].as_str().unwrap().len() <= 256 * 3, "{v}");
            }
        }
    }
    let bytes_after: u64 = after.iter().map(|f| f.1).sum();
    let per_stream = REJECTED_BURST + (flood_s / REJECTED_PERIOD_S).ceil() + 1.0;
    let bound_msgs = (Stream::ALL.len() as f64 * per_stream) as u64;
    println!(
        "flood: {sent} payloads sent in {flood_s:.1} s; recorded {rejected_msgs} rejected records ({rejected_bytes} bytes, {suppressed} suppressed counted in them); recordings {} -> {} bytes in {} -> {} files; daemon stats {}",
        bytes_before,
        bytes_after,
        before.len(),
        after.len(),
        summaries[0].stats["recorded"]
    );
    assert!(rejected_msgs > 0, "the flood is recorded, bounded");
    assert!(
        rejected_msgs <= bound_msgs,
        "{rejected_msgs} rejected records, bound {bound_msgs}"
    );
    assert!(rejected_bytes <= bound_msgs * REJECTED_RECORD_MAX_BYTES);
    // The files grew by the flood's records and the open segment's summary, no more.
    assert!(
        bytes_after <= bytes_before + bound_msgs * REJECTED_RECORD_MAX_BYTES + (1 << 20),
        "{bytes_before} -> {bytes_after}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}
