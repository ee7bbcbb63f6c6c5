//! The `helmwatch` binary: all logic lives in the library; this only sets the exit code.
fn main() {
    std::process::exit(helmwatch::cli::main());
}
