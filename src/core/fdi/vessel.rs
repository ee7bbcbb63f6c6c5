//! The vessel's window: evidence summed across both methods' tests.
//!
//! The daemon runs CLFRT and HBT in turn, and each method decides on its own tests
//! (persistence, the mean of its last tests). A shift too small for either method's limits
//! then needs two or three tests *of one method*, four to six tests of the ship. The
//! vessel's window adds the methods' evidence: the sum of the last `fdi.vessel-window` tests'
//! parameter chi-square `q = z_speed^2 + z_disp^2` of the ship, each clipped to
//! `fdi.glr-clip^2` (no one test carries the window) and each against its own method's
//! commissioned reference. For a healthy ship each `q` is chi-square with 2 degrees of
//! freedom (in practice smaller: the commissioned spreads are conservative, median 0.6-0.7
//! against 1.39), so the sum of `n` is at most chi-square with `2 n`; over
//! `fdi.vessel-threshold` the alarm of the method whose test completed the window is raised,
//! as the mean's is. Unlike the mean, the sum does not need the methods' residuals to point
//! the same way (a displacement change moves HBT's and CLFRT's residuals in different
//! directions on a hull unlike the model).
//!
//! The window counts only tests against a commissioned reference, and only with both
//! methods in it: a test on the design reference (commissioning, outside the commissioned
//! speed band) empties it; one method alone never fills it (its own rules stand). Units: `q`
//! is dimensionless (normalised residuals).

use std::collections::VecDeque;

use super::config::{DecisionRule, FdiConfig};
use super::GlrLook;
use crate::core::wire::Method;

/// The last tests of the ship: each test's method and clipped parameter chi-square, newest
/// last.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct VesselWindow {
    tests: VecDeque<(Method, f64)>,
}

impl VesselWindow {
    /// Takes a test's parameter chi-square `q` (`None` or NaN: the test had no parameter
    /// residuals, the window is left as it is); `commissioned`: measured against its
    /// method's commissioned reference (otherwise the window empties). Returns the window's
    /// look once it holds `fdi.vessel-window` tests of both methods (chi-square rule only).
    pub fn look(
        &mut self,
        cfg: &FdiConfig,
        method: Method,
        q: Option<f64>,
        commissioned: bool,
    ) -> Option<GlrLook> {
        let n = cfg.vessel_window as usize;
        if cfg.rule != DecisionRule::ChiSquare || n < 2 || !commissioned {
            self.tests.clear();
            return None;
        }
        let q = q.filter(|q| q.is_finite() && *q >= 0.0)?;
        self.tests
            .push_back((method, q.min(cfg.glr_clip * cfg.glr_clip)));
        while self.tests.len() > n {
            self.tests.pop_front();
        }
        let both = self.tests.iter().any(|t| t.0 == Method::Clfrt)
            && self.tests.iter().any(|t| t.0 == Method::Hbt);
        (self.tests.len() == n && both).then(|| GlrLook {
            statistic: self.tests.iter().map(|t| t.1).sum(),
            window: n,
            threshold: cfg.vessel_threshold,
        })
    }

    /// The evidence is spent on an alarm: the window starts again.
    pub fn clear(&mut self) {
        self.tests.clear();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cfg() -> FdiConfig {
        FdiConfig::default()
    }

    /// The sum of the clipped chi-squares of the last n tests, with both methods in it;
    /// against a sum done by hand.
    #[test]
    fn the_window_sums_the_last_tests_of_both_methods() {
        let c = cfg();
        assert_eq!((c.vessel_window, c.vessel_threshold), (3, 30.0));
        let mut w = VesselWindow::default();
        assert!(w.look(&c, Method::Clfrt, Some(11.0), true).is_none());
        assert!(w.look(&c, Method::Hbt, Some(9.0), true).is_none());
        let l = w.look(&c, Method::Clfrt, Some(12.5), true).unwrap();
        assert!((l.statistic - 32.5).abs() < 1e-12);
        assert!(l.over());
        // The oldest leaves; a test of 40 counts as 16 (glr-clip 4).
        let l = w.look(&c, Method::Hbt, Some(40.0), true).unwrap();
        assert!((l.statistic - (9.0 + 12.5 + 16.0)).abs() < 1e-12);
        // No parameter residuals: the window stays.
        assert!(w.look(&c, Method::Hbt, Some(f64::NAN), true).is_none());
        assert!(w.look(&c, Method::Hbt, None, true).is_none());
        let l = w.look(&c, Method::Clfrt, Some(1.0), true).unwrap();
        assert!((l.statistic - (12.5 + 16.0 + 1.0)).abs() < 1e-12);
        assert!(!l.over());
    }

    /// One method alone never fills it; a test on the design reference empties it; off
    /// with a window under 2 or another rule.
    #[test]
    fn the_window_needs_both_methods_and_the_commissioned_reference() {
        let c = cfg();
        let mut w = VesselWindow::default();
        for _ in 0..5 {
            assert!(w.look(&c, Method::Hbt, Some(16.0), true).is_none());
        }
        let mut w = VesselWindow::default();
        w.look(&c, Method::Clfrt, Some(16.0), true);
        w.look(&c, Method::Hbt, Some(16.0), true);
        assert!(w.look(&c, Method::Clfrt, Some(16.0), false).is_none());
        assert!(
            w.look(&c, Method::Hbt, Some(16.0), true).is_none(),
            "emptied"
        );
        for (rule, n) in [(DecisionRule::ChiSquare, 0), (DecisionRule::Glr, 3)] {
            let off = FdiConfig {
                rule,
                vessel_window: n,
                ..cfg()
            };
            let mut w = VesselWindow::default();
            for m in [Method::Clfrt, Method::Hbt, Method::Clfrt, Method::Hbt] {
                assert!(w.look(&off, m, Some(16.0), true).is_none());
            }
        }
    }
}
