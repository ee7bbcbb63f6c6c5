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
//! Decisions use the design reference with spreads widened to
//! `max(s_u, fdi.commissioning-spread-speed-mps)` and `max(s_D,
//! fdi.commissioning-spread-displacement)`: wide enough that no ship of the family alarms
//! (docs/fdi.md gives the family's biases), narrow enough that a gross fault still does.
//! Each test that did not exceed adds `(e_u, e_D, s_u, s_D, u_log)` to the sample; after K of
//! them the reference is
//!
//! ```text
//! offset   o = mean(e)                         (per residual)
//! spread   s_ref(now) = max(s(now), f sd(e) s(now) / mean(s)) sqrt(1 + 1/K)
//! ```
//!
//! and the displacement's at least `fdi.commissioned-floor-displacement` (0.4 % of D_nom: a
//! healthy ship's displacement, read by a test, is not known better; the design spread in a
//! calm sea is 0.2-0.3 %, in a moderate one 0.44 % and more, which the floor leaves alone).
//! `sd` the sample standard deviation (n - 1), `f = fdi.commissioning-spread-factor` (a few
//! tests under-estimate a spread: with K = 5 the sample sd is below half the true one one time
//! in twenty), scaled from the commissioning's sea to the test's by the design spreads' ratio,
//! and `sqrt(1 + 1/K)` the offset's own uncertainty. After it: `r = e - o`, `z = r / s_ref`.
//!
//! A structural bias depends on the operating point: a test whose speed log lies more than
//! `fdi.commissioning-speed-band-mps` from the commissioning's mean speed falls back to the
//! wide design reference (reported as such) until the vessel is commissioned again.
//! Commissioning starts again on request (the `fdi/commission` queryable, `helmwatch
//! commission`), and when the saved reference was made under another ship configuration or
//! other models (the daemon says which).

pub use super::config::Commissioning as Settings;
use serde::{Deserialize, Serialize};

/// What commissioning has measured for one method, and the reference it set.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Commissioning {
    /// Tests in the sample so far (completed, with an estimate, within the wide limits).
    pub tests: u32,
    /// Sums over the sample: `e_u`, `e_D`, `s_u`, `s_D`, `u_log`.
    sum: [f64; 5],
    /// Sums of squares of `e_u`, `e_D`.
    sum_sq: [f64; 2],
    /// The vessel's own reference, once the sample is complete.
    pub reference: Option<Reference>,
}

/// The vessel's own healthy reference of one method.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Reference {
    /// Tests it was made of.
    pub tests: u32,
    /// Offset of `e_u` [m/s].
    pub speed_offset_mps: f64,
    /// Sample standard deviation of `e_u` [m/s].
    pub speed_sd_mps: f64,
    /// Mean design spread of the speed over the sample [m/s].
    pub speed_design_sigma_mps: f64,
    /// Offset of `e_D` [fraction of D_nom].
    pub displacement_offset: f64,
    /// Sample standard deviation of `e_D` [fraction].
    pub displacement_sd: f64,
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
    /// Commissioning, this test being number `k` of `of` (1-based) when it joins the sample.
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

