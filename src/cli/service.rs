//! The subcommands that open a Zenoh session: `run` (the daemon), `ship` (the simulated ship
//! as a peer), `demo`, `bench` and `bridge nmea` (NMEA in, the contract's keys out).

use super::args::{BenchArgs, DemoArgs, NmeaBridgeArgs, RunArgs, ShipPeerArgs};
use super::offline::scenario;
use super::Failure;
use crate::config::Config;
use crate::tools::results::{models_suffix, slug};
use helmwatch_core::sim::Fault;
use std::path::Path;

pub(crate) fn runtime() -> Result<tokio::runtime::Runtime, Failure> {
    tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()
        .map_err(|e| Failure::Os(anyhow::anyhow!("cannot start the async runtime: {e}")))
}

pub(crate) fn check_endpoints(flag: &str, eps: &[String]) -> Result<(), Failure> {
    for e in eps {
        crate::shells::net::check_endpoint(flag, e).map_err(Failure::usage)?;
    }
    Ok(())
}

pub(crate) fn run_daemon(cfg: &Config, a: RunArgs) -> Result<(), Failure> {
    use crate::shells::daemon::Daemon;
    use crate::shells::systemd;
    check_endpoints("--listen", &a.listen)?;
    check_endpoints("--connect", &a.connect)?;
    let zcfg = crate::shells::net::zenoh_config(&cfg.zenoh, &a.listen, &a.connect)?;
    let mut dcfg = cfg.daemon.clone();
    if let Some(d) = &a.state_dir {
        dcfg.state_dir = Some(d.display().to_string());
    }
    // Each vessel's own configuration: `[vessel.<name>]` over the file's top level.
    let fleet = cfg.fleet()?;
    let rt = runtime()?;
    rt.block_on(async {
        let daemon = Daemon::start_fleet(&fleet, &dcfg, zcfg).await?;
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

pub(crate) fn ship(cfg: &Config, a: ShipPeerArgs) -> Result<(), Failure> {
    use crate::shells::shipnode::{ShipNode, ShipNodeOptions};
    let vessel = match &a.vessel {
        Some(v) => {
            helmwatch_core::config::check_vessel_name("--vessel", v).map_err(Failure::usage)?;
            v.clone()
        }
        None => cfg.simulation.vessel.clone(),
    };
    // The simulated ship is the vessel's own: `[vessel.<name>]` over the top level.
    let cfg = &cfg.for_vessel(&vessel)?;
    let mut sc = scenario(cfg, &a.ship)?;
    let mut faults = cfg
        .ship_peer
        .faults
        .iter()
        .map(|f| f.parse::<Fault>())
        .collect::<Result<Vec<_>, _>>()?;
    faults.append(&mut sc.faults);
    sc.faults = faults;
    let mut opts = ShipNodeOptions::from_config(&cfg.ship_peer, &vessel);
    if a.real_time {
        opts.lockstep = false;
    }
    if let Some(s) = a.speed_up {
        helmwatch_core::config::check_range_open_low("--speed-up", s, 0.0, 10000.0)
            .map_err(Failure::usage)?;
        opts.speed_up = s;
    }
    if let Some(d) = a.duration_s {
        helmwatch_core::config::check_range_open_low("--duration-s", d, 0.0, 366.0 * 86400.0)
            .map_err(Failure::usage)?;
        opts.duration_s = Some(d);
    }
    check_endpoints("--listen", &a.listen)?;
    check_endpoints("--connect", &a.connect)?;
    let zcfg = crate::shells::net::zenoh_config(&cfg.ship_peer.zenoh(), &a.listen, &a.connect)?;
    let mut node = ShipNode::new(&cfg.sim(), &sc, opts).map_err(Failure::usage)?;
    if let Some(path) = &a.record {
        let file = std::fs::File::create(path).map_err(|e| Failure::io(path, e))?;
        node = node.record_to(file);
    }
    if let Some(addr) = a.nmea_udp {
        node = node.nmea_to(addr);
    }
    let rt = runtime()?;
    let summary = rt
        .block_on(node.run(zcfg, crate::shells::systemd::signals()))
        .map_err(|e| Failure::Unavailable(e.into()))?;
    println!(
        "ship: {} ticks, t = {:.1} s, {} excitations received, {} lockstep timeouts",
        summary.ticks, summary.t_end_s, summary.excitations, summary.excitation_timeouts
    );
    Ok(())
}

pub(crate) fn demo(cfg: &Config, a: DemoArgs) -> Result<(), Failure> {
    let fault = a
        .fault
        .parse::<Fault>()
        .map_err(|e| Failure::Usage(anyhow::anyhow!("--fault {}: {e}", a.fault)))?;
    let opts = crate::tools::demo::DemoOptions {
        seed: a.seed,
        fault,
        fault_reports: a.fault_reports,
        ..crate::tools::demo::DemoOptions::default()
    };
    let rt = runtime()?;
    let mut out = std::io::stdout();
    rt.block_on(crate::tools::demo::run(cfg, &opts, &mut out))
        .map_err(Failure::software)?;
    Ok(())
}

pub(crate) fn bench(cfg: &Config, config: Option<&Path>, a: BenchArgs) -> Result<(), Failure> {
    use crate::tools::bench;
    if a.time_to_alarm {
        return time_to_alarm(cfg, &a);
    }
    let rt = runtime()?;
    let window = std::time::Duration::from_secs_f64(a.window_s.clamp(1.0, 600.0));
    if let Some(n) = a.one_fleet {
        let f = rt
            .block_on(bench::fleet(cfg, n, window))
            .map_err(Failure::software)?;
        println!("{}", bench::fleet_json(&f));
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
        .block_on(bench::lockstep(cfg, a.lockstep_s))
        .map_err(Failure::software)?;
    println!(
        "lockstep, one vessel over Zenoh at {} Hz: {:.0} ship s in {:.2} wall s = {:.0}x real time ({} lockstep timeouts)",
        cfg.sensors.rate_hz, l.ship_s, l.wall_s, l.ratio, l.excitation_timeouts
    );
    drop(rt);
    let exe = std::env::current_exe().map_err(|e| Failure::Os(e.into()))?;
    let best = bench::fleet_sizes(&exe, config, &a.fleet, a.window_s, &mut std::io::stdout())
        .map_err(|e| Failure::Os(e.into()))?;
    println!("vessels kept up with at 10 Hz: {best} (largest size tried that passed)");
    Ok(())
}

/// The one member of the family whose name contains `text`, `cfg` with its structure and
/// autopilot (`bench --time-to-alarm --member`); exit 64 naming the members otherwise.
fn family_member(cfg: &Config, text: &str) -> Result<(&'static str, Config), Failure> {
    let found = crate::tools::eval::fdi::family_members(cfg, Some(text));
    match <[_; 1]>::try_from(found) {
        Ok([(_, name, c)]) => Ok((name, c)),
        Err(_) => {
            let names: Vec<&str> = (helmwatch_core::sim::config::family().iter())
                .skip(1)
                .map(|m| m.name)
                .collect();
            Err(Failure::Usage(anyhow::anyhow!(
                "--member {text:?}: one member's name or part of it, of: {}",
                names.join("; ")
            )))
        }
    }
}

/// The time-to-alarm page's name: `time-to-alarm-<sea>-seed<S>[-<member>][-models-<dir>]
/// [-<mechanisms>-off]`, `<dir>` the models directory's name when one is set (a class's).
fn page_name(
    cfg: &Config,
    o: &crate::tools::time_to_alarm::TimeToAlarmOptions,
    member: Option<&str>,
    off: &[helmwatch_core::fdi::ablation::Mechanism],
) -> String {
    let models = models_suffix(
        cfg.estimator
            .models_dir
            .as_deref()
            .map(std::path::Path::new),
    );
    let ship: String = member.map_or(String::new(), |name| format!("-{}", slug(name)));
    let off: String = if off.is_empty() {
        String::new()
    } else {
        let names: String = off.iter().map(|m| format!("-{}", m.name())).collect();
        format!("{names}-off")
    };
    format!(
        "time-to-alarm-{}-seed{}{ship}{models}{off}",
        o.sea.name(),
        o.seed
    )
}

/// `helmwatch bench --time-to-alarm`: exit 64 for a bad interval, run count or cap, 70 when
/// a run fails.
fn time_to_alarm(cfg: &Config, a: &BenchArgs) -> Result<(), Failure> {
    use crate::tools::time_to_alarm::{bench_faults, print, run, TimeToAlarmOptions};
    use std::io::Write as _;
    let usage = |e: helmwatch_core::config::ConfigError| Failure::Usage(e.into());
    let member = match &a.member {
        Some(text) => Some(family_member(cfg, text)?),
        None => None,
    };
    let cfg = member.as_ref().map_or(cfg, |(_, c)| c);
    for &i in &a.intervals {
        helmwatch_core::config::check_range("--intervals", i, 0.0, 30.0 * 86400.0)
            .map_err(usage)?;
    }
    helmwatch_core::config::check_range_open_low("--cap-h", a.cap_h, 0.0, 24.0 * 366.0)
        .map_err(usage)?;
    if a.runs == 0 || a.intervals.is_empty() {
        return Err(Failure::Usage(anyhow::anyhow!(
            "--runs and --intervals: at least one each"
        )));
    }
    let o = TimeToAlarmOptions {
        seed: a.seed,
        runs: a.runs,
        sea: a.sea.unwrap_or(cfg.sea.state),
        intervals_s: a.intervals.clone(),
        cap_s: a.cap_h * 3600.0,
        threads: a
            .threads
            .unwrap_or_else(crate::tools::training::database::default_threads)
            .max(1),
    };
    let off = match &a.ablate {
        Some(list) => {
            let sets = super::offline::mechanisms(list)?;
            match <[_; 1]>::try_from(sets) {
                Ok([set]) => set,
                Err(_) => {
                    return Err(Failure::Usage(anyhow::anyhow!(
                        "--ablate: one set of mechanisms (a+b), not a list"
                    )))
                }
            }
        }
        None => Vec::new(),
    };
    helmwatch_core::fdi::ablation::switch_off(&off);
    let faults = bench_faults().map_err(|e| Failure::Software(anyhow::anyhow!(e)))?;
    let started = std::time::Instant::now();
    let per = run(cfg, &o, &faults).map_err(Failure::software);
    helmwatch_core::fdi::ablation::switch_off(&[]);
    let per = per?;
    let mut out = Vec::new();
    if let Some((name, _)) = &member {
        let _ = writeln!(out, "Ship: the family's {name}\n");
    }
    if !off.is_empty() {
        let names: Vec<&str> = off.iter().map(|m| m.name()).collect();
        let _ = writeln!(out, "Mechanisms off: {}\n", names.join(", "));
    }
    print(cfg, &o, &faults, &per, &mut out).map_err(|e| Failure::Write(e.into()))?;
    let mut text = String::from_utf8_lossy(&out).into_owned();
    let name = page_name(cfg, &o, member.as_ref().map(|(name, _)| *name), &off);
    if let Some(dir) = &a.compare {
        let path = dir.join(format!("{name}.md"));
        let before = std::fs::read_to_string(&path).map_err(|e| Failure::io(&path, e))?;
        // The earlier file's tables, without its header and its own before-section, their
        // titles two levels down; named by the commit its header gives.
        let commit = before
            .lines()
            .find_map(|l| l.strip_prefix("Commit: "))
            .unwrap_or("(not given)")
            .trim()
            .to_string();
        let body = before
            .find("\n# ")
            .map_or(before.as_str(), |i| &before[i + 1..]);
        let body = body.find("\n## Before").map_or(body, |i| &body[..i]);
        let body: Vec<String> = body
            .lines()
            .map(|l| match l.starts_with('#') {
                true => format!("##{l}"),
                false => l.to_string(),
            })
            .collect();
        text.push_str(&format!(
            "\n## Before: {} at commit {commit}\n\n{}\n",
            path.file_name()
                .map_or(path.display(), |f| std::path::Path::new(f).display()),
            body.join("\n")
        ));
    }
    print!("{text}");
    if let Some(dir) = &a.results {
        let path = crate::tools::results::write(dir, &name, o.seed, &text)
            .map_err(|e| Failure::io(dir, e))?;
        eprintln!("wrote {}", path.display());
    }
    println!(
        "\nbench --time-to-alarm done in {:.1} s of wall time ({} threads)",
        started.elapsed().as_secs_f64(),
        o.threads
    );
    Ok(())
}

/// `helmwatch bridge nmea`: the `[bridge]` section with the command line's overrides, until
/// SIGTERM or SIGINT.
pub(crate) fn bridge_nmea(cfg: &Config, a: NmeaBridgeArgs) -> Result<(), Failure> {
    use crate::shells::bridge::{Bridge, BridgeInput};
    let mut b = cfg.bridge.clone();
    if let Some(v) = a.vessel {
        b.vessel = v;
    }
    if let Some(u) = a.udp {
        b.input = BridgeInput::Udp;
        b.udp_listen = u;
    }
    if let Some(t) = a.tcp {
        b.input = BridgeInput::Tcp;
        b.tcp_connect = t;
    }
    if let Some(p) = a.serial {
        b.input = BridgeInput::Serial;
        b.serial_path = p;
    }
    b.check().map_err(Failure::usage)?;
    check_endpoints("--listen", &a.listen)?;
    check_endpoints("--connect", &a.connect)?;
    let zcfg = crate::shells::net::zenoh_config(&b.zenoh(), &a.listen, &a.connect)?;
    let rt = runtime()?;
    rt.block_on(async {
        let bridge = Bridge::start(&b, zcfg).await?;
        crate::shells::systemd::ready(&format!("bridging NMEA for vessel {}", b.vessel));
        let watchdog = crate::shells::systemd::spawn_watchdog();
        let r = bridge.run(crate::shells::systemd::signals()).await;
        crate::shells::systemd::stopping();
        if let Some(w) = watchdog {
            w.abort();
        }
        r.map(|_| ()).map_err(|e| Failure::Unavailable(e.into()))
    })
}
