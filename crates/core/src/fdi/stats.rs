//! The distributions the decision's limits come from, and `P x P` covariance algebra
//! (docs/fdi.md, "The window GLR and its limits").
//!
//! - The standard normal's tail, `erfc(z / sqrt 2) / 2`, with `erfc` from the Chebyshev
//!   expansion of Numerical Recipes (3rd ed., `Erf::erfccheb`). The chi-square's tail at any
//!   dof and Hotelling's `T^2(p, nu)` from `statrs`' regularised incomplete gamma and beta
//!   functions: 1 at or below 0 and for NaN; Hotelling's is the chi-square's at infinite `nu`
//!   and 1 when `nu <= p - 1`.
//! - Quantiles by bisection on the decreasing tails, to the f64 grain.
//! - [`Cov`], the covariance of the `P` parameter residuals (speed [m/s], displacement
//!   [fraction], ln gain): `whiten` gives `z = L^-1 r` (`L L' = Sigma`, so `|z|^2 = r' Sigma^-1
//!   r`), `solve` gives `Sigma^-1 r`; both `None` unless `Sigma` is finite and positive
//!   definite and the result finite.

use serde::{Deserialize, Serialize};

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

/// The parameter residual's dimension: speed [m/s], displacement [fraction of D], the ln of
/// the test's high-frequency gain `b^` (`crate::fdi::sensitivity::ln_gain`).
pub const P: usize = 3;

/// `P(chi2_dof > x)` for any `dof > 0` (the regularised upper incomplete gamma function,
/// `statrs`).
pub fn chi2_sf(x: f64, dof: f64) -> f64 {
    if x.is_nan() || x <= 0.0 {
        return 1.0;
    }
    if x.is_infinite() {
        return 0.0;
    }
    statrs::function::gamma::gamma_ur(0.5 * dof, 0.5 * x)
}

/// The `x` with `P(chi2_dof > x) = p`.
pub fn chi2_isf(p: f64, dof: f64) -> f64 {
    bisect(|x| chi2_sf(x, dof), p, 0.0, 10_000.0)
}

/// `P(T^2 > t)` for Hotelling's `T^2 (p, nu)` (a `p`-vector whitened by a covariance with
/// `nu` degrees of freedom): `T^2 nu^-1 (nu - p + 1) / p ~ F(p, nu - p + 1)`, whose tail is
/// the regularised incomplete beta function `I_{nu / (nu + t)}((nu - p + 1) / 2, p / 2)`.
/// For `p = 2` that is `(1 + t / nu)^(-(nu - 1) / 2)`.
pub fn hotelling_sf(t: f64, p: usize, nu: f64) -> f64 {
    let d2 = nu - p as f64 + 1.0;
    if t.is_nan() || t <= 0.0 {
        return 1.0;
    }
    if !nu.is_finite() {
        return chi2_sf(t, p as f64);
    }
    if d2 <= 0.0 {
        return 1.0;
    }
    statrs::function::beta::beta_reg(0.5 * d2, 0.5 * p as f64, nu / (nu + t))
}

/// The `t` with `P(T^2 (p, nu) > t) = alpha` (infinite when `nu <= p - 1`).
pub fn hotelling_isf(alpha: f64, p: usize, nu: f64) -> f64 {
    if nu <= p as f64 - 1.0 {
        return f64::INFINITY;
    }
    if !nu.is_finite() {
        return chi2_isf(alpha, p as f64);
    }
    bisect(|t| hotelling_sf(t, p, nu), alpha, 0.0, 1e12)
}

/// A symmetric `P x P` covariance of the parameter residual (its rows: speed [m/s],
/// displacement [fraction], ln gain).
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
#[serde(transparent)]
pub struct Cov(pub [[f64; P]; P]);

impl Cov {
    /// A diagonal covariance of standard deviations `s`.
    pub fn diag(s: [f64; P]) -> Self {
        Self(std::array::from_fn(|i| {
            std::array::from_fn(|j| if i == j { s[i] * s[i] } else { 0.0 })
        }))
    }

    /// Element `(i, j)`.
    pub fn at(&self, i: usize, j: usize) -> f64 {
        self.0[i][j]
    }

    /// The variances.
    pub fn variances(&self) -> [f64; P] {
        std::array::from_fn(|i| self.0[i][i])
    }

