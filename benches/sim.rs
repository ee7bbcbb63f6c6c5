//! One simulated hour of the default ship at 10 Hz in a moderate sea (36 000 ticks of
//! `publish` + `step`, the caller's buffer reused), and the same without `publish`.
//! Criterion reports the time per hour and the throughput in ticks (elements) per second.
//!
//! Target: under 50 ms of CPU per simulated hour in an optimised build.

// `criterion_group!` generates an undocumented public function.
#![allow(missing_docs)]

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use helmwatch::config::Config;
use helmwatch_core::sim::{Scenario, Ship};
use std::hint::black_box;

fn one_hour(cfg: &Config, publish: bool) -> f64 {
    let mut ship = match Ship::new(&cfg.sim(), &Scenario::nominal(&cfg.sim(), 1)) {
        Ok(s) => s,
        Err(e) => {
            eprintln!("{e}");
            return f64::NAN;
        }
    };
    let ticks = (3600.0 * cfg.sensors.rate_hz).round() as usize;
    let mut buf = Vec::with_capacity(8);
    for _ in 0..ticks {
        if publish {
            buf.clear();
            ship.publish(&mut buf);
            black_box(&buf);
        }
        ship.step();
    }
    ship.truth().psi_rad
}

fn bench(c: &mut Criterion) {
    let cfg = Config::default();
    let ticks = (3600.0 * cfg.sensors.rate_hz).round() as u64;
    let mut g = c.benchmark_group("sim");
    g.throughput(Throughput::Elements(ticks));
    g.sample_size(20);
    g.bench_function("one_hour_10hz_moderate_publish_step", |b| {
        b.iter(|| black_box(one_hour(&cfg, true)))
    });
    g.bench_function("one_hour_10hz_moderate_step_only", |b| {
        b.iter(|| black_box(one_hour(&cfg, false)))
    });
    g.finish();

    // A plain figure for reports: steps per second over a few hours.
    let start = std::time::Instant::now();
    let hours = 5;
    for _ in 0..hours {
        black_box(one_hour(&cfg, true));
    }
    let s = start.elapsed().as_secs_f64();
    println!(
        "sim: {:.1} ms per simulated hour, {:.3e} steps per second (publish + step, {hours} h)",
        s / f64::from(hours) * 1e3,
        (ticks * u64::from(hours as u32)) as f64 / s
    );
}

criterion_group!(benches, bench);
criterion_main!(benches);
