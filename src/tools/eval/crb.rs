//! `eval --crb`: how close one test's estimate comes to the Cramer-Rao bound of its features.
//!
//! ## Model
//!
//! At the ship's operating point `theta = (u [m/s], D [t])` one test of method `m` gives the
//! features its speed network reads (`f`: CLFRT `ln |G|` and `arg G` at each tone; HBT
//! `ln omega_u`, `ln A`, `period_cv`, `ln |G(j omega_u)|`, `arg G(j omega_u)`), taken as
//! Gaussian about their mean:
//!
//! ```text
//! f ~ N(mu(theta), Sigma_f)          I = J' Sigma_f^-1 J,   J = d mu / d theta
//! sd(u^) >= sqrt((I^-1)_uu)          the speed, D unknown (the speed network)
//! sd(D^) >= 1 / sqrt(I_DD)           the displacement, u given (the displacement network
//!                                    reads the speed log)
//! ```
//!
//! (Cramer-Rao, for any unbiased estimator from `f`; the information of `Sigma_f`'s own
//! dependence on `theta` is left out, so the bound is that of a mean-shift reading.)
//!
//! `mu`, `J` and `Sigma_f` come from the simulated ship in its sea, under its autopilot and
//! sensors, through the same monitor core as the daemon: `R` seeded tests at `theta` give
//! `Sigma_f` (sample covariance, its inverse scaled by `(R - p - 2) / (R - 1)` so that it is
//! unbiased, `p` features); `R` more at `theta +- h_k e_k` with the same seeds give `J` by
//! central differences (common random numbers: the sea and the sensors' noise cancel in the
//! difference). The networks' spread is the standard deviation of their estimates over the
//! `R` tests at `theta`. The networks are biased on a hull they were not trained on (they
//! may barely follow `u`): the bound for an estimator of their own sensitivity
//! `g = d E[theta^] / d theta` (the same differences of their estimates) is
//! `sqrt(g' I^-1 g)` (for the displacement, the speed given, `|g_D| / sqrt(I_DD)`). Ratio =
//! spread / that bound: 1 is efficient; well above 1 says the features hold more than the
//! networks read (a shorter test could do).
//!
//! `tests::the_features_slopes_are_the_nomoto_ships` checks `J` against the analytic
//! derivative of the first-order ship's `G(j w) = b / (j w (j w + a))`.

use crate::config::Config;
use crate::tools::training::database::par_map;
use helmwatch_core::drivers::probe::{run_probe, ProbeOptions};
use helmwatch_core::estimator::features::{extract_into, speed_inputs, Feature};
use helmwatch_core::estimator::Estimator;
use helmwatch_core::model::SeaState;
use helmwatch_core::monitor::Monitor;
use helmwatch_core::sim::Scenario;
use helmwatch_core::wire::{Method, Outcome, Report};
use nalgebra::{DMatrix, DVector, Matrix2};
use std::fmt::Write as _;
use std::sync::Arc;

/// Step of the speed in the central differences [m/s].
pub const H_SPEED_MPS: f64 = 0.3;
/// Step of the displacement, as a fraction of it.
pub const H_DISPLACEMENT: f64 = 0.05;

/// One method and sea: the bound and the networks' spread.
#[derive(Debug, Clone, PartialEq)]
pub struct Bound {
    /// The method.
    pub method: Method,
    /// The sea.
    pub sea: SeaState,
    /// Tests at `theta` that completed (of `R`), and the features read.
    pub tests: usize,
    /// The features' names.
    pub features: Vec<String>,
    /// `J`: per feature, `d mu / d u` [per m/s] and `d mu / d D` [per t].
    pub jacobian: Vec<[f64; 2]>,
    /// The bound on the speed's standard deviation, D unknown [m/s].
    pub speed_mps: f64,
    /// The bound on the displacement's standard deviation, the speed given [t].
    pub displacement_t: f64,
    /// The networks' spread: speed [m/s] and displacement [t] (NaN without an estimator).
    pub spread: [f64; 2],
    /// The networks' sensitivity: `d E[u^] / d u` and `d E[D^] / d D` (1: unbiased to first
    /// order).
    pub sensitivity: [f64; 2],
    /// The bound for an estimator of the networks' own sensitivity `g = d E[.] / d theta`
    /// (`sqrt(g' I^-1 g)`; for the displacement, the speed given, `|g_D| / sqrt(I_DD)`):
    /// speed [m/s], displacement [t]. A biased reader can beat the unbiased bound; not this.
    pub biased: [f64; 2],
}