    /// `D Sigma D` for `D = diag(d)`.
    pub fn scaled(self, d: [f64; P]) -> Self {
        Self(std::array::from_fn(|i| {
            std::array::from_fn(|j| self.0[i][j] * d[i] * d[j])
        }))
    }

    /// `k Sigma`.
    pub fn times(self, k: f64) -> Self {
        Self(self.0.map(|r| r.map(|v| v * k)))
    }

    /// `Sigma + other`.
    pub fn plus(self, o: Self) -> Self {
        Self(std::array::from_fn(|i| {
            std::array::from_fn(|j| self.0[i][j] + o.0[i][j])
        }))
    }

    /// The correlation of components `i` and `j` (0 when a variance is 0).
    pub fn correlation(self, i: usize, j: usize) -> f64 {
        let d = (self.0[i][i] * self.0[j][j]).sqrt();
        if d > 0.0 {
            self.0[i][j] / d
        } else {
            0.0
        }
    }

    /// Every element finite.
    pub fn is_finite(&self) -> bool {
        self.0.iter().flatten().all(|v| v.is_finite())
    }

    /// The first `dim` components' covariance, the others independent with variance `fill`
    /// (1 for a residual measured in fewer components, its missing ones 0; 0 for a part of
    /// its covariance).
    pub fn leading(self, dim: usize, fill: f64) -> Self {
        Self(std::array::from_fn(|i| {
            std::array::from_fn(|j| match (i < dim && j < dim, i == j) {
                (true, _) => self.0[i][j],
                (false, true) => fill,
                (false, false) => 0.0,
            })
        }))
    }

    fn matrix(&self) -> nalgebra::SMatrix<f64, P, P> {
        nalgebra::SMatrix::<f64, P, P>::from_fn(|i, j| self.0[i][j])
    }

    /// The largest `lambda` with `det(self - lambda other) = 0`: the largest share of
    /// `other`'s variance, in any direction, that `self` accounts for (0 when `other` is
    /// not positive definite).
    pub fn max_ratio(self, other: Self) -> f64 {
        let Some(l) = other.matrix().cholesky() else {
            return 0.0;
        };
        let Some(li) = l.l().try_inverse() else {
            return 0.0;
        };
        let m = li * self.matrix() * li.transpose();
        let m = (m + m.transpose()) * 0.5;
        let top = m.symmetric_eigenvalues().max();
        if top.is_finite() {
            top.max(0.0)
        } else {
            0.0
        }
    }

    /// `L^-1 r` with `L` the lower Cholesky factor (`None` unless positive definite).
    pub fn whiten(self, r: [f64; P]) -> Option<[f64; P]> {
        if !self.is_finite() {
            return None;
        }
        let l = self.matrix().cholesky()?;
        let z = l
            .l()
            .solve_lower_triangular(&nalgebra::SVector::<f64, P>::from(r))?;
        let z: [f64; P] = z.into();
        z.iter().all(|v| v.is_finite()).then_some(z)
    }

    /// `Sigma^-1 r` (`None` unless positive definite).
    pub fn solve(self, r: [f64; P]) -> Option<[f64; P]> {
        if !self.is_finite() {
            return None;
        }
        let y = self
            .matrix()
            .cholesky()?
            .solve(&nalgebra::SVector::<f64, P>::from(r));
        let y: [f64; P] = y.into();
        y.iter().all(|v| v.is_finite()).then_some(y)
    }

    /// `a' Sigma b`.
    pub fn form(&self, a: [f64; P], b: [f64; P]) -> f64 {
        (0..P)
            .flat_map(|i| (0..P).map(move |j| (i, j)))
            .map(|(i, j)| a[i] * self.0[i][j] * b[j])
            .sum()
    }
}

/// `a . b`.
pub fn dot(a: [f64; P], b: [f64; P]) -> f64 {
    a.iter().zip(&b).map(|(x, y)| x * y).sum()
}

/// `v / |v|` (0 stays 0).
pub fn unit(v: [f64; P]) -> [f64; P] {
    let n = dot(v, v).sqrt();
    if n > 0.0 && n.is_finite() {
        v.map(|x| x / n)
    } else {
        [0.0; P]
    }
}

