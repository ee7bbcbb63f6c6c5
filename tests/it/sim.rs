//! Acceptance tests of the simulated ship against independent answers: the analytic step
//! response and transfer function of b / (s (s + a)), the servo's limits, closed-loop quality
//! in a moderate sea, fault effects from their onsets, determinism of recordings.

use helmwatch::config::Config;
use helmwatch_core::model::SeaState;
use helmwatch_core::sim::{CommandSource, Fault, Scenario, Ship, SimOptions};
use helmwatch_core::wire::{Excitation, ExcitationMode, Input};
use proptest::prelude::*;
use std::f64::consts::PI;

const DEG: f64 = PI / 180.0;

fn scenario(u: f64, d: f64, sea: SeaState, faults: &[&str], seed: u64) -> Scenario {
    Scenario {
        speed_mps: u,
        displacement_t: d,
        sea,
        faults: faults.iter().map(|f| f.parse().unwrap()).collect(),
        seed,
    }
}

fn clean_ship(cfg: &Config, u: f64, d: f64, faults: &[&str]) -> Ship {
    Ship::with_options(
        &cfg.sim(),
        &scenario(u, d, SeaState::Calm, faults, 1),
        SimOptions::CLEAN,
    )
    .unwrap()
}

fn run(ship: &mut Ship, ticks: usize) {
    for _ in 0..ticks {
        ship.step();
    }
}

fn ticks(seconds: f64, cfg: &Config) -> usize {
    (seconds * cfg.sensors.rate_hz).round() as usize
}

const GRID: [(f64, f64); 6] = [
    (4.0, 4000.0),
    (4.0, 10000.0),
    (7.0, 4000.0),
    (7.0, 10000.0),
    (10.0, 4000.0),
    (10.0, 10000.0),
];

// ---------------------------------------------------------------------------------------------
// 1. Open-loop rudder step

/// A 2 deg step (below the servo's knee R T_r = 4 deg, so no rate limit): steady turn rate
/// (b/a) delta within 1 %, time constant 1/a within 2 %, from the simulated trace alone.
#[test]
fn step_gives_steady_turn_rate_and_time_constant() {
    let cfg = Config::default();
    let delta = 2.0 * DEG;
    for (u, d) in GRID {
        let (a, b) = cfg.ship.nomoto(u, d);
        let t_const = 1.0 / a;
        let mut ship = clean_ship(&cfg, u, d, &[]);
        ship.set_command_override(Some(delta));
        let n = ticks(15.0 * t_const, &cfg);
        let mut trace = Vec::with_capacity(n);
        for _ in 0..n {
            ship.step();
            let tr = ship.truth();
            trace.push((tr.t_s, tr.r_rad_s));
        }
        let r_ss = trace[n - 1].1;
        approx::assert_relative_eq!(r_ss, b / a * delta, max_relative = 0.01);
        // Least-squares slope of ln(r_ss - r) over [T, 4T]: -1 / time constant.
        let pts: Vec<(f64, f64)> = trace
            .iter()
            .filter(|(t, _)| *t >= t_const && *t <= 4.0 * t_const)
            .map(|&(t, r)| (t, (r_ss - r).ln()))
            .collect();
        let m = pts.len() as f64;
        let (st, sy) = pts.iter().fold((0.0, 0.0), |(a, b), p| (a + p.0, b + p.1));
        let (mt, my) = (st / m, sy / m);
        let sxy: f64 = pts.iter().map(|p| (p.0 - mt) * (p.1 - my)).sum();
        let sxx: f64 = pts.iter().map(|p| (p.0 - mt).powi(2)).sum();
        let tau = -sxx / sxy;
        approx::assert_relative_eq!(tau, t_const, max_relative = 0.02);
        eprintln!(
            "step u={u} D={d}: turn rate error {:.2e}, time constant error {:.2e}",
            r_ss / (b / a * delta) - 1.0,
            tau / t_const - 1.0
        );
    }
}

