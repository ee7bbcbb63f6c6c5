//! A surge-sway-yaw hull from a published manoeuvring model: the MMG standard model of the
//! KVLCC2 tanker (Yasukawa & Yoshimura 2015, "Introduction of MMG standard method for ship
//! maneuvering predictions", J. Mar. Sci. Technol. 20:37-52; below "Y&Y"), scaled by Froude
//! similarity to a chosen length.
//!
//! ## State and equations of motion (Y&Y eq. 4, midship-fixed axes)
//!
//! ```text
//! x = (u, v, r, psi, x0, y0)   surge u [m/s], sway at midship v [m/s], yaw rate r [rad/s],
//!                              heading psi [rad], earth-fixed position x0, y0 [m]
//! (m + m_x) u' - (m + m_y) v r - x_G m r^2       = X_H + X_P + X_R
//! (m + m_y) v' + (m + m_x) u r + x_G m r'        = Y_H + Y_R + Y_S
//! (I_zG + x_G^2 m + J_z) r' + x_G m (v' + u r)   = N_H + N_R + N_S
//! psi' = r,  x0' = u cos psi - v sin psi,  y0' = u sin psi + v cos psi
//! ```
//!
//! m = rho V (times the displacement factor D / D_nom), I_zG = m (0.25 L)^2, added masses
//! m_x, m_y = (rho/2) L^2 d (m_x', m_y'), J_z = (rho/2) L^4 d J_z'. (Y_S, N_S) is the sea's
//! rudder-equivalent yaw disturbance beta: the straight-running linear rudder force and moment
//! of a rudder angle beta, `(Y_delta, N_delta) beta`.
//!
//! ## Hull (Y&Y eq. 7-8), U = sqrt(u^2 + v^2), v' = v/U, r' = r L/U
//!
//! ```text
//! X_H = (rho/2) L d U^2 (-R_0' + X_vv' v'^2 + X_vr' v' r' + X_rr' r'^2 + X_vvvv' v'^4)
//! Y_H = (rho/2) L d U^2 (Y_v' v' + Y_R' r' + Y_vvv' v'^3 + Y_vvr' v'^2 r' + Y_vrr' v' r'^2 + Y_rrr' r'^3)
//! N_H = (rho/2) L^2 d U^2 (N_v' v' + N_R' r' + N_vvv' v'^3 + N_vvr' v'^2 r' + N_vrr' v' r'^2 + N_rrr' r'^3)
//! ```
//!
//! ## Propeller (Y&Y eq. 9-13), constant revolutions n_P [1/s]
//!
//! ```text
//! X_P = (1 - t_P) rho n_P^2 D_P^4 K_T(J_P),   K_T = k_0 + k_1 J_P + k_2 J_P^2
//! J_P = u (1 - w_P) / (n_P D_P),   beta = atan(-v/u),   beta_P = beta - x_P' r'
//! 1 - w_P = (1 - w_P0) [1 + (1 - exp(-C_1 |beta_P|)) (C_2 - 1)],  C_2 = 1.6 (beta_P > 0), 1.1
//! ```
//!
//! n_P is set at construction so that X = 0 in straight running at the design speed u0 (a
//! bisection on n_P; X_P is increasing in n_P).
//!
//! ## Rudder (Y&Y eq. 14-24), rudder angle delta [rad], effectiveness e (1 nominal)
//!
//! ```text
//! F_N = e (rho/2) A_R U_R^2 f_alpha sin alpha_R,   U_R^2 = u_R^2 + v_R^2,   alpha_R = delta - atan(v_R/u_R)
//! X_R = -(1 - t_R) F_N sin delta,  Y_R = -(1 + a_H) F_N cos delta,  N_R = -(x_R + a_H x_H) F_N cos delta
//! u_R = eps u (1 - w_P) sqrt(eta {1 + kappa (sqrt(1 + 8 K_T / (pi J_P^2)) - 1)}^2 + (1 - eta)),  eta = D_P / H_R
//! v_R = U gamma_R beta_R,   beta_R = beta - l_R' r',   gamma_R = 0.640 (beta_R > 0), 0.395 (beta_R <= 0)
//! ```
//!
//! u_R is evaluated as
//! `eps sqrt(eta (u_P + kappa (sqrt(u_P^2 + 8 K_T (n_P D_P)^2 / pi) - u_P))^2 + (1 - eta) u_P^2)`,
//! u_P = u (1 - w_P), the same expression without the 1/J_P singularity.
//! Positive delta turns the ship to starboard (r > 0), as on the Nomoto hull.
//!
//! ## Constants (Y&Y Tables 1-3, KVLCC2 model, scale 1/45.7: L_pp = 7.00 m)
//!
//! | | |
//! |---|---|
//! | particulars | L = 7.00 m, d = 0.46 m, V = 3.27 m^3, x_G = 0.25 m, D_P = 0.216 m, H_R = 0.345 m, A_R = 0.0539 m^2 |
//! | added masses | m_x' = 0.022, m_y' = 0.223, J_z' = 0.011 |
//! | hull | R_0' = 0.022; X_vv' = -0.040, X_vr' = 0.002, X_rr' = 0.011, X_vvvv' = 0.771; Y_v' = -0.315, Y_R' = 0.083, Y_vvv' = -1.607, Y_vvr' = 0.379, Y_vrr' = -0.391, Y_rrr' = 0.008; N_v' = -0.137, N_R' = -0.049, N_vvv' = -0.030, N_vvr' = -0.294, N_vrr' = 0.055, N_rrr' = -0.013 |
//! | propeller | t_P = 0.220, w_P0 = 0.40, x_P' = -0.48, k_0 = 0.2931, k_1 = -0.2753, k_2 = -0.1385, C_1 = 2.0, C_2 = 1.6 / 1.1 |
//! | rudder | t_R = 0.387, a_H = 0.312, x_H' = -0.464, x_R' = -0.5, eps = 1.09, kappa = 0.50, l_R' = -0.710, gamma_R = 0.395 / 0.640, f_alpha = 2.747 |
//!
//! ## Scale
//!
//! Lengths scale with lambda = L / 7.00 m (volume lambda^3, areas lambda^2); every
//! non-dimensional coefficient is kept, and the speed is the scenario's. The manoeuvre in
//! ship lengths is then the same at every length and speed (time goes with L/U), which is how
//! the turning test compares with the published model-scale figures. The displacement factor
//! D / D_nom multiplies m and I_zG only: draft, added masses and every force are those of the
//! design loading (a lighter or heavier ship of the same immersed shape; the mass is what a
//! displacement fault changes, as b does on the Nomoto hull).
//!
//! ## Integration
//!
//! One classical Runge-Kutta step per servo piece (delta linear over it), as for the other
//! structured hulls; pieces are at most a sub-step (0.02 s) against the hull's fastest time
//! constant of several seconds at 120 m.
//!
//! ## Linear sway-yaw model
//!
//! Around straight running at u0 the sway-yaw equations are linear in (v, r, delta) on each
//! side of beta_R = 0 (gamma_R differs, so the hull is piecewise linear even for tiny rudder
//! angles): [`MmgHull::linear`] gives the second-order Nomoto model
//! `r/delta = K (1 + T3 s) / ((1 + T1 s)(1 + T2 s))` of either side. KVLCC2 is course stable
//! on the starboard side (beta_R > 0: 120 m, 7 m/s: K = 0.40 1/s, T1 = 263 s, T2 = 5.8 s,
//! T3 = 15.4 s) and unstable on the port side (T1 = -237 s): straight running at zero rudder
//! drifts into a slow port turn.

