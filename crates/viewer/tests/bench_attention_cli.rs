//! `gazecast bench attention` (issue 18) on the real binary: a synthesised
//! session round-trips through the evaluation, a viewer who looks only at
//! the one object worth attending scores A1 = 1 where the model ranks it,
//! and bad sessions are refused naming file and line.

mod common;

use std::path::Path;

use common::{gazecast, Run};

const DISPLAY: &str = "Display(name: \"tiny\", resolution_px: (160, 128), size_mm: (337.9, 253.4), eye_distance_mm: 540.0)";

/// A sphere at the screen centre worth looking at, and a larger one beside
/// it marked as scenery (importance 0).
const SCENE: &str = r#"Scene(
    name: "one-target",
    meshes: {"ball": Icosphere(subdivisions: 2)},
    objects: [
        (mesh: "ball", translate_mm: (0.0, 0.0, -20.0), scale_mm: 30.0),
        (mesh: "ball", translate_mm: (100.0, 0.0, -20.0), scale_mm: 45.0, importance: 0.0),
    ],
)"#;

const SEARCH: &str = "config/scenes/search-task.ron";

/// `gazecast bench attention --scene SCENE --display DISPLAY`.
fn attention(scene: &Path, display: &Path) -> std::process::Command {
    let mut c = gazecast();
    c.args(["bench", "attention", "--scene"])
        .arg(scene)
        .arg("--display")
        .arg(display);
    c
}

fn header() -> &'static str {
    "seq,device_time_us,host_time_us,mapped_time_us,time_order,left_x,left_y,left_valid,right_x,right_y,right_valid,gaze_x,gaze_y,gaze_valid"
}

#[test]
fn a_synthesised_session_is_evaluated_in_eight_combinations() {
    let dir = tempfile::tempdir().expect("tempdir");
    let display = dir.path().join("tiny.ron");
    std::fs::write(&display, DISPLAY).expect("write");
    let session = dir.path().join("synthetic.csv");
    attention(Path::new(SEARCH), &display)
        .args(["--seconds", "2", "--synthesize-gaze"])
        .arg(&session)
        .succeed();
    let text = std::fs::read_to_string(&session).expect("session");
    assert!(
        text.starts_with("# synthetic:"),
        "{}",
        &text[..80.min(text.len())]
    );
    assert_eq!(
        text.lines().count(),
        2 + 240,
        "a comment, the header and 2 s at 120 Hz"
    );

    let out = dir.path().join("eval");
    let run = attention(Path::new(SEARCH), &display)
        .arg("--gaze")
        .arg(&session)
        .arg("--out")
        .arg(&out)
        .succeed();
    let report = String::from_utf8_lossy(&run.stdout);
    assert!(report.contains("**Synthetic data:**"), "{report}");
    let rows: Vec<&str> = report
        .lines()
        .filter(|l| l.starts_with("| 0 ") || l.starts_with("| 1 "))
        .collect();
    assert_eq!(rows.len(), 8, "{report}");
    let csv = std::fs::read_to_string(out.join("attention.csv")).expect("csv");
    assert_eq!(csv.lines().count(), 1 + 8);
    let frames = std::fs::read_to_string(out.join("frames-1.csv")).expect("frames");
    // 2 s at 60 Hz: the frames at 0, 1/60, …, up to the last sample.
    assert!(
        (115..=121).contains(&(frames.lines().count() - 1)),
        "{}",
        frames.lines().count()
    );
    assert!(frames.contains(",fixation,"));
}

#[test]
fn a_viewer_on_the_only_target_scores_one_and_scenery_is_never_predicted() {
    let dir = tempfile::tempdir().expect("tempdir");
    let display = dir.path().join("tiny.ron");
    std::fs::write(&display, DISPLAY).expect("write");
    let scene = dir.path().join("scene.ron");
    std::fs::write(&scene, SCENE).expect("write");
    // One second at 100 Hz on the centre sphere, a blink in the middle.
    let mut csv = format!("{}\n", header());
    for k in 0..100u64 {
        let t = 5_000_000 + k * 10_000;
        if (40..45).contains(&k) {
            csv.push_str(&format!("{k},,{t},{t},ok,,,0,,,0,,,0\n"));
        } else {
            let x = 80.0 + (k % 3) as f64 * 0.5;
            csv.push_str(&format!("{k},,{t},{t},ok,,,0,,,0,{x},64.0,1\n"));
        }
    }
    let session = dir.path().join("centre.csv");
    std::fs::write(&session, csv).expect("write");
    let out = dir.path().join("eval");
    attention(&scene, &display)
        .arg("--gaze")
        .arg(&session)
        .arg("--out")
        .arg(&out)
        .succeed();
    let table = std::fs::read_to_string(out.join("attention.csv")).expect("csv");
    let rows: Vec<Vec<&str>> = table
        .lines()
        .skip(1)
        .map(|l| l.split(',').collect())
        .collect();
    assert_eq!(rows.len(), 8);
    for r in &rows {
        let scored: u64 = r[5].parse().expect("frames");
        assert!(scored > 40, "{r:?}");
        if r[2..5] != ["0", "0", "0"] {
            // Every model ranks the one object of importance above 0 first.
            assert_eq!(r[7], "1.0000", "A1 of {r:?}");
        }
    }
    // The random pixel hits the small sphere only sometimes.
    assert_ne!(rows[0][7], "1.0000", "baseline {:?}", rows[0]);
    let frames = std::fs::read_to_string(out.join("frames-1.csv")).expect("frames");
    assert!(frames.contains(",blink,"));
    for l in frames.lines().skip(1) {
        let top1 = l.split(',').nth(6).unwrap_or("");
        assert_ne!(top1, "1", "scenery ranked first: {l}");
    }
}

#[test]
fn bad_sessions_are_refused_naming_file_and_line() {
    let dir = tempfile::tempdir().expect("tempdir");
    let display = dir.path().join("tiny.ron");
    std::fs::write(&display, DISPLAY).expect("write");
    let session = dir.path().join("back.csv");
    std::fs::write(
        &session,
        format!(
            "{}\n0,,200,200,ok,,,0,,,0,1,2,1\n1,,100,100,ok,,,0,,,0,1,2,1\n",
            header()
        ),
    )
    .expect("write");
    let out = dir.path().join("eval");
    let run = attention(Path::new(SEARCH), &display)
        .arg("--gaze")
        .arg(&session)
        .arg("--out")
        .arg(&out)
        .output()
        .expect("run");
    assert!(!run.status.success());
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(
        err.contains("back.csv") && err.contains("line 3") && err.contains("mapped_time_us"),
        "{err}"
    );
    assert!(!out.exists(), "nothing written for a bad session");
    // An output over an input is refused.
    let run = attention(Path::new(SEARCH), &display)
        .arg("--synthesize-gaze")
        .arg(&display)
        .output()
        .expect("run");
    assert!(!run.status.success());
    assert!(String::from_utf8_lossy(&run.stderr).contains("refusing to overwrite an input"));
}
