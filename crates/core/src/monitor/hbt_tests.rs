//! HBT's tests: the relay run against the describing function and its measurements by hand.

use super::analysis::{handback_instant, nominal_slew_rad_s, slew_peak, HbtReport};
use super::HbtRun;
use crate::monitor::config::CoreConfig;
use crate::monitor::{AbortReason, Measured};
use crate::wire::ExcitationMode;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

/// On a sinusoid through +eps rising at t = 0, the instant found makes e + tau de/dt
/// vanish, and e is falling there (an independent check by direct evaluation).
#[test]
fn slew_peak_reads_the_rate_limit_per_period() {
    // A servo slewing at 4 deg/s between +-8 deg twice a period of 100 s, 0.1 deg of
    // noise; one period slewing at 6 deg/s (a glitch) does not move the median.
    let (dt, rate, h, period) = (0.1, 4.0f64.to_radians(), 8.0f64.to_radians(), 100.0);
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let d: Vec<f64> = (0..6000)
        .map(|i| {
            let t = i as f64 * dt;
            let r = if t > 340.0 && t < 400.0 {
                1.5 * rate
            } else {
                rate
            };
            let ph = t % period;
            let up = (-h + r * ph).min(h);
            let down = (h - r * (ph - 50.0)).max(-h);
            let z: f64 = StandardNormal.sample(&mut rng);
            (if ph < 50.0 { up } else { down }) + 0.1f64.to_radians() * z
        })
        .collect();
    let switches = [10.0, 110.0, 210.0, 310.0, 410.0];
    let mut scratch = Vec::new();
    let p = slew_peak(&d, 0.0, dt, &switches, &mut scratch).unwrap();
    // The largest of ~40 fitted slopes is biased up by ~2 sd of the slope noise (0.04 deg/s).
    let got = p.to_degrees();
    assert!(got > 4.0 && got < 4.15, "{got}");
    assert!(slew_peak(&d, 0.0, dt, &[10.0], &mut scratch).is_none());
    assert!(slew_peak(&d[..10], 0.0, dt, &switches, &mut scratch).is_none());
}

#[test]
fn nominal_slew_needs_a_saturating_relay() {
    let cfg = CoreConfig::default();
    let slew = |h_deg: f64| nominal_slew_rad_s(&cfg.servo, 10.0, h_deg.to_radians());
    assert_eq!(
        slew(cfg.hbt.relay_height_deg),
        Some(cfg.servo.max_rate_rad_s())
    );
    assert_eq!(slew(3.0), None);
}

/// One relay test on a linear ship integrated here, independently of the simulator:
/// `psi'' = -a psi' + b delta`, the servo of `cfg` (command clamped, first-order lag,
/// rate limit, angle limit), no noise, on course at rest; sampled at `sensors.rate-hz`,
/// 20 Euler steps per sample. Returns the test's outcome and the largest |heading error|
/// over the measured periods.
fn relay_on_linear_ship(cfg: &CoreConfig, u: f64, d: f64) -> (Result<HbtReport, AbortReason>, f64) {
    relay_in_a_sea(cfg, u, d, &|_| 0.0, None)
}

/// Wave yaw of rms `sigma_rad` on the measured heading, independent of the simulator's
/// wave filter: 40 tones spread evenly over 0.6-1.0 rad/s (the default sea's peak at 0.8),
/// each of amplitude `sigma sqrt(2 / 40)`, random phases from `seed`.
fn wave_yaw(sigma_rad: f64, seed: u64) -> impl Fn(f64) -> f64 {
    use rand::Rng;
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let n = 40;
    let amp = sigma_rad * (2.0 / n as f64).sqrt();
    let tones: Vec<(f64, f64)> = (0..n)
        .map(|i| {
            let w = 0.6 + 0.4 * (i as f64 + 0.5) / n as f64;
            (w, rng.gen_range(0.0..std::f64::consts::TAU))
        })
        .collect();
    move |t| tones.iter().map(|(w, ph)| amp * (w * t + ph).sin()).sum()
}

