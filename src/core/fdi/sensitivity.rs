//! How a change of `b` (displacement, rudder effectiveness) moves a test's features on this
//! vessel, so that isolation reads the displacement's direction through the networks at
//! the vessel's own operating point instead of assuming it.
//!
//! `b` is the ship's high-frequency gain: `psi/delta = b / (s (s + a))` on the training model,
//! and on any hull whose rudder force and inertia scale together it multiplies the whole
//! transfer function. Scaling it by `k`:
//!
//! - **CLFRT**: the tones sit at fixed frequencies, so every tone's gain is multiplied by `k`
//!   and no phase moves: exact for any hull of that kind.
//! - **HBT**: the relay with height `h` and hysteresis `eps` holds the limit cycle where
//!   `k G(jw) = -(pi / 4h) (sqrt(A^2 - eps^2) + j eps)`; the cycle moves. Locally the ship is
//!   the first-order model with the `a` its measured response phase gives at the cycle,
//!   `phi = -pi/2 - atan(w/a)`. Then, with `q = w^2 / (w^2 + a^2)`:
//!
//! ```text
//! d ln w / d ln k        = 1 / (1 + 2 q)                (from k Im G(jw) = -pi eps / 4h)
//! d ln sqrt(A^2 - eps^2) = d ln k - 2 q d ln w          (from k Re G(jw))
//! d ln |G(jw)| / d ln k  = 1 - (1 + q) d ln w / d ln k  (the response gain, measured rudder)
//! d phi / d ln k         = -sqrt(q (1 - q)) d ln w / d ln k
//! ```
//!
//! and the periods scale with `1/w` (their relative spread unchanged).

use crate::core::wire::Features;

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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::core::wire::features::sample;

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
