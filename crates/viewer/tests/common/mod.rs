//! Running the real `gazecast` binary from the repository root.
#![allow(dead_code)]

use std::path::Path;
use std::process::{Command, Output};

pub use fixtures::Xvfb;

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

/// The binary, showing its windows on `x` (never on a Wayland session).
pub fn windowed(x: &Xvfb) -> Command {
    let mut c = gazecast();
    c.env("DISPLAY", &x.display).env_remove("WAYLAND_DISPLAY");
    c
}

/// Runs `gazecast` with `args` in a window on `x` and requires exit 0. Under
/// a loaded machine a fresh Xvfb has refused a connection; one retry on a new
/// server (which replaces `x`) tells that apart from the binary not opening
/// its window, which fails twice.
pub fn succeed_windowed(x: &mut Xvfb, args: &[&str]) -> Output {
    let out = windowed(x).args(args).succeed();
    if !String::from_utf8_lossy(&out.stdout).contains("cannot open a window") {
        return out;
    }
    eprintln!(
        "could not connect to {}; retrying on a new Xvfb:\n{}",
        x.display,
        String::from_utf8_lossy(&out.stdout)
    );
    *x = Xvfb::start();
    windowed(x).args(args).succeed()
}

/// `cmd` under a file size limit of `kib` KiB with SIGXFSZ ignored, so a
/// write past it fails with EFBIG as a full disk fails with ENOSPC: a real
/// write error part-way through a recording, without mounting anything.
pub fn with_file_limit(cmd: &std::process::Command, kib: u32) -> std::process::Command {
    let mut c = std::process::Command::new("bash");
    c.arg("-c")
        .arg(format!("trap '' XFSZ; ulimit -f {kib}; exec \"$0\" \"$@\""))
        .arg(cmd.get_program())
        .args(cmd.get_args());
    if let Some(d) = cmd.get_current_dir() {
        c.current_dir(d);
    }
    for (k, v) in cmd.get_envs() {
        match v {
            Some(v) => c.env(k, v),
            None => c.env_remove(k),
        };
    }
    c
}

/// The small test design (or `design`) run for P01 with the simulated
/// mouse tracker on the small display without a window or a display
/// (DISPLAY unset), no stimulus pictures, on `backend`, into `out`, with
/// `extra` arguments (`--headless` and the simulation among them).
pub fn small_session(
    design: &std::ffi::OsStr,
    backend: &str,
    out: &Path,
    extra: &[&str],
) -> Output {
    let mut c = gazecast();
    c.env_remove("DISPLAY").env_remove("WAYLAND_DISPLAY");
    c.args(["experiment", "run"])
        .arg(design)
        .args([
            "--participant",
            "P01",
            "--tracker",
            "tests/data/mouse-participant.ron",
            "--display",
            "tests/data/experiment/display-small.ron",
            "--backend",
            backend,
            "--no-stimulus-pictures",
            "--out",
        ])
        .arg(out)
        .args(extra);
    c.output().expect("the binary runs")
}

/// The small test design: the 11 scene types, one run, with the click.
pub const SMALL_DESIGN: &str = "tests/data/experiment/design-small.ron";
