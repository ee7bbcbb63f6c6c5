//! NMEA 0183 (IEC 61162-1) and IEC 61162-450 in: bytes to the contract's input samples,
//! without any I/O.
//!
//! A [`Decoder`] turns a UDP datagram ([`Decoder::datagram`]) or one line of a byte stream
//! ([`Decoder::line`], lines cut by a [`LineBuffer`]) into [`Input`] samples of one vessel, in
//! the contract's units, and counts every line it does not turn into a sample by
//! [`Reject`] reason. Time is passed in (`recv_s`, the time of reception); the decoder keeps
//! no clock.
//!
//! | sentence | stream | value |
//! |---|---|---|
//! | HDT | heading | heading true [deg] -> [rad] in [0, 2 pi) (when `heading = "hdt"`) |
//! | HDG | heading | magnetic sensor heading + deviation + variation (E positive) -> true [rad] (when `heading = "hdg"`); no variation, no true heading |
//! | RSA | rudder | starboard (or single) rudder when its status is A, else the port rudder when its status is A; negative = bow to port [deg] -> [rad] |
//! | VHW | speed | speed through water [kn] -> [m/s] (the km/h field when the knots field is empty) (when `speed = "vhw"`) |
//! | VBW | speed | longitudinal water speed [kn] -> [m/s] when the water status is A (when `speed = "vbw"`) |
//! | HTD | autopilot state, target | steering mode S or H -> `auto`, T -> `route`, M -> `standby`, R -> `directControl`; override A -> `standby`; heading-to-steer [deg] -> [rad] when the heading reference is T |
//! | ZDA | - | sets the UTC offset of the receive clock (`time-source = "zda"`) |
//!
//! Framing, the checksum and the sentences the `nmea` crate parses (HDT, VHW, ZDA) go through
//! that crate; HDG, RSA, VBW and HTD are parsed here from the crate's data field (the crate
//! has no parser for them). The talker is not looked at (any two upper-case letters or
//! digits) unless `talkers` lists the accepted ones.
//!
//! Time of a sample ([`TimeSource`]): the time of reception; the tag block's `c:` (UNIX
//! seconds, or milliseconds); or the time of reception plus the offset to UTC that the last
//! ZDA gave.
//!
//! Invariants: a line longer than [`MAX_LINE_BYTES`] is never looked into; the decoder holds
//! no per-line state (its memory does not grow with its input); a [`LineBuffer`] never holds
//! more than [`MAX_LINE_BYTES`] bytes; every line is counted exactly once: as a sample
//! source (`used`), `ignored` (a sentence the bridge does not use), or rejected by reason.

use crate::angle::{deg, wrap_2pi};
use crate::config::{check_range_open_low, fail, ConfigError};
use crate::wire::{Input, Scalar, StateValue, Stream};
use serde::{Deserialize, Serialize};

mod encode;
mod lines;
pub use encode::{datagram, sentence, tag_block, tag_time_ms, tick_sentences};
pub use lines::{Line, LineBuffer};

/// Metres per second in one knot.
pub const KNOT_MPS: f64 = 1852.0 / 3600.0;
/// Metres per second in one km/h.
pub const KMH_MPS: f64 = 1.0 / 3.6;
/// The IEC 61162-450 header of a datagram of sentences.
pub const UDPBC: &[u8; 6] = b"UdPbC\0";
/// The longest line looked into [bytes]: a tag block and a sentence (the sentence itself at
/// most the `nmea` crate's 102 characters; IEC 61162-1 allows 82).
pub const MAX_LINE_BYTES: usize = 512;

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

/// Why a line gave no sample.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Reject {
    /// Longer than [`MAX_LINE_BYTES`] (or than the `nmea` crate's 102-character sentence).
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
}

impl Reject {
    /// Every reason, in the order of the counters.
    pub const ALL: [Reject; 12] = [
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
        }
    }

    fn index(self) -> usize {
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
    pub rejected: [u64; 12],
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

/// One vessel's NMEA decoder: options, the ZDA offset, counters. See the module doc.
#[derive(Debug, Clone)]
pub struct Decoder {
    opts: DecodeOptions,
    /// UTC minus the receive clock at the latest valid ZDA [s] (`time-source = "zda"`).
    zda_offset_s: Option<f64>,
    stats: DecodeStats,
}

/// What a line's tag block says.
#[derive(Debug, Default)]
struct Tags<'a> {
    /// `c:` as written (an integer).
    time: Option<i64>,
    /// `s:`.
    source: Option<&'a str>,
}

