//! The daemon's metrics: counters, gauges and a histogram per vessel, served as OpenMetrics
//! text over HTTP (`daemon.metrics-listen`, off by default; `GET /metrics`).
//!
//! Each daemon has its own [`Registry`] (several daemons run in one process: the tests, the
//! demo), so nothing here is process-global. Every counter starts at 0 when the daemon
//! starts. The vessel task counts what the core counts, at the same moments (an accepted or
//! rejected sample, a test's start and end, a decision, a notification); the Zenoh callbacks
//! count the flood drops; the queue depth is read from the queue itself at each scrape.
//!
//! | metric | type | labels | what |
//! |---|---|---|---|
//! | `helmwatch_inputs_accepted_total` | counter | vessel, stream | samples the core accepted |
//! | `helmwatch_inputs_rejected_total` | counter | vessel, stream, reason | samples rejected (a series appears at its first rejection) |
//! | `helmwatch_tests_started_total` | counter | vessel, method | tests started |
//! | `helmwatch_tests_total` | counter | vessel, method, outcome | tests ended: `completed`, `aborted` |
//! | `helmwatch_test_aborts_total` | counter | vessel, method, reason | aborted tests by reason code (as in `fdi/stats`; a series appears at its first abort) |
//! | `helmwatch_decisions_total` | counter | vessel, method, decision | reports by decision: `nominal`, `fault`, `inconclusive` |
//! | `helmwatch_alarm_state` | gauge | vessel | 0 normal, 1 alert, 2 warn, 3 alarm |
//! | `helmwatch_queue_depth` | gauge | vessel | messages waiting in the vessel's queue |
//! | `helmwatch_queue_capacity` | gauge | vessel | `daemon.queue-capacity` |
//! | `helmwatch_queue_dropped_total` | counter | vessel | samples dropped because the queue was full (`dropped.flood`) |
//! | `helmwatch_controls_dropped_total` | counter | vessel | trigger and commission requests refused: queue full (`dropped.triggers`) |
//! | `helmwatch_publish_errors_total` | counter | vessel | failed publications |
//! | `helmwatch_replicated_states_refused_total` | counter | vessel | the holder's `fdi/state` refused by this standby (another format, vessel, configuration or models) |
//! | `helmwatch_excitation_latency_seconds` | histogram | vessel | wall time from a heading sample's arrival (the Zenoh callback) to its excitation's publication |

pub mod http;
mod queues;

use helmwatch_core::monitor::input::RejectReason;
use helmwatch_core::wire::{AlarmState, Decision, Method, Outcome, Stream};
use prometheus_client::encoding::EncodeLabelSet;
use prometheus_client::metrics::counter::Counter;
use prometheus_client::metrics::family::Family;
use prometheus_client::metrics::gauge::Gauge;
use prometheus_client::metrics::histogram::{exponential_buckets, Histogram};
use prometheus_client::registry::{Registry, Unit};
use std::time::Duration;

/// The content type of the OpenMetrics text exposition.
pub const CONTENT_TYPE: &str = "application/openmetrics-text; version=1.0.0; charset=utf-8";

/// Every metric family's name, as exposed (counters with their `_total`).
pub const FAMILIES: [&str; 14] = [
    "helmwatch_inputs_accepted_total",
    "helmwatch_inputs_rejected_total",
    "helmwatch_tests_started_total",
    "helmwatch_tests_total",
    "helmwatch_test_aborts_total",
    "helmwatch_decisions_total",
    "helmwatch_alarm_state",
    "helmwatch_queue_depth",
    "helmwatch_queue_capacity",
    "helmwatch_queue_dropped_total",
    "helmwatch_controls_dropped_total",
    "helmwatch_publish_errors_total",
    "helmwatch_replicated_states_refused_total",
    "helmwatch_excitation_latency_seconds",
];

const METHODS: [Method; 2] = [Method::Hbt, Method::Clfrt];
const OUTCOMES: [Outcome; 2] = [Outcome::Completed, Outcome::Aborted];
const DECISIONS: [Decision; 3] = [Decision::Nominal, Decision::Fault, Decision::Inconclusive];

#[derive(Clone, Debug, Hash, PartialEq, Eq, EncodeLabelSet)]
struct VesselLabels {
    vessel: String,
}

