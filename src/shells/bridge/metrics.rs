//! The bridge's metrics: the decoder's counters as OpenMetrics families, read at each scrape.

use helmwatch_core::nmea::{DecodeStats, Reject};
use helmwatch_core::wire::Stream;
use prometheus_client::collector::Collector;
use prometheus_client::encoding::{DescriptorEncoder, EncodeLabelSet, EncodeMetric};
use prometheus_client::metrics::counter::ConstCounter;
use prometheus_client::metrics::MetricType;
use std::sync::{Arc, Mutex};

/// Every metric family of the bridge, as exposed.
pub const METRIC_FAMILIES: [&str; 5] = [
    "helmwatch_bridge_datagrams_total",
    "helmwatch_bridge_lines_total",
    "helmwatch_bridge_ignored_total",
    "helmwatch_bridge_samples_total",
    "helmwatch_bridge_rejected_total",
];

#[derive(Clone, Debug, Hash, PartialEq, Eq, EncodeLabelSet)]
struct VesselLabel {
    vessel: String,
}

#[derive(Clone, Debug, Hash, PartialEq, Eq, EncodeLabelSet)]
struct StreamLabel {
    vessel: String,
    stream: &'static str,
}

#[derive(Clone, Debug, Hash, PartialEq, Eq, EncodeLabelSet)]
struct ReasonLabel {
    vessel: String,
    reason: &'static str,
}

/// The decoder's counters, read at each scrape.
#[derive(Debug)]
pub(super) struct StatsCollector {
    pub(super) vessel: String,
    pub(super) stats: Arc<Mutex<DecodeStats>>,
}

impl Collector for StatsCollector {
    fn encode(&self, mut encoder: DescriptorEncoder) -> Result<(), std::fmt::Error> {
        let s = self.stats.lock().map(|g| g.clone()).unwrap_or_default();
        let vl = VesselLabel {
            vessel: self.vessel.clone(),
        };
        for (name, help, v) in [
            ("bridge_datagrams", "UDP datagrams received", s.datagrams),
            (
                "bridge_lines",
                "NMEA lines looked at (empty lines are not counted)",
                s.lines,
            ),
            (
                "bridge_ignored",
                "Valid sentences the bridge does not use",
                s.ignored,
            ),
        ] {
            let mut f = encoder.encode_descriptor(name, help, None, MetricType::Counter)?;
            ConstCounter::new(v).encode(f.encode_family(&vl)?)?;
        }
        let mut f = encoder.encode_descriptor(
            "bridge_samples",
            "Samples published, by stream",
            None,
            MetricType::Counter,
        )?;
        for st in Stream::REQUIRED {
            let l = StreamLabel {
                vessel: self.vessel.clone(),
                stream: st.name(),
            };
            ConstCounter::new(s.samples[st.index()]).encode(f.encode_family(&l)?)?;
        }
        let mut f = encoder.encode_descriptor(
            "bridge_rejected",
            "Lines rejected, by reason (never published)",
            None,
            MetricType::Counter,
        )?;
        for r in Reject::ALL {
            let l = ReasonLabel {
                vessel: self.vessel.clone(),
                reason: r.name(),
            };
            ConstCounter::new(s.rejected(r)).encode(f.encode_family(&l)?)?;
        }
        Ok(())
    }
}
