//! Outputs never overwrite inputs, and a failed command leaves existing
//! files as they were (the reliability issue, item 6).

mod common;

use std::path::{Path, PathBuf};

use common::gazecast;

fn repo(p: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..").join(p)
}

/// A copy of a shipped file in `dir`, and its bytes.
fn copy(dir: &Path, from: &str, name: &str) -> (PathBuf, Vec<u8>) {
    let to = dir.join(name);
    std::fs::copy(repo(from), &to).expect("copy");
    let bytes = std::fs::read(&to).expect("read");
    (to, bytes)
}

fn refused(out: std::process::Output, what: &str) {
    assert_eq!(out.status.code(), Some(1), "{what}: {out:?}");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("refusing to overwrite an input"),
        "{what}: {err}"
    );
}

#[test]
fn view_record_over_its_replay_is_refused_and_the_recording_survives() {
    let dir = tempfile::tempdir().expect("tempdir");
    let (rec, bytes) = copy(dir.path(), "tests/data/mouse-120hz.gzrec", "r.gzrec");
    // The same file spelt another way.
    let spelt = dir.path().join(".").join("r.gzrec");
    let out = gazecast()
        .args(["view", "--scene", "config/scenes/search-task.ron"])
        .args([
            "--display",
            "config/displays/tobii-et1750-17in.ron",
            "--replay",
        ])
        .arg(&rec)
        .arg("--record")
        .arg(&spelt)
        .args(["--frames", "2"])
        .env_remove("DISPLAY")
        .output()
        .expect("runs");
    refused(out, "view");
    assert_eq!(std::fs::read(&rec).expect("read"), bytes);
}

#[test]
fn replay_csv_over_its_input_is_refused() {
    let dir = tempfile::tempdir().expect("tempdir");
    let (rec, bytes) = copy(dir.path(), "tests/data/mouse-120hz.gzrec", "r.gzrec");
    let out = gazecast()
        .args([
            "replay",
            "--tracker",
            "config/trackers/mouse.ron",
            "--input",
        ])
        .arg(&rec)
        .arg("--csv")
        .arg(&rec)
        .output()
        .expect("runs");
    refused(out, "replay");
    assert_eq!(std::fs::read(&rec).expect("read"), bytes);
}

#[test]
fn render_out_over_its_scene_is_refused() {
    let dir = tempfile::tempdir().expect("tempdir");
    let (scene, bytes) = copy(dir.path(), "config/scenes/search-task.ron", "s.ron");
    let out = gazecast()
        .args(["render", "--scene"])
        .arg(&scene)
        .args([
            "--display",
            "config/displays/tobii-et1750-17in.ron",
            "--out",
        ])
        .arg(&scene)
        .output()
        .expect("runs");
    refused(out, "render");
    assert_eq!(std::fs::read(&scene).expect("read"), bytes);
}

/// The meshes a scene loads are inputs too: every output flag that names
/// one (however it is spelt: relative to the scene, through `.`, a hard
/// link) is refused and the mesh survives. Before, `render --out m.obj`
/// replaced the mesh and exited 0.
#[test]
fn an_output_over_a_mesh_the_scene_loads_is_refused() {
    let dir = tempfile::tempdir().expect("tempdir");
    let mesh = dir.path().join("m.obj");
    let bytes = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n".to_vec();
    std::fs::write(&mesh, &bytes).expect("write");
    let link = dir.path().join("linked.obj");
    std::fs::hard_link(&mesh, &link).expect("link");
    let scene = dir.path().join("s.ron");
    std::fs::write(
        &scene,
        "Scene(name: \"m\", background: (0.0, 0.0, 0.0), meshes: { \"m\": Obj(path: \"m.obj\") }, materials: {}, objects: [(mesh: \"m\", translate_mm: (0.0, 0.0, -100.0), scale_mm: 80.0)])",
    )
    .expect("write");
    let display = repo("config/displays/tobii-et1750-17in.ron");
    let spellings = [mesh.clone(), dir.path().join(".").join("m.obj"), link];
    for flag in ["--out", "--stats", "--layers", "--coc"] {
        for spelt in &spellings {
            let mut c = gazecast();
            c.args(["render", "--backend", "cpu", "--scene"])
                .arg(&scene)
                .arg("--display")
                .arg(&display);
            if flag != "--out" {
                c.arg("--out").arg(dir.path().join("frame.png"));
            }
            let out = c.arg(flag).arg(spelt).output().expect("runs");
            refused(out, &format!("render {flag} {}", spelt.display()));
            assert_eq!(std::fs::read(&mesh).expect("read"), bytes);
        }
    }
    let out = gazecast()
        .args(["view", "--scene"])
        .arg(&scene)
        .arg("--display")
        .arg(&display)
        .args([
            "--replay",
            "tests/data/mouse-120hz.gzrec",
            "--frames",
            "1",
            "--screenshot",
        ])
        .arg(&mesh)
        .env_remove("DISPLAY")
        .output()
        .expect("runs");
    refused(out, "view --screenshot");
    let out = gazecast()
        .args(["bench", "attention", "--scene"])
        .arg(&scene)
        .arg("--display")
        .arg(&display)
        .arg("--synthesize-gaze")
        .arg(&mesh)
        .output()
        .expect("runs");
    refused(out, "bench attention --synthesize-gaze");
    assert_eq!(std::fs::read(&mesh).expect("read"), bytes);
}

/// A bad `--calibration` used to truncate an existing `--csv` to its header
/// before the error.
#[test]
fn a_bad_input_leaves_an_existing_output_untouched() {
    let dir = tempfile::tempdir().expect("tempdir");
    let csv = dir.path().join("old.csv");
    std::fs::write(&csv, "precious\n").expect("write");
    let bad = dir.path().join("bad-calibration.ron");
    std::fs::write(&bad, "Calibration(nonsense").expect("write");
    let out = gazecast()
        .args([
            "replay",
            "--tracker",
            "config/trackers/mouse.ron",
            "--input",
        ])
        .arg(repo("tests/data/mouse-120hz.gzrec"))
        .arg("--csv")
        .arg(&csv)
        .arg("--calibration")
        .arg(&bad)
        .output()
        .expect("runs");
    assert_eq!(out.status.code(), Some(1), "{out:?}");
    assert_eq!(std::fs::read_to_string(&csv).expect("read"), "precious\n");
    // And no temporary file is left beside it.
    assert_eq!(std::fs::read_dir(dir.path()).expect("dir").count(), 2);
}
