//! How a change of `b` (displacement, rudder effectiveness) or of the ship's speed moves a
//! test's features on this vessel: the residuals' directions and slopes (docs/fdi.md,
//! "Residuals"), read through the networks at the test's own point.
//!
//! **`b`** multiplies the transfer function by `k`. CLFRT ([`scale_b`]): every tone's gain
//! times `k`, no phase moves. HBT: the relay's cycle, `k G(jw) N(A) = -1`, moves by the
//! harmonic balance with the loop's local slopes at the cycle, `m = d ln|G| / d ln w` and
//! `p = d arg G / d ln w`, and the relay's lag:
//!
//! ```text
//! d ln w / d ln k = -1 / (m + p tan(lag)),     d ln A / d ln k = -p tan(lag) d ln w / d ln k
//! d ln |G(jw)| = d ln k + m d ln w,            d phi = p d ln w,    periods scale with 1/w
//! ```
//!
//! [`scale_b`] takes the first-order model at the cycle (`q = sin^2(lag)`: `d ln w / d ln k =
//! 1 / (1 + 2 q)`); [`scale_b_at`] the vessel's measured slopes ([`tone_slopes`], `shape`),
//! and the first-order model without them or where the cycle would not be stable
//! (`m + p tan(lag)` not below -1/2).
//!
//! **Speed**, by the similarity law ([`scale_speed`]): `G_u1(jw) = G_u0(jw u0 / u1)`. HBT's
//! cycle is the same cycle `u1 / u0` times faster; each CLFRT tone reads `ln G` interpolated
//! at `w_k u0 / u1` through the test's own tones. The servo and the sea do not scale.
//! [`ln_gain`] and [`ln_damping`] read `ln b` and `ln a` from the features, no network. Every
//! function returns `None` when the features do not say (no response, a lag outside
//! `(0, pi/2)`, too few tones, no speed log).

use crate::wire::Features;

/// The ln of the test's own estimate of the ship's high-frequency gain `b` [ln 1/s^2]: the
/// response where the ship is nearest its inertia, `psi / delta -> b / (jw)^2`, read straight
/// from the features (no network):
///
/// - **CLFRT**: the highest tone, `ln(|G(jw)| w^2)` (on the first-order model
///   `b / sqrt(1 + (a / w)^2)`: the tones sit well above `a`);
/// - **HBT**: the relay cycle's response gain and phase through the first-order model at
///   the cycle, `|G| = b / (w sqrt(w^2 + a^2))`, `tan(lag) = w / a`:
///   `ln(|G| w^2 / sin(lag))`.
///
/// `b` scales with `1 / D` (rudder force over inertia) and with `u^2` (the similarity law):
/// on a hull whose networks cannot read its displacement it still moves with it. `None`
/// when the features do not say (an HBT test without its response, a lag outside the
/// model's range).
pub fn ln_gain(features: &Features) -> Option<f64> {
    let v = match features {
        Features::Clfrt(c) => {
            let t = c
                .tones
                .iter()
                .filter(|t| t.omega_rad_s > 0.0 && t.gain > 0.0)
                .max_by(|a, b| a.omega_rad_s.total_cmp(&b.omega_rad_s))?;
            (t.gain * t.omega_rad_s * t.omega_rad_s).ln()
        }
        Features::Hbt(h) => {
            let w = h.omega_u_rad_s;
            let g = h.response_gain?;
            let lag = -h.response_phase_rad? - std::f64::consts::FRAC_PI_2;
            if !(lag > 0.0 && lag < std::f64::consts::FRAC_PI_2 && w > 0.0 && g > 0.0) {
                return None;
            }
            (g * w * w / lag.sin()).ln()
        }
        Features::None => return None,
    };
    v.is_finite().then_some(v)
}