/// A line's outcome before counting.
enum Outcome {
    /// Samples were pushed (or a time fix taken).
    Used,
    /// A valid sentence not used.
    Ignored,
}

impl Decoder {
    /// A decoder with `opts` (checked by the configuration).
    pub fn new(opts: DecodeOptions) -> Self {
        Self {
            opts,
            zda_offset_s: None,
            stats: DecodeStats::default(),
        }
    }

    /// The counters so far.
    pub fn stats(&self) -> &DecodeStats {
        &self.stats
    }

    /// A UDP datagram received at `recv_s` [UNIX s]: IEC 61162-450 (`UdPbC\0`, then lines)
    /// or bare lines. Samples are appended to `out` in the order of the lines.
    pub fn datagram(&mut self, bytes: &[u8], recv_s: f64, out: &mut Vec<Input>) {
        self.stats.datagrams += 1;
        let body = if bytes.len() >= UDPBC.len() && bytes[UDPBC.len() - 1] == 0 {
            if bytes.starts_with(UDPBC) {
                &bytes[UDPBC.len()..]
            } else {
                // Another IEC 61162-450 header (binary image, retransmittable binary...).
                self.reject(Reject::Header);
                return;
            }
        } else {
            bytes
        };
        for line in body.split(|b| *b == b'\n') {
            self.line(line, recv_s, out);
        }
    }

    /// One line (with or without its `\r`; an empty line is skipped uncounted) received at
    /// `recv_s` [UNIX s]; samples are appended to `out`.
    pub fn line(&mut self, line: &[u8], recv_s: f64, out: &mut Vec<Input>) {
        let line = line.strip_suffix(b"\r").unwrap_or(line);
        if line.is_empty() {
            return;
        }
        self.stats.lines += 1;
        let before = out.len();
        match self.decode(line, recv_s, out) {
            Ok(Outcome::Used) => {
                self.stats.used += 1;
                for i in &out[before..] {
                    self.stats.samples[i.stream().index()] += 1;
                }
            }
            Ok(Outcome::Ignored) => self.stats.ignored += 1,
            Err(r) => {
                out.truncate(before);
                self.reject(r);
            }
        }
    }

    fn reject(&mut self, r: Reject) {
        self.stats.rejected[r.index()] += 1;
    }

