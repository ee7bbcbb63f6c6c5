//! KVLCC2 model particulars and coefficients (Y&Y Tables 1-3, model scale; see the module
//! documentation of `mmg`).

pub const LENGTH_M: f64 = 7.00;
pub const DRAFT_M: f64 = 0.46;
pub const VOLUME_M3: f64 = 3.27;
pub const X_G_M: f64 = 0.25;
pub const PROP_DIAMETER_M: f64 = 0.216;
pub const RUDDER_HEIGHT_M: f64 = 0.345;
pub const RUDDER_AREA_M2: f64 = 0.0539;
pub const GYRATION_RATIO: f64 = 0.25;

pub const MX: f64 = 0.022;
pub const MY: f64 = 0.223;
pub const JZ: f64 = 0.011;

pub const R0: f64 = 0.022;
pub const X_VV: f64 = -0.040;
pub const X_VR: f64 = 0.002;
pub const X_RR: f64 = 0.011;
pub const X_VVVV: f64 = 0.771;
pub const Y_V: f64 = -0.315;
pub const Y_R: f64 = 0.083;
pub const Y_VVV: f64 = -1.607;
pub const Y_VVR: f64 = 0.379;
pub const Y_VRR: f64 = -0.391;
pub const Y_RRR: f64 = 0.008;
pub const N_V: f64 = -0.137;
pub const N_R: f64 = -0.049;
pub const N_VVV: f64 = -0.030;
pub const N_VVR: f64 = -0.294;
pub const N_VRR: f64 = 0.055;
pub const N_RRR: f64 = -0.013;

pub const T_P: f64 = 0.220;
pub const W_P0: f64 = 0.40;
pub const X_P: f64 = -0.48;
pub const K0: f64 = 0.2931;
pub const K1: f64 = -0.2753;
pub const K2: f64 = -0.1385;
pub const C1: f64 = 2.0;
pub const C2_PLUS: f64 = 1.6;
pub const C2_MINUS: f64 = 1.1;

pub const T_R: f64 = 0.387;
pub const A_H: f64 = 0.312;
pub const X_H: f64 = -0.464;
pub const X_R: f64 = -0.5;
pub const EPSILON: f64 = 1.09;
pub const KAPPA: f64 = 0.50;
pub const L_R: f64 = -0.710;
pub const GAMMA_MINUS: f64 = 0.395;
pub const GAMMA_PLUS: f64 = 0.640;
pub const F_ALPHA: f64 = 2.747;
