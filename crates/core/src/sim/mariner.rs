//! A second published nonlinear hull: the Mariner-class cargo ship's surge-sway-yaw model from
//! planar-motion-mechanism tests (Chislett & Strøm-Tejsen 1965, "Planar motion mechanism tests
//! and full-scale steering and manoeuvring predictions for a Mariner class vessel", Hy-6,
//! Hydro- og Aerodynamisk Laboratorium, Lyngby), in the form and with the coefficients of
//! Fossen's `mariner.m` (Marine Systems Simulator; Fossen, *Handbook of Marine Craft
//! Hydrodynamics and Motion Control*, 2011), Froude-scaled to a chosen length.
//!
//! Unlike the MMG hull ([`crate::sim::mmg`]) it has no propeller or rudder-inflow model: a
//! polynomial (Abkowitz) expansion in the perturbed surge `u' = (u - U0) / U`, the sway
//! `v' = v / U`, the yaw rate `r' = r L / U` and the rudder `delta`, its coefficients from
//! captive tests, the Coriolis terms folded into them (`X_rv' = m'`, `Y_r' = Y_ru'` carry
//! `-m'`, `N_r' = N_ru'` carry `-m' x_G'`).
//!
//! ## Equations (non-dimensional by L, U and (rho/2) L^3; U = sqrt(u^2 + v^2))
//!
//! ```text
//! (m' - X_u.') u''                       = X'
//! (m' - Y_v.') v'' + (m' x_G' - Y_r.') r'' = Y'          (accelerations in U^2/L, U^2/L^2)
//! (m' x_G' - N_v.') v'' + (I_z' - N_r.') r'' = N'
//! X' = X_u u + X_uu u^2 + X_uuu u^3 + X_vv v^2 + X_rr r^2 + X_rv r v
//!      + e (X_dd d^2 + X_udd u d^2 + X_vd v d + X_uvd u v d)
//! Y' = Y_v v + Y_r r + Y_vvv v^3 + Y_vvr v^2 r + Y_vu v u + Y_ru r u + Y_0 + Y_0u u + Y_0uu u^2
//!      + e (Y_d d + Y_ddd d^3 + Y_ud u d + Y_uud u^2 d + Y_vdd v d^2 + Y_vvd v^2 d) + Y_d b
//! N' likewise with the N coefficients
//! ```
//!
//! `d = -delta` (the model's rudder turns the ship to port for a positive angle: here a
//! positive `delta` turns it to starboard, as on the other hulls), `e` the rudder
//! effectiveness (1 nominal), `b = -beta` the sea's rudder-equivalent yaw disturbance acting as
//! the straight-running linear rudder force and moment of that angle. `(Y_0, N_0)` is the
//! single-screw asymmetry: straight running needs about 1 deg of rudder, which the
//! autopilot's integral finds.
//!
//! ## Coefficients (x 1e-5; m' = 798, I_z' = 39.2, x_G' = -0.023)
//!
//! | | | |
//! |---|---|---|
//! | X_u. -42, X_u -184, X_uu -110, X_uuu -215, X_vv -899, X_rr 18, X_dd -95, X_udd -190, X_rv 798, X_vd 93, X_uvd 93 | Y_v. -748, Y_r. -9.354, Y_v -1160, Y_r -499, Y_vvv -8078, Y_vvr 15356, Y_vu -1160, Y_ru -499, Y_d 278, Y_ddd -90, Y_ud 556, Y_uud 278, Y_vdd -4, Y_vvd 1190, Y_0 -4, Y_0u -8, Y_0uu -4 | N_v. 4.646, N_r. -43.8, N_v -264, N_r -166, N_vvv 1636, N_vvr -5483, N_vu -264, N_ru -166, N_d -139, N_ddd 45, N_ud -278, N_uud -139, N_vdd 13, N_vvd -489, N_0 3, N_0u 6, N_0uu 3 |
//!
//! Linearised at U0 = 7.7175 m/s and L = 160.93 m these give Fossen's published Nomoto model
//! of the Mariner, K = 0.185 1/s, T1 = 118 s, T2 = 7.8 s, T3 = 18.5 s (the test
//! `tests/it/mariner.rs` checks [`MarinerHull::linear`] and the nonlinear hull's small-rudder
//! response against it).
//!
//! ## Scale, speed and loading
//!
//! Every coefficient is non-dimensional: at another length (Froude similarity) or another
//! design speed `U0` the manoeuvre in ship lengths is the same and time goes with L / U. A
//! speed change sets `U0` (the model has no propeller: its surge equation restores the
//! perturbation to zero). The displacement factor `f = D / D_nom` multiplies m' and I_z' only,
//! in the mass matrix and in the Coriolis terms folded into `X_rv, X_rr, Y_r, Y_ru, N_r, N_ru`
//! (each gains `(f - 1)` times its rigid-body share); the hydrodynamics are those of the
//! design loading, as on the MMG hull.
//!
//! ## Integration
//!
//! One classical Runge-Kutta step per servo piece (rudder linear over it), as the MMG hull.
use super::mmg::{rk4_piece, LinearNomoto, MmgError, MmgInput, MmgState};

