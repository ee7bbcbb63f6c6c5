//! Replay: the monitor core over a recording, in the recording's order, without a clock.
//!
//! A recording is JSON lines `{"key": "vessels/<v>/<path>", "payload": {...}}` (the output of
//! `helmwatch simulate` and of `helmwatch ship --record`), or the daemon's MCAP recordings
//! (read in `shells::recording`, which feeds the same [`Replayer`] message by message). Each line on an input stream key is
//! decoded and fed to the core of its vessel (one core per vessel found, created on first
//! sight); lines on other keys (excitations, reports) are skipped. After each sample every
//! output is handed to the caller. Silence is noticed on the recording's own clock: after a
//! non-heading sample, [`Monitor::handle_timeout`] is called with that sample's `t`.
//!
//! A recording made without a daemon (`simulate`) has no excitation in it, so tests started
//! by the scheduler see no response and abort (HBT: no limit cycle): that is the truth about
//! such a recording. A recording of a live session (`ship --record`) replays the daemon's
//! tests: same configuration, same inputs, same reports.

use crate::monitor::config::CoreConfig;
use crate::monitor::{Monitor, Output};
use crate::wire::{self, Keys, RecordLine};
use std::collections::HashMap;
use std::io::BufRead;

/// Most vessels one replay creates cores for (a hostile file cannot exhaust memory).
pub const MAX_VESSELS: usize = 10_000;

/// Why a replay stopped.
#[derive(Debug, thiserror::Error)]
pub enum ReplayError {
    /// Reading the recording failed.
    #[error("reading the recording: {0}")]
    Io(#[from] std::io::Error),
    /// The estimator's model files are missing, invalid, or not for this configuration.
    #[error(transparent)]
    Estimator(#[from] crate::estimator::model::ModelError),
    /// More vessels than [`MAX_VESSELS`].
    #[error("more than {MAX_VESSELS} vessels in the recording")]
    TooManyVessels,
}

/// Counts of a replay.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct ReplaySummary {
    /// Lines read.
    pub lines: u64,
    /// Lines that are not a `{"key", "payload"}` object.
    pub bad_lines: u64,
    /// Lines on keys that are not input streams (skipped).
    pub skipped: u64,
    /// Samples rejected by the cores (malformed payloads included).
    pub rejected: u64,
    /// Reports produced.
    pub reports: u64,
    /// Vessels found.
    pub vessels: u64,
}

/// Replays `reader` through one core per vessel; `on_output(vessel, output)` sees every
/// output except excitations (there is no autopilot to send them to).
pub fn replay(
    cfg: &CoreConfig,
    reader: impl BufRead,
    on_output: impl FnMut(&str, &Output),
) -> Result<ReplaySummary, ReplayError> {
    replay_fleet(cfg, &[], reader, on_output)
}

/// As [`replay`], with a configuration of their own for the vessels named in `own` (ships
/// of another class); every other vessel gets `cfg`.
pub fn replay_fleet(
    cfg: &CoreConfig,
    own: &[(String, CoreConfig)],
    reader: impl BufRead,
    mut on_output: impl FnMut(&str, &Output),
) -> Result<ReplaySummary, ReplayError> {
    let mut r = Replayer::new(cfg, own)?;
    for line in reader.lines() {
        let line = line?;
        if line.trim().is_empty() {
            r.sum.lines += 1;
            continue;
        }
        match serde_json::from_str::<RecordLine>(&line) {
            Ok(rec) => r.feed(&rec.key, Payload::Value(rec.payload), &mut on_output)?,
            Err(_) => {
                r.sum.lines += 1;
                r.sum.bad_lines += 1;
            }
        }
    }
    Ok(r.finish())
}

/// A sample's payload as a recording holds it.
#[derive(Debug)]
pub enum Payload<'a> {
    /// Already parsed (JSON lines).
    Value(serde_json::Value),
    /// The bytes as received (an MCAP recording), decoded as the daemon decodes them.
    Bytes(&'a [u8]),
}

/// What both models loaded and the multisine designed once per configuration share.
type Parts = (
    Option<crate::dsp::multisine::Multisine>,
    Option<std::sync::Arc<crate::estimator::Estimator>>,
);

/// The replay engine: one core per vessel, fed one recorded publication at a time in the
/// recording's order. [`replay_fleet`] drives it over JSON lines; an MCAP reader (in the
/// shells, where the `mcap` crate is) drives it over an MCAP file's messages.
#[derive(Debug)]
pub struct Replayer {
    cfg: CoreConfig,
    parts: Parts,
    own: HashMap<String, (CoreConfig, Parts)>,
    cores: HashMap<String, (Keys, Monitor)>,
    sum: ReplaySummary,
}

impl Replayer {
    /// Loads the models and designs the multisine once per configuration (`cfg` for every
    /// vessel not named in `own`).
    pub fn new(cfg: &CoreConfig, own: &[(String, CoreConfig)]) -> Result<Self, ReplayError> {
        // A failed design is the monitor's to report, per test.
        let parts = |c: &CoreConfig| -> Result<Parts, ReplayError> {
            Ok((
                Monitor::design_multisine(c).ok(),
                crate::estimator::Estimator::from_config(c)?,
            ))
        };
        Ok(Self {
            parts: parts(cfg)?,
            cfg: cfg.clone(),
            own: own
                .iter()
                .map(|(v, c)| Ok((v.clone(), (c.clone(), parts(c)?))))
                .collect::<Result<HashMap<_, _>, ReplayError>>()?,
            cores: HashMap::new(),
            sum: ReplaySummary::default(),
        })
    }

