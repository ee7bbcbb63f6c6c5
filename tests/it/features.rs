//! Accuracy of the two tests' features, measured end to end (simulated ship + monitor core in
//! lockstep) against independent answers: the analytic transfer function b / (jw (jw + a)) for
//! CLFRT, the relay reference table (docs/dsp.md, "HBT") and the describing function for HBT.
//!
//! Runs are spread over both cores with scoped threads; each run is a few tens of
//! milliseconds of CPU in the `ci` profile.

use crate::common::par_map;
use helmwatch::config::Config;
use helmwatch_core::drivers::probe::{run_probe, ProbeOptions};
use helmwatch_core::dsp::relay::limit_cycle_describing_function;
use helmwatch_core::model::SeaState;
use helmwatch_core::sim::{Fault, Scenario};
use helmwatch_core::wire::features::HbtFeatures;
use helmwatch_core::wire::Method;
use helmwatch_core::wire::{Outcome, Report};
use std::f64::consts::PI;
use std::sync::OnceLock;

const GRID: [(f64, f64); 6] = [
    (4.0, 4000.0),
    (4.0, 10000.0),
    (7.0, 4000.0),
    (7.0, 10000.0),
    (10.0, 4000.0),
    (10.0, 10000.0),
];

fn probe(method: Method, u: f64, d: f64, sea: SeaState, seed: u64, faults: Vec<Fault>) -> Report {
    probe_after(600.0, method, u, d, sea, seed, faults)
}

/// The relay of the reference table (docs/dsp.md, "HBT"): h = 5 deg (the default relay is
/// 8 deg, chosen for the estimator's accuracy within 30 minutes), everything else the
/// defaults.
fn table_cfg() -> Config {
    let mut cfg = Config::default();
    cfg.hbt.relay_height_deg = 5.0;
    // Two more periods than the default test would take at 5 deg on the slowest ship.
    cfg.hbt.timeout_s = 2400.0;
    cfg.safety.max_test_duration_s = 3000.0;
    cfg
}

/// A probe whose test starts `warmup_s` after the simulation (and the faults' onsets).
fn probe_after(
    warmup_s: f64,
    method: Method,
    u: f64,
    d: f64,
    sea: SeaState,
    seed: u64,
    faults: Vec<Fault>,
) -> Report {
    probe_with(
        &Config::default(),
        warmup_s,
        method,
        (u, d),
        sea,
        seed,
        faults,
    )
}

/// A probe with configuration `cfg`.
fn probe_with(
    cfg: &Config,
    warmup_s: f64,
    method: Method,
    (u, d): (f64, f64),
    sea: SeaState,
    seed: u64,
    faults: Vec<Fault>,
) -> Report {
    let cfg = cfg.clone();
    let sc = Scenario {
        speed_mps: u,
        displacement_t: d,
        sea,
        faults,
        seed,
    };
    let mut opts = ProbeOptions::new(&cfg.core(), method);
    opts.warmup_s = warmup_s;
    let r = run_probe(&cfg.core(), &cfg.sim(), &sc, &opts)
        .unwrap()
        .report;
    assert_eq!(
        r.outcome,
        Outcome::Completed,
        "u {u} D {d} {sea:?} seed {seed}: {:?}",
        r.reason
    );
    r
}

/// The HBT features of a completed report.
fn hbt(r: &Report) -> &HbtFeatures {
    r.features
        .hbt()
        .unwrap_or_else(|| panic!("not a completed HBT test: {r:?}"))
}

/// `(gain, phase_rad)` of b / (jw (jw + a)), phase in (-pi, 0].
fn nomoto_response(u: f64, d: f64, w: f64) -> (f64, f64) {
    let (a, b) = Config::default().ship.nomoto(u, d);
    let gain = b / (w * (w * w + a * a).sqrt());
    let phase = -PI / 2.0 - (w / a).atan();
    (gain, phase)
}

struct Tone {
    omega: f64,
    gain: f64,
    phase: f64,
    gain_ci: f64,
    phase_ci: f64,
}

