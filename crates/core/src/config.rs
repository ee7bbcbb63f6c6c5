//! Configuration machinery shared by every section: the error that names a key and its
//! allowed range (exit code 78), the range checks, and the vessel-name rule.
//!
//! Each section of the file is defined beside the code that owns it (see
//! docs/architecture.md); the file as a whole is [`crate::config::Config`].

/// A name that is none of the allowed ones (a method, a sea state, a command-line choice),
/// from a `FromStr`: "unknown {what} `{got}`: allowed {allowed}".
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("unknown {what} `{got}`: allowed {allowed}")]
pub struct UnknownName {
    /// What was named (`method`, `sea state`, ...).
    pub what: &'static str,
    /// The name given.
    pub got: String,
    /// The allowed names, as the message lists them.
    pub allowed: &'static str,
}

impl UnknownName {
    /// `got` is no `what`; `allowed` lists the names.
    pub fn new(what: &'static str, got: &str, allowed: &'static str) -> Self {
        Self {
            what,
            got: got.to_string(),
            allowed,
        }
    }
}

/// A configuration value outside its allowed range, or a file that does not parse.
#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    /// A key holds a value outside its allowed range.
    #[error("configuration key `{key}` = {value}: allowed {allowed}")]
    OutOfRange {
        /// Dotted path of the key, e.g. `servo.max-rate-deg-s`.
        key: String,
        /// The offending value, as text.
        value: String,
        /// The allowed range or set, as text.
        allowed: String,
    },
    /// The file is not valid TOML for this schema (unknown key, wrong type...).
    #[error("configuration does not parse: {0}")]
    Parse(String),
    /// The file cannot be read.
    #[error("cannot read configuration file {path}: {source}")]
    Io {
        /// The path given.
        path: String,
        /// The I/O error.
        source: std::io::Error,
    },
}

impl ConfigError {
    /// The sysexits code for configuration errors (`EX_CONFIG`).
    pub const EXIT_CODE: i32 = 78;
}

/// Checks `lo <= v <= hi` (and finiteness), naming `key` on failure.
pub fn check_range(key: &str, v: f64, lo: f64, hi: f64) -> Result<(), ConfigError> {
    if v.is_finite() && v >= lo && v <= hi {
        Ok(())
    } else {
        Err(ConfigError::OutOfRange {
            key: key.to_string(),
            value: format!("{v}"),
            allowed: format!("[{lo}, {hi}]"),
        })
    }
}

/// Checks `lo < v <= hi` (and finiteness), naming `key` on failure.
pub fn check_range_open_low(key: &str, v: f64, lo: f64, hi: f64) -> Result<(), ConfigError> {
    if v.is_finite() && v > lo && v <= hi {
        Ok(())
    } else {
        Err(ConfigError::OutOfRange {
            key: key.to_string(),
            value: format!("{v}"),
            allowed: format!("({lo}, {hi}]"),
        })
    }
}

/// Checks `lo <= v <= hi` for a count, naming `key` on failure.
pub fn check_count(key: &str, v: u32, lo: u32, hi: u32) -> Result<(), ConfigError> {
    if v >= lo && v <= hi {
        Ok(())
    } else {
        Err(ConfigError::OutOfRange {
            key: key.to_string(),
            value: v.to_string(),
            allowed: format!("integer in [{lo}, {hi}]"),
        })
    }
}

/// An out-of-range error for `key` with `value` and the `allowed` range or set.
pub fn fail(key: &str, value: impl std::fmt::Display, allowed: &str) -> ConfigError {
    ConfigError::OutOfRange {
        key: key.to_string(),
        value: value.to_string(),
        allowed: allowed.to_string(),
    }
}
/// One degree [rad].
pub const DEG: f64 = std::f64::consts::PI / 180.0;

/// A vessel name must be one non-empty Zenoh key chunk: no `/`, `*`, `$`, `#`, `?`, spaces.
pub fn check_vessel_name(key: &str, name: &str) -> Result<(), ConfigError> {
    let ok = !name.is_empty()
        && name.len() <= 64
        && name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_' || c == '.');
    if ok {
        Ok(())
    } else {
        Err(fail(
            key,
            format!("{name:?}"),
            "1 to 64 characters among A-Z a-z 0-9 - _ .",
        ))
    }
}
