//! The annotated example configuration stays true to the code, and bad configuration is
//! refused with the key, the range and exit code 78.

use helmwatch::config::Config;
use helmwatch_core::config::ConfigError;
use std::path::Path;

#[test]
fn example_config_equals_the_defaults() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("config/helmwatch.example.toml");
    let cfg = Config::from_file(&path).unwrap();
    assert_eq!(cfg, Config::default());
}

/// Runs `check-config` on `text` written to `dir/name`: the exit code and standard error.
fn check_config(dir: &Path, name: &str, text: &str) -> (Option<i32>, String) {
    let file = dir.join(name);
    std::fs::write(&file, text).unwrap();
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_helmwatch"))
        .args(["--config", file.to_str().unwrap(), "check-config"])
        .output()
        .unwrap();
    (
        out.status.code(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn binary_exits_78_naming_the_key_and_range() {
    let dir = std::env::temp_dir().join(format!("helmwatch-cfg-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    // (file, text, what the error must name: the key and its range)
    let bad = [
        (
            "bad.toml",
            "[safety]\nmax-heading-error-deg = 90\n",
            ["safety.max-heading-error-deg", "(0, 45]"],
        ),
        // What commissioning must resolve.
        (
            "resolve.toml",
            "[reference]\nresolve-displacement = 2\n",
            ["reference.resolve-displacement", "(0, 1]"],
        ),
        // The models' calibration is no operator key: refused by name.
        (
            "calibration.toml",
            "[fdi]\nsea-wave-yaw-deg = [0.05, 0.18]\n",
            ["sea-wave-yaw-deg", "sea-wave-yaw-deg"],
        ),
        // An unknown key: named, with no range to give.
        (
            "unknown.toml",
            "[hbt]\nrelay-hight-deg = 5\n",
            ["relay-hight-deg", "relay-hight-deg"],
        ),
    ];
    assert_eq!(ConfigError::EXIT_CODE, 78);
    for (name, text, [key, range]) in bad {
        let (code, err) = check_config(&dir, name, text);
        assert_eq!(code, Some(ConfigError::EXIT_CODE), "{name}: {err}");
        assert!(err.contains(key) && err.contains(range), "{name}: {err}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}
