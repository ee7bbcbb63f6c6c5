//! The KVLCC2 MMG hull (`sim::mmg`) against independent answers: the closed-form
//! self-propulsion point, Froude similarity of a 35 deg turn, the published model-scale
//! manoeuvre figures (via an independent re-implementation, see `turning_circle_at_model_scale`),
//! the analytic linear sway-yaw step and frequency responses on both sides of its
//! piecewise-linear flow straightening, and the hull inside the simulated ship (faults,
//! autopilot, speed log; the autopilot's course keeping also for the Mariner hull,
//! `tests/it/mariner.rs`).

use helmwatch::config::Config;
use helmwatch_core::model::SeaState;
use helmwatch_core::sim::config::{family, HullModel};
use helmwatch_core::sim::mmg::{MmgHull, MmgInput, Side};
use helmwatch_core::sim::{Scenario, Ship, SimOptions};
use std::f64::consts::PI;

const DEG: f64 = PI / 180.0;

/// KVLCC2 model (Yasukawa & Yoshimura 2015, Tables 1-3), restated here from the paper: the
/// draft [m], propeller diameter [m], R_0', t_P, w_P0, k_0, k_1, k_2.
const DRAFT_M: f64 = 0.46;
const PROP_D_M: f64 = 0.216;
const R0: f64 = 0.022;
const T_P: f64 = 0.220;
const W_P0: f64 = 0.40;
const K: [f64; 3] = [0.2931, -0.2753, -0.1385];

/// Straight running: X_P = R with J = u (1 - w_P0) / (n D) gives k0 x^2 + k1 x + k2 = C for
/// x = 1/J, C = L d R_0' / (2 (1 - t_P) D^2 (1 - w_P0)^2) (lambda cancels between L d and D^2).
#[test]
fn self_propulsion_matches_the_closed_form() {
    for (l, u) in [(7.0, 1.179), (120.0, 4.0), (120.0, 10.0), (320.0, 7.97)] {
        let h = MmgHull::new(l, u, 0.0).unwrap();
        let lambda: f64 = l / 7.0;
        let d = PROP_D_M * lambda;
        approx::assert_relative_eq!(h.propeller_diameter_m(), d, max_relative = 1e-12);
        let cc = l * DRAFT_M * lambda * R0 / (2.0 * (1.0 - T_P) * d * d * (1.0 - W_P0).powi(2));
        let x = (-K[1] + (K[1] * K[1] - 4.0 * K[0] * (K[2] - cc)).sqrt()) / (2.0 * K[0]);
        let n = u * (1.0 - W_P0) * x / d;
        approx::assert_relative_eq!(h.propeller_rps(), n, max_relative = 1e-10);
    }
}

/// At zero rudder and no sea, straight running at the design speed is an equilibrium.
#[test]
fn straight_running_is_an_equilibrium() {
    let mut h = MmgHull::new(120.0, 7.0, 0.3).unwrap();
    for _ in 0..30_000 {
        h.advance(0.0, 0.0, &MmgInput::default(), 0.02);
    }
    let s = h.state;
    assert!((s.u_mps - 7.0).abs() < 1e-9, "{s:?}");
    assert!(s.v_mps.abs() < 1e-12 && s.r_rad_s.abs() < 1e-12, "{s:?}");
    approx::assert_relative_eq!(s.x_m, 4200.0 * 0.3f64.cos(), max_relative = 1e-9);
    approx::assert_relative_eq!(s.y_m, 4200.0 * 0.3f64.sin(), max_relative = 1e-9);
}

/// Turning indices of a `rudder_deg` turn (negative: to port) with the rudder moved at
/// `rate_deg_s` from straight running: (advance, transfer, tactical diameter) in ship
/// lengths, and the speed ratio u/u0 when the heading has changed by 180 deg (None if it
/// never does).
fn turn(l: f64, u0: f64, rudder_deg: f64, rate_deg_s: f64, h_s: f64) -> Option<[f64; 4]> {
    let mut hull = MmgHull::new(l, u0, 0.0).unwrap();
    let target = rudder_deg * DEG;
    let step = rate_deg_s * DEG * h_s;
    let mut delta: f64 = 0.0;
    let (mut advance, mut transfer) = (f64::NAN, f64::NAN);
    for _ in 0..(2000.0 * l / u0 / h_s) as usize {
        let next = delta + (target - delta).clamp(-step, step);
        hull.advance(delta, next, &MmgInput::default(), h_s);
        delta = next;
        let s = hull.state;
        if advance.is_nan() && s.psi_rad.abs() >= PI / 2.0 {
            advance = s.x_m / l;
            transfer = s.y_m.abs() / l;
        }
        if s.psi_rad.abs() >= PI {
            return Some([advance, transfer, s.y_m.abs() / l, s.u_mps / u0]);
        }
    }
    None
}

