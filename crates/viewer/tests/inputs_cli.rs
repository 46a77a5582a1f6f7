//! Every file a command reads is a regular file of a bounded size: a FIFO
//! (which blocks until something writes to it), a character device
//! (`/dev/zero` never ends) or a directory given for any input — a scene,
//! a mesh the scene loads, a display, a tracker, a calibration, a design,
//! a gaze CSV, a recording — is refused at once with what it is, and the
//! flag or field that named it (issue 29, "Hangs and unbounded reads").
//! Before `input-file`, `render` with `/dev/zero` as a mesh grew to
//! gigabytes and a FIFO as `--scene` blocked forever.

mod common;

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use common::gazecast;

fn repo(p: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..").join(p)
}

fn mkfifo(path: &Path) {
    let ok = Command::new("mkfifo")
        .arg(path)
        .status()
        .expect("mkfifo runs");
    assert!(ok.success(), "mkfifo {}", path.display());
}

/// Runs `cmd` and requires it to fail within 20 s (it is killed
/// otherwise) with every one of `expected` in its stderr.
fn fails_at_once(mut cmd: Command, what: &str, expected: &[&str]) {
    let mut child = cmd
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .spawn()
        .expect("runs");
    let start = Instant::now();
    loop {
        if child.try_wait().expect("wait").is_some() {
            break;
        }
        if start.elapsed() > Duration::from_secs(20) {
            let _ = child.kill();
            let _ = child.wait();
            panic!("{what}: still running after 20 s (blocked or reading without end)");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    let out = child.wait_with_output().expect("output");
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{what}: {err}");
    for e in expected {
        assert!(err.contains(e), "{what}: expected {e:?} in: {err}");
    }
}

/// `render` with `scene` and `display`.
fn render(scene: &Path, display: &Path, out: &Path) -> Command {
    let mut c = gazecast();
    c.arg("render")
        .arg("--scene")
        .arg(scene)
        .arg("--display")
        .arg(display)
        .arg("--out")
        .arg(out)
        .args(["--backend", "cpu"]);
    c
}

/// What each kind of special file is called in the refusal.
fn specials(dir: &Path) -> Vec<(PathBuf, &'static str)> {
    let fifo = dir.join("special.fifo");
    if !fifo.exists() {
        mkfifo(&fifo);
    }
    vec![
        (fifo, "FIFO"),
        (PathBuf::from("/dev/zero"), "character device"),
        (dir.to_path_buf(), "directory"),
    ]
}

#[test]
fn scenes_displays_and_the_meshes_a_scene_loads_must_be_files() {
    let dir = tempfile::tempdir().expect("tempdir");
    let scene = repo("config/scenes/search-task.ron");
    let display = repo("config/displays/tobii-et1750-17in.ron");
    let out = dir.path().join("f.png");
    for (special, kind) in specials(dir.path()) {
        fails_at_once(
            render(&special, &display, &out),
            &format!("--scene {kind}"),
            &[kind],
        );
        fails_at_once(
            render(&scene, &special, &out),
            &format!("--display {kind}"),
            &[kind],
        );
        // A scene whose OBJ mesh is the special file.
        let with_mesh = dir.path().join("mesh-scene.ron");
        let text = format!(
            "Scene(name: \"m\", background: (0.0, 0.0, 0.0), meshes: {{ \"m\": Obj(path: {:?}) }}, materials: {{}}, objects: [(mesh: \"m\", translate_mm: (0.0, 0.0, -100.0), scale_mm: 80.0)])",
            special.display().to_string()
        );
        std::fs::write(&with_mesh, text).expect("write");
        fails_at_once(
            render(&with_mesh, &display, &out),
            &format!("mesh {kind}"),
            &[kind, "an OBJ mesh"],
        );
        assert!(!out.exists(), "nothing was rendered");
    }
}

#[test]
fn trackers_recordings_calibrations_gaze_csvs_and_designs_must_be_files() {
    let dir = tempfile::tempdir().expect("tempdir");
    for (special, kind) in specials(dir.path()) {
        let p = special.as_os_str();
        let mut c = gazecast();
        c.args([
            "replay",
            "--tracker",
            "config/trackers/mouse.ron",
            "--input",
        ])
        .arg(p)
        .arg("--csv")
        .arg(dir.path().join("r.csv"));
        fails_at_once(c, &format!("replay --input {kind}"), &[kind]);

        let mut c = gazecast();
        c.args(["replay", "--tracker"])
            .arg(p)
            .args(["--input", "tests/data/mouse-120hz.gzrec", "--csv"])
            .arg(dir.path().join("r.csv"));
        fails_at_once(c, &format!("replay --tracker {kind}"), &[kind]);

        let mut c = gazecast();
        c.args([
            "view",
            "--scene",
            "config/scenes/search-task.ron",
            "--display",
            "config/displays/tobii-et1750-17in.ron",
            "--replay",
            "tests/data/mouse-120hz.gzrec",
            "--frames",
            "1",
            "--calibration",
        ])
        .arg(p);
        fails_at_once(c, &format!("view --calibration {kind}"), &[kind]);

        let mut c = gazecast();
        c.args([
            "view",
            "--scene",
            "config/scenes/search-task.ron",
            "--display",
            "config/displays/tobii-et1750-17in.ron",
            "--frames",
            "1",
            "--replay",
        ])
        .arg(p);
        fails_at_once(c, &format!("view --replay {kind}"), &[kind]);

        let mut c = gazecast();
        c.args([
            "bench",
            "attention",
            "--scene",
            "config/scenes/search-task.ron",
            "--display",
            "config/displays/tobii-et1750-17in.ron",
            "--gaze",
        ])
        .arg(p)
        .arg("--out")
        .arg(dir.path().join("att"));
        fails_at_once(c, &format!("bench attention --gaze {kind}"), &[kind]);

        let mut c = gazecast();
        c.args(["experiment", "plan"]).arg(p);
        fails_at_once(c, &format!("experiment plan DESIGN {kind}"), &[kind]);

        let mut c = gazecast();
        c.args([
            "experiment",
            "plan",
            "config/experiments/murphy2007-search.ron",
            "--display",
        ])
        .arg(p);
        fails_at_once(c, &format!("experiment plan --display {kind}"), &[kind]);
    }
}

/// A file over its kind's limit is refused before it is read: a sparse
/// display file of 17 MiB (the limit for configuration files is 16 MiB)
/// costs no disk and no memory.
#[test]
fn an_oversized_config_is_refused_by_its_size() {
    let dir = tempfile::tempdir().expect("tempdir");
    let big = dir.path().join("huge.ron");
    let f = std::fs::File::create(&big).expect("create");
    f.set_len(17 << 20).expect("sparse");
    let out = dir.path().join("f.png");
    fails_at_once(
        render(&repo("config/scenes/search-task.ron"), &big, &out),
        "17 MiB display",
        &["huge.ron", "17825792 bytes"],
    );
}
