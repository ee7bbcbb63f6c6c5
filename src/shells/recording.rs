//! MCAP recordings of what the daemon saw and did (`[daemon] record = true`), for Foxglove or
//! Lichtblick, and their replay.
//!
//! ## What a file holds
//!
//! One channel per Zenoh key, message encoding `json`, schema encoding `jsonschema` (a real
//! JSON schema per kind of payload, so the viewers know the fields):
//!
//! | channel | payload | schema |
//! |---|---|---|
//! | the input streams' keys (`vessels/<v>/navigation/headingTrue`, ...) | the bytes as received, malformed ones included | `helmwatch.Scalar` / `helmwatch.AutopilotState` |
//! | `vessels/<v>/steering/autopilot/excitation` | every excitation published | `helmwatch.Excitation` |
//! | `vessels/<v>/fdi/status`, `fdi/report`, `notifications/steering/fdi` | as published | `helmwatch.Status`, `.Report`, `.Notification` |
//! | `vessels/<v>/fdi/analysis` (recordings only) | one message per grid point of a completed test's analysis: the resampled heading, rudder and excitation | `helmwatch.AnalysisPoint` |
//! | `vessels/<v>/fdi/rejected` (recordings only) | a rejected input sample: `{"stream", "reason", "len", "head", "suppressed"}`, at most [`rejected::REJECTED_HEAD_BYTES`] of it, at a bounded rate | `helmwatch.Rejected` |
//!
//! The input channels hold the accepted samples only. A rejected one (malformed, oversized,
//! out of range, out of order, duplicate, a time jump) goes to `fdi/rejected` as its reason,
//! its length and its first [`rejected::REJECTED_HEAD_BYTES`] bytes, through a token bucket per stream
//! ([`rejected::REJECTED_BURST`] records, then one every [`rejected::REJECTED_PERIOD_S`] s of wall time); the
//! rest are counted (`suppressed`: how many were left out before this one). So bad input
//! writes at most [`rejected::rejected_bytes_per_hour`] per hour whatever its rate (1.3 MiB/h for the six
//! streams with every byte of every head escaped, about 0.3 MiB/h for text; normal service
//! records about 20 MiB/h), so it can take at most 7 % of the recordings' budget: under a
//! flood that never ends, the accepted inputs, excitations, reports and analysis records are
//! kept as long as with a budget 7 % smaller, and a flood of a minute writes at most 122 KiB. (A
//! replay re-synchronises after a time jump on the accepted samples alone: the rejected ones
//! that counted towards it are not inputs of the recording.)
//!
//! `log_time` and `publish_time` are the sample's ship time `t` in nanoseconds (UNIX time in
//! service; negative times are clamped to 0): a report at its `t_end`, a notification at its
//! report's. Messages are written in the order the daemon handled them, which is the order
//! [`replay::replay_mcap`] feeds them back to a monitor core: same inputs, same order, same reports.
//!
//! ## Files, rotation and bounds
//!
//! Files go to `<state-dir>/recordings/`, named `helmwatch-<UTC start>-<n>.mcap`, the name
//! sorting in time. A segment is written as `<name>.part` and renamed when finished (summary,
//! indexes and statistics written, as the `mcap` writer does by default): at rotation (the
//! segment reached `recordings-segment-mb`, or was open `recordings-segment-s` seconds) and at
//! shutdown. Before a segment opens, the oldest finished files are deleted until at most
//! `recordings-max-files - 1` remain and they plus one full segment fit in `recordings-max-mb`:
//! the directory never holds more than the bound (up to one message over a segment's size).
//! A `.part` left by a crash is renamed `<name>.unfinished.mcap` at start (readable linearly,
//! without a summary) and counts against the bound.
//!
//! Chunks are uncompressed (the `mcap` crate without its zstd and lz4 features).

pub mod message;
pub mod rejected;
pub mod replay;

use message::{ship_ns, Kind};
use std::collections::{BTreeMap, HashMap};
use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};
use std::time::{Instant, SystemTime};

