//! The vessel's loop shape (docs/fdi.md, "Residuals"): the slopes of its measured frequency
//! response (rudder to heading) around HBT's cycle, from its own last CLFRT tests, so that
//! HBT's displacement direction follows this ship's harmonic balance
//! (`sensitivity::scale_b_at`) and not the first-order model's.
//!
//! [`LoopShape::learn`] keeps the last [`TESTS`] completed CLFRT tests that have a speed log
//! and at least two tones of positive frequency and gain, healthy or not: a change of `b`
//! moves no slope, and a speed-log bias `beta` moves where the shape is read by only
//! `beta / u` in `ln w`.
//!
//! [`LoopShape::slopes_at`] reads each kept test `i` at an HBT test's cycle moved by the
//! similarity law, `ln(w_u u_i / u_h)`, as the derivatives of the parabola through its
//! nearest tones (`sensitivity::tone_slopes`, within the tones' span and half a spacing
//! beyond), and returns their mean over the tests that cover it. It returns `None` for a
//! CLFRT test, an HBT test without a speed log, or when no kept test covers the cycle: HBT
//! then takes the first-order model. The tones are an octave or more apart: where a hull's
//! phase bends between them the parabola misses its slope.

use super::sensitivity::{tone_slopes, unwrap, ResponseSlopes};
use crate::wire::Features;
use serde::{Deserialize, Serialize};
use std::collections::VecDeque;

/// How many of the vessel's last CLFRT tests the shape keeps.
pub const TESTS: usize = 8;

/// One CLFRT test's measured response.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MeasuredResponse {
    /// The speed log over the test [m/s].
    pub speed_mps: f64,
    /// Per tone, increasing frequency: `(ln w [ln rad/s], ln|G|, arg G [rad], continuous)`.
    pub points: Vec<[f64; 3]>,
}

/// The last CLFRT tests' responses, oldest first.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct LoopShape {
    tests: VecDeque<MeasuredResponse>,
}

impl LoopShape {
    /// Takes a completed test's features: a CLFRT test with a speed log and two or more
    /// tones of positive frequency and gain is kept (the oldest dropped past [`TESTS`]).
    pub fn learn(&mut self, features: &Features) {
        let Features::Clfrt(c) = features else {
            return;
        };
        let Some(u) = c.speed_log_mps.filter(|u| u.is_finite() && *u > 0.0) else {
            return;
        };
        let mut tones: Vec<_> = c
            .tones
            .iter()
            .filter(|t| {
                t.omega_rad_s > 0.0 && t.gain > 0.0 && t.phase_rad.is_finite() && t.gain.is_finite()
            })
            .collect();
        tones.sort_by(|a, b| a.omega_rad_s.total_cmp(&b.omega_rad_s));
        if tones.len() < 2 {
            return;
        }
        let phases = unwrap(tones.iter().map(|t| t.phase_rad));
        let points = tones
            .iter()
            .zip(phases)
            .map(|(t, p)| [t.omega_rad_s.ln(), t.gain.ln(), p])
            .collect();
        self.tests.push_back(MeasuredResponse {
            speed_mps: u,
            points,
        });
        while self.tests.len() > TESTS {
            self.tests.pop_front();
        }
    }