/// [`relay_on_linear_ship`] with `wave(t)` [rad] added to the heading the test reads, and
/// the sea's wave yaw as the vessel's last test measured it (`sea_rad`).
fn relay_in_a_sea(
    cfg: &CoreConfig,
    u: f64,
    d: f64,
    wave: &dyn Fn(f64) -> f64,
    sea_rad: Option<f64>,
) -> (Result<HbtReport, AbortReason>, f64) {
    let (a, b) = cfg.ship.nomoto(u, d);
    let dt = 1.0 / cfg.sensors.rate_hz;
    let sub = 20;
    let h = dt / sub as f64;
    let (max_angle, max_rate, tr) = (
        cfg.servo.max_angle_rad(),
        cfg.servo.max_rate_rad_s(),
        cfg.servo.time_constant_s,
    );
    let t0 = 100.0;
    let mut run = HbtRun::new(cfg, t0, Some(u), sea_rad);
    let (mut psi, mut r, mut delta, mut cmd) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
    let mut peak = 0.0f64;
    for k in 0..40_000 {
        let t = t0 + k as f64 * dt;
        run.push_rudder(t, delta).unwrap();
        let seen = psi + wave(t);
        let step = run.on_heading(t, seen, -seen);
        if let Some(done) = step.done {
            let report = done.map(|m| match m {
                Measured::Hbt(r) => r,
                Measured::Clfrt(_) => unreachable!(),
            });
            return (report, peak);
        }
        if run.up_switches.len() > run.settle_periods && run.result.is_none() {
            peak = peak.max(psi.abs());
        }
        cmd = match step.mode {
            ExcitationMode::Replace => step.value.clamp(-max_angle, max_angle),
            _ => cmd,
        };
        for _ in 0..sub {
            let rate = ((cmd - delta) / tr).clamp(-max_rate, max_rate);
            delta = (delta + rate * h).clamp(-max_angle, max_angle);
            let acc = -a * r + b * delta;
            psi += r * h;
            r += acc * h;
        }
    }
    panic!("no report");
}

/// Homogeneity: the relay forced to half size (the floor on the hysteresis, 0.5 deg of
/// the designed 1 deg, decides) gives the designed relay's cycle at about half the
/// amplitude and the same period; the servo's rate limit (4 deg/s: the 16 deg step slews
/// 4 s, the 8 deg one 2 s) makes the small cycle a little faster and smaller, as the
/// describing function says, and the estimator's inputs, read through its ratios, stay.
/// The independent answer: the describing function on the true ship.
#[test]
fn a_relay_sized_to_half_gives_the_same_cycle_at_half_the_amplitude() {
    use crate::dsp::relay::limit_cycle_describing_function;
    use crate::estimator::features::Feature;
    use crate::wire::Features;
    let mut full = CoreConfig::default();
    full.hbt.resize_at_switch = 0;
    // The slow ship's period (~330 s) needs room for the settling after the resize.
    full.hbt.timeout_s = 3000.0;
    full.safety.max_test_duration_s = 3600.0;
    let mut half = full.clone();
    half.hbt.resize_at_switch = 2;
    half.hbt.resize_heading_fraction = 0.01;
    half.hbt.resize_min_hysteresis_deg = 0.5;
    half.hbt.resize_wave_factor = 0.0;
    let (h, eps) = (full.hbt.relay_height_rad(), full.hbt.hysteresis_rad());
    let rel = |x: f64, y: f64| x / y - 1.0;
    for (u, d) in [(7.0, 7000.0), (10.0, 4000.0), (4.0, 10000.0)] {
        let (r1, peak1) = relay_on_linear_ship(&full, u, d);
        let (r2, _) = relay_on_linear_ship(&half, u, d);
        let (r1, r2) = (r1.unwrap(), r2.unwrap());
        assert_eq!(r1.relay_scale, None);
        assert_eq!(r2.relay_scale, Some(0.5));
        assert!((r2.relay_height_rad - 0.5 * h).abs() < 1e-15);
        assert!((r2.hysteresis_rad - 0.5 * eps).abs() < 1e-15);
        let (p1, p2) = (r1.cycle.period_s, r2.cycle.period_s);
        let (a1, a2) = (r1.cycle.amplitude_rad, r2.cycle.amplitude_rad);
        // Same period and half the amplitude within the rate limit's share.
        assert!(rel(p2, p1).abs() < 0.06, "{u} {d}: period {p2} vs {p1}");
        assert!(
            rel(a2 / 0.5, a1).abs() < 0.11,
            "{u} {d}: a_u / s {a2} vs {a1}"
        );
        // The describing function on the true ship at the relay as played, both sizes,
        // and its ratios against the measured ones.
        let (a, b) = full.ship.nomoto(u, d);
        let df = |s: f64| {
            let (w, amp) =
                limit_cycle_describing_function(a, b, s * h, s * eps, &full.servo).unwrap();
            (2.0 * std::f64::consts::PI / w, amp)
        };
        let ((dp1, da1), (dp2, da2)) = (df(1.0), df(0.5));
        for (p, amp, dp, da) in [(p1, a1, dp1, da1), (p2, a2, dp2, da2)] {
            assert!(rel(p, dp).abs() < 0.05, "{u} {d}: P {p} vs DF {dp}");
            assert!(rel(amp, da).abs() < 0.10, "{u} {d}: A {amp} vs DF {da}");
        }
        assert!(
            rel(p2 / p1, dp2 / dp1).abs() < 0.02,
            "{u} {d}: period ratio"
        );
        assert!(
            rel(a2 / a1, da2 / da1).abs() < 0.04,
            "{u} {d}: amplitude ratio"
        );
        // The sizing's own prediction of the designed relay's cycle, from the record up
        // to the second switch, against the designed relay's measured cycle and peak.
        let pr = r2.prediction.unwrap();
        assert!(rel(pr.a_per_s, a).abs() < 0.05, "{u} {d}: a {}", pr.a_per_s);
        assert!(
            rel(pr.b_per_s2, b).abs() < 0.05,
            "{u} {d}: b {}",
            pr.b_per_s2
        );
        assert!(
            rel(pr.amplitude_rad, a1).abs() < 0.06,
            "{u} {d}: predicted A"
        );
        assert!(
            rel(pr.peak_rad, peak1).abs() < 0.08,
            "{u} {d}: predicted peak"
        );
        // The estimator reads the designed relay's cycle from both.
        let f1 = Features::Hbt(r1.to_features());
        let f2 = Features::Hbt(r2.to_features());
        for (feature, tol) in [(Feature::LnOmegaU, 0.02), (Feature::LnAmplitude, 0.04)] {
            let (x1, x2) = (feature.value(&f1).unwrap(), feature.value(&f2).unwrap());
            assert!((x1 - x2).abs() < tol, "{u} {d}: {feature} {x1} vs {x2}");
        }
    }
}