/// The recording's bounds, in bytes and seconds.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Limits {
    /// Most bytes the recordings directory holds.
    pub max_bytes: u64,
    /// Most files it holds (the open segment included), at least 2.
    pub max_files: u32,
    /// A segment is finished once it holds this many bytes.
    pub segment_bytes: u64,
    /// A segment is finished once it was open this long (wall time) [s].
    pub segment_s: f64,
}

/// Why the recording failed.
#[derive(Debug, thiserror::Error)]
pub enum RecordingError {
    /// A file operation failed.
    #[error("recording {path}: {source}")]
    Io {
        /// The file or directory.
        path: String,
        /// The I/O error.
        source: std::io::Error,
    },
    /// The MCAP writer or reader failed.
    #[error("recording {path}: {message}")]
    Mcap {
        /// The file.
        path: String,
        /// The `mcap` crate's message.
        message: String,
    },
}

fn io_err(path: &Path) -> impl FnOnce(std::io::Error) -> RecordingError + '_ {
    move |source| RecordingError::Io {
        path: path.display().to_string(),
        source,
    }
}

fn mcap_err(path: &Path) -> impl FnOnce(mcap::McapError) -> RecordingError + '_ {
    move |e| RecordingError::Mcap {
        path: path.display().to_string(),
        message: e.to_string(),
    }
}

/// One finished file.
#[derive(Debug, Clone, PartialEq)]
pub struct FileStats {
    /// Where it is.
    pub path: PathBuf,
    /// Its size [bytes].
    pub bytes: u64,
    /// Messages per channel (topic).
    pub messages: BTreeMap<String, u64>,
}

/// What a recorder did.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RecorderStats {
    /// Messages written per channel, all segments.
    pub messages: BTreeMap<String, u64>,
    /// The files this recorder finished, oldest first (some may be deleted since).
    pub finished: Vec<FileStats>,
    /// Files deleted to hold the bounds.
    pub deleted: u64,
    /// Failed writes (the message is lost; the segment is abandoned and a new one opened).
    pub errors: u64,
}

/// The open segment.
struct Segment {
    writer: mcap::Writer<BufWriter<File>>,
    part: PathBuf,
    path: PathBuf,
    schemas: HashMap<&'static str, u16>,
    channels: HashMap<String, u16>,
    /// Bytes written so far, estimated (records, message indexes; the summary comes at the
    /// end and is small).
    bytes: u64,
    opened: Instant,
    messages: BTreeMap<String, u64>,
    sequence: u32,
}

/// Writes MCAP segments into a directory within its [`Limits`].
pub struct Recorder {
    dir: PathBuf,
    limits: Limits,
    segment: Option<Segment>,
    /// Segments opened by this recorder (part of the name).
    opened: u64,
    stats: RecorderStats,
}

impl std::fmt::Debug for Recorder {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Recorder")
            .field("dir", &self.dir)
            .field("limits", &self.limits)
            .field("stats", &self.stats)
            .finish_non_exhaustive()
    }
}

/// Bytes one message adds to a file besides its payload: the record (opcode, length,
/// channel, sequence, two times: 31 bytes) and its entry in the chunk's message index (16).
const MESSAGE_OVERHEAD: u64 = 47;

impl Recorder {
    /// A recorder writing into `dir` (created when missing). A `.part` left by a crash is
    /// renamed `<name>.unfinished.mcap`.
    pub fn open(dir: &Path, limits: Limits) -> Result<Self, RecordingError> {
        std::fs::create_dir_all(dir).map_err(io_err(dir))?;
        for entry in std::fs::read_dir(dir).map_err(io_err(dir))? {
            let path = entry.map_err(io_err(dir))?.path();
            if let Some(name) = path.file_name().and_then(|n| n.to_str()) {
                if let Some(stem) = name.strip_suffix(".mcap.part") {
                    let to = dir.join(format!("{stem}.unfinished.mcap"));
                    tracing::warn!(from = %path.display(), to = %to.display(), "an unfinished recording (the daemon stopped without finishing it) is kept");
                    std::fs::rename(&path, &to).map_err(io_err(&path))?;
                }
            }
        }
        Ok(Self {
            dir: dir.to_path_buf(),
            limits,
            segment: None,
            opened: 0,
            stats: RecorderStats::default(),
        })
    }