mod kvlcc2;
mod linear;
mod state;
use kvlcc2 as c;
pub use linear::{LinearNomoto, Side};
pub(super) use state::rk4_piece;
pub use state::{MmgInput, MmgState};

/// Water density used for forces and mass [kg/m^3]. It cancels: every force and every mass
/// is proportional to it.
const RHO_KG_M3: f64 = 1025.0;

/// Why a hull cannot be built.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum MmgError {
    /// Length or speed not finite and positive.
    #[error(
        "surge-sway-yaw hull: length {length_m} m and design speed {speed_mps} m/s must be finite and > 0"
    )]
    Particulars {
        /// Length [m].
        length_m: f64,
        /// Design speed [m/s].
        speed_mps: f64,
    },
    /// No propeller revolutions balance the resistance (cannot happen with KVLCC2's
    /// coefficients).
    #[error("MMG hull: no propeller revolutions give a steady speed of {speed_mps} m/s")]
    NoSelfPropulsion {
        /// Design speed [m/s].
        speed_mps: f64,
    },
}

/// The KVLCC2 MMG hull at one length and design speed, with its state.
#[derive(Debug, Clone, PartialEq)]
pub struct MmgHull {
    length_m: f64,
    draft_m: f64,
    prop_diameter_m: f64,
    rudder_area_m2: f64,
    x_g_m: f64,
    /// m and I_zG at the design loading [kg, kg m^2].
    mass_kg: f64,
    inertia_kg_m2: f64,
    /// Added masses [kg, kg, kg m^2].
    mx_kg: f64,
    my_kg: f64,
    jz_kg_m2: f64,
    /// Design speed u0 [m/s].
    speed_mps: f64,
    /// Propeller revolutions n_P [1/s].
    n_rps: f64,
    /// Straight-running linear rudder derivatives at u0 [N/rad, N m/rad] (for the sea).
    y_delta_n: f64,
    n_delta_nm: f64,
    /// The state.
    pub state: MmgState,
}