/// The 35 deg turning test as SIMMAN 2008 / 2020 case 1.2 runs the KVLCC2 model (L = 7 m,
/// Fn = 0.142: 1.179 m/s, constant revolutions of self-propulsion, rudder rate 15.68 deg/s
/// model scale = 2.32 deg/s full scale), starboard and port.
///
/// Reference: an independent re-implementation of the same published equations and
/// constants (plain Python, RK4 at 0.01 s, written from the paper for this test) gave
/// advance 3.081 L, transfer 1.332 L, tactical diameter 3.118 L to starboard and 3.092,
/// 1.332, 3.105 L to port; tolerance 1 % (the integration step and rudder-ramp
/// discretisation differ). The published free-running figures could not be retrieved for
/// this test (docs/sim.md); IMO's criteria (MSC.137(76): advance < 4.5 L, tactical
/// diameter < 5 L) bound them from above, and a VLCC's 35 deg turn is no tighter than 2.5 L.
///
/// Froude similarity: the same turn at 120 m and 7 m/s with the rudder rate and the step
/// scaled by the time ratio (L/U) gives the same indices in ship lengths.
#[test]
fn turning_circle_at_model_scale() {
    let (l, u0, rate) = (7.0, 1.179, 15.68);
    let reference = [
        (35.0, [3.081, 1.332, 3.118]),
        (-35.0, [3.092, 1.332, 3.105]),
    ];
    for (rudder, want) in reference {
        let got = turn(l, u0, rudder, rate, 0.005).unwrap();
        eprintln!(
            "35 deg turn {}: advance {:.3} L, transfer {:.3} L, tactical diameter {:.3} L, u/u0 {:.3} at 180 deg",
            if rudder > 0.0 { "starboard" } else { "port" },
            got[0],
            got[1],
            got[2],
            got[3]
        );
        for (g, w) in got.iter().zip(want) {
            assert!((g / w - 1.0).abs() < 0.01, "{got:?} vs {want:?}");
        }
        assert!(got[0] > 2.5 && got[0] < 4.5, "advance {}", got[0]);
        assert!(got[2] > 2.5 && got[2] < 5.0, "tactical diameter {}", got[2]);
        // Speed loss in the turn (surge coupled to sway and yaw): well below the approach.
        assert!(got[3] > 0.3 && got[3] < 0.6, "u/u0 {}", got[3]);
        // Froude similarity: 120 m at 7 m/s, time scaled by (120/7) / (7/1.179).
        let time_ratio = (120.0 / 7.0) / (l / u0);
        let big = turn(120.0, 7.0, rudder, rate / time_ratio, 0.005 * time_ratio).unwrap();
        for (g, b) in got.iter().zip(big) {
            assert!((g - b).abs() < 1e-6 * g, "{got:?} vs {big:?}");
        }
    }
}

/// r(t) of K (1 + T3 s) / ((1 + T1 s)(1 + T2 s)) after a rudder step `delta` at t = 0.
fn linear_step(lin: &helmwatch_core::sim::mmg::LinearNomoto, delta: f64, t: f64) -> f64 {
    let (k, t1, t2, t3) = (lin.k_per_s, lin.t1_s, lin.t2_s, lin.t3_s);
    k * delta
        * (1.0 - (t1 - t3) / (t1 - t2) * (-t / t1).exp() - (t2 - t3) / (t2 - t1) * (-t / t2).exp())
}

/// Simulated turn rate at the whole seconds in `at_s` after a rudder step from straight
/// running (120 m, 7 m/s), for the given input.
fn step_rates(delta: f64, input: &MmgInput, at_s: &[u32]) -> Vec<f64> {
    let mut hull = MmgHull::new(120.0, 7.0, 0.0).unwrap();
    let mut out = Vec::new();
    let per_s = 50;
    for i in 1..=(at_s.iter().max().copied().unwrap_or(0) * per_s) {
        hull.advance(delta, delta, input, 1.0 / f64::from(per_s));
        if i % per_s == 0 && at_s.contains(&(i / per_s)) {
            out.push(hull.state.r_rad_s);
        }
    }
    out
}