    /// What it did so far.
    pub fn stats(&self) -> &RecorderStats {
        &self.stats
    }

    /// The finished recordings in the directory, oldest first, with their sizes.
    pub fn files(&self) -> Result<Vec<(PathBuf, u64)>, RecordingError> {
        list(&self.dir)
    }

    /// Writes one message on `topic` at ship time `t` [s]; opens or rotates the segment as
    /// needed. On an error the message is lost, counted, and the segment abandoned (finished
    /// as far as it can be).
    pub fn write(
        &mut self,
        topic: &str,
        kind: Kind,
        t: f64,
        payload: &[u8],
    ) -> Result<(), RecordingError> {
        let r = self.try_write(topic, kind, t, payload);
        if r.is_err() {
            self.stats.errors += 1;
            if let Some(seg) = self.segment.take() {
                let _ = self.close(seg);
            }
        }
        r
    }

    fn try_write(
        &mut self,
        topic: &str,
        kind: Kind,
        t: f64,
        payload: &[u8],
    ) -> Result<(), RecordingError> {
        let full = self.segment.as_ref().is_some_and(|s| {
            s.bytes >= self.limits.segment_bytes
                || s.opened.elapsed().as_secs_f64() >= self.limits.segment_s
        });
        if full {
            self.rotate()?;
        }
        let seg = match &mut self.segment {
            Some(s) => s,
            None => {
                let s = self.open_segment()?;
                self.segment.insert(s)
            }
        };
        let channel_id = match seg.channels.get(topic) {
            Some(&id) => id,
            None => {
                let (name, schema) = kind.schema();
                let schema_id = match seg.schemas.get(name) {
                    Some(&id) => id,
                    None => {
                        let text = serde_json::to_vec(&schema).unwrap_or_default();
                        let id = seg
                            .writer
                            .add_schema(name, "jsonschema", &text)
                            .map_err(mcap_err(&seg.part))?;
                        seg.bytes += text.len() as u64 + name.len() as u64 + 32;
                        seg.schemas.insert(name, id);
                        id
                    }
                };
                let id = seg
                    .writer
                    .add_channel(schema_id, topic, "json", &BTreeMap::new())
                    .map_err(mcap_err(&seg.part))?;
                seg.bytes += topic.len() as u64 + 32;
                seg.channels.insert(topic.to_string(), id);
                id
            }
        };
        let ns = ship_ns(t);
        seg.writer
            .write_to_known_channel(
                &mcap::records::MessageHeader {
                    channel_id,
                    sequence: seg.sequence,
                    log_time: ns,
                    publish_time: ns,
                },
                payload,
            )
            .map_err(mcap_err(&seg.part))?;
        seg.sequence = seg.sequence.wrapping_add(1);
        seg.bytes += payload.len() as u64 + MESSAGE_OVERHEAD;
        *seg.messages.entry(topic.to_string()).or_default() += 1;
        *self.stats.messages.entry(topic.to_string()).or_default() += 1;
        Ok(())
    }

    /// Finishes the open segment (if any); the next message opens a new one.
    pub fn rotate(&mut self) -> Result<(), RecordingError> {
        match self.segment.take() {
            Some(seg) => self.close(seg),
            None => Ok(()),
        }
    }

    /// Finishes the open segment: the file is complete and renamed when this returns.
    pub fn finish(mut self) -> Result<RecorderStats, RecordingError> {
        self.rotate()?;
        Ok(self.stats)
    }

    fn close(&mut self, mut seg: Segment) -> Result<(), RecordingError> {
        seg.writer.finish().map_err(mcap_err(&seg.part))?;
        let file = seg
            .writer
            .into_inner()
            .into_inner()
            .map_err(|e| RecordingError::Io {
                path: seg.part.display().to_string(),
                source: e.into_error(),
            })?;
        file.sync_all().map_err(io_err(&seg.part))?;
        drop(file);
        std::fs::rename(&seg.part, &seg.path).map_err(io_err(&seg.path))?;
        if let Ok(d) = File::open(&self.dir) {
            let _ = d.sync_all();
        }
        let bytes = std::fs::metadata(&seg.path).map(|m| m.len()).unwrap_or(0);
        tracing::info!(file = %seg.path.display(), bytes, "recording finished");
        self.stats.finished.push(FileStats {
            path: seg.path,
            bytes,
            messages: seg.messages,
        });
        Ok(())
    }