/// The model's length [m] (its coefficients are non-dimensional).
pub const LENGTH_M: f64 = 160.93;
/// The speed the published Nomoto model is taken at [m/s] (15 knots).
pub const PUBLISHED_SPEED_MPS: f64 = 7.7175;

const S: f64 = 1e-5;
const M: f64 = 798.0 * S;
const IZ: f64 = 39.2 * S;
const XG: f64 = -0.023;

const X_UDOT: f64 = -42.0 * S;
const X_U: f64 = -184.0 * S;
const X_UU: f64 = -110.0 * S;
const X_UUU: f64 = -215.0 * S;
const X_VV: f64 = -899.0 * S;
const X_RR: f64 = 18.0 * S;
const X_DD: f64 = -95.0 * S;
const X_UDD: f64 = -190.0 * S;
const X_RV: f64 = 798.0 * S;
const X_VD: f64 = 93.0 * S;
const X_UVD: f64 = 93.0 * S;

const Y_VDOT: f64 = -748.0 * S;
const Y_RDOT: f64 = -9.354 * S;
const Y_V: f64 = -1160.0 * S;
const Y_R: f64 = -499.0 * S;
const Y_VVV: f64 = -8078.0 * S;
const Y_VVR: f64 = 15356.0 * S;
const Y_VU: f64 = -1160.0 * S;
const Y_RU: f64 = -499.0 * S;
const Y_D: f64 = 278.0 * S;
const Y_DDD: f64 = -90.0 * S;
const Y_UD: f64 = 556.0 * S;
const Y_UUD: f64 = 278.0 * S;
const Y_VDD: f64 = -4.0 * S;
const Y_VVD: f64 = 1190.0 * S;
const Y_0: f64 = -4.0 * S;
const Y_0U: f64 = -8.0 * S;
const Y_0UU: f64 = -4.0 * S;

const N_VDOT: f64 = 4.646 * S;
const N_RDOT: f64 = -43.8 * S;
const N_V: f64 = -264.0 * S;
const N_R: f64 = -166.0 * S;
const N_VVV: f64 = 1636.0 * S;
const N_VVR: f64 = -5483.0 * S;
const N_VU: f64 = -264.0 * S;
const N_RU: f64 = -166.0 * S;
const N_D: f64 = -139.0 * S;
const N_DDD: f64 = 45.0 * S;
const N_UD: f64 = -278.0 * S;
const N_UUD: f64 = -139.0 * S;
const N_VDD: f64 = 13.0 * S;
const N_VVD: f64 = -489.0 * S;
const N_0: f64 = 3.0 * S;
const N_0U: f64 = 6.0 * S;
const N_0UU: f64 = 3.0 * S;

/// The Mariner hull at one length and design speed, with its state.
#[derive(Debug, Clone, PartialEq)]
pub struct MarinerHull {
    length_m: f64,
    /// Design speed U0 [m/s].
    speed_mps: f64,
    /// The state (u the total surge speed, U0 plus the perturbation).
    pub state: MmgState,
}

/// The mass matrix's entries at displacement factor `f`: (m11, m22, m23, m32, m33).
fn masses(f: f64) -> (f64, f64, f64, f64, f64) {
    let (m, iz) = (f * M, f * IZ);
    (
        m - X_UDOT,
        m - Y_VDOT,
        m * XG - Y_RDOT,
        m * XG - N_VDOT,
        iz - N_RDOT,
    )
}

impl MarinerHull {
    /// The hull scaled to `length_m`, running straight at `speed_mps` (v = r = 0) on heading
    /// `psi_rad`.
    pub fn new(length_m: f64, speed_mps: f64, psi_rad: f64) -> Result<Self, MmgError> {
        let ok = |x: f64| x.is_finite() && x > 0.0;
        if !ok(length_m) || !ok(speed_mps) {
            return Err(MmgError::Particulars {
                length_m,
                speed_mps,
            });
        }
        Ok(Self {
            length_m,
            speed_mps,
            state: MmgState {
                u_mps: speed_mps,
                v_mps: 0.0,
                r_rad_s: 0.0,
                psi_rad,
                x_m: 0.0,
                y_m: 0.0,
            },
        })
    }