/// What the bound needs: the configuration, the operating point, the tests per point.
#[derive(Debug, Clone)]
pub struct CrbOptions {
    /// Seeded tests per point (`R`).
    pub tests: usize,
    /// The first seed.
    pub seed: u64,
    /// Worker threads.
    pub threads: usize,
    /// Also every member of the family of real ships (but the first-order ship), whose name
    /// contains `member` when given.
    pub family: bool,
    /// With `family`: only members whose name contains this.
    pub member: Option<String>,
}

/// The features of `inputs` a completed report holds, with its estimate (`None`: not
/// completed, or a feature missing).
fn read(inputs: &[Feature], r: &Report) -> Option<(Vec<f64>, Option<[f64; 2]>)> {
    if r.outcome != Outcome::Completed {
        return None;
    }
    let mut x = Vec::new();
    extract_into(inputs, &r.features, &mut x).ok()?;
    Some((x, r.estimate.map(|e| [e.speed_mps, e.displacement_t])))
}

/// The bound for `method` in `sea` at the configuration's nominal point.
pub fn bound(cfg: &Config, method: Method, sea: SeaState, o: &CrbOptions) -> Option<Bound> {
    let core = cfg.core();
    let sim = cfg.sim();
    let estimator: Option<Arc<Estimator>> = Estimator::from_config(&core).ok().flatten();
    let mut opts = ProbeOptions::new(&core, method);
    opts.estimator = estimator;
    opts.multisine = Monitor::design_multisine(&core).ok();
    let n_tones = opts.multisine.as_ref().map_or(3, |m| m.omegas().len());
    let inputs = speed_inputs(method, n_tones);
    let (u0, d0) = (sim.ship.nominal_speed_mps, sim.ship.nominal_displacement_t);
    let (hu, hd) = (H_SPEED_MPS, H_DISPLACEMENT * d0);
    // Points: theta, then u -+ hu, then D -+ hd.
    let points = [
        (u0, d0),
        (u0 - hu, d0),
        (u0 + hu, d0),
        (u0, d0 - hd),
        (u0, d0 + hd),
    ];
    let jobs: Vec<(usize, u64)> = (0..points.len())
        .flat_map(|p| (0..o.tests as u64).map(move |k| (p, k)))
        .collect();
    let reports = par_map(jobs.len(), o.threads, |j| {
        let (p, k) = jobs[j];
        let mut sc = Scenario::nominal(&sim, o.seed.wrapping_add(k));
        (sc.speed_mps, sc.displacement_t) = points[p];
        sc.sea = sea;
        run_probe(&core, &sim, &sc, &opts)
            .ok()
            .and_then(|r| read(&inputs, &r.report))
    });
    let at = |p: usize| &reports[p * o.tests..(p + 1) * o.tests];
    // Seeds complete at every point (for the differences) and at theta (for the rest).
    let centre: Vec<&(Vec<f64>, Option<[f64; 2]>)> = at(0).iter().flatten().collect();
    let pn = inputs.len();
    if centre.len() < pn + 4 {
        return None;
    }
    let mean = |rows: &[&Vec<f64>]| {
        let n = rows.len() as f64;
        DVector::from_fn(pn, |i, _| rows.iter().map(|r| r[i]).sum::<f64>() / n)
    };
    let xs: Vec<&Vec<f64>> = centre.iter().map(|c| &c.0).collect();
    let m0 = mean(&xs);
    let r = xs.len() as f64;
    let mut sigma = DMatrix::zeros(pn, pn);
    for x in &xs {
        let d = DVector::from_fn(pn, |i, _| x[i] - m0[i]);
        sigma += &d * d.transpose() / (r - 1.0);
    }
    let sigma_inv = sigma.try_inverse()? * ((r - pn as f64 - 2.0) / (r - 1.0));
    // J by central differences over the seeds complete at both ends.
    let slope = |lo: usize, hi: usize, h: f64| -> Option<DVector<f64>> {
        let pairs: Vec<(&Vec<f64>, &Vec<f64>)> = (at(lo).iter().zip(at(hi)))
            .filter_map(|(a, b)| Some((&a.as_ref()?.0, &b.as_ref()?.0)))
            .collect();
        (!pairs.is_empty()).then(|| {
            let n = pairs.len() as f64;
            DVector::from_fn(pn, |i, _| {
                pairs.iter().map(|(a, b)| b[i] - a[i]).sum::<f64>() / (n * 2.0 * h)
            })
        })
    };
    let (ju, jd) = (slope(1, 2, hu)?, slope(3, 4, hd)?);
    // The networks' sensitivity: d E[estimate] / d theta, by the same differences.
    let sens = |lo: usize, hi: usize, h: f64, k: usize| -> f64 {
        let pairs: Vec<(f64, f64)> = (at(lo).iter().zip(at(hi)))
            .filter_map(|(a, b)| Some((a.as_ref()?.1?[k], b.as_ref()?.1?[k])))
            .collect();
        let n = pairs.len() as f64;
        pairs.iter().map(|(a, b)| b - a).sum::<f64>() / (n * 2.0 * h)
    };
    let g_speed = nalgebra::Vector2::new(sens(1, 2, hu, 0), sens(3, 4, hd, 0));
    let g_disp = sens(3, 4, hd, 1);
    let j = DMatrix::from_columns(&[ju.clone(), jd.clone()]);
    let info = j.transpose() * &sigma_inv * &j;
    let info = Matrix2::new(info[(0, 0)], info[(0, 1)], info[(1, 0)], info[(1, 1)]);
    let crb = info.try_inverse()?;
    let ests: Vec<[f64; 2]> = centre.iter().filter_map(|c| c.1).collect();
    let sd = |k: usize| {
        let n = ests.len() as f64;
        let m = ests.iter().map(|e| e[k]).sum::<f64>() / n;
        (ests.iter().map(|e| (e[k] - m).powi(2)).sum::<f64>() / (n - 1.0)).sqrt()
    };
    Some(Bound {
        method,
        sea,
        tests: centre.len(),
        features: inputs.iter().map(ToString::to_string).collect(),
        jacobian: (0..pn).map(|i| [ju[i], jd[i]]).collect(),
        speed_mps: crb[(0, 0)].sqrt(),
        displacement_t: 1.0 / info[(1, 1)].sqrt(),
        sensitivity: [g_speed[0], g_disp],
        biased: [
            (g_speed.transpose() * crb * g_speed)[(0, 0)].sqrt(),
            g_disp.abs() / info[(1, 1)].sqrt(),
        ],
        spread: if ests.len() > 2 {
            [sd(0), sd(1)]
        } else {
            [f64::NAN; 2]
        },
    })
}

