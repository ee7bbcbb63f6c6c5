//! `helmwatch bench --time-to-alarm`: how long after a fault's onset the alarm comes, and how
//! much rudder travel the scheduled tests add, per scheduler interval. The figures the
//! scheduler's defaults are chosen from (docs/fdi.md, "What is measured"; written to
//! docs/results/ with `--results`).
//!
//! One *run* is one seeded ship at its nominal speed and displacement in the chosen sea,
//! driven by [`Lockstep`](helmwatch_core::drivers::probe::Lockstep) (the simulated ship and
//! the same monitor core as the daemon, in virtual time) with the scheduler on as configured
//! (`[scheduler]`, its `interval-s` set to the interval under study) and the configured
//! `[fdi]` and estimator:
//!
//! 1. *Commissioning*: the healthy ship runs until both methods are commissioned
//!    (`fdi.commissioning-tests` completed tests each,
//!    [`Monitor::commissioned`](helmwatch_core::monitor::Monitor::commissioned)), then
//!    through the confirmation (until no scheduled method is establishing its reference,
//!    [`Monitor::establishing`](helmwatch_core::monitor::Monitor::establishing)), both at the
//!    commissioning cadence; the report that ends the confirmation ends at the *onset* `t_0`,
//!    the watch's start. The healthy ship runs on for `cap_s` of the watch (its rudder
//!    travel); its alarms in all three are counted.
//! 2. *Faults*: the run is cloned at `t_0` once per fault, the fault injected from `t_0`
//!    ([`helmwatch_core::sim::Ship::inject`]), and each clone runs until the first notification in
//!    state `alarm`, or `cap_s` of ship time after `t_0`. Every clone sees the same ship, sea
//!    and noise up to `t_0` (what a separate run per fault with the same seed would see), and
//!    tests at `interval-s`, the interval under study.
//!
//! Per fault and run: `tests` = completed reports (either method) from `t_0` to the alarm,
//! the alarm's report included; `hours` = `(t_end of that report - t_0) / 3600`; the cause is
//! right when the report's isolation is exactly the fault's cause. A heading drift must not
//! alarm: its alarms are counted.
//!
//! Rudder travel: `sum |delta_k - delta_(k-1)|` of the simulated *true* rudder angle (the
//! blade, [`helmwatch_core::sim::Truth::delta_rad`]; the measured one carries white noise that would
//! dominate the sum) over three windows of the healthy ship: commissioning `[t_a, t_0]`, `t_a`
//! the end of the first test, so the window holds whole test cycles (interval, steady wait,
//! test); its confirmation `[t_0, t_1]`, `t_1` when no scheduled method is establishing its
//! reference ([`Monitor::establishing`](helmwatch_core::monitor::Monitor::establishing)); and
//! `[t_1, t_1 + cap_s]` of the watch. The same seed with the
//! scheduler off (the autopilot alone) over the same window gives the autopilot's own travel;
//! the difference per hour is the travel the tests add [deg/h]. Without a test in the run
//! (scheduler off) the window is the whole run.
//!
//! Deterministic: the same options give the same table (each run seeded, [`par_map`] keeps
//! the order).
//!
//! Files: this one (the faults, the options, the figures of a run, all runs, the tables) and
//! `seed_run` (one seeded run).

pub mod seed_run;

use crate::config::Config;
use crate::tools::eval::fdi::{quantiles, scenarios};
use crate::tools::training::database::par_map;
use helmwatch_core::model::SeaState;
use helmwatch_core::sim::{Fault, FaultKind, SimError};
use helmwatch_core::wire::Cause;
use seed_run::{run_seed, Parts};
use std::io::Write;

/// A fault of the bench: what is injected at the onset and which cause must be named.
#[derive(Debug, Clone, PartialEq)]
pub struct BenchFault {
    /// Name in the table.
    pub name: String,
    /// The fault (its onset is set when injected).
    pub fault: Fault,
    /// The cause the isolation must name; `None`: it must not alarm.
    pub expected: Option<Cause>,
}

/// The faults of the bench, in print order: the fault scenarios of `eval --fdi`
/// ([`scenarios`]) and a heading drift of 1 deg/min, which must not alarm.
pub fn bench_faults() -> Result<Vec<BenchFault>, String> {
    let order = [
        "displacement +20 %",
        "displacement -20 %",
        "displacement +10 %",
        "displacement -10 %",
        "rudder effectiveness -30 %",
        "servo rate 2 deg/s",
        "speed log +0.5 m/s",
    ];
    let all = scenarios();
    let mut out = Vec::with_capacity(order.len() + 1);
    for name in order {
        let sc = all
            .iter()
            .find(|s| s.name == name)
            .ok_or_else(|| format!("no fault scenario `{name}`"))?;
        let spec = sc.fault.ok_or_else(|| format!("`{name}` has no fault"))?;
        out.push(BenchFault {
            name: name.to_string(),
            fault: spec.parse::<Fault>().map_err(|e| e.to_string())?,
            expected: sc.expected,
        });
    }
    out.push(BenchFault {
        name: "heading drift 1 deg/min (must not alarm)".into(),
        fault: Fault::new(FaultKind::HeadingDriftDegPerMin, 1.0, 0.0).map_err(|e| e.to_string())?,
        expected: None,
    });
    Ok(out)
}

