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
//! | THS | heading | true heading [deg] -> [rad] when its mode is `A` (autonomous) (when `heading = "ths"`); other modes are a `status` rejection |
//! | RSA | rudder | starboard (or single) rudder when its status is A, else the port rudder when its status is A; negative = bow to port [deg] -> [rad] |
//! | VHW | speed | speed through water [kn] -> [m/s] (the km/h field when the knots field is empty) (when `speed = "vhw"`) |
//! | VBW | speed | longitudinal water speed [kn] -> [m/s] when the water status is A (when `speed = "vbw"`) |
//! | HTD | autopilot state, target | steering mode S or H -> `auto`, T -> `route`, M -> `standby`, R -> `directControl`; override A -> `standby`; heading-to-steer [deg] -> [rad] when the heading reference is T |
//! | ZDA | - | sets the UTC offset of the receive clock (`time-source = "zda"`) |
//!
//! Framing, the checksum and the sentences the `nmea` crate parses (VHW, ZDA) go through
//! that crate; HDT (in double precision: the crate reads it as `f32`), HDG, RSA, VBW and HTD
//! are read here from the crate's data field, THS (which the crate does not know) from the
//! sentence. Proprietary sentences (`$P` and a 4- to 9-character address) and `!`
//! encapsulation are valid and ignored. The talker is not looked at (any two upper-case letters or
//! digits) unless `talkers` lists the accepted ones.
//!
//! Time of a sample ([`TimeSource`]): the time of reception; the tag block's `c:` (UNIX
//! seconds, or milliseconds), held per stream to its own timeline by the daemon's rule
//! ([`crate::timeline`]: a jump beyond `time-jump-s` is a `time_jump` rejection until
//! `resync-samples` in a row make a new timeline); or the time of reception plus the offset
//! to UTC that the last ZDA gave.
//!
//! Invariants: a line longer than [`MAX_LINE_BYTES`] is never looked into; the decoder holds
//! a fixed state (the ZDA offset, one tag-block clock per stream, counters: its memory does
//! not grow with its input); a [`LineBuffer`] never holds
//! more than [`MAX_LINE_BYTES`] bytes; every line is counted exactly once: as a sample
//! source (`used`), `ignored` (a sentence the bridge does not use), or rejected by reason.

use crate::angle::deg;
use crate::timeline::{Clocks, Jump};
use crate::wire::{Input, Stream};

mod encode;
mod fields;
mod framing;
mod lines;
mod options;
mod stats;
pub use encode::{datagram, sentence, tag_block, tag_time_ms, tick_sentences};
use fields::{hdg, hdt, htd, number, plain_numbers, ths, Value};
use framing::{check_framing, framing_checksum_ok, split_tag_block, valid_talker, Tags};
pub use lines::{Line, LineBuffer};
pub use options::{DecodeOptions, HeadingSentence, SpeedSentence, TimeSource};
pub use stats::{DecodeStats, Reject};

/// Metres per second in one knot.
pub const KNOT_MPS: f64 = 1852.0 / 3600.0;
/// Metres per second in one km/h.
pub const KMH_MPS: f64 = 1.0 / 3.6;
/// The IEC 61162-450 header of a datagram of sentences.
pub const UDPBC: &[u8; 6] = b"UdPbC\0";
/// The longest line looked into [bytes]: a tag block and a sentence (the sentence itself at
/// most the `nmea` crate's 102 characters; IEC 61162-1 allows 82).
pub const MAX_LINE_BYTES: usize = 512;

/// One vessel's NMEA decoder: options, the ZDA offset, counters. See the module doc.
#[derive(Debug, Clone)]
pub struct Decoder {
    opts: DecodeOptions,
    /// UTC minus the receive clock at the latest valid ZDA [s] (`time-source = "zda"`).
    zda_offset_s: Option<f64>,
    /// Tag-block time: each stream's clock ([`crate::timeline`]) and its last accepted `t`.
    clocks: Clocks,
    last_t: [Option<f64>; Stream::ALL.len()],
    stats: DecodeStats,
}

