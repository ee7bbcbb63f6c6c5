//! The commissioning sample's change-point test (docs/fdi.md, "Commissioning"): a fault that
//! arises during commissioning splits the sample in two (one present from its first test
//! does not: only the wide limits see it).
//!
//! For every split `k` of a method's sample the difference `d` of the segments' mean
//! residuals, less the operating point's move along their common slopes (prior: the physical
//! slopes, updated by the points' own spread), is judged against its healthy covariance:
//!
//! ```text
//! C_k = (S_r / nu + F) (1/k + 1/(n - k)) + Psi,    T_k = d' C_k^-1 d
//! ```
//!
//! `S_r` the scatter about the segments' fits, `nu = n - 2` less the slopes' effective number
//! (at least 1), `F` the floors, `Psi` the slopes' error and the sea prior's allowance. Two
//! looks, `(e_u, e_D)` and `e_b` alone, each at Hotelling's tail for the dof its learned share
//! leaves (the share at its `BOUND` upper bound, `measured::effective_dof`); a split's tail is
//! the smaller doubled, in `[0, 1]`. At each moment between two of the vessel's tests the
//! methods it splits combine tails by Fisher's rule, healthy `-2 sum_m ln p_m ~ chi2(2 M)`.
//!
//! [`check`] runs when a method completes its sample; [`confirm`] at each test it learns while
//! its sample holds at most twice its commissioning tests and nothing was forgotten (only
//! moments inside a commissioning split it; only learned tests in its sea join). The moment
//! of smallest combined tail, if under `Settings::change_alpha` (`confirm_alpha`), makes each
//! method it splits `Phase::Inconsistent`. A method with fewer than [`MIN_TESTS`] tests, or
//! fewer than [`MIN_CHANGED`] after the moment, is not split.
use super::envelope::{same_sea, sea_step};
use super::measured::{bound_factor, effective_dof};
use super::point::{Regression as Envelope, Sample};
use super::reference::{MethodReference, Phase, Settings, MIN_TESTS};
use super::stats::{chi2_sf, dot, hotelling_sf, Cov, P};
use nalgebra::{Matrix3, Vector3};

/// The confidence level of the upper bound on the scatter's share of a look
/// (`measured::effective_dof`): at 99 % a one-dof look's exact size stays within its budget
/// at every `nu >= 4` and every share (the unit test
/// `a_one_dof_look_keeps_its_budget_whatever_the_known_share`).
const BOUND: f64 = 0.99;

/// The fewest tests of a method after the moment for its split to count. One test alone
/// against the others is a single test's look, the decision's: a change at a sample's last
/// test moves the reference by `1/n` of itself, and every later test is judged against it.
pub const MIN_CHANGED: usize = 2;

/// The vessel's change-point test when method `i` has completed its commissioning sample:
/// [`joint_change_point`] over its sample and the other method's (still gathering, or
/// completed or found inconsistent from tests that overlap `i`'s in time: its commissioning
/// tests only); each method whose sample the change splits is declared inconsistent (its
/// reference, just completed or completed during `i`'s commissioning, is not used; one
/// already inconsistent keeps its verdict).
pub fn check(c: &mut [MethodReference; 2], i: usize, s: &Settings) -> Option<Change> {
    let first = c[i].samples.first().map_or(0, |x| x.order);
    let samples: [&[Sample]; 2] = std::array::from_fn(|m| {
        let x = &c[m];
        let gathered = commissioning_tests(x);
        match x.phase {
            Phase::Commissioning => &x.samples[..],
            _ if gathered.last().is_some_and(|l| l.order > first) => gathered,
            _ => &[],
        }
    });
    let all = samples.map(<[Sample]>::len);
    let change = joint_change_point(samples, all, &s.envelope, s.floors(), s.change_alpha)?;
    Some(mark(c, change))
}

