#![allow(clippy::unwrap_used, clippy::expect_used)]

use super::whittle::{fit, log_likelihood};
use super::*;
use rand::SeedableRng;
use rand_distr::{Distribution, StandardNormal};

/// The design's ship at 7 m/s and 7000 t under its pole-placement autopilot in a moderate
/// sea, sampled at 10 Hz (docs/passive.md's nominal loop).
fn nominal() -> LoopModel {
    LoopModel {
        a: 0.014_583,
        b: 5.98e-4,
        kp: 4.2,
        td_s: 30.0,
        ti_s: 200.0,
        wf_rad_s: 0.25,
        servo_s: 1.0,
        bias_rad: 0.5_f64.to_radians(),
        bias_s: 300.0,
        wave_rad: 0.2_f64.to_radians(),
        wave_w0_rad_s: 0.8,
        wave_damping: 0.1,
        heading_noise_rad: 0.05_f64.to_radians(),
        rudder_noise_rad: 0.1_f64.to_radians(),
    }
}

const DT: f64 = 0.1;

/// Trapezoid in ln w of `f(w) w` over 1e-6 .. 1e3 rad/s, both signs (the densities are even).
fn integral(f: impl Fn(f64) -> f64) -> f64 {
    let n = 200_000;
    let (lo, hi) = (1.0e-6_f64.ln(), 1.0e3_f64.ln());
    let h = (hi - lo) / n as f64;
    let g = |i: usize| {
        let w = (lo + i as f64 * h).exp();
        f(w) * w
    };
    let inner: f64 = (1..n).map(g).sum();
    2.0 * h * (inner + 0.5 * (g(0) + g(n)))
}

#[test]
fn the_bias_and_the_wave_have_their_variances() {
    let m = nominal();
    let bias = integral(|w| {
        let ib = 1.0 / m.bias_s;
        m.bias_rad * m.bias_rad * ib / (PI * (w * w + ib * ib))
    });
    let rel = bias / (m.bias_rad * m.bias_rad);
    assert!((rel - 1.0).abs() < 1.0e-3, "bias variance ratio {rel}");
    // The wave: the heading source less the gyro's white noise.
    let white = m.heading_noise_rad.powi(2) * DT / (2.0 * PI);
    let wave = integral(|w| m.sources(w, DT)[1] - white);
    let rel = wave / (m.wave_rad * m.wave_rad);
    assert!((rel - 1.0).abs() < 1.0e-3, "wave variance ratio {rel}");
}

#[test]
fn the_spectrum_and_the_tone_obey_the_loop() {
    // Independent of `spectrum`'s algebra: a tone r on the command gives delta = Sr (r - K y)
    // and y = G delta; without the rudder's noise the rudder is -L y exactly, so
    // Phi_dy = -L Phi_yy.
    let mut m = nominal();
    let w = 0.05;
    let s = Complex64::new(0.0, w);
    let one = Complex64::new(1.0, 0.0);
    let g = m.b / (s * (s + m.a));
    let f = m.wf_rad_s.powi(2) / ((s + m.wf_rad_s) * (s + m.wf_rad_s));
    let k = f * m.kp * (one + s * m.td_s + one / (s * m.ti_s));
    let sr = one / (s * m.servo_s + one);
    let [cy, cd] = m.tone_response(w);
    assert!((cd - sr * (one - k * cy)).norm() < 1e-12 * cd.norm());
    assert!((cy - g * cd).norm() < 1e-12 * cy.norm());
    m.rudder_noise_rad = 1.0e-12;
    let p = m.spectrum(w, DT);
    let ratio = p[1][0] / p[0][0];
    assert!(
        (ratio + k * sr).norm() < 1e-9 * (k * sr).norm(),
        "{ratio} {}",
        -k * sr
    );
}

#[test]
fn the_information_grows_with_the_record_and_the_ship_is_identifiable() {
    let t = nominal().to_logs();
    let i1 = information(&t, 1800.0, DT);
    let i2 = information(&t, 3600.0, DT);
    // Each parameter's own information at least doubles with the record; that of those
    // seen above the band's lowest frequencies (2 pi / T) doubles, while the integral's and
    // the slow bias's, which live at the bottom, grow faster.
    for i in 0..N_PARAMS {
        let r = i2[i * N_PARAMS + i] / i1[i * N_PARAMS + i];
        assert!(r > 1.9, "{}: {r}", PARAM_NAMES[i]);
        if [0, 1, 9, 10, 11, 12, 13].contains(&i) {
            assert!(r < 2.3, "{}: {r}", PARAM_NAMES[i]);
        }
    }
    let ship = ship_information(&i2).unwrap();
    let (su, sd) = speed_displacement_bounds(&ship).unwrap();
    assert!(su > 0.0 && su.is_finite() && sd > 0.0 && sd.is_finite());
}

/// A periodogram drawn from the model itself: `Z_k ~ CN(0, 2 pi T Phi_k)`.
fn synthetic(m: &LoopModel, record_s: f64, seed: u64) -> Vec<(f64, M2)> {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    fourier_frequencies(record_s)
        .map(|w| {
            let phi = m.spectrum(w, DT);
            // Cholesky of the Hermitian 2 x 2 matrix, phi = C C^H.
            let c00 = phi[0][0].re.sqrt();
            let c10 = phi[1][0] / c00;
            let c11 = (phi[1][1].re - c10.norm_sqr()).sqrt();
            let mut e = || {
                let (re, im): (f64, f64) = (
                    StandardNormal.sample(&mut rng),
                    StandardNormal.sample(&mut rng),
                );
                Complex64::new(re, im) / 2.0_f64.sqrt()
            };
            let (e0, e1) = (e(), e());
            let z = [e0 * c00, c10 * e0 + e1 * c11];
            (w, [0, 1].map(|r| [0, 1].map(|c| z[r] * z[c].conj())))
        })
        .collect()
}

#[test]
fn whittle_finds_the_ship_within_its_bound() {
    // A record drawn from the model: the estimate of ln a and ln b lies within 4 bounds of
    // the truth, from a start 20 % off, and the likelihood rose.
    let truth = nominal();
    let record_s = 3600.0;
    let bound = {
        let info = information(&truth.to_logs(), record_s, DT);
        let n = nalgebra::DMatrix::from_row_slice(N_PARAMS, N_PARAMS, &info);
        let inv = n.try_inverse().unwrap();
        [inv[(0, 0)].sqrt(), inv[(1, 1)].sqrt()]
    };
    for seed in 0..3 {
        let pg = synthetic(&truth, record_s, seed);
        let mut start = truth;
        start.a *= 1.2;
        start.b *= 0.8;
        let l0 = log_likelihood(&start.to_logs(), &pg, DT).unwrap();
        let f = fit(&start, &pg, DT).unwrap();
        assert!(f.converged && f.log_likelihood > l0);
        let ea = (f.model.a / truth.a).ln() / bound[0];
        let eb = (f.model.b / truth.b).ln() / bound[1];
        assert!(
            ea.abs() < 4.0 && eb.abs() < 4.0,
            "seed {seed}: {ea} {eb} bounds"
        );
    }
}
