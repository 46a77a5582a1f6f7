//! Scenes that move (issue 18, part 5) through the binary: `render --time`,
//! `view --explain`, and the methods and backends that refuse them.

mod common;

use common::{gazecast, Run};

const SCENE: &str = "config/scenes/moving.ron";

fn small_display(dir: &std::path::Path) -> std::path::PathBuf {
    let p = dir.join("small.ron");
    std::fs::write(&p, "Display(name: \"small\", resolution_px: (320, 256), size_mm: (337.9, 270.3), eye_distance_mm: 540.0)")
        .expect("write");
    p
}

fn render(dir: &std::path::Path, time: Option<&str>, name: &str) -> (Vec<u8>, serde_json::Value) {
    let d = small_display(dir);
    let (png, stats) = (
        dir.join(format!("{name}.png")),
        dir.join(format!("{name}.json")),
    );
    let mut cmd = gazecast();
    cmd.args(["render", "--scene", SCENE, "--display"])
        .arg(&d)
        .arg("--out")
        .arg(&png)
        .arg("--stats")
        .arg(&stats);
    if let Some(t) = time {
        cmd.args(["--time", t]);
    }
    cmd.succeed();
    let v = serde_json::from_str(&std::fs::read_to_string(&stats).expect("stats")).expect("json");
    (std::fs::read(&png).expect("png"), v)
}

#[test]
fn render_poses_a_moving_scene_at_the_time_asked() {
    let dir = tempfile::tempdir().expect("tempdir");
    let (at_zero, v0) = render(dir.path(), None, "default");
    let (again, _) = render(dir.path(), Some("0"), "zero");
    // Without --time a moving scene is rendered at 0, not the wall clock.
    assert_eq!(at_zero, again);
    let (later, v) = render(dir.path(), Some("1.5"), "later");
    assert_ne!(at_zero, later, "the scene moved between 0 and 1.5 s");
    assert_eq!(v0["pose"]["time_s"], 0.0);
    let pose = &v["pose"];
    assert_eq!(pose["time_s"], 1.5);
    // The flying ball (object 5) moves at 100 mm/s across and about
    // 13 mm/s down; the viewer walks forward at 50 mm/s.
    let ball = &pose["object_velocity_mm_per_s"][5];
    let speed = (0..3)
        .map(|i| ball[i].as_f64().expect("number").powi(2))
        .sum::<f64>()
        .sqrt();
    assert!(speed > 50.0, "{pose}");
    assert!(
        pose["camera_velocity_mm_per_s"][2].as_f64().expect("z") < -40.0,
        "{pose}"
    );
}

#[test]
fn a_static_scene_has_no_pose() {
    let dir = tempfile::tempdir().expect("tempdir");
    let d = small_display(dir.path());
    let stats = dir.path().join("s.json");
    gazecast()
        .args([
            "render",
            "--scene",
            "config/scenes/bunny.ron",
            "--time",
            "3",
            "--display",
        ])
        .arg(&d)
        .arg("--out")
        .arg(dir.path().join("b.png"))
        .arg("--stats")
        .arg(&stats)
        .succeed();
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&stats).expect("stats")).expect("json");
    assert!(v["pose"].is_null(), "{v}");
}

#[test]
fn explain_names_what_moves_and_methods_that_cannot_refuse() {
    let out = gazecast()
        .args([
            "view",
            "--explain",
            "--scene",
            SCENE,
            "--display",
            "config/displays/tobii-et1750-17in.ron",
        ])
        .succeed();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        text.contains("scene moves: a camera path of 2 keys (Bounce); 2 of 6 objects on paths"),
        "{text}"
    );
    for args in [&["--method", "lod"][..], &["--method", "ulod"][..]] {
        let out = gazecast()
            .args(["view", "--explain", "--scene", SCENE, "--display"])
            .arg("config/displays/tobii-et1750-17in.ron")
            .args(args)
            .output()
            .expect("runs");
        assert!(!out.status.success(), "{args:?} should be refused");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains("this scene moves"), "{args:?}: {err}");
    }
}

#[test]
fn render_refuses_a_time_that_is_not_finite() {
    let dir = tempfile::tempdir().expect("tempdir");
    let d = small_display(dir.path());
    for t in ["nan", "inf", "1e300"] {
        let out = gazecast()
            .args(["render", "--scene", SCENE, "--time", t, "--display"])
            .arg(&d)
            .arg("--out")
            .arg(dir.path().join("x.png"))
            .output()
            .expect("runs");
        assert!(!out.status.success(), "--time {t}");
        assert!(
            String::from_utf8_lossy(&out.stderr).contains("--time"),
            "{t}"
        );
    }
}