/// The confirmation (module doc): when method `i` has learned a test after its
/// commissioning of `k <= K` tests and its sample holds at most `2 k` (nothing forgotten),
/// the joint test again over the methods' samples as they are now (each commissioned
/// method's first twice its commissioning tests, a gathering one's all, an inconsistent
/// one's commissioning tests): a change the commissioning's few tests could not prove,
/// proven as the tests after it add their dof.
pub fn confirm(c: &mut [MethodReference; 2], i: usize, s: &Settings) -> Option<Change> {
    let x = &c[i];
    let n = x.samples.len();
    let k = x.tests as usize;
    if x.phase != Phase::Learning || !intact(x) || n <= k || n > 2 * k {
        return None;
    }
    let owned: [Vec<Sample>; 2] = std::array::from_fn(|m| {
        let x = &c[m];
        match x.phase {
            Phase::Commissioning => x.samples.clone(),
            Phase::Learning if intact(x) => confirmation_sample(x, &s.envelope),
            _ => commissioning_tests(x).to_vec(),
        }
    });
    let samples = owned.each_ref().map(Vec::as_slice);
    // The moments inside each method's commissioning: the tests it learned after only add
    // to the changed segment (a change among them is the decision's).
    let within: [usize; 2] = std::array::from_fn(|m| match c[m].phase {
        Phase::Learning => (c[m].tests as usize).min(samples[m].len()),
        _ => samples[m].len(),
    });
    let change = joint_change_point(samples, within, &s.envelope, s.floors(), s.confirm_alpha)?;
    Some(mark(c, change))
}

/// A commissioned method's confirmation sample: its commissioning tests, then those of the
/// tests it learned after (its first `2 k` in all) that are in the commissioning's sea
/// (`envelope::same_sea` of its tests' mean `w`). The test is over one sea (`Point::x3`):
/// a test in another sea is another operating point, its offset and scatter the
/// reference's to learn (`envelope::local_shape`), not a change of health.
fn confirmation_sample(x: &MethodReference, env: &Envelope) -> Vec<Sample> {
    let upto = x.samples.len().min(2 * x.tests as usize);
    let (head, tail) = x.samples[..upto].split_at((x.tests as usize).min(upto));
    let ws: Vec<f64> = head
        .iter()
        .map(|t| t.x(env)[3])
        .filter(|w| w.is_finite())
        .collect();
    let sea = (!ws.is_empty()).then(|| ws.iter().sum::<f64>() / ws.len() as f64);
    let here = |t: &&Sample| sea.is_none_or(|m| same_sea(env, t.x(env)[3], m));
    head.iter()
        .chain(tail.iter().filter(here))
        .copied()
        .collect()
}

/// `x`'s confirmation still runs: commissioned, nothing forgotten, and its sample short of
/// twice its commissioning tests (the confirmation's last evaluation is at `2 k`).
pub fn confirming(x: &MethodReference) -> bool {
    x.phase == Phase::Learning && intact(x) && x.samples.len() < 2 * x.tests as usize
}

/// Nothing forgotten (`reference::MEMORY_TESTS`): the commissioning tests come first.
fn intact(x: &MethodReference) -> bool {
    x.samples.len() == (x.tests + x.learned) as usize
}

/// A method's commissioning tests while it has forgotten none; else none.
fn commissioning_tests(x: &MethodReference) -> &[Sample] {
    if intact(x) {
        x.samples.get(..x.tests as usize).unwrap_or(&[])
    } else {
        &[]
    }
}

/// Each method whose sample `change` splits is declared inconsistent (one already
/// inconsistent keeps its verdict).
fn mark(c: &mut [MethodReference; 2], change: Change) -> Change {
    for (x, k) in c.iter_mut().zip(change.splits) {
        if let (Some(k), false) = (k, matches!(x.phase, Phase::Inconsistent { .. })) {
            x.phase = Phase::Inconsistent {
                at: k as u32 + 1,
                statistic: change.tail,
            };
        }
    }
    change
}