/// The ln of the test's own estimate of the ship's yaw damping `a` [ln 1/s], the first-order
/// model's corner, read from the phase of the heading's response to the rudder (no
/// network): at a frequency `w`, `phi = -pi/2 - atan(w / a)`, so `a = w / tan(lag)`,
/// `lag = -phi - pi/2`.
///
/// - **CLFRT**: every tone's `ln a_k`, weighted by its variance from the tone's phase
///   interval (`d ln a / d lag = -2 / sin(2 lag)`: a tone far above the corner says little);
/// - **HBT**: the cycle's response phase.
///
/// `a` carries the speed (`a = a0 u / l`, and by the similarity law every hull's time
/// constants scale with `l / u`); on the Nomoto model not the displacement or the rudder
/// (they scale `b`, which moves no phase at a fixed frequency). Reported only (docs/fdi.md,
/// "Residuals"). `None` when the features do not say (no phase in the model's range).
pub fn ln_damping(features: &Features) -> Option<f64> {
    use std::f64::consts::FRAC_PI_2;
    let in_range = |lag: f64| lag > 0.0 && lag < FRAC_PI_2;
    let v = match features {
        Features::Clfrt(c) => {
            let (mut num, mut den) = (0.0, 0.0);
            for t in &c.tones {
                let lag = -t.phase_rad - FRAC_PI_2;
                let sd_phase = t.phase_ci90_rad / 1.645;
                if !(in_range(lag) && t.omega_rad_s > 0.0 && sd_phase > 0.0) {
                    continue;
                }
                let sd = sd_phase * 2.0 / (2.0 * lag).sin();
                let w = 1.0 / (sd * sd);
                num += w * (t.omega_rad_s / lag.tan()).ln();
                den += w;
            }
            (den > 0.0).then(|| num / den)?
        }
        Features::Hbt(h) => {
            let lag = -h.response_phase_rad? - FRAC_PI_2;
            let w = h.omega_u_rad_s;
            if !(in_range(lag) && w > 0.0) {
                return None;
            }
            (w / lag.tan()).ln()
        }
        Features::None => return None,
    };
    v.is_finite().then_some(v)
}

/// The features of the same test on a ship whose `b` is `k` times larger (`k` near 1), or
/// `None` when the features do not say enough (an HBT test without its response phase, or
/// one whose phase is outside the first-order model's range).
pub fn scale_b(features: &Features, k: f64) -> Option<Features> {
    let lk = k.ln();
    match features {
        Features::Clfrt(c) => {
            let mut c = c.clone();
            for t in &mut c.tones {
                t.gain *= k;
            }
            Some(Features::Clfrt(c))
        }
        Features::Hbt(h) => {
            let w = h.omega_u_rad_s;
            let lag = -h.response_phase_rad? - std::f64::consts::FRAC_PI_2;
            if !(lag > 0.0 && lag < std::f64::consts::FRAC_PI_2 && w > 0.0) {
                return None;
            }
            // tan(lag) = w / a, so q = w^2 / (w^2 + a^2) = sin^2(lag).
            let q = lag.sin().powi(2);
            let dlw = lk / (1.0 + 2.0 * q);
            let mut h = h.clone();
            let eps = h.hysteresis_rad;
            let a = h.amplitude_rad;
            let root = (a * a - eps * eps).max(0.0).sqrt() * (lk - 2.0 * q * dlw).exp();
            h.amplitude_rad = (root * root + eps * eps).sqrt();
            h.omega_u_rad_s = w * dlw.exp();
            h.period_s *= (-dlw).exp();
            h.period_std_s *= (-dlw).exp();
            h.response_gain = h.response_gain.map(|g| g * (lk - (1.0 + q) * dlw).exp());
            h.response_phase_rad = h
                .response_phase_rad
                .map(|p| p - (q * (1.0 - q)).sqrt() * dlw);
            Some(Features::Hbt(h))
        }
        Features::None => None,
    }
}

/// The local slopes of the ship's measured frequency response (rudder to heading) at one
/// frequency.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ResponseSlopes {
    /// `d ln|G| / d ln w`.
    pub ln_gain: f64,
    /// `d arg G / d ln w` [rad].
    pub phase: f64,
}

/// The slopes at `ln_omega` of a response measured at `points` (`(ln w, ln|G|, arg G)`,
/// increasing `w`, phases continuous): the derivative of the parabola through the three
/// points nearest (a line through two). `None` outside the points' span widened by half its
/// mean spacing on either side, or with fewer than two points.
pub fn tone_slopes(points: &[[f64; 3]], ln_omega: f64) -> Option<ResponseSlopes> {
    let n = points.len();
    if n < 2 || !ln_omega.is_finite() {
        return None;
    }
    let (lo, hi) = (points[0][0], points[n - 1][0]);
    let margin = 0.5 * (hi - lo) / (n - 1) as f64;
    if !(margin > 0.0 && ln_omega >= lo - margin && ln_omega <= hi + margin) {
        return None;
    }
    let nearest = points
        .iter()
        .enumerate()
        .min_by(|a, b| {
            (a.1[0] - ln_omega)
                .abs()
                .total_cmp(&(b.1[0] - ln_omega).abs())
        })
        .map(|(k, _)| k)?;
    let idx = stencil(n, nearest);
    // d/dx of Lagrange's form: sum_i y_i sum_{j != i} prod_{l != i, j} (x - x_l) / prod_{j != i} (x_i - x_j).
    let mut d = [0.0; 2];
    for &i in &idx {
        let mut den = 1.0;
        let mut num = 0.0;
        for &j in idx.iter().filter(|&&j| j != i) {
            den *= points[i][0] - points[j][0];
            num += idx
                .iter()
                .filter(|&&l| l != i && l != j)
                .map(|&l| ln_omega - points[l][0])
                .product::<f64>();
        }
        if den.abs() < 1e-12 {
            return None;
        }
        for (c, dc) in d.iter_mut().enumerate() {
            *dc += points[i][c + 1] * num / den;
        }
    }
    let s = ResponseSlopes {
        ln_gain: d[0],
        phase: d[1],
    };
    (s.ln_gain.is_finite() && s.phase.is_finite()).then_some(s)
}

