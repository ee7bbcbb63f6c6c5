//! The parity reference of one method: the design's, or the vessel's own after commissioning.
//!
//! A real ship is never the training model (a second-order hull, Norrbin damping, a dead band,
//! an autopilot of its own): on such a ship the networks' estimates carry a bias of their own,
//! constant for the ship at its operating point, that the design spreads (the estimator's
//! error on the training model: 0.2 % of D, 0.06 m/s in a calm sea) read as a fault. The paper's
//! premise is that the features are nominal if, and only if, the plant's parameters are: so
//! the reference a test is compared with is the vessel's own healthy behaviour.
//!
//! ## Raw residuals
//!
//! Per completed test with an estimate, against the design (see the module above):
//!
//! ```text
//! e_u = u_est - u_log - m_u            [m/s]
//! e_D = (D_est - D_nom - m_D) / D_nom  [-]     (relative: a reference survives a new D_nom)
//! ```
//!
//! with `s_u`, `s_D` (relative) the design spreads at the test's sea index.
//!
//! ## Commissioning (the first `fdi.commissioning-tests` = K tests of each method)
//!
//! Decisions use the design reference with standard deviations widened to
//! `max(s_u, fdi.commissioning-spread-speed-mps)` and `max(s_D,
//! fdi.commissioning-spread-displacement)`, uncorrelated: wide enough that no ship of the
//! family alarms on its own structural bias, narrow enough that a gross fault still does.
//! Each test within those limits adds `(e_u, e_D, s_u, s_D, u_log)` to the sample; after K
//! of them the reference is the sample's mean `mu` (the offset) and covariance `S` (n - 1),
//! full: on a hull unlike the training model the speed and displacement errors correlate
//! strongly (-0.5 to -0.98 measured on second-order hulls), and a fault that moves one of
//! them alone stands far out in the direction the healthy scatter does not take.
//!
//! ## The vessel's own reference (after commissioning)
//!
//! For a test at a sea whose design spreads are `s = (s_u, s_D)`:
//!
//! ```text
//! r     = e - mu                                       residual [m/s, fraction]
//! Sigma = kappa_K D S D + diag(f_u^2, f_D^2)           its covariance
//! D     = diag(s_u / sbar_u, s_D / sbar_D)             the sample's sea carried to the test's
//! kappa_K = (K - 1) / (K - p - 2),  p = 2              the K-sample factor
//! ```
//!
//! - `sbar` is the mean design spread over the sample: the vessel's scatter is carried from
//!   the sea it was learned in to the test's by the estimator's own growth of error with the
//!   sea (the design spreads' ratio).
//! - `kappa_K` is the expectation of Hotelling's statistic over the chi-square's: with `S`
//!   estimated from K tests, `E[r' S^-1 r] = p (K - 1) / (K - p - 2)` against `p` for the
//!   true covariance (a Wishart matrix's inverse has mean `Sigma^-1 (K - 1) / (K - p - 2)`).
//!   K = 8: 1.75; K = 20: 1.19. Hence K >= 5.
//! - `f_u = fdi.floor-speed-mps` (the speed log's noise: the log is the speed residual's
//!   reference) and `f_D = fdi.floor-displacement` (how well a healthy ship's displacement is
//!   known between declarations): error sources the commissioning sample cannot see, added
//!   as independent variances. They also bound the covariance's smallest eigenvalue, which K
//!   tests under-estimate most.
//! - The offset `mu` carries the error `Sigma / K`, shared by every later test: the decision
//!   counts it (`crate::core::fdi::decision`).
//!
//! A structural bias depends on the operating point: a test whose speed log lies more than
//! `fdi.commissioning-speed-band-mps` from the commissioning's mean speed falls back to the
//! wide design reference (reported as such) until the vessel is commissioned again.
//! Commissioning starts again on request (the `fdi/commission` queryable, `helmwatch
//! commission`), and when the saved reference was made under another ship configuration or
//! other models (the daemon says which).

pub use super::config::Commissioning as Settings;
use super::stats::Cov2;
use serde::{Deserialize, Serialize};

/// The residual vector's dimension (speed, displacement).
const P: f64 = 2.0;

/// What commissioning has measured for one method, and the reference it set.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct Commissioning {
    /// Tests in the sample so far (completed, with an estimate, within the wide limits).
    pub tests: u32,
    /// Sums over the sample: `e_u`, `e_D`, `s_u`, `s_D`, `u_log`.
    sum: [f64; 5],
    /// Sums of `e_u^2`, `e_D^2`, `e_u e_D`.
    sum_sq: [f64; 3],
    /// The vessel's own reference, once the sample is complete.
    pub reference: Option<Reference>,
}

