//! Bounded time-series records of one test, and their alignment onto a uniform grid.
//!
//! Streams arrive at their own rates, with jitter, and not in lockstep with each other (the
//! rudder of time t may come after the heading of time t). During a test every accepted
//! sample of the heading and the rudder is appended to its own record with its own `t`
//! (records are strictly increasing in `t`, which validation guarantees). At analysis time
//! each record is resampled by linear interpolation onto one uniform grid
//! `t0 + n dt, n = 0..N` - that is the alignment by `t` of the contract. Interpolating a 10 Hz
//! record at frequencies below 0.2 rad/s costs a gain error below (w dt)^2 / 24 ~ 1.4e-5.
//!
//! A record has a fixed capacity decided when the test starts (its maximum duration times the
//! sample rate, with margin): a flood of samples fills it and the test aborts with a reason,
//! memory never grows without bound.

/// One stream's samples during a test.
#[derive(Debug, Clone)]
pub struct Record {
    t: Vec<f64>,
    v: Vec<f64>,
    capacity: usize,
}

/// Why a record could not take a sample or be resampled.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum RecordError {
    /// The record is full: more samples than the test can have at the configured rate.
    #[error("more than {0} samples in one test (input flood)")]
    Full(usize),
    /// The grid reaches outside the recorded span, or across a gap longer than allowed.
    #[error("no data to interpolate at t = {t:.3} s (gap or outside the record)")]
    Gap {
        /// Grid time that could not be served.
        t: f64,
    },
}

impl Record {
    /// An empty record that takes at most `capacity` samples (allocated once, here).
    pub fn with_capacity(capacity: usize) -> Self {
        Self {
            t: Vec::with_capacity(capacity),
            v: Vec::with_capacity(capacity),
            capacity,
        }
    }

    /// Appends a sample. Callers guarantee increasing `t` (validated inputs).
    pub fn push(&mut self, t: f64, v: f64) -> Result<(), RecordError> {
        if self.t.len() >= self.capacity {
            return Err(RecordError::Full(self.capacity));
        }
        self.t.push(t);
        self.v.push(v);
        Ok(())
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.t.len()
    }

    /// Time of the last sample.
    pub fn last_t(&self) -> Option<f64> {
        self.t.last().copied()
    }

    /// Whether the record is empty.
    pub fn is_empty(&self) -> bool {
        self.t.is_empty()
    }

    /// Resamples onto `t0 + n dt`, `n = 0..n`, into `out` (cleared first) by linear
    /// interpolation. Fails if a grid point lies outside the record or between two samples
    /// more than `max_gap_s` apart.
    pub fn resample(
        &self,
        t0: f64,
        dt: f64,
        n: usize,
        max_gap_s: f64,
        out: &mut Vec<f64>,
    ) -> Result<(), RecordError> {
        out.clear();
        out.reserve(n);
        let mut j = 0usize; // index of the sample at or before the grid time
        for i in 0..n {
            let tg = t0 + i as f64 * dt;
            while j + 1 < self.t.len() && self.t[j + 1] <= tg {
                j += 1;
            }
            if self.t.is_empty() || tg < self.t[0] {
                return Err(RecordError::Gap { t: tg });
            }
            if j + 1 >= self.t.len() {
                // At or past the last sample: only exactly on it (or within float noise).
                let last = self.t[self.t.len() - 1];
                if (tg - last).abs() <= 1e-9 * tg.abs().max(1.0) {
                    out.push(self.v[self.v.len() - 1]);
                    continue;
                }
                return Err(RecordError::Gap { t: tg });
            }
            let (ta, tb) = (self.t[j], self.t[j + 1]);
            if tb - ta > max_gap_s {
                return Err(RecordError::Gap { t: tg });
            }
            let w = (tg - ta) / (tb - ta);
            out.push(self.v[j] + w * (self.v[j + 1] - self.v[j]));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn interpolates_a_line_exactly_and_refuses_gaps() {
        let mut r = Record::with_capacity(100);
        for k in 0..50 {
            // jittered sample times
            let t = k as f64 * 0.1 + if k % 3 == 0 { 0.013 } else { -0.007 } + 0.01;
            r.push(t, 2.0 * t - 1.0).unwrap();
        }
        let mut out = Vec::new();
        r.resample(0.5, 0.1, 40, 0.5, &mut out).unwrap();
        for (i, v) in out.iter().enumerate() {
            let t = 0.5 + i as f64 * 0.1;
            assert!((v - (2.0 * t - 1.0)).abs() < 1e-12);
        }
        assert!(r.resample(0.0, 0.1, 10, 0.5, &mut out).is_err());
        assert!(r.resample(4.0, 0.1, 20, 0.5, &mut out).is_err());
    }

    #[test]
    fn full_record_refuses_samples() {
        let mut r = Record::with_capacity(2);
        r.push(0.0, 0.0).unwrap();
        r.push(1.0, 0.0).unwrap();
        assert_eq!(r.push(2.0, 0.0), Err(RecordError::Full(2)));
        assert_eq!(r.len(), 2);
    }

    #[test]
    fn gap_inside_is_refused() {
        let mut r = Record::with_capacity(10);
        for t in [0.0, 0.1, 0.2, 3.0, 3.1] {
            r.push(t, t).unwrap();
        }
        let mut out = Vec::new();
        assert!(matches!(
            r.resample(0.0, 0.1, 31, 1.0, &mut out),
            Err(RecordError::Gap { .. })
        ));
    }
}
