//! The demo: the daemon and the simulated ship in one process, as separate Zenoh sessions on
//! loopback, in lockstep (accelerated) time, plus an observer session that prints what a
//! client of the daemon sees: every status change and every report's decision, as they arrive.
//!
//! Timeline: the ship holds its course; the scheduler runs tests back to back (CLFRT and HBT
//! in turn, one minute apart); the first tests commission the vessel (its own reference, two
//! per method here instead of the configured eight, so the demo stays short); at the fault's
//! onset, after commissioning, the ship's displacement steps up; the demo runs until the alarm
//! is raised (or a cap of reports of the faulty ship). Everything goes over real Zenoh sessions on
//! `127.0.0.1` (a free port), multicast off.

use crate::config::Config;
use crate::shells::daemon::Daemon;
use crate::shells::net::{free_loopback_port, loopback_peer};
use crate::shells::shipnode::{ShipNode, ShipNodeOptions};
use crate::tools::loopback::LoopbackError;
use helmwatch_core::sim::{Fault, Scenario};
use helmwatch_core::wire::{Keys, Notification, Report, Status};
use std::io::Write;
use std::time::Instant;
use tokio::sync::mpsc;
use tokio_util::sync::CancellationToken;

/// What the demo runs.
#[derive(Debug, Clone, PartialEq)]
pub struct DemoOptions {
    /// Seed of the simulated ship.
    pub seed: u64,
    /// The fault injected (its onset is in ship time).
    pub fault: Fault,
    /// Reports of tests that started after the fault's onset before the demo stops without
    /// an alarm.
    pub fault_reports: usize,
    /// Commissioning tests per method (`fdi.commissioning-tests` of the demo's daemon).
    pub commissioning_tests: u32,
    /// Ship time after which the demo stops anyway [s].
    pub max_ship_s: f64,
}

impl Default for DemoOptions {
    fn default() -> Self {
        Self {
            seed: 1,
            fault: Fault {
                kind: helmwatch_core::sim::FaultKind::DisplacementPct,
                value: 25.0,
                onset_s: DEFAULT_ONSET_S,
            },
            fault_reports: 8,
            commissioning_tests: DEMO_COMMISSIONING_TESTS,
            max_ship_s: 12.0 * 3600.0,
        }
    }
}

/// Onset of the demo's fault [s of ship time]: after commissioning (two CLFRT and two HBT
/// tests; with seed 1 the fourth ends at 5954 s, the fifth starts at 6090 s).
pub const DEFAULT_ONSET_S: f64 = 14930.0;

/// Commissioning tests per method in the demo.
pub const DEMO_COMMISSIONING_TESTS: u32 = 5;

/// What the demo saw.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct DemoSummary {
    /// Reports received over Zenoh.
    pub reports: Vec<Report>,
    /// Notifications received over Zenoh.
    pub notifications: usize,
    /// The alarm was raised (the demo stopped at it).
    pub alarm: bool,
    /// Ship time simulated [s].
    pub ship_s: f64,
    /// Wall time [s].
    pub wall_s: f64,
}

enum Seen {
    Status(Status),
    Report(Box<Report>),
    Notification(Notification),
}

