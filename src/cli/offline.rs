//! The offline subcommands: `simulate`, `probe`, `replay`, `check-config`, `eval --fdi` and
//! `plot`.
//! Each parses nothing itself (see [`super::args`]), calls one floor below and prints.

use super::args::{EvalArgs, PlotArgs, ProbeArgs, ReplayArgs, ShipArgs, SimulateArgs};
use super::print::{print_baseline, print_estimate, print_features};
use super::Failure;
use crate::config::Config;
use crate::tools::results::{models_suffix, slug};
use helmwatch_core::drivers::probe::{run_probe, ProbeOptions};
use helmwatch_core::estimator::Estimator;
use helmwatch_core::sim::{Fault, Scenario};
use std::path::PathBuf;
use std::sync::Arc;

pub(crate) fn scenario(cfg: &Config, a: &ShipArgs) -> Result<Scenario, Failure> {
    let faults = a
        .faults
        .iter()
        .map(|f| {
            f.parse::<Fault>()
                .map_err(|e| anyhow::anyhow!("--fault {f}: {e}"))
        })
        .collect::<Result<Vec<_>, _>>()
        .map_err(Failure::Usage)?;
    Ok(Scenario {
        speed_mps: a.speed_mps.unwrap_or(cfg.ship.nominal_speed_mps),
        displacement_t: a.displacement_t.unwrap_or(cfg.ship.nominal_displacement_t),
        sea: a.sea.unwrap_or(cfg.sea.state),
        faults,
        seed: a.seed,
    })
}

pub(crate) fn simulate(cfg: &Config, a: SimulateArgs) -> Result<(), Failure> {
    let sc = scenario(cfg, &a.ship)?;
    if !(a.duration_s.is_finite() && a.duration_s > 0.0) {
        return Err(Failure::Usage(anyhow::anyhow!(
            "--duration-s must be a positive number of seconds"
        )));
    }
    helmwatch_core::config::check_vessel_name("--vessel", &a.vessel).map_err(Failure::usage)?;
    let lines = if a.out.as_os_str() == "-" {
        let stdout = std::io::stdout();
        helmwatch_core::sim::record(&cfg.sim(), &sc, a.duration_s, &a.vessel, stdout.lock())
    } else {
        let file = std::fs::File::create(&a.out).map_err(|e| Failure::io(&a.out, e))?;
        helmwatch_core::sim::record(
            &cfg.sim(),
            &sc,
            a.duration_s,
            &a.vessel,
            std::io::BufWriter::new(file),
        )
    }
    .map_err(|e| Failure::Write(e.into()))?;
    tracing::info!(lines, out = %a.out.display(), "recording written");
    Ok(())
}

