//! A test's residual against the vessel's reference: which reference ([`Basis`]), the
//! residual and its covariance ([`Measured`]), and the calibration of Hotelling's statistic
//! onto the chi-square (docs/fdi.md, "The model").

use super::envelope::Prediction;
use super::stats::{chi2_isf, dot, hotelling_sf, Cov, P};

/// Which reference a test was measured against.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Basis {
    /// No commissioning configured: the design's own spreads.
    Design,
    /// Commissioning, this test being number `done + 1` of at most `of` when it joins.
    Commissioning {
        /// Tests in the sample before this one.
        done: u32,
        /// `fdi.commissioning-tests`.
        of: u32,
    },
    /// The commissioning sample held a change at test `at`: wide limits.
    Inconsistent {
        /// The first test after the change.
        at: u32,
    },
    /// The vessel's own, predicted at the test's operating point.
    Vessel(Prediction),
}

/// A test's residual against a reference.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Measured {
    /// `(r_u [m/s], r_D [fraction], r_b [ln])`; the components from `dim` on are 0.
    pub r: [f64; P],
    /// Its covariance for a healthy ship (the offset's error included); from `dim` on,
    /// independent unit variances.
    pub cov: Cov,
    /// The offset error's share of `cov`, shared by every later test against this reference
    /// (`Some(0)` for the design's); `None` on wide design limits (the residual there is the
    /// model's bias on this ship, the same at every test: no average over tests shrinks it).
    pub offset_var: Option<f64>,
    /// The degrees of freedom the learned part of `cov` was estimated with (infinite:
    /// nothing learned).
    pub dof: f64,
    /// The part of `cov` that rests on the learned tests (the scatter and the offset's
    /// error; the rest, the floors, is known).
    pub learned: Cov,
    /// The components measured: 2 (`e_u`, `e_D`: against the design, or a test without
    /// `e_b`) or `P`.
    pub dim: usize,
    /// The learned part's share is taken at its upper confidence bound (at a learned loading
    /// and excitation; at a new one `dof` is already cut to the tests near it).
    pub bounded: bool,
    /// `1 +` the largest share of the test's covariance, in any direction, that its own
    /// measurement error beyond the vessel's typical adds (`crate::fdi::noise`): 1 for
    /// a test as clean as the vessel's typical, or without intervals of its own.
    pub noise_ratio: f64,
}

impl Measured {
    /// The whitened residual, calibrated: `z = L^-1 r` (`L L' = cov`) scaled so that
    /// `|z|^2` has the chi-square's tail (`dim` dof) where `r' cov^-1 r` has Hotelling's (see
    /// the module doc); `None` unless `cov` is positive definite.
    pub fn whitened(&self) -> Option<[f64; P]> {
        let z = self.cov.whiten(self.r)?;
        let k = if super::ablation::off(super::ablation::Mechanism::HotellingCalibration) {
            1.0
        } else {
            calibration(dot(z, z), self.effective_dof(), self.dim)
        };
        Some(z.map(|v| v * k))
    }

    /// The degrees of freedom along the residual: the known floors' share of the residual's
    /// variance in its own direction adds degrees of freedom (the conservative root of
    /// Satterthwaite's approximation, `nu / share_learned`). The learned part's share is
    /// taken at its 95 % upper confidence bound, `A` times `m = nu / chi2_nu^-1(0.05)`
    /// (`y = Sigma^-1 r`, `T = y' Sigma y`, `a = y' A y`):
    ///
    /// ```text
    /// share = m a / (T + (m - 1) a),   nu_eff = nu / share  (at least nu)
    /// ```
    ///
    /// A learned variance small by chance (a point with two tests alike) would otherwise
    /// make its own share small and its tail the chi-square's, the very case Hotelling's tail
    /// is there for.
    pub fn effective_dof(&self) -> f64 {
        if !self.dof.is_finite() {
            return f64::INFINITY;
        }
        let Some(y) = self.cov.solve(self.r) else {
            return self.dof;
        };
        let m = if self.bounded {
            bound_factor(self.dof, 0.95)
        } else {
            1.0
        };
        effective_dof(dot(self.r, y), self.learned.form(y, y), self.dof, m)
    }
}

/// The degrees of freedom of a statistic `t = r' Sigma^-1 r` whose covariance `Sigma` is
/// known but for a learned part `A` estimated with `nu` dof: `a = y' A y` (`y = Sigma^-1 r`)
/// is the learned part's share of `t`, taken at an upper confidence bound `m` times the
/// estimate (`bound_factor`; 1: as estimated):
///
/// ```text
/// share = m a / (t + (m - 1) a),   nu_eff = nu / share  (at least nu)
/// ```
///
/// (`Measured::effective_dof`; the commissioning's change-point test,
/// `crate::fdi::changepoint`). Infinite when nothing of `t` is learned.
pub fn effective_dof(t: f64, a: f64, nu: f64, m: f64) -> f64 {
    if !(a > 0.0 && t > 0.0) {
        return f64::INFINITY;
    }
    let share = m * a / (t + (m - 1.0) * a);
    (nu / share).max(nu)
}

/// The factor of a variance estimated with `nu` dof to its upper confidence bound of `level`:
/// `m = nu / chi2_nu^-1(1 - level)` (`nu` at least `P + 1.5`), at least 1.
pub fn bound_factor(nu: f64, level: f64) -> f64 {
    let n = nu.max(P as f64 + 1.5);
    (n / chi2_isf(level, n)).max(1.0)
}

/// The factor `sqrt(T' / T)` that maps Hotelling's `T^2(p, nu)` statistic `t` onto the
/// chi-square (`p` dof) of the same tail probability (`stats::hotelling_sf`; at `p = 2`,
/// `T' = (nu - 1) ln(1 + t / nu)`). `nu` below `p + 1.5` is taken as `p + 1.5`.
pub fn calibration(t: f64, nu: f64, p: usize) -> f64 {
    if !nu.is_finite() || t.is_nan() || t <= 0.0 {
        return 1.0;
    }
    let nu = nu.max(p as f64 + 1.5);
    let tail = hotelling_sf(t, p, nu);
    if tail.is_nan() || tail <= 0.0 {
        // Beyond any tail a float holds: the chi-square's own far limit.
        return (chi2_isf(f64::MIN_POSITIVE, p as f64) / t).sqrt().min(1.0);
    }
    (chi2_isf(tail, p as f64) / t).sqrt().min(1.0)
}

/// The Hotelling factor `nu / (nu - p - 1)` for a shape with `nu` effective dof (see the
/// module doc); `nu <= p + 1.5` is taken as `p + 1.5` (a factor of `nu / 0.5`).
pub fn kappa(nu: f64) -> f64 {
    let nu = nu.max(P as f64 + 1.5);
    nu / (nu - P as f64 - 1.0)
}

impl Basis {
    /// Whether it is the vessel's reference at a point it has learned (a learned test
    /// within one bandwidth: the report's `commissioned`), not a prediction.
    pub fn at_learned_point(&self) -> bool {
        matches!(self, Basis::Vessel(p) if p.nearest <= 1.0)
    }

    /// Name in the report's `residuals.reference.kind`.
    pub fn name(&self) -> &'static str {
        match self {
            Basis::Design => "design",
            Basis::Commissioning { .. } => "commissioning",
            Basis::Inconsistent { .. } => "commissioning_inconsistent",
            b if b.at_learned_point() => "commissioned",
            Basis::Vessel(_) => "predicted",
        }
    }
}
