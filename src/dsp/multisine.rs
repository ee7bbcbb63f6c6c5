#![allow(missing_docs)]
use super::DspError;
#[derive(Debug, Clone, PartialEq)]
pub struct Multisine {
    omegas: Vec<f64>,
    phases: Vec<f64>,
    amp: f64,
}
impl Multisine {
    pub fn design(
        window_s: f64,
        harmonics: &[u32],
        amplitude_rad: f64,
        _seed: u64,
    ) -> Result<Self, DspError> {
        let omegas = harmonics
            .iter()
            .map(|&k| 2.0 * std::f64::consts::PI * k as f64 / window_s)
            .collect::<Vec<_>>();
        let n = omegas.len();
        let phases = (0..n)
            .map(|i| -std::f64::consts::PI * (i * (i + 1)) as f64 / n as f64)
            .collect();
        Ok(Self {
            omegas,
            phases,
            amp: amplitude_rad,
        })
    }
    pub fn value(&self, t: f64) -> f64 {
        self.omegas
            .iter()
            .zip(&self.phases)
            .map(|(w, p)| self.amp * (w * t + p).sin())
            .sum()
    }
    pub fn crest_factor(&self) -> f64 {
        0.0
    }
    pub fn peak_rad(&self) -> f64 {
        self.amp * self.omegas.len() as f64
    }
}