fn tones(r: &Report) -> Vec<Tone> {
    r.features
        .clfrt()
        .unwrap_or_else(|| panic!("not a completed CLFRT test: {r:?}"))
        .tones
        .iter()
        .map(|t| Tone {
            omega: t.omega_rad_s,
            gain: t.gain,
            phase: t.phase_rad,
            gain_ci: t.gain_ci90_rel,
            phase_ci: t.phase_ci90_rad,
        })
        .collect()
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

fn clfrt_runs(sea: SeaState, seeds: u64) -> Vec<((f64, f64), Report)> {
    let jobs: Vec<(f64, f64, u64)> = GRID
        .iter()
        .flat_map(|&(u, d)| (0..seeds).map(move |s| (u, d, 1000 + s)))
        .collect();
    par_map(jobs, |(u, d, seed)| {
        ((u, d), probe(Method::Clfrt, u, d, sea, seed, vec![]))
    })
}

/// The slow tier's CLFRT runs: 50 seeds at each grid point, made once per sea for the
/// accuracy and the calibration tests that read them.
fn clfrt_runs_50(sea: SeaState) -> &'static [((f64, f64), Report)] {
    static CALM: OnceLock<Vec<((f64, f64), Report)>> = OnceLock::new();
    static MODERATE: OnceLock<Vec<((f64, f64), Report)>> = OnceLock::new();
    let cell = match sea {
        SeaState::Calm => &CALM,
        SeaState::Moderate => &MODERATE,
        other => panic!("no slow-tier CLFRT runs in a {other:?} sea"),
    };
    cell.get_or_init(|| clfrt_runs(sea, 50))
}

/// Fraction of runs inside the CLFRT accuracy bounds, per tone.
///
/// The bounds were 5 % / 3 deg, 5 % / 3 deg, 10 % / 10 deg for 2 deg tones; the errors scale
/// as 1 / amplitude (the disturbances do not change), so they are halved for the default
/// 4 deg tones: the same 95.7 / 100 / 96.7 % of runs fall inside as before. At least 90 %
/// of the runs must: the fast tier checks 10 seeds a grid point (60 runs), the slow tier 50.
fn check_accuracy(runs: &[((f64, f64), Report)]) {
    let bounds = [(0.025, 1.5), (0.025, 1.5), (0.05, 5.0)];
    let mut inside = [0usize; 3];
    let mut worst = [(0.0f64, 0.0f64); 3];
    for ((u, d), r) in runs {
        for (i, t) in tones(r).iter().enumerate() {
            let (g0, p0) = nomoto_response(*u, *d, t.omega);
            let ge = (t.gain / g0 - 1.0).abs();
            let pe = dphase(t.phase, p0).abs().to_degrees();
            worst[i] = (worst[i].0.max(ge), worst[i].1.max(pe));
            if ge <= bounds[i].0 && pe <= bounds[i].1 {
                inside[i] += 1;
            }
        }
    }
    let n = runs.len() as f64;
    for i in 0..3 {
        let frac = inside[i] as f64 / n;
        println!(
            "tone {i}: {:.1} % of {} runs within {:.1} % / {:.1} deg (worst {:.1} % / {:.2} deg)",
            100.0 * frac,
            runs.len(),
            100.0 * bounds[i].0,
            bounds[i].1,
            100.0 * worst[i].0,
            worst[i].1
        );
        assert!(
            frac >= 0.90,
            "tone {i}: only {:.1} % of runs in bounds",
            100.0 * frac
        );
    }
}

#[test]
fn clfrt_calm_gain_and_phase_match_the_transfer_function() {
    check_accuracy(&clfrt_runs(SeaState::Calm, 10));
}

#[test]
#[ignore = "slow tier: cargo test --profile ci -- --ignored"]
fn clfrt_calm_gain_and_phase_match_the_transfer_function_300_runs() {
    check_accuracy(clfrt_runs_50(SeaState::Calm));
}

/// The reported 90 % intervals hold the true value in 85 to 97 % of 300 runs (binomial 1 sd
/// at p = 0.9 is 1.7 %: the band is -3 to +4 sd).
fn check_calibration(sea: SeaState) {
    let runs = clfrt_runs_50(sea);
    let mut cover = [[0usize; 2]; 3];
    for ((u, d), r) in runs {
        for (i, t) in tones(r).iter().enumerate() {
            let (g0, p0) = nomoto_response(*u, *d, t.omega);
            if (t.gain / g0 - 1.0).abs() <= t.gain_ci {
                cover[i][0] += 1;
            }
            if dphase(t.phase, p0).abs() <= t.phase_ci {
                cover[i][1] += 1;
            }
        }
    }
    let n = runs.len() as f64;
    let mut bad = Vec::new();
    for (i, c) in cover.iter().enumerate() {
        for (j, name) in ["gain", "phase"].iter().enumerate() {
            let frac = c[j] as f64 / n;
            println!("{sea:?} tone {i} {name}: coverage {:.1} %", 100.0 * frac);
            if !(0.85..=0.97).contains(&frac) {
                bad.push(format!("tone {i} {name} {:.1} %", 100.0 * frac));
            }
        }
    }
    assert!(bad.is_empty(), "{sea:?}: miscalibrated: {bad:?}");
}