/// The integrator against the exact three-pole response (servo lag 1/(T_r s + 1), ship
/// b/(s (s + a))) of the same step: far tighter than the acceptance tolerances.
#[test]
fn step_response_matches_exact_solution_closely() {
    let cfg = Config::default();
    let delta = 2.0 * DEG;
    let c = 1.0 / cfg.servo.time_constant_s;
    let mut worst_r: f64 = 0.0;
    let mut worst_psi: f64 = 0.0;
    for (u, d) in GRID {
        let (a, b) = cfg.ship.nomoto(u, d);
        let k = b / a * delta;
        let mut ship = clean_ship(&cfg, u, d, &[]);
        let psi0 = ship.truth().psi_rad;
        ship.set_command_override(Some(delta));
        for _ in 0..ticks(600.0, &cfg) {
            ship.step();
            let tr = ship.truth();
            let t = tr.t_s;
            let (ea, ec) = ((-a * t).exp(), (-c * t).exp());
            let r = k * (1.0 - (c * ea - a * ec) / (c - a));
            let psi = k * (t - (c * (1.0 - ea) / a - a * (1.0 - ec) / c) / (c - a));
            worst_r = worst_r.max((tr.r_rad_s - r).abs() / k);
            worst_psi = worst_psi.max((tr.psi_rad - psi0 - psi).abs() / (k * t));
            // The rudder itself: 2 deg (1 - e^{-t / T_r}).
            assert!((tr.delta_rad - delta * (1.0 - ec)).abs() < 1e-12);
        }
    }
    eprintln!("exact step: worst r error {worst_r:.2e} K delta, psi {worst_psi:.2e} K delta t");
    assert!(worst_r < 1e-5, "turn rate error {worst_r} of K delta");
    assert!(worst_psi < 1e-5, "heading error {worst_psi} of K delta t");
}

// ---------------------------------------------------------------------------------------------
// 2. Open-loop frequency response

/// DFT bin `k` of the first differences of `x` over `n` samples from `start`. Differencing
/// turns the heading's ramp into a constant (no power at bin k != 0); the factor it puts on
/// the tone, 1 - e^{-j w dt}, is the same for rudder and heading and cancels in their ratio.
fn dft_of_difference(x: &[f64], start: usize, n: usize, k: usize) -> (f64, f64) {
    let (mut re, mut im) = (0.0, 0.0);
    for i in 0..n {
        let dx = x[start + i + 1] - x[start + i];
        let ph = -2.0 * PI * (k * i) as f64 / n as f64;
        re += dx * ph.cos();
        im += dx * ph.sin();
    }
    (re, im)
}

/// Sinusoidal commands at 0.031, 0.073, 0.178 rad/s (harmonics 3, 7, 17 of 600 s, whole
/// periods in the window), 2 deg: gain within 1 % and phase within 1 deg of b/(jw (jw + a)).
#[test]
fn sinusoidal_rudder_matches_transfer_function() {
    let cfg = Config::default();
    let window_s = 600.0;
    let amp = 2.0 * DEG;
    let mut worst_gain: f64 = 0.0;
    let mut worst_phase_deg: f64 = 0.0;
    for (u, d) in [(4.0, 10000.0), (7.0, 7000.0), (10.0, 4000.0)] {
        let (a, b) = cfg.ship.nomoto(u, d);
        for harmonic in [3usize, 7, 17] {
            let w = 2.0 * PI * harmonic as f64 / window_s;
            assert!(amp * w < cfg.servo.max_rate_rad_s() / 2.0);
            let (gain, phase) = measured_response(&cfg, u, d, harmonic, amp);
            // b / (jw (jw + a)) = b / (-w^2 + j a w).
            let (hr, hi) = (-w * w, a * w);
            let gain_true = b / (hr * hr + hi * hi).sqrt();
            let phase_true = -hi.atan2(hr);
            let dphase = (phase - phase_true + PI).rem_euclid(2.0 * PI) - PI;
            approx::assert_relative_eq!(gain, gain_true, max_relative = 0.01);
            assert!(
                dphase.abs() < 1.0 * DEG,
                "phase off by {} deg",
                dphase / DEG
            );
            worst_gain = worst_gain.max((gain / gain_true - 1.0).abs());
            worst_phase_deg = worst_phase_deg.max(dphase.abs() / DEG);
        }
    }
    eprintln!(
        "sine: worst gain error {worst_gain:.2e}, worst phase error {worst_phase_deg:.2e} deg"
    );
    // The achieved accuracy, far inside the acceptance tolerances.
    assert!(worst_gain < 1e-3, "worst gain error {worst_gain}");
    assert!(
        worst_phase_deg < 0.05,
        "worst phase error {worst_phase_deg} deg"
    );
}

