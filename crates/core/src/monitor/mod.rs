//! The monitor core: a pure state machine, one per vessel, fed timestamped samples.
//!
//! ## Driving it (the order a driver follows, as in quinn-proto)
//!
//! 1. Decode each incoming payload ([`crate::wire::decode`]); on a decode error call
//!    [`Monitor::count_malformed`]; otherwise call [`Monitor::handle_input`].
//! 2. After every call, drain [`Monitor::poll_output`] until `None` and publish each output on
//!    its key. Every accepted heading sample yields exactly one [`Output::Excitation`] with the
//!    same `t` (the autopilot's heartbeat), so drain promptly: the autopilot waits for it.
//! 3. Call [`Monitor::trigger`] for the `fdi/trigger` queryable; its reply is immediate.
//! 4. When no heading arrives, call [`Monitor::handle_timeout`] with the driver's estimate of
//!    ship time (last heading `t` plus elapsed wall time) so a silent stream aborts a test.
//!
//! The core never reads a clock: all time is the ship time carried by the samples. It never
//! draws random numbers either (the multisine phases come from a seeded design). Given the
//! same inputs it gives the same outputs, bit for bit.
//!
//! ## States (published on `fdi/status` at every change)
//!
//! `idle -> settling -> exciting -> analysing -> idle`; any state -> `idle` on abort.
//! - HBT: settling = trim measurement (autopilot steering, mean rudder = delta0) and the first
//!   `hbt.settle-periods` relay periods (counted again after the relay sizing lowers h and
//!   eps, `hbt.resize-*`); exciting = `hbt.measure-periods` periods measured
//!   between switches to `+h`; analysing = features, then the relay runs on until the
//!   hand-back instant (`hbt.handback-lead-s`), then the report.
//! - CLFRT: settling = `clfrt.settle-windows` windows: the servo check (a 0.6 rad/s sinusoid,
//!   ~2 min) then the faded-in multisine; exciting =
//!   `clfrt.measure-windows` windows recorded; analysing = features, then the excitation ramps
//!   to zero at the safety rate limit, then the report.
//!
//! ## Estimate
//!
//! A completed test's `features` also carry `speed_log_mps`, the mean of the speed-log
//! samples received from the test's start to its end (settling included): the measured speed
//! that the displacement network reads, defined once here for the daemon and the training
//! database alike. When the monitor was built with an estimator
//! ([`Monitor::with_estimator`]), the report's `estimate` holds the networks' speed and
//! displacement ([`crate::estimator`]), and [`crate::fdi`] turns them into the report's
//! `residuals`, `decision` and `isolation`, and queues a notification when the vessel's alarm
//! state changes (after the report). Every completed
//! test's `features` also carry `baseline`, the time-domain least-squares a and b on the
//! same records ([`crate::baseline`]; `null` and `baseline_error` when that fit failed).
//!
//! ## Safety (checked at every heading sample of a test; an abort sends `mode: none` at once)
//!
//! Autopilot not in `auto`; |heading error| over `safety.max-heading-error-deg`; |rudder| at
//! `safety.rudder-saturation-deg`; any stream silent longer than `safety.stream-timeout-s`;
//! smoothed speed off its start value by more than `safety.max-speed-change-mps`; the target
//! course changed; the test longer than `safety.max-test-duration-s`; a record full (flood).
//! Every excitation passes a final gate that bounds its value (`safety.max-excitation-deg`
//! around zero for `add`, around the trim for `replace`, and the servo's angle limit) and, for
//! `add`, its rate (`safety.max-excitation-rate-deg-s`). Every abort is an [`AbortReason`];
//! [`Stats::aborts`] counts them by kind.
//!
//! ## Files
//!
//! | file | what |
//! |---|---|
//! | `mod.rs` | the state machine: its state, triggers, the start of a test |
//! | `feed.rs` | each sample's way in: validation, clock steps, the streams' handlers, silence |
//! | `run.rs` | a test under way: its steps, its end (report, decision), the outputs, shutdown |
//! | `safety.rs` | preconditions, steady course, the safety checks, the excitation gate |
//! | `hbt.rs`, `hbt_analysis.rs` | HBT's relay run; its analysis and typed features |
//! | `clfrt.rs`, `clfrt_servo_check.rs` | CLFRT's run, analysis and typed features; its servo check |
//! | `sizing.rs`, `sizing_relay.rs` | the excitation sized to the loop: CLFRT's tones; HBT's relay |
//! | `input.rs`, `record.rs` | input validation and counters; bounded test records |
//! | `abort.rs` | why a test stopped |
//! | `state.rs` | what a vessel's monitor keeps across a restart |
//! | `config.rs` | the monitor's sections and [`CoreConfig`] |

