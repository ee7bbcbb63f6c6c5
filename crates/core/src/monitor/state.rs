//! What a vessel's monitor keeps across a restart ([`VesselState`]): the FDI's memory and the
//! scheduler's. Part of [`Monitor`]; the daemon saves it in its state directory.

use super::Monitor;
use crate::wire::Notification;

/// What a vessel's monitor keeps across a restart: the FDI's memory (alarm tracks, CUSUM,
/// sea memory, the last notification) and the scheduler's (when the last test ended, which
/// method is next, how many tests so far: test ids do not repeat). Saved by the daemon after
/// every decision, restored at start.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct VesselState {
    /// [`VesselState::FORMAT`].
    pub format: String,
    /// The vessel.
    pub vessel: String,
    /// The FDI's memory.
    pub fdi: crate::fdi::FdiState,
    /// End of the last test (ship time) [s].
    pub last_test_end: Option<f64>,
    /// Index of the next scheduled method.
    pub next_method: usize,
    /// Tests started so far.
    pub test_seq: u64,
    /// The sea the next relay is sized for: the wave yaw the last completed test measured
    /// [rad] (absent in states of earlier releases: not known).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sea_wave_yaw_rad: Option<f64>,
    /// The gap the last test asked for under commissioning's added-travel budget [s]
    /// (absent: not known, `scheduler.commissioning-interval-s`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub commissioning_gap_s: Option<f64>,
    /// The next CLFRT test's heading guard is armed (absent: not armed).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub clfrt_heading_guard: bool,
}

impl VesselState {
    /// The format tag of this version.
    pub const FORMAT: &'static str = "helmwatch-vessel-state/1";
}

/// Why a saved state was refused ([`Monitor::restore`]; the daemon logs this text).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum RestoreError {
    /// Another format than [`VesselState::FORMAT`].
    #[error("format `{0}`, expected `{expected}`", expected = VesselState::FORMAT)]
    Format(String),
    /// Saved for another vessel.
    #[error("saved for vessel `{saved}`, not `{this}`")]
    Vessel {
        /// The vessel it was saved for.
        saved: String,
        /// This monitor's vessel.
        this: String,
    },
}

impl Monitor {
    /// What to save after a decision (see [`VesselState`]).
    pub fn saved_state(&self) -> VesselState {
        VesselState {
            format: VesselState::FORMAT.to_string(),
            vessel: self.vessel.clone(),
            fdi: self.fdi.state(),
            last_test_end: self.last_test_end,
            next_method: self.next_method,
            test_seq: self.test_seq,
            sea_wave_yaw_rad: self.sea_wave_yaw_rad,
            commissioning_gap_s: self.commissioning_gap_s,
            clfrt_heading_guard: self.clfrt_heading_guard,
        }
    }

    /// Takes up a saved state (before any sample). Refused, changing nothing, when it is of
    /// another format or another vessel. `Ok(Some(message))` when the commissioning
    /// reference was discarded (made under another ship configuration or other models).
    pub fn restore(&mut self, s: VesselState) -> Result<Option<String>, RestoreError> {
        if s.format != VesselState::FORMAT {
            return Err(RestoreError::Format(s.format));
        }
        if s.vessel != self.vessel {
            return Err(RestoreError::Vessel {
                saved: s.vessel,
                this: self.vessel.clone(),
            });
        }
        let discarded = self.fdi.restore(s.fdi);
        self.last_test_end = s.last_test_end.filter(|t| t.is_finite());
        self.next_method = s.next_method % self.cfg.scheduler.methods.len().max(1);
        self.test_seq = s.test_seq;
        self.sea_wave_yaw_rad = s.sea_wave_yaw_rad.filter(|w| w.is_finite() && *w >= 0.0);
        self.commissioning_gap_s = s.commissioning_gap_s.filter(|g| g.is_finite() && *g >= 0.0);
        self.clfrt_heading_guard = s.clfrt_heading_guard;
        Ok(discarded)
    }

    /// Starts commissioning again for `method`, or both (see `crate::fdi::reference`).
    pub fn commission(&mut self, method: Option<crate::wire::Method>) {
        self.fdi.commission(method);
    }

    /// Per method, the commissioning's progress and reference (JSON, the `fdi/commission`
    /// reply).
    pub fn commissioning_status(&self) -> serde_json::Value {
        serde_json::to_value(self.fdi.commissioning_status()).unwrap_or_default()
    }

    /// Both methods are commissioned (or commissioning is off).
    pub fn commissioned(&self) -> bool {
        self.fdi.commissioned()
    }

    /// A scheduled method's reference is being established (commissioning, or its
    /// confirmation): the scheduler runs at commissioning's cadence (`cadence`).
    pub fn establishing(&self) -> bool {
        (self.cfg.scheduler.methods.iter()).any(|&m| self.fdi.establishing(m))
    }

    /// `method` is commissioned (or commissioning is off).
    pub fn method_commissioned(&self, method: crate::wire::Method) -> bool {
        self.fdi.method_commissioned(method)
    }

    /// "CLFRT commissioning 2 of 5, HBT commissioned (...)".
    pub fn commissioning_text(&self) -> String {
        self.fdi.commissioning_text()
    }

    /// The last alarm notification published, to publish again at once after a restore (an
    /// alarm stays an alarm across a restart).
    pub fn last_notification(&self) -> Option<&Notification> {
        self.fdi.last_notification()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::monitor::config::CoreConfig;

    /// The sea the next relay is sized for survives a restart; a state of an earlier release
    /// (no such key) restores with the sea unknown, and a non-finite one is refused.
    #[test]
    fn the_sea_survives_a_restart_and_old_states_restore() {
        let cfg = CoreConfig::default();
        let mut m = Monitor::new(&cfg, "self");
        let mut s = m.saved_state();
        assert_eq!(s.sea_wave_yaw_rad, None);
        let json = serde_json::to_string(&s).unwrap();
        assert!(!json.contains("sea_wave_yaw_rad"), "{json}");
        let old: VesselState = serde_json::from_str(&json).unwrap();
        assert_eq!(old.sea_wave_yaw_rad, None);
        s.sea_wave_yaw_rad = Some(0.008);
        m.restore(s.clone()).unwrap();
        assert_eq!(m.saved_state().sea_wave_yaw_rad, Some(0.008));
        s.sea_wave_yaw_rad = Some(f64::NAN);
        m.restore(s).unwrap();
        assert_eq!(m.saved_state().sea_wave_yaw_rad, None);
    }

    /// Commissioning's gap (`cadence`) survives a restart; a state without it restores
    /// with none (the most, `commissioning-interval-s`), and a negative or NaN one is refused.
    #[test]
    fn the_commissioning_gap_survives_a_restart() {
        let cfg = CoreConfig::default();
        let mut m = Monitor::new(&cfg, "self");
        let mut s = m.saved_state();
        assert!(!serde_json::to_string(&s)
            .unwrap()
            .contains("commissioning_gap_s"));
        s.commissioning_gap_s = Some(120.0);
        m.restore(s.clone()).unwrap();
        assert_eq!(m.saved_state().commissioning_gap_s, Some(120.0));
        for bad in [-1.0, f64::NAN] {
            s.commissioning_gap_s = Some(bad);
            m.restore(s.clone()).unwrap();
            assert_eq!(m.saved_state().commissioning_gap_s, None);
        }
    }
}
