//! The CLFRT servo check, end to end (simulated ship + monitor core in lockstep), against
//! independent answers: the analytic closed loop `S H / (1 + S H C G)` of the simulated
//! autopilot and ship for the nominal servo, and a finely integrated rate-limited first-order
//! servo for the degraded one. Also: the test stays within its duration limit and the safety
//! gate never bounds a nominal test's excitation.

use crate::common::par_map;
use helmwatch::config::Config;
use helmwatch_core::drivers::probe::Lockstep;
use helmwatch_core::model::SeaState;
use helmwatch_core::sim::{Fault, FaultKind, Scenario, Ship, SimOptions};
use helmwatch_core::wire::Method;
use helmwatch_core::wire::{Outcome, Report};
use rustfft::num_complex::Complex64;
use std::f64::consts::PI;

/// What one lockstep test gave: the report and the gate's clamp count.
struct Run {
    report: Report,
    clamped: u64,
}

/// One CLFRT test after `warmup_s`, on a ship with `options`.
fn run(cfg: &Config, sc: &Scenario, options: SimOptions, warmup_s: f64) -> Run {
    let mut cfg = cfg.clone();
    cfg.scheduler.enabled = false;
    let mut ls = Lockstep::new(&cfg.core(), &cfg.sim(), sc).unwrap();
    ls.ship = Ship::with_options(&cfg.sim(), sc, options).unwrap();
    let mut out = Vec::new();
    ls.run_until(warmup_s, &mut out);
    let reply = ls.trigger(Method::Clfrt);
    assert!(reply.accepted, "{:?}", reply.reason);
    let t_end = ls.time_s() + cfg.safety.max_test_duration_s + 120.0;
    let report = ls.next_report(t_end, drop).expect("no report");
    Run {
        report,
        clamped: ls.monitor.stats().excitation_clamped,
    }
}

fn scenario(u: f64, d: f64, sea: SeaState, seed: u64, faults: Vec<Fault>) -> Scenario {
    Scenario {
        speed_mps: u,
        displacement_t: d,
        sea,
        faults,
        seed,
    }
}

fn servo_fault(rate_deg_s: f64) -> Fault {
    Fault::new(FaultKind::ServoRateDegS, rate_deg_s, 0.0).unwrap()
}

fn drift_fault(deg_per_min: f64) -> Fault {
    Fault::new(FaultKind::HeadingDriftDegPerMin, deg_per_min, 0.0).unwrap()
}

/// The servo check of a completed report.
struct Check {
    omega: f64,
    amplitude: f64,
    ln_gain: f64,
    phase: f64,
    ln_gain_error: f64,
    phase_error: f64,
    h3: f64,
    residual: f64,
    rate_p95: f64,
    rate_nominal: f64,
    ratio_ln_gain: f64,
    ratio_phase: f64,
}

fn check(r: &Report) -> Check {
    assert_eq!(r.outcome, Outcome::Completed, "{:?}", r.reason);
    let c = r
        .features
        .clfrt()
        .and_then(|c| c.servo_check.as_ref())
        .unwrap_or_else(|| panic!("no servo check in {:?}", r.features));
    let f = |k: &str, x: Option<f64>| x.unwrap_or_else(|| panic!("missing {k} in {c:?}"));
    Check {
        omega: c.omega_rad_s,
        amplitude: c.amplitude_rad,
        ln_gain: f("ln_gain", c.ln_gain),
        phase: f("phase_rad", c.phase_rad),
        ln_gain_error: f("ln_gain_error", c.ln_gain_error),
        phase_error: f("phase_error_rad", c.phase_error_rad),
        h3: f("harmonic3_ratio", c.harmonic3_ratio),
        residual: f("residual_rms_rad", c.residual_rms_rad),
        rate_p95: f("rudder_rate_p95_rad_s", c.rudder_rate_p95_rad_s),
        rate_nominal: f("rudder_rate_nominal_rad_s", c.rudder_rate_nominal_rad_s),
        ratio_ln_gain: f("ratio_ln_gain", c.ratio_ln_gain),
        ratio_phase: f("ratio_phase_rad", c.ratio_phase_rad),
    }
}