/// A change the joint test found.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Change {
    /// Per method, the split of its sample (`Some(k)`: the change at its test `k + 1`), or
    /// `None` when the moment does not split it.
    pub splits: [Option<usize>; 2],
    /// The combined tail probability (Fisher's rule over the split methods).
    pub tail: f64,
}

/// The vessel's change point over its methods' commissioning samples (each in the order
/// of its tests, `Sample::order` the vessel's test number): for every moment between two of
/// the vessel's tests, the methods whose sample it splits (with at least [`MIN_TESTS`]
/// tests) inside its commissioning (at least one of its first `within[m]` tests after the
/// moment, and at least [`MIN_CHANGED`] of its tests after it) combine their split's tail
/// probabilities ([`split_tails`]) by Fisher's rule, `X = -2 sum_m ln p_m ~ chi2(2 M)` under
/// a healthy sample (the methods' tests are independent); the moment whose combined tail is
/// the smallest, if under `alpha`.
pub fn joint_change_point(
    samples: [&[Sample]; 2],
    within: [usize; 2],
    env: &Envelope,
    floors: [f64; P],
    alpha: f64,
) -> Option<Change> {
    let tails = samples.map(|s| split_tails(s, env, floors));
    let mut moments: Vec<u64> = samples
        .iter()
        .zip(&tails)
        .filter(|(_, t)| !t.is_empty())
        .flat_map(|(s, _)| s.iter().map(|x| x.order))
        .collect();
    moments.sort_unstable();
    moments.dedup();
    let mut best: Option<(Change, f64)> = None;
    for t in moments {
        let mut splits = [None; 2];
        let (mut x, mut dof) = (0.0, 0.0);
        for m in 0..2 {
            let k = samples[m].iter().filter(|s| s.order < t).count();
            let changed = samples[m].len().saturating_sub(k);
            if let Some(p) = tails[m]
                .get(k)
                .filter(|_| k >= 1 && k < within[m] && changed >= MIN_CHANGED)
            {
                splits[m] = Some(k);
                x -= 2.0 * p.max(f64::MIN_POSITIVE).ln();
                dof += 2.0;
            }
        }
        if dof == 0.0 {
            continue;
        }
        let tail = chi2_sf(x, dof);
        // Equal tails (both under the smallest double): the larger evidence per method.
        let better = best.is_none_or(|(b, bx)| {
            tail.total_cmp(&b.tail)
                .then_with(|| bx.total_cmp(&(x / dof)))
                .is_lt()
        });
        if tail < alpha && better {
            best = Some((Change { splits, tail }, x / dof));
        }
    }
    best.map(|(c, _)| c)
}

