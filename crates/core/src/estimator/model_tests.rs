//! Tests of [`super`] (`model.rs`), kept beside it so that the module reads in one screenful
//! of code; they check it against independent answers.

use super::*;
use crate::testing::sample_model;

fn edit(f: impl FnOnce(&mut serde_json::Value)) -> Result<Model, ModelError> {
    let mut v: serde_json::Value =
        serde_json::from_str(&sample_model().to_json().unwrap()).unwrap();
    f(&mut v);
    Model::from_json(&v.to_string(), "edited.json")
}

#[test]
fn round_trip_is_bit_exact() {
    let m = sample_model();
    let text = m.to_json().unwrap();
    let back = Model::from_json(&text, "x.json").unwrap();
    assert_eq!(back, m);
    assert_eq!(back.to_json().unwrap(), text);
    assert_eq!(m.file_name(), "clfrt_displacement.json");
}

/// A case of a bad model file: what the error names, and how the file is spoiled.
type Spoil = (&'static str, Box<dyn FnOnce(&mut serde_json::Value)>);

#[test]
fn loader_refuses_bad_files_with_a_clear_error() {
    let cases: Vec<Spoil> = vec![
        ("format", Box::new(|v| v["format"] = "other".into())),
        ("version", Box::new(|v| v["version"] = 2.into())),
        (
            "unknown feature name",
            Box::new(|v| v["inputs"][0] = "ln_gain_x".into()),
        ),
        (
            "not a hbt feature",
            Box::new(|v| v["method"] = "hbt".into()),
        ),
        (
            "speed log",
            Box::new(|v| {
                v["target"] = "speed".into();
                v["unit"] = "m/s".into();
            }),
        ),
        ("unit", Box::new(|v| v["unit"] = "kg".into())),
        (
            "architecture",
            Box::new(|v| v["architecture"]["layers"][1] = 12.into()),
        ),
        (
            "w1 must be 10 rows of 7",
            Box::new(|v| {
                v["weights"]["w1"][3].as_array_mut().unwrap().pop();
            }),
        ),
        (
            "b2 must have 10",
            Box::new(|v| {
                v["weights"]["b2"].as_array_mut().unwrap().push(1.0.into());
            }),
        ),
        // serde_json writes NaN as null: it must not load.
        (
            "does not parse",
            Box::new(|v| v["weights"]["w2"][0][0] = serde_json::Value::Null),
        ),
        (
            "input ranges",
            Box::new(|v| {
                v["scaling"]["input_min"].as_array_mut().unwrap().pop();
            }),
        ),
        (
            "range 2 is empty",
            Box::new(|v| v["scaling"]["input_max"][2] = (-5.0).into()),
        ),
        (
            "uncertainty",
            Box::new(|v| v["uncertainty"]["residual_std"] = 0.0.into()),
        ),
        (
            "appears twice",
            Box::new(|v| v["inputs"][1] = "ln_gain_1".into()),
        ),
        ("does not parse", Box::new(|v| v["extra"] = 1.into())),
    ];
    for (needle, f) in cases {
        let e = edit(f).unwrap_err().to_string();
        assert!(e.contains("edited.json"), "{e}");
        assert!(e.contains(needle), "expected `{needle}` in: {e}");
    }
    // The unedited file loads.
    edit(|_| {}).unwrap();
}

#[test]
fn check_for_refuses_another_design_or_slot() {
    let m = sample_model();
    let cfg = CoreConfig::default();
    m.check_for(&cfg, Method::Clfrt, Target::Displacement, "m")
        .unwrap();
    let e = m
        .check_for(&cfg, Method::Clfrt, Target::Speed, "m")
        .unwrap_err();
    assert!(e.to_string().contains("expected clfrt speed"), "{e}");
    let mut other = cfg.clone();
    other.clfrt.amplitude_deg += 0.5;
    let e = m
        .check_for(&other, Method::Clfrt, Target::Displacement, "m")
        .unwrap_err();
    assert!(e.to_string().contains("another design"), "{e}");
    let mut other = cfg.clone();
    other.ship.length_m = 100.0;
    assert!(m
        .check_for(&other, Method::Clfrt, Target::Displacement, "m")
        .is_err());
    // Another nominal displacement (the parity reference) is the same design.
    let mut loaded = cfg.clone();
    loaded.ship.nominal_displacement_t = 8500.0;
    m.check_for(&loaded, Method::Clfrt, Target::Displacement, "m")
        .unwrap();
    // A longer measurement is the same design.
    let mut longer = cfg;
    longer.clfrt.measure_windows += 1;
    m.check_for(&longer, Method::Clfrt, Target::Displacement, "m")
        .unwrap();
}

/// A models directory is its networks and their calibration: the calibration is read with
/// them (and is part of their fingerprint), its wave band checked against the sensors'
/// Nyquist frequency, and a directory without one refused, naming the file.
#[test]
fn a_models_directory_carries_its_calibration() {
    use crate::estimator::{Estimator, CALIBRATION_FILE, EMBEDDED_MODELS};
    use crate::fdi::config::Calibration;
    let cfg = crate::monitor::config::CoreConfig::default();
    let dir = std::env::temp_dir().join(format!("hw-cal-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for (name, text) in EMBEDDED_MODELS {
        std::fs::write(dir.join(name), text).unwrap();
    }
    let e = Estimator::load_dir(&dir, &cfg).unwrap_err().to_string();
    assert!(e.contains(CALIBRATION_FILE), "{e}");
    let cal = Calibration {
        sea_wave_yaw_deg: [0.04, 0.2],
        ..Calibration::default()
    };
    std::fs::write(
        dir.join(CALIBRATION_FILE),
        serde_json::to_string(&cal).unwrap(),
    )
    .unwrap();
    let est = Estimator::load_dir(&dir, &cfg).unwrap();
    assert_eq!(est.calibration(), &cal);
    let embedded = Estimator::embedded(&cfg).unwrap();
    assert_ne!(est.fingerprint(), embedded.fingerprint());
    assert_eq!(embedded.calibration(), &Calibration::default());
    // 2 Hz sensors: a wave band to 8 rad/s is above pi * 2 = 6.28 rad/s.
    let slow = crate::monitor::config::CoreConfig {
        sensors: crate::model::SensorConfig {
            rate_hz: 2.0,
            ..cfg.sensors.clone()
        },
        ..cfg.clone()
    };
    let wide = Calibration {
        wave_band_rad_s: [0.4, 8.0],
        ..Calibration::default()
    };
    std::fs::write(
        dir.join(CALIBRATION_FILE),
        serde_json::to_string(&wide).unwrap(),
    )
    .unwrap();
    let e = Estimator::load_dir(&dir, &slow).unwrap_err().to_string();
    assert!(e.contains("wave-band-rad-s"), "{e}");
    std::fs::remove_dir_all(&dir).unwrap();
}