    fn decode(
        &mut self,
        line: &[u8],
        recv_s: f64,
        out: &mut Vec<Input>,
    ) -> Result<Outcome, Reject> {
        if line.len() > MAX_LINE_BYTES {
            return Err(Reject::TooLong);
        }
        if !line.iter().all(|b| (0x20..0x7f).contains(b)) {
            return Err(Reject::Framing);
        }
        // Printable ASCII: a valid str.
        let text = std::str::from_utf8(line).map_err(|_| Reject::Framing)?;
        let (tags, sentence) = split_tag_block(text)?;
        if !self.opts.sources.is_empty()
            && !tags
                .source
                .is_some_and(|s| self.opts.sources.iter().any(|x| x == s))
        {
            return Err(Reject::Source);
        }
        check_framing(sentence)?;
        if sentence.starts_with('!') || sentence.as_bytes().get(1) == Some(&b'P') {
            // Encapsulation (AIS) and proprietary sentences: valid, not ours.
            return Ok(Outcome::Ignored);
        }
        if sentence.len() > nmea::SENTENCE_MAX_LEN {
            return Err(Reject::TooLong);
        }
        let talker = &sentence.as_bytes()[1..3];
        let parsed = match nmea::parse_nmea_sentence(sentence) {
            Ok(p) => p,
            // Framing was checked above: what the crate refuses is a sentence type it does
            // not know (e.g. `$IIXYZ`) - unless the checksum is wrong, which is checked first.
            Err(_) => {
                return if framing_checksum_ok(sentence) {
                    Ok(Outcome::Ignored)
                } else {
                    Err(Reject::Checksum)
                };
            }
        };
        if parsed.checksum != parsed.calc_checksum() {
            return Err(Reject::Checksum);
        }
        if !valid_talker(talker)
            || (!self.opts.talkers.is_empty()
                && !self.opts.talkers.iter().any(|t| t.as_bytes() == talker))
        {
            return Err(Reject::Talker);
        }
        use nmea::SentenceType as S;
        let kind = parsed.message_id;
        let wanted = match kind {
            S::HDT => self.opts.heading == HeadingSentence::Hdt,
            S::HDG => self.opts.heading == HeadingSentence::Hdg,
            S::VHW => self.opts.speed == SpeedSentence::Vhw,
            S::VBW => self.opts.speed == SpeedSentence::Vbw,
            S::RSA | S::HTD => true,
            S::ZDA => self.opts.time_source == TimeSource::Zda,
            _ => false,
        };
        if !wanted {
            return Ok(Outcome::Ignored);
        }
        if kind == S::ZDA {
            let z = nmea::sentences::parse_zda(parsed).map_err(|_| Reject::BadField)?;
            let utc = z.utc_date_time().ok_or(Reject::NoValue)?;
            let utc_s = utc.and_utc().timestamp_micros() as f64 * 1e-6;
            self.zda_offset_s = Some(utc_s - recv_s);
            return Ok(Outcome::Used);
        }
        let data = parsed.data;
        // The crate reads numbers with Rust's parser, which takes `inf`, `NaN` and `1e3`:
        // its sentences' numeric fields are held to plain decimals first, as ours are.
        match kind {
            S::HDT => plain_numbers(data, &[0])?,
            S::VHW => plain_numbers(data, &[0, 2, 4, 6])?,
            _ => {}
        }
        // The value first (its reasons say more about the instrument than a missing time).
        let value = match kind {
            S::HDT => {
                let h = nmea::sentences::parse_hdt(parsed).map_err(|_| Reject::BadField)?;
                Value::Heading(heading_rad(f64::from(h.heading.ok_or(Reject::NoValue)?))?)
            }
            S::HDG => Value::Heading(hdg(data)?),
            S::VHW => {
                let v = nmea::sentences::parse_vhw(parsed).map_err(|_| Reject::BadField)?;
                let mps = match (v.relative_speed_knots, v.relative_speed_kmph) {
                    (Some(kn), _) => kn * KNOT_MPS,
                    (None, Some(kmh)) => kmh * KMH_MPS,
                    (None, None) => return Err(Reject::NoValue),
                };
                Value::Speed(self.speed(mps, false)?)
            }
            S::VBW => Value::Speed(self.vbw(data)?),
            S::RSA => Value::Rudder(self.rsa(data)?),
            S::HTD => {
                let (state, target) = htd(data)?;
                Value::Autopilot(state, target)
            }
            _ => return Ok(Outcome::Ignored),
        };
        let t = self.time(&tags, recv_s)?;
        let sc = |value: f64| Scalar { t, value };
        match value {
            Value::Heading(v) => out.push(Input::Heading(sc(v))),
            Value::Rudder(v) => out.push(Input::Rudder(sc(v))),
            Value::Speed(v) => out.push(Input::Speed(sc(v))),
            Value::Autopilot(state, target) => {
                out.push(Input::AutopilotState(StateValue {
                    t,
                    value: state.to_string(),
                }));
                if let Some(v) = target {
                    out.push(Input::TargetHeading(sc(v)));
                }
            }
        }
        Ok(Outcome::Used)
    }

    fn time(&self, tags: &Tags<'_>, recv_s: f64) -> Result<f64, Reject> {
        match self.opts.time_source {
            TimeSource::Receive => Ok(recv_s),
            TimeSource::TagBlockS => tags.time.map(|c| c as f64).ok_or(Reject::NoTime),
            TimeSource::TagBlockMs => tags.time.map(|c| c as f64 / 1000.0).ok_or(Reject::NoTime),
            TimeSource::Zda => self.zda_offset_s.map(|o| recv_s + o).ok_or(Reject::NoTime),
        }
    }

    fn speed(&self, mps: f64, signed: bool) -> Result<f64, Reject> {
        let lo = if signed {
            -self.opts.max_speed_mps
        } else {
            0.0
        };
        if mps.is_finite() && (lo..=self.opts.max_speed_mps).contains(&mps) {
            Ok(mps)
        } else {
            Err(Reject::OutOfRange)
        }
    }

    /// VBW: longitudinal water speed [kn], transverse, status (A valid), ground speeds...
    fn vbw(&self, data: &str) -> Result<f64, Reject> {
        let f: Vec<&str> = data.split(',').collect();
        if f.len() < 6 {
            return Err(Reject::BadField);
        }
        if f[2] != "A" {
            return Err(Reject::Status);
        }
        let kn = number(f[0])?.ok_or(Reject::NoValue)?;
        self.speed(kn * KNOT_MPS, true)
    }