/// Gain and phase of heading over the measured (blade) rudder at `harmonic` of a 600 s
/// window, with a sinusoidal command of `amp` on a clean ship of `cfg`: three windows
/// (>= 15 time constants) to settle, the fourth measured.
fn measured_response(cfg: &Config, u: f64, d: f64, harmonic: usize, amp: f64) -> (f64, f64) {
    let window_s = 600.0;
    let n = ticks(window_s, cfg);
    let w = 2.0 * PI * harmonic as f64 / window_s;
    let mut ship = clean_ship(cfg, u, d, &[]);
    let settle = 3 * n;
    let (mut delta, mut psi) = (Vec::new(), Vec::new());
    for _ in 0..settle + n + 1 {
        let t = ship.time_s();
        let tr = ship.truth();
        delta.push(tr.delta_rad);
        psi.push(tr.psi_rad);
        ship.set_command_override(Some(amp * (w * t).sin()));
        ship.step();
    }
    let (dr, di) = dft_of_difference(&delta, settle, n, harmonic);
    let (pr, pi) = dft_of_difference(&psi, settle, n, harmonic);
    (
        (pr * pr + pi * pi).sqrt() / (dr * dr + di * di).sqrt(),
        pi.atan2(pr) - di.atan2(dr),
    )
}

/// A second-order Nomoto ship (T2/T1 = 0.1, T3/T1 = 0.25) against its transfer function
/// K (1 + jw T3) / (jw (1 + jw T1)(1 + jw T2)), T1 + T2 - T3 = 1/a, K = b/a: gain within
/// 0.5 %, phase within 0.3 deg; and it differs measurably from the first-order ship at the
/// highest tone (the structure is really there).
#[test]
fn second_order_ship_matches_its_transfer_function() {
    let mut cfg = Config::default();
    cfg.structure.nomoto_t2_ratio = 0.1;
    cfg.structure.nomoto_t3_ratio = 0.25;
    let (u, d) = (7.0, 7000.0);
    let (a, b) = cfg.ship.nomoto(u, d);
    let t1 = 1.0 / (a * (1.0 + 0.1 - 0.25));
    let (t2, t3, k) = (0.1 * t1, 0.25 * t1, b / a);
    for harmonic in [3usize, 7, 17, 40] {
        let w = 2.0 * PI * harmonic as f64 / 600.0;
        let (gain, phase) = measured_response(&cfg, u, d, harmonic, 2.0 * DEG);
        // G = K (1 + j w T3) / (j w (1 + j w T1)(1 + j w T2)), as modulus and argument.
        let gain_true = k * (1.0 + (w * t3).powi(2)).sqrt()
            / (w * (1.0 + (w * t1).powi(2)).sqrt() * (1.0 + (w * t2).powi(2)).sqrt());
        let phase_true = (w * t3).atan() - PI / 2.0 - (w * t1).atan() - (w * t2).atan();
        let dphase = (phase - phase_true + PI).rem_euclid(2.0 * PI) - PI;
        approx::assert_relative_eq!(gain, gain_true, max_relative = 0.005);
        assert!(
            dphase.abs() < 0.3 * DEG,
            "h {harmonic}: {} deg",
            dphase / DEG
        );
        if harmonic == 40 {
            let first = b / (w * (w * w + a * a).sqrt());
            assert!((gain / first - 1.0).abs() > 0.05, "{gain} vs {first}");
        }
    }
}

/// Steering dead band and backlash on the ship: the blade (what the sensor reads) stays
/// inside the servo's play and the hull answers the blade, not the servo: a heading
/// response over the measured rudder still equals the first-order transfer function.
#[test]
fn dead_band_and_backlash_act_before_the_rudder_sensor() {
    let mut cfg = Config::default();
    cfg.structure.rudder_dead_band_deg = 0.5;
    cfg.structure.rudder_backlash_deg = 1.0;
    let (u, d) = (7.0, 7000.0);
    let (a, b) = cfg.ship.nomoto(u, d);
    let harmonic = 7;
    let w = 2.0 * PI * harmonic as f64 / 600.0;
    // Relative to the measured blade, the hull is the plain b / (jw (jw + a)) (1 %: the
    // blade's flat tops add harmonics, not error at the tone).
    let (gain, _) = measured_response(&cfg, u, d, harmonic, 3.0 * DEG);
    let gain_true = b / (w * (w * w + a * a).sqrt());
    approx::assert_relative_eq!(gain, gain_true, max_relative = 0.01);
    // The blade's amplitude: the command's less the dead band's and the play's halves.
    let mut ship = clean_ship(&cfg, u, d, &[]);
    let mut peak: f64 = 0.0;
    for i in 0..ticks(2400.0, &cfg) {
        let t = ship.time_s();
        ship.set_command_override(Some(3.0 * DEG * (w * t).sin()));
        ship.step();
        if i > ticks(1200.0, &cfg) {
            peak = peak.max(ship.truth().delta_rad.abs());
        }
    }
    // 3 deg less 0.25 (dead band) less 0.5 (play); the servo's lag at 0.073 rad/s takes
    // 0.3 % off the amplitude.
    assert!(
        (peak / DEG - 2.25).abs() < 0.03,
        "blade peak {} deg",
        peak / DEG
    );
}

