//! `gazecast calibrate` under Xvfb on simulated sessions: an ISCAN that sees
//! the screen in perspective with a second-order bow, a person who follows
//! the targets and closes the eyes through one of them.

mod common;

use common::{gazecast, windowed, Run, Xvfb};

const DISPLAY: &str = "config/displays/tobii-et1750-17in.ron";
/// Short targets keep the replay at about 9 s.
const TIMING: [&str; 4] = ["--settle-ms", "200", "--collect-ms", "400"];

fn simulate(dir: &std::path::Path, tracker: &str) -> std::path::PathBuf {
    let rec = dir.join("calibration.gzrec");
    gazecast()
        .args([
            "simulate",
            "--script",
            "calibration",
            "--closed-target",
            "4",
        ])
        .args(["--tracker", tracker, "--display", DISPLAY])
        .args(TIMING)
        .arg("--out")
        .arg(&rec)
        .succeed();
    rec
}

#[test]
#[ignore = "slow tier: a windowed calibration session under Xvfb"]
fn a_recorded_iscan_session_calibrates_validates_and_saves() {
    let x = Xvfb::start();
    let dir = tempfile::tempdir().expect("tempdir");
    let rec = simulate(dir.path(), "config/trackers/iscan-binary.ron");
    let cal = dir.path().join("cal.ron");
    let shot = dir.path().join("cal.png");
    let out = windowed(&x)
        .args(["calibrate", "--display", DISPLAY, "--model", "polynomial2"])
        .args(TIMING)
        .arg("--replay")
        .arg(&rec)
        .arg("--out")
        .arg(&cal)
        .arg("--screenshot")
        .arg(&shot)
        .succeed();
    let text = String::from_utf8_lossy(&out.stdout);
    // The closed-eye target was rejected, shown again and then accepted.
    assert!(
        text.contains("calibration targets [4] rejected: shown again"),
        "{text}"
    );
    assert_eq!(text.matches(": accepted,").count(), 9, "{text}");
    assert_eq!(text.matches("validation (").count(), 4, "{text}");
    let accuracy: f64 = text
        .lines()
        .find_map(|l| l.strip_prefix("validation: accuracy "))
        .and_then(|l| l.split('°').next())
        .and_then(|v| v.parse().ok())
        .unwrap_or_else(|| panic!("no overall accuracy: {text}"));
    assert!(accuracy < 0.3, "accuracy {accuracy}°: {text}");
    // The saved file loads and maps the uncalibrated tracker onto the screen.
    let c = gazecast_viewer::config::load_calibration(&cal).expect("the calibration loads");
    for p in [[320.0, 256.0], [640.0, 512.0], [1000.0, 800.0]] {
        let raw = tracker_hal::sim::uncalibrated_raw(p, (1280, 1024), (512.0, 512.0));
        let got = c.map(raw).expect("maps");
        let e = (got[0] - p[0]).hypot(got[1] - p[1]);
        assert!(e < 12.0, "{p:?} maps to {got:?} ({e:.1} px off)");
    }
    let saved = std::fs::read_to_string(&cal).expect("text");
    assert!(
        saved.starts_with("// gazecast calibrate: Polynomial2 on 9 targets"),
        "{saved}"
    );
    // The screenshot is the result screen: green arrows (good points).
    let img = std::fs::read(&shot).expect("screenshot");
    let mut reader = png::Decoder::new(std::io::Cursor::new(img))
        .read_info()
        .expect("png");
    let mut buf = vec![0; reader.output_buffer_size()];
    let info = reader.next_frame(&mut buf).expect("frame");
    assert_eq!((info.width, info.height), (1280, 1024));
    let green = buf.chunks(3).filter(|p| *p == [0, 140, 0]).count();
    assert!(green > 20, "{green} arrow pixels");
    // The calibration maps the replayed session in `view` too.
    let out = windowed(&x)
        .args([
            "view",
            "--scene",
            "config/scenes/bunny.ron",
            "--backend",
            "cpu",
            "--display",
            DISPLAY,
        ])
        .args(["--frames", "1", "--replay"])
        .arg(&rec)
        .arg("--calibration")
        .arg(&cal)
        .succeed();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("through"), "{text}");
}

#[test]
fn bad_plans_are_refused_before_any_window_opens() {
    for (args, says) in [
        (vec!["--points", "7"], "--points"),
        (
            vec!["--model", "polynomial2", "--points", "5"],
            "needs at least 6",
        ),
        (vec!["--collect-ms", "10"], "--collect-ms"),
        (vec!["--max-error-deg", "nan"], "--max-error-deg"),
    ] {
        let out = gazecast()
            .env_remove("DISPLAY")
            .env_remove("WAYLAND_DISPLAY")
            .args([
                "calibrate",
                "--tracker",
                "config/trackers/mouse.ron",
                "--display",
                DISPLAY,
            ])
            .args(["--out", "/nonexistent/never-written.ron"])
            .args(&args)
            .output()
            .expect("runs");
        assert!(!out.status.success(), "{args:?}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(says), "{args:?}: {err}");
    }
}

#[test]
fn simulating_a_calibration_needs_a_display() {
    let out = gazecast()
        .args([
            "simulate",
            "--script",
            "calibration",
            "--tracker",
            "config/trackers/mouse.ron",
        ])
        .args(["--out", "/nonexistent/x.gzrec"])
        .output()
        .expect("runs");
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("--display"));
}
