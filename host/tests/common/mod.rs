//! Helpers the CLI test binaries share: run the `kdray` binary, a scratch folder per test.

use std::path::Path;
use std::process::{Command, Output};

/// Runs the `kdray` binary with `args`.
pub fn kdray(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_kdray"))
        .args(args)
        .output()
        .expect("run kdray")
}

/// A fresh scratch folder for test `name`, removed with everything in it when dropped (at the
/// end of the test, passed or failed).
pub struct Scratch(tempfile::TempDir);

impl core::ops::Deref for Scratch {
    type Target = Path;
    fn deref(&self) -> &Path {
        self.0.path()
    }
}

impl AsRef<Path> for Scratch {
    fn as_ref(&self) -> &Path {
        self.0.path()
    }
}

/// A fresh scratch folder for test `name` ([`Scratch`]).
pub fn dir(name: &str) -> Scratch {
    Scratch(
        tempfile::Builder::new()
            .prefix(&format!("kdray-cli-{name}-"))
            .tempdir()
            .unwrap(),
    )
}

/// A path as the `&str` an argument list wants.
pub fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}