#[derive(Clone, Debug, Hash, PartialEq, Eq, EncodeLabelSet)]
struct StreamLabels {
    vessel: String,
    stream: &'static str,
}

#[derive(Clone, Debug, Hash, PartialEq, Eq, EncodeLabelSet)]
struct RejectLabels {
    vessel: String,
    stream: &'static str,
    reason: &'static str,
}

#[derive(Clone, Debug, Hash, PartialEq, Eq, EncodeLabelSet)]
struct MethodLabels {
    vessel: String,
    method: &'static str,
}

#[derive(Clone, Debug, Hash, PartialEq, Eq, EncodeLabelSet)]
struct OutcomeLabels {
    vessel: String,
    method: &'static str,
    outcome: &'static str,
}

#[derive(Clone, Debug, Hash, PartialEq, Eq, EncodeLabelSet)]
struct AbortLabels {
    vessel: String,
    method: &'static str,
    reason: &'static str,
}

#[derive(Clone, Debug, Hash, PartialEq, Eq, EncodeLabelSet)]
struct DecisionLabels {
    vessel: String,
    method: &'static str,
    decision: &'static str,
}

fn outcome_name(o: Outcome) -> &'static str {
    match o {
        Outcome::Completed => "completed",
        Outcome::Aborted => "aborted",
    }
}

fn decision_name(d: Decision) -> &'static str {
    match d {
        Decision::Nominal => "nominal",
        Decision::Fault => "fault",
        Decision::Inconclusive => "inconclusive",
    }
}

/// The gauge value of an alarm state: 0 normal, 1 alert, 2 warn, 3 alarm.
pub fn alarm_level(s: AlarmState) -> i64 {
    match s {
        AlarmState::Normal => 0,
        AlarmState::Alert => 1,
        AlarmState::Warn => 2,
        AlarmState::Alarm => 3,
    }
}

/// Bucket bounds of the excitation latency [s]: 100 us doubling to 3.3 s (16 bounds).
fn latency_histogram() -> Histogram {
    Histogram::new(exponential_buckets(1e-4, 2.0, 16))
}

type LatencyFamily = Family<VesselLabels, Histogram, fn() -> Histogram>;

/// One daemon's metric families and their registry.
#[derive(Debug)]
pub struct Metrics {
    registry: Registry,
    inputs_accepted: Family<StreamLabels, Counter>,
    inputs_rejected: Family<RejectLabels, Counter>,
    tests_started: Family<MethodLabels, Counter>,
    tests: Family<OutcomeLabels, Counter>,
    test_aborts: Family<AbortLabels, Counter>,
    decisions: Family<DecisionLabels, Counter>,
    alarm_state: Family<VesselLabels, Gauge>,
    queue_dropped: Family<VesselLabels, Counter>,
    controls_dropped: Family<VesselLabels, Counter>,
    publish_errors: Family<VesselLabels, Counter>,
    states_refused: Family<VesselLabels, Counter>,
    excitation_latency: LatencyFamily,
}

impl Default for Metrics {
    fn default() -> Self {
        Self::new()
    }
}