/// Each split's tail probability of one method's sample: `p[k]` for the change at its test
/// `k + 1` (`k` in `1..n`; `p[0] = 1`), the smaller of its two looks' tails doubled
/// (Bonferroni); empty with fewer than [`MIN_TESTS`] tests.
pub fn split_tails(samples: &[Sample], env: &Envelope, floors: [f64; P]) -> Vec<f64> {
    let n = samples.len();
    if n < MIN_TESTS {
        return Vec::new();
    }
    let nu = (n - 2) as f64;
    // Prefix sums of e, e e' and the operating point: every split in O(1).
    let mut pre = vec![Sums::default(); n + 1];
    for (i, s) in samples.iter().enumerate() {
        pre[i + 1] = pre[i].plus(s, env);
    }
    let total = pre[n];
    let mut tails = vec![1.0; n];
    for (k, &a) in pre.iter().enumerate().take(n).skip(1) {
        let b = total.minus(&a);
        let (ma, xa) = a.means();
        let (mb, xb) = b.means();
        let sp = a.scatter().plus(b.scatter());
        let f = 1.0 / k as f64 + 1.0 / (n - k) as f64;
        let (du, dl, dg) = (xb[0] - xa[0], xb[1] - xa[1], xb[2] - xa[2]);
        // The physical move between the segments' points (the slope priors' means): the
        // similarity law's in speed, `b` scaling by `1 / D` in declared loading, along the
        // trapezoid of the two segments' mean slopes (the law bends: `envelope`).
        let ends = |sa: [f64; P], sb: [f64; P]| -> [f64; P] {
            std::array::from_fn(|i| 0.5 * (sa[i] / a.n.max(1.0) + sb[i] / b.n.max(1.0)))
        };
        let slope = ends(a.slope, b.slope);
        let lslope = ends(a.lslope, b.lslope);
        // The slopes common to both segments (`common_slopes`), from the prior and the
        // segments' own spread of operating points; the scatter is taken about them, with
        // the dof the fitted slopes use (`h`, 0 without a spread). Two passes: the first
        // with the scatter about the segments' means (which counts a slope's move as noise).
        let dx = Vector3::new(du, dl, dg);
        let within = a.point_scatter() + b.point_scatter();
        let cross: [Vector3<f64>; P] = std::array::from_fn(|j| a.point_cross(j) + b.point_cross(j));
        let fit_at = |per: Cov| {
            let noise = per.variances();
            let slopes: [_; P] = std::array::from_fn(|j| {
                let prior_mean = Vector3::new(slope[j], lslope[j], 0.0);
                let v = noise[j] + floors[j] * floors[j];
                common_slopes(env, j, prior_mean, v, within, cross[j])
            });
            CommonSlopes::fitted(sp, nu, within, &cross, slopes)
        };
        let fit = fit_at(fit_at(sp.times(1.0 / nu)).per);
        let (nu, per) = (fit.nu, fit.per);
        let m = bound_factor(nu, BOUND);
        let d: [f64; P] = std::array::from_fn(|j| mb[j] - ma[j] - fit.beta[j].0.dot(&dx));
        // The sea: another sea is another operating point (`Point::x`'s `w`), whose offset
        // the reference's sea prior lets move by `tau_w` per unit of `w` beyond half a
        // bandwidth (`envelope::sea_step`), about no mean (the networks' bias per sea is
        // the hull's). Within one sea (segments' mean `w` within a quarter of each other)
        // it adds nothing.
        let dw = match (a.sea(), b.sea()) {
            (Some(wa), Some(wb)) => sea_step(env, wb - wa),
            _ => 0.0,
        };
        let psi: [f64; P] = std::array::from_fn(|j| {
            let tau_w = env.slope_sea[j.min(1)] * dw;
            dx.dot(&(fit.beta[j].1 * dx)).max(0.0) + tau_w * tau_w
        });
        // The learned part (the scatter, estimated with `nu` dof) and the known ones (the
        // floors, the slopes' share).
        let learned = per.times(f);
        let c = learned
            .plus(Cov::diag(floors).times(f))
            .plus(Cov::diag(psi.map(f64::sqrt)));
        // Two looks: the networks' pair (e_u, e_D), and the gain e_b alone (one dof: at the
        // few tests of a commissioning, Hotelling's tail in three dimensions would cost the
        // gain's evidence more than it adds). Each at the dof its learned share leaves
        // (`measured::effective_dof`, the share at its upper bound).
        let pair = {
            let (c2, l2) = (c.leading(2, 1.0), learned.leading(2, 0.0));
            let d2 = [d[0], d[1], 0.0];
            c2.solve(d2).map(|y| {
                let t = dot(d2, y);
                hotelling_sf(t, 2, effective_dof(t, l2.form(y, y), nu, m))
            })
        };
        let cb = c.at(2, 2);
        let gain = (cb > 0.0 && d[2].is_finite()).then(|| {
            let t = d[2] * d[2] / cb;
            let a = learned.at(2, 2) * t / cb;
            hotelling_sf(t, 1, effective_dof(t, a, nu, m))
        });
        let least = [pair, gain].into_iter().flatten().fold(1.0, f64::min);
        tails[k] = (2.0 * least).min(1.0);
    }
    tails
}