    /// Deletes the oldest files until the bounds leave room for one more segment, then opens
    /// it.
    fn open_segment(&mut self) -> Result<Segment, RecordingError> {
        let files = list(&self.dir)?;
        let keep_files = self.limits.max_files.saturating_sub(1) as usize;
        let room = self
            .limits
            .max_bytes
            .saturating_sub(self.limits.segment_bytes);
        let mut total: u64 = files.iter().map(|(_, b)| b).sum();
        let mut count = files.len();
        for (path, bytes) in &files {
            if count <= keep_files && total <= room {
                break;
            }
            std::fs::remove_file(path).map_err(io_err(path))?;
            tracing::info!(file = %path.display(), "recording deleted (recordings-max-files, recordings-max-mb)");
            self.stats.deleted += 1;
            total -= bytes;
            count -= 1;
        }
        self.opened += 1;
        let name = format!("helmwatch-{}-{}", utc_stamp(SystemTime::now()), self.opened);
        let path = self.dir.join(format!("{name}.mcap"));
        let part = self.dir.join(format!("{name}.mcap.part"));
        let file = File::create(&part).map_err(io_err(&part))?;
        let writer = mcap::WriteOptions::new()
            .compression(None)
            .profile("")
            .library(concat!("helmwatch ", env!("CARGO_PKG_VERSION")))
            .create(BufWriter::new(file))
            .map_err(mcap_err(&part))?;
        Ok(Segment {
            writer,
            part,
            path,
            schemas: HashMap::new(),
            channels: HashMap::new(),
            bytes: 64,
            opened: Instant::now(),
            messages: BTreeMap::new(),
            sequence: 0,
        })
    }
}

/// The finished recordings in `dir` (`*.mcap`, unfinished ones included), oldest first.
fn list(dir: &Path) -> Result<Vec<(PathBuf, u64)>, RecordingError> {
    let mut files = Vec::new();
    for entry in std::fs::read_dir(dir).map_err(io_err(dir))? {
        let entry = entry.map_err(io_err(dir))?;
        let path = entry.path();
        if path.extension().is_some_and(|e| e == "mcap") {
            let bytes = entry.metadata().map(|m| m.len()).unwrap_or(0);
            files.push((path, bytes));
        }
    }
    // Names sort in time: `helmwatch-<UTC stamp>-<n>`; `n` breaks ties within a second.
    files.sort_by_key(|a| sort_key(&a.0));
    Ok(files)
}

fn sort_key(path: &Path) -> (String, u64) {
    let name = path
        .file_name()
        .and_then(|n| n.to_str())
        .unwrap_or_default();
    let stem = name.split('.').next().unwrap_or_default();
    match stem.rsplit_once('-') {
        Some((head, n)) => (head.to_string(), n.parse().unwrap_or(0)),
        None => (stem.to_string(), 0),
    }
}

