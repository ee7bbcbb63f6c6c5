#![allow(missing_docs)]
use super::DspError;
#[derive(Debug, Clone, PartialEq)]
pub struct ToneEstimate {
    pub omega_rad_s: f64,
    pub gain: f64,
    pub phase_rad: f64,
    pub coherence: f64,
    pub snr_db: f64,
    pub gain_ci90_rel: f64,
    pub phase_ci90_rad: f64,
}
#[derive(Debug, Default)]
pub struct ToneAnalyser;
impl ToneAnalyser {
    pub fn new() -> Self {
        Self
    }
    pub fn analyse(
        &mut self,
        _h: &[f64],
        _d: &[f64],
        _r: &[f64],
        _dt: f64,
        _w: usize,
        _k: &[u32],
    ) -> Result<Vec<ToneEstimate>, DspError> {
        Err(DspError::NotImplemented)
    }
}
