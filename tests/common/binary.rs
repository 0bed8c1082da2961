//! Running the `rain-composite` binary the tests are built with.
#![allow(dead_code)]

use std::process::{Command, Output};

/// The binary, with a runtime directory for the GPU drivers that want one.
pub fn bin() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_rain-composite"));
    c.env("XDG_RUNTIME_DIR", std::env::temp_dir());
    c
}

/// Runs `cmd` and returns its output, failing the test with its stderr if it fails.
pub fn ok(cmd: &mut Command) -> Output {
    let out = cmd.output().expect("spawn");
    assert!(
        out.status.success(),
        "{cmd:?} failed:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    out
}
