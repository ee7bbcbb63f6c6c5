//! The `[daemon]` section: vessels, queues, timers.

use helmwatch_core::config::{
    check_count, check_range, check_range_open_low, check_vessel_name, fail, ConfigError,
};
use serde::{Deserialize, Serialize};

/// The daemon (`helmwatch run`): one monitor core per vessel, each fed by a bounded queue.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(default, deny_unknown_fields, rename_all = "kebab-case")]
pub struct DaemonConfig {
    /// Vessels monitored, one monitor core each (`vessels/<vessel>/...`); 1 to 100000 names.
    pub vessels: Vec<String>,
    /// Capacity of each vessel's input queue [messages]. A full queue drops new samples and
    /// counts them (`dropped.flood` in the stats): a flood never grows memory.
    pub queue_capacity: u32,
    /// Period of the silence check [s]: ship time is estimated as the last heading's `t` plus
    /// the wall time since it arrived, so a silent heading stream aborts a test.
    pub tick_s: f64,
    /// Period of the statistics (log at debug level, `fdi/stats` publication) [s]; 0 = never.
    pub stats_period_s: f64,
    /// Publish the statistics on `vessels/<v>/fdi/stats` (an addition to the contract).
    pub publish_stats: bool,
    /// Longest wait for the final publications (`mode: none`, status) at shutdown [s].
    pub shutdown_timeout_s: f64,
    /// The state directory: each vessel's alarm tracks, CUSUM, sea memory and scheduler are
    /// saved there after every decision and restored at start (`helmwatch run --state-dir`
    /// overrides it; systemd's `StateDirectory=helmwatch` is `/var/lib/helmwatch`). Absent:
    /// nothing is kept across a restart.
    pub state_dir: Option<String>,
    /// Report history in the state directory (`history.sqlite`): records older than this are
    /// dropped [days].
    pub history_days: f64,
    /// Report history: at most this many records, the oldest dropped first.
    pub history_max_records: u64,
    /// The metrics endpoint: `IP:PORT` to serve OpenMetrics text on (`GET /metrics`), e.g.
    /// `127.0.0.1:9464` (port 0: any free port, see `Daemon::metrics_addr`); empty = off.
    pub metrics_listen: String,
    /// Record every input sample, excitation, status, report, notification and each completed
    /// test's resampled analysis records into MCAP files in `<state-dir>/recordings/`
    /// (Foxglove, Lichtblick; `helmwatch replay` reads them). Needs a state directory.
    pub record: bool,
    /// Most disk space the recordings take, the open segment included [MiB]; the oldest files
    /// are deleted first. 1 to 1000000, at least `recordings-segment-mb`.
    pub recordings_max_mb: u32,
    /// Most recording files kept, the open segment included; 2 to 100000.
    pub recordings_max_files: u32,
    /// A segment is finished (and a new one opened) once it holds this much [MiB]; 1 to 4096.
    pub recordings_segment_mb: u32,
    /// ... or once it has been open this long (wall time) [s]; (0, 604800].
    pub recordings_segment_s: f64,
    /// This daemon's id in the vessels' ownership (`vessels/<v>/fdi/candidate/<id>`): 1 to 64
    /// characters among `A-Z a-z 0-9 - _ .`; empty = `<hostname>-<pid>`. Of daemons started
    /// together for a vessel, the lowest id drives it.
    pub id: String,
    /// How long a daemon listens for the vessels' owners before it decides to drive or stand
    /// by [s]; (0, 10].
    pub claim_s: f64,
    /// How long a standby waits after the driving daemon's token went before it takes the
    /// vessel over [s]: longer than `safety.hold-s` (the old driver's last excitation has
    /// expired, its test is never continued); (0, 600].
    pub takeover_s: f64,
}

impl Default for DaemonConfig {
    fn default() -> Self {
        Self {
            vessels: vec!["self".to_string()],
            queue_capacity: 256,
            tick_s: 0.5,
            stats_period_s: 60.0,
            publish_stats: true,
            shutdown_timeout_s: 5.0,
            state_dir: None,
            history_days: 365.0,
            history_max_records: 1_000_000,
            metrics_listen: String::new(),
            record: false,
            recordings_max_mb: 2048,
            recordings_max_files: 200,
            recordings_segment_mb: 64,
            recordings_segment_s: 3600.0,
            id: String::new(),
            claim_s: 0.5,
            takeover_s: 2.0,
        }
    }
}