/// The small-rudder response against the analytic linearisation (`MmgHull::linear`, the
/// derivatives of the published model taken by hand): a 0.1 deg step to starboard follows
/// the stable starboard-side model (T1 ~ 263 s) within 1 % over 300 s, one to port the
/// unstable port-side model (T1 < 0) within 1 % over 100 s. At 2 deg the steady turn rate
/// is far below the linear one (the hull is nonlinear: K halves).
#[test]
fn small_rudder_steps_follow_the_linearised_model_on_each_side() {
    let hull = MmgHull::new(120.0, 7.0, 0.0).unwrap();
    let stbd = hull.linear(Side::Starboard, 1.0, 1.0);
    let port = hull.linear(Side::Port, 1.0, 1.0);
    eprintln!("linear starboard {stbd:?}\nlinear port {port:?}");
    assert!(stbd.t1_s > 100.0 && stbd.k_per_s > 0.0, "{stbd:?}");
    assert!(port.t1_s < -100.0 && port.k_per_s < 0.0, "{port:?}");
    let input = MmgInput::default();
    for (side, lin, times) in [
        (1.0, stbd, vec![10, 30, 100, 300]),
        (-1.0, port, vec![10, 30, 100]),
    ] {
        let delta = side * 0.1 * DEG;
        let sim = step_rates(delta, &input, &times);
        for (t, r) in times.iter().zip(sim) {
            let want = linear_step(&lin, delta, f64::from(*t));
            assert!(
                (r / want - 1.0).abs() < 0.01,
                "side {side} t {t}: {r} vs {want}"
            );
        }
    }
    let big = step_rates(2.0 * DEG, &input, &[1500])[0];
    let linear = stbd.k_per_s * 2.0 * DEG;
    assert!(
        big < 0.6 * linear && big > 0.2 * linear,
        "{big} vs {linear}"
    );
}

/// A rudder-effectiveness loss (e = 0.7) and a heavier ship (mass factor 1.2) answer as the
/// linearised model with that effectiveness or mass does: the ratio of the simulated step
/// responses to the nominal one equals the ratio of the models' within 1 %. (e scales F_N, so
/// it also takes 30 % of the rudder's share of the hull's damping: the ratio is not 0.7.)
#[test]
fn effectiveness_and_mass_act_as_the_linear_model_says() {
    let times = [5, 20, 60];
    let delta = 0.1 * DEG;
    let nominal = step_rates(delta, &MmgInput::default(), &times);
    let weak = step_rates(
        delta,
        &MmgInput {
            rudder_effectiveness: 0.7,
            ..MmgInput::default()
        },
        &times,
    );
    let heavy = step_rates(
        delta,
        &MmgInput {
            mass_factor: 1.2,
            ..MmgInput::default()
        },
        &times,
    );
    let hull = MmgHull::new(120.0, 7.0, 0.0).unwrap();
    let l1 = hull.linear(Side::Starboard, 1.0, 1.0);
    let l_weak = hull.linear(Side::Starboard, 1.0, 0.7);
    let l_heavy = hull.linear(Side::Starboard, 1.2, 1.0);
    for (i, t) in times.iter().enumerate() {
        let t_s = f64::from(*t);
        let base = linear_step(&l1, delta, t_s);
        for (name, sim, lin) in [("weak", &weak, &l_weak), ("heavy", &heavy, &l_heavy)] {
            let want = linear_step(lin, delta, t_s) / base;
            let got = sim[i] / nominal[i];
            eprintln!("{name} t {t}: {got:.4} (linear {want:.4})");
            assert!(
                (got / want - 1.0).abs() < 0.01,
                "{name} t {t}: {got} vs {want}"
            );
        }
        // The test can tell: a weaker rudder always answers less; the heavier ship starts
        // slower (inertia) and later turns faster (mass takes course stability away).
        assert!(weak[i] / nominal[i] < 0.9, "t {t}");
    }
    assert!(heavy[0] / nominal[0] < 0.95 && heavy[2] / nominal[2] > 1.05);
}

fn member_config(hull: HullModel) -> Config {
    let mut cfg = Config::default();
    let member = family()
        .into_iter()
        .find(|m| m.structure.hull == hull)
        .unwrap();
    member.apply(&mut cfg.structure, &mut cfg.autopilot);
    cfg
}

fn mmg_config() -> Config {
    member_config(HullModel::Kvlcc2Mmg)
}