pub mod abort;
pub mod cadence;
mod clfrt;
pub mod config;
mod feed;
mod hbt;
pub mod input;
pub mod record;
mod run;
mod safety;
mod sizing;
mod state;

use crate::angle::wrap_pi;
use crate::dsp::multisine::Multisine;
use crate::estimator::{Estimator, EstimatorScratch};
use crate::fdi::Fdi;
use crate::monitor::config::CoreConfig;
use crate::timeline::{Clocks, Order};
use crate::wire::Method;
use crate::wire::{
    Decision, Excitation, ExcitationMode, Features, Input, MonitorState, Notification, Outcome,
    Report, Status, Stream, TriggerReply,
};
pub use abort::{AbortCounts, AbortReason};
use input::{Counters, Latest, Limits, RejectReason, Rejection};
pub use state::{RestoreError, VesselState};
use std::collections::VecDeque;
use std::sync::Arc;

/// Something the driver publishes.
#[derive(Debug, Clone, PartialEq)]
pub enum Output {
    /// On `steering/autopilot/excitation`; one per accepted heading sample.
    Excitation(Excitation),
    /// On `fdi/status`, at every change of state.
    Status(Status),
    /// On `fdi/report`, after every test.
    Report(Box<Report>),
    /// On `notifications/steering/fdi`, when the alarm state changes.
    Notification(Notification),
    /// The resampled series a completed test's analysis used, just before its report; only
    /// when asked for ([`Monitor::set_analysis_output`]: recordings). Not on the wire.
    Analysis(Box<AnalysisRecord>),
}

/// The records one completed test's analysis used, on its uniform grid `t0_s + i dt_s`.
///
/// `heading_rad` is the continuous (unwrapped) heading, `rudder_rad` the measured rudder,
/// both resampled by linear interpolation (the alignment by `t`); `excitation_rad` is, for
/// CLFRT, the multisine reference the tone analysis used and, for HBT, the relay command the
/// monitor sent, held from one excitation to the next. The HBT rudder may be shorter than the
/// heading (the span both records cover).
#[derive(Debug, Clone, PartialEq)]
pub struct AnalysisRecord {
    /// The test's id.
    pub test: String,
    /// Its method.
    pub method: Method,
    /// First grid time (ship time) [s].
    pub t0_s: f64,
    /// Grid step [s].
    pub dt_s: f64,
    /// Continuous heading on the grid [rad].
    pub heading_rad: Vec<f64>,
    /// Rudder on the grid [rad].
    pub rudder_rad: Vec<f64>,
    /// Excitation on the grid [rad].
    pub excitation_rad: Vec<f64>,
}

impl AnalysisRecord {
    /// Number of grid points every series covers.
    pub fn len(&self) -> usize {
        self.heading_rad
            .len()
            .min(self.rudder_rad.len())
            .min(self.excitation_rad.len())
    }

    /// Whether no grid point has all three series.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// What a finished test measured, by method: the analysis, from which the report's typed
/// [`Features`] are drawn.
#[derive(Debug, Clone, PartialEq)]
pub enum Measured {
    /// Relay test analysis.
    Hbt(HbtReport),
    /// Multisine test analysis.
    Clfrt(clfrt::ClfrtReport),
}

impl Measured {
    /// The report's `features` (without `speed_log_mps`, which the monitor adds).
    pub fn to_features(&self) -> Features {
        match self {
            Measured::Hbt(f) => Features::Hbt(f.to_features()),
            Measured::Clfrt(f) => Features::Clfrt(f.to_features()),
        }
    }
}

pub use clfrt::ClfrtReport;
pub use hbt::analysis::HbtReport;
pub use sizing::{square_wave_peak_factor, RelayPrediction};

/// Why the CLFRT multisine could not be designed from the configuration (a CLFRT test then
/// cannot start: the trigger's reply gives this text).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MultisineError {
    /// The design refused the configuration's window, harmonics or amplitude.
    #[error("multisine design failed: {0}")]
    Design(crate::dsp::DspError),
}

