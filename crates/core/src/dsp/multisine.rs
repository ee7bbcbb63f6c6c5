//! The CLFRT excitation: a multisine on the DFT grid of a window, eq. (8)-(9) of the paper.
//!
//! ```text
//! r(t) = sum_i A sin(omega_i t + phi_i),     omega_i = 2 pi k_i / T_w     [rad, t in s]
//! ```
//!
//! Every tone has a whole number `k_i` of periods in the window `T_w`, so `r` is periodic in
//! `T_w` and each tone falls exactly on bin `k_i` of the DFT of one window (bin `k_i M` of
//! `M` windows) with no leakage. All tones have the same amplitude `A` [rad].
//!
//! # Phases and crest factor
//!
//! The crest factor is `CF = max_t |r(t)| / rms(r)` over one window, with `rms = A sqrt(n/2)`
//! for `n` distinct tones. It is evaluated on a uniform grid of `G >= 4096` points per window
//! (at least 64 per period of the highest tone, up to a memory cap). All cosine phases zero
//! (`phi_i = pi/2` here, sines) align every tone at `t = 0`: `CF = n / sqrt(n/2)`, 2.449 for
//! three tones. The design starts from Schroeder's phases (for the cosine form
//! `phi_i = -pi i (i-1) / n`, i = 1..n, i.e. `phi_i + pi/2` in the sine form used here), from
//! zero phases and from seeded random phases (`ChaCha8Rng`), refines each start by a
//! deterministic compass search on the grid peak (steps pi/4 down to 2e-4 rad) and keeps the
//! best. The design is a pure function of its arguments.
//!
//! Bounds for safety checks: [`Multisine::peak_rad`] is the grid peak plus `M2 h^2 / 8`
//! (`h` the grid step, `M2 = sum A omega_i^2` a bound on `|r''|`), a guaranteed upper bound
//! of `|r|`; [`Multisine::max_rate_rad_s`] is `sum A omega_i >= |dr/dt|`.

use super::{check_positive, DspError};
use crate::angle::wrap_2pi;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::f64::consts::PI;

/// Grid points per window, at least.
const MIN_GRID: usize = 4096;
/// Grid points per period of the highest tone, at least (until the memory cap).
const GRID_PER_PERIOD: usize = 64;
/// Cap on grid points times tones (two tables of f64 of this size are held during design).
const MAX_GRID_TONES: usize = 1 << 20;
/// Random starts of the phase optimisation, at most.
const MAX_RANDOM_STARTS: usize = 48;
/// Largest harmonic accepted.
const MAX_HARMONIC: u32 = 1_000_000;

/// A designed multisine: tones, amplitude, phases and its measured crest factor.
#[derive(Debug, Clone, PartialEq)]
pub struct Multisine {
    /// Window T_w [s]: the period of the whole signal.
    window_s: f64,
    /// Harmonic numbers k_i of the window, as given.
    harmonics: Vec<u32>,
    /// Tone frequencies omega_i = 2 pi k_i / T_w [rad/s].
    omegas: Vec<f64>,
    /// Amplitude of each tone [rad].
    amplitude_rad: f64,
    /// Sine phases phi_i [rad], in [0, 2 pi).
    phases: Vec<f64>,
    /// Grid peak / rms over one window.
    crest: f64,
    /// Guaranteed upper bound of |r(t)| [rad].
    peak_bound_rad: f64,
}

/// Precomputed sin/cos tables of every tone on the grid: the optimiser's inner loop is
/// multiply-adds only.
struct Grid {
    points: usize,
    tones: usize,
    /// `sin(2 pi k_i g / G)`, tone-major.
    sin: Vec<f64>,
    /// `cos(2 pi k_i g / G)`, tone-major.
    cos: Vec<f64>,
}

