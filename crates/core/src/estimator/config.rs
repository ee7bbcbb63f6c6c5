//! The `[estimator]` section: where the model files come from.

use crate::config::{fail, ConfigError};
use serde::{Deserialize, Serialize};

/// Where the estimator's model files come from (see `crate::estimator`).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(default, deny_unknown_fields, rename_all = "kebab-case")]
pub struct EstimatorConfig {
    /// Attach the estimator to the monitor cores: completed tests carry an `estimate`.
    pub enabled: bool,
    /// Directory of the model files (`clfrt_speed.json`, ...); absent: the models embedded in
    /// the binary (those of the repository's `models/` at build time).
    pub models_dir: Option<String>,
}

impl Default for EstimatorConfig {
    fn default() -> Self {
        Self {
            enabled: true,
            models_dir: None,
        }
    }
}

impl EstimatorConfig {
    /// Checks the section's limits; the error names the key and its allowed range.
    pub fn check(&self) -> Result<(), ConfigError> {
        if let Some(d) = &self.models_dir {
            if d.is_empty() {
                return Err(fail(
                    "estimator.models-dir",
                    "\"\"",
                    "a directory path (leave the key out for the embedded models)",
                ));
            }
        }
        Ok(())
    }
}