/// Counters beyond the per-stream input counts.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Stats {
    /// Tests started.
    pub tests_started: u64,
    /// Tests completed.
    pub tests_completed: u64,
    /// Tests aborted.
    pub tests_aborted: u64,
    /// Tests aborted, by reason.
    pub aborts: AbortCounts,
    /// Excitation values the safety gate had to bound (should stay 0: a non-zero count means
    /// a generator asked for more than the limits allow).
    pub excitation_clamped: u64,
}

/// Detects a steady course for the scheduler, in O(1) memory.
#[derive(Debug, Clone, Default)]
struct Steady {
    since: Option<f64>,
    rudder: (f64, f64),
    speed: (f64, f64),
}

/// A test in progress.
#[derive(Debug, Clone)]
struct Run {
    id: String,
    method: Method,
    t_start: f64,
    phase: MonitorState,
    target_rad: f64,
    speed_start_mps: f64,
    /// Sum and count of the speed-log samples since the start (for `speed_log_mps`).
    speed_sum_mps: f64,
    speed_n: u64,
    kind: RunKind,
    /// The excitations sent, `(t, value)`, when analysis records are asked for (bounded by
    /// `sent_capacity`).
    sent: Vec<(f64, f64)>,
}

#[derive(Debug, Clone)]
enum RunKind {
    Hbt(Box<hbt::HbtRun>),
    Clfrt(Box<clfrt::ClfrtRun>),
}

/// What one step of a test run asks for at a heading sample.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Step {
    /// Excitation mode and value for this sample.
    mode: ExcitationMode,
    value: f64,
    /// New phase, if it changed.
    phase: Option<MonitorState>,
    /// The test is over: features or an abort reason.
    done: Option<Result<Measured, AbortReason>>,
}

/// The monitor of one vessel. See the module documentation for the driving order.
#[derive(Debug, Clone)]
pub struct Monitor {
    /// The configuration, checked.
    cfg: CoreConfig,
    /// Used in test ids.
    vessel: String,
    /// Plausibility limits derived from the configuration.
    limits: Limits,
    /// Per-stream clock-step detection.
    clocks: Clocks,
    /// The latest accepted sample of each stream (safety checks, steadiness).
    latest: Latest,
    /// Smoothed speed [m/s] and the time of its last update.
    speed_smooth: Option<(f64, f64)>,
    /// The heading made continuous (no jump at 0 / 2 pi), for records [rad].
    heading_unwrapped: Option<f64>,
    /// Accepted and rejected samples.
    counters: Counters,
    /// Test and gate counters.
    stats: Stats,
    /// Steady-course detector for the scheduler.
    steady: Steady,
    /// The test in progress.
    run: Option<Run>,
    /// End of the last test (ship time), for the scheduler interval.
    last_test_end: Option<f64>,
    /// The steering gear's work, measured: commissioning's cadence (`cadence`).
    work: cadence::Work,
    /// The gap the last test asked for under the added-travel budget [s] (`cadence`).
    commissioning_gap_s: Option<f64>,
    /// Which scheduled method runs next (index into `scheduler.methods`).
    next_method: usize,
    /// The wave yaw on the heading the last completed test measured [rad]: the sea the
    /// next relay is sized for (`crate::monitor::sizing`).
    sea_wave_yaw_rad: Option<f64>,
    /// Whether the next CLFRT test's heading guard is armed: the vessel's last CLFRT test
    /// ended on the heading limit, or the guard lowered its tones
    /// (`crate::monitor::sizing`, `clfrt.resize-heading-fraction`).
    clfrt_heading_guard: bool,
    /// Tests started so far (part of the test id).
    test_seq: u64,
    /// Outputs waiting for the driver.
    outputs: VecDeque<Output>,
    /// The last status published.
    status: MonitorState,
    /// The last excitation published: `(t, mode, value)`.
    last_excitation: Option<(f64, ExcitationMode, f64)>,
    /// The CLFRT multisine, designed once from the configuration (or why it could not be).
    multisine: Result<Multisine, MultisineError>,
    /// The networks that turn features into an estimate, with their buffers (optional).
    estimator: Option<(Arc<Estimator>, EstimatorScratch)>,
    /// Residuals, decision, alarm state and isolation over the completed tests.
    fdi: Fdi,
    /// Queue an [`Output::Analysis`] before each completed test's report.
    analysis_output: bool,
}

