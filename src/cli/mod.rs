//! The `helmwatch` command line: thin drivers around the library.
//!
//! Logging starts before anything else, so configuration errors are logged. Exit codes follow
//! sysexits: 0 success, 64 usage, 65 bad input data, 70 internal error, 74 I/O error,
//! 78 configuration error.

pub mod estimator;
use crate::cli::estimator::{
    EvalOptions, TrainOptions, DEFAULT_EVAL_POINTS, DEFAULT_RESTARTS, DEFAULT_TRAIN_POINTS,
};
use crate::config::Config;
use crate::core::config::ConfigError;
use crate::core::estimator::Estimator;
use crate::core::model::SeaState;
use crate::core::wire::Method;
use crate::drivers::probe::{run_probe, ProbeOptions};
use crate::sim::{Fault, Scenario};
use clap::{Args, Parser, Subcommand};
use std::path::PathBuf;
use std::sync::Arc;

/// Exit code: success.
pub const EX_OK: i32 = 0;
/// Exit code: command line usage error.
pub const EX_USAGE: i32 = 64;
/// Exit code: bad input data.
pub const EX_DATAERR: i32 = 65;
/// Exit code: a service is unavailable (the Zenoh session cannot be opened).
pub const EX_UNAVAILABLE: i32 = 69;
/// Exit code: internal software error.
pub const EX_SOFTWARE: i32 = 70;
/// Exit code: operating system error (no runtime).
pub const EX_OSERR: i32 = 71;
/// Exit code: I/O error.
pub const EX_IOERR: i32 = 74;
/// Exit code: configuration error.
pub const EX_CONFIG: i32 = ConfigError::EXIT_CODE;

#[derive(Debug, Parser)]
#[command(
    name = "helmwatch",
    version,
    about = "Steering fault detection for ships: closed-loop frequency tests over Zenoh"
)]
struct Cli {
    /// Configuration file (TOML); without it the embedded defaults are used.
    #[arg(long, global = true, value_name = "FILE")]
    config: Option<PathBuf>,
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Record what a simulated ship publishes, as JSON lines {"key": .., "payload": ..}.
    Simulate(SimulateArgs),
    /// Run one test (HBT or CLFRT) on a simulated ship in virtual time and print its report.
    Probe(ProbeArgs),
    /// Check a configuration file and print it with every default filled in.
    CheckConfig,
    /// The daemon: monitor the configured vessels over Zenoh until SIGTERM or SIGINT.
    Run(RunArgs),
    /// The simulated ship as a Zenoh peer (lockstep with the daemon, or real time).
    Ship(ShipPeerArgs),
    /// Daemon and simulated ship in one process over Zenoh on loopback, accelerated time:
    /// a few nominal tests, then a displacement fault; prints each decision as it arrives.
    Demo(DemoArgs),
    /// Run the monitor core over a recording (JSON lines, as `simulate` writes) and print
    /// its reports.
    Replay(ReplayArgs),
    /// Print the daemon's benchmark figures (lockstep speed, vessels kept up with, memory).
    Bench(BenchArgs),
    /// Regenerate the training database and every estimator model (bit for bit per seed).
    Train(TrainArgs),
    /// Evaluate the models on a held-out database: accuracy tables, durations, drift.
    Eval(EvalArgs),
}

#[derive(Debug, Args)]
struct TrainArgs {
    /// Seed of the database (design, simulations, split) and of the training restarts.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Directory for the model files (Levenberg-Marquardt; Fletcher-Reeves in `traincgf/`).
    #[arg(long, default_value = "models")]
    out: PathBuf,
    /// Latin-hypercube points per sea state.
    #[arg(long, default_value_t = DEFAULT_TRAIN_POINTS)]
    points: usize,
    /// Seeded restarts per network and trainer.
    #[arg(long, default_value_t = DEFAULT_RESTARTS)]
    restarts: usize,
    /// Worker threads (default: every core).
    #[arg(long)]
    threads: Option<usize>,
}

