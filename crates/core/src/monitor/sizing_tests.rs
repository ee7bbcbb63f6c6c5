//! Tests of the excitation's sizing (`super`).
use super::relay::unexplained_heading;
use super::*;
use crate::dsp::spectrum::{band_rms, Spectrum};
use crate::monitor::Monitor;

/// A rudder that answers each tone `i` with gain `gains[i]` (a lag of 0.3 rad) plus a
/// trim and a slow wander, sampled at 10 Hz from the multisine's start: what the sizing
/// sees in a loop whose sensitivity at the tones is `gains`.
fn run(gains: [f64; 3], noise_rad: f64) -> (ToneSizing, Multisine) {
    let cfg = CoreConfig::default();
    let ms = Monitor::design_multisine(&cfg).unwrap();
    let t0 = 1000.0;
    let mut sizing = ToneSizing::new(&cfg, &ms, t0, (t0, t0 + 400.0), false, None);
    feed(&mut sizing, &ms, t0, gains, noise_rad);
    (sizing, ms)
}

/// 400 s of the rudder `run` describes, from `t0`.
fn feed(sizing: &mut ToneSizing, ms: &Multisine, t0: f64, gains: [f64; 3], noise_rad: f64) {
    let mut rng_state = 7u64;
    let mut noise = || {
        // xorshift, uniform in [-1, 1].
        rng_state ^= rng_state << 13;
        rng_state ^= rng_state >> 7;
        rng_state ^= rng_state << 17;
        (rng_state >> 11) as f64 / (1u64 << 52) as f64 - 1.0
    };
    for n in 0..4000 {
        let t = t0 + n as f64 * 0.1;
        let scales = sizing.scales(t);
        let rudder: f64 = (0..3)
            .map(|i| {
                let arg = ms.omegas()[i] * (t - t0) + ms.phases()[i] - 0.3;
                gains[i] * scales[i] * ms.amplitude_rad() * arg.sin()
            })
            .sum::<f64>()
            + 0.02
            + 0.01 * (0.01 * t).sin()
            + noise_rad * noise();
        sizing.on_rudder(t, rudder, 1.0);
    }
}

#[test]
fn the_fit_reads_each_tones_gain() {
    // No tone over the limit: no resize, and the record's fit gives the gains back.
    let (sizing, _) = run([0.4, 1.5, 2.2], 0.0);
    assert!(!sizing.resized());
    let g = sizing.tone_gains();
    for (i, want) in [0.4, 1.5, 2.2].iter().enumerate() {
        let (got, se) = g[i].unwrap();
        // The slower tones leak a little into a faster one's one-period fit (the
        // quadratic trend takes most of it): within 5 %. The error bar is the noise's
        // alone, small without noise.
        assert!(
            (got - want).abs() < 0.05 * want,
            "tone {i}: {got} vs {want}"
        );
        assert!(se < 0.05 * want, "tone {i}: se {se}");
    }
}

#[test]
fn only_the_amplified_tone_is_lowered() {
    let (sizing, _) = run([0.1, 0.4, 12.0], 0.001);
    let (once, _) = run([0.1, 0.4, 6.0], 0.001);
    // Gain 6: 6 x 0.25 = 1.5, under the limit after one resize.
    assert_eq!(once.scales(f64::INFINITY)[2], 0.25);
    assert!(sizing.resized());
    let s = sizing.scales(f64::INFINITY);
    assert_eq!(&s[..2], &[1.0, 1.0]);
    // Gain 12: 12 x 0.25 = 3 is still over 2.5, 12 x 0.0625 = 0.75 is not.
    assert_eq!(s[2], 0.0625, "{s:?}");
    assert_eq!(sizing.resizes, 2);
}

#[test]
fn rudder_noise_does_not_lower_a_tone() {
    // Gains of 2 under a rudder noise of +-3 deg: one-period fits scatter, the lower
    // confidence bound stays under the limit.
    let (sizing, _) = run([1.6, 2.0, 2.0], 3f64.to_radians());
    assert!(!sizing.resized(), "{:?}", sizing.scales(f64::INFINITY));
}

