//! Inference cost of the shipped estimator: one estimate (speed and displacement networks,
//! inputs read from a report's typed features) per method, with the caller's scratch reused
//! (no allocation), and one network's forward pass alone.
//!
//! The features are those of a real test (probe on the nominal ship, moderate sea).

// `criterion_group!` generates an undocumented public function.
#![allow(missing_docs)]

use criterion::{criterion_group, criterion_main, Criterion};
use helmwatch::config::Config;
use helmwatch_core::drivers::probe::{run_probe, ProbeOptions};
use helmwatch_core::estimator::model::Target;
use helmwatch_core::estimator::nn::Scratch;
use helmwatch_core::estimator::Estimator;
use helmwatch_core::sim::Scenario;
use helmwatch_core::wire::{Features, Method};
use std::hint::black_box;

fn features(cfg: &Config, method: Method) -> Option<Features> {
    let r = run_probe(
        &cfg.core(),
        &cfg.sim(),
        &Scenario::nominal(&cfg.sim(), 1),
        &ProbeOptions::new(&cfg.core(), method),
    )
    .ok()?;
    Some(r.report.features)
}

fn bench(c: &mut Criterion) {
    let cfg = Config::default();
    let est = match Estimator::embedded(&cfg.core()) {
        Ok(e) => e,
        Err(e) => {
            eprintln!("estimator: {e}");
            return;
        }
    };
    let mut g = c.benchmark_group("estimator");
    for method in [Method::Clfrt, Method::Hbt] {
        let Some(f) = features(&cfg, method) else {
            eprintln!("{}: the probe did not complete", method.name());
            continue;
        };
        let mut scratch = est.scratch();
        g.bench_function(format!("estimate_{}", method.name()), |b| {
            b.iter(|| black_box(est.estimate(method, black_box(&f), &mut scratch).ok()))
        });
        let m = est.model(method, Target::Displacement);
        let mut x = Vec::new();
        let mut s = Scratch::new(m.inputs.len());
        if m.predict_features(&f, &mut x, &mut s).is_err() {
            eprintln!("{}: features lack an input", method.name());
            continue;
        }
        g.bench_function(format!("forward_{}_displacement", method.name()), |b| {
            b.iter(|| black_box(m.net.predict(&m.scaling, black_box(&x), &mut s)))
        });

        // A plain figure for reports.
        let n = 200_000;
        let start = std::time::Instant::now();
        for _ in 0..n {
            black_box(est.estimate(method, black_box(&f), &mut scratch).ok());
        }
        let ns = start.elapsed().as_secs_f64() / f64::from(n) * 1e9;
        println!(
            "estimator: {ns:.0} ns per {} estimate (speed + displacement networks, inputs read from the typed features)",
            method.name()
        );
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