#[derive(Debug, Args)]
struct EvalArgs {
    /// Seed of the held-out database (drawn on other random streams than training's).
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Directory of the model files (Levenberg-Marquardt; Fletcher-Reeves in `traincgf/`).
    #[arg(long, default_value = "models")]
    models: PathBuf,
    /// Held-out points per sea state.
    #[arg(long, default_value_t = DEFAULT_EVAL_POINTS)]
    points: usize,
    /// Also run every held-out test with a heading drift of 1 deg/min and compare.
    #[arg(long)]
    drift: bool,
    /// Run the fault-decision scenario suite instead (docs/fdi.md): false alarms, detection,
    /// isolation, delay, per method and sea state, beside the equation-error baseline.
    #[arg(long)]
    fdi: bool,
    /// With --fdi: runs per fault scenario.
    #[arg(long, default_value_t = 60)]
    runs: usize,
    /// With --fdi: runs per nominal scenario (each of `--tests` tests).
    #[arg(long, default_value_t = 60)]
    nominal_runs: usize,
    /// With --fdi: tests per run.
    #[arg(long, default_value_t = 4)]
    tests: usize,
    /// With --fdi: only this method (default both).
    #[arg(long)]
    method: Option<Method>,
    /// With --fdi: only this sea state (default calm and moderate).
    #[arg(long)]
    sea: Option<SeaState>,
    /// Skip the accuracy-against-test-length table.
    #[arg(long)]
    no_lengths: bool,
    /// Worker threads (default: every core).
    #[arg(long)]
    threads: Option<usize>,
}

#[derive(Debug, Args)]
struct RunArgs {
    /// Endpoint to listen on, e.g. tcp/127.0.0.1:7447 (repeatable; replaces `zenoh.listen`).
    #[arg(long, value_name = "ENDPOINT")]
    listen: Vec<String>,
    /// Endpoint to connect to (repeatable; replaces `zenoh.connect`).
    #[arg(long, value_name = "ENDPOINT")]
    connect: Vec<String>,
}

#[derive(Debug, Args)]
struct ShipPeerArgs {
    #[command(flatten)]
    ship: ShipArgs,
    /// Vessel name in the keys (default: `simulation.vessel`).
    #[arg(long)]
    vessel: Option<String>,
    /// Tick on a timer instead of waiting for the daemon's excitation (lockstep).
    #[arg(long)]
    real_time: bool,
    /// Ship seconds per wall second on the timer (default: `ship-peer.speed-up`).
    #[arg(long)]
    speed_up: Option<f64>,
    /// Stop after this much ship time [s] (default: run until SIGTERM or SIGINT).
    #[arg(long)]
    duration_s: Option<f64>,
    /// Endpoint to listen on (repeatable; replaces `ship-peer.listen`).
    #[arg(long, value_name = "ENDPOINT")]
    listen: Vec<String>,
    /// Endpoint to connect to (repeatable; replaces `ship-peer.connect`).
    #[arg(long, value_name = "ENDPOINT")]
    connect: Vec<String>,
    /// Record every publication as JSON lines (the `simulate` format, input of `replay`).
    #[arg(long, value_name = "FILE")]
    record: Option<PathBuf>,
}

#[derive(Debug, Args)]
struct DemoArgs {
    /// Seed of the simulated ship.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// The fault, KIND:VALUE@ONSET_S.
    #[arg(long, default_value = "displacement_pct:+25@5000")]
    fault: String,
    /// Reports of the faulty ship to wait for before stopping.
    #[arg(long, default_value_t = 2)]
    fault_reports: usize,
}

#[derive(Debug, Args)]
struct ReplayArgs {
    /// The recording (JSON lines {"key": .., "payload": ..}); `-` for standard input.
    file: PathBuf,
    /// Print each report as one JSON line (the `fdi/report` payload).
    #[arg(long)]
    json: bool,
}