/// Phase difference wrapped to (-pi, pi].
fn dphase(a: f64, b: f64) -> f64 {
    let d = (a - b).rem_euclid(2.0 * PI);
    if d > PI {
        d - 2.0 * PI
    } else {
        d
    }
}

/// The nominal servo with the zero-order hold of the excitation, `S H`:
/// `1 / (1 + s T_r)` times `H = (1 - e^{-s dt}) / (s dt)`.
fn servo_hold(cfg: &Config, w: f64) -> Complex64 {
    let s = Complex64::new(0.0, w);
    let dt = cfg.sensors.dt_s();
    let servo = 1.0 / (1.0 + s * cfg.servo.time_constant_s);
    servo * (1.0 - (-s * dt).exp()) / (s * dt)
}

/// `C G` at `w` for the simulated loop: autopilot `C = Kp F (1 + Td s + 1 / (Ti s))` with the
/// critically damped low-pass `F = wf^2 / (s + wf)^2` (gains scheduled at `u`), ship
/// `G = b / (s (s + a))`.
fn loop_cg(cfg: &Config, u: f64, d: f64, w: f64) -> Complex64 {
    let s = Complex64::new(0.0, w);
    let g = cfg.autopilot.gains_at(&cfg.ship, u);
    let wf = cfg.autopilot.wave_filter_rad_s;
    let f = wf * wf / ((s + wf) * (s + wf));
    let c = g.kp * f * (1.0 + g.td_s * s + 1.0 / (g.ti_s * s));
    let (a, b) = cfg.ship.nomoto(u, d);
    c * b / (s * (s + a))
}

/// The rudder's answer to the added excitation: `A / (1 + A C G)` with `A` the servo's
/// response to the held excitation (`S H`, or a describing function).
fn closed_loop(a: Complex64, cg: Complex64) -> Complex64 {
    a / (1.0 + a * cg)
}

/// First harmonic ratio output / input of the servo `delta' = clamp((c - delta) / T_r, +-R)`
/// driven by `c(t) = A sin(w t)` held over each sample period `dt` (the excitation as sent),
/// integrated by Euler steps of 1e-4 s over 20 periods, the first harmonic of the last 10
/// against that of `c` unheld: its describing function, hold included.
fn rate_limited_servo(amplitude: f64, w: f64, t_r: f64, rate: f64, dt: f64) -> Complex64 {
    let h = 1e-4;
    let period = 2.0 * PI / w;
    let total = 20.0 * period;
    let t_meas = 10.0 * period;
    let mut delta = 0.0f64;
    let mut acc_d = Complex64::new(0.0, 0.0);
    let mut acc_c = Complex64::new(0.0, 0.0);
    let steps = (total / h).round() as usize;
    for i in 0..steps {
        let t = i as f64 * h;
        let t_held = (t / dt).floor() * dt;
        let c = amplitude * (w * t_held).sin();
        if t >= t_meas {
            let ph = Complex64::from_polar(1.0, -w * t);
            acc_d += delta * ph;
            acc_c += amplitude * (w * t).sin() * ph;
        }
        delta += h * ((c - delta) / t_r).clamp(-rate, rate);
    }
    acc_d / acc_c
}

/// The (u, D) corners and centre of the method's range.
const GRID: [(f64, f64); 5] = [
    (4.0, 4000.0),
    (4.0, 10000.0),
    (7.0, 7000.0),
    (10.0, 4000.0),
    (10.0, 10000.0),
];

