//! Helpers the CLI test binaries share: run the `kdray` binary, a scratch folder per test.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// Runs the `kdray` binary with `args`.
pub fn kdray(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_kdray"))
        .args(args)
        .output()
        .expect("run kdray")
}

/// A fresh scratch folder for test `name` of this process.
pub fn dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("kdray-cli-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A path as the `&str` an argument list wants.
pub fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}