    /// A new design speed U0 (the ship's speed is changed, not a fault): the surge speed set
    /// to it (sway, yaw and position unchanged).
    pub fn set_speed_mps(&mut self, speed_mps: f64) -> Result<(), MmgError> {
        if !(speed_mps.is_finite() && speed_mps > 0.0) {
            return Err(MmgError::Particulars {
                length_m: self.length_m,
                speed_mps,
            });
        }
        self.speed_mps = speed_mps;
        self.state.u_mps = speed_mps;
        Ok(())
    }

    /// Ship length L [m].
    pub fn length_m(&self) -> f64 {
        self.length_m
    }

    /// Design speed U0 [m/s].
    pub fn design_speed_mps(&self) -> f64 {
        self.speed_mps
    }

    /// Straight running against the single screw's asymmetry, to first order: the rudder
    /// [rad] and the sway speed [m/s] at which `Y' = N' = 0` with `r = u' = 0` at rudder
    /// effectiveness `e`, from `Y_v v' - e Y_d delta = -Y_0`, `N_v v' - e N_d delta = -N_0`
    /// (the cubic terms at these angles are under 1e-5 of the linear ones).
    pub fn trim(&self, rudder_effectiveness: f64) -> (f64, f64) {
        let det = -Y_V * N_D + Y_D * N_V;
        let v = (Y_0 * N_D - Y_D * N_0) / det;
        let delta = (-Y_V * N_0 + N_V * Y_0) / det / rudder_effectiveness;
        (delta, v * self.speed_mps)
    }

    /// The non-dimensional forces (X', Y', N') at perturbed surge `u`, sway `v`, yaw rate `r`
    /// (non-dimensional) and the model's rudder `d` [rad].
    fn forces(u: f64, v: f64, r: f64, d: f64, input: &MmgInput) -> (f64, f64, f64) {
        let e = input.rudder_effectiveness;
        let c = input.mass_factor - 1.0;
        let b = -input.sea_rad;
        let (v2, d2) = (v * v, d * d);
        let x = X_U * u
            + X_UU * u * u
            + X_UUU * u * u * u
            + X_VV * v2
            + (X_RR + c * M * XG) * r * r
            + (X_RV + c * M) * r * v
            + e * (X_DD * d2 + X_UDD * u * d2 + X_VD * v * d + X_UVD * u * v * d);
        let y = Y_V * v
            + (Y_R - c * M) * r
            + Y_VVV * v2 * v
            + Y_VVR * v2 * r
            + Y_VU * v * u
            + (Y_RU - c * M) * r * u
            + Y_0
            + Y_0U * u
            + Y_0UU * u * u
            + e * (Y_D * d
                + Y_DDD * d2 * d
                + Y_UD * u * d
                + Y_UUD * u * u * d
                + Y_VDD * v * d2
                + Y_VVD * v2 * d)
            + Y_D * b;
        let n = N_V * v
            + (N_R - c * M * XG) * r
            + N_VVV * v2 * v
            + N_VVR * v2 * r
            + N_VU * v * u
            + (N_RU - c * M * XG) * r * u
            + N_0
            + N_0U * u
            + N_0UU * u * u
            + e * (N_D * d
                + N_DDD * d2 * d
                + N_UD * u * d
                + N_UUD * u * u * d
                + N_VDD * v * d2
                + N_VVD * v2 * d)
            + N_D * b;
        (x, y, n)
    }

    /// d/dt of the state at rudder `delta` [rad] (positive: to starboard).
    fn derivative(&self, s: &[f64; 6], delta: f64, input: &MmgInput) -> [f64; 6] {
        let l = self.length_m;
        let (u_abs, v, r, psi) = (s[0], s[1], s[2], s[3]);
        let uu = (u_abs * u_abs + v * v).sqrt().max(1e-9);
        let (up, vp, rp) = ((u_abs - self.speed_mps) / uu, v / uu, r * l / uu);
        let (x, y, n) = Self::forces(up, vp, rp, -delta, input);
        let (m11, m22, m23, m32, m33) = masses(input.mass_factor);
        let det = m22 * m33 - m23 * m32;
        let k = uu * uu / l;
        let udot = x * k / m11;
        let vdot = (m33 * y - m23 * n) * k / det;
        let rdot = (m22 * n - m32 * y) * k / (l * det);
        let (sn, cs) = psi.sin_cos();
        [
            udot,
            vdot,
            rdot,
            r,
            u_abs * cs - v * sn,
            u_abs * sn + v * cs,
        ]
    }