/// Noise-free, disturbance-free ship: the plain ratio Delta / E is the analytic closed loop
/// `S H / (1 + S H C G)` within 0.3 % and 0.2 deg (measured: 0.05 % and 0.05 deg).
#[test]
fn noise_free_ratio_matches_the_closed_loop() {
    let cfg = Config::default();
    for (u, d) in GRID {
        let r = run(
            &cfg,
            &scenario(u, d, SeaState::Calm, 1, vec![]),
            SimOptions::CLEAN,
            600.0,
        );
        let c = check(&r.report);
        let t = closed_loop(servo_hold(&cfg, c.omega), loop_cg(&cfg, u, d, c.omega));
        assert!(
            (c.ratio_ln_gain - t.norm().ln()).abs() < 0.003,
            "u {u} D {d}: ln gain {} analytic {}",
            c.ratio_ln_gain,
            t.norm().ln()
        );
        assert!(
            dphase(c.ratio_phase, t.arg()).abs() < 0.2f64.to_radians(),
            "u {u} D {d}: phase {} analytic {}",
            c.ratio_phase.to_degrees(),
            t.arg().to_degrees()
        );
        assert!((c.amplitude - 5f64.to_radians()).abs() < 1e-12);
        assert!((c.omega / 0.6 - 1.0).abs() < 5e-4);
        assert_eq!(r.clamped, 0);
    }
}

/// With a sea (and a gyro), the autopilot's own rudder is fitted at the neighbouring bins and
/// removed: the servo estimate is `S H` (no loop term, no sea noise). Calm sea, 25 runs: 90 %
/// within 1.2 % / 1 deg, all within 3 % / 3 deg (measured over 120 runs: mean -0.2 % / -0.09
/// deg, sd 0.34 % / 0.23 deg, worst 1.6 % / 1.7 deg). Gyro noise only: within 2 % / 1 deg.
#[test]
fn servo_estimate_matches_the_nominal_servo() {
    let cfg = Config::default();
    let jobs: Vec<(f64, f64, u64)> = GRID
        .iter()
        .flat_map(|&(u, d)| (0..5).map(move |s| (u, d, 300 + s)))
        .collect();
    let res = par_map(jobs, |(u, d, seed)| {
        let sc = scenario(u, d, SeaState::Calm, seed, vec![]);
        let c = check(&run(&cfg, &sc, SimOptions::default(), 600.0).report);
        let t0 = servo_hold(&cfg, c.omega);
        (c.ln_gain - t0.norm().ln(), dphase(c.phase, t0.arg()))
    });
    let inside = res
        .iter()
        .filter(|(g, p)| g.abs() <= 0.012 && p.abs() <= 1f64.to_radians())
        .count();
    assert!(
        inside * 10 >= res.len() * 9,
        "{inside} of {}: {res:?}",
        res.len()
    );
    for (g, p) in &res {
        assert!(g.abs() <= 0.03 && p.abs() <= 3f64.to_radians(), "{res:?}");
    }
    let gyro_only = SimOptions {
        noise: true,
        disturbances: false,
    };
    for (u, d) in GRID {
        let sc = scenario(u, d, SeaState::Calm, 7, vec![]);
        let c = check(&run(&cfg, &sc, gyro_only, 600.0).report);
        let t0 = servo_hold(&cfg, c.omega);
        assert!((c.ln_gain - t0.norm().ln()).abs() <= 0.02, "u {u} D {d}");
        assert!(
            dphase(c.phase, t0.arg()).abs() <= 1f64.to_radians(),
            "u {u} D {d}"
        );
        assert!((c.ln_gain_error - (c.ln_gain - t0.norm().ln())).abs() < 1e-3);
    }
}

