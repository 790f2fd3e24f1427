//! The manylights binary, run from a test: one runner for every test of the command line.

use std::ffi::OsStr;
use std::process::{Command, Output};

/// Runs `manylights ARGS…` to completion, capturing its output streams.
pub fn manylights<S: AsRef<OsStr>>(args: &[S]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_manylights"))
        .args(args)
        .output()
        .expect("the manylights binary runs")
}
