//! The NMEA bridge (`helmwatch bridge nmea`): a ship's NMEA 0183 / IEC 61162-450 sentences in,
//! the contract's keys of one vessel out over Zenoh.
//!
//! Input, one of (`bridge.input`):
//! - `udp`: datagrams on `bridge.udp-listen`, unicast, or multicast when `bridge.udp-group`
//!   is set (joined on `bridge.udp-interface`); IEC 61162-450 (`UdPbC\0` and tag blocks) or
//!   bare sentences.
//! - `tcp`: a byte stream from `bridge.tcp-connect` (an NMEA multiplexer, a serial-to-LAN
//!   server), reconnected every `bridge.reconnect-s` after a failure.
//! - `serial`: a serial device read as a byte stream (`bridge.serial-path`, its line speed
//!   set by the system: `stty`, a udev rule), reopened the same way.
//!
//! Every datagram or chunk goes through [`helmwatch_core::nmea::Decoder`] (pure: checksum,
//! talker, status, ranges, time), and each sample is published on its key at once, in the
//! order of the lines (a lockstep ship sends its heading last). Nothing rejected is
//! published; rejections are counted by reason, published every `bridge.stats-period-s` on
//! `vessels/<v>/bridge/stats` and served as metrics on `bridge.metrics-listen`. Over-long
//! lines never grow a buffer ([`helmwatch_core::nmea::LineBuffer`]).
//!
//! The bridge keeps no state a restart would lose: a restarted bridge publishes the next
//! sentence it receives. While it is down the daemon hears nothing, and its silence check
//! (`safety.stream-timeout-s`) aborts a running test.

pub mod metrics;

use crate::shells::net::{ZenohConfig, ZenohMode};
use helmwatch_core::config::{check_range_open_low, fail, ConfigError};
use helmwatch_core::nmea::{
    DecodeOptions, DecodeStats, Decoder, HeadingSentence, LineBuffer, Reject, SpeedSentence,
    TimeSource,
};
use helmwatch_core::wire::{Input, Keys, Stream};
use prometheus_client::registry::Registry;
use serde::{Deserialize, Serialize};
use std::future::Future;
use std::net::{Ipv4Addr, SocketAddr};
use std::path::PathBuf;
use std::sync::{Arc, Mutex};
use std::time::Duration;
use tokio::io::{AsyncRead, AsyncReadExt};
use zenoh::bytes::Encoding;
use zenoh::qos::{CongestionControl, Priority};

/// Key of the bridge's counters below the vessel prefix.
pub const STATS_PATH: &str = "bridge/stats";