/// Forces and moment [N, N, N m].
type Forces = (f64, f64, f64);

impl MmgHull {
    /// The hull scaled to `length_m`, its propeller set for a steady straight course at
    /// `speed_mps`, at rest in that course (u = speed, v = r = 0) on heading `psi_rad`.
    pub fn new(length_m: f64, speed_mps: f64, psi_rad: f64) -> Result<Self, MmgError> {
        let ok = |x: f64| x.is_finite() && x > 0.0;
        if !ok(length_m) || !ok(speed_mps) {
            return Err(MmgError::Particulars {
                length_m,
                speed_mps,
            });
        }
        let lambda = length_m / c::LENGTH_M;
        let draft_m = c::DRAFT_M * lambda;
        let mass_kg = RHO_KG_M3 * c::VOLUME_M3 * lambda.powi(3);
        let half_l2d = 0.5 * RHO_KG_M3 * length_m * length_m * draft_m;
        let mut hull = Self {
            length_m,
            draft_m,
            prop_diameter_m: c::PROP_DIAMETER_M * lambda,
            rudder_area_m2: c::RUDDER_AREA_M2 * lambda * lambda,
            x_g_m: c::X_G_M * lambda,
            mass_kg,
            inertia_kg_m2: mass_kg * (c::GYRATION_RATIO * length_m).powi(2),
            mx_kg: half_l2d * c::MX,
            my_kg: half_l2d * c::MY,
            jz_kg_m2: half_l2d * length_m * length_m * c::JZ,
            speed_mps,
            n_rps: 0.0,
            y_delta_n: 0.0,
            n_delta_nm: 0.0,
            state: MmgState {
                u_mps: speed_mps,
                v_mps: 0.0,
                r_rad_s: 0.0,
                psi_rad,
                x_m: 0.0,
                y_m: 0.0,
            },
        };
        hull.n_rps = hull.self_propulsion_rps()?;
        let (_, y_delta, n_delta) = hull.rudder_derivatives();
        hull.y_delta_n = y_delta;
        hull.n_delta_nm = n_delta;
        Ok(hull)
    }

    /// A new design speed u0 (the ship's speed is changed, not a fault): the propeller
    /// revolutions for a steady straight course at `speed_mps`, the rudder derivatives at it,
    /// and the surge speed set to it (sway, yaw and position unchanged).
    pub fn set_speed_mps(&mut self, speed_mps: f64) -> Result<(), MmgError> {
        if !(speed_mps.is_finite() && speed_mps > 0.0) {
            return Err(MmgError::Particulars {
                length_m: self.length_m,
                speed_mps,
            });
        }
        self.speed_mps = speed_mps;
        self.n_rps = self.self_propulsion_rps()?;
        let (_, y_delta, n_delta) = self.rudder_derivatives();
        self.y_delta_n = y_delta;
        self.n_delta_nm = n_delta;
        self.state.u_mps = speed_mps;
        Ok(())
    }

