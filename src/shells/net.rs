//! Zenoh session set-up shared by the daemon, the simulated ship peer, the demo and the
//! benchmarks: a [`zenoh::Config`] from the `[zenoh]` settings (or a Zenoh JSON5 file), with
//! command-line endpoint overrides, and small helpers.
//!
//! Multicast scouting is off unless asked for, and the endpoints are always explicit, so a
//! default session only ever talks on the endpoints written in the configuration
//! (`tcp/127.0.0.1:7447` by default).

use helmwatch_core::config::{fail, ConfigError};
use serde::{Deserialize, Serialize};
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
    pub const EXIT_CODE: i32 = helmwatch_core::config::ConfigError::EXIT_CODE;
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
    loopback(ZenohMode::Peer, listen, connect)
}

/// [`loopback_peer`] in any mode (a router, a client of one).
pub fn loopback(
    mode: ZenohMode,
    listen: &[String],
    connect: &[String],
) -> Result<zenoh::Config, NetError> {
    zenoh_config(
        &ZenohConfig {
            mode,
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

// ---------------------------------------------------------------------------------------------
// The [zenoh] section

/// Zenoh node mode.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq, Eq, Default)]
#[serde(rename_all = "lowercase")]
pub enum ZenohMode {
    /// Peer: talks directly to other peers and routers (default).
    #[default]
    Peer,
    /// Client: talks through one router.
    Client,
    /// Router: routes for others (a shore server usually runs `zenohd` instead).
    Router,
}

impl ZenohMode {
    /// The name Zenoh uses (`"peer"`, `"client"`, `"router"`).
    pub fn name(self) -> &'static str {
        match self {
            ZenohMode::Peer => "peer",
            ZenohMode::Client => "client",
            ZenohMode::Router => "router",
        }
    }
}

/// A Zenoh session: mode, endpoints, scouting, or a Zenoh JSON5 configuration file.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(default, deny_unknown_fields, rename_all = "kebab-case")]
pub struct ZenohConfig {
    /// Node mode: `peer`, `client` or `router`.
    pub mode: ZenohMode,
    /// Endpoints to listen on, e.g. `tcp/127.0.0.1:7447` (`--listen` overrides).
    pub listen: Vec<String>,
    /// Endpoints to connect to, e.g. `tcp/192.0.2.10:7447` (`--connect` overrides).
    pub connect: Vec<String>,
    /// UDP multicast scouting (off: only the endpoints above are used).
    pub multicast_scouting: bool,
    /// A Zenoh JSON5 configuration file (routers, TLS, access control). When set, the session
    /// is configured from that file alone and the four keys above are ignored; `--listen` and
    /// `--connect` still override its endpoints.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub config_file: Option<std::path::PathBuf>,
}

impl Default for ZenohConfig {
    fn default() -> Self {
        Self {
            mode: ZenohMode::Peer,
            listen: vec!["tcp/127.0.0.1:7447".to_string()],
            connect: Vec::new(),
            multicast_scouting: false,
            config_file: None,
        }
    }
}

/// Checks that `endpoint` parses as a Zenoh endpoint (`proto/address[?metadata][#config]`).
pub fn check_endpoint(key: &str, endpoint: &str) -> Result<(), ConfigError> {
    match endpoint.parse::<zenoh::config::EndPoint>() {
        Ok(_) => Ok(()),
        Err(e) => Err(fail(
            key,
            format!("{endpoint:?}"),
            &format!("a Zenoh endpoint such as \"tcp/127.0.0.1:7447\" ({e})"),
        )),
    }
}

impl ZenohConfig {
    /// Checks the endpoints; `section` names the table in errors (`zenoh`, `ship-peer`).
    pub fn check(&self, section: &str) -> Result<(), ConfigError> {
        for (i, e) in self.listen.iter().enumerate() {
            check_endpoint(&format!("{section}.listen[{i}]"), e)?;
        }
        for (i, e) in self.connect.iter().enumerate() {
            check_endpoint(&format!("{section}.connect[{i}]"), e)?;
        }
        if self.mode == ZenohMode::Client && self.connect.is_empty() && self.config_file.is_none() {
            return Err(fail(
                &format!("{section}.connect"),
                "[]",
                "at least one endpoint when mode = \"client\"",
            ));
        }
        Ok(())
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