#[derive(Debug, Args)]
struct BenchArgs {
    /// Ship time of the lockstep figure [s].
    #[arg(long, default_value_t = 1800.0)]
    lockstep_s: f64,
    /// Fleet sizes tried, in order, until one is not kept up with.
    #[arg(long, value_delimiter = ',', default_values_t = vec![100, 250, 500, 1000, 2000])]
    fleet: Vec<usize>,
    /// Measurement window of each fleet size [s of wall time].
    #[arg(long, default_value_t = 5.0)]
    window_s: f64,
    /// Internal: measure one fleet size in this process and print it as JSON.
    #[arg(long, hide = true)]
    one_fleet: Option<usize>,
}

/// The simulated ship of one run.
#[derive(Debug, Args)]
struct ShipArgs {
    /// True speed through water [m/s].
    #[arg(long, default_value_t = 7.0)]
    speed_mps: f64,
    /// True displacement [t].
    #[arg(long, default_value_t = 7000.0)]
    displacement_t: f64,
    /// Seed of every random draw (sensor noise, sea).
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// A fault KIND:VALUE@ONSET_S, e.g. displacement_pct:+10@300 (repeatable). Kinds:
    /// displacement_pct, speed_log_bias_mps, speed_log_scale, servo_rate_deg_s,
    /// rudder_effectiveness, heading_drift_deg_per_min.
    #[arg(long = "fault", value_name = "KIND:VALUE@ONSET_S")]
    faults: Vec<String>,
    /// Sea state: calm, moderate or rough (default: the configuration's, moderate).
    #[arg(long)]
    sea: Option<SeaState>,
}

#[derive(Debug, Args)]
struct SimulateArgs {
    #[command(flatten)]
    ship: ShipArgs,
    /// Simulated duration [s].
    #[arg(long, default_value_t = 3600.0)]
    duration_s: f64,
    /// Vessel name in the keys.
    #[arg(long, default_value = "self")]
    vessel: String,
    /// Output file (JSON lines); `-` for standard output.
    #[arg(long)]
    out: PathBuf,
}

#[derive(Debug, Args)]
struct ProbeArgs {
    #[command(flatten)]
    ship: ShipArgs,
    /// Directory of the estimator's model files (default: the models embedded in the binary).
    #[arg(long, value_name = "DIR")]
    models: Option<PathBuf>,
    /// Test method.
    #[arg(long, default_value = "clfrt")]
    method: Method,
    /// Print the report as JSON (the `fdi/report` payload).
    #[arg(long)]
    json: bool,
}

/// Runs the command line; returns the process exit code.
pub fn main() -> i32 {
    init_logging();
    let cli = match Cli::try_parse() {
        Ok(c) => c,
        Err(e) => {
            let code = if e.use_stderr() { EX_USAGE } else { EX_OK };
            let _ = e.print();
            return code;
        }
    };
    let cfg = match load_config(cli.config.as_deref()) {
        Ok(c) => c,
        Err(e) => {
            tracing::error!("{e}");
            eprintln!("helmwatch: {e}");
            return EX_CONFIG;
        }
    };
    let result = match cli.command {
        Command::Simulate(a) => simulate(&cfg, a),
        Command::Probe(a) => probe(&cfg, a),
        Command::CheckConfig => check_config(&cfg),
        Command::Run(a) => run_daemon(&cfg, a),
        Command::Ship(a) => ship(&cfg, a),
        Command::Demo(a) => demo(&cfg, a),
        Command::Replay(a) => replay(&cfg, a),
        Command::Bench(a) => bench(&cfg, a),
        Command::Train(a) => crate::cli::estimator::train(&cfg, &a.into()),
        Command::Eval(a) if a.fdi => eval_fdi(&cfg, &a),
        Command::Eval(a) => crate::cli::estimator::eval(&cfg, &a.into()),
    };
    match result {
        Ok(()) => EX_OK,
        Err(e) => {
            eprintln!("helmwatch: {:#}", e.error);
            e.code
        }
    }
}