#[test]
#[ignore = "slow tier: cargo test --profile ci -- --ignored"]
fn clfrt_uncertainty_is_calibrated_in_a_calm_sea() {
    check_calibration(SeaState::Calm);
}

#[test]
#[ignore = "slow tier: cargo test --profile ci -- --ignored"]
fn clfrt_uncertainty_is_calibrated_in_a_moderate_sea() {
    check_calibration(SeaState::Moderate);
}

/// The relay reference table (docs/dsp.md, "HBT"): (u, D, period s, first-harmonic amplitude
/// deg).
const HBT_TABLE: [(f64, f64, f64, f64); 6] = [
    (4.0, 4000.0, 255.0, 3.38),
    (4.0, 10000.0, 345.0, 2.38),
    (7.0, 7000.0, 180.0, 2.88),
    (7.0, 7700.0, 187.0, 2.81),
    (10.0, 4000.0, 110.0, 3.90),
    (10.0, 10000.0, 145.0, 2.62),
];

/// `(omega_u rad/s, heading amplitude rad)` of the relay loop by the describing function,
/// for the ship (u, D) and the relay and servo of `cfg`.
fn describing_function(cfg: &Config, u: f64, d: f64) -> (f64, f64) {
    let (a, b) = cfg.ship.nomoto(u, d);
    limit_cycle_describing_function(
        a,
        b,
        cfg.hbt.relay_height_rad(),
        cfg.hbt.hysteresis_rad(),
        &cfg.servo,
    )
    .unwrap()
}

/// The describing function reproduces the reference table (so it can stand in where the
/// table has no row).
#[test]
fn describing_function_agrees_with_the_reference_table() {
    let cfg = table_cfg();
    for (u, d, p, a_deg) in HBT_TABLE {
        let (w, amp) = describing_function(&cfg, u, d);
        let pe = (2.0 * PI / w / p - 1.0).abs();
        let ae = (amp.to_degrees() / a_deg - 1.0).abs();
        println!(
            "u {u} D {d}: DF period {:.1} s ({:.1} %), amplitude {:.3} deg ({:.1} %)",
            2.0 * PI / w,
            100.0 * pe,
            amp.to_degrees(),
            100.0 * ae
        );
        assert!(pe < 0.03 && ae < 0.05, "u {u} D {d}: {pe} {ae}");
    }
}

/// HBT features in a calm sea against the table and the describing function, with the
/// table's relay (h = 5 deg).
#[test]
fn hbt_calm_matches_the_independent_answer() {
    let cfg = table_cfg();
    let jobs: Vec<(f64, f64, u64)> = GRID
        .iter()
        .flat_map(|&(u, d)| (0..3).map(move |s| (u, d, 2000 + s)))
        .collect();
    let runs = par_map(jobs, |(u, d, seed)| {
        (
            (u, d),
            probe_with(
                &cfg,
                600.0,
                Method::Hbt,
                (u, d),
                SeaState::Calm,
                seed,
                vec![],
            ),
        )
    });
    for ((u, d), r) in runs {
        // The table where it has the row, the describing function elsewhere.
        let (p_ref, a_ref) = match HBT_TABLE.iter().find(|x| x.0 == u && x.1 == d) {
            Some(&(_, _, p, a)) => (p, a.to_radians()),
            None => {
                let (w, amp) = describing_function(&cfg, u, d);
                (2.0 * PI / w, amp)
            }
        };
        let p = hbt(&r).period_s;
        let amp = hbt(&r).amplitude_rad;
        println!(
            "u {u} D {d}: period {p:.1} s vs {p_ref:.1}, amplitude {:.3} deg vs {:.3}",
            amp.to_degrees(),
            a_ref.to_degrees()
        );
        assert!(
            (p / p_ref - 1.0).abs() < 0.03,
            "u {u} D {d}: period {p} vs {p_ref}"
        );
        assert!(
            (amp / a_ref - 1.0).abs() < 0.05,
            "u {u} D {d}: amplitude {amp} vs {a_ref}"
        );
        let w = hbt(&r).omega_u_rad_s;
        assert!((w * p / (2.0 * PI) - 1.0).abs() < 1e-9);
        // Heading over the measured rudder at omega_u: the ship's own b / (jw (jw + a)),
        // whatever the relay and the servo did.
        let (a, b) = cfg.ship.nomoto(u, d);
        let g_ref = b / (w * (w * w + a * a).sqrt());
        let ph_ref = -PI / 2.0 - (w / a).atan();
        let g = hbt(&r).response_gain.expect("response gain");
        let ph = hbt(&r).response_phase_rad.expect("response phase");
        println!(
            "u {u} D {d}: response gain {g:.3} vs {g_ref:.3}, phase {:.2} deg vs {:.2}",
            ph.to_degrees(),
            ph_ref.to_degrees()
        );
        assert!(
            (g / g_ref - 1.0).abs() < 0.02,
            "u {u} D {d}: response gain {g} vs {g_ref}"
        );
        assert!(
            (ph - ph_ref).abs().to_degrees() < 1.0,
            "u {u} D {d}: response phase {ph} vs {ph_ref}"
        );
    }
}

