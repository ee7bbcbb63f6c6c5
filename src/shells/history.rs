//! The report history: every report and notification of every vessel the daemon monitors, in
//! an embedded SQLite database in the state directory (`<dir>/history.sqlite`, WAL journal,
//! `synchronous = FULL`), written before it is published, so that what a subscriber saw is on
//! disk. Retention is bounded by age (`daemon.history-days`) and by size
//! (`daemon.history-max-records`), pruned as records are added.
//!
//! Queried over Zenoh on `vessels/<v>/fdi/history`, parameters `from` and `to` (ship time,
//! inclusive, seconds) and `limit` (the latest `limit` records of the range, default 100, at
//! most 10000); the reply is `{"vessel", "records": [{"kind", "t", "written_unix_s",
//! "payload"}]}`, oldest first (docs/contract.md).
//!
//! A database that cannot be opened or fails SQLite's quick check is moved aside to
//! `history.sqlite.corrupt` with a message naming it, and a fresh one is started.

use helmwatch_core::wire::Keys;
use rusqlite::{params, Connection, OptionalExtension};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

/// Why the history cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum HistoryError {
    /// SQLite refused.
    #[error("history database {path}: {source}")]
    Sqlite {
        /// The file.
        path: String,
        /// What SQLite said.
        source: rusqlite::Error,
    },
    /// A record cannot be encoded.
    #[error("history record: {0}")]
    Encode(String),
}

/// What a record is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Kind {
    /// An `fdi/report` payload.
    Report,
    /// A `notifications/steering/fdi` payload.
    Notification,
}

impl Kind {
    fn name(self) -> &'static str {
        match self {
            Kind::Report => "report",
            Kind::Notification => "notification",
        }
    }
}

/// One record, as a query returns it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Record {
    /// Report or notification.
    pub kind: Kind,
    /// Ship time: the report's `t_end`, or the time of the test that raised the notification
    /// [s].
    pub t: f64,
    /// When it was written (wall clock, Unix seconds).
    pub written_unix_s: f64,
    /// The payload as published.
    pub payload: serde_json::Value,
}

/// The reply of `fdi/history`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct HistoryReply {
    /// The vessel.
    pub vessel: String,
    /// The records, oldest first.
    pub records: Vec<Record>,
}

/// A query of the history.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Range {
    /// From this ship time on [s] (inclusive).
    pub from_t: f64,
    /// Up to this ship time [s] (inclusive).
    pub to_t: f64,
    /// The latest this many records of the range.
    pub limit: usize,
}

impl Default for Range {
    fn default() -> Self {
        Self {
            from_t: f64::NEG_INFINITY,
            to_t: f64::INFINITY,
            limit: 100,
        }
    }
}

/// Most records one query returns.
pub const MAX_LIMIT: usize = 10_000;

impl Range {
    /// From Zenoh query parameters `from`, `to`, `limit` (each optional).
    pub fn from_params(get: impl Fn(&str) -> Option<String>) -> Result<Range, String> {
        let mut r = Range::default();
        let num = |k: &str| -> Result<Option<f64>, String> {
            match get(k) {
                None => Ok(None),
                Some(v) => v
                    .parse::<f64>()
                    .ok()
                    .filter(|x| !x.is_nan())
                    .map(Some)
                    .ok_or_else(|| format!("parameter {k}={v} is not a number")),
            }
        };
        if let Some(x) = num("from")? {
            r.from_t = x;
        }
        if let Some(x) = num("to")? {
            r.to_t = x;
        }
        if let Some(v) = get("limit") {
            r.limit = v
                .parse::<usize>()
                .ok()
                .filter(|&n| (1..=MAX_LIMIT).contains(&n))
                .ok_or_else(|| {
                    format!("parameter limit={v}: a whole number in [1, {MAX_LIMIT}]")
                })?;
        }
        Ok(r)
    }
}

/// The history database.
#[derive(Debug)]
pub struct History {
    conn: Mutex<Connection>,
    path: PathBuf,
    max_age_s: f64,
    max_records: u64,
}