/// A heading limit that even the smallest relay would cross: abort at the look, with the
/// prediction in the reason, before the cycle gets there.
#[test]
fn a_relay_that_cannot_shrink_enough_aborts_at_the_look() {
    let mut cfg = CoreConfig::default();
    cfg.safety.max_heading_error_deg = 3.0;
    cfg.hbt.resize_min_hysteresis_deg = cfg.hbt.hysteresis_deg;
    let (r, peak) = relay_on_linear_ship(&cfg, 10.0, 4000.0);
    match r {
        Err(AbortReason::RelayTooLarge {
            predicted_deg,
            limit_deg,
            hysteresis_deg,
        }) => {
            assert!(
                predicted_deg > 3.0 && predicted_deg < 15.0,
                "{predicted_deg}"
            );
            assert!((limit_deg - 3.0).abs() < 1e-12, "{limit_deg}");
            assert!((hysteresis_deg - 1.0).abs() < 1e-12, "{hysteresis_deg}");
        }
        other => panic!("{other:?}"),
    }
    assert_eq!(peak, 0.0);
}

#[test]
fn handback_instant_zeroes_the_pd_term() {
    let (p, a, eps, tau): (f64, f64, f64, f64) = (180.0, 0.05, 0.0175, 30.0);
    let w = 2.0 * std::f64::consts::PI / p;
    let phi0 = (eps / a).asin();
    let t = handback_instant(0.0, p, a, eps, tau);
    let e = a * (w * t + phi0).sin();
    let de = a * w * (w * t + phi0).cos();
    assert!((e + tau * de).abs() < 1e-12, "{}", e + tau * de);
    assert!(de < 0.0 && e > 0.0);
    assert!(t > 0.0 && t < p / 2.0);
}

/// The sea's scale ([`RelaySizing::for_sea`]) by hand: `3 x wave yaw / eps` where that is
/// over 1, capped by the excitation's limit; 1 in a moderate sea, without a known sea, or
/// with the sizing off.
#[test]
fn the_relay_is_sized_for_the_sea_it_finds() {
    use crate::monitor::sizing::RelaySizing;
    let cfg = CoreConfig::default();
    let design = (cfg.hbt.relay_height_rad(), cfg.hbt.hysteresis_rad());
    let sizing = RelaySizing::new(&cfg);
    let sea = |deg: f64| Some(deg.to_radians());
    let roomy = 20f64.to_radians();
    // 3 x 0.4 deg over the designed 1 deg; 3 x 0.5 deg.
    assert!((sizing.for_sea(sea(0.4), design, roomy) - 1.2).abs() < 1e-12);
    assert!((sizing.for_sea(sea(0.5), design, roomy) - 1.5).abs() < 1e-12);
    // Capped by safety.max-excitation-deg (10 deg for the 8 deg relay: 1.25).
    let capped = sizing.for_sea(sea(0.5), design, 10f64.to_radians());
    assert!((capped - 1.25).abs() < 1e-12, "{capped}");
    // A moderate sea (0.2 deg: 0.6 deg wanted) and an unknown one leave the design.
    assert_eq!(sizing.for_sea(sea(0.2), design, roomy), 1.0);
    assert_eq!(sizing.for_sea(None, design, roomy), 1.0);
    let mut off = cfg.clone();
    off.hbt.resize_at_switch = 0;
    assert_eq!(RelaySizing::new(&off).for_sea(sea(0.5), design, roomy), 1.0);
}