impl Monitor {
    /// A monitor for `vessel` with a checked configuration.
    pub fn new(cfg: &CoreConfig, vessel: &str) -> Self {
        Self::with_parts(cfg, vessel, None, None)
    }

    /// The CLFRT multisine of `cfg` (a seeded phase optimisation, ~0.1 s of CPU).
    pub fn design_multisine(cfg: &CoreConfig) -> Result<Multisine, MultisineError> {
        Multisine::design(
            cfg.clfrt.window_s,
            &cfg.clfrt.harmonics,
            cfg.clfrt.amplitude_rad(),
            cfg.clfrt.phase_seed,
        )
        .map_err(MultisineError::Design)
    }

    /// A monitor whose completed tests carry an `estimate` from `estimator` (validated for
    /// `cfg`, e.g. by [`Estimator::load_dir`] or [`Estimator::embedded`]).
    pub fn with_estimator(cfg: &CoreConfig, vessel: &str, estimator: Arc<Estimator>) -> Self {
        Self::with_parts(cfg, vessel, None, Some(estimator))
    }

    /// A monitor built from parts prepared once for many monitors of one configuration (the
    /// training database runs thousands): `multisine` from [`Monitor::design_multisine`]`(cfg)`
    /// (designed here when `None`, or when its window, harmonics or amplitude differ from
    /// `cfg`'s), and an optional estimator.
    pub fn with_parts(
        cfg: &CoreConfig,
        vessel: &str,
        multisine: Option<Multisine>,
        estimator: Option<Arc<Estimator>>,
    ) -> Self {
        // The models' calibration on their class of hull, else the shipped models'.
        let cfg = &CoreConfig {
            calibration: estimator
                .as_ref()
                .map_or_else(Default::default, |e| e.calibration().clone()),
            ..cfg.clone()
        };
        let c = &cfg.clfrt;
        let multisine = match multisine {
            Some(ms)
                if ms.window_s() == c.window_s
                    && ms.harmonics() == c.harmonics.as_slice()
                    && ms.amplitude_rad() == c.amplitude_rad() =>
            {
                Ok(ms)
            }
            _ => Self::design_multisine(cfg),
        };
        let mut fdi = Fdi::new(cfg);
        fdi.set_models(estimator.as_ref().map(|e| e.fingerprint().to_string()));
        let estimator = estimator.map(|e| {
            let scratch = e.scratch();
            (e, scratch)
        });
        Self {
            limits: Limits {
                max_rudder_rad: cfg.input.max_rudder_deg.to_radians(),
                max_speed_mps: cfg.input.max_speed_mps,
            },
            cfg: cfg.clone(),
            vessel: vessel.to_string(),
            latest: Latest::default(),
            clocks: Clocks::default(),
            speed_smooth: None,
            heading_unwrapped: None,
            counters: Counters::default(),
            stats: Stats::default(),
            steady: Steady::default(),
            run: None,
            last_test_end: None,
            work: cadence::Work::default(),
            commissioning_gap_s: None,
            next_method: 0,
            sea_wave_yaw_rad: None,
            clfrt_heading_guard: false,
            test_seq: 0,
            outputs: VecDeque::new(),
            status: MonitorState::Idle,
            last_excitation: None,
            multisine,
            estimator,
            fdi,
            analysis_output: false,
        }
    }

    /// Asks for an [`Output::Analysis`] before each completed test's report (the driver
    /// records it); off by default. It changes no other output.
    pub fn set_analysis_output(&mut self, on: bool) {
        self.analysis_output = on;
    }

    /// Most excitations a test keeps for its analysis record: its longest duration at twice
    /// the nominal rate.
    fn sent_capacity(&self) -> usize {
        ((self.cfg.safety.max_test_duration_s + 60.0) * self.cfg.sensors.rate_hz * 2.0).ceil()
            as usize
    }