/// Why the bridge stopped with an error.
#[derive(Debug, thiserror::Error)]
pub enum BridgeError {
    /// The Zenoh session could not be opened or a declaration failed.
    #[error("Zenoh: {0}")]
    Zenoh(String),
    /// The UDP socket could not be bound or the multicast group joined.
    #[error("bridge.udp-listen = {addr:?}: {reason}")]
    Udp {
        /// The configured address.
        addr: String,
        /// The operating system's message.
        reason: String,
    },
    /// The metrics endpoint could not start.
    #[error(transparent)]
    Metrics(#[from] crate::shells::metrics::http::MetricsError),
}

/// Where the sentences come from.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq, Eq, Default)]
#[serde(rename_all = "lowercase")]
pub enum BridgeInput {
    /// UDP datagrams (IEC 61162-450 or bare sentences), unicast or multicast.
    #[default]
    Udp,
    /// A TCP byte stream.
    Tcp,
    /// A serial device read as a byte stream.
    Serial,
}

/// The `[bridge]` section: one vessel's NMEA input, its checks, its Zenoh session.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(default, deny_unknown_fields, rename_all = "kebab-case")]
pub struct BridgeConfig {
    /// The vessel whose keys are published (`vessels/<vessel>/...`).
    pub vessel: String,
    /// `udp`, `tcp` or `serial`.
    pub input: BridgeInput,
    /// UDP: the address and port to bind (`0.0.0.0:<port>` to hear a multicast group).
    pub udp_listen: String,
    /// UDP: an IPv4 multicast group to join (IEC 61162-450 transmission group), or empty.
    pub udp_group: String,
    /// UDP: the IPv4 address of the interface that joins the group (`0.0.0.0`: the system's
    /// choice).
    pub udp_interface: String,
    /// TCP: the server to connect to, `host:port`.
    pub tcp_connect: String,
    /// Serial: the device, e.g. `/dev/ttyUSB0` (line speed set by the system).
    pub serial_path: PathBuf,
    /// TCP, serial: wait before reconnecting or reopening [s], (0, 600].
    pub reconnect_s: f64,
    /// Where a sample's `t` comes from: `receive`, `tag-block-s`, `tag-block-ms`, `zda`.
    pub time_source: TimeSource,
    /// The heading sentence: `hdt`, `hdg` or `ths`.
    pub heading: HeadingSentence,
    /// The speed-through-water sentence: `vhw` or `vbw`.
    pub speed: SpeedSentence,
    /// Accepted talkers (e.g. `["HE", "AG", "VW"]`); empty: any.
    pub talkers: Vec<String>,
    /// Accepted IEC 61162-450 sources (tag block `s:`); empty: any.
    pub sources: Vec<String>,
    /// Largest |rudder angle| published [deg], (0, 90].
    pub max_rudder_deg: f64,
    /// Largest |speed through water| published [m/s], (0, 100].
    pub max_speed_mps: f64,
    /// Tag-block time: a step of a stream's time larger than this is a jump, rejected
    /// (`time_jump`) [s], (0, 86400].
    pub time_jump_s: f64,
    /// Tag-block time: consecutive samples of a new timeline that re-synchronise a stream on
    /// it, [2, 1000].
    pub resync_samples: u32,
    /// Period of `vessels/<v>/bridge/stats` [s, wall], (0, 3600].
    pub stats_period_s: f64,
    /// `IP:PORT` of the bridge's metrics endpoint (`GET /metrics`), or empty for none.
    pub metrics_listen: String,
    /// Zenoh node mode of the bridge.
    pub mode: ZenohMode,
    /// Endpoints the bridge listens on (none by default).
    pub listen: Vec<String>,
    /// Endpoints the bridge connects to (the daemon's by default).
    pub connect: Vec<String>,
    /// UDP multicast scouting of Zenoh.
    pub multicast_scouting: bool,
}

impl Default for BridgeConfig {
    fn default() -> Self {
        let d = DecodeOptions::default();
        Self {
            vessel: "self".to_string(),
            input: BridgeInput::Udp,
            udp_listen: "127.0.0.1:10110".to_string(),
            udp_group: String::new(),
            udp_interface: "0.0.0.0".to_string(),
            tcp_connect: "127.0.0.1:10110".to_string(),
            serial_path: PathBuf::from("/dev/ttyUSB0"),
            reconnect_s: 2.0,
            time_source: d.time_source,
            heading: d.heading,
            speed: d.speed,
            talkers: d.talkers,
            sources: d.sources,
            max_rudder_deg: d.max_rudder_deg,
            max_speed_mps: d.max_speed_mps,
            time_jump_s: d.time_jump_s,
            resync_samples: d.resync_samples,
            stats_period_s: 10.0,
            metrics_listen: String::new(),
            mode: ZenohMode::Peer,
            listen: Vec::new(),
            connect: vec!["tcp/127.0.0.1:7447".to_string()],
            multicast_scouting: false,
        }
    }
}

impl BridgeConfig {
    /// Checks the section's limits; the error names the key and its allowed range.
    pub fn check(&self) -> Result<(), ConfigError> {
        helmwatch_core::config::check_vessel_name("bridge.vessel", &self.vessel)?;
        if self.udp_listen.parse::<SocketAddr>().is_err() {
            return Err(fail(
                "bridge.udp-listen",
                format!("{:?}", self.udp_listen),
                "IP:PORT, e.g. \"0.0.0.0:60004\"",
            ));
        }
        if !self.udp_group.is_empty()
            && !self
                .udp_group
                .parse::<Ipv4Addr>()
                .is_ok_and(|g| g.is_multicast())
        {
            return Err(fail(
                "bridge.udp-group",
                format!("{:?}", self.udp_group),
                "an IPv4 multicast address (224.0.0.0/4), e.g. \"239.192.0.4\", or empty",
            ));
        }
        if self.udp_interface.parse::<Ipv4Addr>().is_err() {
            return Err(fail(
                "bridge.udp-interface",
                format!("{:?}", self.udp_interface),
                "an IPv4 address, e.g. \"0.0.0.0\"",
            ));
        }
        if self.tcp_connect.rsplit_once(':').is_none() {
            return Err(fail(
                "bridge.tcp-connect",
                format!("{:?}", self.tcp_connect),
                "host:port",
            ));
        }
        if self.input == BridgeInput::Serial && self.serial_path.as_os_str().is_empty() {
            return Err(fail("bridge.serial-path", "\"\"", "a device path"));
        }
        check_range_open_low("bridge.reconnect-s", self.reconnect_s, 0.0, 600.0)?;
        check_range_open_low("bridge.stats-period-s", self.stats_period_s, 0.0, 3600.0)?;
        if !self.metrics_listen.is_empty() && self.metrics_listen.parse::<SocketAddr>().is_err() {
            return Err(fail(
                "bridge.metrics-listen",
                format!("{:?}", self.metrics_listen),
                "IP:PORT, e.g. \"127.0.0.1:9899\", or empty",
            ));
        }
        self.decode_options().check("bridge")?;
        self.zenoh().check("bridge")
    }

