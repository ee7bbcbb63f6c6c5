//! The state directory (`--state-dir`, systemd `StateDirectory=helmwatch`): what the daemon
//! keeps across a restart.
//!
//! Layout: `<dir>/vessels/<vessel>.json`, one [`VesselState`] per vessel, rewritten after
//! every decision. Every write is atomic: the new text goes to `<file>.tmp`, is flushed to the
//! disk (`fsync`), renamed over the old file, and the directory is flushed, so a crash or a
//! power loss leaves the old state or the new one, never half of one.
//!
//! A file that cannot be read or parsed (truncated, garbage, another format, another vessel)
//! is moved aside to `<file>.corrupt` with a message naming it, and the vessel starts afresh:
//! the daemon keeps monitoring.

use helmwatch_core::monitor::VesselState;
use std::io::Write;
use std::path::{Path, PathBuf};

/// Why the state directory cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum StateError {
    /// The directory cannot be created or written.
    #[error("state directory {path}: {source}")]
    Io {
        /// The path.
        path: String,
        /// The I/O error.
        source: std::io::Error,
    },
    /// A state cannot be serialised.
    #[error("state of vessel {vessel}: {message}")]
    Encode {
        /// The vessel.
        vessel: String,
        /// What failed.
        message: String,
    },
}

/// What loading a vessel's state found.
#[derive(Debug)]
pub enum Loaded {
    /// No state saved yet.
    Fresh,
    /// The saved state.
    State(Box<VesselState>),
    /// The file was unusable: moved aside (the message names it and why).
    Corrupt(String),
}

/// The state directory.
#[derive(Debug, Clone)]
pub struct StateDir {
    vessels: PathBuf,
}

fn io(path: &Path) -> impl FnOnce(std::io::Error) -> StateError + '_ {
    move |source| StateError::Io {
        path: path.display().to_string(),
        source,
    }
}

impl StateDir {
    /// Opens (creating it when missing) the state directory at `path`.
    pub fn open(path: &Path) -> Result<Self, StateError> {
        let vessels = path.join("vessels");
        std::fs::create_dir_all(&vessels).map_err(io(&vessels))?;
        Ok(Self { vessels })
    }

    /// The file of `vessel`'s state.
    pub fn vessel_file(&self, vessel: &str) -> PathBuf {
        self.vessels.join(format!("{vessel}.json"))
    }

    /// Loads `vessel`'s state; an unusable file is moved aside to `<file>.corrupt`.
    pub fn load(&self, vessel: &str) -> Loaded {
        let path = self.vessel_file(vessel);
        let text = match std::fs::read(&path) {
            Ok(t) => t,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Loaded::Fresh,
            Err(e) => return self.corrupt(&path, &format!("cannot be read: {e}")),
        };
        match serde_json::from_slice::<VesselState>(&text) {
            Ok(s) if s.format != VesselState::FORMAT => {
                self.corrupt(&path, &format!("is of format `{}`", s.format))
            }
            Ok(s) if s.vessel != vessel => {
                self.corrupt(&path, &format!("holds vessel `{}`", s.vessel))
            }
            Ok(s) => Loaded::State(Box::new(s)),
            Err(e) => self.corrupt(&path, &format!("does not parse: {e}")),
        }
    }

    fn corrupt(&self, path: &Path, why: &str) -> Loaded {
        let aside = path.with_extension("json.corrupt");
        let moved = match std::fs::rename(path, &aside) {
            Ok(()) => format!("moved to {}", aside.display()),
            Err(e) => format!("could not be moved aside: {e}"),
        };
        Loaded::Corrupt(format!(
            "state file {} {why}; {moved}; the vessel starts with a fresh state",
            path.display()
        ))
    }

    /// Saves `state` atomically (module documentation).
    pub fn save(&self, state: &VesselState) -> Result<(), StateError> {
        let path = self.vessel_file(&state.vessel);
        let text = serde_json::to_vec_pretty(state).map_err(|e| StateError::Encode {
            vessel: state.vessel.clone(),
            message: e.to_string(),
        })?;
        let tmp = path.with_extension("json.tmp");
        {
            let mut f = std::fs::File::create(&tmp).map_err(io(&tmp))?;
            f.write_all(&text).map_err(io(&tmp))?;
            f.sync_all().map_err(io(&tmp))?;
        }
        std::fs::rename(&tmp, &path).map_err(io(&path))?;
        // The rename itself is durable once the directory is.
        std::fs::File::open(&self.vessels)
            .and_then(|d| d.sync_all())
            .map_err(io(&self.vessels))?;
        Ok(())
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use helmwatch_core::monitor::config::CoreConfig;
    use helmwatch_core::monitor::Monitor;

    fn temp(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("helmwatch-state-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        d
    }

    #[test]
    fn saves_atomically_and_loads_back() {
        let d = temp("roundtrip");
        let dir = StateDir::open(&d).unwrap();
        assert!(matches!(dir.load("self"), Loaded::Fresh));
        let m = Monitor::new(&CoreConfig::default(), "self");
        let s = m.saved_state();
        dir.save(&s).unwrap();
        dir.save(&s).unwrap();
        match dir.load("self") {
            Loaded::State(back) => assert_eq!(*back, s),
            other => panic!("{other:?}"),
        }
        assert!(!dir.vessel_file("self").with_extension("json.tmp").exists());
        let _ = std::fs::remove_dir_all(&d);
    }

    #[test]
    fn a_truncated_or_foreign_file_is_moved_aside_with_a_message_naming_it() {
        let d = temp("corrupt");
        let dir = StateDir::open(&d).unwrap();
        let m = Monitor::new(&CoreConfig::default(), "self");
        dir.save(&m.saved_state()).unwrap();
        let file = dir.vessel_file("self");
        let text = std::fs::read(&file).unwrap();
        for bad in [&text[..text.len() / 2], b"\x00\xffgarbage".as_slice(), b""] {
            std::fs::write(&file, bad).unwrap();
            match dir.load("self") {
                Loaded::Corrupt(msg) => {
                    assert!(msg.contains(&file.display().to_string()), "{msg}");
                    assert!(msg.contains("corrupt"), "{msg}");
                }
                other => panic!("{other:?}"),
            }
            assert!(!file.exists());
            assert!(file.with_extension("json.corrupt").exists());
            // Fresh after that.
            assert!(matches!(dir.load("self"), Loaded::Fresh));
        }
        // Another vessel's state under this name.
        let other = Monitor::new(&CoreConfig::default(), "other");
        let mut s = other.saved_state();
        s.vessel = "other".into();
        std::fs::write(&file, serde_json::to_vec(&s).unwrap()).unwrap();
        assert!(matches!(dir.load("self"), Loaded::Corrupt(m) if m.contains("holds vessel")));
        let _ = std::fs::remove_dir_all(&d);
    }
}