    /// RSA: starboard (or single) rudder, status, port rudder, status; negative = bow to
    /// port.
    fn rsa(&self, data: &str) -> Result<f64, Reject> {
        let f: Vec<&str> = data.split(',').collect();
        if f.len() < 4 {
            return Err(Reject::BadField);
        }
        let pick = if f[1] == "A" {
            f[0]
        } else if f[3] == "A" {
            f[2]
        } else {
            return Err(Reject::Status);
        };
        let d = number(pick)?.ok_or(Reject::NoValue)?;
        if d.abs() <= self.opts.max_rudder_deg {
            Ok(deg(d))
        } else {
            Err(Reject::OutOfRange)
        }
    }
}

/// A sentence's value before its time is known.
enum Value {
    Heading(f64),
    Rudder(f64),
    Speed(f64),
    Autopilot(&'static str, Option<f64>),
}

/// A heading in [0, 360] degrees to [0, 2 pi) radians (360 is north).
fn heading_rad(d: f64) -> Result<f64, Reject> {
    if d.is_finite() && (0.0..=360.0).contains(&d) {
        Ok(wrap_2pi(deg(d)))
    } else {
        Err(Reject::OutOfRange)
    }
}

/// A numeric field: empty is `None`; anything but a plain decimal (digits, one point, a
/// leading sign) is a bad field (Rust's parser would take `inf`, `NaN`, `1e3`).
fn number(s: &str) -> Result<Option<f64>, Reject> {
    if s.is_empty() {
        return Ok(None);
    }
    let digits = s.strip_prefix(['-', '+']).unwrap_or(s);
    let ok = !digits.is_empty()
        && digits.bytes().all(|b| b.is_ascii_digit() || b == b'.')
        && digits.bytes().filter(|b| *b == b'.').count() <= 1
        && digits.bytes().any(|b| b.is_ascii_digit());
    if !ok {
        return Err(Reject::BadField);
    }
    s.parse::<f64>().map(Some).map_err(|_| Reject::BadField)
}

/// Each field of `data` at `idx` (when present) is empty or a plain decimal.
fn plain_numbers(data: &str, idx: &[usize]) -> Result<(), Reject> {
    let f: Vec<&str> = data.split(',').collect();
    for i in idx {
        if let Some(x) = f.get(*i) {
            number(x)?;
        }
    }
    Ok(())
}

/// An east/west-signed angle: value and `E` (+) or `W` (-); an empty pair is `None`.
fn east_west(v: &str, dir: &str) -> Result<Option<f64>, Reject> {
    match (number(v)?, dir) {
        (None, "") => Ok(None),
        (None, _) => Err(Reject::BadField),
        (Some(x), _) if !(0.0..=180.0).contains(&x) => Err(Reject::OutOfRange),
        (Some(x), "E") => Ok(Some(x)),
        (Some(x), "W") => Ok(Some(-x)),
        (Some(_), _) => Err(Reject::BadField),
    }
}

/// HDG: magnetic sensor heading, deviation, E/W, variation, E/W. True heading = sensor +
/// deviation + variation (east positive). No deviation: 0 (a compensated compass); no
/// variation: no true heading.
fn hdg(data: &str) -> Result<f64, Reject> {
    let f: Vec<&str> = data.split(',').collect();
    if f.len() < 5 {
        return Err(Reject::BadField);
    }
    let sensor = number(f[0])?.ok_or(Reject::NoValue)?;
    if !(0.0..=360.0).contains(&sensor) {
        return Err(Reject::OutOfRange);
    }
    let deviation = east_west(f[1], f[2])?.unwrap_or(0.0);
    let variation = east_west(f[3], f[4])?.ok_or(Reject::NoValue)?;
    Ok(wrap_2pi(deg(sensor + deviation + variation)))
}

/// HTD (heading/track control data, IEC 61162-1): the autopilot's state and its
/// heading-to-steer (true) when given. Fields (0-based): 0 override (A in use), 3 steering
/// mode, 9 commanded heading-to-steer [deg], 12 heading reference (T/M).
fn htd(data: &str) -> Result<(&'static str, Option<f64>), Reject> {
    let f: Vec<&str> = data.split(',').collect();
    if f.len() < 13 {
        return Err(Reject::BadField);
    }
    let mode = match f[3] {
        "" => return Err(Reject::NoValue),
        "S" | "H" => "auto",
        "T" => "route",
        "M" => "standby",
        "R" => "directControl",
        _ => return Err(Reject::BadField),
    };
    let state = match f[0] {
        "A" => "standby",
        "V" | "" => mode,
        _ => return Err(Reject::BadField),
    };
    let target = match number(f[9])? {
        None => None,
        Some(d) => {
            if f[12] != "T" {
                // A magnetic heading-to-steer cannot be made true here.
                return Err(Reject::BadField);
            }
            Some(heading_rad(d)?)
        }
    };
    Ok((state, target))
}

fn valid_talker(t: &[u8]) -> bool {
    t.len() == 2
        && t.iter()
            .all(|b| b.is_ascii_uppercase() || b.is_ascii_digit())
}

fn hex_byte(s: &[u8]) -> Option<u8> {
    let h = std::str::from_utf8(s).ok()?;
    if h.len() != 2 || !h.bytes().all(|b| b.is_ascii_hexdigit()) {
        return None;
    }
    u8::from_str_radix(h, 16).ok()
}

fn xor(bytes: &[u8]) -> u8 {
    bytes.iter().fold(0, |c, b| c ^ b)
}

/// Splits an optional leading tag block `\k:v,k:v*hh\` off the sentence.
fn split_tag_block(text: &str) -> Result<(Tags<'_>, &str), Reject> {
    let Some(rest) = text.strip_prefix('\\') else {
        return Ok((Tags::default(), text));
    };
    let end = rest.find('\\').ok_or(Reject::TagBlock)?;
    let (block, sentence) = (&rest[..end], &rest[end + 1..]);
    let star = block.rfind('*').ok_or(Reject::TagBlock)?;
    let (params, hh) = (&block[..star], &block.as_bytes()[star + 1..]);
    if hex_byte(hh) != Some(xor(params.as_bytes())) {
        return Err(Reject::TagBlock);
    }
    let mut tags = Tags::default();
    for p in params.split(',') {
        let (k, v) = p.split_once(':').ok_or(Reject::TagBlock)?;
        match k {
            "c" => {
                if v.is_empty() || !v.bytes().all(|b| b.is_ascii_digit()) {
                    return Err(Reject::TagBlock);
                }
                tags.time = Some(v.parse().map_err(|_| Reject::TagBlock)?);
            }
            "s" => tags.source = Some(v),
            _ => {}
        }
    }
    Ok((tags, sentence))
}

/// `$` or `!`, five header characters, fields, `*`, two hex digits, nothing after.
fn check_framing(s: &str) -> Result<(), Reject> {
    let b = s.as_bytes();
    if b.len() < 9 || !(b[0] == b'$' || b[0] == b'!') {
        return Err(Reject::Framing);
    }
    let star = b.len() - 3;
    if b[star] != b'*' || hex_byte(&b[star + 1..]).is_none() {
        return Err(Reject::Framing);
    }
    let header = &b[1..6];
    if !header.iter().all(|c| c.is_ascii_alphanumeric()) || b[6] != b',' {
        return Err(Reject::Framing);
    }
    if b[1..star]
        .iter()
        .any(|c| matches!(c, b'$' | b'!' | b'*' | b'\\'))
    {
        return Err(Reject::Framing);
    }
    Ok(())
}

/// Whether the checksum of a framed sentence matches (for sentence types the crate does not
/// know, so that a corrupted known sentence is not counted as an unknown one).
fn framing_checksum_ok(s: &str) -> bool {
    let b = s.as_bytes();
    let star = b.len() - 3;
    hex_byte(&b[star + 1..]) == Some(xor(&b[1..star]))
}

// ---------------------------------------------------------------------------------------------
// A byte stream cut into lines (TCP, a serial line)

impl Decoder {
    /// Feeds stream bytes received at `recv_s` through `lines` (over-long lines are counted
    /// as [`Reject::TooLong`]).
    pub fn stream(
        &mut self,
        lines: &mut LineBuffer,
        bytes: &[u8],
        recv_s: f64,
        out: &mut Vec<Input>,
    ) {
        lines.push(bytes, |l| match l {
            Line::Complete(b) => self.line(b, recv_s, out),
            Line::TooLong => {
                self.stats.lines += 1;
                self.reject(Reject::TooLong);
            }
        });
    }
}
