//! Cost of the monitor core: per input sample (idle, and while a CLFRT test records), and per
//! analysis (the tone analysis of a 2 x 600 s CLFRT record, the relay analysis of an HBT
//! record). Criterion reports time per iteration; the per-sample figure is for one tick of
//! five samples (rudder, speed, state, target, heading), so one vessel at 10 Hz costs
//! 10 x that per second of ship time.

// `criterion_group!` generates an undocumented public function.
#![allow(missing_docs)]

use criterion::{criterion_group, criterion_main, BatchSize, Criterion, Throughput};
use helmwatch::config::Config;
use helmwatch_core::dsp::relay::analyse_limit_cycle;
use helmwatch_core::dsp::tones::{analyse_tones, ToneAnalyser};
use helmwatch_core::monitor::Monitor;
use helmwatch_core::wire::Method;
use helmwatch_core::wire::{Input, Scalar, StateValue};
use std::hint::black_box;

fn tick(m: &mut Monitor, t: f64) {
    let h = 1.0 + 0.01 * (0.05 * t).sin();
    for i in [
        Input::Rudder(Scalar {
            t,
            value: 0.02 * (0.07 * t).sin(),
        }),
        Input::Speed(Scalar { t, value: 7.0 }),
        Input::AutopilotState(StateValue {
            t,
            value: "auto".into(),
        }),
        Input::TargetHeading(Scalar { t, value: 1.0 }),
        Input::Heading(Scalar { t, value: h }),
    ] {
        let _ = m.handle_input(i);
    }
    while let Some(o) = m.poll_output() {
        black_box(o);
    }
}

fn per_sample(c: &mut Criterion) {
    let mut cfg = Config::default();
    cfg.scheduler.enabled = false;
    let mut g = c.benchmark_group("core_tick");
    g.throughput(Throughput::Elements(5));
    let mut m = Monitor::new(&cfg.core(), "self");
    let mut t = 0.0;
    g.bench_function("idle", |b| {
        b.iter(|| {
            t += 0.1;
            tick(&mut m, t);
        })
    });
    // A CLFRT test in its measurement (records growing); restarted when it ends.
    let mut m = Monitor::new(&cfg.core(), "self");
    let mut t = 0.0;
    for _ in 0..100 {
        t += 0.1;
        tick(&mut m, t);
    }
    g.bench_function("clfrt_recording", |b| {
        b.iter(|| {
            t += 0.1;
            tick(&mut m, t);
            if m.state() == helmwatch_core::wire::MonitorState::Idle {
                let _ = m.trigger(Method::Clfrt);
            }
        })
    });
    g.finish();
}

fn per_analysis(c: &mut Criterion) {
    let cfg = Config::default();
    let dt = 1.0 / cfg.sensors.rate_hz;
    let w = (cfg.clfrt.window_s * cfg.sensors.rate_hz).round() as usize;
    let n = w * cfg.clfrt.measure_windows as usize;
    let (a, b) = cfg.ship.nomoto(7.0, 7000.0);
    let tone = |k: u32, t: f64| {
        let om = 2.0 * std::f64::consts::PI * k as f64 / cfg.clfrt.window_s;
        (om, (om * t).sin())
    };
    let mut r = Vec::with_capacity(n);
    let mut d = Vec::with_capacity(n);
    let mut h = Vec::with_capacity(n);
    for i in 0..n {
        let t = i as f64 * dt;
        let (mut rs, mut hs) = (0.0, 0.0);
        for &k in &cfg.clfrt.harmonics {
            let (om, s) = tone(k, t);
            rs += 0.035 * s;
            let g = b / (om * (om * om + a * a).sqrt());
            let ph = -std::f64::consts::FRAC_PI_2 - (om / a).atan();
            hs += 0.035 * g * (om * t + ph).sin();
        }
        r.push(rs);
        d.push(rs);
        h.push(hs + 1e-4 * ((i * 7919) % 13) as f64);
    }
    let mut an = ToneAnalyser::new();
    let mut g = c.benchmark_group("core_analysis");
    g.bench_function("clfrt_2x600s", |bch| {
        bch.iter(|| {
            black_box(analyse_tones(
                &mut an,
                &h,
                &d,
                &r,
                dt,
                w,
                &cfg.clfrt.harmonics,
            ))
        })
    });
    // HBT: 3 periods of 180 s.
    let p = 180.0;
    let m = (3.0 * p / dt) as usize + 20;
    let x: Vec<f64> = (0..m)
        .map(|i| 0.05 * (2.0 * std::f64::consts::PI * i as f64 * dt / p).sin())
        .collect();
    let switches = [1.0, 1.0 + p, 1.0 + 2.0 * p, 1.0 + 3.0 * p];
    g.bench_function("hbt_3_periods", |bch| {
        bch.iter_batched(
            || x.clone(),
            |x| black_box(analyse_limit_cycle(0.0, dt, &x, &switches)),
            BatchSize::SmallInput,
        )
    });
    g.finish();
}

criterion_group!(benches, per_sample, per_analysis);
criterion_main!(benches);