    /// Ship length L [m].
    pub fn length_m(&self) -> f64 {
        self.length_m
    }

    /// Propeller revolutions n_P [1/s].
    pub fn propeller_rps(&self) -> f64 {
        self.n_rps
    }

    /// Propeller diameter D_P [m].
    pub fn propeller_diameter_m(&self) -> f64 {
        self.prop_diameter_m
    }

    /// Design speed u0 [m/s].
    pub fn design_speed_mps(&self) -> f64 {
        self.speed_mps
    }

    /// The revolutions at which straight running at u0 is in surge equilibrium: bisection
    /// on X(n) = X_H + X_P (increasing in n), bracket [0, n_hi] found by doubling.
    fn self_propulsion_rps(&self) -> Result<f64, MmgError> {
        let u = self.speed_mps;
        let x = |n: f64| {
            let (xh, _, _) = self.hull_forces(u, 0.0, 0.0);
            xh + self.propeller(u, 0.0, 0.0, n).0
        };
        let mut hi = u / self.prop_diameter_m;
        let mut tries = 0;
        while x(hi) <= 0.0 {
            hi *= 2.0;
            tries += 1;
            if tries > 60 {
                return Err(MmgError::NoSelfPropulsion { speed_mps: u });
            }
        }
        let mut lo = 0.0;
        for _ in 0..200 {
            let mid = 0.5 * (lo + hi);
            if x(mid) > 0.0 {
                hi = mid;
            } else {
                lo = mid;
            }
            if hi - lo <= 1e-15 * hi {
                break;
            }
        }
        Ok(0.5 * (lo + hi))
    }

    fn hull_forces(&self, u: f64, v: f64, r: f64) -> Forces {
        let l = self.length_m;
        let uu = (u * u + v * v).sqrt().max(1e-9);
        let vp = v / uu;
        let rp = r * l / uu;
        let q = 0.5 * RHO_KG_M3 * l * self.draft_m * uu * uu;
        let (v2, r2) = (vp * vp, rp * rp);
        let x = -c::R0 + c::X_VV * v2 + c::X_VR * vp * rp + c::X_RR * r2 + c::X_VVVV * v2 * v2;
        let y = c::Y_V * vp
            + c::Y_R * rp
            + c::Y_VVV * v2 * vp
            + c::Y_VVR * v2 * rp
            + c::Y_VRR * vp * r2
            + c::Y_RRR * r2 * rp;
        let n = c::N_V * vp
            + c::N_R * rp
            + c::N_VVV * v2 * vp
            + c::N_VVR * v2 * rp
            + c::N_VRR * vp * r2
            + c::N_RRR * r2 * rp;
        (q * x, q * y, q * l * n)
    }

    /// (X_P [N], K_T, u_P = u (1 - w_P) [m/s]) at revolutions `n`.
    fn propeller(&self, u: f64, v: f64, r: f64, n: f64) -> (f64, f64, f64) {
        let uu = (u * u + v * v).sqrt().max(1e-9);
        let beta = (-v).atan2(u);
        let beta_p = beta - c::X_P * r * self.length_m / uu;
        let c2 = if beta_p > 0.0 {
            c::C2_PLUS
        } else {
            c::C2_MINUS
        };
        let one_minus_w =
            (1.0 - c::W_P0) * (1.0 + (1.0 - (-c::C1 * beta_p.abs()).exp()) * (c2 - 1.0));
        let u_p = u * one_minus_w;
        let nd = n * self.prop_diameter_m;
        // K_T n^2 D^2 = k0 (nD)^2 + k1 (nD) u_P + k2 u_P^2: no division by J.
        let kt_n2d2 = c::K0 * nd * nd + c::K1 * nd * u_p + c::K2 * u_p * u_p;
        let d2 = self.prop_diameter_m * self.prop_diameter_m;
        let x_p = (1.0 - c::T_P) * RHO_KG_M3 * d2 * kt_n2d2;
        let kt = if nd > 0.0 { kt_n2d2 / (nd * nd) } else { 0.0 };
        (x_p, kt, u_p)
    }

