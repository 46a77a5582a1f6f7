//! `gazecast bench ulod` (issue 18, Lee ch. 7) on the real binary: a small
//! run writes the table, the cost model, the CSV and the plot, and ULOD
//! draws fewer triangles than no LOD once attention has settled.

mod common;

use common::{gazecast, Run};

#[test]
fn a_small_ulod_run_writes_table_cost_model_and_plot() {
    let dir = tempfile::tempdir().expect("tempdir");
    let display = dir.path().join("tiny.ron");
    std::fs::write(
        &display,
        "Display(name: \"tiny\", resolution_px: (160, 128), size_mm: (337.9, 253.4), eye_distance_mm: 540.0)",
    )
    .expect("write");
    let scene = dir.path().join("ball.ron");
    std::fs::write(
        &scene,
        r#"Scene(name: "ball", meshes: {"b": Icosphere(subdivisions: 4)}, objects: [(mesh: "b", translate_mm: (0.0, 0.0, 0.0), scale_mm: 10.0)])"#,
    )
    .expect("write");
    let out = dir.path().join("ulod");
    let run = gazecast()
        .args(["bench", "ulod", "--mesh-scene"])
        .arg(&scene)
        .arg("--display")
        .arg(&display)
        .arg("--out")
        .arg(&out)
        .args(["--objects", "1,8", "--levels", "2,4", "--frames", "1"])
        .succeed();
    let report = String::from_utf8_lossy(&run.stdout);
    assert!(
        report.contains("| objects | NOLOD | ULOD2 | ULOD4 |"),
        "{report}"
    );
    assert!(report.contains("5120 / 1280 / 320 / 80 / 20"), "{report}");
    assert!(report.contains("Cost model"), "{report}");
    let csv = std::fs::read_to_string(out.join("ulod.csv")).expect("csv");
    let rows: Vec<Vec<&str>> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').collect())
        .collect();
    assert_eq!(rows.len(), 2 * 3);
    for r in &rows {
        let (drawn, full): (usize, usize) =
            (r[5].parse().expect("drawn"), r[6].parse().expect("full"));
        let objects: usize = r[1].parse().expect("objects");
        assert_eq!(full, objects * 5120, "{r:?}");
        if r[0] == "ULOD4" && objects == 8 {
            assert!(
                drawn < full,
                "attention coarsens the unattended objects: {r:?}"
            );
        }
    }
    assert!(std::fs::metadata(out.join("ulod.png")).expect("png").len() > 1000);
    // Counts outside 1–256 are refused by the parser.
    let bad = gazecast()
        .args(["bench", "ulod", "--display"])
        .arg(&display)
        .arg("--out")
        .arg(dir.path().join("x"))
        .args(["--objects", "0"])
        .output()
        .expect("run");
    assert!(!bad.status.success());
}