/// The family's surge-sway-yaw members inside the simulated ship, moderate sea, at the
/// corners of the (u, D) box: the autopilot (tuned on the hull's own linear model) keeps the
/// true heading error RMS under the member's bound with the servo rate limited under 5 % of
/// the time, and the speed log reads the hull's surge speed (within
/// 0.1 m/s of the scenario's on a steady course). The bound: 0.5 deg for KVLCC2, 1 deg for
/// the Mariner. The sea acts as a rudder-equivalent angle, and the Mariner answers a rudder
/// angle 5.5 times as much as the family's ship (K L / U = 3.9 against 0.7; KVLCC2's 6.9
/// with four times the time constant): its heading error at 10 m/s is 0.6-0.85 deg
/// (KVLCC2's 0.4-0.5 deg, the first-order ship's 0.15-0.2 deg).
#[test]
fn surge_sway_yaw_members_keep_their_course_in_a_moderate_sea() {
    for (hull, bound_deg) in [(HullModel::Kvlcc2Mmg, 0.5), (HullModel::Mariner, 1.0)] {
        let cfg = member_config(hull);
        assert_eq!(cfg.structure.mmg_length_m, 120.0);
        for (u, d) in [
            (4.0, 4000.0),
            (4.0, 10000.0),
            (10.0, 4000.0),
            (10.0, 10000.0),
        ] {
            let sc = Scenario {
                speed_mps: u,
                displacement_t: d,
                sea: SeaState::Moderate,
                faults: Vec::new(),
                seed: 5,
            };
            let mut ship = Ship::new(&cfg.sim(), &sc).unwrap();
            let dt = 1.0 / cfg.sensors.rate_hz;
            for _ in 0..(600.0 / dt) as usize {
                ship.step();
            }
            let n = (1800.0 / dt) as usize;
            let (mut sum2, mut limited, mut speed_err) = (0.0, 0usize, 0.0f64);
            for _ in 0..n {
                ship.step();
                let tr = ship.truth();
                let err = (tr.psi_rad - tr.target_rad + PI).rem_euclid(2.0 * PI) - PI;
                sum2 += err * err;
                limited += usize::from(tr.rate_limited);
                speed_err = speed_err.max((tr.speed_mps - u).abs());
            }
            let rms_deg = (sum2 / n as f64).sqrt() / DEG;
            let frac = limited as f64 / n as f64;
            eprintln!("{hull:?} u {u} D {d}: heading RMS {rms_deg:.3} deg, rate limited {:.2} %, max |u - u0| {speed_err:.4} m/s", frac * 100.0);
            assert!(
                rms_deg < bound_deg && rms_deg > 0.005,
                "{hull:?} u {u} D {d}: {rms_deg}"
            );
            assert!(frac < 0.05, "{hull:?} u {u} D {d}: {frac}");
            assert!(
                speed_err < 0.1 && speed_err > 0.0,
                "{hull:?} u {u} D {d}: {speed_err}"
            );
        }
    }
}

/// Open loop in the ship, clean: a small rudder step with a displacement fault of +20 %
/// answers as the hull alone does at mass factor 1.2 (the fault reaches the MMG mass), and
/// the truth reports the hull's linearised b, lower for the heavier ship.
#[test]
fn displacement_fault_reaches_the_mmg_mass() {
    let cfg = mmg_config();
    let run = |faults: Vec<helmwatch_core::sim::Fault>| {
        let sc = Scenario {
            speed_mps: 7.0,
            displacement_t: 7000.0,
            sea: SeaState::Calm,
            faults,
            seed: 1,
        };
        let mut ship = Ship::with_options(&cfg.sim(), &sc, SimOptions::CLEAN).unwrap();
        ship.set_command_override(Some(0.1 * DEG));
        for _ in 0..300 {
            ship.step();
        }
        ship.truth()
    };
    let nominal = run(Vec::new());
    let heavy = run(vec!["displacement_pct:+20@0".parse().unwrap()]);
    let hull = MmgHull::new(120.0, 7.0, 0.0).unwrap();
    let (l1, l12) = (
        hull.linear(Side::Starboard, 1.0, 1.0),
        hull.linear(Side::Starboard, 1.2, 1.0),
    );
    // The servo (T_r = 1 s) delays the step by about a second: compare at 29 s.
    let want = linear_step(&l12, 1.0, 29.0) / linear_step(&l1, 1.0, 29.0);
    let got = heavy.r_rad_s / nominal.r_rad_s;
    assert!((got / want - 1.0).abs() < 0.01, "{got} vs {want}");
    assert!(heavy.b_per_s2 < nominal.b_per_s2);
    let (k, t) = l1.first_order();
    approx::assert_relative_eq!(nominal.b_per_s2, k / t, max_relative = 1e-12);
    approx::assert_relative_eq!(heavy.displacement_t, 8400.0, max_relative = 1e-12);
}

