//! The `rain-composite` command line.
fn main() {}
