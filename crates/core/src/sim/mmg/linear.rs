//! The linearised sway-yaw model as a second-order Nomoto model, on either side of
//! beta_R = 0.

/// Which side of beta_R = 0 a linearisation is taken on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Side {
    /// beta_R > 0 (starboard turn, gamma_R = 0.640).
    Starboard,
    /// beta_R < 0 (port turn, gamma_R = 0.395).
    Port,
}

/// The second-order Nomoto model `r/delta = K (1 + T3 s) / ((1 + T1 s)(1 + T2 s))` of the
/// linearised sway-yaw equations (T1 < 0 on a course-unstable side).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LinearNomoto {
    /// Gain K [1/s].
    pub k_per_s: f64,
    /// Slow time constant T1 [s] (1 / the pole nearer zero).
    pub t1_s: f64,
    /// Fast time constant T2 [s].
    pub t2_s: f64,
    /// Zero T3 [s].
    pub t3_s: f64,
}

impl LinearNomoto {
    /// The yaw rate's answer to the rudder of the linear sway-yaw system `M (v', r') = A (v,
    /// r) + B delta` (`M` the inertia matrix with added masses, `A` the damping with the
    /// Coriolis terms, `B` the rudder's force and moment): `r/delta = (g2 s + f21 g1 - f11 g2)
    /// / (s^2 - tr s + det)` with `F = M^-1 A`, `G = M^-1 B`, in seconds when the system's
    /// time unit is `time_s` seconds and its yaw rate is per that unit (1 for a dimensional
    /// system).
    pub fn of_sway_yaw(m: [[f64; 2]; 2], a: [[f64; 2]; 2], b: [f64; 2], time_s: f64) -> Self {
        let ([m11, m12], [m21, m22]) = (m[0], m[1]);
        let ([a11, a12], [a21, a22]) = (a[0], a[1]);
        let det_m = m11 * m22 - m12 * m21;
        let f11 = (m22 * a11 - m12 * a21) / det_m;
        let f12 = (m22 * a12 - m12 * a22) / det_m;
        let f21 = (m11 * a21 - m21 * a11) / det_m;
        let f22 = (m11 * a22 - m21 * a12) / det_m;
        let g1 = (m22 * b[0] - m12 * b[1]) / det_m;
        let g2 = (m11 * b[1] - m21 * b[0]) / det_m;
        let tr = f11 + f22;
        let det = f11 * f22 - f12 * f21;
        let num0 = f21 * g1 - f11 * g2;
        let disc = (tr * tr - 4.0 * det).max(0.0).sqrt();
        let (p_slow, p_fast) = ((tr + disc) / 2.0, (tr - disc) / 2.0);
        Self {
            k_per_s: num0 / det / time_s,
            t1_s: -time_s / p_slow,
            t2_s: -time_s / p_fast,
            t3_s: g2 / num0 * time_s,
        }
    }

    /// Nomoto's first-order approximation (K, T = T1 + T2 - T3).
    pub fn first_order(&self) -> (f64, f64) {
        (self.k_per_s, self.t1_s + self.t2_s - self.t3_s)
    }
}
