//! `gazecast demo` headless (issue 7's first part): the animation, the
//! contact sheet and a line per frame.

mod common;

use common::{gazecast, Run};

#[test]
fn the_headless_demo_writes_an_animation_a_sheet_and_a_line_per_frame() {
    let dir = tempfile::tempdir().expect("tempdir");
    // No display: the demo renders headless by itself.
    let run = gazecast()
        .env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .args(["demo", "--fps", "4", "--out"])
        .arg(dir.path())
        .succeed();
    let text = String::from_utf8_lossy(&run.stdout);
    let frames = text.lines().filter(|l| l.starts_with("frame ")).count();
    assert!(frames >= 8, "{text}");
    assert!(
        text.contains("no display"),
        "says why it is headless: {text}"
    );
    let apng = std::fs::read(dir.path().join("demo.png")).expect("demo.png");
    assert!(apng.starts_with(b"\x89PNG"));
    // An animated PNG: an acTL chunk and one fcTL per frame.
    assert!(apng.windows(4).any(|w| w == b"acTL"));
    assert_eq!(apng.windows(4).filter(|w| *w == b"fcTL").count(), frames);
    let sheet = std::fs::read(dir.path().join("demo-sheet.png")).expect("sheet");
    assert!(sheet.starts_with(b"\x89PNG"));
    let bad = gazecast()
        .args(["demo", "--headless", "--fps", "0", "--out"])
        .arg(dir.path())
        .output()
        .expect("runs");
    assert!(!bad.status.success());
    assert!(String::from_utf8_lossy(&bad.stderr).contains("--fps"));
}