/// The median of `v` (NaN when empty).
pub fn median(v: &mut [f64]) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `P(chi2_dof > x)` for an even `dof >= 2`.
    fn chi2_sf_even(x: f64, dof: usize) -> f64 {
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
    fn chi2_isf_even(p: f64, dof: usize) -> f64 {
        bisect(|x| chi2_sf_even(x, dof), p, 0.0, 10_000.0)
    }

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
    fn general_chi2_and_hotelling_tails_match_exact_forms() {
        // Even dof: the exact finite sum; odd: chi2_3 at 5 % is 7.8147 (tables), at 0.1 %
        // 16.2662.
        for (x, dof) in [(13.8155, 2usize), (18.4668, 4), (40.0, 6)] {
            let (a, b) = (chi2_sf(x, dof as f64), chi2_sf_even(x, dof));
            assert!((a / b - 1.0).abs() < 1e-9, "{x} {dof}: {a} vs {b}");
        }
        assert!((chi2_isf(0.05, 3.0) - 7.8147).abs() < 2e-4);
        assert!((chi2_isf(1e-3, 3.0) - 16.2662).abs() < 2e-4);
        // Hotelling p = 2: (1 + t / nu)^(-(nu - 1) / 2).
        for (t, nu) in [(5.0f64, 6.0f64), (30.0, 4.5), (80.0, 40.0)] {
            let want = (1.0 + t / nu).powf(-(nu - 1.0) / 2.0);
            let got = hotelling_sf(t, 2, nu);
            assert!((got / want - 1.0).abs() < 1e-9, "{t} {nu}: {got} vs {want}");
        }
        // p = 1: T^2 is a squared Student t: t_5 two-sided 1 % is 4.0321.
        assert!((hotelling_isf(0.01, 1, 5.0) - 4.0321f64.powi(2)).abs() < 1e-3);
        // p = 3, nu = 10: 3 nu / (nu - 2) F(3, 8); F(3, 8) at 5 % is 4.0662.
        assert!((hotelling_isf(0.05, 3, 10.0) - 3.75 * 4.0662).abs() < 2e-3);
        // To the chi-square as nu grows.
        let c = chi2_isf(1e-4, 3.0);
        assert!((hotelling_isf(1e-4, 3, 1e8) - c).abs() < 1e-3 * c);
    }

    fn cov(m: [[f64; 3]; 3]) -> Cov {
        Cov(m)
    }

    #[test]
    fn max_ratio_is_the_largest_generalised_eigenvalue() {
        // B = I: the eigenvalues of A itself; [[3, 1], [1, 2]] beside 1: (5 + sqrt 5) / 2.
        let a = cov([[3.0, 1.0, 0.0], [1.0, 2.0, 0.0], [0.0, 0.0, 1.0]]);
        let id = Cov::diag([1.0; 3]);
        assert!((a.max_ratio(id) - (5.0 + 5f64.sqrt()) / 2.0).abs() < 1e-12);
        // A = c B: c in every direction.
        let b = cov([[4.0, -1.0, 0.3], [-1.0, 0.5, 0.1], [0.3, 0.1, 2.0]]);
        assert!((b.times(0.3).max_ratio(b) - 0.3).abs() < 1e-12);
        // A share of one direction only: diag(1, 0, 0) against diag(4, 1, 1) is 1/4.
        let one = Cov::diag([1.0, 0.0, 0.0]);
        assert!((one.max_ratio(Cov::diag([2.0, 1.0, 1.0])) - 0.25).abs() < 1e-12);
    }

    #[test]
    fn whitening_gives_the_mahalanobis_distance() {
        let s = cov([[4.0, -1.8, 0.5], [-1.8, 1.0, -0.2], [0.5, -0.2, 0.7]]);
        let r = [1.0, 0.5, -0.3];
        let z = s.whiten(r).unwrap();
        // r' S^-1 r by the explicit inverse (nalgebra's LU, not the Cholesky factor).
        let m = nalgebra::Matrix3::from_fn(|i, j| s.0[i][j]);
        let inv = m.try_inverse().unwrap();
        let rv = nalgebra::Vector3::from(r);
        let want = (rv.transpose() * inv * rv)[(0, 0)];
        assert!((dot(z, z) - want).abs() < 1e-12);
        let y = s.solve(r).unwrap();
        assert!((dot(r, y) - want).abs() < 1e-12);
        assert!((s.correlation(0, 1) + 0.9).abs() < 1e-12);
        assert!(cov([[1.0, 1.0, 0.0], [1.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
            .whiten(r)
            .is_none());
        // The leading block: the third component independent, unit.
        let l = s.leading(2, 1.0);
        assert_eq!((l.at(2, 2), l.at(0, 2), l.at(1, 1)), (1.0, 0.0, 1.0));
    }
}