fn sqlite(path: &Path) -> impl FnOnce(rusqlite::Error) -> HistoryError + '_ {
    move |source| HistoryError::Sqlite {
        path: path.display().to_string(),
        source,
    }
}

fn now_unix_s() -> f64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0.0, |d| d.as_secs_f64())
}

impl History {
    /// Opens (creating it) `<dir>/history.sqlite`, keeping records for `max_age_days` and at
    /// most `max_records`. Returns the history and, when the old file was unusable, the
    /// message saying it was moved aside.
    pub fn open(
        dir: &Path,
        max_age_days: f64,
        max_records: u64,
    ) -> Result<(History, Option<String>), HistoryError> {
        let path = dir.join("history.sqlite");
        let mut note = None;
        let conn = match Self::connect(&path) {
            Ok(c) => c,
            Err(e) => {
                let aside = dir.join("history.sqlite.corrupt");
                let moved = match std::fs::rename(&path, &aside) {
                    Ok(()) => format!("moved to {}", aside.display()),
                    Err(m) => format!("could not be moved aside: {m}"),
                };
                for ext in ["sqlite-wal", "sqlite-shm"] {
                    let _ = std::fs::remove_file(dir.join(format!("history.{ext}")));
                }
                note = Some(format!(
                    "history database {} is unusable ({e}); {moved}; a fresh history starts",
                    path.display()
                ));
                Self::connect(&path)?
            }
        };
        Ok((
            History {
                conn: Mutex::new(conn),
                path,
                max_age_s: max_age_days * 86400.0,
                max_records,
            },
            note,
        ))
    }

    fn connect(path: &Path) -> Result<Connection, HistoryError> {
        let conn = Connection::open(path).map_err(sqlite(path))?;
        let check: String = conn
            .query_row("PRAGMA quick_check", [], |r| r.get(0))
            .map_err(sqlite(path))?;
        if check != "ok" {
            return Err(HistoryError::Sqlite {
                path: path.display().to_string(),
                source: rusqlite::Error::InvalidQuery,
            });
        }
        conn.execute_batch(
            "PRAGMA journal_mode = WAL;
             PRAGMA synchronous = FULL;
             CREATE TABLE IF NOT EXISTS records (
                 id INTEGER PRIMARY KEY,
                 vessel TEXT NOT NULL,
                 kind TEXT NOT NULL,
                 t REAL NOT NULL,
                 written_unix_s REAL NOT NULL,
                 payload TEXT NOT NULL
             );
             CREATE INDEX IF NOT EXISTS records_vessel_t ON records (vessel, t);",
        )
        .map_err(sqlite(path))?;
        Ok(conn)
    }

    /// The database file.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Adds a record (durable when this returns) and prunes what retention drops.
    pub fn add(
        &self,
        vessel: &str,
        kind: Kind,
        t: f64,
        payload: &impl Serialize,
    ) -> Result<(), HistoryError> {
        let text =
            serde_json::to_string(payload).map_err(|e| HistoryError::Encode(e.to_string()))?;
        let now = now_unix_s();
        let conn = self.conn.lock().unwrap_or_else(|p| p.into_inner());
        let t = if t.is_finite() { t } else { 0.0 };
        conn.execute(
            "INSERT INTO records (vessel, kind, t, written_unix_s, payload) VALUES (?1, ?2, ?3, ?4, ?5)",
            params![vessel, kind.name(), t, now, text],
        )
        .map_err(sqlite(&self.path))?;
        conn.execute(
            "DELETE FROM records WHERE written_unix_s < ?1",
            params![now - self.max_age_s],
        )
        .map_err(sqlite(&self.path))?;
        let max_id: Option<i64> = conn
            .query_row("SELECT MAX(id) FROM records", [], |r| r.get(0))
            .optional()
            .map_err(sqlite(&self.path))?
            .flatten();
        if let Some(max_id) = max_id {
            conn.execute(
                "DELETE FROM records WHERE id <= ?1",
                params![max_id - self.max_records as i64],
            )
            .map_err(sqlite(&self.path))?;
        }
        Ok(())
    }