#[test]
fn hbt_moderate_sea_does_not_chatter_and_completes() {
    let jobs: Vec<(f64, f64, u64)> = GRID
        .iter()
        .flat_map(|&(u, d)| (0..4).map(move |s| (u, d, 3000 + s)))
        .collect();
    let runs = par_map(jobs, |(u, d, seed)| {
        (
            (u, d),
            probe(Method::Hbt, u, d, SeaState::Moderate, seed, vec![]),
        )
    });
    for ((u, d), r) in runs {
        let min_gap = hbt(&r).min_switch_interval_s;
        assert!(min_gap > 20.0, "u {u} D {d}: switches {min_gap:.1} s apart");
    }
}

/// A heading drift of 1 deg/min changes no feature by more than 1 % (gains, amplitude,
/// period) or 1 deg (phases): same seed, drift on and off.
///
/// The drift is established when the test starts (a drifting gyro in service has drifted for
/// hours): the test starts 3000 s after its onset. Right after an onset the autopilot is
/// still converging onto the ramp (integral time 200 s), and that transient, not the drift,
/// shifted HBT features by up to 1.8 % at 600 s in a moderate sea.
#[test]
fn heading_drift_does_not_disturb_the_features() {
    let drift: Fault = "heading_drift_deg_per_min:1@0".parse().unwrap();
    let probe = |m, u, d, sea, seed, f| probe_after(3000.0, m, u, d, sea, seed, f);
    for sea in [SeaState::Calm, SeaState::Moderate] {
        for (u, d) in [(7.0, 7000.0), (4.0, 10000.0), (10.0, 4000.0)] {
            for seed in [11, 12] {
                let a = probe(Method::Clfrt, u, d, sea, seed, vec![]);
                let b = probe(Method::Clfrt, u, d, sea, seed, vec![drift]);
                for (x, y) in tones(&a).iter().zip(tones(&b).iter()) {
                    let ge = (y.gain / x.gain - 1.0).abs();
                    let pe = dphase(y.phase, x.phase).abs().to_degrees();
                    assert!(
                        ge < 0.01 && pe < 1.0,
                        "CLFRT {sea:?} u {u} D {d} w {}: {ge} {pe}",
                        x.omega
                    );
                }
                let a = probe(Method::Hbt, u, d, sea, seed, vec![]);
                let b = probe(Method::Hbt, u, d, sea, seed, vec![drift]);
                let (fa, fb) = (hbt(&a), hbt(&b));
                for (k, x, y) in [
                    ("period_s", fa.period_s, fb.period_s),
                    ("amplitude_rad", fa.amplitude_rad, fb.amplitude_rad),
                    (
                        "response_gain",
                        fa.response_gain.unwrap_or(f64::NAN),
                        fb.response_gain.unwrap_or(f64::NAN),
                    ),
                ] {
                    let e = (y / x - 1.0).abs();
                    assert!(e < 0.01, "HBT {sea:?} u {u} D {d} {k}: {e}");
                }
                let pe = dphase(
                    fb.response_phase_rad.unwrap_or(f64::NAN),
                    fa.response_phase_rad.unwrap_or(f64::NAN),
                )
                .abs();
                assert!(
                    pe.to_degrees() < 1.0,
                    "HBT {sea:?} u {u} D {d} response_phase_rad: {pe}"
                );
            }
        }
    }
}

#[test]
fn same_seed_same_report_other_seed_other_report() {
    for method in [Method::Hbt, Method::Clfrt] {
        let a = probe(method, 7.0, 7000.0, SeaState::Moderate, 5, vec![]);
        let b = probe(method, 7.0, 7000.0, SeaState::Moderate, 5, vec![]);
        let c = probe(method, 7.0, 7000.0, SeaState::Moderate, 6, vec![]);
        let js = |r: &Report| serde_json::to_string(r).unwrap();
        assert_eq!(js(&a), js(&b));
        assert_ne!(js(&a), js(&c));
    }
}

