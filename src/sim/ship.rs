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
