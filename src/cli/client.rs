//! The daemon's clients over Zenoh: `status`, `trigger`, `history`, `commission`, and `fleet`
//! (every vessel at once, live: [`crate::tools::fleet`]). Each opens a peer session
//! (multicast off) to `--connect`, asks, prints a table (or the JSON with `--json`) and closes
//! the session. Exit codes: 0 answered (a refused trigger included: the refusal is the
//! answer), 64 bad arguments, 69 no answer within `--timeout-s` (no daemon for the vessel).

use super::args::{ClientArgs, CommissionArgs, FleetArgs, HistoryArgs, TriggerArgs};
use super::service::runtime;
use super::Failure;
use crate::config::Config;
use crate::shells::history::{HistoryReply, Kind};
use helmwatch_core::wire::{vessel_key, Keys, TriggerReply};
use std::time::Duration;

fn vessel(cfg: &Config, a: &ClientArgs) -> Result<String, Failure> {
    let v = a
        .vessel
        .clone()
        .or_else(|| cfg.daemon.vessels.first().cloned())
        .unwrap_or_else(|| "self".to_string());
    helmwatch_core::config::check_vessel_name("--vessel", &v).map_err(Failure::usage)?;
    Ok(v)
}

async fn session(a: &ClientArgs) -> Result<zenoh::Session, Failure> {
    for e in &a.connect {
        crate::shells::net::check_endpoint("--connect", e).map_err(Failure::usage)?;
    }
    let zcfg = crate::shells::net::loopback_peer(&[], &a.connect).map_err(Failure::usage)?;
    zenoh::open(zcfg)
        .await
        .map_err(|e| Failure::Unavailable(anyhow::anyhow!("zenoh session: {e}")))
}

fn timeout(a: &ClientArgs) -> Result<Duration, Failure> {
    if a.timeout_s.is_finite() && a.timeout_s > 0.0 && a.timeout_s <= 3600.0 {
        Ok(Duration::from_secs_f64(a.timeout_s))
    } else {
        Err(Failure::Usage(anyhow::anyhow!(
            "--timeout-s: (0, 3600] seconds"
        )))
    }
}

/// One reply's payload for `selector`, or why there is none.
async fn get_one(s: &zenoh::Session, selector: &str, limit: Duration) -> Result<Vec<u8>, Failure> {
    let replies = s
        .get(selector)
        .timeout(limit)
        .await
        .map_err(|e| Failure::Unavailable(anyhow::anyhow!("{selector}: {e}")))?;
    match replies.recv_async().await {
        Ok(reply) => match reply.result() {
            Ok(sample) => Ok(sample.payload().to_bytes().into_owned()),
            Err(e) => Err(Failure::Usage(anyhow::anyhow!(
                "{selector}: {}",
                String::from_utf8_lossy(&e.payload().to_bytes())
            ))),
        },
        Err(_) => Err(Failure::Unavailable(anyhow::anyhow!(
            "{selector}: no answer within {limit:?} (is a daemon monitoring the vessel, with a state directory for the history?)"
        ))),
    }
}

fn block<T>(f: impl std::future::Future<Output = Result<T, Failure>>) -> Result<T, Failure> {
    runtime()?.block_on(f)
}

/// Asks `selector` once over a session of its own and closes it. With `--json` the reply is
/// printed as it came and `None` returned; else it is parsed (`what` names it in errors).
fn ask<T: serde::de::DeserializeOwned>(
    a: &ClientArgs,
    selector: &str,
    what: &str,
) -> Result<Option<T>, Failure> {
    let limit = timeout(a)?;
    let bytes = block(async {
        let s = session(a).await?;
        let bytes = get_one(&s, selector, limit).await;
        let _ = s.close().await;
        bytes
    })?;
    if a.json {
        println!("{}", String::from_utf8_lossy(&bytes));
        return Ok(None);
    }
    serde_json::from_slice(&bytes)
        .map(Some)
        .map_err(|e| Failure::Unavailable(anyhow::anyhow!("{what}: {e}")))
}

/// `helmwatch trigger`.
pub(crate) fn trigger(cfg: &Config, a: TriggerArgs) -> Result<(), Failure> {
    let v = vessel(cfg, &a.client)?;
    let sel = format!("{}?method={}", Keys::new(&v).trigger(), a.method.name());
    if let Some(r) = ask::<TriggerReply>(&a.client, &sel, "trigger reply")? {
        match (r.accepted, r.test, r.reason) {
            (true, Some(t), _) => println!("{v}: test {t} started"),
            (_, _, reason) => println!("{v}: refused: {}", reason.unwrap_or_default()),
        }
    }
    Ok(())
}