/// Sparing the fastest, against hand-worked answers: the sum falls by the factor, the kept
/// share keeps its size and the others are lowered alike; `None` where the kept share alone
/// is at or above the target.
#[test]
fn spare_the_fastest_known_answers() {
    // 10.8 + 2.9 + 0.7 = 14.4, target 7.2: the others by (7.2 - 0.7) / 13.7.
    let k = spare_the_fastest(&[10.8, 2.9, 0.7], 2, 0.5).unwrap();
    let want = 6.5 / 13.7;
    assert!(
        (k[0] - want).abs() < 1e-15 && (k[1] - want).abs() < 1e-15,
        "{k:?}"
    );
    assert_eq!(k[2], 1.0);
    // The kept share is the middle one here: 1 + 1 + 2 = 4, target 2.4: others by 0.2.
    let k = spare_the_fastest(&[1.0, 2.0, 1.0], 1, 0.6).unwrap();
    assert!(
        (k[0] - 0.2).abs() < 1e-15 && (k[2] - 0.2).abs() < 1e-15,
        "{k:?}"
    );
    assert_eq!(spare_the_fastest(&[1.0, 1.0, 2.0], 2, 0.5), None);
    assert_eq!(spare_the_fastest(&[0.0, 0.0, 2.0], 2, 0.5), None);
    assert_eq!(spare_the_fastest(&[1.0, 2.0], 5, 0.5), None);
    let mut x = 0.3f64;
    for _ in 0..200 {
        let v: Vec<f64> = (0..5)
            .map(|_| {
                x = (x * 997.0 + 0.123).fract();
                0.1 + x * 10.0
            })
            .collect();
        let total: f64 = v.iter().sum();
        let f = 0.2 + 0.7 * x;
        let Some(k) = spare_the_fastest(&v, 4, f) else {
            assert!(v[4] >= f * total, "{v:?} {f}");
            continue;
        };
        let got: f64 = v.iter().zip(&k).map(|(y, k)| y * k).sum();
        assert!((got - f * total).abs() < 1e-9 * total, "{v:?} {f} {k:?}");
        assert!(
            k[..4].iter().all(|&c| c == k[0] && c > 0.0 && c < f),
            "{k:?}"
        );
    }
}

/// The heading guard on a ship whose slowest tone carries the heading: the tones' summed
/// heading share (scale x the loop's rudder gain the fit reads x the first-order ship's
/// `1 / (w sqrt(w^2 + a^2))`, written out here) falls by `resize-heading-factor`, the
/// slower tones are lowered alike, a little more than an even cut would, and the fastest
/// keeps its size.
#[test]
fn the_heading_cut_spares_the_fastest_tone() {
    let cfg = CoreConfig::default();
    let ms = Monitor::design_multisine(&cfg).unwrap();
    let t0 = 1000.0;
    let u = 8.0;
    let mut sizing = ToneSizing::new(&cfg, &ms, t0, (t0, t0 + 500.0), true, Some(u));
    let gains = [0.5, 1.2, 1.5];
    feed(&mut sizing, &ms, t0, gains, 0.0);
    assert!(!sizing.resized());
    let limit = cfg.safety.max_heading_error_deg.to_radians();
    sizing.on_heading(t0 + 400.0, 0.9 * limit);
    sizing.on_heading(t0 + 400.1, 0.9 * limit);
    assert!(sizing.heading_guarded());
    let after = sizing.scales(f64::INFINITY);
    let a = cfg.ship.yaw_damping_a0 * u / cfg.ship.length_m;
    let share = |i: usize, s: f64| {
        let w = ms.omegas()[i];
        s * gains[i] / (w * (w * w + a * a).sqrt())
    };
    let before: f64 = (0..3).map(|i| share(i, 1.0)).sum();
    let now: f64 = (0..3).map(|i| share(i, after[i])).sum();
    // The gains as the fit reads them (within 5 %, `the_fit_reads_each_tones_gain`).
    let want = cfg.clfrt.resize_heading_factor * before;
    assert!(
        (now / want - 1.0).abs() < 0.05,
        "{now} vs {want}: {after:?}"
    );
    let f = cfg.clfrt.resize_heading_factor;
    assert!(after[0] < f && after[0] > 0.75 * f, "{after:?}");
    assert!((after[1] / after[0] - 1.0).abs() < 1e-12, "{after:?}");
    assert_eq!(after[2], 1.0, "{after:?}");
}

#[test]
fn sizing_off_leaves_the_tones() {
    let mut cfg = CoreConfig::default();
    cfg.clfrt.resize_max = 0;
    let ms = Monitor::design_multisine(&cfg).unwrap();
    let mut sizing = ToneSizing::new(&cfg, &ms, 0.0, (0.0, 400.0), false, None);
    for n in 0..4000 {
        let t = n as f64 * 0.1;
        sizing.on_rudder(t, 0.4 * (ms.omegas()[2] * t).sin(), 1.0);
    }
    assert!(!sizing.resized());
}