impl Metrics {
    /// Empty families, registered under the prefix `helmwatch`.
    pub fn new() -> Self {
        let mut m = Self {
            registry: Registry::with_prefix("helmwatch"),
            inputs_accepted: Family::default(),
            inputs_rejected: Family::default(),
            tests_started: Family::default(),
            tests: Family::default(),
            test_aborts: Family::default(),
            decisions: Family::default(),
            alarm_state: Family::default(),
            queue_dropped: Family::default(),
            controls_dropped: Family::default(),
            publish_errors: Family::default(),
            states_refused: Family::default(),
            excitation_latency: Family::new_with_constructor(latency_histogram as fn() -> _),
        };
        m.registry.register(
            "inputs_accepted",
            "Samples the monitor core accepted, by input stream",
            m.inputs_accepted.clone(),
        );
        m.registry.register(
            "inputs_rejected",
            "Samples rejected, by input stream and reason (malformed, not_finite, out_of_range, out_of_order, duplicate, time_jump)",
            m.inputs_rejected.clone(),
        );
        m.registry.register(
            "tests_started",
            "Tests started, by method",
            m.tests_started.clone(),
        );
        m.registry.register(
            "tests",
            "Tests ended, by method and outcome (completed, aborted)",
            m.tests.clone(),
        );
        m.registry.register(
            "test_aborts",
            "Aborted tests, by method and abort reason code",
            m.test_aborts.clone(),
        );
        m.registry.register(
            "decisions",
            "Reports by method and decision (nominal, fault, inconclusive)",
            m.decisions.clone(),
        );
        m.registry.register(
            "alarm_state",
            "The vessel's alarm state: 0 normal, 1 alert, 2 warn, 3 alarm",
            m.alarm_state.clone(),
        );
        m.registry.register(
            "queue_dropped",
            "Samples dropped because the vessel's input queue was full (flood)",
            m.queue_dropped.clone(),
        );
        m.registry.register(
            "controls_dropped",
            "Trigger and commission requests refused because the vessel's queue was full",
            m.controls_dropped.clone(),
        );
        m.registry.register(
            "publish_errors",
            "Publications that failed",
            m.publish_errors.clone(),
        );
        m.registry.register(
            "replicated_states_refused",
            "States published by the vessel's holder that this standby refused (another format, vessel, configuration or models)",
            m.states_refused.clone(),
        );
        m.registry.register_with_unit(
            "excitation_latency",
            "Wall time from a heading sample's arrival to the publication of its excitation",
            Unit::Seconds,
            m.excitation_latency.clone(),
        );
        m
    }

    /// The handles of one vessel's metrics; its series exist (at 0) from now on, except the
    /// rejections and aborts, which appear at their first occurrence.
    pub fn vessel(&self, name: &str) -> VesselMetrics {
        let v = || name.to_string();
        let vl = VesselLabels { vessel: v() };
        let accepted = Stream::BY_INDEX.map(|s| {
            self.inputs_accepted.get_or_create_owned(&StreamLabels {
                vessel: v(),
                stream: s.name(),
            })
        });
        let started = METHODS.map(|m| {
            self.tests_started.get_or_create_owned(&MethodLabels {
                vessel: v(),
                method: m.name(),
            })
        });
        let tests = METHODS.map(|m| {
            OUTCOMES.map(|o| {
                self.tests.get_or_create_owned(&OutcomeLabels {
                    vessel: v(),
                    method: m.name(),
                    outcome: outcome_name(o),
                })
            })
        });
        let decisions = METHODS.map(|m| {
            DECISIONS.map(|d| {
                self.decisions.get_or_create_owned(&DecisionLabels {
                    vessel: v(),
                    method: m.name(),
                    decision: decision_name(d),
                })
            })
        });
        VesselMetrics {
            vessel: v(),
            accepted,
            rejected: self.inputs_rejected.clone(),
            started,
            tests,
            aborts: self.test_aborts.clone(),
            decisions,
            alarm: self.alarm_state.get_or_create_owned(&vl),
            queue_dropped: self.queue_dropped.get_or_create_owned(&vl),
            controls_dropped: self.controls_dropped.get_or_create_owned(&vl),
            publish_errors: self.publish_errors.get_or_create_owned(&vl),
            states_refused: self.states_refused.get_or_create_owned(&vl),
            latency: self.excitation_latency.get_or_create_owned(&vl),
        }
    }

    /// Adds the queue gauges (`helmwatch_queue_depth`, `helmwatch_queue_capacity`), read
    /// from `queues` at each scrape.
    pub fn register_queues<T: Send + 'static>(
        &mut self,
        queues: Vec<(String, tokio::sync::mpsc::WeakSender<T>)>,
    ) {
        self.registry
            .register_collector(Box::new(queues::QueueCollector { queues }));
    }

    /// The registry, for [`http::serve`] and [`encode`].
    pub fn into_registry(self) -> Registry {
        self.registry
    }
}

/// The OpenMetrics text exposition of `registry` (ends with `# EOF`).
pub fn encode(registry: &Registry) -> String {
    let mut out = String::new();
    if let Err(e) = prometheus_client::encoding::text::encode(&mut out, registry) {
        tracing::warn!("encoding the metrics: {e}");
    }
    out
}