/// A rough sea (0.5 deg of wave yaw) on the designed relay's 1 deg hysteresis: the wave's
/// envelope crosses the hysteresis band (a Rayleigh envelope passes 2 sigma at
/// `exp(-2)` = 14 % of its peaks), the relay chatters and the test aborts in some seas.
/// Sized for the sea (h and eps x 1.5, `safety.max-excitation-deg` 12 deg so the cap does
/// not bind) a back-crossing needs an envelope of 3 sigma (`exp(-4.5)` = 1 %): every test
/// completes. The independent answers are homogeneity and the describing function:
/// - without waves, the cycle at 1.5 against the designed one in the describing function's
///   ratios (the servo's rate limit: the 24 deg step slews 6 s, the 16 deg one 4 s);
/// - in the sea, on a linear ship the relay `(s h, s eps)` in the wave `w(t)` is the
///   designed relay in the wave `w(t) / s`, scaled by `s` (the rate limit aside, which the
///   ratios take out). Each sea moves a cycle by a few % (the wave advances or delays
///   switches, and the two runs' switches part after the first), so the estimator's inputs
///   of the two agree on the mean over 12 seas, within the half-size test's tolerances
///   (without the ratios `ln a_u` would be off by `ln 1.5` = 0.41).
#[test]
fn a_relay_sized_for_a_rough_sea_completes_with_the_designed_cycle() {
    use crate::estimator::features::Feature;
    use crate::wire::Features;
    let mut cfg = CoreConfig::default();
    cfg.safety.max_excitation_deg = 12.0;
    cfg.hbt.timeout_s = 3000.0;
    cfg.safety.max_test_duration_s = 3600.0;
    let mut designed = cfg.clone();
    designed.hbt.resize_at_switch = 0;
    let (u, d) = (7.0, 7000.0);
    let sigma = 0.5f64.to_radians();
    let rel = |x: f64, y: f64| x / y - 1.0;
    let (r, _) = relay_in_a_sea(&cfg, u, d, &|_| 0.0, Some(sigma));
    let (r0, _) = relay_in_a_sea(&designed, u, d, &|_| 0.0, None);
    let (r, r0) = (r.unwrap(), r0.unwrap());
    let (rw, ra) = r.prediction.unwrap().ratios();
    let (c, c0) = (r.cycle, r0.cycle);
    assert!(
        rel(c.omega_u_rad_s / c0.omega_u_rad_s, rw).abs() < 0.02,
        "{c:?} {c0:?} {rw}"
    );
    assert!(
        rel(c.amplitude_rad / c0.amplitude_rad, ra).abs() < 0.04,
        "{c:?} {c0:?} {ra}"
    );
    let features = [Feature::LnOmegaU, Feature::LnAmplitude];
    let (mut chatter, mut diff, seas) = (0, [0.0; 2], 12);
    for seed in 0..seas {
        let wave = wave_yaw(sigma, 100 + seed);
        let (r, _) = relay_in_a_sea(&designed, u, d, &wave, Some(sigma));
        chatter += usize::from(matches!(r, Err(AbortReason::RelayChatter { .. })));
        let (r, _) = relay_in_a_sea(&cfg, u, d, &wave, Some(sigma));
        let r = r.unwrap_or_else(|e| panic!("seed {seed}: {e}"));
        let s = r.relay_scale.unwrap();
        assert!((s - 1.5).abs() < 1e-12, "seed {seed}: scale {s}");
        let (r0, _) = relay_in_a_sea(&designed, u, d, &|t| wave(t) / s, None);
        let r0 = r0.unwrap_or_else(|e| panic!("seed {seed}, the sea / s: {e}"));
        let (f, f0) = (
            Features::Hbt(r.to_features()),
            Features::Hbt(r0.to_features()),
        );
        for (k, feature) in features.iter().enumerate() {
            diff[k] += (feature.value(&f).unwrap() - feature.value(&f0).unwrap()) / seas as f64;
        }
    }
    assert!(diff[0].abs() < 0.02, "mean ln w_u difference {}", diff[0]);
    assert!(diff[1].abs() < 0.04, "mean ln a_u difference {}", diff[1]);
    // The designed relay in the same seas: 3 of 12 chatter here (half the simulator's rough
    // seas, whose gyro noise adds to the wave yaw).
    assert!(
        chatter > 0,
        "the designed relay never chattered in {seas} seas"
    );
}