/// `YYYYMMDDTHHMMSSZ` of `at` (UTC).
fn utc_stamp(at: SystemTime) -> String {
    let secs = at
        .duration_since(SystemTime::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs());
    let (days, rem) = (secs / 86_400, secs % 86_400);
    // Civil date from days since 1970-01-01 (H. Hinnant's algorithm).
    let z = days as i64 + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i64::from(m <= 2);
    format!(
        "{y:04}{m:02}{d:02}T{:02}{:02}{:02}Z",
        rem / 3600,
        rem / 60 % 60,
        rem % 60
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use helmwatch_core::wire::Stream;

    #[test]
    fn utc_stamps_are_civil_dates() {
        let at = |s: u64| SystemTime::UNIX_EPOCH + std::time::Duration::from_secs(s);
        assert_eq!(utc_stamp(at(0)), "19700101T000000Z");
        // 2000-02-29 12:34:56 UTC = 951827696 (a leap day).
        assert_eq!(utc_stamp(at(951_827_696)), "20000229T123456Z");
        // 2026-11-23 16:18:42 UTC = 1795450722.
        assert_eq!(utc_stamp(at(1_795_450_722)), "20261123T161842Z");
    }

    fn temp(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("helmwatch-rec-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        d
    }

    #[test]
    fn rotation_deletes_the_oldest_and_holds_the_bounds() {
        let dir = temp("rotation");
        let limits = Limits {
            max_bytes: 40_000,
            max_files: 5,
            segment_bytes: 4_000,
            segment_s: 3600.0,
        };
        let mut rec = Recorder::open(&dir, limits).unwrap();
        let topic = "vessels/self/navigation/headingTrue";
        let n_messages = 2000u64;
        for i in 0..n_messages {
            let t = 1.7e9 + i as f64 * 0.1;
            let payload = format!("{{\"t\":{t},\"value\":{}}}", (i % 60) as f64 * 0.1);
            rec.write(topic, Kind::Input(Stream::Heading), t, payload.as_bytes())
                .unwrap();
            let files = rec.files().unwrap();
            // Finished files plus the open one stay within the count bound, and the finished
            // ones leave room for the open segment.
            assert!(files.len() < limits.max_files as usize, "{files:?}");
            let total: u64 = files.iter().map(|f| f.1).sum();
            assert!(total <= limits.max_bytes - limits.segment_bytes, "{total}");
        }
        let stats = rec.finish().unwrap();
        let files = list(&dir).unwrap();
        assert_eq!(files.len(), limits.max_files as usize);
        assert!(files.iter().map(|f| f.1).sum::<u64>() <= limits.max_bytes);
        // Each segment: about 4000 bytes of ~75-byte messages, ~50 per file; 2000 messages make
        // ~40 segments, all but the last five deleted.
        let made = stats.finished.len() as u64;
        assert!((30..=50).contains(&made), "{made} segments");
        assert_eq!(stats.deleted, made - limits.max_files as u64);
        assert_eq!(stats.messages[topic], n_messages);
        assert_eq!(stats.errors, 0);
        // The files kept are the newest, finished (no `.part`), each readable with its summary
        // statistics equal to what the recorder counted for it; their log times follow on.
        let kept: Vec<_> = stats.finished[stats.finished.len() - 5..].to_vec();
        assert_eq!(
            kept.iter().map(|f| f.path.clone()).collect::<Vec<_>>(),
            files.iter().map(|f| f.0.clone()).collect::<Vec<_>>()
        );
        let mut last_ns = 0;
        for f in &kept {
            assert!(f.bytes <= limits.segment_bytes + 2_000, "{f:?}");
            let bytes = std::fs::read(&f.path).unwrap();
            let summary = mcap::read::Summary::read(&bytes).unwrap().unwrap();
            let s = summary.stats.unwrap();
            assert_eq!(s.message_count, f.messages[topic]);
            assert!(s.message_start_time > last_ns);
            last_ns = s.message_end_time;
        }
        assert_eq!(last_ns, ship_ns(1.7e9 + (n_messages - 1) as f64 * 0.1));
        assert!(std::fs::read_dir(&dir).unwrap().all(|e| !e
            .unwrap()
            .path()
            .to_string_lossy()
            .ends_with(".part")));
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_part_left_by_a_crash_is_kept_as_unfinished() {
        let dir = temp("crash");
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join("helmwatch-20260101T000000Z-1.mcap.part"), b"x").unwrap();
        let rec = Recorder::open(
            &dir,
            Limits {
                max_bytes: 1 << 20,
                max_files: 3,
                segment_bytes: 1 << 16,
                segment_s: 60.0,
            },
        )
        .unwrap();
        let files = rec.files().unwrap();
        assert_eq!(files.len(), 1);
        assert!(files[0]
            .0
            .ends_with("helmwatch-20260101T000000Z-1.unfinished.mcap"));
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
