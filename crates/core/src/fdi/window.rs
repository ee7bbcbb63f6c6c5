//! One test in the vessel's window, and a look's sums over its newest tests: what the
//! decision's looks (`decision`) and the causes' costs (`isolation`) are computed from.

use super::measured::{Basis, Measured};
use super::raw::Raw;
use super::reference::{MethodReference, Settings};
use super::stats::{dot, unit, P};
use crate::wire::Method;
use serde::{Deserialize, Serialize};
use std::collections::VecDeque;

/// The speed log's reading at a test and before it.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct LogReading {
    /// The test's mean speed log [m/s].
    pub now_mps: f64,
    /// The ship's previous test's (`None`: none since the daemon's state began) [m/s].
    pub before_mps: Option<f64>,
    /// A test's mean reading's wander on a ship at steady speed (`isolation::log_wander`) [m/s].
    pub sigma_mps: f64,
    /// Whether the test was measured at a point the vessel has learned (the report's
    /// `commissioned`): only there does its residual say the ship is where it was
    /// (`isolation`).
    #[serde(default)]
    pub learned_point: bool,
}

/// One test in the vessel's window.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Entry {
    /// Its method.
    pub method: Method,
    /// The whitened parameter residual (`None`: none measured).
    pub z: Option<[f64; P]>,
    /// Its measured components (2: no `e_b`).
    #[serde(default = "all_components")]
    pub dim: usize,
    /// The reference offset error's share `c` of the residual's variance (`None`: wide
    /// design limits).
    pub offset_var: Option<f64>,
    /// The reference it was measured against (a new one for the method drops its older
    /// tests from the window).
    pub epoch: u32,
    /// The whitened directions of the parameter causes (speed log, displacement).
    pub directions: [[f64; P]; 2],
    /// The rudder effectiveness's whitened direction, where it is not the displacement's
    /// (`Source::rudder`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rudder: Option<[f64; P]>,
    /// The servo check's score (`None`: no servo check).
    pub z_rate: Option<f64>,
    /// What it was measured from, to measure it again against a newer reference of its
    /// method (`None`: as it stands).
    #[serde(default)]
    pub source: Option<Source>,
    /// The speed log's reading at the test and before it (`None`: not known): a speed-log
    /// bias is a jump of the reading, a change of loading leaves it where it was
    /// (`isolation`).
    #[serde(default)]
    pub log: Option<LogReading>,
}

/// A test's raw residuals and its cause directions before whitening (speed log,
/// displacement), from which its entry is measured against the method's reference.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Source {
    /// Its raw residuals against the design.
    pub raw: Raw,
    /// The causes' directions in `(e_u, e_D, e_b)`.
    pub directions: [[f64; P]; 2],
    /// The rudder effectiveness's, where it is not the displacement's (a class whose
    /// displacement moves more than `b`: `crate::fdi::raw::NnRaw::rudder_dir`); the
    /// isolation's other model of that cause.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rudder: Option<[f64; P]>,
}

impl Entry {
    /// Whether a look over the newest `n` entries takes it: one with a parameter residual, on
    /// the vessel's reference (`n > 1`) or any (`n = 1`, the newest alone).
    pub fn in_look(&self, n: usize) -> bool {
        self.z.is_some() && (self.offset_var.is_some() || n == 1)
    }
}

fn all_components() -> usize {
    P
}

/// One method's part of a look: the sums over its tests in the look.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MethodSums {
    /// The method.
    pub method: Method,
    /// Sum of its whitened residuals.
    pub sum: [f64; P],
    /// Sum of its tests' unit cause directions (speed log, displacement).
    pub directions: [[f64; P]; 2],
    /// Sum of its tests' unit rudder-effectiveness directions (the displacement's where a
    /// test has none of its own).
    pub rudder: [f64; P],
    /// Per cause, the sum of its tests' whitened directions as they are (per unit of the
    /// cause: m/s of log bias, the displacement's step).
    pub along_sum: [[f64; P]; 2],
    /// Per cause, `sum_k v_k . z_k`.
    pub projection: [f64; 2],
    /// Per cause, `sum_k |v_k|^2`.
    pub norm2: [f64; 2],
    /// Its tests in the look.
    pub tests: usize,
    /// The most components among them.
    pub dim: usize,
    /// Its reference offset error's share `c` (the largest among its tests in the look).
    pub offset_var: f64,
}