impl Grid {
    fn new(harmonics: &[u32]) -> Self {
        let kmax = harmonics.iter().copied().max().unwrap_or(1) as usize;
        let tones = harmonics.len().max(1);
        let points = (GRID_PER_PERIOD * kmax)
            .max(MIN_GRID)
            .min((MAX_GRID_TONES / tones).max(MIN_GRID));
        let mut sin = Vec::with_capacity(points * harmonics.len());
        let mut cos = Vec::with_capacity(points * harmonics.len());
        for &k in harmonics {
            let k = k as usize % points;
            let mut m = 0usize;
            for _ in 0..points {
                let (s, c) = (2.0 * PI * m as f64 / points as f64).sin_cos();
                sin.push(s);
                cos.push(c);
                m += k;
                if m >= points {
                    m -= points;
                }
            }
        }
        Self {
            points,
            tones: harmonics.len(),
            sin,
            cos,
        }
    }

    /// `max_g |sum_i sin(w_i t_g + phi_i)|` for unit amplitudes.
    fn peak(&self, phases: &[f64], coef: &mut Vec<(f64, f64)>) -> f64 {
        coef.clear();
        coef.extend(phases.iter().map(|p| (p.cos(), p.sin())));
        let mut peak = 0.0f64;
        for g in 0..self.points {
            let mut v = 0.0;
            for (i, &(cp, sp)) in coef.iter().enumerate().take(self.tones) {
                let j = i * self.points + g;
                v += cp * self.sin[j] + sp * self.cos[j];
            }
            peak = peak.max(v.abs());
        }
        peak
    }
}

fn check_harmonics(harmonics: &[u32]) -> Result<(), DspError> {
    if harmonics.is_empty() {
        return Err(DspError::TooShort {
            what: "harmonics",
            got: 0,
            need: 1,
        });
    }
    for (i, &k) in harmonics.iter().enumerate() {
        if k == 0 || k > MAX_HARMONIC {
            return Err(DspError::InvalidParameter {
                name: "harmonics",
                value: f64::from(k),
                reason: "each harmonic must be in [1, 1e6]",
            });
        }
        if harmonics[..i].contains(&k) {
            return Err(DspError::InvalidParameter {
                name: "harmonics",
                value: f64::from(k),
                reason: "harmonics must be distinct",
            });
        }
    }
    Ok(())
}

/// Compass search on the grid peak from `start`; returns (peak, phases).
fn compass_search(grid: &Grid, start: &[f64], coef: &mut Vec<(f64, f64)>) -> (f64, Vec<f64>) {
    let mut phases = start.to_vec();
    let mut best = grid.peak(&phases, coef);
    let mut step = PI / 4.0;
    while step > 2e-4 {
        let mut improved = true;
        let mut sweeps = 0;
        while improved && sweeps < 50 {
            improved = false;
            sweeps += 1;
            for i in 0..phases.len() {
                for dir in [1.0, -1.0] {
                    let old = phases[i];
                    phases[i] = old + dir * step;
                    let p = grid.peak(&phases, coef);
                    if p < best * (1.0 - 1e-12) {
                        best = p;
                        improved = true;
                        break;
                    }
                    phases[i] = old;
                }
            }
        }
        step *= 0.5;
    }
    (best, phases)
}

impl Multisine {
    /// Designs the multisine: tones on `harmonics` of `window_s`, `amplitude_rad` each, phases
    /// minimising the crest factor (Schroeder, zero and seeded random starts, compass search).
    ///
    /// Deterministic: the same arguments give the same phases. Errors on a non-positive or
    /// non-finite window or amplitude, and on empty, zero, repeated or huge harmonics.
    pub fn design(
        window_s: f64,
        harmonics: &[u32],
        amplitude_rad: f64,
        seed: u64,
    ) -> Result<Multisine, DspError> {
        check_positive("window_s", window_s)?;
        check_positive("amplitude_rad", amplitude_rad)?;
        check_harmonics(harmonics)?;
        let n = harmonics.len();
        let grid = Grid::new(harmonics);
        let mut coef = Vec::with_capacity(n);

        let schroeder: Vec<f64> = (1..=n)
            .map(|i| -PI * (i * (i - 1)) as f64 / n as f64 + PI / 2.0)
            .collect();
        let zero_cos = vec![PI / 2.0; n];
        // Work budget: about 1e9 multiply-adds over all random starts.
        let per_start = (grid.points * n * 2 * n * 120).max(1);
        let random_starts = (1_000_000_000 / per_start).clamp(1, MAX_RANDOM_STARTS);
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut starts = vec![schroeder, zero_cos];
        for _ in 0..random_starts {
            starts.push((0..n).map(|_| rng.gen_range(0.0..2.0 * PI)).collect());
        }
        let mut best: Option<(f64, Vec<f64>)> = None;
        for s in &starts {
            let (p, ph) = compass_search(&grid, s, &mut coef);
            if best.as_ref().is_none_or(|(bp, _)| p < *bp) {
                best = Some((p, ph));
            }
        }
        let phases = match best {
            Some((_, ph)) => ph,
            None => return Err(DspError::NoSolution("no phase design")),
        };
        Self::with_phases(window_s, harmonics, amplitude_rad, &phases)
    }

