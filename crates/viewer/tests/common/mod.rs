//! Running the real `gazecast` binary from the repository root.
#![allow(dead_code)]

use std::path::Path;
use std::process::{Child, Command, Output, Stdio};

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

/// A private Xvfb on a free display number, killed on drop.
pub struct Xvfb {
    child: Child,
    pub display: String,
    /// Where the server keeps its screen as an XWD file (`-fbdir`), when
    /// started with [`Xvfb::start_with_screen_file`].
    screen_dir: Option<tempfile::TempDir>,
}

impl Xvfb {
    /// Xvfb picks a free display number itself (`-displayfd`) and writes it
    /// once it accepts connections, so tests running in parallel never share
    /// or race for a display.
    pub fn start() -> Self {
        Self::start_in(None)
    }

    /// [`Xvfb::start`] with the screen kept in a file ([`Xvfb::screen`]
    /// reads what is on it: the pixels a window actually shows).
    pub fn start_with_screen_file() -> Self {
        Self::start_in(Some(tempfile::tempdir().expect("tempdir")))
    }

    fn start_in(screen_dir: Option<tempfile::TempDir>) -> Self {
        use std::io::BufRead;
        let mut cmd = Command::new("Xvfb");
        if let Some(d) = &screen_dir {
            cmd.arg("-fbdir").arg(d.path());
        }
        let mut child = cmd
            .args([
                "-displayfd",
                "1",
                "-screen",
                "0",
                "1600x1200x24",
                "-nolisten",
                "tcp",
                // Without it the server resets when its last client leaves,
                // and a test's next window, connecting during the reset, is
                // refused (seen on a loaded CI machine).
                "-noreset",
            ])
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .expect("Xvfb runs (scripts/system-deps.sh installs the xvfb package)");
        let mut line = String::new();
        if let Some(out) = child.stdout.take() {
            let _ = std::io::BufReader::new(out).read_line(&mut line);
        }
        let num: u32 = line
            .trim()
            .parse()
            .unwrap_or_else(|_| panic!("Xvfb did not report a display: {line:?}"));
        Self {
            child,
            display: format!(":{num}"),
            screen_dir,
        }
    }

    /// The `w × h` pixels at the screen's top left (where a window opens
    /// on a server without a window manager), as RGB, read from the
    /// server's screen file (XWD: a big-endian header, a colour map, then
    /// 32-bit pixels with the header's masks and byte order).
    pub fn screen(&self, (w, h): (u32, u32)) -> Vec<u8> {
        let dir = self
            .screen_dir
            .as_ref()
            .expect("started with start_with_screen_file");
        let bytes = std::fs::read(dir.path().join("Xvfb_screen0")).expect("the screen file");
        let field = |k: usize| {
            u32::from_be_bytes(bytes[4 * k..4 * k + 4].try_into().expect("4 bytes")) as usize
        };
        let (header, width, height, byte_order) = (field(0), field(4), field(5), field(7));
        let (bits, line, colours) = (field(11), field(12), field(19));
        let masks = [field(14), field(15), field(16)];
        assert_eq!(bits, 32, "a 24-bit screen stored in 32-bit pixels");
        assert!(w as usize <= width && h as usize <= height);
        let start = header + 12 * colours;
        let mut rgb = Vec::with_capacity(3 * (w * h) as usize);
        for y in 0..h as usize {
            for x in 0..w as usize {
                let o = start + y * line + 4 * x;
                let b: [u8; 4] = bytes[o..o + 4].try_into().expect("4 bytes");
                let v = if byte_order == 0 {
                    u32::from_le_bytes(b)
                } else {
                    u32::from_be_bytes(b)
                } as usize;
                rgb.extend(masks.map(|m| ((v & m) >> m.trailing_zeros()) as u8));
            }
        }
        rgb
    }
}

impl Drop for Xvfb {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
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
