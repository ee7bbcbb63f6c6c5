//! HBT: limit-cycle features of the relay test and their describing-function prediction.
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
//! # Describing function
//!
//! [`limit_cycle_describing_function`] predicts `(omega_u, a_u)` for the loop relay with
//! hysteresis -> servo -> ship `b / (s (s + a))` -> heading -> relay, error = -heading. First
//! harmonic balance `N(A) S(omega) G(i omega) = -1`, with
//!
//! * the relay with hysteresis on an error of amplitude `A`: `N(A) = 4h / (pi A) e^{-i
//!   asin(eps/A)}` (the command is `+-h`, clamped to the servo's angle limit);
//! * the servo's response to the relay's square wave, computed exactly: its periodic steady
//!   state is a rate-limited ramp (rate `R` while `|cmd - delta| > R T_r`) followed by the
//!   first-order approach `delta = h - (h - delta_1) e^{-(t - t_1)/T_r}`, half-wave
//!   antisymmetric; its first Fourier coefficient is integrated in closed form and divided by
//!   the square wave's, `-i 4 h / pi`, to give `S(omega)`;
//! * so `A = (4h / pi) |S(omega)| |G(i omega)|` and `arg S + arg G - asin(eps / A) = -pi`,
//!   solved for `omega` by bisection.
//!
//! Units: rad, s, rad/s. `a` [1/s], `b` [1/s^2] as in `ShipConfig::nomoto`.

use super::{check_finite, check_positive, DspError};
use crate::model::ServoConfig;
use rustfft::num_complex::Complex64;
use std::f64::consts::PI;

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

/// First Fourier coefficient `(2/P) int_0^P delta e^{-i w t} dt` of the servo's periodic
/// response to a square-wave command `+-h` (high on `[0, P/2)`), computed exactly.
///
/// Servo: `delta' = clamp((cmd - delta) / T_r, -R, R)`. Returns the coefficient [rad].
fn servo_first_harmonic(h: f64, omega: f64, tr: f64, rate: f64) -> Complex64 {
    let half = PI / omega;
    // Half-period map from the starting value `ds` (moving up towards +h).
    let knee = h - rate * tr; // below the knee the rate limit is active
    let half_map = |ds: f64| -> (f64, f64, f64) {
        // Returns (end value, ramp duration t1, value at the end of the ramp d1).
        let d1 = ds.max(knee);
        let t1 = (d1 - ds) / rate;
        if t1 >= half {
            (ds + rate * half, half, ds + rate * half)
        } else {
            (h - (h - d1) * (-(half - t1) / tr).exp(), t1, d1)
        }
    };
    // Fixed point d0 = F(-d0): g(d0) = F(-d0) - d0 is decreasing on [0, h].
    let (mut lo, mut hi) = (0.0f64, h);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if half_map(-mid).0 > mid {
            lo = mid;
        } else {
            hi = mid;
        }
        if hi - lo <= 1e-15 * h {
            break;
        }
    }
    let d0 = 0.5 * (lo + hi);
    let (_, t1, d1) = half_map(-d0);
    let iw = Complex64::new(0.0, omega);
    let e = |t: f64| (-iw * t).exp();
    // int_a^b e^{-iwt} dt and int_a^b t e^{-iwt} dt.
    let int_1 = |a: f64, b: f64| (e(a) - e(b)) / iw;
    let int_t = |a: f64, b: f64| {
        let prim = |t: f64| (Complex64::new(1.0 / (omega * omega), t / omega)) * e(t);
        prim(b) - prim(a)
    };
    // Ramp on [0, t1]: delta = -d0 + R t.
    let mut integral = int_1(0.0, t1) * (-d0) + int_t(0.0, t1) * rate;
    // Approach on [t1, half]: delta = h - (h - d1) e^{-(t - t1)/T_r}.
    if t1 < half {
        let lambda = Complex64::new(1.0 / tr, omega);
        let exp_part = (e(t1) - (-(half - t1) / tr).exp() * e(half)) / lambda;
        integral += int_1(t1, half) * h - exp_part * (h - d1);
    }
    // Half-wave antisymmetry: (2/P) int_0^P = (4/P) int_0^{P/2}.
    integral * (4.0 / (2.0 * half))
}