/// Runs the demo, printing to `out`.
pub async fn run(
    cfg: &Config,
    opts: &DemoOptions,
    out: &mut (impl Write + Send),
) -> Result<DemoSummary, LoopbackError> {
    let io = |e: std::io::Error| LoopbackError::Other(e.to_string());
    let started = Instant::now();
    let vessel = cfg.simulation.vessel.clone();
    let keys = Keys::new(&vessel);
    let port = free_loopback_port().map_err(io)?;
    let endpoint = format!("tcp/127.0.0.1:{port}");

    let mut dcfg = cfg.clone();
    dcfg.daemon.vessels = vec![vessel.clone()];
    dcfg.scheduler.enabled = true;
    dcfg.scheduler.interval_s = 60.0;
    dcfg.fdi.commissioning_tests = opts.commissioning_tests;
    let daemon = Daemon::start(
        &dcfg.core(),
        &dcfg.daemon,
        loopback_peer(std::slice::from_ref(&endpoint), &[])?,
    )
    .await?;

    let (observer, subs, mut rx) = observe(&endpoint, &keys).await?;
    print_header(cfg, opts, &endpoint, &vessel, out).map_err(io)?;

    let mut scenario = Scenario::nominal(&cfg.sim(), opts.seed);
    scenario.faults = vec![opts.fault];
    let mut sopts = ShipNodeOptions::from_config(&cfg.ship_peer, &cfg.simulation.vessel);
    sopts.vessel = vessel.clone();
    sopts.lockstep = true;
    sopts.duration_s = Some(opts.max_ship_s);
    let ship = ShipNode::new(&cfg.sim(), &scenario, sopts)?;
    let stop_ship = CancellationToken::new();
    let stop = stop_ship.clone();
    let ship_task = tokio::spawn(ship.run(
        loopback_peer(&[], std::slice::from_ref(&endpoint))?,
        async move { stop.cancelled().await },
    ));

    let mut summary = DemoSummary::default();
    watch(&mut rx, || ship_task.is_finished(), opts, &mut summary, out).await?;
    stop_ship.cancel();
    let ship_summary = match ship_task.await {
        Ok(r) => r?,
        Err(e) => return Err(LoopbackError::Other(format!("ship task: {e}"))),
    };
    daemon.stop().await;
    for s in subs {
        let _ = s.undeclare().await;
    }
    let _ = observer.close().await;
    summary.ship_s = ship_summary.t_end_s - cfg.simulation.start_time_s;
    summary.wall_s = started.elapsed().as_secs_f64();
    print_summary(&summary, opts, out).map_err(io)?;
    Ok(summary)
}

/// The observer: a client of the daemon, as any other program would be. Its session, its
/// subscribers (status, report, notification) and what they see.
async fn observe(
    endpoint: &str,
    keys: &Keys,
) -> Result<
    (
        zenoh::Session,
        Vec<zenoh::pubsub::Subscriber<()>>,
        mpsc::Receiver<Seen>,
    ),
    LoopbackError,
> {
    let observer = zenoh::open(loopback_peer(&[], &[endpoint.to_string()])?)
        .await
        .map_err(|e| LoopbackError::Other(e.to_string()))?;
    let (tx, rx) = mpsc::channel::<Seen>(1024);
    let mut subs = Vec::new();
    for key in [keys.status(), keys.report(), keys.notification()] {
        let tx = tx.clone();
        let sub = observer
            .declare_subscriber(key)
            .callback(move |s| {
                let b = s.payload().to_bytes();
                let k = s.key_expr().as_str();
                let seen = if k.ends_with("fdi/status") {
                    serde_json::from_slice(&b).ok().map(Seen::Status)
                } else if k.ends_with("fdi/report") {
                    serde_json::from_slice(&b)
                        .ok()
                        .map(|r| Seen::Report(Box::new(r)))
                } else {
                    serde_json::from_slice(&b).ok().map(Seen::Notification)
                };
                if let Some(seen) = seen {
                    let _ = tx.try_send(seen);
                }
            })
            .await
            .map_err(|e| LoopbackError::Other(e.to_string()))?;
        subs.push(sub);
    }
    drop(tx);
    Ok((observer, subs, rx))
}

/// The demo's first lines: where, which ship, which fault.
fn print_header(
    cfg: &Config,
    opts: &DemoOptions,
    endpoint: &str,
    vessel: &str,
    out: &mut impl Write,
) -> std::io::Result<()> {
    let onset = opts.fault.onset_s;
    writeln!(
        out,
        "helmwatch demo: daemon and simulated ship over Zenoh on {endpoint}, lockstep time\n\
         ship {vessel}: {} m/s, {} t, {} sea; tests on schedule (CLFRT and HBT in turn)\n\
         commissioning: the first {} tests of each method set the vessel's own reference\n\
         fault: {} from t = {onset:.0} s; the demo runs until the alarm\n",
        cfg.ship.nominal_speed_mps,
        cfg.ship.nominal_displacement_t,
        cfg.sea.state.name(),
        opts.commissioning_tests,
        opts.fault
    )
}

