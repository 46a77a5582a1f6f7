//! Running the real `gazecast` binary from the repository root.
#![allow(dead_code)]

use std::path::Path;
use std::process::{Command, Output};

/// The binary, started in the repository root (where `config/` is).
pub fn gazecast() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_gazecast"));
    c.current_dir(Path::new(env!("CARGO_MANIFEST_DIR")).join("../.."));
    c
}

pub trait Run {
    /// Runs to completion and requires exit 0 (stderr in the failure message).
    fn succeed(&mut self) -> Output;
}

impl Run for Command {
    fn succeed(&mut self) -> Output {
        let out = self.output().expect("the binary runs");
        assert!(
            out.status.success(),
            "{:?} failed: {}",
            self,
            String::from_utf8_lossy(&out.stderr)
        );
        out
    }
}