    /// Effective rudder inflow (u_R, v_R) [m/s].
    fn rudder_inflow(&self, u: f64, v: f64, r: f64, kt: f64, u_p: f64) -> (f64, f64) {
        let uu = (u * u + v * v).sqrt().max(1e-9);
        let eta = c::PROP_DIAMETER_M / c::RUDDER_HEIGHT_M;
        let nd = self.n_rps * self.prop_diameter_m;
        let slip = (u_p * u_p + 8.0 * kt.max(0.0) * nd * nd / std::f64::consts::PI).sqrt() - u_p;
        let a = u_p + c::KAPPA * slip;
        let u_r = c::EPSILON * (eta * a * a + (1.0 - eta) * u_p * u_p).sqrt();
        let beta = (-v).atan2(u);
        let beta_r = beta - c::L_R * r * self.length_m / uu;
        let gamma = if beta_r > 0.0 {
            c::GAMMA_PLUS
        } else {
            c::GAMMA_MINUS
        };
        (u_r, uu * gamma * beta_r)
    }

    /// Total forces (hull, propeller, rudder, sea) at a state, rudder `delta` [rad].
    fn forces(&self, x: &[f64; 6], delta: f64, input: &MmgInput) -> Forces {
        let (u, v, r) = (x[0], x[1], x[2]);
        let (xh, yh, nh) = self.hull_forces(u, v, r);
        let (xp, kt, u_p) = self.propeller(u, v, r, self.n_rps);
        let (u_r, v_r) = self.rudder_inflow(u, v, r, kt, u_p);
        let alpha = delta - v_r.atan2(u_r);
        let f_n = input.rudder_effectiveness
            * 0.5
            * RHO_KG_M3
            * self.rudder_area_m2
            * (u_r * u_r + v_r * v_r)
            * c::F_ALPHA
            * alpha.sin();
        let (sd, cd) = delta.sin_cos();
        let xr = -(1.0 - c::T_R) * f_n * sd;
        let yr = -(1.0 + c::A_H) * f_n * cd;
        let nr = -(c::X_R + c::A_H * c::X_H) * self.length_m * f_n * cd;
        (
            xh + xp + xr,
            yh + yr + self.y_delta_n * input.sea_rad,
            nh + nr + self.n_delta_nm * input.sea_rad,
        )
    }

    /// d/dt of the state at rudder `delta`.
    fn derivative(&self, x: &[f64; 6], delta: f64, input: &MmgInput) -> [f64; 6] {
        let (u, v, r, psi) = (x[0], x[1], x[2], x[3]);
        let (fx, fy, fn_) = self.forces(x, delta, input);
        let m = self.mass_kg * input.mass_factor;
        let iz = self.inertia_kg_m2 * input.mass_factor;
        let xg = self.x_g_m;
        let udot = (fx + (m + self.my_kg) * v * r + xg * m * r * r) / (m + self.mx_kg);
        // [[m + m_y, x_G m], [x_G m, I_zG + x_G^2 m + J_z]] (v', r') = (b1, b2)
        let (a11, a12, a22) = (m + self.my_kg, xg * m, iz + xg * xg * m + self.jz_kg_m2);
        let b1 = fy - (m + self.mx_kg) * u * r;
        let b2 = fn_ - xg * m * u * r;
        let det = a11 * a22 - a12 * a12;
        let vdot = (b1 * a22 - a12 * b2) / det;
        let rdot = (a11 * b2 - a12 * b1) / det;
        let (s, co) = psi.sin_cos();
        [udot, vdot, rdot, r, u * co - v * s, u * s + v * co]
    }