/// The vessel's own healthy reference of one method.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct Reference {
    /// Tests it was made of (K).
    pub tests: u32,
    /// Offset of `e_u` [m/s].
    pub speed_offset_mps: f64,
    /// Offset of `e_D` [fraction of D_nom].
    pub displacement_offset: f64,
    /// Sample covariance of `(e_u, e_D)` [(m/s)^2, m/s x fraction, fraction^2].
    pub covariance: Cov2,
    /// Mean design spread of the speed over the sample [m/s].
    pub speed_design_sigma_mps: f64,
    /// Mean design spread of the displacement over the sample [fraction].
    pub displacement_design_sigma: f64,
    /// Mean speed log over the sample [m/s].
    pub speed_log_mps: f64,
}

/// One test's raw residuals against the design (see the module doc).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Raw {
    /// `e_u` [m/s].
    pub speed_mps: f64,
    /// `e_D` [fraction of D_nom].
    pub displacement: f64,
    /// Design spread of the speed at this test's sea [m/s].
    pub speed_sigma_mps: f64,
    /// Design spread of the displacement [fraction].
    pub displacement_sigma: f64,
    /// Speed log over the test [m/s].
    pub speed_log_mps: f64,
}

/// Which reference a test was measured against.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Basis {
    /// No commissioning configured: the design's own spreads.
    Design,
    /// Commissioning, this test being number `done + 1` of `of` when it joins the sample.
    Commissioning {
        /// Tests in the sample before this one.
        done: u32,
        /// K.
        of: u32,
    },
    /// The vessel's own reference.
    Commissioned(Reference),
    /// The vessel's reference exists but this test's speed lies outside its band.
    OutsideBand(Reference),
}

/// A test's residual against a reference.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Measured {
    /// `(r_u [m/s], r_D [fraction])`.
    pub r: [f64; 2],
    /// Its covariance for a healthy ship (without the offset's error).
    pub cov: Cov2,
    /// The offset's error relative to `cov`, shared by every test against this reference:
    /// `Some(1/K)` for the vessel's, `Some(0)` for the design's, `None` on wide design limits
    /// (the residual there is the model's bias on this ship, the same at every test: no
    /// average over tests shrinks it).
    pub offset_var: Option<f64>,
}

impl Commissioning {
    /// Whether the sample is still being gathered (and commissioning is configured).
    pub fn in_progress(&self, s: &Settings) -> bool {
        s.tests > 0 && self.reference.is_none()
    }

    /// The basis for a test at `speed_log_mps`.
    pub fn basis(&self, s: &Settings, speed_log_mps: f64) -> Basis {
        if s.tests == 0 {
            return Basis::Design;
        }
        match self.reference {
            None => Basis::Commissioning {
                done: self.tests,
                of: s.tests,
            },
            Some(r) if (speed_log_mps - r.speed_log_mps).abs() > s.speed_band_mps => {
                Basis::OutsideBand(r)
            }
            Some(r) => Basis::Commissioned(r),
        }
    }

    /// The residual of `raw` against `basis`.
    pub fn measure(basis: &Basis, s: &Settings, raw: &Raw) -> Measured {
        let e = [raw.speed_mps, raw.displacement];
        match basis {
            Basis::Design => Measured {
                r: e,
                cov: Cov2::diag(raw.speed_sigma_mps, raw.displacement_sigma),
                offset_var: Some(0.0),
            },
            Basis::Commissioning { .. } | Basis::OutsideBand(_) => Measured {
                r: e,
                cov: Cov2::diag(
                    raw.speed_sigma_mps.max(s.wide_speed_mps),
                    raw.displacement_sigma.max(s.wide_displacement),
                ),
                offset_var: None,
            },
            Basis::Commissioned(r) => {
                let k = f64::from(r.tests.max(1));
                let ratio = |now: f64, then: f64| if then > 0.0 { now / then } else { 1.0 };
                let carried = r.covariance.scaled(
                    ratio(raw.speed_sigma_mps, r.speed_design_sigma_mps),
                    ratio(raw.displacement_sigma, r.displacement_design_sigma),
                );
                Measured {
                    r: [e[0] - r.speed_offset_mps, e[1] - r.displacement_offset],
                    cov: carried
                        .times(kappa(r.tests))
                        .plus(Cov2::diag(s.floor_speed_mps, s.floor_displacement)),
                    offset_var: Some(1.0 / k),
                }
            }
        }
    }