/// `helmwatch commission`: prints each method's commissioning; `--start` begins it again.
pub(crate) fn commission(cfg: &Config, a: CommissionArgs) -> Result<(), Failure> {
    let v = vessel(cfg, &a.client)?;
    let mut params = Vec::new();
    if a.start {
        params.push("start".to_string());
        if let Some(m) = a.method {
            params.push(format!("method={}", m.name()));
        }
    }
    let sel = if params.is_empty() {
        Keys::new(&v).commission()
    } else {
        format!("{}?{}", Keys::new(&v).commission(), params.join(";"))
    };
    if let Some(r) = ask::<serde_json::Value>(&a.client, &sel, "commission reply")? {
        if let Some(e) = r["error"].as_str() {
            return Err(Failure::Unavailable(anyhow::anyhow!("{v}: {e}")));
        }
        if a.start {
            println!("{v}: commissioning started");
        }
        println!(
            "{:<6}  {:<14}  {:>5}  {:>4}  {:>7}  {:>14}  {:>16}  {:>15}",
            "method",
            "state",
            "tests",
            "of",
            "learned",
            "speed offset",
            "displacement off",
            "speeds learned"
        );
        for m in ["clfrt", "hbt"] {
            let x = &r[m];
            let f = |k: &str, scale: f64, unit: &str| {
                x["reference"][k]
                    .as_f64()
                    .map_or("-".to_string(), |v| format!("{:+.2}{unit}", v * scale))
            };
            let range = &x["reference"]["speed_range_mps"];
            println!(
                "{:<6}  {:<14}  {:>5}  {:>4}  {:>7}  {:>14}  {:>16}  {:>15}",
                m,
                x["state"].as_str().unwrap_or("?"),
                x["tests"].as_u64().unwrap_or(0),
                x["of"].as_u64().unwrap_or(0),
                x["reference"]["learned"]
                    .as_u64()
                    .map_or("-".to_string(), |v| v.to_string()),
                f("speed_offset_mps", 1.0, " m/s"),
                f("displacement_offset", 100.0, " %"),
                match (range[0].as_f64(), range[1].as_f64()) {
                    (Some(lo), Some(hi)) => format!("{lo:.1}-{hi:.1} m/s"),
                    _ => "-".to_string(),
                },
            );
            if let Some(t) = x["text"].as_str().filter(|t| t.contains("inconsistent")) {
                println!("        {t}");
            }
        }
    }
    Ok(())
}

/// `helmwatch history`.
pub(crate) fn history(cfg: &Config, a: HistoryArgs) -> Result<(), Failure> {
    let v = vessel(cfg, &a.client)?;
    let mut params = vec![format!("limit={}", a.limit)];
    if let Some(f) = a.from {
        params.push(format!("from={f}"));
    }
    if let Some(t) = a.to {
        params.push(format!("to={t}"));
    }
    let sel = format!("{}?{}", Keys::new(&v).history(), params.join(";"));
    if let Some(h) = ask::<HistoryReply>(&a.client, &sel, "history reply")? {
        print_records(&h);
    }
    Ok(())
}

fn print_records(h: &HistoryReply) {
    println!(
        "{:>10}  {:<12}  {:<26}  {:<9}  {:<12}  message",
        "t [s]", "kind", "test", "outcome", "decision"
    );
    for r in &h.records {
        let p = &r.payload;
        let s = |k: &str| p[k].as_str().unwrap_or("-").to_string();
        match r.kind {
            Kind::Report => println!(
                "{:>10.1}  {:<12}  {:<26}  {:<9}  {:<12}  {}",
                r.t,
                "report",
                s("test"),
                s("outcome"),
                s("decision"),
                s("message")
            ),
            Kind::Notification => println!(
                "{:>10.1}  {:<12}  {:<26}  {:<9}  {:<12}  {}",
                r.t,
                "notification",
                "-",
                "-",
                s("state"),
                s("message")
            ),
        }
    }
}

/// What `status` saw of a vessel: its daemons' tokens and the last records of its history.
struct Seen<'a> {
    vessel: &'a str,
    alive: bool,
    holders: Vec<String>,
    standbys: Vec<String>,
    report: Option<serde_json::Value>,
    notification: Option<serde_json::Value>,
    commissioning: Option<serde_json::Value>,
}

impl Seen<'_> {
    /// `status --json`: one object.
    fn json(&self) -> serde_json::Value {
        serde_json::json!({
            "vessel": self.vessel, "alive": self.alive,
            "holders": self.holders, "standbys": self.standbys,
            "alarm": self.notification.as_ref().map_or(serde_json::Value::Null, |n| n["state"].clone()),
            "last_report": self.report, "last_notification": self.notification,
            "commissioning": self.commissioning,
        })
    }

    /// `status` for a person: one line per item.
    fn print(&self) {
        println!("vessel        {}", self.vessel);
        println!(
            "daemon        {}",
            if self.alive {
                "alive"
            } else {
                "NOT alive (no fdi/alive token)"
            }
        );
        let list = |l: &[String]| {
            if l.is_empty() {
                "none".to_string()
            } else {
                l.join(", ")
            }
        };
        println!("holder        {}", list(&self.holders));
        println!("standby       {}", list(&self.standbys));
        match &self.notification {
            Some(n) => println!(
                "alarm state   {} ({})",
                n["state"].as_str().unwrap_or("?"),
                n["message"].as_str().unwrap_or("")
            ),
            None => println!("alarm state   normal (no notification in the history)"),
        }
        if let Some(c) = &self.commissioning {
            let text = |m: &str| c[m]["text"].as_str().unwrap_or("?").to_string();
            println!("reference     CLFRT {}, HBT {}", text("clfrt"), text("hbt"));
        }
        match &self.report {
            Some(r) => println!(
                "last test     {} {} at t = {:.0} s: {}",
                r["test"].as_str().unwrap_or("?"),
                r["outcome"].as_str().unwrap_or("?"),
                r["t_end"].as_f64().unwrap_or(f64::NAN),
                r["message"].as_str().unwrap_or("")
            ),
            None => println!("last test     none in the history"),
        }
    }
}

