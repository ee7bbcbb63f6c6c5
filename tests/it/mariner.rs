//! The Mariner hull (`sim::mariner`) against independent answers: Fossen's published Nomoto
//! model of the Mariner (K = 0.185 1/s, T1 = 118 s, T2 = 7.8 s, T3 = 18.5 s at 7.7175 m/s),
//! the nonlinear hull's small-rudder response against the analytic step of that model, the
//! mass and effectiveness against the linearisation, Froude similarity of a 35 deg turn and
//! IMO's turning criteria. The family's Mariner member keeping its course in the ship:
//! `tests/it/mmg.rs` (`surge_sway_yaw_members_keep_their_course_in_a_moderate_sea`).

use helmwatch_core::sim::mariner::{MarinerHull, LENGTH_M, PUBLISHED_SPEED_MPS};
use helmwatch_core::sim::mmg::{LinearNomoto, MmgInput};
use std::f64::consts::PI;

const DEG: f64 = PI / 180.0;

/// Fossen (Handbook of Marine Craft Hydrodynamics and Motion Control, 2011), the Mariner's
/// Nomoto models at 15 knots, in this crate's sign (a positive rudder turns to starboard).
const PUBLISHED: (f64, f64, f64, f64) = (0.185, 118.0, 7.8, 18.5);

#[test]
fn the_linearisation_is_fossens_published_nomoto_model() {
    let h = MarinerHull::new(LENGTH_M, PUBLISHED_SPEED_MPS, 0.0).unwrap();
    let lin = h.linear(1.0, 1.0);
    eprintln!("{lin:?}");
    let (k, t1, t2, t3) = PUBLISHED;
    // The published figures carry two or three digits: 1 % (T2: 7.76 against 7.8).
    for (got, want) in [
        (lin.k_per_s, k),
        (lin.t1_s, t1),
        (lin.t2_s, t2),
        (lin.t3_s, t3),
    ] {
        assert!((got / want - 1.0).abs() < 0.01, "{lin:?}");
    }
    let (_, t) = lin.first_order();
    assert!((t - 107.3).abs() < 0.5, "{t}");
    // Froude similarity: at 120 m and 7 m/s K L / U and T U / L are the same numbers.
    let small = MarinerHull::new(120.0, 7.0, 0.0).unwrap().linear(1.0, 1.0);
    approx::assert_relative_eq!(
        small.k_per_s * 120.0 / 7.0,
        lin.k_per_s * LENGTH_M / PUBLISHED_SPEED_MPS,
        max_relative = 1e-12
    );
    approx::assert_relative_eq!(
        small.t1_s * 7.0 / 120.0,
        lin.t1_s * PUBLISHED_SPEED_MPS / LENGTH_M,
        max_relative = 1e-12
    );
}

/// r(t) of K (1 + T3 s) / ((1 + T1 s)(1 + T2 s)) after a rudder step `delta` at t = 0.
fn linear_step(lin: &LinearNomoto, delta: f64, t: f64) -> f64 {
    let (k, t1, t2, t3) = (lin.k_per_s, lin.t1_s, lin.t2_s, lin.t3_s);
    k * delta
        * (1.0 - (t1 - t3) / (t1 - t2) * (-t / t1).exp() - (t2 - t3) / (t2 - t1) * (-t / t2).exp())
}

/// The turn rate at the whole seconds `at_s` with the rudder held at `delta` from the trim
/// (the rudder and sway of straight running, `MarinerHull::trim`) at the published length and
/// speed.
fn rates(delta: f64, input: &MmgInput, at_s: &[u32]) -> Vec<f64> {
    let mut hull = MarinerHull::new(LENGTH_M, PUBLISHED_SPEED_MPS, 0.0).unwrap();
    let (trim, v0) = hull.trim(input.rudder_effectiveness);
    hull.state.v_mps = v0;
    let delta = trim + delta;
    let per_s = 50;
    let mut out = Vec::new();
    for i in 1..=(at_s.iter().max().copied().unwrap_or(0) * per_s) {
        hull.advance(delta, delta, input, 1.0 / f64::from(per_s));
        if i % per_s == 0 && at_s.contains(&(i / per_s)) {
            out.push(hull.state.r_rad_s);
        }
    }
    out
}

/// The single screw's asymmetry (Y_0, N_0) asks for 1.1 deg of rudder to port to run
/// straight (the trim holds r under 1e-7 rad/s for 300 s); a small rudder step from the trim
/// follows the published linear model within 1.5 % over 300 s. At 10 deg the steady turn is
/// far below the linear one (the cubic damping).
#[test]
fn small_rudder_steps_follow_the_published_model() {
    let times = [10, 30, 100, 300];
    let input = MmgInput::default();
    let base = rates(0.0, &input, &times);
    let lin = MarinerHull::new(LENGTH_M, PUBLISHED_SPEED_MPS, 0.0)
        .unwrap()
        .linear(1.0, 1.0);
    for delta in [0.2 * DEG, -0.2 * DEG] {
        let got = rates(delta, &input, &times);
        for ((t, r), r0) in times.iter().zip(got).zip(&base) {
            let want = linear_step(&lin, delta, f64::from(*t));
            assert!(
                ((r - r0) / want - 1.0).abs() < 0.015,
                "delta {delta} t {t}: {} vs {want}",
                r - r0
            );
        }
    }
    let (trim, _) = MarinerHull::new(LENGTH_M, PUBLISHED_SPEED_MPS, 0.0)
        .unwrap()
        .trim(1.0);
    assert!((trim / DEG + 1.108).abs() < 0.01, "{trim}");
    // The first-order trim leaves a drift under 0.1 % of the step's answer.
    assert!(base.iter().all(|r| r.abs() < 1e-6), "{base:?}");
    let big = rates(10.0 * DEG, &input, &[1200])[0] - rates(0.0, &input, &[1200])[0];
    let linear = lin.k_per_s * 10.0 * DEG;
    assert!(
        big > 0.2 * linear && big < 0.8 * linear,
        "{big} vs {linear}"
    );
}

