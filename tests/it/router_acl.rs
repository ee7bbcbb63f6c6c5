//! The shipped Zenoh router configurations, run as real routers over mutual TLS.
//!
//! `deploy/zenoh-router.json5` (on board) and `deploy/zenoh-shore.json5` (ashore) are loaded
//! as shipped; only their endpoints and certificate paths are replaced: loopback ports, and a
//! fleet CA with certificates for `shore.example.org` and a ship, made at test time. The
//! ship's router connects to the shore router over TLS, as at sea. The other sessions are
//! clients: on board (plain TCP on loopback, as the daemon and the autopilot's gateway) and
//! ashore (a client of the shore router, as a dashboard). The daemon's queryables are stood in
//! for by plain queryables on the same keys: access control sees keys and message kinds only.
//!
//! Shown from shore: outputs readable, the trigger answered, every publication and liveliness
//! token under the vessel's keys dropped, commission and history queries refused. From on
//! board: everything allowed. And that the test can fail: without the `shore-no-inject` rule,
//! or with the on-board subject matched on the loopback interface alone, shore's samples and
//! tokens reach the vessel.

use helmwatch::shells::net::{free_loopback_port, loopback, wait_matching, ZenohMode};
use rcgen::{BasicConstraints, CertificateParams, DnType, ExtendedKeyUsagePurpose, IsCa, KeyPair};
use serde_json::Value;
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};
use std::time::Duration;
use zenoh::{Session, Wait};

const VESSEL: &str = "244123456";

/// Every key of the vessel a program on board publishes: the ship's streams, the design
/// displacement, the excitation, the daemon's outputs.
const WRITTEN: [&str; 10] = [
    "navigation/headingTrue",
    "navigation/speedThroughWater",
    "steering/rudderAngle",
    "steering/autopilot/state",
    "steering/autopilot/target/headingTrue",
    "steering/autopilot/excitation",
    "design/displacement",
    "fdi/status",
    "fdi/report",
    "notifications/steering/fdi",
];

/// The daemon's outputs, which shore reads.
const OUTPUTS: [&str; 4] = [
    "fdi/status",
    "fdi/report",
    "fdi/stats",
    "notifications/steering/fdi",
];

/// The daemon's liveliness tokens: its claim on the vessel and its heartbeat.
const TOKENS: [&str; 3] = ["fdi/holder/0", "fdi/candidate/0", "fdi/alive"];

fn key(suffix: &str) -> String {
    format!("vessels/{VESSEL}/{suffix}")
}

/// A fleet CA and, signed by it, the shore router's and the ship's certificates (PEM files).
struct Pki {
    ca: PathBuf,
    shore: (PathBuf, PathBuf),
    ship: (PathBuf, PathBuf),
}

impl Pki {
    fn new(dir: &Path) -> Pki {
        let ca_key = KeyPair::generate().unwrap();
        let mut ca = CertificateParams::new(Vec::<String>::new()).unwrap();
        ca.is_ca = IsCa::Ca(BasicConstraints::Unconstrained);
        ca.distinguished_name.push(DnType::CommonName, "fleet CA");
        let ca_cert = ca.self_signed(&ca_key).unwrap();
        let write = |name: &str, text: String| {
            let p = dir.join(name);
            std::fs::write(&p, text).unwrap();
            p
        };
        let leaf = |name: &str, common_name: &str, sans: Vec<String>| {
            let key = KeyPair::generate().unwrap();
            let mut p = CertificateParams::new(sans).unwrap();
            p.distinguished_name.push(DnType::CommonName, common_name);
            p.extended_key_usages = vec![
                ExtendedKeyUsagePurpose::ServerAuth,
                ExtendedKeyUsagePurpose::ClientAuth,
            ];
            let cert = p.signed_by(&key, &ca_cert, &ca_key).unwrap();
            (
                write(&format!("{name}.pem"), cert.pem()),
                write(&format!("{name}.key"), key.serialize_pem()),
            )
        };
        // The ship's router dials the shore router at 127.0.0.1 and checks the name it dialled.
        let shore = leaf(
            "shore",
            "shore.example.org",
            vec!["shore.example.org".into(), "127.0.0.1".into()],
        );
        let ship = leaf("ship", "ship-244123456.example.org", vec![]);
        Pki {
            ca: write("fleet-ca.pem", ca_cert.pem()),
            shore,
            ship,
        }
    }
}

fn deploy(name: &str) -> zenoh::Config {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("deploy")
        .join(name);
    zenoh::Config::from_file(&path).unwrap()
}