/// An error at the binary's edge, with its exit code.
pub(crate) struct Failure {
    pub(crate) error: anyhow::Error,
    pub(crate) code: i32,
}

pub(crate) fn fail(code: i32) -> impl FnOnce(anyhow::Error) -> Failure {
    move |error| Failure { error, code }
}

fn init_logging() {
    // The demo prints to standard output; its default log level keeps standard error quiet.
    // `train` and `eval` run thousands of tests: the core's per-test lines would drown their
    // tables.
    let default = match std::env::args().nth(1).as_deref() {
        Some("demo") => "error",
        Some("train" | "eval") => "warn,helmwatch::monitor=error",
        _ => "info,zenoh=warn",
    };
    let filter = tracing_subscriber::EnvFilter::try_from_default_env()
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new(default));
    let _ = tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        .try_init();
}

fn load_config(path: Option<&std::path::Path>) -> Result<Config, ConfigError> {
    match path {
        Some(p) => Config::from_file(p),
        None => {
            let cfg = Config::default();
            cfg.check()?;
            Ok(cfg)
        }
    }
}

fn scenario(cfg: &Config, a: &ShipArgs) -> Result<Scenario, Failure> {
    let faults = a
        .faults
        .iter()
        .map(|f| {
            f.parse::<Fault>()
                .map_err(|e| anyhow::anyhow!("--fault {f}: {e}"))
        })
        .collect::<Result<Vec<_>, _>>()
        .map_err(fail(EX_USAGE))?;
    Ok(Scenario {
        speed_mps: a.speed_mps,
        displacement_t: a.displacement_t,
        sea: a.sea.unwrap_or(cfg.sea.state),
        faults,
        seed: a.seed,
    })
}

fn simulate(cfg: &Config, a: SimulateArgs) -> Result<(), Failure> {
    let sc = scenario(cfg, &a.ship)?;
    if !(a.duration_s.is_finite() && a.duration_s > 0.0) {
        return Err(fail(EX_USAGE)(anyhow::anyhow!(
            "--duration-s must be a positive number of seconds"
        )));
    }
    crate::core::config::check_vessel_name("--vessel", &a.vessel)
        .map_err(|e| fail(EX_USAGE)(e.into()))?;
    let lines = if a.out.as_os_str() == "-" {
        let stdout = std::io::stdout();
        crate::sim::record(&cfg.sim(), &sc, a.duration_s, &a.vessel, stdout.lock())
    } else {
        let file = std::fs::File::create(&a.out)
            .map_err(|e| fail(EX_IOERR)(anyhow::anyhow!("{}: {e}", a.out.display())))?;
        crate::sim::record(
            &cfg.sim(),
            &sc,
            a.duration_s,
            &a.vessel,
            std::io::BufWriter::new(file),
        )
    }
    .map_err(|e| fail(EX_IOERR)(e.into()))?;
    tracing::info!(lines, out = %a.out.display(), "recording written");
    Ok(())
}

fn probe(cfg: &Config, a: ProbeArgs) -> Result<(), Failure> {
    let sc = scenario(cfg, &a.ship)?;
    let mut opts = ProbeOptions::new(&cfg.core(), a.method);
    let loaded = match &a.models {
        Some(dir) => Estimator::load_dir(dir, &cfg.core()),
        None => Estimator::embedded(&cfg.core()),
    };
    match loaded {
        Ok(e) => opts.estimator = Some(Arc::new(e)),
        Err(e) => {
            tracing::warn!("no estimate: {e}");
            eprintln!("helmwatch: no estimate: {e}");
        }
    }
    let result =
        run_probe(&cfg.core(), &cfg.sim(), &sc, &opts).map_err(|e| fail(EX_SOFTWARE)(e.into()))?;
    let r = &result.report;
    if a.json {
        let text = serde_json::to_string_pretty(r).map_err(|e| fail(EX_SOFTWARE)(e.into()))?;
        println!("{text}");
    } else {
        println!(
            "{} test {}: {:?} after {:.0} s of ship time",
            r.method.name(),
            r.test,
            r.outcome,
            r.t_end - r.t_start
        );
        if let Some(reason) = &r.reason {
            println!("  reason: {reason}");
        }
        print_features(&r.features);
        print_baseline(&r.features);
        print_estimate(r);
        println!("  decision: {:?}; {}", r.decision, r.message);
    }
    Ok(())
}