/// `helmwatch status`.
pub(crate) fn status(cfg: &Config, a: ClientArgs) -> Result<(), Failure> {
    let v = vessel(cfg, &a)?;
    let limit = timeout(&a)?;
    block(async {
        let s = session(&a).await?;
        let keys = Keys::new(&v);
        let alive = match s.liveliness().get(keys.alive()).timeout(limit).await {
            Ok(replies) => replies.recv_async().await.is_ok(),
            Err(_) => false,
        };
        // Which daemon drives the vessel, which stand by (their ownership tokens).
        let ids = |what: &'static str| {
            let s = &s;
            let key = format!("{}/fdi/{what}/*", keys.prefix);
            async move {
                let mut out = Vec::new();
                if let Ok(replies) = s.liveliness().get(key).timeout(limit).await {
                    while let Ok(r) = replies.recv_async().await {
                        if let Ok(sample) = r.result() {
                            let key = sample.key_expr().as_str();
                            if let Some((_, id)) =
                                vessel_key::split(key).and_then(|k| k.fdi_token())
                            {
                                out.push(id.to_string());
                            }
                        }
                    }
                }
                out.sort();
                out.dedup();
                out
            }
        };
        let holders = ids("holder").await;
        let standbys: Vec<String> = ids("candidate")
            .await
            .into_iter()
            .filter(|c| !holders.contains(c))
            .collect();
        let hist = if alive {
            get_one(&s, &format!("{}?limit=50", keys.history()), limit)
                .await
                .ok()
                .and_then(|b| serde_json::from_slice::<HistoryReply>(&b).ok())
        } else {
            None
        };
        let commissioning = if alive {
            get_one(&s, &keys.commission(), limit)
                .await
                .ok()
                .and_then(|b| serde_json::from_slice::<serde_json::Value>(&b).ok())
        } else {
            None
        };
        let _ = s.close().await;
        let last = |kind: Kind| {
            hist.as_ref()
                .and_then(|h| h.records.iter().rev().find(|r| r.kind == kind))
                .map(|r| r.payload.clone())
        };
        let seen = Seen {
            vessel: &v,
            alive,
            holders,
            standbys,
            report: last(Kind::Report),
            notification: last(Kind::Notification),
            commissioning,
        };
        match a.json {
            true => println!("{}", seen.json()),
            false => seen.print(),
        }
        if alive {
            Ok(())
        } else {
            Err(Failure::Unavailable(anyhow::anyhow!(
                "no daemon monitors vessel {v}"
            )))
        }
    })
}

/// `helmwatch fleet`: the table redrawn on every change (cleared first on a terminal), or one
/// JSON object per change; until Ctrl-C or `--duration-s`. Exit 69 when no session opens.
pub(crate) fn fleet(a: FleetArgs) -> Result<(), Failure> {
    use crate::tools::fleet::watch;
    use std::io::{IsTerminal, Write};
    for e in &a.connect {
        crate::shells::net::check_endpoint("--connect", e).map_err(Failure::usage)?;
    }
    let limit = match a.duration_s {
        Some(s) if s.is_finite() && s > 0.0 && s <= 1e7 => Some(Duration::from_secs_f64(s)),
        Some(s) => {
            return Err(Failure::Usage(anyhow::anyhow!(
                "--duration-s: (0, 1e7] seconds, not {s}"
            )))
        }
        None => None,
    };
    let zcfg = crate::shells::net::loopback_peer(&[], &a.connect).map_err(Failure::usage)?;
    let terminal = std::io::stdout().is_terminal();
    let stop = async move {
        match limit {
            Some(d) => {
                tokio::select! {
                    _ = tokio::time::sleep(d) => {}
                    _ = tokio::signal::ctrl_c() => {}
                }
            }
            None => {
                let _ = tokio::signal::ctrl_c().await;
            }
        }
    };
    let json = a.json;
    block(async move {
        watch(zcfg, stop, |view, change| {
            let mut out = std::io::stdout().lock();
            let _ = if json {
                writeln!(out, "{}", view.change_json(change))
            } else if terminal {
                write!(out, "\x1b[2J\x1b[H{}", view.table())
            } else {
                writeln!(out, "{}", view.table())
            };
            let _ = out.flush();
        })
        .await
        .map(|_| ())?;
        Ok(())
    })
}