    /// One recorded publication on `key` (a line or a message): fed to its vessel's core if
    /// it is an input stream, skipped otherwise; `on_output(vessel, output)` then sees every
    /// output except excitations.
    pub fn feed(
        &mut self,
        key: &str,
        payload: Payload<'_>,
        on_output: &mut impl FnMut(&str, &Output),
    ) -> Result<(), ReplayError> {
        let sum = &mut self.sum;
        sum.lines += 1;
        let Some(vessel) = crate::wire::vessel_key::split(key).map(|k| k.vessel) else {
            sum.skipped += 1;
            return Ok(());
        };
        if !self.cores.contains_key(vessel) {
            if crate::config::check_vessel_name("vessel", vessel).is_err() {
                sum.skipped += 1;
                return Ok(());
            }
            if self.cores.len() >= MAX_VESSELS {
                return Err(ReplayError::TooManyVessels);
            }
            let (c, (ms, est)) = match self.own.get(vessel) {
                Some((c, p)) => (c, p),
                None => (&self.cfg, &self.parts),
            };
            self.cores.insert(
                vessel.to_string(),
                (
                    Keys::new(vessel),
                    Monitor::with_parts(c, vessel, ms.clone(), est.clone()),
                ),
            );
        }
        let Some((keys, monitor)) = self.cores.get_mut(vessel) else {
            return Ok(());
        };
        let Some(stream) = keys.stream_of(key) else {
            sum.skipped += 1;
            return Ok(());
        };
        let decoded = match payload {
            Payload::Value(v) => wire::decode_value(stream, v).map_err(|_| ()),
            Payload::Bytes(b) => wire::decode(stream, b).map_err(|_| ()),
        };
        match decoded {
            Err(()) => {
                monitor.count_malformed(stream);
                sum.rejected += 1;
            }
            Ok(input) => {
                let t = input.t();
                let heading = stream == wire::Stream::Heading;
                if monitor.handle_input(input).is_err() {
                    sum.rejected += 1;
                } else if !heading {
                    monitor.handle_timeout(t);
                }
            }
        }
        while let Some(out) = monitor.poll_output() {
            match &out {
                Output::Excitation(_) => continue,
                Output::Report(_) => sum.reports += 1,
                _ => {}
            }
            on_output(vessel, &out);
        }
        Ok(())
    }

    /// The counts of the replay so far.
    pub fn summary(&self) -> &ReplaySummary {
        &self.sum
    }

    /// Counts a line or message that is not a recorded publication.
    pub fn bad_record(&mut self) {
        self.sum.lines += 1;
        self.sum.bad_lines += 1;
    }

    /// Ends the replay: its counts.
    pub fn finish(mut self) -> ReplaySummary {
        self.sum.vessels = self.cores.len() as u64;
        self.sum
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::Scenario;

    #[test]
    fn replay_of_a_simulation_counts_and_skips() {
        let mut cfg = CoreConfig::default();
        cfg.scheduler.steady_time_s = 30.0;
        let sim = crate::sim::config::SimConfig::default();
        let mut buf = Vec::new();
        crate::sim::record(&sim, &Scenario::nominal(&sim, 3), 300.0, "self", &mut buf).unwrap();
        buf.extend_from_slice(b"not json\n{\"key\": \"vessels/self/navigation/headingTrue\", \"payload\": {\"t\": 1.0}}\n{\"key\": \"elsewhere\", \"payload\": {}}\n");
        let mut statuses = 0;
        let sum = replay(&cfg, &buf[..], |v, o| {
            assert_eq!(v, "self");
            if matches!(o, Output::Status(_)) {
                statuses += 1;
            }
        })
        .unwrap();
        assert_eq!(sum.vessels, 1);
        assert_eq!(sum.bad_lines, 1);
        assert_eq!(sum.skipped, 1);
        assert!(sum.rejected >= 1, "{sum:?}");
        assert!(
            statuses >= 1,
            "the scheduler started a test on the steady ship"
        );
    }
}