fn set(cfg: &mut zenoh::Config, key: &str, value: impl Into<Value>) {
    cfg.insert_json5(key, &value.into().to_string())
        .unwrap_or_else(|e| panic!("{key}: {e}"));
}

fn path(p: &Path) -> Value {
    Value::from(p.to_str().unwrap())
}

/// A change to the shipped on-board access control, for the cases that show the test fails.
type AclEdit = fn(&mut Value);

/// The shipped configuration, as it is.
fn as_shipped(_: &mut Value) {}

/// The `shore-no-inject` rule removed (from the rules and the shore's policy).
fn without_no_inject(acl: &mut Value) {
    let gone = |v: &Value| v.get("id").and_then(Value::as_str) == Some("shore-no-inject");
    acl["rules"].as_array_mut().unwrap().retain(|r| !gone(r));
    for policy in acl["policies"].as_array_mut().unwrap() {
        let rules = policy["rules"].as_array_mut().unwrap();
        rules.retain(|r| r.as_str() != Some("shore-no-inject"));
    }
}

/// The on-board subject matched on the loopback interface alone (any protocol).
fn on_board_by_interface(acl: &mut Value) {
    for subject in acl["subjects"].as_array_mut().unwrap() {
        if subject["id"] == "on-board" {
            subject.as_object_mut().unwrap().remove("link_protocols");
        }
    }
}

/// The two routers linked over TLS, and a client on each side.
struct Link {
    routers: [Session; 2],
    on_board: Session,
    shore: Session,
    on_board_ep: String,
}

impl Link {
    async fn open(pki: &Pki, edit: AclEdit) -> Link {
        let ep = || format!("127.0.0.1:{}", free_loopback_port().unwrap());
        let (shore_tcp, shore_tls, ship_tcp) = (ep(), ep(), ep());

        let tls = "transport/link/tls";
        let mut shore = deploy("zenoh-shore.json5");
        let listen = serde_json::json!([format!("tcp/{shore_tcp}"), format!("tls/{shore_tls}")]);
        set(&mut shore, "listen/endpoints", listen);
        for (key, file) in [
            ("root_ca_certificate", &pki.ca),
            ("listen_certificate", &pki.shore.0),
            ("listen_private_key", &pki.shore.1),
        ] {
            set(&mut shore, &format!("{tls}/{key}"), path(file));
        }
        let shore_router = zenoh::open(shore).await.unwrap();

        let mut ship = deploy("zenoh-router.json5");
        set(
            &mut ship,
            "listen/endpoints",
            serde_json::json!([format!("tcp/{ship_tcp}")]),
        );
        let connect = serde_json::json!([format!("tls/{shore_tls}")]);
        set(&mut ship, "connect/endpoints", connect);
        for (key, file) in [
            ("root_ca_certificate", &pki.ca),
            ("connect_certificate", &pki.ship.0),
            ("connect_private_key", &pki.ship.1),
        ] {
            set(&mut ship, &format!("{tls}/{key}"), path(file));
        }
        let mut acl: Value =
            serde_json::from_str(&ship.get_json("access_control").unwrap()).unwrap();
        edit(&mut acl);
        set(&mut ship, "access_control", acl);
        let ship_router = zenoh::open(ship).await.unwrap();

        let client = |ep: &str| loopback(ZenohMode::Client, &[], &[format!("tcp/{ep}")]).unwrap();
        let on_board = zenoh::open(client(&ship_tcp)).await.unwrap();
        let shore_client = zenoh::open(client(&shore_tcp)).await.unwrap();
        Link {
            routers: [ship_router, shore_router],
            on_board,
            shore: shore_client,
            on_board_ep: format!("tcp/{ship_tcp}"),
        }
    }

    async fn close(self) {
        self.shore.close().await.unwrap();
        self.on_board.close().await.unwrap();
        for r in self.routers {
            r.close().await.unwrap();
        }
    }
}

/// What a session heard: sample keys, liveliness tokens and queries, in arrival order.
#[derive(Default, Clone)]
struct Heard(Arc<Mutex<Vec<String>>>);

impl Heard {
    fn push(&self, what: String) {
        self.0.lock().unwrap().push(what);
    }
    fn all(&self) -> Vec<String> {
        self.0.lock().unwrap().clone()
    }
}