/// The servo's describing function `S(omega)` for a relay command `+-h_rad` (clamped to the
/// servo's angle limit, as in the loop): the first harmonic of its exact periodic response
/// over the square wave's, `-i 4h / pi` (module documentation). `S(omega) G(i omega)` is the
/// linear part the relay sees; it meets `-1/N(A)` at the limit cycle.
///
/// Errors: `h_rad`, `omega` or the servo's parameters not positive and finite.
pub fn servo_describing_function(
    h_rad: f64,
    omega: f64,
    servo: &ServoConfig,
) -> Result<Complex64, DspError> {
    check_positive("h_rad", h_rad)?;
    check_positive("omega", omega)?;
    let (tr, rate, max_angle) = (
        servo.time_constant_s,
        servo.max_rate_rad_s(),
        servo.max_angle_rad(),
    );
    check_positive("servo.time_constant_s", tr)?;
    check_positive("servo.max_rate", rate)?;
    check_positive("servo.max_angle", max_angle)?;
    let h = h_rad.min(max_angle);
    Ok(servo_first_harmonic(h, omega, tr, rate) / Complex64::new(0.0, -4.0 * h / PI))
}

/// Describing-function prediction `(omega_u [rad/s], first-harmonic heading amplitude
/// [rad])` of the relay limit cycle (module documentation).
///
/// `a` [1/s] >= 0 and `b` [1/s^2] > 0 are the Nomoto parameters, `h_rad` > 0 the relay
/// height, `eps_rad` >= 0 its hysteresis; the servo's time constant, rate limit and angle
/// limit (which clamps the command) come from `servo`.
///
/// Errors: parameters out of range, or no limit cycle in 1e-6 .. 1e3 rad/s.
pub fn limit_cycle_describing_function(
    a: f64,
    b: f64,
    h_rad: f64,
    eps_rad: f64,
    servo: &ServoConfig,
) -> Result<(f64, f64), DspError> {
    if !(a.is_finite() && a >= 0.0) {
        return Err(DspError::InvalidParameter {
            name: "a",
            value: a,
            reason: "must be finite and >= 0",
        });
    }
    check_positive("b", b)?;
    check_positive("h_rad", h_rad)?;
    if !(eps_rad.is_finite() && eps_rad >= 0.0) {
        return Err(DspError::InvalidParameter {
            name: "eps_rad",
            value: eps_rad,
            reason: "must be finite and >= 0",
        });
    }
    let tr = servo.time_constant_s;
    let rate = servo.max_rate_rad_s();
    let max_angle = servo.max_angle_rad();
    check_positive("servo.time_constant_s", tr)?;
    check_positive("servo.max_rate", rate)?;
    check_positive("servo.max_angle", max_angle)?;
    let h = h_rad.min(max_angle);

    // Amplitude and phase condition at omega: f > 0 below the limit cycle, < 0 above.
    let balance = |w: f64| -> (f64, f64) {
        let jw = Complex64::new(0.0, w);
        let g = b / (jw * (jw + a));
        let s = servo_first_harmonic(h, w, tr, rate) / Complex64::new(0.0, -4.0 * h / PI);
        let amp = 4.0 * h / PI * s.norm() * g.norm();
        if amp <= eps_rad {
            return (-1.0, amp);
        }
        // arg G in (-pi, -pi/2], taken continuously; arg S is a small lag.
        let arg_g = -PI / 2.0 - (w / a.max(f64::MIN_POSITIVE)).atan();
        let f = arg_g + s.arg() - (eps_rad / amp).asin() + PI;
        (f, amp)
    };

    let mut lo = 1e-6;
    if balance(lo).0 <= 0.0 {
        return Err(DspError::NoSolution("no limit cycle above 1e-6 rad/s"));
    }
    let mut hi = lo;
    while balance(hi).0 > 0.0 {
        lo = hi;
        hi *= 2.0;
        if hi > 1e3 {
            return Err(DspError::NoSolution("no limit cycle below 1e3 rad/s"));
        }
    }
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if balance(mid).0 > 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
        if hi - lo <= 1e-14 * hi {
            break;
        }
    }
    let w = 0.5 * (lo + hi);
    let (_, amp) = balance(w);
    Ok((w, amp))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::ShipConfig;
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
        let servo = ServoConfig::default();
        assert!(limit_cycle_describing_function(-0.1, 1e-3, 0.1, 0.01, &servo).is_err());
        assert!(limit_cycle_describing_function(0.01, 0.0, 0.1, 0.01, &servo).is_err());
        assert!(limit_cycle_describing_function(0.01, 1e-3, 0.0, 0.01, &servo).is_err());
        assert!(limit_cycle_describing_function(0.01, 1e-3, 0.1, -0.01, &servo).is_err());
        assert!(limit_cycle_describing_function(0.01, 1e-3, 0.1, f64::NAN, &servo).is_err());
    }

    /// Brute force: integrate the servo alone with a tiny Euler step from rest for 40
    /// periods (the periodic state attracts at ~0.3 per period in the slowest case), then
    /// take the first Fourier coefficient of the last period numerically.
    fn servo_brute_force(h: f64, omega: f64, tr: f64, rate: f64) -> Complex64 {
        let period = 2.0 * PI / omega;
        let steps = 200_000;
        let dt = period / steps as f64;
        let mut d = 0.0;
        let mut acc = Complex64::new(0.0, 0.0);
        for p in 0..40 {
            for i in 0..steps {
                let t = i as f64 * dt;
                let cmd = if i < steps / 2 { h } else { -h };
                if p == 39 {
                    acc += d * (-Complex64::new(0.0, omega * t)).exp() * dt;
                }
                d += dt * ((cmd - d) / tr).clamp(-rate, rate);
            }
        }
        acc * (2.0 / period)
    }

    #[test]
    fn servo_first_harmonic_matches_brute_force() {
        for (h, omega, tr, rate) in [
            (5.0 * DEG, 0.035, 1.0, 4.0 * DEG), // rate limited, then exponential
            (5.0 * DEG, 0.5, 1.0, 4.0 * DEG),   // short half period
            (5.0 * DEG, 2.0, 1.0, 4.0 * DEG),   // never leaves the ramp: triangle
            (1.0 * DEG, 0.05, 2.0, 4.0 * DEG),  // never rate limited: first-order lag
        ] {
            let exact = servo_first_harmonic(h, omega, tr, rate);
            let brute = servo_brute_force(h, omega, tr, rate);
            assert!(
                (exact - brute).norm() < 2e-4 * brute.norm(),
                "{h} {omega}: {exact} vs {brute}"
            );
        }
        // A first-order lag without rate limit: S = 1 / (1 + i w T_r) exactly.
        let (h, omega, tr) = (1.0 * DEG, 0.05, 2.0);
        let s = servo_first_harmonic(h, omega, tr, 4.0 * DEG) / Complex64::new(0.0, -4.0 * h / PI);
        let lag = Complex64::new(1.0, 0.0) / Complex64::new(1.0, omega * tr);
        assert!((s - lag).norm() < 1e-12, "{s} vs {lag}");
    }

    #[test]
    fn servo_describing_function_is_the_lag_when_not_rate_limited() {
        let servo = ServoConfig {
            max_angle_deg: 30.0,
            max_rate_deg_s: 4.0,
            time_constant_s: 2.0,
        };
        let (h, omega) = (1.0 * DEG, 0.05);
        let s = servo_describing_function(h, omega, &servo).unwrap();
        let lag = Complex64::new(1.0, 0.0) / Complex64::new(1.0, omega * 2.0);
        assert!((s - lag).norm() < 1e-12, "{s} vs {lag}");
        // Rate limited: more lag than the linear servo.
        let s = servo_describing_function(8.0 * DEG, 0.5, &servo).unwrap();
        assert!(s.arg() < Complex64::new(1.0, 0.5 * 2.0).inv().arg());
        assert!(servo_describing_function(0.0, omega, &servo).is_err());
        assert!(servo_describing_function(h, f64::NAN, &servo).is_err());
    }

    #[test]
    fn ideal_servo_reduces_to_the_textbook_harmonic_balance() {
        // Servo much faster than the ship: A = 4h/(pi K_u), arg G(i w_u) = -pi + asin(eps/A).
        let servo = ServoConfig {
            max_angle_deg: 30.0,
            max_rate_deg_s: 1e6,
            time_constant_s: 1e-4,
        };
        let (a, b, h, eps) = (0.0146, 5.98e-4, 5.0 * DEG, 1.0 * DEG);
        let (w, amp) = limit_cycle_describing_function(a, b, h, eps, &servo).unwrap();
        let g = b / (w * (w * w + a * a).sqrt());
        assert_relative_eq!(amp, 4.0 * h / PI * g, max_relative = 1e-3);
        let arg_g = -PI / 2.0 - (w / a).atan();
        assert!((arg_g + PI - (eps / amp).asin()).abs() < 1e-3);
        // Closed form for the ideal servo on b/(s(s+a)): with x = w/a, the phase condition
        // atan(x) + asin(eps/A) = pi/2 gives eps/A = 1/sqrt(1+x^2), and the amplitude
        // condition A = (4h/pi) b / (a^2 x sqrt(1+x^2)) then gives x^3 + x = c with
        // c = 4 h b / (pi a^2 eps): one real root, by Cardano.
        let c = 4.0 * h * b / (PI * a * a * eps);
        let q = (c * c / 4.0 + 1.0 / 27.0).sqrt();
        let x = (c / 2.0 + q).cbrt() + (c / 2.0 - q).cbrt();
        assert_relative_eq!(x * x * x + x, c, max_relative = 1e-9);
        assert_relative_eq!(w, a * x, max_relative = 1e-3);
        assert_relative_eq!(amp, eps * (1.0 + x * x).sqrt(), max_relative = 1e-3);
    }

    /// Time-domain relay loop: relay with hysteresis on -heading, servo (Euler, 10 ms),
    /// ship ZOH. Returns (heading at 10 Hz from t = 0, switch-to-+h instants).
    fn relay_loop(a: f64, b: f64, h: f64, eps: f64, servo: &ServoConfig) -> (Vec<f64>, Vec<f64>) {
        let dt = 0.01;
        let total_s = 4000.0;
        let steps = (total_s / dt) as usize;
        let e = (-a * dt).exp();
        let (a10, b0, b1) = (
            (1.0 - e) / a,
            b / a * (1.0 - e),
            b / a * (dt - (1.0 - e) / a),
        );
        let (tr, rate) = (servo.time_constant_s, servo.max_rate_rad_s());
        let (mut r, mut psi, mut d) = (0.0, 0.5 * DEG, 0.0);
        let mut cmd = h;
        let mut heading = Vec::new();
        let mut switches = Vec::new();
        let mut err_prev = -psi;
        for i in 0..steps {
            let t = i as f64 * dt;
            if i % 10 == 0 {
                heading.push(psi);
            }
            let err = -psi;
            if cmd < 0.0 && err > eps {
                cmd = h;
                // Linear interpolation of the crossing of +eps.
                let f = (eps - err_prev) / (err - err_prev);
                switches.push(t - dt + f * dt);
            } else if cmd > 0.0 && err < -eps {
                cmd = -h;
            }
            err_prev = err;
            let r_next = e * r + b0 * d;
            psi += a10 * r + b1 * d;
            r = r_next;
            d += dt * ((cmd - d) / tr).clamp(-rate, rate);
        }
        (heading, switches)
    }

    /// The reference table of this relay loop (h 5 deg, eps 1 deg; docs/dsp.md, "HBT"):
    /// (u, D, period s, amplitude deg).
    const TABLE: [(f64, f64, f64, f64); 6] = [
        (4.0, 4000.0, 255.0, 3.38),
        (4.0, 10000.0, 345.0, 2.38),
        (7.0, 7000.0, 180.0, 2.88),
        (7.0, 7700.0, 187.0, 2.81),
        (10.0, 4000.0, 110.0, 3.90),
        (10.0, 10000.0, 145.0, 2.62),
    ];

    #[test]
    fn describing_function_and_simulation_against_the_domain_table() {
        let ship = ShipConfig::default();
        let servo = ServoConfig::default();
        let (h, eps) = (5.0 * DEG, 1.0 * DEG);
        for &(u, d, p_table, a_table) in &TABLE {
            let (a, b) = ship.nomoto(u, d);
            let (w, amp) = limit_cycle_describing_function(a, b, h, eps, &servo).unwrap();
            let p_df = 2.0 * PI / w;
            let a_df = amp / DEG;
            // Independent: simulate the loop, measure with analyse_limit_cycle after 1500 s.
            let (x, sw) = relay_loop(a, b, h, eps, &servo);
            let sw: Vec<f64> = sw.into_iter().filter(|&t| t > 1500.0).collect();
            let f = analyse_limit_cycle(0.0, 0.1, &x, &sw).unwrap();
            let (p_sim, a_sim) = (f.period_s, f.amplitude_rad / DEG);
            println!(
                "u {u:4} D {d:6}: table {p_table:5.1} s {a_table:.2} deg | DF {p_df:6.1} s \
                 ({:+.1} %) {a_df:.3} deg ({:+.1} %) | sim {p_sim:6.1} s ({:+.1} %) {a_sim:.3} \
                 deg ({:+.1} %), {} periods",
                100.0 * (p_df / p_table - 1.0),
                100.0 * (a_df / a_table - 1.0),
                100.0 * (p_sim / p_table - 1.0),
                100.0 * (a_sim / a_table - 1.0),
                f.periods
            );
            // Two-sided bounds: the describing function's period within 3 %, amplitude 5 %.
            assert_relative_eq!(p_df, p_table, max_relative = 0.03);
            assert_relative_eq!(a_df, a_table, max_relative = 0.05);
            assert_relative_eq!(p_sim, p_table, max_relative = 0.03);
            assert_relative_eq!(a_sim, a_table, max_relative = 0.05);
            // The describing function against the simulated loop (first-harmonic
            // approximation error only): within 1.4 % (period) and 2.4 % (amplitude).
            assert_relative_eq!(p_df, p_sim, max_relative = 0.02);
            assert_relative_eq!(a_df, a_sim, max_relative = 0.03);
            assert!(f.periods >= 3);
        }
    }

    proptest::proptest! {
        #[test]
        fn never_panics_on_arbitrary_input(
            t0 in proptest::prelude::any::<f64>(),
            dt in proptest::prelude::any::<f64>(),
            x in proptest::collection::vec(proptest::prelude::any::<f64>(), 0..50),
            sw in proptest::collection::vec(-10.0..10.0f64, 0..6),
            a in -1.0..1.0f64,
            b in -1.0..1.0f64,
            h in -1.0..1.0f64,
            eps in -0.1..0.5f64,
        ) {
            let _ = analyse_limit_cycle(t0, dt, &x, &sw);
            let _ = analyse_limit_cycle(0.0, 0.5, &x, &sw);
            let _ = limit_cycle_describing_function(a, b, h, eps, &ServoConfig::default());
        }
    }
}