// ---------------------------------------------------------------------------------------------
// 3. Servo limits

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    /// Random command sequences (beyond the angle limit too), random rate limits: the rudder
    /// never moves faster than the rate limit over a tick nor leaves the angle limit.
    #[test]
    fn servo_respects_rate_and_angle_limits(
        rate_deg_s in 0.5f64..20.0,
        seq in proptest::collection::vec((-60.0f64..60.0, 1usize..40), 1..40),
    ) {
        let cfg = Config::default();
        let fault = format!("servo_rate_deg_s:{rate_deg_s}@0");
        let mut ship = clean_ship(&cfg, 7.0, 7000.0, &[fault.as_str()]);
        let max = cfg.servo.max_angle_rad();
        let max_step = rate_deg_s * DEG * ship.dt_s();
        let mut prev = ship.truth().delta_rad;
        for (cmd_deg, hold) in seq {
            ship.set_command_override(Some(cmd_deg * DEG));
            for _ in 0..hold {
                ship.step();
                let tr = ship.truth();
                prop_assert!(tr.delta_rad.abs() <= max * (1.0 + 1e-12));
                prop_assert!((tr.delta_rad - prev).abs() <= max_step * (1.0 + 1e-9),
                    "moved {} deg in a tick, limit {}", (tr.delta_rad - prev) / DEG, max_step / DEG);
                prop_assert!(tr.command_rad.abs() <= max);
                prev = tr.delta_rad;
            }
        }
    }
}

/// The rate limit is reached (the limit above is not vacuous): a 20 deg step moves exactly
/// R dt per tick while far from the command.
#[test]
fn large_step_moves_at_the_rate_limit() {
    let cfg = Config::default();
    let mut ship = clean_ship(&cfg, 7.0, 7000.0, &[]);
    ship.set_command_override(Some(20.0 * DEG));
    let step = cfg.servo.max_rate_rad_s() * ship.dt_s();
    for k in 1..=30 {
        ship.step();
        let tr = ship.truth();
        approx::assert_relative_eq!(tr.delta_rad, k as f64 * step, max_relative = 1e-12);
        assert!(tr.rate_limited);
    }
}

// ---------------------------------------------------------------------------------------------
// 4. Closed loop in a moderate sea

/// 10 deg course change: overshoot below 20 %, and the heading settles within 1 deg.
#[test]
fn course_change_settles_with_small_overshoot() {
    let cfg = Config::default();
    for seed in [1, 2, 3] {
        let mut ship = Ship::new(&cfg.sim(), &Scenario::nominal(&cfg.sim(), seed)).unwrap();
        run(&mut ship, ticks(600.0, &cfg));
        let course = ship.truth().target_rad;
        let psi_start = ship.truth().psi_rad;
        // Unwrapped target 10 deg to starboard of the current heading's course.
        let target = psi_start + (course - psi_start + PI).rem_euclid(2.0 * PI) - PI + 10.0 * DEG;
        ship.set_course(course + 10.0 * DEG);
        let mut overshoot: f64 = 0.0;
        let mut late_error: f64 = 0.0;
        let mut reached = false;
        for k in 0..ticks(900.0, &cfg) {
            ship.step();
            let err = ship.truth().psi_rad - target;
            reached |= err > -DEG;
            overshoot = overshoot.max(err);
            if k as f64 * ship.dt_s() > 400.0 {
                late_error = late_error.max(err.abs());
            }
        }
        eprintln!(
            "course change seed {seed}: overshoot {:.1} %, max |error| after 400 s {:.2} deg",
            overshoot / (10.0 * DEG) * 100.0,
            late_error / DEG
        );
        assert!(reached, "seed {seed}: never came within 1 deg");
        let frac = overshoot / (10.0 * DEG);
        assert!(
            frac < 0.20 && frac > 0.0,
            "seed {seed}: overshoot {:.1} %",
            frac * 100.0
        );
        assert!(
            late_error < 1.0 * DEG,
            "seed {seed}: error {} deg after 400 s",
            late_error / DEG
        );
    }
}