/// On board, as the daemon and the autopilot's gateway: a subscriber on each key written on
/// board, a liveliness subscriber on the daemon's keys, queryables on trigger, commission and
/// history (each answers `{"ok": true}`). The heading's subscriber is declared last.
struct Listener {
    heard: Heard,
    _subs: Vec<zenoh::pubsub::Subscriber<()>>,
    _queryables: Vec<zenoh::query::Queryable<()>>,
}

impl Listener {
    async fn on(session: &Session) -> Listener {
        let heard = Heard::default();
        let mut subs = Vec::new();
        let mut written = WRITTEN.to_vec();
        written.reverse();
        for k in written {
            let h = heard.clone();
            let sub = session
                .declare_subscriber(key(k))
                .callback(move |s| h.push(format!("put {}", s.key_expr())))
                .await
                .unwrap();
            subs.push(sub);
        }
        let h = heard.clone();
        let tokens = session
            .liveliness()
            .declare_subscriber(key("fdi/**"))
            .callback(move |s| h.push(format!("token {}", s.key_expr())))
            .await
            .unwrap();
        subs.insert(0, tokens);
        let mut queryables = Vec::new();
        for k in ["fdi/trigger", "fdi/commission", "fdi/history"] {
            let h = heard.clone();
            let q = session
                .declare_queryable(key(k))
                .callback(move |q| {
                    h.push(format!("query {}", q.key_expr()));
                    q.reply(q.key_expr().clone(), r#"{"ok": true}"#)
                        .wait()
                        .unwrap();
                })
                .await
                .unwrap();
            queryables.push(q);
        }
        Listener {
            heard,
            _subs: subs,
            _queryables: queryables,
        }
    }
}

/// Asks `suffix` once from `session`; the replies' payloads (an error reply as `error`).
async fn ask(session: &Session, suffix: &str) -> Vec<String> {
    let replies = session
        .get(key(suffix))
        .timeout(Duration::from_secs(2))
        .await
        .unwrap();
    let mut out = Vec::new();
    while let Ok(reply) = replies.recv_async().await {
        out.push(match reply.result() {
            Ok(s) => String::from_utf8_lossy(&s.payload().to_bytes()).into_owned(),
            Err(_) => "error".into(),
        });
    }
    out
}

/// From `writer`: a sample on every key written on board, the daemon's liveliness tokens,
/// then (the barrier: same route, same priority, so it arrives after them) the trigger's query.
/// Returns what `listener` heard meanwhile, apart from the barrier's query.
async fn write_everything(writer: &Session, listener: &Listener) -> Vec<String> {
    // The on-board heading subscriber, declared last, is known at the writer's end.
    let probe = writer
        .declare_publisher(key("navigation/headingTrue"))
        .await
        .unwrap();
    assert!(
        wait_matching(&probe, Duration::from_secs(10)).await,
        "the writer never learnt of the subscribers on board"
    );
    probe.undeclare().await.unwrap();
    let mut tokens = Vec::new();
    for k in TOKENS {
        tokens.push(writer.liveliness().declare_token(key(k)).await.unwrap());
    }
    for k in WRITTEN {
        writer
            .put(key(k), r#"{"t": 1.0, "value": 0.1}"#)
            .await
            .unwrap();
    }
    assert_eq!(
        ask(writer, "fdi/trigger").await,
        [r#"{"ok": true}"#],
        "the barrier"
    );
    for t in tokens {
        t.undeclare().await.unwrap();
    }
    let barrier = format!("query {}", key("fdi/trigger"));
    listener
        .heard
        .all()
        .into_iter()
        .filter(|h| *h != barrier)
        .collect()
}

/// Shore, through the shipped configuration: reads the outputs and the streams, gets the
/// trigger's answer, and can write nothing, nor reach commission or history.
#[tokio::test(flavor = "multi_thread")]
async fn the_shipped_router_lets_shore_read_and_trigger_and_nothing_else() {
    let dir = crate::common::temp_dir("router-acl");
    let pki = Pki::new(&dir);
    let link = Link::open(&pki, as_shipped).await;

    // Outputs and streams readable from shore.
    let read = Heard::default();
    let mut subs = Vec::new();
    let mut readable: Vec<&str> = OUTPUTS.to_vec();
    readable.extend(["navigation/headingTrue", "steering/rudderAngle"]);
    for k in &readable {
        let h = read.clone();
        let sub = link
            .shore
            .declare_subscriber(key(k))
            .callback(move |s| h.push(s.key_expr().to_string()))
            .await
            .unwrap();
        subs.push(sub);
    }
    for k in &readable {
        let publisher = link.on_board.declare_publisher(key(k)).await.unwrap();
        assert!(
            wait_matching(&publisher, Duration::from_secs(10)).await,
            "shore's subscriber on {k} never reached the ship"
        );
        publisher.put(r#"{"t": 1.0}"#).await.unwrap();
        publisher.undeclare().await.unwrap();
    }
    let want: BTreeSet<String> = readable.iter().map(|k| key(k)).collect();
    let deadline = tokio::time::Instant::now() + Duration::from_secs(10);
    while read.all().into_iter().collect::<BTreeSet<_>>() != want {
        assert!(
            tokio::time::Instant::now() < deadline,
            "shore read {:?}",
            read.all()
        );
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
    // The daemon's tokens are visible ashore (a fleet view's "alive").
    let token = link
        .on_board
        .liveliness()
        .declare_token(key("fdi/alive"))
        .await
        .unwrap();
    let deadline = tokio::time::Instant::now() + Duration::from_secs(10);
    loop {
        let replies = link.shore.liveliness().get(key("fdi/alive")).await.unwrap();
        if replies.recv_async().await.is_ok() {
            break;
        }
        assert!(
            tokio::time::Instant::now() < deadline,
            "shore never saw fdi/alive"
        );
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
    token.undeclare().await.unwrap();
    for s in subs {
        s.undeclare().await.unwrap();
    }

    // Nothing written from shore reaches the vessel; the trigger is answered (the barrier).
    let listener = Listener::on(&link.on_board).await;
    let leaked = write_everything(&link.shore, &listener).await;
    assert!(leaked.is_empty(), "shore reached the vessel: {leaked:?}");
    // Commission and history are refused.
    for k in ["fdi/commission", "fdi/history"] {
        assert!(
            ask(&link.shore, k).await.is_empty(),
            "shore got an answer on {k}"
        );
    }
    let queried: Vec<String> = listener.heard.all();
    assert_eq!(
        queried,
        [format!("query {}", key("fdi/trigger"))],
        "on board heard"
    );

    // On board, everything is allowed: a second program writes every key and token, and asks
    // commission and history.
    let other = zenoh::open(
        loopback(
            ZenohMode::Client,
            &[],
            std::slice::from_ref(&link.on_board_ep),
        )
        .unwrap(),
    )
    .await
    .unwrap();
    let heard = write_everything(&other, &listener).await;
    for (kind, suffixes) in [("put ", &WRITTEN[..]), ("token ", &TOKENS[..])] {
        let got: BTreeSet<&str> = heard.iter().filter_map(|h| h.strip_prefix(kind)).collect();
        let want: BTreeSet<String> = suffixes.iter().map(|k| key(k)).collect();
        assert_eq!(got, want.iter().map(String::as_str).collect(), "{kind}");
    }
    for k in ["fdi/commission", "fdi/history"] {
        assert_eq!(
            ask(&other, k).await,
            [r#"{"ok": true}"#],
            "on board asks {k}"
        );
    }
    other.close().await.unwrap();
    link.close().await;
    let _ = std::fs::remove_dir_all(&dir);
}

/// The test above fails where the guard is weakened: shore's samples and tokens reach the
/// vessel without `shore-no-inject`, and with the on-board subject matched on the loopback
/// interface alone (a TLS link arriving on loopback is then on board, and any allow wins).
#[tokio::test(flavor = "multi_thread")]
async fn shore_injects_when_the_guard_is_weakened() {
    let dir = crate::common::temp_dir("router-acl-weak");
    let pki = Pki::new(&dir);
    for (name, edit) in [
        ("without shore-no-inject", without_no_inject as AclEdit),
        (
            "on board by interface alone",
            on_board_by_interface as AclEdit,
        ),
    ] {
        let link = Link::open(&pki, edit).await;
        let listener = Listener::on(&link.on_board).await;
        let leaked = write_everything(&link.shore, &listener).await;
        let has = |what: &str| leaked.iter().any(|h| h == what);
        // shore-read allows put on the outputs and streams, both ways: without the deny, they
        // come in; by interface alone, everything does.
        assert!(
            has(&format!("put {}", key("navigation/headingTrue"))),
            "{name}: {leaked:?}"
        );
        assert!(
            has(&format!("put {}", key("fdi/report"))),
            "{name}: {leaked:?}"
        );
        assert!(
            has(&format!("token {}", key("fdi/holder/0"))),
            "{name}: {leaked:?}"
        );
        link.close().await;
    }
    let _ = std::fs::remove_dir_all(&dir);
}
