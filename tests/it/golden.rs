//! Golden outputs of the binary, byte for byte: the probe reports (both methods, calm and
//! moderate seas, seeds 1 and 2) and the replay of a simulated recording with a fault.
//!
//! They pin the behaviour of the whole chain (simulator, monitor, dsp, estimator, FDI, wire
//! encoding) across refactorings: a move of code must leave every file here unchanged. When a
//! change of behaviour is intended, regenerate them and say so in the commit:
//!
//! ```sh
//! HELMWATCH_BLESS=1 cargo test --profile ci --test it golden
//! ```

use std::path::{Path, PathBuf};
use std::process::Command;

fn golden_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/golden")
}

fn helmwatch(args: &[&str]) -> String {
    let out = Command::new(env!("CARGO_BIN_EXE_helmwatch"))
        .args(args)
        .env("RUST_LOG", "off")
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "helmwatch {args:?}: {}\n{}",
        out.status,
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).unwrap()
}

/// Compares `got` with the golden file `name` (or writes it when blessing).
fn check(name: &str, got: &str) {
    let path = golden_dir().join(name);
    if std::env::var_os("HELMWATCH_BLESS").is_some() {
        std::fs::create_dir_all(golden_dir()).unwrap();
        std::fs::write(&path, got).unwrap();
        return;
    }
    let want = std::fs::read_to_string(&path)
        .unwrap_or_else(|e| panic!("{}: {e} (HELMWATCH_BLESS=1 writes it)", path.display()));
    if want != got {
        let line = want
            .lines()
            .zip(got.lines())
            .position(|(a, b)| a != b)
            .unwrap_or(want.lines().count().min(got.lines().count()));
        panic!(
            "{} differs from the golden file at line {}:\n want: {}\n  got: {}",
            name,
            line + 1,
            want.lines().nth(line).unwrap_or("<end>"),
            got.lines().nth(line).unwrap_or("<end>"),
        );
    }
}

#[test]
fn probe_reports_are_the_golden_ones() {
    for method in ["clfrt", "hbt"] {
        for sea in ["calm", "moderate"] {
            for seed in ["1", "2"] {
                let got = helmwatch(&[
                    "probe", "--method", method, "--sea", sea, "--seed", seed, "--json",
                ]);
                assert!(got.contains("\"features\""), "{got}");
                check(&format!("probe-{method}-{sea}-{seed}.json"), &got);
            }
        }
    }
}

/// A recording of the simulated ship (a displacement fault from the start, tests every
/// minute) replayed through the monitor core: every report, decision and notification.
#[test]
fn replay_of_a_recording_is_the_golden_one() {
    let dir = std::env::temp_dir().join(format!("helmwatch-golden-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let cfg = dir.join("golden.toml");
    std::fs::write(
        &cfg,
        "[scheduler]\ninterval-s = 60.0\n\n[simulation]\nvessel = \"golden\"\n",
    )
    .unwrap();
    let rec = dir.join("golden.jsonl");
    let cfg_s = cfg.to_str().unwrap();
    let rec_s = rec.to_str().unwrap();
    helmwatch(&[
        "--config",
        cfg_s,
        "simulate",
        "--duration-s",
        "15000",
        "--seed",
        "3",
        "--sea",
        "moderate",
        "--fault",
        "displacement_pct:+20@0",
        "--out",
        rec_s,
    ]);
    let got = helmwatch(&["--config", cfg_s, "replay", rec_s, "--json"]);
    std::fs::remove_dir_all(&dir).ok();
    assert!(got.contains("\"features\""), "{got}");
    check("replay-displacement-20.jsonl", &got);
}