/// NaN, infinite and out-of-order samples mixed into a real test's streams are rejected and
/// counted, and the test still completes with finite features.
#[test]
fn bad_samples_mixed_into_a_test_are_rejected_and_the_test_completes() {
    use helmwatch_core::drivers::probe::Lockstep;
    use helmwatch_core::monitor::Output;
    use helmwatch_core::wire::{Input, Scalar};
    let mut cfg = Config::default();
    cfg.scheduler.enabled = false;
    let mut ls = Lockstep::new(&cfg.core(), &cfg.sim(), &Scenario::nominal(&cfg.sim(), 3)).unwrap();
    let mut out = Vec::new();
    ls.run_until(600.0, &mut out);
    assert!(ls.trigger(Method::Clfrt).accepted);
    let mut report = None;
    let mut injected = 0u64;
    for k in 0..30_000u64 {
        if k % 97 == 0 {
            let t = ls.time_s();
            let bad = [
                Input::Heading(Scalar { t, value: f64::NAN }),
                Input::Rudder(Scalar {
                    t: t - 50.0,
                    value: 0.0,
                }),
                Input::Heading(Scalar {
                    t: f64::INFINITY,
                    value: 1.0,
                }),
                Input::Heading(Scalar { t, value: 9.0 }),
            ];
            for b in bad {
                assert!(ls.monitor.handle_input(b).is_err());
                injected += 1;
            }
        }
        out.clear();
        ls.tick(&mut out, false);
        if let Some(r) = out.iter().find_map(|o| match o {
            Output::Report(r) => Some(r.clone()),
            _ => None,
        }) {
            report = Some(r);
            break;
        }
    }
    let r = report.expect("a report");
    assert_eq!(r.outcome, Outcome::Completed, "{:?}", r.reason);
    assert!(tones(&r)
        .iter()
        .all(|t| t.gain.is_finite() && t.phase.is_finite()));
    assert_eq!(ls.monitor.counters().rejected_total(), injected);
}

/// Largest |rudder| in the 300 s after an HBT test hands the rudder back to the autopilot.
fn rudder_after_handback(lead_s: f64, u: f64, sea: SeaState) -> f64 {
    use helmwatch_core::drivers::probe::Lockstep;
    use helmwatch_core::monitor::Output;
    let mut cfg = Config::default();
    cfg.scheduler.enabled = false;
    cfg.hbt.handback_lead_s = lead_s;
    let sc = Scenario {
        speed_mps: u,
        displacement_t: 7000.0,
        sea,
        faults: vec![],
        seed: 3,
    };
    let mut ls = Lockstep::new(&cfg.core(), &cfg.sim(), &sc).unwrap();
    let mut out = Vec::new();
    ls.run_until(600.0, &mut out);
    assert!(ls.trigger(Method::Hbt).accepted);
    out.clear();
    while !out.iter().any(|o| matches!(o, Output::Report(_))) {
        ls.tick(&mut out, false);
    }
    let mut max = 0f64;
    for _ in 0..3000 {
        ls.tick(&mut out, false);
        max = max.max(ls.ship.truth().delta_rad.abs());
    }
    max.to_degrees()
}

/// Handing back mid-cycle lets the autopilot's PD term see the whole limit cycle (24 deg of
/// rudder at 7 m/s, 15 deg at 10 m/s); handing back where e + Td de/dt = 0 keeps the swing
/// near the relay's own 8 deg.
#[test]
fn hbt_hands_back_without_a_rudder_swing() {
    for sea in [SeaState::Calm, SeaState::Moderate] {
        for u in [7.0, 10.0] {
            let abrupt = rudder_after_handback(0.0, u, sea);
            let smooth = rudder_after_handback(30.0, u, sea);
            println!(
                "{sea:?} u {u}: after hand-back {abrupt:.1} deg at once, {smooth:.1} deg timed"
            );
            assert!(
                abrupt > 1.5 * smooth,
                "{sea:?} u {u}: abrupt {abrupt} deg vs timed {smooth} deg"
            );
            assert!(
                smooth < 12.0,
                "{sea:?} u {u}: {smooth} deg after a timed hand-back"
            );
        }
    }
}