/// Steady course, 30 min after 10 min of settling: true heading error RMS below 0.5 deg and the
/// servo at its rate limit less than 5 % of the time, while the sea visibly moves the ship.
#[test]
fn steady_course_in_moderate_sea() {
    let cfg = Config::default();
    for seed in [11, 12, 13] {
        let mut ship = Ship::new(&cfg.sim(), &Scenario::nominal(&cfg.sim(), seed)).unwrap();
        run(&mut ship, ticks(600.0, &cfg));
        let n = ticks(1800.0, &cfg);
        let (mut sum2, mut limited, mut rudder_sum, mut rudder_sum2) = (0.0, 0usize, 0.0, 0.0);
        for _ in 0..n {
            ship.step();
            let tr = ship.truth();
            let err = (tr.psi_rad - tr.target_rad + PI).rem_euclid(2.0 * PI) - PI;
            sum2 += err * err;
            limited += usize::from(tr.rate_limited);
            rudder_sum += tr.delta_rad;
            rudder_sum2 += tr.delta_rad * tr.delta_rad;
        }
        let rms_deg = (sum2 / n as f64).sqrt() / DEG;
        let frac_limited = limited as f64 / n as f64;
        let rudder_std_deg =
            ((rudder_sum2 / n as f64) - (rudder_sum / n as f64).powi(2)).sqrt() / DEG;
        eprintln!(
            "steady seed {seed}: RMS {rms_deg:.3} deg, rate limited {:.2} %, rudder std {rudder_std_deg:.2} deg",
            frac_limited * 100.0
        );
        assert!(
            rms_deg < 0.5 && rms_deg > 0.005,
            "seed {seed}: RMS {rms_deg} deg"
        );
        assert!(
            frac_limited < 0.05,
            "seed {seed}: rate limited {frac_limited}"
        );
        assert!(
            rudder_std_deg > 0.05,
            "seed {seed}: rudder std {rudder_std_deg} deg"
        );
    }
}

// ---------------------------------------------------------------------------------------------
// 5. Faults, one test per kind

const ONSET_S: f64 = 300.0;

/// Steps a clean ship (constant 3 deg rudder) and returns the truth and noise-free measurements
/// (rudder, speed, heading) at every tick.
fn fault_trace(faults: &[&str], seconds: f64) -> Vec<(helmwatch_core::sim::Truth, [f64; 3])> {
    let cfg = Config::default();
    let mut ship = clean_ship(&cfg, 7.0, 7000.0, faults);
    ship.set_command_override(Some(3.0 * DEG));
    let mut out = Vec::new();
    let mut buf = Vec::new();
    for _ in 0..ticks(seconds, &cfg) {
        buf.clear();
        ship.publish(&mut buf);
        let mut m = [0.0; 3];
        for i in &buf {
            match i {
                Input::Rudder(s) => m[0] = s.value,
                Input::Speed(s) => m[1] = s.value,
                Input::Heading(s) => m[2] = s.value,
                _ => {}
            }
        }
        out.push((ship.truth(), m));
        ship.step();
    }
    out
}

fn before_after<T>(trace: &[T], t_of: impl Fn(&T) -> f64) -> (&[T], &[T]) {
    let i = trace.iter().position(|x| t_of(x) >= ONSET_S).unwrap();
    trace.split_at(i)
}

#[test]
fn fault_displacement_changes_b_from_onset() {
    let cfg = Config::default();
    let trace = fault_trace(&["displacement_pct:+10@300"], 2000.0);
    let (pre, post) = before_after(&trace, |x| x.0.t_s);
    let (a, b0) = cfg.ship.nomoto(7.0, 7000.0);
    let (_, b1) = cfg.ship.nomoto(7.0, 7700.0);
    assert!((b1 / b0 - 1.0 / 1.1).abs() < 1e-12);
    for (tr, _) in pre {
        assert_eq!((tr.b_per_s2, tr.displacement_t), (b0, 7000.0));
    }
    for (tr, _) in post {
        approx::assert_relative_eq!(tr.b_per_s2, b1, max_relative = 1e-12);
        approx::assert_relative_eq!(tr.displacement_t, 7700.0, max_relative = 1e-12);
    }
    // The dynamics follow: identical to the unfaulted ship before the onset, a slower turn
    // one tick after, and the steady turn rate (b'/a) delta after ~25 time constants.
    let clean = fault_trace(&[], 2000.0);
    for ((tr, _), (tc, _)) in pre.iter().zip(&clean) {
        assert_eq!(tr.r_rad_s, tc.r_rad_s);
    }
    let i = pre.len() + 1;
    assert!(trace[i].0.r_rad_s < clean[i].0.r_rad_s);
    let r_end = post.last().unwrap().0.r_rad_s;
    approx::assert_relative_eq!(r_end, b1 / a * 3.0 * DEG, max_relative = 0.002);
}

#[test]
fn fault_speed_log_bias_from_onset() {
    let trace = fault_trace(&["speed_log_bias_mps:0.5@300"], 400.0);
    let (pre, post) = before_after(&trace, |x| x.0.t_s);
    assert!(pre.iter().all(|(_, m)| (m[1] - 7.0).abs() < 1e-12));
    assert!(post
        .iter()
        .all(|(tr, m)| (m[1] - 7.5).abs() < 1e-12 && tr.speed_mps == 7.0));
}

