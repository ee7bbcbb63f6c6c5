//! The queue gauges (`helmwatch_queue_depth`, `helmwatch_queue_capacity`): a collector that
//! reads the vessels' queues at each scrape.

use super::VesselLabels;
use prometheus_client::collector::Collector;
use prometheus_client::encoding::{DescriptorEncoder, EncodeMetric};
use prometheus_client::metrics::gauge::ConstGauge;
use prometheus_client::metrics::MetricType;

/// The queue gauges, read at each scrape from the vessels' queues (weak: the registry does
/// not keep a stopped vessel's queue open).
pub(super) struct QueueCollector<T> {
    pub(super) queues: Vec<(String, tokio::sync::mpsc::WeakSender<T>)>,
}

impl<T> std::fmt::Debug for QueueCollector<T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("QueueCollector")
            .field("queues", &self.queues.len())
            .finish()
    }
}

impl<T: Send + 'static> Collector for QueueCollector<T> {
    fn encode(&self, mut encoder: DescriptorEncoder) -> Result<(), std::fmt::Error> {
        let sizes: Vec<(VesselLabels, i64, i64)> = self
            .queues
            .iter()
            .filter_map(|(v, q)| {
                let q = q.upgrade()?;
                let max = i64::try_from(q.max_capacity()).unwrap_or(i64::MAX);
                let free = i64::try_from(q.capacity()).unwrap_or(i64::MAX);
                Some((
                    VesselLabels { vessel: v.clone() },
                    max.saturating_sub(free),
                    max,
                ))
            })
            .collect();
        for (name, help, pick) in [
            (
                "queue_depth",
                "Messages waiting in the vessel's input queue.",
                0,
            ),
            (
                "queue_capacity",
                "Capacity of the vessel's input queue (daemon.queue-capacity).",
                1,
            ),
        ] {
            let mut family = encoder.encode_descriptor(name, help, None, MetricType::Gauge)?;
            for (labels, depth, max) in &sizes {
                let v = if pick == 0 { *depth } else { *max };
                ConstGauge::new(v).encode(family.encode_family(labels)?)?;
            }
        }
        Ok(())
    }
}
