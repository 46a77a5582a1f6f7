//! `gazecast view` in a real window under a virtual X server (Xvfb, which
//! `scripts/system-deps.sh` installs), rendering with the replayed gaze of a
//! recording: the POR box must be where the replayed gaze says.

mod common;

use std::process::{Child, Command, Stdio};

use common::{gazecast, Run};

/// A private Xvfb on a free display number, killed on drop.
struct Xvfb {
    child: Child,
    display: String,
}

impl Xvfb {
    /// Xvfb picks a free display number itself (`-displayfd`) and writes it
    /// once it accepts connections, so tests running in parallel never share
    /// or race for a display.
    fn start() -> Self {
        use std::io::BufRead;
        let mut child = Command::new("Xvfb")
            .args([
                "-displayfd",
                "1",
                "-screen",
                "0",
                "1600x1200x24",
                "-nolisten",
                "tcp",
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
        }
    }
}

impl Drop for Xvfb {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// `gazecast view` of the search task on the seed's display, CPU backend, in
/// the given X display.
fn view(x: &Xvfb) -> std::process::Command {
    let mut c = gazecast();
    c.env("DISPLAY", &x.display)
        .env_remove("WAYLAND_DISPLAY")
        .args([
            "view",
            "--scene",
            "config/scenes/search-task.ron",
            "--display",
            "config/displays/tobii-et1750-17in.ron",
            "--backend",
            "cpu",
        ]);
    c
}

#[test]
fn a_replayed_session_renders_in_a_window_with_the_por_box_at_the_gaze() {
    let x = Xvfb::start();
    let dir = tempfile::tempdir().expect("tempdir");
    let shot = dir.path().join("shot.png");
    let out = view(&x)
        .args([
            "--replay",
            "tests/data/mouse-120hz.gzrec",
            "--frames",
            "4",
            "--overlay",
            "por",
            "--screenshot",
        ])
        .arg(&shot)
        .succeed();
    let text = String::from_utf8_lossy(&out.stdout);
    let frames: Vec<&str> = text.lines().filter(|l| l.starts_with("frame ")).collect();
    assert_eq!(frames.len(), 4, "{text}");
    assert!(text.contains("gaze age at submit p50"), "{text}");
    // The last frame's gaze, from the session log: "frame 3 gaze (x, y) …".
    let last = frames[3];
    let inner = &last[last.find('(').expect("(") + 1..last.find(')').expect(")")];
    let xy: Vec<f64> = inner
        .split(',')
        .map(|v| v.trim().parse().expect("number"))
        .collect();
    let png = std::fs::File::open(&shot).expect("screenshot");
    let mut reader = png::Decoder::new(std::io::BufReader::new(png))
        .read_info()
        .expect("png");
    let mut buf = vec![0; reader.output_buffer_size()];
    let info = reader.next_frame(&mut buf).expect("frame");
    assert_eq!((info.width, info.height), (1280, 1024));
    let rgb = |px: i64, py: i64| -> [u8; 3] {
        let i = (py as usize * info.width as usize + px as usize) * info.color_type.samples();
        match info.color_type {
            png::ColorType::Rgb => [buf[i], buf[i + 1], buf[i + 2]],
            other => panic!("unexpected colour type {other:?}"),
        }
    };
    let (cx, cy) = (xy[0].round() as i64, xy[1].round() as i64);
    // The box's top and left edges, 32 px from the gaze.
    assert_eq!(
        rgb(cx, cy - 32),
        [255, 220, 0],
        "top edge at the gaze {xy:?}"
    );
    assert_eq!(
        rgb(cx - 32, cy),
        [255, 220, 0],
        "left edge at the gaze {xy:?}"
    );
}

#[test]
fn without_a_tracker_or_a_display_the_viewer_says_what_to_do() {
    let out = gazecast()
        .args([
            "view",
            "--scene",
            "config/scenes/search-task.ron",
            "--display",
            "config/displays/tobii-et1750-17in.ron",
        ])
        .output()
        .expect("runs");
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("--tracker"));
}

#[test]
fn explain_prints_the_passes_of_the_scene_effects() {
    let out = gazecast()
        .args([
            "view",
            "--explain",
            "--scene",
            "config/scenes/search-task.ron",
            "--display",
            "config/displays/tobii-et1750-17in.ron",
        ])
        .succeed();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        text.contains("cast vertices → classify cells → silhouette margin"),
        "{text}"
    );
    assert!(text.contains("crease > 30°"), "{text}");
    // A scene without FoveatedSampling runs the full-resolution pass only.
    let dir = tempfile::tempdir().expect("tempdir");
    let plain = dir.path().join("plain.ron");
    let text = std::fs::read_to_string("../../config/scenes/bunny.ron").expect("bunny");
    let text = text.replace(
        "effects: [FoveatedSampling, SilhouetteRefinement, CreaseRefinement, DepthRefinement],",
        "effects: [],",
    );
    std::fs::write(&plain, text).expect("write");
    let out = gazecast()
        .args(["view", "--explain", "--scene"])
        .arg(&plain)
        .args(["--display", "config/displays/tobii-et1750-17in.ron"])
        .succeed();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("cast and shade every pixel"), "{text}");
    assert!(!text.contains("classify"), "{text}");
}

#[test]
fn a_lost_or_ended_tracker_keeps_the_viewer_rendering_with_a_status_line() {
    let x = Xvfb::start();
    let dir = tempfile::tempdir().expect("tempdir");
    // A tracker whose serial port does not exist: reopened with backoff.
    let tracker = dir.path().join("gone.ron");
    std::fs::write(
        &tracker,
        std::fs::read_to_string("../../config/trackers/iscan-binary.ron")
            .expect("tracker")
            .replace("Some(\"/dev/ttyUSB0\")", "Some(\"/nonexistent/tty\")"),
    )
    .expect("write");
    let out = view(&x)
        .args(["--frames", "3", "--tracker"])
        .arg(&tracker)
        .succeed();
    let text = String::from_utf8_lossy(&out.stdout);
    assert_eq!(
        text.lines().filter(|l| l.starts_with("frame ")).count(),
        3,
        "{text}"
    );
    assert!(
        text.contains("tracker: ") && text.contains("retrying"),
        "{text}"
    );
    assert!(text.contains("no gaze sample arrived"), "{text}");
    // A recording that ends after 0.2 s: the last gaze stays, a status says so.
    let rec = dir.path().join("short.gzrec");
    gazecast()
        .args([
            "simulate",
            "--tracker",
            "tests/data/mouse-realistic.ron",
            "--seconds",
            "0.2",
            "--out",
        ])
        .arg(&rec)
        .succeed();
    let out = view(&x)
        .args(["--frames", "5", "--replay"])
        .arg(&rec)
        .succeed();
    let text = String::from_utf8_lossy(&out.stdout);
    assert_eq!(
        text.lines().filter(|l| l.starts_with("frame ")).count(),
        5,
        "{text}"
    );
    assert!(
        text.contains("end of stream; keeping the last gaze"),
        "{text}"
    );
}