impl DaemonConfig {
    /// The daemon's id: `daemon.id`, or `<hostname>-<pid>` (characters outside
    /// `A-Z a-z 0-9 - _ .` replaced by `_`, at most 64).
    pub fn daemon_id(&self) -> String {
        if !self.id.is_empty() {
            return self.id.clone();
        }
        let host = std::fs::read_to_string("/proc/sys/kernel/hostname")
            .ok()
            .or_else(|| std::env::var("HOSTNAME").ok())
            .unwrap_or_default();
        let host: String = host
            .trim()
            .chars()
            .map(|c| {
                if c.is_ascii_alphanumeric() || c == '-' || c == '_' || c == '.' {
                    c
                } else {
                    '_'
                }
            })
            .take(48)
            .collect();
        let host = if host.is_empty() {
            "helmwatch".into()
        } else {
            host
        };
        format!("{host}-{}", std::process::id())
    }

    /// The recordings' bounds in bytes and seconds.
    pub fn recording_limits(&self) -> crate::shells::recording::Limits {
        const MIB: u64 = 1 << 20;
        crate::shells::recording::Limits {
            max_bytes: u64::from(self.recordings_max_mb) * MIB,
            max_files: self.recordings_max_files,
            segment_bytes: u64::from(self.recordings_segment_mb) * MIB,
            segment_s: self.recordings_segment_s,
        }
    }

    /// Checks the section's limits; the error names the key and its allowed range.
    pub fn check(&self) -> Result<(), ConfigError> {
        if self.vessels.is_empty() || self.vessels.len() > 100_000 {
            return Err(fail(
                "daemon.vessels",
                format!("{} names", self.vessels.len()),
                "1 to 100000 vessel names",
            ));
        }
        let mut seen = std::collections::HashSet::new();
        for (i, v) in self.vessels.iter().enumerate() {
            let key = format!("daemon.vessels[{i}]");
            check_vessel_name(&key, v)?;
            if !seen.insert(v.as_str()) {
                return Err(fail(&key, format!("{v:?}"), "each vessel once"));
            }
        }
        check_count("daemon.queue-capacity", self.queue_capacity, 16, 1_000_000)?;
        check_range_open_low("daemon.history-days", self.history_days, 0.0, 36500.0)?;
        if !(1..=100_000_000).contains(&self.history_max_records) {
            return Err(fail(
                "daemon.history-max-records",
                self.history_max_records,
                "integer in [1, 100000000]",
            ));
        }
        if !self.metrics_listen.is_empty()
            && self.metrics_listen.parse::<std::net::SocketAddr>().is_err()
        {
            return Err(fail(
                "daemon.metrics-listen",
                format!("{:?}", self.metrics_listen),
                "\"\" (off) or IP:PORT, port 0 to 65535, e.g. \"127.0.0.1:9464\"",
            ));
        }
        check_count(
            "daemon.recordings-max-mb",
            self.recordings_max_mb,
            1,
            1_000_000,
        )?;
        check_count(
            "daemon.recordings-max-files",
            self.recordings_max_files,
            2,
            100_000,
        )?;
        check_count(
            "daemon.recordings-segment-mb",
            self.recordings_segment_mb,
            1,
            4096.min(self.recordings_max_mb),
        )?;
        check_range_open_low(
            "daemon.recordings-segment-s",
            self.recordings_segment_s,
            0.0,
            604_800.0,
        )?;
        check_range_open_low("daemon.tick-s", self.tick_s, 0.0, 10.0)?;
        if !self.id.is_empty() {
            check_vessel_name("daemon.id", &self.id)?;
        }
        check_range_open_low("daemon.claim-s", self.claim_s, 0.0, 10.0)?;
        check_range_open_low("daemon.takeover-s", self.takeover_s, 0.0, 600.0)?;
        check_range("daemon.stats-period-s", self.stats_period_s, 0.0, 86400.0)?;
        check_range_open_low(
            "daemon.shutdown-timeout-s",
            self.shutdown_timeout_s,
            0.0,
            60.0,
        )?;
        Ok(())
    }
}
