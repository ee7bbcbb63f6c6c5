//! The hull: Nomoto's first-order, type-1 yaw model, integrated exactly for a piecewise
//! linear input.
//!
//! ```text
//! psi' = r                                   heading [rad], unwrapped
//! r'   = -a r + b v(t),   v = e delta + beta turn rate [rad/s]; v: rudder-equivalent input [rad]
//! ```
//!
//! a [1/s] and b [1/s^2] come from `ShipConfig::nomoto(u, D)`, e is the rudder effectiveness
//! (1 nominal) and beta the sea's rudder-equivalent bias. For an input linear over a piece of
//! length tau, `v(t) = v0 + (v1 - v0) t / tau`, the exact solution is (z = -a tau)
//!
//! ```text
//! r(tau)   = e^z r0 + b tau   [ (phi1 - phi2) v0 + phi2 v1 ]
//! psi(tau) = psi0 + tau phi1 r0 + b tau^2 [ (phi2 - phi3) v0 + phi3 v1 ]
//! ```
//!
//! with `phi_k(z) = sum_n z^n / (n + k)!` (phi1 = (e^z - 1)/z, ...), evaluated by series for
//! small |z| so that nothing is lost when a tau is tiny. During a rate-limited ramp the rudder
//! *is* linear, so the piece is exact; during the servo's exponential phase the rudder is
//! linearly interpolated between sub-step end points (a first-order hold), with an error of
//! order h^2 / 12 times the rudder's second derivative, i.e. ~3e-5 of a command step at the
//! default h = 0.02 s and T_r = 1 s.

//!
//! ## Other structures
//!
//! A ship of another structure ([`crate::sim::config::StructureConfig`]) has the hull
//!
//! ```text
//! T1 T2 r'' + (T1 + T2) r' + H(r) = K (v + T3 v'),   H(r) = r + n3 r^3
//! ```
//!
//! integrated by [`GeneralHull`] with one classical Runge-Kutta step per piece (v linear over
//! it, as above). The derivative of the input is never formed: with
//! `w = T1 T2 r' - K T3 v` the state (psi, r, w) obeys
//!
//! ```text
//! psi' = r,   r' = (w + K T3 v) / (T1 T2),   w' = -(T1 + T2) r' - H(r) + K v
//! ```
//!
//! and, for T2 = 0 (first order with a zero), `w = T1 r - K T3 v`: `r = (w + K T3 v) / T1`,
//! `w' = K v - H(r)`. Pieces are at most a sub-step (0.02 s by default) against time constants
//! of seconds, so the local error (h^5 / T^4) is far below the sensors' noise.

/// `(e^z, phi1(z), phi2(z), phi3(z))`.
pub fn phis(z: f64) -> (f64, f64, f64, f64) {
    let ez = z.exp();
    if z.abs() < 1.0 {
        // phi_k(z) = sum_{n>=0} z^n / (n + k)!, 20 terms: error < 1/23! for |z| < 1.
        let (mut p1, mut p2, mut p3) = (0.0, 0.0, 0.0);
        let mut zn = 1.0; // z^n
        let mut f1 = 1.0; // 1 / (n + 1)!
        let mut f2 = 0.5; // 1 / (n + 2)!
        let mut f3 = 1.0 / 6.0; // 1 / (n + 3)!
        for n in 0..20 {
            p1 += zn * f1;
            p2 += zn * f2;
            p3 += zn * f3;
            let m = n as f64;
            zn *= z;
            f1 /= m + 2.0;
            f2 /= m + 3.0;
            f3 /= m + 4.0;
        }
        (ez, p1, p2, p3)
    } else {
        let p1 = (ez - 1.0) / z;
        let p2 = (p1 - 1.0) / z;
        let p3 = (p2 - 0.5) / z;
        (ez, p1, p2, p3)
    }
}

/// Coefficients of the exact update over one piece of length tau, for a given a.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HullStep {
    /// e^{-a tau}.
    r_r: f64,
    /// tau phi1: psi gain on r0.
    psi_r: f64,
    /// tau (phi1 - phi2), tau phi2: r gains on v0, v1 (times b).
    r_v0: f64,
    r_v1: f64,
    /// tau^2 (phi2 - phi3), tau^2 phi3: psi gains on v0, v1 (times b).
    psi_v0: f64,
    psi_v1: f64,
}