    /// A multisine with the given sine phases [rad] (no optimisation), e.g. to compare designs.
    pub fn with_phases(
        window_s: f64,
        harmonics: &[u32],
        amplitude_rad: f64,
        phases: &[f64],
    ) -> Result<Multisine, DspError> {
        check_positive("window_s", window_s)?;
        check_positive("amplitude_rad", amplitude_rad)?;
        check_harmonics(harmonics)?;
        if phases.len() != harmonics.len() {
            return Err(DspError::LengthMismatch {
                what: "phases",
                expected: harmonics.len(),
                got: phases.len(),
            });
        }
        super::check_finite("phases", phases)?;
        let phases: Vec<f64> = phases.iter().map(|&p| wrap_2pi(p)).collect();
        let grid = Grid::new(harmonics);
        let mut coef = Vec::with_capacity(phases.len());
        let unit_peak = grid.peak(&phases, &mut coef);
        let n = harmonics.len() as f64;
        let omegas: Vec<f64> = harmonics
            .iter()
            .map(|&k| 2.0 * PI * f64::from(k) / window_s)
            .collect();
        let h = window_s / grid.points as f64;
        let m2: f64 = omegas.iter().map(|w| amplitude_rad * w * w).sum();
        Ok(Multisine {
            window_s,
            harmonics: harmonics.to_vec(),
            omegas,
            amplitude_rad,
            phases,
            crest: unit_peak / (n / 2.0).sqrt(),
            peak_bound_rad: amplitude_rad * unit_peak + m2 * h * h / 8.0,
        })
    }

    /// The excitation `r(t)` [rad] at `t_rel_s` seconds after the window's origin.
    ///
    /// Periodic in the window (the time is reduced modulo `T_w` first, so large times lose no
    /// precision). A non-finite time gives 0 (no excitation).
    pub fn value(&self, t_rel_s: f64) -> f64 {
        // No weights: every tone counts 1 (`1.0 * x` is exact, so this is bit for bit the sum).
        self.value_weighted(t_rel_s, &[])
    }

    /// The excitation with tone `i` scaled by `weights[i]` (a missing weight counts 1): what
    /// the test plays once its sizing has lowered some tones [rad].
    pub fn value_weighted(&self, t_rel_s: f64, weights: &[f64]) -> f64 {
        if !t_rel_s.is_finite() {
            return 0.0;
        }
        let t = t_rel_s.rem_euclid(self.window_s);
        self.omegas
            .iter()
            .zip(&self.phases)
            .enumerate()
            .map(|(i, (w, p))| weights.get(i).copied().unwrap_or(1.0) * (w * t + p).sin())
            .sum::<f64>()
            * self.amplitude_rad
    }

    /// Tone frequencies omega_i = 2 pi k_i / T_w [rad/s], in the order of the harmonics given.
    pub fn omegas(&self) -> &[f64] {
        &self.omegas
    }

    /// Sine phases phi_i [rad] in [0, 2 pi), same order as [`Multisine::omegas`].
    pub fn phases(&self) -> &[f64] {
        &self.phases
    }

    /// Harmonic numbers k_i of the window.
    pub fn harmonics(&self) -> &[u32] {
        &self.harmonics
    }

    /// The window T_w [s].
    pub fn window_s(&self) -> f64 {
        self.window_s
    }