    /// The loop's slopes at an HBT test's cycle (its frequency and speed log), the mean over
    /// the kept tests that cover it; `None` for another method, or when none covers it.
    pub fn slopes_at(&self, features: &Features) -> Option<ResponseSlopes> {
        let Features::Hbt(h) = features else {
            return None;
        };
        let u = h.speed_log_mps.filter(|u| u.is_finite() && *u > 0.0)?;
        let w = h.omega_u_rad_s;
        if !(w.is_finite() && w > 0.0) {
            return None;
        }
        let (mut sum, mut n) = ([0.0; 2], 0usize);
        for t in &self.tests {
            if let Some(s) = tone_slopes(&t.points, (w * t.speed_mps / u).ln()) {
                sum[0] += s.ln_gain;
                sum[1] += s.phase;
                n += 1;
            }
        }
        (n > 0).then(|| ResponseSlopes {
            ln_gain: sum[0] / n as f64,
            phase: sum[1] / n as f64,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fdi::sensitivity::{scale_b, scale_b_at};
    use crate::testing::sample;
    use rustfft::num_complex::Complex64;
    use std::f64::consts::PI;

    /// The second-order Nomoto hull `K (1 + s T3) / (s (1 + s T1) (1 + s T2))` at the
    /// family's upper strength (T2/T1 0.1, T3/T1 0.25), its gain times `k`.
    fn g(w: f64, k: f64) -> Complex64 {
        let (kk, t1, t2, t3) = (0.05 * k, 60.0, 6.0, 15.0);
        let s = Complex64::new(0.0, w);
        kk * (1.0 + s * t3) / (s * (1.0 + s * t1) * (1.0 + s * t2))
    }

    /// The relay's cycle on that hull by harmonic balance, solved directly: `k G(jw) N(A) =
    /// -1` with `N(A) = 4 h / (pi A) e^(-j theta)`, `sin theta = eps / A`, so `A = 4 h |k G|
    /// / pi` and `sin(arg G + pi) = eps / A` (bisection on w). Returns (w, A, |G|, arg G).
    fn cycle(k: f64) -> (f64, f64, f64, f64) {
        let (h, eps) = (0.14, 0.017);
        let f = |w: f64| {
            let z = g(w, k);
            (z.arg() + 2.0 * PI).rem_euclid(2.0 * PI)
                - PI
                - (eps * PI / (4.0 * h * z.norm())).min(1.0).asin()
        };
        let (mut lo, mut hi) = (0.01, 1.0);
        assert!(f(lo) > 0.0 && f(hi) < 0.0, "{} {}", f(lo), f(hi));
        for _ in 0..200 {
            let mid = 0.5 * (lo + hi);
            if f(mid) > 0.0 {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        let w = 0.5 * (lo + hi);
        let z = g(w, k);
        (w, 4.0 * h * z.norm() / PI, z.norm(), z.arg())
    }

    fn hbt_at(k: f64, u: f64) -> Features {
        let (w, a, gain, phase) = cycle(k);
        let mut h = sample::hbt();
        h.omega_u_rad_s = w;
        h.period_s = 2.0 * PI / w;
        h.amplitude_rad = a;
        h.hysteresis_rad = 0.017;
        h.relay_height_rad = 0.14;
        h.response_gain = Some(gain);
        h.response_phase_rad = Some(phase);
        h.speed_log_mps = Some(u);
        Features::Hbt(h)
    }

    /// The vessel's CLFRT test of that hull at speed `u_c`, tones at 0.032 / 0.075 / 0.18
    /// rad/s read from the response at `u_h` moved by the similarity law (`G_uc(jw) =
    /// G_uh(jw uc / uh)`), so that the shape must move it back.
    fn clfrt_at(u_c: f64, u_h: f64) -> Features {
        let tones = [0.0319, 0.0745, 0.181]
            .iter()
            .map(|&w| {
                let z = g(w * u_h / u_c, 1.0);
                sample::tone(w, z.norm(), z.arg())
            })
            .collect();
        let mut c = sample::clfrt(tones);
        c.speed_log_mps = Some(u_c);
        Features::Clfrt(c)
    }

    /// The parabola's slopes through three points of an exact parabola are exact, and a
    /// point outside the span (and half a spacing) has none.
    #[test]
    fn tone_slopes_differentiate_the_parabola_through_the_tones() {
        let p = |x: f64| [x, 1.0 + 2.0 * x - 0.5 * x * x, -0.3 * x + 0.1 * x * x];
        let pts = [p(-3.0), p(-2.0), p(-1.5)];
        let s = tone_slopes(&pts, -2.2).expect("inside");
        assert!((s.ln_gain - (2.0 + 2.2)).abs() < 1e-12, "{s:?}");
        assert!((s.phase - (-0.3 - 0.44)).abs() < 1e-12, "{s:?}");
        assert!(tone_slopes(&pts, -3.6).is_none());
        assert!(tone_slopes(&pts, -0.9).is_none());
        assert!(tone_slopes(&pts, -1.3).is_some());
    }

    /// On the second-order hull, a 1 % change of `b` moves HBT's cycle as harmonic balance
    /// solved on the hull's own transfer function says, when the slopes come from the
    /// vessel's CLFRT tests (at other speeds: the similarity law moves them back): the
    /// frequency's move within 10 % of the exact one, the amplitude's, gain's and phase's
    /// within 40 % (the parabola through tones an octave apart: module doc). The first-order
    /// model with the same measured lag misses the frequency's move by over 20 % and the
    /// amplitude's by over 100 % (so the slopes are what the test checks).
    #[test]
    fn the_hbt_cycle_moves_as_the_hulls_own_harmonic_balance_says() {
        let (u_h, k) = (7.0, 1.01);
        let mut shape = LoopShape::default();
        for u_c in [6.5, 7.0, 7.5] {
            shape.learn(&clfrt_at(u_c, u_h));
        }
        let at = hbt_at(1.0, u_h);
        let slopes = shape.slopes_at(&at).expect("the tones cover the cycle");
        let exact = hbt_at(k, u_h);
        let moves = |f: &Features| {
            let (Features::Hbt(a), Features::Hbt(b)) = (&at, f) else {
                panic!("HBT")
            };
            [
                (b.omega_u_rad_s / a.omega_u_rad_s).ln(),
                (b.amplitude_rad / a.amplitude_rad).ln(),
                (b.response_gain.unwrap() / a.response_gain.unwrap()).ln(),
                b.response_phase_rad.unwrap() - a.response_phase_rad.unwrap(),
            ]
        };
        let want = moves(&exact);
        let got = moves(&scale_b_at(&at, k, Some(slopes)).expect("scaled"));
        for (i, (g, w)) in got.iter().zip(want).enumerate() {
            assert!(w.abs() > 1e-4, "{want:?}");
            let tol = if i == 0 { 0.1 } else { 0.4 };
            assert!((g - w).abs() < tol * w.abs(), "{got:?} vs {want:?}");
        }
        let first_order = moves(&scale_b(&at, k).expect("scaled"));
        assert!(
            (first_order[0] - want[0]).abs() > 0.2 * want[0].abs()
                && (first_order[1] - want[1]).abs() > want[1].abs(),
            "{first_order:?} vs {want:?}"
        );
        // Without a CLFRT test that covers the cycle, the first-order model.
        assert_eq!(LoopShape::default().slopes_at(&at), None);
    }
}
