//! The surge-sway-yaw hull's state and input, and one Runge-Kutta step of its equations.

/// The hull's state (see the module documentation).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MmgState {
    /// Surge speed u [m/s].
    pub u_mps: f64,
    /// Sway speed at midship v [m/s].
    pub v_mps: f64,
    /// Yaw rate r [rad/s].
    pub r_rad_s: f64,
    /// Heading psi [rad], unwrapped.
    pub psi_rad: f64,
    /// Earth-fixed position along the initial heading's north axis x0 [m].
    pub x_m: f64,
    /// Earth-fixed position y0 [m].
    pub y_m: f64,
}

/// One classical Runge-Kutta step of `x' = f(x, delta)` over `tau_s` with the rudder going
/// linearly from `delta0_rad` to `delta1_rad` (its midpoint at the middle stages).
pub(in crate::sim) fn rk4_piece(
    state: MmgState,
    delta0_rad: f64,
    delta1_rad: f64,
    tau_s: f64,
    f: impl Fn(&[f64; 6], f64) -> [f64; 6],
) -> MmgState {
    let x = state.to_array();
    let dm = 0.5 * (delta0_rad + delta1_rad);
    let at = |k: &[f64; 6], h: f64| {
        let mut y = x;
        for (yi, ki) in y.iter_mut().zip(k) {
            *yi += h * ki;
        }
        y
    };
    let k1 = f(&x, delta0_rad);
    let k2 = f(&at(&k1, 0.5 * tau_s), dm);
    let k3 = f(&at(&k2, 0.5 * tau_s), dm);
    let k4 = f(&at(&k3, tau_s), delta1_rad);
    let mut y = x;
    for i in 0..6 {
        y[i] += tau_s / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
    }
    MmgState::from_array(y)
}

impl MmgState {
    fn to_array(self) -> [f64; 6] {
        [
            self.u_mps,
            self.v_mps,
            self.r_rad_s,
            self.psi_rad,
            self.x_m,
            self.y_m,
        ]
    }

    fn from_array(a: [f64; 6]) -> Self {
        Self {
            u_mps: a[0],
            v_mps: a[1],
            r_rad_s: a[2],
            psi_rad: a[3],
            x_m: a[4],
            y_m: a[5],
        }
    }
}

/// What acts on the hull over a piece besides its own state.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MmgInput {
    /// Rudder effectiveness e: multiplies the rudder normal force (1 nominal).
    pub rudder_effectiveness: f64,
    /// The sea's rudder-equivalent bias beta [rad].
    pub sea_rad: f64,
    /// Displacement factor D / D_nom: multiplies m and I_zG.
    pub mass_factor: f64,
}

impl Default for MmgInput {
    fn default() -> Self {
        Self {
            rudder_effectiveness: 1.0,
            sea_rad: 0.0,
            mass_factor: 1.0,
        }
    }
}