fn print_baseline(f: &serde_json::Value) {
    let g = |k: &str| f["baseline"].get(k).and_then(|v| v.as_f64());
    if let (Some(a), Some(b)) = (g("a_per_s"), g("b_per_s2")) {
        println!(
            "  baseline (time domain): a {a:.5} 1/s, b {b:.3e} 1/s^2, speed {:.2} m/s, displacement {:.0} t",
            g("speed_mps").unwrap_or(f64::NAN),
            g("displacement_t").unwrap_or(f64::NAN),
        );
    } else if let Some(e) = f.get("baseline_error").and_then(|v| v.as_str()) {
        println!("  baseline (time domain): none: {e}");
    }
}

fn print_estimate(r: &crate::core::wire::Report) {
    if let Some(e) = &r.estimate {
        println!(
            "  estimate: speed {:.2} m/s, displacement {:.0} t (speed log {:.2} m/s)",
            e.speed_mps,
            e.displacement_t,
            r.features
                .get(crate::core::estimator::features::SPEED_LOG_FIELD)
                .and_then(|v| v.as_f64())
                .unwrap_or(f64::NAN)
        );
    }
}

fn print_features(f: &serde_json::Value) {
    if let Some(tones) = f.get("tones").and_then(|t| t.as_array()) {
        println!("  tone  omega rad/s      gain   phase deg  +-gain %  +-phase deg  coherence");
        for (i, t) in tones.iter().enumerate() {
            let g = |k: &str| t.get(k).and_then(|v| v.as_f64()).unwrap_or(f64::NAN);
            println!(
                "  {:>4}  {:>11.4}  {:>8.4}  {:>10.2}  {:>8.2}  {:>11.2}  {:>9.3}",
                i + 1,
                g("omega_rad_s"),
                g("gain"),
                g("phase_rad").to_degrees(),
                100.0 * g("gain_ci90_rel"),
                g("phase_ci90_rad").to_degrees(),
                g("coherence"),
            );
        }
    } else if let Some(p) = f.get("period_s").and_then(|v| v.as_f64()) {
        let g = |k: &str| f.get(k).and_then(|v| v.as_f64()).unwrap_or(f64::NAN);
        println!(
            "  limit cycle: period {:.1} s (omega_u {:.4} rad/s), amplitude {:.3} deg, trim {:.2} deg, shortest switch interval {:.1} s",
            p,
            g("omega_u_rad_s"),
            g("amplitude_rad").to_degrees(),
            g("trim_rad").to_degrees(),
            g("min_switch_interval_s"),
        );
    }
}

fn check_config(cfg: &Config) -> Result<(), Failure> {
    let text = toml::to_string_pretty(cfg).map_err(|e| fail(EX_SOFTWARE)(e.into()))?;
    println!("{text}");
    Ok(())
}

fn runtime() -> Result<tokio::runtime::Runtime, Failure> {
    tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()
        .map_err(|e| fail(EX_OSERR)(anyhow::anyhow!("cannot start the async runtime: {e}")))
}

fn check_endpoints(flag: &str, eps: &[String]) -> Result<(), Failure> {
    for e in eps {
        crate::shells::net::check_endpoint(flag, e).map_err(|e| fail(EX_USAGE)(e.into()))?;
    }
    Ok(())
}