/// A split's common slopes and the scatter about them.
struct CommonSlopes {
    /// Per component, the slopes' posterior mean and covariance.
    beta: [(Vector3<f64>, Matrix3<f64>); P],
    /// The scatter about the segments' fits per test, `S_r / nu`, and its dof.
    per: Cov,
    nu: f64,
}

impl CommonSlopes {
    /// The scatter about the fitted slopes, `S_r = S_p - b_j' c_k - c_j' b_k + b_j' W b_k`
    /// (`W` the points' scatter, `c` their cross-products with the components), over `nu`
    /// less the slopes' effective number, `h = max_j tr(W A_j^-1) / s_j^2` (at most one
    /// dof per slope; at least one dof is left).
    fn fitted(
        sp: Cov,
        nu: f64,
        w: Matrix3<f64>,
        cross: &[Vector3<f64>; P],
        beta: [(Vector3<f64>, Matrix3<f64>, f64); P],
    ) -> Self {
        let b: [Vector3<f64>; P] = beta.map(|x| x.0);
        let sr = Cov(std::array::from_fn(|j| {
            std::array::from_fn(|k| {
                let v =
                    sp.at(j, k) - b[j].dot(&cross[k]) - b[k].dot(&cross[j]) + b[j].dot(&(w * b[k]));
                if j == k {
                    v.max(0.0)
                } else {
                    v
                }
            })
        }));
        let h = beta
            .iter()
            .map(|x| (w * x.1).trace() / x.2)
            .filter(|v| v.is_finite())
            .fold(0.0, f64::max)
            .clamp(0.0, 3.0);
        let nu = (nu - h).max(1.0);
        Self {
            beta: beta.map(|x| (x.0, x.1)),
            per: sr.times(1.0 / nu),
            nu,
        }
    }
}

/// Component `j`'s slopes in the operating point `(u, ln D, ln s)` common to a split's two
/// segments: the Gaussian prior (mean `prior_mean`, the physical slopes; standard deviations
/// `calibration.slope-*`) updated by the segments' own spread of points about their means
/// (`within`, and `cross` their cross-products with the component), each test's noise
/// `noise` (the scatter's variance and the floor's): `A = P0 + W / s2`, `beta = A^-1 (P0
/// beta_0 + c / s2)`. Returns the posterior mean and covariance, and the noise (infinite
/// where the prior is returned as it is). Without a spread (every test at one point, or one
/// point per segment) it is the prior.
fn common_slopes(
    env: &Envelope,
    j: usize,
    prior_mean: Vector3<f64>,
    noise: f64,
    within: Matrix3<f64>,
    cross: Vector3<f64>,
) -> (Vector3<f64>, Matrix3<f64>, f64) {
    let i = j.min(1);
    let tau = [
        env.speed_sd(j),
        env.slope_loading[i],
        env.slope_excitation[i],
    ];
    let p0 = Matrix3::from_diagonal(&Vector3::from(tau.map(|t| 1.0 / t.max(1e-12).powi(2))));
    let prior = (
        prior_mean,
        Matrix3::from_diagonal(&Vector3::from(tau.map(|t| t * t))),
        f64::INFINITY,
    );
    if !(noise > 0.0
        && noise.is_finite()
        && within.iter().chain(cross.iter()).all(|v| v.is_finite()))
    {
        return prior;
    }
    let a = p0 + within / noise;
    match a.try_inverse() {
        Some(inv) => (inv * (p0 * prior_mean + cross / noise), inv, noise),
        None => prior,
    }
}

/// Sums over a run of samples: count, `e`, `e e'`, `(u, ln D, ln s)`, the similarity
/// slopes (a component that is not finite counting as 0).
#[derive(Debug, Clone, Copy, Default)]
struct Sums {
    n: f64,
    e: [f64; P],
    ee: [[f64; P]; P],
    x: [f64; 3],
    slope: [f64; P],
    lslope: [f64; P],
    /// `sum x x'` and `sum x e_j` (`x` the operating point).
    xx: [[f64; 3]; 3],
    xe: [[f64; P]; 3],
    /// `sum w` and the count of tests with a sea index (`w` finite).
    w: f64,
    nw: f64,
}

