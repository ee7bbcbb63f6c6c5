//! The calibration `train` writes beside the networks (`calibration.json`,
//! `crate::core::fdi::config::Calibration`): the numbers that describe the estimator on the
//! class of hull the database was drawn from.
//!
//! Measured on the database: the sea index's anchors, the median wave yaw of the completed
//! tests in a calm and in a moderate sea [deg] (the heading's rms in the wave band: how the
//! class's hulls answer the seas the networks were trained in). The others are carried from
//! the calibration in force (the shipped models' unless a models directory is given): they
//! describe hulls and servos beyond the simulated class (the commissioning spreads, the
//! servo's spread, the slope priors), which one class's simulations cannot measure.

use super::database::Database;
use crate::core::fdi::config::Calibration;
use crate::core::model::SeaState;

/// The median of `v` (NaN when empty).
fn median(mut v: Vec<f64>) -> f64 {
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

/// The median wave yaw [deg] of the completed tests of `db` in `sea`, both methods.
pub fn wave_yaw_deg(db: &Database, sea: SeaState) -> f64 {
    let v = db
        .spec
        .methods
        .iter()
        .flat_map(|&m| db.completed(m))
        .filter(|(i, _)| db.points[*i].sea == sea)
        .filter_map(|(_, f)| f.wave_yaw_rad())
        .filter(|w| w.is_finite())
        .map(f64::to_degrees)
        .collect();
    median(v)
}

/// `base` with what `db` measures (the module doc); a sea the database lacks keeps its
/// anchor, and anchors that would not increase keep both.
pub fn calibrate(db: &Database, base: &Calibration) -> Calibration {
    let anchors = [
        wave_yaw_deg(db, SeaState::Calm),
        wave_yaw_deg(db, SeaState::Moderate),
    ];
    let mut c = base.clone();
    let measured = [
        if anchors[0].is_finite() && anchors[0] > 0.0 {
            anchors[0]
        } else {
            base.sea_wave_yaw_deg[0]
        },
        if anchors[1].is_finite() {
            anchors[1]
        } else {
            base.sea_wave_yaw_deg[1]
        },
    ];
    if measured[1] > measured[0] {
        c.sea_wave_yaw_deg = measured;
    }
    c
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_median_is_the_middle_value() {
        assert_eq!(median(vec![3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(vec![4.0, 1.0, 2.0, 3.0]), 2.5);
        assert!(median(vec![]).is_nan());
    }
}