/// `|1 / (1 + L(jw))|` of the simulated loop: the first-order ship at (u, D), the servo's
/// first-order lag, the autopilot's PID (pole placement at the nominal ship, fixed gains)
/// behind its critically damped wave filter. Computed here from the configuration's numbers,
/// independently of the simulator's code.
fn fixed_gain_sensitivity(cfg: &Config, u: f64, d: f64, w: f64) -> f64 {
    use rustfft::num_complex::Complex64 as C;
    let s = C::new(0.0, w);
    let (a, b) = cfg.ship.nomoto(u, d);
    let (a0, b0) = cfg
        .ship
        .nomoto(cfg.ship.nominal_speed_mps, cfg.ship.nominal_displacement_t);
    let (k, t) = (b0 / a0, 1.0 / a0);
    let ap = &cfg.autopilot;
    let wn = ap.natural_frequency_rad_s;
    let kp = t / k * wn * wn;
    let td = t / (k * kp) * (2.0 * ap.damping * wn - 1.0 / t);
    let ti = ap.integral_time_factor / wn;
    let c = kp * (1.0 + 1.0 / (ti * s) + td * s);
    let f = 1.0 / ((1.0 + s / ap.wave_filter_rad_s) * (1.0 + s / ap.wave_filter_rad_s));
    let p = b / (s * (s + a));
    let servo = 1.0 / (1.0 + s * cfg.servo.time_constant_s);
    (1.0 / (1.0 + c * f * p * servo)).norm()
}

/// An autopilot with gains fixed at the nominal ship, at the fast and light corner: the loop
/// amplifies the fastest tone (analytic sensitivity ~13 there, under the sizing's limit at
/// the others). Without the sizing every test saturates the rudder; with it the test
/// completes, only that tone is lowered, and the tones' gains still match the ship.
#[test]
fn clfrt_sizes_the_tone_a_fixed_gain_autopilot_amplifies() {
    let mut cfg = Config::default();
    cfg.autopilot.speed_scheduling = false;
    let (u, d) = (10.0, 4000.0);
    let omegas: Vec<f64> = cfg.clfrt.tone_frequencies_rad_s();
    let sens: Vec<f64> = omegas
        .iter()
        .map(|&w| fixed_gain_sensitivity(&cfg, u, d, w))
        .collect();
    assert!(sens[2] > 10.0 && sens[2] < 16.0, "{sens:?}");
    assert!(sens[0] < 1.0 && sens[1] < 1.0, "{sens:?}");
    let runs = par_map(vec![1u64, 2], |seed| {
        let sc = Scenario {
            speed_mps: u,
            displacement_t: d,
            sea: SeaState::Calm,
            faults: vec![],
            seed,
        };
        let mut off = cfg.clone();
        off.clfrt.resize_max = 0;
        let run = |c: &Config| {
            let opts = ProbeOptions::new(&c.core(), Method::Clfrt);
            run_probe(&c.core(), &c.sim(), &sc, &opts).unwrap().report
        };
        (run(&off), run(&cfg))
    });
    for (off, on) in runs {
        assert_eq!(off.outcome, Outcome::Aborted, "{:?}", off.reason);
        assert!(
            off.reason
                .as_deref()
                .unwrap_or("")
                .contains("rudder saturated"),
            "{:?}",
            off.reason
        );
        assert_eq!(on.outcome, Outcome::Completed, "{:?}", on.reason);
        let scales = on
            .features
            .clfrt()
            .unwrap()
            .amplitude_scales
            .clone()
            .unwrap();
        assert_eq!(&scales[..2], &[1.0, 1.0]);
        assert!(scales[2] > 0.0 && scales[2] < 0.3, "{scales:?}");
        assert!(
            on.message.contains("tones sized to the loop"),
            "{}",
            on.message
        );
        for tone in tones(&on) {
            let (g, p) = nomoto_response(u, d, tone.omega);
            assert!((tone.gain / g - 1.0).abs() < 0.05, "{} vs {g}", tone.gain);
            assert!(dphase(tone.phase, p).abs() < 0.05, "{} vs {p}", tone.phase);
        }
    }
}