/// Every method and sea at the nominal point, as a markdown table.
pub fn crb_table(cfg: &Config, o: &CrbOptions) -> String {
    let mut out = String::new();
    let ship = &cfg.ship;
    let _ = writeln!(
        out,
        "# One test's Cramer-Rao bound on (u, D) and the networks' spread\n\n\
         Ship at {:.1} m/s and {:.0} t, {} seeded tests per point from seed {}; the bound from \
         the speed network's features (their covariance at the point, their slopes by central \
         differences of {H_SPEED_MPS} m/s and {:.0} % of D with the same seeds). Speed: D \
         unknown; displacement: the speed given (the log). The bound columns are for an \
         unbiased reader. The networks' sensitivity dE[.]/d(.) (by the same differences) is 1 \
         for an unbiased one; their ratio is their spread over the bound for a reader of their \
         own sensitivity (sqrt(g' I^-1 g)): 1 is efficient, below 1 is Monte Carlo noise or \
         a non-Gaussian feature, above 1 is information the networks leave.\n",
        ship.nominal_speed_mps,
        ship.nominal_displacement_t,
        o.tests,
        o.seed,
        100.0 * H_DISPLACEMENT
    );
    let _ = writeln!(
        out,
        "| ship | method | sea | tests | features | bound u [m/s] | networks u [m/s] | dE[u^]/du | ratio u | bound D [t] | networks D [t] | dE[D^]/dD | ratio D |"
    );
    let _ = writeln!(out, "|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    let mut ships = vec![("configured", cfg.clone())];
    if o.family {
        let members = super::fdi::family_members(cfg, o.member.as_deref());
        ships.extend(members.into_iter().map(|(_, name, c)| (name, c)));
    }
    for (name, cfg) in &ships {
        ship_rows(&mut out, name, cfg, o);
    }
    out
}

/// The table's rows of one ship.
fn ship_rows(out: &mut String, name: &str, cfg: &Config, o: &CrbOptions) {
    for method in [Method::Clfrt, Method::Hbt] {
        for sea in [SeaState::Calm, SeaState::Moderate] {
            match bound(cfg, method, sea, o) {
                Some(b) => {
                    let _ = writeln!(
                        out,
                        "| {name} | {} | {} | {} | {} | {:.4} | {:.4} | {:.2} | {:.2} | {:.1} | {:.1} | {:.2} | {:.2} |",
                        method.name(),
                        sea.name(),
                        b.tests,
                        b.features.len(),
                        b.speed_mps,
                        b.spread[0],
                        b.sensitivity[0],
                        b.spread[0] / b.biased[0],
                        b.displacement_t,
                        b.spread[1],
                        b.sensitivity[1],
                        b.spread[1] / b.biased[1]
                    );
                }
                None => {
                    let _ = writeln!(
                        out,
                        "| {name} | {} | {} | too few completed tests or a singular covariance | | | | | | | | | |",
                        method.name(),
                        sea.name()
                    );
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// On the first-order ship in a calm sea the features' slopes are those of `G(j w) =
    /// b / (j w (j w + a))` at the tones, `(a, b)` from `(u, D)` through the ship model:
    /// `ln |G| = ln b - ln w - ln(w^2 + a^2) / 2`, `arg G = -pi/2 - atan(w / a)`, each
    /// differentiated by central differences of the model itself. Within 15 % (the
    /// simulated slopes carry the estimates' noise, 12 seeds).
    #[test]
    fn the_features_slopes_are_the_nomoto_ships() {
        let cfg = Config::default();
        let o = CrbOptions {
            tests: 12,
            seed: 1,
            threads: crate::tools::training::database::default_threads(),
            family: false,
            member: None,
        };
        let b = bound(&cfg, Method::Clfrt, SeaState::Calm, &o).expect("a bound");
        let ship = &cfg.ship;
        let (u0, d0) = (ship.nominal_speed_mps, ship.nominal_displacement_t);
        let design = Monitor::design_multisine(&cfg.core()).unwrap();
        let g = |u: f64, d: f64, w: f64| {
            let (a, bb) = ship.nomoto(u, d);
            let ln_gain = bb.ln() - w.ln() - 0.5 * (w * w + a * a).ln();
            [ln_gain, -std::f64::consts::FRAC_PI_2 - (w / a).atan()]
        };
        for (k, &w) in design.omegas().iter().enumerate() {
            let (hu, hd) = (1e-4, 1e-3);
            for part in 0..2 {
                let du = (g(u0 + hu, d0, w)[part] - g(u0 - hu, d0, w)[part]) / (2.0 * hu);
                let dd = (g(u0, d0 + hd, w)[part] - g(u0, d0 - hd, w)[part]) / (2.0 * hd);
                let sim = b.jacobian[2 * k + part];
                let name = &b.features[2 * k + part];
                assert!(
                    (sim[0] - du).abs() <= 0.15 * du.abs(),
                    "{name}: d/du {} vs {du}",
                    sim[0]
                );
                // arg G does not depend on D: its slope is noise about zero.
                let tol = if part == 0 {
                    0.15 * dd.abs()
                } else {
                    0.15 / d0
                };
                assert!(
                    (sim[1] - dd).abs() <= tol,
                    "{name}: d/dD {} vs {dd}",
                    sim[1]
                );
            }
        }
        assert!(b.speed_mps > 0.0 && b.displacement_t > 0.0, "{b:?}");
    }
}