#[test]
fn fault_speed_log_scale_from_onset() {
    let trace = fault_trace(&["speed_log_scale:1.05@300"], 400.0);
    let (pre, post) = before_after(&trace, |x| x.0.t_s);
    assert!(pre.iter().all(|(_, m)| (m[1] - 7.0).abs() < 1e-12));
    assert!(post
        .iter()
        .all(|(tr, m)| (m[1] - 7.35).abs() < 1e-12 && tr.speed_mps == 7.0));
}

#[test]
fn fault_servo_rate_from_onset() {
    let cfg = Config::default();
    let mut ship = clean_ship(&cfg, 7.0, 7000.0, &["servo_rate_deg_s:2@300"]);
    let dt = ship.dt_s();
    // Alternate +-20 deg every 30 s: long ramps at the rate limit.
    let (mut pre_max, mut post_max, mut post_at_limit): (f64, f64, usize) = (0.0, 0.0, 0);
    let mut prev = ship.truth().delta_rad;
    for k in 0..ticks(600.0, &cfg) {
        let t = ship.time_s();
        let cmd = if (k / 300) % 2 == 0 { 20.0 } else { -20.0 };
        ship.set_command_override(Some(cmd * DEG));
        ship.step();
        let tr = ship.truth();
        let rate = (tr.delta_rad - prev).abs() / dt / DEG;
        prev = tr.delta_rad;
        if t < ONSET_S {
            pre_max = pre_max.max(rate);
        } else {
            post_max = post_max.max(rate);
            post_at_limit += usize::from((rate - 2.0).abs() < 1e-9);
            assert!((tr.servo_rate_rad_s - 2.0 * DEG).abs() < 1e-15);
        }
    }
    approx::assert_relative_eq!(pre_max, 4.0, max_relative = 1e-9);
    approx::assert_relative_eq!(post_max, 2.0, max_relative = 1e-9);
    // Each 40 deg reversal ramps ~20 s, i.e. ~200 ticks at exactly the new limit.
    assert!(post_at_limit > 500, "{post_at_limit}");
}

#[test]
fn fault_rudder_effectiveness_from_onset() {
    let cfg = Config::default();
    // Onset at 300 s, after ~4 time constants; check that nothing changed before, and that
    // the turn rate then tends to 0.7 (b/a) delta.
    let trace = fault_trace(&["rudder_effectiveness:0.7@300"], 2400.0);
    let clean = fault_trace(&[], 2400.0);
    let (a, b) = cfg.ship.nomoto(7.0, 7000.0);
    let (pre, post) = before_after(&trace, |x| x.0.t_s);
    for ((tr, _), (tc, _)) in pre.iter().zip(&clean) {
        assert_eq!(tr.r_rad_s, tc.r_rad_s);
        assert_eq!(tr.rudder_effectiveness, 1.0);
    }
    // One tick after the onset the turn rate already lags the clean ship's.
    let i = pre.len() + 1;
    assert!(trace[i].0.r_rad_s < clean[i].0.r_rad_s);
    assert!(post.iter().all(|(tr, _)| tr.rudder_effectiveness == 0.7));
    let r_end = post.last().unwrap().0.r_rad_s;
    approx::assert_relative_eq!(r_end, 0.7 * b / a * 3.0 * DEG, max_relative = 0.002);
}

#[test]
fn fault_heading_drift_from_onset() {
    let trace = fault_trace(&["heading_drift_deg_per_min:1@300"], 900.0);
    let (pre, post) = before_after(&trace, |x| x.0.t_s);
    let wrap = |x: f64| (x + PI).rem_euclid(2.0 * PI) - PI;
    for (tr, m) in pre {
        assert!(wrap(m[2] - tr.psi_rad).abs() < 1e-9);
    }
    for (tr, m) in post {
        let expect = (tr.t_s - ONSET_S) / 60.0 * DEG;
        assert!(
            (wrap(m[2] - tr.psi_rad) - expect).abs() < 1e-9,
            "t = {}",
            tr.t_s
        );
        assert!((tr.drift_rad - expect).abs() < 1e-12);
    }
    // At the end: 10 minutes, 10 deg.
    let (tr, m) = trace.last().unwrap();
    assert!((wrap(m[2] - tr.psi_rad) / DEG - 9.99833).abs() < 1e-3);
}

// ---------------------------------------------------------------------------------------------
// 6. Determinism