impl HullStep {
    /// The coefficients for damping `a_per_s` over `tau_s`.
    pub fn new(a_per_s: f64, tau_s: f64) -> Self {
        let (ez, p1, p2, p3) = phis(-a_per_s * tau_s);
        let t2 = tau_s * tau_s;
        Self {
            r_r: ez,
            psi_r: tau_s * p1,
            r_v0: tau_s * (p1 - p2),
            r_v1: tau_s * p2,
            psi_v0: t2 * (p2 - p3),
            psi_v1: t2 * p3,
        }
    }
}

/// Heading and turn rate of the hull.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hull {
    /// Heading psi [rad], unwrapped.
    pub psi_rad: f64,
    /// Turn rate r [rad/s].
    pub r_rad_s: f64,
}

impl Hull {
    /// Advances over one piece with input `v` going linearly from `v0_rad` to `v1_rad`.
    pub fn advance(&mut self, c: &HullStep, b_per_s2: f64, v0_rad: f64, v1_rad: f64) {
        let r0 = self.r_rad_s;
        self.psi_rad += c.psi_r * r0 + b_per_s2 * (c.psi_v0 * v0_rad + c.psi_v1 * v1_rad);
        self.r_rad_s = c.r_r * r0 + b_per_s2 * (c.r_v0 * v0_rad + c.r_v1 * v1_rad);
    }
}

/// The parameters of a hull of another structure (see the module documentation).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Structure {
    /// T1 [s].
    pub t1_s: f64,
    /// T2 [s] (0: first order).
    pub t2_s: f64,
    /// T3 [s] (the zero).
    pub t3_s: f64,
    /// K = b / a [1/s].
    pub k_per_s: f64,
    /// Cubic damping n3 [s^2/rad^2].
    pub n3_s2: f64,
}

impl Structure {
    /// The structure whose first-order approximation is (a, b): T1 + T2 - T3 = 1/a, K = b/a,
    /// with T2 = `t2_ratio` T1 and T3 = `t3_ratio` T1.
    pub fn new(a_per_s: f64, b_per_s2: f64, t2_ratio: f64, t3_ratio: f64, n3_s2: f64) -> Self {
        let t1 = 1.0 / (a_per_s * (1.0 + t2_ratio - t3_ratio));
        Self {
            t1_s: t1,
            t2_s: t2_ratio * t1,
            t3_s: t3_ratio * t1,
            k_per_s: b_per_s2 / a_per_s,
            n3_s2,
        }
    }

    fn damping(&self, r: f64) -> f64 {
        r + self.n3_s2 * r * r * r
    }

    /// For T2 = 0: the turn rate for the auxiliary state `w` under input `v` (with T2 > 0,
    /// r is a state of its own).
    fn rate(&self, w: f64, v: f64) -> f64 {
        (w + self.k_per_s * self.t3_s * v) / self.t1_s
    }

    /// d/dt of (psi, r, w) at input `v`.
    fn derivative(&self, x: [f64; 3], v: f64) -> [f64; 3] {
        let [_, r, w] = x;
        if self.t2_s > 0.0 {
            let rdot = (w + self.k_per_s * self.t3_s * v) / (self.t1_s * self.t2_s);
            let wdot = -(self.t1_s + self.t2_s) * rdot - self.damping(r) + self.k_per_s * v;
            [r, rdot, wdot]
        } else {
            let r = self.rate(w, v);
            [r, 0.0, self.k_per_s * v - self.damping(r)]
        }
    }
}

/// The auxiliary state of a hull of another structure; heading and turn rate stay in
/// [`Hull`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GeneralHull {
    /// w = T1 T2 r' - K T3 v (or T1 r - K T3 v for T2 = 0).
    pub w: f64,
}

impl GeneralHull {
    /// The hull at rest in turn (r' = 0) at rate `hull.r_rad_s` under input `v_rad`.
    pub fn steady(s: &Structure, hull: &Hull, v_rad: f64) -> Self {
        let kt3v = s.k_per_s * s.t3_s * v_rad;
        Self {
            w: match s.t2_s > 0.0 {
                true => -kt3v,
                false => s.t1_s * hull.r_rad_s - kt3v,
            },
        }
    }