/// A Mariner-class cargo ship (Fossen's Nomoto example: K = 0.185 1/s, T = 107.3 s at
/// 7.7 m/s, L = 160.93 m; 17000 t assumed) at its fast and light corner: the designed relay's
/// cycle crosses the 10 deg heading limit; the sized relay completes inside it, and the cycle
/// it reports, read through the sizing's ratios, is the designed relay's by the describing
/// function on the true ship.
#[test]
fn hbt_sizes_the_relay_where_the_ship_is_most_responsive() {
    let mut cfg = Config::default();
    cfg.ship.length_m = 160.93;
    cfg.ship.yaw_damping_a0 = 0.1948;
    cfg.ship.rudder_area_m2 = 155.2;
    let (u, d) = (9.5, 11000.0);
    let (a, b) = cfg.ship.nomoto(u, d);
    let (w1, a1) = limit_cycle_describing_function(
        a,
        b,
        cfg.hbt.relay_height_rad(),
        cfg.hbt.hysteresis_rad(),
        &cfg.servo,
    )
    .unwrap();
    assert!(
        a1.to_degrees() > 10.0,
        "designed cycle {} deg",
        a1.to_degrees()
    );
    let runs = par_map(vec![1u64, 2], |seed| {
        let sc = Scenario {
            speed_mps: u,
            displacement_t: d,
            sea: SeaState::Calm,
            faults: vec![],
            seed,
        };
        let mut off = cfg.clone();
        off.hbt.resize_at_switch = 0;
        let run = |c: &Config| {
            let opts = ProbeOptions::new(&c.core(), Method::Hbt);
            run_probe(&c.core(), &c.sim(), &sc, &opts).unwrap().report
        };
        (run(&off), run(&cfg))
    });
    for (off, on) in runs {
        if std::env::var("AMP").is_ok() {
            for tone in tones(&on) {
                let w = tone.omega;
                let g = b / (w * (w * w + a * a).sqrt());
                eprintln!(
                    "w {w:.4}: gain {:.3} vs {g:.3} sc {:?}",
                    tone.gain,
                    on.features.clfrt().unwrap().amplitude_scales
                );
            }
            continue;
        }
        assert_eq!(off.outcome, Outcome::Aborted, "{:?}", off.reason);
        assert!(
            off.reason
                .as_deref()
                .unwrap_or("")
                .contains("heading error"),
            "{:?}",
            off.reason
        );
        assert_eq!(on.outcome, Outcome::Completed, "{:?}", on.reason);
        assert!(
            on.message.contains("relay sized to the loop"),
            "{}",
            on.message
        );
        let f = hbt(&on);
        let s = f.relay_scale.expect("relay_scale");
        assert!(s > 0.4 && s < 0.75, "{s}");
        assert!(
            f.amplitude_rad.to_degrees() < 8.0,
            "{}",
            f.amplitude_rad.to_degrees()
        );
        // The played relay's cycle against the describing function at that relay.
        let (ws, as_) = limit_cycle_describing_function(
            a,
            b,
            s * cfg.hbt.relay_height_rad(),
            s * cfg.hbt.hysteresis_rad(),
            &cfg.servo,
        )
        .unwrap();
        assert!(
            (f.omega_u_rad_s / ws - 1.0).abs() < 0.05,
            "w {} vs {ws}",
            f.omega_u_rad_s
        );
        assert!(
            (f.amplitude_rad / as_ - 1.0).abs() < 0.10,
            "A {} vs {as_}",
            f.amplitude_rad
        );
        // Read through the ratios: the designed relay's cycle.
        let (rw, ra) = (
            f.relay_omega_ratio.unwrap(),
            f.relay_amplitude_ratio.unwrap(),
        );
        assert!((f.omega_u_rad_s / rw / w1 - 1.0).abs() < 0.05, "designed w");
        assert!((f.amplitude_rad / ra / a1 - 1.0).abs() < 0.10, "designed A");
    }
}

/// The family's ship made as responsive as the Mariner cargo ship scaled to 120 m (its own
/// linearised Nomoto model, K L / U = 3.86 and T U / L = 5.14: `yaw-damping-a0` 0.1945,
/// `rudder-area-m2` 85.4 at 7000 t; 4.3 times the family's rudder gain b), at the fast and
/// light corner.
fn responsive_ship() -> Config {
    let mut cfg = Config::default();
    cfg.ship.yaw_damping_a0 = 0.1945;
    cfg.ship.rudder_area_m2 = 85.4;
    cfg
}

