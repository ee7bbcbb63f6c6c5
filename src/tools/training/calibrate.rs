//! The calibration `train` writes beside the networks (`calibration.json`,
//! `helmwatch_core::fdi::config::Calibration`): the numbers that describe the estimator on the
//! class of hull the database was drawn from.
//!
//! Measured on the database: the sea index's anchors, the median wave yaw of the completed
//! tests in a calm and in a moderate sea [deg] (the heading's rms in the wave band: how the
//! class's hulls answer the seas the networks were trained in). The others are carried from
//! the calibration in force (the shipped models' unless a models directory is given): they
//! describe hulls and servos beyond the simulated class (the commissioning spreads, the
//! servo's spread, the slope priors), which one class's simulations cannot measure.

use super::database::Database;
use helmwatch_core::fdi::config::Calibration;
use helmwatch_core::fdi::stats::median;
use helmwatch_core::model::SeaState;

/// The median wave yaw [deg] of the completed tests of `db` in `sea`, both methods.
pub fn wave_yaw_deg(db: &Database, sea: SeaState) -> f64 {
    let mut v = db
        .spec
        .methods
        .iter()
        .flat_map(|&m| db.completed(m))
        .filter(|(i, _)| db.points[*i].sea == sea)
        .filter_map(|(_, f)| f.wave_yaw_rad())
        .filter(|w| w.is_finite())
        .map(f64::to_degrees)
        .collect::<Vec<_>>();
    median(&mut v)
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

    /// A database of CLFRT tests whose wave yaw is known: the anchors are the medians of
    /// each sea's, a failed test and a rough sea's left out; a database without a moderate
    /// sea keeps that anchor.
    #[test]
    fn the_sea_anchors_are_the_medians_of_the_databases_wave_yaw() {
        use crate::tools::training::database::{DatabaseSpec, Point, Purpose, TestRun};
        use helmwatch_core::testing::sample;
        use helmwatch_core::wire::{Features, Method};
        let test = |deg: f64| TestRun {
            features: Ok(Features::Clfrt(
                helmwatch_core::wire::features::ClfrtFeatures {
                    wave_yaw_rad: Some(f64::to_radians(deg)),
                    ..sample::clfrt(vec![])
                },
            )),
            duration_s: 1200.0,
        };
        let point = |sea| Point {
            sea,
            speed_mps: 7.0,
            displacement_t: 7000.0,
            seed: 1,
            ship: None,
        };
        let seas = [
            (SeaState::Calm, 0.04),
            (SeaState::Calm, 0.06),
            (SeaState::Calm, 0.05),
            (SeaState::Moderate, 0.2),
            (SeaState::Moderate, 0.3),
            (SeaState::Rough, 0.9),
        ];
        let mut runs: Vec<TestRun> = seas.iter().map(|&(_, d)| test(d)).collect();
        runs.push(TestRun {
            features: Err("aborted".into()),
            duration_s: f64::NAN,
        });
        let mut points: Vec<Point> = seas.iter().map(|&(s, _)| point(s)).collect();
        points.push(point(SeaState::Calm));
        let db = Database {
            spec: DatabaseSpec {
                seed: 1,
                purpose: Purpose::Training,
                points_per_sea: 3,
                seas: vec![SeaState::Calm, SeaState::Moderate, SeaState::Rough],
                methods: vec![Method::Clfrt],
                faults: vec![],
                family: false,
            },
            points,
            runs: vec![runs],
        };
        let base = Calibration::default();
        let c = calibrate(&db, &base);
        approx::assert_relative_eq!(c.sea_wave_yaw_deg[0], 0.05, max_relative = 1e-12);
        approx::assert_relative_eq!(c.sea_wave_yaw_deg[1], 0.25, max_relative = 1e-12);
        assert_eq!(
            Calibration {
                sea_wave_yaw_deg: base.sea_wave_yaw_deg,
                ..c
            },
            base
        );
        let calm_only = Database {
            points: db.points[..3].to_vec(),
            runs: vec![db.runs[0][..3].to_vec()],
            ..db
        };
        let c = calibrate(&calm_only, &base);
        approx::assert_relative_eq!(c.sea_wave_yaw_deg[0], 0.05, max_relative = 1e-12);
        assert_eq!(c.sea_wave_yaw_deg[1], base.sea_wave_yaw_deg[1]);
    }

    #[test]
    fn the_median_is_the_middle_value() {
        assert_eq!(median(&mut [3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(&mut [4.0, 1.0, 2.0, 3.0]), 2.5);
        assert!(median(&mut []).is_nan());
    }
}