    /// Advances over one piece of length `tau_s` with input going linearly from `v0` to `v1`:
    /// one classical Runge-Kutta step.
    pub fn advance(&mut self, s: &Structure, hull: &mut Hull, v0: f64, v1: f64, tau_s: f64) {
        let x = [hull.psi_rad, hull.r_rad_s, self.w];
        let vm = 0.5 * (v0 + v1);
        let at =
            |x: [f64; 3], k: [f64; 3], c: f64| [x[0] + c * k[0], x[1] + c * k[1], x[2] + c * k[2]];
        let k1 = s.derivative(x, v0);
        let k2 = s.derivative(at(x, k1, 0.5 * tau_s), vm);
        let k3 = s.derivative(at(x, k2, 0.5 * tau_s), vm);
        let k4 = s.derivative(at(x, k3, tau_s), v1);
        let mut y = [0.0; 3];
        for i in 0..3 {
            y[i] = x[i] + tau_s / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
        }
        hull.psi_rad = y[0];
        self.w = y[2];
        hull.r_rad_s = match s.t2_s > 0.0 {
            true => y[1],
            false => s.rate(y[2], v1),
        };
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn phis_series_and_closed_form_agree_at_the_switch() {
        let (e1, a1, b1, c1) = phis(-0.999_999_999);
        let (e2, a2, b2, c2) = phis(-1.000_000_001);
        for (x, y) in [(e1, e2), (a1, a2), (b1, b2), (c1, c2)] {
            assert!((x - y).abs() < 1e-8, "{x} {y}");
        }
        // Known values at z = -1: phi1 = 1 - 1/e, phi2 = 1/e, phi3 = 1/2 - 1/e.
        let e = (-1f64).exp();
        let (_, p1, p2, p3) = phis(-1.0);
        assert!((p1 - (1.0 - e)).abs() < 1e-14);
        assert!((p2 - e).abs() < 1e-14);
        assert!((p3 - (0.5 - e)).abs() < 1e-14);
        let (_, p1, p2, p3) = phis(0.0);
        assert_eq!((p1, p2, p3), (1.0, 0.5, 1.0 / 6.0));
    }

    /// Constant input from rest against the analytic step response, one long piece and many
    /// short pieces.
    #[test]
    fn constant_input_matches_analytic_step_response() {
        let (a, b, v): (f64, f64, f64) = (0.0146, 5.98e-4, 0.05);
        let t: f64 = 137.0;
        let k = b / a * v;
        let r_exact = k * (1.0 - (-a * t).exp());
        let psi_exact = k * (t - (1.0 - (-a * t).exp()) / a);
        let mut one = Hull {
            psi_rad: 0.0,
            r_rad_s: 0.0,
        };
        one.advance(&HullStep::new(a, t), b, v, v);
        let mut many = one;
        many.psi_rad = 0.0;
        many.r_rad_s = 0.0;
        let c = HullStep::new(a, t / 6850.0);
        for _ in 0..6850 {
            many.advance(&c, b, v, v);
        }
        for h in [one, many] {
            approx::assert_relative_eq!(h.r_rad_s, r_exact, max_relative = 1e-10);
            approx::assert_relative_eq!(h.psi_rad, psi_exact, max_relative = 1e-10);
        }
    }

    /// Runs a general hull from rest under the constant input `v` to `t_s`; returns the hull
    /// at `t_s` and at every whole second.
    fn general_step(s: &Structure, v: f64, t_s: f64, h: f64) -> Vec<Hull> {
        let mut hull = Hull {
            psi_rad: 0.0,
            r_rad_s: 0.0,
        };
        let mut g = GeneralHull::steady(s, &hull, 0.0);
        let n = (t_s / h).round() as usize;
        let per_s = (1.0 / h).round() as usize;
        let mut out = vec![hull];
        for i in 1..=n {
            // The step: the first piece ramps the input from 0, as a servo would in no time.
            let v0 = if i == 1 { 0.0 } else { v };
            g.advance(s, &mut hull, v0, v, h);
            if i % per_s == 0 {
                out.push(hull);
            }
        }
        out
    }

    /// Second-order Nomoto with a zero against its analytic step response,
    /// r(t) = K v [1 - (T1 - T3)/(T1 - T2) e^{-t/T1} - (T2 - T3)/(T2 - T1) e^{-t/T2}],
    /// and the first-order approximation it was built on: T1 + T2 - T3 = 1/a, K = b/a.
    #[test]
    fn second_order_step_response_matches_the_analytic_one() {
        let (a, b, v): (f64, f64, f64) = (0.0146, 5.98e-4, 0.05);
        let s = Structure::new(a, b, 0.1, 0.25, 0.0);
        assert!((s.t1_s + s.t2_s - s.t3_s - 1.0 / a).abs() < 1e-9);
        assert!((s.k_per_s - b / a).abs() < 1e-15);
        let h = 0.02;
        let run = general_step(&s, v, 300.0, h);
        let (t1, t2, t3, k) = (s.t1_s, s.t2_s, s.t3_s, s.k_per_s);
        // The ramp over the first piece delays the input by h/2.
        let exact = |t: f64| {
            let t = t - h / 2.0;
            k * v
                * (1.0
                    - (t1 - t3) / (t1 - t2) * (-t / t1).exp()
                    - (t2 - t3) / (t2 - t1) * (-t / t2).exp())
        };
        let mut worst: f64 = 0.0;
        for (sec, hull) in run.iter().enumerate().skip(1) {
            worst = worst.max((hull.r_rad_s - exact(sec as f64)).abs());
        }
        let scale = k * v;
        assert!(worst < 1e-4 * scale, "worst {worst} of {scale}");
        // And it is not the first-order response (the test can tell them apart).
        let first = k * v * (1.0 - (-10.0 * a).exp());
        assert!((run[10].r_rad_s - first).abs() > 1e-2 * scale);
    }

    /// T2 = 0 with a zero: r(t) = K v [1 - (1 - T3/T1) e^{-t/T1}] (r jumps by K v T3 / T1).
    #[test]
    fn first_order_with_a_zero_matches_the_analytic_step() {
        let (a, b, v): (f64, f64, f64) = (0.02, 4e-4, 0.03);
        let s = Structure::new(a, b, 0.0, 0.2, 0.0);
        let run = general_step(&s, v, 200.0, 0.02);
        let k = s.k_per_s;
        for (sec, hull) in run.iter().enumerate().skip(1) {
            let t = sec as f64 - 0.01;
            let exact = k * v * (1.0 - (1.0 - s.t3_s / s.t1_s) * (-t / s.t1_s).exp());
            assert!(
                (hull.r_rad_s - exact).abs() < 1e-5 * k * v,
                "t {t}: {} vs {exact}",
                hull.r_rad_s
            );
        }
    }

    /// No structure: the general integrator gives the exact first-order hull's answer.
    #[test]
    fn the_general_integrator_reduces_to_the_exact_first_order_hull() {
        let (a, b, v): (f64, f64, f64) = (0.0146, 5.98e-4, 0.05);
        let s = Structure::new(a, b, 0.0, 0.0, 0.0);
        let run = general_step(&s, v, 137.0, 0.02);
        let mut exact = Hull {
            psi_rad: 0.0,
            r_rad_s: 0.0,
        };
        exact.advance(&HullStep::new(a, 0.02), b, 0.0, v);
        exact.advance(&HullStep::new(a, 136.98), b, v, v);
        let last = run.last().unwrap();
        approx::assert_relative_eq!(last.r_rad_s, exact.r_rad_s, max_relative = 1e-9);
        approx::assert_relative_eq!(last.psi_rad, exact.psi_rad, max_relative = 1e-9);
    }

    /// Norrbin: the steady turn rate solves r + n3 r^3 = K v (Cardano's formula), well below
    /// the linear K v in a 20 deg turn (0.8 deg/s linear).
    #[test]
    fn cubic_damping_settles_on_the_root_of_the_cubic() {
        let (a, b, v): (f64, f64, f64) = (0.0146, 5.98e-4, 0.35);
        let n3 = 1000.0;
        let s = Structure::new(a, b, 0.0, 0.0, n3);
        let run = general_step(&s, v, 1500.0, 0.02);
        // r^3 + p r + q = 0 with p = 1/n3, q = -K v / n3: one real root.
        let (p, q) = (1.0 / n3, -s.k_per_s * v / n3);
        let d = (q * q / 4.0 + p * p * p / 27.0).sqrt();
        let root = (-q / 2.0 + d).cbrt() + (-q / 2.0 - d).cbrt();
        let r = run.last().unwrap().r_rad_s;
        approx::assert_relative_eq!(r, root, max_relative = 1e-6);
        assert!(r < 0.9 * s.k_per_s * v, "{r} vs linear {}", s.k_per_s * v);
    }

    /// Ramp input v = s t from rest: r = (b s / a) (t - (1 - e^{-a t}) / a).
    #[test]
    fn ramp_input_is_exact() {
        let (a, b, s): (f64, f64, f64) = (0.02, 4e-4, 0.001);
        let t: f64 = 40.0;
        let mut h = Hull {
            psi_rad: 0.0,
            r_rad_s: 0.0,
        };
        h.advance(&HullStep::new(a, t), b, 0.0, s * t);
        let r_exact = b * s / a * (t - (1.0 - (-a * t).exp()) / a);
        let psi_exact = b * s / a * (t * t / 2.0 - (t - (1.0 - (-a * t).exp()) / a) / a);
        approx::assert_relative_eq!(h.r_rad_s, r_exact, max_relative = 1e-10);
        approx::assert_relative_eq!(h.psi_rad, psi_exact, max_relative = 1e-8);
    }
}
