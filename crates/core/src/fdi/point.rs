//! A test's operating point for the reference over the envelope
//! (`crate::fdi::envelope`): what a healthy residual depends on besides the ship,
//! its coordinates, a learned test and the regression's settings.

use super::stats::{Cov, P};
use serde::{Deserialize, Serialize};

/// One learned healthy test.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Sample {
    /// Raw residual `(e_u [m/s], e_D [fraction of D_nom], e_b [ln])`.
    pub e: [f64; P],
    /// Design spreads at its sea `(s_u [m/s], s_D [fraction], s_D)`.
    pub s: [f64; P],
    /// Speed log [m/s].
    pub speed_mps: f64,
    /// Declared displacement [t].
    pub displacement_t: f64,
    /// The excitation's scale against its design (1: as designed).
    #[serde(default = "as_designed")]
    pub excitation_scale: f64,
    /// How its residual moves per m/s of the ship's own speed by the similarity law
    /// (`crate::fdi::sensitivity::scale_speed`): the speed slope's prior mean.
    #[serde(default)]
    pub speed_slope: [f64; P],
    /// How it moves per unit of `ln D` of a declared loading (`crate::fdi::raw::Raw::
    /// loading_slope`): the loading slope's prior mean.
    #[serde(default)]
    pub loading_slope: [f64; P],
    /// The test's sea index (`crate::fdi::sea_index`, its wave yaw [deg]); `None` in a
    /// state saved before it was kept, or a test that could not say: such a test is at every
    /// sea (it adds no distance in sea).
    #[serde(default)]
    pub sea_index: Option<f64>,
    /// The vessel's test number it came from (both methods count): orders the methods'
    /// samples in time for the commissioning's change-point test. 0 in a state saved
    /// before it was kept: those samples are one moment to the test (no split among them).
    #[serde(default)]
    pub order: u64,
    /// The residual's covariance from the test's own tone intervals
    /// (`crate::fdi::raw::measurement_cov`, physical units); `None` for an HBT test,
    /// or in a state saved before it was kept.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub meas: Option<Cov>,
    /// How `e_D` moves per m/s of a speed-log bias (`crate::fdi::raw::Raw::log_slope`).
    #[serde(default)]
    pub log_slope: f64,
}

fn as_designed() -> f64 {
    1.0
}

impl Sample {
    /// Its operating point.
    pub fn point(&self) -> Point {
        Point {
            speed_mps: self.speed_mps,
            displacement_t: self.displacement_t,
            excitation_scale: self.excitation_scale,
            sea_index: self.sea_index,
        }
    }

    /// Its coordinates.
    pub(super) fn x(&self, st: &Regression) -> X {
        self.point().x(st)
    }

    /// Its own physical slopes.
    pub fn slopes(&self) -> PhysicalSlopes {
        PhysicalSlopes {
            speed: self.speed_slope,
            loading: self.loading_slope,
        }
    }
}

/// A test's own physical slopes at its point (`Sample::speed_slope`,
/// `Sample::loading_slope`): how its residual moves per m/s of the ship's own speed by the
/// similarity law, and per unit of `ln D` of a declared loading, `b` scaling by `1 / D`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PhysicalSlopes {
    /// Per m/s.
    pub speed: [f64; P],
    /// Per unit `ln D`.
    pub loading: [f64; P],
}

/// An operating point: what a test's healthy residual depends on besides the ship.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Point {
    /// Speed log [m/s].
    pub speed_mps: f64,
    /// Declared displacement [t].
    pub displacement_t: f64,
    /// The excitation's scale against its design (1: as designed).
    pub excitation_scale: f64,
    /// The sea index [deg] (`None`: at every sea).
    pub sea_index: Option<f64>,
}

/// The coordinates of an operating point: `(u, ln D, ln s, w)`, `w` NaN for a test at every
/// sea.
pub type X = [f64; 4];

impl Point {
    /// `(u, ln D, ln s)`: the point without its sea (the commissioning's change-point test,
    /// `crate::fdi::changepoint`, whose sample is in one sea).
    pub fn x3(&self) -> [f64; 3] {
        [
            self.speed_mps,
            self.displacement_t.max(1e-9).ln(),
            self.excitation_scale.max(1e-9).ln(),
        ]
    }

    /// `(u, ln D, ln s, w)`, `w = ln(max(i, i_calm) / i_calm)` of the sea index `i` (0 in a
    /// calm sea or calmer, about 1.3 in a moderate one at the default anchors).
    pub fn x(&self, st: &Regression) -> X {
        let calm = st.sea_calm_deg.max(1e-9);
        let [u, l, g] = self.x3();
        [
            u,
            l,
            g,
            self.sea_index
                .filter(|i| i.is_finite())
                .map_or(f64::NAN, |i| (i.max(calm) / calm).ln()),
        ]
    }
}

/// The regression's settings (from the models' calibration, `Calibration`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Regression {
    /// Kernel widths `(b_u [m/s], b_l [ln D], b_g [ln s], b_w [ln of the sea index])`.
    pub bandwidth: [f64; 4],
    /// Prior standard deviation of the slopes in speed `(e_u [m/s per m/s], e_D [per m/s])`.
    pub slope_speed: [f64; 2],
    /// Prior standard deviation of `e_b`'s slope in speed [per m/s].
    pub slope_speed_gain: f64,
    /// Prior standard deviation of the slopes in `ln D` `(e_u [m/s], e_D [fraction])`.
    pub slope_loading: [f64; 2],
    /// Prior standard deviation of the slopes in `ln s` `(e_u [m/s], e_D [fraction])`.
    pub slope_excitation: [f64; 2],
    /// Prior standard deviation of the slopes in the sea's `w` `(e_u [m/s], e_D [fraction])`.
    pub slope_sea: [f64; 2],
    /// The calm sea's index [deg] (`calibration.sea-wave-yaw-deg`'s first): `w = 0` there.
    pub sea_calm_deg: f64,
}

impl Regression {
    /// The prior standard deviation of component `j`'s slope in speed: `e_u`'s, `e_D`'s,
    /// `e_b`'s own.
    pub fn speed_sd(&self, j: usize) -> f64 {
        match j {
            0 | 1 => self.slope_speed[j],
            _ => self.slope_speed_gain,
        }
    }

    /// The regression's settings in the models' calibration.
    pub fn of(r: &super::config::Calibration) -> Self {
        Self {
            bandwidth: [
                r.bandwidth_speed_mps,
                r.bandwidth_loading,
                r.bandwidth_excitation,
                r.bandwidth_sea,
            ],
            slope_speed: r.slope_speed,
            slope_speed_gain: r.slope_speed_gain,
            slope_loading: r.slope_loading,
            slope_excitation: r.slope_excitation,
            slope_sea: r.slope_sea,
            sea_calm_deg: r.sea_wave_yaw_deg[0],
        }
    }
}

/// The geometric mean of the positive finite values, `None` without one.
pub(super) fn log_mean(values: impl Iterator<Item = f64>) -> Option<f64> {
    let (n, sum) = values
        .filter(|v| v.is_finite() && *v > 0.0)
        .fold((0.0, 0.0), |(n, s), v| (n + 1.0, s + v.ln()));
    (n > 0.0).then(|| (sum / n).exp())
}
