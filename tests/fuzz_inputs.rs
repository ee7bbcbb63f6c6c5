//! Hostile input decoding, as a property over many cases: whatever bytes arrive on
//! whatever stream key (garbage, truncated or malformed JSON, wrong types, NaN-like and huge
//! numbers, wild times, headings of 9 rad), decoding never panics, and what decodes goes into
//! a monitor core that never panics, answers every accepted heading with exactly one
//! excitation, and keeps its memory bounded (its resident set grows by less than 64 MiB over
//! the samples: over the slow tier's million, a leak of even 64 bytes a sample would exceed
//! it; over the fast tier's 100 000, one of 640 bytes).
//!
//! A test binary of its own: the resident set is the process's, so no other test may run
//! beside it (each tier runs one of the two tests here).
// A test crate: an unwrap, expect or panic here is the test failing, with its message
// (clippy.toml allows them in `#[test]` functions; the helpers are test code too).
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use helmwatch::config::Config;
use helmwatch::tools::bench::rss_mib;
use helmwatch_core::monitor::{Monitor, Output};
use helmwatch_core::wire::{self, Stream};
use proptest::prelude::*;
use proptest::test_runner::{Config as RunnerConfig, TestRunner};
use std::cell::RefCell;

/// A JSON-ish number: ordinary, huge, tiny, negative, or not a number at all.
fn number() -> impl Strategy<Value = String> {
    prop_oneof![
        (-1.0e4f64..1.0e4).prop_map(|x| format!("{x}")),
        (0.0f64..7.0).prop_map(|x| format!("{x}")),
        Just("1e308".to_string()),
        Just("-1e309".to_string()),
        Just("NaN".to_string()),
        Just("\"9\"".to_string()),
        Just("null".to_string()),
        Just("[]".to_string()),
        any::<i64>().prop_map(|x| x.to_string()),
    ]
}

/// A payload: a `t` (`None`: the next time of the feed's clock, so that most samples are in
/// order and reach the core's state) and a hostile value, or raw bytes.
#[derive(Debug, Clone)]
enum Case {
    Fields {
        t: Option<String>,
        value: String,
        extra: bool,
    },
    Raw(Vec<u8>),
}

fn payload() -> impl Strategy<Value = Case> {
    let value = prop_oneof![
        4 => (0.0f64..std::f64::consts::TAU).prop_map(|x| format!("{x}")),
        4 => (-0.5f64..0.5).prop_map(|x| format!("{x}")),
        1 => number(),
        1 => "[a-z]{0,8}".prop_map(|v| format!("\"{v}\"")),
        1 => Just("\"auto\"".to_string()),
    ];
    let t = prop_oneof![6 => Just(None), 1 => number().prop_map(Some)];
    prop_oneof![
        8 => (t, value, proptest::bool::weighted(0.1))
            .prop_map(|(t, value, extra)| Case::Fields { t, value, extra }),
        1 => proptest::collection::vec(any::<u8>(), 0..48).prop_map(Case::Raw),
        1 => Just(Case::Raw(b"{\"t\": 1.0, \"value\": 0.5".to_vec())),
    ]
}

fn stream() -> impl Strategy<Value = Stream> {
    proptest::sample::select(Stream::ALL.to_vec())
}

#[test]
fn hostile_samples_never_panic_and_memory_stays_flat() {
    hostile_samples(100_000);
}

#[test]
#[ignore = "slow tier: cargo test --profile ci -- --ignored"]
fn a_million_hostile_samples_never_panic_and_memory_stays_flat() {
    hostile_samples(1_000_000);
}

/// `cases` samples through the decoder and one monitor core; the assertions scale with it.
fn hostile_samples(cases: u32) {
    let cfg = Config::default();
    let monitor = RefCell::new(Monitor::new(&cfg.core(), "self"));
    let counts = RefCell::new((0u64, 0u64, 0u64)); // decoded, accepted headings, excitations
    let clock = RefCell::new(0.0f64);
    let mut runner = TestRunner::new(RunnerConfig {
        cases,
        failure_persistence: None,
        ..RunnerConfig::default()
    });
    let rss0 = rss_mib();
    runner
        .run(&(stream(), payload()), |(s, case)| {
            let mut m = monitor.borrow_mut();
            let mut c = counts.borrow_mut();
            let bytes = match case {
                Case::Raw(b) => b,
                Case::Fields { t, value, extra } => {
                    let t = t.unwrap_or_else(|| {
                        let mut k = clock.borrow_mut();
                        *k += 0.02;
                        format!("{}", *k)
                    });
                    let x = if extra {
                        ", \"extra\": {\"a\": [1, 2]}"
                    } else {
                        ""
                    };
                    format!("{{\"t\": {t}, \"value\": {value}{x}}}").into_bytes()
                }
            };
            match wire::decode(s, &bytes) {
                Err(_) => {
                    m.count_malformed(s);
                }
                Ok(input) => {
                    c.0 += 1;
                    let heading = input.stream() == Stream::Heading;
                    if m.handle_input(input).is_ok() && heading {
                        c.1 += 1;
                    }
                }
            }
            while let Some(o) = m.poll_output() {
                if matches!(o, Output::Excitation(_)) {
                    c.2 += 1;
                }
            }
            Ok(())
        })
        .unwrap();
    let grown = rss_mib() - rss0;
    let (decoded, headings, excitations) = *counts.borrow();
    println!(
        "{cases} samples: {decoded} decoded, {headings} headings accepted, RSS grew {grown:.1} MiB"
    );
    let cases = u64::from(cases);
    assert!(
        decoded > cases * 3 / 10,
        "the strategy reaches the decoder's success path"
    );
    assert!(headings > cases / 100, "headings are accepted");
    assert_eq!(excitations, headings, "one excitation per accepted heading");
    let m = monitor.borrow();
    let c = m.counters();
    let rejected: u64 = c.rejected_total();
    assert!(rejected > cases / 10, "{rejected}");
    assert!(grown < 64.0, "resident set grew {grown:.1} MiB");
}