fn run_daemon(cfg: &Config, a: RunArgs) -> Result<(), Failure> {
    use crate::shells::daemon::{Daemon, DaemonError};
    use crate::shells::systemd;
    check_endpoints("--listen", &a.listen)?;
    check_endpoints("--connect", &a.connect)?;
    let zcfg = crate::shells::net::zenoh_config(&cfg.zenoh, &a.listen, &a.connect)
        .map_err(|e| fail(EX_CONFIG)(e.into()))?;
    let rt = runtime()?;
    rt.block_on(async {
        let daemon = Daemon::start(&cfg.core(), &cfg.daemon, zcfg)
            .await
            .map_err(|e| {
                let code = match e {
                    DaemonError::Config(_) | DaemonError::Estimator(_) => EX_CONFIG,
                    DaemonError::Open(_) => EX_UNAVAILABLE,
                    DaemonError::Declare { .. } => EX_SOFTWARE,
                };
                fail(code)(e.into())
            })?;
        let status = format!("monitoring {} vessel(s)", daemon.vessels().len());
        systemd::ready(&status);
        let watchdog = systemd::spawn_watchdog();
        daemon
            .run(async {
                systemd::signals().await;
                systemd::stopping();
            })
            .await;
        if let Some(w) = watchdog {
            w.abort();
        }
        Ok(())
    })
}

fn ship(cfg: &Config, a: ShipPeerArgs) -> Result<(), Failure> {
    use crate::shells::shipnode::{ShipNode, ShipNodeOptions};
    let mut sc = scenario(cfg, &a.ship)?;
    let mut faults = cfg
        .ship_peer
        .faults
        .iter()
        .map(|f| f.parse::<Fault>())
        .collect::<Result<Vec<_>, _>>()
        .map_err(|e| fail(EX_CONFIG)(e.into()))?;
    faults.append(&mut sc.faults);
    sc.faults = faults;
    let mut opts = ShipNodeOptions::from_config(&cfg.ship_peer, &cfg.simulation.vessel);
    if let Some(v) = a.vessel {
        crate::core::config::check_vessel_name("--vessel", &v)
            .map_err(|e| fail(EX_USAGE)(e.into()))?;
        opts.vessel = v;
    }
    if a.real_time {
        opts.lockstep = false;
    }
    if let Some(s) = a.speed_up {
        crate::core::config::check_range_open_low("--speed-up", s, 0.0, 10000.0)
            .map_err(|e| fail(EX_USAGE)(e.into()))?;
        opts.speed_up = s;
    }
    if let Some(d) = a.duration_s {
        crate::core::config::check_range_open_low("--duration-s", d, 0.0, 366.0 * 86400.0)
            .map_err(|e| fail(EX_USAGE)(e.into()))?;
        opts.duration_s = Some(d);
    }
    check_endpoints("--listen", &a.listen)?;
    check_endpoints("--connect", &a.connect)?;
    let zcfg = crate::shells::net::zenoh_config(&cfg.ship_peer.zenoh(), &a.listen, &a.connect)
        .map_err(|e| fail(EX_CONFIG)(e.into()))?;
    let mut node = ShipNode::new(&cfg.sim(), &sc, opts).map_err(|e| fail(EX_USAGE)(e.into()))?;
    if let Some(path) = &a.record {
        let file = std::fs::File::create(path)
            .map_err(|e| fail(EX_IOERR)(anyhow::anyhow!("{}: {e}", path.display())))?;
        node = node.record_to(file);
    }
    let rt = runtime()?;
    let summary = rt
        .block_on(node.run(zcfg, crate::shells::systemd::signals()))
        .map_err(|e| fail(EX_UNAVAILABLE)(e.into()))?;
    println!(
        "ship: {} ticks, t = {:.1} s, {} excitations received, {} lockstep timeouts",
        summary.ticks, summary.t_end_s, summary.excitations, summary.excitation_timeouts
    );
    Ok(())
}

