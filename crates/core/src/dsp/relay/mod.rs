//! HBT: limit-cycle features of the relay test (their prediction: `describing.rs`).
//!
//! # Features, eq. (1)-(4) of the paper
//!
//! [`analyse_limit_cycle`] takes the heading `x(t)` (rad, unwrapped, uniformly sampled from
//! `t0` every `dt`) and the instants `s_0 < s_1 < ... < s_n` at which the relay switched in
//! one direction (interpolated between samples by the caller). Zero crossings of a noisy
//! heading are useless; the relay's own switching instants are clean.
//!
//! * Period `P_u = (s_n - s_0) / n`, the mean interval; also the sample standard deviation of
//!   the intervals and their count `n`. `omega_u = 2 pi / P_u`.
//! * Amplitude `a_u = |(2/T) int_{s_0}^{s_n} x~(t) e^{-i omega_u (t - s_0)} dt|`, `T = n P_u`,
//!   over the whole periods between the first and last switch, where `x~` is `x` minus a
//!   straight line. The line is fitted jointly with the harmonics `m omega_u`, `m = 1..15`
//!   (below the sampling Nyquist frequency) and only the line is removed: a plain line fit
//!   over three periods takes up to ~7 % of the first harmonic with it (a sinusoid still correlates
//!   with a ramp). With `tau = t - (s_0 + s_n)/2`, `u = t - s_0`, and the harmonics orthogonal
//!   to each other and to the constant over whole periods,
//!
//!   ```text
//!   tau~ = tau + sum_m (2 / (m omega)) sin(m omega u)            (tau minus its projections)
//!   c1   = <tau~, x> / (T^3/12 - sum_m 2 T / (m omega)^2)          (slope of the line)
//!   X1   = (2/T) int x e^{-i omega u} dt - 2 i c1 / omega          (first harmonic, line removed)
//!   ```
//!
//!   The integrals use the trapezoid rule on the samples, with the fractional samples at
//!   both ends linearly interpolated (error O((omega dt)^2), 1e-6 at 10 Hz).
//!
//! [`first_harmonic`] is that integral for any signal: over the same interval and `omega`,
//! the heading's and the measured rudder's coefficients share one time reference, so their
//! ratio `X1 / D1` is the ship's own response `G(i omega_u) = b / (i w (i w + a))`, whatever
//! the relay's switching instants and the servo did (the relay is nonlinear; the ship between
//! rudder and heading is not). The describing function predicts `(omega_u, a_u)` from the
//! relay and servo; the response reads the ship directly, which the waves disturb far less:
//! they jitter the switching instants (and so the period and amplitude) but hardly touch the
//! first harmonics at `omega_u`, far below the wave band.
//!
//! Units: rad, s, rad/s. `a` [1/s], `b` [1/s^2] as in `ShipConfig::nomoto`.

use super::{check_finite, check_positive, DspError};
use rustfft::num_complex::Complex64;
use std::f64::consts::PI;

mod describing;
pub use describing::{limit_cycle_describing_function, servo_describing_function};

/// Most harmonics fitted jointly with the trend.
const MAX_TREND_HARMONICS: usize = 15;

/// Features of a relay limit cycle (HBT).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LimitCycle {
    /// Ultimate period P_u: mean interval between same-direction switches [s].
    pub period_s: f64,
    /// omega_u = 2 pi / P_u [rad/s].
    pub omega_u_rad_s: f64,
    /// First-harmonic amplitude of the detrended heading over the whole periods [rad].
    pub amplitude_rad: f64,
    /// The heading's first-harmonic coefficient itself ([`first_harmonic`] over the measured
    /// periods, phase referred to the first switch) [rad]: `amplitude_rad` is its modulus.
    pub harmonic_rad: Complex64,
    /// Number of whole periods measured (switch instants minus one).
    pub periods: usize,
    /// Sample standard deviation of the intervals [s] (0 with a single period).
    pub period_std_s: f64,
}

