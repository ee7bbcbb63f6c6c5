//! `helmwatch fleet` over a Zenoh router on loopback (in-process, a free port, multicast
//! off): three daemons (one vessel each) and their lockstep ships connect to the router as its
//! clients; the
//! fleet view, started after the first daemon (its liveliness history must show it), sees all
//! three alive, sees their states change after a trigger, and sees one gone when its daemon
//! stops. Every wait is bounded and polls for an event; no timing is asserted.

use crate::common::{daemon_config, endpoint};
use helmwatch::config::Config;
use helmwatch::shells::daemon::Daemon;
use helmwatch::shells::net::{loopback, ZenohMode};
use helmwatch::shells::shipnode::{ShipNode, ShipNodeOptions};
use helmwatch_core::sim::Scenario;
use serde_json::Value;
use std::sync::{Arc, Mutex};
use std::time::Duration;
use tokio_util::sync::CancellationToken;

const LIMIT: Duration = Duration::from_secs(120);

/// A session of `mode` on loopback, multicast off, listening on `listen` or connecting to
/// `connect`.
fn zcfg(mode: ZenohMode, listen: &[String], connect: &[String]) -> zenoh::Config {
    loopback(mode, listen, connect).unwrap()
}

/// A client of the router.
fn client(router: &str) -> zenoh::Config {
    zcfg(ZenohMode::Client, &[], &[router.to_string()])
}

/// Asks `vessel`'s daemon for an HBT test until it is accepted.
async fn trigger(s: &zenoh::Session, vessel: &str) {
    let key = format!("vessels/{vessel}/fdi/trigger?method=hbt");
    for _ in 0..600 {
        if let Ok(replies) = s.get(&key).timeout(Duration::from_secs(5)).await {
            if let Ok(reply) = replies.recv_async().await {
                if let Ok(sample) = reply.into_result() {
                    let v: Value = serde_json::from_slice(&sample.payload().to_bytes()).unwrap();
                    if v["accepted"] == true {
                        return;
                    }
                }
            }
        }
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
    panic!("{vessel}: the trigger was never accepted");
}

struct Vessel {
    daemon: Daemon,
    ship_stop: CancellationToken,
    ship: tokio::task::JoinHandle<
        Result<
            helmwatch::shells::shipnode::ShipSummary,
            helmwatch::shells::shipnode::ShipNodeError,
        >,
    >,
}

async fn vessel(cfg: &Config, name: &str, router: &str, seed: u64) -> Vessel {
    let mut cfg = cfg.clone();
    cfg.daemon.vessels = vec![name.to_string()];
    let daemon = Daemon::start(&cfg.core(), &cfg.daemon, client(router))
        .await
        .unwrap();
    let mut opts = ShipNodeOptions::from_config(&cfg.ship_peer, name);
    opts.lockstep = true;
    let node = ShipNode::new(&cfg.sim(), &Scenario::nominal(&cfg.sim(), seed), opts).unwrap();
    let ship_stop = CancellationToken::new();
    let s = ship_stop.clone();
    let ship = tokio::spawn(node.run(client(router), async move { s.cancelled().await }));
    Vessel {
        daemon,
        ship_stop,
        ship,
    }
}

impl Vessel {
    async fn stop(self) {
        self.daemon.stop().await;
        self.ship_stop.cancel();
        let _ = self.ship.await;
    }
}

/// Waits (bounded) until a change line satisfies `pred`.
async fn wait_change(seen: &Mutex<Vec<Value>>, what: &str, pred: impl Fn(&Value) -> bool) {
    let deadline = tokio::time::Instant::now() + LIMIT;
    loop {
        if seen.lock().unwrap().iter().any(&pred) {
            return;
        }
        assert!(
            tokio::time::Instant::now() < deadline,
            "no change: {what}; seen {:?}",
            seen.lock()
                .unwrap()
                .iter()
                .rev()
                .take(10)
                .collect::<Vec<_>>()
        );
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
}

#[tokio::test(flavor = "multi_thread")]
async fn fleet_view_sees_vessels_alive_busy_and_gone() {
    let router_ep = endpoint();
    let router = zenoh::open(zcfg(
        ZenohMode::Router,
        std::slice::from_ref(&router_ep),
        &[],
    ))
    .await
    .unwrap();
    let mut cfg = daemon_config();
    cfg.scheduler.enabled = false;
    let names = ["alpha", "bravo", "charlie"];

    // The first vessel is alive before the view starts.
    let first = vessel(&cfg, names[0], &router_ep, 1).await;
    let seen: Arc<Mutex<Vec<Value>>> = Arc::default();
    let stop = CancellationToken::new();
    let view = {
        let (seen, stop) = (seen.clone(), stop.clone());
        tokio::spawn(helmwatch::tools::fleet::watch(
            client(&router_ep),
            async move { stop.cancelled().await },
            move |view, change| seen.lock().unwrap().push(view.change_json(change)),
        ))
    };
    let alive = |v: &'static str| move |c: &Value| c["vessel"] == v && c["presence"] == "alive";
    wait_change(&seen, "alpha alive (history)", alive("alpha")).await;
    let mut vessels = vec![first];
    for (i, name) in names.iter().enumerate().skip(1) {
        vessels.push(vessel(&cfg, name, &router_ep, 1 + i as u64).await);
    }
    wait_change(&seen, "bravo alive", alive("bravo")).await;
    wait_change(&seen, "charlie alive", alive("charlie")).await;

    // A trigger each: their states leave idle.
    let asker = zenoh::open(client(&router_ep)).await.unwrap();
    for name in names {
        trigger(&asker, name).await;
    }
    for name in names {
        wait_change(&seen, &format!("{name} busy"), |c| {
            c["vessel"] == name
                && c["change"] == "status"
                && (c["state"] == "settling" || c["state"] == "exciting")
        })
        .await;
    }

    // Bravo's daemon stops: gone; the others stay alive.
    let bravo = vessels.remove(1);
    bravo.stop().await;
    wait_change(&seen, "bravo gone", |c| {
        c["vessel"] == "bravo" && c["change"] == "gone" && c["presence"] == "gone"
    })
    .await;
    {
        let lines = seen.lock().unwrap();
        for name in ["alpha", "charlie"] {
            let last = lines.iter().rev().find(|c| c["vessel"] == name).unwrap();
            assert_eq!(last["presence"], "alive", "{last}");
        }
        // Only our three vessels, each seen alive exactly once (no flapping).
        for c in lines.iter() {
            assert!(names.contains(&c["vessel"].as_str().unwrap()), "{c}");
        }
        for name in names {
            let n = lines
                .iter()
                .filter(|c| c["vessel"] == name && c["change"] == "alive")
                .count();
            assert_eq!(n, 1, "{name}");
        }
    }

    stop.cancel();
    let table = view.await.unwrap().unwrap();
    assert_eq!(table.rows().len(), 3);
    assert!(table.table().contains("GONE"), "{}", table.table());
    asker.close().await.unwrap();
    for v in vessels {
        v.stop().await;
    }
    router.close().await.unwrap();
}