    /// The decoder's part of the section.
    pub fn decode_options(&self) -> DecodeOptions {
        DecodeOptions {
            time_source: self.time_source,
            heading: self.heading,
            speed: self.speed,
            talkers: self.talkers.clone(),
            sources: self.sources.clone(),
            max_rudder_deg: self.max_rudder_deg,
            max_speed_mps: self.max_speed_mps,
            time_jump_s: self.time_jump_s,
            resync_samples: self.resync_samples,
        }
    }

    /// The bridge's Zenoh session settings.
    pub fn zenoh(&self) -> ZenohConfig {
        ZenohConfig {
            mode: self.mode,
            listen: self.listen.clone(),
            connect: self.connect.clone(),
            multicast_scouting: self.multicast_scouting,
            config_file: None,
        }
    }
}

/// The input, bound or to be opened.
enum Source {
    Udp(tokio::net::UdpSocket),
    Tcp(String),
    Serial(PathBuf),
}

/// A bridge with its input bound and its Zenoh session open; [`Bridge::run`] drives it.
pub struct Bridge {
    cfg: BridgeConfig,
    source: Source,
    session: zenoh::Session,
    metrics: Option<tokio::net::TcpListener>,
}

impl std::fmt::Debug for Bridge {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Bridge")
            .field("cfg", &self.cfg)
            .finish_non_exhaustive()
    }
}

/// UNIX time now [s] (the time of reception).
fn now_s() -> f64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0.0, |d| d.as_secs_f64())
}

fn bind_udp(cfg: &BridgeConfig) -> Result<tokio::net::UdpSocket, BridgeError> {
    let err = |reason: String| BridgeError::Udp {
        addr: cfg.udp_listen.clone(),
        reason,
    };
    let addr: SocketAddr = cfg.udp_listen.parse().map_err(|e| err(format!("{e}")))?;
    let domain = socket2::Domain::for_address(addr);
    let s = socket2::Socket::new(domain, socket2::Type::DGRAM, Some(socket2::Protocol::UDP))
        .map_err(|e| err(e.to_string()))?;
    if !cfg.udp_group.is_empty() {
        // Other listeners of the same transmission group on this host (a VDR, an ECDIS)
        // bind the same port.
        s.set_reuse_address(true).map_err(|e| err(e.to_string()))?;
    }
    s.set_nonblocking(true).map_err(|e| err(e.to_string()))?;
    // Bursts of sentences at 10 Hz from every instrument: room for a few seconds.
    let _ = s.set_recv_buffer_size(1 << 20);
    s.bind(&addr.into()).map_err(|e| err(e.to_string()))?;
    if !cfg.udp_group.is_empty() {
        let group: Ipv4Addr = cfg.udp_group.parse().map_err(|e| err(format!("{e}")))?;
        let iface: Ipv4Addr = cfg.udp_interface.parse().map_err(|e| err(format!("{e}")))?;
        s.join_multicast_v4(&group, &iface)
            .map_err(|e| err(format!("joining {group} on {iface}: {e}")))?;
    }
    tokio::net::UdpSocket::from_std(s.into()).map_err(|e| err(e.to_string()))
}

impl Bridge {
    /// Binds the input (UDP) and the metrics endpoint, opens the Zenoh session on `zcfg`.
    pub async fn start(cfg: &BridgeConfig, zcfg: zenoh::Config) -> Result<Self, BridgeError> {
        let source = match cfg.input {
            BridgeInput::Udp => Source::Udp(bind_udp(cfg)?),
            BridgeInput::Tcp => Source::Tcp(cfg.tcp_connect.clone()),
            BridgeInput::Serial => Source::Serial(cfg.serial_path.clone()),
        };
        let metrics = if cfg.metrics_listen.is_empty() {
            None
        } else {
            Some(
                crate::shells::metrics::http::bind("bridge.metrics-listen", &cfg.metrics_listen)
                    .await?,
            )
        };
        let session = zenoh::open(zcfg)
            .await
            .map_err(|e| BridgeError::Zenoh(e.to_string()))?;
        Ok(Self {
            cfg: cfg.clone(),
            source,
            session,
            metrics,
        })
    }