/// Period and first-harmonic amplitude of a relay limit cycle (module documentation).
///
/// `heading` is sampled at `t0_s + i dt_s`; `switch_times_s` are the instants of the relay's
/// switches in one direction, increasing, at least two, within the heading record.
///
/// Errors: non-finite or non-positive `dt_s`, non-finite `t0_s`, fewer than 2 samples or 2
/// switches, non-finite values, switches not strictly increasing or outside the record.
pub fn analyse_limit_cycle(
    t0_s: f64,
    dt_s: f64,
    heading: &[f64],
    switch_times_s: &[f64],
) -> Result<LimitCycle, DspError> {
    check_positive("dt_s", dt_s)?;
    if !t0_s.is_finite() {
        return Err(DspError::InvalidParameter {
            name: "t0_s",
            value: t0_s,
            reason: "must be finite",
        });
    }
    if heading.len() < 2 {
        return Err(DspError::TooShort {
            what: "heading",
            got: heading.len(),
            need: 2,
        });
    }
    if switch_times_s.len() < 2 {
        return Err(DspError::TooShort {
            what: "switch_times_s",
            got: switch_times_s.len(),
            need: 2,
        });
    }
    check_finite("heading", heading)?;
    check_finite("switch_times_s", switch_times_s)?;
    if switch_times_s.windows(2).any(|w| w[1] <= w[0]) {
        return Err(DspError::InvalidParameter {
            name: "switch_times_s",
            value: f64::NAN,
            reason: "must be strictly increasing",
        });
    }
    let t_end = t0_s + (heading.len() - 1) as f64 * dt_s;
    let (s0, sn) = (switch_times_s[0], switch_times_s[switch_times_s.len() - 1]);
    if s0 < t0_s || sn > t_end {
        return Err(DspError::InvalidParameter {
            name: "switch_times_s",
            value: if s0 < t0_s { s0 } else { sn },
            reason: "switch instants must lie within the heading record",
        });
    }

    let periods = switch_times_s.len() - 1;
    let total = sn - s0;
    let period = total / periods as f64;
    let period_std = if periods >= 2 {
        let ss: f64 = switch_times_s
            .windows(2)
            .map(|w| (w[1] - w[0] - period).powi(2))
            .sum();
        (ss / (periods - 1) as f64).sqrt()
    } else {
        0.0
    };
    let omega = 2.0 * PI / period;
    let x1 = first_harmonic(t0_s, dt_s, heading, s0, sn, omega)?;
    Ok(LimitCycle {
        period_s: period,
        omega_u_rad_s: omega,
        amplitude_rad: x1.norm(),
        harmonic_rad: x1,
        periods,
        period_std_s: period_std,
    })
}

