//! Benchmark placeholder, filled by the owning work.
fn main() {}
