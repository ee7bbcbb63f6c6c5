//! Rejected inputs in the recording: their channel, the record of one (its reason, length and
//! head) and the token bucket that bounds how many a stream writes.

use helmwatch_core::wire::{Keys, Stream};
use std::time::Instant;

/// Most bytes of a rejected payload recorded (its head).
pub const REJECTED_HEAD_BYTES: usize = 256;
/// Rejected records a stream may write at once (the token bucket's depth).
pub const REJECTED_BURST: f64 = 10.0;
/// Then one rejected record per stream every this many seconds of wall time.
pub const REJECTED_PERIOD_S: f64 = 30.0;
/// Most bytes one rejected record takes in a file: the head, its JSON escaping (a byte may
/// take 6 characters as `\u00XX`), the other fields and the MCAP record and index overhead.
pub const REJECTED_RECORD_MAX_BYTES: u64 = 6 * REJECTED_HEAD_BYTES as u64 + 200;

/// The most bytes rejected inputs write into the recordings per hour, all streams.
pub fn rejected_bytes_per_hour() -> u64 {
    let per_stream = REJECTED_BURST + 3600.0 / REJECTED_PERIOD_S;
    (Stream::ALL.len() as f64 * per_stream) as u64 * REJECTED_RECORD_MAX_BYTES
}

/// `vessels/<v>/fdi/rejected`: the channel of rejected inputs (recordings only).
pub fn rejected_key(keys: &Keys) -> String {
    format!("{}/fdi/rejected", keys.prefix)
}

/// A token bucket: whether a rejected record of one stream may be written now.
#[derive(Debug, Clone)]
pub struct RejectedBudget {
    tokens: f64,
    last: Option<Instant>,
    /// Left out since the last record written.
    pub suppressed: u64,
}

impl Default for RejectedBudget {
    fn default() -> Self {
        Self {
            tokens: REJECTED_BURST,
            last: None,
            suppressed: 0,
        }
    }
}

impl RejectedBudget {
    /// Takes a token at `now` if there is one (else counts the record as suppressed).
    pub fn take(&mut self, now: Instant) -> bool {
        if let Some(last) = self.last {
            let dt = now.saturating_duration_since(last).as_secs_f64();
            self.tokens = (self.tokens + dt / REJECTED_PERIOD_S).min(REJECTED_BURST);
        }
        self.last = Some(now);
        if self.tokens >= 1.0 {
            self.tokens -= 1.0;
            true
        } else {
            self.suppressed += 1;
            false
        }
    }
}

/// The record of a rejected payload: its stream, reason, length, head (lossy UTF-8) and the
/// count left out before it.
pub fn rejected_record(
    stream: Stream,
    reason: &str,
    len: usize,
    head: &[u8],
    suppressed: u64,
) -> Vec<u8> {
    let head = &head[..head.len().min(REJECTED_HEAD_BYTES)];
    serde_json::to_vec(&serde_json::json!({
        "stream": stream.name(),
        "reason": reason,
        "len": len,
        "head": String::from_utf8_lossy(head),
        "suppressed": suppressed,
    }))
    .unwrap_or_default()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_rejected_budget_is_a_burst_then_one_per_period() {
        let t0 = Instant::now();
        let mut b = RejectedBudget::default();
        let written = (0..1000).filter(|_| b.take(t0)).count();
        assert_eq!(written, REJECTED_BURST as usize);
        assert_eq!(b.suppressed, 1000 - REJECTED_BURST as u64);
        // An hour of a flood at 1 kHz: one record per period after the burst.
        let mut b = RejectedBudget::default();
        let mut n = 0u64;
        for ms in 0..3_600_000u64 {
            if b.take(t0 + std::time::Duration::from_millis(ms)) {
                n += 1;
            }
        }
        let want = REJECTED_BURST + 3600.0 / REJECTED_PERIOD_S;
        assert!(
            (n as f64 - want).abs() <= 1.0,
            "{n} records, {want} expected"
        );
        // A record is bounded whatever the payload (all bytes needing escapes).
        let big = vec![0x01u8; 1 << 20];
        let r = rejected_record(Stream::Heading, "malformed", big.len(), &big, u64::MAX);
        assert!((r.len() as u64) < REJECTED_RECORD_MAX_BYTES, "{}", r.len());
        let v: serde_json::Value = serde_json::from_slice(&r).unwrap();
        assert_eq!(v["len"], 1 << 20);
        assert_eq!(v["head"].as_str().unwrap().len(), REJECTED_HEAD_BYTES);
        // The documented hourly bound: 1.3 MiB for all streams, 7 % of 20 MiB.
        let h = rejected_bytes_per_hour() as f64 / (1u64 << 20) as f64;
        assert!(h <= 1.3 && h / 20.0 <= 0.07, "{h} MiB/h");
    }
}