    /// The bound UDP address (input `udp`).
    pub fn udp_addr(&self) -> Option<SocketAddr> {
        match &self.source {
            Source::Udp(s) => s.local_addr().ok(),
            _ => None,
        }
    }

    /// The bound metrics address, when `bridge.metrics-listen` is set.
    pub fn metrics_addr(&self) -> Option<SocketAddr> {
        self.metrics.as_ref().and_then(|l| l.local_addr().ok())
    }

    /// Runs until `shutdown` completes; returns the decoder's counters.
    pub async fn run(self, shutdown: impl Future<Output = ()>) -> Result<DecodeStats, BridgeError> {
        let Bridge {
            cfg,
            source,
            session,
            metrics,
        } = self;
        let r = drive(&cfg, source, &session, metrics, shutdown).await;
        if let Err(e) = session.close().await {
            tracing::warn!("closing the Zenoh session: {e}");
        }
        r
    }
}

/// What the input gave: one datagram, one chunk of a stream, or the news that a stream was
/// (re)opened (its partial line is then stale).
enum Got {
    Datagram(Vec<u8>),
    Bytes(Vec<u8>),
    Opened,
}

/// An open byte stream (TCP or serial).
type ByteStream = Box<dyn AsyncRead + Unpin + Send>;

async fn open_stream(source: &Source) -> std::io::Result<ByteStream> {
    match source {
        Source::Tcp(addr) => {
            let s = tokio::net::TcpStream::connect(addr.as_str()).await?;
            Ok(Box::new(s))
        }
        Source::Serial(path) => {
            let f = tokio::fs::File::open(path).await?;
            Ok(Box::new(f))
        }
        Source::Udp(_) => Err(std::io::Error::other("not a stream")),
    }
}

/// Reads the input for as long as `tx` has a receiver: datagrams as they come; a stream
/// opened, read, and reopened `retry` after a failure or a hang-up. It runs as its own task
/// so that nothing cancels it half way: an open dropped by a `select!` would leave a
/// half-made TCP connection in the server's queue and skip the wait before the next one.
/// The channel is bounded: a slow publisher slows the reads, the kernel buffers the rest.
async fn read_input(source: Source, retry: Duration, tx: tokio::sync::mpsc::Sender<Got>) {
    let mut buf = vec![0u8; 65536];
    let mut stream: Option<ByteStream> = None;
    loop {
        let got = if let Source::Udp(s) = &source {
            match s.recv(&mut buf).await {
                Ok(n) => Got::Datagram(buf[..n].to_vec()),
                Err(e) => {
                    // ICMP errors and the like: nothing to reopen; no busy loop either.
                    tracing::debug!("udp receive: {e}");
                    tokio::time::sleep(Duration::from_millis(10)).await;
                    continue;
                }
            }
        } else if let Some(st) = stream.as_mut() {
            match st.read(&mut buf).await {
                Ok(0) => {
                    tracing::warn!("NMEA input closed; reopening in {:?}", retry);
                    stream = None;
                    tokio::time::sleep(retry).await;
                    continue;
                }
                Ok(n) => Got::Bytes(buf[..n].to_vec()),
                Err(e) => {
                    tracing::warn!("NMEA input: {e}; reopening in {:?}", retry);
                    stream = None;
                    tokio::time::sleep(retry).await;
                    continue;
                }
            }
        } else {
            match open_stream(&source).await {
                Ok(s) => {
                    tracing::info!("NMEA input open");
                    stream = Some(s);
                    Got::Opened
                }
                Err(e) => {
                    tracing::warn!("NMEA input: {e}; retrying in {:?}", retry);
                    tokio::time::sleep(retry).await;
                    continue;
                }
            }
        };
        if tx.send(got).await.is_err() {
            return;
        }
    }
}