impl MethodSums {
    /// The sum's variance bound in units of one test's: `n_m (1 + (n_m - 1) c_m)`.
    pub fn scale(&self) -> f64 {
        let k = self.tests as f64;
        k * (1.0 + (k - 1.0) * self.offset_var)
    }

    /// The sum's component along cause `j`'s unit mean direction, `u_mj . s_m`.
    pub fn along(&self, j: usize) -> f64 {
        dot(unit(self.directions[j]), self.sum)
    }

    /// The sum's component along the rudder effectiveness's unit mean direction.
    pub fn along_rudder(&self) -> f64 {
        dot(unit(self.rudder), self.sum)
    }
}

/// The per-method sums of the newest `n` entries (`n = 1`: the newest alone, wide or not;
/// `n > 1`: entries on wide limits left out).
pub fn method_sums(window: &VecDeque<Entry>, n: usize) -> Vec<MethodSums> {
    let mut out: Vec<MethodSums> = Vec::new();
    for e in window.iter().rev().take(n).filter(|e| e.in_look(n)) {
        let (Some(z), c) = (e.z, e.offset_var.unwrap_or(0.0)) else {
            continue;
        };
        let d = e.directions.map(unit);
        let r = unit(e.rudder.unwrap_or(e.directions[1]));
        let v = e.directions;
        let projection = v.map(|v| dot(v, z));
        let norm2 = v.map(|v| dot(v, v));
        match out.iter_mut().find(|o| o.method == e.method) {
            Some(o) => {
                o.offset_var = o.offset_var.max(c);
                for i in 0..P {
                    o.sum[i] += z[i];
                    for (acc, di) in o.directions.iter_mut().zip(&d) {
                        acc[i] += di[i];
                    }
                    o.rudder[i] += r[i];
                    for (acc, vi) in o.along_sum.iter_mut().zip(&v) {
                        acc[i] += vi[i];
                    }
                }
                for j in 0..2 {
                    o.projection[j] += projection[j];
                    o.norm2[j] += norm2[j];
                }
                o.tests += 1;
                o.dim = o.dim.max(e.dim);
            }
            None => out.push(MethodSums {
                method: e.method,
                sum: z,
                directions: d,
                rudder: r,
                along_sum: v,
                projection,
                norm2,
                tests: 1,
                dim: e.dim,
                offset_var: c,
            }),
        }
    }
    out
}

/// The index of a method in the per-method arrays: CLFRT 0, HBT 1.
pub fn method_index(m: Method) -> usize {
    match m {
        Method::Clfrt => 0,
        Method::Hbt => 1,
    }
}

/// A test's entry in the vessel's window, measured against `c`, its method's reference.
pub fn measure_entry(
    c: &MethodReference,
    settings: &Settings,
    method: Method,
    source: Source,
    epoch: u32,
    z_rate: Option<f64>,
) -> (Basis, Measured, Entry) {
    let (basis, m) = c.measure(&settings.method(method_index(method)), &source.raw);
    // Against the vessel's reference a speed-log bias also moves the reference's predicted
    // offset, by its slope in speed: the similarity law's (the slope prior's mean, `envelope`).
    let mut directions = source.directions;
    if matches!(basis, Basis::Vessel(_)) {
        for (d, s) in directions[0].iter_mut().zip(source.raw.speed_slope) {
            *d -= s;
        }
    }
    // The components not measured take no part.
    let measured =
        |v: [f64; P]| -> [f64; P] { std::array::from_fn(|j| if j < m.dim { v[j] } else { 0.0 }) };
    let directions = directions.map(measured);
    let entry = Entry {
        method,
        z: m.whitened(),
        dim: m.dim,
        offset_var: m.offset_var,
        epoch,
        directions: directions.map(|d| m.cov.whiten(d).unwrap_or([0.0; P])),
        rudder: source.rudder.and_then(|d| m.cov.whiten(measured(d))),
        z_rate,
        source: Some(source),
        log: None,
    };
    (basis, m, entry)
}