    /// The latest `range.limit` records of `vessel` with `t` in the range, oldest first.
    pub fn query(&self, vessel: &str, range: Range) -> Result<Vec<Record>, HistoryError> {
        let conn = self.conn.lock().unwrap_or_else(|p| p.into_inner());
        let mut stmt = conn
            .prepare(
                "SELECT kind, t, written_unix_s, payload FROM records
                 WHERE vessel = ?1 AND t >= ?2 AND t <= ?3
                 ORDER BY t DESC, id DESC LIMIT ?4",
            )
            .map_err(sqlite(&self.path))?;
        let rows = stmt
            .query_map(
                params![
                    vessel,
                    range.from_t.max(-1e300),
                    range.to_t.min(1e300),
                    range.limit.min(MAX_LIMIT) as i64
                ],
                |r| {
                    let kind: String = r.get(0)?;
                    let payload: String = r.get(3)?;
                    Ok((kind, r.get::<_, f64>(1)?, r.get::<_, f64>(2)?, payload))
                },
            )
            .map_err(sqlite(&self.path))?;
        let mut out = Vec::new();
        for row in rows {
            let (kind, t, written_unix_s, payload) = row.map_err(sqlite(&self.path))?;
            out.push(Record {
                kind: if kind == "notification" {
                    Kind::Notification
                } else {
                    Kind::Report
                },
                t,
                written_unix_s,
                payload: serde_json::from_str(&payload).unwrap_or(serde_json::Value::Null),
            });
        }
        out.reverse();
        Ok(out)
    }
}