#[test]
fn same_seed_same_bytes_other_seed_other_bytes() {
    let cfg = Config::default();
    let rec = |seed| {
        let sc = scenario(
            7.0,
            7000.0,
            SeaState::Moderate,
            &["displacement_pct:10@30"],
            seed,
        );
        let mut out = Vec::new();
        let lines = helmwatch_core::sim::record(&cfg.sim(), &sc, 120.0, "self", &mut out).unwrap();
        (lines, out)
    };
    let (l1, a) = rec(5);
    let (l2, b) = rec(5);
    let (_, c) = rec(6);
    // 1200 ticks of rudder, speed, heading + 120 status pairs.
    assert_eq!(l1, 1200 * 3 + 120 * 2);
    assert_eq!(l1, l2);
    assert_eq!(a, b);
    assert_ne!(a, c);
    let text = String::from_utf8(a).unwrap();
    let first: helmwatch_core::wire::RecordLine =
        serde_json::from_str(text.lines().next().unwrap()).unwrap();
    assert_eq!(first.key, "vessels/self/steering/rudderAngle");
    assert_eq!(text.lines().count() as u64, l1);
}

// ---------------------------------------------------------------------------------------------
// Contract details

/// Lockstep order, status period, one draw per tick, RNG independent of publish().
#[test]
fn publish_order_and_single_draw() {
    let cfg = Config::default();
    let sc = Scenario::nominal(&cfg.sim(), 9);
    let mut a = Ship::new(&cfg.sim(), &sc).unwrap();
    let mut b = Ship::new(&cfg.sim(), &sc).unwrap();
    let mut buf = Vec::new();
    let mut status_ticks = Vec::new();
    for k in 0..50 {
        buf.clear();
        a.publish(&mut buf);
        let first = buf.clone();
        a.publish(&mut buf); // same tick again: same values, status not repeated
        let again = &buf[first.len()..];
        assert_eq!(again.len(), 3);
        assert_eq!(again[0], first[0]);
        assert_eq!(again[1], first[1]);
        assert_eq!(again[2], first[first.len() - 1]);
        let kinds: Vec<_> = first.iter().map(Input::stream).collect();
        use helmwatch_core::wire::Stream::*;
        if kinds.len() == 5 {
            assert_eq!(
                kinds,
                [Rudder, Speed, AutopilotState, TargetHeading, Heading]
            );
            status_ticks.push(k);
        } else {
            assert_eq!(kinds, [Rudder, Speed, Heading]);
        }
        assert!(first.iter().all(|i| i.t() == a.time_s()));
        if let Input::Heading(h) = first.last().unwrap() {
            assert!((0.0..2.0 * PI).contains(&h.value));
        }
        a.step();
        b.step(); // never published
        assert_eq!(a.truth(), b.truth());
    }
    assert_eq!(status_ticks, [0, 10, 20, 30, 40]);
}

/// Excitation: `add` shifts the command, expiry reverts, standby holds and ignores it.
#[test]
fn excitation_and_standby_on_the_ship() {
    let cfg = Config::default();
    let mut ship = Ship::with_options(
        &cfg.sim(),
        &Scenario::nominal(&cfg.sim(), 4),
        SimOptions::CLEAN,
    )
    .unwrap();
    run(&mut ship, 100);
    let t = ship.time_s();
    ship.receive_excitation(&Excitation {
        t,
        mode: ExcitationMode::Add,
        value: 5.0 * DEG,
        hold_s: 0.25,
        test: Some("x".into()),
    });
    ship.step();
    let tr = ship.truth();
    assert_eq!(tr.command_source, CommandSource::Added);
    assert!(
        (tr.command_rad - 5.0 * DEG).abs() < 0.01 * DEG,
        "{}",
        tr.command_rad / DEG
    );
    run(&mut ship, 3); // the last step at t + 0.3 > t + hold
    assert_eq!(ship.truth().command_source, CommandSource::Own);
    ship.set_autopilot_engaged(false);
    let held = ship.truth().command_rad;
    ship.receive_excitation(&Excitation {
        t: ship.time_s(),
        mode: ExcitationMode::Replace,
        value: 10.0 * DEG,
        hold_s: 1.0,
        test: None,
    });
    ship.step();
    assert_eq!(ship.truth().command_source, CommandSource::Standby);
    assert_eq!(ship.truth().command_rad, held);
    let mut buf = Vec::new();
    ship.publish(&mut buf);
    assert!(buf
        .iter()
        .any(|i| matches!(i, Input::AutopilotState(s) if s.value == "standby")));
}