/// A servo limited to 2 deg/s: noise-free, the ratio is the closed loop around the
/// describing function of a finely integrated rate-limited servo (within 1 % / 0.5 deg); in a
/// calm sea the gain error is clearly negative (the describing function gives -0.10; the sea
/// adds rate and so more limiting), and the rudder's 95th-percentile rate sits at the limit.
#[test]
fn degraded_servo_is_seen() {
    let cfg = Config::default();
    let dt = cfg.sensors.dt_s();
    let limit = 2f64.to_radians();
    for (u, d) in GRID {
        let sc = scenario(u, d, SeaState::Calm, 2, vec![servo_fault(2.0)]);
        let c = check(&run(&cfg, &sc, SimOptions::CLEAN, 600.0).report);
        let n = rate_limited_servo(c.amplitude, c.omega, cfg.servo.time_constant_s, limit, dt);
        let t = closed_loop(n, loop_cg(&cfg, u, d, c.omega));
        assert!(
            (c.ratio_ln_gain - t.norm().ln()).abs() < 0.01,
            "u {u} D {d}: {} vs {}",
            c.ratio_ln_gain,
            t.norm().ln()
        );
        assert!(
            dphase(c.ratio_phase, t.arg()).abs() < 0.5f64.to_radians(),
            "u {u} D {d}: {} vs {}",
            c.ratio_phase.to_degrees(),
            t.arg().to_degrees()
        );
        let df_error = (n / servo_hold(&cfg, c.omega)).norm().ln();
        assert!((-0.12..-0.08).contains(&df_error), "{df_error}");
    }
    let jobs: Vec<(f64, f64, u64)> = GRID
        .iter()
        .flat_map(|&(u, d)| (0..2).map(move |s| (u, d, 400 + s)))
        .collect();
    let res = par_map(jobs, |(u, d, seed)| {
        let sc = scenario(u, d, SeaState::Calm, seed, vec![servo_fault(2.0)]);
        check(&run(&cfg, &sc, SimOptions::default(), 900.0).report)
    });
    for c in &res {
        assert!(c.ln_gain_error < -0.06, "{}", c.ln_gain_error);
        assert!(c.phase_error < -3f64.to_radians(), "{}", c.phase_error);
        assert!(
            (0.98 * limit..1.05 * limit).contains(&c.rate_p95),
            "{}",
            c.rate_p95.to_degrees()
        );
        assert!(c.rate_p95 < 0.9 * c.rate_nominal);
    }
}

/// Nominal tests, calm and moderate, some with an established 1 deg/min heading drift: the
/// test ends within `safety.max-test-duration-s`, the gate never bounds the excitation, and
/// the rudder reaches at least the nominal servo's rate.
#[test]
fn nominal_tests_stay_within_the_limits() {
    let cfg = Config::default();
    let jobs: Vec<(f64, f64, SeaState, bool)> = GRID
        .iter()
        .flat_map(|&(u, d)| {
            [
                (u, d, SeaState::Calm, false),
                (u, d, SeaState::Moderate, false),
                (u, d, SeaState::Moderate, true),
            ]
        })
        .collect();
    let res = par_map(jobs, |(u, d, sea, drift)| {
        let faults = if drift {
            vec![drift_fault(1.0)]
        } else {
            vec![]
        };
        let sc = scenario(u, d, sea, 500, faults);
        run(&cfg, &sc, SimOptions::default(), 900.0)
    });
    for r in &res {
        let c = check(&r.report);
        assert_eq!(r.clamped, 0);
        assert!(r.report.t_end - r.report.t_start <= cfg.safety.max_test_duration_s);
        assert!(
            c.rate_p95 > 0.97 * c.rate_nominal,
            "{} {}",
            c.rate_p95,
            c.rate_nominal
        );
        assert!(c.h3 < 0.06 && c.residual > 0.0);
    }
}

