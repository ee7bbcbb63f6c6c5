//! Logging: to the systemd journal with structured fields when standard error is the
//! journal, else plain text on standard error.
//!
//! systemd tells a service that its standard error is connected to the journal by the
//! environment variable `JOURNAL_STREAM=<device>:<inode>` (decimal) of that stream
//! (systemd.exec(5)); a child started from the service's shell inherits the variable but not
//! necessarily the stream, so the device and inode of our own standard error must match it
//! ([`stderr_is_journal`], a pure function of both). Then every event goes to journald through
//! `tracing-journald`: the message as `MESSAGE`, the level as `PRIORITY`, each field as
//! `F_<NAME>` (`F_VESSEL`, `F_STATE`, ...), the module as `TARGET`, identifier `helmwatch`.
//! If journald cannot be reached, logging falls back to standard error with a warning.

use tracing_subscriber::layer::SubscriberExt;
use tracing_subscriber::util::SubscriberInitExt;

/// Whether standard error is the journal: `journal_stream` (the value of `JOURNAL_STREAM`)
/// is `<device>:<inode>` in decimal and equals standard error's `(device, inode)`.
pub fn stderr_is_journal(journal_stream: Option<&str>, stderr: Option<(u64, u64)>) -> bool {
    let (Some(value), Some((dev, ino))) = (journal_stream, stderr) else {
        return false;
    };
    let Some((d, i)) = value.trim().split_once(':') else {
        return false;
    };
    matches!((d.parse::<u64>(), i.parse::<u64>()), (Ok(d), Ok(i)) if d == dev && i == ino)
}

/// Standard error's device and inode, if it is open.
fn stderr_dev_ino() -> Option<(u64, u64)> {
    use std::os::fd::AsFd;
    use std::os::unix::fs::MetadataExt;
    let fd = std::io::stderr().as_fd().try_clone_to_owned().ok()?;
    let meta = std::fs::File::from(fd).metadata().ok()?;
    Some((meta.dev(), meta.ino()))
}

/// Starts logging with `filter`: the journal when standard error is the journal (see the
/// module documentation), standard error otherwise.
pub fn init(filter: tracing_subscriber::EnvFilter) {
    let env = std::env::var("JOURNAL_STREAM").ok();
    let mut journal_error = None;
    if stderr_is_journal(env.as_deref(), stderr_dev_ino()) {
        match tracing_journald::layer() {
            Ok(layer) => {
                let layer = layer.with_syslog_identifier("helmwatch".to_string());
                let _ = tracing_subscriber::registry()
                    .with(filter)
                    .with(layer)
                    .try_init();
                return;
            }
            Err(e) => journal_error = Some(e),
        }
    }
    let _ = tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        .try_init();
    if let Some(e) = journal_error {
        tracing::warn!("cannot log to the journal ({e}): logging to standard error");
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn journal_stream_must_name_our_stderr() {
        let ours = Some((64769, 123456));
        assert!(stderr_is_journal(Some("64769:123456"), ours));
        // Inherited from a service by a child whose stderr is elsewhere.
        assert!(!stderr_is_journal(Some("64769:123457"), ours));
        assert!(!stderr_is_journal(Some("64768:123456"), ours));
        // Not under systemd, or stderr closed.
        assert!(!stderr_is_journal(None, ours));
        assert!(!stderr_is_journal(Some("64769:123456"), None));
        // Malformed values.
        for bad in [
            "",
            ":",
            "64769",
            "64769:",
            ":123456",
            "x:123456",
            "64769:12x",
            "-1:123456",
        ] {
            assert!(!stderr_is_journal(Some(bad), ours), "{bad:?}");
        }
        // Large device numbers (st_dev is 64 bits) and a trailing newline.
        let big = Some((u64::MAX, 1));
        assert!(stderr_is_journal(Some(&format!("{}:1\n", u64::MAX)), big));
    }

    #[test]
    fn our_stderr_has_a_device_and_inode() {
        // Whatever stderr is under the test runner (a pipe, a file, a terminal), it is open.
        assert!(stderr_dev_ino().is_some());
    }
}