    /// Advances the state over `tau_s` with the rudder going linearly from `delta0_rad` to
    /// `delta1_rad`: one classical Runge-Kutta step.
    pub fn advance(&mut self, delta0_rad: f64, delta1_rad: f64, input: &MmgInput, tau_s: f64) {
        let f = |x: &[f64; 6], delta: f64| self.derivative(x, delta, input);
        self.state = rk4_piece(self.state, delta0_rad, delta1_rad, tau_s, f);
    }

    /// The linearised sway-yaw model around straight running at U0, at displacement factor
    /// `mass_factor` and rudder effectiveness `rudder_effectiveness`: the second-order Nomoto
    /// model of `(v', r')` driven by the rudder, in seconds at this length and speed (the
    /// model's own K is negative: here a positive rudder turns to starboard, K > 0).
    pub fn linear(&self, mass_factor: f64, rudder_effectiveness: f64) -> LinearNomoto {
        let c = mass_factor - 1.0;
        let (_, m22, m23, m32, m33) = masses(mass_factor);
        let (a11, a12, a21, a22) = (Y_V, Y_R - c * M, N_V, N_R - c * M * XG);
        let (b1, b2) = (-rudder_effectiveness * Y_D, -rudder_effectiveness * N_D);
        // Non-dimensional time t U / L and yaw rate r L / U: r = r' U / L, t = t' L / U.
        LinearNomoto::of_sway_yaw(
            [[m22, m23], [m32, m33]],
            [[a11, a12], [a21, a22]],
            [b1, b2],
            self.length_m / self.speed_mps,
        )
    }
}

/// The surge-sway-yaw hull a simulated ship integrates instead of Nomoto's equation
/// (`structure.hull`): both take the rudder, the sea's rudder-equivalent angle, the rudder
/// effectiveness and the displacement factor ([`MmgInput`]), and give the state and their
/// linearised first-order model the autopilot is tuned on.
#[derive(Debug, Clone, PartialEq)]
pub enum Manoeuvring {
    /// KVLCC2's MMG model ([`crate::sim::mmg`]).
    Kvlcc2(super::mmg::MmgHull),
    /// The Mariner's model (this module).
    Mariner(MarinerHull),
}

impl Manoeuvring {
    /// The hull `model` scaled to `length_m`, running straight at `speed_mps` on heading
    /// `psi_rad`; None for the Nomoto hull.
    pub fn new(
        model: super::config::HullModel,
        length_m: f64,
        speed_mps: f64,
        psi_rad: f64,
    ) -> Result<Option<Self>, MmgError> {
        use super::config::HullModel;
        Ok(match model {
            HullModel::Nomoto => None,
            HullModel::Kvlcc2Mmg => Some(Self::Kvlcc2(super::mmg::MmgHull::new(
                length_m, speed_mps, psi_rad,
            )?)),
            HullModel::Mariner => Some(Self::Mariner(MarinerHull::new(
                length_m, speed_mps, psi_rad,
            )?)),
        })
    }

    /// The state.
    pub fn state(&self) -> &MmgState {
        match self {
            Self::Kvlcc2(h) => &h.state,
            Self::Mariner(h) => &h.state,
        }
    }

    /// Advances the state over `tau_s`, the rudder linear from `delta0_rad` to `delta1_rad`.
    pub fn advance(&mut self, delta0_rad: f64, delta1_rad: f64, input: &MmgInput, tau_s: f64) {
        match self {
            Self::Kvlcc2(h) => h.advance(delta0_rad, delta1_rad, input, tau_s),
            Self::Mariner(h) => h.advance(delta0_rad, delta1_rad, input, tau_s),
        }
    }

    /// A new design speed (not a fault).
    pub fn set_speed_mps(&mut self, speed_mps: f64) -> Result<(), MmgError> {
        match self {
            Self::Kvlcc2(h) => h.set_speed_mps(speed_mps),
            Self::Mariner(h) => h.set_speed_mps(speed_mps),
        }
    }

    /// The linearised model (KVLCC2: its course-stable starboard side).
    pub fn linear(&self, mass_factor: f64, rudder_effectiveness: f64) -> LinearNomoto {
        match self {
            Self::Kvlcc2(h) => h.linear(
                super::mmg::Side::Starboard,
                mass_factor,
                rudder_effectiveness,
            ),
            Self::Mariner(h) => h.linear(mass_factor, rudder_effectiveness),
        }
    }
}