/// Residuals against a reference: `(r_u [m/s], s_u [m/s], r_D [fraction], s_D [fraction])`.
pub type Measured = (f64, f64, f64, f64);

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

    /// The residuals of `raw` against `basis`.
    pub fn measure(basis: &Basis, s: &Settings, raw: &Raw) -> Measured {
        match basis {
            Basis::Design => (
                raw.speed_mps,
                raw.speed_sigma_mps,
                raw.displacement,
                raw.displacement_sigma,
            ),
            Basis::Commissioning { .. } | Basis::OutsideBand(_) => (
                raw.speed_mps,
                raw.speed_sigma_mps.max(s.wide_speed_mps),
                raw.displacement,
                raw.displacement_sigma.max(s.wide_displacement),
            ),
            Basis::Commissioned(r) => {
                let k = f64::from(r.tests.max(1));
                let offset_term = (1.0 + 1.0 / k).sqrt();
                let own = |sd: f64, design_mean: f64, now: f64| {
                    let scaled = if design_mean > 0.0 {
                        s.spread_factor * sd * now / design_mean
                    } else {
                        0.0
                    };
                    now.max(scaled) * offset_term
                };
                (
                    raw.speed_mps - r.speed_offset_mps,
                    own(
                        r.speed_sd_mps,
                        r.speed_design_sigma_mps,
                        raw.speed_sigma_mps,
                    ),
                    raw.displacement - r.displacement_offset,
                    own(
                        r.displacement_sd,
                        r.displacement_design_sigma,
                        raw.displacement_sigma,
                    )
                    .max(s.floor_displacement),
                )
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
        if self.tests < s.tests {
            return false;
        }
        let n = f64::from(self.tests);
        let mean = |i: usize| self.sum[i] / n;
        let sd = |i: usize| {
            if self.tests < 2 {
                return 0.0;
            }
            let m = mean(i);
            ((self.sum_sq[i] - n * m * m).max(0.0) / (n - 1.0)).sqrt()
        };
        self.reference = Some(Reference {
            tests: self.tests,
            speed_offset_mps: mean(0),
            speed_sd_mps: sd(0),
            speed_design_sigma_mps: mean(2),
            displacement_offset: mean(1),
            displacement_sd: sd(1),
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
            tests: 4,
            wide_speed_mps: 1.0,
            wide_displacement: 0.1,
            spread_factor: 2.0,
            speed_band_mps: 1.0,
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

    #[test]
    fn the_reference_is_the_sample_mean_and_sd() {
        let s = settings();
        let mut c = Commissioning::default();
        let e = [(1.0, -0.20), (1.2, -0.22), (0.8, -0.18), (1.0, -0.20)];
        for (i, (u, d)) in e.iter().enumerate() {
            assert!(matches!(
                c.basis(&s, 7.0),
                Basis::Commissioning { done, of: 4 } if done == i as u32
            ));
            assert_eq!(c.add(&s, &raw(*u, *d)), i == 3);
        }
        let r = c.reference.unwrap();
        assert!((r.speed_offset_mps - 1.0).abs() < 1e-12);
        assert!((r.displacement_offset + 0.20).abs() < 1e-12);
        // Naive two-pass sample sd (n - 1) of 1.0, 1.2, 0.8, 1.0: sqrt(0.08 / 3).
        assert!((r.speed_sd_mps - (0.08f64 / 3.0).sqrt()).abs() < 1e-12);
        assert!((r.displacement_sd - (0.0008f64 / 3.0).sqrt()).abs() < 1e-12);
        assert_eq!(c.describe(&s), "commissioned (4 tests at 7.0 m/s)");
        // A fifth test adds nothing.
        assert!(!c.add(&s, &raw(9.0, 9.0)));
        assert_eq!(c.reference.unwrap(), r);
    }

    #[test]
    fn after_commissioning_the_offset_is_removed_and_the_spread_is_the_larger() {
        let s = settings();
        let mut c = Commissioning::default();
        for (u, d) in [(1.0, -0.2), (1.2, -0.2), (0.8, -0.2), (1.0, -0.2)] {
            c.add(&s, &raw(u, d));
        }
        let basis = c.basis(&s, 7.2);
        assert!(matches!(basis, Basis::Commissioned(_)));
        let (ru, su, rd, sd) = Commissioning::measure(&basis, &s, &raw(1.3, -0.2));
        assert!((ru - 0.3).abs() < 1e-12);
        assert!(rd.abs() < 1e-12);
        let k = (1.25f64).sqrt();
        // Speed: the observed sd (0.163) times f = 2 beats the design's 0.05.
        let want_su = 2.0 * (0.08f64 / 3.0).sqrt() * k;
        assert!((su - want_su).abs() < 1e-12, "{su} {want_su}");
        // Displacement: no observed spread, the design's own.
        assert!((sd - 0.002 * k).abs() < 1e-15, "{sd}");
        // In a rougher sea (design spread x3) the observed spread scales with it.
        let mut rough = raw(1.3, -0.2);
        rough.speed_sigma_mps = 0.15;
        let (_, su3, _, _) = Commissioning::measure(&basis, &s, &rough);
        assert!((su3 - 3.0 * want_su).abs() < 1e-12);
        // The displacement's floor: it replaces a smaller spread, leaves a larger one, and
        // does not touch the speed's.
        let floored = Settings {
            floor_displacement: 0.004,
            ..s
        };
        let (_, su_f, _, sd_f) = Commissioning::measure(&basis, &floored, &raw(1.3, -0.2));
        assert_eq!((su_f, sd_f), (su, 0.004));
        let mut wide = raw(1.3, -0.2);
        wide.displacement_sigma = 0.005;
        let (_, _, _, sd_w) = Commissioning::measure(&basis, &floored, &wide);
        assert!((sd_w - 0.005 * k).abs() < 1e-15, "{sd_w}");
        // The design and commissioning bases keep their own spreads.
        let (_, _, _, sd_d) = Commissioning::measure(&Basis::Design, &floored, &raw(1.3, -0.2));
        assert_eq!(sd_d, 0.002);
    }

    #[test]
    fn commissioning_is_wide_and_outside_the_band_falls_back_to_it() {
        let s = settings();
        let mut c = Commissioning::default();
        let (_, su, _, sd) = Commissioning::measure(&c.basis(&s, 7.0), &s, &raw(1.0, -0.2));
        assert_eq!((su, sd), (1.0, 0.1));
        for _ in 0..4 {
            c.add(&s, &raw(1.0, -0.2));
        }
        assert!(matches!(c.basis(&s, 8.1), Basis::OutsideBand(_)));
        assert!(matches!(c.basis(&s, 5.9), Basis::OutsideBand(_)));
        assert!(matches!(c.basis(&s, 7.9), Basis::Commissioned(_)));
        let (ru, su, _, _) = Commissioning::measure(&c.basis(&s, 8.1), &s, &raw(1.0, -0.2));
        assert_eq!((ru, su), (1.0, 1.0));
        c.restart();
        assert!(c.in_progress(&s));
        assert_eq!(c.describe(&s), "commissioning 0 of 4");
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
        assert_eq!(
            Commissioning::measure(&Basis::Design, &s, &raw(1.0, -0.2)),
            (1.0, 0.05, -0.2, 0.002)
        );
    }
}