/// [`scale_b`] with HBT's cycle moved by the loop's measured local `slopes` at the cycle
/// (module doc) instead of the first-order model's; CLFRT's tones as in [`scale_b`]. `None`
/// slopes, or slopes under which the cycle would not be stable (`m + p tan(lag)` not below
/// -1/2: a cycle whose frequency moves over twice as fast as `b`), take the first-order model.
pub fn scale_b_at(features: &Features, k: f64, slopes: Option<ResponseSlopes>) -> Option<Features> {
    let (Features::Hbt(h), Some(sl)) = (features, slopes) else {
        return scale_b(features, k);
    };
    let w = h.omega_u_rad_s;
    let lag = -h.response_phase_rad? - std::f64::consts::FRAC_PI_2;
    if !(lag > 0.0 && lag < std::f64::consts::FRAC_PI_2 && w > 0.0) {
        return None;
    }
    let den = sl.ln_gain + sl.phase * lag.tan();
    if den.is_nan() || den >= -0.5 {
        return scale_b(features, k);
    }
    let lk = k.ln();
    let dlw = -lk / den;
    let dla = -sl.phase * lag.tan() * dlw;
    let mut h = h.clone();
    h.amplitude_rad *= dla.exp();
    h.omega_u_rad_s = w * dlw.exp();
    h.period_s *= (-dlw).exp();
    h.period_std_s *= (-dlw).exp();
    h.response_gain = h.response_gain.map(|g| g * (lk + sl.ln_gain * dlw).exp());
    h.response_phase_rad = h.response_phase_rad.map(|p| p + sl.phase * dlw);
    Some(Features::Hbt(h))
}

/// The features of the same test on the same ship at speed `u1_mps` (the similarity law, see
/// the module documentation), the speed log reading `u1_mps`; `None` when the test has no
/// speed log or CLFRT fewer than two tones.
pub fn scale_speed(features: &Features, u1_mps: f64) -> Option<Features> {
    let u0 = features
        .speed_log_mps()
        .filter(|u| u.is_finite() && *u > 0.0)?;
    if !(u1_mps.is_finite() && u1_mps > 0.0) {
        return None;
    }
    let r = u1_mps / u0;
    match features {
        Features::Hbt(h) => {
            let mut h = h.clone();
            h.omega_u_rad_s *= r;
            h.period_s /= r;
            h.period_std_s /= r;
            h.min_switch_interval_s /= r;
            h.speed_log_mps = Some(u1_mps);
            Some(Features::Hbt(h))
        }
        Features::Clfrt(c) => {
            let n = c.tones.len();
            if n < 2
                || c.tones
                    .iter()
                    .any(|t| !(t.omega_rad_s > 0.0 && t.gain > 0.0))
            {
                return None;
            }
            let x: Vec<f64> = c.tones.iter().map(|t| t.omega_rad_s.ln()).collect();
            let gain: Vec<f64> = c.tones.iter().map(|t| t.gain.ln()).collect();
            let phase = unwrap(c.tones.iter().map(|t| t.phase_rad));
            let shift = -r.ln();
            let mut c = c.clone();
            for (k, t) in c.tones.iter_mut().enumerate() {
                let at = x[k] + shift;
                let dg = interpolate(&x, &gain, at, k)? - gain[k];
                let dp = interpolate(&x, &phase, at, k)? - phase[k];
                t.gain *= dg.exp();
                t.phase_rad += dp;
            }
            c.speed_log_mps = Some(u1_mps);
            Some(Features::Clfrt(c))
        }
        Features::None => None,
    }
}

