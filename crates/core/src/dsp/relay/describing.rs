//! HBT: the describing-function prediction of the relay test's limit cycle, servo included.
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

use crate::dsp::{check_positive, DspError};
use crate::model::ServoConfig;
use rustfft::num_complex::Complex64;
use std::f64::consts::PI;

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
    use crate::dsp::relay::analyse_limit_cycle;
    use crate::model::ShipConfig;
    use approx::assert_relative_eq;

    const DEG: f64 = PI / 180.0;

    #[test]
    fn bad_input_is_an_error() {
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
            a in -1.0..1.0f64,
            b in -1.0..1.0f64,
            h in -1.0..1.0f64,
            eps in -0.1..0.5f64,
        ) {
            let _ = limit_cycle_describing_function(a, b, h, eps, &ServoConfig::default());
        }
    }
}