fn demo(cfg: &Config, a: DemoArgs) -> Result<(), Failure> {
    let fault = a
        .fault
        .parse::<Fault>()
        .map_err(|e| fail(EX_USAGE)(anyhow::anyhow!("--fault {}: {e}", a.fault)))?;
    let opts = crate::tools::demo::DemoOptions {
        seed: a.seed,
        fault,
        fault_reports: a.fault_reports,
        ..crate::tools::demo::DemoOptions::default()
    };
    let rt = runtime()?;
    let mut out = std::io::stdout();
    rt.block_on(crate::tools::demo::run(cfg, &opts, &mut out))
        .map_err(|e| fail(EX_SOFTWARE)(e.into()))?;
    Ok(())
}

fn replay(cfg: &Config, a: ReplayArgs) -> Result<(), Failure> {
    use crate::core::monitor::Output;
    let reader: Box<dyn std::io::BufRead> = if a.file.as_os_str() == "-" {
        Box::new(std::io::BufReader::new(std::io::stdin()))
    } else {
        let f = std::fs::File::open(&a.file)
            .map_err(|e| fail(EX_IOERR)(anyhow::anyhow!("{}: {e}", a.file.display())))?;
        Box::new(std::io::BufReader::new(f))
    };
    let json = a.json;
    let sum = crate::drivers::replay::replay(&cfg.core(), reader, |vessel, out| {
        if let Output::Report(r) = out {
            if json {
                if let Ok(line) = serde_json::to_string(r) {
                    println!("{line}");
                }
            } else {
                println!(
                    "{vessel}: {} test {} t = {:.1} .. {:.1} s: {:?}{}",
                    r.method.name(),
                    r.test,
                    r.t_start,
                    r.t_end,
                    r.outcome,
                    r.reason
                        .as_ref()
                        .map(|x| format!(" ({x})"))
                        .unwrap_or_default()
                );
                print_features(&r.features);
                println!("  decision: {:?}; {}", r.decision, r.message);
            }
        }
    })
    .map_err(|e| fail(EX_IOERR)(e.into()))?;
    tracing::info!(
        lines = sum.lines,
        bad_lines = sum.bad_lines,
        skipped = sum.skipped,
        rejected = sum.rejected,
        reports = sum.reports,
        vessels = sum.vessels,
        "replay done"
    );
    if sum.lines > 0 && sum.bad_lines == sum.lines {
        return Err(fail(EX_DATAERR)(anyhow::anyhow!(
            "{}: no line is a {{\"key\", \"payload\"}} object",
            a.file.display()
        )));
    }
    Ok(())
}