/// Options of the bench.
#[derive(Debug, Clone, PartialEq)]
pub struct TimeToAlarmOptions {
    /// Seed of the runs (run `k` of every interval has the same ship seed).
    pub seed: u64,
    /// Runs per interval.
    pub runs: usize,
    /// Sea state of every run.
    pub sea: SeaState,
    /// Scheduler intervals studied [s].
    pub intervals_s: Vec<f64>,
    /// Ship time after the onset within which an alarm counts [s].
    pub cap_s: f64,
    /// Worker threads.
    pub threads: usize,
}

impl Default for TimeToAlarmOptions {
    fn default() -> Self {
        Self {
            seed: 1,
            runs: 12,
            sea: SeaState::Moderate,
            intervals_s: vec![1800.0, 3600.0, 7200.0],
            cap_s: 24.0 * 3600.0,
            threads: 1,
        }
    }
}

/// The alarm of one fault run.
#[derive(Debug, Clone, PartialEq)]
pub struct Alarm {
    /// Completed tests from the onset to the alarm, its report included.
    pub tests: usize,
    /// Ship hours from the onset to the end of the alarm's report [h].
    pub hours: f64,
    /// The alarm report's isolation.
    pub isolation: Vec<Cause>,
}

/// One fault injected into one commissioned run.
#[derive(Debug, Clone, PartialEq)]
pub struct FaultRun {
    /// The first alarm within the cap, if any.
    pub alarm: Option<Alarm>,
    /// Completed tests from the onset to the alarm or the cap.
    pub tests: usize,
    /// Aborted tests in the same span.
    pub aborted: usize,
}

/// Rudder travel over one window.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Travel {
    /// Window length [h].
    pub hours: f64,
    /// Travel with the run's scheduler [deg].
    pub with_tests_deg: f64,
    /// Travel of the same ship with the scheduler off, the autopilot alone [deg].
    pub autopilot_deg: f64,
    /// Tests completed or aborted in the window, the first test's excluded.
    pub tests: usize,
}

impl Travel {
    /// The travel the tests add per hour [deg/h].
    pub fn added_deg_per_h(&self) -> f64 {
        (self.with_tests_deg - self.autopilot_deg) / self.hours
    }
}

/// One seeded run at one interval: its commissioning, its travel, each fault.
#[derive(Debug, Clone, PartialEq)]
pub struct SeedRun {
    /// Ship seed.
    pub seed: u64,
    /// The run's start, before the first test's steady wait [s].
    pub start_s: f64,
    /// End of the report that completed commissioning [s]; `None` if it never did.
    pub commissioned_s: Option<f64>,
    /// Tests reported until then (commissioning and any that did not count for it).
    pub commissioning_reports: usize,
    /// Alarm notifications of the healthy ship: commissioning, confirmation and watch (false
    /// alarms).
    pub healthy_alarms: usize,
    /// Rudder travel over the commissioning window.
    pub travel: Travel,
    /// Over the confirmation after it (the healthy ship, at the commissioning cadence until
    /// no scheduled method is establishing its reference); `None` when not commissioned.
    pub confirmation: Option<Travel>,
    /// Over `cap_s` of the watch after the confirmation (the healthy ship at `interval-s`).
    pub watch: Option<Travel>,
    /// The watch's start, the faults' onset: the end of the report that ended the
    /// confirmation [s]; `None` if it did not end within the cap (no fault runs).
    pub watch_start_s: Option<f64>,
    /// Per fault of the bench, in order (empty when not commissioned).
    pub faults: Vec<FaultRun>,
}