/// One vessel's metric handles (clones of the registered series: updating one is an atomic
/// add, no lookup).
#[derive(Debug, Clone)]
pub struct VesselMetrics {
    vessel: String,
    /// In [`Stream::index`] order.
    accepted: [Counter; 6],
    rejected: Family<RejectLabels, Counter>,
    started: [Counter; 2],
    tests: [[Counter; 2]; 2],
    aborts: Family<AbortLabels, Counter>,
    decisions: [[Counter; 3]; 2],
    alarm: Gauge,
    queue_dropped: Counter,
    controls_dropped: Counter,
    publish_errors: Counter,
    states_refused: Counter,
    latency: Histogram,
}

fn method_index(m: Method) -> usize {
    match m {
        Method::Hbt => 0,
        Method::Clfrt => 1,
    }
}

impl VesselMetrics {
    /// A sample accepted on `stream`.
    pub fn accepted(&self, stream: Stream) {
        self.accepted[stream.index()].inc();
    }

    /// A sample rejected on `stream` for `reason`.
    pub fn rejected(&self, stream: Stream, reason: RejectReason) {
        self.rejected
            .get_or_create(&RejectLabels {
                vessel: self.vessel.clone(),
                stream: stream.name(),
                reason: reason.name(),
            })
            .inc();
    }

    /// A test of `method` started.
    pub fn test_started(&self, method: Method) {
        self.started[method_index(method)].inc();
    }