/// The frequency response on the stable side: around a steady 0.1 deg starboard turn
/// (beta_R positive throughout, the linear range), a 0.05 deg rudder sine at 0.03 and 0.15 rad/s (either
/// side of the hull's fast pole and zero, 1/T3 = 0.065 rad/s) gives a turn-rate first
/// harmonic within 2 % in gain and 1 deg in phase of the starboard linear model's
/// K (1 + j w T3) / ((1 + j w T1)(1 + j w T2)). The test can tell: the gain falls by a factor
/// 2.8 between the two (the first-order approximation K / (1 + j w T) would fall 5-fold and
/// be 46 % low at 0.15 rad/s).
#[test]
fn frequency_response_follows_the_linearised_model() {
    let hull0 = MmgHull::new(120.0, 7.0, 0.0).unwrap();
    let lin = hull0.linear(Side::Starboard, 1.0, 1.0);
    let (bias, amp) = (0.1 * DEG, 0.05 * DEG);
    let h = 0.02;
    let input = MmgInput::default();
    let mut gains = Vec::new();
    for w in [0.03, 0.15] {
        let mut hull = hull0.clone();
        // Settle on the biased turn (> 10 T1).
        for _ in 0..(3000.0 / h) as usize {
            hull.advance(bias, bias, &input, h);
        }
        // Four periods to let the sine's transient decay (T2 ~ 6 s; T1's decays as e^-t/T1,
        // its remnant is a slow drift taken out by fitting over whole periods), then eight
        // measured periods.
        let period = 2.0 * PI / w;
        let steps = (period / h).round() as usize;
        let dt = period / steps as f64;
        let (mut c, mut s) = (0.0, 0.0);
        let n_meas = 8 * steps;
        let mut t = 0.0;
        for k in 0..(12 * steps) {
            let d0 = bias + amp * (w * t).sin();
            let d1 = bias + amp * (w * (t + dt)).sin();
            hull.advance(d0, d1, &input, dt);
            t += dt;
            if k >= 4 * steps {
                let r = hull.state.r_rad_s;
                c += r * (w * t).cos();
                s += r * (w * t).sin();
            }
        }
        // r ~ A sin(w t + phi): s -> (N/2) A cos phi, c -> (N/2) A sin phi.
        let (a_sin, a_cos) = (2.0 * s / n_meas as f64, 2.0 * c / n_meas as f64);
        let gain = (a_sin * a_sin + a_cos * a_cos).sqrt() / amp;
        let phase = a_cos.atan2(a_sin);
        let jw = |x: f64| (1.0, w * x);
        let mul = |a: (f64, f64), b: (f64, f64)| (a.0 * b.0 - a.1 * b.1, a.0 * b.1 + a.1 * b.0);
        let div = |a: (f64, f64), b: (f64, f64)| {
            let d = b.0 * b.0 + b.1 * b.1;
            ((a.0 * b.0 + a.1 * b.1) / d, (a.1 * b.0 - a.0 * b.1) / d)
        };
        let g = div(
            mul((lin.k_per_s, 0.0), jw(lin.t3_s)),
            mul(jw(lin.t1_s), jw(lin.t2_s)),
        );
        let (want_gain, want_phase) = ((g.0 * g.0 + g.1 * g.1).sqrt(), g.1.atan2(g.0));
        eprintln!(
            "w {w}: gain {gain:.5} (linear {want_gain:.5}), phase {:.2} deg (linear {:.2} deg)",
            phase / DEG,
            want_phase / DEG
        );
        assert!(
            (gain / want_gain - 1.0).abs() < 0.02,
            "w {w}: {gain} vs {want_gain}"
        );
        assert!(
            (phase - want_phase).abs() < 1.0 * DEG,
            "w {w}: {phase} vs {want_phase}"
        );
        let (k, t1) = lin.first_order();
        let first_order_gain = k / (1.0 + (w * t1).powi(2)).sqrt();
        gains.push((gain, first_order_gain));
    }
    let ((g_lo, _), (g_hi, first_hi)) = (gains[0], gains[1]);
    assert!(g_lo / g_hi > 2.0 && g_lo / g_hi < 4.0, "{gains:?}");
    assert!(g_hi / first_hi > 1.3, "{gains:?}");
}
