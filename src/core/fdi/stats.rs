//! The distributions the decision's limits come from, and 2 x 2 covariance algebra.
//!
//! - Chi-square with an even number of degrees of freedom `2k` (the parameter channel has 2
//!   per method in the window): `P(X > x) = e^{-x/2} sum_{j<k} (x/2)^j / j!`, exact.
//! - The standard normal's upper tail (the servo channel): `P(Z > z) = erfc(z / sqrt 2) / 2`,
//!   with `erfc` from a Chebyshev expansion (Numerical Recipes, 3rd ed., `Erf::erfccheb`:
//!   relative error about 1e-16, far below anything a limit needs).
//! - Quantiles by bisection on the tails (monotone; 200 halvings reach the f64 grain).
//!
//! A covariance `[[xx, xy], [xy, yy]]` of the two parameter residuals (speed [m/s],
//! displacement [fraction]) whitens a residual by its Cholesky factor: `z = L^-1 r` with
//! `L L' = Sigma`, so `|z|^2 = r' Sigma^-1 r` and, for a healthy ship, `z` is standard normal.

use serde::{Deserialize, Serialize};

/// `P(chi2_dof > x)` for an even `dof >= 2`.
pub fn chi2_sf_even(x: f64, dof: usize) -> f64 {
    if x <= 0.0 {
        return 1.0;
    }
    let k = (dof / 2).max(1);
    let h = x / 2.0;
    let mut term = 1.0;
    let mut sum = 1.0;
    for j in 1..k {
        term *= h / j as f64;
        sum += term;
    }
    (-h).exp() * sum
}

/// The `x` with `P(chi2_dof > x) = p` (even `dof`).
pub fn chi2_isf_even(p: f64, dof: usize) -> f64 {
    bisect(|x| chi2_sf_even(x, dof), p, 0.0, 10_000.0)
}

/// `erfc(x)` (the Chebyshev expansion of the module doc for `x >= 0`, reflected below).
pub fn erfc(x: f64) -> f64 {
    if x < 0.0 {
        return 2.0 - erfc(-x);
    }
    // Chebyshev coefficients of erfc(z) = t exp(-z^2) P(t), t = 2 / (2 + z) (Numerical
    // Recipes 3rd ed., Erf::erfccheb), relative error < 1.2e-16.
    #[allow(clippy::excessive_precision)] // the published coefficients, as printed
    const COF: [f64; 28] = [
        -1.3026537197817094,
        6.4196979235649026e-1,
        1.9476473204185836e-2,
        -9.561514786808631e-3,
        -9.46595344482036e-4,
        3.66839497852761e-4,
        4.2523324806907e-5,
        -2.0278578112534e-5,
        -1.624290004647e-6,
        1.303655835580e-6,
        1.5626441722e-8,
        -8.5238095915e-8,
        6.529054439e-9,
        5.059343495e-9,
        -9.91364156e-10,
        -2.27365122e-10,
        9.6467911e-11,
        2.394038e-12,
        -6.886027e-12,
        8.94487e-13,
        3.13092e-13,
        -1.12708e-13,
        3.81e-16,
        7.106e-15,
        -1.523e-15,
        -9.4e-17,
        1.21e-16,
        -2.8e-17,
    ];
    let t = 2.0 / (2.0 + x);
    let ty = 4.0 * t - 2.0;
    let (mut d, mut dd) = (0.0, 0.0);
    for &c in COF[1..].iter().rev() {
        let tmp = d;
        d = ty * d - dd + c;
        dd = tmp;
    }
    t * (-x * x + 0.5 * (COF[0] + ty * d) - dd).exp()
}

/// `P(Z > z)` for a standard normal `Z`.
pub fn normal_sf(z: f64) -> f64 {
    0.5 * erfc(z / std::f64::consts::SQRT_2)
}

/// The `z` with `P(Z > z) = p`.
pub fn normal_isf(p: f64) -> f64 {
    bisect(normal_sf, p, -40.0, 40.0)
}

/// The `x` in `[lo, hi]` with `tail(x) = p`, `tail` decreasing.
fn bisect(tail: impl Fn(f64) -> f64, p: f64, mut lo: f64, mut hi: f64) -> f64 {
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if tail(mid) > p {
            lo = mid;
        } else {
            hi = mid;
        }
        if hi - lo <= f64::EPSILON * hi.abs().max(1.0) {
            break;
        }
    }
    0.5 * (lo + hi)
}

/// A symmetric 2 x 2 covariance `[[xx, xy], [xy, yy]]`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Cov2 {
    /// Variance of the first component.
    pub xx: f64,
    /// Covariance.
    pub xy: f64,
    /// Variance of the second component.
    pub yy: f64,
}

impl Cov2 {
    /// A diagonal covariance of standard deviations `sx`, `sy`.
    pub fn diag(sx: f64, sy: f64) -> Self {
        Self {
            xx: sx * sx,
            xy: 0.0,
            yy: sy * sy,
        }
    }

    /// `D Sigma D` for `D = diag(dx, dy)`.
    pub fn scaled(self, dx: f64, dy: f64) -> Self {
        Self {
            xx: self.xx * dx * dx,
            xy: self.xy * dx * dy,
            yy: self.yy * dy * dy,
        }
    }