/// A checked sentence: one the `nmea` crate parsed, or one it does not know that we read.
enum Sentence<'a> {
    /// Parsed by the `nmea` crate (its data field read here for HDG, RSA, VBW, HTD).
    Crate(nmea::NmeaSentence<'a>),
    /// THS, true heading and status: its data field.
    Ths(&'a str),
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
            clocks: Clocks::default(),
            last_t: [None; Stream::ALL.len()],
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
        let Some((tags, sentence)) = self.sentence(line)? else {
            return Ok(Outcome::Ignored);
        };
        use nmea::SentenceType as S;
        let parsed = match sentence {
            Sentence::Ths(data) if self.opts.heading == HeadingSentence::Ths => {
                return self.push(Value::Heading(ths(data)?), &tags, recv_s, out);
            }
            Sentence::Ths(_) => return Ok(Outcome::Ignored),
            Sentence::Crate(p) => p,
        };
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
        // The value first (its reasons say more about the instrument than a missing time).
        let Some(value) = self.value(parsed)? else {
            return Ok(Outcome::Ignored);
        };
        self.push(value, &tags, recv_s, out)
    }

    /// A line's value, at the time its source gives, appended to `out`.
    fn push(
        &mut self,
        value: Value,
        tags: &Tags<'_>,
        recv_s: f64,
        out: &mut Vec<Input>,
    ) -> Result<Outcome, Reject> {
        let t = self.time(tags, recv_s)?;
        if matches!(
            self.opts.time_source,
            TimeSource::TagBlockS | TimeSource::TagBlockMs
        ) {
            self.continues(value.stream(), t)?;
        }
        value.push(t, out);
        Ok(Outcome::Used)
    }

    /// Whether a tag-block time `t` continues its stream's timeline ([`crate::timeline`],
    /// `time-jump-s`, `resync-samples`): a jump ahead or back is rejected until it is a
    /// timeline of its own. A repeated time passes (a tag block in whole seconds repeats at
    /// 10 Hz); the daemon counts duplicates.
    fn continues(&mut self, stream: Stream, t: f64) -> Result<(), Reject> {
        let last = &mut self.last_t[stream.index()];
        let (jump, resync) = (self.opts.time_jump_s, self.opts.resync_samples);
        match self.clocks.check(stream, t, *last, jump, resync) {
            Ok(_) => {
                *last = Some(t);
                Ok(())
            }
            Err(Jump::Duplicate) => Ok(()),
            Err(Jump::Backwards { .. } | Jump::Ahead { .. }) => Err(Reject::TimeJump),
        }
    }

    /// A line's tag block and its sentence, parsed and checked (framing, source, checksum,
    /// talker); `None` for a valid sentence that is not ours (encapsulation, proprietary, a
    /// type the `nmea` crate does not know).
    fn sentence<'a>(&self, line: &'a [u8]) -> Result<Option<(Tags<'a>, Sentence<'a>)>, Reject> {
        if line.len() > MAX_LINE_BYTES {
            return Err(Reject::TooLong);
        }
        // Length before content: the sentence after an optional tag block is held to the
        // `nmea` crate's 102 characters before its bytes are looked at.
        let body = match line.strip_prefix(b"\\") {
            Some(rest) => rest
                .iter()
                .position(|b| *b == b'\\')
                .map_or(line, |end| &rest[end + 1..]),
            None => line,
        };
        if body.len() > nmea::SENTENCE_MAX_LEN {
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
            return Ok(None);
        }
        let talker = &sentence.as_bytes()[1..3];
        let parsed = if &sentence[3..6] == "THS" {
            // True heading and status: the `nmea` crate does not know it.
            if !framing_checksum_ok(sentence) {
                return Err(Reject::Checksum);
            }
            Sentence::Ths(&sentence[7..sentence.len() - 3])
        } else {
            match nmea::parse_nmea_sentence(sentence) {
                Ok(p) if p.checksum != p.calc_checksum() => return Err(Reject::Checksum),
                Ok(p) => Sentence::Crate(p),
                // Framing was checked above: what the crate refuses is a sentence type it
                // does not know (e.g. `$IIXYZ`) - unless the checksum is wrong, checked first.
                Err(_) => {
                    return if framing_checksum_ok(sentence) {
                        Ok(None)
                    } else {
                        Err(Reject::Checksum)
                    };
                }
            }
        };
        if !valid_talker(talker)
            || (!self.opts.talkers.is_empty()
                && !self.opts.talkers.iter().any(|t| t.as_bytes() == talker))
        {
            return Err(Reject::Talker);
        }
        Ok(Some((tags, parsed)))
    }

    /// The value of a wanted sentence other than ZDA; `None` for a type without one.
    fn value(&self, parsed: nmea::NmeaSentence<'_>) -> Result<Option<Value>, Reject> {
        use nmea::SentenceType as S;
        let kind = parsed.message_id;
        let data = parsed.data;
        // The crate reads numbers with Rust's parser, which takes `inf`, `NaN` and `1e3`:
        // VHW's numeric fields are held to plain decimals first, as ours are.
        if kind == S::VHW {
            plain_numbers(data, &[0, 2, 4, 6])?;
        }
        let value = match kind {
            S::HDT => Value::Heading(hdt(data)?),
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
            _ => return Ok(None),
        };
        Ok(Some(value))
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
    /// port. A missing status field is no valid status.
    fn rsa(&self, data: &str) -> Result<f64, Reject> {
        let f: Vec<&str> = data.split(',').collect();
        let valid = |i: usize| f.get(i) == Some(&"A");
        let pick = if valid(1) {
            f[0]
        } else if valid(3) {
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
