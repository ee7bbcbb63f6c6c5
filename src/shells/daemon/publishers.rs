//! The publishers of one vessel: the contract's outputs, its state for the standbys and the
//! daemon's statistics, each declared once with its quality of service.

use super::DaemonError;
use helmwatch_core::wire::Keys;
use zenoh::bytes::Encoding;
use zenoh::pubsub::Publisher;
use zenoh::qos::{CongestionControl, Priority};

/// The publishers of one vessel, declared once.
pub(super) struct Publishers {
    pub(super) excitation: Publisher<'static>,
    pub(super) status: Publisher<'static>,
    pub(super) report: Publisher<'static>,
    pub(super) notification: Publisher<'static>,
    pub(super) stats: Option<Publisher<'static>>,
    /// `fdi/state`: the vessel's state for the standbys.
    pub(super) state: Publisher<'static>,
}

impl Publishers {
    pub(super) async fn declare(
        session: &zenoh::Session,
        keys: &Keys,
        stats: bool,
    ) -> Result<Self, DaemonError> {
        let json = || Encoding::APPLICATION_JSON;
        // Declared key expressions travel as numeric ids and let the receivers cache routes.
        let excitation_key = keys.excitation();
        let ke = session
            .declare_keyexpr(excitation_key.clone())
            .await
            .map_err(DaemonError::declare("key expression", &excitation_key))?;
        let excitation = session
            .declare_publisher(ke)
            .encoding(json())
            .congestion_control(CongestionControl::Block)
            .priority(Priority::RealTime)
            .express(true)
            .await
            .map_err(DaemonError::declare("publisher", &excitation_key))?;
        let reliable = |key: String, priority: Priority| {
            session
                .declare_publisher(key)
                .encoding(json())
                .congestion_control(CongestionControl::Block)
                .priority(priority)
        };
        let k = keys.status();
        let status = reliable(k.clone(), Priority::Data)
            .await
            .map_err(DaemonError::declare("publisher", &k))?;
        let k = keys.report();
        let report = reliable(k.clone(), Priority::Data)
            .await
            .map_err(DaemonError::declare("publisher", &k))?;
        let k = keys.notification();
        let notification = reliable(k.clone(), Priority::DataHigh)
            .await
            .map_err(DaemonError::declare("publisher", &k))?;
        let k = keys.state();
        let state = reliable(k.clone(), Priority::Data)
            .await
            .map_err(DaemonError::declare("publisher", &k))?;
        let stats = if stats {
            let k = stats_key(keys);
            Some(
                session
                    .declare_publisher(k.clone())
                    .encoding(json())
                    .congestion_control(CongestionControl::Drop)
                    .priority(Priority::DataLow)
                    .await
                    .map_err(DaemonError::declare("publisher", &k))?,
            )
        } else {
            None
        };
        Ok(Self {
            excitation,
            status,
            report,
            notification,
            stats,
            state,
        })
    }
}

/// `vessels/<v>/fdi/stats`: the daemon's counters for one vessel (an addition to the contract).
pub fn stats_key(keys: &Keys) -> String {
    format!("{}/fdi/stats", keys.prefix)
}