#[test]
fn bad_scenarios_are_refused() {
    let cfg = Config::default();
    for (u, d) in [
        (0.0, 7000.0),
        (-1.0, 7000.0),
        (f64::NAN, 7000.0),
        (7.0, 0.0),
        (7.0, f64::INFINITY),
    ] {
        assert!(Ship::new(&cfg.sim(), &scenario(u, d, SeaState::Calm, &[], 1)).is_err());
    }
    let mut sc = Scenario::nominal(&cfg.sim(), 1);
    sc.faults.push(Fault {
        kind: helmwatch_core::sim::FaultKind::RudderEffectiveness,
        value: 0.0,
        onset_s: 0.0,
    });
    assert!(Ship::new(&cfg.sim(), &sc).is_err());
    let mut out = Vec::new();
    assert!(helmwatch_core::sim::record(
        &cfg.sim(),
        &Scenario::nominal(&cfg.sim(), 1),
        1.0,
        "a/b",
        &mut out
    )
    .is_err());
    assert!(helmwatch_core::sim::record(
        &cfg.sim(),
        &Scenario::nominal(&cfg.sim(), 1),
        -1.0,
        "self",
        &mut out
    )
    .is_err());
}

// ---------------------------------------------------------------------------------------------
// Cross-check against the relay reference table (docs/dsp.md, "HBT"; docs/sim.md)

/// Relay feedback (h = 5 deg, eps = 1 deg, centred on zero rudder, gyro noise only, no sea):
/// limit-cycle period and first-harmonic heading amplitude against the reference table
/// (docs/dsp.md, "HBT"), within 3 %. Period from the relay's switching instants, amplitude
/// from the first-harmonic Fourier integral over whole periods of the linearly detrended
/// heading.
#[test]
fn relay_limit_cycle_matches_domain_reference() {
    let cfg = Config::default();
    let table = [
        (4.0, 4000.0, 255.0, 3.38),
        (4.0, 10000.0, 345.0, 2.38),
        (7.0, 7000.0, 180.0, 2.88),
        (7.0, 7700.0, 187.0, 2.81),
        (10.0, 4000.0, 110.0, 3.90),
        (10.0, 10000.0, 145.0, 2.62),
    ];
    let (h, eps) = (5.0 * DEG, 1.0 * DEG);
    let mut buf = Vec::new();
    for (u, d, period_ref, amp_ref) in table {
        let opts = SimOptions {
            noise: true,
            disturbances: false,
        };
        let mut ship =
            Ship::with_options(&cfg.sim(), &scenario(u, d, SeaState::Calm, &[], 21), opts).unwrap();
        let target = ship.truth().target_rad;
        let mut relay = h;
        // Upward switches (relay goes to +h) and the heading trace.
        let (mut ups, mut trace) = (Vec::new(), Vec::new());
        for _ in 0..ticks(12.0 * period_ref, &cfg) {
            buf.clear();
            ship.publish(&mut buf);
            let m = buf
                .iter()
                .find_map(|i| match i {
                    Input::Heading(m) => Some(*m),
                    _ => None,
                })
                .unwrap();
            let err = (target - m.value + PI).rem_euclid(2.0 * PI) - PI;
            if err > eps && relay < 0.0 {
                relay = h;
                ups.push(m.t);
            } else if err < -eps && relay > 0.0 {
                relay = -h;
            }
            trace.push((m.t, ship.truth().psi_rad));
            ship.set_command_override(Some(relay));
            ship.step();
        }
        // Skip the first 4 cycles, measure the rest.
        let ups = &ups[4..];
        let cycles = ups.len() - 1;
        assert!(cycles >= 3);
        let period = (ups[cycles] - ups[0]) / cycles as f64;
        let win: Vec<(f64, f64)> = trace
            .iter()
            .copied()
            .filter(|(t, _)| *t >= ups[0] && *t < ups[cycles])
            .collect();
        let n = win.len() as f64;
        let (mt, mp) = win
            .iter()
            .fold((0.0, 0.0), |acc, p| (acc.0 + p.0 / n, acc.1 + p.1 / n));
        let slope = win.iter().map(|p| (p.0 - mt) * (p.1 - mp)).sum::<f64>()
            / win.iter().map(|p| (p.0 - mt).powi(2)).sum::<f64>();
        let w = 2.0 * PI / period;
        let (mut re, mut im) = (0.0, 0.0);
        for (t, p) in &win {
            let y = p - mp - slope * (t - mt);
            re += y * (w * t).cos();
            im += y * (w * t).sin();
        }
        let amp_deg = 2.0 * (re * re + im * im).sqrt() / n / DEG;
        eprintln!(
            "relay u={u} D={d}: period {period:.1} s (ref {period_ref}), amplitude {amp_deg:.2} deg (ref {amp_ref})"
        );
        approx::assert_relative_eq!(period, period_ref, max_relative = 0.03);
        approx::assert_relative_eq!(amp_deg, amp_ref, max_relative = 0.03);
    }
}