    /// Advances the state over `tau_s` with the rudder going linearly from `delta0_rad` to
    /// `delta1_rad`: one classical Runge-Kutta step.
    pub fn advance(&mut self, delta0_rad: f64, delta1_rad: f64, input: &MmgInput, tau_s: f64) {
        let f = |x: &[f64; 6], delta: f64| self.derivative(x, delta, input);
        self.state = rk4_piece(self.state, delta0_rad, delta1_rad, tau_s, f);
    }

    /// The rudder's straight-running linear derivatives at u0 (the same on both sides of
    /// beta_R = 0): (d F_N / d delta [N/rad], Y_delta [N/rad], N_delta [N m/rad]); to first
    /// order F_N = c_N (delta + gamma_R (v + l_R' L r) / u_R0).
    fn rudder_derivatives(&self) -> (f64, f64, f64) {
        let u = self.speed_mps;
        let (_, kt, u_p) = self.propeller(u, 0.0, 0.0, self.n_rps);
        let (u_r, _) = self.rudder_inflow(u, 0.0, 0.0, kt, u_p);
        let c_n = 0.5 * RHO_KG_M3 * self.rudder_area_m2 * u_r * u_r * c::F_ALPHA;
        (
            c_n,
            -(1.0 + c::A_H) * c_n,
            -(c::X_R + c::A_H * c::X_H) * self.length_m * c_n,
        )
    }

    /// The straight-running inflow to the rudder u_R0 [m/s].
    pub fn rudder_inflow_straight_mps(&self) -> f64 {
        let u = self.speed_mps;
        let (_, kt, u_p) = self.propeller(u, 0.0, 0.0, self.n_rps);
        self.rudder_inflow(u, 0.0, 0.0, kt, u_p).0
    }

    /// The linearised sway-yaw model around straight running at u0 on one side of
    /// beta_R = 0, at displacement factor `mass_factor` and rudder effectiveness
    /// `rudder_effectiveness` (analytic derivatives of the equations in the module
    /// documentation; the wake's |beta_P| term only changes u_R to second order and drops
    /// out). The effectiveness scales F_N, so it also scales the rudder's share of the sway
    /// and yaw damping (its flow-straightening terms), not only the input.
    pub fn linear(&self, side: Side, mass_factor: f64, rudder_effectiveness: f64) -> LinearNomoto {
        let u = self.speed_mps;
        let l = self.length_m;
        let gamma = match side {
            Side::Starboard => c::GAMMA_PLUS,
            Side::Port => c::GAMMA_MINUS,
        };
        let (c_n, y_d, n_d) = self.rudder_derivatives();
        let (c_n, y_d, n_d) = (
            rudder_effectiveness * c_n,
            rudder_effectiveness * y_d,
            rudder_effectiveness * n_d,
        );
        let u_r = self.rudder_inflow_straight_mps();
        let q = 0.5 * RHO_KG_M3 * l * self.draft_m * u;
        // d alpha_R / d v = gamma / u_R, d alpha_R / d r = gamma l_R' L / u_R
        let fn_v = c_n * gamma / u_r;
        let fn_r = c_n * gamma * c::L_R * l / u_r;
        let y_arm = -(1.0 + c::A_H);
        let n_arm = -(c::X_R + c::A_H * c::X_H) * l;
        let y_v = q * c::Y_V + y_arm * fn_v;
        let y_r = q * l * c::Y_R + y_arm * fn_r;
        let n_v = q * l * c::N_V + n_arm * fn_v;
        let n_r = q * l * l * c::N_R + n_arm * fn_r;
        let m = self.mass_kg * mass_factor;
        let iz = self.inertia_kg_m2 * mass_factor;
        let xg = self.x_g_m;
        // M (v', r') = A (v, r) + B delta
        let (m11, m12, m22) = (m + self.my_kg, xg * m, iz + xg * xg * m + self.jz_kg_m2);
        let (a11, a12, a21, a22) = (y_v, y_r - (m + self.mx_kg) * u, n_v, n_r - xg * m * u);
        LinearNomoto::of_sway_yaw(
            [[m11, m12], [m12, m22]],
            [[a11, a12], [a21, a22]],
            [y_d, n_d],
            1.0,
        )
    }
}