/// The peak factor's two limits: parabolic arcs (`a = 0`, `pi^3 / 32`) and a triangle
/// (`a >> w`, `pi^2 / 8`); and in between, a brute-force steady state of the ship under a
/// square wave (Euler, many periods) agrees.
#[test]
fn square_wave_peak_factor_known_answers() {
    let k0 = square_wave_peak_factor(0.05, 0.0);
    assert!((k0 / (PI.powi(3) / 32.0) - 1.0).abs() < 1e-3, "{k0}");
    let kt = square_wave_peak_factor(0.001, 1.0);
    assert!((kt / (PI * PI / 8.0) - 1.0).abs() < 5e-3, "{kt}");
    // psi'' = -a psi' + sign(sin w t): peak and first harmonic of psi minus its mean over
    // the tenth period.
    let (w, a) = (0.05, 0.03);
    let period = 2.0 * PI / w;
    let dt = 1e-3;
    let n = (period / dt).round() as usize;
    // From rest: the rate's transient decays as e^{-a t} (e^{-38} after ten periods) and
    // leaves the heading a constant offset, removed with the mean.
    let (mut psi, mut r) = (0.0f64, 0.0f64);
    let mut last = Vec::with_capacity(n);
    for k in 0..10 * n {
        let t = k as f64 * dt;
        let u = if (w * t).sin() >= 0.0 { 1.0 } else { -1.0 };
        psi += r * dt;
        r += (-a * r + u) * dt;
        if k >= 9 * n {
            last.push((t, psi));
        }
    }
    let mean = last.iter().map(|x| x.1).sum::<f64>() / n as f64;
    let peak = last.iter().map(|x| (x.1 - mean).abs()).fold(0.0, f64::max);
    let (c, si) = last.iter().fold((0.0, 0.0), |(c, si), (t, x)| {
        (
            c + (x - mean) * (w * t).cos(),
            si + (x - mean) * (w * t).sin(),
        )
    });
    let h1 = 2.0 / n as f64 * c.hypot(si);
    let k = square_wave_peak_factor(w, a);
    assert!((k / (peak / h1) - 1.0).abs() < 5e-3, "{k} vs {}", peak / h1);
}

/// The heading the fitted ship does not explain, against the exact answer: a relay's
/// first 31 s as the sizing sees them on a responsive ship (8 deg steps about a trim,
/// switching at 6 s and 21 s) on `psi'' = -a psi' + b delta + c` solved in closed form
/// per sample, plus a wave of 0.1 deg at 0.8 rad/s. The residual is the wave (less its
/// value at the record's start, where the fitted ship starts) within 1e-4 deg, and in the
/// wave band it reads what the wave alone reads (within 2 %); the heading itself reads
/// several times as much (the band's lower edge, 0.4 rad/s, is the record's second bin:
/// inside the window's main lobe of the relay's own swing).
#[test]
fn the_unexplained_heading_is_the_sea() {
    let (a, b, c, dt, n) = (0.0146, 0.0059, -2e-5, 0.1, 310);
    let (h, trim) = (8f64.to_radians(), 0.01);
    let wave = |t: f64| 0.1f64.to_radians() * (0.8 * t + 0.3).sin();
    let (mut psi, mut r) = (0.5, 0.0);
    let (mut heading, mut rudder) = (Vec::new(), Vec::new());
    for k in 0..n {
        let t = k as f64 * dt;
        let d = trim + if (6.0..21.0).contains(&t) { -h } else { h };
        heading.push(psi + wave(t));
        rudder.push(d);
        // Exact over the sample for a constant input u: r -> r e + u (1 - e) / a.
        let u = b * d + c;
        let e = (-a * dt).exp();
        let r1 = r * e + u / a * (1.0 - e);
        psi += u / a * dt + (r - u / a) * (1.0 - e) / a;
        r = r1;
    }
    let res = unexplained_heading(&heading, &rudder, dt, a, b, c);
    let worst = heading
        .iter()
        .zip(&res)
        .enumerate()
        .map(|(k, (_, x))| (x - (wave(k as f64 * dt) - wave(0.0))).abs())
        .fold(0.0f64, f64::max);
    // The trapezoid on psi against the exact integral: O(dt^2 r'').
    assert!(worst.to_degrees() < 1e-4, "{}", worst.to_degrees());
    let (mut sp, mut sc) = (Spectrum::new(), Vec::new());
    let raw = band_rms(&heading, dt, (0.4, 2.0), &mut sp, &mut sc).unwrap();
    let sea = band_rms(&res, dt, (0.4, 2.0), &mut sp, &mut sc).unwrap();
    // The same estimate on the wave alone (0.1 / sqrt 2 deg, up to the record's length).
    let alone: Vec<f64> = (0..n).map(|k| wave(k as f64 * dt)).collect();
    let want = band_rms(&alone, dt, (0.4, 2.0), &mut sp, &mut sc).unwrap();
    assert!(
        (want / (0.1f64.to_radians() / 2f64.sqrt()) - 1.0).abs() < 0.1,
        "{want}"
    );
    assert!((sea / want - 1.0).abs() < 0.02, "{sea} vs {want}");
    assert!(raw > 3.0 * want, "{raw} vs {want}");
}