    /// Amplitude of each tone [rad].
    pub fn amplitude_rad(&self) -> f64 {
        self.amplitude_rad
    }

    /// A guaranteed upper bound of `|r(t)|` [rad] (grid peak plus the curvature bound).
    pub fn peak_rad(&self) -> f64 {
        self.peak_bound_rad
    }

    /// A bound on `|dr/dt|` [rad/s]: `sum_i A omega_i`.
    pub fn max_rate_rad_s(&self) -> f64 {
        self.omegas.iter().map(|w| self.amplitude_rad * w).sum()
    }

    /// Crest factor: grid peak of `|r|` over one window divided by `rms = A sqrt(n/2)`.
    pub fn crest_factor(&self) -> f64 {
        self.crest
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dsp::spectrum::naive_dft;
    use approx::assert_relative_eq;

    const DEG: f64 = PI / 180.0;

    fn default_design() -> Multisine {
        Multisine::design(600.0, &[3, 7, 17], 2.0 * DEG, 1).unwrap()
    }

    #[test]
    fn weighted_value_is_the_sum_of_scaled_tones() {
        let m = default_design();
        for i in 0..200 {
            let t = 7.3 * i as f64;
            // Unit weights: bit for bit the plain value (what an unsized test plays).
            assert_eq!(
                m.value_weighted(t, &[1.0; 8]).to_bits(),
                m.value(t).to_bits()
            );
            let want: f64 = [1.0, 0.5, 0.0625]
                .iter()
                .zip(m.omegas().iter().zip(m.phases()))
                .map(|(k, (w, p))| k * 2.0 * DEG * (w * t.rem_euclid(600.0) + p).sin())
                .sum();
            assert_relative_eq!(
                m.value_weighted(t, &[1.0, 0.5, 0.0625]),
                want,
                epsilon = 1e-15
            );
        }
        assert_eq!(m.value_weighted(f64::NAN, &[1.0]), 0.0);
    }

    #[test]
    fn zero_cosine_phases_have_the_analytic_crest_factor() {
        // All tones peak together at t = 0: CF = n / sqrt(n / 2).
        let z = Multisine::with_phases(600.0, &[3, 7, 17], 2.0 * DEG, &[PI / 2.0; 3]).unwrap();
        assert_relative_eq!(z.crest_factor(), 3.0 / 1.5f64.sqrt(), max_relative = 1e-12);
        let one = Multisine::with_phases(100.0, &[5], 1.0, &[0.3]).unwrap();
        assert_relative_eq!(one.crest_factor(), 2f64.sqrt(), max_relative = 1e-6);
    }

    #[test]
    fn optimised_crest_factor_beats_schroeder_and_zero_phases() {
        let m = default_design();
        let schroeder: Vec<f64> = (1..=3)
            .map(|i| -PI * (i * (i - 1)) as f64 / 3.0 + PI / 2.0)
            .collect();
        let s = Multisine::with_phases(600.0, &[3, 7, 17], 2.0 * DEG, &schroeder).unwrap();
        let z = Multisine::with_phases(600.0, &[3, 7, 17], 2.0 * DEG, &[PI / 2.0; 3]).unwrap();
        let cf = m.crest_factor();
        println!(
            "crest factor: optimised {cf:.4}, Schroeder {:.4}, zero {:.4}, phases {:?}, peak {} rad, rate {} rad/s",
            s.crest_factor(),
            z.crest_factor(),
            m.phases(),
            m.peak_rad(),
            m.max_rate_rad_s()
        );
        assert!(cf < 2.0, "crest factor {cf}");
        assert!(
            cf < s.crest_factor() - 1e-3,
            "{cf} vs Schroeder {}",
            s.crest_factor()
        );
        assert!(cf < z.crest_factor() - 1e-3);
        // Not better than physically possible: the peak of n tones exceeds the rms of one
        // tone's peak, A sqrt(2) ... and CF >= sqrt(2) for any real multisine.
        assert!(cf > 2f64.sqrt());
    }

    #[test]
    fn crest_factor_agrees_with_a_brute_force_peak_search() {
        let m = default_design();
        // Independent: scan 600 s at 1 ms with value().
        let mut peak = 0.0f64;
        for i in 0..600_000 {
            peak = peak.max(m.value(i as f64 * 1e-3).abs());
        }
        let rms = 2.0 * DEG * 1.5f64.sqrt();
        assert_relative_eq!(m.crest_factor(), peak / rms, max_relative = 1e-3);
        assert!(m.peak_rad() >= peak && m.peak_rad() <= peak * 1.001);
    }

    #[test]
    fn design_is_deterministic_and_seeded() {
        let a = default_design();
        let b = default_design();
        assert_eq!(a, b);
    }

    #[test]
    fn signal_is_periodic_in_the_window() {
        let m = default_design();
        for i in 0..100 {
            let t = i as f64 * 5.77;
            let v = m.value(t);
            assert!((m.value(t + 600.0) - v).abs() < 1e-12);
            assert!((m.value(t + 6000.0) - v).abs() < 1e-12);
            assert!((m.value(t - 600.0) - v).abs() < 1e-12);
        }
        assert_eq!(m.value(f64::NAN), 0.0);
    }

    #[test]
    fn each_tone_is_in_its_bin_with_amplitude_and_phase() {
        let m = default_design();
        let dt = 0.1;
        let n = 6000;
        let x: Vec<f64> = (0..n).map(|i| m.value(i as f64 * dt)).collect();
        for (i, &k) in [3usize, 7, 17].iter().enumerate() {
            let xk = naive_dft(&x, k);
            // A sin(wt + phi) -> (N A / 2) e^{i (phi - pi/2)}.
            assert_relative_eq!(xk.norm(), n as f64 * 2.0 * DEG / 2.0, max_relative = 1e-9);
            let dphi = crate::angle::wrap_pi(xk.arg() - (m.phases()[i] - PI / 2.0));
            assert!(dphi.abs() < 1e-9, "tone {k}: {dphi}");
        }
        // Unexcited bins are empty.
        for k in [1usize, 2, 4, 6, 8, 16, 18, 34] {
            assert!(naive_dft(&x, k).norm() < 1e-9 * n as f64);
        }
    }

    #[test]
    fn rate_bound_holds() {
        let m = default_design();
        let expected: f64 = [3.0, 7.0, 17.0]
            .iter()
            .map(|k| 2.0 * DEG * 2.0 * PI * k / 600.0)
            .sum();
        assert_relative_eq!(m.max_rate_rad_s(), expected, max_relative = 1e-12);
        let h = 1e-3;
        let mut max_rate = 0.0f64;
        for i in 0..60_000 {
            let t = i as f64 * 0.01;
            max_rate = max_rate.max(((m.value(t + h) - m.value(t - h)) / (2.0 * h)).abs());
        }
        assert!(max_rate <= m.max_rate_rad_s() && max_rate > 0.3 * m.max_rate_rad_s());
    }

    #[test]
    fn accessors_and_bad_input() {
        let m = default_design();
        assert_eq!(m.harmonics(), &[3, 7, 17]);
        assert_relative_eq!(m.omegas()[0], 2.0 * PI * 3.0 / 600.0, max_relative = 1e-15);
        assert_eq!(m.window_s(), 600.0);
        assert_eq!(m.amplitude_rad(), 2.0 * DEG);
        assert!(Multisine::design(0.0, &[3], 1.0, 1).is_err());
        assert!(Multisine::design(f64::NAN, &[3], 1.0, 1).is_err());
        assert!(Multisine::design(600.0, &[], 1.0, 1).is_err());
        assert!(Multisine::design(600.0, &[0, 3], 1.0, 1).is_err());
        assert!(Multisine::design(600.0, &[3, 3], 1.0, 1).is_err());
        assert!(Multisine::design(600.0, &[3], -1.0, 1).is_err());
        assert!(Multisine::with_phases(600.0, &[3, 4], 1.0, &[0.0]).is_err());
        assert!(Multisine::with_phases(600.0, &[3], 1.0, &[f64::NAN]).is_err());
    }
}