/// The distributions of the servo check's features (nominal and 2 deg/s servo, calm and
/// moderate seas, u 4..10 m/s and D 4000..10000 t on a Halton sequence, a third of the nominal
/// runs with an established +-1 deg/min heading drift), printed as the table of docs/dsp.md,
/// and what the table shows checked: no gate clamp and every test within its limit; the
/// rate-limited servo's rudder rate ratio below every healthy run's in the same sea (it cannot
/// exceed its limit; a healthy servo reaches at least the nominal rate), with heading drift
/// or without; the servo's gain error below the healthy mean.
/// `cargo test --profile ci --test it servo_check_distributions -- --ignored --nocapture`
#[test]
#[ignore = "slow tier: cargo test --profile ci -- --ignored"]
fn servo_check_distributions() {
    let cfg = Config::default();
    let rows: Vec<(&str, SeaState, Option<f64>, usize)> = vec![
        ("nominal calm", SeaState::Calm, None, 120),
        ("nominal moderate", SeaState::Moderate, None, 120),
        ("servo 2 deg/s calm", SeaState::Calm, Some(2.0), 60),
        ("servo 2 deg/s moderate", SeaState::Moderate, Some(2.0), 60),
    ];
    println!("| runs | feature | mean | std | min | max |\n|---|---|---|---|---|---|");
    // Per row: (sea, faulty, rate ratios, mean ln gain error).
    let mut seen: Vec<(SeaState, bool, Vec<f64>, f64)> = Vec::new();
    for (name, sea, fault, n) in rows {
        let jobs: Vec<usize> = (0..n).collect();
        let res = par_map(jobs, |i| {
            let u = 4.0 + 6.0 * halton(i + 1, 2);
            let d = 4000.0 + 6000.0 * halton(i + 1, 3);
            let mut faults = Vec::new();
            match fault {
                Some(rate) => faults.push(servo_fault(rate)),
                None if i % 3 == 2 => faults.push(drift_fault(if i % 2 == 0 { 1.0 } else { -1.0 })),
                None => {}
            }
            let sc = scenario(u, d, sea, 5000 + i as u64, faults);
            let r = run(&cfg, &sc, SimOptions::default(), 900.0);
            let c = check(&r.report);
            let t0 = servo_hold(&cfg, c.omega);
            [
                c.ln_gain_error,
                c.phase_error.to_degrees(),
                c.ratio_ln_gain - t0.norm().ln(),
                dphase(c.ratio_phase, t0.arg()).to_degrees(),
                c.rate_p95 / c.rate_nominal,
                c.h3,
                c.residual.to_degrees(),
                r.clamped as f64,
                r.report.t_end - r.report.t_start,
            ]
        });
        let names = [
            "ln_gain_error",
            "phase_error deg",
            "plain ratio ln gain error",
            "plain ratio phase error deg",
            "rudder rate p95 / nominal",
            "harmonic3_ratio",
            "residual_rms deg",
            "gate clamps",
            "test duration s",
        ];
        for (j, feature) in names.iter().enumerate() {
            let v: Vec<f64> = res.iter().map(|r| r[j]).collect();
            let m = v.iter().sum::<f64>() / v.len() as f64;
            let var = v.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (v.len() as f64 - 1.0);
            let lo = v.iter().copied().fold(f64::INFINITY, f64::min);
            let hi = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            println!(
                "| {name} ({n}) | {feature} | {m:+.4} | {:.4} | {lo:+.4} | {hi:+.4} |",
                var.sqrt()
            );
        }
        assert!(res.iter().all(|r| r[7] == 0.0), "{name}: a gate clamped");
        let limit = cfg.safety.max_test_duration_s;
        assert!(
            res.iter().all(|r| r[8] < limit),
            "{name}: a test over {limit} s"
        );
        let rates: Vec<f64> = res.iter().map(|r| r[4]).collect();
        let gain = res.iter().map(|r| r[0]).sum::<f64>() / res.len() as f64;
        seen.push((sea, fault.is_some(), rates, gain));
    }
    for (sea, _, rates, gain) in seen.iter().filter(|r| r.1) {
        let healthy = seen.iter().find(|r| r.0 == *sea && !r.1).unwrap();
        let worst = rates.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let least = healthy.2.iter().copied().fold(f64::INFINITY, f64::min);
        assert!(
            worst < least,
            "{sea:?}: a rate-limited servo's rate ratio {worst} reaches a healthy one's {least}"
        );
        assert!(
            *gain < healthy.3,
            "{sea:?}: gain error {gain} not below {}",
            healthy.3
        );
    }
}

fn halton(mut i: usize, base: usize) -> f64 {
    let (mut f, mut r) = (1.0, 0.0);
    while i > 0 {
        f /= base as f64;
        r += f * (i % base) as f64;
        i /= base;
    }
    r
}