async fn drive(
    cfg: &BridgeConfig,
    source: Source,
    session: &zenoh::Session,
    metrics: Option<tokio::net::TcpListener>,
    shutdown: impl Future<Output = ()>,
) -> Result<DecodeStats, BridgeError> {
    let z = |e: zenoh::Error| BridgeError::Zenoh(e.to_string());
    let keys = Keys::new(&cfg.vessel);
    let mut pubs = Vec::with_capacity(Stream::BY_INDEX.len());
    for s in Stream::BY_INDEX {
        let p = session
            .declare_publisher(keys.stream(s))
            .encoding(Encoding::APPLICATION_JSON)
            // A sample is never dropped inside the bridge (the daemon aligns by `t`).
            .congestion_control(CongestionControl::Block)
            .priority(Priority::Data)
            .express(s == Stream::Heading)
            .await
            .map_err(z)?;
        pubs.push(p);
    }
    let stats_pub = session
        .declare_publisher(format!("{}/{STATS_PATH}", keys.prefix))
        .encoding(Encoding::APPLICATION_JSON)
        .await
        .map_err(z)?;

    let shared = Arc::new(Mutex::new(DecodeStats::default()));
    let _metrics_task = metrics.map(|listener| {
        let mut registry = Registry::with_prefix("helmwatch");
        registry.register_collector(Box::new(metrics::StatsCollector {
            vessel: cfg.vessel.clone(),
            stats: shared.clone(),
        }));
        AbortOnDrop(tokio::spawn(crate::shells::metrics::http::serve(
            listener,
            Arc::new(registry),
        )))
    });

    let mut decoder = Decoder::new(cfg.decode_options());
    let mut lines = LineBuffer::new();
    let mut out: Vec<Input> = Vec::with_capacity(16);
    let (tx, mut rx) = tokio::sync::mpsc::channel(64);
    let _reader = AbortOnDrop(tokio::spawn(read_input(
        source,
        Duration::from_secs_f64(cfg.reconnect_s),
        tx,
    )));
    let mut tick = tokio::time::interval(Duration::from_secs_f64(cfg.stats_period_s));
    tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    let mut logged = [0u64; Reject::ALL.len()];
    tracing::info!(vessel = %cfg.vessel, input = ?cfg.input, time_source = ?cfg.time_source, "NMEA bridge running");
    tokio::pin!(shutdown);
    loop {
        let got = tokio::select! {
            biased;
            _ = &mut shutdown => break,
            _ = tick.tick() => {
                publish_stats(&stats_pub, decoder.stats()).await;
                continue;
            }
            g = rx.recv() => match g {
                Some(g) => g,
                None => break, // the reader ended: it only does when the runtime stops
            },
        };
        let recv_s = now_s();
        out.clear();
        match got {
            Got::Datagram(b) => decoder.datagram(&b, recv_s, &mut out),
            Got::Bytes(b) => decoder.stream(&mut lines, &b, recv_s, &mut out),
            Got::Opened => {
                lines.clear();
                continue;
            }
        }
        for input in &out {
            let bytes = serde_json::to_vec(&input.payload()).unwrap_or_default();
            if let Err(e) = pubs[input.stream().index()].put(bytes).await {
                tracing::warn!("publishing {}: {e}", input.stream().name());
            }
        }
        let stats = decoder.stats();
        // Rejections are logged once per burst: at the 1st, 2nd, 4th, 8th... of each reason.
        for r in Reject::ALL {
            let n = stats.rejected(r);
            let i = r as usize;
            if n > logged[i] {
                if n.is_power_of_two() || logged[i] == 0 {
                    tracing::warn!(reason = r.name(), count = n, "NMEA sentences rejected");
                }
                logged[i] = n;
            }
        }
        if let Ok(mut s) = shared.lock() {
            s.clone_from(stats);
        }
    }
    publish_stats(&stats_pub, decoder.stats()).await;
    let stats = decoder.stats().clone();
    tracing::info!(
        lines = stats.lines,
        used = stats.used,
        ignored = stats.ignored,
        rejected = stats.rejected_total(),
        "NMEA bridge stopped"
    );
    Ok(stats)
}

async fn publish_stats(p: &zenoh::pubsub::Publisher<'_>, stats: &DecodeStats) {
    let mut v = stats.to_json();
    if let Some(o) = v.as_object_mut() {
        o.insert("t".to_string(), now_s().into());
    }
    let bytes = serde_json::to_vec(&v).unwrap_or_default();
    if let Err(e) = p.put(bytes).await {
        tracing::warn!("publishing the bridge's stats: {e}");
    }
}

/// Aborts a spawned task when dropped (the metrics server lives as long as the bridge).
struct AbortOnDrop(tokio::task::JoinHandle<()>);

impl Drop for AbortOnDrop {
    fn drop(&mut self) {
        self.0.abort();
    }
}