/// CLFRT on a ship more responsive than its tones were sized for: the tones' heading
/// (`|G S|` times the amplitude, growing as `b / w^2`) crosses the 10 deg limit during the
/// settling and the vessel's first test ends there (the guard is not armed); armed, as after
/// such a test, the tones' summed heading is lowered by `clfrt.resize-heading-factor` when
/// the heading error passes `clfrt.resize-heading-fraction` (0.7) of the limit heading for
/// it, and the test completes. The slower tones carry the heading and take the cut, alike;
/// the fastest keeps its designed size. The cut leaves no trace in the
/// measurement: every tone reads the ship's own response (the first-order model at the
/// point; the slowest within 15 %: at a fraction of a degree it competes with the calm sea's
/// own slow bias; the others within 5 %).
#[test]
fn clfrt_lowers_the_tones_that_carry_the_heading_where_it_nears_its_limit() {
    let cfg = responsive_ship();
    let (u, d) = (10.0, 4000.0);
    let probe = |c: &Config, seed: u64, armed: bool| {
        let sc = Scenario {
            speed_mps: u,
            displacement_t: d,
            sea: SeaState::Calm,
            faults: vec![],
            seed,
        };
        let mut opts = ProbeOptions::new(&c.core(), Method::Clfrt);
        opts.clfrt_heading_guard = armed;
        run_probe(&c.core(), &c.sim(), &sc, &opts).unwrap().report
    };
    // Not armed (a fresh vessel), then armed.
    let runs = par_map(vec![1u64, 2], |seed| {
        (probe(&cfg, seed, false), probe(&cfg, seed, true))
    });
    let (a, b) = cfg.ship.nomoto(u, d);
    let factor = cfg.clfrt.resize_heading_factor;
    for (off, on) in runs {
        assert_eq!(off.outcome, Outcome::Aborted, "{:?}", off.reason);
        assert!(
            off.reason
                .as_deref()
                .unwrap_or("")
                .contains("heading error"),
            "{:?}",
            off.reason
        );
        assert_eq!(on.outcome, Outcome::Completed, "{:?}", on.reason);
        let scales = on
            .features
            .clfrt()
            .unwrap()
            .amplitude_scales
            .clone()
            .unwrap();
        // The slower tones cut alike, a little deeper than a cut of every tone would cut
        // them, the fastest kept.
        assert!(
            scales[0] < factor && scales[0] > 0.5 * factor * factor,
            "{scales:?}"
        );
        assert_eq!(scales[0], scales[1], "{scales:?}");
        assert!(scales.windows(2).all(|p| p[0] <= p[1]), "{scales:?}");
        assert_eq!(scales[scales.len() - 1], 1.0, "{scales:?}");
        for (i, tone) in tones(&on).iter().enumerate() {
            let w = tone.omega;
            let g = b / (w * (w * w + a * a).sqrt());
            let p = -PI / 2.0 - (w / a).atan();
            let tol = if i == 0 { 0.15 } else { 0.05 };
            assert!(
                (tone.gain / g - 1.0).abs() < tol,
                "{i}: {} vs {g}",
                tone.gain
            );
            assert!(
                dphase(tone.phase, p).abs() < tol,
                "{i}: {} vs {p}",
                tone.phase
            );
        }
    }
}

/// HBT on the same ship with no sea known yet (a fresh vessel): the relay must shrink to
/// about half to stay inside the heading limit, and the hysteresis floor is 3 x the wave yaw
/// on the relay's own record. Read from the heading as it is, that record's first steps
/// leak their `w^-3` spectrum into the wave band (0.3 deg of "wave yaw" in a calm sea: a
/// floor at the designed 1 deg, and the test aborted as relay-too-large); read from what the
/// fitted ship does not explain, the calm sea's floor is the 0.5 deg minimum and the relay
/// completes at the scale that keeps its peak inside 0.7 of the limit.
#[test]
fn hbt_reads_the_sea_on_its_record_from_what_the_ship_does_not_explain() {
    let cfg = responsive_ship();
    let (u, d) = (9.0, 5000.0);
    let runs = par_map(vec![1u64, 2], |seed| {
        let sc = Scenario {
            speed_mps: u,
            displacement_t: d,
            sea: SeaState::Calm,
            faults: vec![],
            seed,
        };
        let opts = ProbeOptions::new(&cfg.core(), Method::Hbt);
        run_probe(&cfg.core(), &cfg.sim(), &sc, &opts)
            .unwrap()
            .report
    });
    let calm_wave_deg = cfg.sea.levels(SeaState::Calm).wave_yaw_deg;
    for on in runs {
        assert_eq!(on.outcome, Outcome::Completed, "{:?}", on.reason);
        let f = hbt(&on);
        let s = f.relay_scale.expect("relay_scale");
        assert!((0.5..0.7).contains(&s), "{s}");
        assert!(
            f.amplitude_rad.to_degrees() < 7.0,
            "{}",
            f.amplitude_rad.to_degrees()
        );
        // The completed test's own sea (whole periods of the cycle): the calm sea's wave
        // yaw and the heading sensor's noise in the band, not the relay's steps.
        let w = f.wave_yaw_rad.expect("wave yaw").to_degrees();
        assert!(
            w > 0.3 * calm_wave_deg && w < 3.0 * calm_wave_deg,
            "{w} vs {calm_wave_deg}"
        );
    }
}
