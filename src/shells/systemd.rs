//! The service manager: `READY=1`, `STOPPING=1` and the watchdog (systemd `Type=notify`), and
//! the signals that stop the daemon. Every call is a no-op outside systemd.

use sd_notify::NotifyState;

/// Tells systemd the service is ready, with a status line.
pub fn ready(status: &str) {
    if let Err(e) = sd_notify::notify(&[NotifyState::Ready, NotifyState::Status(status)]) {
        tracing::warn!("sd_notify READY: {e}");
    }
}

/// Tells systemd the service is stopping.
pub fn stopping() {
    let _ = sd_notify::notify(&[NotifyState::Stopping]);
}

/// Feeds the watchdog, when systemd enabled one, from the calling runtime at half its period:
/// a stuck runtime stops feeding it and systemd restarts the service. Abort the returned task
/// at shutdown.
pub fn spawn_watchdog() -> Option<tokio::task::JoinHandle<()>> {
    sd_notify::watchdog_enabled().map(|period| {
        tracing::info!(?period, "systemd watchdog enabled");
        tokio::spawn(async move {
            let mut i = tokio::time::interval(period / 2);
            loop {
                i.tick().await;
                let _ = sd_notify::notify(&[NotifyState::Watchdog]);
            }
        })
    })
}

/// Completes on SIGTERM or SIGINT.
pub async fn signals() {
    use tokio::signal::unix::{signal, SignalKind};
    match signal(SignalKind::terminate()) {
        Ok(mut term) => {
            tokio::select! {
                _ = term.recv() => tracing::info!("SIGTERM received"),
                _ = tokio::signal::ctrl_c() => tracing::info!("SIGINT received"),
            }
        }
        Err(e) => {
            tracing::warn!("cannot watch SIGTERM ({e}); SIGINT only");
            let _ = tokio::signal::ctrl_c().await;
        }
    }
}
