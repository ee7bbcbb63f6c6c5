//! What the NMEA decoder accepts: the time source, the heading and speed sentences, the
//! talkers and sources, the value limits (the decoding part of `[bridge]`).

use super::framing::valid_talker;
use crate::config::{check_count, check_range_open_low, fail, ConfigError};
use serde::{Deserialize, Serialize};

/// Where a sample's `t` comes from.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq, Eq, Default)]
#[serde(rename_all = "kebab-case")]
pub enum TimeSource {
    /// The time of reception (the bridge's clock, UNIX seconds).
    #[default]
    Receive,
    /// The tag block's `c:` in UNIX seconds (NMEA 0183 v4 tag blocks); lines without it are
    /// rejected (`no_time`).
    TagBlockS,
    /// The tag block's `c:` in milliseconds (some IEC 61162-450 senders; the simulated ship).
    TagBlockMs,
    /// The time of reception plus the offset to UTC from the latest ZDA; lines before the
    /// first valid ZDA are rejected (`no_time`).
    Zda,
}

/// Which sentence gives the heading (one source per stream: two would interleave).
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq, Eq, Default)]
#[serde(rename_all = "lowercase")]
pub enum HeadingSentence {
    /// HDT, heading true (a gyro compass).
    #[default]
    Hdt,
    /// HDG, magnetic sensor heading with deviation and variation.
    Hdg,
    /// THS, true heading and status (gyros and INS that send it instead of HDT); only mode
    /// `A` is a heading.
    Ths,
}

/// Which sentence gives the speed through water.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq, Eq, Default)]
#[serde(rename_all = "lowercase")]
pub enum SpeedSentence {
    /// VHW, water speed and heading.
    #[default]
    Vhw,
    /// VBW, dual ground/water speed (longitudinal water speed).
    Vbw,
}

/// What the decoder accepts (the decoding part of `[bridge]`).
#[derive(Debug, Clone, PartialEq)]
pub struct DecodeOptions {
    /// Where `t` comes from.
    pub time_source: TimeSource,
    /// The heading sentence.
    pub heading: HeadingSentence,
    /// The speed sentence.
    pub speed: SpeedSentence,
    /// Accepted talkers (e.g. `HE`, `AG`); empty: any.
    pub talkers: Vec<String>,
    /// Accepted IEC 61162-450 sources (tag block `s:`); empty: any, and lines without one.
    pub sources: Vec<String>,
    /// Largest |rudder angle| accepted [deg].
    pub max_rudder_deg: f64,
    /// Largest |speed through water| accepted [m/s].
    pub max_speed_mps: f64,
    /// Tag-block time: a step larger than this from a stream's last accepted time is a jump
    /// [s] (as the daemon's `input.time-jump-s`).
    pub time_jump_s: f64,
    /// Tag-block time: consecutive samples of a new timeline that re-synchronise a stream on
    /// it (as the daemon's `input.resync-samples`).
    pub resync_samples: u32,
}

impl Default for DecodeOptions {
    fn default() -> Self {
        Self {
            time_source: TimeSource::Receive,
            heading: HeadingSentence::Hdt,
            speed: SpeedSentence::Vhw,
            talkers: Vec::new(),
            sources: Vec::new(),
            max_rudder_deg: 45.0,
            max_speed_mps: 30.0,
            time_jump_s: 60.0,
            resync_samples: 5,
        }
    }
}

impl DecodeOptions {
    /// Checks the limits; `section` names the table (`bridge`).
    pub fn check(&self, section: &str) -> Result<(), ConfigError> {
        check_range_open_low(
            &format!("{section}.max-rudder-deg"),
            self.max_rudder_deg,
            0.0,
            90.0,
        )?;
        check_range_open_low(
            &format!("{section}.max-speed-mps"),
            self.max_speed_mps,
            0.0,
            100.0,
        )?;
        check_range_open_low(
            &format!("{section}.time-jump-s"),
            self.time_jump_s,
            0.0,
            86400.0,
        )?;
        check_count(
            &format!("{section}.resync-samples"),
            self.resync_samples,
            2,
            1000,
        )?;
        for (i, t) in self.talkers.iter().enumerate() {
            if !valid_talker(t.as_bytes()) {
                return Err(fail(
                    &format!("{section}.talkers[{i}]"),
                    format!("{t:?}"),
                    "two upper-case letters or digits, e.g. \"HE\"",
                ));
            }
        }
        for (i, s) in self.sources.iter().enumerate() {
            if s.is_empty() || s.len() > 32 || !s.bytes().all(|b| b.is_ascii_alphanumeric()) {
                return Err(fail(
                    &format!("{section}.sources[{i}]"),
                    format!("{s:?}"),
                    "1 to 32 letters or digits, e.g. \"GP0001\"",
                ));
            }
        }
        Ok(())
    }
}