    /// Adds a healthy commissioning test; sets the reference at the K-th. Returns whether
    /// this test completed the commissioning.
    pub fn add(&mut self, s: &Settings, raw: &Raw) -> bool {
        if !self.in_progress(s) {
            return false;
        }
        let x = [
            raw.speed_mps,
            raw.displacement,
            raw.speed_sigma_mps,
            raw.displacement_sigma,
            raw.speed_log_mps,
        ];
        if x.iter().any(|v| !v.is_finite()) {
            return false;
        }
        self.tests += 1;
        for (acc, v) in self.sum.iter_mut().zip(x) {
            *acc += v;
        }
        self.sum_sq[0] += x[0] * x[0];
        self.sum_sq[1] += x[1] * x[1];
        self.sum_sq[2] += x[0] * x[1];
        if self.tests < s.tests {
            return false;
        }
        let n = f64::from(self.tests);
        let mean = |i: usize| self.sum[i] / n;
        let co = |sq: f64, a: usize, b: usize| {
            if self.tests < 2 {
                0.0
            } else {
                (sq - n * mean(a) * mean(b)) / (n - 1.0)
            }
        };
        self.reference = Some(Reference {
            tests: self.tests,
            speed_offset_mps: mean(0),
            displacement_offset: mean(1),
            covariance: Cov2 {
                xx: co(self.sum_sq[0], 0, 0).max(0.0),
                xy: co(self.sum_sq[2], 0, 1),
                yy: co(self.sum_sq[1], 1, 1).max(0.0),
            },
            speed_design_sigma_mps: mean(2),
            displacement_design_sigma: mean(3),
            speed_log_mps: mean(4),
        });
        true
    }

    /// Starts again: the sample and the reference are dropped.
    pub fn restart(&mut self) {
        *self = Self::default();
    }

    /// `off` (no commissioning configured), `commissioning` or `commissioned`.
    pub fn state(&self, s: &Settings) -> &'static str {
        match (s.tests, &self.reference) {
            (0, _) => "off",
            (_, None) => "commissioning",
            (_, Some(_)) => "commissioned",
        }
    }

    /// Status text: "commissioning k of K", "commissioned (K tests at u m/s)" or "design".
    pub fn describe(&self, s: &Settings) -> String {
        match (s.tests, &self.reference) {
            (0, _) => "design reference (commissioning off)".into(),
            (_, None) => format!("commissioning {} of {}", self.tests, s.tests),
            (_, Some(r)) => format!(
                "commissioned ({} tests at {:.1} m/s)",
                r.tests, r.speed_log_mps
            ),
        }
    }
}

/// The K-sample factor `(K - 1) / (K - p - 2)` (see the module doc); 1 for K <= p + 2, which
/// the configuration's limits exclude.
pub fn kappa(k: u32) -> f64 {
    let k = f64::from(k);
    if k > P + 2.0 {
        (k - 1.0) / (k - P - 2.0)
    } else {
        1.0
    }
}