/// Prints what the observer sees, into `summary`, until the alarm and its report are both in,
/// the cap of reports of the faulty ship is reached, or the ship has stopped.
async fn watch(
    rx: &mut mpsc::Receiver<Seen>,
    ship_finished: impl Fn() -> bool,
    opts: &DemoOptions,
    summary: &mut DemoSummary,
    out: &mut impl Write,
) -> Result<(), LoopbackError> {
    let io = |e: std::io::Error| LoopbackError::Other(e.to_string());
    let onset = opts.fault.onset_s;
    let mut after_fault = 0usize;
    let mut fault_report = false;
    while let Some(seen) = rx.recv().await {
        match seen {
            Seen::Status(s) => {
                let what = match (&s.method, &s.reason) {
                    (Some(m), _) => format!("{} {:?}", m.name(), s.state).to_lowercase(),
                    (None, Some(r)) => format!("{:?} ({r})", s.state).to_lowercase(),
                    (None, None) => format!("{:?}", s.state).to_lowercase(),
                };
                writeln!(out, "  t = {:>6.0} s  status: {what}", s.t).map_err(io)?;
            }
            Seen::Report(r) => {
                print_report(&r, onset, out).map_err(io)?;
                if r.t_start >= onset {
                    after_fault += 1;
                }
                fault_report |= r.decision == helmwatch_core::wire::Decision::Fault;
                summary.reports.push(*r);
                if (summary.alarm && fault_report) || after_fault >= opts.fault_reports {
                    break;
                }
            }
            Seen::Notification(n) => {
                summary.notifications += 1;
                writeln!(out, "NOTIFICATION {:?}: {}", n.state, n.message).map_err(io)?;
                // Stop once both the alarm and its report (in either order) are in.
                summary.alarm |= n.state == helmwatch_core::wire::AlarmState::Alarm;
                if summary.alarm && fault_report {
                    break;
                }
            }
        }
        if ship_finished() {
            break;
        }
    }
    Ok(())
}

/// A report as the observer prints it, with the ship's state relative to the fault's onset.
fn print_report(r: &Report, onset: f64, out: &mut impl Write) -> std::io::Result<()> {
    let when = if r.t_start >= onset {
        "faulty ship"
    } else if r.t_end >= onset {
        "fault began during the test"
    } else {
        "nominal ship"
    };
    writeln!(
        out,
        "t = {:>6.0} s  REPORT {} ({when}): {:?}{}, decision {:?}\n    {}",
        r.t_end,
        r.test,
        r.outcome,
        r.reason
            .as_ref()
            .map(|x| format!(" ({x})"))
            .unwrap_or_default(),
        r.decision,
        r.message
    )
}

/// The demo's last lines: reports, time, and when the alarm was raised.
fn print_summary(
    summary: &DemoSummary,
    opts: &DemoOptions,
    out: &mut impl Write,
) -> std::io::Result<()> {
    let onset = opts.fault.onset_s;
    writeln!(
        out,
        "\n{} reports; {:.0} s of ship time in {:.1} s ({:.0}x real time)",
        summary.reports.len(),
        summary.ship_s,
        summary.wall_s,
        summary.ship_s / summary.wall_s.max(1e-9)
    )?;
    let first_fault = summary
        .reports
        .iter()
        .position(|r| r.t_start >= onset)
        .map(|i| summary.reports.len() - i);
    match (summary.alarm, first_fault) {
        (true, Some(n)) => writeln!(
            out,
            "the alarm was raised at the {} test of the faulty ship",
            ordinal(n)
        ),
        (true, None) => writeln!(out, "the alarm was raised"),
        (false, _) => writeln!(
            out,
            "no alarm within {} reports of the faulty ship",
            opts.fault_reports
        ),
    }
}

fn ordinal(n: usize) -> String {
    match n {
        1 => "first".into(),
        2 => "second".into(),
        3 => "third".into(),
        n => format!("{n}th"),
    }
}
