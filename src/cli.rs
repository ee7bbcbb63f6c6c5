//! The `helmwatch` command line: thin drivers around the library.
//!
//! Logging starts before anything else, so configuration errors are logged. Exit codes follow
//! sysexits: 0 success, 64 usage, 65 bad input data, 70 internal error, 74 I/O error,
//! 78 configuration error.

use crate::config::{Config, ConfigError, Method, SeaState};
use crate::probe::{run_probe, ProbeOptions};
use crate::sim::{Fault, Scenario};
use clap::{Args, Parser, Subcommand};
use std::path::PathBuf;

/// Exit code: success.
pub const EX_OK: i32 = 0;
/// Exit code: command line usage error.
pub const EX_USAGE: i32 = 64;
/// Exit code: bad input data.
pub const EX_DATAERR: i32 = 65;
/// Exit code: internal software error.
pub const EX_SOFTWARE: i32 = 70;
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
struct Failure {
    error: anyhow::Error,
    code: i32,
}

fn fail(code: i32) -> impl FnOnce(anyhow::Error) -> Failure {
    move |error| Failure { error, code }
}

fn init_logging() {
    let filter = tracing_subscriber::EnvFilter::try_from_default_env()
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("info"));
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
    crate::config::check_vessel_name("--vessel", &a.vessel)
        .map_err(|e| fail(EX_USAGE)(e.into()))?;
    let lines = if a.out.as_os_str() == "-" {
        let stdout = std::io::stdout();
        crate::sim::record(cfg, &sc, a.duration_s, &a.vessel, stdout.lock())
    } else {
        let file = std::fs::File::create(&a.out)
            .map_err(|e| fail(EX_IOERR)(anyhow::anyhow!("{}: {e}", a.out.display())))?;
        crate::sim::record(
            cfg,
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
    let opts = ProbeOptions::new(cfg, a.method);
    let result = run_probe(cfg, &sc, &opts).map_err(|e| fail(EX_SOFTWARE)(e.into()))?;
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
        println!("  decision: {:?}; {}", r.decision, r.message);
    }
    Ok(())
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