/// A rudder-effectiveness loss (e = 0.7) and a heavier ship (mass factor 1.2) answer as the
/// linearised model with that effectiveness or mass: the ratio of the step responses to the
/// nominal one (differences from the zero-rudder run) equals the models' within 1.5 %.
#[test]
fn effectiveness_and_mass_act_as_the_linear_model_says() {
    let times = [5, 20, 60, 200];
    let delta = 0.2 * DEG;
    let step = |input: &MmgInput| -> Vec<f64> {
        let base = rates(0.0, input, &times);
        rates(delta, input, &times)
            .iter()
            .zip(base)
            .map(|(a, b)| a - b)
            .collect()
    };
    let nominal = step(&MmgInput::default());
    let hull = MarinerHull::new(LENGTH_M, PUBLISHED_SPEED_MPS, 0.0).unwrap();
    let l1 = hull.linear(1.0, 1.0);
    for (name, input) in [
        (
            "weak",
            MmgInput {
                rudder_effectiveness: 0.7,
                ..MmgInput::default()
            },
        ),
        (
            "heavy",
            MmgInput {
                mass_factor: 1.2,
                ..MmgInput::default()
            },
        ),
    ] {
        let got = step(&input);
        let lin = hull.linear(input.mass_factor, input.rudder_effectiveness);
        for (i, t) in times.iter().enumerate() {
            let t_s = f64::from(*t);
            let want = linear_step(&lin, delta, t_s) / linear_step(&l1, delta, t_s);
            let ratio = got[i] / nominal[i];
            eprintln!("{name} t {t}: {ratio:.4} (linear {want:.4})");
            assert!((ratio / want - 1.0).abs() < 0.015, "{name} t {t}");
        }
        if name == "weak" {
            // No damping from the rudder in this model: the gain scales exactly.
            assert!((lin.k_per_s / l1.k_per_s - 0.7).abs() < 1e-12);
        } else {
            // Heavier: slower at first, and slower to settle.
            assert!(got[0] < 0.95 * nominal[0] && lin.t1_s > l1.t1_s);
        }
    }
}

/// A 35 deg turn from straight running (rudder at 2.32 deg/s): advance, transfer and tactical
/// diameter in ship lengths, the speed ratio at 180 deg.
fn turn(l: f64, u0: f64, rudder_deg: f64, rate_deg_s: f64, h_s: f64) -> [f64; 4] {
    let mut hull = MarinerHull::new(l, u0, 0.0).unwrap();
    let target = rudder_deg * DEG;
    let step = rate_deg_s * DEG * h_s;
    let mut delta: f64 = 0.0;
    let mut adv = [f64::NAN; 2];
    for _ in 0..(200.0 * l / u0 / h_s) as usize {
        let next = delta + (target - delta).clamp(-step, step);
        hull.advance(delta, next, &MmgInput::default(), h_s);
        delta = next;
        let s = hull.state;
        if adv[0].is_nan() && s.psi_rad.abs() >= PI / 2.0 {
            adv = [s.x_m / l, s.y_m.abs() / l];
        }
        if s.psi_rad.abs() >= PI {
            return [adv[0], adv[1], s.y_m.abs() / l, s.u_mps / u0];
        }
    }
    panic!("no 180 deg turn");
}

/// The 35 deg turn against IMO's criteria (MSC.137(76): advance < 4.5 L, tactical diameter
/// < 5 L), with a speed loss, and the same in ship lengths at 120 m and 7 m/s (Froude
/// similarity, time scaled by L / U).
#[test]
fn a_35_deg_turn_meets_imo_and_scales() {
    for rudder in [35.0, -35.0] {
        let got = turn(LENGTH_M, PUBLISHED_SPEED_MPS, rudder, 2.32, 0.02);
        eprintln!(
            "35 deg turn {rudder}: advance {:.3} L, transfer {:.3} L, tactical diameter {:.3} L, u/u0 {:.3}",
            got[0], got[1], got[2], got[3]
        );
        // IMO's advance criterion holds; the tactical diameter (6.4 L) is over IMO's 5 L (a
        // 1950s hull, and no trim against the asymmetry here); the linear model would turn in
        // 0.85 L (2 U / (K delta)): the cubic damping is most of the turn.
        assert!(got[0] > 2.0 && got[0] < 4.5, "{got:?}");
        assert!(got[2] > 4.0 && got[2] < 9.0, "{got:?}");
        assert!(got[3] > 0.5 && got[3] < 0.95, "{got:?}");
        let ratio = (120.0 / 7.0) / (LENGTH_M / PUBLISHED_SPEED_MPS);
        let small = turn(120.0, 7.0, rudder, 2.32 / ratio, 0.02 * ratio);
        for (a, b) in got.iter().zip(small) {
            assert!((a - b).abs() < 1e-6 * a.abs(), "{got:?} vs {small:?}");
        }
    }
}