/// First-harmonic Fourier coefficient `X1 = (2/T) int_{s0}^{sn} x~(t) e^{-i omega (t - s0)} dt`
/// of a record over `[s0, sn]`, `T = sn - s0` a whole number of periods of `omega`, with the
/// straight line fitted jointly with the harmonics removed (module documentation). `x_rec`
/// is sampled at `t0_s + i dt_s`; `s0`, `sn` must lie within it. The phase is that of
/// `cos(omega (t - s0) + arg X1)`: the same reference for every signal of one test, so the
/// ratio of two signals' coefficients is their frequency response at `omega`.
///
/// Errors: as [`analyse_limit_cycle`], and a trend that the harmonics cannot be separated
/// from (less than about one period).
pub fn first_harmonic(
    t0_s: f64,
    dt_s: f64,
    x_rec: &[f64],
    s0: f64,
    sn: f64,
    omega: f64,
) -> Result<Complex64, DspError> {
    check_positive("dt_s", dt_s)?;
    check_positive("omega", omega)?;
    if x_rec.len() < 2 {
        return Err(DspError::TooShort {
            what: "signal",
            got: x_rec.len(),
            need: 2,
        });
    }
    check_finite("signal", x_rec)?;
    let t_end = t0_s + (x_rec.len() - 1) as f64 * dt_s;
    if !(t0_s <= s0 && s0 < sn && sn <= t_end) {
        return Err(DspError::InvalidParameter {
            name: "interval",
            value: if s0 < t0_s { s0 } else { sn },
            reason: "the interval must lie within the record",
        });
    }
    let total = sn - s0;
    // Harmonics for the joint trend fit: below the sampling Nyquist frequency.
    let nyquist = PI / dt_s;
    let harmonics = (1..=MAX_TREND_HARMONICS)
        .take_while(|&m| m as f64 * omega < 0.8 * nyquist)
        .count()
        .max(1);

    // Accumulators: [tau x, cos(w u) x, sin(m w u) x for m = 1..H].
    let mut acc = [0.0f64; MAX_TREND_HARMONICS + 2];
    let mid = 0.5 * (s0 + sn);
    let integrand = |t: f64, x: f64, out: &mut [f64; MAX_TREND_HARMONICS + 2]| {
        let u = t - s0;
        out[0] = (t - mid) * x;
        out[1] = (omega * u).cos() * x;
        for m in 1..=harmonics {
            out[m + 1] = (m as f64 * omega * u).sin() * x;
        }
    };
    let interp = |t: f64| -> f64 {
        let pos = (t - t0_s) / dt_s;
        let i = (pos.floor().max(0.0) as usize).min(x_rec.len() - 2);
        let f = pos - i as f64;
        x_rec[i] + f * (x_rec[i + 1] - x_rec[i])
    };
    // Nodes: s0, every sample strictly inside (s0, sn), sn.
    let first_inside = ((s0 - t0_s) / dt_s).floor() as usize + 1;
    let mut prev_t = s0;
    let mut prev = [0.0f64; MAX_TREND_HARMONICS + 2];
    integrand(s0, interp(s0), &mut prev);
    let mut cur = [0.0f64; MAX_TREND_HARMONICS + 2];
    let mut i = first_inside;
    loop {
        let (t, x) = match x_rec.get(i) {
            Some(&x) if t0_s + i as f64 * dt_s < sn => (t0_s + i as f64 * dt_s, x),
            _ => (sn, interp(sn)),
        };
        integrand(t, x, &mut cur);
        let h = t - prev_t;
        for k in 0..harmonics + 2 {
            acc[k] += 0.5 * h * (prev[k] + cur[k]);
        }
        if t >= sn {
            break;
        }
        prev = cur;
        prev_t = t;
        i += 1;
    }

    let mut num = acc[0];
    let mut den = total.powi(3) / 12.0;
    for m in 1..=harmonics {
        let mw = m as f64 * omega;
        num += 2.0 / mw * acc[m + 1];
        den -= 2.0 * total / (mw * mw);
    }
    if den <= 1e-6 * total.powi(3) / 12.0 {
        return Err(DspError::Degenerate(
            "trend not separable from the limit cycle",
        ));
    }
    let slope = num / den;
    Ok(Complex64::new(acc[1], -acc[2]) * (2.0 / total) - Complex64::new(0.0, 2.0 * slope / omega))
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;
    use rand_distr::{Distribution, StandardNormal};

    const DEG: f64 = PI / 180.0;

    /// Limit-cycle-like heading: fundamental, 3rd and 5th harmonics, white noise, ramp.
    fn synthetic(
        period: f64,
        amp: f64,
        noise_sd: f64,
        ramp_rad_s: f64,
        seed: u64,
    ) -> (f64, f64, Vec<f64>, Vec<f64>) {
        let (t0, dt) = (13.37, 0.1);
        let n = 12_000;
        let w = 2.0 * PI / period;
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let x: Vec<f64> = (0..n)
            .map(|i| {
                let t = t0 + i as f64 * dt;
                let z: f64 = StandardNormal.sample(&mut rng);
                0.2 + ramp_rad_s * (t - t0)
                    + amp * (w * t + 0.3).sin()
                    + 0.12 * amp * (3.0 * w * t - 1.0).sin()
                    + 0.05 * amp * (5.0 * w * t + 2.0).sin()
                    + noise_sd * z
            })
            .collect();
        // Switches where the fundamental's phase is 0.1 rad past a crossing: 4 periods,
        // starting at a fractional sample.
        let first = (2.0 * PI * 2.0 - 0.3 + 0.1) / w;
        let switches: Vec<f64> = (0..5).map(|j| first + j as f64 * period).collect();
        (t0, dt, x, switches)
    }

    #[test]
    fn synthetic_limit_cycle_amplitude_and_period() {
        let (period, amp) = (180.0, 2.88 * DEG);
        for (ramp, seed) in [(0.0, 1), (1.0 * DEG / 60.0, 2), (-DEG / 60.0, 3)] {
            let (t0, dt, x, sw) = synthetic(period, amp, 0.05 * DEG, ramp, seed);
            let f = analyse_limit_cycle(t0, dt, &x, &sw).unwrap();
            assert_relative_eq!(f.period_s, period, max_relative = 1e-3);
            assert_relative_eq!(f.omega_u_rad_s, 2.0 * PI / period, max_relative = 1e-3);
            assert_relative_eq!(f.amplitude_rad, amp, max_relative = 5e-3);
            assert_eq!(f.periods, 4);
            assert!(f.period_std_s < 1e-9);
        }
    }

    #[test]
    fn noise_free_amplitude_is_exact_to_discretisation() {
        let (period, amp) = (145.0, 2.62 * DEG);
        let (t0, dt, x, sw) = synthetic(period, amp, 0.0, 1.0 * DEG / 60.0, 0);
        let f = analyse_limit_cycle(t0, dt, &x, &sw).unwrap();
        // Trapezoid with interpolated ends: O((omega dt)^2) for the fundamental, and the
        // 3rd/5th harmonics are orthogonal over whole periods.
        assert_relative_eq!(f.amplitude_rad, amp, max_relative = 1e-4);
    }

    #[test]
    fn a_plain_line_fit_would_fail_the_ramp_case() {
        // Independent check of the claim in the module doc: removing a plain least-squares
        // line over the periods biases the first harmonic by several per cent.
        let (period, amp) = (180.0, 2.88 * DEG);
        let (t0, dt, x, sw) = synthetic(period, amp, 0.0, 0.0, 0);
        let (s0, sn) = (sw[0], sw[4]);
        let i0 = ((s0 - t0) / dt).ceil() as usize;
        let i1 = ((sn - t0) / dt).floor() as usize;
        let mut seg: Vec<f64> = x[i0..=i1].to_vec();
        crate::dsp::spectrum::detrend_linear(&mut seg);
        let w = 2.0 * PI / period;
        let mut acc = Complex64::new(0.0, 0.0);
        for (k, v) in seg.iter().enumerate() {
            let t = t0 + (i0 + k) as f64 * dt;
            acc += v * (-Complex64::new(0.0, w * t)).exp() * dt;
        }
        let plain = (acc * 2.0 / (sn - s0)).norm();
        assert!((plain / amp - 1.0).abs() > 0.01, "{}", plain / amp);
    }

    /// Heading over rudder at the fundamental is the response `G(i w)`: a rudder square wave
    /// (odd harmonics, a trim offset), the heading its exact steady state through
    /// `G(s) = b / (s (s + a))` harmonic by harmonic, plus a 1 deg/min ramp and noise.
    #[test]
    fn response_ratio_is_the_transfer_function() {
        let (a, b) = (0.0146, 5.98e-4);
        let g = |w: f64| Complex64::new(b, 0.0) / (Complex64::new(0.0, w) * Complex64::new(a, w));
        let (t0, dt, period) = (3.3, 0.1, 180.0);
        let w = 2.0 * PI / period;
        let mut rng = ChaCha8Rng::seed_from_u64(9);
        let (mut rudder, mut heading) = (Vec::new(), Vec::new());
        for i in 0..10_000 {
            let t = t0 + i as f64 * dt;
            let (mut d, mut x) = (0.01, DEG / 60.0 * t);
            for m in (1..40).step_by(2) {
                // Square wave of height h: (4h / pi) sum sin(m w t) / m.
                let c = 4.0 * 8.0 * DEG / (PI * m as f64);
                let gm = g(m as f64 * w);
                d += c * (m as f64 * w * t).sin();
                x += c * gm.norm() * (m as f64 * w * t + gm.arg()).sin();
            }
            let z: f64 = StandardNormal.sample(&mut rng);
            rudder.push(d);
            heading.push(x + 0.02 * DEG * z);
        }
        let (s0, sn) = (t0 + 17.77, t0 + 17.77 + 4.0 * period);
        let x1 = first_harmonic(t0, dt, &heading, s0, sn, w).unwrap();
        let d1 = first_harmonic(t0, dt, &rudder, s0, sn, w).unwrap();
        let (got, want) = (x1 / d1, g(w));
        assert_relative_eq!(got.norm(), want.norm(), max_relative = 2e-3);
        assert!(
            (got.arg() - want.arg()).abs() < 0.1 * DEG,
            "{got} vs {want}"
        );
        assert_relative_eq!(d1.norm(), 4.0 * 8.0 * DEG / PI, max_relative = 1e-3);
        // Bad input.
        assert!(first_harmonic(t0, dt, &rudder, s0, t0 + 1e6, w).is_err());
        assert!(first_harmonic(t0, dt, &rudder, sn, s0, w).is_err());
        assert!(first_harmonic(t0, dt, &rudder, s0, sn, 0.0).is_err());
        assert!(first_harmonic(t0, dt, &rudder[..1], s0, sn, w).is_err());
    }

    #[test]
    fn period_std_and_count() {
        let x = vec![0.0; 1000];
        let sw = [1.0, 11.0, 20.0, 31.0];
        // Intervals 10, 9, 11: mean 10, sample std 1.
        let f = analyse_limit_cycle(0.0, 0.1, &x, &sw).unwrap();
        assert_relative_eq!(f.period_s, 10.0, max_relative = 1e-12);
        assert_relative_eq!(f.period_std_s, 1.0, max_relative = 1e-12);
        assert_eq!(f.periods, 3);
        assert!(f.amplitude_rad.abs() < 1e-15);
    }

    #[test]
    fn bad_input_is_an_error() {
        let x = vec![0.0; 100];
        assert!(analyse_limit_cycle(0.0, 0.0, &x, &[1.0, 2.0]).is_err());
        assert!(analyse_limit_cycle(f64::NAN, 0.1, &x, &[1.0, 2.0]).is_err());
        assert!(analyse_limit_cycle(0.0, 0.1, &x[..1], &[1.0, 2.0]).is_err());
        assert!(analyse_limit_cycle(0.0, 0.1, &x, &[1.0]).is_err());
        assert!(analyse_limit_cycle(0.0, 0.1, &x, &[2.0, 1.0]).is_err());
        assert!(analyse_limit_cycle(0.0, 0.1, &x, &[1.0, 1.0]).is_err());
        assert!(analyse_limit_cycle(0.0, 0.1, &x, &[-1.0, 2.0]).is_err());
        assert!(analyse_limit_cycle(0.0, 0.1, &x, &[1.0, 9.95]).is_err());
        assert!(analyse_limit_cycle(0.0, 0.1, &x, &[1.0, f64::INFINITY]).is_err());
        let mut bad = x.clone();
        bad[5] = f64::NAN;
        assert_eq!(
            analyse_limit_cycle(0.0, 0.1, &bad, &[1.0, 2.0]),
            Err(DspError::NonFinite("heading"))
        );
    }

    proptest::proptest! {
        #[test]
        fn never_panics_on_arbitrary_input(
            t0 in proptest::prelude::any::<f64>(),
            dt in proptest::prelude::any::<f64>(),
            x in proptest::collection::vec(proptest::prelude::any::<f64>(), 0..50),
            sw in proptest::collection::vec(-10.0..10.0f64, 0..6),
        ) {
            let _ = analyse_limit_cycle(t0, dt, &x, &sw);
            let _ = analyse_limit_cycle(0.0, 0.5, &x, &sw);
        }
    }
}
