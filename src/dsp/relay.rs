#![allow(missing_docs)]
use super::DspError;
#[derive(Debug, Clone, PartialEq)]
pub struct HbtFeatures {
    pub period_s: f64,
    pub omega_u_rad_s: f64,
    pub amplitude_rad: f64,
    pub periods: usize,
    pub period_std_s: f64,
}
pub fn analyse_limit_cycle(
    _t0_s: f64,
    _dt_s: f64,
    _heading: &[f64],
    _switch_times_s: &[f64],
) -> Result<HbtFeatures, DspError> {
    Err(DspError::NotImplemented)
}
