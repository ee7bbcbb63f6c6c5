//! Zenoh session set-up shared by the daemon, the simulated ship peer, the demo and the
//! benchmarks: a [`zenoh::Config`] from the `[zenoh]` settings (or a Zenoh JSON5 file), with
//! command-line endpoint overrides, and small helpers.
//!
//! Multicast scouting is off unless asked for, and the endpoints are always explicit, so a
//! default session only ever talks on the endpoints written in the configuration
//! (`tcp/127.0.0.1:7447` by default).

use crate::config::{ZenohConfig, ZenohMode};
use std::time::Duration;

/// A Zenoh configuration that could not be built.
#[derive(Debug, thiserror::Error)]
pub enum NetError {
    /// A key could not be set (bad endpoint, bad value).
    #[error("Zenoh configuration `{key}` = {value}: {reason}")]
    Key {
        /// The Zenoh configuration key, e.g. `listen/endpoints`.
        key: String,
        /// The value tried, as JSON5.
        value: String,
        /// Zenoh's message.
        reason: String,
    },
    /// The Zenoh JSON5 file could not be read or parsed.
    #[error("Zenoh configuration file {path}: {reason}")]
    File {
        /// The path given.
        path: String,
        /// Zenoh's message.
        reason: String,
    },
}

impl NetError {
    /// The sysexits code: these are configuration errors (`EX_CONFIG`).
    pub const EXIT_CODE: i32 = crate::config::ConfigError::EXIT_CODE;
}

fn insert(cfg: &mut zenoh::Config, key: &str, value: String) -> Result<(), NetError> {
    cfg.insert_json5(key, &value).map_err(|e| NetError::Key {
        key: key.to_string(),
        value,
        reason: e.to_string(),
    })
}

fn json_list(items: &[String]) -> String {
    serde_json::to_string(items).unwrap_or_else(|_| "[]".to_string())
}

/// Builds the Zenoh configuration of `z`, then applies `listen` and `connect` when they are
/// not empty (the command line's `--listen` / `--connect`).
pub fn zenoh_config(
    z: &ZenohConfig,
    listen: &[String],
    connect: &[String],
) -> Result<zenoh::Config, NetError> {
    let mut cfg = match &z.config_file {
        Some(path) => zenoh::Config::from_file(path).map_err(|e| NetError::File {
            path: path.display().to_string(),
            reason: e.to_string(),
        })?,
        None => {
            let mut cfg = zenoh::Config::default();
            insert(&mut cfg, "mode", format!("{:?}", z.mode.name()))?;
            insert(&mut cfg, "listen/endpoints", json_list(&z.listen))?;
            insert(&mut cfg, "connect/endpoints", json_list(&z.connect))?;
            insert(
                &mut cfg,
                "scouting/multicast/enabled",
                z.multicast_scouting.to_string(),
            )?;
            cfg
        }
    };
    if !listen.is_empty() {
        insert(&mut cfg, "listen/endpoints", json_list(listen))?;
    }
    if !connect.is_empty() {
        insert(&mut cfg, "connect/endpoints", json_list(connect))?;
    }
    Ok(cfg)
}

/// A peer configuration on loopback: listens on `listen` (may be empty), connects to
/// `connect`, multicast scouting off. For tests, the demo and benchmarks.
pub fn loopback_peer(listen: &[String], connect: &[String]) -> Result<zenoh::Config, NetError> {
    zenoh_config(
        &ZenohConfig {
            mode: ZenohMode::Peer,
            listen: listen.to_vec(),
            connect: connect.to_vec(),
            multicast_scouting: false,
            config_file: None,
        },
        &[],
        &[],
    )
}

/// A free TCP port on 127.0.0.1 (bound, read, released). Another process may take it in the
/// meantime; good enough for tests and the demo.
pub fn free_loopback_port() -> std::io::Result<u16> {
    let l = std::net::TcpListener::bind("127.0.0.1:0")?;
    Ok(l.local_addr()?.port())
}

/// Waits until `publisher` has a matching subscriber, polling every 10 ms for at most
/// `limit`. Returns whether it matched.
pub async fn wait_matching(publisher: &zenoh::pubsub::Publisher<'_>, limit: Duration) -> bool {
    let deadline = tokio::time::Instant::now() + limit;
    loop {
        if let Ok(status) = publisher.matching_status().await {
            if status.matching() {
                return true;
            }
        }
        if tokio::time::Instant::now() >= deadline {
            return false;
        }
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_config_is_loopback_peer_without_multicast() {
        let cfg = zenoh_config(&ZenohConfig::default(), &[], &[]).unwrap();
        let text = format!("{cfg}");
        assert!(text.contains("tcp/127.0.0.1:7447"), "{text}");
        let cfg = zenoh_config(
            &ZenohConfig::default(),
            &["tcp/127.0.0.1:7999".into()],
            &["tcp/127.0.0.1:7998".into()],
        )
        .unwrap();
        let text = format!("{cfg}");
        assert!(
            text.contains("tcp/127.0.0.1:7999") && text.contains("tcp/127.0.0.1:7998"),
            "{text}"
        );
        assert!(!text.contains("tcp/127.0.0.1:7447"), "{text}");
    }

    #[test]
    fn bad_file_is_a_config_error() {
        let z = ZenohConfig {
            config_file: Some("/nonexistent/zenoh.json5".into()),
            ..ZenohConfig::default()
        };
        assert!(matches!(
            zenoh_config(&z, &[], &[]),
            Err(NetError::File { .. })
        ));
    }
}