    /// `k Sigma`.
    pub fn times(self, k: f64) -> Self {
        Self {
            xx: self.xx * k,
            xy: self.xy * k,
            yy: self.yy * k,
        }
    }

    /// `Sigma + other`.
    pub fn plus(self, o: Self) -> Self {
        Self {
            xx: self.xx + o.xx,
            xy: self.xy + o.xy,
            yy: self.yy + o.yy,
        }
    }

    /// The correlation (0 when a variance is 0).
    pub fn correlation(self) -> f64 {
        let d = (self.xx * self.yy).sqrt();
        if d > 0.0 {
            self.xy / d
        } else {
            0.0
        }
    }

    /// The largest `lambda` with `det(self - lambda other) = 0`: the largest share of
    /// `other`'s variance, in any direction, that `self` accounts for (0 when `other` is
    /// not positive definite).
    pub fn max_ratio(self, other: Self) -> f64 {
        let det_b = other.xx * other.yy - other.xy * other.xy;
        let det_a = self.xx * self.yy - self.xy * self.xy;
        if det_b.is_nan() || det_b <= 0.0 {
            return 0.0;
        }
        let q = self.xx * other.yy + self.yy * other.xx - 2.0 * self.xy * other.xy;
        let disc = (q * q - 4.0 * det_b * det_a).max(0.0);
        let l = (q + disc.sqrt()) / (2.0 * det_b);
        if l.is_finite() {
            l.max(0.0)
        } else {
            0.0
        }
    }

    /// `L^-1 r` with `L` the lower Cholesky factor (`None` unless positive definite).
    pub fn whiten(self, r: [f64; 2]) -> Option<[f64; 2]> {
        if !(self.xx.is_finite() && self.xx > 0.0) {
            return None;
        }
        let l11 = self.xx.sqrt();
        let l21 = self.xy / l11;
        let d = self.yy - l21 * l21;
        if !(d.is_finite() && d > 0.0) {
            return None;
        }
        let l22 = d.sqrt();
        let z0 = r[0] / l11;
        let z1 = (r[1] - l21 * z0) / l22;
        (z0.is_finite() && z1.is_finite()).then_some([z0, z1])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chi2_tails_match_known_values() {
        // Tables: chi2_2 at 0.1 % is 13.8155, chi2_4 at 0.1 % is 18.4668, chi2_2 at 5 % 5.9915.
        for (p, dof, x) in [(1e-3, 2, 13.8155), (1e-3, 4, 18.4668), (0.05, 2, 5.9915)] {
            let q = chi2_isf_even(p, dof);
            assert!((q - x).abs() < 2e-4, "{p} {dof}: {q} vs {x}");
            assert!((chi2_sf_even(x, dof) / p - 1.0).abs() < 1e-4);
        }
        // chi2_2 is exponential: P(X > x) = e^{-x/2} exactly.
        assert!((chi2_sf_even(25.0, 2) - (-12.5f64).exp()).abs() < 1e-18);
    }

    #[test]
    fn normal_tail_matches_known_values() {
        for (z, p) in [
            (0.0, 0.5),
            (1.959964, 0.025),
            (3.090232, 1e-3),
            (4.753424, 1e-6),
        ] {
            let got = normal_sf(z);
            assert!((got / p - 1.0).abs() < 1e-5, "{z}: {got} vs {p}");
            assert!((normal_isf(p) - z).abs() < 1e-5);
        }
        // Symmetry.
        assert!((normal_sf(-1.3) + normal_sf(1.3) - 1.0).abs() < 1e-15);
    }

    #[test]
    fn max_ratio_is_the_largest_generalised_eigenvalue() {
        // B = I: the eigenvalues of A itself, (5 +- sqrt(1 + 4)) / 2 for [[3, 1], [1, 2]].
        let a = Cov2 {
            xx: 3.0,
            xy: 1.0,
            yy: 2.0,
        };
        let id = Cov2::diag(1.0, 1.0);
        assert!((a.max_ratio(id) - (5.0 + 5f64.sqrt()) / 2.0).abs() < 1e-12);
        // A = c B: c in every direction.
        let b = Cov2 {
            xx: 4.0,
            xy: -1.0,
            yy: 0.5,
        };
        assert!((b.times(0.3).max_ratio(b) - 0.3).abs() < 1e-12);
        // A share of one direction only: diag(1, 0) against diag(4, 1) is 1/4.
        assert!((Cov2::diag(1.0, 0.0).max_ratio(Cov2::diag(2.0, 1.0)) - 0.25).abs() < 1e-12);
    }

    #[test]
    fn whitening_gives_the_mahalanobis_distance() {
        let s = Cov2 {
            xx: 4.0,
            xy: -1.8,
            yy: 1.0,
        };
        let r = [1.0, 0.5];
        let z = s.whiten(r).unwrap();
        // r' S^-1 r by the explicit inverse.
        let det = s.xx * s.yy - s.xy * s.xy;
        let m = (s.yy * r[0] * r[0] - 2.0 * s.xy * r[0] * r[1] + s.xx * r[1] * r[1]) / det;
        assert!((z[0] * z[0] + z[1] * z[1] - m).abs() < 1e-12);
        assert!((s.correlation() + 0.9).abs() < 1e-12);
        assert!(Cov2 {
            xx: 1.0,
            xy: 1.0,
            yy: 1.0
        }
        .whiten(r)
        .is_none());
    }
}
