//! The classes' own models in the repository (`config/classes/*.toml`, each naming its
//! `models/classes/<name>`): each loads with its class's configuration and carries
//! the calibration `train` measures on the class: the healthy scatter's prior and the
//! displacement's direction (docs/fdi.md, "Keys and calibration").

use helmwatch::config::Config;
use helmwatch_core::estimator::Estimator;
use std::path::Path;

#[test]
fn every_class_config_loads_its_own_models_with_their_calibration() {
    let mut seen = 0;
    for entry in std::fs::read_dir("config/classes").unwrap() {
        let path = entry.unwrap().path();
        if path.extension().and_then(|e| e.to_str()) != Some("toml") {
            continue;
        }
        let cfg = Config::from_file(&path).unwrap();
        let dir = cfg.estimator.models_dir.clone().unwrap();
        let name = path.file_stem().unwrap().to_str().unwrap();
        assert_eq!(
            Path::new(&dir),
            Path::new("models/classes").join(name),
            "{path:?}"
        );
        let est = Estimator::from_config(&cfg.core())
            .unwrap_or_else(|e| panic!("{path:?}: {e}"))
            .unwrap();
        let cal = est.calibration();
        assert!(cal.healthy_scatter.is_some(), "{path:?}");
        let d = cal.displacement_direction.unwrap();
        for pair in [d.clfrt, d.hbt] {
            for v in pair {
                assert!(v[1] > 0.5 && v[1] < 1.5, "{path:?}: {v:?}");
            }
        }
        seen += 1;
    }
    assert!(seen >= 2, "{seen} class configurations");
}