    /// The vessel's alarm state (the worst of the methods' decision tracks).
    pub fn alarm_state(&self) -> crate::wire::AlarmState {
        self.fdi.alarm_state()
    }

    /// The nominal displacement in force [t]: the ship's latest `design/displacement`, or
    /// `ship.nominal-displacement-t`.
    pub fn nominal_displacement_t(&self) -> f64 {
        self.latest
            .design_displacement
            .map_or(self.cfg.ship.nominal_displacement_t, |(_, kg)| kg / 1000.0)
    }

    /// The vessel this monitor watches.
    pub fn vessel(&self) -> &str {
        &self.vessel
    }

    /// Current state.
    pub fn state(&self) -> MonitorState {
        self.status
    }

    /// Input counters.
    pub fn counters(&self) -> &Counters {
        &self.counters
    }

    /// Test and gate counters.
    pub fn stats(&self) -> &Stats {
        &self.stats
    }

    /// Ship time of the last accepted heading sample.
    pub fn last_heading_t(&self) -> Option<f64> {
        self.latest.heading.map(|h| h.0)
    }

    /// Next output for the driver to publish, oldest first.
    pub fn poll_output(&mut self) -> Option<Output> {
        self.outputs.pop_front()
    }

    /// Starts a test now if possible (the `fdi/trigger` queryable).
    pub fn trigger(&mut self, method: Method) -> TriggerReply {
        let refuse = |reason: String| TriggerReply {
            accepted: false,
            test: None,
            reason: Some(reason),
        };
        if let Some(run) = &self.run {
            return refuse(format!("test {} is under way", run.id));
        }
        let Some(t) = self.last_heading_t() else {
            return refuse("no heading received yet".into());
        };
        if let Err(reason) = self.preconditions(t) {
            return refuse(reason.to_string());
        }
        match self.start(t, method, "trigger") {
            Ok(id) => TriggerReply {
                accepted: true,
                test: Some(id),
                reason: None,
            },
            Err(reason) => refuse(reason.to_string()),
        }
    }

    fn excitation_sent_at(&self, t: f64) -> bool {
        self.last_excitation.is_some_and(|e| e.0 == t)
    }

    fn heading_error(&self, t_target: f64, heading_rad: f64) -> f64 {
        wrap_pi(t_target - heading_rad)
    }

    /// Starts a test at `t` (preconditions already checked). Returns its id; a CLFRT test
    /// cannot start without its multisine.
    fn start(&mut self, t: f64, method: Method, why: &str) -> Result<String, MultisineError> {
        let kind = match method {
            Method::Hbt => {
                let speed = self.speed_smooth.map(|x| x.0);
                RunKind::Hbt(Box::new(hbt::HbtRun::new(
                    &self.cfg,
                    t,
                    speed,
                    self.sea_wave_yaw_rad,
                )))
            }
            Method::Clfrt => {
                let ms = self.multisine.clone()?;
                RunKind::Clfrt(Box::new(clfrt::ClfrtRun::new(
                    &self.cfg,
                    t,
                    ms,
                    self.clfrt_heading_guard,
                    self.speed_smooth.map(|x| x.0),
                )))
            }
        };
        self.test_seq += 1;
        let id = format!(
            "{}-{}-{}-{}",
            self.vessel,
            method.name(),
            t.floor() as i64,
            self.test_seq
        );
        let target_rad = self.latest.target.map(|x| x.1).unwrap_or(0.0);
        let speed_start_mps = self.speed_smooth.map(|x| x.0).unwrap_or(0.0);
        self.run = Some(Run {
            id: id.clone(),
            method,
            t_start: t,
            phase: MonitorState::Settling,
            target_rad,
            speed_start_mps,
            speed_sum_mps: 0.0,
            speed_n: 0,
            kind,
            sent: Vec::new(),
        });
        self.stats.tests_started += 1;
        self.work.test_started();
        self.steady.since = None;
        tracing::info!(vessel = %self.vessel, test = %id, method = method.name(), "test started ({why})");
        self.emit_status(t, MonitorState::Settling, Some(format!("started on {why}")));
        Ok(id)
    }
}