/// Why the bench could not run.
#[derive(Debug, thiserror::Error)]
pub enum TimeToAlarmError {
    /// The simulated ship.
    #[error(transparent)]
    Sim(#[from] SimError),
    /// The estimator's models.
    #[error("estimator: {0}")]
    Estimator(String),
    /// Anything else.
    #[error("{0}")]
    Other(String),
}

/// The bench's runs: per interval (outer, in order), `o.runs` seeded runs.
pub fn run(
    cfg: &Config,
    o: &TimeToAlarmOptions,
    faults: &[BenchFault],
) -> Result<Vec<Vec<SeedRun>>, TimeToAlarmError> {
    let parts = Parts::new(cfg)?;
    let jobs: Vec<(usize, u64)> = (0..o.intervals_s.len())
        .flat_map(|i| (0..o.runs).map(move |k| (i, k as u64)))
        .collect();
    let results = par_map(jobs.len(), o.threads, |j| {
        let (i, k) = jobs[j];
        let mut c = cfg.clone();
        c.scheduler.interval_s = o.intervals_s[i];
        run_seed(
            &c,
            &parts,
            faults,
            o.sea,
            o.seed.wrapping_mul(1_000_003).wrapping_add(k),
            o.cap_s,
        )
    });
    let mut per = vec![Vec::with_capacity(o.runs); o.intervals_s.len()];
    for (j, r) in results.into_iter().enumerate() {
        per[jobs[j].0].push(r?);
    }
    Ok(per)
}

fn median_max(v: Vec<f64>, digits: usize) -> String {
    match quantiles(v) {
        Some((m, _, mx)) => format!("{m:.digits$} / {mx:.digits$}"),
        None => "-".into(),
    }
}

/// Prints the bench's tables (markdown) to `out`: a header with the options and the
/// configuration, time to alarm per fault and interval, rudder travel per interval.
pub fn print(
    cfg: &Config,
    o: &TimeToAlarmOptions,
    faults: &[BenchFault],
    per: &[Vec<SeedRun>],
    out: &mut impl Write,
) -> std::io::Result<()> {
    let f = &cfg.fdi;
    let s = &cfg.scheduler;
    let cap_h = o.cap_s / 3600.0;
    writeln!(
        out,
        "# Time to alarm and rudder travel per scheduler interval\n\n\
         seed {}, {} runs per interval, {} sea, ship at {} m/s and {} t; scheduler methods [{}] in turn, \
         steady-time-s {}, interval-s as below; fdi false-alarms-per-year {}, window-tests {}, \
         commissioning-tests {} per method; estimator {}; faults from the end of the confirmation (the watch's start), alarms counted within {cap_h} ship hours",
        o.seed,
        o.runs,
        o.sea.name(),
        cfg.ship.nominal_speed_mps,
        cfg.ship.nominal_displacement_t,
        s.methods.iter().map(|m| m.name()).collect::<Vec<_>>().join(", "),
        s.steady_time_s,
        f.false_alarms_per_year,
        f.window_tests,
        f.commissioning_tests,
        match (&cfg.estimator.enabled, &cfg.estimator.models_dir) {
            (false, _) => "off".to_string(),
            (true, Some(d)) => format!("models-dir {d}"),
            (true, None) => "the embedded models".to_string(),
        },
    )?;
    writeln!(out)?;
    writeln!(
        out,
        "| fault | interval [s] | alarmed within {cap_h} h | tests to alarm (median / max) | hours to alarm (median / max) | right cause at the alarm | aborted tests |"
    )?;
    writeln!(out, "|---|---|---|---|---|---|---|")?;
    for (fi, bf) in faults.iter().enumerate() {
        for (ii, runs) in per.iter().enumerate() {
            let frs: Vec<&FaultRun> = runs.iter().filter_map(|r| r.faults.get(fi)).collect();
            let alarms: Vec<&Alarm> = frs.iter().filter_map(|r| r.alarm.as_ref()).collect();
            let right = match bf.expected {
                Some(c) => format!(
                    "{} of {}",
                    alarms
                        .iter()
                        .filter(|a| a.isolation.len() == 1 && a.isolation[0] == c)
                        .count(),
                    alarms.len()
                ),
                None => "-".into(),
            };
            let alarmed = if bf.expected.is_some() {
                format!("{} of {}", alarms.len(), frs.len())
            } else {
                format!("{} of {} (false alarms)", alarms.len(), frs.len())
            };
            writeln!(
                out,
                "| {} | {:.0} | {alarmed} | {} | {} | {right} | {} |",
                bf.name,
                o.intervals_s[ii],
                median_max(alarms.iter().map(|a| a.tests as f64).collect(), 0),
                median_max(alarms.iter().map(|a| a.hours).collect(), 1),
                frs.iter().map(|r| r.aborted).sum::<usize>(),
            )?;
        }
    }
    writeln!(out)?;
    print_hours(out, o, per)?;
    print_travel(out, cfg, o, per, cap_h)?;
    let mut notes = Vec::new();
    for (ii, runs) in per.iter().enumerate() {
        for r in runs {
            if r.commissioned_s.is_none() {
                notes.push(format!(
                    "interval {:.0} s, seed {}: not commissioned within {} reports; no fault runs",
                    o.intervals_s[ii], r.seed, r.commissioning_reports
                ));
            }
            if r.commissioned_s.is_some() && r.watch_start_s.is_none() {
                notes.push(format!(
                    "interval {:.0} s, seed {}: the confirmation did not end within the cap; no fault runs",
                    o.intervals_s[ii], r.seed
                ));
            }
            if r.healthy_alarms > 0 {
                notes.push(format!(
                    "interval {:.0} s, seed {}: {} alarm(s) of the healthy ship (commissioning, confirmation, watch)",
                    o.intervals_s[ii], r.seed, r.healthy_alarms
                ));
            }
        }
    }
    if !notes.is_empty() {
        writeln!(out)?;
        for n in notes {
            writeln!(out, "- {n}")?;
        }
    }
    Ok(())
}

/// The hours to the vessel's own reference and to the confirmation's end, per interval:
/// median, 90th percentile and max over the runs.
fn print_hours(
    out: &mut impl Write,
    o: &TimeToAlarmOptions,
    per: &[Vec<SeedRun>],
) -> std::io::Result<()> {
    writeln!(
        out,
        "\nShip hours of the healthy ship from the run's start (the first test's steady wait included) to the vessel's own reference (both methods commissioned), and from it to the confirmation's end (the watch's start):\n"
    )?;
    writeln!(
        out,
        "| interval [s] | runs commissioned | to the reference [h] (median / 90th pct / max) | confirmation [h] (median / 90th pct / max) |"
    )?;
    writeln!(out, "|---|---|---|---|")?;
    let spread = |mut v: Vec<f64>| {
        v.retain(|x| x.is_finite());
        v.sort_by(f64::total_cmp);
        let q = |p: f64| v[((v.len() - 1) as f64 * p).ceil() as usize];
        if v.is_empty() {
            "-".to_string()
        } else {
            format!("{:.1} / {:.1} / {:.1}", q(0.5), q(0.9), q(1.0))
        }
    };
    for (ii, runs) in per.iter().enumerate() {
        let to_ref: Vec<f64> = runs
            .iter()
            .filter_map(|r| r.commissioned_s.map(|c| (c - r.start_s) / 3600.0))
            .collect();
        let confirm: Vec<f64> = runs
            .iter()
            .filter_map(|r| Some((r.watch_start_s? - r.commissioned_s?) / 3600.0))
            .collect();
        writeln!(
            out,
            "| {:.0} | {} of {} | {} | {} |",
            o.intervals_s[ii],
            to_ref.len(),
            runs.len(),
            spread(to_ref),
            spread(confirm)
        )?;
    }
    writeln!(out)
}

/// The rudder travel table: per interval and phase of the healthy ship (commissioning, its
/// confirmation, the watch), the travel per ship hour with the tests and without.
fn print_travel(
    out: &mut impl Write,
    cfg: &Config,
    o: &TimeToAlarmOptions,
    per: &[Vec<SeedRun>],
    cap_h: f64,
) -> std::io::Result<()> {
    writeln!(
        out,
        "Rudder travel (sum of |d delta| of the true rudder) per ship hour, by phase of the healthy ship: commissioning (from the end of the first test to both methods commissioned), its confirmation, and {cap_h} h of the watch after it; in the first two, scheduled tests after the gap the added-travel budget allows, at most scheduler.commissioning-interval-s ({:.0} s):\n",
        cfg.scheduler.commissioning_interval_s
    )?;
    writeln!(
        out,
        "| interval [s] | phase | window [h] (median) | tests per hour | autopilot alone [deg/h] | with the tests [deg/h] | added by the tests [deg/h] (median / max) | added per test [deg] (median) |"
    )?;
    writeln!(out, "|---|---|---|---|---|---|---|---|")?;
    for (ii, runs) in per.iter().enumerate() {
        let phases: [(&str, Vec<Travel>); 3] = [
            ("commissioning", runs.iter().map(|r| r.travel).collect()),
            (
                "confirmation",
                runs.iter().filter_map(|r| r.confirmation).collect(),
            ),
            ("watch", runs.iter().filter_map(|r| r.watch).collect()),
        ];
        for (phase, tr) in phases {
            if tr.is_empty() {
                continue;
            }
            let med = |v: Vec<f64>| quantiles(v).map_or(f64::NAN, |q| q.0);
            writeln!(
                out,
                "| {:.0} | {phase} | {:.1} | {:.3} | {:.0} | {:.0} | {} | {:.0} |",
                o.intervals_s[ii],
                med(tr.iter().map(|t| t.hours).collect()),
                med(tr.iter().map(|t| t.tests as f64 / t.hours).collect()),
                med(tr.iter().map(|t| t.autopilot_deg / t.hours).collect()),
                med(tr.iter().map(|t| t.with_tests_deg / t.hours).collect()),
                median_max(tr.iter().map(Travel::added_deg_per_h).collect(), 0),
                med(tr
                    .iter()
                    .map(|t| (t.with_tests_deg - t.autopilot_deg) / t.tests as f64)
                    .collect()),
            )?;
        }
    }
    Ok(())
}
