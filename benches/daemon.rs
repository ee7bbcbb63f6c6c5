//! Daemon benchmark figures over Zenoh on loopback: runs `helmwatch bench` (the same code,
//! `src/bench.rs`) built in this bench's profile and prints its figures: lockstep ship seconds
//! per wall second for one vessel, and the largest fleet one daemon keeps up with at 10 Hz,
//! with its memory. `cargo bench --bench daemon`.
fn main() {
    let status = std::process::Command::new(env!("CARGO_BIN_EXE_helmwatch"))
        .arg("bench")
        .env("RUST_LOG", "off")
        .status();
    match status {
        Ok(s) if s.success() => {}
        Ok(s) => eprintln!("helmwatch bench failed: {s}"),
        Err(e) => eprintln!("cannot run helmwatch bench: {e}"),
    }
}