/// Phases made continuous from one tone to the next (steps within `(-pi, pi]`).
pub(super) fn unwrap(phases: impl Iterator<Item = f64>) -> Vec<f64> {
    let mut out: Vec<f64> = Vec::new();
    for p in phases {
        let q = match out.last() {
            Some(&prev) => {
                let tau = std::f64::consts::TAU;
                prev + (p - prev + std::f64::consts::PI).rem_euclid(tau) - std::f64::consts::PI
            }
            None => p,
        };
        out.push(q);
    }
    out
}

/// The points a parabola near point `k` of `n >= 2` goes through: the three centred on `k`
/// (shifted inside at the ends), the two when there are two.
fn stencil(n: usize, k: usize) -> Vec<usize> {
    if n == 2 {
        vec![0, 1]
    } else {
        let lo = k.saturating_sub(1).min(n - 3);
        vec![lo, lo + 1, lo + 2]
    }
}

/// `y` over `x` (increasing) at `at`, near point `k`: the parabola through the three points
/// nearest `k` (a line through two).
fn interpolate(x: &[f64], y: &[f64], at: f64, k: usize) -> Option<f64> {
    let idx = stencil(x.len(), k);
    // Lagrange's form.
    let mut v = 0.0;
    for &i in &idx {
        let mut l = 1.0;
        for &j in &idx {
            if j != i {
                let d = x[i] - x[j];
                if d.abs() < 1e-12 {
                    return None;
                }
                l *= (at - x[j]) / d;
            }
        }
        v += l * y[i];
    }
    v.is_finite().then_some(v)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::sample;

    /// The HBT cycle of the first-order model found by solving the harmonic-balance
    /// equations directly (bisection on the imaginary part), against the local derivatives.
    #[test]
    fn the_hbt_cycle_moves_as_harmonic_balance_says() {
        let (a, b, h_relay, eps) = (0.0146, 5.98e-4, 0.14, 0.017);
        let cycle = |b: f64| {
            // k Im G = -b a / (w (w^2 + a^2)) = -pi eps / (4 h): solve for w.
            let target = std::f64::consts::PI * eps / (4.0 * h_relay);
            let (mut lo, mut hi) = (1e-4, 10.0);
            for _ in 0..200 {
                let mid: f64 = 0.5 * (lo + hi);
                if b * a / (mid * (mid * mid + a * a)) > target {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            let w = 0.5 * (lo + hi);
            let re = b / (w * w + a * a);
            let root = re * 4.0 * h_relay / std::f64::consts::PI;
            let amp = (root * root + eps * eps).sqrt();
            let gain = b / (w * (w * w + a * a).sqrt());
            let phase = -std::f64::consts::FRAC_PI_2 - (w / a).atan();
            (w, amp, gain, phase)
        };
        let (w0, a0, g0, p0) = cycle(b);
        let mut hf = sample::hbt();
        hf.omega_u_rad_s = w0;
        hf.period_s = 2.0 * std::f64::consts::PI / w0;
        hf.amplitude_rad = a0;
        hf.hysteresis_rad = eps;
        hf.relay_height_rad = h_relay;
        hf.response_gain = Some(g0);
        hf.response_phase_rad = Some(p0);
        let k = 1.001;
        let Some(Features::Hbt(s)) = scale_b(&Features::Hbt(hf), k) else {
            panic!("no scaled features")
        };
        let (w1, a1, g1, p1) = cycle(b * k);
        // Relative changes agree to first order (the step is 0.1 %: second order is 1e-6).
        let close = |got: f64, want: f64, base: f64| {
            let (dg, dw) = (got / base - 1.0, want / base - 1.0);
            assert!((dg - dw).abs() < 0.02 * dw.abs() + 1e-7, "{dg} vs {dw}");
        };
        close(s.omega_u_rad_s, w1, w0);
        close(s.amplitude_rad, a1, a0);
        close(s.response_gain.unwrap(), g1, g0);
        let dp = s.response_phase_rad.unwrap() - p0;
        assert!(
            (dp - (p1 - p0)).abs() < 0.02 * (p1 - p0).abs() + 1e-9,
            "{dp} {}",
            p1 - p0
        );
    }

    /// The second-order Nomoto hull of the family at the upper strength (T2/T1 0.1, T3/T1
    /// 0.25, time constants and gain scaling with the speed as the similarity law says),
    /// measured by CLFRT's three tones at 7 m/s and moved to 6.5 and 7.5 m/s, against its
    /// analytic transfer function at those speeds: the interpolated tones explain the gain's
    /// move (11-13 %) to within 8 % of it (4-6 % measured), and leave less than the move and
    /// under 0.008 rad of the phase's (0.009-0.02 rad; the parabola's error is largest at the
    /// lowest tone, 0.006 rad, a third of a tone's 90 % interval in a calm sea). The moves
    /// themselves are asserted large, so that nothing moving cannot pass.
    #[test]
    fn clfrt_tones_at_another_speed_follow_the_analytic_transfer_function() {
        use rustfft::num_complex::Complex64;
        let (l, a0, kp) = (120.0, 0.25, 0.041 * 120.0 / 7.0);
        let g = |u: f64, w: f64| -> Complex64 {
            // 1/a = T1 + T2 - T3 with T2 = 0.1 T1, T3 = 0.25 T1; K = K' u / l.
            let t1 = l / (a0 * u) / (1.0 + 0.1 - 0.25);
            let (t2, t3) = (0.1 * t1, 0.25 * t1);
            let s = Complex64::new(0.0, w);
            kp * u / l * (1.0 + t3 * s) / (s * (1.0 + t1 * s) * (1.0 + t2 * s))
        };
        let omegas = [3.0, 7.0, 17.0].map(|k| 2.0 * std::f64::consts::PI * k / 590.0);
        let at = |u: f64| {
            let mut c = sample::clfrt(
                omegas
                    .iter()
                    .map(|&w| {
                        let z = g(u, w);
                        sample::tone(w, z.norm(), z.arg())
                    })
                    .collect(),
            );
            c.speed_log_mps = Some(u);
            c
        };
        let base = at(7.0);
        for u1 in [6.5, 7.5] {
            let Some(Features::Clfrt(moved)) = scale_speed(&Features::Clfrt(base.clone()), u1)
            else {
                panic!("no features at {u1} m/s")
            };
            let want = at(u1);
            assert_eq!(moved.speed_log_mps, Some(u1));
            for k in 0..3 {
                let (b, m, w) = (&base.tones[k], &moved.tones[k], &want.tones[k]);
                let dg_true = (w.gain / b.gain).ln();
                let dg_err = (m.gain / w.gain).ln();
                let dp_true = wrap(w.phase_rad - b.phase_rad);
                let dp_err = wrap(m.phase_rad - w.phase_rad);
                assert!(dg_true.abs() > 0.02, "tone {k}: gain moved {dg_true}");
                assert!(dp_true.abs() > 0.005, "tone {k}: phase moved {dp_true}");
                assert!(
                    dg_err.abs() < 0.08 * dg_true.abs(),
                    "tone {k} at {u1}: ln gain error {dg_err} of a move {dg_true}"
                );
                assert!(
                    dp_err.abs() < 0.008 && dp_err.abs() < dp_true.abs(),
                    "tone {k} at {u1}: phase error {dp_err} of a move {dp_true}"
                );
            }
        }
    }

    fn wrap(x: f64) -> f64 {
        (x + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU) - std::f64::consts::PI
    }

    /// HBT's cycle at another speed: the same cycle faster (exact).
    #[test]
    fn the_hbt_cycle_at_another_speed_is_the_same_cycle_faster() {
        let mut h = sample::hbt();
        h.speed_log_mps = Some(7.0);
        h.response_gain = Some(0.4);
        h.response_phase_rad = Some(-2.7);
        let Some(Features::Hbt(m)) = scale_speed(&Features::Hbt(h.clone()), 8.0) else {
            panic!()
        };
        let r = 8.0 / 7.0;
        assert!((m.omega_u_rad_s / h.omega_u_rad_s - r).abs() < 1e-12);
        assert!((m.period_s * r - h.period_s).abs() < 1e-9);
        assert!((m.period_std_s / m.period_s - h.period_std_s / h.period_s).abs() < 1e-12);
        assert_eq!(m.amplitude_rad, h.amplitude_rad);
        assert_eq!(m.response_gain, h.response_gain);
        assert_eq!(m.response_phase_rad, h.response_phase_rad);
        assert_eq!(m.speed_log_mps, Some(8.0));
        // Without a speed log there is no speed to scale from.
        assert!(scale_speed(&Features::Hbt(sample::hbt()), 8.0).is_none());
    }

    #[test]
    fn clfrt_gains_scale_and_phases_stay() {
        let c = sample::clfrt(vec![
            sample::tone(0.03, 2.0, -2.0),
            sample::tone(0.07, 0.5, -2.5),
        ]);
        let Some(Features::Clfrt(s)) = scale_b(&Features::Clfrt(c.clone()), 1.1) else {
            panic!()
        };
        for (a, b) in s.tones.iter().zip(&c.tones) {
            assert!((a.gain / b.gain - 1.1).abs() < 1e-12);
            assert_eq!(a.phase_rad, b.phase_rad);
        }
    }
}