/// Serves `fdi/history` queries for `vessels` until `cancel`: each vessel whose key the
/// query's key expression intersects gets one reply ([`HistoryReply`]), or an error reply
/// naming the bad parameter.
pub async fn serve(
    history: Arc<History>,
    vessels: Vec<String>,
    mut rx: tokio::sync::mpsc::Receiver<zenoh::query::Query>,
    cancel: tokio_util::sync::CancellationToken,
) {
    let keys: Vec<Option<zenoh::key_expr::KeyExpr<'static>>> = vessels
        .iter()
        .map(|v| zenoh::key_expr::KeyExpr::try_from(Keys::new(v).history()).ok())
        .collect();
    loop {
        let query = tokio::select! {
            biased;
            _ = cancel.cancelled() => return,
            q = rx.recv() => match q { Some(q) => q, None => return },
        };
        let params = query.parameters().clone();
        let range = Range::from_params(|k| params.get(k).map(String::from));
        let qke = query.key_expr().clone();
        for (i, key) in keys.iter().enumerate() {
            let Some(key) = key.as_ref().filter(|k| k.intersects(&qke)) else {
                continue;
            };
            let reply = match range {
                Err(ref e) => Err(e.clone()),
                Ok(r) => {
                    let h = history.clone();
                    let v = vessels[i].clone();
                    tokio::task::spawn_blocking(move || h.query(&v, r))
                        .await
                        .map_err(|e| e.to_string())
                        .and_then(|x| x.map_err(|e| e.to_string()))
                        .map(|records| HistoryReply {
                            vessel: vessels[i].clone(),
                            records,
                        })
                }
            };
            let sent = match reply.and_then(|r| serde_json::to_vec(&r).map_err(|e| e.to_string())) {
                Ok(bytes) => {
                    query
                        .reply(key.clone(), bytes)
                        .encoding(zenoh::bytes::Encoding::APPLICATION_JSON)
                        .await
                }
                Err(e) => query.reply_err(e.into_bytes()).await,
            };
            if let Err(e) = sent {
                tracing::warn!(vessel = %vessels[i], "history reply failed: {e}");
            }
        }
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    fn temp(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("helmwatch-hist-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    #[test]
    fn records_come_back_by_vessel_and_range_latest_first_cut_oldest_first_shown() {
        let d = temp("query");
        let (h, note) = History::open(&d, 365.0, 1000).unwrap();
        assert!(note.is_none());
        for i in 0..10 {
            h.add(
                "a",
                Kind::Report,
                i as f64 * 100.0,
                &serde_json::json!({"i": i}),
            )
            .unwrap();
            h.add(
                "b",
                Kind::Report,
                i as f64 * 100.0,
                &serde_json::json!({"i": -i}),
            )
            .unwrap();
        }
        h.add(
            "a",
            Kind::Notification,
            950.0,
            &serde_json::json!({"state": "alarm"}),
        )
        .unwrap();
        let all = h.query("a", Range::default()).unwrap();
        assert_eq!(all.len(), 11);
        assert!(all.windows(2).all(|w| w[0].t <= w[1].t));
        let r = h
            .query(
                "a",
                Range {
                    from_t: 200.0,
                    to_t: 600.0,
                    limit: 3,
                },
            )
            .unwrap();
        let is: Vec<i64> = r.iter().map(|x| x.payload["i"].as_i64().unwrap()).collect();
        assert_eq!(is, vec![4, 5, 6]);
        assert_eq!(all.last().unwrap().kind, Kind::Notification);
        // Reopened: still there.
        drop(h);
        let (h, _) = History::open(&d, 365.0, 1000).unwrap();
        assert_eq!(h.query("b", Range::default()).unwrap().len(), 10);
        let _ = std::fs::remove_dir_all(&d);
    }

    #[test]
    fn retention_keeps_the_newest_records() {
        let d = temp("retention");
        let (h, _) = History::open(&d, 365.0, 5).unwrap();
        for i in 0..12 {
            h.add("a", Kind::Report, i as f64, &i).unwrap();
        }
        let r = h.query("a", Range::default()).unwrap();
        let ts: Vec<f64> = r.iter().map(|x| x.t).collect();
        assert_eq!(ts, vec![7.0, 8.0, 9.0, 10.0, 11.0]);
        // Age: a zero-day retention keeps only what was written this instant or later.
        let (h, _) = History::open(&d, 0.0, 100).unwrap();
        h.add("a", Kind::Report, 99.0, &0).unwrap();
        assert!(h.query("a", Range::default()).unwrap().len() <= 1);
        let _ = std::fs::remove_dir_all(&d);
    }

    #[test]
    fn a_garbage_database_is_moved_aside_with_a_message_naming_it() {
        let d = temp("garbage");
        std::fs::write(
            d.join("history.sqlite"),
            b"this is not a database, not at all",
        )
        .unwrap();
        let (h, note) = History::open(&d, 365.0, 100).unwrap();
        let note = note.unwrap();
        assert!(note.contains("history.sqlite"), "{note}");
        assert!(d.join("history.sqlite.corrupt").exists());
        h.add("a", Kind::Report, 1.0, &1).unwrap();
        assert_eq!(h.query("a", Range::default()).unwrap().len(), 1);
        let _ = std::fs::remove_dir_all(&d);
    }

    #[test]
    fn query_parameters_are_checked() {
        let p = |pairs: &'static [(&'static str, &'static str)]| {
            Range::from_params(|k| {
                pairs
                    .iter()
                    .find(|(n, _)| *n == k)
                    .map(|(_, v)| v.to_string())
            })
        };
        assert_eq!(p(&[]).unwrap(), Range::default());
        let r = p(&[("from", "10"), ("to", "20.5"), ("limit", "7")]).unwrap();
        assert_eq!((r.from_t, r.to_t, r.limit), (10.0, 20.5, 7));
        assert!(p(&[("limit", "0")]).unwrap_err().contains("limit"));
        assert!(p(&[("limit", "20000")]).is_err());
        assert!(p(&[("from", "soon")]).unwrap_err().contains("from=soon"));
        assert!(p(&[("to", "NaN")]).is_err());
    }
}