    /// A test of `method` ended with `outcome` and `decision`; `abort_codes`: the reason
    /// codes counted for it (one for an aborted test).
    pub fn test_ended(
        &self,
        method: Method,
        outcome: Outcome,
        decision: Decision,
        abort_codes: impl IntoIterator<Item = (&'static str, u64)>,
    ) {
        let m = method_index(method);
        let o = OUTCOMES.iter().position(|x| *x == outcome).unwrap_or(0);
        let d = DECISIONS.iter().position(|x| *x == decision).unwrap_or(2);
        self.tests[m][o].inc();
        self.decisions[m][d].inc();
        for (code, n) in abort_codes {
            self.aborts
                .get_or_create(&AbortLabels {
                    vessel: self.vessel.clone(),
                    method: method.name(),
                    reason: code,
                })
                .inc_by(n);
        }
    }

    /// The vessel's alarm state now.
    pub fn alarm(&self, state: AlarmState) {
        self.alarm.set(alarm_level(state));
    }

    /// A sample dropped at a full queue; returns the count so far.
    pub fn queue_dropped(&self) -> u64 {
        self.queue_dropped.inc() + 1
    }

    /// Samples dropped at a full queue so far.
    pub fn queue_dropped_count(&self) -> u64 {
        self.queue_dropped.get()
    }

    /// A control request refused at a full queue.
    pub fn control_dropped(&self) {
        self.controls_dropped.inc();
    }

    /// Control requests refused so far.
    pub fn controls_dropped_count(&self) -> u64 {
        self.controls_dropped.get()
    }

    /// A failed publication.
    pub fn publish_error(&self) {
        self.publish_errors.inc();
    }

    /// A replicated state refused.
    pub fn state_refused(&self) {
        self.states_refused.inc();
    }

    /// An excitation published `latency` after its heading arrived.
    pub fn excitation_latency(&self, latency: Duration) {
        self.latency.observe(latency.as_secs_f64());
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `(name, labels, value)` of every sample line of an exposition; `# ` lines skipped.
    fn samples(text: &str) -> Vec<(String, String, f64)> {
        text.lines()
            .filter(|l| !l.starts_with('#') && !l.is_empty())
            .map(|l| {
                let (series, value) = l.rsplit_once(' ').unwrap();
                let (name, labels) = match series.split_once('{') {
                    Some((n, rest)) => (n, rest.trim_end_matches('}')),
                    None => (series, ""),
                };
                (name.to_string(), labels.to_string(), value.parse().unwrap())
            })
            .collect()
    }

    #[test]
    fn exposition_parses_and_holds_every_documented_family() {
        let mut m = Metrics::new();
        let (tx, _rx) = tokio::sync::mpsc::channel::<u8>(16);
        tx.try_send(1).unwrap();
        tx.try_send(2).unwrap();
        m.register_queues(vec![("self".to_string(), tx.downgrade())]);
        let v = m.vessel("self");
        v.accepted(Stream::Heading);
        v.accepted(Stream::Heading);
        v.accepted(Stream::Rudder);
        v.rejected(Stream::Heading, RejectReason::Duplicate);
        v.test_started(Method::Hbt);
        v.test_ended(
            Method::Hbt,
            Outcome::Aborted,
            Decision::Inconclusive,
            [("heading_error", 1)],
        );
        v.alarm(AlarmState::Warn);
        v.queue_dropped();
        v.control_dropped();
        v.publish_error();
        v.excitation_latency(Duration::from_micros(150));
        v.excitation_latency(Duration::from_millis(20));
        let text = encode(&m.into_registry());
        assert!(text.ends_with("# EOF\n"), "{text}");
        // Every documented family has its TYPE line and at least one sample.
        let s = samples(&text);
        for family in FAMILIES {
            let base = family.trim_end_matches("_total");
            assert!(
                text.contains(&format!("# TYPE {base} ")),
                "{family} has no TYPE line:\n{text}"
            );
            assert!(
                s.iter().any(|(n, _, _)| n.starts_with(base)),
                "{family} has no sample:\n{text}"
            );
        }
        // Every sample line is `name{labels} value` with a vessel label.
        assert!(s.len() > 30, "{}", s.len());
        assert!(s.iter().all(|(_, l, _)| l.contains("vessel=\"self\"")));
        let get = |name: &str, labels: &str| -> f64 {
            s.iter()
                .find(|(n, l, _)| n == name && l == labels)
                .map(|x| x.2)
                .unwrap_or_else(|| panic!("no {name}{{{labels}}} in\n{text}"))
        };
        let ia = "helmwatch_inputs_accepted_total";
        assert_eq!(get(ia, r#"vessel="self",stream="heading""#), 2.0);
        assert_eq!(get(ia, r#"vessel="self",stream="rudder""#), 1.0);
        assert_eq!(get(ia, r#"vessel="self",stream="speed""#), 0.0);
        assert_eq!(
            get(
                "helmwatch_inputs_rejected_total",
                r#"vessel="self",stream="heading",reason="duplicate""#
            ),
            1.0
        );
        let t = "helmwatch_tests_total";
        assert_eq!(
            get(t, r#"vessel="self",method="hbt",outcome="aborted""#),
            1.0
        );
        assert_eq!(
            get(t, r#"vessel="self",method="clfrt",outcome="completed""#),
            0.0
        );
        assert_eq!(
            get(
                "helmwatch_test_aborts_total",
                r#"vessel="self",method="hbt",reason="heading_error""#
            ),
            1.0
        );
        assert_eq!(
            get(
                "helmwatch_decisions_total",
                r#"vessel="self",method="hbt",decision="inconclusive""#
            ),
            1.0
        );
        assert_eq!(get("helmwatch_alarm_state", r#"vessel="self""#), 2.0);
        assert_eq!(get("helmwatch_queue_depth", r#"vessel="self""#), 2.0);
        assert_eq!(get("helmwatch_queue_capacity", r#"vessel="self""#), 16.0);
        let h = "helmwatch_excitation_latency_seconds";
        assert_eq!(get(&format!("{h}_count"), r#"vessel="self""#), 2.0);
        let sum = get(&format!("{h}_sum"), r#"vessel="self""#);
        assert!((sum - 0.02015).abs() < 1e-9, "{sum}");
        // 150 us lies in (100 us, 200 us]; 20 ms in (12.8 ms, 25.6 ms].
        assert_eq!(
            get(&format!("{h}_bucket"), r#"le="0.0001",vessel="self""#),
            0.0
        );
        assert_eq!(
            get(&format!("{h}_bucket"), r#"le="0.0002",vessel="self""#),
            1.0
        );
        assert_eq!(
            get(&format!("{h}_bucket"), r#"le="0.0128",vessel="self""#),
            1.0
        );
        assert_eq!(
            get(&format!("{h}_bucket"), r#"le="0.0256",vessel="self""#),
            2.0
        );
        assert_eq!(
            get(&format!("{h}_bucket"), r#"le="+Inf",vessel="self""#),
            2.0
        );
    }

    #[test]
    fn two_registries_count_apart() {
        let a = Metrics::new();
        let b = Metrics::new();
        a.vessel("self").accepted(Stream::Heading);
        let _ = b.vessel("self");
        let text = encode(&b.into_registry());
        assert!(
            text.contains(
                "helmwatch_inputs_accepted_total{vessel=\"self\",stream=\"heading\"} 0\n"
            ),
            "{text}"
        );
    }
}