fn bench(cfg: &Config, a: BenchArgs) -> Result<(), Failure> {
    let rt = runtime()?;
    let window = std::time::Duration::from_secs_f64(a.window_s.clamp(1.0, 600.0));
    if let Some(n) = a.one_fleet {
        let f = rt
            .block_on(crate::tools::bench::fleet(cfg, n, window))
            .map_err(|e| fail(EX_SOFTWARE)(e.into()))?;
        println!(
            "{}",
            serde_json::json!({
                "vessels": f.vessels, "headings": f.headings, "excitations": f.excitations,
                "p50_ms": f.p50_ms, "p99_ms": f.p99_ms, "flood_drops": f.flood_drops,
                "rss_mib": f.rss_mib, "kept_up": f.kept_up,
            })
        );
        return Ok(());
    }
    let profile = if cfg!(debug_assertions) {
        "an optimised build with debug assertions (profile ci) or a debug build"
    } else {
        "a release build"
    };
    println!(
        "helmwatch bench ({profile}; {} CPUs)",
        std::thread::available_parallelism()
            .map(|n| n.get())
            .unwrap_or(1)
    );
    let l = rt
        .block_on(crate::tools::bench::lockstep(cfg, a.lockstep_s))
        .map_err(|e| fail(EX_SOFTWARE)(e.into()))?;
    println!(
        "lockstep, one vessel over Zenoh at {} Hz: {:.0} ship s in {:.2} wall s = {:.0}x real time ({} lockstep timeouts)",
        cfg.sensors.rate_hz, l.ship_s, l.wall_s, l.ratio, l.excitation_timeouts
    );
    drop(rt);
    // Each fleet size in a fresh process, so its memory is its own.
    let exe = std::env::current_exe().map_err(|e| fail(EX_OSERR)(e.into()))?;
    let mut best = 0usize;
    for n in a.fleet {
        let mut cmd = std::process::Command::new(&exe);
        if let Some(c) = &cli_config_path() {
            cmd.arg("--config").arg(c);
        }
        let out = cmd
            .args([
                "bench",
                "--window-s",
                &a.window_s.to_string(),
                "--one-fleet",
                &n.to_string(),
            ])
            .env("RUST_LOG", "off")
            .stderr(std::process::Stdio::null())
            .output()
            .map_err(|e| fail(EX_OSERR)(e.into()))?;
        let text = String::from_utf8_lossy(&out.stdout);
        let Some(v) = text
            .lines()
            .rev()
            .find_map(|l| serde_json::from_str::<serde_json::Value>(l).ok())
        else {
            println!("fleet of {n}: the measurement failed ({})", out.status);
            break;
        };
        let g = |k: &str| v.get(k).and_then(|x| x.as_f64()).unwrap_or(f64::NAN);
        let kept = v.get("kept_up").and_then(|x| x.as_bool()).unwrap_or(false);
        println!(
            "fleet of {n} vessels at 10 Hz: {:.0}/{:.0} headings answered, delay p50 {:.1} ms p99 {:.1} ms, {:.0} flood drops, RSS {:.0} MiB: {}",
            g("excitations"), g("headings"), g("p50_ms"), g("p99_ms"), g("flood_drops"), g("rss_mib"),
            if kept { "kept up" } else { "NOT kept up" }
        );
        if !kept {
            break;
        }
        best = n;
    }
    println!("vessels kept up with at 10 Hz: {best} (largest size tried that passed)");
    Ok(())
}

/// The `--config` path of this invocation, to pass on to child processes.
fn cli_config_path() -> Option<PathBuf> {
    let mut args = std::env::args_os();
    while let Some(a) = args.next() {
        if a == "--config" {
            return args.next().map(PathBuf::from);
        }
        if let Some(s) = a.to_str() {
            if let Some(p) = s.strip_prefix("--config=") {
                return Some(PathBuf::from(p));
            }
        }
    }
    None
}

impl From<TrainArgs> for TrainOptions {
    fn from(a: TrainArgs) -> Self {
        Self {
            seed: a.seed,
            out: a.out,
            points: a.points,
            restarts: a.restarts,
            threads: a.threads,
        }
    }
}

fn eval_fdi(cfg: &Config, a: &EvalArgs) -> Result<(), Failure> {
    use crate::tools::eval::fdi::{run_suite, FdiEvalOptions};
    let t0 = std::time::Instant::now();
    let est = crate::core::estimator::Estimator::load_dir(&a.models, &cfg.core())
        .map_err(|e| fail(EX_CONFIG)(e.into()))?;
    let mut o = FdiEvalOptions {
        seed: a.seed,
        runs: a.runs,
        nominal_runs: a.nominal_runs,
        tests: a.tests.max(1),
        threads: a
            .threads
            .unwrap_or_else(crate::tools::training::database::default_threads)
            .max(1),
        ..FdiEvalOptions::default()
    };
    if let Some(m) = a.method {
        o.methods = vec![m];
    }
    if let Some(s) = a.sea {
        o.seas = vec![s];
    }
    run_suite(cfg, std::sync::Arc::new(est), &o);
    println!();
    println!("suite done in {:.1} s", t0.elapsed().as_secs_f64());
    Ok(())
}

impl From<EvalArgs> for EvalOptions {
    fn from(a: EvalArgs) -> Self {
        Self {
            seed: a.seed,
            models: a.models,
            points: a.points,
            drift: a.drift,
            lengths: !a.no_lengths,
            threads: a.threads,
        }
    }
}
