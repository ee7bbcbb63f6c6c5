//! Reading a recording back: whether a file is MCAP, and its replay through the monitor core.

use helmwatch_core::drivers::replay::{Payload, ReplayError, ReplaySummary, Replayer};

/// Whether `head` starts with the MCAP magic bytes.
pub fn is_mcap(head: &[u8]) -> bool {
    head.starts_with(mcap::MAGIC)
}

/// Replays an MCAP recording through the monitor core, message by message in the file's
/// order (the order the daemon handled them); see [`helmwatch_core::drivers::replay`].
pub fn replay_mcap(
    cfg: &helmwatch_core::monitor::config::CoreConfig,
    own: &[(String, helmwatch_core::monitor::config::CoreConfig)],
    reader: impl std::io::Read,
    mut on_output: impl FnMut(&str, &helmwatch_core::monitor::Output),
) -> Result<ReplaySummary, ReplayError> {
    let mut r = Replayer::new(cfg, own)?;
    for message in mcap::io::MessageReader::new(reader) {
        match message {
            Ok(m) => r.feed(&m.channel.topic, Payload::Bytes(&m.data), &mut on_output)?,
            Err(mcap::McapError::Io(e)) => return Err(ReplayError::Io(e)),
            // A file cut short (a crash) ends where it ends; anything else is a bad record.
            Err(e) => {
                tracing::warn!("MCAP recording: {e}");
                r.bad_record();
                break;
            }
        }
    }
    Ok(r.finish())
}