pub(crate) fn probe(cfg: &Config, a: ProbeArgs) -> Result<(), Failure> {
    let sc = scenario(cfg, &a.ship)?;
    let mut opts = ProbeOptions::new(&cfg.core(), a.method);
    // `--models` overrides the configuration's `estimator.models-dir` (the vessel's own
    // with `--vessel`); without either the embedded models serve.
    let loaded = match &a.models {
        Some(dir) => Estimator::load_dir(dir, &cfg.core()).map(|e| Some(Arc::new(e))),
        None => Estimator::from_config(&cfg.core()),
    };
    match loaded {
        Ok(e) => opts.estimator = e,
        Err(e) => {
            tracing::warn!("no estimate: {e}");
            eprintln!("helmwatch: no estimate: {e}");
        }
    }
    let result = run_probe(&cfg.core(), &cfg.sim(), &sc, &opts).map_err(Failure::software)?;
    let r = &result.report;
    if a.json {
        let text = serde_json::to_string_pretty(r).map_err(Failure::software)?;
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

pub(crate) fn replay(cfg: &Config, a: ReplayArgs) -> Result<(), Failure> {
    use helmwatch_core::monitor::Output;
    use std::io::BufRead;
    let mut reader: Box<dyn std::io::BufRead> = if a.file.as_os_str() == "-" {
        Box::new(std::io::BufReader::new(std::io::stdin()))
    } else {
        let f = std::fs::File::open(&a.file).map_err(|e| Failure::io(&a.file, e))?;
        Box::new(std::io::BufReader::new(f))
    };
    // An MCAP recording (the daemon's `[daemon] record`) starts with its magic bytes.
    let mcap = crate::shells::recording::replay::is_mcap(
        reader.fill_buf().map_err(|e| Failure::io(&a.file, e))?,
    );
    let json = a.json;
    // Vessels with a `[vessel.<name>]` table are replayed with their own configuration.
    let own = cfg
        .vessel
        .keys()
        .map(|v| Ok((v.clone(), cfg.for_vessel(v)?.core())))
        .collect::<Result<Vec<_>, helmwatch_core::config::ConfigError>>()?;
    let on_output = |vessel: &str, out: &Output| {
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
    };
    let sum = if mcap {
        crate::shells::recording::replay::replay_mcap(&cfg.core(), &own, reader, on_output)
    } else {
        helmwatch_core::drivers::replay::replay_fleet(&cfg.core(), &own, reader, on_output)
    }
    .map_err(|e| Failure::Write(e.into()))?;
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
        return Err(Failure::Data(anyhow::anyhow!(
            "{}: no line is a {{\"key\", \"payload\"}} object",
            a.file.display()
        )));
    }
    Ok(())
}

pub(crate) fn check_config(cfg: &Config) -> Result<(), Failure> {
    let text = toml::to_string_pretty(cfg).map_err(Failure::software)?;
    println!("{text}");
    Ok(())
}

impl EvalArgs {
    /// The models `eval` reads: `--models`, else the configuration's `estimator.models-dir`
    /// (a class's, as every other subcommand reads it), else `models`.
    pub(crate) fn models_dir(&self, cfg: &Config) -> PathBuf {
        (self.models.clone())
            .or_else(|| cfg.estimator.models_dir.as_ref().map(PathBuf::from))
            .unwrap_or_else(|| PathBuf::from("models"))
    }

    /// The results page's name after `-seed<S>`: `-<member>` for `--member TEXT`, and
    /// `-models-<dir>` when a models directory is named (by `--models` or the configuration),
    /// as `bench --time-to-alarm` names its pages.
    fn page_suffix(&self, cfg: &Config) -> String {
        let member = (self.member.as_deref()).map_or(String::new(), |m| format!("-{}", slug(m)));
        let named =
            (self.models.clone()).or_else(|| cfg.estimator.models_dir.as_ref().map(PathBuf::from));
        format!("{member}{}", models_suffix(named.as_deref()))
    }
}

pub(crate) fn eval_fdi(cfg: &Config, a: &EvalArgs) -> Result<(), Failure> {
    use crate::tools::eval::fdi::compare::{compare_table, suite_name};
    use crate::tools::eval::fdi::{run_suite, FdiEvalOptions};
    let t0 = std::time::Instant::now();
    let est = helmwatch_core::estimator::Estimator::load_dir(&a.models_dir(cfg), &cfg.core())?;
    let mut o = FdiEvalOptions {
        seed: a.seed,
        runs: a.runs,
        nominal_runs: a.nominal_runs,
        tests: a.tests.max(1),
        threads: eval_threads(a),
        ..FdiEvalOptions::default()
    };
    o.family = a.family;
    o.member = a.member.clone();
    o.outcomes = a.outcomes.clone();
    o.in_turn = a.in_turn;
    o.scenarios = a.scenarios;
    o.onset_after = a.onset_after;
    if let Some(m) = a.method {
        o.methods = vec![m];
    }
    if let Some(s) = a.sea {
        o.seas = vec![s];
    }
    let est = std::sync::Arc::new(est);
    let res = run_suite(cfg, est.clone(), &o);
    let mut body = res.text.clone();
    if let Some(dir) = &a.compare {
        let name = format!("{}{}", suite_name(&o), a.page_suffix(cfg));
        let before = read_figures(&dir.join(format!("{name}.json")))?;
        body.push_str(&format!(
            "\n## Before and after\n\nBefore: `{}`. A count marked **(differs)** is past Monte Carlo noise (pooled two-proportion |z| > 2).\n\n{}",
            dir.display(),
            compare_table(&before, &res.figures)
        ));
    }
    if let Some(list) = &a.ablate {
        let ms = mechanisms(list)?;
        body.push_str(&crate::tools::eval::fdi::ablate::ablate(
            cfg,
            &est,
            &o,
            &res.figures,
            &ms,
        ));
    }
    print!("{body}");
    if let Some(dir) = &a.results {
        let name = format!("{}{}", suite_name(&o), a.page_suffix(cfg));
        let io = |e: std::io::Error| Failure::io(dir, e);
        let path = crate::tools::results::write(dir, &name, o.seed, &body).map_err(io)?;
        let json = serde_json::to_vec_pretty(&res.figures).map_err(Failure::software)?;
        crate::tools::results::write_atomic(&dir.join(format!("{name}.json")), &json)
            .map_err(io)?;
        eprintln!("wrote {}", path.display());
    }
    println!();
    println!("suite done in {:.1} s", t0.elapsed().as_secs_f64());
    Ok(())
}

/// `eval --budget`: the decision's Monte Carlo on its own model, printed and with
/// `--results DIR` written to `DIR/budget-seed<SEED>.md`.
pub(crate) fn eval_budget(a: &EvalArgs) -> Result<(), Failure> {
    let threads = eval_threads(a);
    let body = crate::tools::eval::budget::budget_table(a.seed, threads);
    print_and_write(a, &format!("budget-seed{}", a.seed), &body)
}

/// `--threads`, or every core; at least one.
fn eval_threads(a: &EvalArgs) -> usize {
    a.threads
        .unwrap_or_else(crate::tools::training::database::default_threads)
        .max(1)
}

/// Prints `body`, and with `--results DIR` writes it to `DIR/<name>.md`.
fn print_and_write(a: &EvalArgs, name: &str, body: &str) -> Result<(), Failure> {
    print!("{body}");
    if let Some(dir) = &a.results {
        let path = crate::tools::results::write(dir, name, a.seed, body)
            .map_err(|e| Failure::io(dir, e))?;
        eprintln!("wrote {}", path.display());
    }
    Ok(())
}

/// `eval --crb`: one test's Cramer-Rao bound beside the networks' spread (theirs of
/// `--models`, else the configuration's), printed and with `--results DIR` written to
/// `DIR/crb-seed<SEED>[-<member>][-models-<dir>].md`.
pub(crate) fn eval_crb(cfg: &Config, a: &EvalArgs) -> Result<(), Failure> {
    let mut cfg = cfg.clone();
    if let Some(dir) = &a.models {
        cfg.estimator.models_dir = Some(dir.to_string_lossy().into_owned());
    }
    let cfg = &cfg;
    let threads = eval_threads(a);
    let o = crate::tools::eval::crb::CrbOptions {
        tests: a.runs,
        seed: a.seed,
        threads,
        family: a.family,
        member: a.member.clone(),
    };
    let body = crate::tools::eval::crb::crb_table(cfg, &o);
    print_and_write(
        a,
        &format!("crb-seed{}{}", a.seed, a.page_suffix(cfg)),
        &body,
    )
}

/// `eval --passive`: the passive watch's bound and Whittle's estimator against it, printed
/// and with `--results DIR` written to `DIR/passive-seed<SEED>.md`.
pub(crate) fn eval_passive(cfg: &Config, a: &EvalArgs) -> Result<(), Failure> {
    let threads = eval_threads(a);
    let o = crate::tools::eval::passive::PassiveOptions {
        runs: a.runs.max(2),
        seed: a.seed,
        threads,
    };
    let body = crate::tools::eval::passive::passive_table(cfg, &o);
    print_and_write(a, &format!("passive-seed{}", a.seed), &body)
}

/// The mechanisms `--ablate` names, one set per comma (`a+b`: both off together; `all`:
/// every one alone); exit 64 naming the allowed ones.
pub(crate) fn mechanisms(
    list: &str,
) -> Result<Vec<Vec<helmwatch_core::fdi::ablation::Mechanism>>, Failure> {
    use helmwatch_core::fdi::ablation::Mechanism;
    if list == "all" {
        return Ok(Mechanism::ALL.iter().map(|&m| vec![m]).collect());
    }
    let one = |w: &str| {
        Mechanism::ALL
            .into_iter()
            .find(|m| m.name() == w.trim())
            .ok_or_else(|| {
                let names: Vec<&str> = Mechanism::ALL.iter().map(|m| m.name()).collect();
                Failure::Usage(anyhow::anyhow!(
                    "--ablate: unknown mechanism {w:?}; one of all, {} (a+b: both off)",
                    names.join(", ")
                ))
            })
    };
    list.split(',')
        .map(|set| set.split('+').map(one).collect())
        .collect()
}

/// The figures an earlier `eval --fdi --results` wrote.
fn read_figures(
    path: &std::path::Path,
) -> Result<Vec<crate::tools::eval::fdi::RowFigures>, Failure> {
    let text = std::fs::read_to_string(path).map_err(|e| Failure::io(path, e))?;
    serde_json::from_str(&text)
        .map_err(|e| Failure::Data(anyhow::anyhow!("{}: {e}", path.display())))
}

/// `helmwatch plot`: exit 65 when the input is not what its kind needs, 64 for a bad size or
/// vessel, 74 when a file cannot be read or written.
pub(crate) fn plot(cfg: &Config, a: PlotArgs) -> Result<(), Failure> {
    use crate::tools::plot::{
        as_text, detect, plot, plot_mcap, read_input, InputKind, PlotError, PlotOptions,
    };
    for (key, v) in [("--width", a.width), ("--height", a.height)] {
        if !(200..=10_000).contains(&v) {
            return Err(Failure::Usage(anyhow::anyhow!(
                "{key}: 200 to 10000 pixels, not {v}"
            )));
        }
    }
    if let Some(v) = &a.vessel {
        helmwatch_core::config::check_vessel_name("--vessel", v).map_err(Failure::usage)?;
    }
    let bytes = read_input(&a.input).map_err(|e| Failure::io(&a.input, e))?;
    let code = |e: PlotError| Failure::plot(&a.input, e);
    let opts = PlotOptions {
        width_px: a.width,
        height_px: a.height,
        vessel: a.vessel.clone(),
    };
    let (kind, svg) = if crate::shells::recording::replay::is_mcap(&bytes) {
        if a.kind.is_some_and(|k| k != InputKind::Recording) {
            return Err(code(PlotError::Data(
                "an MCAP file is a recording (--kind recording)".into(),
            )));
        }
        let svg = plot_mcap(&bytes, &opts).map_err(code)?;
        (InputKind::Recording, svg)
    } else {
        let text = as_text(&bytes).map_err(code)?;
        let kind = match a.kind {
            Some(k) => k,
            None => detect(text).map_err(code)?,
        };
        (kind, plot(cfg, text, kind, &opts).map_err(code)?)
    };
    std::fs::write(&a.out, svg).map_err(|e| Failure::io(&a.out, e))?;
    eprintln!(
        "helmwatch: {} ({}) drawn to {}",
        a.input.display(),
        kind.name(),
        a.out.display()
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::super::args::{Cli, Command};
    use super::*;
    use clap::Parser as _;

    fn eval_args(argv: &[&str]) -> EvalArgs {
        let argv = ["helmwatch", "eval", "--crb"].iter().chain(argv);
        match Cli::try_parse_from(argv).unwrap().command {
            Command::Eval(a) => a,
            other => panic!("not eval: {other:?}"),
        }
    }

    /// `eval` reads the models every other subcommand reads (the configuration's class),
    /// `--models` before it, `models` without either; its page is named after the member and
    /// a named models directory, as `bench --time-to-alarm`'s are.
    #[test]
    fn eval_reads_the_configured_models_and_names_its_page_after_them() {
        let design = Config::default();
        let mut class = Config::default();
        class.estimator.models_dir = Some("models/classes/kvlcc2-120".into());
        let plain = eval_args(&[]);
        assert_eq!(plain.models_dir(&design), PathBuf::from("models"));
        assert_eq!(plain.page_suffix(&design), "");
        assert_eq!(
            plain.models_dir(&class),
            PathBuf::from("models/classes/kvlcc2-120")
        );
        assert_eq!(plain.page_suffix(&class), "-models-kvlcc2-120");
        let named = eval_args(&[
            "--family",
            "--member",
            "120 m",
            "--models",
            "/srv/m/Mariner",
        ]);
        assert_eq!(named.models_dir(&class), PathBuf::from("/srv/m/Mariner"));
        assert_eq!(named.page_suffix(&class), "-120-m-models-mariner");
        assert_eq!(named.page_suffix(&design), "-120-m-models-mariner");
    }
}
