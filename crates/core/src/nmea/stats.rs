//! Why the NMEA decoder turned a line away, and its counters.

use crate::wire::Stream;

/// Why a line gave no sample.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Reject {
    /// Longer than [`super::MAX_LINE_BYTES`] (or than the `nmea` crate's 102-character sentence).
    TooLong,
    /// Not `$TTSSS,...*hh` of printable ASCII: truncated, no checksum, garbage.
    Framing,
    /// The checksum does not match.
    Checksum,
    /// A tag block that is not `\...*hh\` with a matching checksum, or a bad `c:`.
    TagBlock,
    /// A datagram whose IEC 61162-450 header is not `UdPbC` (counted once per datagram).
    Header,
    /// A talker that is not two upper-case letters or digits, or not in `talkers`.
    Talker,
    /// A tag-block source not in `sources`.
    Source,
    /// A status field says the value is invalid (V), or is empty.
    Status,
    /// The value's field is empty (or, for HDG, no variation).
    NoValue,
    /// A field that does not parse (a number, a unit letter, a mode).
    BadField,
    /// A value outside its range (heading [0, 360], |rudder| `max-rudder-deg`, speed).
    OutOfRange,
    /// The configured time source has no time for this line (no `c:`, no ZDA yet).
    NoTime,
    /// A tag-block time that jumps ahead or back of its stream's timeline by more than
    /// `time-jump-s` (until `resync-samples` of them make a timeline of their own).
    TimeJump,
}

impl Reject {
    /// Every reason, in the order of the counters.
    pub const ALL: [Reject; 13] = [
        Reject::TooLong,
        Reject::Framing,
        Reject::Checksum,
        Reject::TagBlock,
        Reject::Header,
        Reject::Talker,
        Reject::Source,
        Reject::Status,
        Reject::NoValue,
        Reject::BadField,
        Reject::OutOfRange,
        Reject::NoTime,
        Reject::TimeJump,
    ];

    /// The reason's name in `bridge/stats` and the metrics.
    pub fn name(self) -> &'static str {
        match self {
            Reject::TooLong => "too_long",
            Reject::Framing => "framing",
            Reject::Checksum => "checksum",
            Reject::TagBlock => "tag_block",
            Reject::Header => "header",
            Reject::Talker => "talker",
            Reject::Source => "source",
            Reject::Status => "status",
            Reject::NoValue => "no_value",
            Reject::BadField => "bad_field",
            Reject::OutOfRange => "out_of_range",
            Reject::NoTime => "no_time",
            Reject::TimeJump => "time_jump",
        }
    }

    pub(super) fn index(self) -> usize {
        Reject::ALL.iter().position(|r| *r == self).unwrap_or(0)
    }
}

/// The decoder's counters (what `vessels/<v>/bridge/stats` publishes).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct DecodeStats {
    /// Datagrams looked at.
    pub datagrams: u64,
    /// Lines looked at (a datagram's lines, a stream's lines; empty lines are not counted).
    pub lines: u64,
    /// Lines that gave one or more samples, or a ZDA time fix.
    pub used: u64,
    /// Valid sentences the bridge does not use (other types, proprietary, `!` encapsulation,
    /// the heading or speed sentence not selected).
    pub ignored: u64,
    /// Samples made, by [`Stream::index`].
    pub samples: [u64; 6],
    /// Lines rejected, by [`Reject::ALL`] order (a bad datagram header counts once).
    pub rejected: [u64; Reject::ALL.len()],
}

impl DecodeStats {
    /// Rejections for `r`.
    pub fn rejected(&self, r: Reject) -> u64 {
        self.rejected[r.index()]
    }
    /// Every rejection.
    pub fn rejected_total(&self) -> u64 {
        self.rejected.iter().sum()
    }
    /// The counters as a JSON object: `{"datagrams", "lines", "used", "ignored",
    /// "samples": {stream: n}, "rejected": {reason: n}}` (every reason, zeros included).
    pub fn to_json(&self) -> serde_json::Value {
        let samples: serde_json::Map<String, serde_json::Value> = Stream::BY_INDEX
            .iter()
            .filter(|s| **s != Stream::DesignDisplacement)
            .map(|s| (s.name().to_string(), self.samples[s.index()].into()))
            .collect();
        let rejected: serde_json::Map<String, serde_json::Value> = Reject::ALL
            .iter()
            .map(|r| (r.name().to_string(), self.rejected(*r).into()))
            .collect();
        serde_json::json!({
            "datagrams": self.datagrams,
            "lines": self.lines,
            "used": self.used,
            "ignored": self.ignored,
            "samples": samples,
            "rejected": rejected,
        })
    }
}