impl Sums {
    fn plus(self, s: &Sample, env: &Envelope) -> Self {
        let finite = |x: f64| if x.is_finite() { x } else { 0.0 };
        let [u, l, g, w] = s.x(env);
        let x = [u, l, g];
        let (w, nw) = if w.is_finite() { (w, 1.0) } else { (0.0, 0.0) };
        Self {
            n: self.n + 1.0,
            e: std::array::from_fn(|i| self.e[i] + s.e[i]),
            ee: std::array::from_fn(|i| std::array::from_fn(|j| self.ee[i][j] + s.e[i] * s.e[j])),
            x: std::array::from_fn(|i| self.x[i] + x[i]),
            slope: std::array::from_fn(|i| self.slope[i] + finite(s.speed_slope[i])),
            lslope: std::array::from_fn(|i| self.lslope[i] + finite(s.loading_slope[i])),
            xx: std::array::from_fn(|i| std::array::from_fn(|j| self.xx[i][j] + x[i] * x[j])),
            xe: std::array::from_fn(|i| std::array::from_fn(|j| self.xe[i][j] + x[i] * s.e[j])),
            w: self.w + w,
            nw: self.nw + nw,
        }
    }

    fn minus(self, o: &Self) -> Self {
        Self {
            n: self.n - o.n,
            e: std::array::from_fn(|i| self.e[i] - o.e[i]),
            ee: std::array::from_fn(|i| std::array::from_fn(|j| self.ee[i][j] - o.ee[i][j])),
            x: std::array::from_fn(|i| self.x[i] - o.x[i]),
            slope: std::array::from_fn(|i| self.slope[i] - o.slope[i]),
            lslope: std::array::from_fn(|i| self.lslope[i] - o.lslope[i]),
            xx: std::array::from_fn(|i| std::array::from_fn(|j| self.xx[i][j] - o.xx[i][j])),
            xe: std::array::from_fn(|i| std::array::from_fn(|j| self.xe[i][j] - o.xe[i][j])),
            w: self.w - o.w,
            nw: self.nw - o.nw,
        }
    }

    /// The mean sea `w` of the tests with a sea index (`None`: none has one).
    fn sea(&self) -> Option<f64> {
        (self.nw > 0.5).then(|| self.w / self.nw)
    }

    /// Mean residual and mean operating point.
    fn means(&self) -> ([f64; P], [f64; 3]) {
        let n = self.n.max(1.0);
        (self.e.map(|v| v / n), self.x.map(|v| v / n))
    }

    /// The operating points' scatter about their mean, `sum (x - m_x)(x - m_x)'`.
    fn point_scatter(&self) -> Matrix3<f64> {
        let (_, m) = self.means();
        Matrix3::from_fn(|i, j| self.xx[i][j] - self.n * m[i] * m[j])
    }

    /// The operating points' cross-products with component `j` about the means,
    /// `sum (x - m_x)(e_j - m_j)`.
    fn point_cross(&self, j: usize) -> Vector3<f64> {
        let (e, m) = self.means();
        Vector3::from_fn(|i, _| self.xe[i][j] - self.n * m[i] * e[j])
    }

    /// The scatter about the mean, `sum (e - m)(e - m)'`.
    fn scatter(&self) -> Cov {
        let (m, _) = self.means();
        Cov(std::array::from_fn(|i| {
            std::array::from_fn(|j| {
                let v = self.ee[i][j] - self.n * m[i] * m[j];
                if i == j {
                    v.max(0.0)
                } else {
                    v
                }
            })
        }))
    }
}

#[cfg(test)]
#[path = "changepoint_tests.rs"]
mod tests;
