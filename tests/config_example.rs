//! The annotated example configuration stays true to the code, and bad configuration is
//! refused with the key, the range and exit code 78.
// A test crate: an unwrap, expect or panic here is the test failing, with its message
// (clippy.toml allows them in `#[test]` functions; the helpers are test code too).
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use helmwatch::config::Config;
use helmwatch::core::config::ConfigError;
use std::path::Path;

#[test]
fn example_config_equals_the_defaults() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("config/helmwatch.example.toml");
    let cfg = Config::from_file(&path).unwrap();
    assert_eq!(cfg, Config::default());
}

#[test]
fn binary_exits_78_naming_the_key_and_range() {
    let dir = std::env::temp_dir().join(format!("helmwatch-cfg-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let bad = dir.join("bad.toml");
    std::fs::write(&bad, "[safety]\nmax-heading-error-deg = 90\n").unwrap();
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_helmwatch"))
        .args(["--config", bad.to_str().unwrap(), "check-config"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(ConfigError::EXIT_CODE));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("safety.max-heading-error-deg") && err.contains("(0, 45]"),
        "{err}"
    );
    // The reference's own-noise learning limit.
    let noise = dir.join("noise.toml");
    std::fs::write(&noise, "[reference]\nlearn-noise-ratio-max = 0.5\n").unwrap();
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_helmwatch"))
        .args(["--config", noise.to_str().unwrap(), "check-config"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(78));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("reference.learn-noise-ratio-max") && err.contains("[1, 1000000]"),
        "{err}"
    );
    let unknown = dir.join("unknown.toml");
    std::fs::write(&unknown, "[hbt]\nrelay-hight-deg = 5\n").unwrap();
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_helmwatch"))
        .args(["--config", unknown.to_str().unwrap(), "check-config"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(78));
    assert!(String::from_utf8_lossy(&out.stderr).contains("relay-hight-deg"));
    let _ = std::fs::remove_dir_all(&dir);
}