impl Basis {
    /// Name in the report's `residuals.reference.kind`.
    pub fn name(&self) -> &'static str {
        match self {
            Basis::Design => "design",
            Basis::Commissioning { .. } => "commissioning",
            Basis::Commissioned(_) => "commissioned",
            Basis::OutsideBand(_) => "outside_commissioned_band",
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn settings() -> Settings {
        Settings {
            tests: 5,
            wide_speed_mps: 1.0,
            wide_displacement: 0.1,
            speed_band_mps: 1.0,
            floor_speed_mps: 0.0,
            floor_displacement: 0.0,
        }
    }

    fn raw(e_u: f64, e_d: f64) -> Raw {
        Raw {
            speed_mps: e_u,
            displacement: e_d,
            speed_sigma_mps: 0.05,
            displacement_sigma: 0.002,
            speed_log_mps: 7.0,
        }
    }

    const SAMPLE: [(f64, f64); 5] = [
        (1.0, -0.20),
        (1.2, -0.22),
        (0.8, -0.18),
        (1.1, -0.20),
        (0.9, -0.21),
    ];

    #[test]
    fn the_reference_is_the_sample_mean_and_covariance() {
        let s = settings();
        let mut c = Commissioning::default();
        for (i, (u, d)) in SAMPLE.iter().enumerate() {
            assert!(matches!(
                c.basis(&s, 7.0),
                Basis::Commissioning { done, of: 5 } if done == i as u32
            ));
            assert_eq!(c.add(&s, &raw(*u, *d)), i == 4);
        }
        let r = c.reference.unwrap();
        // Two-pass sample moments (n - 1), computed here independently.
        let n = SAMPLE.len() as f64;
        let mu = SAMPLE
            .iter()
            .fold((0.0, 0.0), |a, x| (a.0 + x.0 / n, a.1 + x.1 / n));
        let cov = |f: &dyn Fn(&(f64, f64)) -> f64| SAMPLE.iter().map(f).sum::<f64>() / (n - 1.0);
        let sxx = cov(&|x| (x.0 - mu.0).powi(2));
        let sxy = cov(&|x| (x.0 - mu.0) * (x.1 - mu.1));
        let syy = cov(&|x| (x.1 - mu.1).powi(2));
        assert!((r.speed_offset_mps - mu.0).abs() < 1e-12);
        assert!((r.displacement_offset - mu.1).abs() < 1e-12);
        assert!((r.covariance.xx - sxx).abs() < 1e-12);
        assert!((r.covariance.xy - sxy).abs() < 1e-13);
        assert!((r.covariance.yy - syy).abs() < 1e-14);
        assert!(
            r.covariance.correlation() < -0.5,
            "the sample is anti-correlated"
        );
        assert_eq!(c.describe(&s), "commissioned (5 tests at 7.0 m/s)");
        assert!(!c.add(&s, &raw(9.0, 9.0)));
        assert_eq!(c.reference.unwrap(), r);
    }

    #[test]
    fn the_test_covariance_carries_the_sea_the_k_factor_and_the_floors() {
        let s = Settings {
            floor_speed_mps: 0.05,
            floor_displacement: 0.004,
            ..settings()
        };
        let mut c = Commissioning::default();
        for (u, d) in SAMPLE {
            c.add(&s, &raw(u, d));
        }
        let r = c.reference.unwrap();
        let basis = c.basis(&s, 7.2);
        let m = Commissioning::measure(&basis, &s, &raw(1.3, -0.2));
        assert!((m.r[0] - (1.3 - r.speed_offset_mps)).abs() < 1e-12);
        assert_eq!(m.offset_var, Some(0.2));
        // kappa_5 = 4 / 1 = 4.
        assert_eq!(kappa(5), 4.0);
        assert_eq!(kappa(8), 1.75);
        assert!((m.cov.xx - (4.0 * r.covariance.xx + 0.05f64.powi(2))).abs() < 1e-12);
        assert!((m.cov.xy - 4.0 * r.covariance.xy).abs() < 1e-12);
        assert!((m.cov.yy - (4.0 * r.covariance.yy + 0.004f64.powi(2))).abs() < 1e-15);
        // A sea with three times the design spread of the speed: its variance x9, the
        // covariance x3, the displacement's untouched.
        let mut rough = raw(1.3, -0.2);
        rough.speed_sigma_mps = 0.15;
        let m3 = Commissioning::measure(&basis, &s, &rough);
        assert!((m3.cov.xx - (36.0 * r.covariance.xx + 0.0025)).abs() < 1e-12);
        assert!((m3.cov.xy - 12.0 * r.covariance.xy).abs() < 1e-12);
        assert!((m3.cov.yy - m.cov.yy).abs() < 1e-18);
    }

    #[test]
    fn commissioning_is_wide_and_outside_the_band_falls_back_to_it() {
        let s = settings();
        let mut c = Commissioning::default();
        let m = Commissioning::measure(&c.basis(&s, 7.0), &s, &raw(1.0, -0.2));
        assert_eq!(m.cov, Cov2::diag(1.0, 0.1));
        assert_eq!(m.offset_var, None);
        for (u, d) in SAMPLE {
            c.add(&s, &raw(u, d));
        }
        assert!(matches!(c.basis(&s, 8.1), Basis::OutsideBand(_)));
        assert!(matches!(c.basis(&s, 5.9), Basis::OutsideBand(_)));
        assert!(matches!(c.basis(&s, 7.9), Basis::Commissioned(_)));
        let m = Commissioning::measure(&c.basis(&s, 8.1), &s, &raw(1.0, -0.2));
        assert_eq!(
            (m.r, m.cov, m.offset_var),
            ([1.0, -0.2], Cov2::diag(1.0, 0.1), None)
        );
        c.restart();
        assert!(c.in_progress(&s));
        assert_eq!(c.describe(&s), "commissioning 0 of 5");
    }

    #[test]
    fn without_commissioning_the_design_reference_serves() {
        let s = Settings {
            tests: 0,
            ..settings()
        };
        let mut c = Commissioning::default();
        assert_eq!(c.basis(&s, 7.0), Basis::Design);
        assert!(!c.add(&s, &raw(1.0, 0.0)));
        let m = Commissioning::measure(&Basis::Design, &s, &raw(1.0, -0.2));
        assert_eq!(
            (m.r, m.cov, m.offset_var),
            ([1.0, -0.2], Cov2::diag(0.05, 0.002), Some(0.0))
        );
    }
}
